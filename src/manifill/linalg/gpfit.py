"""The Matérn field's hyperparameters by maximum restricted likelihood, in the kriging form.

Observed at ``m`` rows ``H`` (a subset of the samples when there are many), field ``j``
is ``y_j ~ N(beta_j 1, s_j^2 R(kappa) + n_j I)`` with ``R(kappa) = H (Q / tau^2)^-1 H'``
(:meth:`manifill.linalg.spde.MaternShape.covariance_at`: one factorisation of ``K`` and
``m`` solves per ``kappa``), ``s_j^2 = 1 / tau_j^2`` and ``n_j`` the noise variance.
The constant mean ``beta_j`` is integrated out with a flat prior (REML, the restricted
likelihood), or known. One eigendecomposition of ``R`` per ``kappa`` makes every
``(s^2, n)`` cost ``O(m)``: the scale is profiled in closed form, the noise ratio
searched in one dimension, ``log kappa`` on a grid then refined (Brent).

``-2 log L = sum log D + log(1' S^-1 1) + r' S^-1 r + (m - 1) log 2 pi`` with ``S = U
diag(D) U'`` (REML; a known mean drops the middle term and uses ``m``).
"""

import math

import numpy as np
from scipy.special import gamma, kv

from .search import bounded_search

__all__ = ["Likelihood", "restricted_loglik", "fit_range", "matern_correlation", "near_euclidean"]

_LOG2PI = math.log(2.0 * math.pi)


class Likelihood:
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

    def terms(self, D, j):
        """``(log-det part, quadratic form)`` of field ``j`` for the spectrum ``D``."""
        yt = self.yt[:, j]
        if self.known:
            return float(np.log(D).sum()), float((yt * yt / D).sum())
        a = float((self.ot * self.ot / D).sum())
        b = float((self.ot * yt / D).sum())
        r = yt - (b / a) * self.ot
        return float(np.log(D).sum() + math.log(a)), float((r * r / D).sum())

    def dof(self):
        """Degrees of freedom of the scale: ``m - 1`` (REML) or ``m``."""
        return self.m - (0 if self.known else 1)

    def profiled(self, eta, j):
        """``(-2 log L, s^2)`` with ``S = s^2 (R + eta I)`` and the best ``s^2`` for field ``j``."""
        ld, q = self.terms(self.lam + eta, j)
        f = self.dof()
        s2 = max(q / f, 1e-300)
        return ld + f * math.log(s2) + f + f * _LOG2PI, s2

    def absolute(self, s2, n2, j):
        """``-2 log L`` with ``S = s^2 R + n2 I`` for field ``j``."""
        D = s2 * self.lam + n2
        ld, q = self.terms(D, j)
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


def fit_range(covariance, Y, kappa_bounds, *, mean="constant", s2=None, noise2=None, fit_noise=False,
              kappa=None, points=7, likelihood=None):
    """Fit ``kappa`` (unless given) and the scales and noise of the fields ``Y`` together.

    Parameters
    ----------
    covariance : callable
        ``kappa -> R(kappa)`` (dense ``m x m``).
    Y : (m, p) numpy array
    kappa_bounds : (float, float)
        The search interval of ``kappa``.
    kappa : float, optional
        Known ``kappa``: only the scales and the noise are fitted.
    points : int, optional
        The grid of ``log kappa`` before Brent's refinement.
    likelihood : callable, optional
        ``kappa -> `` an object with :class:`Likelihood`'s ``profiled`` and ``dof`` (exact samples, the scale
        profiled: :class:`manifill.linalg.sparselik.VertexLikelihood`), instead of ``Likelihood(covariance(kappa))``.
    mean, s2, noise2, fit_noise
        As :class:`Likelihood` and :func:`restricted_loglik`; ``s2`` may also be a function
        of ``kappa`` (a given marginal sigma fixes the scale at each ``kappa``).

    Returns
    -------
    dict
        ``kappa``, ``s2`` and ``noise2`` (lists per field), ``neg2loglik``, ``loglik``,
        ``evaluations`` (of ``R``).
    """
    Y = np.asarray(Y, dtype=np.float64).reshape(len(Y), -1)
    cols = list(range(Y.shape[1]))
    cache = {}

    def objective(lk):
        lik = Likelihood(covariance(math.exp(lk)), Y, mean) if likelihood is None else likelihood(math.exp(lk))
        s = s2(math.exp(lk)) if callable(s2) else s2  # a given sigma makes the scale follow kappa
        v, params = restricted_loglik(lik, cols, s2=s, noise2=noise2, fit_noise=fit_noise)
        cache[lk] = (v, params)
        return v

    if kappa is None:
        lo, hi = (math.log(b) for b in kappa_bounds)
        lk, _ = bounded_search(objective, lo, hi, points, parabolic=True)
    else:
        lk = math.log(kappa)
    if lk not in cache:
        objective(lk)
    v, params = cache[lk]
    return {"kappa": math.exp(lk), "s2": [p[0] for p in params], "noise2": [p[1] for p in params],
            "neg2loglik": v, "loglik": -0.5 * v, "evaluations": len(cache)}


def matern_correlation(D, kappa, nu):
    """The Matérn correlation ``2^(1-nu) / Gamma(nu) (kappa r)^nu K_nu(kappa r)`` of distances ``D`` (``nu > 0``).

    Examples
    --------
    >>> c = matern_correlation(np.array([0.0, 1.0]), 2.0, 0.5)
    >>> bool(np.allclose(c, [1.0, np.exp(-2.0)]))
    True
    """
    x = np.maximum(np.asarray(D, dtype=np.float64) * kappa, 1e-300)
    c = (2.0 ** (1.0 - nu) / gamma(nu)) * x ** nu * kv(nu, x)
    return np.where(np.asarray(D) == 0, 1.0, c)


def near_euclidean(P, Y, bounds, v, mean, noise2, fit_noise, report):
    """``(bounds, grid points)`` for the mesh's search: within a factor 2 of the straight-line Matérn fit."""
    D = np.linalg.norm(P[:, None, :] - P[None, :, :], axis=-1)
    fit = fit_range(lambda kap: matern_correlation(D, kap, v), Y, bounds, mean=mean, noise2=noise2,
                    fit_noise=fit_noise)
    k0 = fit["kappa"]
    lo, hi = max(bounds[0], k0 / 2.0), min(bounds[1], k0 * 2.0)
    report["fit_start"] = {"kappa": k0, "from": "straight-line distances", "bracket": [lo, hi]}
    if not lo < hi:
        return bounds, 7
    return (lo, hi), 3
