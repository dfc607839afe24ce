"""Samples anywhere on the surface: reconstruct(V, F, positions, vals) (manifill.surface.points)."""

import numpy as np
import pytest

from conftest import grid, icosphere
from manifill.errors import OptionError, SampleError
from manifill.surface.points import is_positions, point_samples
from manifill.surface.reconstruct import reconstruct

ENERGY = ["harmonic", "biharmonic", "triharmonic"]


def sphere_points(k=40, seed=0, lift=1.002):
    """Random points just off the unit icosphere (3), with a smooth two-field value."""
    V, F = icosphere(3)
    P = np.random.default_rng(seed).normal(size=(k, 3))
    P *= lift / np.linalg.norm(P, axis=1)[:, None]
    vals = np.column_stack([P[:, 0] + P[:, 1] * P[:, 2], np.cos(2 * P[:, 2])])
    return V, F, P, vals


def flat_case(seed=1, inner=25):
    """A flat grid; its boundary vertices (as positions) and random points inside faces."""
    V, F = grid(9)
    bd = np.flatnonzero((V[:, 0] % 1 == 0) | (V[:, 1] % 1 == 0))
    P = np.vstack([V[bd], np.column_stack([0.05 + 0.9 * np.random.default_rng(seed).random((inner, 2)),
                                           np.zeros(inner)])])
    return V, F, P


def linear(P):
    return 0.5 + 2.0 * P[:, 0] - 3.0 * P[:, 1]


def test_flat_harmonic_with_points_inside_faces_reproduces_a_linear_field():
    V, F, P = flat_case()
    r = reconstruct(V, F, P, linear(P), method="harmonic")
    assert np.abs(r.values - linear(V)).max() <= 1e-10
    pts = r.report["points"]
    assert pts["located"] == "closest surface point" and pts["inside_faces"] == 25
    assert pts["at_vertices"] == len(P) - 25 and pts["max_distance"] < 1e-15
    # (k, 2) positions on the flat mesh, the same
    r2 = reconstruct(V, F, P[:, :2], linear(P), method="harmonic")
    assert np.abs(r2.values - r.values).max() <= 1e-12


def test_linear_precision_has_teeth():
    """Snapping the points to their nearest vertices instead breaks the linear field."""
    V, F, P = flat_case()
    r = reconstruct(V, F, V[r_idx(V, F, P)], linear(P), method="harmonic", duplicates="mean")
    assert np.abs(r.values - linear(V)).max() > 1e-3


def r_idx(V, F, P):
    return point_samples(V, F, P, np.zeros(len(P)), nearest_only=True).located.nearest_vertex


@pytest.mark.parametrize("method", ENERGY)
@pytest.mark.parametrize("bounds", [None, "samples"])
def test_exact_at_the_points(method, bounds):
    V, F, P, vals = sphere_points()
    r = reconstruct(V, F, P, vals, method=method, bounds=bounds)
    err = np.abs(r.points.interpolate(r.values) - vals).max()
    assert err <= 1e-10 * np.ptp(vals)
    assert r.report["points"]["inside_faces"] == len(P) and r.report["fill"]["solver"] == "direct"
    assert 0.002 <= r.report["points"]["max_distance"] == r.points.distance.max() <= 0.01
    if bounds:
        assert r.report["overshoot"] <= 1e-12 * np.ptp(vals)
        assert r.report["fill"]["bounds"]


@pytest.mark.parametrize("method", ["gvf-harmonic", "gvf"])
def test_partition_methods_use_the_nearest_vertex(method):
    V, F, P, vals = sphere_points(20, seed=3)
    r = reconstruct(V, F, P, vals[:, 0], method=method)
    nv = r.points.nearest_vertex
    assert np.unique(nv).size == len(P)
    assert np.allclose(r.values[nv], vals[:, 0], rtol=0, atol=1e-12)
    assert r.report["points"]["located"] == "nearest vertex"
    d = np.linalg.norm(P - V[nv], axis=1)
    assert r.report["points"]["max_distance"] == pytest.approx(d.max(), rel=1e-12)
    assert np.array_equal(np.flatnonzero(r.sample_mask), np.sort(nv))


@pytest.mark.parametrize("method", ENERGY + ["gvf-harmonic", "gvf"])
def test_points_at_vertices_equal_vertex_indices(method):
    V, F = icosphere(2)
    idx = np.array([3, 17, 40, 77, 101, 150, 160])
    vals = np.sin(3 * V[idx, 0]) + V[idx, 2]
    a = reconstruct(V, F, idx, vals, method=method)
    b = reconstruct(V, F, V[idx].copy(), vals, method=method)
    assert np.abs(a.values - b.values).max() <= 1e-12
    assert np.array_equal(a.sample_mask, b.sample_mask)
    if method in ENERGY:
        assert b.report["points"]["inside_faces"] == 0 and b.report["points"]["at_vertices"] == idx.size


def test_mixed_points_in_one_face():
    V, F = icosphere(2)
    f = 11
    T = V[F[f]]
    b = np.array([[0.6, 0.3, 0.1], [0.2, 0.5, 0.3], [0.1, 0.2, 0.7]])
    P = np.vstack([b @ T, V[[0, 50, 100]]])
    vals = np.array([1.0, -2.0, 0.5, 0.0, 3.0, 1.0])
    for method in ENERGY:
        r = reconstruct(V, F, P, vals, method=method)
        assert np.abs(r.points.interpolate(r.values) - vals).max() <= 1e-10
        # three independent rows on one face: its corners are determined
        assert np.allclose(b @ r.values[F[f]], vals[:3], atol=1e-10)
    # a point on an edge, and points on both sides of it in the two faces
    e = 0.5 * (V[F[f, 0]] + V[F[f, 1]])
    other = np.flatnonzero((np.isin(F, F[f, :2]).sum(axis=1) == 2) & (np.arange(len(F)) != f))[0]
    P = np.vstack([e, V[F[f]].mean(axis=0), V[F[other]].mean(axis=0), V[[0, 100]]])
    r = reconstruct(V, F, P, [1.0, 2.0, 3.0, 0.0, 0.0], method="biharmonic")
    assert np.abs(r.points.interpolate(r.values) - [1.0, 2.0, 3.0, 0.0, 0.0]).max() <= 1e-10


def test_dependent_rows_are_refused_clearly():
    V, F = icosphere(2)
    T = V[F[7]]
    four = np.array([[0.6, 0.3, 0.1], [0.2, 0.5, 0.3], [0.1, 0.2, 0.7], [0.3, 0.3, 0.4]]) @ T
    with pytest.raises(SampleError, match="not independent"):
        reconstruct(V, F, np.vstack([four, V[[0]]]), [1.0, 2.0, 3.0, 4.0, 0.0], method="harmonic")
    on_edge = np.array([[0.2, 0.8, 0], [0.5, 0.5, 0], [0.7, 0.3, 0]]) @ T
    with pytest.raises(SampleError, match="not independent"):
        reconstruct(V, F, np.vstack([on_edge, V[[0]]]), [1.0, 2.0, 3.0, 0.0], method="biharmonic")
    # a point on an edge between two vertex samples: its value is already fixed
    with pytest.raises(SampleError, match="vertices are all samples"):
        reconstruct(V, F, np.vstack([T[:2], on_edge[1]]), [1.0, 2.0, 1.5], method="harmonic")


def test_duplicate_points():
    V, F, P, vals = sphere_points(10, seed=5)
    P2, v2 = np.vstack([P, P[3]]), np.concatenate([vals[:, 0], [vals[3, 0]]])
    r = reconstruct(V, F, P2, v2, method="harmonic")  # equal values merge silently
    assert r.report["points"]["inside_faces"] == 10
    v2[-1] += 1.0
    with pytest.raises(SampleError, match="duplicates='mean'"):
        reconstruct(V, F, P2, v2, method="harmonic")
    r = reconstruct(V, F, P2, v2, method="harmonic", duplicates="mean")
    assert r.points.interpolate(r.values)[3] == pytest.approx(vals[3, 0] + 0.5, abs=1e-10)


def test_solvers_with_points_inside_faces():
    V, F, P, vals = sphere_points(15)
    a = reconstruct(V, F, P, vals, method="biharmonic", solver="direct")
    b = reconstruct(V, F, P, vals, method="biharmonic")
    assert np.array_equal(a.values, b.values) and b.report["fill"]["solver"] == "direct"
    for method in ("harmonic", "biharmonic"):
        # AMG on the rows eliminated: the same minimiser, the rows held exactly
        d = reconstruct(V, F, P, vals, method=method, solver="direct")
        g = reconstruct(V, F, P, vals, method=method, solver="amg")
        assert g.report["fill"]["solver"] == "amg" and g.report["fill"]["eliminated"]
        assert np.abs(g.values - d.values).max() <= 1e-7 * np.ptp(vals)
        assert np.abs(g.points.interpolate(g.values) - vals).max() <= 1e-12 * np.ptp(vals)
    with pytest.raises(OptionError, match="solver='iterate' cannot"):
        reconstruct(V, F, P, vals, method="harmonic", solver="iterate")
    with pytest.raises(OptionError, match="pass solver='direct'"):
        reconstruct(V, F, P, vals, method="biharmonic", solver="amg", bounds="samples")
    # points at vertices only: every solver, as for vertex indices
    idx = np.array([0, 30, 99, 400, 600])
    r = reconstruct(V, F, V[idx], vals[:5], method="harmonic", solver="iterate")
    assert np.allclose(r.values[idx], vals[:5], atol=1e-8)


def test_amg_with_points_and_a_component_without_samples():
    V, F = icosphere(2)
    V2, F2 = np.vstack([V, V + [3.0, 0, 0]]), np.vstack([F, F + len(V)])
    P = np.vstack([V[F[[4, 90, 200]]].mean(axis=1), V[[7]]])
    vals = np.array([1.0, 2.0, -1.0, 0.5])
    for solver in ("direct", "amg"):
        with pytest.raises(Exception, match="no fixed vertex|has no sample"):
            reconstruct(V2, F2, P, vals, method="harmonic", solver=solver)
        r = reconstruct(V2, F2, P, vals, method="harmonic", solver=solver, on_empty="nan")
        assert np.isnan(r.values[len(V):]).all() and np.isfinite(r.values[:len(V)]).all()
        assert np.abs(r.points.interpolate(r.values) - vals).max() <= 1e-10


def test_far_points_refused_and_max_distance():
    V, F, P, vals = sphere_points(5)
    far = np.vstack([P, [0.0, 0.0, 50.0]])
    with pytest.raises(SampleError, match=r"row 5: 49 from the surface.*wrong units\?"):
        reconstruct(V, F, far, vals[:, 0].tolist() + [1.0], method="harmonic")
    with pytest.raises(SampleError, match="from the nearest vertex|from the surface"):
        reconstruct(V, F, far, vals[:, 0].tolist() + [1.0], method="gvf-harmonic")
    r = reconstruct(V, F, far, vals[:, 0].tolist() + [1.0], method="harmonic", max_distance=60.0)
    assert r.report["points"]["max_distance"] == pytest.approx(49.0, rel=1e-9)
    with pytest.raises(OptionError, match="max_distance applies to samples given as positions"):
        reconstruct(V, F, [0, 5], [1.0, 2.0], max_distance=1.0)


@pytest.mark.parametrize("scale", [1e-150, 1e150])
def test_scale_invariance(scale):
    V, F, P, vals = sphere_points(12, seed=7)
    ref = reconstruct(V, F, P, vals, method="biharmonic")
    got = reconstruct(V * scale, F, P * scale, vals, method="biharmonic")
    assert np.abs(got.values - ref.values).max() <= 1e-9 * np.ptp(vals)
    assert got.report["points"]["max_distance"] == pytest.approx(ref.report["points"]["max_distance"] * scale,
                                                                 rel=1e-9)


@pytest.mark.parametrize("method", ["harmonic", "biharmonic"])
def test_smoothing_with_points_interpolates_as_lambda_goes_to_zero(method):
    V, F, P, vals = sphere_points(30, seed=2)
    exact = reconstruct(V, F, P, vals, method=method)
    res = []
    for lam in (1e-4, 1e-6, 1e-8):
        r = reconstruct(V, F, P, vals, method=method, smoothing=lam)
        res.append(np.abs(r.points.interpolate(r.values) - vals).max())
    assert res[0] > 1e-6 * np.ptp(vals)  # smoothing does smooth
    assert res[2] <= 2e-4 * res[0] and res[2] <= 1e-6 * np.ptp(vals)  # ~ linear in lambda
    assert np.abs(r.values - exact.values).max() <= 1e-5 * np.ptp(vals)
    # per-point weights: one per input row
    w = np.ones(len(P))
    r1 = reconstruct(V, F, P, vals, method=method, smoothing=1e-4, sample_weights=w)
    assert np.allclose(r1.values, reconstruct(V, F, P, vals, method=method, smoothing=1e-4).values, atol=1e-12)
    with pytest.raises(SampleError, match="one weight per point"):
        reconstruct(V, F, P, vals, method=method, smoothing=1e-4, sample_weights=w[:-1])


def test_all_points_inside_faces_and_one_field():
    V, F, P, vals = sphere_points(8, seed=9)
    r = reconstruct(V, F, P, vals[:, 0], method="harmonic")
    assert r.values.shape == (len(V),) and r.report["points"]["at_vertices"] == 0
    assert np.abs(r.points.interpolate(r.values) - vals[:, 0]).max() <= 1e-10
    assert r.sample_mask.sum() == np.unique(r.points.nearest_vertex).size


def test_is_positions():
    assert is_positions(np.zeros((3, 3))) and is_positions([[0.5, 0.5]])
    assert not is_positions([1, 2, 3]) and not is_positions(np.zeros((3, 3), dtype=int))
    assert not is_positions(np.zeros((3, 4)))
