"""Gaussian-process reconstruction on any domain with a stiffness and a mass: options, fit, mean and std.

:func:`gp_condition` takes the Matérn shape of a domain (:class:`manifill.linalg.spde.MaternShape`),
the observations (vertex samples and barycentric rows) and :class:`GPOptions`, and returns the
posterior mean and standard deviation at every node with a report:

1. hyperparameters: the range, the marginal standard deviation and the noise, each given or
   fitted by maximum restricted likelihood (:mod:`manifill.linalg.gpfit`, on at most
   ``fit_samples`` of the samples, drawn at random with ``seed``);
2. the mean: a constant ``beta`` per field by generalised least squares (or known), plus the
   conditional mean of the rest (:class:`manifill.linalg.gaussian.Conditional`);
3. the variance: the conditional variance, plus the variance of ``beta``'s estimate
   (universal kriging: ``s^2 (1 - x_1)^2 / (1' S^-1 1)``, ``x_1`` the predictor of unit data).

:func:`intrinsic_std` gives the same reading to an energy method (harmonic: ``Q = L``, the
Gaussian free field; biharmonic: ``L M^-1 L``), whose mean is the method's own result.
"""

import math
import time
from dataclasses import dataclass

import numpy as np

from ..errors import OptionError, SampleError
from .factorise import factorise
from .gaussian import Conditional, factoriser_for, loo_summary, observation_matrix, variance_summary
from .likelihood import VertexLikelihood
from .logdet import LogdetFactors, sparse_fit_pays
from .gpfit import fit_range, near_euclidean
from .gpoptions import BARRIER_MODELS, GPOptions, as_gp_options  # noqa: F401 (their home before)
from .spde import kappa_from_range, nu, range_from_kappa, sigma_from_tau

__all__ = ["GPOptions", "BARRIER_MODELS", "as_gp_options", "gp_condition", "intrinsic_std"]


def _groups(keys):
    out = {}
    for j, key in enumerate(keys):
        out.setdefault(key, []).append(j)
    return out


@dataclass(frozen=True)
class _Prior:
    """The SPDE's order and dimension, and the conversion between ``sigma`` and the scale ``s^2``."""

    alpha: int
    d: int
    nu: float
    var_factor: float  # the marginal variance at kappa = 1 and s^2 = 1

    @classmethod
    def of(cls, alpha, d):
        v = nu(alpha, d)
        return cls(alpha, d, v, 1.0 if v <= 0 else sigma_from_tau(1.0, 1.0, alpha, d) ** 2)

    def s2_of_sigma(self, sigma, kappa):
        """``s^2`` from ``sigma^2 = s^2 * factor(kappa)``, ``factor = factor(1) * kappa^(-2 nu)``."""
        return float(sigma) ** 2 / (self.var_factor * kappa ** (-2.0 * self.nu))

    def sigma(self, s2, kappa):
        """The marginal standard deviation of the scale ``s2`` at ``kappa`` (None without a finite variance)."""
        return None if self.nu <= 0 else math.sqrt(s2 * self.var_factor * kappa ** (-2.0 * self.nu))


@dataclass
class _Hyper:
    """Per field: ``kappa``, the scale ``s2`` (None: profiled in closed form with the mean) and noise ``n2``."""

    kappa: list
    s2: list
    n2: list


@dataclass(frozen=True)
class _FitData:
    """What the likelihood sees: each field standardised, ``Z = (Y[sub] - centre) / unit``."""

    sub: np.ndarray
    Z: np.ndarray
    unit: np.ndarray
    mean: object  # 0.0 (a known mean, subtracted) or 'constant'
    noise2: object  # the given noise variance per field in the units of Z, or None
    fit_noise: bool


def gp_condition(shape, idx, rows, Y, opts, *, length, diameter, solver="auto", positions=None, with_std=True):
    """Posterior mean and standard deviation of the Matérn field at every node.

    The steps: :func:`_check_samples`; the hyperparameters, fitted (:func:`_fit`) or given
    (:func:`_given`); the posterior per group of fields sharing a precision (:func:`_posterior`);
    the report's summary (:func:`_summary`).

    Parameters
    ----------
    shape : MaternShape
    idx : (k,) int64 numpy array
        Sample nodes, sorted and unique.
    rows : (m, n) scipy sparse matrix or None
        Barycentric rows of samples inside faces (after the vertex samples in ``Y``).
    Y : (k + m, p) numpy array
    opts : GPOptions
    length, diameter : float
        A typical edge length and the domain's diameter: the search interval of the range.
    solver : {'auto', 'direct', 'amg'}, optional
    positions : (k + m, d) numpy array, optional
        Where the observations are. With them, a fitted range starts from the fit of the
        continuum Matérn correlation of straight-line distances (no solves), and the mesh's
        likelihood is then searched within a factor 2 of it (fewer factorisations; the
        whole interval when the optimum is at that bracket's edge).

    with_std : bool, optional
        False: the mean only (``std`` is None; no variance is computed).

    Returns
    -------
    X, std : (n, p) numpy arrays
    report : dict
    """
    t0 = time.perf_counter()
    prior = _Prior.of(opts.alpha, shape.d)
    Y = np.asarray(Y, dtype=np.float64)
    _check_samples(opts, prior, Y.shape[0])
    report = {"alpha": prior.alpha, "nu": prior.nu, "dimension": prior.d, "fitted": [], "mean_model": opts.mean}
    seconds = {}
    if _needs_fit(opts):
        t = time.perf_counter()
        hyper = _fit(shape, idx, rows, Y, opts, prior, (length, diameter), positions, report)
        seconds["fit"] = time.perf_counter() - t
    else:
        hyper = _given(opts, prior, Y.shape[1], report)
    t = time.perf_counter()
    X, std, beta, var_info, groups = _posterior(shape, idx, rows, Y, opts, hyper, solver, with_std, report)
    seconds["posterior"] = time.perf_counter() - t
    report.update(_summary(prior, hyper, beta, var_info, groups))
    report["seconds"] = {**seconds, "total": time.perf_counter() - t0}
    return X, (std if with_std else None), report


def _check_samples(opts, prior, m):
    """Refuse a fit with fewer than 3 observations, and a given ``sigma`` without a finite prior variance."""
    if m < 3 and "auto" in (opts.range, opts.sigma, opts.noise):
        raise SampleError(f"fitting the gp's hyperparameters needs at least 3 samples, got {m}; give range, "
                          f"sigma and noise in gp=")
    if opts.sigma != "auto" and prior.nu <= 0:
        raise OptionError(f"gp sigma= needs a finite prior variance, and alpha={prior.alpha} in dimension "
                          f"{prior.d} has none; pass alpha=2 or leave sigma='auto'")


def _needs_fit(opts):
    """Whether the likelihood is searched: a range or a noise to fit, or a scale with a given noise."""
    return opts.range == "auto" or opts.noise == "auto" or (opts.sigma == "auto" and opts.noise not in (0.0,))


def _noise2(opts, p):
    """The given noise variance per field, None when it is fitted."""
    return None if opts.noise == "auto" else np.full(p, float(opts.noise) ** 2)


def _field_sets(opts, p):
    """The columns fitted together: all of them (``share``), else one at a time."""
    return [list(range(p))] if opts.share else [[j] for j in range(p)]


def _given(opts, prior, p, report):
    """The hyperparameters as given (the scale, when not, is profiled later in closed form)."""
    kap = kappa_from_range(opts.range, prior.alpha, prior.d)
    noise2 = _noise2(opts, p)
    s2 = prior.s2_of_sigma(opts.sigma, kap) if opts.sigma != "auto" else None
    if opts.sigma == "auto":
        report["fitted"] = ["sigma"]
    return _Hyper([kap] * p, [s2] * p, [0.0 if noise2 is None else float(noise2[j]) for j in range(p)])


def _fit_data(Y, opts, positions, every=False):
    """The fit's subset of the samples (all of them with ``every``), each field standardised (:class:`_FitData`)."""
    m, p = Y.shape
    sub = np.arange(m)
    if m > opts.fit_samples and not every:  # in the order of the positions: the same subset however nodes are numbered
        order = np.arange(m) if positions is None else np.lexsort(np.asarray(positions, dtype=np.float64).T)
        pick = np.random.default_rng(opts.seed).choice(m, opts.fit_samples, replace=False)
        sub = np.sort(order[pick])
    # the fit sees each field standardised: the range it finds is then the same for a * y + b, exactly
    known = not isinstance(opts.mean, str)
    centre = np.full(p, float(opts.mean)) if known else Y[sub].mean(axis=0)
    unit = Y[sub].std(axis=0)
    unit[~(unit > 0)] = 1.0
    noise2 = _noise2(opts, p)
    return _FitData(sub, (Y[sub] - centre) / unit, unit, 0.0 if known else "constant",
                    None if noise2 is None else noise2 / unit ** 2, opts.noise == "auto")


def _fit(shape, idx, rows, Y, opts, prior, lengths, positions, report):
    """The fitted hyperparameters (:class:`_Hyper`); adds ``loglik``, ``fit`` (``fit_start``) and ``fitted``."""
    p = Y.shape[1]
    # exact samples at vertices, many of them: the likelihood of all from sparse factors (likelihood), not of a
    # subset from its dense covariance
    every = (rows is None and Y.shape[0] > opts.fit_samples and opts.sigma == "auto" and opts.noise != "auto"
             and not np.any(_noise2(opts, p)) and sparse_fit_pays())
    data = _fit_data(Y, opts, positions, every=every)
    Hs = observation_matrix(shape.n, idx, rows)[data.sub]

    def covariance(kap):
        return shape.covariance_at(kap, Hs, factorise(shape.K(kap).tocsc())[1])

    if every:
        factors = LogdetFactors()

        def likelihood(kap, Z):
            return VertexLikelihood(shape, kap, idx, Z, data.mean, factors)
    else:
        likelihood = None

    length, diameter = lengths
    bounds = (kappa_from_range(2.0 * diameter, prior.alpha, prior.d),
              kappa_from_range(max(2.0 * length, diameter / 200.0), prior.alpha, prior.d))
    bracket, points = bounds, 7
    if positions is not None and opts.range == "auto" and prior.nu > 0 and opts.sigma == "auto":
        near = data if not every else _fit_data(Y, opts, positions)  # the start from a subset's distances
        bracket, points = near_euclidean(np.asarray(positions, dtype=np.float64)[near.sub], near.Z, bounds,
                                          prior.nu, near.mean, near.noise2, near.fit_noise, report)
    hyper = _Hyper([None] * p, [None] * p, [0.0] * p)
    fits = []
    for cols in _field_sets(opts, p):
        fit = _fit_fields(covariance, data, cols, opts, prior, (bounds, bracket, points), likelihood)
        for i, j in enumerate(cols):
            hyper.kappa[j] = fit["kappa"]
            s2, hyper.n2[j] = fit["s2"][i] * data.unit[j] ** 2, fit["noise2"][i] * data.unit[j] ** 2
            # without noise and sigma, the scale is re-profiled on all the samples (closed form)
            hyper.s2[j] = None if opts.sigma == "auto" and hyper.n2[j] == 0.0 else s2
        # the standardisation's Jacobian: the data's own likelihood
        dof = data.sub.size - (1 if isinstance(data.mean, str) else 0)
        fit["loglik"] -= dof * float(np.log(data.unit[cols]).sum())
        fits.append(fit)
    report["loglik"] = float(sum(f["loglik"] for f in fits))
    report["fit"] = {"samples": int(data.sub.size),
                     "likelihood": f"sparse factors ({factors.name})" if every else "dense covariance",
                     "evaluations": int(sum(f["evaluations"] for f in fits)),
                     "range_bounds": [range_from_kappa(b, prior.alpha, prior.d) for b in bounds[::-1]],
                     "criterion": "restricted likelihood" if opts.mean == "constant" else "likelihood"}
    report["fitted"] = [name for name in ("range", "sigma", "noise") if getattr(opts, name) == "auto"]
    return hyper


def _fit_fields(covariance, data, cols, opts, prior, search, likelihood=None):
    """The likelihood fit of the columns ``cols`` (one :func:`manifill.linalg.gpfit.fit_range` answer).

    ``search`` is ``(bounds, bracket, points)``: the whole interval of ``kappa``, the bracket
    searched first on a grid of ``points``; a fit at an inner edge of the bracket searches it all.
    """
    bounds, bracket, points = search
    Z = data.Z[:, cols]
    noise2 = None if data.noise2 is None else data.noise2[cols]
    fixed_s2 = opts.sigma != "auto"
    given_k = None if opts.range == "auto" else kappa_from_range(opts.range, prior.alpha, prior.d)
    if fixed_s2 and given_k is None:  # the scale follows kappa
        return fit_range(covariance, Z, bounds, mean=data.mean,
                         s2=lambda kap: (prior.s2_of_sigma(opts.sigma, kap) / data.unit ** 2)[cols],
                         noise2=noise2, fit_noise=data.fit_noise)
    s2_given = None if not fixed_s2 else (prior.s2_of_sigma(opts.sigma, given_k) / data.unit ** 2)[cols]
    lik = None if likelihood is None else (lambda kap: likelihood(kap, Z))
    kw = dict(mean=data.mean, s2=s2_given, noise2=noise2, fit_noise=data.fit_noise, kappa=given_k, likelihood=lik)
    fit = fit_range(covariance, Z, bracket, points=points, **kw)
    # at an edge of the bracket that is not an end of the whole interval: search it all
    inner = [b for b, f in zip(bracket, bounds) if abs(math.log(b / f)) > 1e-9]
    edge = min((abs(math.log(fit["kappa"] / b)) for b in inner), default=np.inf)
    if given_k is None and edge < 0.02:
        more = fit_range(covariance, Z, bounds, **kw)
        more["evaluations"] += fit["evaluations"]
        fit = more
    return fit


def _posterior(shape, idx, rows, Y, opts, hyper, solver, with_std, report):
    """``(X, std, beta, variance infos, groups)``: the posterior of every group of fields that share a precision.

    A scale ``hyper.s2`` left None is set here, in closed form (REML, or ML with a known mean).
    ``std`` is not filled without ``with_std``. ``report['solver']`` is the last group's.
    """
    m, p = Y.shape
    X = np.empty((shape.n, p))
    std = np.empty((shape.n, p))
    beta = [0.0] * p
    var_info = []
    known = not isinstance(opts.mean, str)
    kappa, s2, n2 = hyper.kappa, hyper.s2, hyper.n2
    # fields that share kappa and the noise ratio share one precision (the ratio to 12 digits: a shared fit's
    # fields carry it through their own scales, rounded apart in the last bits)
    eta_key = [(kappa[j], None if s2[j] is None or n2[j] == 0 else float(f"{n2[j] / s2[j]:.12g}")) for j in range(p)]
    groups = _groups(eta_key)
    for (kap, eta), cols in groups.items():
        Q, B = shape.precision(kap), shape.root(kap)
        unknowns = shape.n - (len(idx) if eta is None else 0)
        cond = Conditional(Q, B, idx, rows=rows, eta=eta, solver=_many_rhs(solver), definite=True,
                           factoriser=factoriser_for(with_std, opts.variance, unknowns))
        data = Y[:, cols] - (float(opts.mean) if known else 0.0)
        Z = cond.extend(np.column_stack([data, np.ones(m)]))
        G = cond.gram(np.column_stack([data, np.ones(m)]), Z)
        a = G[-1, -1]
        for i, j in enumerate(cols):
            if known:
                beta[j] = float(opts.mean)
                X[:, j] = Z[:, i] + beta[j]
                q = G[i, i]
            else:
                beta[j] = G[i, -1] / a
                X[:, j] = Z[:, i] + beta[j] * (1.0 - Z[:, -1])
                q = G[i, i] - G[i, -1] ** 2 / a
            if s2[j] is None:  # the scale in closed form: REML (or ML with a known mean)
                s2[j] = max(q / (m - (0 if known else 1)), 1e-300)
        report["solver"] = cond.report
        if not with_std:
            continue
        var, info = cond.variance(opts.variance, samples=opts.samples, seed=opts.seed)
        loo = cond.loo(data, 0.0 if known else "constant")  # exact vertex data: leave-one-out, one more factor
        if loo is not None:
            info["loo"] = [{**loo_summary(loo[:, i] / math.sqrt(s2[j])), "field": j} for i, j in enumerate(cols)]
        extra = 0.0 if known else (1.0 - Z[:, -1]) ** 2 / a
        for j in cols:
            std[:, j] = np.sqrt(np.maximum(s2[j] * (var + extra), 0.0))
        var_info.append(info)
    return X, std, beta, var_info, len(groups)


def _summary(prior, hyper, beta, var_info, groups):
    """The report's hyperparameters per field, the means, the variance's summary and the number of groups."""
    kappa, s2 = hyper.kappa, hyper.s2
    return {
        "kappa": [float(k) for k in kappa],
        "range": [range_from_kappa(k, prior.alpha, prior.d) for k in kappa],
        "scale": [math.sqrt(s) for s in s2],
        "sigma": [prior.sigma(s2[j], kappa[j]) for j in range(len(kappa))],
        "noise": [math.sqrt(x) for x in hyper.n2],
        "mean": [float(b) for b in beta],
        "variance": variance_summary(var_info),
        "groups": groups,
    }


def _many_rhs(solver):
    """``auto`` factorises: the variance takes ``samples`` solves, and CG would pay for each one anew."""
    return "direct" if solver == "auto" else solver


def intrinsic_std(Q, B, idx, rows, Y, X, *, eta=None, how="auto", samples=100, seed=0, solver="auto",
                  components=1):
    """The standard deviation of an energy method read as an intrinsic Gaussian field.

    The field ``x ~ N(0, s^2 Q^+)`` (``Q`` the method's energy, whose null space holds the
    constants) conditioned on the samples has the method's result ``X`` as its mean; the
    scale is the restricted likelihood's, ``s^2 = q / (m - c)`` with ``q`` the minimum
    energy (exact data; with smoothing, the penalised fit's value) and ``c`` the
    components.

    Returns
    -------
    std : (n, p) numpy array
    report : dict
        ``scale`` per field, ``variance`` (how, seconds, Monte Carlo error).
    """
    Y = np.asarray(Y, dtype=np.float64)
    m, p = Y.shape
    if m <= components:
        raise SampleError(f"a standard deviation needs more samples than components ({components}), got {m}; "
                          f"add samples")
    cond = Conditional(Q, B, idx, rows=rows, eta=eta, solver=_many_rhs(solver),
                       factoriser=factoriser_for(True, how, Q.shape[0] - (0 if eta is not None else len(idx))))
    G = cond.gram(Y, X)
    var, info = cond.variance(how, samples=samples, seed=seed)
    scale = [math.sqrt(max(G[j, j] / (m - components), 0.0)) for j in range(p)]
    std = np.sqrt(np.maximum(var, 0.0))[:, None] * np.asarray(scale)[None, :]
    return std, {"scale": scale, "variance": {k: v for k, v in info.items() if k != "se"},
                 "model": "intrinsic Gaussian field with the method's energy as precision"}
