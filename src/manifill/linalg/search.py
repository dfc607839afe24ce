"""The one 1-D search: a score evaluated on a grid of one parameter, then refined between the best point's neighbours.

Its two callers differ in what a call costs and what is scored, not in the search: the smoothing's ``lam``
(:meth:`manifill.linalg.smoothing.SmoothingFit.select`: one GCV or leave-one-out score per field, a log grid of
``lam``, golden sections on ``log lam`` per field: :func:`grid_search`) and the gp's range, scale and noise
(:mod:`manifill.linalg.gpfit`: one restricted likelihood, a grid of the parameter's log, Brent's bounded method or,
where a call costs a sparse factorisation, parabolic steps through the grid's best three points:
:func:`bounded_search`). Both look at every grid point once, take the best, and refine only inside the bracket of
its neighbours.
"""

import math

import numpy as np
from scipy.optimize import minimize_scalar

__all__ = ["grid_search", "bounded_search", "REFINE_DECADES"]

#: The golden-section refinement stops when its bracket is narrower than this many decades.
REFINE_DECADES = 0.01
_GOLD = (math.sqrt(5.0) - 1.0) / 2.0


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
    >>> chosen, curve = grid_search(lambda t: np.array([np.log(t / 3.0) ** 2]), np.logspace(-2, 2, 5))
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


def bounded_search(f, lo, hi, points=7, parabolic=False):
    """Minimise ``f`` on ``[lo, hi]`` (log scale): a grid of ``points``, then a refinement in the best bracket.

    To 3% in ``kappa``: from 100 samples the range is known to about 20% anyway. The refinement is Brent's
    bounded method, or with ``parabolic`` (for costly ``f``: the range's likelihood, a sparse factorisation per
    call) safeguarded parabolic steps through the grid's best three points, which reuse them, and at an end of
    the grid one probe just inside (a range at the search's bound: 4 calls in all, where the grid and Brent
    took 9).
    """
    grid = np.linspace(lo, hi, points)
    vals = [f(g) for g in grid]
    i = int(np.argmin(vals))
    a, b = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    if b <= a:
        return grid[i], vals[i]
    if parabolic and 0 < i < len(grid) - 1:
        return _parabolic(f, [grid[i - 1], grid[i], grid[i + 1]], [vals[i - 1], vals[i], vals[i + 1]])
    if parabolic:  # the best at an end: one probe just inside says whether the minimum is there (4 calls, not 9)
        t = grid[i] + (0.03 if i == 0 else -0.03)
        if vals[i] <= f(t):
            return grid[i], vals[i]
    r = minimize_scalar(f, bounds=(a, b), method="bounded", options={"xatol": 0.03})
    return (r.x, r.fun) if r.fun <= vals[i] else (grid[i], vals[i])


def _parabolic(f, x, y, xatol=0.03, steps=6):
    """Successive parabolic interpolation in the bracket ``x0 < x1 < x2`` (``y1`` the least), kept bracketing."""
    (x0, x1, x2), (y0, y1, y2) = x, y
    for _ in range(steps):
        d0, d2 = x1 - x0, x1 - x2
        den = d0 * (y1 - y2) - d2 * (y1 - y0)
        if den == 0:
            break
        t = x1 - 0.5 * (d0 * d0 * (y1 - y2) - d2 * d2 * (y1 - y0)) / den
        t = min(max(t, x0 + xatol / 2), x2 - xatol / 2)  # inside the bracket, off its ends
        if abs(t - x1) < xatol / 2:
            break
        yt = f(t)
        if yt < y1:  # the new best: the bracket closes around it
            (x0, y0, x2, y2) = (x0, y0, x1, y1) if t < x1 else (x1, y1, x2, y2)
            x1, y1 = t, yt
        elif t < x1:
            x0, y0 = t, yt
        else:
            x2, y2 = t, yt
        if x2 - x0 < xatol:
            break
    return x1, y1
