"""Sparse factors with their log-determinants for the likelihood's trials, and leave-one-out residuals.

:class:`LogdetFactors` factorises one pattern after another (``Q_ff``, ``K``, or ``Q`` with the samples last) for
:class:`manifill.linalg.likelihood.VertexLikelihood`, CHOLMOD's symbolic analyses kept between trials;
:func:`loo_residuals` gives every sample's leave-one-out residual from one factor with the samples last.
"""


import numpy as np
import scipy.sparse as sp

from ..errors import SolveError
from ..memory import check_fits, lu_memory
from .cholesky import (NOT_DEFINITE, SAMPLES_LAST_MAX, SamplesLast, cholesky, cholmod_available, cholmod_module,
                       from_cholmod, superlu_spd)

__all__ = ["spd_logdet", "sparse_fit_pays", "LogdetFactors", "LOO_MAX", "loo_residuals"]


#: Most samples whose leave-one-out residuals :func:`loo_residuals` computes (a dense ``m x m`` block of a factor
#: with the samples last: :data:`manifill.linalg.cholesky.SAMPLES_LAST_MAX`).
LOO_MAX = SAMPLES_LAST_MAX


def spd_logdet(A):
    """``(factor, log det A)`` of a sparse symmetric positive definite ``A`` (SuperLU, symmetric mode).

    Examples
    --------
    >>> f, ld = spd_logdet(sp.diags([2.0, 3.0]))
    >>> round(ld, 12) == round(float(np.log(6.0)), 12), f.solve(np.array([2.0, 3.0])).tolist()
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
