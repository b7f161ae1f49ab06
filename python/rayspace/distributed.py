"""Distributed frames and sweeps on Ray (``pip install rayspace[ray]``).

A long BART animation, or a sweep over scenes × engines × configurations, outgrows one
machine. These functions run rayspace's own work as Ray tasks: each worker process loads
its scene once (one actor per worker), frames and measurements are handed out one at a
time from a queue (so a slow frame does not hold up the others), frames are written as
they come back, a lost worker costs only the work it held (handed out again), and a
second call resumes where the first stopped. A frame rendered here is the command line's frame byte for byte
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
import hashlib
import json
import os
import re
import time
from typing import Any, Dict, Iterator, List, Optional, Sequence, Union

from . import DEFAULT_ENGINE, Engine, Error, Scene, _rayspace, engine_options, rays

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


MANIFEST = "frames.manifest.json"


def _lost_errors() -> tuple:
    """Ray's exceptions for work lost with its worker (those this Ray version has)."""
    import ray.exceptions as x

    names = ("RayActorError", "WorkerCrashedError", "NodeDiedError", "ObjectLostError", "OwnerDiedError")
    return tuple(getattr(x, n) for n in names if hasattr(x, n))


def _params(scene_path: str, times: List[float], engine: str, width: int, height: int, bounces: int,
            pattern: str, meshes: str, options: Dict[str, Any]) -> Dict[str, Any]:
    """What decides a frame's bytes: a re-run whose parameters differ renders again."""
    stat = None
    if os.path.exists(scene_path):
        st = os.stat(scene_path)
        stat = [st.st_size, st.st_mtime_ns]
    return {
        "scene": scene_path, "scene_file": stat, "times": [float(t).hex() for t in times],
        "engine": engine, "width": width, "height": height, "bounces": bounces,
        "pattern": pattern, "meshes": meshes, "options": {k: repr(v) for k, v in sorted(options.items())},
    }


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _done_frames(out_dir: str, pattern: str, params: Dict[str, Any]) -> Dict[int, Dict[str, str]]:
    """The frames of an earlier call with the same parameters that are on disk as it
    wrote them (index → its hash and CSV line)."""
    try:
        with open(os.path.join(out_dir, MANIFEST)) as f:
            m = json.load(f)
    except (OSError, ValueError):
        return {}
    if not isinstance(m, dict) or m.get("params") != params:
        return {}
    done = {}
    for k, rec in (m.get("frames") or {}).items():
        try:
            index = int(k)
            with open(os.path.join(out_dir, _frame_path(pattern, index)), "rb") as f:
                ok = _sha256(f.read()) == rec["sha256"]
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if ok:
            done[index] = {"sha256": rec["sha256"], "line": rec["line"]}
    return done


def _write_manifest(out_dir: str, params: Dict[str, Any], frames: Dict[int, Dict[str, str]]) -> None:
    m = {"params": params, "frames": {str(k): frames[k] for k in sorted(frames)}}
    _rayspace.write_atomic(os.path.join(out_dir, MANIFEST), json.dumps(m).encode())


def render_frames(
    scene_path: str,
    frames: Union[int, Sequence[float]],
    engine: str = DEFAULT_ENGINE,
    width: int = 512,
    height: int = 512,
    bounces: int = 3,
    out_dir: Union[str, "os.PathLike[str]"] = ".",
    pattern: str = "frame_%04d.png",
    address: Optional[str] = None,
    workers: Optional[int] = None,
    chunk: int = 1,
    meshes: str = "groups",
    cpus_per_worker: int = 1,
    retries: int = 3,
    **options: Any,
) -> List[Dict[str, Any]]:
    """Render frames of an animated scene on Ray, as ``rayspace render SCENE --frames N``.

    ``frames``: a count, spread over the animation as ``--frames`` spreads it, or a list
    of times. Each Ray worker (``workers`` actors, default one per ``cpus_per_worker`` CPUs
    of the cluster, each reserving that many CPUs and tracing on that many threads) loads
    the scene once; frames go out in tasks of ``chunk`` frames, interleaved over the
    animation (task k holds frames k, k + K, k + 2K, …), handed to whichever worker is free.

    Each PNG is written (atomically) into ``out_dir`` under ``pattern`` as it arrives, so
    the caller holds a few frames at a time, and recorded with its hash in
    ``frames.manifest.json``; ``frames.csv`` (``--frame-csv``'s columns) is written at the
    end. A lost worker (its process or node killed) costs only its task: the task's frames
    are handed out again (up to ``retries`` times each) to a new worker. Calling again with
    the same parameters renders only the frames not yet on disk as the manifest recorded
    them (a changed parameter renders them all). Returns one dictionary per frame, in frame
    order: ``frame``, ``time``, ``path``, ``rendered`` (False: kept from an earlier call)
    and the CSV's columns.
    """
    out_dir = os.fspath(out_dir)
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise Error(f"out_dir {out_dir}: exists and is not a directory")
    try:
        os.makedirs(out_dir, exist_ok=True)
    except OSError as e:
        raise Error(f"out_dir {out_dir}: cannot make the folder: {e.strerror}") from None
    _frame_path(pattern, 0)
    if chunk < 1:
        raise Error(f"chunk={chunk}: expected at least 1")
    if cpus_per_worker < 1:
        raise Error(f"cpus_per_worker={cpus_per_worker}: expected at least 1")
    if retries < 0:
        raise Error(f"retries={retries}: expected 0 or more")
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
    params = _params(scene_path, times, engine, width, height, bounces, pattern, meshes, options)
    done = _done_frames(out_dir, pattern, params)
    kept = set(done)
    todo = [i for i in range(n) if i not in done]
    if todo:
        tasks = (len(todo) + chunk - 1) // chunk
        queue = [[(i, times[i]) for i in todo[k::tasks]] for k in range(tasks)]
        with _session(address, workers) as ray:
            lost = _lost_errors()
            cpus = int(ray.cluster_resources().get("CPU", 1))
            count = max(1, min(workers or max(1, cpus // cpus_per_worker), tasks))
            env = {"env_vars": {"RAYON_NUM_THREADS": str(cpus_per_worker)}}
            actor = ray.remote(num_cpus=cpus_per_worker, runtime_env=env)(_FrameWorker)
            idle = [actor.remote(scene_path, meshes) for _ in range(count)]
            running: Dict[Any, Any] = {}
            failures: Dict[int, int] = {}
            while queue or running:
                while queue and idle:
                    a, w = idle.pop(), queue.pop(0)
                    running[a.frames.remote(w, engine, width, height, bounces, options)] = (a, w)
                ready, _ = ray.wait(list(running), num_returns=1)
                a, w = running.pop(ready[0])
                try:
                    part = ray.get(ready[0])
                except lost as e:
                    # The worker is gone: its frames go out again, to a new worker.
                    key = w[0][0]
                    failures[key] = failures.get(key, 0) + 1
                    if failures[key] > retries:
                        raise Error(f"frames {[i for i, _ in w]}: lost {failures[key]} times ({type(e).__name__})") from e
                    queue.insert(0, w)
                    idle.append(actor.remote(scene_path, meshes))
                    continue
                idle.append(a)
                for index, png, line in part:
                    _rayspace.write_atomic(os.path.join(out_dir, _frame_path(pattern, index)), png)
                    done[index] = {"sha256": _sha256(png), "line": line}
                _write_manifest(out_dir, params, done)
    header = _rayspace.frame_csv_header()
    columns = header.split(",")
    rows = []
    for index in range(n):
        line = done[index]["line"]
        values: Dict[str, Any] = {"path": os.path.join(out_dir, _frame_path(pattern, index)), "rendered": index not in kept}
        for c, v in zip(columns, line.split(",")):
            values[c] = int(v) if c in ("frame", "triangles", "rays", "total_tests") else float(v)
        rows.append(values)
    csv = header + "\n" + "".join(done[i]["line"] + "\n" for i in range(n))
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
    options), each taken by every engine of ``engines`` (an option of another engine raises
    :class:`rayspace.Error` before any task runs, as the command line refuses it); ``rays``: keyword arguments of :func:`rayspace.rays` (``kind``, ``width``,
    ``height``, ``spp``, ``seed``, ``ao_distance``) plus ``any_hit`` (default: true for
    shadow and ao rays). One task per point, each on one CPU and one thread (a task whose
worker is lost runs again, up to 3 times). Returns a pandas DataFrame
    when pandas is installed, else a list of dictionaries: build and trace milliseconds
    (best of ``repeats``), MRays/s, hits and the engine's counts, which equal one local
    process's.
    """
    configs = list(configs) if configs else [{}]
    takers = {o["name"]: o["engines"] for o in engine_options()}
    for e in engines:
        for c in configs:
            for k in c:
                if k in takers and e not in takers[k]:
                    raise Error(f"sweep: {k} does not apply to engine={e} (it is an option of {', '.join(takers[k])})")
    points = [(_portable(s), e, c, k) for s in scenes for e in engines for c in configs for k in rays]
    if not points:
        raise Error("sweep: no scenes, engines or rays")
    with _session(address, workers) as ray:
        # A point whose worker is lost is measured again (Ray's task retries).
        env = {"env_vars": {"RAYON_NUM_THREADS": "1"}}
        task = ray.remote(num_cpus=1, max_retries=3, runtime_env=env)(_measure)
        refs = [task.remote(s, e, c, dict(k), meshes, repeats) for s, e, c, k in points]
        rows = ray.get(refs)
    try:
        import pandas

        return pandas.DataFrame(rows)
    except ImportError:
        return rows
