"""A time series reconstructed and written chunk by chunk: memory flat in the number of time steps.

:func:`reconstruct_series` prepares one :class:`manifill.Reconstructor` for the mesh and the
samples, applies it to a chunk of time steps at a time and hands each chunk to a
:class:`~manifill.io.series_write.SeriesWriter` (``.xdmf``, ``.pvd``, ``.h5``, ``.npy``), so that
only one chunk of ``(n, t)`` values is in memory at once. The file appears at the end, whole, or
not at all (an error or Ctrl-C on the way leaves nothing). ``manifill reconstruct MESH SAMPLES -o
OUT.xdmf`` is this function.
"""

import time

import numpy as np

from ..errors import OptionError, SampleError
from ..results import CURVE_MASK, PATCH_LABEL, SAMPLE_MASK, sample_mask
from ..surface.reconstructor import Reconstructor
from .series_write import SeriesWriter

__all__ = ["CHUNK_BYTES", "chunk_size", "reconstruct_series"]

#: Bytes of values one chunk of time steps may hold (the result and the solver's copies: about 4x this).
CHUNK_BYTES = 64 * 2**20


def chunk_size(n, steps, given=None):
    """Time steps per chunk: ``given``, else as many as :data:`CHUNK_BYTES` of ``n`` values each allows.

    Examples
    --------
    >>> chunk_size(32_000, 10_000), chunk_size(10, 5), chunk_size(10, 5, given=2)
    (262, 5, 2)
    """
    if given is not None:
        if isinstance(given, bool) or not isinstance(given, (int, np.integer)) or given < 1:
            raise OptionError(f"chunk={given!r}: pass a number of time steps >= 1")
        return int(min(given, steps))
    return int(max(1, min(steps, CHUNK_BYTES // (8 * max(n, 1)))))


def reconstruct_series(V, F, idx, vals, path, *, times=None, name="value", chunk=None, progress=None, **options):
    """Reconstruct ``T`` time steps and write them as a series file, one chunk of steps at a time.

    Parameters
    ----------
    V, F, idx
        As for :func:`manifill.reconstruct` (vertex indices or positions).
    vals : (k, T) array_like of float
        One row per sample, one column per time step.
    path : str or Path
        ``.xdmf`` (with its ``.h5``), ``.pvd`` (with a folder of ``.vtu``), ``.h5``/``.hdf5`` or ``.npy``
        (:class:`~manifill.io.series_write.SeriesWriter`).
    times : (T,) array_like of float, optional
        Increasing; ``0 .. T-1`` by default.
    name : str, optional
        The field's name in the file.
    chunk : int, optional
        Time steps per chunk (default: :func:`chunk_size`).
    progress : callable, optional
        Called with ``'steps a-b'`` as each chunk starts.
    **options
        The options of :func:`manifill.reconstruct` (``method``, ``solver``, ...), but
        ``uncertainty`` and ``trust`` (a series file holds the values alone).

    Returns
    -------
    dict
        ``steps``, ``chunk``, ``chunks``, ``seconds`` (``prepare``, ``reconstruct``,
        ``write``, ``total``) and ``report``: the last chunk's reconstruction report.

    Raises
    ------
    OptionError, SampleError, WriteError
        As :func:`manifill.reconstruct` and the writer; nothing is left at ``path``.

    Examples
    --------
    >>> import os, tempfile
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(2)
    >>> idx = np.arange(0, 162, 20)
    >>> vals = np.outer(V[idx, 0], np.arange(5.0))                  # (9, 5): five time steps
    >>> out = os.path.join(tempfile.mkdtemp(), "x.npy")
    >>> s = reconstruct_series(V, F, idx, vals, out, chunk=2, method="harmonic")
    >>> s["steps"], s["chunks"], np.load(out).shape
    (5, 3, (162, 5))
    """
    t0 = time.perf_counter()
    if options.get("uncertainty") or options.get("trust") is not None:
        raise OptionError("a series file holds the values alone, without the std; leave uncertainty and trust out")
    options = {k: v for k, v in options.items() if k not in ("uncertainty", "trust")}
    vals = np.asarray(vals, dtype=np.float64)
    if vals.ndim == 1:
        vals = vals[:, None]
    if vals.ndim != 2:
        raise SampleError(f"vals has shape {vals.shape}; pass (k, T) values, one column per time step")
    T = vals.shape[1]
    times = np.arange(T, dtype=np.float64) if times is None else np.asarray(times, dtype=np.float64).ravel()
    if times.shape != (T,):
        raise SampleError(f"{times.size} times for {T} time steps (columns of vals); pass one time per column")
    rec = Reconstructor(V, F, idx, fields=T, **options)
    n = rec.surface.n
    step = chunk_size(n, T, chunk)
    seconds = {"prepare": time.perf_counter() - t0, "reconstruct": 0.0, "write": 0.0}
    writer, r = None, None
    try:
        for s in range(0, T, step):
            if progress is not None:
                progress(f"steps {s}-{min(s + step, T) - 1}")
            t = time.perf_counter()
            r = rec.apply(vals[:, s:s + step])
            seconds["reconstruct"] += time.perf_counter() - t
            t = time.perf_counter()
            if writer is None:  # the masks do not change in time: given with the first chunk
                static = {SAMPLE_MASK: sample_mask(n, r.idx)}
                if r.report.get("partition"):
                    static[CURVE_MASK] = np.asarray(r.on_curve, dtype=bool)
                    static[PATCH_LABEL] = np.asarray(r.components)
                writer = SeriesWriter(path, rec.surface.V, rec.surface.F, names=name, steps=T,
                                      static=None if str(path).lower().endswith(".npy") else static)
            writer.write(np.asarray(r.values, dtype=np.float64).reshape(n, -1), times[s:s + step])
            seconds["write"] += time.perf_counter() - t
        writer.close()
    except BaseException:
        if writer is not None:
            writer.abort()
        raise
    seconds["total"] = time.perf_counter() - t0
    return {"steps": T, "chunk": step, "chunks": -(-T // step), "seconds": seconds, "report": r.report}
