"""The restricted likelihood (manifill.linalg.gpfit) against a brute-force dense one, and the fit.

For ``y ~ N(beta 1, S)``, ``S = s^2 R + n^2 I``, with ``beta`` integrated out under a flat
prior (REML), with ``beta_hat = 1'S^-1 y / 1'S^-1 1`` and ``r = y - beta_hat 1``:

    -2 log L = log|S| + log(1' S^-1 1) + r' S^-1 r + (m - 1) log 2 pi;

with ``beta`` known (ML): ``log|S| + (y - beta)' S^-1 (y - beta) + m log 2 pi``. With
``S = s^2 (R + eta I)`` the best scale is ``s^2 = q / f`` (``q`` the quadratic form at
``s^2 = 1``, ``f = m - 1`` or ``m``), and the profiled value is the minimum over ``s^2``.
"""

import math

import numpy as np
import scipy.sparse as sp
import pytest
from scipy.special import kv

from manifill.linalg.gpfit import fit_range
from manifill.linalg.likelihood import Likelihood, restricted_loglik


def _points(m, seed):
    return np.random.default_rng(seed).uniform(0.0, 4.0, size=(m, 2))


def _matern1(P, kappa):
    """The Matérn nu = 1 correlation ``kappa r K_1(kappa r)`` (1 at r = 0) of points ``P`` or distances."""
    r = P if P.shape[0] == P.shape[1] else np.linalg.norm(P[:, None, :] - P[None, :, :], axis=2)
    with np.errstate(invalid="ignore"):
        c = kappa * r * kv(1, kappa * r)
    c[r == 0] = 1.0
    return c


def _dense_m2ll(R, y, s2, n2, mean):
    m = len(y)
    S = s2 * R + n2 * np.eye(m)
    _, logdet = np.linalg.slogdet(S)
    one = np.ones(m)
    if mean == "constant":
        a = one @ np.linalg.solve(S, one)
        beta = one @ np.linalg.solve(S, y) / a
        r = y - beta
        return logdet + math.log(a) + r @ np.linalg.solve(S, r) + (m - 1) * math.log(2 * math.pi)
    r = y - mean
    return logdet + r @ np.linalg.solve(S, r) + m * math.log(2 * math.pi)


def _data(m=40, seed=0, p=2):
    P = _points(m, seed)
    R = _matern1(P, 1.5)
    rng = np.random.default_rng(seed + 1)
    Y = np.linalg.cholesky(R + 1e-10 * np.eye(m)) @ rng.standard_normal((m, p)) + 3.0
    return R, Y


@pytest.mark.parametrize("mean", ["constant", 3.0, -1.0])
def test_absolute_is_the_dense_likelihood(mean):
    R, Y = _data()
    lik = Likelihood(R, Y, mean)
    for j in range(2):
        for s2, n2 in ((1.0, 0.0), (0.3, 0.01), (4.0, 2.0)):
            want = _dense_m2ll(R, Y[:, j], s2, n2, mean)
            assert abs(lik.absolute(s2, n2, j) - want) < 1e-8 * max(1.0, abs(want))
    assert lik.dof() == (39 if mean == "constant" else 40)


@pytest.mark.parametrize("mean", ["constant", 3.0])
def test_profiled_is_the_dense_likelihood_at_the_best_scale(mean):
    R, Y = _data()
    lik = Likelihood(R, Y, mean)
    for eta in (0.0, 0.05, 1.0):
        for j in range(2):
            v, s2 = lik.profiled(eta, j)
            want = _dense_m2ll(R, Y[:, j], s2, eta * s2, mean)
            assert abs(v - want) < 1e-8 * abs(want)
            # the best scale: moving it either way increases -2 log L
            for f in (0.9, 0.99, 1.01, 1.1):
                assert _dense_m2ll(R, Y[:, j], f * s2, f * eta * s2, mean) > want
            # the closed form: s2 = q / f with q the quadratic form at s2 = 1
            S = R + eta * np.eye(len(R))
            one = np.ones(len(R))
            y = Y[:, j] - (0.0 if mean == "constant" else mean)
            if mean == "constant":
                y = y - (one @ np.linalg.solve(S, y)) / (one @ np.linalg.solve(S, one))
            assert math.isclose(s2, y @ np.linalg.solve(S, y) / lik.dof(), rel_tol=1e-9)


def test_restricted_loglik_with_given_scale_and_noise_is_absolute():
    R, Y = _data()
    lik = Likelihood(R, Y)
    v, params = restricted_loglik(lik, [0, 1], s2=np.array([0.5, 2.0]), noise2=np.array([0.1, 0.2]))
    want = _dense_m2ll(R, Y[:, 0], 0.5, 0.1, "constant") + _dense_m2ll(R, Y[:, 1], 2.0, 0.2, "constant")
    assert abs(v - want) < 1e-8 * abs(want)
    assert params == [(0.5, 0.1), (2.0, 0.2)]


def test_restricted_loglik_searches_the_scale_given_the_noise():
    R, Y = _data()
    lik = Likelihood(R, Y)
    v, [(s2, n2)] = restricted_loglik(lik, [0], noise2=np.array([0.3, 0.3]))
    assert n2 == 0.3
    want = _dense_m2ll(R, Y[:, 0], s2, 0.3, "constant")
    assert abs(v - want) < 1e-8 * abs(want)
    for f in (0.8, 1.25):  # a minimum (Brent to 1e-3 in log s2)
        assert _dense_m2ll(R, Y[:, 0], f * s2, 0.3, "constant") > want - 1e-6


def test_fit_range_recovers_the_range_scale_and_noise():
    # 250 points of one Matérn nu = 1 field (kappa 2, scale 2, noise sd 0.3) in a 4 x 4 square,
    # fitted with the same correlation family: kappa within a factor 1.5, the scale within 2, the
    # noise sd within 1.3. Measured with this seed: kappa 1.85, scale 2.14, noise sd 0.33; over six
    # other seeds kappa 1.33-2.70, scale 1.10-3.14, noise sd 0.25-0.34 (the 4 x 4 square holds
    # few ranges, so the scale is the loosest).
    m = 250
    P = _points(m, 21)
    D = np.linalg.norm(P[:, None, :] - P[None, :, :], axis=2)
    kappa0, s20, noise0 = 2.0, 2.0, 0.3
    rng = np.random.default_rng(22)
    y = (math.sqrt(s20) * np.linalg.cholesky(_matern1(P, kappa0) + 1e-10 * np.eye(m)) @ rng.standard_normal(m)
         + noise0 * rng.standard_normal(m) + 5.0)
    calls = []

    def cov(k):
        calls.append(k)
        return _matern1(D, k)

    fit = fit_range(cov, y, (0.05, 50.0), fit_noise=True)
    assert 1 / 1.5 < fit["kappa"] / kappa0 < 1.5, fit
    assert 1 / 2 < fit["s2"][0] / s20 < 2, fit
    assert 1 / 1.3 < math.sqrt(fit["noise2"][0]) / noise0 < 1.3, fit
    assert fit["evaluations"] == len(set(calls))
    assert math.isclose(fit["loglik"], -0.5 * fit["neg2loglik"])
    # the fit is the optimum: the likelihood at the fitted parameters is the dense one, and a
    # kappa off by 20% either way is worse
    best = _dense_m2ll(_matern1(D, fit["kappa"]), y, fit["s2"][0], fit["noise2"][0], "constant")
    assert abs(best - fit["neg2loglik"]) < 1e-6 * abs(best)
    for f in (0.8, 1.25):
        other, _ = restricted_loglik(Likelihood(_matern1(D, f * fit["kappa"]), y), [0], fit_noise=True)
        assert other > fit["neg2loglik"]


def test_fit_range_without_noise_profiles_the_scale():
    m = 200
    P = _points(m, 5)
    rng = np.random.default_rng(6)
    y = np.linalg.cholesky(_matern1(P, 3.0) + 1e-10 * np.eye(m)) @ rng.standard_normal(m)
    fit = fit_range(lambda k: _matern1(P, k), y, (0.05, 50.0))
    assert fit["noise2"] == [0.0]
    assert 1 / 1.5 < fit["kappa"] / 3.0 < 1.5, fit
    lik = Likelihood(_matern1(P, fit["kappa"]), y)
    assert math.isclose(fit["s2"][0], lik.profiled(0.0, 0)[1], rel_tol=1e-12)


@pytest.mark.parametrize("factoriser", ["superlu", "cholmod"])
@pytest.mark.parametrize("alpha", [1, 2])
@pytest.mark.parametrize("kappa", [0.5, 3.0])
@pytest.mark.parametrize("mean", ["constant", 0.3])
def test_the_sparse_vertex_likelihood_is_the_dense_one(alpha, kappa, mean, factoriser):
    """log det R = log det Q_ff - log det Q and R^-1 = the Schur complement: the kriging form's value exactly."""
    from manifill.linalg.factorise import factorise
    from manifill.linalg.gaussian import observation_matrix
    from manifill.linalg.likelihood import VertexLikelihood
    from manifill.linalg.logdet import LogdetFactors
    from manifill.linalg.spde import MaternShape
    from manifill.mesh.laplacian import laplacian, mass_matrix
    from manifill.mesh.roots import gradient_root
    from manifill.mesh.shapes import icosphere

    rng = np.random.default_rng(1)
    V, F = icosphere(3)
    V = V * (1 + 0.05 * rng.normal(size=(len(V), 1)))
    idx = np.sort(rng.choice(len(V), 60, replace=False))
    Y = np.column_stack([np.sin(2 * V[idx, 0]), V[idx, 1]])
    shape = MaternShape(laplacian(V, F), mass_matrix(V, F, mass="barycentric").diagonal(), gradient_root(V, F),
                        alpha, 2)
    R = shape.covariance_at(kappa, observation_matrix(shape.n, idx, None), factorise(shape.K(kappa).tocsc())[1])
    factors = LogdetFactors()
    if factoriser == "superlu":
        factors._cholmod = None  # the pure-pip path
    elif factors.name != "cholmod":
        pytest.skip("the [cholmod] extra (scikit-sparse) is not installed")
    dense = Likelihood(R, Y, mean)
    sparse = VertexLikelihood(shape, kappa, idx, Y, mean, factors)
    VertexLikelihood(shape, 2.0 * kappa, idx, Y, mean, factors)  # a second trial reuses the symbolic analysis
    sparse = VertexLikelihood(shape, kappa, idx, Y, mean, factors)
    for j in range(2):
        (v0, s0), (v1, s1) = dense.profiled(0.0, j), sparse.profiled(0.0, j)
        assert v1 == pytest.approx(v0, rel=1e-10, abs=1e-9) and s1 == pytest.approx(s0, rel=1e-10)
    # the slope from the same factors by selected inversion is the derivative of the value (central differences)
    sloped = VertexLikelihood(shape, kappa, idx, Y, mean, factors, slope=True)
    h = 1e-5
    for j in range(2):
        up = VertexLikelihood(shape, kappa * math.exp(h), idx, Y, mean, factors).profiled(0.0, j)[0]
        down = VertexLikelihood(shape, kappa * math.exp(-h), idx, Y, mean, factors).profiled(0.0, j)[0]
        assert sloped.slope(j) == pytest.approx((up - down) / (2 * h), rel=1e-6, abs=1e-6)
        assert sloped.profiled(0.0, j)[0] == pytest.approx(sparse.profiled(0.0, j)[0], rel=1e-12)
    with pytest.raises(ValueError, match="slope=True"):
        sparse.slope(0)


def test_the_sparse_likelihood_refuses_a_factor_that_will_not_fit(monkeypatch):
    from manifill import memory
    from manifill.errors import ResourceError
    from manifill.linalg.logdet import LogdetFactors

    monkeypatch.setattr(memory, "available_bytes", lambda: 1000)
    A = sp.identity(50, format="csc") * 2.0
    with pytest.raises(ResourceError, match="likelihood's sparse factor of 50 unknowns.*give the range and sigma"):
        LogdetFactors().factor("Q_ff", A)


@pytest.mark.parametrize("mean", ["constant", 3.0])
def test_leave_one_out_residuals_are_universal_krigings_refits(mean):
    """One factor with the samples last gives every sample's leave-one-out residual: the same as refitting without
    it (the constant mean estimated again, its variance added: universal kriging), sample by sample, densely."""
    from manifill.linalg.logdet import loo_residuals
    from manifill.linalg.spde import MaternShape
    from manifill.mesh.laplacian import laplacian, mass_matrix
    from manifill.mesh.roots import gradient_root
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(3)
    rng = np.random.default_rng(0)
    m = 40
    idx = np.sort(rng.choice(len(V), m, replace=False))
    free = np.setdiff1d(np.arange(len(V)), idx)
    shape = MaternShape(laplacian(V, F), mass_matrix(V, F, mass="barycentric").diagonal(), gradient_root(V, F), 2, 2)
    Q = shape.precision(2.0)
    Y = rng.standard_normal((m, 2)) + 3.0
    R = np.linalg.inv(Q.toarray())[np.ix_(idx, idx)]
    want = np.empty((m, 2))
    for i in range(m):
        o = np.delete(np.arange(m), i)
        w = np.linalg.solve(R[np.ix_(o, o)], R[o, i])
        for j in range(2):
            y = Y[:, j]
            if mean == "constant":
                r1 = np.linalg.solve(R[np.ix_(o, o)], np.ones(m - 1))
                b = r1 @ y[o] / r1.sum()
                mu, var = b + w @ (y[o] - b), R[i, i] - w @ R[o, i] + (1 - w.sum()) ** 2 / r1.sum()
            else:
                mu, var = mean + w @ (y[o] - mean), R[i, i] - w @ R[o, i]
            want[i, j] = (y[i] - mu) / np.sqrt(var)
    order = rng.permutation(len(free))  # any order of the other vertices: the same residuals
    got = loo_residuals(Q, idx, Y, order, mean)
    assert np.abs(got - want).max() < 1e-9 * np.abs(want).max()


@pytest.mark.parametrize("centre", [-0.9, -0.3, 0.12, 0.55, 1.1])
def test_the_costly_search_finds_the_minimum_in_few_calls(centre):
    from manifill.linalg.search import bounded_search

    calls = []

    def f(x):
        calls.append(x)
        return (x - centre) ** 2 + 0.3 * (x - centre) ** 4 + 0.05 * math.sin(3 * x)

    xs = np.linspace(-2, 2, 40001)
    best = xs[np.argmin([f(x) for x in xs])]
    calls.clear()
    x, v = bounded_search(f, -2.0, 2.0, 3, parabolic=True)
    used = len(calls)
    interior = int(np.argmin([f(g) for g in (-2.0, 0.0, 2.0)])) == 1  # the grid's best in the middle: parabolas
    assert abs(x - best) < 0.03 and v == pytest.approx(f(x))
    assert used <= (3 + 6 if interior else 3 + 1 + 12)
    calls.clear()
    xb, _ = bounded_search(f, -2.0, 2.0, 3)  # Brent: the same minimum
    assert abs(xb - best) < 0.03


def test_the_costly_search_stops_at_an_end_that_holds_the_minimum():
    from manifill.linalg.search import bounded_search

    calls = []
    down = lambda x: calls.append(x) or -x  # noqa: E731  (decreasing: the minimum at the upper end)
    x, _ = bounded_search(down, 0.0, 1.0, 3, parabolic=True)
    assert x == 1.0 and len(calls) == 4
    calls.clear()
    near = lambda x: calls.append(x) or (x - 0.9) ** 2  # noqa: E731  (the grid's best is the end, the minimum inside)
    x, _ = bounded_search(near, 0.0, 1.0, 3, parabolic=True)
    assert abs(x - 0.9) < 0.03
