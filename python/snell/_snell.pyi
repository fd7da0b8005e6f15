"""Type stubs of the native module (snell._snell); import ``snell`` instead."""

from os import PathLike
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Path = Union[str, PathLike[str]]
_Vec3 = Union[Sequence[float], npt.NDArray[np.floating[Any]]]
_Points = Union[Sequence[Sequence[float]], npt.NDArray[Any]]
_Progress = Union[bool, Callable[[Dict[str, Union[int, float]]], Any], None]

class SceneError(ValueError):
    """A scene that cannot be loaded; the message is the command line's."""

    file: str
    key: str
    line: Optional[int]
    column: Optional[int]
    message: str

class Scene:
    """A loaded scene; immutable (``set`` returns a new one)."""

    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def spp(self) -> int: ...
    @property
    def seed(self) -> int: ...
    @property
    def solids(self) -> List[str]: ...
    @property
    def warnings(self) -> List[str]: ...
    @property
    def overrides(self) -> List[str]: ...
    def set(self, key: str, value: Any) -> Scene: ...
    def to_toml(self) -> str: ...

def load_file(path: _Path) -> Scene: ...
def load_string(toml: str, base_dir: Optional[_Path] = None, name: str = "<string>") -> Scene: ...
def load_dict(scene: Dict[str, Any], base_dir: Optional[_Path] = None) -> Scene: ...

class RenderResult:
    """One render's image, diagnostic layers and statistics."""

    @property
    def image(self) -> npt.NDArray[np.float32]: ...
    @property
    def variance(self) -> npt.NDArray[np.float32]: ...
    @property
    def aovs(self) -> Dict[str, npt.NDArray[np.float32]]: ...
    @property
    def stats(self) -> Dict[str, Any]: ...
    @property
    def complete(self) -> bool: ...
    @property
    def region(self) -> Tuple[int, int, int, int]: ...
    @property
    def samples(self) -> Tuple[int, int]: ...

def render(
    scene: Scene,
    spp: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    nested: str = "filter",
    aovs: Sequence[str] = (),
    region: Optional[Tuple[int, int, int, int]] = None,
    samples: Optional[Tuple[int, int]] = None,
    width: Optional[int] = None,
    height: Optional[int] = None,
    progress: _Progress = None,
) -> Union[npt.NDArray[np.float32], Tuple[npt.NDArray[np.float32], Dict[str, npt.NDArray[np.float32]]]]: ...
def render_result(
    scene: Scene,
    spp: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    nested: str = "filter",
    aovs: Sequence[str] = (),
    region: Optional[Tuple[int, int, int, int]] = None,
    samples: Optional[Tuple[int, int]] = None,
    width: Optional[int] = None,
    height: Optional[int] = None,
    progress: _Progress = None,
) -> RenderResult: ...
def read(path: _Path) -> npt.NDArray[np.float32]: ...
def write(
    path: _Path,
    image: npt.ArrayLike,
    aovs: Optional[Dict[str, npt.ArrayLike]] = None,
) -> None: ...
def trace_path(
    scene: Scene,
    origin: _Vec3,
    direction: _Vec3,
    inside: Optional[Sequence[str]] = None,
    nested: str = "filter",
    max_events: int = 64,
) -> Dict[str, Any]: ...

class GrinTrace:
    """The end of every ray of ``snell.grin.trace``."""

    @property
    def end(self) -> npt.NDArray[np.float64]: ...
    @property
    def direction(self) -> npt.NDArray[np.float64]: ...
    @property
    def length(self) -> npt.NDArray[np.float64]: ...
    @property
    def evaluations(self) -> npt.NDArray[np.uint64]: ...
    @property
    def steps(self) -> npt.NDArray[np.uint64]: ...
    @property
    def ok(self) -> npt.NDArray[np.bool_]: ...
    @property
    def status(self) -> List[str]: ...
    def __len__(self) -> int: ...

def trace(
    field: Dict[str, Any],
    origins: _Points,
    directions: _Points,
    method: str = "rk45",
    length: Optional[float] = None,
    x: Optional[float] = None,
    tolerance: Optional[float] = None,
    step: Optional[float] = None,
    steps: Optional[int] = None,
    max_length: Optional[float] = None,
) -> GrinTrace: ...

class WarpImages:
    """Every image of every vertex of a warp."""

    FAMILIES: List[str]
    @property
    def positions(self) -> npt.NDArray[np.float64]: ...
    @property
    def directions(self) -> npt.NDArray[np.float64]: ...
    @property
    def family(self) -> npt.NDArray[np.uint8]: ...
    @property
    def refractions(self) -> npt.NDArray[np.uint32]: ...
    @property
    def parity(self) -> npt.NDArray[np.int8]: ...
    @property
    def counts(self) -> npt.NDArray[np.uint32]: ...
    @property
    def offsets(self) -> npt.NDArray[np.int64]: ...
    @property
    def vertex(self) -> npt.NDArray[np.int64]: ...
    @property
    def status(self) -> npt.NDArray[np.uint8]: ...
    @property
    def statuses(self) -> List[str]: ...
    def messages(self) -> List[str]: ...
    def __len__(self) -> int: ...

def plate(
    vertices: _Points,
    eye: _Vec3,
    near_face_point: _Vec3,
    normal: _Vec3,
    thickness: float,
    ior: float,
    solver: str = "batch",
) -> WarpImages: ...
def plate_positions(
    vertices: _Points,
    eye: _Vec3,
    near_face_point: _Vec3,
    normal: _Vec3,
    thickness: float,
    ior: float,
    out: Optional[npt.NDArray[np.float32]] = None,
) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.int8]]: ...
def hollow_cylinder(
    vertices: _Points,
    eye: _Vec3,
    axis_point: _Vec3,
    axis_direction: _Vec3,
    outer_radius: float,
    inner_radius: float,
    ior: float,
    method: str = "exact",
    solver: str = "tables",
    parity: bool = True,
) -> WarpImages: ...
