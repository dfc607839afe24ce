"""The restricted likelihood of exact samples at vertices from sparse factors: every sample, no dense covariance.

For the field ``x ~ N(beta 1, s^2 Q^-1)`` observed exactly at the vertices ``s`` (the others ``f``), the data's
covariance is ``s^2 R`` with ``R = (Q^-1)_ss`` and, by the Schur complement,

    R^-1 = S = Q_ss - Q_sf Q_ff^-1 Q_fs,        log det R = log det Q_ff - log det Q,

so one factorisation of ``Q_ff`` (and one of ``K``: ``log det Q = 2 log det K - log det C`` for ``alpha = 2``)
gives the likelihood of all ``m`` samples (with CHOLMOD, one factorisation of ``Q`` with the samples ordered
last instead: ``log det R = -log det S`` from its last diagonal entries, 25% less per trial at 163k vertices),
where the kriging form (:mod:`manifill.linalg.gpfit`) builds the dense ``m x m`` matrix ``R`` by ``m`` solves and
so fits on a subset. The value is the same
(:meth:`manifill.linalg.gpfit.Likelihood.profiled` with no noise, the scale profiled, the mean by REML or
known).

Its derivative in ``kappa`` (:meth:`VertexLikelihood.slope`) comes from the same factors by selected inversion
(:mod:`manifill.linalg.selinv`): ``d log det Q_ff = tr(Q_ff^-1 dQ_ff)`` on ``Q``'s pattern, ``d log det K =
2 kappa sum_i c_i (K^-1)_ii``, and ``d (t' S t) = x' dQ x`` with ``x`` the extension of ``t`` that ``S`` minimises
(``x_f = -Q_ff^-1 Q_fs t``), with ``dQ = 4 kappa K`` (``alpha = 2``) or ``2 kappa C``.
"""

import math

import numpy as np
import scipy.sparse as sp

from ..errors import SolveError
from ..memory import check_fits, lu_memory
from .cholesky import (NOT_DEFINITE, SAMPLES_LAST_MAX, SamplesLast, cholesky, cholmod_available, cholmod_module,
                       from_cholmod, superlu_spd)
from .selinv import SelectedInverse

__all__ = ["spd_logdet", "sparse_fit_pays", "LogdetFactors", "VertexLikelihood", "LOO_MAX", "loo_residuals"]

_LOG2PI = math.log(2.0 * math.pi)

#: Most samples whose leave-one-out residuals :func:`loo_residuals` computes (a dense ``m x m`` block of a factor
#: with the samples last: :data:`manifill.linalg.cholesky.SAMPLES_LAST_MAX`).
LOO_MAX = SAMPLES_LAST_MAX


def spd_logdet(A):
    """``(factor, log det A)`` of a sparse symmetric positive definite ``A`` (SuperLU, symmetric mode).

    Examples
    --------
    >>> f, ld = spd_logdet(sp.diags([2.0, 3.0]))
    >>> round(ld, 12) == round(math.log(6.0), 12), f.solve(np.array([2.0, 3.0])).tolist()
    (True, [1.0, 1.0])
    """
    lu, d = superlu_spd(sp.csc_matrix(A))
    return lu, float(np.log(d).sum())


def sparse_fit_pays():
    """Whether a fit on every sample through :class:`VertexLikelihood` pays: with CHOLMOD (the ``[cholmod]``
    extra) it took 5.7 s where the dense fit on a subset of 200 took 21 s (41k vertices, 1,000 samples, side by
    side), 27.5 s against 84.5 s at 163k; with SuperLU alone 22.7 s at 41k and unfinished after 10 minutes at 163k."""
    return cholmod_available()


class LogdetFactors:
    """Factorisations with their log-determinants for one pattern after another (the trials of a fit).

    With CHOLMOD (the ``[cholmod]`` extra) the symbolic analysis of each pattern is done once and every trial
    factorises numerically only (0.30 s against SuperLU's 0.94 s for ``Q_ff`` at 41k vertices, 0.12 s against
    1.46 s for ``K``); without it, SuperLU (:func:`spd_logdet`).
    """

    def __init__(self):
        self._cholmod = cholmod_module()
        self._symbolic = {}
        self._checked = set()
        self.name = "cholmod" if self._cholmod is not None else "superlu"

    def samples_last(self, Q, idx):
        """A :class:`manifill.linalg.cholesky.SamplesLast` factor of ``Q`` (CHOLMOD), its analyses kept for the next."""
        if "samples last" not in self._checked:
            n = Q.shape[0]
            check_fits(lu_memory(n, Q.nnz, dim=2), f"the likelihood's sparse factor of {n:,} unknowns",
                       "give the range and sigma (gp={'range': ..., 'sigma': ...}) instead of fitting them")
            self._checked.add("samples last")
        return SamplesLast(Q, idx, self._symbolic.setdefault("samples last", {}))

    def factor(self, key, A, selected=False):
        """``(solve, log det A)`` of the symmetric positive definite ``A``, whose pattern is named ``key``; with
        ``selected``, the first is a :class:`manifill.linalg.cholesky.Factor` (for a selected inversion).

        The first factorisation of each pattern is refused before it starts if its estimated fill
        (:func:`manifill.memory.lu_memory`) will not fit."""
        if key not in self._checked:
            n = A.shape[0]
            check_fits(lu_memory(n, A.nnz, dim=2), f"the likelihood's sparse factor of {n:,} unknowns",
                       "give the range and sigma (gp={'range': ..., 'sigma': ...}) instead of fitting them")
            self._checked.add(key)
        if self._cholmod is None:
            if selected:
                f = cholesky(A, backend="superlu")
                return f, f.logdet
            lu, ld = spd_logdet(A)
            return lu.solve, ld
        A = sp.csc_matrix(A)
        try:
            if key not in self._symbolic:
                self._symbolic[key] = self._cholmod.analyze(A)
            f = self._symbolic[key].cholesky(A)
        except self._cholmod.CholmodNotPositiveDefiniteError:
            raise SolveError(NOT_DEFINITE) from None
        return (from_cholmod(f) if selected else f), float(f.logdet())



class VertexLikelihood:
    """``-2 log L`` of the columns of ``Y`` observed exactly at the vertices ``idx``, for one ``kappa``.

    Parameters
    ----------
    shape : manifill.linalg.spde.MaternShape
    kappa : float
    idx : (m,) int64 numpy array
        Sorted unique observed vertices.
    Y : (m, p) numpy array
    mean : 'constant' or float
        Estimated constant mean (REML) or a known one.
    factors : LogdetFactors, optional
        Shared by the trials of one fit (CHOLMOD's symbolic analyses are kept there).
    """

    def __init__(self, shape, kappa, idx, Y, mean="constant", factors=None, slope=False):
        factors = LogdetFactors() if factors is None else factors
        n = shape.n
        free = np.setdiff1d(np.arange(n), idx)
        Q = sp.csr_array(shape.precision(kappa))
        Qff = Q[free][:, free]
        Qsf = sp.csr_array(Q[idx][:, free])
        Qss = Q[idx][:, idx]
        if factors.name == "cholmod" and not slope and len(idx) <= SAMPLES_LAST_MAX:  # log det R = -log det S
            sl = factors.samples_last(Q, idx)
            self.logdet_r = -sl.logdet_schur()
            solve_ff = sl.solve_free
        else:
            f_ff, ld_ff = factors.factor("Q_ff", Qff, selected=slope)
            f_k, ld_k = factors.factor("K", shape.K(kappa), selected=slope)
            ld_q = ld_k if shape.alpha == 1 else 2.0 * ld_k - float(np.log(shape.mid).sum())
            self.logdet_r = ld_ff - ld_q
            solve_ff = f_ff.solve if slope else f_ff
        self.m = len(idx)
        self.known = not isinstance(mean, str)
        Y = np.asarray(Y, dtype=np.float64).reshape(self.m, -1) - (float(mean) if self.known else 0.0)
        T = np.column_stack([np.ones(self.m), Y])
        Xf = -np.asarray(solve_ff(np.asarray(Qsf.T @ T))).reshape(len(free), -1)
        self.G = T.T @ (Qss @ T + Qsf @ Xf)  # [1 Y]' S [1 Y]
        self.kappa = kappa
        self.dG = self.dlogdet_r = None
        if slope:
            dQ = shape.dprecision(kappa)
            X = np.empty((n, T.shape[1]))
            X[idx], X[free] = T, Xf
            self.dG = X.T @ (dQ @ X)  # d/dkappa of [1 Y]' S [1 Y]
            tr_ff = SelectedInverse(f_ff).trace_product(dQ[free][:, free])
            dld_k = 2.0 * kappa * float(shape.c @ SelectedInverse(f_k).diagonal())
            self.dlogdet_r = tr_ff - (dld_k if shape.alpha == 1 else 2.0 * dld_k)

    def dof(self):
        """Degrees of freedom of the scale: ``m - 1`` (REML) or ``m``."""
        return self.m - (0 if self.known else 1)

    def profiled(self, eta, j):
        """``(-2 log L, s^2)`` of field ``j`` with the scale profiled (no noise: ``eta`` must be 0)."""
        if eta:
            raise ValueError("the vertex likelihood is for exact samples (eta = 0)")
        a, b, c = self.G[0, 0], self.G[0, j + 1], self.G[j + 1, j + 1]
        f = self.dof()
        q = c if self.known else c - b * b / a
        s2 = max(q / f, 1e-300)
        ld = self.logdet_r + (0.0 if self.known else math.log(a))
        return ld + f * math.log(s2) + f + f * _LOG2PI, s2

    def slope(self, j):
        """``d(-2 log L) / d log kappa`` of :meth:`profiled` for field ``j`` (built with ``slope=True``)."""
        if self.dG is None:
            raise ValueError("build the likelihood with slope=True for its derivative")
        G, dG, f = self.G, self.dG, self.dof()
        a, b, c = G[0, 0], G[0, j + 1], G[j + 1, j + 1]
        da, db, dc = dG[0, 0], dG[0, j + 1], dG[j + 1, j + 1]
        if self.known:
            d = self.dlogdet_r + f * dc / c
        else:
            q = c - b * b / a
            dq = dc - 2.0 * b * db / a + b * b * da / (a * a)
            d = self.dlogdet_r + da / a + f * dq / q
        return float(d * self.kappa)


def loo_residuals(Q, idx, Y, free_order, mean="constant", Lss=None):
    """Leave-one-out residuals of exact samples at the vertices ``idx``, standardised (units of the scale ``s``).

    With the samples ordered last, the Cholesky factor of ``Q`` ends in ``L_ss`` with ``L_ss L_ss' = S``, the
    Schur complement (``S = R^-1``, the data's precision). Universal kriging's leave-one-out (the constant mean
    estimated again without each sample) then has, with ``S_b = S - S 1 1' S / (1' S 1)``, the residual
    ``(S_b y)_i / (S_b)_ii`` and the variance ``s^2 / (S_b)_ii``: so ``z_i = (S_b y)_i / sqrt((S_b)_ii)`` / ``s``
    (Dubrule 1983), for every sample from one factorisation.

    Parameters
    ----------
    Q : (n, n) sparse precision (shape)
    idx : (m,) sorted unique int array
    Y : (m, p) array
    free_order : (n - m,) int array
        A fill-reducing order of the other vertices (e.g. the variance's factor's ``p``).
    mean : 'constant' or float
    Lss : (m, m) numpy array, optional
        The factor's last block where it is at hand (:class:`manifill.linalg.cholesky.SamplesLast`).

    Returns
    -------
    (m, p) numpy array
        ``z * s`` for each sample and field (divide by the field's scale).
    """
    n, m = Q.shape[0], len(idx)
    if Lss is None:
        free = np.setdiff1d(np.arange(n), idx)
        f = cholesky(Q, order=np.concatenate([free[free_order], idx]))
        Lss = f.L[n - m:, n - m:].toarray()
    known = not isinstance(mean, str)
    Y = np.asarray(Y, dtype=np.float64).reshape(m, -1) - (float(mean) if known else 0.0)
    SY = Lss @ (Lss.T @ Y)
    d = np.einsum("ij,ij->i", Lss, Lss)
    if not known:
        s1 = Lss @ (Lss.T @ np.ones(m))
        a = float(s1.sum())
        SY = SY - np.outer(s1, s1 @ Y) / a
        d = d - s1 * s1 / a
    return SY / np.sqrt(np.maximum(d, 1e-300))[:, None]
