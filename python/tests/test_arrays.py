"""Scenes from arrays (``Scene.from_arrays``/``from_meshes``), changed between frames
(``Scene.update``) and engines brought up to date (``Engine.rebuild``): the hits of a scene
loaded from a file, of a scene built fresh, brute force's; a stale engine raises."""

import os
import pathlib
import runpy
import shutil
import sys

import numpy as np
import pytest

import rayspace as rs
from conftest import REPO, need

ENGINES = ["bvh", "crsh", "rah", "grid", "grid2l", "brute"]


def same_hits(a, b):
    assert np.array_equal(a["triangle"], b["triangle"])
    for k in ("t", "u", "v"):
        assert np.array_equal(a[k].view(np.uint32), b[k].view(np.uint32)), k


def wavy(n=24, phase=0.0):
    """A wavy n × n sheet with vertices exactly representable in float32 (and in text)."""
    x, z = np.meshgrid(np.arange(n) / 8.0 - 1.5, np.arange(n) / 8.0 - 1.5, indexing="ij")
    y = np.round(np.sin(2 * x + phase) * np.cos(z) * 64) / 256
    v = np.stack([x, y, z], -1).reshape(-1, 3).astype(np.float32)
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).ravel()
    f = np.concatenate([np.stack([a, a + n, a + n + 1], 1), np.stack([a, a + n + 1, a + 1], 1)])
    return v, f


def sensor_rays(n=3000, seed=5):
    rng = np.random.default_rng(seed)
    o = np.column_stack([rng.uniform(-2, 2, n), rng.uniform(0.5, 2, n), rng.uniform(-2, 2, n)])
    d = np.column_stack([rng.uniform(-0.3, 0.3, n), -np.ones(n), rng.uniform(-0.3, 0.3, n)])
    return o.astype(np.float32), d.astype(np.float32)


def test_arrays_trace_as_the_same_obj_loaded(tmp_path):
    v, f = wavy()
    obj = tmp_path / "sheet.obj"
    lines = [f"v {a!r} {b!r} {c!r}" for a, b, c in v.astype(float).tolist()]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f.tolist()]
    obj.write_text("\n".join(lines) + "\n")
    loaded = rs.Scene.load(str(obj))
    # Any real and integer array-likes: float64 lists and int64 faces.
    made = rs.Scene.from_arrays(v.astype(np.float64).tolist(), f.astype(np.int64))
    assert made.triangle_count == loaded.triangle_count == len(f)
    assert np.array_equal(made.triangles(), loaded.triangles())
    o, d = sensor_rays()
    for e in ENGINES:
        a = rs.Engine(made, e).trace(o, d)
        b = rs.Engine(loaded, e).trace(o, d)
        same_hits(a, b)
        assert (a["triangle"] != rs.MISS).sum() > 1000, e


def test_hits_name_the_faces_rows_degenerate_ones_kept():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], np.float32)
    f = np.array([[0, 1, 2], [1, 1, 2], [1, 3, 2]])  # row 1 degenerate, kept
    s = rs.Scene.from_arrays(v, f)
    assert s.triangle_count == 3
    o = np.array([[0.2, 0.2, 1], [0.8, 0.9, 1], [3, 3, 1]], np.float32)
    d = np.tile(np.array([0, 0, -1], np.float32), (3, 1))
    for e in ENGINES:
        h = rs.Engine(s, e).trace(o, d, points=True, normals=True)
        assert h["triangle"].tolist() == [0, 2, rs.MISS], e
        assert np.allclose(h["point"][:2], [[0.2, 0.2, 0], [0.8, 0.9, 0]], atol=1e-6)
        assert np.allclose(h["normal"][:2], [[0, 0, 1], [0, 0, 1]])
        assert np.isnan(h["point"][2]).all() and np.isnan(h["normal"][2]).all()


def test_bad_arrays_raise_with_the_row():
    v, f = wavy(4)
    with pytest.raises(rs.Error, match=r"face 1: vertex index 99 is out of range \(16 vertices\)"):
        rs.Scene.from_arrays(v, np.array([[0, 1, 2], [0, 99, 2]]))
    with pytest.raises(rs.Error, match="faces: values outside uint32"):
        rs.Scene.from_arrays(v, -f)
    with pytest.raises(TypeError, match="faces: expected integers"):
        rs.Scene.from_arrays(v, f.astype(np.float32))
    with pytest.raises(rs.Error, match=r"vertices: expected shape \(N, 3\)"):
        rs.Scene.from_arrays(v[:, :2], f)
    bad = v.copy()
    bad[5, 1] = np.nan
    with pytest.raises(rs.Error, match="vertex 5 is not finite"):
        rs.Scene.from_arrays(bad, f)
    with pytest.raises(rs.Error, match="no faces"):
        rs.Scene.from_arrays(v, np.zeros((0, 3), np.int32))
    s = rs.Scene.from_arrays(v, f)
    with pytest.raises(rs.Error, match="mesh 0: 3 vertices given, the mesh has 16"):
        s.update(vertices=v[:3])
    with pytest.raises(rs.Error, match="mesh 4: no such mesh"):
        s.update(vertices=v, mesh=4)
    with pytest.raises(rs.Error, match="not finite or not invertible"):
        s.update(transform=np.zeros((4, 4)))


def test_an_update_needs_a_rebuild_and_then_traces_as_a_fresh_scene():
    v0, f = wavy(phase=0.0)
    v1, _ = wavy(phase=1.3)
    o, d = sensor_rays()
    for e in ENGINES:
        s = rs.Scene.from_arrays(v0, f)
        eng = rs.Engine(s, e)
        before = eng.trace(o, d)
        s.update(vertices=v1)
        assert not eng.current
        with pytest.raises(rs.Error, match=r"scene changed since this engine was built.*rebuild\(\)"):
            eng.trace(o, d)
        eng.rebuild()
        assert eng.current
        got = eng.trace(o, d)
        fresh = rs.Engine(rs.Scene.from_arrays(v1, f), e).trace(o, d)
        same_hits(got, fresh)
        assert not np.array_equal(got["t"], before["t"]), e


def test_per_mesh_transforms_update_as_built_fresh():
    v, f = wavy(8)
    lift = np.eye(4, dtype=np.float32)
    lift[:3, 3] = [0.5, 0.25, 0.0]  # row-major: the translation is the last column
    s = rs.Scene.from_meshes([(v, f), (v, f)])
    assert s.mesh_count == 2 and s.triangle_count == 2 * len(f)
    o, d = sensor_rays(2000, seed=9)
    for e in ["bvh", "crsh", "grid"]:
        eng = rs.Engine(s, e)
        s.update(transform=lift, mesh=1)
        eng.rebuild()
        fresh = rs.Scene.from_meshes([(v, f), (v, f, lift)])
        assert np.array_equal(s.triangles(), fresh.triangles())
        same_hits(eng.trace(o, d), rs.Engine(fresh, e).trace(o, d))
        s.update(transform=np.eye(4), mesh=1)
    tri = s.triangles()
    assert np.array_equal(tri[: len(f)], tri[len(f):])


def test_a_scene_from_arrays_renders():
    v, f = wavy()
    img, stats = rs.render(rs.Scene.from_arrays(v, f), width=48, height=32)
    assert img.shape == (32, 48, 3)
    black = (img < 8).all(axis=2).mean()
    assert black < 0.5, f"{black:.0%} black"
    assert stats["rays"] > 0 if "rays" in stats else True


def test_the_sensor_sweep_example_runs(capsys, monkeypatch):
    script = REPO / "python" / "examples" / "sensor_sweep.py"
    monkeypatch.setattr(sys, "argv", [str(script), "--frames", "3", "--rays", "500"])
    runpy.run_path(str(script), run_name="__main__")
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 3 and all(" of 500 rays hit" in line for line in out), out
    assert int(out[0].split("=")[1].split(":")[1].split()[0]) > 100


def test_installed_from_the_wheel_without_rust():
    wheel = os.environ.get("RAYSPACE_WHEEL")
    need(wheel is not None, "not run against a built wheel (RAYSPACE_WHEEL unset; .ci/run sets it)")
    where = pathlib.Path(rs.__file__).resolve()
    assert "site-packages" in where.parts, where
    assert shutil.which("cargo") is None and shutil.which("rustc") is None
