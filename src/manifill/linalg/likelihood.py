"""The restricted likelihood of the Matérn field's samples: one formula, two ways to its terms.

Field ``j`` observed at ``m`` samples is ``y_j ~ N(beta_j 1, s_j^2 R + n_j I)``; with ``S`` the covariance shape
(``R + eta I``, ``eta = n_j / s_j^2``), ``a = 1' S^-1 1``, ``b = 1' S^-1 y``, ``c = y' S^-1 y``, the constant mean
integrated out with a flat prior (REML) gives

    -2 log L = log det S + log a + (c - b^2 / a) / s^2 + (m - 1) log s^2 + (m - 1) log 2 pi

(a known mean drops ``log a`` and ``b`` and counts ``m``); :func:`reml_terms` is that algebra, the one place it is
written, and the best scale ``s^2`` is in closed form (:meth:`_Restricted.profiled`). The terms come

- from the spectrum of a dense ``R`` (:class:`Likelihood`: the kriging form of :mod:`manifill.linalg.gpfit`, one
  eigendecomposition per ``kappa``, every ``(s^2, n)`` then ``O(m)``), or
- from sparse factors of the precision ``Q`` for exact samples at vertices (:class:`VertexLikelihood`: by the Schur
  complement ``R^-1 = Q_ss - Q_sf Q_ff^-1 Q_fs`` and ``log det R = log det Q_ff - log det Q``, every sample and no
  dense covariance; :mod:`manifill.linalg.logdet` holds the factors), with its derivative in ``kappa`` by selected
  inversion: ``d log det Q_ff = tr(Q_ff^-1 dQ_ff)``, ``d log det K = 2 kappa sum_i c_i (K^-1)_ii``, ``d (t' S t) =
  x' dQ x`` with ``x`` the extension of ``t`` that ``S`` minimises, ``dQ = 4 kappa K`` (``alpha = 2``) or
  ``2 kappa C``.

The two agree to 1e-13 (a test). :func:`restricted_loglik` maximises either over the scales and the noise.
"""

import math

import numpy as np
import scipy.sparse as sp

from .cholesky import SAMPLES_LAST_MAX
from .logdet import LogdetFactors
from .search import bounded_search
from .selinv import SelectedInverse

__all__ = ["reml_terms", "Likelihood", "VertexLikelihood", "restricted_loglik"]

_LOG2PI = math.log(2.0 * math.pi)


def reml_terms(logdet, a, b, c, known):
    """``(log-det part, quadratic form)`` of one field from ``log det S``, ``a = 1'S^-1 1``, ``b = 1'S^-1 y`` and
    ``c = y'S^-1 y``: the mean integrated out (``known`` False) or known (``y`` already centred on it).

    Examples
    --------
    >>> reml_terms(0.0, 2.0, 2.0, 3.0, known=False) == (math.log(2.0), 1.0)
    True
    """
    if known:
        return float(logdet), float(c)
    return float(logdet + math.log(a)), float(c - b * b / a)


class _Restricted:
    """``-2 log L`` from :meth:`terms`, the scale profiled or given (shared by the dense and the sparse forms)."""

    m = 0
    known = False

    def terms(self, eta, j):
        raise NotImplementedError

    def dof(self):
        """Degrees of freedom of the scale: ``m - 1`` (REML) or ``m``."""
        return self.m - (0 if self.known else 1)

    def profiled(self, eta, j):
        """``(-2 log L, s^2)`` of field ``j`` with ``S = s^2 (R + eta I)`` and the best ``s^2``."""
        ld, q = self.terms(eta, j)
        f = self.dof()
        s2 = max(q / f, 1e-300)
        return ld + f * math.log(s2) + f + f * _LOG2PI, s2


class Likelihood(_Restricted):
    """The restricted likelihood of the data columns for one ``R`` (eigendecomposed once).

    Parameters
    ----------
    R : (m, m) numpy array
        Covariance shape at the observations, symmetric positive definite.
    Y : (m, p) numpy array
    mean : 'constant' or float
        Estimated constant mean (REML) or a known one.
    """

    def __init__(self, R, Y, mean="constant"):
        lam, U = np.linalg.eigh(R)
        self.lam = np.maximum(lam, lam.max() * 1e-15)
        self.m = R.shape[0]
        self.known = not isinstance(mean, str)
        Y = np.asarray(Y, dtype=np.float64).reshape(self.m, -1)
        self.yt = U.T @ (Y - (float(mean) if self.known else 0.0))
        self.ot = U.T @ np.ones(self.m)

    def spectrum_terms(self, D, j):
        """``(log-det part, quadratic form)`` of field ``j`` for the spectrum ``D`` of ``S``."""
        yt = self.yt[:, j]
        if self.known:
            return reml_terms(np.log(D).sum(), None, None, (yt * yt / D).sum(), True)
        return reml_terms(np.log(D).sum(), (self.ot * self.ot / D).sum(), (self.ot * yt / D).sum(),
                          (yt * yt / D).sum(), False)

    def terms(self, eta, j):
        """``(log-det part, quadratic form)`` of field ``j`` with ``S = R + eta I``."""
        return self.spectrum_terms(self.lam + eta, j)

    def absolute(self, s2, n2, j):
        """``-2 log L`` with ``S = s^2 R + n2 I`` for field ``j``."""
        D = s2 * self.lam + n2
        ld, q = self.spectrum_terms(D, j)
        return ld + q + self.dof() * _LOG2PI


def restricted_loglik(lik, cols, *, s2=None, noise2=None, fit_noise=False):
    """Best ``-2 log L`` summed over the fields ``cols``, and each field's ``(s2, noise2)``.

    Parameters
    ----------
    lik : Likelihood
    cols : list of int
        Fields fitted together (sharing the noise ratio when ``fit_noise``).
    s2 : None or (p,) array, optional
        Known scales (None: fitted).
    noise2 : None or (p,) array, optional
        Known noise variances (None: 0 unless ``fit_noise``).
    fit_noise : bool, optional

    Returns
    -------
    value : float
    params : list of (s2, noise2) per field in ``cols``
    """
    if noise2 is not None and not fit_noise and not np.any(np.asarray(noise2)[cols]):
        noise2 = None  # no noise: the scale in closed form, whatever the units of R
    if s2 is None and noise2 is None and not fit_noise:  # the scale profiled, no noise
        out = [lik.profiled(0.0, j) for j in cols]
        return sum(o[0] for o in out), [(o[1], 0.0) for o in out]
    scale = float(np.mean(lik.lam))  # the searches below are in the units of R
    lo, hi = math.log(scale * 1e-8), math.log(scale * 10.0)
    if s2 is None and (noise2 is None or fit_noise):  # scale profiled; the noise ratio shared by cols

        def total(le):
            return sum(lik.profiled(math.exp(le), j)[0] for j in cols)

        le, v = bounded_search(total, lo, hi)
        v0 = sum(lik.profiled(0.0, j)[0] for j in cols)  # no noise at all: the end of the log scale
        eta = 0.0 if v0 <= v else math.exp(le)
        out = [lik.profiled(eta, j) for j in cols]
        return sum(o[0] for o in out), [(o[1], eta * o[1]) for o in out]
    value, params = 0.0, []
    for j in cols:
        if s2 is None:  # absolute noise given: search the scale
            n2 = float(noise2[j])
            # the data are standardised, so s^2 R is near 1 at the optimum: the search is in the units of R
            ls, v = bounded_search(lambda x, n2=n2, j=j: lik.absolute(math.exp(x), n2, j),
                                   math.log(1e-12 / scale), math.log(1e12 / scale))
            params.append((math.exp(ls), n2))
        elif fit_noise:  # scale given: search the noise
            sj = float(s2[j])
            ln, v = bounded_search(lambda x, sj=sj, j=j: lik.absolute(sj, math.exp(x), j),
                                   math.log(sj * scale * 1e-8), math.log(sj * scale * 10.0))
            v0 = lik.absolute(sj, 0.0, j)
            if v0 <= v:
                ln, v = -np.inf, v0
            params.append((sj, math.exp(ln)))
        else:
            n2 = 0.0 if noise2 is None else float(noise2[j])
            v = lik.absolute(float(s2[j]), n2, j)
            params.append((float(s2[j]), n2))
        value += v
    return value, params


class VertexLikelihood(_Restricted):
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

    def terms(self, eta, j):
        """``(log-det part, quadratic form)`` of field ``j`` (exact samples: ``eta`` must be 0)."""
        if eta:
            raise ValueError("the vertex likelihood is for exact samples (eta = 0)")
        a, b, c = self.G[0, 0], self.G[0, j + 1], self.G[j + 1, j + 1]
        return reml_terms(self.logdet_r, a, b, c, self.known)

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
