"""Samples: vertex indices, their values, and ``(idx, vals)`` pairs with repeated vertices merged.

Every malformed input raises a :class:`~manifill.errors.SampleError` (an unknown
option an :class:`~manifill.errors.OptionError`) whose one-line message names the fix.
"""

import numpy as np

from ..errors import SampleError
from ..tolerances import TOL
from .options import check_option, first_entries, integral_floats

__all__ = ["as_indices", "as_values", "as_samples"]


def as_indices(idx, n, *, what="idx", unique=True):
    """Validate vertex indices.

    Parameters
    ----------
    idx : (k,) array_like of int
        0-based vertex indices, any integer dtype (integral floats are accepted).
    n : int
        Number of vertices of the mesh.
    what : str, optional
        The argument's name, for the messages.
    unique : bool, optional
        Reject an index listed twice.

    Returns
    -------
    (k,) int64 numpy array
        The indices, in the given order.

    Raises
    ------
    SampleError
        Not 1-D, empty, not integers, outside ``0..n-1`` or (with ``unique``)
        listed twice.

    Examples
    --------
    >>> as_indices([3.0, 1], 5).tolist()
    [3, 1]
    """
    try:
        idx = np.asarray(idx)
    except (TypeError, ValueError):
        raise SampleError(f"{what} is ragged or not an array; pass a 1-D array of vertex indices") from None
    if idx.ndim != 1:
        raise SampleError(f"{what} has shape {idx.shape}; pass a 1-D array of vertex indices")
    if idx.size == 0:
        raise SampleError(f"{what} is empty; fix at least one vertex")
    if not np.issubdtype(idx.dtype, np.integer):
        if integral_floats(idx):
            idx = idx.astype(np.int64)
        else:
            raise SampleError(f"{what} has dtype {idx.dtype}; pass vertex indices as integers")
    idx = idx.astype(np.int64, copy=False)
    lo, hi = int(idx.min()), int(idx.max())
    if lo < 0 or hi >= n:
        bad = np.flatnonzero((idx < 0) | (idx >= n))
        raise SampleError(
            f"{what} holds vertex {lo if lo < 0 else hi}, outside 0..{n - 1} (entries {first_entries(bad)}); "
            f"indices must be 0-based and below the number of vertices"
        )
    if unique:
        srt = np.sort(idx)
        rep = srt[1:][srt[1:] == srt[:-1]]
        if rep.size:
            raise SampleError(
                f"{what} lists vertex {int(rep[0])} more than once ({np.unique(rep).size} repeated vertices); "
                f"list each vertex once"
            )
    return idx


#: The largest sample value (in magnitude) taken: an energy ``x^T A x`` of values beyond it overflows float64.
MAX_VALUE = 1e150


def as_values(vals, k, *, what="vals"):
    """Validate the values at ``k`` vertices: ``(k,)`` or ``(k, p)`` finite floats.

    Parameters
    ----------
    vals : (k,) or (k, p) array_like of float
        One value, or one row of ``p`` values, per vertex.
    k : int
        Number of vertices the values belong to.
    what : str, optional
        The argument's name, for the messages.

    Returns
    -------
    vals : (k, p) float64 numpy array
        Always two-dimensional.
    squeeze : bool
        True if ``vals`` was one-dimensional.

    Raises
    ------
    SampleError
        Wrong shape, non-numeric, NaN or infinite values (the rows are named).

    Examples
    --------
    >>> vals, squeeze = as_values([1, 2], 2)
    >>> vals.shape, squeeze
    ((2, 1), True)
    """
    try:
        raw = np.asarray(vals)
        complex_values = np.iscomplexobj(raw)
        vals = raw.astype(np.float64) if not complex_values else raw
    except (TypeError, ValueError):
        raise SampleError(f"{what} could not be read as numbers; pass a (k,) or (k, p) float array") from None
    if complex_values:
        raise SampleError(f"{what} holds complex numbers; pass real values (e.g. their .real or abs)")
    squeeze = vals.ndim == 1
    if squeeze:
        vals = vals[:, None]
    if vals.ndim != 2 or vals.shape[0] != k:
        shape = vals.shape[:1] if squeeze else vals.shape
        raise SampleError(f"{what} has shape {shape} for {k} vertices; pass one value (or one row) per vertex")
    if vals.shape[1] == 0:
        raise SampleError(f"{what} has no columns; pass at least one field")
    bad = ~np.isfinite(vals).all(axis=1)
    if bad.any():
        rows = first_entries(np.flatnonzero(bad))
        raise SampleError(f"{what} has NaN or infinite values in rows {rows}; remove those samples")
    check_magnitude(vals, what)
    return np.ascontiguousarray(vals), squeeze


def check_magnitude(a, what, fix="divide the values by a power of ten and scale the result back"):
    """Refuse finite values beyond :data:`MAX_VALUE` in magnitude, naming the first rows, in one line."""
    a = np.asarray(a, dtype=np.float64)
    big = np.abs(a).max(initial=0.0)
    if big > MAX_VALUE:
        far = np.abs(a.reshape(len(a), -1)) > MAX_VALUE
        raise SampleError(f"{what} reaches {big:.3g} (rows {first_entries(np.flatnonzero(far.any(axis=1)))}), "
                          f"beyond {MAX_VALUE:.0e}, where the energies' squares overflow; {fix}")


def as_samples(idx, vals, n, *, duplicates="error"):
    """Validate samples ``(idx, vals)``, merging repeated vertices.

    Parameters
    ----------
    idx : (k,) array_like of int
        Vertex of each sample, 0-based, any integer dtype.
    vals : (k,) or (k, p) array_like of float
        Value(s) of each sample: one column per field.
    n : int
        Number of vertices of the mesh.
    duplicates : {'error', 'mean'}, optional
        What to do when a vertex carries two different values: raise, or
        average them. Repeats with equal values are merged silently.

    Returns
    -------
    idx : (k',) int64 numpy array
        Sorted unique vertex indices.
    vals : (k', p) float64 numpy array
        Their values, always two-dimensional.
    squeeze : bool
        True if ``vals`` was one-dimensional.

    Raises
    ------
    SampleError
        Wrong shapes, indices outside ``0..n-1``, NaN or infinite values, or one
        vertex with two different values (listed, with the fix).

    Examples
    --------
    >>> idx, vals, squeeze = as_samples([2, 0, 2], [1.0, 3.0, 1.0], 4)
    >>> idx.tolist(), vals.ravel().tolist(), squeeze
    ([0, 2], [3.0, 1.0], True)
    """
    check_option("duplicates", duplicates, ("error", "mean"))
    idx = as_indices(idx, n, what="idx", unique=False)
    vals, squeeze = as_values(vals, idx.size, what="vals")
    uniq, inv, counts = np.unique(idx, return_inverse=True, return_counts=True)
    if uniq.size == idx.size:
        order = np.argsort(idx)
        return idx[order], np.ascontiguousarray(vals[order]), squeeze
    sums = np.zeros((uniq.size, vals.shape[1]))
    np.add.at(sums, inv, vals)
    mean = sums / counts[:, None]
    spread = np.abs(vals - mean[inv]).max(axis=1)
    conflict = spread > TOL.sample_conflict * float(np.abs(vals).max())
    if conflict.any() and duplicates == "error":
        v = int(idx[np.flatnonzero(conflict)[0]])
        rows = np.flatnonzero(idx == v)
        shown = ", ".join(f"{vals[r, 0]:g}" for r in rows[:4])
        nv = np.unique(idx[conflict]).size
        raise SampleError(
            f"{nv} vertices get two different values (vertex {v}: rows {first_entries(rows)} = {shown}); "
            f"remove the conflicting samples, or average them (duplicates='mean', CLI: --duplicates mean)"
        )
    return uniq, mean, squeeze
