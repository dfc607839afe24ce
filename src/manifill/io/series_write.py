"""Writing a field in time, ``(n, T)`` values, chunk of time steps after chunk, with flat memory.

:class:`SeriesWriter` takes the values a few columns (time steps) at a time and
never keeps them; the format is the extension (:data:`manifill.io.series.SERIES_FORMATS`):

``.xdmf``
    XDMF 3 with its arrays in ``<stem>.h5`` beside it (h5py: the ``[series]``
    extra): the mesh once (in the first step), one grid per time step, the field
    and the static fields as point data of every step (each static array stored
    once). meshio's ``TimeSeriesReader``, ParaView and pyvista's ``XdmfReader`` read it.
``.pvd``
    ParaView's collection of VTU files: ``<stem>.pvd`` and a folder ``<stem>/``
    beside it holding ``<stem>_000000.vtu``, ``<stem>_000001.vtu``, ..., each the
    mesh with the field and the static fields. Nothing beyond numpy.
``.npy``
    The ``(n, T)`` float64 array (stored column after column, Fortran order, so
    that each chunk is appended). It holds the values alone: no times, no static
    fields. Needs ``steps=T`` up front.
``.h5``, ``.hdf5``
    An ``(n, T)`` float64 dataset named after the field, a ``times`` dataset and
    the static fields as ``(n,)``/``(n, p)`` datasets; the root attribute
    ``field`` names the field. Needs ``steps=T`` up front and h5py.

Every output is written under temporary names in its folder and renamed at
:meth:`SeriesWriter.close`; an error or an interruption (Ctrl-C) before that
removes them and leaves the final path as it was. :func:`manifill.io.series.read_series_values`
reads any of the four back.

Examples
--------
>>> import os, tempfile
>>> from manifill.mesh.shapes import icosphere
>>> V, F = icosphere(1)
>>> X = np.arange(len(V) * 4.0).reshape(len(V), 4)
>>> path = os.path.join(tempfile.mkdtemp(), "temp.pvd")
>>> with SeriesWriter(path, V, F, names="temp") as w:
...     w.write(X[:, :3], [0.0, 0.5, 1.0])
...     w.write(X[:, 3:], [2.0])
>>> from manifill.io.series import read_series_values
>>> times, values = read_series_values(path)
>>> times.tolist(), bool((values == X).all())
([0.0, 0.5, 1.0, 2.0], True)
"""

from pathlib import Path

import numpy as np

from ..errors import WriteError
from .field_names import check_field_names
from .formats import Format, lookup, register_format
from .series_read import read_gifti_series, read_h5_series, read_npy_series, read_pvd_series, read_xdmf_series
from .gifti_write import GiftiSeries
from .series_steps import H5Steps, NpySteps, PvdSteps, XdmfSteps

__all__ = ["SeriesWriter", "write_series"]

def _static_array(name, arr, n):
    arr = np.asarray(arr)
    if np.iscomplexobj(arr) or not (arr.dtype == bool or np.issubdtype(arr.dtype, np.number)):
        raise WriteError(f"static field {name!r} is {arr.dtype}; pass real numbers or booleans")
    if arr.ndim not in (1, 2) or arr.shape[0] != n:
        raise WriteError(f"static field {name!r} has shape {arr.shape}; pass (n,) or (n, p) values for {n} vertices")
    if arr.dtype == bool:
        return arr.astype(np.uint8)
    if np.issubdtype(arr.dtype, np.integer):
        if arr.size and (int(arr.min()) < np.iinfo(np.int32).min or int(arr.max()) > np.iinfo(np.int32).max):
            raise WriteError(f"static field {name!r} holds integers beyond 32 bits; store it as floats")
        return arr.astype(np.int32)
    return arr.astype(np.float64)


def _cells(path, V, F, needed):
    """The mesh as (n, 3) float64 points and (m, 3) or (m, 4) int64 cells (None if not ``needed``)."""
    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 3:
        raise WriteError(f"{path.name}: the points have shape {V.shape}; pass (n, 3) vertex positions")
    if not needed:
        return V, None
    if F is None:
        raise WriteError(f"{path.name}: {path.suffix.lower()} holds the mesh; pass its cells F")
    C = np.asarray(F)
    if C.dtype.kind not in "iu" or C.ndim != 2 or C.shape[1] not in (1, 3, 4) or len(C) == 0:
        raise WriteError(f"{path.name}: the cells are {C.dtype} of shape {C.shape}; pass (m, 3) triangles, "
                         f"(m, 4) tetrahedra or a point cloud's (n, 1) vertex cells as integers")
    if (C < 0).any() or (C >= len(V)).any():
        raise WriteError(f"{path.name}: a cell uses a vertex outside 0..{len(V) - 1}; pass cells of this mesh")
    return V, C.astype(np.int64)


class SeriesWriter:
    """Write one field's ``(n, T)`` values chunk by chunk of time steps (see the module docstring).

    Parameters
    ----------
    path : str or Path
        ``.xdmf``, ``.pvd``, ``.npy``, ``.h5`` or ``.hdf5``.
    V : (n, 3) array_like of float
        Vertex positions.
    F : (m, 1), (m, 3) or (m, 4) array_like of int, or None
        Vertex cells (a point cloud), triangles or tetrahedra (``None`` is enough for ``.npy`` and ``.h5``).
    names : str or list of one str, optional
        The field's name (``'value'`` by default).
    static : dict of str to (n,) or (n, p) array_like, optional
        Fields that do not change in time (the sample mask, ...), written with
        every step (``.xdmf`` stores each once); not for ``.npy``. Booleans are
        stored as 0/1 bytes, integers as 32-bit integers, the rest as float64.
    steps : int, optional
        The number of time steps ``T``; required for ``.npy`` and ``.h5``, checked
        at :meth:`close` when given for the others.

    Raises
    ------
    WriteError
        Unknown extension, a missing folder, a malformed mesh or static field, a
        name no format can store (or a mask's name for the field), ``steps``
        missing for ``.npy``/``.h5``, static fields for ``.npy``, h5py missing for
        ``.xdmf``/``.h5``, or a ``<stem>/`` folder of other files beside a ``.pvd``.

    Notes
    -----
    Use it in a ``with`` block: an exception inside it (Ctrl-C included) removes
    every temporary and leaves nothing at ``path``. Outside one, call
    :meth:`close`, or :meth:`abort` on failure.
    """

    def __init__(self, path, V, F, *, names=None, static=None, steps=None):
        self.path = Path(path)
        self.format = lookup("series", self.path, writing=True)
        ext = self.path.suffix.lower()
        if not self.path.parent.is_dir():
            raise WriteError(f"folder {self.path.parent} does not exist; create it first or choose another output "
                             f"path")
        name = [names] if isinstance(names, str) or names is None else list(names)
        if len(name) != 1:
            raise WriteError(f"{len(name)} names for one field; a series file holds one field, pass one name")
        self.name = "value" if name[0] is None else str(name[0])
        static = dict(static or {})
        check_field_names([self.name], self.path)
        check_field_names([str(k) for k in static], masks=False)
        if self.name in map(str, static):
            raise WriteError(f"{self.path.name}: the field and a static field are both named {self.name!r}; rename "
                             f"one")
        if static and not self.format.static:
            raise WriteError(f"{self.path.name}: {self.format.name} holds the values alone; write .h5, .xdmf or .pvd "
                             f"to keep static fields, or pass static=None")
        bad = [k for k in [self.name, *map(str, static)]
               if self.format.reserved is not None and self.format.reserved(k)]
        if bad:
            raise WriteError(f"{self.path.name}: {bad[0]!r} cannot name an HDF5 dataset here ('/' makes groups, "
                             f"'times' is taken); rename the field")
        if self.format.needs_steps and steps is None:
            raise WriteError(f"{self.path.name}: {ext} needs the number of time steps up front: pass steps=T "
                             f"(or write .xdmf or .pvd, which do not)")
        if steps is not None and (isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1):
            raise WriteError(f"steps={steps!r}; pass the number of time steps, an integer >= 1")
        self.steps = None if steps is None else int(steps)
        self.V, self.C = _cells(self.path, V, F, self.format.cells)
        self.n = len(self.V)
        self.static = {str(k): _static_array(k, a, self.n) for k, a in static.items()}
        self.written = 0
        self.last_time = None
        self._open = False
        self._out = self.format.write(self)
        self._open = True

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        self.abort() if exc_type is not None else self.close()

    def write(self, X, times=None):
        """Append time steps.

        Parameters
        ----------
        X : (n, t) or (n,) array_like of float
            The field at ``t`` time steps (one column each), or at one.
        times : (t,) array_like of float or float, optional
            Their times, increasing, after the last written; by default the
            step numbers (``0, 1, ...`` over the whole series).

        Raises
        ------
        WriteError
            A closed writer, values of the wrong shape or type, times not
            increasing, more steps than ``steps``, or a failed write (the writer
            is then aborted: nothing is left behind).
        """
        if not self._open:
            raise WriteError(f"{self.path.name}: the writer is closed; open a new SeriesWriter")
        X = np.asarray(X)
        if np.iscomplexobj(X) or not (X.dtype == bool or np.issubdtype(X.dtype, np.number)):
            raise WriteError(f"{self.path.name}: values are {X.dtype}; pass real numbers")
        X = X.astype(np.float64, copy=False)
        X = X[:, None] if X.ndim == 1 else X
        if X.ndim != 2 or X.shape[0] != self.n:
            raise WriteError(f"{self.path.name}: values have shape {X.shape}; pass (n, t) with n = {self.n} vertices, "
                             f"one column per time step")
        t = X.shape[1]
        if times is None:
            times = np.arange(self.written, self.written + t, dtype=np.float64)
        else:
            times = np.atleast_1d(np.asarray(times, dtype=np.float64))
        if times.shape != (t,):
            raise WriteError(f"{self.path.name}: {times.size} times for {t} columns; pass one time per column")
        if not np.isfinite(times).all():
            raise WriteError(f"{self.path.name}: a time is NaN or infinite; pass finite times")
        seq = times if self.last_time is None else np.concatenate([[self.last_time], times])
        bad = np.flatnonzero(~(np.diff(seq) > 0))
        if bad.size:
            j = int(bad[0])
            raise WriteError(f"{self.path.name}: time {seq[j + 1]:.17g} comes after {seq[j]:.17g}; write the steps "
                             f"in increasing time")
        if self.steps is not None and self.written + t > self.steps:
            raise WriteError(f"{self.path.name}: {self.written + t} time steps written for steps={self.steps}; pass "
                             f"the right steps=")
        if t == 0:
            return
        try:
            self._out.add(X, times, self.written)
        except (OSError, WriteError) as exc:
            self.abort()
            if isinstance(exc, WriteError):
                raise
            raise WriteError(f"{self.path.name}: could not write ({exc.strerror or exc}); check the free space "
                             f"(nothing was left behind)") from None
        self.written += t
        self.last_time = float(times[-1])

    def close(self):
        """Finish the files and move them to their final names.

        Raises
        ------
        WriteError
            No step written, fewer than ``steps``, or a failed write (then nothing
            is left behind).
        """
        if not self._open:
            return
        if self.written == 0 or (self.steps is not None and self.written != self.steps):
            self.abort()
            want = f" of steps={self.steps}" if self.steps is not None else ""
            raise WriteError(f"{self.path.name}: {self.written} time steps written{want}; nothing was written, call "
                             f"write() for every step before closing")
        try:
            self._out.finish()
        except OSError as exc:
            self.abort()
            raise WriteError(f"{self.path.name}: could not finish ({exc.strerror or exc}); check the folder's "
                             f"permissions and free space (nothing was left behind)") from None
        self._open = False

    def abort(self):
        """Remove every temporary; nothing is written at :attr:`path`."""
        if self._open:
            self._open = False
            self._out.abort()


def write_series(path, V, F, X, times=None, *, names=None, static=None):
    """Write a field's ``(n, T)`` values ``X`` at ``times`` in one go: a :class:`SeriesWriter` with one chunk.

    ``F`` may be ``None`` for ``.npy`` and ``.h5``; ``times`` are ``0 .. T-1`` by default; ``names`` and
    ``static`` are :class:`SeriesWriter`'s, which also says when :class:`~manifill.errors.WriteError` is raised.
    """
    X = np.asarray(X)
    steps = X.shape[1] if X.ndim == 2 else 1
    with SeriesWriter(path, V, F, names=names, static=static, steps=steps) as w:
        w.write(X, times)


def _h5_reserved(name):
    """A name that cannot name one of manifill's HDF5 datasets ('/' makes groups, 'times' is taken)."""
    return "/" in name or name == "times" or name.startswith(".")


# series: read(path, name) -> (times, values) (:mod:`manifill.io.series`); write(SeriesWriter) -> the writer of the
# steps (``add``, ``finish``, ``abort``)
for _fmt in (
    Format("XDMF + HDF5", "series", (".xdmf",), read_xdmf_series, XdmfSteps, fields=True, cells=True,
           beside=("{stem}.h5",), times=True, static=True, extra="series", seen_by=("meshio", "pyvista", "ParaView")),
    Format("ParaView collection of VTU", "series", (".pvd",), read_pvd_series, PvdSteps, fields=True, cells=True,
           folder=True, beside=("{stem}",), times=True, static=True, seen_by=("pyvista", "ParaView")),
    Format("NumPy array", "series", (".npy",), read_npy_series, NpySteps, cells=False, needs_steps=True),
    Format("HDF5 datasets", "series", (".h5", ".hdf5"), read_h5_series, H5Steps, fields=True, cells=False, times=True,
           static=True, needs_steps=True, reserved=_h5_reserved, extra="series", seen_by=("h5py",)),
    Format("GIfTI time series", "series", (".gii",), read_gifti_series, GiftiSeries, cells=False, times=True,
           extra="neuro", seen_by=("nibabel", "nilearn", "Workbench"), exact=False),
):
    register_format(_fmt)
