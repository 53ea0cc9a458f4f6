import os
from typing import Any, Dict, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

Faces = Union[npt.NDArray[np.int64], Tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]]
PathLike = Union[str, os.PathLike]

__version__: str
FORMAT_VERSION: int
WRITABLE_FORMATS: Tuple[str, ...]

class FormatError(ValueError): ...

class PointCloud:
    points: npt.NDArray[np.float64]
    normals: Optional[npt.NDArray[np.float32]]
    colors: Optional[npt.NDArray[np.uint8]]
    intensities: Optional[npt.NDArray[np.float32]]
    def __init__(
        self,
        points: npt.NDArray[np.float64],
        normals: Optional[npt.NDArray[np.floating]] = None,
        colors: Optional[npt.NDArray[np.uint8]] = None,
        intensities: Optional[npt.NDArray[np.floating]] = None,
    ) -> None: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]: ...
    def __len__(self) -> int: ...
    def to_trimesh(self) -> Any: ...
    def to_open3d(self) -> Any: ...

class Mesh:
    vertices: npt.NDArray[np.float64]
    faces: Faces
    normals: Optional[npt.NDArray[np.float32]]
    colors: Optional[npt.NDArray[np.uint8]]
    def __init__(
        self,
        vertices: npt.NDArray[np.float64],
        faces: Faces,
        normals: Optional[npt.NDArray[np.floating]] = None,
        colors: Optional[npt.NDArray[np.uint8]] = None,
    ) -> None: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]: ...
    @property
    def face_offsets(self) -> npt.NDArray[np.int64]: ...
    @property
    def face_indices(self) -> npt.NDArray[np.int64]: ...
    def triangles(self) -> npt.NDArray[np.int64]: ...
    def distance(self, points: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...
    def to_trimesh(self, process: bool = False) -> Any: ...
    def to_open3d(self) -> Any: ...

class Level(Mesh):
    parent: npt.NDArray[np.int64]
    quadrant: npt.NDArray[np.int8]
    kind: Optional[str]

class Hierarchy:
    def __len__(self) -> int: ...
    def __getitem__(self, k: int) -> Level: ...
    def __iter__(self) -> Iterator[Level]: ...
    @property
    def cube(self) -> Optional[Tuple[Tuple[float, float, float], Tuple[float, float, float]]]: ...
    def save(
        self,
        path: PathLike,
        bits: Optional[int] = None,
        step: Optional[float] = None,
        exact: bool = False,
        zstd_level: int = 19,
        units: str = "",
        source: str = "",
        keep_positions: Optional[bool] = None,
    ) -> None: ...

class MrqFile:
    info: Dict[str, Any]
    def __len__(self) -> int: ...
    def level(self, k: int) -> Level: ...
    def hierarchy(self, k: Optional[int] = None) -> Hierarchy: ...

def read(path: PathLike) -> Union[PointCloud, Mesh]: ...
def write(path: PathLike, data: Union[PointCloud, Mesh], ascii: bool = False) -> None: ...
def reconstruct(
    points: npt.NDArray[np.float64],
    max_level: Union[int, str] = "auto",
    relax_passes: int = 4,
    relax_from_level: int = 4,
    fit_passes: int = 3,
    fit_max_faces: int = 100_000,
    min_points: float = 8.0,
    wrap_sparse: bool = False,
    region_levels: int = 0,
    region_density: float = 4.0,
    bits: Optional[int] = None,
    keep_positions: bool = False,
    threads: Optional[int] = None,
) -> Hierarchy: ...
def open_mrq(path: PathLike) -> MrqFile: ...
def validate(
    vertices: npt.NDArray[np.float64],
    faces: Faces,
    require: Sequence[str] = ("manifold",),
    weld: bool = False,
    self_intersections: bool = False,
    max_elements: int = 100,
) -> Dict[str, Any]: ...

MeshSource = Union[Mesh, Hierarchy, MrqFile, npt.NDArray[np.float64]]

def distance(
    points: npt.NDArray[np.float64],
    mesh: Union[Mesh, npt.NDArray[np.float64]],
    faces: Optional[Faces] = None,
) -> npt.NDArray[np.float64]: ...
def decimate(
    data: MeshSource,
    faces: Optional[Faces] = None,
    *,
    target_faces: Optional[int] = None,
    ratio: Optional[float] = None,
    max_error: Union[None, float, str] = None,
    view: Union[None, Dict[str, Any], PathLike] = None,
    lock_border: bool = False,
    quads: str = "auto",
    measure: bool = False,
    cut: str = "auto",
) -> Tuple[Mesh, Dict[str, Any]]: ...
def export_glb(
    data: MeshSource,
    faces: Optional[Faces] = None,
    *,
    path: Optional[PathLike] = None,
    levels: Union[str, int] = "finest",
    quantize: bool = False,
    meshopt: bool = False,
    crease_angle: Optional[float] = None,
    colors: bool = True,
    screen_error: float = 1.0,
    metadata: Union[None, Dict[str, str], Sequence[Tuple[str, str]]] = None,
) -> Tuple[bytes, Dict[str, Any]]: ...
def export_tiles(
    data: Union[MeshSource, PathLike],
    directory: PathLike,
    *,
    faces: Optional[Faces] = None,
    quantize: bool = False,
    meshopt: bool = False,
    colors: bool = True,
    metadata: Union[None, Dict[str, str], Sequence[Tuple[str, str]]] = None,
) -> Dict[str, Any]: ...
