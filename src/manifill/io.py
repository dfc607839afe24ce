"""Meshes, samples and fields on disk.

Meshes go through meshio; one registry maps each file extension to its meshio
format and says whether it can hold named point data (the reconstructed fields).
Every write is atomic: the data goes to a temporary file in the target folder,
which is renamed over the target only when complete, so a failure never leaves a
truncated output behind.

Sample files
------------
CSV
    A header, then one row per sample. Either ``vertex,value[,value2...]``
    (0-based vertex indices) or ``x,y,z,value[,...]`` (positions, snapped to the
    nearest vertex). The value columns keep their header names.
NPZ
    Arrays ``idx`` (or ``points``) and ``vals`` (``(k,)`` or ``(k, p)``), and
    optionally ``names``.
NPY
    A structured array whose field names follow the CSV header rules.
"""

import csv
import os
import re
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from .errors import ReadError, SampleError, WriteError
from .samples import Samples, field_names

__all__ = ["MESH_FORMATS", "read_mesh", "write_mesh", "read_samples", "write_values"]

#: extension -> (meshio format name, can hold point data)
MESH_FORMATS = {
    ".off": ("off", False),
    ".obj": ("obj", False),
    ".ply": ("ply", True),
    ".stl": ("stl", False),
    ".vtk": ("vtk", True),
    ".vtu": ("vtu", True),
}

VALUE_FORMATS = (".csv", ".npy")
SAMPLE_FORMATS = (".csv", ".npz", ".npy")
_VERTEX_COLUMNS = ("vertex", "idx", "index", "vertex_id", "id")


def _suffix(path, allowed, what):
    ext = Path(path).suffix.lower()
    if ext not in allowed:
        raise (WriteError if what.startswith("write") else ReadError)(
            f"{Path(path).name}: cannot {what} '{ext or '(no extension)'}' files; use one of {', '.join(allowed)}"
        )
    return ext


@contextmanager
def atomic_path(path):
    """A temporary path beside ``path`` that replaces it on success.

    Parameters
    ----------
    path : str or Path
        Final destination.

    Yields
    ------
    Path
        Where to write; renamed to ``path`` when the block completes, removed
        if it raises.

    Raises
    ------
    WriteError
        If the destination folder does not exist.
    """
    path = Path(path)
    if not path.parent.is_dir():
        raise WriteError(f"folder {path.parent} does not exist; create it first or choose another output path")
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp{path.suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def read_mesh(path):
    """Read a triangle mesh (OFF, OBJ, PLY, STL, VTK, VTU).

    Quads are split into two triangles; other cell types are ignored.

    Parameters
    ----------
    path : str or Path
        The file; its extension selects the format.

    Returns
    -------
    V : (n, 3) float64 numpy array
    F : (m, 3) int64 numpy array

    Raises
    ------
    ReadError
        A missing file, an unknown extension, a file meshio cannot parse, or
        a file without triangles or quads.
    """
    path = Path(path)
    ext = _suffix(path, tuple(MESH_FORMATS), "read")
    if not path.is_file():
        raise ReadError(f"{path}: no such file")
    if ext == ".off":
        _check_off_header(path)
    mesh = _meshio_read(path, ext, MESH_FORMATS[ext][0])
    faces = []
    for block in mesh.cells:
        if block.type == "triangle":
            faces.append(block.data)
        elif block.type == "quad":
            q = block.data
            faces.append(np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]]))
    if not faces:
        kinds = ", ".join(sorted({b.type for b in mesh.cells})) or "none"
        raise ReadError(f"{path.name}: holds no triangles (cells found: {kinds}); pass a surface mesh")
    V = np.asarray(mesh.points, dtype=np.float64)
    if V.ndim == 2 and V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    return V, np.concatenate(faces).astype(np.int64)


def _meshio_read(path, ext, fmt):
    """meshio's reader of one format, with its failures as one-line :class:`ReadError`."""
    import meshio

    try:
        return getattr(meshio, fmt).read(str(path))  # not meshio.read: it sys.exit()s on bad files
    except (meshio.ReadError, ValueError, KeyError, IndexError, TypeError, OSError, UnicodeDecodeError) as exc:
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ReadError(f"{path.name}: not a readable {ext[1:].upper()} mesh ({msg}); check the file") from None


def _check_off_header(path):
    """Reject an OFF file without its counts line (meshio's reader would never return)."""
    words = []
    try:
        with open(path, "rb") as fh:
            for raw in fh:
                line = raw.split(b"#")[0].strip()
                if line:
                    words.extend(line.split())
                if len(words) >= 4:
                    break
    except OSError as exc:
        raise ReadError(f"{path.name}: could not read ({exc})") from None
    ok = len(words) >= 4 and words[0].endswith(b"OFF")
    if ok:
        try:
            [int(w) for w in words[1:4]]
        except ValueError:
            ok = False
    if not ok:
        raise ReadError(f"{path.name}: not a readable OFF mesh (no 'OFF' line followed by vertex, face "
                        f"and edge counts); check the file")


def write_mesh(path, V, F, point_data=None):
    """Write a triangle mesh with named per-vertex fields, atomically.

    Parameters
    ----------
    path : str or Path
        Destination; the extension selects the format. Fields need PLY, VTK
        or VTU.
    V : (n, 3) numpy array
        Vertex positions.
    F : (m, 3) numpy array of int
        Triangles.
    point_data : dict of str to (n,) or (n, p) numpy array, optional
        Named fields. A ``(n, p)`` field is written as one ``p``-component
        array in VTU, and in VTK when ``p`` is 3; otherwise (PLY, and VTK with
        ``p`` other than 3) as ``p`` scalar fields ``name_0 ... name_{p-1}``.
        Integer and boolean fields (labels, masks) keep an integer type. PLY
        property names must be plain words distinct from the coordinates, so
        there other characters become ``_`` and ``x``, ``y``, ``z`` (or a
        repeated name) get a ``field_`` prefix.

    Returns
    -------
    dict of str to str
        The name each field was written under (differs from the given name
        only for PLY, as above).

    Raises
    ------
    WriteError
        Unknown extension, fields for a format that cannot hold them, a
        missing folder, or a failure while writing (nothing is left behind).
    """
    import meshio

    ext = _suffix(path, tuple(MESH_FORMATS), "write")
    fmt, has_fields = MESH_FORMATS[ext]
    point_data = dict(point_data or {})
    if point_data and not has_fields:
        raise WriteError(
            f"{Path(path).name}: {ext[1:].upper()} cannot store per-vertex fields; write .ply, .vtu or .vtk "
            f"(or the values alone as .csv/.npy)"
        )
    from .errors import ManifillError
    from .validate import as_mesh

    try:
        V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    except ManifillError as exc:
        raise WriteError(f"{Path(path).name}: not written, the mesh is malformed: {exc}") from None
    out, written = {}, {}
    n = len(V)
    for name, arr in point_data.items():
        arr = np.asarray(arr)
        if arr.ndim not in (1, 2):
            raise WriteError(f"field {name!r} has shape {arr.shape}; pass (n,) or (n, p) per-vertex values")
        if arr.dtype == bool:
            arr = arr.astype(np.uint8)
        elif np.issubdtype(arr.dtype, np.integer):
            arr = arr.astype(np.int32)
        else:
            arr = arr.astype(np.float64)
        if arr.shape[0] != n:
            raise WriteError(f"field {name!r} has {arr.shape[0]} values for {n} vertices; pass one per vertex")
        key = _ply_name(name, out) if fmt == "ply" else str(name)
        written[name] = key
        if arr.ndim == 2 and (fmt == "ply" or (fmt == "vtk" and arr.shape[1] != 3)):
            for j in range(arr.shape[1]):
                out[f"{key}_{j}"] = np.ascontiguousarray(arr[:, j])
        else:
            out[key] = arr
    mesh = meshio.Mesh(np.asarray(V, dtype=np.float64), [("triangle", np.asarray(F, dtype=np.int32))], point_data=out)
    with atomic_path(path) as tmp:
        try:
            meshio.write(tmp, mesh, file_format=fmt)
        except (meshio.WriteError, ValueError, KeyError, TypeError, OSError) as exc:
            raise WriteError(f"{Path(path).name}: could not write ({exc}); check the path and the fields") from None
    return written


def _ply_name(name, taken):
    """A PLY property name for ``name``: a plain word, not a coordinate, not taken."""
    key = re.sub(r"\W", "_", str(name)) or "field"
    if key in ("x", "y", "z") or key[0].isdigit():
        key = f"field_{key}"
    while key in taken:
        key = f"field_{key}"
    return key


def _split_header(header, path):
    cols = [h.strip().lower() for h in header]
    if len(cols) >= 2 and cols[0] in _VERTEX_COLUMNS:
        return "vertex", 1
    if len(cols) >= 4 and cols[:3] == ["x", "y", "z"]:
        return "points", 3
    raise ReadError(
        f"{Path(path).name}: header {','.join(header)!r} is neither 'vertex,value[,...]' nor "
        f"'x,y,z,value[,...]'; add such a header line"
    )


def read_samples(path, V, *, duplicates="error", max_distance=None):
    """Read samples from CSV, NPZ or NPY, snapping positions to vertices.

    Parameters
    ----------
    path : str or Path
        The file (see the module docstring for the layouts).
    V : (n, 3) numpy array
        Vertex positions of the mesh the samples belong to.
    duplicates : {'error', 'mean'}, optional
        Several samples on one vertex with different values: raise, or average.
    max_distance : float, optional
        Largest accepted snap distance for positions (see
        :func:`manifill.samples.snap_to_vertices`).

    Returns
    -------
    Samples
        Unique vertex indices, values, field names and snap distances.

    Raises
    ------
    ReadError
        Missing file, unknown extension, bad header, non-numeric cells (the
        line and column are named).
    SampleError
        Out-of-range indices, NaN values, far-away positions ("wrong units?"),
        conflicting duplicates.
    """
    path = Path(path)
    ext = _suffix(path, SAMPLE_FORMATS, "read")
    if not path.is_file():
        raise ReadError(f"{path}: no such file")
    if ext == ".csv":
        kind, table, names = _read_csv(path)
    elif ext == ".npz":
        kind, table, names = _read_npz(path)
    else:
        kind, table, names = _read_structured_npy(path)
    if kind == "vertex":
        col = table[:, 0]
        if np.any(np.abs(col) >= 2.0**62):
            row = int(np.flatnonzero(np.abs(col) >= 2.0**62)[0])
            raise ReadError(f"{path.name}: vertex index {col[row]:g} in data row {row + 1} is far too large")
        if not np.all(col == np.round(col)):
            row = int(np.flatnonzero(col != np.round(col))[0])
            raise ReadError(f"{path.name}: vertex index {col[row]:g} in data row {row + 1} is not an integer")
        return Samples.from_indices(col.astype(np.int64), table[:, 1:], len(V), names=names, duplicates=duplicates)
    return Samples.from_points(V, table[:, :3], table[:, 3:], names=names, duplicates=duplicates,
                               max_distance=max_distance)


def _read_csv(path):
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            reader = csv.reader(fh)
            rows, lineno = [], []
            for r in reader:
                if r and any(c.strip() for c in r):
                    rows.append(r)
                    lineno.append(reader.line_num)
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise ReadError(f"{path.name}: could not read as CSV ({exc})") from None
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
                    f"{path.name}: line {lineno[i + 1]}, column {header[j].strip()!r}: {cell!r} is not a number"
                ) from None
    bad = ~np.isfinite(table).all(axis=1)
    if bad.any():
        lines = ", ".join(str(lineno[int(r) + 1]) for r in np.flatnonzero(bad)[:5])
        raise SampleError(f"{path.name}: NaN or infinite values on lines {lines}; remove or fix those samples")
    return kind, table, [h.strip() for h in header[ncoord:]]


def _read_npz(path):
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError):
        raise ReadError(f"{path.name}: not a readable .npz archive; save it with numpy.savez") from None
    if "vals" not in data or not ({"idx", "points"} & set(data)):
        raise ReadError(f"{path.name}: needs arrays 'vals' and 'idx' (or 'points'); found {sorted(data)}")
    try:
        vals = np.asarray(data["vals"], dtype=np.float64)
        key = "idx" if "idx" in data else "points"
        loc = np.asarray(data[key], dtype=np.float64)
    except (TypeError, ValueError):
        raise ReadError(f"{path.name}: 'vals' and '{key}' must be numeric arrays") from None
    vals = vals[:, None] if vals.ndim == 1 else vals
    names = [str(s) for s in data["names"]] if "names" in data else None
    want = "(k,)" if key == "idx" else "(k, 3)"
    if vals.ndim != 2 or loc.ndim != (1 if key == "idx" else 2) or len(loc) != len(vals) or (
            key == "points" and loc.shape[1] != 3):
        raise ReadError(f"{path.name}: '{key}' has shape {loc.shape} and 'vals' {vals.shape}; pass '{key}' "
                        f"as {want} and 'vals' as (k,) or (k, p) with one row per sample")
    return ("vertex" if key == "idx" else "points"), np.column_stack([loc, vals]), names


def _read_structured_npy(path):
    try:
        arr = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError):
        raise ReadError(f"{path.name}: not a readable .npy array; save it with numpy.save") from None
    if arr.dtype.names is None:
        raise ReadError(
            f"{path.name}: a plain array has no column names; save a structured array with fields "
            f"vertex (or x, y, z) and the values, or an .npz with 'idx' (or 'points') and 'vals'"
        )
    header = list(arr.dtype.names)
    kind, ncoord = _split_header(header, path)
    try:
        table = np.column_stack([np.asarray(arr[h], dtype=np.float64).ravel() for h in header])
    except (TypeError, ValueError):
        raise ReadError(f"{path.name}: every field of the array must be numeric") from None
    return kind, table, header[ncoord:]


def write_values(path, values, names=None):
    """Write per-vertex values as CSV (``vertex,name...``) or NPY, atomically.

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
        Unknown extension, missing folder or a failed write.
    """
    ext = _suffix(path, VALUE_FORMATS, "write")
    values = np.asarray(values, dtype=np.float64)
    values = values[:, None] if values.ndim == 1 else values
    if values.ndim != 2:
        raise WriteError(f"values have shape {values.shape}; pass (n,) or (n, p) per-vertex values")
    names = field_names(names, values.shape[1])
    if ext == ".csv" and any(("," in nm or '"' in nm or "\n" in nm) for nm in names):
        raise WriteError("a column name holds a comma, quote or line break; rename it for CSV")
    with atomic_path(path) as tmp:
        try:
            if ext == ".npy":
                with open(tmp, "wb") as fh:
                    np.save(fh, values[:, 0] if values.shape[1] == 1 else values)
            else:
                table = np.column_stack([np.arange(len(values)), values])
                fmt = ["%d"] + ["%.17g"] * values.shape[1]
                np.savetxt(tmp, table, fmt=fmt, delimiter=",", header=",".join(["vertex", *names]), comments="")
        except OSError as exc:
            raise WriteError(f"{Path(path).name}: could not write ({exc})") from None
