"""The penalised fit min sum w_i ((Sx)_i - y_i)^2 + lam x'Ax: limits, normal equations, influence matrix, GCV/LOO."""

import numpy as np
import pytest
import scipy.sparse as sp

from manifill import OptionError, SampleError, SolveError
from manifill.linalg.quadratic import QuadraticSolver
from manifill.linalg.lamsearch import log_grid
from manifill.linalg.search import grid_search
from manifill.linalg.smoothing import SmoothingFit, smooth
from manifill.mesh.laplacian import laplacian
from manifill.mesh.shapes import icosphere


def selection(idx, n):
    idx = np.asarray(idx)
    return sp.csr_array((np.ones(idx.size), (np.arange(idx.size), idx)), shape=(idx.size, n))


def barycentric(F, n, faces, rng):
    """One row per face in ``faces``: random barycentric coordinates on its three vertices."""
    B = rng.dirichlet(np.ones(3), len(faces))
    rows = np.repeat(np.arange(len(faces)), 3)
    return sp.csr_array((B.ravel(), (rows, F[faces].ravel())), shape=(len(faces), n))


def field(V):
    return np.sin(2 * V[:, 0]) + V[:, 1] * V[:, 2] + 0.5 * V[:, 2]


@pytest.fixture(scope="module")
def sphere():
    V, F = icosphere(3)
    return V, F, laplacian(V, F)


@pytest.fixture(scope="module")
def tiny():
    """42 vertices; 8 vertex samples and 6 points inside faces; random weights and values."""
    V, F = icosphere(1)
    n = len(V)
    rng = np.random.default_rng(3)
    rows = [selection(rng.choice(n, 8, replace=False), n), barycentric(F, n, [0, 5, 9, 30, 41, 60], rng)]
    S = sp.csr_array(sp.vstack(rows))
    w = rng.uniform(0.5, 2.0, S.shape[0])
    y = rng.standard_normal(S.shape[0])
    return laplacian(V, F), S, w, y


def dense_x(A, S, w, y, lam):
    K = (S.T.toarray() * w) @ S.toarray() + lam * A.toarray()
    return np.linalg.solve(K, (S.T.toarray() * w) @ y)


def dense_h(A, S, w, lam):
    K = (S.T.toarray() * w) @ S.toarray() + lam * A.toarray()
    return S.toarray() @ np.linalg.inv(K) @ (S.T.toarray() * w)


def test_lam_to_zero_is_interpolation(sphere):
    V, F, A = sphere
    rng = np.random.default_rng(0)
    idx = rng.choice(len(V), 60, replace=False)
    y = field(V)[idx] + 0.1 * rng.standard_normal(idx.size)
    fit = SmoothingFit(A, selection(idx, len(V)))
    ref = QuadraticSolver(A, idx).solve(y)
    x0, info = fit.solve(y, 0.0)
    np.testing.assert_allclose(x0, ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(x0[idx], y, rtol=0, atol=1e-12)
    assert np.abs(info["residuals"]).max() < 1e-12
    x, info = fit.solve(y, 1e-10 * fit.lam0)
    assert np.abs(x - ref).max() <= 1e-6 * np.ptp(y)
    assert fit.edf(0) == idx.size


def test_lam_zero_two_samples_at_one_vertex_take_their_weighted_mean(sphere):
    V, F, A = sphere
    idx = np.array([0, 5, 9, 5])
    y, w = np.array([1.0, 2.0, 3.0, 5.0]), np.array([1.0, 1.0, 1.0, 3.0])
    x, _ = SmoothingFit(A, selection(idx, len(V)), w=w).solve(y, 0.0)
    np.testing.assert_allclose(x[[0, 5, 9]], [1.0, (2 + 15) / 4, 3.0], atol=1e-12)
    x_small, _ = SmoothingFit(A, selection(idx, len(V)), w=w).solve(y, 1e-10)
    assert np.abs(x_small - x).max() < 1e-6


def test_lam_to_infinity_is_the_null_space_weighted_means(sphere):
    V, F, A = sphere
    n = len(V)
    A2 = sp.csr_array(sp.block_diag([A, 2.0 * A]))  # two components
    rng = np.random.default_rng(1)
    idx = np.concatenate([rng.choice(n, 20, replace=False), n + rng.choice(n, 15, replace=False)])
    y = rng.uniform(-1, 3, idx.size)
    w = rng.uniform(0.2, 5.0, idx.size)
    fit = SmoothingFit(A2, selection(idx, 2 * n), w=w)
    x, _ = fit.solve(y, 1e8 * fit.lam0)
    first = idx < n
    for part, sl in ((first, slice(0, n)), (~first, slice(n, 2 * n))):
        mean = (w[part] * y[part]).sum() / w[part].sum()
        assert np.abs(x[sl] - mean).max() < 1e-5 * np.ptp(y)


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
def test_normal_equations_hold(tiny, scale):
    A, S, w, y = tiny
    fit = SmoothingFit(A, S, w=w)
    lam = scale * fit.lam0
    x, info = fit.solve(y, lam)
    r = S.T @ (w * (S @ x - y)) + lam * (A @ x)
    assert np.linalg.norm(r) <= 1e-10 * np.linalg.norm(S.T @ (w * y))
    np.testing.assert_allclose(x, dense_x(A, S, w, y, lam), atol=1e-9 * np.ptp(y))
    np.testing.assert_allclose(info["residuals"], S @ x - y, atol=1e-14)


@pytest.mark.parametrize("scale", [1e-4, 0.1, 10.0])
def test_influence_matrix_equals_the_dense_inverse(tiny, scale):
    A, S, w, y = tiny
    fit = SmoothingFit(A, S, w=w)
    lam = scale * fit.lam0
    ref = dense_h(A, S, w, lam)
    np.testing.assert_allclose(fit.influence(lam), ref, atol=1e-9)
    np.testing.assert_allclose(fit.leverage(lam), np.diag(ref), atol=1e-9)
    assert fit.edf(lam) == pytest.approx(np.trace(ref), abs=1e-9)
    H1 = SmoothingFit(A, S).influence(lam)  # w = 1: H is symmetric
    np.testing.assert_allclose(H1, H1.T, atol=1e-12)
    np.testing.assert_allclose(H1, dense_h(A, S, np.ones_like(w), lam), atol=1e-9)


def test_gcv_score_is_the_formula(tiny):
    A, S, w, y = tiny
    fit = SmoothingFit(A, S, w=w)
    k, lam = S.shape[0], 0.3 * fit.lam0
    H = dense_h(A, S, w, lam)
    r = y - H @ y
    expected = k * (w * r**2).sum() / (k - np.trace(H)) ** 2
    assert fit.scores(y, lam, method="gcv")[0] == pytest.approx(expected, rel=1e-9)


def test_loo_equals_brute_force_refits(tiny):
    A, S, w, y = tiny
    fit = SmoothingFit(A, S, w=w)
    k = S.shape[0]
    for lam in (0.01 * fit.lam0, fit.lam0, 30 * fit.lam0):
        errs = []
        for i in range(k):
            keep = np.arange(k) != i
            xi, _ = SmoothingFit(A, S[keep], w=w[keep]).solve(y[keep], lam)
            errs.append(w[i] * (y[i] - (S[[i]] @ xi)[0]) ** 2)
        assert fit.scores(y, lam, method="loo")[0] == pytest.approx(np.mean(errs), rel=1e-8)


@pytest.mark.parametrize("method", ["gcv", "loo"])
def test_chosen_lambda_beats_interpolation_on_a_noisy_field(method):
    V, F = icosphere(4)
    A = laplacian(V, F)
    truth = field(V)
    rng = np.random.default_rng(7)
    idx = rng.choice(len(V), 800, replace=False)
    y = truth[idx] + 0.05 * np.ptp(truth) * rng.standard_normal(idx.size)
    S = selection(idx, len(V))
    x, rep = smooth(A, S, y, "auto", method=method)
    x0, rep0 = smooth(A, S, y, 0.0)
    err, err0 = np.sqrt(np.mean((x - truth) ** 2)), np.sqrt(np.mean((x0 - truth) ** 2))
    assert err < 0.75 * err0
    fit = SmoothingFit(A, S)
    oracle = min(np.sqrt(np.mean((fit.solve(y, lam)[0] - truth) ** 2)) for lam in fit.default_grid())
    assert err < 1.1 * oracle  # close to the best lam on the grid, which knows the truth
    assert rep["lambda"] > 0 and rep0["lambda"] == 0
    assert 0 < rep["edf"] < idx.size and rep0["edf"] == idx.size
    np.testing.assert_allclose(rep["residuals"], x[idx] - y, atol=1e-12)
    curve = rep["curve"]
    assert not curve["at_edge"] and curve["grid"].sum() == 41
    assert rep["score"] <= curve["scores"].min() + 1e-15  # the refinement keeps the best point evaluated
    assert np.all(np.diff(curve["lambdas"]) > 0)


def test_doubling_weights_and_lambda_gives_the_same_fit(tiny):
    A, S, w, y = tiny
    lam = 0.7 * SmoothingFit(A, S, w=w).lam0
    x1, _ = smooth(A, S, y, lam, w=w)
    x2, _ = smooth(A, S, y, 2 * lam, w=2 * w)
    np.testing.assert_allclose(x2, x1, atol=1e-11 * np.ptp(y))
    a1, r1 = smooth(A, S, y, w=w)
    a2, r2 = smooth(A, S, y, w=2 * w)
    assert r2["lambda"] == pytest.approx(2 * r1["lambda"], rel=1e-6)


@pytest.mark.parametrize("lam", [0.0, 0.5, "auto"])
def test_many_columns_equal_column_by_column(sphere, lam):
    V, F, A = sphere
    rng = np.random.default_rng(2)
    idx = rng.choice(len(V), 40, replace=False)
    Y = np.column_stack([field(V)[idx], rng.standard_normal(idx.size), 5 + 0 * idx])
    S = selection(idx, len(V))
    X, rep = smooth(A, S, Y, lam)
    assert X.shape == (len(V), 3) and rep["residuals"].shape == (40, 3)
    for j in range(3):
        xj, rj = smooth(A, S, Y[:, j], lam)
        np.testing.assert_allclose(X[:, j], xj, atol=1e-12)
        assert rep["lambda"][j] == rj["lambda"]


def test_per_field_lambdas(tiny):
    A, S, w, y = tiny
    fit = SmoothingFit(A, S, w=w)
    Y = np.column_stack([y, 2 * y])
    X, info = fit.solve(Y, [0.1, 10.0])
    np.testing.assert_allclose(X[:, 1], 2 * fit.solve(y, 10.0)[0], atol=1e-12)
    np.testing.assert_allclose(X[:, 0], fit.solve(y, 0.1)[0], atol=1e-12)


def test_bad_inputs_raise_one_line_errors(tiny, sphere):
    A, S, w, y = tiny
    fit = SmoothingFit(A, S)
    cases = [
        (OptionError, lambda: fit.solve(y, -1.0)),
        (OptionError, lambda: fit.solve(y, np.nan)),
        (OptionError, lambda: fit.solve(y, np.inf)),
        (OptionError, lambda: smooth(A, S, y, "gcv")),
        (OptionError, lambda: smooth(A, S, y, method="aic")),
        (OptionError, lambda: fit.solve(y, [1.0, 2.0])),
        (OptionError, lambda: fit.select(y, lams=[1.0, -1.0])),
        (SampleError, lambda: SmoothingFit(A, sp.csr_array((3, A.shape[0] + 1)))),
        (SampleError, lambda: fit.solve(y[:-1], 1.0)),
        (SampleError, lambda: SmoothingFit(A, S, w=np.r_[0.0, w[1:]])),
        (SampleError, lambda: SmoothingFit(A, S, w=-w)),
        (SampleError, lambda: SmoothingFit(A, S, w=w[:-1])),
        (SampleError, lambda: SmoothingFit(A, sp.csr_array(sp.vstack([S, sp.csr_array((1, A.shape[0]))])))),
        (SampleError, lambda: smooth(A, S[:2], y[:2])),
        (SampleError, lambda: SmoothingFit(A, S[:2]).select(y[:2], method="loo")),
    ]
    for kind, call in cases:
        with pytest.raises(kind) as e:
            call()
        assert "\n" not in str(e.value)
    x, rep = smooth(A, S[:2], y[:2], 1.0)  # a fixed lam needs no cross-validation
    assert np.isnan(rep["score"])


def test_component_without_sample_is_named(sphere):
    V, F, A = sphere
    n = len(V)
    A2 = sp.csr_array(sp.block_diag([A, A]))
    with pytest.raises(SolveError, match=f"component of {n} vertices.*vertex {n}\\)") as e:
        SmoothingFit(A2, selection([0, 1, 2], 2 * n))
    assert "\n" not in str(e.value)


def test_grid_search_refines_each_field_to_its_own_minimum():
    def f(lam):
        return np.array([np.log(lam / 0.037) ** 2, (np.log10(lam) - 2.3) ** 2 + 1, -np.log(lam)])

    chosen, curve = grid_search(f, log_grid(1.0, (-3, 3), 2))
    np.testing.assert_allclose(chosen[:2], [0.037, 10**2.3], rtol=0.03)
    assert chosen[2] == 1e3 and curve["at_edge"].tolist() == [False, False, True]
    assert curve["grid"].sum() == 13 and np.all(np.diff(curve["lambdas"]) > 0)
    plain, _ = grid_search(f, log_grid(1.0, (-3, 3), 2), refine=False)
    assert plain[0] == pytest.approx(10**-1.5)


def test_lam_zero_with_points_inside_faces_interpolates_them(tiny):
    A, S, w, y = tiny
    fit = SmoothingFit(A, S, w=w)
    x, info = fit.solve(y, 0.0)
    assert np.abs(S @ x - y).max() < 1e-10 and np.abs(info["residuals"]).max() < 1e-10
    assert fit.edf(0) == S.shape[0]
    # directions only a barycentric row's neighbours see are scaled by 1/lam: tiny lam loses digits, hence 1e-7
    x_small, _ = fit.solve(y, 1e-7 * fit.lam0)
    assert np.abs(x_small - x).max() < 1e-5 * np.ptp(y)


def test_biharmonic_energy_with_sparse_samples(sphere):
    from manifill.mesh.laplacian import mass_matrix

    V, F, L = sphere
    A = sp.csr_array(L @ sp.diags(1 / mass_matrix(V, F).diagonal()) @ L)  # L M^-1 L
    truth = field(V)
    rng = np.random.default_rng(5)
    idx = rng.choice(len(V), 120, replace=False)
    y = truth[idx] + 0.05 * np.ptp(truth) * rng.standard_normal(idx.size)
    S = selection(idx, len(V))
    x, rep = smooth(A, S, y)
    x0, _ = smooth(A, S, y, 0.0)
    assert np.sqrt(np.mean((x - truth) ** 2)) < 0.75 * np.sqrt(np.mean((x0 - truth) ** 2))
    r = S.T @ (S @ x - y) + rep["lambda"] * (A @ x)
    assert np.linalg.norm(r) <= 1e-10 * np.linalg.norm(S.T @ y)
