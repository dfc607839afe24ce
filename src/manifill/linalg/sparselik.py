"""The restricted likelihood of exact samples at vertices from sparse factors: every sample, no dense covariance.

For the field ``x ~ N(beta 1, s^2 Q^-1)`` observed exactly at the vertices ``s`` (the others ``f``), the data's
covariance is ``s^2 R`` with ``R = (Q^-1)_ss`` and, by the Schur complement,

    R^-1 = S = Q_ss - Q_sf Q_ff^-1 Q_fs,        log det R = log det Q_ff - log det Q,

so one factorisation of ``Q_ff`` (and one of ``K``: ``log det Q = 2 log det K - log det C`` for ``alpha = 2``)
gives the likelihood of all ``m`` samples, where the kriging form (:mod:`manifill.linalg.gpfit`) builds the dense
``m x m`` matrix ``R`` by ``m`` solves and so fits on a subset. The value is the same
(:meth:`manifill.linalg.gpfit.Likelihood.profiled` with no noise, the scale profiled, the mean by REML or
known).
"""

import math

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..errors import SolveError

__all__ = ["spd_logdet", "VertexLikelihood"]

_LOG2PI = math.log(2.0 * math.pi)


def spd_logdet(A):
    """``(factor, log det A)`` of a sparse symmetric positive definite ``A`` (SuperLU, symmetric mode).

    Examples
    --------
    >>> f, ld = spd_logdet(sp.diags([2.0, 3.0]))
    >>> round(ld, 12) == round(math.log(6.0), 12), f.solve(np.array([2.0, 3.0])).tolist()
    (True, [1.0, 1.0])
    """
    lu = splu(sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
              options={"SymmetricMode": True})
    d = lu.U.diagonal()
    if not np.all(d > 0):
        raise SolveError("the precision is not positive definite to working precision (degenerate elements?); "
                         "clean the mesh")
    return lu, float(np.log(d).sum())


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
    """

    def __init__(self, shape, kappa, idx, Y, mean="constant"):
        n = shape.n
        free = np.setdiff1d(np.arange(n), idx)
        Q = sp.csr_array(shape.precision(kappa))
        Qff = Q[free][:, free]
        Qsf = sp.csr_array(Q[idx][:, free])
        Qss = Q[idx][:, idx]
        ff, ld_ff = spd_logdet(Qff)
        _, ld_k = spd_logdet(shape.K(kappa))
        ld_q = ld_k if shape.alpha == 1 else 2.0 * ld_k - float(np.log(shape.c).sum())
        self.logdet_r = ld_ff - ld_q
        self.m = len(idx)
        self.known = not isinstance(mean, str)
        Y = np.asarray(Y, dtype=np.float64).reshape(self.m, -1) - (float(mean) if self.known else 0.0)
        T = np.column_stack([np.ones(self.m), Y])
        ST = Qss @ T - Qsf @ np.asarray(ff.solve(np.asarray(Qsf.T @ T))).reshape(len(free), -1)
        self.G = T.T @ ST  # [1 Y]' S [1 Y]

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
