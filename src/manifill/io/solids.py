"""Solids on disk: voxel grids (VTI, NPY) and tetrahedral meshes (VTU, VTK, MSH).

A voxel result is written as VTK ImageData (``.vti``): one point per voxel centre,
``Origin`` the centre of voxel ``(0, 0, 0)``, ``Spacing`` the voxel size, every
field as named point data (NaN outside the solid), zlib-compressed binary,
readable by ParaView, VTK and pyvista. The same writer's files, and ImageData
from elsewhere in any VTK XML encoding, read back with :func:`read_vti` (both
through :mod:`manifill.io.vtkxml_read` and :mod:`manifill.io.vtkxml_write`). A mask can
also come as a ``.npy`` boolean array. Tetrahedral meshes go through meshio.
Writes are atomic (:func:`manifill.io.files.atomic_path`).
"""

import base64  # noqa: F401  (manifill.io.solids.base64 is the module the VTI writer encodes with)
import os
import re
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ManifillError, ReadError, WriteError
from ..validate import as_tets
from .files import atomic_path, check_count
from .formats import Format, FormatView, lookup, register_format
from .meshio_files import meshio_read
from .registry import CELL_WRITERS, check_cells, write_cells
from .samples import load_npy
from .vtklegacy_read import read_legacy
from .vtkxml_read import read_imagedata
from .vtkxml_write import grid_arrays, write_imagedata

__all__ = ["TET_FORMATS", "GRID_FORMATS", "read_tets", "write_tets", "write_vti", "read_vti", "read_mask", "has_tets"]

def _read_legacy_tets(path, fmt):
    V, cells, _ = read_legacy(path)
    if len(cells.get("tetra", ())) == 0:
        kinds = ", ".join(k for k, c in cells.items() if len(c)) or "none"
        raise ReadError(f"{path.name}: holds no tetrahedra (cells found: {kinds}); pass a tetrahedral mesh")
    return V, cells["tetra"]


def _read_meshio_tets(path, fmt):
    if fmt.meshio == "gmsh":
        _check_msh(path)
    mesh = meshio_read(path, fmt.suffixes[0], fmt.meshio)
    tets = [b.data for b in mesh.cells if b.type == "tetra"]
    if not tets:
        kinds = ", ".join(sorted({b.type for b in mesh.cells})) or "none"
        raise ReadError(f"{path.name}: holds no tetrahedra (cells found: {kinds}); pass a tetrahedral mesh")
    V = np.asarray(mesh.points, dtype=np.float64)
    T = np.concatenate(tets).astype(np.int64)
    check_cells(path, V[:, :3] if V.ndim == 2 else V, T, "tetrahedron")
    return V[:, :3], T


def _write_gmsh(path, V, kind, C, data, fmt):
    CELL_WRITERS["meshio"](path, V, kind, C, data, replace(fmt, meshio="gmsh22"))  # Gmsh 2.2, which every reader takes


def _read_npy_grid(path, fmt):
    return {None: load_npy(path, ".npy array")}, None, None  # the header checked against the file's size first


def _read_vti_grid(path, fmt):
    return read_imagedata(path)


def _write_npy_grid(path, fields, spacing, origin):
    _, arrays = grid_arrays(fields)
    if len(arrays) != 1:
        raise WriteError(f"{Path(path).name}: .npy holds one array but {len(arrays)} fields were given; "
                         f"write .vti")
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        np.save(fh, next(iter(arrays.values())))


# tets: read(path, format) -> (V, T); written by the cell writers. grid: read(path, format) -> (fields, spacing,
# origin) (one unnamed field from .npy); write(path, fields, spacing, origin)
for _fmt in (
    Format("VTU", "tets", (".vtu",), _read_meshio_tets, CELL_WRITERS["vtu"], fields=True, vectors=True,
           meshio="vtu"),
    Format("legacy VTK", "tets", (".vtk",), _read_legacy_tets, CELL_WRITERS["legacy"], fields=True, vectors=True,
           plain_names=True),
    Format("Gmsh", "tets", (".msh",), _read_meshio_tets, _write_gmsh, fields=True, plain_names=True,
           meshio="gmsh"),
    Format("VTK ImageData", "grid", (".vti",), _read_vti_grid, write_imagedata, fields=True, vectors=True),
    Format("NumPy array", "grid", (".npy",), _read_npy_grid, _write_npy_grid),
):
    register_format(_fmt)

#: The formats of tetrahedral meshes and of voxel grids (views of :mod:`manifill.io.formats`' registry).
TET_FORMATS = FormatView("tets")
GRID_FORMATS = FormatView("grid")


def read_tets(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray]:
    """Read a tetrahedral mesh.

    Parameters
    ----------
    path : str or Path
        ``.vtu``, ``.vtk`` or ``.msh`` (Gmsh).

    Returns
    -------
    V : (n, 3) float64 numpy array
    T : (m, 4) int64 numpy array

    Raises
    ------
    ReadError
        Missing file, unknown extension, unparsable file, or no tetrahedra.
    """
    path = Path(path)
    fmt = lookup("tets", path)
    if not path.is_file():
        raise ReadError(f"{path}: no such file")
    return fmt.read(path, fmt)


def _check_msh(path):
    """Refuse Gmsh counts that the file cannot hold: meshio allocates for them (numpy.fromfile) before reading.

    Version 2 files are walked section by section (nodes, element blocks, node and element data); of ASCII version 4
    files the counts lines of ``$Nodes`` and ``$Elements`` are checked.
    """
    data = path.read_bytes()
    fmt = re.search(rb"^\$MeshFormat[ \t\r]*\n[ \t]*([0-9.]+)[ \t]+([0-9]+)", data, re.M)
    if fmt is None:
        return  # meshio says what is wrong
    binary, major = fmt.group(2) == b"1", fmt.group(1).split(b".")[0]

    def ints(pos, what):
        """The integers of the line at ``pos`` and where the next line starts."""
        end = data.find(b"\n", pos)
        end = len(data) if end < 0 else end
        words = data[pos:end].split()
        if not words or not all(re.fullmatch(rb"[-+]?[0-9]{1,40}", w) for w in words):
            raise ReadError(f"{path.name}: the {what} line {data[pos:end][:40].decode('latin-1')!r} is not a line of "
                            f"integers; the file is damaged, check it")
        return [int(w) for w in words], end + 1

    for sec in re.finditer(rb"^\$(Nodes|Elements|NodeData|ElementData)[ \t\r]*\n", data, re.M):
        name, pos = sec.group(1).decode(), sec.end()
        if major != b"2" and binary:
            break  # version 4 gives its binary counts as size_t, not as a line: meshio's checks alone
        (count, *rest), pos = ints(pos, f"${name} count")
        if major != b"2":
            for c in [count] + rest[:1]:
                check_count(c, path, f"${name} entries", bytes_each=1, start=pos)
            continue
        if name == "Nodes":
            check_count(count, path, "nodes", bytes_each=28 if binary else 8, start=pos)
        elif name == "Elements":
            check_count(count, path, "elements", bytes_each=12 if binary else 8, start=pos)
            seen = 0
            while binary and seen < count:  # blocks of (type, n, tags) and n records
                head = np.frombuffer(data[pos:pos + 12], dtype="<i4")
                if head.size < 3:
                    break  # meshio's own error
                if head[1] < 0 or head[2] < 0:
                    raise ReadError(f"{path.name}: an element block claims {head[1]} elements of {head[2]} tags; the "
                                    f"file is damaged, check it")
                width = 1 + int(head[2]) + _gmsh_nodes(int(head[0]))
                check_count(int(head[1]), path, "elements in a block", bytes_each=4 * width, start=pos + 12)
                pos, seen = pos + 12 + 4 * width * int(head[1]), seen + int(head[1])
        else:  # string, real and integer tags, one a line, then the values
            for kind in ("string", "real", "integer"):
                check_count(count, path, f"{kind} tags of ${name}", bytes_each=2, start=pos)
                tags = []
                for _ in range(count):
                    end = data.find(b"\n", pos)
                    tags.append(data[pos:end if end >= 0 else len(data)])
                    pos = len(data) if end < 0 else end + 1
                if kind == "integer":
                    values = [int(t) for t in tags if re.fullmatch(rb"\s*[-+]?[0-9]{1,40}\s*", t)]
                    if len(values) >= 3:  # items of an index and the components (4-byte values at least)
                        comps = max(values[1], 0)
                        check_count(values[2], path, f"items of ${name}", bytes_each=4 * (1 + comps) if binary
                                    else 2 * (1 + comps), start=pos)
                elif pos < len(data):
                    (count, *_), pos = ints(pos, f"${name} tag count")


def _gmsh_nodes(code):
    """Nodes of a Gmsh element type (1 for types meshio does not know: it refuses them itself)."""
    from meshio._common import num_nodes_per_cell
    from meshio.gmsh.common import _gmsh_to_meshio_type

    return num_nodes_per_cell.get(_gmsh_to_meshio_type.get(code), 1)


def has_tets(path):
    """Whether a mesh file holds tetrahedra (a cheap test for choosing the form).

    Parameters
    ----------
    path : str or Path
        A ``.vtu``, ``.vtk`` or ``.msh`` file.

    Returns
    -------
    bool
        False also for a file :func:`read_tets` refuses.
    """
    try:
        read_tets(path)
    except ReadError:
        return False
    return True


def write_tets(path: str | os.PathLike[str], V: ArrayLike, T: ArrayLike,
               point_data: Mapping[str, ArrayLike] | None = None) -> dict[str, str]:
    """Write a tetrahedral mesh with named per-vertex fields, atomically.

    Parameters
    ----------
    path : str or Path
        ``.vtu``, ``.vtk`` or ``.msh``.
    V : (n, 3) numpy array
    T : (m, 4) numpy array of int
    point_data : dict of str to (n,) or (n, p) numpy array, optional

    Returns
    -------
    dict of str to str
        The name each field was written under (see :func:`manifill.io.field_names.stored_names`).

    Raises
    ------
    WriteError
        Unknown extension, a malformed mesh, wrong field lengths or names, or a
        failure while writing (nothing is left behind).
    """
    lookup("tets", path, writing=True)
    try:
        V, T = as_tets(V, T, allow_degenerate=True, allow_unreferenced=True)
    except ManifillError as exc:
        raise WriteError(f"{Path(path).name}: not written, the tetrahedral mesh is malformed: {exc}") from None
    return write_cells(path, V, T, point_data)


def write_vti(path: str | os.PathLike[str], fields: Mapping[str, ArrayLike], *, spacing: ArrayLike = (1.0, 1.0, 1.0),
              origin: ArrayLike = (0.0, 0.0, 0.0)) -> None:
    """Write voxel fields as VTK ImageData (``.vti``) or, for one field, as ``.npy``; atomically.

    Parameters
    ----------
    path : str or Path
    fields : dict of str to (n0, n1, n2) or (n0, n1, n2, p) numpy array
        Named fields on the same grid (boolean fields are stored as UInt8).
    spacing, origin : (3,) array_like of float, optional

    Raises
    ------
    WriteError
        Unknown extension, fields of different grids, several fields for
        ``.npy``, or a failure while writing.

    Examples
    --------
    >>> import tempfile, os
    >>> f = os.path.join(tempfile.mkdtemp(), "a.vti")
    >>> write_vti(f, {"t": np.arange(24.0).reshape(2, 3, 4)}, spacing=(1, 1, 2))
    >>> d, h, o = read_vti(f)
    >>> bool((d["t"] == np.arange(24.0).reshape(2, 3, 4)).all()), h.tolist()
    (True, [1.0, 1.0, 2.0])
    """
    lookup("grid", path, writing=True).write(path, fields, spacing, origin)


def read_vti(path: str | os.PathLike[str]) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """Read point data of VTK ImageData (ASCII, binary or appended, compressed or not).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    fields : dict of str to (n0, n1, n2) or (n0, n1, n2, p) numpy array
    spacing, origin : (3,) numpy arrays

    Raises
    ------
    ReadError
        Missing file, not ImageData, a damaged file or a rotated grid.
    """
    path = Path(path)
    fmt = lookup("grid", path)
    if not fmt.fields:
        raise ReadError(f"{path.name}: holds one unnamed array, not named fields on a grid; pass a .vti file")
    return fmt.read(path, fmt)


def read_mask(path, *, field=None):
    """Read a voxel mask from ``.npy`` (a boolean array) or ``.vti`` (a 0/1 point field).

    Parameters
    ----------
    path : str or Path
    field : str, optional
        The VTI field holding the mask (default: the only one, or ``mask``).

    Returns
    -------
    mask : (n0, n1, n2) bool numpy array
    spacing, origin : (3,) numpy arrays or None
        From the VTI header; None for ``.npy``.

    Raises
    ------
    ReadError
        A missing file, no such field, or values other than 0 and 1.
    """
    path = Path(path)
    fmt = lookup("grid", path)
    if not path.is_file():
        raise ReadError(f"{path}: no such file")
    fields, spacing, origin = fmt.read(path, fmt)
    if not fmt.fields:
        arr = fields[None]
    else:
        name = field or ("mask" if "mask" in fields else (next(iter(fields)) if len(fields) == 1 else None))
        if name not in fields:
            raise ReadError(f"{path.name}: holds fields {', '.join(fields) or '(none)'}; name the mask with "
                            f"--mask-field")
        arr = fields[name]
    if arr.ndim != 3 or arr.size == 0 or not (arr.dtype == bool or (arr.dtype.kind in "iuf"
                                                                   and np.isin(arr, (0, 1)).all())):
        raise ReadError(f"{path.name}: not a 3-D mask of 0 and 1 (shape {arr.shape}, dtype {arr.dtype}); "
                        f"pass a boolean voxel array")
    return arr.astype(bool), spacing, origin
