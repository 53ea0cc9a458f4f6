"""octowrap: point clouds to multiresolution quad meshes, for numpy, trimesh and Open3D users.

Arrays in and out are numpy arrays: positions ``float64 (N, 3)``, normals ``float32 (N, 3)``,
colours ``uint8 (N, 3)``, faces ``int64``. A mesh whose faces all have ``k`` corners (triangles,
quads) gives ``faces`` as an ``(M, k)`` array; a mesh of mixed polygons gives the pair
``(offsets, indices)``, face ``i`` being ``indices[offsets[i]:offsets[i + 1]]`` (both forms are
accepted as input). Inputs must be C-contiguous arrays of the stated dtype: anything else is a
``ValueError`` that says what to pass. Each array is copied once on the way in, then the work runs
with the GIL released, so other Python threads keep running.

``import octowrap`` does not import numpy (whose import is most of a cold start): numpy is
imported when an array is first passed in or handed out.

Errors: ``OSError`` (with the path) when the operating system refuses, ``FormatError`` (a
``ValueError``) for files octowrap cannot read, ``ValueError`` for bad arguments; the messages are
the command line's.

>>> import numpy as np, octowrap
>>> rng = np.random.default_rng(1)
>>> p = rng.normal(size=(20000, 3)); p /= np.linalg.norm(p, axis=1, keepdims=True)
>>> h = octowrap.reconstruct(p, max_level=4)
>>> len(h), h[4].faces.shape[1]
(5, 4)
>>> octowrap.validate(h[4].vertices, h[4].faces, require=["watertight", "oriented"])["passed"]
True
"""

from __future__ import annotations

import operator
import os

# numpy, typing and json are imported where they are used, not here: together they are most of
# the time `import octowrap` would take (the .pyi stub carries the types for checkers).
TYPE_CHECKING = False
if TYPE_CHECKING:
    from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

    import numpy as np

    Faces = Union[np.ndarray, Tuple[np.ndarray, np.ndarray]]
    MeshSource = Union["Mesh", "Hierarchy", "MrqFile", np.ndarray]

from . import _octowrap
from ._octowrap import FORMAT_VERSION, FormatError, __version__

__all__ = [
    "FORMAT_VERSION",
    "FormatError",
    "Hierarchy",
    "Level",
    "Mesh",
    "MrqFile",
    "PointCloud",
    "decimate",
    "distance",
    "export_glb",
    "export_tiles",
    "open_mrq",
    "read",
    "reconstruct",
    "validate",
    "write",
    "WRITABLE_FORMATS",
    "__version__",
]

#: Extensions (without the dot) that :func:`write` writes.
WRITABLE_FORMATS: Tuple[str, ...] = tuple(_octowrap.writable_extensions())


def _faces_from_csr(offsets: np.ndarray, indices: np.ndarray, k: Optional[int]) -> Faces:
    import numpy as np

    if k is not None:
        return indices.reshape(-1, k)
    if len(offsets) == 1:
        return np.empty((0, 3), dtype=np.int64)
    return (offsets, indices)


def _rgba(colors: Optional[np.ndarray]) -> Optional[np.ndarray]:
    if colors is None:
        return None
    import numpy as np

    return np.hstack([colors, np.full((len(colors), 1), 255, np.uint8)])


def _open3d_attributes(o3d: Any, geometry: Any, normals: Optional[np.ndarray], colors: Optional[np.ndarray], prefix: str) -> Any:
    import numpy as np

    if normals is not None:
        setattr(geometry, prefix + "normals", o3d.utility.Vector3dVector(normals.astype(np.float64)))
    if colors is not None:
        setattr(geometry, prefix + "colors", o3d.utility.Vector3dVector(colors / 255.0))
    return geometry


def _need(module: str, extra: str) -> Any:
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as e:
        raise ImportError(f"this needs the '{module}' package: pip install {extra}") from e


class PointCloud:
    """Points with optional normals, colours and intensities (``None`` when absent).

    >>> import numpy as np, octowrap
    >>> c = octowrap.PointCloud(np.zeros((2, 3)))
    >>> c.points.shape, c.normals
    ((2, 3), None)
    """

    def __init__(
        self,
        points: np.ndarray,
        normals: Optional[np.ndarray] = None,
        colors: Optional[np.ndarray] = None,
        intensities: Optional[np.ndarray] = None,
    ) -> None:
        self.points = points
        self.normals = normals
        self.colors = colors
        self.intensities = intensities

    @property
    def positions(self) -> np.ndarray:
        """The points, ``float64 (N, 3)``."""
        return self.points

    def __len__(self) -> int:
        return len(self.points)

    def __repr__(self) -> str:
        return f"PointCloud({len(self)} points)"

    def to_trimesh(self) -> Any:
        """A ``trimesh.PointCloud`` (needs trimesh)."""
        trimesh = _need("trimesh", "trimesh")
        return trimesh.PointCloud(self.points, colors=_rgba(self.colors))

    def to_open3d(self) -> Any:
        """An ``open3d.geometry.PointCloud`` (needs open3d)."""
        o3d = _need("open3d", "open3d")
        pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(self.points))
        return _open3d_attributes(o3d, pc, self.normals, self.colors, "")


class Mesh:
    """A polygon mesh: ``vertices float64 (N, 3)`` and ``faces``.

    ``faces`` is an ``(M, k)`` ``int64`` array when every face has ``k`` corners, else the pair
    ``(offsets, indices)``; ``face_offsets`` and ``face_indices`` give the pair form always.

    >>> import numpy as np, octowrap
    >>> m = octowrap.Mesh(np.eye(3), np.array([[0, 1, 2]]))
    >>> m.faces.shape, m.face_offsets.tolist()
    ((1, 3), [0, 3])
    """

    def __init__(
        self,
        vertices: np.ndarray,
        faces: Faces,
        normals: Optional[np.ndarray] = None,
        colors: Optional[np.ndarray] = None,
    ) -> None:
        self.vertices = vertices
        self.faces = faces
        self.normals = normals
        self.colors = colors

    @property
    def positions(self) -> np.ndarray:
        """The vertices, ``float64 (N, 3)``."""
        return self.vertices

    @property
    def face_offsets(self) -> np.ndarray:
        """``int64 (M + 1,)``: face ``i`` is ``face_indices[face_offsets[i]:face_offsets[i + 1]]``."""
        import numpy as np

        if isinstance(self.faces, tuple):
            return np.asarray(self.faces[0])
        m, k = np.shape(self.faces)
        return np.arange(0, (m + 1) * k, k, dtype=np.int64)

    @property
    def face_indices(self) -> np.ndarray:
        """``int64 (C,)``: every face's corners, face after face."""
        import numpy as np

        if isinstance(self.faces, tuple):
            return np.asarray(self.faces[1])
        return np.asarray(self.faces).reshape(-1)

    def __repr__(self) -> str:
        return f"Mesh({len(self.vertices)} vertices, {len(self.face_offsets) - 1} faces)"

    def triangles(self) -> np.ndarray:
        """The faces as triangles ``int64 (T, 3)``: each face fanned from its first corner."""
        import numpy as np

        off, idx = self.face_offsets, self.face_indices
        sizes = np.diff(off)
        if sizes.size and (sizes == 3).all():
            return idx.reshape(-1, 3)
        fans = np.maximum(sizes - 2, 0)
        face = np.repeat(np.arange(len(sizes)), fans)
        step = np.arange(fans.sum()) - np.repeat(np.cumsum(fans) - fans, fans)
        first = off[:-1][face]
        return np.stack([idx[first], idx[first + step + 1], idx[first + step + 2]], axis=1)

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Each point's distance to this mesh's surface: see :func:`distance`."""
        return distance(points, self)

    def to_trimesh(self, process: bool = False) -> Any:
        """A ``trimesh.Trimesh`` (needs trimesh); polygons fanned into triangles, vertex order kept."""
        trimesh = _need("trimesh", "trimesh")
        return trimesh.Trimesh(
            vertices=self.vertices,
            faces=self.triangles(),
            vertex_normals=self.normals,
            vertex_colors=_rgba(self.colors),
            process=process,
        )

    def to_open3d(self) -> Any:
        """An ``open3d.geometry.TriangleMesh`` (needs open3d); polygons fanned into triangles."""
        import numpy as np

        o3d = _need("open3d", "open3d")
        m = o3d.geometry.TriangleMesh(
            o3d.utility.Vector3dVector(self.vertices), o3d.utility.Vector3iVector(self.triangles().astype(np.int32))
        )
        return _open3d_attributes(o3d, m, self.normals, self.colors, "vertex_")


class Level(Mesh):
    """One level of a :class:`Hierarchy`: a quad mesh plus each face's origin one level up.

    ``parent`` (``int64 (M,)``) is the face of the level above that a face subdivides, ``-1`` for a
    created face (and every face of level 0); ``quadrant`` (``int8 (M,)``) the quarter of that
    parent it covers (the one touching the parent's corner ``quadrant``), ``-1`` when created.
    ``kind`` is ``"root"``, ``"wrapped"`` or ``"subdivided"`` for reconstructed levels, ``None``
    for levels read from a file.
    """

    def __init__(self, raw: tuple) -> None:
        positions, offsets, indices, k, parent, quadrant, kind = raw
        super().__init__(positions, _faces_from_csr(offsets, indices, k))
        self.parent: np.ndarray = parent
        self.quadrant: np.ndarray = quadrant
        self.kind: Optional[str] = kind

    def __repr__(self) -> str:
        return f"Level({len(self.vertices)} vertices, {len(self.parent)} faces, kind={self.kind!r})"


class Hierarchy:
    """A coarse-to-fine sequence of quad meshes; ``h[k]`` is level ``k`` (a :class:`Level`).

    >>> import numpy as np, octowrap
    >>> p = np.random.default_rng(0).normal(size=(5000, 3))
    >>> h = octowrap.reconstruct(p / np.linalg.norm(p, axis=1, keepdims=True), max_level=3)
    >>> [h[k].kind for k in range(len(h))]
    ['root', 'wrapped', 'wrapped', 'wrapped']
    """

    def __init__(self, raw: Any) -> None:
        self._raw = raw

    def __len__(self) -> int:
        return len(self._raw)

    def __getitem__(self, k: int) -> Level:
        n = len(self)
        try:
            k = operator.index(k)
        except TypeError:
            raise TypeError(f"level numbers are integers, not {type(k).__name__}") from None
        if k < 0:
            k += n
        if not 0 <= k < n:
            raise IndexError(f"level {k}: the hierarchy has levels 0 to {n - 1}")
        return Level(self._raw.level(k))

    def __iter__(self):
        return (self[k] for k in range(len(self)))

    def __repr__(self) -> str:
        return f"Hierarchy({len(self)} levels)"

    @property
    def cube(self) -> Optional[Tuple[Tuple[float, float, float], Tuple[float, float, float]]]:
        """The octree root cube ``(min, max)``, when the hierarchy came from an octree."""
        return self._raw.cube

    def save(
        self,
        path: Union[str, os.PathLike],
        bits: Optional[int] = None,
        step: Optional[float] = None,
        exact: bool = False,
        zstd_level: int = 19,
        units: str = "",
        source: str = "",
        keep_positions: Optional[bool] = None,
    ) -> None:
        """Writes the hierarchy as an MRQ file, exactly as ``octowrap reconstruct -o x.mrq``.

        A hierarchy from :func:`reconstruct` is saved as the command line saves it with the same
        options: on the grid it was built for (``reconstruct``'s ``bits``; by default a 64th of
        the finest level's voxel, ``bits = finest level + 6``), each refined vertex already on
        the line the decoder predicts it on, so the file decodes to exactly these levels; with
        ``reconstruct(..., keep_positions=True)`` the positions as they are (each decoded within
        half a grid step). ``h.save("x.mrq", source="points.ply")`` then gives the bytes of
        ``octowrap reconstruct points.ply -o x.mrq`` (the command line records the input file's
        name as ``source``; ``units`` is recorded too).

        ``bits`` (a grid of ``2**bits`` steps across the octree cube), ``step`` (world units) or
        ``exact`` store the positions on another grid: the vertices first slide along their
        tangent planes onto the decoder's lines (the hierarchy held here is not changed), as the
        command line does with ``--step``, unless ``keep_positions`` (``None``: as given to
        ``reconstruct``; ``False`` for a hierarchy read from a file).
        """
        self._raw.save(os.fspath(path), bits, step, exact, zstd_level, units, source, keep_positions)


class MrqFile:
    """An MRQ file opened by :func:`open_mrq`: only its preamble is read until a level is asked for.

    ``info`` holds what ``octowrap info --format json`` reports: ``version``, ``grid`` (the
    quantization: ``origin``, ``step``, ``bits``, ``tied_to_cube``; ``None`` for exact files),
    ``cube``, ``metadata``, and ``levels`` (per level ``offset``, ``stored_size`` in bytes,
    ``raw_size``, ``checksum``, ``vertex_count``, ``face_count``, ``corner_count``).
    """

    def __init__(self, raw: Any) -> None:
        self._raw = raw
        import json

        self.info: Dict[str, Any] = json.loads(raw.info_json())

    def __len__(self) -> int:
        return len(self._raw)

    def __repr__(self) -> str:
        return f"MrqFile({len(self)} levels)"

    def level(self, k: int) -> Level:
        """Level ``k``, decoding levels ``0..k`` only (the rest of the file is not read)."""
        if k < 0:
            k += len(self)
        return Level(self._raw.level(k))

    def hierarchy(self, k: Optional[int] = None) -> Hierarchy:
        """Levels ``0..k`` (all by default) as a :class:`Hierarchy`."""
        return Hierarchy(self._raw.hierarchy(k))


def _mesh_from_raw(raw: tuple) -> Mesh:
    positions, normals, colors, _intensities, offsets, indices, k = raw
    return Mesh(positions, _faces_from_csr(offsets, indices, k), normals, colors)


def read(path: Union[str, os.PathLike]) -> Union[PointCloud, Mesh]:
    """Reads a point cloud or mesh: PLY, OBJ, OFF, STL, XYZ/PTS, PCD, LAS/LAZ, E57, EXR, .conf.

    The format comes from the content, else the extension; ``.gz`` files are decompressed. A file
    without faces gives a :class:`PointCloud`, else a :class:`Mesh`.

    >>> import octowrap
    >>> octowrap.read("missing.ply")
    Traceback (most recent call last):
    ...
    FileNotFoundError: [Errno 2] missing.ply: i/o error: No such file or directory (os error 2): 'missing.ply'
    """
    raw, _format = _octowrap.read(os.fspath(path))
    positions, normals, colors, intensities, offsets, _indices, _k = raw
    if len(offsets) == 1:
        return PointCloud(positions, normals, colors, intensities)
    return _mesh_from_raw(raw)


def write(path: Union[str, os.PathLike], data: Union[PointCloud, Mesh], ascii: bool = False) -> None:
    """Writes a :class:`PointCloud` or :class:`Mesh` in the format the extension names.

    Writable: ``.ply`` (binary, or text with ``ascii=True``), ``.obj``, ``.off``, ``.stl`` (triangles:
    quads split along their shorter diagonal), ``.xyz`` (points only). The file is written
    beside the target and renamed into place, so a failure never leaves half a file.
    """
    if isinstance(data, Mesh):
        faces: Any = data.faces
        _octowrap.write(os.fspath(path), data.vertices, faces, data.normals, data.colors, None, ascii)
    elif isinstance(data, PointCloud):
        _octowrap.write(os.fspath(path), data.points, None, data.normals, data.colors, data.intensities, ascii)
    else:
        raise ValueError(f"write takes an octowrap.Mesh or octowrap.PointCloud, not {type(data).__name__}")


def reconstruct(
    points: np.ndarray,
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
) -> Hierarchy:
    """Reconstructs a surface from ``points`` (``float64 (N, 3)``): a quad mesh at every octree level.

    The options are ``octowrap reconstruct``'s: ``max_level`` (``"auto"``: the deepest level the
    sampling density supports, or a level number; deeper levels are subdivided), ``relax_passes``
    from ``relax_from_level`` on, ``fit_passes`` of the least-squares fit on levels of at most
    ``fit_max_faces`` faces, ``min_points`` (median points per cell for a trusted level),
    ``wrap_sparse``, ``region_levels`` and ``region_density``. ``threads`` sets the size of the
    worker pool (``None``: every core); the result is the same for any number. The GIL is released
    while it runs.

    The levels are built for the MRQ file :meth:`Hierarchy.save` writes, as the command line
    builds them for ``-o x.mrq``: each refined vertex within 0.3 voxel of the line the decoder
    predicts it on goes onto that line (one number in the file) and the fit's last passes move
    it along the line only, every vertex on the
    file's grid of ``2**bits`` steps across the octree cube (``bits``: ``None`` for 64 steps per
    finest voxel, or 1 to 28, the command line's ``--bits``). ``keep_positions=True``
    (``--keep-positions``) leaves the vertices free: slightly closer to the points, a larger file.

    >>> import numpy as np, octowrap
    >>> octowrap.reconstruct(np.zeros((0, 3)))
    Traceback (most recent call last):
    ...
    ValueError: the point cloud is empty
    """
    return Hierarchy(
        _octowrap.reconstruct(
            points,
            max_level,
            relax_passes,
            relax_from_level,
            fit_passes,
            fit_max_faces,
            min_points,
            wrap_sparse,
            region_levels,
            region_density,
            bits,
            keep_positions,
            threads,
        )
    )


def open_mrq(path: Union[str, os.PathLike]) -> MrqFile:
    """Opens an MRQ file, reading and checking its preamble only (see :class:`MrqFile`)."""
    return MrqFile(_octowrap.open_mrq(os.fspath(path)))


def validate(
    vertices: np.ndarray,
    faces: Faces,
    require: Sequence[str] = ("manifold",),
    weld: bool = False,
    self_intersections: bool = False,
    max_elements: int = 100,
) -> Dict[str, Any]:
    """Checks a mesh as ``octowrap validate`` does; returns its JSON report entry as a dict.

    ``require`` names properties that must hold: ``manifold``, ``oriented``, ``closed``,
    ``watertight``, ``clean``, ``intersection-free``. The dict has ``passed``,
    ``failed_requirements``, and ``outcome`` with ``properties``, ``counts`` and ``findings`` (each
    with its stable ``code``, such as ``E-NONMANIFOLD-EDGE``). Broken faces (indices out of range,
    fewer than 3 corners) are reported, not refused. ``weld`` merges bit-equal vertices first.

    >>> import numpy as np, octowrap
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, -1, 0]], dtype=float)
    >>> r = octowrap.validate(v, np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]]))
    >>> r["passed"], r["outcome"]["counts"]["non_manifold_edges"], r["outcome"]["findings"][0]["code"]
    (False, 1, 'E-NONMANIFOLD-EDGE')
    """
    if isinstance(require, str):
        require = [require]
    import json

    report = json.loads(
        _octowrap.validate(vertices, faces, list(require), weld, self_intersections, max_elements)
    )
    report["passed"] = not report["failed_requirements"]
    return report



def _source(data: Any, faces: Optional[Faces], function: str) -> Tuple[Optional[tuple], Any]:
    """``(mesh, hierarchy)`` for the compiled module, one of them ``None``: a :class:`Mesh`, or
    vertex and face arrays, as ``(vertices, faces, normals, colors)``; a :class:`Hierarchy` (or
    an :class:`MrqFile`, decoded whole) as the hierarchy it holds."""
    if isinstance(data, MrqFile):
        data = data.hierarchy()
    if isinstance(data, Hierarchy):
        if faces is not None:
            raise ValueError(f"{function}: a Hierarchy brings its own faces; pass faces only with a vertex array")
        return None, data._raw
    if isinstance(data, Mesh):
        if faces is not None:
            raise ValueError(f"{function}: faces come with the Mesh; pass faces only with a vertex array")
        return (data.vertices, data.faces, data.normals, data.colors), None
    if isinstance(data, PointCloud):
        raise ValueError(f"{function} needs a mesh (faces), not a PointCloud")
    if faces is None:
        raise ValueError(
            f"{function} takes a Mesh, a Level, a Hierarchy, an MrqFile, or vertices and faces arrays; "
            f"found {type(data).__name__} without faces"
        )
    return (data, faces, None, None), None


def _error_bound(max_error: Union[None, float, str]) -> Tuple[Optional[float], bool]:
    """``max_error`` as ``(value, relative)``: a length, or a string such as ``"0.1%"``."""
    if max_error is None:
        return None, False
    if isinstance(max_error, str):
        text = max_error.strip()
        relative = text.endswith("%")
        try:
            value = float(text[:-1] if relative else text)
        except ValueError:
            raise ValueError(f"max_error '{max_error}' is not a number (or a percentage like '0.1%')") from None
        return (value / 100.0, True) if relative else (value, False)
    if isinstance(max_error, bool):
        raise ValueError("max_error is a length or a percentage string, not a bool")
    return float(max_error), False


def distance(points: np.ndarray, mesh: Union[Mesh, np.ndarray], faces: Optional[Faces] = None) -> np.ndarray:
    """The unsigned distance from each of ``points`` (``float64 (N, 3)``) to the surface of ``mesh``.

    ``mesh`` is a :class:`Mesh` (a :class:`Level` too) or a vertex array with ``faces``; its faces
    are taken as triangles, quads split along their shorter diagonal as everywhere in octowrap.
    Returns ``float64 (N,)``, in the input's units, each the exact distance to the nearest point
    of the nearest triangle (a bounding-volume hierarchy finds it; no sampling), ``inf`` for
    every point when the mesh has no faces. ``np.sqrt(np.mean(d**2))`` is the points-to-mesh RMS
    error of the paper's Table 3. The GIL is released while it runs; the result is the same for
    any thread count.

    >>> import numpy as np, octowrap
    >>> square = octowrap.Mesh(np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float), np.array([[0, 1, 2, 3]]))
    >>> octowrap.distance(np.array([[0.5, 0.5, 2.0], [4.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), square)
    array([2., 3., 0.])
    >>> square.distance(np.zeros((1, 2)))
    Traceback (most recent call last):
    ...
    ValueError: points must be an array of float64 with shape (N, 3), found shape (1, 2) of float64
    """
    m, raw_h = _source(mesh, faces, "distance")
    if m is None:
        raise ValueError("distance measures to one mesh: pass a Level (h[k]), not a whole Hierarchy")
    return _octowrap.distance(points, m)


def decimate(
    data: MeshSource,
    faces: Optional[Faces] = None,
    *,
    target_faces: Optional[int] = None,
    ratio: Optional[float] = None,
    max_error: Union[None, float, str] = None,
    view: Union[None, Dict[str, Any], str, os.PathLike] = None,
    lock_border: bool = False,
    quads: str = "auto",
    measure: bool = False,
    cut: str = "auto",
) -> Tuple[Mesh, Dict[str, Any]]:
    """Decimates a mesh, or cuts a hierarchy adaptively, as ``octowrap decimate`` does.

    ``data`` is a :class:`Mesh` (a :class:`Level` too), a vertex array with ``faces``, or a
    :class:`Hierarchy` or :class:`MrqFile`. Returns the new :class:`Mesh` and the report
    ``octowrap decimate --json`` prints (without the file names): ``mode`` (``"decimate"`` or
    ``"cut"``), ``input_faces``, ``output_faces``, ``output_vertices``, ``seconds``, and
    ``decimate`` or ``cut`` with the details (``measured`` too with ``measure=True``). The mesh
    is the one the command writes: ``octowrap.write`` gives the same file bytes.

    Targets (at least one; with several, decimation stops at whichever comes first):
    ``target_faces`` (faces as written: a quad is one face, and so is each triangle), ``ratio``
    (a fraction of the input's faces, in ``(0, 1]``), ``max_error`` (the certified Hausdorff
    distance to the input: a length in the input's units, or a percentage of the bounding-box
    diagonal such as ``"0.1%"``). Edge collapse by quadric error never makes the mesh less
    manifold; ``lock_border`` keeps boundary vertices fixed; ``quads`` is ``"auto"`` (re-pair
    triangles into quads when half or more of the input faces are quads), ``"quads"`` or
    ``"triangles"``. ``measure`` adds the certified and sampled distances (about three times the
    decimation's time).

    A hierarchy with ``max_error`` alone, or with ``view`` (a camera: a dict with ``position``,
    ``target``, ``up``, ``fov_y_degrees``, ``viewport_height_px``, ``pixel_error``, or the path of
    such a JSON file), is cut through its levels instead: each region takes the coarsest level
    within the bound, stitched crack-free; with ``target_faces`` or ``ratio`` its finest level is
    decimated. ``cut`` chooses how, as ``octowrap decimate --cut`` does: ``"faces"`` cuts face by
    face through the decoded hierarchy; ``"chunks"`` (an :class:`MrqFile` of format version 5)
    takes whole chunks chosen by their geometric errors, reads only those and their ancestors,
    and reports ``mode`` ``"chunk cut"`` with ``chunk_cut`` (chunks drawn and refined, bytes
    read); ``"auto"``, the default, is ``"chunks"`` for a chunked :class:`MrqFile` and
    ``"faces"`` otherwise. The GIL is released while it runs.

    >>> import numpy as np, octowrap
    >>> rng = np.random.default_rng(2)
    >>> p = rng.normal(size=(20000, 3)); p /= np.linalg.norm(p, axis=1, keepdims=True)
    >>> finest = octowrap.reconstruct(p, max_level=5)[5]
    >>> small, report = octowrap.decimate(finest, ratio=0.1)
    >>> report["mode"], report["output_faces"] <= round(0.1 * len(finest.parent))
    ('decimate', True)
    >>> octowrap.validate(small.vertices, small.faces, require=["watertight", "oriented"])["passed"]
    True
    >>> octowrap.decimate(finest.vertices, finest.faces, ratio=2.0)
    Traceback (most recent call last):
    ...
    ValueError: ratio must be in (0, 1], not 2.0
    """
    if cut not in ("auto", "chunks", "faces"):
        raise ValueError(f'cut must be "auto", "chunks" or "faces", not {cut!r}')
    value, relative = _error_bound(max_error)
    import json

    camera = None
    if view is not None:
        if isinstance(view, dict):
            camera = json.dumps(view)
        else:
            with open(os.fspath(view), encoding="utf-8") as f:
                camera = f.read()
    is_cut = target_faces is None and ratio is None and (max_error is not None or view is not None)
    chunked = isinstance(data, MrqFile) and data.info["version"] >= 5
    if cut == "chunks" and not (isinstance(data, MrqFile) and is_cut):
        raise ValueError('cut="chunks" cuts an MrqFile with max_error alone or view')
    if is_cut and (cut == "chunks" or (cut == "auto" and chunked)) and not lock_border and quads == "auto":
        raw, report = _octowrap.cut_chunks(data._raw, value, relative, camera, measure)
        return _mesh_from_raw(raw), json.loads(report)
    mesh, raw_h = _source(data, faces, "decimate")
    raw, report = _octowrap.decimate(
        mesh, raw_h, target_faces, ratio, value, relative, camera, lock_border, quads, measure
    )
    return _mesh_from_raw(raw), json.loads(report)


def export_glb(
    data: MeshSource,
    faces: Optional[Faces] = None,
    *,
    path: Union[None, str, os.PathLike] = None,
    levels: Union[str, int] = "finest",
    quantize: bool = False,
    meshopt: bool = False,
    crease_angle: Optional[float] = None,
    colors: bool = True,
    screen_error: float = 1.0,
    metadata: Union[None, Dict[str, str], Sequence[Tuple[str, str]]] = None,
) -> Tuple[bytes, Dict[str, Any]]:
    """Exports a mesh or hierarchy as binary glTF 2.0 (GLB), as ``octowrap export -o x.glb`` does.

    ``data`` is a :class:`Mesh` (a :class:`Level` too), a vertex array with ``faces``, a
    :class:`Hierarchy` or an :class:`MrqFile`. Returns the GLB bytes and a summary: ``levels``
    (per exported level, finest first: ``level``, ``source_faces``, ``vertices``, ``triangles``,
    ``u32_indices``, ``geometric_error``), ``screen_coverage``, ``extensions_used``,
    ``extensions_required`` and ``bytes``. With ``path`` (a ``.glb``), the bytes are also written
    there, to a temporary file renamed into place.

    ``levels``: ``"finest"`` (the default), ``"all"`` (every level as an ``MSFT_lod`` chain with
    screen-coverage hints that allow ``screen_error`` pixels of a 1080-pixel-high view), or a
    level number (0 = coarsest; an :class:`MrqFile` then decodes levels up to it only). Quads are
    split along their shorter diagonal; normals are smooth unless ``crease_angle`` (degrees)
    splits them; vertex colours are kept unless ``colors=False``. ``quantize`` stores 16-bit
    positions and 8-bit normals (``KHR_mesh_quantization``), ``meshopt`` compresses the buffers
    (``EXT_meshopt_compression``). ``metadata`` (pairs, in order) goes in
    ``asset.extras.octowrap``; from an :class:`MrqFile` the file's own metadata comes first, as
    the command line records it (the command records a mesh file's name as ``source``:
    ``metadata={"source": "part.ply"}`` gives its bytes). The same input and options give the
    same bytes; the GIL is released while it runs.

    >>> import numpy as np, octowrap
    >>> quad = octowrap.Mesh(np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float), np.array([[0, 1, 2, 3]]))
    >>> glb, summary = octowrap.export_glb(quad, quantize=True)
    >>> glb[:4], summary["levels"][0]["triangles"], summary["extensions_required"], summary["bytes"] == len(glb)
    (b'glTF', 2, ['KHR_mesh_quantization'], True)
    >>> octowrap.export_glb(quad, levels="some")
    Traceback (most recent call last):
    ...
    ValueError: levels must be "finest", "all" or a level number (0 = coarsest), not 'some'
    """
    import json

    pairs: List[Tuple[str, str]] = []
    if isinstance(data, MrqFile):
        pairs = list(data._raw.export_metadata())
        if isinstance(levels, int) and not isinstance(levels, bool) and 0 <= levels < len(data):
            data, levels = data.hierarchy(levels), "finest"  # levels past it are not read
    mesh, raw_h = _source(data, faces, "export_glb")
    if metadata is not None:
        items = metadata.items() if isinstance(metadata, dict) else metadata
        pairs += [(str(k), str(v)) for k, v in items]
    glb, summary = _octowrap.export_glb(
        mesh,
        raw_h,
        levels,
        quantize,
        meshopt,
        crease_angle,
        colors,
        screen_error,
        pairs,
        None if path is None else os.fspath(path),
    )
    return glb, json.loads(summary)


def export_tiles(
    data: Union[MeshSource, str, os.PathLike],
    directory: Union[str, os.PathLike],
    *,
    faces: Optional[Faces] = None,
    quantize: bool = False,
    meshopt: bool = False,
    colors: bool = True,
    metadata: Union[None, Dict[str, str], Sequence[Tuple[str, str]]] = None,
) -> Dict[str, Any]:
    """Exports a hierarchy as an OGC 3D Tiles 1.1 tileset, as ``octowrap export X -o DIR/tileset.json``.

    ``data`` is a :class:`Hierarchy`, an :class:`MrqFile`, the path of an ``.mrq`` file, a
    :class:`Mesh` (or the path of a mesh file, or a vertex array with ``faces``), which becomes
    one tile. ``directory`` receives ``tileset.json`` and one binary glTF per tile under
    ``tiles/`` (the folder is created when missing; a ``directory`` ending in ``.json`` names the
    tileset file itself). A tile is one level's faces in one octree cell; every tile refines by
    ``REPLACE`` and carries its measured ``geometricError`` (the certified Hausdorff distance to
    the finest level) and a flange that hides cracks between neighbours drawn at different levels.
    From an MRQ file, its units, source and generator go in the tileset's ``extras`` and its CRS,
    when it records one, georeferences the tileset (EPSG:4978); otherwise the tileset is in the
    input's own frame. ``quantize`` and ``meshopt`` apply to every tile, ``colors=False`` drops
    vertex colours; ``metadata`` pairs follow in ``extras``.

    Returns the summary: ``tiles``, ``content_tiles``, ``levels``, ``bytes`` (every file written),
    ``root_error``, ``frame``. The same input and options give the bytes of the command line; the
    GIL is released while it runs.

    >>> import numpy as np, octowrap, tempfile, os
    >>> quad = octowrap.Mesh(np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float), np.array([[0, 1, 2, 3]]))
    >>> out = tempfile.mkdtemp()
    >>> s = octowrap.export_tiles(quad, out)
    >>> s["tiles"], s["levels"], sorted(os.listdir(out))
    (1, 1, ['tiles', 'tileset.json'])
    """
    if isinstance(data, (str, os.PathLike)):
        name = os.fspath(data)
        data = open_mrq(name) if name.lower().endswith(".mrq") else read(name)
    mrq = None
    mesh, raw_h = None, None
    if isinstance(data, MrqFile):
        mrq = data._raw
        if faces is not None:
            raise ValueError("export_tiles: an MrqFile brings its own faces; pass faces only with a vertex array")
    else:
        mesh, raw_h = _source(data, faces, "export_tiles")
    pairs: List[Tuple[str, str]] = []
    if metadata is not None:
        items = metadata.items() if isinstance(metadata, dict) else metadata
        pairs = [(str(k), str(v)) for k, v in items]
    target = os.fspath(directory)
    if not target.lower().endswith(".json"):
        target = os.path.join(target, "tileset.json")
    import json

    return json.loads(_octowrap.export_tiles(target, mesh, raw_h, mrq, quantize, meshopt, colors, pairs))
