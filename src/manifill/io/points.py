"""Point clouds in text files: ``.xyz`` (x y z per line) and ``.csv`` (columns ``x, y, z``); barrier lines.

A scan exported as text has one point per line: ``.xyz`` as three (or more) numbers separated by spaces,
tabs or commas, ``#`` starting a comment (columns after the third -- normals, colours -- are ignored);
``.csv`` with a header naming ``x``, ``y`` and ``z`` (other numeric columns are kept as per-point fields),
or no header and the coordinates first. Each malformed line is named. Point clouds in mesh formats
(a PLY or VTP with vertices and no faces) are read by the mesh readers (:class:`manifill.io.files.PointsOnly`).

Barriers (:func:`read_barriers`, ``--barriers FILE``): a ``.txt`` or ``.csv`` with one polyline of vertex
indices per line; a ``.csv`` whose header names ``x, y, z`` (and ``barrier``, the polyline each row is on) for
polylines of positions; or an ``.npy`` of per-face integer labels.
"""

import csv
import re
from pathlib import Path

import numpy as np

from ..errors import ReadError
from .files import is_number
from .formats import Format, FormatView, find_format, register_format, suffix_list
from .samples import load_npy

__all__ = ["read_xyz", "read_csv_points", "read_barriers", "BARRIER_FORMATS"]

#: What ``--barriers`` reads.

_SPLIT = re.compile(r"[\s,;]+")


def _text_lines(path):
    try:
        with open(path, encoding="utf-8-sig") as fh:
            return fh.read().splitlines()
    except UnicodeDecodeError as exc:
        raise ReadError(f"{Path(path).name}: could not read as text (byte 0x{exc.object[exc.start]:02x}, which is "
                        f"not UTF-8); export the points as text, one 'x y z' per line") from None


def _numbers(path, lineno, cells, first):
    try:
        return [float(c) for c in cells]
    except ValueError:
        bad = next(c for c in cells if not is_number(c))
        raise ReadError(f"{Path(path).name}: line {lineno}: {bad!r} is not a number; the file holds one point per "
                        f"line ({first})") from None


def _checked(path, P):
    if len(P) == 0:
        raise ReadError(f"{Path(path).name}: no points; the file holds one point per line ('x y z')")
    bad = np.flatnonzero(~np.isfinite(P).all(axis=1))
    if bad.size:
        raise ReadError(f"{Path(path).name}: point {int(bad[0])} has a NaN or infinite coordinate; fix or remove it")
    return P


def read_xyz(path):
    """``(P, {})``: the points of an ``.xyz`` file (the first three numbers of every line that is not a comment).

    Raises
    ------
    ReadError
        Undecodable text, a line with fewer than three numbers or with a word where a number belongs, no point.

    Examples
    --------
    >>> import os, tempfile
    >>> f = os.path.join(tempfile.mkdtemp(), "p.xyz")
    >>> _ = open(f, "w").write("# scan\\n0 0 0\\n1,0,0 0.1 0.2 0.9\\n0\\t1\\t0\\n")
    >>> read_xyz(f)[0].tolist()
    [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    """
    rows = []
    for lineno, line in enumerate(_text_lines(path), start=1):
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        cells = [c for c in _SPLIT.split(text) if c]
        if len(cells) < 3:
            raise ReadError(f"{Path(path).name}: line {lineno} holds {len(cells)} value(s) where a point needs 3 "
                            f"('x y z'); fix the line or remove it")
        rows.append(_numbers(path, lineno, cells[:3], "'x y z'"))
    return _checked(path, np.asarray(rows, dtype=np.float64).reshape(-1, 3)), {}


def read_csv_points(path):
    """``(P, fields)``: the points of a ``.csv`` file and its other numeric columns as per-point fields.

    The header names the coordinate columns ``x``, ``y``, ``z`` (any case); without a header, the first three
    columns are the coordinates.

    Raises
    ------
    ReadError
        As :func:`read_xyz`; a header without ``x``, ``y`` and ``z``; rows of different lengths.

    Examples
    --------
    >>> import os, tempfile
    >>> f = os.path.join(tempfile.mkdtemp(), "p.csv")
    >>> _ = open(f, "w").write("z,x,y,t\\n1,0,0,5\\n0,1,0,6\\n")
    >>> P, fields = read_csv_points(f)
    >>> P.tolist(), fields["t"].tolist()
    ([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]], [5.0, 6.0])
    """
    name = Path(path).name
    try:
        rows = [(i, r) for i, r in enumerate(csv.reader(_text_lines(path)), start=1) if any(c.strip() for c in r)]
    except csv.Error as exc:
        raise ReadError(f"{name}: could not read as CSV ({exc}); save it as UTF-8 text") from None
    if not rows:
        raise ReadError(f"{name}: no points; the file holds a header 'x,y,z' and one point per line")
    header = [c.strip().lower() for c in rows[0][1]]
    if all(is_number(c) for c in header):
        cols, names, body = [0, 1, 2], [], rows
        width = len(header)
    else:
        if not {"x", "y", "z"} <= set(header):
            raise ReadError(f"{name}: the header ({', '.join(header)}) does not name columns x, y and z; name the "
                            f"coordinate columns so, or write the points as .xyz")
        cols = [header.index(c) for c in "xyz"]
        names = [(j, rows[0][1][j].strip()) for j in range(len(header)) if j not in cols]
        body, width = rows[1:], len(header)
    table = []
    for lineno, row in body:
        if len(row) != width or width < 3:
            raise ReadError(f"{name}: line {lineno} has {len(row)} fields where {max(width, 3)} belong; fix the line")
        table.append(_numbers(path, lineno, [c.strip() for c in row], "'x,y,z' and numbers"))
    T = np.asarray(table, dtype=np.float64).reshape(-1, width)
    return _checked(path, T[:, cols]), {label: T[:, j] for j, label in names}


def read_barriers(path):
    """The ``barriers=`` of :func:`manifill.reconstruct` from a file (see the module docstring).

    Raises
    ------
    ReadError
        An unknown extension, a word where a vertex index belongs, a negative or fractional index, an ``.npy``
        that is not one row of integers, no barrier.

    Examples
    --------
    >>> import os, tempfile
    >>> f = os.path.join(tempfile.mkdtemp(), "b.txt")
    >>> _ = open(f, "w").write("# two walls\\n0 1 2 3\\n10, 11\\n")
    >>> [p.tolist() for p in read_barriers(f)]
    [[0, 1, 2, 3], [10, 11]]
    """
    path = Path(path)
    fmt = find_format("barriers", path)
    if fmt is None:
        ext = path.suffix.lower()
        raise ReadError(f"{path.name}: barriers are read from {suffix_list('barriers')} files, not "
                        f"'{ext or '(none)'}'; write one polyline of vertex indices per line (.txt)")
    return fmt.read(path)


def _read_face_labels(path):
    labels = load_npy(path, "NPY file of per-face labels")
    if labels.ndim != 1 or labels.dtype.kind not in "iub":
        raise ReadError(f"{path.name}: holds {labels.dtype} of shape {labels.shape}; barriers as .npy are per-face "
                        f"integer labels, one per face")
    return labels.astype(np.int64)


def _read_barrier_points(path):
    """A CSV of ``x,y,z[,barrier]`` points (snapped later), else vertex paths as in a .txt."""
    lines = _text_lines(path)
    first = next((ln for ln in lines if ln.split("#", 1)[0].strip()), "")
    if {"x", "y", "z"} <= {c.strip().lower() for c in first.split(",")}:
        P, fields = read_csv_points(path)
        which = fields.get(next((k for k in fields if k.strip().lower() == "barrier"), None), np.zeros(len(P)))
        return [P[which == b] for b in np.unique(which)]
    return _read_vertex_paths(path, lines)


def _read_vertex_paths(path, lines=None):
    """One polyline of vertex indices per line (``#`` starts a comment)."""
    name = path.name
    lines = _text_lines(path) if lines is None else lines
    paths = []
    for lineno, line in enumerate(lines, start=1):
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        cells = [c for c in _SPLIT.split(text) if c]
        nums = _numbers(path, lineno, cells, "vertex indices")
        bad = [v for v in nums if not (0 <= v < 2**62 and v == int(v))]
        if bad:
            raise ReadError(f"{name}: line {lineno} holds {bad[0]!r}, not a vertex index (a whole number >= 0); fix "
                            f"the line")
        paths.append(np.asarray(nums, dtype=np.int64))
    if not paths:
        raise ReadError(f"{name}: no barrier; write one polyline of vertex indices per line")
    return paths


# barriers: read(path) -> a list of vertex paths or of point arrays, or per-face labels
for _fmt in (
    Format("text of vertex paths", "barriers", (".txt",), _read_vertex_paths),
    Format("CSV of points or vertex paths", "barriers", (".csv",), _read_barrier_points, text=True),
    Format("NumPy per-face labels", "barriers", (".npy",), _read_face_labels),
):
    register_format(_fmt)

#: The formats barriers are read from (a view of :mod:`manifill.io.formats`' registry).
BARRIER_FORMATS = FormatView("barriers")
