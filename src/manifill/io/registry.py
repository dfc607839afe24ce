"""Meshes and their fields on disk: read and write any mesh format through the one registry of formats.

The formats themselves, their readers and writers and what each keeps (named per-vertex fields, which common
readers see them, whether reading keeps the file's vertex numbering: STL's reader merges its corners), are
:mod:`manifill.io.formats`' registry, the mesh formats registered by :mod:`manifill.io.mesh_formats`.
:func:`read_mesh_file` and :func:`write_mesh` look a path up there; FreeSurfer surfaces (``lh.pial``,
``rh.white``: no telling extension) are recognised by their first bytes. (The module keeps its name, ``registry``,
from when it held the mesh table; :data:`MESH_FORMATS` is a view of the registry.)

Field names and manifill's mask names are :mod:`manifill.io.field_names`'. Every
write is atomic (:func:`manifill.io.files.atomic_path`); every read of a damaged
file ends in one :class:`~manifill.errors.ReadError` naming the file. Samples and
per-vertex values are read and written by :mod:`manifill.io.samples`.
"""

import contextlib
import contextvars
import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ManifillError, ReadError, WriteError
from ..mesh.objects import mesh_arrays
from ..validate import as_mesh, as_vertices, is_mesh_object
from .field_names import stored_names
from .files import PointsOnly, check_input_file, check_not_foreign
from .formats import Format, find_format, suffix_list
from .mesh_formats import CELL_WRITERS, FREESURFER, MESH_FORMATS, POINT_FORMATS  # noqa: F401 (shown here too)
from .neuro import sniff

__all__ = ["MESH_FORMATS", "POINT_FORMATS", "MeshFile", "FREESURFER", "mesh_format", "read_mesh",
           "read_mesh_file", "reading_once", "check_cells", "write_mesh", "write_cells", "format_note"]



_READERS_SHOWN = {"meshio": "meshio", "pyvista": "pyvista/VTK/ParaView", "nibabel": "nibabel"}


@dataclass
class MeshFile:
    """A surface read from a file.

    Attributes
    ----------
    V : (n, 3) float64 numpy array
    F : (m, 3) int64 numpy array, or None
        None for a point cloud (read with ``points=True``).
    point_data : dict of str to (n,) or (n, p) numpy array
        The per-vertex arrays stored with it.
    format : manifill.io.formats.Format
    path : Path
    """

    V: np.ndarray
    F: np.ndarray
    point_data: dict = field(default_factory=dict)
    format: Format | None = None
    path: Path | None = None

    def __iter__(self):
        """``V, F = mesh_file``: the arrays, as :func:`read_mesh` gave them before it gave a :class:`MeshFile`."""
        return iter((self.V, self.F))

    @property
    def vertex_numbering(self):
        """None if vertex numbers in sample files refer to this mesh's vertices, else why they cannot."""
        if self.format is None or self.format.vertex_numbering:
            return None
        return (f"{self.path.name}: {self.format.name} does not keep vertex numbers (its reader merges the corners "
                f"of the triangles), so samples given by vertex index would land on other vertices")


def mesh_format(path, *, writing=False):
    """The mesh :class:`~manifill.io.formats.Format` of ``path`` (by extension, else FreeSurfer by magic number).

    Raises
    ------
    ReadError or WriteError
        An extension manifill does not read (or write).
    """
    ext = Path(path).suffix.lower()
    fmt = find_format("mesh", path, writing=writing)
    if writing:
        if fmt is None:
            raise WriteError(f"{Path(path).name}: cannot write '{ext or '(no extension)'}' meshes; use one of "
                             f"{suffix_list('mesh', writing=True)}")
        return fmt
    if fmt is None:
        if Path(path).is_file() and sniff(path) == "freesurfer-surface":
            return FREESURFER
        raise ReadError(f"{Path(path).name}: cannot read '{ext or '(no extension)'}' files; use one of "
                        f"{suffix_list('mesh')} or a FreeSurfer surface")
    return fmt


#: The meshes read inside :func:`reading_once` blocks, by (path, modification time, size); None outside.
_READ = contextvars.ContextVar("manifill_meshes_read", default=None)


@contextlib.contextmanager
def reading_once():
    """Within the block, an unchanged mesh file read again is not parsed again (each read gets its own copy).

    A batch job reads its mesh for its memory estimate and then for its command line; parsing
    a 160k-vertex mesh costs a tenth of a second of a one-second job.

    Examples
    --------
    >>> import os, tempfile
    >>> from manifill.mesh.shapes import icosphere
    >>> path = os.path.join(tempfile.mkdtemp(), "s.ply")
    >>> _ = write_mesh(path, *icosphere(1))
    >>> with reading_once():
    ...     a, b = read_mesh_file(path), read_mesh_file(path)
    >>> bool((a.V == b.V).all()), a.V is b.V
    (True, False)
    """
    token = _READ.set({})
    try:
        yield
    finally:
        _READ.reset(token)


def read_mesh_file(path: str | os.PathLike[str], *, points: bool = False) -> MeshFile:
    """Read a triangle surface and the per-vertex fields stored with it (parsed once per :func:`reading_once`).

    Formats: VTU, VTP, legacy VTK (POLYDATA or UNSTRUCTURED_GRID), PLY, OFF, OBJ,
    STL, GIfTI ``.surf.gii`` and FreeSurfer surfaces (the last two need the
    ``[neuro]`` extra). Quads and polygons are split into triangles; other cells
    are ignored.

    Parameters
    ----------
    path : str or Path
    points : bool, optional
        Also take a point cloud: a file with points and no faces (PLY, VTP, VTU, legacy VTK, OBJ),
        ``.xyz`` or ``.csv`` points (:mod:`manifill.io.points`) gives ``F`` None.

    Returns
    -------
    MeshFile

    Raises
    ------
    ReadError
        A missing file, an unknown extension, a damaged file (one line naming
        the file), or a file without triangles (unless ``points``).
    """
    path = Path(path)
    fmt = mesh_format(path)
    check_input_file(path)
    check_not_foreign(path, f"a {fmt.name} mesh" if fmt.cells else f"a file of {fmt.name}", "mesh")
    read = _READ.get()
    if read is None:
        return _read_or_points(path, fmt, points)
    st = path.stat()
    key = (str(path.resolve()), st.st_mtime_ns, st.st_size, points)
    if key not in read:
        read.clear()  # one mesh kept: a job's
        read[key] = _read_or_points(path, fmt, points)
    m = read[key]
    return replace(m, V=m.V.copy(), F=None if m.F is None else m.F.copy(),
                   point_data={k: a.copy() for k, a in m.point_data.items()}, path=path)


def _read_or_points(path, fmt, points):
    try:
        V, F, point_data = fmt.read(path, fmt)
    except PointsOnly as exc:
        if not points or exc.V is None or not len(exc.V):
            raise
        V, F, point_data = exc.V, None, exc.point_data
    if F is None and not points:
        raise ReadError(f"{path.name}: holds points, not a mesh; pass a surface mesh (or reconstruct on the points "
                        f"as a point cloud: 'manifill reconstruct {path.name} SAMPLES -o OUT')")
    V = np.asarray(V, dtype=np.float64)
    if V.ndim == 2 and V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    if F is None:
        check_cells(path, V, np.zeros((0, 1), np.int64), "point")
    else:
        F = np.asarray(F, dtype=np.int64)
        check_cells(path, V, F, "face")
    point_data = {str(k): np.asarray(a) for k, a in point_data.items() if np.shape(a)[:1] == (len(V),)}
    return MeshFile(V, F, point_data, fmt, path)


def check_cells(path, V, C, what):
    """Refuse points that are not ``(n, 3)`` or cells with a vertex index outside ``0..n-1`` (a damaged file).

    Parameters
    ----------
    path : Path
        The file read (for the message).
    V : (n, 3) float64 numpy array
    C : (m, k) int64 numpy array
    what : str
        What a cell is (``'face'``, ``'tetrahedron'``).

    Raises
    ------
    ReadError
        Points of another shape, or a cell using a vertex the file does not have.
    """
    if V.ndim != 2 or V.shape[1] != 3:
        raise ReadError(f"{path.name}: the points have shape {V.shape}, not (n, 3); the file is damaged, check it")
    bad = np.flatnonzero(((C < 0) | (C >= len(V))).any(axis=1)) if C.ndim == 2 else []
    if len(bad):
        i = int(bad[0])
        v = int(C[i][(C[i] < 0) | (C[i] >= len(V))][0])
        raise ReadError(f"{path.name}: {what} {i} uses vertex {v} but the file has {len(V):,} vertices "
                        f"(0..{len(V) - 1}); the file is damaged, check it")


def read_mesh(path: str | os.PathLike[str]) -> MeshFile:
    """Read a triangle mesh (see :func:`read_mesh_file` for the formats): a :class:`MeshFile`, which unpacks as
    ``V, F`` (``V, F = read_mesh(path)``).

    Parameters
    ----------
    path : str or Path
        The file; its extension selects the format.

    Returns
    -------
    MeshFile
        ``V`` (n, 3) float64, ``F`` (m, 3) int64, the fields stored with them (``point_data``), the format.

    Raises
    ------
    ReadError
        A missing file, an unknown extension, a damaged file, or a file
        without triangles or quads.
    """
    return read_mesh_file(path)


def format_note(path):
    """One line telling which common readers will not see the fields of ``path`` (None if all do).

    Examples
    --------
    >>> print(format_note("out.ply"))
    note: out.ply: pyvista/VTK/ParaView do not show PLY files' named fields (meshio does); write .vtu for every reader
    """
    fmt = find_format("mesh", path, writing=True)
    if fmt is None or not fmt.fields:
        return None
    missing = [r for r in ("meshio", "pyvista") if r not in fmt.seen_by]
    if not missing:
        return None
    shown = " and ".join(_READERS_SHOWN[r] for r in missing)
    seen = ", ".join(_READERS_SHOWN[r] for r in fmt.seen_by)
    verb = "does" if len(fmt.seen_by) == 1 else "do"
    verb_missing = "does" if missing == ["meshio"] else "do"  # "meshio does", "pyvista/VTK/ParaView do"
    return (f"note: {Path(path).name}: {shown} {verb_missing} not show {fmt.name} files' named fields ({seen} "
            f"{verb}); write .vtu for every reader")


def _field_array(name, arr, n):
    arr = np.asarray(arr)
    if np.iscomplexobj(arr) or not (arr.dtype == bool or np.issubdtype(arr.dtype, np.number)):
        raise WriteError(f"field {name!r} is {arr.dtype}; pass real numbers")
    if arr.ndim not in (1, 2):
        raise WriteError(f"field {name!r} has shape {arr.shape}; pass (n,) or (n, p) per-vertex values")
    if arr.shape[0] != n:
        raise WriteError(f"field {name!r} has {arr.shape[0]} values for {n} vertices; pass one per vertex")
    if arr.dtype in (bool, np.uint8):  # masks: 0/1 bytes
        return arr.astype(np.uint8)
    if np.issubdtype(arr.dtype, np.integer):
        i32 = np.iinfo(np.int32)
        if arr.size and (int(arr.min()) < i32.min or int(arr.max()) > i32.max):
            raise WriteError(f"field {name!r} holds integers beyond 32 bits; store it as floats")
        return arr.astype(np.int32)
    return arr.astype(np.float64)


def write_mesh(path: str | os.PathLike[str], V: ArrayLike, F: ArrayLike, point_data: dict | None = None, *,
               cell_data: dict | None = None) -> dict[str, str]:
    """Write a triangle mesh with named per-vertex fields, atomically.

    Parameters
    ----------
    path : str or Path
        Destination; the extension selects the format. Fields need VTU, VTP,
        legacy VTK or PLY (see :data:`MESH_FORMATS` for who reads them back).
    V : (n, 3) numpy array, or a mesh object with ``F=None``
        Vertex positions.
    F : (m, 3) numpy array of int, or None
        Triangles; None with an array ``V`` writes a point cloud (``.vtp``, ``.vtu``, ``.vtk``: one vertex
        cell per point; ``.ply``: the vertices alone).
    point_data : dict of str to (n,) or (n, p) numpy array, optional
        Named fields. A ``(n, p)`` field is one ``p``-component array in VTU,
        VTP and VTK, and ``p`` scalar fields ``name_0 ... name_{p-1}`` in PLY.
        Boolean fields (masks) are stored as 0/1 bytes, integer fields (labels)
        as 32-bit integers, the rest as float64.
    cell_data : dict of str to (m,) or (m, p) numpy array, optional
        Named fields per triangle (e.g. a vector field's face vectors), in the formats with
        ``cell_fields`` (VTU, VTP, legacy VTK).

    Returns
    -------
    dict of str to str
        The name each field was written under (see :func:`manifill.io.field_names.stored_names`).

    Raises
    ------
    WriteError
        Unknown extension, fields for a format that cannot hold them, names no
        format can store, a missing folder, or a failure while writing
        (nothing is left behind).
    """
    fmt = mesh_format(path, writing=True)
    point_data = dict(point_data or {})
    if point_data and not fmt.fields:
        raise WriteError(
            f"{Path(path).name}: {fmt.name} cannot store per-vertex fields; write .vtu, .vtp, .vtk or .ply "
            f"(or the values alone as .csv/.npy)"
        )
    try:
        if F is None and not is_mesh_object(V):  # a point cloud
            V = as_vertices(V)
            if find_format("points", path, writing=True) is None:
                raise WriteError(f"{Path(path).name}: a point cloud is written as "
                                 f"{suffix_list('points', writing=True)} "
                                 f"(or its values as .csv); change the name")
            return write_cells(path, V, np.arange(len(V), dtype=np.int64)[:, None], point_data)
        V, F = as_mesh(*mesh_arrays(V, F), allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    except WriteError:
        raise
    except ManifillError as exc:
        raise WriteError(f"{Path(path).name}: not written, the mesh is malformed: {exc}") from None
    return write_cells(path, V, F, point_data, cell_data)


def write_cells(path, V, C, point_data=None, cell_data=None):
    """Write validated triangles or tetrahedra with named per-vertex fields, atomically, by extension.

    Parameters
    ----------
    path : str or Path
        ``.vtu``, ``.vtp`` (triangles), ``.vtk``, ``.ply``, ``.off``, ``.obj``,
        ``.stl`` (triangles, no fields there) or ``.msh`` (Gmsh).
    V : (n, 3) float64 numpy array
    C : (m, 3) or (m, 4) int64 numpy array
    point_data : dict of str to (n,) or (n, p) numpy array, optional
    cell_data : dict of str to (m,) or (m, p) numpy array, optional
        Fields per cell, for a format with ``cell_fields`` (VTU, VTP, legacy VTK).

    Returns
    -------
    dict of str to str
        The name each field was written under.

    Raises
    ------
    WriteError
        As :func:`write_mesh`.
    """
    kind = {1: "vertex", 3: "triangle"}.get(C.shape[1], "tetra")
    fmt = find_format({1: "points", 3: "mesh"}.get(C.shape[1], "tets"), path, writing=True)
    if fmt is None:
        raise WriteError(f"{Path(path).name}: cannot write {kind} cells as '{Path(path).suffix or '(no extension)'}'; "
                         f"use one of {suffix_list({1: 'points', 3: 'mesh'}.get(C.shape[1], 'tets'), writing=True)}")
    names = stored_names(point_data or {}, fmt)
    out = {}
    for name, arr in (point_data or {}).items():
        arr = _field_array(name, arr, len(V))
        key = names[str(name)]
        if arr.ndim == 2 and fmt.columns:
            for j in range(arr.shape[1]):
                out[f"{key}_{j}"] = np.ascontiguousarray(arr[:, j])
        else:
            out[key] = arr
    if cell_data:
        if not fmt.cell_fields:
            raise WriteError(f"{Path(path).name}: {fmt.name} cannot store per-cell fields; write .vtu, .vtp or .vtk")
        cells = stored_names(cell_data, fmt)
        fmt.write(path, V, kind, C, out, fmt, cell_data={cells[str(k)]: _field_array(k, a, len(C))
                                                         for k, a in cell_data.items()})
    else:
        fmt.write(path, V, kind, C, out, fmt)
    return names
