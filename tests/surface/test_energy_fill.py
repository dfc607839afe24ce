"""The energy methods of reconstruct: harmonic, biharmonic, triharmonic with the samples alone as constraints.

Checked against libigl (``igl.harmonic(V, F, b, bc, k)``), for exactness at the samples, linearity in the data,
the bounded minimiser (no overshoot, KKT signs) and the smoothed fit (lambda -> 0 interpolates, lambda -> infinity
gives the energy's null space: a constant).
"""

import numpy as np
import pytest

import manifill
from manifill import OptionError, SampleError
from manifill.mesh.shapes import icosphere
from manifill.surface.energy_fill import as_bounds

igl = pytest.importorskip("igl")

V, F = icosphere(3)
RNG = np.random.default_rng(7)
IDX = np.sort(RNG.choice(len(V), 40, replace=False))


def field(X):
    return np.sin(2 * X[:, 0]) + X[:, 1] * X[:, 2] + 0.5 * np.cos(3 * X[:, 1])


VALS = field(V[IDX])


@pytest.mark.parametrize("solver", ["auto", "direct", "amg"])
@pytest.mark.parametrize("method, k", [("biharmonic", 2), ("triharmonic", 3)])
def test_equals_libigl(method, k, solver):
    r = manifill.reconstruct(V, F, IDX, VALS, method=method, solver=solver)
    ref = igl.harmonic(V, F.astype(np.int64), IDX.astype(np.int64), VALS[:, None], k)[:, 0]
    assert np.abs(r.values - ref).max() <= 1e-8 * np.ptp(VALS)
    np.testing.assert_array_equal(r.values[IDX], VALS)
    assert r.report["fill"]["energy"] == k


@pytest.mark.parametrize("method", ["biharmonic", "triharmonic"])
def test_linear_in_the_data(method):
    a, b = VALS, np.cos(V[IDX, 2]) * 3
    ra, rb = (manifill.reconstruct(V, F, IDX, x, method=method, solver="direct").values for x in (a, b))
    rab = manifill.reconstruct(V, F, IDX, 2 * a - b, method=method, solver="direct").values
    np.testing.assert_allclose(rab, 2 * ra - rb, atol=1e-10 * np.ptp(a))


def test_biharmonic_overshoots_and_bounds_remove_it():
    free = manifill.reconstruct(V, F, IDX, VALS, method="biharmonic", solver="direct")
    assert free.report["overshoot"] > 1e-3  # the unbounded minimiser leaves the samples' range here
    r = manifill.reconstruct(V, F, IDX, VALS, method="biharmonic", solver="direct", bounds="samples")
    assert r.report["overshoot"] <= 0
    assert VALS.min() <= r.values.min() and r.values.max() <= VALS.max()
    np.testing.assert_array_equal(r.values[IDX], VALS)
    # KKT: where the bound is not active the energy's gradient vanishes; where it is, its sign points outwards
    from manifill.linalg.energies import polyharmonic_energy
    from manifill.mesh.laplacian import mass_matrix

    E = polyharmonic_energy(manifill.laplacian(V, F), mass_matrix(V, F, mass="voronoi"), 2)
    g = E @ r.values
    free_idx = np.setdiff1d(np.arange(len(V)), IDX)
    at_lo = free_idx[r.values[free_idx] <= VALS.min()]
    at_hi = free_idx[r.values[free_idx] >= VALS.max()]
    inner = np.setdiff1d(free_idx, np.r_[at_lo, at_hi])
    scale = np.abs(E).max() * np.ptp(VALS)
    assert at_lo.size + at_hi.size > 0
    assert np.abs(g[inner]).max() <= 1e-8 * scale
    assert (g[at_lo] >= -1e-8 * scale).all() and (g[at_hi] <= 1e-8 * scale).all()
    # and it is not the clip of the unbounded solution
    assert np.abs(r.values - np.clip(free.values, VALS.min(), VALS.max())).max() > 1e-6


def test_bounds_as_a_pair_and_refusals():
    lo, hi = VALS.min() - 0.01, VALS.max() + 0.01
    r = manifill.reconstruct(V, F, IDX, VALS, method="biharmonic", solver="direct", bounds=(lo, hi))
    assert lo - 1e-12 <= r.values.min() and r.values.max() <= hi + 1e-12
    with pytest.raises(SampleError, match="outside the bounds"):
        manifill.reconstruct(V, F, IDX, VALS, method="biharmonic", bounds=(0.0, 0.1))
    with pytest.raises(SampleError, match="exceeds the upper bound"):
        as_bounds((1.0, 0.0), VALS[:, None])
    with pytest.raises(OptionError, match="energy methods"):
        manifill.reconstruct(V, F, IDX, VALS, smoothing=0.1, method="gvf-harmonic")  # no soft constraints
    with pytest.raises(OptionError, match="'samples'"):
        manifill.reconstruct(V, F, IDX, VALS, method="biharmonic", bounds="range")


def test_harmonic_with_bounds_changes_nothing_with_uniform_weights():
    """The maximum principle: uniform weights never leave the samples' range, so the bounds are inactive."""
    a = manifill.reconstruct(V, F, IDX, VALS, method="harmonic", weights="uniform", solver="direct")
    b = manifill.reconstruct(V, F, IDX, VALS, method="harmonic", weights="uniform", solver="direct",
                             bounds="samples")
    np.testing.assert_allclose(b.values, a.values, atol=1e-12)


@pytest.mark.parametrize("method", ["harmonic", "biharmonic"])
def test_smoothing_limits(method):
    exact = manifill.reconstruct(V, F, IDX, VALS, method=method, solver="direct").values
    tiny = manifill.reconstruct(V, F, IDX, VALS, method=method, smoothing=1e-9)
    np.testing.assert_allclose(tiny.values, exact, atol=1e-5 * np.ptp(VALS))
    huge = manifill.reconstruct(V, F, IDX, VALS, method=method, smoothing=1e9)
    np.testing.assert_allclose(huge.values, VALS.mean(), atol=1e-5 * np.ptp(VALS))


def test_smoothing_auto_beats_interpolation_on_noise():
    Vb, Fb = icosphere(4)
    rng = np.random.default_rng(3)
    idx = np.sort(rng.choice(len(Vb), 300, replace=False))
    truth = field(Vb)
    noisy = truth[idx] + 0.05 * np.ptp(truth) * rng.standard_normal(idx.size)
    exact = manifill.reconstruct(Vb, Fb, idx, noisy, method="biharmonic", solver="direct")
    smooth = manifill.reconstruct(Vb, Fb, idx, noisy, method="biharmonic", smoothing="auto")
    err = lambda r: np.sqrt(np.mean((r.values - truth) ** 2))  # noqa: E731
    assert err(smooth) < 0.8 * err(exact)
    rep = smooth.report["fill"]["smoothing"]
    assert np.asarray(rep["lambda"]).ravel()[0] > 0
    np.testing.assert_allclose(np.asarray(rep["residuals"]).ravel(), smooth.values[idx] - noisy, atol=1e-9)


def test_bad_smoothing_and_weights():
    with pytest.raises(OptionError):
        manifill.reconstruct(V, F, IDX, VALS, method="biharmonic", smoothing="gcv-ish")
    with pytest.raises(OptionError, match="smoothing"):
        manifill.reconstruct(V, F, IDX, VALS, method="biharmonic", sample_weights=np.ones(IDX.size))
    with pytest.raises(OptionError, match="not supported"):
        manifill.reconstruct(V, F, IDX, VALS, method="biharmonic", smoothing=1.0, bounds="samples")


def test_auto_falls_back_to_a_factorisation_when_cg_stalls(monkeypatch):
    """solver='auto' picks CG for a large biharmonic system; if it stalls, the direct solve answers (reported)."""
    monkeypatch.setenv("MANIFILL_DIRECT", "superlu")  # with Pardiso, auto factorises this size in the first place
    Vb, Fb = icosphere(5)
    idx = np.sort(np.random.default_rng(5).choice(len(Vb), 50, replace=False))
    vals = field(Vb[idx])
    r = manifill.reconstruct(Vb, Fb, idx, vals, method="biharmonic", maxiter=2)
    assert "stalled" in r.report["fill"]["fallback"] and r.report["fill"]["solver"] == "direct"
    ref = manifill.reconstruct(Vb, Fb, idx, vals, method="biharmonic", solver="direct")
    np.testing.assert_allclose(r.values, ref.values, atol=1e-12 * np.ptp(vals))
    with pytest.raises(manifill.SolveError, match="did not reach"):
        manifill.reconstruct(Vb, Fb, idx, vals, method="biharmonic", solver="amg", maxiter=2)


@pytest.mark.parametrize("weights", ["cotan", "uniform"])
def test_the_pipeline_with_bounds_projects_the_curves_and_fills_within_them(weights):
    """gvf-harmonic with bounds: Hermite curve values projected onto the bounds, then the bounded harmonic fill.

    The fill is the Dirichlet problem's bounded minimiser with the projected curve values fixed: where the free
    fill already lies within the bounds (the maximum principle), the two agree exactly.
    """
    from manifill.surface.fill import fill_patches
    from manifill.surface.surface import Surface

    free = manifill.reconstruct(V, F, IDX, VALS, method="gvf-harmonic", weights=weights)
    assert free.report["overshoot"] > 1e-3  # Hermite curves overshoot here: the bounds have work to do
    r = manifill.reconstruct(V, F, IDX, VALS, method="gvf-harmonic", weights=weights, bounds="samples")
    lo, hi = VALS.min(), VALS.max()
    assert lo - 1e-12 <= r.values.min() and r.values.max() <= hi + 1e-12 and r.report["overshoot"] <= 1e-12
    assert r.report["bounds"]["clipped_curve_values"] > 0
    np.testing.assert_allclose(r.values[IDX], VALS, rtol=0, atol=1e-12)
    curve = np.flatnonzero(r.on_curve)
    np.testing.assert_allclose(r.values[curve], np.clip(free.values[curve], lo, hi), rtol=0, atol=1e-12)
    x, _ = fill_patches(Surface.from_mesh(V, F), curve, r.values[curve], weights=weights, solver="direct")
    if lo - 1e-12 <= x.min() and x.max() <= hi + 1e-12:
        np.testing.assert_allclose(r.values, x, rtol=0, atol=1e-9 * np.ptp(VALS))
    with pytest.raises(SampleError, match="outside the bounds"):
        manifill.reconstruct(V, F, IDX, VALS, method="gvf-harmonic", bounds=(0.0, 0.1))
