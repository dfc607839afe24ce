"""Minimise a score over a positive parameter: a log grid, then a golden-section refinement on its log.

Domain-free: :meth:`manifill.linalg.smoothing.SmoothingFit.select` uses it to
choose the smoothing ``lam`` by GCV or leave-one-out. The score is a function
``f(lam) -> (p,)`` (one score per field); every field gets its own minimiser,
found among the grid and its own refinement points only, so a field's choice
does not depend on the others.
"""

import math

import numpy as np

from ..errors import OptionError

__all__ = ["check_lam", "log_grid", "as_grid", "grid_search"]

#: The golden-section refinement stops when its bracket is narrower than this many decades.
REFINE_DECADES = 0.01
_GOLD = (math.sqrt(5.0) - 1.0) / 2.0


def check_lam(lam, p):
    """``lam`` as a float, or an array of ``p`` floats, each finite and >= 0 (:class:`~manifill.errors.OptionError`)."""
    try:
        a = np.asarray(lam, dtype=np.float64)
    except (TypeError, ValueError):
        raise OptionError(f"lam={lam!r} is not a number; pass lam >= 0 (0 interpolates) or 'auto'") from None
    if a.ndim > 1 or (a.ndim == 1 and a.size != p):
        raise OptionError(f"lam has shape {a.shape} for {p} fields; pass one number, or one per field")
    if not np.isfinite(a).all():
        raise OptionError(f"lam={lam!r} is NaN or infinite; pass a finite lam >= 0 (0 interpolates) or 'auto'")
    if (a < 0).any():
        raise OptionError(f"lam={lam!r} is negative; pass lam >= 0 (0 interpolates) or 'auto'")
    return float(a) if a.ndim == 0 else a


def log_grid(scale, decades=(-6.0, 4.0), per_decade=4):
    """``scale * 10**t`` for ``t`` from ``decades[0]`` to ``decades[1]``, ``per_decade`` points a decade.

    >>> log_grid(2.0, (0, 1), 2).tolist()
    [2.0, 6.324555320336759, 20.0]
    """
    lo, hi = decades
    return scale * 10.0 ** np.linspace(lo, hi, int(round((hi - lo) * per_decade)) + 1)


def as_grid(lams, what="lams"):
    """A user's grid: sorted, unique, finite values > 0 (:class:`~manifill.errors.OptionError` otherwise)."""
    try:
        grid = np.atleast_1d(np.asarray(lams, dtype=np.float64)).ravel()
    except (TypeError, ValueError):
        grid = np.empty(0)
    if grid.size == 0 or not np.isfinite(grid).all() or (grid <= 0).any():
        raise OptionError(f"{what} must be finite values > 0; pass a grid such as np.logspace(-3, 3, 13)")
    return np.unique(grid)


def grid_search(f, grid, *, refine=True):
    """The minimiser of ``f`` per field: the best grid point, refined between its neighbours.

    Parameters
    ----------
    f : callable
        ``f(lam) -> (p,)`` scores (``inf`` where undefined), for ``lam > 0``.
    grid : (m,) numpy array
        Sorted values > 0.
    refine : bool, optional
        Golden-section search on ``log lam`` between the best grid point's
        neighbours (to :data:`REFINE_DECADES`).

    Returns
    -------
    chosen : (p,) numpy array
    curve : dict
        ``lambdas`` (sorted, every value evaluated), ``scores`` ``(M, p)``,
        ``grid`` (bool: a grid point), ``at_edge`` ((p,) bool: the best grid
        point is an end of the grid).

    Examples
    --------
    >>> chosen, curve = grid_search(lambda t: np.array([np.log(t / 3.0) ** 2]), log_grid(1.0, (-2, 2), 1))
    >>> round(float(chosen[0]), 2), bool(curve["at_edge"][0])
    (3.0, False)
    """
    seen = {float(t): np.asarray(f(float(t)), dtype=np.float64) for t in grid}
    table = np.array([seen[float(t)] for t in grid])
    best = np.argmin(table, axis=0)
    chosen = grid[best].astype(np.float64)
    if refine and grid.size >= 2:
        for j in range(table.shape[1]):
            lo, hi = grid[max(best[j] - 1, 0)], grid[min(best[j] + 1, grid.size - 1)]
            chosen[j] = _golden(f, j, math.log(lo), math.log(hi), seen, float(chosen[j]))
    lambdas = np.array(sorted(seen))
    return chosen, {"lambdas": lambdas, "scores": np.array([seen[t] for t in lambdas]),
                    "grid": np.isin(lambdas, grid), "at_edge": (best == 0) | (best == grid.size - 1)}


def _golden(f, j, a, b, seen, start):
    """Golden-section search for field ``j`` on ``log lam`` in ``[a, b]``: the best of ``start`` and its points."""
    own = [start]

    def g(t):
        lam = float(math.exp(t))
        if lam not in seen:
            seen[lam] = np.asarray(f(lam), dtype=np.float64)
        own.append(lam)
        return seen[lam][j]

    c, d = b - _GOLD * (b - a), a + _GOLD * (b - a)
    fc, fd = g(c), g(d)
    while b - a > REFINE_DECADES * math.log(10.0):
        if fc <= fd:
            b, d, fd = d, c, fc
            c = b - _GOLD * (b - a)
            fc = g(c)
        else:
            a, c, fc = c, d, fd
            d = a + _GOLD * (b - a)
            fd = g(d)
    return min(own, key=lambda t: seen[t][j])
