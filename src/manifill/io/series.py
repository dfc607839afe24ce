"""Samples in time: one set of sample places, a value at each of ``T`` time steps.

:func:`read_series` reads three layouts into a :class:`SampleSeries` (values ``(k, T)``,
times ``(T,)``):

Wide
    Anything :func:`~manifill.io.samples.read_samples` reads, each value column one
    time step: CSV ``vertex,v1,v2,...`` or ``x,y,z,v1,...``; NPZ ``idx`` (or ``points``)
    with ``vals`` ``(k, T)`` and optionally ``times`` ``(T,)``; a structured NPY; a GIfTI
    file of many arrays. The times are NPZ's ``times``, else the value columns' names
    when every one is a distinct number (``vertex,0.5,1.0,1.5``), else ``0 .. T-1``.
Long
    A CSV whose first value column is ``time``: ``vertex,time,value`` or
    ``x,y,z,time,value``, one row per (sample, time) in any order. Every sample must
    have exactly one row at every time.
Per-time files
    A glob pattern (``'samples_*.csv'``) or a folder: each file one time step, all with
    the same columns and the same samples (in any row order), one value column each.
    The times are the last number in each file name (``day_0.5.csv`` -> 0.5) when every
    name has one and they differ; otherwise the files in name order, at ``0 .. T-1``.

Columns are sorted by time. A reconstruction's ``(n, T)`` values are written by
:mod:`manifill.io.series_write` in the formats of :data:`SERIES_FORMATS` (``.xdmf``,
``.pvd``, ``.npy``, ``.h5``) and read back by :func:`read_series_values`.

Examples
--------
>>> import os, tempfile
>>> from manifill.mesh.shapes import icosphere
>>> V, F = icosphere(1)
>>> path = os.path.join(tempfile.mkdtemp(), "long.csv")
>>> with open(path, "w") as fh:
...     _ = fh.write("vertex,time,temp\\n3,1.5,20\\n0,0.5,11\\n3,0.5,21\\n0,1.5,10\\n")
>>> s = read_series(path, V)
>>> s.samples.idx.tolist(), s.times.tolist(), s.vals.tolist(), s.names
([0, 3], [0.5, 1.5], [[11.0, 10.0], [21.0, 20.0]], ['temp'])
"""

import glob
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ReadError, SampleError, WriteError
from ..surface.samples import Samples
from .files import check_input_file
from .formats import FormatView, find_format, lookup
from .samples import SAMPLE_FORMATS, SampleTable, load_npz, read_sample_table, samples_from_table

__all__ = ["SampleSeries", "read_series", "TIME_COLUMNS", "SERIES_FORMATS", "series_only", "need_h5py",
           "read_series_values"]

#: names of the time column of a long CSV (any case); not ``t``, which is a common field name
TIME_COLUMNS = ("time",)
_NUMBER = re.compile(r"\d+(?:\.\d+)?")


#: The formats of a field over time (a view of :mod:`manifill.io.formats`' registry; registered by
#: :mod:`manifill.io.series_write`, which holds their writers): read(path, name) -> (times, values)
SERIES_FORMATS = FormatView("series")


def series_only(path):
    """Whether ``path`` is written only as a time series (``.xdmf``, ``.pvd``, ``.h5``), not as one result's
    values (``.npy``, ``.gii`` are both)."""
    return find_format("series", path, writing=True) is not None and find_format("values", path, writing=True) is None


def need_h5py(path, error=WriteError):
    """h5py, or one line naming the ``[series]`` extra and ``.pvd`` (``error``: WriteError or ReadError)."""
    try:
        import h5py
    except ImportError:
        verb = "writing" if error is WriteError else "reading"
        raise error(f"{Path(path).name}: {verb} '{Path(path).suffix.lower()}' needs h5py, the [series] extra (pip "
                    f"install 'manifill[series]'); or use .pvd, which needs nothing more") from None
    return h5py


@dataclass
class SampleSeries:
    """Samples with a value at each of ``T`` time steps.

    Attributes
    ----------
    samples : Samples
        Sample vertices (and positions) as :func:`~manifill.io.samples.read_samples`
        gives them; ``samples.vals`` is ``(k, T)``, one column per time step, and
        ``samples.names`` one label per step (the column's name, or the time).
    times : (T,) float64 numpy array
        Strictly increasing.
    names : list of str
        The field's name (one): the long CSV's value column, the per-time files'
        value column, ``'value'`` for a wide file.
    files : list of Path
        The file read, or the per-time files in time order.
    times_from : str
        Where the times came from, in words (``"the value columns' names"``, ``"the file's 'times'"``,
        ``"the step numbers"``, ``"the 'time' column"``, ``"the file names"``), for the user to check.
    """

    samples: Samples
    times: np.ndarray
    names: list = field(default_factory=lambda: ["value"])
    files: list = field(default_factory=list)
    times_from: str = "the step numbers"

    @property
    def vals(self):
        """(k, T) float64 numpy array: the values, one column per time step."""
        return self.samples.vals

    @property
    def steps(self):
        """int: the number of time steps ``T``."""
        return len(self.times)


def read_series(path, V, *, duplicates="error", max_distance=None, vertex_numbering=None, snap_to=None,
                keep_points=False):
    """Read samples with values at many time steps (wide, long or per-time files; see the module docstring).

    Parameters
    ----------
    path : str or Path
        A sample file, a folder of per-time files, or a glob pattern matching them.
    V : (n, 3) numpy array
        Vertex positions of the mesh.
    duplicates, max_distance, vertex_numbering, snap_to, keep_points
        As :func:`manifill.io.samples.read_samples` (applied to all steps at once:
        samples snapped onto one vertex merge in every column).

    Returns
    -------
    SampleSeries

    Raises
    ------
    ReadError
        As :func:`~manifill.io.samples.read_samples`; a long CSV without a value
        column or with several; per-time files with different columns, or with
        several value columns; a pattern or folder without sample files.
    SampleError
        As :func:`~manifill.io.samples.read_samples`; a (sample, time) pair missing
        or given twice in a long CSV; per-time files with different samples;
        NPZ ``times`` of the wrong length, not finite, or repeated.
    """
    opts = dict(duplicates=duplicates, max_distance=max_distance, vertex_numbering=vertex_numbering,
                snap_to=snap_to, keep_points=keep_points)
    text = str(path)
    path = Path(path)
    if path.is_dir():
        return _read_files(_folder_files(path), path, V, opts)
    if not path.exists() and any(c in text for c in "*?["):
        return _read_files(sorted(Path(p) for p in glob.glob(text) if Path(p).is_file()), path, V, opts)
    tab = read_sample_table(path, len(V))
    if tab.names and tab.names[0].strip().lower() in TIME_COLUMNS:
        return _read_long(path, V, tab, opts)
    return _read_wide(path, V, tab, opts)


def _ncoord(tab):
    return 1 if tab.kind == "vertex" else 3


def _row(tab, r):
    """Where row ``r`` of a table is, for a message: its CSV line, else its data row (1-based)."""
    return f"line {int(tab.lines[r])}" if tab.lines is not None else f"data row {r + 1}"


def _sample(kind, key):
    if kind == "vertex":
        return f"vertex {key[0]:.17g}"
    return "the sample at (" + ", ".join(f"{c:.9g}" for c in key) + ")"


def _times_from_names(names):
    """The value columns' names as times, if every one is a distinct number (else None)."""
    try:
        t = np.array([float(s) for s in names])
    except (TypeError, ValueError):
        return None
    return t if np.isfinite(t).all() and len(np.unique(t)) == len(t) else None


def _read_wide(path, V, tab, opts):
    nc = _ncoord(tab)
    vals = tab.table[:, nc:]
    T = vals.shape[1]
    times, source = None, "the step numbers"
    fmt = find_format("samples", path)
    if fmt is not None and fmt.times:  # a NumPy archive's 'times'
        times = load_npz(path).get("times")
        if times is not None:
            times, source = _npz_times(path, times, T), "the file's 'times'"
    if times is None and tab.names is not None:
        times = _times_from_names(tab.names)
        source = source if times is None else "the value columns' names"
    if times is None:
        times = np.arange(T, dtype=np.float64)
    order = np.argsort(times, kind="stable")
    labels = [str(s) for s in (tab.names if tab.names is not None else [repr(float(t)) for t in times])]
    table = SampleTable(tab.kind, np.column_stack([tab.table[:, :nc], vals[:, order]]),
                        [labels[j] for j in order], tab.lines)
    S = samples_from_table(path, V, table, **opts)
    return SampleSeries(S, times[order], ["value"], [path], source)


def _npz_times(path, times, T):
    t = np.asarray(times)
    if not (t.dtype == bool or np.issubdtype(t.dtype, np.number)) or np.iscomplexobj(t):
        raise ReadError(f"{path.name}: 'times' is {t.dtype}, not real numbers; store the times as floats")
    t = t.astype(np.float64).ravel()
    if t.size != T:
        raise SampleError(f"{path.name}: 'times' has {t.size} entries for {T} value columns; store one time per "
                          f"column of 'vals'")
    if not np.isfinite(t).all():
        raise SampleError(f"{path.name}: 'times' holds NaN or infinite entries; store finite times")
    u, counts = np.unique(t, return_counts=True)
    if (counts > 1).any():
        raise SampleError(f"{path.name}: 'times' holds {u[counts > 1][0]:.17g} twice; give every column its own "
                          f"time")
    return t


def _read_long(path, V, tab, opts):
    nc = _ncoord(tab)
    head = ",".join((["vertex"] if nc == 1 else ["x", "y", "z"]) + list(tab.names))
    if len(tab.names) != 2:
        what = "no value column" if len(tab.names) < 2 else f"{len(tab.names) - 1} value columns"
        raise ReadError(f"{path.name}: header {head!r} has a time column and {what}; a long file holds exactly "
                        f"one value column after the time (one file per field)")
    keys, t, values = tab.table[:, :nc], tab.table[:, nc], tab.table[:, nc + 1]
    ukeys, kinv = np.unique(keys, axis=0, return_inverse=True)
    times, tinv = np.unique(t, return_inverse=True)
    k, T = len(ukeys), len(times)
    cell = kinv.ravel() * T + tinv
    order = np.argsort(cell, kind="stable")
    twice = np.flatnonzero(cell[order][1:] == cell[order][:-1])
    if twice.size:
        a, b = sorted(order[twice[0]:twice[0] + 2])
        raise SampleError(f"{path.name}: {_row(tab, a)} and {_row(tab, b)} both give {_sample(tab.kind, keys[a])} "
                          f"at time {t[a]:.17g}; remove one of them")
    if cell.size != k * T:
        filled = np.zeros(k * T, dtype=bool)
        filled[cell] = True
        c = int(np.flatnonzero(~filled)[0])
        raise SampleError(f"{path.name}: {_sample(tab.kind, ukeys[c // T])} has no row at time "
                          f"{times[c % T]:.17g} (the file has {T} times); every sample needs one row at every "
                          f"time: add it or remove the sample")
    vals = np.empty(k * T)
    vals[cell] = values
    table = SampleTable(tab.kind, np.column_stack([ukeys, vals.reshape(k, T)]), [repr(float(x)) for x in times])
    S = samples_from_table(path, V, table, **opts)
    return SampleSeries(S, times.astype(np.float64), [tab.names[1]], [path], "the 'time' column")


def _folder_files(folder):
    files = sorted(p for p in folder.iterdir() if p.is_file() and not p.name.startswith(".")
                   and find_format("samples", p) is not None)
    if not files:
        raise ReadError(f"{folder}: a folder without sample files ({', '.join(SAMPLE_FORMATS)}); put one file per "
                        f"time step in it")
    return files


def _file_times(files):
    """The per-time files in time order and their times (numbers in the names, else name order)."""
    found = [_NUMBER.findall(p.stem) for p in files]
    if all(found):
        t = np.array([float(f[-1]) for f in found])
        if len(np.unique(t)) == len(t):
            order = np.argsort(t, kind="stable")
            return [files[j] for j in order], t[order]
    return list(files), np.arange(len(files), dtype=np.float64)


def _read_files(files, pattern, V, opts):
    if not files:
        raise ReadError(f"{pattern}: no file matches this pattern; check the folder and the '*'")
    files, times = _file_times(files)
    first, ref, keys, cols = None, None, None, []
    for p in files:
        tab = read_sample_table(p, len(V))
        nc = _ncoord(tab)
        head = (["vertex"] if nc == 1 else ["x", "y", "z"]) + list(tab.names or [])
        if first is None:
            first, ref = p, head
            if len(tab.names or []) != 1:
                raise ReadError(f"{p.name}: {len(tab.names or [])} value columns ({', '.join(tab.names or [])}); "
                                f"per-time files hold one value column each (one set of files per field)")
        elif tab.kind != ("vertex" if len(ref) == 2 else "points") or [h.lower() for h in head] != \
                [h.lower() for h in ref]:
            raise ReadError(f"{p.name}: columns {','.join(head)!r} differ from {first.name}'s {','.join(ref)!r}; "
                            f"give every per-time file the same columns")
        order = np.lexsort(tab.table[:, :nc].T[::-1])
        rows = tab.table[order]
        if keys is None:
            keys = rows[:, :nc]
        elif rows.shape[0] != keys.shape[0] or not np.array_equal(rows[:, :nc], keys):
            raise SampleError(f"{p.name}: {_difference(keys, rows[:, :nc], tab.kind, first.name)}; every "
                              f"per-time file must hold the same samples")
        cols.append(rows[:, nc])
    labels = [repr(float(x)) for x in times]
    table = SampleTable("vertex" if len(ref) == 2 else "points", np.column_stack([keys] + cols), labels)
    S = samples_from_table(first, V, table, **opts)
    return SampleSeries(S, times, [ref[-1]], files, "the file names")


def _difference(keys, other, kind, first):
    """Which sample one per-time file has that the other lacks, in words."""
    a = {tuple(r) for r in keys.tolist()}
    b = {tuple(r) for r in other.tolist()}
    if a - b:
        return f"{_sample(kind, min(a - b))} of {first} is not in it"
    if b - a:
        return f"{_sample(kind, min(b - a))} is not in {first}"
    return f"it has {len(other)} rows for {first}'s {len(keys)} (a sample repeats)"


def read_series_values(path, *, name=None):
    """Read a field in time back from a file :class:`SeriesWriter` wrote (or any of its four formats).

    Parameters
    ----------
    path : str or Path
        ``.xdmf``, ``.pvd``, ``.npy``, ``.h5`` or ``.hdf5``.
    name : str, optional
        The field; by default the ``.h5`` file's ``field`` attribute, else the
        first point array of each step.

    Returns
    -------
    times : (T,) float64 numpy array
        ``0 .. T-1`` for ``.npy``.
    values : (n, T) float64 numpy array

    Raises
    ------
    ReadError
        A missing or damaged file, an unknown extension, a field not in the
        file, or steps of different sizes.
    """
    path = Path(path)
    fmt = lookup("series", path)
    check_input_file(path)
    return fmt.read(path, name)
