"""Neuroimaging surfaces and per-vertex data: GIfTI and FreeSurfer files, through nibabel (the ``[neuro]`` extra).

Surfaces: GIfTI (``.surf.gii``: a POINTSET and a TRIANGLE array) and FreeSurfer
triangle surfaces (``lh.pial``, ``rh.white``, ``lh.inflated``, ... recognised by
their magic number, whatever their name). Per-vertex data, one value per vertex
with NaN where nothing was measured: GIfTI data arrays (``.func.gii``,
``.shape.gii``, or the extra arrays of a surface file), FreeSurfer morphometry
files (``lh.thickness``, ``lh.curv``, ``lh.sulc``), MGH/MGZ volumes of shape
``(n, 1, 1[, t])``; and FreeSurfer labels (``.label``: vertex numbers with a value
each). Every per-vertex array can be given as samples: its finite entries are
the samples.
"""

import gzip
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ..errors import ReadError
from .files import check_count, reading

__all__ = ["FREESURFER_SURFACE", "FREESURFER_MORPH", "sniff", "read_gifti", "read_freesurfer_surface",
           "read_vertex_data", "read_gifti_data", "read_mgh_data", "read_morph_data",
           "read_label"]

#: magic numbers (first 3 bytes, big-endian) of FreeSurfer triangle surfaces and of new-style morphometry files
FREESURFER_SURFACE = b"\xff\xff\xfe"
FREESURFER_MORPH = b"\xff\xff\xff"

#: file suffixes of FreeSurfer morphometry data (``lh.thickness`` has the suffix ``.thickness``)
MORPH_SUFFIXES = (".thickness", ".curv", ".sulc", ".area", ".volume", ".jacobian_white", ".avg_curv")


def _nibabel():
    try:
        import nibabel
        import nibabel.freesurfer  # noqa: F401
        import nibabel.gifti  # noqa: F401
    except ImportError:
        raise ImportError("reading GIfTI and FreeSurfer files needs nibabel: pip install 'manifill[neuro]'") from None
    return nibabel


def sniff(path):
    """What a file without a known extension is, from its first bytes.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    {'freesurfer-surface', 'freesurfer-morph', None}
    """
    try:
        with open(path, "rb") as fh:
            head = fh.read(3)
    except OSError:
        return None
    if head == FREESURFER_SURFACE:
        return "freesurfer-surface"
    if head == FREESURFER_MORPH:
        return "freesurfer-morph"
    return None


def _gifti_arrays(path):
    nib = _nibabel()
    from nibabel.nifti1 import intent_codes

    with reading(path, "GIfTI file"):
        _check_gifti(path)
        img = nib.load(str(path))
        if not isinstance(img, nib.gifti.GiftiImage):
            raise ReadError(f"{Path(path).name}: not a GIfTI image; pass a .gii file")
        arrays = []
        for da in img.darrays:
            intent = intent_codes.label[da.intent] if da.intent in intent_codes.label else str(da.intent)
            meta = dict(da.meta) if da.meta is not None else {}
            arrays.append((intent, meta.get("Name") or meta.get("name"), np.asarray(da.data)))
    return arrays


def _check_gifti(path):
    """Refuse a DataArray Dimensionality beyond GIfTI's 6: nibabel counts up to it looking for Dim attributes."""
    for _, elem in ET.iterparse(str(path), events=("start",)):
        if elem.tag != "DataArray":
            continue
        text = elem.get("Dimensionality", "0")
        try:
            dims = int(text)
        except ValueError:
            continue  # nibabel's own error
        if dims > 6:
            raise ReadError(f"{Path(path).name}: a DataArray has Dimensionality {text[:30]!r}, more than GIfTI's 6; "
                            f"the file is damaged, check it")


def read_gifti(path):
    """Read a GIfTI surface and the per-vertex arrays stored with it.

    Parameters
    ----------
    path : str or Path
        A ``.gii`` (usually ``.surf.gii``) file.

    Returns
    -------
    V : (n, 3) float64 numpy array
    F : (m, 3) int64 numpy array
    point_data : dict of str to (n,) numpy array
        Every other data array of one value per vertex.

    Raises
    ------
    ReadError
        An unreadable file, or a file without a POINTSET and a TRIANGLE array
        (per-vertex data alone: pass it as samples with the surface as the mesh).
    ImportError
        Without nibabel (the ``[neuro]`` extra).
    """
    arrays = _gifti_arrays(path)
    points = [a for intent, _, a in arrays if intent == "pointset"]
    tris = [a for intent, _, a in arrays if intent == "triangle"]
    name = Path(path).name
    if not points or not tris:
        raise ReadError(f"{name}: a GIfTI file without a surface (no POINTSET and TRIANGLE arrays); if it holds "
                        f"per-vertex data, pass it as SAMPLES with the surface (.surf.gii) as the mesh")
    V, F = _surface_arrays(points[0], tris[0], name)
    point_data = {}
    for j, (intent, nm, a) in enumerate(arrays):
        if intent in ("pointset", "triangle") or a.shape[:1] != (len(V),):
            continue
        key = nm or f"array{j}"
        point_data[key if key not in point_data else f"{key}_{j}"] = a
    return V, F, point_data


def _surface_arrays(V, F, name):
    V = np.asarray(V)
    F = np.asarray(F)
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3:
        raise ReadError(f"{name}: the surface arrays have shapes {V.shape} and {F.shape}, not (n, 3) and (m, 3); "
                        f"check the file")
    if not np.issubdtype(F.dtype, np.integer):
        raise ReadError(f"{name}: the triangles are stored as {F.dtype}, not integers; check the file")
    return V.astype(np.float64), F.astype(np.int64)


def read_freesurfer_surface(path):
    """Read a FreeSurfer triangle surface (``lh.pial``, ``rh.white``, ...).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    V : (n, 3) float64 numpy array
        Vertex positions (surface RAS, millimetres).
    F : (m, 3) int64 numpy array

    Raises
    ------
    ReadError
        Not a readable FreeSurfer surface.
    ImportError
        Without nibabel (the ``[neuro]`` extra).
    """
    nib = _nibabel()
    name = Path(path).name
    with reading(path, "FreeSurfer surface"):
        with open(path, "rb") as fh:
            fh.seek(3)
            fh.readline()
            fh.readline()  # the creator line and a blank line, then two big-endian int32 counts
            counts = np.frombuffer(fh.read(8), dtype=">i4")
        if counts.size == 2:
            check_count(int(counts[0]), path, "vertices", bytes_each=12)
            check_count(int(counts[1]), path, "triangles", bytes_each=12)
        V, F = nib.freesurfer.read_geometry(str(path))
    return _surface_arrays(V, F, name)


def read_vertex_data(path, n):
    """Per-vertex values of a GIfTI, FreeSurfer morphometry or MGH/MGZ file (its reader from the registry of formats).

    Parameters
    ----------
    path : str or Path
    n : int or None
        The number of vertices of the surface the data belongs to (None, a GIfTI file: its first data array's).

    Returns
    -------
    values : (n, p) float64 numpy array
        One column per data array (or time point); NaN where nothing was measured.
    names : list of str

    Raises
    ------
    ReadError
        An unreadable file, or data whose length is not ``n``.
    ImportError
        Without nibabel (the ``[neuro]`` extra).
    """
    from .formats import find_format

    fmt = find_format("values", path)
    if fmt is None or fmt.read is None:  # no telling suffix: a FreeSurfer morphometry file by its first bytes
        return read_morph_data(path, n)
    return fmt.read(path, n)


def read_gifti_data(path, n):
    """Per-vertex values of a GIfTI file (``.func.gii``, ``.shape.gii``): one column per data array (as
    :func:`read_vertex_data`)."""
    _nibabel()
    path = Path(path)
    name = path.name
    cols, names = [], []
    for j, (intent, nm, a) in enumerate(_gifti_arrays(path)):
        if intent in ("pointset", "triangle"):
            continue
        a = np.asarray(a)
        a = a[:, None] if a.ndim == 1 else a
        n = len(a) if n is None else n  # a series read on its own: its first array's length
        if a.ndim != 2 or len(a) != n:
            raise ReadError(f"{name}: data array {j} has shape {np.shape(a)} but the mesh has {n:,} vertices; "
                            f"pass the surface this data belongs to")
        cols.append(a)
        stem = nm or (path.name.split(".")[0] if len(cols) == 1 else f"array{j}")
        names += [stem] if a.shape[1] == 1 else [f"{stem}_{i}" for i in range(a.shape[1])]
    if not cols:
        raise ReadError(f"{name}: a GIfTI file without per-vertex data arrays; pass a .func.gii or .shape.gii")
    return _real(np.column_stack(cols), name), names


def read_mgh_data(path, n, compressed=False):
    """Per-vertex values of an MGH file (MGZ: ``compressed``), ``(n, 1, 1[, t])``: one column per time point (as
    :func:`read_vertex_data`)."""
    nib = _nibabel()
    path = Path(path)
    name = path.name
    with reading(path, "MGH/MGZ file"):
        _check_mgh(path, compressed=compressed)
        values = np.asarray(nib.load(str(path)).get_fdata())
    if values.ndim < 1 or values.shape[0] != n or int(np.prod(values.shape[1:3])) != 1:
        raise ReadError(f"{name}: data of shape {values.shape}, not ({n:,}, 1, 1[, t]) for the mesh's {n:,} "
                        f"vertices; pass the surface this data belongs to")
    values = values.reshape(n, -1)
    names = [path.name.split(".")[0] + ("" if values.shape[1] == 1 else f"_{j}") for j in range(values.shape[1])]
    return _real(values, name), names


def read_morph_data(path, n, named=False):
    """Per-vertex values of a FreeSurfer morphometry file (``lh.thickness``): one column named after its suffix
    (``thickness``), or ``value`` where the suffix is not a measure's (as :func:`read_vertex_data`)."""
    nib = _nibabel()
    path = Path(path)
    name = path.name
    with reading(path, "FreeSurfer morphometry file"):
        with open(path, "rb") as fh:
            head = fh.read(15)
        if head[:3] == FREESURFER_MORPH and len(head) == 15:
            check_count(int(np.frombuffer(head[3:7], ">i4")[0]), path, "values", bytes_each=4, start=15)
        values = np.asarray(nib.freesurfer.read_morph_data(str(path)), dtype=np.float64)
    if values.ndim != 1 or len(values) != n:
        raise ReadError(f"{name}: {values.size:,} values but the mesh has {n:,} vertices; pass the surface "
                        f"this data belongs to")
    return _real(values[:, None], name), [path.suffix[1:] if named else "value"]


def _real(values, name):
    if np.iscomplexobj(values) or not np.issubdtype(values.dtype, np.number):
        raise ReadError(f"{name}: the data is {values.dtype}, not real numbers; pass real-valued data")
    return np.asarray(values, dtype=np.float64)


#: bytes per value of the MGH data types nibabel reads (uchar, int, float, short, ushort)
_MGH_SIZES = {0: 1, 1: 4, 3: 4, 4: 2, 10: 2}
_MGH_DATA = 284  # where the values start
_GZIP_RATIO = 1032  # deflate never expands data more than this


def _check_mgh(path, compressed):
    """Refuse MGH dimensions that the file cannot hold: nibabel allocates for them before reading."""
    with (gzip.open if compressed else open)(path, "rb") as fh:
        head = fh.read(24)
    if len(head) < 24:
        return  # nibabel says what is missing
    _, *dims, code = np.frombuffer(head, dtype=">i4").tolist()
    count = int(np.prod(dims, dtype=object))
    size = os.path.getsize(path)
    room = size * _GZIP_RATIO if compressed else size - _MGH_DATA
    if min(dims) < 0 or count * _MGH_SIZES.get(code, 1) > room:
        raise ReadError(f"{Path(path).name}: the header claims {' x '.join(map(str, dims))} values but the file has "
                        f"only {size:,} bytes; it is truncated or damaged, check it")


def read_label(path):
    """A FreeSurfer label file (``lh.V1.label``): vertex numbers and one value each.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    idx : (k,) int64 numpy array
    values : (k, 1) float64 numpy array

    Raises
    ------
    ReadError
        Not a readable label file.
    ImportError
        Without nibabel (the ``[neuro]`` extra).
    """
    _nibabel()
    name = Path(path).name
    with reading(path, "FreeSurfer label file"):
        with open(path, "rb") as fh:
            fh.readline()
            count = fh.readline().strip()
        # as nibabel.freesurfer.read_label, with the row count and the columns checked (a cut row is not data)
        table = np.loadtxt(str(path), skiprows=2, ndmin=2, dtype=np.float64)
    if not count.isdigit() or len(count) > 18:
        raise ReadError(f"{name}: line 2 is {count[:30].decode('latin-1')!r}, not the number of vertices; check the "
                        f"file")
    rows = len(table) if table.size else 0
    if rows and table.shape[1] != 5:
        raise ReadError(f"{name}: rows of {table.shape[1]} numbers, not 5 (vertex x y z value); the file is "
                        f"damaged, check it")
    if rows != int(count):
        raise ReadError(f"{name}: the header claims {int(count):,} vertices but {rows:,} rows follow; the file is "
                        f"truncated or damaged, check it")
    col = table[:, 0] if rows else np.zeros(0)
    good = np.isfinite(col) & (np.abs(col) < 2.0**62) & (col == np.round(col))
    if not good.all():
        raise ReadError(f"{name}: vertex number {col[~good][0]:g} in row {int(np.flatnonzero(~good)[0]) + 1} is not "
                        f"an integer vertex index; check the file")
    table = table.reshape(rows, 5)
    return table[:, 0].astype(np.int64), table[:, 4:5].copy()
