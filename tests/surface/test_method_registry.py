"""The method registry and the options object: every method keeps the promises its capabilities make.

Each capability a method declares (bounds, smoothing, points inside faces, a std, linearity) is
checked against what it does, so that generic code can trust the declaration instead of the name;
a method added to the registry reaches ``reconstruct``, ``Reconstructor`` and ``cross_validate``.
"""

import dataclasses

import numpy as np
import pytest

import manifill
from manifill.errors import OptionError
from manifill.mesh.shapes import icosphere
from manifill.surface.methods import registry
from manifill.surface.methods.base import Method
from manifill.surface.options import OPTION_NAMES, Options

V, F = icosphere(3)
IDX = np.arange(0, len(V), 23)
VALS = np.sin(3 * V[IDX, 0]) + V[IDX, 2] ** 2
NAMES = registry.names(presets=False)


@pytest.mark.parametrize("name", NAMES)
def test_every_method_is_exact_at_the_samples_and_reports_itself(name):
    r = manifill.reconstruct(V, F, IDX, VALS, method=name)
    np.testing.assert_allclose(r.values[IDX], VALS, atol=1e-8 * np.ptp(VALS))
    m = registry.method_of(name)
    assert r.report["method"] == name or m.delegates  # auto reports the method it chose
    assert registry.method_of(r.report["method"]).name == r.report["method"]


@pytest.mark.parametrize("name", NAMES)
def test_bounds_are_taken_exactly_by_the_methods_that_say_so(name):
    m = registry.method_of(name)
    if not m.can_bound:
        with pytest.raises(OptionError, match="bounds"):
            manifill.reconstruct(V, F, IDX, VALS, method=name, bounds="samples")
        return
    r = manifill.reconstruct(V, F, IDX, VALS, method=name, bounds="samples")
    assert VALS.min() - 1e-9 <= np.nanmin(r.values) and np.nanmax(r.values) <= VALS.max() + 1e-9


@pytest.mark.parametrize("name", NAMES)
def test_smoothing_is_taken_by_the_methods_that_say_so(name):
    m = registry.method_of(name)
    if not m.can_smooth:
        with pytest.raises(OptionError, match="smoothing"):
            manifill.reconstruct(V, F, IDX, VALS, method=name, smoothing=1e-3)
        return
    if m.delegates:
        return  # auto hands smoothing to its candidates
    r = manifill.reconstruct(V, F, IDX, VALS, method=name, smoothing=1e3)
    assert np.abs(r.values[IDX] - VALS).max() > 1e-6 * np.ptp(VALS)  # soft: no longer exact at the samples


@pytest.mark.parametrize("name", NAMES)
def test_a_std_is_given_by_the_methods_that_say_so(name):
    m = registry.method_of(name)
    if not m.gives_std:
        with pytest.raises(OptionError, match="probability model"):
            manifill.reconstruct(V, F, IDX, VALS, method=name, uncertainty=True)
        return
    r = manifill.reconstruct(V, F, IDX, VALS, method=name, uncertainty=True,
                             **({"gp": {"range": 1.0}} if m.gp_mean else {}))
    assert r.std.shape == r.values.shape
    assert np.abs(r.std[IDX]).max() < 1e-6 and (r.std[np.setdiff1d(np.arange(len(V)), IDX)] > 0).all()


@pytest.mark.parametrize("name", [n for n in NAMES if not registry.method_of(n).delegates])
def test_points_inside_faces_are_met_where_the_method_says(name):
    rng = np.random.default_rng(3)
    f = rng.choice(len(F), 12, replace=False)
    w = rng.dirichlet(np.ones(3), 12)
    P = np.einsum("tj,tjd->td", w, V[F[f]])
    y = P[:, 0] - P[:, 1]
    r = manifill.reconstruct(V, F, P, y, method=name, **({"gp": {"range": 1.0}} if name == "gp" else {}))
    at = r.points.interpolate(r.values)
    exact = r.report["points"]["located"] == "closest surface point"
    assert exact == registry.method_of(name).at_points
    if exact:
        np.testing.assert_allclose(at, y, atol=1e-7 * np.ptp(y))


@pytest.mark.parametrize("name", NAMES)
def test_linear_methods_have_the_map_of_their_results(name):
    m = registry.method_of(name)
    opts = {"gp": {"range": 1.0, "sigma": 1.0, "noise": 0.0}} if m.gp_mean else {}
    rec = manifill.Reconstructor(V, F, IDX, method=name, **opts)
    linear, why = m.linear(rec.options)
    assert rec.linear == linear
    if not linear:
        with pytest.raises(OptionError, match="not linear"):
            rec.matrix()
        return
    W = rec.matrix()
    Y = np.column_stack([VALS, np.cos(V[IDX, 1])])
    np.testing.assert_allclose(W @ Y, rec.apply(Y).values, atol=1e-7 * np.ptp(Y))


def test_the_default_is_a_named_preset_that_says_what_it_ran():
    for method in (None, "default"):
        r = manifill.reconstruct(V, F, IDX, VALS, method=method)
        assert r.report["preset"] == "default" and r.report["default"] is True
        assert r.report["method"] == "biharmonic" and r.report["bounds"]["mode"] == "project"
    plain = manifill.reconstruct(V, F, IDX, VALS, method="biharmonic")
    assert "preset" not in plain.report and "bounds" not in plain.report
    # a preset fills in only what the caller did not give
    mine = manifill.reconstruct(V, F, IDX, VALS, bounds_mode="exact")
    assert mine.report["method"] == "biharmonic" and "mode" not in mine.report.get("bounds", {})
    assert mine.report["fill"]["bounds"]["iterations"]  # the active set ran
    same = manifill.reconstruct(V, F, IDX, VALS, method="biharmonic", bounds="samples", bounds_mode="project")
    np.testing.assert_array_equal(same.values, manifill.reconstruct(V, F, IDX, VALS).values)
    # curve values belong to the pipeline: the default refuses them (they are not dropped)
    with pytest.raises(OptionError, match="curve_values"):
        manifill.reconstruct(V, F, IDX, VALS, curve_values="linear")


def test_a_surface_without_triangles_takes_the_pipeline_by_default():
    """A voxel mask's digital surface has no mass matrix for the biharmonic: the default falls back to the
    paper's pipeline with monotone curve values, bounded (what the default was before issue 37)."""
    from manifill.surface.methods.registry import configure, for_surface
    from manifill.surface.surface import Surface

    s = Surface.from_mesh(V, F)
    s.mass = None
    o = for_surface(configure(), s)
    assert (o.method, o.preset, o.fill.curve_values, o.fit.bounds) == ("gvf-harmonic", "default", "monotone",
                                                                       "samples")
    given = for_surface(configure(solver="direct"), s)  # what the caller gave is kept
    assert given.fill.solver == "direct" and given.method == "gvf-harmonic"
    assert for_surface(configure(), Surface.from_mesh(V, F)).method == "biharmonic"


def test_options_are_built_once_checked_and_frozen():
    o = Options.build(method="biharmonic", solver="direct", bounds="samples", trust=None)
    assert (o.fill.solver, o.fit.bounds) == ("direct", "samples")
    assert o.given == frozenset({"solver", "bounds"})  # None is not given
    with pytest.raises(dataclasses.FrozenInstanceError):
        o.fill.solver = "amg"
    with pytest.raises(OptionError, match="did you mean 'weights'"):
        Options.build(wieghts="cotan")
    for bad in ({"solver": "fast"}, {"partition": "voronoi"}, {"duplicates": "max"}, {"untrusted": "drop"},
                {"trust": -1}, {"check": "yes"}):
        with pytest.raises(OptionError, match=next(iter(bad))):
            Options.build(**bad)
    assert set(o.keywords()) == set(OPTION_NAMES)
    again = Options.build(method=o.method, **o.keywords())
    assert (again.fill, again.step1, again.fit, again.points, again.uq) == (o.fill, o.step1, o.fit, o.points, o.uq)


def test_configure_is_idempotent_and_keywords_equal_the_object():
    o = registry.configure(method=None, smoothing=None)
    assert registry.configure(o) == o
    a = manifill.reconstruct(V, F, IDX, VALS, options=o)
    b = manifill.reconstruct(V, F, IDX, VALS)
    np.testing.assert_array_equal(a.values, b.values)
    # keywords beside the object change it
    c = manifill.reconstruct(V, F, IDX, VALS, options=o, method="harmonic")
    np.testing.assert_array_equal(c.values, manifill.reconstruct(V, F, IDX, VALS, method="harmonic").values)


class Nearest(Method):
    """A toy method: every vertex takes the value of the sample nearest in space (one module's worth)."""

    name = "nearest"
    step_names = ("check", "nearest")

    def fill(self, run):
        run.step1(self)
        with run.step("nearest"):
            d = ((run.surface.V[:, None, :] - run.surface.V[run.idx][None]) ** 2).sum(-1)
            values = run.vals[np.argmin(d, axis=1)]
        return values, None


def test_a_new_method_is_one_object_and_one_registry_entry(monkeypatch):
    monkeypatch.setitem(registry.METHODS, "nearest", Nearest())
    r = manifill.reconstruct(V, F, IDX, VALS, method="nearest")
    assert r.report["method"] == "nearest" and np.array_equal(r.values[IDX], VALS)
    assert VALS.min() <= r.values.min() and r.values.max() <= VALS.max()
    rec = manifill.Reconstructor(V, F, IDX, method="nearest")
    np.testing.assert_array_equal(rec.apply(VALS).values, r.values)
    assert not rec.linear
    cv = manifill.cross_validate(V, F, IDX, VALS, methods=["nearest", "harmonic"], folds=4)
    assert set(cv.errors) == {"nearest", "harmonic"} and np.isfinite(cv.errors["nearest"])
    with pytest.raises(OptionError, match="bounds"):  # it declares no bounds: refused, not ignored
        manifill.reconstruct(V, F, IDX, VALS, method="nearest", bounds="samples")
