"""``reconstruct(..., method='gp')`` and ``uncertainty=True`` against dense Gaussian oracles and invariances.

The Matérn field on the mesh has precision ``Q = tau^2 K C^-1 K`` (alpha = 2, ``K = kappa^2 C +
G``, ``G`` the cotangent stiffness, ``C`` the lumped barycentric mass, ``kappa = sqrt(8) /
range``, ``sigma^2 = 1 / (4 pi kappa^2 tau^2)``), ``Sigma = Q^-1``. Observed as ``y = H x + e``
with ``S = H Sigma H' + noise^2 I`` and an unknown constant mean (universal kriging):

    beta = 1'S^-1 y / 1'S^-1 1,    mean = beta + k' S^-1 (y - beta 1),    k = H Sigma,
    var = diag(Sigma) - diag(k' S^-1 k) + (1 - k' S^-1 1)^2 / (1' S^-1 1).

The energy methods' std is that of the intrinsic field with precision ``E / s^2`` (``E = L``
harmonic, ``L M^-1 L`` biharmonic, ``M`` the Voronoi mass), ``s^2 = x'Ex / (m - 1)``, whose
conditional variance given exact vertex samples is ``s^2 diag((E_ff)^-1)``.
"""

import math

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.sparse.csgraph import shortest_path

import manifill
from conftest import grid, icosphere
from manifill.errors import OptionError
from manifill.mesh.laplacian import laplacian, mass_matrix

V2, F2 = icosphere(2)
N2 = len(V2)
RANGE, SIGMA = 0.8, 0.7
GP = {"range": RANGE, "sigma": SIGMA, "variance": "exact"}


def _samples(n, k, seed):
    rng = np.random.default_rng(seed)
    idx = np.sort(rng.choice(n, k, replace=False))
    return idx, rng


def _sigma_dense(V, F, rng_, sigma, alpha=2):
    kappa = math.sqrt(8.0) / rng_
    tau2 = 1.0 / (4 * math.pi * kappa ** 2 * sigma ** 2)
    G = laplacian(V, F).toarray()
    c = mass_matrix(V, F, mass="barycentric").diagonal()
    K = kappa ** 2 * np.diag(c) + G
    return np.linalg.inv(tau2 * (K @ np.diag(1.0 / c) @ K))


def _kriging(Sigma, H, y, noise=0.0):
    """Universal kriging (constant mean by GLS): mean and std at every vertex."""
    S = H @ Sigma @ H.T + noise ** 2 * np.eye(len(H))
    k = H @ Sigma  # (m, n)
    one = np.ones(len(H))
    Si1 = np.linalg.solve(S, one)
    a = one @ Si1
    beta = Si1 @ y / a
    W = np.linalg.solve(S, k)
    mean = beta + W.T @ (y - beta)
    var = np.diagonal(Sigma) - np.einsum("ij,ij->j", k, W) + (1.0 - k.T @ Si1) ** 2 / a
    return mean, np.sqrt(np.maximum(var, 0.0)), beta


def _unit_rows(idx, n):
    H = np.zeros((idx.size, n))
    H[np.arange(idx.size), idx] = 1.0
    return H


# ---- the dense oracle -----------------------------------------------------------------------------------


@pytest.mark.parametrize("noise", [0.0, 0.2])
def test_mean_and_std_are_dense_universal_kriging(noise):
    idx, rng = _samples(N2, 15, 0)
    y = V2[idx, 0] + 0.3 * rng.standard_normal(idx.size)
    r = manifill.reconstruct(V2, F2, idx, y, method="gp", gp={**GP, "noise": noise})
    mean, std, beta = _kriging(_sigma_dense(V2, F2, RANGE, SIGMA), _unit_rows(idx, N2), y, noise)
    assert np.abs(r.values - mean).max() < 1e-8 * np.abs(y).max()
    assert np.abs(r.std - std).max() < 1e-6 * std.max()
    rep = r.report["gp"]
    assert math.isclose(rep["mean"][0], beta, rel_tol=1e-8, abs_tol=1e-12)
    assert math.isclose(rep["sigma"][0], SIGMA, rel_tol=1e-12)
    assert math.isclose(rep["range"][0], RANGE, rel_tol=1e-12)
    if noise == 0:
        assert np.array_equal(r.values[idx], y)  # interpolates
        assert np.all(r.std[idx] == 0.0)
        assert np.all(np.delete(r.std, idx) > 0)
    else:
        assert np.abs(r.values[idx] - y).max() > 1e-3  # smooths
        assert np.all(r.std > 0)


@pytest.mark.parametrize("mean", ["constant", 0.3])
def test_fitted_scale_is_the_closed_form_reml_or_ml(mean):
    # range given, sigma fitted: with R the covariance at sigma = 1 and r the GLS residual (or
    # y - mu), sigma^2 = r' R^-1 r / (m - 1) (REML) or / m (ML, known mean); the result is then the
    # kriging oracle with Sigma scaled by it
    idx, rng = _samples(N2, 15, 9)
    y = V2[idx, 0] + 0.3 * rng.standard_normal(idx.size)
    S1 = _sigma_dense(V2, F2, RANGE, 1.0)
    R = S1[np.ix_(idx, idx)]
    one = np.ones(idx.size)
    if mean == "constant":
        r = y - (one @ np.linalg.solve(R, y)) / (one @ np.linalg.solve(R, one))
        s2 = r @ np.linalg.solve(R, r) / (idx.size - 1)
    else:
        r = y - mean
        s2 = r @ np.linalg.solve(R, r) / idx.size
    out = manifill.reconstruct(V2, F2, idx, y, method="gp", gp={"range": RANGE, "variance": "exact", "mean": mean})
    assert out.report["gp"]["fitted"] == ["sigma"]
    assert math.isclose(out.report["gp"]["sigma"][0] ** 2, s2, rel_tol=1e-10)
    H = _unit_rows(idx, N2)
    if mean == "constant":
        want, std, _ = _kriging(S1 * s2, H, y)
    else:  # simple kriging
        Sk = S1 * s2
        W = np.linalg.solve(Sk[np.ix_(idx, idx)], Sk[idx])
        want = mean + W.T @ (y - mean)
        std = np.sqrt(np.maximum(np.diagonal(Sk) - np.einsum("ij,ij->j", Sk[idx], W), 0.0))
    assert np.abs(out.values - want).max() < 1e-8
    assert np.abs(out.std - std).max() < 1e-6 * std.max()


def test_samples_as_points_inside_faces_are_interpolated_and_kriged():
    rng = np.random.default_rng(4)
    faces = rng.choice(len(F2), 8, replace=False)
    bary = rng.dirichlet(np.ones(3) * 3, size=8)
    P = np.einsum("kj,kjd->kd", bary, V2[F2[faces]])
    y = P[:, 1] ** 2 + P[:, 2]
    r = manifill.reconstruct(V2, F2, P, y, method="gp", gp=GP)
    assert np.abs(r.points.interpolate(r.values) - y).max() < 1e-10
    H = np.zeros((8, N2))
    for i, f in enumerate(faces):
        H[i, F2[f]] = bary[i]
    mean, std, _ = _kriging(_sigma_dense(V2, F2, RANGE, SIGMA), H, y)
    assert np.abs(r.values - mean).max() < 1e-8
    assert np.abs(r.std - std).max() < 1e-6 * std.max()


def test_points_report_of_gp_says_closest_surface_point():
    rng = np.random.default_rng(4)
    faces = rng.choice(len(F2), 8, replace=False)
    P = np.einsum("kj,kjd->kd", rng.dirichlet(np.ones(3) * 3, size=8), V2[F2[faces]])
    r = manifill.reconstruct(V2, F2, P, P[:, 0], method="gp", gp=GP)
    assert r.report["points"]["located"] == "closest surface point"
    assert r.report["points"]["inside_faces"] == 8


def test_alpha_one_with_a_huge_range_is_harmonic_interpolation():
    # alpha = 1, Q = tau^2 (kappa^2 C + G) -> tau^2 G as kappa = 1 / range -> 0: the mean is
    # the harmonic interpolant up to O(kappa^2) (measured 1.6e-5 at range 100, 1.6e-7 at 1000)
    idx, rng = _samples(N2, 12, 1)
    y = rng.standard_normal(idx.size)
    h = manifill.harmonic(V2, F2, idx, y)
    gaps = [np.abs(manifill.reconstruct(V2, F2, idx, y, method="gp", gp={"alpha": 1, "range": R}).values - h).max()
            for R in (1e2, 1e3)]
    assert gaps[0] < 1e-4 * np.abs(y).max()
    assert 50 < gaps[0] / gaps[1] < 200  # O(kappa^2): 100x per decade of range


def test_std_grows_with_the_distance_from_the_samples():
    V, F = icosphere(3)
    idx, rng = _samples(len(V), 10, 2)
    y = rng.standard_normal(idx.size)
    r = manifill.reconstruct(V, F, idx, y, method="gp", gp={"range": 1.0, "sigma": 1.0})
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    A = sp.coo_array((np.ones(len(E)), (E[:, 0], E[:, 1])), shape=(len(V),) * 2)
    hops = shortest_path(A, unweighted=True, directed=False, indices=idx).min(axis=0)
    means = [r.std[hops == h].mean() for h in range(5)]
    assert means[0] == 0.0
    assert np.all(np.diff(means) > 0), means
    # far away the std approaches the prior sigma (plus the mean's uncertainty), never far above
    assert r.std.max() < 1.5


def test_fitted_range_and_sigma_on_prior_draws_are_calibrated():
    # six fields drawn from the mesh's own prior (range 0.8, sigma 1) on icosphere(2), 100 of the
    # 162 vertices sampled: the shared range is fitted within 15% (seeds 0-5: 0.78-0.89), each
    # sigma within 20% (0.92-1.16), and at the held-out vertices the errors over the std have
    # a standard deviation in [0.85, 1.15] (0.93-1.07) with >= 90% inside +-2 (93-97%).
    Sigma = _sigma_dense(V2, F2, 0.8, 1.0)
    rng = np.random.default_rng(1)
    X = np.linalg.cholesky(Sigma) @ rng.standard_normal((N2, 6)) + 2.0
    idx = np.sort(rng.choice(N2, 100, replace=False))
    r = manifill.reconstruct(V2, F2, idx, X[idx], method="gp", gp={"variance": "exact"})
    g = r.report["gp"]
    assert g["fitted"] == ["range", "sigma"]
    assert abs(g["range"][0] / 0.8 - 1) < 0.15, g["range"]
    assert np.all(np.abs(np.array(g["sigma"]) - 1) < 0.2), g["sigma"]
    free = np.setdiff1d(np.arange(N2), idx)
    z = (r.values[free] - X[free]) / r.std[free]
    assert 0.85 < z.std() < 1.15 and np.mean(np.abs(z) < 2) >= 0.9, (z.std(), np.mean(np.abs(z) < 2))


# ---- invariances ----------------------------------------------------------------------------------------


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2 ** 31 - 1), st.integers(4, 25))
def test_relabelling_the_vertices_permutes_the_result(seed, k):
    idx, rng = _samples(N2, k, seed)
    y = rng.standard_normal(idx.size)
    perm = rng.permutation(N2)  # new vertex i is old vertex perm[i]
    inv = np.argsort(perm)
    Vp, Fp = V2[perm], inv[F2]
    a = manifill.reconstruct(V2, F2, idx, y, method="gp", gp=GP)
    b = manifill.reconstruct(Vp, Fp, inv[idx], y, method="gp", gp=GP)
    assert np.abs(b.values[inv] - a.values).max() < 1e-9
    assert np.abs(b.std[inv] - a.std).max() < 1e-9


@settings(max_examples=6, deadline=None)
@given(st.floats(-5, 5).filter(lambda a: abs(a) > 1e-2), st.floats(-100, 100), st.integers(0, 1000))
def test_affine_equivariance_in_the_data(a, c, seed):
    # the GLS mean makes the predictor affine-equivariant: R(a y + c) = a R(y) + c; with sigma
    # fixed the std does not depend on the data; with sigma fitted it scales by |a|
    idx, rng = _samples(N2, 12, seed)
    y = rng.standard_normal(idx.size)
    r0 = manifill.reconstruct(V2, F2, idx, y, method="gp", gp=GP)
    r1 = manifill.reconstruct(V2, F2, idx, a * y + c, method="gp", gp=GP)
    tol = 1e-9 * (1 + abs(c) + abs(a))
    assert np.abs(r1.values - (a * r0.values + c)).max() < tol
    assert np.abs(r1.std - r0.std).max() < 1e-9
    fit = {"range": RANGE, "variance": "exact"}
    f0 = manifill.reconstruct(V2, F2, idx, y, method="gp", gp=fit)
    f1 = manifill.reconstruct(V2, F2, idx, a * y + c, method="gp", gp=fit)
    assert np.abs(f1.values - (a * f0.values + c)).max() < tol
    assert np.abs(f1.std - abs(a) * f0.std).max() < 1e-8 * abs(a) * f0.std.max()


def test_linearity_with_a_known_mean():
    idx, rng = _samples(N2, 12, 3)
    y1, y2 = rng.standard_normal((2, idx.size))
    gp = {**GP, "mean": 0.0}
    R = [manifill.reconstruct(V2, F2, idx, y, method="gp", gp=gp) for y in (y1, y2, 2 * y1 - 3 * y2)]
    assert np.abs(R[2].values - (2 * R[0].values - 3 * R[1].values)).max() < 1e-10
    assert np.array_equal(R[0].std, R[1].std)
    # several fields at once: each column as alone
    both = manifill.reconstruct(V2, F2, idx, np.column_stack([y1, y2]), method="gp", gp=gp)
    assert np.abs(both.values[:, 0] - R[0].values).max() < 1e-12
    assert np.abs(both.values[:, 1] - R[1].values).max() < 1e-12
    # a known mean mu: the field is mu + the zero-mean predictor of y - mu
    mu = 0.4
    shifted = manifill.reconstruct(V2, F2, idx, y1 + mu, method="gp", gp={**GP, "mean": mu})
    assert np.abs(shifted.values - (R[0].values + mu)).max() < 1e-10


@pytest.mark.parametrize("s", [1e-2, 40.0])
def test_scaling_the_mesh_with_the_range(s):
    idx, rng = _samples(N2, 14, 5)
    y = rng.standard_normal(idx.size)
    a = manifill.reconstruct(V2, F2, idx, y, method="gp", gp=GP)
    b = manifill.reconstruct(s * V2, F2, idx, y, method="gp", gp={**GP, "range": s * RANGE})
    assert np.abs(b.values - a.values).max() < 1e-8
    assert np.abs(b.std - a.std).max() < 1e-8 * a.std.max()
    # with the range fitted: its search interval scales with the mesh, so the fit follows
    fa = manifill.reconstruct(V2, F2, idx, y, method="gp", gp={"variance": "exact"})
    fb = manifill.reconstruct(s * V2, F2, idx, y, method="gp", gp={"variance": "exact"})
    assert math.isclose(fb.report["gp"]["range"][0], s * fa.report["gp"]["range"][0], rel_tol=1e-4)
    assert np.abs(fb.values - fa.values).max() < 1e-4


def test_translation_invariance():
    idx, rng = _samples(N2, 14, 6)
    y = rng.standard_normal(idx.size)
    a = manifill.reconstruct(V2, F2, idx, y, method="gp", gp=GP)
    b = manifill.reconstruct(V2 + np.array([30.0, -7.0, 2.5]), F2, idx, y, method="gp", gp=GP)
    assert np.abs(b.values - a.values).max() < 1e-8
    assert np.abs(b.std - a.std).max() < 1e-8


# ---- the energy methods' uncertainty ------------------------------------------------------------------


@pytest.mark.parametrize("method", ["harmonic", "biharmonic"])
def test_energy_method_std_is_the_intrinsic_oracle(method):
    V, F = grid(10)
    n = len(V)
    idx, rng = _samples(n, 12, 7)
    y = np.sin(3 * V[idx, 0]) + V[idx, 1] + 0.1 * rng.standard_normal(idx.size)
    plain = manifill.reconstruct(V, F, idx, y, method=method)
    r = manifill.reconstruct(V, F, idx, y, method=method, uncertainty=True)
    assert np.array_equal(r.values, plain.values)
    assert np.all(r.std[idx] == 0)
    L = laplacian(V, F).toarray()
    if method == "harmonic":
        E = L
    else:
        m = mass_matrix(V, F, mass="voronoi").diagonal()
        E = L @ np.diag(1.0 / m) @ L
    x = r.values
    s2 = x @ E @ x / (idx.size - 1)
    free = np.setdiff1d(np.arange(n), idx)
    std = np.zeros(n)
    std[free] = np.sqrt(s2 * np.diagonal(np.linalg.inv(E[np.ix_(free, free)])))
    assert np.abs(r.std - std).max() < 1e-6 * std.max()
    assert math.isclose(r.report["uncertainty"]["scale"][0], math.sqrt(s2), rel_tol=1e-8)
    # the method's result is the oracle's conditional mean: the minimiser of x'Ex given the samples
    want = np.zeros(n)
    want[idx] = y
    want[free] = -np.linalg.solve(E[np.ix_(free, free)], E[np.ix_(free, idx)] @ y)
    assert np.abs(x - want).max() < 1e-8


def test_harmonic_std_with_points_inside_faces_is_the_kkt_oracle():
    # points inside faces constrain H_rows x = y: the conditional covariance of the free
    # vertices is the free block of the inverse of the KKT matrix [[L_ff, A'], [A, 0]]
    rng = np.random.default_rng(1)
    faces = rng.choice(len(F2), 5, replace=False)
    bary = rng.dirichlet(np.ones(3) * 3, size=5)
    P = np.vstack([V2[[5, 40]], np.einsum("kj,kjd->kd", bary, V2[F2[faces]])])
    y = rng.standard_normal(7)
    r = manifill.reconstruct(V2, F2, P, y, method="harmonic", uncertainty=True)
    assert np.abs(r.points.interpolate(r.values) - y).max() < 1e-10
    L = laplacian(V2, F2).toarray()
    free = np.setdiff1d(np.arange(N2), [5, 40])
    A = np.zeros((5, N2))
    for i, f in enumerate(faces):
        A[i, F2[f]] = bary[i]
    A = A[:, free]
    kkt = np.block([[L[np.ix_(free, free)], A.T], [A, np.zeros((5, 5))]])
    cov = np.linalg.inv(kkt)[:free.size, :free.size]
    x = r.values
    std = np.zeros(N2)
    std[free] = np.sqrt(np.maximum(x @ L @ x / (7 - 1) * np.diagonal(cov), 0.0))
    assert np.abs(r.std - std).max() < 1e-6 * std.max()
    assert np.all(r.std[[5, 40]] == 0)


# ---- trust ----------------------------------------------------------------------------------------------


def test_trust_marks_and_blanks_the_uncertain_vertices():
    V, F = icosphere(3)
    idx, rng = _samples(len(V), 10, 8)
    y = rng.standard_normal(idx.size)
    gp = {"range": 0.6, "sigma": 1.0}
    plain = manifill.reconstruct(V, F, idx, y, method="gp", gp=gp)
    t = 0.5
    thr = t * np.std(y)
    want = plain.std <= thr
    assert 0 < want.sum() < len(V)  # the threshold cuts somewhere
    m = manifill.reconstruct(V, F, idx, y, method="gp", gp=gp, trust=t)
    assert np.array_equal(m.trusted, want)
    assert np.array_equal(m.values, plain.values)
    assert np.all(m.trusted[idx])
    nan = manifill.reconstruct(V, F, idx, y, method="gp", gp=gp, trust=t, untrusted="nan")
    assert np.array_equal(np.isnan(nan.values), ~want)
    assert np.array_equal(nan.values[want], plain.values[want])
    assert nan.report["trust"]["untrusted"] == int((~want).sum())


# ---- refusals -------------------------------------------------------------------------------------------


REFUSALS = {
    "uncertainty for gvf-harmonic": dict(method="gvf-harmonic", uncertainty=True),
    "gp with bounds": dict(method="gp", bounds="samples"),
    "gp with bounds, no uncertainty": dict(method="gp", bounds="samples", uncertainty=False),
    "bad gp name": dict(method="gp", gp={"ragne": 1.0}),
    "sigma with alpha 1": dict(method="gp", gp={"alpha": 1, "range": 1.0, "sigma": 1.0}),
    "trust 0": dict(method="gp", gp=GP, trust=0),
    "trust < 0": dict(method="gp", gp=GP, trust=-1.0),
    "gp options for harmonic": dict(method="harmonic", gp=GP),
    "bad untrusted": dict(method="gp", gp=GP, trust=1.0, untrusted="zero"),
    "bad alpha": dict(method="gp", gp={"alpha": 3}),
    "bad variance": dict(method="gp", gp={"variance": "dense"}),
    "negative range": dict(method="gp", gp={"range": -1.0}),
}


@pytest.mark.parametrize("name", sorted(REFUSALS))
def test_refusals_are_option_errors_with_one_line(name):
    idx = np.arange(0, N2, 10)
    with pytest.raises(OptionError) as e:
        manifill.reconstruct(V2, F2, idx, V2[idx, 0], **REFUSALS[name])
    msg = str(e.value)
    assert "\n" not in msg and len(msg) > 20


@pytest.mark.parametrize("variance", ["exact", "sampled"])
def test_every_vertex_sampled_gives_the_samples_and_no_uncertainty(variance, capfd):
    # printed LAPACK's "DPOTRI parameter number 4 had an illegal value", then a wrong "not positive definite" error
    V, F = icosphere(2)
    vals = np.sin(V[:, 0])
    r = manifill.reconstruct(V, F, np.arange(len(V)), vals, method="gp", gp=dict(variance=variance))
    np.testing.assert_array_equal(r.values, vals)
    np.testing.assert_array_equal(r.std, 0.0)
    assert capfd.readouterr().err == ""


# ---------------------------------------------------------------------------
# posterior draws: r.sample(count, seed)
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("gp", [None, dict(noise=0.05)])
def test_draws_spread_as_the_std_says_and_centre_on_the_mean(gp):
    V, F = icosphere(3)
    idx = np.sort(np.random.default_rng(0).choice(len(V), 40, replace=False))
    r = manifill.reconstruct(V, F, idx, np.sin(2 * V[idx, 0]) + V[idx, 1], method="gp", gp=gp)
    D = r.sample(1000, seed=1)
    assert D.shape == (len(V), 1000)
    free = r.std > 1e-6 * r.std.max()
    ratio = D.std(axis=1)[free] / r.std[free]
    assert abs(np.median(ratio) - 1.0) < 0.03 and np.mean(np.abs(ratio - 1.0) < 0.1) > 0.95
    assert np.abs(D.mean(axis=1) - r.values).max() < 5.0 * r.std.max() / np.sqrt(1000)
    if gp is None:  # exact data: every draw goes through the samples
        np.testing.assert_allclose(D[idx], np.repeat(r.values[idx, None], 1000, axis=1), rtol=0, atol=1e-12)


def test_draws_go_through_samples_inside_faces_and_repeat_with_their_seed():
    V, F = icosphere(3)
    rng = np.random.default_rng(3)
    P = V[rng.choice(len(V), 30, replace=False)] + 0.02 * rng.normal(size=(30, 3))
    vals = np.column_stack([P[:, 0], np.cos(P[:, 1])])
    r = manifill.reconstruct(V, F, P, vals, method="gp")
    D = r.sample(20, seed=7)
    assert D.shape == (len(V), 2, 20)
    loc = r.points
    at = np.einsum("kc,kcpd->kpd", loc.bary, D[loc.corners])  # each draw, linear on the triangles, at the points
    np.testing.assert_allclose(at, np.repeat(vals[:, :, None], 20, axis=2), rtol=0, atol=1e-9)
    np.testing.assert_array_equal(r.sample(20, seed=7), D)
    assert not np.allclose(r.sample(20, seed=8), D)


def test_only_a_fitted_model_is_drawn_from():
    V, F = icosphere(2)
    r = manifill.reconstruct(V, F, np.arange(0, 162, 9), np.ones(18), method="biharmonic")
    with pytest.raises(OptionError, match="method='biharmonic' has no fitted probability model.*use method='gp'"):
        r.sample(3)
    g = manifill.reconstruct(V, F, np.arange(0, 162, 9), np.arange(18.0), method="gp")
    with pytest.raises(OptionError, match="count=0 draws: pass 1 or more"):
        g.sample(0)


def test_draws_carry_the_uncertainty_of_the_estimated_mean():
    # six samples near a pole and a range given: far away, the unknown mean is much of the uncertainty
    V, F = icosphere(3)
    idx = np.flatnonzero(V[:, 2] > 0.8)[:6]
    r = manifill.reconstruct(V, F, idx, V[idx, 0], method="gp", gp=dict(range=1.0))
    D = r.sample(1000, seed=1)
    free = r.std > 1e-6 * r.std.max()
    assert abs(np.median(D.std(axis=1)[free] / r.std[free]) - 1.0) < 0.03  # without the mean's share: 0.89


@pytest.mark.parametrize("mean", ["constant", 0.2])
def test_the_fit_on_sparse_factors_finds_the_dense_fits_optimum_on_every_sample(mean):
    # beyond fit_samples the likelihood was that of a random subset of 200; now of every sample, from sparse
    # factors (log det Q_ff - log det Q, one solve): the same function (tests/linalg/test_gpfit.py), so the same
    # optimum within the search's tolerance (3% in kappa), here inside the search's bounds
    from manifill.linalg import logdet as sparselik

    if not sparselik.sparse_fit_pays():
        pytest.skip("the fit on every sample runs with the [cholmod] extra (scikit-sparse) only")
    V, F = icosphere(3)
    idx = np.sort(np.random.default_rng(4).choice(len(V), 90, replace=False))
    vals = np.sin(6 * V[idx, 0]) * np.cos(5 * V[idx, 1])
    dense = manifill.reconstruct(V, F, idx, vals, method="gp", gp=dict(fit_samples=90, mean=mean))
    sparse = manifill.reconstruct(V, F, idx, vals, method="gp", gp=dict(fit_samples=89, mean=mean))
    d, s = dense.report["gp"], sparse.report["gp"]
    assert d["fit"]["likelihood"] == "dense covariance" and s["fit"]["likelihood"].startswith("sparse factors")
    assert s["fit"]["samples"] == 90
    lo, hi = s["fit"]["range_bounds"]
    assert lo * 1.1 < s["range"][0] < hi / 1.1  # an optimum inside the bounds: the test has teeth
    assert s["kappa"][0] == pytest.approx(d["kappa"][0], rel=0.05)
    assert s["loglik"] == pytest.approx(d["loglik"], abs=0.01)
    np.testing.assert_allclose(sparse.values, dense.values, rtol=0, atol=0.02 * np.ptp(vals))


def test_the_std_is_checked_on_the_samples_by_leaving_each_out():
    """The report's leave-one-out check predicts the held-out calibration: calibrated on draws of the prior with
    the true hyperparameters, far too wide on a smooth field (said in the summary), within 1.5x of the held-out
    RMS of error / std in both cases."""
    from manifill.report import uncertainty_lines

    V, F = icosphere(4)
    Sigma = _sigma_dense(V, F, RANGE, SIGMA)
    Lc = np.linalg.cholesky(Sigma)
    idx, rng = _samples(len(V), 300, 3)
    free = np.setdiff1d(np.arange(len(V)), idx)
    smooth = np.sin(3 * V[:, 0]) + V[:, 1] * V[:, 2]
    cases = {"prior": (Lc @ rng.standard_normal((len(V), 4)) + 2.0, GP),
             "smooth": (smooth[:, None], {"variance": "exact"})}
    for name, (X, gp) in cases.items():
        r = manifill.reconstruct(V, F, idx, X[idx], method="gp", gp=gp)
        loo = r.report["gp"]["variance"]["loo"]
        assert len(loo) == X.shape[1] and all(x["samples"] == 300 for x in loo)
        values, std = r.values.reshape(len(V), -1), r.std.reshape(len(V), -1)
        for j, x in enumerate(loo):
            held = float(np.sqrt(np.mean(((values[free, j] - X[free, j]) / std[free, j]) ** 2)))
            assert 1 / 1.5 < x["rms_z"] / held < 1.5, (name, x, held)
        lines = uncertainty_lines(r.report, r.std)
        if name == "prior":
            assert all(x["verdict"] == "calibrated" for x in loo), loo
            assert not any("too" in line for line in lines)
        else:
            assert loo[0]["verdict"] == "too wide" and loo[0]["rms_z"] < 0.5
            assert any("too wide on this field" in line for line in lines)


def test_the_leave_one_out_check_is_reported_in_the_fields_order():
    """Fields fitted apart make groups in another order than the fields': the check still follows the fields."""
    from manifill.report import uncertainty_lines

    V, F = icosphere(3)
    idx, _ = _samples(len(V), 130, 5)
    smooth = np.sin(2 * V[:, 0]) + V[:, 1]
    rough = np.random.default_rng(0).standard_normal(len(V))
    Y = np.column_stack([smooth, rough, smooth])[idx]
    r = manifill.reconstruct(V, F, idx, Y, method="gp", gp={"share": False})
    loo = r.report["gp"]["variance"]["loo"]
    alone = [manifill.reconstruct(V, F, idx, Y[:, j], method="gp").report["gp"]["variance"]["loo"][0]["rms_z"]
             for j in range(3)]
    assert [x["rms_z"] for x in loo] == pytest.approx(alone, rel=1e-6)
    assert loo[0]["verdict"] == "too wide" and loo[1]["verdict"] == "calibrated"
    assert any("too wide on field 1 of 3" in line for line in uncertainty_lines(r.report, r.std))
