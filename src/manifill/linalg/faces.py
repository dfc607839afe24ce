"""One face of the bounds' active set: the energy's minimiser with some free indices held at a bound.

:mod:`manifill.linalg.active_set` walks from face to face; this module solves each one. A face
``W`` (free indices fixed at ``lo`` or ``hi``) differs from the unbounded problem by ``|W|`` more
fixed indices, so with a factorised (``direct``) backend it needs no factorisation of its own. With
``A_uu`` the factorised system of a *base* (the unbounded problem, or a face solved earlier), its
minimiser ``y`` and ``Z = A_uu^-1 E_W`` (one column per index of ``W``)::

    x = y + Z g,   with   (E_W^T Z) g = bvals - y_W

(``g``: the face's multipliers; ``E_W^T Z``, the ``W`` block of ``A_uu^-1``, is symmetric positive
definite). A column costs one pair of triangular solves and is kept (its entries at the indices
that have joined so far, the rest by symmetry), so an index that leaves and rejoins the face costs
nothing, and a face costs its new columns plus one solve. When a face would cost more in new
columns than a factorisation did (both timed as they run), or it releases an index the base holds,
that face is factorised and becomes the base: the loop then costs at most about what it did with
a factorisation per face, and about one unbounded solve when the faces are small (a smooth field's
overshoot near its extreme samples). Measured in ``docs/benchmarks.md`` (bounded solves).

Without a factorisation (``amg``, or equality rows) every face is set up anew, or with
``reuse=True`` and AMG, solved by CG preconditioned by the unbounded hierarchy restricted to
the face.
"""

import time

import numpy as np
import scipy.linalg as sla

from ..memory import available_bytes
from .pcg import nrm2, pcg

__all__ = ["Faces", "KEEP_BYTES", "MAX_SCHUR"]

#: The columns of ``A_uu^-1`` kept (at most this many bytes, and an eighth of the memory available); beyond, each
#: face costs one more solve (at 163k unknowns 0.12 s, against a product with the kept columns in milliseconds).
KEEP_BYTES = 2**30
#: A face with more indices beyond its base than this is factorised (its dense Schur block would cost more).
MAX_SCHUR = 2_000


class Faces:
    """The minimiser on a face (free indices ``side != 0`` fixed at ``lo`` (-1) or ``hi`` (+1)) of one field.

    Parameters
    ----------
    q : QuadraticSolver
        The problem without bounds.
    vals : (k,) numpy array
        The field's values at ``q.idx``.
    lo, hi : float
        The field's bounds.
    c : (n,) numpy array
        The linear term (zero outside ``q.unknown``).
    reuse : bool
        With ``amg``: CG preconditioned by ``q``'s hierarchy instead of a new one per face.
    """

    def __init__(self, q, vals, lo, hi, c, reuse=True):
        self.q, self.vals, self.lo, self.hi, self.c = q, vals, lo, hi, c
        backend = q.backend
        self.restricted = reuse and q.Aeq is None and backend.name == "amg" and hasattr(backend, "precondition")
        self.schur = q.Aeq is None and backend.name == "direct"
        self.setups = self.cg_iterations = self.columns = 0
        self.known = np.zeros(q.n)  # the fixed values, zero elsewhere (empty components too)
        self.known[q.idx] = vals
        self._base = None  # (solver, its extra fixed indices (sorted), their sides, its minimiser)
        self._setup_seconds = float(q.report["seconds"]["setup"])
        self._column_seconds = None
        self.keep_bytes = KEEP_BYTES

    def energy(self, x):
        """``q(x)`` (NaN, on empty components, read as 0)."""
        x = np.nan_to_num(x, nan=0.0)
        return 0.5 * float(x @ (self.q.A @ x)) + float(self.c @ x)

    def solve(self, side, x0, beq=None):
        """The minimiser with ``q.unknown[side != 0]`` at their bounds (and the Aeq multipliers or None)."""
        q = self.q
        at = np.flatnonzero(side)
        W = q.unknown[at]
        bvals = np.where(side[at] > 0, self.hi, self.lo)
        if self.restricted:
            x = self._restricted(side == 0, W, bvals, x0)
            if x is not None:
                return x, None
        if self.schur:
            x = self._by_schur(W, side[at], bvals)
            if x is not None:
                return x, None
        sub, x = self._factorise(W, bvals, x0, beq)
        if self.schur:
            self._new_base(sub, W, side[at], x)
        return x, (None if sub.eq_multipliers is None else sub.eq_multipliers[:, 0])

    def _factorise(self, W, bvals, x0, beq):
        """The face's own reduced system, set up and solved: ``(solver, minimiser)``."""
        sub = self.q.fixing(W)
        self.setups += 1
        x = sub.solve(np.concatenate([self.vals, bvals]), linear=self.c,
                      x0=None if sub.report["solver"] == "direct" else np.nan_to_num(x0, nan=0.0), beq=beq)
        self._setup_seconds = float(sub.report["seconds"]["setup"])
        return sub, x

    def _new_base(self, solver, W, sides, x):
        """Make the face just factorised the base of the next faces (no columns yet)."""
        self._base = {"solver": solver, "fixed": W, "sides": sides, "y": x, "order": np.zeros(0, np.int64),
                      "slot": np.full(self.q.n, -1, np.int64), "S": np.zeros((0, 0)),
                      "Z": np.zeros((0, solver.unknown.size))}  # the kept columns, as rows, with room to grow

    def _by_schur(self, W, sides, bvals):
        """The face's minimiser from the base's factor and the columns of its extra indices, or None when
        a factorisation is due (the face releases an index of the base, or its new columns cost more)."""
        if self._base is None:
            t = time.perf_counter()
            y = self.q.solve(self.vals, linear=self.c)
            self._column_seconds = time.perf_counter() - t
            self._new_base(self.q, np.zeros(0, np.int64), np.zeros(0, np.int8), y)
        base = self._base
        pos = np.searchsorted(W, base["fixed"])
        held = pos < W.size
        held[held] = W[pos[held]] == base["fixed"][held]
        if not held.all() or (sides[pos] != base["sides"]).any():
            return None
        extra = np.delete(np.arange(W.size), pos)
        E = W[extra]
        if E.size > MAX_SCHUR:
            return None
        new = E[base["slot"][E] < 0]
        if new.size and new.size * self._column_seconds > self._setup_seconds:
            return None
        if new.size:
            self._add_columns(new)
        at = base["slot"][E]  # each index's place in the Schur block
        y = base["y"]
        if E.size:
            try:
                g = sla.cho_solve(sla.cho_factor(base["S"][np.ix_(at, at)]), bvals[extra] - y[E])
            except np.linalg.LinAlgError:  # round-off made the block indefinite: factorise the face
                return None
        solver = base["solver"]
        x = y.copy()
        if E.size and base["Z"] is not None:  # the kept columns: x = y + Z g
            m = base["order"].size
            full = np.zeros(m)
            full[at] = g
            x[solver.unknown] += base["Z"][:m].T @ full
        elif E.size:  # only the block kept: one solve
            r = np.zeros(solver.unknown.size)
            r[np.searchsorted(solver.unknown, E)] = g
            x[solver.unknown] += solver.backend.solve(r)[0][:, 0]
        x[W] = bvals
        return x

    def _add_columns(self, new):
        """Solve for the columns of ``new`` (indices among the base's unknowns) and extend the Schur block."""
        base = self._base
        solver = base["solver"]
        u = solver.unknown
        R = np.zeros((u.size, new.size))
        R[np.searchsorted(u, new), np.arange(new.size)] = 1.0
        t = time.perf_counter()
        Z, _ = solver.backend.solve(R)
        self._column_seconds = (time.perf_counter() - t) / new.size
        self.columns += new.size
        order = np.concatenate([base["order"], new])
        rows = Z[np.searchsorted(u, order)]  # (old + new, new): the new columns at every kept index
        m = base["order"].size
        S = np.empty((order.size, order.size))
        S[:m, :m] = base["S"]
        S[:, m:] = rows
        S[m:, :m] = rows[:m].T
        S[m:, m:] = 0.5 * (rows[m:] + rows[m:].T)
        base["slot"][new] = np.arange(m, order.size)
        avail = available_bytes()
        cap = self.keep_bytes if avail is None else min(self.keep_bytes, avail / 8)
        if base["Z"] is not None and order.size * Z.shape[0] * 8 <= cap:
            if order.size > base["Z"].shape[0]:  # grow by half at least: copies stay linear in the columns
                grown = np.empty((max(order.size, 3 * base["Z"].shape[0] // 2), Z.shape[0]))
                grown[:m] = base["Z"][:m]
                base["Z"] = grown
            base["Z"][m:order.size] = Z.T
        else:  # too many to keep: each face then costs one solve more
            base["Z"] = None
        base["order"], base["S"] = order, S

    def _restricted(self, free, W, bvals, x0):
        """CG on ``A_FF`` preconditioned by ``q``'s hierarchy restricted to ``F``; None if it does not converge."""
        q, backend = self.q, self.q.backend
        F = q.unknown[free]
        full = self.known.copy()
        full[W] = bvals
        b = -(q.A @ full)[F] - self.c[F]
        wide, inner = np.zeros(q.n), np.zeros(q.unknown.size)

        def matvec(v):
            wide[F] = v
            return (q.A @ wide)[F]

        def precondition(r, _):
            inner[free] = r
            return backend.precondition(inner)[free]

        xF = np.nan_to_num(x0[F], nan=0.0)
        bnorm = nrm2(b)
        r = b - matvec(xF)
        s = nrm2(r)
        if s > backend.rtol * bnorm:
            r *= 1.0 / s
            e = np.zeros_like(r)
            res = pcg(matvec, r, e, precondition=precondition, rtol=backend.rtol * bnorm / s,
                      maxiter=backend.maxiter, flexible=True)
            self.cg_iterations += res.iterations
            if not res.converged:
                return None
            xF = xF + s * e
        full[F] = xF
        full[q.empty] = np.nan
        return full
