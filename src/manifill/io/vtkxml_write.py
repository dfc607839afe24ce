"""Writing VTK XML files: PolyData (``.vtp``), UnstructuredGrid (``.vtu``) and ImageData (``.vti``).

The writers store zlib-compressed inline binary arrays with a UInt64 header, which
VTK, ParaView, pyvista (and, for ``.vtu``, meshio) open, and write atomically
(:func:`manifill.io.files.atomic_path`). Field names are any non-empty text
without control characters, escaped for XML.
"""

import base64
import unicodedata
import zlib
from pathlib import Path

import numpy as np

from ..errors import ManifillError, WriteError
from ..validate import as_mesh, as_vertices
from .files import atomic_path
from .vtkxml_decode import VTK_TYPES

__all__ = ["write_polydata", "write_unstructured", "write_imagedata", "grid_arrays"]

_VTK_NAMES = {np.dtype(v).newbyteorder("="): k for k, v in VTK_TYPES.items()}
_BLOCK = 1 << 20  # uncompressed bytes per zlib block in written files
_LEVEL = 5  # VTK's default zlib level


def _xml(name):
    return (name.replace("&", "&amp;").replace('"', "&quot;").replace("'", "&apos;")
            .replace("<", "&lt;").replace(">", "&gt;"))


def _check_name(name):
    """The field name as text; WriteError if XML cannot keep it."""
    text = str(name)
    if not text:
        raise WriteError("a field has an empty name; name every field")
    bad = [c for c in text if unicodedata.category(c) in ("Cc", "Cs") or c in "\ufffe\uffff"]
    if bad:
        raise WriteError(f"field name {text!r} contains the control character {bad[0]!r}; use printable text")
    return text


def _vtk_array(arr):
    """``arr`` in the type it is written as: bool and uint8 (masks) -> UInt8, integers -> Int32 (or 64), floats ->
    Float64."""
    if arr.dtype in (bool, np.uint8):
        return arr.astype(np.uint8)
    if np.issubdtype(arr.dtype, np.integer):
        if arr.size == 0:
            return arr.astype(np.int32)
        lo, hi = int(arr.min()), int(arr.max())
        for t in (np.int32, np.int64, np.uint64):
            if np.iinfo(t).min <= lo and hi <= np.iinfo(t).max:
                return arr.astype(t)  # the smallest that holds them, rather than wrap around
    if arr.dtype.kind not in "fiuO":
        return None
    try:
        return arr.astype(np.float64)
    except (TypeError, ValueError):
        return None


def grid_arrays(fields):
    """Validate voxel fields: (grid shape, dict name -> array in its written dtype)."""
    if not fields:
        raise WriteError("no fields to write; pass at least one")
    shape = None
    arrays = {}
    for name, arr in fields.items():
        arr = np.asarray(arr)
        if arr.ndim not in (3, 4) or (shape is not None and arr.shape[:3] != shape) or 0 in arr.shape:
            raise WriteError(f"field {name!r} has shape {arr.shape}; pass (n0, n1, n2) arrays on one grid")
        shape = arr.shape[:3]
        arrays[str(name)] = _vtk_array(arr)
        if arrays[str(name)] is None:
            raise WriteError(f"field {name!r} holds {arr.dtype} values; pass numbers or booleans")
    return shape, arrays


def _header(kind):
    return ('<?xml version="1.0"?>\n'
            f'<VTKFile type="{kind}" version="1.0" byte_order="LittleEndian" header_type="UInt64" '
            f'compressor="vtkZLibDataCompressor">\n')


def _write_array(fh, name, values, p, indent, cache=None):
    """One zlib-compressed inline binary DataArray of flat ``values`` (p components).

    ``cache`` (a dict kept by the caller): the encoded array is kept there under ``name`` and
    written again as it is next time; only for arrays the caller knows unchanged (a series'
    mesh and masks, step after step).
    """
    if cache is not None and name in cache:
        fh.write(cache[name])
        return
    raw = np.ascontiguousarray(values, dtype=values.dtype.newbyteorder("<")).tobytes()
    blocks = [zlib.compress(raw[i:i + _BLOCK], _LEVEL) for i in range(0, len(raw), _BLOCK)]
    header = np.array([len(blocks), _BLOCK, len(raw) % _BLOCK] + [len(b) for b in blocks], dtype="<u8")
    # the header is encoded on its own, then the blocks in one stream, as VTK does
    blob = base64.b64encode(header.tobytes()) + base64.b64encode(b"".join(blocks))
    kind = _VTK_NAMES[values.dtype.newbyteorder("=")]
    comps = f' NumberOfComponents="{p}"' if p != 1 else ""  # VTK's default; meshio then keeps (n,) arrays
    text = (f'{indent}<DataArray type="{kind}" Name="{_xml(name)}"{comps} format="binary">\n'
            f'{indent}  {blob.decode("ascii")}\n{indent}</DataArray>\n')
    if cache is not None:
        cache[name] = text
    fh.write(text)


def _point_arrays(point_data, n, what="vertices"):
    """Named point (or cell) fields as VTK-typed (n, p) arrays, each name checked."""
    arrays = {}
    for name, arr in (point_data or {}).items():
        key = _check_name(name)
        arr = np.asarray(arr)
        if arr.ndim not in (1, 2) or arr.shape[0] != n or (arr.ndim == 2 and arr.shape[1] < 1):
            raise WriteError(f"field {name!r} has shape {arr.shape}; pass (n,) or (n, p) values for {n} {what}")
        out = _vtk_array(arr)
        if out is None:
            raise WriteError(f"field {name!r} holds {arr.dtype} values; pass numbers or booleans")
        if key in arrays:
            raise WriteError(f"two fields are named {key!r}; give every field its own name")
        arrays[key] = out.reshape(n, -1)
    return arrays


def _active(arrays):
    """The attribute that makes the first 3-component float array the active vectors (ParaView's and pyvista's
    glyphs point along it), or nothing."""
    name = next((key for key, a in arrays.items() if a.shape[1] == 3 and a.dtype.kind == "f"), None)
    return "" if name is None else f' Vectors="{_xml(name)}"'


def _write_cells(path, kind, V, C, arrays, cache=None, constant=(), cell_arrays=None):
    """PolyData of triangles, or an UnstructuredGrid of triangles or tetrahedra, with point arrays (and cell arrays).

    With ``cache``: the mesh's arrays and the point arrays named in ``constant`` are encoded once
    and reused from it (:func:`_write_array`)."""
    n, m, width = len(V), len(C), C.shape[1]
    mesh = None if cache is None else cache.setdefault("mesh", {})  # apart: a field may be named "Points"
    fields = None if cache is None else cache.setdefault("fields", {})
    ind = " " * 8
    with atomic_path(path) as tmp:
        try:
            with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
                fh.write(_header(kind))
                verts = m if width == 1 else 0  # a point cloud: one vertex cell per point
                if kind == "PolyData":
                    fh.write(f'  <PolyData>\n    <Piece NumberOfPoints="{n}" NumberOfVerts="{verts}" NumberOfLines="0" '
                             f'NumberOfStrips="0" NumberOfPolys="{m - verts}">\n      <PointData{_active(arrays)}>\n')
                else:
                    fh.write(f'  <UnstructuredGrid>\n    <Piece NumberOfPoints="{n}" NumberOfCells="{m}">\n'
                             f'      <PointData{_active(arrays)}>\n')
                for key, arr in arrays.items():
                    _write_array(fh, key, arr, arr.shape[1], ind, fields if key in constant else None)
                fh.write("      </PointData>\n")
                if cell_arrays:  # per cell: a vector field's face vectors
                    fh.write(f"      <CellData{_active(cell_arrays)}>\n")
                    for key, arr in cell_arrays.items():
                        _write_array(fh, key, arr, arr.shape[1], ind)
                    fh.write("      </CellData>\n")
                fh.write("      <Points>\n")
                _write_array(fh, "Points", V, 3, ind, mesh)
                tag = ("Verts" if verts else "Polys") if kind == "PolyData" else "Cells"
                fh.write(f"      </Points>\n      <{tag}>\n")
                _write_array(fh, "connectivity", C.astype(np.int64), 1, ind, mesh)
                _write_array(fh, "offsets", width * np.arange(1, m + 1, dtype=np.int64), 1, ind, mesh)
                if kind == "PolyData":
                    fh.write(f"      </{tag}>\n    </Piece>\n  </PolyData>\n</VTKFile>\n")
                else:
                    _write_array(fh, "types", np.full(m, {1: 1, 3: 5, 4: 10}[width], dtype=np.uint8), 1, ind, mesh)
                    fh.write("      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n")
        except OSError as exc:
            raise WriteError(f"{Path(path).name}: could not write ({exc}); check the path") from None


def write_polydata(path, V, F, point_data=None, cell_data=None):
    """Write a triangle mesh with named point fields as VTK PolyData (``.vtp``), atomically.

    The arrays are inline binary, zlib-compressed, with a UInt64 header: points as
    Float64, the triangles as Int64 ``connectivity``/``offsets``, booleans as UInt8,
    integers as Int32 (Int64, or UInt64, when they do not fit) and floats as Float64.
    VTK, ParaView, pyvista and :func:`manifill.io.vtkxml_read.read_polydata` read it.

    Parameters
    ----------
    path : str or Path
        Destination (conventionally ``.vtp``).
    V : (n, 3) or (n, 2) array_like of float
    F : (m, 3) array_like of int, or None
        Triangles; None writes a point cloud (one vertex cell per point).
    point_data : dict of str to (n,) or (n, p) numpy array, optional
        Named fields; a ``(n, p)`` field is one ``p``-component array. Names are any
        non-empty text without control characters.
    cell_data : dict of str to (m,) or (m, p) numpy array, optional
        Named fields per triangle, as ``point_data``.

    Raises
    ------
    WriteError
        A malformed mesh, a field of the wrong shape or type or with an unusable
        name, a missing folder, or a failure while writing (nothing is left behind).
    """
    try:
        if F is None:  # a point cloud: its points as vertex cells
            V = as_vertices(V)
            F = np.arange(len(V), dtype=np.int64)[:, None]
        else:
            V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    except ManifillError as exc:
        raise WriteError(f"{Path(path).name}: not written, the mesh is malformed: {exc}") from None
    _write_cells(path, "PolyData", V, F, _point_arrays(point_data, len(V)),
                 cell_arrays=_point_arrays(cell_data, len(F), "cells"))


def write_unstructured(path, V, C, point_data=None, *, cache=None, constant=(), cell_data=None):
    """Write triangles or tetrahedra with named point fields as a VTK UnstructuredGrid (``.vtu``), atomically.

    Encoded as :func:`write_polydata`; VTK, ParaView, pyvista and meshio read it,
    with any field name (meshio's own writer leaves ``&`` and ``<`` unescaped,
    which no XML reader accepts).

    Parameters
    ----------
    path : str or Path
        Destination (conventionally ``.vtu``).
    V : (n, 3) array_like of float
    C : (m, 1), (m, 3) or (m, 4) array_like of int
        Vertex cells (a point cloud), triangles or tetrahedra, validated by the caller.
    point_data : dict of str to (n,) or (n, p) numpy array, optional
    cache : dict, optional
        For files written one after another with the same mesh (a time series): an empty dict
        the first time, the same dict for the next files; the mesh's arrays, and the fields named
        in ``constant``, are encoded once. The caller guarantees they do not change.
    constant : collection of str, optional
        Fields the same in every file written with ``cache``.
    cell_data : dict of str to (m,) or (m, p) numpy array, optional
        Named fields per cell.

    Raises
    ------
    WriteError
        As :func:`write_polydata`.
    """
    V = np.asarray(V, dtype=np.float64)
    C = np.asarray(C, dtype=np.int64)
    if V.ndim != 2 or V.shape[1] != 3 or C.ndim != 2 or C.shape[1] not in (1, 3, 4):
        raise WriteError(f"{Path(path).name}: points {V.shape} and cells {C.shape}; pass (n, 3) points and "
                         f"(m, 3) triangles or (m, 4) tetrahedra")
    _write_cells(path, "UnstructuredGrid", V, C, _point_arrays(point_data, len(V)), cache, constant,
                 _point_arrays(cell_data, len(C), "cells"))


def write_imagedata(path, fields, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0)):
    """Write voxel fields as VTK ImageData (``.vti``), atomically.

    One point per voxel centre: ``Origin`` is the centre of voxel ``(0, 0, 0)``,
    ``Spacing`` the voxel size, every field a named point array (zlib-compressed
    inline binary, x fastest), readable by ParaView, VTK, pyvista and
    :func:`manifill.io.vtkxml_read.read_imagedata`.

    Parameters
    ----------
    path : str or Path
        Destination (conventionally ``.vti``).
    fields : dict of str to (n0, n1, n2) or (n0, n1, n2, p) numpy array
        Named fields on the same grid: booleans are stored as UInt8, integers as
        Int32 (Int64, or UInt64, when they do not fit), floats as Float64.
    spacing, origin : (3,) array_like of float, optional

    Raises
    ------
    WriteError
        No fields, fields of different grids, an unusable name, spacing or origin
        not three numbers, or a failure while writing (nothing is left behind).
    """
    shape, arrays = grid_arrays(fields)
    for name in arrays:
        _check_name(name)
    try:
        h = np.asarray(spacing, dtype=np.float64).reshape(3)
        o = np.asarray(origin, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise WriteError(f"spacing {spacing!r} or origin {origin!r} is not three numbers; pass e.g. "
                         f"spacing=(1.0, 1.0, 2.5)") from None
    extent = " ".join(f"0 {n - 1}" for n in shape)
    with atomic_path(path) as tmp:
        try:
            with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
                fh.write(_header("ImageData"))
                fh.write(f'  <ImageData WholeExtent="{extent}" Origin="{" ".join(map(repr, o.tolist()))}" '
                         f'Spacing="{" ".join(map(repr, h.tolist()))}">\n    <Piece Extent="{extent}">\n'
                         f'      <PointData>\n')
                for name, arr in arrays.items():
                    p = arr.shape[3] if arr.ndim == 4 else 1
                    # VTK orders points x fastest: Fortran order over (i, j, k), components innermost
                    flat = np.moveaxis(arr.reshape(shape + (p,)), (0, 1, 2), (2, 1, 0))
                    _write_array(fh, name, flat, p, " " * 8)
                fh.write("      </PointData>\n    </Piece>\n  </ImageData>\n</VTKFile>\n")
        except OSError as exc:
            raise WriteError(f"{Path(path).name}: could not write ({exc}); check the path") from None
