"""Linear precision, the limits of smoothing, and the errors of every method of ``reconstruct``.

The companion of tests/surface/test_method_properties.py (its samples, data and settings): what the
energies reproduce on flat meshes (and, honestly, what they do not), smoothing's two limits (lambda -> 0
interpolates, lambda -> infinity gives the energy's null space, the weighted mean of the samples) and the
sample weights, and one-line errors for bounds the samples break, malformed bounds, options a method
cannot take, and too few samples to cross-validate.
"""

import re

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import manifill
from conftest import grid, icosphere, irregular
from manifill import OptionError, SampleError
from manifill.surface.reconstruct import reconstruct
from test_method_properties import FA, IDX, VA, data, hsettings, needs_auto, needs_rbf, seeds


# ---------------------------------------------------------------------------
# linear precision on flat meshes
# ---------------------------------------------------------------------------

FLAT = {"grid": lambda: grid(7), "irregular": lambda: irregular(8, seed=3)}


def flat_samples(V_, F_, inside=4, all_boundary=True, seed=0):
    from manifill.mesh.topology import boundary_loops

    bnd = np.unique(np.concatenate(boundary_loops(F_)))
    rng = np.random.default_rng(seed)
    inner = rng.choice(np.setdiff1d(np.arange(len(V_)), bnd), inside, replace=False)
    return np.r_[bnd if all_boundary else bnd[:: max(1, bnd.size // 4)], inner], bnd


linear_coefficients = st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-5, 5)).filter(
    lambda t: abs(t[1]) + abs(t[2]) > 0.1)


@pytest.mark.parametrize("mesh", FLAT)
@hsettings
@given(coef=linear_coefficients, seed=seeds)
def test_harmonic_with_cotan_weights_reproduces_linear_fields(mesh, coef, seed):
    """Samples on the whole boundary and some inside: a linear field is discrete-harmonic (cotan), so it is it."""
    V_, F_ = FLAT[mesh]()
    idx, _ = flat_samples(V_, F_, seed=seed)
    f = coef[0] + V_[:, :2] @ np.array(coef[1:])
    for extra in ({}, dict(bounds="samples")):
        r = reconstruct(V_, F_, idx, f[idx], method="harmonic", weights="cotan", **extra)
        np.testing.assert_allclose(r.values, f, rtol=0, atol=1e-10 * np.ptp(f))


@pytest.mark.parametrize("mesh", FLAT)
def test_what_does_not_reproduce_linear_fields_on_an_open_flat_mesh(mesh):
    """A free boundary vertex gets the energies' natural boundary condition, which a linear field does not meet.

    Harmonic: zero normal derivative (the row of L at a boundary vertex is the flux through its boundary
    edges). Biharmonic and triharmonic (x' L (M^-1 L)^(k-1) x): even with every boundary vertex sampled, the
    rows of L at the boundary enter the energy, and L applied to a linear field is zero in the interior but
    not there, so a linear field has positive energy and is not the minimiser (libigl's too; only with the
    outer k rings fixed is it reproduced, tests/surface/test_polyharmonic.py).
    """
    V_, F_ = FLAT[mesh]()
    f = 0.3 + V_[:, :2] @ np.array([2.0, -1.5])
    few, bnd = flat_samples(V_, F_, all_boundary=False)
    full, _ = flat_samples(V_, F_, all_boundary=True)
    err = lambda idx, m: np.abs(reconstruct(V_, F_, idx, f[idx], method=m).values - f).max() / np.ptp(f)  # noqa: E731
    assert err(few, "harmonic") > 1e-2
    for m in ("biharmonic", "triharmonic"):
        assert err(full, m) > 1e-2, m
        assert err(few, m) > 1e-2, m
    Lf = manifill.laplacian(V_, F_) @ f
    inner = np.setdiff1d(np.arange(len(V_)), bnd)
    assert np.abs(Lf[inner]).max() <= 1e-12 * np.abs(f).max()  # linear fields are harmonic inside...
    assert np.abs(Lf[bnd]).max() > 1e-3  # ...but not at the boundary rows


@pytest.mark.parametrize("diagonal", ["alternate", "right"])
def test_the_pipeline_with_monotone_curves_reproduces_linear_fields_on_a_flat_grid(diagonal):
    """Straight curves covering the boundary (nine samples): the limiter does not bind on a linear field.

    (linear and hermite curve values: tests/surface/test_reconstruct.py::test_linear_field_reproduced_on_a_flat_grid)
    """
    from conftest import GRID_N, GRID_SAMPLES

    V_, F_ = grid(GRID_N, diagonal=diagonal)
    idx = np.array(GRID_SAMPLES["nine"])
    f = 0.3 + V_[:, :2] @ np.array([2.0, -1.5])
    r = reconstruct(V_, F_, idx, f[idx], method="gvf-harmonic", curve_values="monotone", distance="length")
    np.testing.assert_allclose(r.values, f, rtol=0, atol=1e-10 * np.ptp(f))


# ---------------------------------------------------------------------------
# smoothing: its two limits, and the weights
# ---------------------------------------------------------------------------

SMOOTH_ENERGIES = ["harmonic", "biharmonic", "triharmonic"]


@pytest.mark.parametrize("method", SMOOTH_ENERGIES)
@hsettings
@given(seed=seeds, weighted=st.booleans())
def test_lambda_to_zero_recovers_interpolation(method, seed, weighted):
    vals = data(seed)
    w = np.random.default_rng(seed).uniform(0.2, 5.0, IDX.size) if weighted else None
    exact = reconstruct(VA, FA, IDX, vals, method=method, solver="direct").values
    for lam, tol in ((0.0, 1e-10), (1e-12, 1e-6)):
        r = reconstruct(VA, FA, IDX, vals, method=method, smoothing=lam, sample_weights=w)
        np.testing.assert_allclose(r.values, exact, rtol=0, atol=tol * np.ptp(vals))


@pytest.mark.parametrize("method", SMOOTH_ENERGIES)
@hsettings
@given(seed=seeds)
def test_lambda_to_infinity_gives_the_weighted_mean(method, seed):
    """The energies' null space on a closed surface is the constants; the data term picks the weighted mean."""
    rng = np.random.default_rng(seed)
    vals = data(seed)
    w = rng.uniform(0.1, 10.0, IDX.size)
    r = reconstruct(VA, FA, IDX, vals, method=method, smoothing=1e8, sample_weights=w)  # >= 1e9 lam0 here
    mean = w @ vals / w.sum()
    np.testing.assert_allclose(r.values, mean, rtol=0, atol=1e-6 * np.ptp(vals))
    assert abs(mean - vals.mean()) > 1e-3 * np.ptp(vals)  # the weights matter: the plain mean is another value
    res = np.asarray(r.report["fill"]["smoothing"]["residuals"]).ravel()
    np.testing.assert_allclose(res, mean - vals, rtol=0, atol=1e-6 * np.ptp(vals))


@pytest.mark.parametrize("method, weighted", [("harmonic", True), ("biharmonic", False)])
def test_lambda_far_beyond_the_scale_still_gives_the_weighted_mean(method, weighted):
    vals = data(0)
    w = np.random.default_rng(0).uniform(0.1, 10.0, IDX.size) if weighted else np.ones(IDX.size)
    r = reconstruct(VA, FA, IDX, vals, method=method, smoothing=1e16, sample_weights=w)
    np.testing.assert_allclose(r.values, w @ vals / w.sum(), rtol=0, atol=1e-6 * np.ptp(vals))


def test_lambda_to_infinity_on_two_components_gives_each_its_own_weighted_mean():
    V1, F1 = icosphere(1)
    V_ = np.vstack([V1, V1 + [5.0, 0.0, 0.0]])
    F_ = np.vstack([F1, F1 + len(V1)])
    rng = np.random.default_rng(2)
    first, second = (np.sort(rng.choice(len(V1), m, replace=False)) for m in (6, 5))
    idx = np.r_[first, len(V1) + second]
    vals, w = rng.standard_normal(idx.size), rng.uniform(0.5, 4.0, idx.size)
    r = reconstruct(V_, F_, idx, vals, method="biharmonic", smoothing=1e8, sample_weights=w)
    for part, verts in ((slice(0, 6), slice(0, len(V1))), (slice(6, None), slice(len(V1), None))):
        np.testing.assert_allclose(r.values[verts], w[part] @ vals[part] / w[part].sum(), rtol=0, atol=1e-6)


def fitted_error(method, idx, vals, w, row):
    r = reconstruct(VA, FA, idx, vals, method=method, smoothing=1e-2, sample_weights=w)
    return abs(r.values[idx[row]] - vals[row])


WEIGHTED = ["harmonic", "biharmonic", "triharmonic", pytest.param("rbf", marks=needs_rbf)]


@pytest.mark.parametrize("method", WEIGHTED)
def test_a_heavier_sample_is_fitted_closer(method):
    vals = data(4)
    w = np.ones(IDX.size)
    w[3] = 100.0
    assert fitted_error(method, IDX, vals, w, 3) < 0.1 * fitted_error(method, IDX, vals, None, 3)


@pytest.mark.parametrize("method", WEIGHTED)
def test_sample_weights_follow_the_callers_rows(method):
    order = np.random.default_rng(9).permutation(IDX.size)  # the same samples, given in another order
    idx, vals = IDX[order], data(4)[order]
    row = int(np.flatnonzero(order == 3)[0])
    w = np.ones(IDX.size)
    w[row] = 100.0
    assert fitted_error(method, idx, vals, w, row) < 0.1 * fitted_error(method, idx, vals, None, row)


def test_residuals_follow_the_callers_rows():
    order = np.random.default_rng(9).permutation(IDX.size)
    idx, vals = IDX[order], data(4)[order]
    r = reconstruct(VA, FA, idx, vals, method="biharmonic", smoothing=1e-2)
    res = np.asarray(r.report["fill"]["smoothing"]["residuals"])
    assert res.shape == vals.shape
    np.testing.assert_allclose(res, r.values[idx] - vals, rtol=0, atol=1e-10 * np.ptp(vals))


# ---------------------------------------------------------------------------
# clear errors
# ---------------------------------------------------------------------------


def one_line(e):
    msg = str(e.value)
    assert "\n" not in msg and len(msg) < 300, msg
    return msg


@pytest.mark.parametrize("method", ["harmonic", "biharmonic", "triharmonic"])
def test_samples_outside_the_bounds_are_refused_naming_them_and_the_fix(method):
    vals = data(1)
    lo, hi = np.sort(vals)[2], np.sort(vals)[-1]  # two samples below lo
    with pytest.raises(SampleError) as e:
        reconstruct(VA, FA, IDX, vals, method=method, bounds=(lo, hi))
    msg = one_line(e)
    first = int(np.flatnonzero(vals < lo)[0])
    assert "outside the bounds" in msg and "(2," in msg and f"sample {first} " in msg, msg
    assert "widen the bounds" in msg and "bounds='samples'" in msg


def test_the_refused_sample_is_named_in_the_callers_numbering():
    idx, vals = np.array([100, 50, 7, 120, 3]), np.array([0.1, 0.2, 0.3, 5.0, 0.4])
    with pytest.raises(SampleError) as e:
        reconstruct(VA, FA, idx, vals, method="biharmonic", bounds=(0.0, 1.0))
    assert re.search(r"(sample|row) 3\b|vertex 120\b", one_line(e))


@pytest.mark.parametrize("bounds, error, words", [
    ((1.0, -1.0), SampleError, "exceeds the upper bound"),
    (("low", 1.0), SampleError, "could not be read as numbers"),
    ((np.nan, 1.0), SampleError, "NaN"),
    ((0.0, 1.0, 2.0), OptionError, "(lo, hi) pair"),
    (3.0, OptionError, "(lo, hi) pair"),
    ("range", OptionError, "'samples'"),
])
def test_impossible_or_malformed_bounds_are_refused(bounds, error, words):
    with pytest.raises(error) as e:
        reconstruct(VA, FA, IDX, data(0), method="biharmonic", bounds=bounds)
    assert words in one_line(e)


REFUSED = [(m, o) for m in ("gvf-harmonic", "gvf") for o in ("smoothing", "smoothing-auto", "weights")]
REFUSED += [pytest.param("rbf", o, marks=needs_rbf) for o in ("bounds", "smoothing-auto", "weights")]
REFUSED += [pytest.param("auto", "weights", marks=needs_auto)]
OPTIONS = {"bounds": dict(bounds="samples"), "smoothing": dict(smoothing=1.0), "smoothing-auto": dict(smoothing="auto"),
           "weights": dict(sample_weights=np.ones(IDX.size))}


@pytest.mark.parametrize("method, option", REFUSED)
def test_bounds_and_smoothing_on_a_method_that_cannot_take_them(method, option):
    """Refused, never dropped: the message names the method (or the option) and what to pass instead."""
    with pytest.raises(OptionError) as e:
        reconstruct(VA, FA, IDX, data(0), method=method, **OPTIONS[option])
    msg = one_line(e)
    assert method in msg or "smoothing=" in msg, msg
    assert "pass" in msg or "pick" in msg or "use" in msg, msg


def test_too_few_samples_for_choosing_lambda():
    with pytest.raises(SampleError) as e:
        reconstruct(VA, FA, IDX[:2], data(0)[:2], method="biharmonic", smoothing="auto")
    assert "at least 3 samples" in one_line(e)


@pytest.mark.parametrize("smoothing, n", [(-1.0, IDX.size), (np.inf, IDX.size), ("auto", 2)])
def test_smoothing_errors_name_the_option_the_caller_passed(smoothing, n):
    with pytest.raises((OptionError, SampleError)) as e:
        reconstruct(VA, FA, IDX[:n], data(0)[:n], method="biharmonic", smoothing=smoothing)
    assert "smoothing" in one_line(e)


@pytest.mark.skipif(not hasattr(manifill, "cross_validate"), reason="manifill.cross_validate not there yet (B)")
@pytest.mark.parametrize("k, folds", [(2, 10), (2, "loo"), (4, 10)])
def test_too_few_samples_for_cross_validation(k, folds):
    with pytest.raises(SampleError) as e:
        manifill.cross_validate(VA, FA, IDX[:k], data(0)[:k], methods=("harmonic",), folds=folds)
    msg = one_line(e)
    assert "at least" in msg and f"got {k}" in msg, msg


@needs_auto
def test_too_few_samples_for_method_auto():
    with pytest.raises(SampleError) as e:
        reconstruct(VA, FA, IDX[:2], data(0)[:2], method="auto")
    msg = one_line(e)
    assert "at least" in msg and "got 2" in msg and "pick a method" in msg, msg
