"""Writing legacy VTK files (``.vtk``): triangles or tetrahedra with named point fields, as VTK and meshio read them.

:func:`write_legacy` writes version 4.2 BINARY UNSTRUCTURED_GRID files (the one
layout that both meshio and VTK 9 read with all their arrays) with every field in
one ``FIELD`` block, atomically. The reader is :func:`manifill.io.vtklegacy_read.read_legacy`.
"""

from pathlib import Path

import numpy as np

from ..errors import WriteError
from .files import atomic_path
from .vtklegacy_scan import MAX_COUNT

__all__ = ["write_legacy"]


#: The cell kinds written: points per cell and VTK's type number (a point cloud's points are vertex cells).
_CELL_TYPES = {"vertex": (1, 1), "triangle": (3, 5), "tetra": (4, 10)}


def write_legacy(path, V, kind, cells, point_data=None, cell_data=None):
    """Write a triangle or tetrahedral mesh with named point fields as legacy VTK, atomically.

    The file is version 4.2, BINARY, ``DATASET UNSTRUCTURED_GRID`` with double
    points and one ``FIELD`` block in ``POINT_DATA``: meshio and VTK (pyvista,
    ParaView) both read it back with every field.

    Parameters
    ----------
    path : str or Path
        The ``.vtk`` file to write.
    V : (n, 3) float numpy array
        Points.
    kind : {"vertex", "triangle", "tetra"}
        What the cells are (``vertex``: a point cloud, one cell per point).
    cells : (m, 3) or (m, 4) int numpy array
        Point indices of each triangle or tetrahedron.
    point_data : dict of str to (n,) or (n, p) numpy array, optional
        Fields: bool arrays are stored as ``unsigned_char`` (read back as
        uint8), integers as ``int`` (int32), floats as ``double``.
    cell_data : dict of str to (m,) or (m, p) numpy array, optional
        Fields per cell (a ``CELL_DATA`` block), stored alike.

    Raises
    ------
    WriteError
        A name the legacy format cannot hold for every reader (empty, with
        whitespace, control characters, ``%`` or non-ASCII characters, or one
        VTK reads as a keyword: ``NULL_ARRAY``, ``METADATA...``), a field of the
        wrong length or shape, integers beyond int32, a malformed mesh, or a
        failed write.
    """
    name = Path(path).name
    try:
        V = np.asarray(V, dtype=np.float64)
    except (TypeError, ValueError):
        raise WriteError(f"{name}: the points are not numbers; pass V as an (n, 3) float array") from None
    if V.ndim != 2 or V.shape[1] != 3:
        raise WriteError(f"{name}: the points have shape {V.shape}, not (n, 3); pass V as an (n, 3) float array")
    if kind not in _CELL_TYPES:
        raise WriteError(f"{name}: cell kind {kind!r} is not 'vertex', 'triangle' or 'tetra'; pass one of them")
    k, vtk_type = _CELL_TYPES[kind]
    try:
        C = np.asarray(cells)
    except (TypeError, ValueError):  # ragged lists
        raise WriteError(f"{name}: the {kind} cells are not an (m, {k}) integer array; pass them as one") from None
    if C.size == 0:
        C = C.reshape(0, k)
    n = len(V)
    if C.ndim != 2 or C.shape[1] != k or C.dtype.kind not in "iu":
        raise WriteError(f"{name}: the {kind} cells have shape {C.shape} and type {C.dtype}, not an (m, {k}) "
                         f"integer array; pass the cells as one")
    if C.size and (C.min() < 0 or C.max() >= n):
        raise WriteError(f"{name}: the cells use point {int(C.min() if C.min() < 0 else C.max())} but there are "
                         f"{n:,} points; pass indices in 0..{n - 1}")
    if n > MAX_COUNT or len(C) * (k + 1) > MAX_COUNT:
        raise WriteError(f"{name}: {n:,} points and {len(C):,} cells are more than legacy VTK holds; write .vtu")
    fields = [_field(name, key, arr, n) for key, arr in (point_data or {}).items()]
    per_cell = [_field(name, key, arr, len(C)) for key, arr in (cell_data or {}).items()]
    with atomic_path(path) as tmp:
        try:
            with open(tmp, "wb") as fh:
                fh.write(b"# vtk DataFile Version 4.2\nwritten by manifill\nBINARY\nDATASET UNSTRUCTURED_GRID\n")
                fh.write(f"POINTS {n} double\n".encode())
                fh.write(V.astype(">f8").tobytes() + b"\n")
                fh.write(f"CELLS {len(C)} {len(C) * (k + 1)}\n".encode())
                records = np.column_stack([np.full(len(C), k), C]).astype(">i4")
                fh.write(records.tobytes() + b"\n")
                fh.write(f"CELL_TYPES {len(C)}\n".encode())
                fh.write(np.full(len(C), vtk_type, dtype=">i4").tobytes() + b"\n")
                for section, count, block in (("POINT_DATA", n, fields), ("CELL_DATA", len(C), per_cell)):
                    if block:
                        fh.write(f"{section} {count}\nFIELD FieldData {len(block)}\n".encode())
                    for key, vtype, arr in block:
                        p = 1 if arr.ndim == 1 else arr.shape[1]
                        fh.write(f"{key} {p} {count} {vtype}\n".encode())
                        fh.write(arr.tobytes() + b"\n")
        except OSError as exc:
            raise WriteError(f"{name}: could not write ({exc.strerror or exc}); check the path and free space") \
                from None


def _field(fname, key, arr, n):
    """(name, VTK type, big-endian array) of one field, or WriteError."""
    if not isinstance(key, str) or not key:
        raise WriteError(f"{fname}: field name {key!r} is empty or not text; rename it")
    bad = sorted({c for c in key if c.isspace() or c == "%" or not 33 <= ord(c) <= 126})
    if bad:
        raise WriteError(f"{fname}: field name {key!r} has {', '.join(map(repr, bad))}, which legacy VTK cannot "
                         f"hold in a name; rename it or write .vtu/.vtp")
    if key == "NULL_ARRAY" or key.lower().startswith("metadata"):
        raise WriteError(f"{fname}: field name {key!r} reads as a keyword in legacy VTK; rename it or write "
                         f".vtu/.vtp")
    try:
        arr = np.asarray(arr)
    except (TypeError, ValueError):  # ragged lists
        raise WriteError(f"{fname}: field {key!r} is not an array of numbers; pass one value (or row) per point") \
            from None
    if arr.ndim not in (1, 2) or len(arr) != n or (arr.ndim == 2 and arr.shape[1] < 1):
        raise WriteError(f"{fname}: field {key!r} has shape {arr.shape}, not ({n},) or ({n}, p) for {n:,} points; "
                         f"pass one value (or row) per point")
    if arr.dtype in (bool, np.uint8):  # masks: 0/1 bytes
        return key, "unsigned_char", arr.astype("u1")
    if arr.dtype.kind in "iu":
        info = np.iinfo(np.int32)
        if arr.size and (arr.min() < info.min or arr.max() > info.max):
            raise WriteError(f"{fname}: field {key!r} has integers beyond int32 ({arr.min()}..{arr.max()}), which "
                             f"legacy VTK cannot store for every reader; convert it to float or write .vtu")
        return key, "int", arr.astype(">i4")
    if arr.dtype.kind == "f":
        return key, "double", arr.astype(">f8")
    raise WriteError(f"{fname}: field {key!r} has type {arr.dtype}, not bool, integer or float; convert it")
