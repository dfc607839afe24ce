"""Bounds ``lo <= x <= hi`` for :class:`manifill.linalg.quadratic.QuadraticSolver`: a monotone active-set loop.

The problem, ``minimise q(x) = 1/2 x^T A x + c^T x subject to x[idx] = vals, lo <= x <= hi`` on the free indices, is
a convex box-constrained QP. Its minimiser satisfies the KKT conditions, with ``g = A x + c`` (``+ Aeq^T mu``
with equality rows): ``lo <= x <= hi``; ``g_i = 0`` where ``lo < x_i < hi``; ``g_i >= 0`` where ``x_i = lo``;
``g_i <= 0`` where ``x_i = hi`` (``g_i``: the bound's multiplier; an index is inside or at its bound), each to a
tolerance scaled by its own row of ``A`` (scaled by ``max |A|``, small parts of a mesh stopped early).

The loop, one field at a time, keeps a *face* (free indices fixed at a bound)
and solves for ``y``, the minimiser of ``q`` on it, from the unbounded
minimiser (the empty face). Two phases:

1. *Primal-dual steps* (a semismooth Newton step of the box, as for obstacle
   problems): every index of the face whose multiplier has the wrong sign
   leaves it, and every free index whose violation is a *peak* (at least that
   of each neighbour in ``A``'s graph) joins it, in one step. Fixing only the
   peaks, not every violator, matters: the bounded minimiser touches its bound
   on far fewer indices than the unbounded one violates it (42 against 271 on
   a 10k sphere), and fixing them all, then releasing a ring at a time, took
   libigl's loop (fix all, release all) 69 re-solves where this takes 12.
   The phase ends at the KKT point, or when a face comes back (it may cycle).
2. *A monotone loop*, from there on, with a feasible point ``z`` on the face.
   If ``y`` violates a bound, ``z`` moves towards ``y``: to the projection
   ``clip(y)`` when that lowers ``q`` (every violator joins the face),
   otherwise along the segment to the first bound it meets (those join; ``q``
   does not rise, by convexity); the face grows at every such step. If ``y``
   is feasible it minimises its face; when every multiplier has the right
   sign it is the answer, otherwise every wrong-signed index leaves the face
   (only the worst, if one of them would at once leave the box the other
   way), and ``q`` falls strictly. So ``q`` falls from one feasible face
   minimiser to the next, no face comes back, and the loop ends (a finite
   rule; a face seen again, possible only by round-off, is an error).

Both phases are finite (phase 1 stops at the first repeated face), so the
loop always settles; ``maxiter`` caps the face solves all the same. The faces
are solved by :class:`manifill.linalg.faces.Faces`: with a factorised backend
from the unbounded factor and a Schur block of the indices at a bound (a face
is factorised anew only when its new columns would cost more), otherwise by a
new set-up per face (or, with ``reuse=True`` and ``amg``, by conjugate
gradients preconditioned by the unbounded hierarchy restricted to the face:
the same answer, but 1.4x slower on a 10k bilaplacian, so it is off).

With equality rows ``Aeq x = beq`` (points inside faces) the older loop runs
(fix every violator, then release every wrong-signed multiplier, with the
multipliers of ``A x + c + Aeq^T mu``): a projection would break the rows. An
index is not fixed if that would leave the rows without a matching to distinct
free indices (a singular KKT system): the least violated such index stays
free; if nothing else can move, a :class:`~manifill.errors.SolveError` says
the rows cannot be met within the bounds.
"""

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import maximum_bipartite_matching

from ..deprecation import renamed
from ..errors import SampleError, SolveError
from ..tolerances import TOL
from .faces import Faces

__all__ = ["MAX_ITERATIONS", "bounds_per_field", "solve_bounded", "check_samples"]

#: Public names renamed, kept one release with a warning (:mod:`manifill.deprecation`): ``as_bounds`` is
#: :func:`manifill.surface.energy_fill.as_bounds`'s name (the option ``bounds=``); here, the per-field arrays.
__getattr__ = renamed(__name__, {"as_bounds": "manifill.linalg.active_set:bounds_per_field"})

#: Default cap on the active-set iterations (face solves) of one field.
MAX_ITERATIONS = 100


def bounds_per_field(lo, hi, p):
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
    >>> bounds_per_field(0.0, None, 2)
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


def solve_bounded(q, vals, lo, hi, *, linear=None, x0=None, beq=None, maxiter=MAX_ITERATIONS, reuse=False):
    """The minimiser of ``q``'s energy with ``x[idx] = vals`` and ``lo <= x <= hi`` on the free indices.

    Parameters
    ----------
    q : QuadraticSolver
        The problem without bounds (its :meth:`~QuadraticSolver.solve`,
        :attr:`~QuadraticSolver.backend` and :meth:`~QuadraticSolver.fixing` are used).
    vals : (k, p) float numpy array
        Validated values at ``q.idx``.
    lo, hi : (p,) float numpy arrays
        Validated bounds (:func:`bounds_per_field`), ``-inf`` / ``inf`` for none.
    linear, x0, beq : optional
        As for :meth:`QuadraticSolver.solve`.
    maxiter : int, optional
        Cap on the face solves of one field.
    reuse : bool, optional
        With the ``amg`` backend, precondition every face solve by ``q``'s
        hierarchy (no new set-up); False (the default, faster as measured)
        sets a backend up for every face.

    Returns
    -------
    X : (n, p) numpy array
        The minimiser, one column per field, each with its own active set.
    report : dict
        ``lo``, ``hi`` (per field, None for unbounded), ``iterations`` (face
        solves), ``setups`` (backend set-ups among them), ``cg_iterations``
        (conjugate-gradient steps of the reused hierarchy), ``columns``
        (columns of the unbounded factor's inverse solved for, per field:
        :mod:`manifill.linalg.faces`), ``active_lo``,
        ``active_hi`` (per field), ``kkt_residual`` (the largest ``|g_i|`` on
        an inactive free index or wrong-signed part of a multiplier, over all
        fields, in the units of ``A x``) and ``violation`` (the largest bound
        violation of a free index before the final round-off clip, in the
        units of ``x``).

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
    ([0.0, 2.0, 2.0, 2.0, 0.0], [1])
    """
    check_samples(vals, lo, hi)
    n, p = q.n, vals.shape[1]
    X = q.solve(vals, linear=linear, x0=x0, beq=beq)
    X = X[:, None] if X.ndim == 1 else X.copy()
    C = np.zeros((n, p))
    if linear is not None:
        c = np.asarray(linear, dtype=np.float64)
        C[q.unknown] = (c[:, None] if c.ndim == 1 else c)[q.unknown]
    B = None if beq is None else np.asarray(beq, dtype=np.float64)
    B = None if B is None else np.broadcast_to(B[:, None] if B.ndim == 1 else B, (B.shape[0], p))
    mu = q.eq_multipliers
    rows = np.asarray(abs(sp.csr_array(q.A)).sum(axis=1)).ravel()  # sum |A_ij| of every row: its tolerance's scale
    report = {"lo": [None if np.isinf(v) else float(v) for v in lo],
              "hi": [None if np.isinf(v) else float(v) for v in hi],
              **{key: [0] * p for key in ("iterations", "setups", "cg_iterations", "columns", "active_lo",
                                          "active_hi")},
              "kkt_residual": 0.0, "violation": 0.0}
    scales = np.array([max([float(np.abs(vals[:, j]).max()) if vals.size else 0.0,
                            *[abs(v) for v in (lo[j], hi[j]) if np.isfinite(v)]]) or 1.0 for j in range(p)])
    inside = _within(q, X, lo, hi, TOL.bound_rtol * scales)
    if q.Aeq is None and inside.any():  # fields already within their bounds: no face to solve, all at once
        _settle(q, X, C, lo, hi, np.flatnonzero(inside), report)
    for j in range(p):
        if q.Aeq is None and inside[j]:
            continue
        scale = scales[j]
        tol_x = TOL.bound_rtol * scale
        tol_g = TOL.bound_rtol * (rows * scale + float(np.abs(C[:, j]).max()))  # per index: its row's own size
        faces = Faces(q, vals[:, j], lo[j], hi[j], C[:, j], reuse=reuse)
        if np.isinf(lo[j]) and np.isinf(hi[j]):
            x, m, its, active, at_hi = X[:, j], None, 0, np.zeros(0, np.int64), np.zeros(0, bool)
        elif q.Aeq is None:
            x, its, active, at_hi = _bounded_field(faces, X[:, j], tol_x, tol_g, maxiter, j)
            m = None
        else:
            x, m, its, active, at_hi = _rows_loop(faces, X[:, j], None if B is None else B[:, j],
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
        report["iterations"][j], report["setups"][j] = its, faces.setups
        report["cg_iterations"][j], report["columns"][j] = faces.cg_iterations, faces.columns
        report["active_lo"][j], report["active_hi"][j] = int(np.count_nonzero(~at_hi)), int(np.count_nonzero(at_hi))
        X[:, j] = x
    return X, report


def _within(q, X, lo, hi, tol):
    """(p,) bool: the fields whose values at the free indices lie within their bounds (to ``tol``)."""
    with np.errstate(invalid="ignore"):
        return ~((X[q.unknown] < lo - tol) | (X[q.unknown] > hi + tol)).any(axis=0)


def _settle(q, X, C, lo, hi, cols, report):
    """The loop's clip and report for the fields ``cols``, within their bounds already (nothing active), at once."""
    U = q.unknown
    XU = X[np.ix_(U, cols)]
    report["violation"] = max(report["violation"], float(np.max(lo[cols] - XU, initial=0.0)),
                              float(np.max(XU - hi[cols], initial=0.0)))
    X[np.ix_(U, cols)] = np.clip(XU, lo[cols], hi[cols])
    G = q.A @ np.nan_to_num(X[:, cols], nan=0.0) + C[:, cols]
    report["kkt_residual"] = max(report["kkt_residual"], float(np.abs(G[U]).max(initial=0.0)))


def _bounded_field(faces, y, tol_x, tol_g, maxiter, field):
    """The two phases of the module's docstring for one field: (x, face solves, active indices, at_hi)."""
    q, lo, hi, A = faces.q, faces.lo, faces.hi, faces.q.A
    U = q.unknown
    tol_u = np.broadcast_to(tol_g, (q.n,))[U]  # a scalar, or one per index
    side = np.zeros(U.size, dtype=np.int8)  # -1 at lo, +1 at hi, 0 free
    seen, solves, full = {side.tobytes()}, 0, np.zeros(q.n)
    while True:  # primal-dual steps: release the wrong-signed, fix the peaks of the violation
        yu = y[U]
        free = side == 0
        viol = np.where(free & (yu < lo - tol_x), lo - yu, np.where(free & (yu > hi + tol_x), yu - hi, 0.0))
        g = _gradient(q, y, faces.c, None)[U]
        wrong = (side != 0) & (np.where(side < 0, -g, g) > tol_u)
        if not (wrong.any() or viol.any()):
            active = np.flatnonzero(side)
            return y, solves, U[active], side[active] > 0
        full[U] = viol  # a peak: violated at least as much as every neighbour in A's graph
        peak = (viol > 0) & (viol >= np.maximum.reduceat(full[A.indices], A.indptr[:-1])[U])
        trial = side.copy()
        trial[wrong] = 0
        trial[peak & (yu < lo)], trial[peak & (yu > hi)] = -1, 1
        if trial.tobytes() in seen or solves == maxiter:  # a face seen before: the monotone loop
            break
        side = trial
        seen.add(side.tobytes())
        solves += 1
        y, _ = faces.solve(side, y)
    return _monotone(faces, y, side, solves, tol_x, tol_g, maxiter, field)


def _monotone(faces, y, side, solves, tol_x, tol_g, maxiter, field):
    """The monotone loop from the face ``side`` and its minimiser ``y``: (x, solves, active indices, at_hi)."""
    q, lo, hi = faces.q, faces.lo, faces.hi
    U = q.unknown
    tol_u = np.broadcast_to(tol_g, (q.n,))[U]  # a scalar, or one per index
    z = ez = None  # the feasible point on the face and its energy
    undo = None  # (side before a block release, the worst index) while that release is on trial
    seen = set()
    while True:
        yu = y[U]
        free = side == 0
        low, high = free & (yu < lo - tol_x), free & (yu > hi + tol_x)
        if not (low.any() or high.any()):  # y minimises its face and is feasible
            xu = np.clip(yu, lo, hi)
            side[free & (xu <= lo + tol_x)] = -1  # at a bound already: on the face, multiplier ~0
            side[free & (xu >= hi - tol_x)] = 1
            xu = np.where(side < 0, lo, np.where(side > 0, hi, xu))
            x = y.copy()
            x[U] = xu
            g = _gradient(q, x, faces.c, None)[U]
            wrong = np.where(side < 0, -g, np.where(side > 0, g, 0.0))  # > 0: the multiplier's wrong sign
            if not (wrong > tol_u).any():
                active = np.flatnonzero(side)
                return x, solves, U[active], side[active] > 0
            key = side.tobytes()
            if key in seen:
                raise SolveError(f"the active set of the bounds cycles (field {field}, "
                                 f"{np.count_nonzero(side)} indices at a bound; round-off); pass "
                                 f"solver='direct', or wider bounds")
            seen.add(key)
            z, ez = x, faces.energy(x)
            worst = int(np.argmax(wrong))
            undo = (side.copy(), worst) if np.count_nonzero(wrong > tol_u) > 1 else None
            side[wrong > tol_u] = 0  # release every wrong-signed index
        elif z is None:  # the unbounded minimiser: clip it
            side[low], side[high] = -1, 1
            z = y.copy()
            z[U] = np.clip(yu, lo, hi)
            ez = faces.energy(z)
        else:
            cand = y.copy()
            cand[U] = np.clip(yu, lo, hi)
            ec = faces.energy(cand)
            if ec < ez:  # the projection lowers q: every violator joins the face
                side[low], side[high] = -1, 1
                z, ez, undo = cand, ec, None
            else:  # along the segment to the first bound met
                zu = z[U]
                d = yu - zu
                out = low | high
                ratio = np.full(U.size, np.inf)
                ratio[low] = (lo - zu[low]) / d[low]
                ratio[high] = (hi - zu[high]) / d[high]
                alpha = float(ratio.min())
                if alpha <= 0.0 and undo is not None:  # a released index leaves at once: release the worst only
                    side, worst = undo
                    side[worst], undo = 0, None
                else:
                    undo = None
                    hits = out & (ratio <= alpha)
                    zu = np.clip(zu + alpha * d, lo, hi)
                    side[hits & low], side[hits & high] = -1, 1
                    zu[side < 0], zu[side > 0] = lo, hi
                    z = z.copy()
                    z[U] = zu
                    ez = faces.energy(z)
        if solves == maxiter:
            raise SolveError(f"the active set of the bounds did not settle in {maxiter} iterations (field {field}, "
                             f"{np.count_nonzero(side)} indices at a bound); pass a larger bound_iterations, "
                             f"or wider bounds")
        solves += 1
        y, _ = faces.solve(side, z)


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


def _rows_loop(faces, x, beq, mu, tol_x, tol_g, maxiter, field):
    """The loop with equality rows: (x, multipliers of Aeq, iterations, active indices, at_hi)."""
    q, lo, hi, c = faces.q, faces.lo, faces.hi, faces.c
    active = np.zeros(0, dtype=np.int64)
    at_hi = np.zeros(0, dtype=bool)
    seen = {active.tobytes()}
    for it in range(maxiter + 1):
        free = np.setdiff1d(q.unknown, active)
        below = free[x[free] < lo - tol_x]
        above = free[x[free] > hi + tol_x]
        new = np.concatenate([below, above])
        blocked = False
        if new.size:
            excess = np.concatenate([lo - x[below], x[above] - hi])
            kept = _keep_rows_solvable(q, active, new, excess)
            blocked = kept.size < new.size
            below, above = below[kept[kept < below.size]], above[kept[kept >= below.size] - below.size]
        if below.size or above.size:  # fix every violated index at its bound
            active = np.concatenate([active, below, above])
            at_hi = np.concatenate([at_hi, np.zeros(below.size, bool), np.ones(above.size, bool)])
        else:  # release every multiplier of the wrong sign (>= 0 at lo, <= 0 at hi)
            g = _gradient(q, x, c, mu)[active]
            tg = np.broadcast_to(tol_g, (q.n,))[active]
            keep = np.where(at_hi, g <= tg, g >= -tg)
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
        side = np.zeros(q.unknown.size, dtype=np.int8)
        side[np.searchsorted(q.unknown, active)] = np.where(at_hi, 1, -1)
        x, mu = faces.solve(side, x, beq)
    raise AssertionError("unreachable")  # pragma: no cover
