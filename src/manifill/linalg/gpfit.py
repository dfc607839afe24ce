"""The Matérn field's hyperparameters by maximum restricted likelihood, in the kriging form.

Observed at ``m`` rows ``H`` (a subset of the samples when there are many), field ``j``
is ``y_j ~ N(beta_j 1, s_j^2 R(kappa) + n_j I)`` with ``R(kappa) = H (Q / tau^2)^-1 H'``
(:meth:`manifill.linalg.spde.MaternShape.covariance_at`: one factorisation of ``K`` and
``m`` solves per ``kappa``), ``s_j^2 = 1 / tau_j^2`` and ``n_j`` the noise variance.
The likelihood itself is :mod:`manifill.linalg.likelihood`'s (the dense :class:`Likelihood`, or the sparse
:class:`VertexLikelihood` for exact samples at vertices); here ``log kappa`` is searched on a grid then refined
(Brent), the scales and the noise fitted at each trial by :func:`manifill.linalg.likelihood.restricted_loglik`.
"""

import math

import numpy as np
from scipy.special import gamma, kv

from .likelihood import Likelihood, restricted_loglik  # noqa: F401 (restricted_loglik: the name here before)
from .search import bounded_search

__all__ = ["fit_range", "matern_correlation", "near_euclidean"]


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
        profiled: :class:`manifill.linalg.likelihood.VertexLikelihood`), instead of ``Likelihood(covariance(kappa))``.
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
