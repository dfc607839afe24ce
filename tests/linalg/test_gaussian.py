"""The conditioned Gaussian field (manifill.linalg.gaussian.Conditional) against dense Gaussian conditioning.

For ``x ~ N(0, Sigma)``, ``Sigma = Q^-1``, observed as ``y = H x + e``, ``e ~ N(0, diag(eta))``
(``eta = 0``: exact), with ``S = H Sigma H' + diag(eta)``:

    E[x | y] = Sigma H' S^-1 y,    Cov[x | y] = Sigma - Sigma H' S^-1 H Sigma.

``gram(Y)`` is ``Y' S^-1 Y``. For an intrinsic ``Q`` (a Laplacian, constants in its null
space) with exact vertex data the conditional law of the free vertices ``f`` given the
observed ``o`` is ``N(-Q_ff^-1 Q_fo y, Q_ff^-1)`` and ``y' S^-1 y`` becomes the Schur
complement ``y' (Q_oo - Q_of Q_ff^-1 Q_fo) y``. The sampled variance is a Monte Carlo
estimate: calibrated against the exact one within its own standard error.
"""

import numpy as np
import pytest
import scipy.sparse as sp

from conftest import icosphere
from manifill.errors import OptionError
from manifill.linalg import gaussian
from manifill.linalg.gaussian import Conditional
from manifill.linalg.spde import MaternShape
from manifill.mesh.laplacian import laplacian, mass_matrix
from manifill.mesh.roots import gradient_root

V, F = icosphere(2)
N = len(V)
RNG = np.random.default_rng(11)
IDX = np.sort(RNG.choice(N, 14, replace=False))
FACES = RNG.choice(len(F), 5, replace=False)
ROWS = np.zeros((5, N))
for _r, _f in enumerate(FACES):
    ROWS[_r, F[_f]] = RNG.dirichlet(np.ones(3))
ROWS = sp.csr_array(ROWS)


def _matern(alpha=2, kappa=3.0):
    s = MaternShape(laplacian(V, F), mass_matrix(V, F).diagonal(), gradient_root(V, F), alpha, 2)
    return s.precision(kappa), s.root(kappa)


def _H(idx, rows):
    E = np.zeros((idx.size, N))
    E[np.arange(idx.size), idx] = 1.0
    return E if rows is None else np.vstack([E, rows.toarray()])


def _oracle(Q, idx, rows, eta, Y):
    Sigma = np.linalg.inv(Q.toarray())
    H = _H(idx, rows)
    S = H @ Sigma @ H.T + (0.0 if eta is None else np.diag(np.broadcast_to(eta, (H.shape[0],))))
    mean = Sigma @ H.T @ np.linalg.solve(S, Y)
    cov = Sigma - Sigma @ H.T @ np.linalg.solve(S, H @ Sigma)
    return mean, Y.T @ np.linalg.solve(S, Y), np.diagonal(cov)


CASES = {
    "vertices": (None, None),
    "vertices+rows": (ROWS, None),
    "noisy": (None, 0.05),
    "noisy-rows": (ROWS, np.linspace(0.01, 0.2, IDX.size + 5)),
}


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("alpha", [1, 2])
def test_mean_gram_and_exact_variance_are_dense_conditioning(case, alpha):
    rows, eta = CASES[case]
    Q, B = _matern(alpha)
    m = IDX.size + (0 if rows is None else rows.shape[0])
    Y = np.random.default_rng(2).standard_normal((m, 3))
    c = Conditional(Q, B, IDX, rows=rows, eta=eta)
    X = c.extend(Y)
    mean, gram, var = _oracle(Q, IDX, rows, eta, Y)
    scale = np.abs(mean).max()
    assert np.abs(X - mean).max() < 1e-8 * scale
    G = c.gram(Y, X)
    assert np.abs(G - gram).max() < 1e-8 * np.abs(gram).max()
    v, info = c.variance("exact")
    assert info["how"] == "exact"
    assert np.abs(v - var).max() < 1e-8 * var.max()
    if eta is None:
        assert np.all(v[IDX] == 0.0)
        free = np.setdiff1d(np.arange(N), IDX)
        assert np.all(v[free] > 0)
        if rows is not None:  # the data are reproduced: vertices exactly, rows to rounding
            assert np.allclose(X[IDX], Y[:IDX.size], atol=0, rtol=0)
            assert np.abs(rows @ X - Y[IDX.size:]).max() < 1e-10 * scale
    else:
        assert np.all(v > 0)


def test_one_column_data_is_accepted_flat():
    Q, B = _matern()
    y = np.random.default_rng(0).standard_normal(IDX.size)
    X = Conditional(Q, B, IDX).extend(y)
    assert X.shape == (N, 1)


def test_noise_to_zero_approaches_the_exact_data_mean():
    Q, B = _matern()
    Y = np.random.default_rng(5).standard_normal((IDX.size, 1))
    exact = Conditional(Q, B, IDX).extend(Y)
    # eta in units of the prior variance (about 1 / (4 pi kappa^2) = 0.009 here): the gap is O(eta)
    gaps = [np.abs(Conditional(Q, B, IDX, eta=e).extend(Y) - exact).max() for e in (1e-4, 1e-6, 1e-8)]
    assert gaps[0] > 50 * gaps[1] > 2500 * gaps[2]
    assert gaps[2] < 1e-5 * np.abs(exact).max()


def test_intrinsic_precision_with_exact_vertex_data():
    L = laplacian(V, F)
    B = gradient_root(V, F)
    Y = np.random.default_rng(7).standard_normal((IDX.size, 2))
    c = Conditional(L, B, IDX)
    X = c.extend(Y)
    free = np.setdiff1d(np.arange(N), IDX)
    Ld = L.toarray()
    Lff, Lfo = Ld[np.ix_(free, free)], Ld[np.ix_(free, IDX)]
    want = np.zeros((N, 2))
    want[IDX] = Y
    want[free] = -np.linalg.solve(Lff, Lfo @ Y)
    assert np.abs(X - want).max() < 1e-8 * np.abs(want).max()
    schur = Ld[np.ix_(IDX, IDX)] - Lfo.T @ np.linalg.solve(Lff, Lfo)
    G = c.gram(Y, X)
    assert np.abs(G - Y.T @ schur @ Y).max() < 1e-8 * np.abs(G).max()
    v, _ = c.variance("exact")
    assert np.abs(v[free] - np.diagonal(np.linalg.inv(Lff))).max() < 1e-6 * v.max()
    assert np.all(v[IDX] == 0)
    # constants are free: adding one to the data adds one to the mean, the gram is unchanged
    X1 = c.extend(Y + 1.0)
    assert np.abs(X1 - X - 1.0).max() < 1e-8
    assert np.abs(c.gram(Y + 1.0, X1) - G).max() < 1e-8 * np.abs(G).max()


@pytest.mark.parametrize("case", ["vertices", "vertices+rows", "noisy"])
def test_sampled_variance_is_calibrated(case):
    # the Monte Carlo estimate with S samples: |sampled - exact| <= 4 se at >= 97% of the
    # vertices, the mean ratio sampled / exact within 3 standard errors of 1 (over seeds), and the
    # standard error shrinks by sqrt(2) (+-15%, median over the vertices) when S doubles.
    rows, eta = CASES[case]
    Q, B = _matern()
    c = Conditional(Q, B, IDX, rows=rows, eta=eta)
    exact, _ = c.variance("exact")
    v, info = c.variance("sampled", samples=400, seed=1)
    assert info["how"] == "sampled" and info["samples"] == 400
    se = info["se"]
    live = exact > 0
    assert np.array_equal(v > 0, live)
    ok = np.abs(v - exact)[live] <= 4 * se[live]
    assert ok.mean() >= 0.97, ok.mean()
    # unbiased: the vertices' errors share the samples (they are correlated), so the mean ratio's
    # error is measured over independent seeds: 12 estimates of 100 samples each
    r = np.array([np.mean(c.variance("sampled", samples=100, seed=100 + t)[0][live] / exact[live])
                  for t in range(12)])
    assert abs(r.mean() - 1.0) < 3 * r.std(ddof=1) / np.sqrt(r.size), (r.mean(), r.std(ddof=1))
    _, info2 = c.variance("sampled", samples=800, seed=2)
    shrink = np.median(se[live] / info2["se"][live])
    assert 0.85 * np.sqrt(2) < shrink < 1.15 * np.sqrt(2), shrink
    # same seed, same estimate
    v2, _ = c.variance("sampled", samples=400, seed=1)
    assert np.array_equal(v, v2)


def test_sampled_variance_is_zero_at_observed_vertices():
    Q, B = _matern()
    v, info = Conditional(Q, B, IDX).variance("sampled", samples=20)
    assert np.all(v[IDX] == 0) and np.all(info["se"][IDX] == 0)
    free = np.setdiff1d(np.arange(N), IDX)
    assert np.all(v[free] > 0)


def test_refusals():
    Q, B = _matern()
    c = Conditional(Q, None, IDX)
    for call in (lambda: c.variance("dense"), lambda: c.variance("sampled"),
                 lambda: Conditional(Q, B, IDX).variance("sampled", samples=1),
                 lambda: Conditional(Q, B, IDX, eta=0.0), lambda: Conditional(Q, B, IDX, eta=np.nan)):
        with pytest.raises(OptionError) as e:
            call()
        assert "\n" not in str(e.value)


@pytest.mark.parametrize("case", ["vertices", "noisy"])
def test_the_mean_and_the_exact_variance_share_one_cholesky_factor(case, monkeypatch):
    rows, eta = CASES[case]
    Q, B = _matern()
    calls = []
    real = gaussian.cholesky
    monkeypatch.setattr(gaussian, "cholesky", lambda *a, **k: calls.append(1) or real(*a, **k))
    c = Conditional(Q, B, IDX, eta=eta, factoriser="cholesky", solver="direct")
    Y = np.random.default_rng(2).standard_normal((IDX.size, 1))
    X = c.extend(Y)
    v, info = c.variance("exact")
    assert calls == [] and info["factor"] in ("superlu", "cholmod") and info["factor_entries"] > 0
    mean, _, var = _oracle(Q, IDX, rows, eta, Y)
    assert np.abs(X - mean).max() < 1e-8 * np.abs(mean).max()
    assert np.abs(v - var).max() < 1e-8 * var.max()
    # without the shared factor, the variance factorises on its own: the same numbers
    v2, _ = Conditional(Q, B, IDX, eta=eta).variance("exact")
    assert calls == [1] and np.abs(v2 - v).max() < 1e-10 * v.max()


def test_auto_variance_is_exact_with_cholmod_or_small_and_says_why_it_samples(monkeypatch):
    Q, B = _matern()
    monkeypatch.setattr(gaussian, "EXACT_MAX", 10)
    monkeypatch.setattr(gaussian, "cholmod_available", lambda: False)
    v, info = Conditional(Q, B, IDX).variance("auto", samples=10)
    assert info["how"] == "sampled" and "[cholmod]" in info["why"] and f"{N - IDX.size:,} unknowns" in info["why"]
    monkeypatch.setattr(gaussian, "cholmod_available", lambda: True)
    _, info = Conditional(Q, B, IDX).variance("auto")
    assert info["how"] == "exact"
    monkeypatch.setattr(gaussian, "EXACT_MAX", N)
    monkeypatch.setattr(gaussian, "cholmod_available", lambda: False)
    _, info = Conditional(Q, B, IDX).variance("auto")
    assert info["how"] == "exact"


def test_loo_summary_calls_a_std_off_when_the_errors_disagree():
    z = np.random.default_rng(0).standard_normal(4000)
    ok, wide, narrow = gaussian.loo_summary(z), gaussian.loo_summary(0.4 * z), gaussian.loo_summary(2.0 * z)
    assert ok["verdict"] == "calibrated" and abs(ok["rms_z"] - 1) < 0.05 and abs(ok["within_1.96"] - 0.95) < 0.01
    assert wide["verdict"] == "too wide" and narrow["verdict"] == "too narrow"
    assert wide["rms_z"] == pytest.approx(0.4 * ok["rms_z"]) and narrow["within_1.96"] < 0.7


@pytest.mark.skipif(not gaussian.cholmod_available(), reason="the [cholmod] extra (scikit-sparse) is not installed")
def test_one_factor_with_the_samples_last_gives_mean_variance_draws_and_leave_one_out():
    Q, B = _matern()
    Y = np.random.default_rng(2).standard_normal((IDX.size, 2))
    c = Conditional(Q, B, IDX, factoriser="cholesky", definite=True)
    assert c._sl is not None
    mean, gram, var = _oracle(Q, IDX, None, None, Y)
    X = c.extend(Y)
    assert np.abs(X - mean).max() < 1e-9 * np.abs(mean).max()
    assert np.abs(c.gram(Y, X) - gram).max() < 1e-9 * np.abs(gram).max()
    v, info = c.variance("exact")
    assert np.abs(v - var).max() < 1e-9 * var.max() and info["factor"] == "cholmod"
    plain = Conditional(Q, B, IDX, definite=True)
    plain.variance("exact")
    assert np.abs(c.loo(Y) - plain.loo(Y)).max() < 1e-9 * np.abs(plain.loo(Y)).max()
    # draws: zero at the samples, covariance Q_ff^-1 (the same draws as the general path, same generator)
    d1, d2 = c.draws(3, np.random.default_rng(4)), plain.draws(3, np.random.default_rng(4))
    assert np.all(d1[IDX] == 0) and np.abs(d1 - d2).max() < 1e-9 * np.abs(d2).max()


def test_auto_variance_falls_back_to_sampling_when_the_exact_one_cannot_be_read(monkeypatch):
    from manifill.errors import ResourceError

    Q, B = _matern()

    def refuse(factor):
        raise ResourceError("the selected inversion needs about 9 GB but only 1 GB of memory is available")

    monkeypatch.setattr(gaussian, "SelectedInverse", refuse)
    v, info = Conditional(Q, B, IDX).variance("auto", samples=20)
    assert info["how"] == "sampled" and "needs about 9 GB" in info["why"] and np.all(v[IDX] == 0)
    with pytest.raises(ResourceError, match="9 GB"):
        Conditional(Q, B, IDX).variance("exact")


@pytest.mark.skipif(not gaussian.cholmod_available(), reason="the [cholmod] extra (scikit-sparse) is not installed")
def test_many_samples_leave_the_shared_factor_for_the_two_factor_path(monkeypatch):
    Q, B = _matern()
    Y = np.random.default_rng(6).standard_normal((IDX.size, 1))
    shared = Conditional(Q, B, IDX, factoriser="cholesky", definite=True)
    monkeypatch.setattr(gaussian, "SAMPLES_LAST_MAX", IDX.size - 1)
    apart = Conditional(Q, B, IDX, factoriser="cholesky", definite=True)
    assert shared._sl is not None and apart._sl is None
    assert np.abs(shared.extend(Y) - apart.extend(Y)).max() < 1e-10
    assert np.abs(shared.variance("exact")[0] - apart.variance("exact")[0]).max() < 1e-10
