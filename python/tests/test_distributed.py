"""Distributed frames and sweeps on a real local Ray cluster (a head and a worker process on
127.0.0.1): the frames equal the command line's byte for byte, the counts one process's."""

import csv
import os
import socket
import subprocess
import sys
import threading
import time

import pytest

import rayspace as rs
from conftest import need, run_cli, scene_file
from rayspace import distributed

try:
    import ray
except ImportError:  # pragma: no cover - the install step provides it
    ray = None
need(ray is not None, "no Ray (pip install 'rayspace[ray]')", module=True)

RAY = os.path.join(os.path.dirname(sys.executable), "ray")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_sweep_on_a_local_ray_the_call_starts():
    """address=None: the call starts a local Ray for itself and stops it afterwards."""
    need(not ray.is_initialized(), "Ray is already initialised in this process")
    rows = distributed.sweep(["cornell"], ["grid"], rays=[{"kind": "random", "width": 16, "height": 16}], workers=2)
    rows = rows.to_dict("records") if hasattr(rows, "to_dict") else rows
    assert len(rows) == 1 and rows[0]["rays"] == 256 and rows[0]["total_tests"] > 0
    assert not ray.is_initialized()


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """`ray start --head` and one `ray start --address` worker, one CPU each."""
    need(os.access(RAY, os.X_OK), f"no ray command beside {sys.executable} (pip install 'rayspace[ray]')")
    port = free_port()
    small = ["--num-cpus=1", "--object-store-memory=100000000", "--disable-usage-stats"]
    env = dict(os.environ, RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER="1")
    subprocess.run([RAY, "stop", "--force"], capture_output=True, env=env)
    head = subprocess.run(
        [RAY, "start", "--head", "--node-ip-address=127.0.0.1", f"--port={port}", "--include-dashboard=false", *small],
        capture_output=True, text=True, env=env,
    )
    assert head.returncode == 0, head.stderr + head.stdout
    address = f"127.0.0.1:{port}"
    try:
        worker = subprocess.run(
            [RAY, "start", f"--address={address}", "--node-ip-address=127.0.0.1", *small],
            capture_output=True, text=True, env=env,
        )
        assert worker.returncode == 0, worker.stderr + worker.stdout
        yield address
    finally:
        subprocess.run([RAY, "stop", "--force"], capture_output=True, env=env)


def test_render_frames_equal_the_command_lines(cluster, tmp_path):
    museum = scene_file("bart-museum/aff/museum5.aff")
    # Neither folder exists: the command line and render_frames both make theirs.
    cli_dir, ray_dir = tmp_path / "cli", tmp_path / "ray" / "frames"
    run_cli(
        "render", museum, "--frames", "3", "--width", "64", "--height", "64", "--engine", "grid",
        "--out", str(cli_dir / "frame_%04d.png"), "--frame-csv", str(cli_dir / "frames.csv"),
    )
    rows = distributed.render_frames(
        museum, 3, engine="grid", width=64, height=64, out_dir=ray_dir, address=cluster
    )
    assert [r["frame"] for r in rows] == [0, 1, 2]
    for i in range(3):
        name = f"frame_{i:04d}.png"
        assert (ray_dir / name).read_bytes() == (cli_dir / name).read_bytes(), name
    with open(cli_dir / "frames.csv") as f:
        want = list(csv.DictReader(f))
    with open(ray_dir / "frames.csv") as f:
        got = list(csv.DictReader(f))
    assert list(got[0]) == list(want[0])
    for g, w in zip(got, want):
        for k in ("frame", "time", "triangles", "rays", "total_tests"):
            assert g[k] == w[k], k


def test_a_killed_worker_loses_no_frame_and_a_second_call_renders_none(cluster, tmp_path):
    """240 frames on the two workers; once 10 are on disk one worker process is killed:
    every frame is still written once, byte-identical to the command line's, and calling
    again with the same arguments rewrites none (a changed argument renders again)."""
    museum = scene_file("bart-museum/aff/museum5.aff")
    cli_dir, ray_dir = tmp_path / "cli", tmp_path / "ray"
    cli_dir.mkdir()
    ray_dir.mkdir()
    args = dict(engine="grid", width=24, height=24, out_dir=ray_dir, address=cluster)
    run_cli(
        "render", museum, "--frames", "240", "--width", "24", "--height", "24", "--engine", "grid",
        "--out", str(cli_dir / "frame_%04d.png"),
    )
    result = {}

    def render():
        try:
            result["rows"] = distributed.render_frames(museum, 240, **args)
        except BaseException as e:  # pragma: no cover - reported below
            result["error"] = e

    th = threading.Thread(target=render)
    th.start()
    deadline = time.time() + 240
    while len(list(ray_dir.glob("frame_*.png"))) < 10 and th.is_alive() and time.time() < deadline:
        time.sleep(0.02)
    on_disk = len(list(ray_dir.glob("frame_*.png")))
    assert th.is_alive() and on_disk < 240, f"the call ended ({on_disk} frames) before a worker could be killed"
    killed = subprocess.run(["pkill", "-9", "-o", "-f", "ray::_FrameWorker"], capture_output=True)
    print(f"killed the oldest worker process with {on_disk} frames on disk: pkill exit {killed.returncode}")
    assert killed.returncode == 0, "no worker process to kill"
    th.join(timeout=600)
    assert not th.is_alive(), "render_frames did not finish"
    assert "error" not in result, result.get("error")
    rows = result["rows"]
    assert [r["frame"] for r in rows] == list(range(240))
    for i in range(240):
        name = f"frame_{i:04d}.png"
        assert (ray_dir / name).read_bytes() == (cli_dir / name).read_bytes(), name
    # Again, the same arguments: nothing rendered, no file rewritten.
    stamp = {p.name: p.stat().st_mtime_ns for p in ray_dir.glob("frame_*.png")}
    again = distributed.render_frames(museum, 240, **args)
    assert not any(r["rendered"] for r in again)
    assert {p.name: p.stat().st_mtime_ns for p in ray_dir.glob("frame_*.png")} == stamp
    # A frame removed, or a changed argument: those frames are rendered again.
    (ray_dir / "frame_0007.png").unlink()
    redo = distributed.render_frames(museum, 240, **args)
    assert [r["frame"] for r in redo if r["rendered"]] == [7]
    assert (ray_dir / "frame_0007.png").read_bytes() == (cli_dir / "frame_0007.png").read_bytes()
    changed = distributed.render_frames(museum, [0.0, 1.0], **{**args, "width": 16})
    assert all(r["rendered"] for r in changed)


def test_sweep_refuses_an_option_an_engine_does_not_take():
    with pytest.raises(rs.Error, match="sweep: levels does not apply to engine=grid"):
        distributed.sweep(["cornell"], ["grid", "crsh"], configs=[{"levels": 2}])


def test_sweep_counts_equal_one_process(cluster):
    table = distributed.sweep(
        ["cornell", "office"], ["bvh", "crsh"], configs=[{}, {"object_builder": "lbvh"}],
        rays=[{"kind": "shadow", "width": 32, "height": 32}], address=cluster,
    )
    rows = table.to_dict("records") if hasattr(table, "to_dict") else table
    assert len(rows) == 8
    for row in rows:
        scene = rs.Scene.load(row["scene"])
        e = rs.Engine(scene, row["engine"], **row["config"])
        hits = e.trace(**rs.rays(scene, "shadow", width=32, height=32), any_hit=True)
        c = e.counters()
        assert row["hits"] == int((hits["triangle"] != rs.MISS).sum())
        assert (row["ray_tri_tests"], row["total_tests"]) == (c["ray_tri_tests"], c["total_tests"])


def test_bad_arguments_raise_before_any_work(tmp_path):
    afile = tmp_path / "a-file"
    afile.write_text("x")
    with pytest.raises(rs.Error, match="not a directory"):
        distributed.render_frames("cornell", 2, out_dir=afile)
    with pytest.raises(rs.Error, match="not animated"):
        distributed.render_frames("cornell", 2, out_dir=tmp_path)
    with pytest.raises(rs.Error, match="frame number pattern"):
        distributed.render_frames("cornell", [0.0], out_dir=tmp_path, pattern="frame.png")
