"""A time series reconstructed and written chunk by chunk: memory flat in the number of time steps.

:func:`reconstruct_series` prepares one :class:`manifill.Reconstructor` for the mesh and the
samples, applies it to a chunk of time steps at a time and hands each chunk to a
:class:`~manifill.io.series_write.SeriesWriter` (``.xdmf``, ``.pvd``, ``.h5``, ``.npy``), so that
only one chunk of ``(n, t)`` values is in memory at once. A linear reconstruction with many more
time steps than samples (an EEG: 70 channels, 10,000 steps) goes through its dense ``(n, k)`` map
instead: ``k`` solves once, then one matrix product per chunk (:func:`dense_map`). The file appears
at the end, whole, or not at all (an error or Ctrl-C on the way leaves nothing); what was written
is said by a :class:`SeriesResult`. ``manifill reconstruct MESH SAMPLES -o OUT.xdmf`` is this
function.
"""

from __future__ import annotations

import os
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import OptionError, SampleError
from ..results import CURVE_MASK, PATCH_LABEL, SAMPLE_MASK, sample_mask
from ..surface.methods.registry import configure
from ..surface.reconstructor import Reconstructor
from .distributed import ordered_map
from .formats import find_format
from .series_write import SeriesWriter

if TYPE_CHECKING:  # the [batch] extra's client, a type here only
    import distributed

__all__ = ["CHUNK_BYTES", "MAP_BYTES", "MAP_STEPS_PER_SAMPLE", "SeriesResult", "apply_chunk", "chunk_size",
           "dense_map", "reconstruct_series"]

#: Bytes of values one chunk of time steps may hold (the result and the solver's copies: about 4x this).
CHUNK_BYTES = 64 * 2**20
#: A linear series goes through its dense n x k map when it has this many time steps per sample or more ...
MAP_STEPS_PER_SAMPLE = 2
#: ... and the map takes at most this many bytes.
MAP_BYTES = 256 * 2**20


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


@dataclass(frozen=True)
class SeriesResult:
    """What :func:`reconstruct_series` wrote: the values themselves are in the file, never all in memory.

    Attributes
    ----------
    path : Path
        The series file (with its ``.h5`` or folder of ``.vtu`` beside it).
    steps : int
        Time steps written.
    chunk : int
        Time steps per chunk.
    chunks : int
        Chunks applied and written.
    seconds : dict of str to float
        ``prepare``, ``reconstruct`` (the chunks' applies, summed over workers with a client),
        ``write``, ``total``; with a client also ``send`` (the broadcast) and ``wait`` (the time
        blocked on results); through the dense map, ``map`` (its ``k`` solves).
    report : dict
        The last chunk's reconstruction report (through the map: the last step's).

    Examples
    --------
    >>> r = SeriesResult(Path("x.npy"), steps=5, chunk=2, chunks=3, seconds={}, report={})
    >>> r.chunks, r.linear_map
    (3, False)
    """

    path: Path
    steps: int
    chunk: int
    chunks: int
    seconds: dict
    report: dict

    @property
    def linear_map(self):
        """Whether the series went through the dense ``(n, k)`` map (:func:`dense_map`)."""
        return "map" in self.seconds

    def __getitem__(self, key):
        """``result["steps"]``, as when this was a dict (deprecated: use the attribute; removed in 0.3)."""
        if key not in ("steps", "chunk", "chunks", "seconds", "report"):
            raise KeyError(key)
        warnings.warn(f"reconstruct_series(...)[{key!r}] is deprecated; use the attribute .{key}",
                      DeprecationWarning, stacklevel=2)
        return getattr(self, key)


def reconstruct_series(V: ArrayLike, F: ArrayLike | None, idx: ArrayLike, vals: ArrayLike, path: str | os.PathLike[str],
                       *, times: ArrayLike | None = None, name: str = "value", chunk: int | None = None,
                       progress: Callable[[str], object] | None = None, client: distributed.Client | None = None,
                       **options: Any) -> SeriesResult:
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
        Called with ``'steps a-b'`` as each chunk starts (with a ``client``: as it is written).
    client : distributed.Client, optional
        Apply the chunks on this Dask cluster's workers (:func:`manifill.io.distributed.ordered_map`):
        the Reconstructor is prepared here, sent once to every worker (each factorises again at its
        first chunk; the partition and Step 4's map travel with it), at most two chunks per worker
        are out at once, and the chunks are written here in time order as they come back: the same
        file as without a client. The caller owns the client (it is not closed here); workers need
        manifill installed. None (default): every chunk in this process. A linear series long enough
        for its dense map (:func:`dense_map`) runs here: one product per chunk.
    **options
        The options of :func:`manifill.reconstruct` (``method``, ``solver``, ..., or ``options=``), but
        ``uncertainty`` and ``trust`` (a series file holds the values alone).

    Returns
    -------
    SeriesResult
        ``path``, ``steps``, ``chunk``, ``chunks``, ``seconds`` (per stage) and ``report`` (the
        last chunk's reconstruction report; through the map: the last step's).

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
    >>> s.steps, s.chunks, np.load(out).shape
    (5, 3, (162, 5))
    """
    t0 = time.perf_counter()
    o = configure(options.pop("options", None), **options)
    if ("uncertainty" in o.given and o.uq.uncertainty) or o.uq.trust is not None:
        raise OptionError("a series file holds the values alone, without the std; leave uncertainty and trust out")
    vals = np.asarray(vals, dtype=np.float64)
    if vals.ndim == 1:
        vals = vals[:, None]
    if vals.ndim != 2:
        raise SampleError(f"vals has shape {vals.shape}; pass (k, T) values, one column per time step")
    T = vals.shape[1]
    times = np.arange(T, dtype=np.float64) if times is None else np.asarray(times, dtype=np.float64).ravel()
    if times.shape != (T,):
        raise SampleError(f"{times.size} times for {T} time steps (columns of vals); pass one time per column")
    rec = Reconstructor(V, F, idx, fields=T, options=o)
    n = rec.n
    step = chunk_size(n, T, chunk)
    starts = range(0, T, step)
    seconds = {"prepare": time.perf_counter() - t0, "reconstruct": 0.0, "write": 0.0}
    W = dense_map(rec, T, o.step1.check, seconds)

    def span(s):
        return f"steps {s}-{min(s + step, T) - 1}"

    if W is not None or client is None:  # here: through the map (whatever the client), or applied chunk by chunk
        if W is not None:
            last = apply_chunk(rec, vals[:, T - 1:], True)  # the report and the masks, from one solve

            def one(block, first):
                t = time.perf_counter()
                rec.check_values(block)
                return W @ block, last[1], last[2] if first else None, time.perf_counter() - t
        else:
            def one(block, first):
                return apply_chunk(rec, block, first)

        def blocks():
            for s in starts:
                if progress is not None:
                    progress(span(s))
                yield one(vals[:, s:s + step], s == 0)
        results = blocks()
    else:
        seconds.update(send=0.0, wait=0.0)
        results = ordered_map(client, apply_chunk, rec, ((vals[:, s:s + step], s == 0) for s in starts),
                              seconds=seconds)
    writer, report = None, None
    try:
        for s in starts:
            values, report, static, spent = next(results)
            seconds["reconstruct"] += spent
            t = time.perf_counter()
            if W is None and client is not None and progress is not None:  # as each chunk comes back
                progress(span(s))
            if writer is None:  # the masks do not change in time: given with the first chunk
                mV, mF = rec.mesh()  # a point cloud's points are vertex cells
                cells = np.arange(len(mV))[:, None] if mF is None else mF
                writer = SeriesWriter(path, mV, cells, names=name, steps=T,
                                      static=static if getattr(find_format("series", path), "static", True) else None)
            writer.write(values, times[s:s + step])
            seconds["write"] += time.perf_counter() - t
        writer.close()  # type: ignore[union-attr]  # made at the first chunk, and there is one
    except BaseException:
        if writer is not None:
            writer.abort()
        raise
    finally:
        results.close()  # a Dask run cancels the chunks not yet done
    seconds["total"] = time.perf_counter() - t0
    return SeriesResult(Path(path), steps=T, chunk=step, chunks=len(starts), seconds=seconds,
                        report=report)  # type: ignore[arg-type]  # the last chunk's


def apply_chunk(rec, block, first):
    """One chunk: ``(values (n, c), report, static, seconds)``; ``static`` (the masks) for the first chunk only.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(1)
    >>> rec = Reconstructor(V, F, [0, 5, 20], method="harmonic")
    >>> values, report, static, _ = apply_chunk(rec, np.eye(3), True)
    >>> values.shape, sorted(static), int(static["sample_mask"].sum())
    ((42, 3), ['sample_mask'], 3)
    """
    t = time.perf_counter()
    r = rec.apply(block)
    n = rec.n
    static = None
    if first:
        static = {SAMPLE_MASK: sample_mask(n, r.idx)}
        if r.report.get("partition"):
            static[CURVE_MASK] = np.asarray(r.on_curve, dtype=bool)
            static[PATCH_LABEL] = np.asarray(r.components)
    return np.asarray(r.values, dtype=np.float64).reshape(n, -1), r.report, static, time.perf_counter() - t


def dense_map(rec, steps, check=None, seconds=None):
    """The dense ``(n, k)`` map ``W`` of a linear Reconstructor when a series of ``steps`` pays for it, else None.

    A linear reconstruction of ``T`` time steps costs ``T`` solves; through ``W`` it costs ``k``
    (the samples' unit values, in blocks) and one ``(n, k) x (k, t)`` product per chunk. Built when
    ``rec.linear``, ``steps >= MAP_STEPS_PER_SAMPLE * k``, ``W`` takes at most :data:`MAP_BYTES`
    and Step 1 is not asked for every step (``check=True``). ``seconds`` gets ``map`` added.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(2)
    >>> rec = Reconstructor(V, F, [0, 40, 80, 120], method="harmonic")
    >>> dense_map(rec, 8).shape, dense_map(rec, 7) is None
    ((162, 4), True)
    """
    n, k = rec.n, rec.samples
    if not rec.linear or check is True or steps < MAP_STEPS_PER_SAMPLE * k or 8.0 * n * k > MAP_BYTES:
        return None
    t = time.perf_counter()
    W = np.ascontiguousarray(rec.matrix(form="operator").matmat(np.eye(k)).reshape(n, k))
    if seconds is not None:
        seconds["map"] = time.perf_counter() - t
    return W
