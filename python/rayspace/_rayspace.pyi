"""Type stubs of the compiled module (the public API is re-exported by ``rayspace``)."""

from typing import Any, Dict, List, Optional, Tuple

import numpy as np
import numpy.typing as npt

MISS: int
DEFAULT_ENGINE: str

class Error(ValueError): ...

class Scene:
    @staticmethod
    def load(
        spec: str,
        meshes: str = "groups",
        allow_outside_paths: bool = False,
        fill: Optional[bool] = None,
        exposure: Optional[float] = None,
    ) -> Scene: ...
    @staticmethod
    def from_arrays(
        vertices: npt.ArrayLike,
        faces: npt.ArrayLike,
        transform: Optional[npt.ArrayLike] = None,
        name: str = "arrays",
    ) -> Scene: ...
    @staticmethod
    def from_meshes(meshes: Any, name: str = "arrays") -> Scene: ...
    def update(
        self,
        vertices: Optional[npt.ArrayLike] = None,
        transform: Optional[npt.ArrayLike] = None,
        mesh: int = 0,
    ) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def triangle_count(self) -> int: ...
    @property
    def mesh_count(self) -> int: ...
    @property
    def light_count(self) -> int: ...
    @property
    def bounds(self) -> Tuple[Tuple[float, float, float], Tuple[float, float, float]]: ...
    @property
    def animated(self) -> bool: ...
    @property
    def time_range(self) -> Optional[Tuple[float, float]]: ...
    @property
    def load_seconds(self) -> float: ...
    @property
    def warnings(self) -> List[str]: ...
    def at_time(self, t: float) -> Scene: ...
    def frame_times(self, n: int) -> List[float]: ...
    def triangles(self) -> npt.NDArray[np.float32]: ...

class Engine:
    def __init__(self, scene: Scene, name: str, **options: Any) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def build_seconds(self) -> float: ...
    @property
    def build_report(self) -> Optional[str]: ...
    @property
    def build_passes(self) -> List[Tuple[str, float]]: ...
    def trace(
        self,
        origins: npt.NDArray[np.float32],
        directions: npt.NDArray[np.float32],
        tmin: Optional[npt.NDArray[np.float32]] = None,
        tmax: Optional[npt.NDArray[np.float32]] = None,
        any_hit: bool = False,
        points: bool = False,
        normals: bool = False,
    ) -> Dict[str, np.ndarray]: ...
    def rebuild(self) -> None: ...
    @property
    def current(self) -> bool: ...
    def counters(self) -> Dict[str, Any]: ...

def rays(
    scene: Scene,
    kind: str = "primary",
    width: int = 512,
    height: int = 512,
    spp: int = 1,
    seed: int = 1,
    ao_distance: Optional[float] = None,
) -> Dict[str, np.ndarray]: ...
def read_rays(path: str) -> Dict[str, np.ndarray]: ...
def write_rays(
    path: str,
    origins: npt.NDArray[np.float32],
    directions: npt.NDArray[np.float32],
    tmin: Optional[npt.NDArray[np.float32]] = None,
    tmax: Optional[npt.NDArray[np.float32]] = None,
    scene: Optional[Scene] = None,
) -> None: ...
def read_hits(path: str) -> Tuple[Dict[str, np.ndarray], bool]: ...
def write_hits(
    path: str,
    t: npt.NDArray[np.float32],
    triangle: npt.NDArray[np.uint32],
    u: npt.NDArray[np.float32],
    v: npt.NDArray[np.float32],
    any_hit: bool = False,
) -> None: ...
def render(
    scene: Scene,
    engine: Optional[str] = None,
    width: int = 512,
    height: int = 512,
    bounces: int = 3,
    time: Optional[float] = None,
    dynamic: bool = False,
    spp: int = 1,
    viewpoint: Optional[Any] = None,
    **options: Any,
) -> Tuple[npt.NDArray[np.uint8], str]: ...
def frame(
    scene: Scene,
    t: float,
    index: int,
    engine: Optional[str] = None,
    width: int = 512,
    height: int = 512,
    bounces: int = 3,
    **options: Any,
) -> Tuple[bytes, str]: ...
def frame_csv_header() -> str: ...
def png_bytes(image: npt.NDArray[np.uint8]) -> bytes: ...
def write_atomic(path: str, data: bytes) -> None: ...
def engine_names() -> List[str]: ...
def engine_options() -> List[Dict[str, Any]]: ...
