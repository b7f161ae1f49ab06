"""rayspace from Python: load scenes, make rays, trace them with any engine, render frames.

The engines are rayspace's own (Rust, through PyO3): ``bvh`` (the object tree walked by
packets or single rays, the default), CRSH and RAH (ray-space hierarchies), the irregular
grid and its two-level baseline, brute force (the oracle) and the obvhs peers. Engine
options are the command line's, spelled with ``_`` for ``-``
(``Engine(scene, "crsh", branching=16, levels=3)``; :func:`engine_options` lists them),
and every result is the command line's: the same hits bit for bit, the same image bytes,
the same counters.

Arrays in and out are NumPy: rays as ``(N, 3)`` origins and directions of any real dtype
and any strides (converted to float32 once; float32 C arrays are used as they are) with
``tmin``/``tmax`` each a scalar or ``(N,)``; hits as ``{"t", "triangle", "u", "v"}`` (a
miss has triangle ``MISS`` and t = inf). Bad values raise :class:`Error` (a
``ValueError``) with a one-line message naming the argument; input that is not numbers,
or an unknown keyword argument, raises ``TypeError``. The GIL is released while scenes
load, engines build and rays are traced.

Distributed frames and sweeps on Ray: :mod:`rayspace.distributed`.
"""

from __future__ import annotations

import json as _json
import os as _os
from importlib import metadata as _metadata
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as _np
from numpy.typing import ArrayLike

from . import _rayspace
from ._rayspace import MISS, Error, Scene

try:
    __version__ = _metadata.version("rayspace")
except _metadata.PackageNotFoundError:  # a source tree without an installed package
    __version__ = "0.1.0"

def __dir__() -> List[str]:
    """The public names (``dir(rayspace)``), not the helpers this module imports."""
    return sorted(__all__ + ["distributed"])


__all__ = [
    "__version__",
    "MISS",
    "Error",
    "Scene",
    "Engine",
    "DEFAULT_ENGINE",
    "engines",
    "engine_options",
    "rays",
    "render",
    "png_bytes",
    "write_png",
    "read_rays",
    "write_rays",
    "read_hits",
    "write_hits",
]

PathLike = Union[str, "_os.PathLike[str]"]


DEFAULT_ENGINE: str = _rayspace.DEFAULT_ENGINE
"""The engine used when none is named (the command line's default too)."""


def engines() -> List[str]:
    """The engine names this build has (``--engine``'s values)."""
    return list(_rayspace.engine_names())


def engine_options() -> List[Dict[str, Any]]:
    """Every engine option: ``{"name", "takes", "doc", "engines", "default"}`` each, from
    the engines' own declarations (``rayspace engines`` on the command line)."""
    return [dict(o) for o in _rayspace.engine_options()]


def _array(name: str, a: Any, dtype: Any, shape: Tuple[Optional[int], ...]) -> _np.ndarray:
    """``a`` (any array-like: any real dtype, any strides) as a C-contiguous array of
    ``dtype`` and ``shape`` (None: any), converted once; an array that is one already is
    passed as it is, without a copy. Integer targets take integers only (a float is not
    silently truncated). Not real numbers: ``TypeError``; the wrong shape: ``ValueError``."""
    arr = _np.asarray(a)
    want_int = _np.dtype(dtype).kind in "iu"
    kinds = "iub" if want_int else "iufb"
    if arr.dtype.kind not in kinds:
        what = "integers" if want_int else "real numbers"
        raise TypeError(f"{name}: expected {what}, got an array of dtype {arr.dtype}")
    if arr.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, arr.shape)):
        want = "(" + ", ".join("N" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
        raise Error(f"{name}: expected shape {want}, got {arr.shape}")
    if want_int and arr.dtype != dtype and arr.size:
        info = _np.iinfo(dtype)
        if arr.min() < info.min or arr.max() > info.max:
            raise Error(f"{name}: values outside {_np.dtype(dtype).name}'s range [{info.min}, {info.max}]")
    return _np.ascontiguousarray(arr, dtype=dtype)


def _finite(name: str, a: _np.ndarray) -> None:
    bad = ~_np.isfinite(a)
    if bad.any():
        row = int(_np.argwhere(bad)[0][0])
        raise Error(f"{name}: row {row} is not finite ({a[row]})")


def _rays(origins: Any, directions: Any, tmin: Any, tmax: Any):
    o = _array("origins", origins, _np.float32, (None, 3))
    d = _array("directions", directions, _np.float32, (None, 3))
    if len(o) != len(d):
        raise Error(f"directions: {len(d)} rays, but origins has {len(o)}")
    _finite("origins", o)
    _finite("directions", d)
    return o, d, _bound("tmin", tmin, len(o)), _bound("tmax", tmax, len(o))


def _bound(name: str, b: Any, n: int) -> Optional[_np.ndarray]:
    """A ray bound: None (the default), a scalar for every ray, or one per ray."""
    if b is None:
        return None
    if _np.ndim(b) == 0:
        s = _array(name, b, _np.float32, ())
        return _np.full(n, s, _np.float32)
    return _array(name, b, _np.float32, (n,))


class Engine:
    """An engine built over a scene: ``Engine(scene, "grid", grid_top_density=0.1)``.

    ``name`` is any of :func:`engines`; ``options`` are the command line's engine options
    with ``_`` for ``-`` (:func:`engine_options` lists each with the engines that take it);
    booleans mean on/off. An option the engine does not take raises :class:`Error`.
    """

    def __init__(self, scene: Scene, name: str, **options: Any) -> None:
        self._engine = _rayspace.Engine(scene, name, **options)

    @property
    def name(self) -> str:
        """The engine's name."""
        return self._engine.name

    @property
    def build_seconds(self) -> float:
        """Wall time of the build."""
        return self._engine.build_seconds

    @property
    def build_passes(self) -> List[Tuple[str, float]]:
        """Seconds per build pass (the grids': references, octrees, merge, ...)."""
        return list(self._engine.build_passes)

    @property
    def build_report(self) -> Optional[str]:
        """The command line's one-line description of what was built (grids), or None."""
        return self._engine.build_report

    def trace(
        self,
        origins: ArrayLike,
        directions: ArrayLike,
        tmin: Optional[ArrayLike] = None,
        tmax: Optional[ArrayLike] = None,
        any_hit: bool = False,
        points: bool = False,
        normals: bool = False,
    ) -> Dict[str, _np.ndarray]:
        """Trace rays: ``(N, 3)`` origins and directions, optional bounds, each a scalar or
        ``(N,)`` (default 0 and inf). Any real dtype and any strides are taken (converted to
        C-contiguous float32 once; float32 C arrays are used as they are); the wrong shape
        raises ``ValueError`` (:class:`Error`), non-numbers ``TypeError``. Returns
        ``{"t", "triangle", "u", "v"}`` arrays; a
        closest-hit record is brute force's bit for bit (smallest t, ties to the smallest
        triangle), an any-hit record is some hit in range. ``points=True`` adds ``"point"``,
        the ``(N, 3)`` world-space hit points, ``normals=True`` ``"normal"``, the unit
        shading normals (NaN rows for misses). ``engine.trace(**rays(scene))`` works as is.
        After :meth:`Scene.update`, tracing raises :class:`Error` until :meth:`rebuild`."""
        o, d, lo, hi = _rays(origins, directions, tmin, tmax)
        return self._engine.trace(o, d, lo, hi, bool(any_hit), bool(points), bool(normals))

    def rebuild(self) -> None:
        """Bring the engine to its scene as it is now (after :meth:`Scene.update`): the
        engine is built again over the scene's current triangles. Until then, tracing after
        an update raises :class:`Error` rather than answering for the old triangles."""
        self._engine.rebuild()

    @property
    def current(self) -> bool:
        """Whether the engine was built for its scene as it is now."""
        return self._engine.current

    def counters(self) -> Dict[str, Any]:
        """The last trace's counters: rays, hits, ray_tri_tests, node_tri_tests,
        total_tests, the engine's own counters (traversal steps, ...) and phase seconds."""
        return self._engine.counters()

    def __repr__(self) -> str:
        return f"Engine({self.name!r})"


def rays(
    scene: Scene,
    kind: str = "primary",
    width: int = 512,
    height: int = 512,
    spp: int = 1,
    seed: int = 1,
    ao_distance: Optional[float] = None,
) -> Dict[str, _np.ndarray]:
    """The rays ``rayspace rays`` makes: ``kind`` primary, shadow, ao or random, per pixel
    of a ``width`` × ``height`` view of the scene's camera (``spp`` per pixel for ao and
    random). Returns ``{"origins", "directions", "tmin", "tmax"}``."""
    return _rayspace.rays(scene, kind, width, height, spp, seed, ao_distance)


def render(
    scene: Scene,
    engine: str = DEFAULT_ENGINE,
    width: int = 512,
    height: int = 512,
    bounces: int = 3,
    time: Optional[float] = None,
    dynamic: bool = False,
    spp: int = 1,
    viewpoint: Optional[Any] = None,
    **options: Any,
) -> Tuple[_np.ndarray, Dict[str, Any]]:
    """``rayspace render``: an ``(height, width, 3) uint8`` sRGB image and the ``--stats``
    dictionary. ``time`` renders the animation at that time; ``dynamic=True`` takes the
    engine options a frame of ``--frames`` takes (the grid's single expansion pass);
    ``spp`` samples per pixel antialias it (``--spp``); ``viewpoint`` is ``--viewpoint``'s
    camera, ``"EX,EY,EZ,TX,TY,TZ[,FOV]"`` or six or seven numbers."""
    img, stats = _rayspace.render(scene, engine, width, height, bounces, time, dynamic, spp, viewpoint, **options)
    return img, _json.loads(stats)


def png_bytes(image: _np.ndarray) -> bytes:
    """An ``(H, W, 3) uint8`` image as PNG bytes, encoded as the command line encodes."""
    return _rayspace.png_bytes(_array("image", image, _np.uint8, (None, None, 3)))


def write_png(path: PathLike, image: _np.ndarray) -> None:
    """Write an ``(H, W, 3) uint8`` image as the command line's PNG bytes, atomically."""
    _rayspace.write_atomic(_os.fspath(path), png_bytes(image))


def read_rays(path: PathLike) -> Dict[str, _np.ndarray]:
    """A ray file (rayspace's, or hagrid's headerless 6 × f32 per ray) as
    ``{"origins", "directions", "tmin", "tmax"}``."""
    return _rayspace.read_rays(_os.fspath(path))


def write_rays(
    path: PathLike,
    origins: ArrayLike,
    directions: ArrayLike,
    tmin: Optional[ArrayLike] = None,
    tmax: Optional[ArrayLike] = None,
    scene: Optional[Scene] = None,
) -> None:
    """Write rays as a rayspace ray file (``write_rays(path, **rays(scene), scene=scene)``);
    ``scene``, the scene they were made for, is recorded in the file (its name and a hash
    of its triangles), as ``rayspace rays`` records it, so ``rayspace trace`` can warn when
    they are traced against another."""
    o, d, lo, hi = _rays(origins, directions, tmin, tmax)
    _rayspace.write_rays(_os.fspath(path), o, d, lo, hi, scene)


def read_hits(path: PathLike) -> Dict[str, Any]:
    """A hit file as ``{"t", "triangle", "u", "v", "any_hit"}``."""
    hits, any_hit = _rayspace.read_hits(_os.fspath(path))
    hits["any_hit"] = any_hit
    return hits


def write_hits(
    path: PathLike,
    t: ArrayLike,
    triangle: ArrayLike,
    u: ArrayLike,
    v: ArrayLike,
    any_hit: bool = False,
) -> None:
    """Write hit records as a rayspace hit file (``write_hits(path, **engine.trace(...))``)."""
    n = _np.shape(t)[0] if _np.ndim(t) == 1 else None
    t = _array("t", t, _np.float32, (n,))
    triangle = _array("triangle", triangle, _np.uint32, (n,))
    u = _array("u", u, _np.float32, (n,))
    v = _array("v", v, _np.float32, (n,))
    _rayspace.write_hits(_os.fspath(path), t, triangle, u, v, bool(any_hit))
