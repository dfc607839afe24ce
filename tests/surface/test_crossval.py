"""Which method to trust: ``cross_validate`` and ``method="auto"`` (manifill.surface.crossval).

The error is recomputed here from hand-made folds; a method that reproduces the field
has error ~0; on a U-shaped strip (two arms close in space, far apart on the surface)
cross-validation ranks the thin-plate spline first for a field in space and a mesh
method first for a field along the surface; leave-one-out equals ``folds=k``; seeds
reproduce; failures, unreached components and too few samples are reported, not crashes;
``auto`` equals the chosen method's own result.
"""

import numpy as np
import pytest

from manifill import CrossValidation, OptionError, SampleError, cross_validate, reconstruct
from manifill.mesh.shapes import grid, icosphere
from manifill.surface.crossval import CANDIDATES, fold_labels

MESH_METHODS = ("gvf-harmonic", "harmonic", "biharmonic", "triharmonic")


def u_strip(ns=80, nt=8, gap=0.1, width=0.5):
    """A strip bent into a U: two parallel arms ``gap`` apart, joined by a half-circle; and arc length ``s``."""
    g = gap / 2
    L1, Lb = 1.0, np.pi * g
    s = np.linspace(0, 2 * L1 + Lb, ns)
    x = np.where(s < L1, s, np.where(s < L1 + Lb, L1 + g * np.sin((s - L1) / g), L1 - (s - L1 - Lb)))
    z = np.where(s < L1, -g, np.where(s < L1 + Lb, -g * np.cos((s - L1) / g), g))
    t = np.linspace(0, width, nt)
    V = np.column_stack([np.repeat(x, nt), np.tile(t, ns), np.repeat(z, nt)])
    i, j = np.meshgrid(np.arange(ns - 1), np.arange(nt - 1), indexing="ij")
    a = (i * nt + j).ravel()
    F = np.vstack([np.column_stack([a, a + nt, a + nt + 1]), np.column_stack([a, a + nt + 1, a + 1])])
    return V, F, np.repeat(s, nt), np.tile(t, ns)


@pytest.fixture(scope="module")
def sphere():
    V, F = icosphere(3)
    idx = np.sort(np.random.default_rng(2).choice(len(V), 40, replace=False))
    return V, F, idx


def test_the_error_is_the_held_out_rmse_over_the_range(sphere):
    V, F, idx = sphere
    y = np.column_stack([np.sin(2 * V[idx, 0]), V[idx, 1] * 4.0])
    cv = cross_validate(V, F, idx, y, methods=["biharmonic"], folds=4, seed=7)
    assert isinstance(cv, CrossValidation) and cv.folds == 4 and not cv.loo
    pred = np.empty_like(y)
    for f in range(4):
        test = cv.labels == f
        r = reconstruct(V, F, idx[~test], y[~test], method="biharmonic")
        pred[test] = r.values[idx[test]]
    per_field = np.sqrt(((pred - y) ** 2).mean(0)) / np.ptp(y, axis=0)
    assert np.allclose(cv.field_errors["biharmonic"], per_field, rtol=1e-9)
    assert np.isclose(cv.errors["biharmonic"], np.sqrt((per_field ** 2).mean()), rtol=1e-9)
    fold0 = np.sqrt(((((pred - y) / np.ptp(y, axis=0))[cv.labels == 0]) ** 2).mean())
    assert np.isclose(cv.fold_errors["biharmonic"][0], fold0, rtol=1e-9)


def test_a_method_that_reproduces_the_field_has_zero_error(sphere):
    V, F, idx = sphere
    y = 1.0 + V[idx, 0] - 2.0 * V[idx, 2]  # affine in space: the thin-plate spline is exact
    cv = cross_validate(V, F, idx, y, methods=["rbf", "harmonic", "biharmonic"], folds=5)
    assert cv.errors["rbf"] < 1e-9
    assert cv.errors["harmonic"] > 1e-3 and cv.errors["biharmonic"] > 1e-4
    assert cv.best == "rbf" and "reproduces the held-out samples" in cv.recommendation


def test_affine_field_on_a_flat_mesh():
    V, F = grid(10)
    idx = np.arange(0, 100, 3)
    y = 0.5 + 2.0 * V[idx, 0] - V[idx, 1]
    cv = cross_validate(V, F, idx, y, methods=["harmonic", "rbf"], folds=5)
    assert cv.errors["rbf"] < 1e-9 < cv.errors["harmonic"]


@pytest.mark.parametrize("kind", ["space", "surface"])
def test_cross_validation_tells_space_fields_from_surface_fields(kind):
    V, F, s, t = u_strip()
    idx = np.random.default_rng(3).choice(len(V), 60, replace=False)
    if kind == "space":  # smooth in space: both arms see it, a gap of 0.1 apart
        f = np.sin(2 * V[:, 0]) + np.cos(3 * V[:, 1]) + 3 * V[:, 2]
    else:  # along the surface (arc length): the arms, close in space, differ by ~2 in s
        f = np.sin(2.5 * s) + 0.3 * t
    cv = cross_validate(V, F, idx, f[idx], folds=10)
    ranking = cv.ranking()
    assert len(ranking) == len(CANDIDATES)
    if kind == "space":
        assert cv.best == "rbf" and "lives in space" in cv.recommendation
    else:
        assert cv.best.split()[0] in MESH_METHODS and ranking[-1] == "rbf"


def test_leave_one_out_equals_k_folds():
    V, F = icosphere(2)
    idx = np.arange(3, len(V), 11)
    y = np.cos(3 * V[idx, 1])
    m = ["harmonic", ("biharmonic", {"bounds": "samples"}), "rbf"]
    loo = cross_validate(V, F, idx, y, methods=m, folds="loo")
    k = cross_validate(V, F, idx, y, methods=m, folds=idx.size, seed=5)
    assert loo.loo and loo.folds == idx.size and loo.what == "leave-one-out"
    for label in loo.methods:
        assert np.isclose(loo.errors[label], k.errors[label], rtol=1e-10, atol=1e-15)
        # fold i of leave-one-out holds out sample i; fold labels[i] of the K-fold split does too
        assert np.allclose(loo.fold_errors[label], k.fold_errors[label][k.labels], rtol=1e-10, atol=1e-15)


def test_seeds_reproduce_and_differ(sphere):
    V, F, idx = sphere
    y = V[idx, 0] ** 2
    a = cross_validate(V, F, idx, y, methods=["harmonic"], folds=5, seed=1)
    b = cross_validate(V, F, idx, y, methods=["harmonic"], folds=5, seed=1)
    c = cross_validate(V, F, idx, y, methods=["harmonic"], folds=5, seed=2)
    assert np.array_equal(a.labels, b.labels) and a.errors == b.errors
    assert not np.array_equal(a.labels, c.labels)
    assert np.bincount(a.labels).tolist() == [8] * 5


def test_too_few_samples_for_the_folds(sphere):
    V, F, _ = sphere
    idx = np.array([0, 5, 9, 20, 31])
    with pytest.raises(SampleError, match="needs at least 10 samples, got 5; use 5 folds or fewer") as e:
        cross_validate(V, F, idx, V[idx, 0], folds=10)
    assert "\n" not in str(e.value)
    with pytest.raises(SampleError, match="at least 3"):
        cross_validate(V, F, idx[:2], V[idx[:2], 0], folds="loo")
    for bad in (1, 2.5, "all", True):
        with pytest.raises(OptionError, match="folds"):
            fold_labels(10, bad)


def test_a_failing_method_is_reported_not_raised(sphere):
    V, F, idx = sphere
    y = V[idx, 2]
    cv = cross_validate(V, F, idx, y, methods=["harmonic", ("biharmonic", {"bounds": (0.5, None)})], folds=4)
    bad = "biharmonic bounds=(0.5, None)"
    assert set(cv.failures[bad]) == {0, 1, 2, 3} and not cv.failures["harmonic"]
    assert all("\n" not in reason for reason in cv.failures[bad].values())
    assert cv.best == "harmonic" and cv.ranking()[-1] == bad
    line = [ln for ln in cv.table().splitlines() if bad in ln][0]
    assert "failed on 4/4 folds" in line and line.lstrip().startswith("-")


def test_a_component_without_training_samples_is_excluded_and_counted():
    V1, F1 = icosphere(2)
    V = np.vstack([V1, V1 + [4.0, 0.0, 0.0]])
    F = np.vstack([F1, F1 + len(V1)])
    idx = np.append(np.arange(0, len(V1), 8), len(V1) + 3)  # one sample alone on the second sphere
    y = V[idx, 0] + V[idx, 1]
    cv = cross_validate(V, F, idx, y, methods=["harmonic", "rbf"], folds="loo")
    assert cv.excluded["harmonic"] == 1 and cv.excluded["rbf"] == 0
    assert not cv.failures["harmonic"] and np.isfinite(cv.errors["harmonic"])
    assert "1 held-out samples unreached" in cv.table()


def test_options_and_candidates_are_checked(sphere):
    V, F, idx = sphere
    y = V[idx, 0]
    with pytest.raises(OptionError, match="no option 'colour'"):
        cross_validate(V, F, idx, y, colour="red")
    with pytest.raises(OptionError, match="method='fast'"):
        cross_validate(V, F, idx, y, methods=["fast"])
    with pytest.raises(OptionError, match="auto"):
        cross_validate(V, F, idx, y, methods=["auto"])
    with pytest.raises(OptionError, match="twice"):
        cross_validate(V, F, idx, y, methods=["rbf", "rbf"])
    with pytest.raises(OptionError, match="option 'distance'"):
        cross_validate(V, F, idx, y, methods=[("harmonic", {"distance": "hops"})])
    with pytest.raises(OptionError, match="weights="):
        cross_validate(V, F, idx, y, weights="fancy")
    # options every fit gets; a candidate's own override them
    cv = cross_validate(V, F, idx, y, methods=["harmonic", ("harmonic", {"weights": "cotan"})], folds=3,
                        weights="uniform")
    assert cv.errors["harmonic"] != cv.errors["harmonic weights=cotan"]


def test_digital_surface_leaves_out_the_methods_that_need_triangles():
    from manifill.solid.boundary import digital_surface, digital_surface_graph

    g = np.indices((8, 8, 8)).reshape(3, -1).T
    mask = (((g - 3.5) ** 2).sum(1) < 9).reshape(8, 8, 8)
    _, P, E, normals = digital_surface(mask)
    surface = digital_surface_graph(P, E, normals)
    idx = np.arange(0, len(P), 4)
    cv = cross_validate(surface, None, idx, P[idx, 0] - P[idx, 2], folds=3)
    assert not any(m.startswith(("biharmonic", "triharmonic")) for m in cv.methods)
    assert cv.errors["rbf"] < 1e-9 and cv.best == "rbf"


def test_auto_equals_the_chosen_method(sphere):
    V, F, idx = sphere
    y = np.column_stack([np.sin(2 * V[idx, 0]) + V[idx, 1], V[idx, 2] ** 2])
    r = reconstruct(V, F, idx, y, method="auto", weights="cotan")
    auto = r.report["auto"]
    assert auto["folds"] == 5 and auto["chosen"] == auto["methods"][0]
    assert r.report["method"] == auto["chosen_options"]["method"]
    assert auto["errors"] == sorted(auto["errors"])
    again = reconstruct(V, F, idx, y, weights="cotan", **auto["chosen_options"])
    assert np.array_equal(r.values, again.values)
    # the choice is the cross-validation's, with the same split
    from manifill.surface.crossval import AUTO_CANDIDATES

    cv = cross_validate(V, F, idx, y, methods=AUTO_CANDIDATES, folds=5, seed=0)
    assert cv.best == auto["chosen"]


@pytest.mark.parametrize("field,chosen", [("space", "rbf"), ("surface", None)])
def test_auto_on_the_u_strip(field, chosen):
    V, F, s, t = u_strip()
    idx = np.random.default_rng(3).choice(len(V), 60, replace=False)
    f = np.sin(2 * V[:, 0]) + 3 * V[:, 2] if field == "space" else np.sin(2.5 * s) + 0.3 * t
    r = reconstruct(V, F, idx, f[idx], method="auto")
    assert (r.report["method"] == "rbf") == (chosen == "rbf")
    assert np.allclose(r.values[np.sort(idx)], f[np.sort(idx)], atol=1e-8)


def test_auto_with_few_samples_leaves_one_out_and_refuses_two(sphere):
    V, F, _ = sphere
    idx = np.array([0, 40, 90, 130])
    r = reconstruct(V, F, idx, V[idx, 0], method="auto")
    assert r.report["auto"]["folds"] == "loo"
    with pytest.raises(SampleError, match="at least 3 samples"):
        reconstruct(V, F, idx[:2], V[idx[:2], 0], method="auto")


def test_samples_at_positions_are_cross_validated_where_they_are():
    V, F = icosphere(3)
    rng = np.random.default_rng(4)
    P = rng.normal(size=(40, 3))
    P /= np.linalg.norm(P, axis=1)[:, None]  # on the sphere, off the vertices (within the facets' sag)
    from manifill.surface.locate import locate_points

    Q = locate_points(V, F, P).points  # the closest surface points: where the fits constrain the samples
    y = 1.0 + Q[:, 0] - 2.0 * Q[:, 2]
    cv = cross_validate(V, F, Q, y, methods=["rbf", "biharmonic", "gvf-harmonic"], folds=4)
    assert cv.samples == 40 and cv.errors["rbf"] < 1e-9  # exact at the points, affine: held-out points too
    assert cv.errors["biharmonic"] > 1e-4 and np.isfinite(cv.errors["gvf-harmonic"])
    with pytest.raises(OptionError, match="max_distance"):
        cross_validate(V, F, np.arange(10), np.arange(10.0), max_distance=0.1)


def test_overshoot_is_each_candidates_farthest_excursion_and_the_advice_names_a_bounded_one(sphere):
    V, F, idx = sphere
    vals = np.sin(2 * V[idx, 0]) + V[idx, 1] * V[idx, 2]
    cv = cross_validate(V, F, idx, vals, methods=["triharmonic", ("biharmonic", {"bounds": "samples"}), "harmonic"],
                        folds=4)
    # the overshoot of one fold's fit, recomputed: how far it leaves its training samples' range, over the range
    labels = cv.labels
    far = 0.0
    for f in range(cv.folds):
        train = labels != f
        r = reconstruct(V, F, idx[train], vals[train], method="triharmonic", on_empty="nan")
        lo, hi = vals[train].min(), vals[train].max()
        far = max(far, max(r.values.max() - hi, lo - r.values.min()) / (hi - lo))
    assert cv.overshoot["triharmonic"] == pytest.approx(far, rel=1e-9) and far > 0.01
    assert cv.overshoot["biharmonic bounds=samples"] <= 1e-9 and cv.overshoot["harmonic"] <= 1e-9
    text = cv.recommendation
    assert cv.best == "triharmonic" and "overshoots the samples' range" in text
    assert "the best that stays within it is method='biharmonic', bounds='samples'" in text
    assert "overshoot" in cv.table().splitlines()[1] and cv.summary()["overshoot"]["triharmonic"] == far
    alone = cross_validate(V, F, idx, vals, methods=["triharmonic", "rbf"], folds=4)
    assert "none of the candidates stayed within it" in alone.recommendation


def test_auto_with_bounds_chooses_among_the_candidates_that_hold_them(sphere):
    V, F, idx = sphere
    vals = np.sin(2 * V[idx, 0]) + V[idx, 1] * V[idx, 2]
    r = reconstruct(V, F, idx, vals, method="auto", bounds="samples")
    assert all(not m.startswith("rbf") for m in r.report["auto"]["methods"])  # rbf takes no bounds: not a candidate
    assert not r.report["auto"]["failures"]
    assert vals.min() - 1e-9 <= r.values.min() and r.values.max() <= vals.max() + 1e-9


def test_several_fields_say_what_each_loses_to_its_own_best(sphere):
    V, F, idx = sphere
    smooth = np.sin(2 * V[idx, 0]) + V[idx, 1] * V[idx, 2]
    step = (V[idx, 0] + 0.5 * V[idx, 1] > 0.2).astype(float)
    methods = ["triharmonic", ("biharmonic", {"bounds": "samples"}), "harmonic"]
    cv = cross_validate(V, F, idx, np.column_stack([smooth, step]), methods=methods, folds=4)
    alone = [cross_validate(V, F, idx, y, methods=methods, folds=4) for y in (smooth, step)]
    for j, (own, loss) in enumerate(cv.per_field()):
        assert own == alone[j].best  # a field's own best is what cross-validating it alone picks
        assert loss == pytest.approx(alone[j].errors[cv.best] / alone[j].errors[own], rel=1e-9)
    losers = [j for j, (own, r) in enumerate(cv.per_field()) if own != cv.best and r > 1.05]
    assert losers and f"field {losers[0] + 1} would be" in cv.recommendation
