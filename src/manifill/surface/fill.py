"""Steps 5-6 of the paper: fill every patch harmonically, the curve values fixed.

:func:`fill_patches` solves the Dirichlet problem ``x[b] = bc``, ``(L x)_i = 0``
elsewhere, on a :class:`manifill.surface.surface.Surface` with its Laplacian for the
chosen weights, through :meth:`manifill.surface.harmonic.HarmonicSolver.from_laplacian`.
The paper's Step 5 iterates from random values or from a gradually varied fit;
:func:`start_values` gives either (used by ``solver='iterate'`` only).
:func:`gvf_fill` is the gradually varied fit of the whole surface itself (the
``gvf`` method of :func:`manifill.surface.reconstruct.reconstruct`).
"""

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from ..errors import SolveError
from ..linalg.backends import AUTO_DIRECT_FIELDS, AUTO_DIRECT_MAX, auto_backend
from ..mesh.laplacian import WEIGHTS
from ..validate import check_option
from .gradual import gvf
from .harmonic import HarmonicSolver
from .prepared import Prepared, cached
from .surface import Surface

__all__ = ["INITS", "PatchFill", "fill_patches", "gvf_fill", "start_values"]

#: Initial values of ``solver='iterate'``: a GVF fit, random values in the samples' range,
#: or the mean of the fixed values (the solver's own start).
INITS = ("gvf", "random", "mean")


class PatchFill(NamedTuple):
    """The result of :func:`fill_patches`: the values and the solver's report (unpacks as ``values, report``)."""

    values: np.ndarray
    report: dict


def gvf_fill(surface, idx, vals, checks, *, on_empty="nan"):
    """The gradually varied fit of the whole surface: a level at every vertex, the samples' own values.

    Parameters
    ----------
    surface : Surface
        Its ``G_hops`` is used.
    idx : (k,) int64 numpy array
        Sample vertices, sorted and unique.
    vals : (k, p) numpy array
        Sample values.
    checks : list of p GradualCheck
        Step 1 per field (:func:`manifill.surface.gradual.check_gradual`): the
        levels and each sample's level.
    on_empty : {'nan', 'error'}, optional
        Vertices no sample reaches: NaN, or raise.

    Returns
    -------
    (n, p) numpy array
        ``levels[gvf]`` of every field at every vertex, ``vals`` at ``idx``.

    Raises
    ------
    SampleError
        The samples break the gradual variation condition.
    SolveError
        Vertices without a sample in their component and ``on_empty='error'``.

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> from manifill.surface.gradual import check_gradual
    >>> from manifill.surface.surface import Surface
    >>> s, idx, vals = Surface.from_mesh(*grid(3)), np.array([0, 8]), np.array([[0.0], [2.0]])
    >>> gvf_fill(s, idx, vals, [check_gradual(s.G_hops, idx, vals[:, 0])]).ravel().tolist()
    [0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 1.0, 1.0, 2.0]
    """
    check_option("on_empty", on_empty, ("nan", "error"))
    n = surface.G_hops.shape[0]
    X = np.empty((n, vals.shape[1]))
    for j, c in enumerate(checks):
        lev = gvf(surface.G_hops, idx, c.level)
        X[:, j] = np.where(lev >= 0, c.levels[np.maximum(lev, 0)], np.nan)
    X[idx] = vals
    empty = np.isnan(X[:, 0])
    if empty.any() and on_empty == "error":
        v = int(np.flatnonzero(empty)[0])
        raise SolveError(
            f"{int(empty.sum())} vertices (e.g. vertex {v}) lie in components without samples, so their "
            f"values are undetermined; add a sample there, or pass on_empty='nan' to leave them NaN")
    return X


def start_values(init, surface, idx, vals, *, checks=None, seed=0):
    """Initial values of the paper's iteration (Step 5).

    Parameters
    ----------
    init : {'gvf', 'random', 'mean'}
        The gradually varied fit (:func:`gvf_fill`, the paper's faster start),
        uniform random values in the range of each field's samples, or None
        (the solver starts from the mean of the fixed values).
    surface : Surface
    idx : (k,) int64 numpy array
        Sample vertices, sorted and unique.
    vals : (k, p) numpy array
        Sample values.
    checks : list of p GradualCheck, optional
        Step 1 per field (``gvf``).
    seed : int, optional
        Seed of ``random``.

    Returns
    -------
    (n, p) numpy array or None

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> from manifill.surface.surface import Surface
    >>> x0 = start_values("random", Surface.from_mesh(*grid(3)), np.array([0, 8]), np.array([[0.0], [2.0]]))
    >>> x0.shape, bool((0 <= x0).all() and (x0 <= 2).all())
    ((9, 1), True)
    """
    check_option("init", init, INITS)
    if init == "gvf":
        return gvf_fill(surface, idx, vals, checks)
    if init == "random":
        rng = np.random.default_rng(seed)
        lo, hi = vals.min(axis=0), vals.max(axis=0)
        return lo + (hi - lo) * rng.random((surface.G_hops.shape[0], vals.shape[1]))
    return None


def fill_patches(surface: Surface, idx: np.ndarray, vals: np.ndarray, *, weights: str = "cotan", solver: str = "auto",
                 on_empty: str = "error", x0: ArrayLike | Callable[[], ArrayLike] | None = None,
                 bounds: tuple[ArrayLike, ArrayLike] | None = None, fields: int | None = None,
                 largest: int | None = None, prepared: Prepared | None = None, **settings: Any) -> PatchFill:
    """Steps 5-6: the harmonic fill with the values at ``idx`` fixed.

    Parameters
    ----------
    surface : Surface
        Its Laplacian for ``weights`` (``surface.laplacian(weights)``, cached).
    idx : (c,) int64 numpy array
        Fixed vertices (the curve vertices of Step 4, or the samples alone), unique.
    vals : (c,) or (c, p) numpy array
        Their values.
    weights : {'cotan', 'uniform', 'intrinsic', 'robust'}, optional
        Laplacian weights (:mod:`manifill.mesh.laplacian`).
    solver : {'auto', 'direct', 'amg', 'iterate'}, optional
        Linear solver (:mod:`manifill.linalg.backends`).
    on_empty : {'error', 'nan'}, optional
        A component without a fixed vertex: raise, or leave it NaN.
    x0 : (n,) or (n, p) array, callable or None, optional
        Initial values, used only when the solver is ``iterate``; a callable
        (e.g. ``lambda: start_values(...)``) is called only then.
    bounds : ((p,), (p,)) pair of array_like, optional
        ``(lo, hi)``: bounds of the fill (see :meth:`manifill.surface.harmonic.HarmonicSolver.solve`);
        ``vals`` must lie within them.
    fields : int, optional
        How many fields will share this fixed set (default: ``vals``' columns);
        with many, ``solver='auto'`` factorises larger systems too
        (:func:`manifill.linalg.backends.auto_backend`).
    largest : int, optional
        The most unknowns of one patch (the partition's largest), when known.
    prepared : Prepared, optional
        Keeps the solver for the next call with the same fixed set
        (:mod:`manifill.surface.prepared`).
    **settings
        The solver's settings: ``iteration`` ({'gauss-seidel', 'jacobi'}, the sweeps of
        ``solver='iterate'``), ``tol``, ``maxiter``.

    Returns
    -------
    PatchFill
        ``values`` ((n,) or (n, p) numpy array, shaped like ``vals``' columns; exactly ``vals``
        at ``idx``) and ``report`` (the solver's, :class:`~manifill.surface.harmonic.HarmonicSolver`,
        with ``weights``); unpacks as ``values, report``.

    Raises
    ------
    SolveError
        A component without a fixed vertex and ``on_empty='error'``, or a solver failure.

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> from manifill.surface.surface import Surface
    >>> V, F = grid(5)
    >>> b = np.flatnonzero((V[:, 0] == 0) | (V[:, 0] == 1))
    >>> x, report = fill_patches(Surface.from_mesh(V, F), b, V[b, 0])
    >>> bool(np.allclose(x, V[:, 0])), report["weights"]
    (True, 'cotan')
    """
    check_option("weights", weights, WEIGHTS)
    fields = (1 if np.ndim(vals) == 1 else np.shape(vals)[1]) if fields is None else fields

    def build():
        L = surface.laplacian(weights)
        backend, factoriser = solver, None
        if fields >= AUTO_DIRECT_FIELDS:  # many fields: a factorisation if it fits, by SuperLU (see factorise)
            if solver == "auto":
                backend = auto_backend(L.shape[0] - len(idx), L.nnz, fields, largest=largest, spd=True)
            factoriser = "superlu" if largest is not None and largest <= AUTO_DIRECT_MAX else None
        hs = HarmonicSolver.from_laplacian(L, idx, solver=backend, on_empty=on_empty,
                                           symmetric_pattern=weights in ("uniform", "cotan"), factoriser=factoriser,
                                           **settings)
        hs.report["weights"] = weights
        return hs

    hs = cached(prepared, "fill", build)
    start = None
    if hs.report["solver"] == "iterate":
        start = x0() if callable(x0) else x0
    lo, hi = (None, None) if bounds is None else bounds
    values = hs.solve(vals, x0=start, lo=lo, hi=hi)
    report = {k: v for k, v in hs.report.items() if k != "seconds"}
    report["seconds"] = dict(hs.report["seconds"])
    return PatchFill(values, report)
