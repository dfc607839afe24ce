"""Bounds ``lo <= x <= hi`` for :class:`manifill.linalg.quadratic.QuadraticSolver`: a primal active-set loop.

The problem is

    minimise  1/2 x^T A x + c^T x   subject to  x[idx] = vals,  lo <= x <= hi  on the free indices,

a convex box-constrained QP. Its minimiser satisfies the KKT conditions, with
``g = A x + c`` (``+ Aeq^T mu`` with equality rows): ``lo <= x <= hi``;
``g_i = 0`` where ``lo < x_i < hi``; ``g_i >= 0`` where ``x_i = lo``; ``g_i <= 0``
where ``x_i = hi`` (``g_i`` is the multiplier of the bound, and complementarity
holds since an index is either strictly inside or at its bound).

The loop, in the manner of libigl's ``active_set`` (used by bounded biharmonic
weights), one field at a time: start from the unbounded minimiser; while a free
index violates a bound, fix every violated index at its bound (it joins the
fixed set) and solve again; when none violates, release every fixed-at-a-bound
index whose multiplier has the wrong sign and solve again; stop when nothing
violates and every multiplier has the right sign. Unlike libigl, violations are
fixed before anything is released (the two are never mixed in one step), and a
repeated active set (a cycle) stops the loop with a
:class:`~manifill.errors.SolveError`, as does the iteration cap.

With equality rows ``Aeq x = beq`` the multipliers are those of ``A x + c +
Aeq^T mu`` (``mu`` from the KKT solve), and an index is not fixed if that would
leave the rows without a matching to distinct free indices (a singular KKT
system): the least violated such index stays free; if nothing else can move, a
:class:`~manifill.errors.SolveError` says the rows cannot be met within the
bounds (the tests confirm each such case infeasible by a linear program).

Every change of the active set builds the reduced system of the new fixed set
through :meth:`QuadraticSolver.fixing` (the one reduction path), with the
solver's backend: one factorisation (``direct``) or hierarchy (``amg``) per
iteration and field, so the cost is ``iterations`` times a setup and a solve.
"""

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import maximum_bipartite_matching

from ..errors import SampleError, SolveError
from ..tolerances import TOL

__all__ = ["MAX_ITERATIONS", "as_bounds", "solve_bounded", "check_samples"]

#: Default cap on the active-set iterations (re-solves) of one field.
MAX_ITERATIONS = 100


def as_bounds(lo, hi, p):
    """Validate the bounds: scalars or ``(p,)`` per field; None is unbounded on that side.

    Parameters
    ----------
    lo, hi : float, (p,) array_like of float, or None
        Lower and upper bounds; ``-inf`` and ``inf`` are allowed.
    p : int
        Number of fields.

    Returns
    -------
    lo, hi : (p,) float64 numpy arrays
        With ``-inf`` / ``inf`` for None.

    Raises
    ------
    SampleError
        NaN, a wrong shape, or ``lo > hi`` for a field.

    Examples
    --------
    >>> as_bounds(0.0, None, 2)
    (array([0., 0.]), array([inf, inf]))
    """
    out = []
    for name, b, default in (("lo", lo, -np.inf), ("hi", hi, np.inf)):
        if b is None:
            out.append(np.full(p, default))
            continue
        try:
            b = np.asarray(b, dtype=np.float64)
        except (TypeError, ValueError):
            raise SampleError(f"{name} could not be read as numbers; pass a float or one per field") from None
        if b.ndim > 1 or (b.ndim == 1 and b.size != p):
            raise SampleError(f"{name} has shape {b.shape} for {p} fields; pass a float or ({p},)")
        if np.isnan(b).any():
            raise SampleError(f"{name} holds NaN; pass numbers, or None (or +-inf) for no bound")
        out.append(np.broadcast_to(b, (p,)).astype(np.float64))
    lo, hi = out
    bad = np.flatnonzero(lo > hi)
    if bad.size:
        j = int(bad[0])
        raise SampleError(f"the lower bound {lo[j]:g} exceeds the upper bound {hi[j]:g} (field {j}); "
                          f"pass lo <= hi")
    return lo, hi


def check_samples(vals, lo, hi):
    """Refuse sample values outside their field's bounds (the problem then has no feasible point)."""
    out = (vals < lo) | (vals > hi)
    if out.any():
        i, j = np.argwhere(out)[0]
        raise SampleError(f"sample values outside the bounds ({int(out.sum())}, e.g. sample {i} = "
                          f"{vals[i, j]:g} not in [{lo[j]:g}, {hi[j]:g}]); widen the bounds or use "
                          f"bounds='samples'")


def solve_bounded(q, vals, lo, hi, *, linear=None, x0=None, beq=None, maxiter=MAX_ITERATIONS):
    """The minimiser of ``q``'s energy with ``x[idx] = vals`` and ``lo <= x <= hi`` on the free indices.

    Parameters
    ----------
    q : QuadraticSolver
        The problem without bounds (its :meth:`~QuadraticSolver.solve` and
        :meth:`~QuadraticSolver.fixing` are used).
    vals : (k, p) float numpy array
        Validated values at ``q.idx``.
    lo, hi : (p,) float numpy arrays
        Validated bounds (:func:`as_bounds`), ``-inf`` / ``inf`` for none.
    linear, x0, beq : optional
        As for :meth:`QuadraticSolver.solve`.
    maxiter : int, optional
        Cap on the re-solves of one field.

    Returns
    -------
    X : (n, p) numpy array
        The minimiser, one column per field, each with its own active set.
    report : dict
        ``lo``, ``hi`` (per field, None for unbounded), ``iterations``,
        ``active_lo``, ``active_hi`` (per field), ``kkt_residual`` (the largest
        ``|g_i|`` on an inactive free index or wrong-signed part of a
        multiplier, over all fields, in the units of ``A x``) and
        ``violation`` (the largest bound violation of a free index before the
        final round-off clip, in the units of ``x``).

    Raises
    ------
    SampleError
        Sample values outside the bounds.
    SolveError
        The iteration cap is hit or the active set cycles.

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> from manifill.linalg.quadratic import QuadraticSolver
    >>> A = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(5, 5))
    >>> q = QuadraticSolver(A, [0, 4])
    >>> X, rep = solve_bounded(q, np.zeros((2, 1)), np.array([-np.inf]), np.array([2.0]),
    ...                        linear=-2 * np.ones(5))
    >>> X[:, 0].round(12).tolist(), rep["active_hi"]
    ([0.0, 2.0, 2.0, 2.0, 0.0], [3])
    """
    check_samples(vals, lo, hi)
    n, p = q.n, vals.shape[1]
    X = q.solve(vals, linear=linear, x0=x0, beq=beq)
    X = X[:, None] if X.ndim == 1 else X.copy()
    C = np.zeros((n, p))
    if linear is not None:
        c = np.asarray(linear, dtype=np.float64)
        C[q.unknown] = (c[:, None] if c.ndim == 1 else c)[q.unknown]
    B = None
    if beq is not None:
        B = np.asarray(beq, dtype=np.float64)
        B = np.broadcast_to(B[:, None] if B.ndim == 1 else B, (B.shape[0], p))
    mu = q.eq_multipliers
    amax = float(np.abs(q.A.data).max()) if q.A.nnz else 0.0
    report = {"lo": [None if np.isinf(v) else float(v) for v in lo],
              "hi": [None if np.isinf(v) else float(v) for v in hi],
              "iterations": [], "active_lo": [], "active_hi": [], "kkt_residual": 0.0, "violation": 0.0}
    for j in range(p):
        finite = [abs(v) for v in (lo[j], hi[j]) if np.isfinite(v)]
        scale = max([float(np.abs(vals[:, j]).max()) if vals.size else 0.0, *finite]) or 1.0
        tol_x = TOL.bound_rtol * scale
        tol_g = TOL.bound_rtol * (amax * scale + float(np.abs(C[:, j]).max()))
        x, m, its, active, at_hi = _one_field(q, vals[:, j], lo[j], hi[j], C[:, j], X[:, j],
                                              None if B is None else B[:, j],
                                              None if mu is None else mu[:, j], tol_x, tol_g, maxiter, j)
        free = np.setdiff1d(q.unknown, active)
        xf = x[free]
        report["violation"] = max(report["violation"], float(np.max(lo[j] - xf, initial=0.0)),
                                  float(np.max(xf - hi[j], initial=0.0)))
        x[free] = np.clip(xf, lo[j], hi[j])
        g = _gradient(q, x, C[:, j], m)
        res = max(float(np.abs(g[free]).max(initial=0.0)),
                  float(np.max(-g[active[~at_hi]], initial=0.0)), float(np.max(g[active[at_hi]], initial=0.0)))
        report["kkt_residual"] = max(report["kkt_residual"], res)
        report["iterations"].append(its)
        report["active_lo"].append(int(np.count_nonzero(~at_hi)))
        report["active_hi"].append(int(np.count_nonzero(at_hi)))
        X[:, j] = x
    return X, report


def _gradient(q, x, c, mu):
    """``A x + c (+ Aeq^T mu)``, with NaN (empty components) read as 0."""
    g = q.A @ np.nan_to_num(x, nan=0.0) + c
    if mu is not None:
        g += q.Aeq.T @ mu
    return g


def _keep_rows_solvable(q, active, new, excess):
    """Positions in ``new`` to fix, so that the equality rows keep a matching to distinct free indices (the
    structural full rank of ``Aeq_I``, without which the KKT system is singular): while the matching falls
    short, the least violated new index whose release lengthens it stays free."""
    pattern = q.Aeq.copy()
    pattern.data = (pattern.data != 0).astype(np.float64)
    pattern.eliminate_zeros()
    fixed = np.zeros(q.n, dtype=bool)
    fixed[q.idx] = fixed[q.empty] = fixed[active] = True
    take = np.ones(new.size, dtype=bool)
    in_rows = np.isin(new, pattern.indices)

    def matched(take):
        trial = fixed.copy()
        trial[new[take]] = True
        return int(np.count_nonzero(maximum_bipartite_matching(sp.csr_array(pattern[:, ~trial]),
                                                               perm_type="column") >= 0))

    size = matched(take)
    while size < pattern.shape[0]:
        for pos in np.flatnonzero(take & in_rows)[np.argsort(excess[take & in_rows], kind="stable")]:
            take[pos] = False
            longer = matched(take)
            if longer > size:
                size = longer
                break
            take[pos] = True
        else:  # not made by this step: the reduction names it
            break
    return np.flatnonzero(take)


def _one_field(q, vals, lo, hi, c, x, beq, mu, tol_x, tol_g, maxiter, field):
    """The active-set loop of one field: (x, multipliers of Aeq, iterations, active indices, at_hi)."""
    active = np.zeros(0, dtype=np.int64)
    at_hi = np.zeros(0, dtype=bool)
    seen = {active.tobytes()}
    if np.isinf(lo) and np.isinf(hi):
        return x, mu, 0, active, at_hi
    for it in range(maxiter + 1):
        free = np.setdiff1d(q.unknown, active)
        below = free[x[free] < lo - tol_x]
        above = free[x[free] > hi + tol_x]
        new = np.concatenate([below, above])
        blocked = False
        if new.size and q.Aeq is not None:
            excess = np.concatenate([lo - x[below], x[above] - hi])
            kept = _keep_rows_solvable(q, active, new, excess)
            blocked = kept.size < new.size
            below, above = below[kept[kept < below.size]], above[kept[kept >= below.size] - below.size]
        if below.size or above.size:  # fix every violated index at its bound
            active = np.concatenate([active, below, above])
            at_hi = np.concatenate([at_hi, np.zeros(below.size, bool), np.ones(above.size, bool)])
        else:  # release every multiplier of the wrong sign (>= 0 at lo, <= 0 at hi)
            g = _gradient(q, x, c, mu)[active]
            keep = np.where(at_hi, g <= tol_g, g >= -tol_g)
            if keep.all() and blocked:
                raise SolveError(f"an equality row (a point inside a face) cannot be met within the bounds "
                                 f"(field {field}); widen the bounds or check the point's value")
            if keep.all():
                return x, mu, it, active, at_hi
            active, at_hi = active[keep], at_hi[keep]
        order = np.argsort(active, kind="stable")
        active, at_hi = active[order], at_hi[order]
        key = active.tobytes() + at_hi.tobytes()
        if it == maxiter or key in seen:
            why = "cycles" if key in seen else f"did not settle in {maxiter} iterations"
            raise SolveError(f"the active set of the bounds {why} (field {field}, {active.size} indices at a "
                             f"bound); pass a larger bound_iterations, solver='direct', or wider bounds")
        seen.add(key)
        sub = q.fixing(active)
        bvals = np.where(at_hi, hi, lo)
        x = sub.solve(np.concatenate([vals, bvals]), linear=c, x0=x if sub.report["solver"] != "direct" else None,
                      beq=beq)
        mu = None if sub.eq_multipliers is None else sub.eq_multipliers[:, 0]
    raise AssertionError("unreachable")  # pragma: no cover
