"""Distributed frames and sweeps on Ray (``pip install rayspace[ray]``).

A long BART animation, or a sweep over scenes × engines × configurations, outgrows one
machine. These functions run rayspace's own work as Ray tasks: each worker process loads
its scene once (one actor per worker), frames and measurements are handed out one at a
time from a queue (so a slow frame does not hold up the others), and the results come
back to the caller. A frame rendered here is the command line's frame byte for byte
(:func:`rayspace._rayspace.frame` is the function ``rayspace render --frames`` calls), and
every count equals one local process's.

``address=None`` starts a local Ray for the call (and stops it afterwards); an address
(``"127.0.0.1:6379"``, ``"ray://host:10001"``) joins an existing cluster, which is left
running. If Ray is already initialised in this process, that session is used as it is.
Start a cluster with ``ray start --head`` on one machine and
``ray start --address HEAD:6379`` on the others.
"""

from __future__ import annotations

import contextlib
import os
import re
import time
from typing import Any, Dict, Iterator, List, Optional, Sequence, Union

from . import Engine, Error, Scene, _rayspace, rays

__all__ = ["render_frames", "sweep"]


def _ray() -> Any:
    try:
        import ray
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise Error(
            "rayspace.distributed needs Ray: pip install 'rayspace[ray]' (or pip install ray)"
        ) from e
    return ray


@contextlib.contextmanager
def _session(address: Optional[str], num_cpus: Optional[int]) -> Iterator[Any]:
    """Ray, initialised for the call unless it already is."""
    ray = _ray()
    if ray.is_initialized():
        yield ray
        return
    kwargs: Dict[str, Any] = {"include_dashboard": False, "logging_level": "ERROR", "log_to_driver": False}
    if address is None:
        if num_cpus is not None:
            kwargs["num_cpus"] = num_cpus
        ray.init(**kwargs)
    else:
        ray.init(address=address, **kwargs)
    try:
        yield ray
    finally:
        ray.shutdown()


def _frame_path(pattern: str, frame: int) -> str:
    """``pattern`` with its ``%d`` / ``%0Nd`` replaced by ``frame`` (as ``--out``)."""
    m = re.search(r"%(0?)(\d*)d", pattern)
    if m is None:
        raise Error(f"pattern {pattern}: needs a frame number pattern such as %04d")
    width = int(m.group(2) or 0)
    if width > 12:
        raise Error(f"pattern {pattern}: bad frame number pattern {m.group(0)}")
    return pattern[: m.start()] + str(frame).zfill(width) + pattern[m.end() :]


def _portable(scene: str) -> str:
    """A scene file as an absolute path (workers need not share the caller's working
    directory); a built-in scene's name as it is."""
    return os.path.abspath(scene) if os.path.exists(scene) else scene


class _FrameWorker:
    """One per worker process: the scene, loaded once."""

    def __init__(self, scene_path: str, meshes: str) -> None:
        self.scene = Scene.load(scene_path, meshes=meshes)

    def frames(self, work: List[Any], engine: str, width: int, height: int, bounces: int, options: Dict[str, Any]) -> List[Any]:
        out = []
        for index, t in work:
            png, line = _rayspace.frame(self.scene, t, index, engine, width, height, bounces, **options)
            out.append((index, bytes(png), line))
        return out


def render_frames(
    scene_path: str,
    frames: Union[int, Sequence[float]],
    engine: str = "crsh",
    width: int = 512,
    height: int = 512,
    bounces: int = 3,
    out_dir: Union[str, "os.PathLike[str]"] = ".",
    pattern: str = "frame_%04d.png",
    address: Optional[str] = None,
    workers: Optional[int] = None,
    chunk: int = 1,
    meshes: str = "groups",
    **options: Any,
) -> List[Dict[str, Any]]:
    """Render frames of an animated scene on Ray, as ``rayspace render SCENE --frames N``.

    ``frames``: a count, spread over the animation as ``--frames`` spreads it, or a list
    of times. Each Ray worker (``workers`` actors, default one per CPU of the cluster)
    loads the scene once; frames go out in tasks of ``chunk`` frames, interleaved over the
    animation (task k holds frames k, k + K, k + 2K, …), handed to whichever worker is free.
    The PNGs are written (atomically) into ``out_dir`` under ``pattern``, with
    ``frames.csv`` (``--frame-csv``'s columns). Returns one dictionary per frame, in frame
    order: ``frame``, ``time``, ``path`` and the CSV's columns.
    """
    out_dir = os.fspath(out_dir)
    if not os.path.isdir(out_dir):
        raise Error(f"out_dir {out_dir}: not a directory")
    _frame_path(pattern, 0)
    if chunk < 1:
        raise Error(f"chunk={chunk}: expected at least 1")
    scene_path = _portable(scene_path)
    if isinstance(frames, int):
        if frames < 1:
            raise Error(f"frames={frames}: expected at least one frame")
        times = Scene.load(scene_path, meshes=meshes).frame_times(frames)
    else:
        times = [float(t) for t in frames]
        if not times:
            raise Error("frames: an empty list of times")
    n = len(times)
    tasks = (n + chunk - 1) // chunk
    work = [[(i, times[i]) for i in range(k, n, tasks)] for k in range(tasks)]
    with _session(address, workers) as ray:
        from ray.util import ActorPool

        cpus = int(ray.cluster_resources().get("CPU", 1))
        count = max(1, min(workers or cpus, tasks))
        actor = ray.remote(num_cpus=1)(_FrameWorker)
        pool = ActorPool([actor.remote(scene_path, meshes) for _ in range(count)])
        results = []
        for part in pool.map_unordered(
            lambda a, w: a.frames.remote(w, engine, width, height, bounces, options), work
        ):
            results.extend(part)
    results.sort(key=lambda r: r[0])
    header = _rayspace.frame_csv_header()
    columns = header.split(",")
    rows = []
    for index, png, line in results:
        path = os.path.join(out_dir, _frame_path(pattern, index))
        _rayspace.write_atomic(path, png)
        values: Dict[str, Any] = {"path": path}
        for c, v in zip(columns, line.split(",")):
            values[c] = int(v) if c in ("frame", "triangles", "rays", "total_tests") else float(v)
        rows.append(values)
    csv = header + "\n" + "".join(line + "\n" for _, _, line in results)
    _rayspace.write_atomic(os.path.join(out_dir, "frames.csv"), csv.encode())
    return rows


def _measure(scene_path: str, engine: str, config: Dict[str, Any], kind: Dict[str, Any], meshes: str, repeats: int) -> Dict[str, Any]:
    """One sweep point: build the engine, trace the rays (best of ``repeats``)."""
    scene = Scene.load(scene_path, meshes=meshes)
    r = rays(scene, **{k: v for k, v in kind.items() if k != "any_hit"})
    any_hit = bool(kind.get("any_hit", kind.get("kind") in ("shadow", "ao")))
    t0 = time.perf_counter()
    e = Engine(scene, engine, **config)
    build = time.perf_counter() - t0
    best = float("inf")
    for _ in range(max(1, repeats)):
        t1 = time.perf_counter()
        hits = e.trace(**r, any_hit=any_hit)
        best = min(best, time.perf_counter() - t1)
    c = e.counters()
    n = len(r["tmin"])
    return {
        "scene": scene.name,
        "engine": e.name,
        "config": dict(config),
        "kind": kind.get("kind", "primary"),
        "rays": n,
        "any_hit": any_hit,
        "build_ms": build * 1e3,
        "trace_ms": best * 1e3,
        "mrays_per_s": n / best / 1e6 if best > 0 else float("inf"),
        "hits": int((hits["triangle"] != _rayspace.MISS).sum()),
        "ray_tri_tests": c["ray_tri_tests"],
        "node_tri_tests": c["node_tri_tests"],
        "total_tests": c["total_tests"],
        "traversal_steps": c.get("counters", {}).get("traversal steps"),
    }


def sweep(
    scenes: Sequence[str],
    engines: Sequence[str],
    configs: Optional[Sequence[Dict[str, Any]]] = None,
    rays: Sequence[Dict[str, Any]] = ({"kind": "primary", "width": 256, "height": 256},),
    address: Optional[str] = None,
    workers: Optional[int] = None,
    repeats: int = 1,
    meshes: str = "groups",
) -> Any:
    """Measure every scene × engine × configuration × ray set as Ray tasks.

    ``configs``: engine-option dictionaries (``[{}, {"levels": 4}]``; default one with no
    options); ``rays``: keyword arguments of :func:`rayspace.rays` (``kind``, ``width``,
    ``height``, ``spp``, ``seed``, ``ao_distance``) plus ``any_hit`` (default: true for
    shadow and ao rays). One task per point, each on one CPU. Returns a pandas DataFrame
    when pandas is installed, else a list of dictionaries: build and trace milliseconds
    (best of ``repeats``), MRays/s, hits and the engine's counts, which equal one local
    process's.
    """
    configs = list(configs) if configs else [{}]
    points = [(_portable(s), e, c, k) for s in scenes for e in engines for c in configs for k in rays]
    if not points:
        raise Error("sweep: no scenes, engines or rays")
    with _session(address, workers) as ray:
        task = ray.remote(num_cpus=1)(_measure)
        refs = [task.remote(s, e, c, dict(k), meshes, repeats) for s, e, c, k in points]
        rows = ray.get(refs)
    try:
        import pandas

        return pandas.DataFrame(rows)
    except ImportError:
        return rows
