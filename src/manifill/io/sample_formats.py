"""The formats of samples and of per-vertex values: their readers and writers, registered in
:mod:`manifill.io.formats` (the ``samples`` and ``values`` kinds), and :func:`write_values`.

CSV (``vertex,value[,...]`` or ``x,y,z,value[,...]``), NPZ (``idx`` or ``points``, ``vals``, ``names``, ``times``),
structured NPY, and through the ``[neuro]`` extra GIfTI, MGH/MGZ, FreeSurfer morphometry and ``.label`` files (see
:mod:`manifill.io.samples`, which reads samples through them). An NPY header or a ZIP member that lies about its size
is refused before anything is allocated.
"""

import csv
import difflib
import os
import zipfile
from collections.abc import Sequence
from functools import partial
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ReadError, SampleError, WriteError
from ..surface.samples import field_names
from ..validate.samples import MAX_VALUE
from .files import atomic_path, is_number, reading
from .formats import Format, FormatView, lookup, register_format
from .gifti_write import write_gifti_data
from .neuro import MORPH_SUFFIXES, read_gifti_data, read_label, read_mgh_data, read_morph_data

__all__ = ["SAMPLE_FORMATS", "VALUE_FORMATS", "MORPH", "VECTOR_COLUMNS", "load_npy", "load_npz", "write_values"]

_VERTEX_COLUMNS = ("vertex", "idx", "index", "vertex_id", "id")
#: The value columns of arrows (a tangent vector field's samples, :mod:`manifill.io.vector_files`); an NPZ's
#: ``vectors`` (k, 3) is read as them.
VECTOR_COLUMNS = ("vx", "vy", "vz")


def _split_header(header, path):
    cols = [h.strip().lower() for h in header]
    if len(cols) >= 2 and cols[0] in _VERTEX_COLUMNS:
        return "vertex", 1
    if len(cols) >= 4 and cols[:3] == ["x", "y", "z"]:
        return "points", 3
    raise ReadError(f"{Path(path).name}: {_header_problem(header, cols)}")


def _header_problem(header, cols):
    """What is wrong with a sample file's header, naming the column and the expected name nearest to it."""
    shown = ",".join(h.strip() for h in header)
    if len(cols) < 2 or (all(is_number(c) for c in cols) and cols):
        return f"the first line {shown!r} is not a header; add one such as vertex,value or x,y,z,value"
    if cols[0] in ("x", "y", "z") or (len(cols) >= 3 and difflib.get_close_matches(cols[0], ["x"], cutoff=0.5)):
        want = ["x", "y", "z"]
        for j, (got, exp) in enumerate(zip(cols[:3], want)):
            if got != exp:
                return (f"header {shown!r}: column {j + 1} is {header[j].strip()!r}, not {exp!r} (positions are "
                        f"x,y,z,value[,...]); rename it {exp!r}")
        return f"header {shown!r} has positions x,y,z but no value column; add one (x,y,z,value)"
    close = difflib.get_close_matches(cols[0], _VERTEX_COLUMNS, n=1, cutoff=0.5)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    return (f"header {shown!r}: the first column {header[0].strip()!r} is neither 'vertex'{hint} nor 'x'; a header is "
            f"vertex,value[,...] (vertex indices) or x,y,z,value[,...] (positions): rename it")


def _read_label(path, n):
    idx, vals = read_label(path)
    if len(idx) == 0:
        raise ReadError(f"{path.name}: a label file without vertices; check the file")
    return "vertex", np.column_stack([idx, vals]), [path.name.split(".label")[0]], None





def _vertex_data(read):
    """A reader of per-vertex data (NaN = not measured, :mod:`manifill.io.neuro`) as a reader of vertex samples."""

    def read_table(path, n):
        return _vertex_samples(path, *read(path, n))

    return read_table


def _vertex_samples(path, values, names):
    """Per-vertex data (NaN = not measured) as vertex-indexed samples."""
    known = np.isfinite(values)
    rows = known.all(axis=1)
    mixed = known.any(axis=1) & ~rows
    if mixed.any():
        raise SampleError(f"{path.name}: vertex {int(np.flatnonzero(mixed)[0])} has a value in some arrays and NaN "
                          f"in others; every array must be measured at the same vertices (split the file)")
    if not rows.any():
        raise SampleError(f"{path.name}: every value is NaN; mark the measured vertices with numbers")
    idx = np.flatnonzero(rows)
    return "vertex", np.column_stack([idx, values[idx]]), names, None


def _read_csv(path):
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            reader = csv.reader(fh)
            rows, lineno = [], []
            for r in reader:
                if r and any(c.strip() for c in r):
                    rows.append(r)
                    lineno.append(reader.line_num)
    except UnicodeDecodeError as exc:
        raise ReadError(f"{path.name}: could not read as CSV (byte 0x{exc.object[exc.start]:02x}, which is not "
                        f"UTF-8 text); save it as UTF-8 text") from None
    except (OSError, csv.Error) as exc:
        raise ReadError(f"{path.name}: could not read as CSV ({exc}); save it as UTF-8 text") from None
    if not rows:
        raise ReadError(f"{path.name}: empty file; expected a header and one row per sample")
    header = rows[0]
    kind, ncoord = _split_header(header, path)
    if len(rows) == 1:
        raise ReadError(f"{path.name}: a header but no samples; add one row per sample")
    table = np.empty((len(rows) - 1, len(header)))
    for i, row in enumerate(rows[1:]):
        if len(row) != len(header):
            raise ReadError(f"{path.name}: line {lineno[i + 1]} has {len(row)} fields, the header {len(header)}")
        for j, cell in enumerate(row):
            try:
                table[i, j] = float(cell)
            except ValueError:
                raise ReadError(
                    f"{path.name}: line {lineno[i + 1]}, column {header[j].strip()!r}: {cell!r} is not a real number"
                ) from None
    bad = ~np.isfinite(table).all(axis=1)
    if bad.any():
        lines = ", ".join(str(lineno[int(r) + 1]) for r in np.flatnonzero(bad)[:5])
        raise SampleError(f"{path.name}: NaN or infinite values on lines {lines}; remove or fix those samples")
    big = (np.abs(table[:, ncoord:]) > MAX_VALUE).any(axis=1)
    if big.any():  # said here with the file's lines (the check of the values counts rows from 0)
        lines = ", ".join(str(lineno[int(r) + 1]) for r in np.flatnonzero(big)[:5])
        raise SampleError(f"{path.name}: values beyond {MAX_VALUE:.0e} on lines {lines} (up to "
                          f"{np.abs(table[:, ncoord:]).max():.3g}), where the energies' squares overflow; divide the "
                          f"values by a power of ten and scale the result back")
    return kind, table, [h.strip() for h in header[ncoord:]], np.asarray(lineno[1:])


def _npy_header(fh, name, size):
    """Shape and dtype from an NPY header, checked against the bytes that follow."""
    version = np.lib.format.read_magic(fh)
    if version not in ((1, 0), (2, 0), (3, 0)):
        raise ReadError(f"{name}: NPY format version {version[0]}.{version[1]} is not 1.0, 2.0 or 3.0; the file is "
                        f"damaged")
    # the header's own length first: numpy reads that many bytes at once, 4 GB if the file says so
    start = fh.tell()
    width = 2 if version == (1, 0) else 4
    length = int.from_bytes(fh.read(width), "little")
    fh.seek(start)
    if length > size - start - width:
        raise ReadError(f"{name}: the header claims {length:,} header bytes but only {max(size - start - width, 0):,} "
                        f"bytes follow; the file is truncated or damaged")
    if version == (1, 0):
        shape, fortran, dtype = np.lib.format.read_array_header_1_0(fh)
    else:
        shape, fortran, dtype = np.lib.format.read_array_header_2_0(fh)
    if dtype.hasobject:
        raise ReadError(f"{name}: an array of Python objects; save numbers (numpy.save of a numeric array)")
    need = int(np.prod(shape, dtype=object)) * dtype.itemsize
    if need > size - fh.tell():
        raise ReadError(f"{name}: the header claims {shape} {dtype} values ({need:,} bytes) but only "
                        f"{size - fh.tell():,} bytes follow; the file is truncated or damaged")
    return shape, dtype


def load_npy(path, kind="NPY array"):
    """np.load of one ``.npy`` file whose header was checked first (``kind`` names it in messages)."""
    with reading(path, kind):
        with open(path, "rb") as fh:
            _npy_header(fh, path.name, os.path.getsize(path))
        return np.load(path, allow_pickle=False)


#: The ending of an archive's arrays (``np.savez`` names each ``<key>.npy``); other members are skipped.
_NPZ_MEMBER = ".npy"


def load_npz(path):
    """The arrays of a ``.npz`` archive, each member's header checked against its size first."""
    with reading(path, "NPZ archive"):
        with zipfile.ZipFile(path) as zf:
            data = {}
            for info in zf.infolist():
                if not info.filename.endswith(_NPZ_MEMBER):
                    continue
                with zf.open(info) as fh:
                    _npy_header(fh, f"{path.name} ({info.filename})", info.file_size)
                with zf.open(info) as fh:
                    data[info.filename[:-4]] = np.lib.format.read_array(fh, allow_pickle=False)
    return data


def _numeric(arr, what, path):
    arr = np.asarray(arr)
    if np.iscomplexobj(arr):
        raise SampleError(f"{path.name}: {what} holds complex numbers; pass real values (e.g. their .real or abs)")
    if not (arr.dtype == bool or np.issubdtype(arr.dtype, np.number)):
        raise ReadError(f"{path.name}: {what} is {arr.dtype}, not numbers; pass a numeric array")
    return arr.astype(np.float64)


def _read_npz(path):
    data = load_npz(path)
    if "vectors" in data and "vals" not in data:  # arrows: read as the value columns vx, vy, vz
        vec = np.asarray(data["vectors"])
        if vec.ndim != 2 or vec.shape[1] != 3:
            raise ReadError(f"{path.name}: 'vectors' has shape {vec.shape}; pass one 3-vector per sample, (k, 3)")
        data["vals"], data["names"] = vec, np.array(VECTOR_COLUMNS)
    if "vals" not in data or not ({"idx", "points"} & set(data)):
        raise ReadError(f"{path.name}: needs arrays 'vals' (or 'vectors') and 'idx' (or 'points'); found "
                        f"{sorted(data)}")
    key = "idx" if "idx" in data else "points"
    vals = _numeric(data["vals"], "'vals'", path)
    loc = _numeric(data[key], f"'{key}'", path)
    vals = vals[:, None] if vals.ndim == 1 else vals
    names = [str(s) for s in np.asarray(data["names"]).ravel()] if "names" in data else None
    want = "(k,)" if key == "idx" else "(k, 3)"
    if vals.ndim != 2 or loc.ndim != (1 if key == "idx" else 2) or len(loc) != len(vals) or (
            key == "points" and loc.shape[1] != 3):
        raise ReadError(f"{path.name}: '{key}' has shape {loc.shape} and 'vals' {vals.shape}; pass '{key}' "
                        f"as {want} and 'vals' as (k,) or (k, p) with one row per sample")
    if len(vals) == 0:
        raise ReadError(f"{path.name}: no samples (empty arrays); pass at least one")
    return ("vertex" if key == "idx" else "points"), np.column_stack([loc, vals]), names


def _read_structured_npy(path):
    arr = load_npy(path)
    if arr.dtype.names is None:
        raise ReadError(
            f"{path.name}: a plain array has no column names; save a structured array with fields "
            f"vertex (or x, y, z) and the values (vx, vy, vz for arrows), or an .npz with 'idx' (or 'points') and "
            f"'vals' (or 'vectors', (k, 3))"
        )
    header = list(arr.dtype.names)
    kind, ncoord = _split_header(header, path)
    if arr.ndim != 1:
        raise ReadError(f"{path.name}: a structured array of shape {arr.shape}; save one row per sample, shape (k,)")
    nested = [h for h in header if arr.dtype[h].shape or arr.dtype[h].names]
    if nested:
        raise ReadError(f"{path.name}: field {nested[0]!r} holds {arr.dtype[nested[0]]} per row, not one number; "
                        f"save one field per column (e.g. x, y, z apart)")
    table = np.column_stack([_numeric(arr[h], f"field {h!r}", path).ravel() for h in header])
    if len(table) == 0:
        raise ReadError(f"{path.name}: no samples (an empty array); pass at least one")
    bad = ~np.isfinite(table).all(axis=1)
    if bad.any():
        raise SampleError(f"{path.name}: NaN or infinite values in rows {np.flatnonzero(bad)[:5].tolist()}; "
                          f"remove or fix those samples")
    return kind, table, header[ncoord:]


def write_values(path: str | os.PathLike[str], values: ArrayLike, *, names: Sequence[str] | None = None) -> None:
    """Write per-vertex values as CSV (``vertex,name...``), NPY or GIfTI (``.func.gii``), atomically.

    Parameters
    ----------
    path : str or Path
        ``.csv`` or ``.npy``.
    values : (n,) or (n, p) numpy array
        One row per vertex.
    names : list of str, optional
        Column names for CSV; ``value``, ``value2``, ... by default.

    Raises
    ------
    WriteError
        Unknown extension, missing folder, names CSV cannot hold, or a failed
        write.
    """
    return lookup("values", path, writing=True).write(path, values, names)


def _value_table(values, names, fmt):
    values = np.asarray(values, dtype=np.float64)
    values = values[:, None] if values.ndim == 1 else values
    if values.ndim != 2:
        raise WriteError(f"values have shape {values.shape}; pass (n,) or (n, p) per-vertex values")
    names = field_names(names, values.shape[1])
    if fmt.text and any(("," in nm or '"' in nm or "\n" in nm or "\r" in nm) for nm in names):
        raise WriteError("a column name holds a comma, quote or line break; rename it for CSV")
    return values, names


def _write_npy_values(path, values, names):
    values, names = _value_table(values, names, _NPY_VALUES)
    with atomic_path(path) as tmp:
        try:
            with open(tmp, "wb") as fh:
                np.save(fh, values[:, 0] if values.shape[1] == 1 else values)
        except OSError as exc:
            raise WriteError(f"{Path(path).name}: could not write ({exc})") from None


def _write_csv_values(path, values, names):
    values, names = _value_table(values, names, _CSV_VALUES)
    with atomic_path(path) as tmp:
        try:
            table = np.column_stack([np.arange(len(values)), values])
            fmt = ["%d"] + ["%.17g"] * values.shape[1]
            np.savetxt(tmp, table, fmt=fmt, delimiter=",", header=",".join(["vertex", *names]), comments="",
                       encoding="utf-8")
        except OSError as exc:
            raise WriteError(f"{Path(path).name}: could not write ({exc})") from None


def _write_gifti_values(path, values, names):
    return write_gifti_data(path, values, names=names)  # one data array per field (.func.gii)


def _read_npy_samples(path, n):
    return (*_read_structured_npy(path), None)


def _read_npz_samples(path, n):
    return (*_read_npz(path), None)


def _read_csv_samples(path, n):
    return _read_csv(path)


# values (per-vertex values alone): read(path, n) -> (values (n, p) with NaN where unmeasured, names);
# write(path, values, names)
_CSV_VALUES = Format("CSV", "values", (".csv",), write=_write_csv_values, fields=True, text=True)
_NPY_VALUES = Format("NumPy array", "values", (".npy",), write=_write_npy_values)
MORPH = Format("FreeSurfer morphometry", "samples", (), _vertex_data(read_morph_data), extra="neuro")
for _fmt in (
    _CSV_VALUES, _NPY_VALUES,
    Format("GIfTI", "values", (".gii",), read_gifti_data, _write_gifti_values, fields=True, seen_by=("nibabel",),
           exact=False, extra="neuro"),  # float32, what Workbench reads
    Format("MGH", "values", (".mgh",), read_mgh_data, extra="neuro"),
    Format("MGZ", "values", (".mgz", ".mgh.gz"), partial(read_mgh_data, compressed=True), extra="neuro"),
    Format("FreeSurfer morphometry", "values", MORPH_SUFFIXES, partial(read_morph_data, named=True),
           extra="neuro"),
    # samples: read(path, n) -> (kind, table, names, CSV line numbers or None)
    Format("CSV", "samples", (".csv",), _read_csv_samples, text=True),
    Format("NumPy archive", "samples", (".npz",), _read_npz_samples, times=True, container="zip"),  # its .times.
    Format("NumPy array", "samples", (".npy",), _read_npy_samples),
    Format("GIfTI", "samples", (".gii",), _vertex_data(read_gifti_data), extra="neuro"),
    Format("MGH", "samples", (".mgh",), _vertex_data(read_mgh_data), extra="neuro"),
    Format("MGZ", "samples", (".mgz", ".mgh.gz"), _vertex_data(partial(read_mgh_data, compressed=True)),
           container="gzip", extra="neuro"),
    Format("FreeSurfer label", "samples", (".label",), _read_label, extra="neuro"),
    Format("FreeSurfer morphometry", "samples", MORPH_SUFFIXES, _vertex_data(partial(read_morph_data, named=True)),
           extra="neuro"),
):
    register_format(_fmt)

#: The formats of per-vertex values written, and of samples read (views of :mod:`manifill.io.formats`' registry).
VALUE_FORMATS = FormatView("values", writing=True)
SAMPLE_FORMATS = FormatView("samples")
