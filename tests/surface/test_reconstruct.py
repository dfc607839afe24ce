"""The whole pipeline, Steps 1-6: exactness, maximum principle, linear precision, references, invariances."""

import numpy as np
import pytest
from scipy.sparse import csgraph

from conftest import edge_set, grid, icosphere, irregular, relabel, torus, two_components
from manifill import OptionError, SampleError, SolveError, harmonic
from manifill.mesh.graph import mesh_graph
from manifill.surface.reconstruct import STEPS
from manifill.surface.reconstruct import reconstruct as _reconstruct
from manifill.mesh.shapes import grid as shapes_grid

METHODS = ("gvf-harmonic", "harmonic", "gvf")
#: These tests are about the paper's Steps 1-6: without a method they run the pipeline as the default ran it
#: before issue 37 (monotone curve values, bounded by the samples' range; each option given by a test wins).
PIPELINE_DEFAULT = {"curve_values": "monotone", "bounds": "samples"}


def reconstruct(V, F, idx, vals, **kw):
    """``manifill.reconstruct``, with the paper's pipeline where no method is named."""
    if kw.get("method") is None:
        kw = {**PIPELINE_DEFAULT, **{k: v for k, v in kw.items() if v is not None}, "method": "gvf-harmonic"}
    return _reconstruct(V, F, idx, vals, **kw)
PARTITIONS = ("delaunay", "cycle", "tree")
CURVE_VALUES = ("linear", "hermite", "gvf")


def jittered_icosphere(k=2, seed=0):
    """An icosphere with radii jittered by 5 %: no two edges of equal length, so no ties in distances."""
    V, F = icosphere(k)
    rng = np.random.default_rng(seed)
    return V * (1.0 + 0.05 * rng.standard_normal((len(V), 1))), F


def random_samples(V, k, seed):
    rng = np.random.default_rng(seed)
    idx = rng.choice(len(V), size=k, replace=False)
    return idx, rng


def on_levels(V, F, idx, s=0.25, c=-0.5):
    """Sample values c + s * (hops to the first sample): exactly on uniform levels that auto levels pick."""
    hops = csgraph.shortest_path(mesh_graph(V, F, distance="hops"), unweighted=True, indices=idx[0])[idx]
    return c + s * hops


# ---------------------------------------------------------------------------
# exact at the samples
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("curve_values", CURVE_VALUES)
@pytest.mark.parametrize("partition", PARTITIONS)
@pytest.mark.parametrize("method", METHODS)
def test_exact_at_samples_on_levels(method, partition, curve_values):
    V, F = icosphere(2)
    idx, _ = random_samples(V, 12, seed=1)
    vals = on_levels(V, F, idx)
    r = reconstruct(V, F, idx, vals, method=method, partition=partition, curve_values=curve_values)
    assert r.report["check"][0]["level_error"] < 1e-12
    np.testing.assert_allclose(r.values[idx], vals, rtol=0, atol=1e-12)
    assert np.isfinite(r.values).all()


@pytest.mark.parametrize("distance", ["length", "hops"])
@pytest.mark.parametrize("curve_values", ["linear", "hermite"])
@pytest.mark.parametrize("partition", PARTITIONS)
@pytest.mark.parametrize("method", ["gvf-harmonic", "harmonic"])
def test_exact_at_samples(method, partition, curve_values, distance):
    V, F = torus()
    idx, rng = random_samples(V, 14, seed=2)
    vals = rng.uniform(-3.0, 3.0, size=idx.size)
    r = reconstruct(V, F, idx, vals, method=method, partition=partition, curve_values=curve_values,
                    distance=distance)
    np.testing.assert_array_equal(r.values[idx], vals)
    assert r.values.shape == (len(V),)


@pytest.mark.parametrize("method, curve_values", [("gvf-harmonic", "gvf"), ("gvf", "linear")])
def test_exact_at_samples_off_levels_with_gvf(method, curve_values):
    V, F = icosphere(2)
    rng = np.random.default_rng(0)
    idx = rng.choice(len(V), size=10, replace=False)
    vals = rng.standard_normal(10)
    r = reconstruct(V, F, idx, vals, method=method, curve_values=curve_values)
    assert r.report["check"][0]["level_error"] > 0.1
    np.testing.assert_allclose(r.values[idx], vals)


@pytest.mark.parametrize("weights", ["cotan", "uniform", "intrinsic", "robust"])
def test_method_harmonic_is_harmonic_with_the_samples_fixed(weights):
    V, F = irregular()
    idx, rng = random_samples(V, 9, seed=3)
    vals = rng.uniform(-1.0, 2.0, size=(idx.size, 2))
    r = reconstruct(V, F, idx, vals, method="harmonic", weights=weights)
    np.testing.assert_allclose(r.values, harmonic(V, F, idx, vals, weights=weights), rtol=0, atol=1e-12)
    assert r.curves == [] and not r.on_curve[np.setdiff1d(np.arange(len(V)), idx)].any()


# ---------------------------------------------------------------------------
# maximum principle
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("partition", PARTITIONS)
@pytest.mark.parametrize("name, build", [("icosphere3", lambda: icosphere(3)), ("torus", torus),
                                         ("irregular", irregular), ("grid", lambda: grid(12))])
@pytest.mark.parametrize("seed", [0, 1])
def test_maximum_principle_per_patch(partition, name, build, seed):
    V, F = build()
    idx, rng = random_samples(V, 10, seed)
    vals = rng.uniform(-2.0, 4.0, size=idx.size)
    r = reconstruct(V, F, idx, vals, partition=partition, weights="uniform", curve_values="linear")
    x = r.values
    eps = 1e-10
    assert x.min() >= vals.min() - eps and x.max() <= vals.max() + eps
    labels = r.components
    np.testing.assert_array_equal(labels < 0, r.on_curve)
    bnd = {}
    for i, j in edge_set(F):
        for a, b in ((i, j), (j, i)):
            if labels[a] >= 0 and r.on_curve[b]:
                bnd.setdefault(labels[a], set()).add(b)
    for p in range(labels.max() + 1):
        inside = x[labels == p]
        ring = x[sorted(bnd[p])]
        assert inside.min() >= ring.min() - eps and inside.max() <= ring.max() + eps, f"patch {p}"


# ---------------------------------------------------------------------------
# linear precision on a flat grid
# ---------------------------------------------------------------------------

from conftest import GRID_N as N, GRID_SAMPLES as SAMPLES, linear_field  # noqa: E402


# the curves must cover the grid's boundary (elsewhere the fill has natural boundary conditions) and be
# straight; with diagonal='right' the path from (14, 0) to the centre zig-zags, so corners_center is
# exact only on the alternating grid (see the report)
FLAT_CASES = [
    ("alternate", "corners", "delaunay"), ("alternate", "corners", "cycle"),
    ("alternate", "corners_center", "delaunay"), ("alternate", "nine", "delaunay"),
    ("right", "corners", "delaunay"), ("right", "corners", "cycle"), ("right", "nine", "delaunay"),
]


@pytest.mark.parametrize("curve_values", ["linear", "hermite"])
@pytest.mark.parametrize("diagonal, samples, partition", FLAT_CASES)
def test_linear_field_reproduced_on_a_flat_grid(diagonal, samples, partition, curve_values):
    V, F = shapes_grid(N, diagonal=diagonal)
    idx = np.array(SAMPLES[samples])
    r = reconstruct(V, F, idx, linear_field(V[idx]), distance="length", curve_values=curve_values,
                    weights="cotan", partition=partition)
    np.testing.assert_allclose(r.values, linear_field(V), rtol=0, atol=1e-10)


# ---------------------------------------------------------------------------
# reference: libigl
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("partition", PARTITIONS)
@pytest.mark.parametrize("curve_values", CURVE_VALUES)
@pytest.mark.parametrize("name, build", [("icosphere3", lambda: icosphere(3)), ("irregular", irregular),
                                         ("torus", torus)])
def test_agrees_with_igl_harmonic_on_the_fixed_curves(partition, curve_values, name, build):
    V, F = build()
    idx, rng = random_samples(V, 12, seed=5)
    vals = rng.uniform(-1.0, 1.0, size=idx.size)
    r = reconstruct(V, F, idx, vals, partition=partition, curve_values=curve_values, weights="cotan")
    b = np.flatnonzero(r.on_curve)
    assert np.isin(idx, b).all()
    igl = pytest.importorskip("igl")
    ref = igl.harmonic(V, np.asarray(F, np.int64), b.astype(np.int64), r.values[b][:, None].copy(), 1)
    np.testing.assert_allclose(r.values, ref[:, 0], rtol=0, atol=1e-8)


# ---------------------------------------------------------------------------
# several fields
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("method, curve_values", [("gvf-harmonic", "linear"), ("gvf-harmonic", "hermite"),
                                                  ("gvf-harmonic", "gvf"), ("harmonic", "linear"),
                                                  ("gvf", "linear")])
def test_columns_are_independent(method, curve_values):
    V, F = jittered_icosphere(2, seed=1)
    idx, rng = random_samples(V, 11, seed=6)
    vals = np.column_stack([rng.uniform(-1, 1, idx.size), on_levels(V, F, idx), np.full(idx.size, 3.0)])
    r = reconstruct(V, F, idx, vals, method=method, curve_values=curve_values)
    assert r.values.shape == (len(V), 3) and len(r.levels) == 3
    for j in range(3):
        rj = reconstruct(V, F, idx, vals[:, j], method=method, curve_values=curve_values)
        assert rj.values.shape == (len(V),)
        np.testing.assert_allclose(r.values[:, j], rj.values, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(r.levels[j], rj.levels[0])
        assert r.report["check"][j] == rj.report["check"][0]


# ---------------------------------------------------------------------------
# invariances
# ---------------------------------------------------------------------------

INVARIANT_MESHES = [("jittered_icosphere", lambda: jittered_icosphere(2)), ("irregular", irregular)]


@pytest.mark.parametrize("method, partition, curve_values", [
    ("gvf-harmonic", "delaunay", "linear"), ("gvf-harmonic", "delaunay", "hermite"),
    ("gvf-harmonic", "delaunay", "gvf"), ("gvf-harmonic", "tree", "linear"), ("gvf-harmonic", "tree", "hermite"),
    ("harmonic", "delaunay", "linear"), ("gvf", "delaunay", "linear"),
])
@pytest.mark.parametrize("name, build", INVARIANT_MESHES)
def test_invariant_under_vertex_relabelling(method, partition, curve_values, name, build):
    # distance='length' on meshes without equal edge lengths: no ties for the shortest paths to break
    V, F = build()
    idx, rng = random_samples(V, 10, seed=7)
    vals = rng.uniform(-1.0, 1.0, size=idx.size)
    V2, F2, inv = relabel(V, F, rng.permutation(len(V)), rng)
    kw = dict(method=method, partition=partition, curve_values=curve_values, distance="length")
    r1 = reconstruct(V, F, idx, vals, **kw)
    r2 = reconstruct(V2, F2, inv[idx], vals, **kw)
    np.testing.assert_allclose(r2.values[inv], r1.values, rtol=0, atol=1e-11)
    np.testing.assert_array_equal(r2.on_curve[inv], r1.on_curve)


@pytest.mark.parametrize("curve_values", ["linear", "hermite"])
@pytest.mark.parametrize("name, build", INVARIANT_MESHES)
def test_cycle_invariant_under_relabelling_that_keeps_the_sample_order(curve_values, name, build):
    # the cycle starts at the sample with the smallest vertex index, so only such relabellings keep it
    V, F = build()
    idx, rng = random_samples(V, 10, seed=8)
    vals = rng.uniform(-1.0, 1.0, size=idx.size)
    inv = rng.permutation(len(V))
    order = np.sort(idx)
    inv[order] = np.sort(inv[order])
    V2, F2, inv2 = relabel(V, F, np.argsort(inv), rng)
    np.testing.assert_array_equal(inv2, inv)
    kw = dict(partition="cycle", curve_values=curve_values, distance="length")
    r1 = reconstruct(V, F, idx, vals, **kw)
    r2 = reconstruct(V2, F2, inv[idx], vals, **kw)
    np.testing.assert_allclose(r2.values[inv], r1.values, rtol=0, atol=1e-11)


@pytest.mark.parametrize("distance", ["length", "hops"])
@pytest.mark.parametrize("curve_values", CURVE_VALUES)
@pytest.mark.parametrize("partition", PARTITIONS)
def test_invariant_under_scaling_and_translation(partition, curve_values, distance):
    V, F = jittered_icosphere(2, seed=2)
    idx, rng = random_samples(V, 10, seed=9)
    vals = rng.uniform(-1.0, 1.0, size=idx.size)
    kw = dict(partition=partition, curve_values=curve_values, distance=distance)
    r1 = reconstruct(V, F, idx, vals, **kw)
    r2 = reconstruct(3.7 * V + np.array([1.0, -20.0, 5.0]), F, idx, vals, **kw)
    np.testing.assert_allclose(r2.values, r1.values, rtol=0, atol=1e-10)
    np.testing.assert_array_equal(r2.on_curve, r1.on_curve)


# ---------------------------------------------------------------------------
# the paper's averaging iteration
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("partition", ["delaunay", "tree"])
@pytest.mark.parametrize("seed", [0, 1])
def test_iterate_converges_from_gvf_and_random_starts(partition, seed):
    V, F = icosphere(3)
    idx, _ = random_samples(V, 15, seed)
    vals = np.sin(2 * V[idx, 0]) + V[idx, 1] * V[idx, 2]
    direct = reconstruct(V, F, idx, vals, partition=partition, solver="direct")
    its = {}
    for init in ("gvf", "random"):
        r = reconstruct(V, F, idx, vals, partition=partition, solver="iterate", init=init, tol=1e-12, seed=seed)
        assert r.report["fill"]["solver"] == "iterate"
        its[init] = r.report["fill"]["iterations"]
        assert len(its[init]) == 1 and its[init][0] > 1
        np.testing.assert_allclose(r.values, direct.values, rtol=0, atol=1e-8)
    # GVF starts are not reliably faster (e.g. tree, seed 0: more sweeps than random): not asserted


# ---------------------------------------------------------------------------
# components without samples, broken gradual variation, options
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("solver", ["direct", "iterate"])
@pytest.mark.parametrize("method, partition", [("gvf-harmonic", "delaunay"), ("gvf-harmonic", "cycle"),
                                               ("gvf-harmonic", "tree"), ("harmonic", "delaunay"),
                                               ("gvf", "delaunay")])
def test_on_empty_nan(method, partition, solver):
    V, F = two_components()
    idx = np.array([0, 5, 10, 15])
    vals = V[idx, 0] + 2 * V[idx, 1]
    r = reconstruct(V, F, idx, vals, method=method, partition=partition, on_empty="nan", solver=solver)
    assert np.isnan(r.values[16:]).all()
    assert np.isfinite(r.values[:16]).all()
    np.testing.assert_allclose(r.values[idx], vals, rtol=0, atol=1e-12)
    if method != "gvf":
        assert r.report["fill"]["empty_components"][0]["vertices"] == 9


@pytest.mark.parametrize("method", ["gvf-harmonic", "harmonic"])
def test_on_empty_error(method):
    V, F = two_components()
    with pytest.raises(SolveError):
        reconstruct(V, F, [0, 5, 15], [0.0, 1.0, 2.0], method=method)


def test_on_empty_error_with_method_gvf():
    V, F = two_components()
    with pytest.raises(SolveError):
        reconstruct(V, F, [0, 5, 15], [0.0, 1.0, 2.0], method="gvf")


def test_broken_gradual_variation():
    # vertices 0 and 1 are adjacent; with 40 levels their values are 39 levels apart
    V, F = grid(6)
    idx = np.array([0, 1, 20, 35])
    vals = np.array([0.0, 1.0, 0.5, 0.2])
    with pytest.raises(SampleError, match="vertices"):
        reconstruct(V, F, idx, vals, levels=40, curve_values="gvf")
    with pytest.raises(SampleError):
        reconstruct(V, F, idx, vals, levels=40, method="gvf")
    for cv in ("linear", "hermite"):
        r = reconstruct(V, F, idx, vals, levels=40, curve_values=cv)
        check = r.report["check"][0]
        assert not check["holds"] and check["violations"] >= 1 and check["levels"] == 40
        np.testing.assert_array_equal(r.values[idx], vals)
    assert reconstruct(V, F, idx, vals, curve_values="gvf").report["check"][0]["holds"]


@pytest.mark.parametrize("option", ["method", "partition", "weights", "distance", "curve_values", "solver",
                                    "on_empty", "duplicates", "iteration", "init"])
def test_bad_options_raise(option):
    V, F = grid(4)
    with pytest.raises(OptionError):
        reconstruct(V, F, [0, 15], [0.0, 1.0], **{option: "bogus"})


def test_levels_as_an_array():
    V, F = grid(6)
    idx = np.array([0, 14, 35])
    r = reconstruct(V, F, idx, [0.0, 0.4, 1.0], levels=[0.0, 0.5, 1.0], curve_values="gvf")
    np.testing.assert_array_equal(r.levels[0], [0.0, 0.5, 1.0])
    with pytest.raises(SampleError):
        reconstruct(V, F, idx, [0.0, 0.4, 1.0], levels=[0.0, 1.0, 0.5])


def test_hermite_on_sparse_samples_stays_in_range_and_beats_linear():
    # 17 samples on a coarse sphere: neighbours far round the surface must not spoil the slopes
    V, F = icosphere(3)
    idx = np.arange(0, 642, 40)
    f = V[:, 0]
    herm = reconstruct(V, F, idx, f[idx])
    lin = reconstruct(V, F, idx, f[idx], curve_values="linear")
    assert herm.report["overshoot"] <= 1e-12
    assert np.abs(herm.values - f).max() <= np.abs(lin.values - f).max()


# ---------------------------------------------------------------------------
# reconstruct is the composition of the public steps
# ---------------------------------------------------------------------------


def compose(V, F, idx, vals, *, method=None, partition="delaunay", weights="cotan", distance="length",
            levels=None, curve_values=None, solver="auto", init="gvf", seed=0):
    """Steps 1-6 by hand, from the public functions only, in the order the paper's pipeline runs them.

    The default (no method given) is the pipeline with monotone curve values (unless given), projected onto
    the samples' range, and the harmonic fill bounded by it.
    """
    bounded = method is None
    if method is None:
        method, curve_values = "gvf-harmonic", curve_values or "monotone"
    curve_values = curve_values or "hermite"
    from manifill.surface.curve_values import values_on_curves
    from manifill.surface.fill import fill_patches, gvf_fill, start_values
    from manifill.surface.gradual import check_gradual
    from manifill.surface.partition import partition as draw
    from manifill.surface.surface import Surface
    from manifill.validate import as_samples

    s = Surface.from_mesh(V, F, distance=distance, allow_degenerate=weights in ("uniform", "robust"))
    idx, X, squeeze = as_samples(idx, vals, s.n)
    part = draw(s, idx, method=partition) if method == "gvf-harmonic" else None
    starts = part.steepest(idx, X) if part is not None else [None] * X.shape[1]
    checks = [check_gradual(s, idx, X[:, j], levels=levels, start=starts[j]) for j in range(X.shape[1])]
    if method == "gvf":
        out = gvf_fill(s, idx, X, checks)
    else:
        b, bc = values_on_curves(s, part, idx, X, method=curve_values, checks=checks) if part else (idx, X)
        lohi = (X.min(axis=0), X.max(axis=0)) if bounded and part else None
        bc = np.clip(bc, *lohi) if lohi else bc
        out, _ = fill_patches(s, b, bc, weights=weights, solver=solver,
                              x0=lambda: start_values(init, s, idx, X, checks=checks, seed=seed), bounds=lohi)
    return (out[:, 0] if squeeze else out), part, checks


COMPOSITIONS = [
    {},
    {"method": "gvf-harmonic"},
    {"method": "gvf-harmonic", "curve_values": "hermite", "partition": "cycle"},
    {"partition": "cycle"},
    {"partition": "tree", "curve_values": "linear"},
    {"curve_values": "gvf", "round": True},
    {"method": "harmonic", "weights": "uniform"},
    {"method": "gvf", "round": True},
    {"distance": "hops", "weights": "intrinsic"},
    {"solver": "iterate", "init": "random", "seed": 3},
    {"solver": "iterate", "init": "gvf"},
    {"solver": "amg", "levels": 9},
]


@pytest.mark.parametrize("columns", [1, 2])
@pytest.mark.parametrize("options", COMPOSITIONS, ids=lambda o: ",".join(f"{k}={v}" for k, v in o.items()) or "default")
def test_reconstruct_equals_the_public_steps_composed_by_hand(options, columns):
    options = dict(options)
    rounded = options.pop("round", False)
    V, F = jittered_icosphere(3, seed=2)
    idx = np.random.default_rng(7).choice(len(V), 40, replace=False)
    vals = np.column_stack([np.sin(2 * V[idx, 0]) + V[idx, 2], V[idx, 1] ** 2])[:, :columns]
    vals = np.round(vals * 4) / 4 if rounded else vals
    vals = vals[:, 0] if columns == 1 else vals
    r = reconstruct(V, F, idx, vals, **options)
    x, part, checks = compose(V, F, idx, vals, **options)
    assert r.values.shape == x.shape and r.values.tobytes() == x.tobytes()
    assert r.report["check"] == [c.summary() for c in checks]
    assert all(a.tobytes() == c.levels.tobytes() for a, c in zip(r.levels, checks))
    if part is not None:
        assert np.array_equal(r.on_curve, part.on_curve) and np.array_equal(r.components, part.labels)
        assert r.report["partition"] == part.report
    else:
        assert r.on_curve.sum() == len(idx) and not r.components.any()


def test_reconstruct_surface_keeps_the_field_axis_and_adds_its_timings():
    from manifill.surface.reconstruct import reconstruct_surface
    from manifill.surface.surface import Surface

    V, F = icosphere(2)
    idx = np.arange(0, len(V), 11)
    vals = V[idx, :1] + 1.0
    seconds = {"validate": 1.0, "graph": 2.0}
    r = reconstruct_surface(Surface.from_mesh(V, F), idx, vals, seconds=seconds, method="gvf-harmonic",
                            **PIPELINE_DEFAULT)
    assert r.values.shape == (len(V), 1) and r.report["seconds"] is seconds
    assert {"partition", "check", "curve_values", "harmonic"} <= set(seconds) and seconds["total"] > 3.0
    assert r.values[:, 0].tobytes() == reconstruct(V, F, idx, vals[:, 0]).values.tobytes()
    with pytest.raises(OptionError, match="curve_values"):
        reconstruct_surface(Surface.from_mesh(V, F), idx, vals, curve_values="cubic")


@pytest.mark.parametrize("method", sorted(STEPS))
def test_progress_names_exactly_the_steps_run(method):
    """A progress bar's total (the command line's) is the count of STEPS: the steps told must be those."""
    V, F = icosphere(2)
    idx = np.arange(0, len(V), 9)
    told = []
    reconstruct(V, F, idx, V[idx, 0], method=method, progress=told.append)
    assert tuple(told) == ("graph",) + STEPS[method]
