"""Draws of a fitted Gaussian process's posterior field: whole fields, for carrying its uncertainty onwards.

The mean of :func:`manifill.linalg.gp.gp_condition` plus conditional draws of the zero-mean field
(:meth:`manifill.linalg.gaussian.Conditional.draws`) at the fitted scale, with the estimated mean's own
uncertainty; their spread is the std ``gp_condition`` reports.
"""

import math

import numpy as np

from .gaussian import Conditional

__all__ = ["posterior_draws"]


def posterior_draws(shape, idx, rows, X, summary, draws, seed=0):
    """Draws of the posterior field, ``(n, p, draws)``: the mean ``X`` plus conditional draws at the fitted scale.

    With the mean estimated (REML), each draw also carries the mean's own uncertainty, ``(1 - z) xi / sqrt(a)``
    (``z`` the conditional mean of a field of ones, ``a = 1' S^-1 1``, ``xi ~ N(0, 1)``), so that the draws'
    spread is the std :func:`gp_condition` reports.

    Parameters
    ----------
    shape : MaternShape
    idx, rows
        The observations, as for :func:`gp_condition`.
    X : (n, p) numpy array
        The posterior mean.
    summary : dict
        The report of :func:`gp_condition` (``kappa``, ``scale``, ``noise`` per field, ``mean_model``).
    draws : int
    seed : int, optional
    """
    rng = np.random.default_rng(seed)
    n, p = X.shape
    out = np.empty((n, p, int(draws)))
    known = summary.get("mean_model", "constant") != "constant"
    laws = {}  # fields sharing kappa and the noise ratio share one conditional law (one factorisation)
    for j in range(p):
        kap, scale, noise = summary["kappa"][j], summary["scale"][j], summary["noise"][j]
        eta = None if noise == 0 or scale == 0 else (noise / scale) ** 2
        if (kap, eta) not in laws:
            cond = Conditional(shape.precision(kap), shape.root(kap), idx, rows=rows, eta=eta, solver="direct",
                               definite=True)
            ones = np.ones((cond.m, 1))
            z = cond.extend(ones)
            laws[kap, eta] = cond, z, float(cond.gram(ones, z)[0, 0])
        cond, z, a = laws[kap, eta]
        E = cond.draws(int(draws), rng)
        if not known:
            E = E + (1.0 - z) * rng.standard_normal(int(draws))[None, :] / math.sqrt(a)
        out[:, j, :] = X[:, j:j + 1] + scale * E
    return out
