"""Solids on disk: voxel grids (VTI, NPY) and tetrahedral meshes (VTU, VTK, MSH).

A voxel result is written as VTK ImageData (``.vti``): one point per voxel centre,
``Origin`` the centre of voxel ``(0, 0, 0)``, ``Spacing`` the voxel size, every
field as named point data (NaN outside the solid), binary and uncompressed,
readable by ParaView, VTK and pyvista. The same writer's files, and ASCII or
raw-binary ImageData from elsewhere, read back with :func:`read_vti`. A mask can
also come as a ``.npy`` boolean array. Tetrahedral meshes go through meshio.
Writes are atomic, as in :mod:`manifill.io`.
"""

import base64
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .errors import ReadError, WriteError
from .io import _meshio_read, _suffix, atomic_path

__all__ = ["TET_FORMATS", "GRID_FORMATS", "read_tets", "write_tets", "write_vti", "read_vti", "read_mask"]

#: extension -> meshio format of tetrahedral meshes
TET_FORMATS = {".vtu": "vtu", ".vtk": "vtk", ".msh": "gmsh"}
GRID_FORMATS = (".vti", ".npy")

_VTK_TYPES = {np.dtype(np.float64): "Float64", np.dtype(np.float32): "Float32", np.dtype(np.int32): "Int32",
              np.dtype(np.uint8): "UInt8", np.dtype(np.int64): "Int64"}
_NP_TYPES = {v: k for k, v in _VTK_TYPES.items()} | {"Int8": np.dtype(np.int8), "UInt16": np.dtype(np.uint16),
                                                      "Int16": np.dtype(np.int16), "UInt32": np.dtype(np.uint32),
                                                      "UInt64": np.dtype(np.uint64)}


def read_tets(path):
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
    ext = _suffix(path, tuple(TET_FORMATS), "read")
    if not path.is_file():
        raise ReadError(f"{path}: no such file")
    mesh = _meshio_read(path, ext, TET_FORMATS[ext])
    tets = [b.data for b in mesh.cells if b.type == "tetra"]
    if not tets:
        kinds = ", ".join(sorted({b.type for b in mesh.cells})) or "none"
        raise ReadError(f"{path.name}: holds no tetrahedra (cells found: {kinds}); pass a tetrahedral mesh")
    return np.asarray(mesh.points, dtype=np.float64)[:, :3], np.concatenate(tets).astype(np.int64)


def has_tets(path):
    """Whether a mesh file holds tetrahedra (a cheap test for choosing the form)."""
    try:
        read_tets(path)
    except ReadError:
        return False
    return True


def write_tets(path, V, T, point_data=None):
    """Write a tetrahedral mesh with named per-vertex fields, atomically.

    Parameters
    ----------
    path : str or Path
        ``.vtu``, ``.vtk`` or ``.msh``.
    V : (n, 3) numpy array
    T : (m, 4) numpy array of int
    point_data : dict of str to (n,) or (n, p) numpy array, optional

    Raises
    ------
    WriteError
        Unknown extension, wrong field lengths, or a failure while writing.
    """
    import meshio

    ext = _suffix(path, tuple(TET_FORMATS), "write")
    n = len(V)
    data = {}
    for name, arr in (point_data or {}).items():
        arr = np.asarray(arr)
        if arr.shape[0] != n or arr.ndim not in (1, 2):
            raise WriteError(f"field {name!r} has shape {arr.shape}; pass (n,) or (n, p) values for {n} vertices")
        data[str(name)] = arr.astype(np.uint8) if arr.dtype == bool else arr
    mesh = meshio.Mesh(np.asarray(V, dtype=np.float64), [("tetra", np.asarray(T, dtype=np.int32))],
                       point_data=data)
    with atomic_path(path) as tmp:
        try:
            meshio.write(tmp, mesh, file_format=TET_FORMATS[ext] if ext != ".msh" else "gmsh22")
        except (meshio.WriteError, ValueError, KeyError, TypeError, OSError) as exc:
            raise WriteError(f"{Path(path).name}: could not write ({exc}); check the path and the fields") from None


def write_vti(path, fields, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0)):
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
    ext = _suffix(path, GRID_FORMATS, "write")
    if not fields:
        raise WriteError("no fields to write; pass at least one")
    shape = None
    arrays = {}
    for name, arr in fields.items():
        arr = np.asarray(arr)
        if arr.ndim not in (3, 4) or (shape is not None and arr.shape[:3] != shape):
            raise WriteError(f"field {name!r} has shape {arr.shape}; pass (n0, n1, n2) arrays on one grid")
        shape = arr.shape[:3]
        if arr.dtype == bool:
            arr = arr.astype(np.uint8)
        elif np.issubdtype(arr.dtype, np.integer):
            i32 = np.iinfo(np.int32)
            fits = arr.size == 0 or (int(arr.min()) >= i32.min and int(arr.max()) <= i32.max)
            arr = arr.astype(np.int32 if fits else np.int64)  # Int64 rather than wrap around
        else:
            arr = arr.astype(np.float64)
        arrays[str(name)] = arr
    if ext == ".npy":
        if len(arrays) != 1:
            raise WriteError(f"{Path(path).name}: .npy holds one array but {len(arrays)} fields were given; "
                             f"write .vti")
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.save(fh, next(iter(arrays.values())))
        return
    try:
        h = np.asarray(spacing, dtype=np.float64).reshape(3)
        o = np.asarray(origin, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise WriteError(f"spacing {spacing!r} or origin {origin!r} is not three numbers; pass e.g. "
                         f"spacing=(1.0, 1.0, 2.5)") from None
    extent = " ".join(f"0 {n - 1}" for n in shape)
    with atomic_path(path) as tmp:
        try:
            with open(tmp, "w", encoding="utf-8") as fh:  # field names may be any text
                fh.write('<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" '
                         'header_type="UInt64">\n')
                fh.write(f'  <ImageData WholeExtent="{extent}" Origin="{" ".join(map(repr, o.tolist()))}" '
                         f'Spacing="{" ".join(map(repr, h.tolist()))}">\n    <Piece Extent="{extent}">\n'
                         f'      <PointData>\n')
                for name, arr in arrays.items():
                    p = arr.shape[3] if arr.ndim == 4 else 1
                    # VTK orders points x fastest: Fortran order over (i, j, k), components innermost
                    flat = np.ascontiguousarray(np.moveaxis(arr.reshape(shape + (p,)), (0, 1, 2), (2, 1, 0)))
                    raw = flat.astype(arr.dtype.newbyteorder("<"), copy=False).tobytes()
                    blob = base64.b64encode(np.uint64(len(raw)).tobytes() + raw).decode("ascii")
                    fh.write(f'        <DataArray type="{_VTK_TYPES[arr.dtype]}" Name="{_xml(name)}" '
                             f'NumberOfComponents="{p}" format="binary">\n{blob}\n        </DataArray>\n')
                fh.write("      </PointData>\n    </Piece>\n  </ImageData>\n</VTKFile>\n")
        except OSError as exc:
            raise WriteError(f"{Path(path).name}: could not write ({exc}); check the path") from None


def _xml(name):
    return name.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;").replace(">", "&gt;")


def read_vti(path):
    """Read point data of VTK ImageData (inline binary or ASCII, uncompressed).

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
        Missing file, not ImageData, compressed or appended data.
    """
    path = Path(path)
    _suffix(path, (".vti",), "read")
    if not path.is_file():
        raise ReadError(f"{path}: no such file")
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise ReadError(f"{path.name}: not a readable VTI file ({exc}); check the file") from None
    img = root.find("ImageData")
    if root.get("type") != "ImageData" or img is None:
        raise ReadError(f"{path.name}: not VTK ImageData; pass a .vti image")
    if root.get("compressor"):
        raise ReadError(f"{path.name}: compressed VTI is not supported; save it uncompressed (or as .npy)")
    try:
        ext = [int(v) for v in img.get("WholeExtent", "").split()]
        spacing = np.array([float(v) for v in img.get("Spacing", "1 1 1").split()])
        origin = np.array([float(v) for v in img.get("Origin", "0 0 0").split()])
    except ValueError:
        raise ReadError(f"{path.name}: ImageData with a malformed WholeExtent, Spacing or Origin; "
                        f"check the file") from None
    if len(ext) != 6 or spacing.size != 3 or origin.size != 3:
        raise ReadError(f"{path.name}: ImageData without a WholeExtent of 6 numbers (or a Spacing or Origin "
                        f"of 3); check the file")
    shape = tuple(ext[2 * a + 1] - ext[2 * a] + 1 for a in range(3))
    header = np.uint64 if root.get("header_type") == "UInt64" else np.uint32
    fields = {}
    # point data only: cell data (one value per cell, fewer) is not a voxel field here
    for da in (da for pd in img.iter("PointData") for da in pd.iter("DataArray")):
        kind, fmt = da.get("type"), da.get("format", "ascii")
        if kind not in _NP_TYPES or fmt not in ("ascii", "binary"):
            raise ReadError(f"{path.name}: DataArray {da.get('Name')!r} is {fmt} {kind}; save the image with "
                            f"inline binary or ASCII data")
        dt = _NP_TYPES[kind].newbyteorder("<" if root.get("byte_order", "LittleEndian") == "LittleEndian" else ">")
        text = re.sub(r"\s+", "", da.text or "") if fmt == "binary" else (da.text or "")
        if fmt == "binary":
            raw = base64.b64decode(text)
            values = np.frombuffer(raw[np.dtype(header).itemsize:], dtype=dt)
        else:
            values = np.array(text.split(), dtype=dt)
        p = int(da.get("NumberOfComponents", "1"))
        if values.size != np.prod(shape) * p:
            raise ReadError(f"{path.name}: DataArray {da.get('Name')!r} has {values.size} values for "
                            f"{int(np.prod(shape))} points; check the file")
        arr = np.moveaxis(values.reshape(shape[::-1] + (p,)), (0, 1, 2), (2, 1, 0))
        fields[da.get("Name") or f"array{len(fields)}"] = np.ascontiguousarray(arr[..., 0] if p == 1 else arr)
    return fields, spacing, origin


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
    ext = _suffix(path, GRID_FORMATS, "read")
    if not path.is_file():
        raise ReadError(f"{path}: no such file")
    if ext == ".npy":
        try:
            arr = np.load(path, allow_pickle=False)
        except (ValueError, OSError) as exc:
            raise ReadError(f"{path.name}: not a readable .npy array ({exc}); check the file") from None
        spacing = origin = None
    else:
        fields, spacing, origin = read_vti(path)
        name = field or ("mask" if "mask" in fields else (next(iter(fields)) if len(fields) == 1 else None))
        if name not in fields:
            raise ReadError(f"{path.name}: holds fields {', '.join(fields) or '(none)'}; name the mask with "
                            f"--mask-field")
        arr = fields[name]
    if arr.ndim != 3 or not (arr.dtype == bool or np.isin(arr, (0, 1)).all()):
        raise ReadError(f"{path.name}: not a 3-D mask of 0 and 1 (shape {arr.shape}, dtype {arr.dtype}); "
                        f"pass a boolean voxel array")
    return arr.astype(bool), spacing, origin
