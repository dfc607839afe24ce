"""Reconstruction on point clouds: ``reconstruct(P, None, idx, vals)`` and everything a mesh gets."""

import pickle

import numpy as np
import pytest

import manifill
from manifill import Reconstructor, cross_validate, reconstruct
from manifill.errors import MeshError, OptionError, SampleError
from manifill.mesh.shapes import icosphere

V, F = icosphere(3)
IDX = np.random.default_rng(0).choice(len(V), 60, replace=False)


def field(P):
    return np.sin(3 * P[:, 0]) + P[:, 1] * P[:, 2]


def jittered_grid(n=20, jitter=0.3, seed=0):
    rng = np.random.default_rng(seed)
    h = 1.0 / (n - 1)
    P = np.mgrid[0:n, 0:n].reshape(2, -1).T * h + rng.uniform(-jitter * h, jitter * h, (n * n, 2))
    return np.column_stack([P, np.zeros(n * n)])


@pytest.mark.parametrize("method", ["harmonic", "biharmonic", "triharmonic", "rbf"])
def test_on_a_delaunay_mesh_s_vertices_the_cloud_gives_the_mesh_s_result(method):
    """The icosphere's vertices as a cloud: the fans are its triangles, so the energy methods give the mesh's
    values (the cotangent Laplacian and the Voronoi mass are the mesh's)."""
    a = reconstruct(V, F, IDX, field(V[IDX]), method=method)
    b = reconstruct(V, None, IDX, field(V[IDX]), method=method)
    assert np.abs(a.values - b.values).max() < 1e-9
    assert b.report["cloud"]["points"] == len(V) and b.report["cloud"]["components"] == 1


def test_the_gp_on_the_cloud_is_the_mesh_s_with_the_cloud_s_mass():
    """The gp's precision on the cloud: the same stiffness, the fans' (Voronoi) lumped mass where the mesh has
    the barycentric one: values and std close, errors alike."""
    kw = dict(method="gp", gp={"range": 0.8, "sigma": 1.0})
    a = reconstruct(V, F, IDX, field(V[IDX]), **kw)
    b = reconstruct(V, None, IDX, field(V[IDX]), **kw)
    assert np.abs(a.values - b.values).max() < 0.03 * np.ptp(a.values)
    assert np.abs(a.std - b.std).max() < 0.03 * a.std.max()
    err = [np.sqrt(np.mean((r.values - field(V)) ** 2)) for r in (a, b)]
    assert err[1] <= 1.2 * err[0]


@pytest.mark.parametrize("method", ["gvf-harmonic", None, "gvf"])
def test_the_pipeline_runs_on_the_cloud_s_graph(method):
    """The paper's pipeline on the cloud's graph (curves as graph paths), and the default (the projected
    biharmonic on the fans' operators, no curves): exact at the samples, within the samples' range for the
    default, and as accurate as on the mesh."""
    vals = field(V[IDX])
    b = reconstruct(V, None, IDX, vals, method=method)
    a = reconstruct(V, F, IDX, vals, method=method)
    assert np.allclose(b.values[IDX], vals)
    assert np.all(np.isfinite(b.values)) and (len(b.curves) > 0) == (method == "gvf-harmonic")
    if method is None:
        assert vals.min() - 1e-12 <= b.values.min() and b.values.max() <= vals.max() + 1e-12
    err = [np.sqrt(np.mean((r.values - field(V)) ** 2)) for r in (a, b)]
    assert err[1] <= 1.2 * err[0]


def test_maximum_principle_and_linear_precision_on_a_flat_cloud():
    """Harmonic on a jittered flat cloud: a linear field sampled on the boundary comes back exactly inside,
    and any data stays within the samples' range."""
    P = jittered_grid(18)
    edge = np.flatnonzero((P[:, :2].min(axis=1) < 0.03) | (P[:, :2].max(axis=1) > 0.97))
    lin = 2 * P[:, 0] - P[:, 1] + 0.5
    r = reconstruct(P, None, edge, lin[edge], method="harmonic")
    inside = np.setdiff1d(np.arange(len(P)), edge)
    far = inside[(P[inside, :2].min(axis=1) > 0.2) & (P[inside, :2].max(axis=1) < 0.8)]
    assert np.abs(r.values[far] - lin[far]).max() < 1e-9
    rough = np.random.default_rng(1).normal(size=edge.size)
    x = reconstruct(P, None, edge, rough, method="harmonic").values
    assert rough.min() - 1e-12 <= x.min() and x.max() <= rough.max() + 1e-12
    g = r.gradient()
    assert np.abs(g[far] - [2, -1, 0]).max() < 1e-8


def test_positions_are_snapped_to_the_nearest_point():
    pos = V[IDX] * 1.02
    r = reconstruct(V, None, pos, field(V[IDX]), method="biharmonic")
    assert np.allclose(r.values[IDX], field(V[IDX]))
    assert r.report["points"]["at_vertices"] == len(IDX)
    with pytest.raises(SampleError, match="far"):
        reconstruct(V, None, V[IDX[:3]] * 3.0, [1.0, 2.0, 3.0])
    assert r.at(V[IDX[:4]] * 1.001) == pytest.approx(r.values[IDX[:4]])


def test_reconstructor_matrix_pickle_and_cross_validation():
    vals = field(V[IDX])
    rec = Reconstructor(V, None, IDX, method="harmonic")
    W = rec.matrix()
    assert np.allclose(W @ vals, rec.apply(vals).values)
    back = pickle.loads(pickle.dumps(rec))
    assert np.array_equal(back.apply(vals).values, rec.apply(vals).values)
    a = cross_validate(V, F, IDX, vals, methods=["harmonic", "biharmonic"], folds=5)
    b = cross_validate(V, None, IDX, vals, methods=["harmonic", "biharmonic"], folds=5)
    assert a.errors == pytest.approx(b.errors, rel=1e-8)


def test_gp_on_a_cloud_is_exact_at_the_samples_and_draws():
    vals = field(V[IDX])
    r = reconstruct(V, None, IDX, vals, method="gp")
    assert np.allclose(r.values[IDX], vals) and np.allclose(r.std[IDX], 0.0, atol=1e-8)
    assert r.std.max() > 0.01
    D = r.sample(3)
    assert D.shape == (len(V), 3) and np.allclose(D[IDX], vals[:, None])


def test_smoothing_bounds_uncertainty_and_robust_weights():
    vals = field(V[IDX]) + np.random.default_rng(2).normal(0, 0.05, len(IDX))
    s = reconstruct(V, None, IDX, vals, method="biharmonic", smoothing="auto")
    assert s.report["fill"]["smoothing"]["lambda"] > 0
    b = reconstruct(V, None, IDX, vals, method="biharmonic", bounds="samples")
    assert vals.min() - 1e-9 <= b.values.min() and b.values.max() <= vals.max() + 1e-9
    u = reconstruct(V, None, IDX, vals, method="harmonic", uncertainty=True)
    assert np.allclose(u.std[IDX], 0.0, atol=1e-9) and u.std.max() > 0
    pytest.importorskip("robust_laplacian")
    r = reconstruct(V, None, IDX, field(V[IDX]), method="biharmonic", weights="robust")
    exact = reconstruct(V, F, IDX, field(V[IDX]), method="biharmonic")
    err = [np.sqrt(np.mean((x.values - field(V)) ** 2)) for x in (exact, r)]
    assert err[1] < 1.5 * err[0]


def test_bad_clouds_and_options_are_refused_in_one_line():
    with pytest.raises(MeshError, match="coincide"):
        reconstruct(np.vstack([V, V[:1]]), None, IDX, field(V[IDX]))
    with pytest.raises(OptionError, match="neighbours"):
        reconstruct(V, None, IDX, field(V[IDX]), neighbours=2)
    r = reconstruct(V, None, IDX, field(V[IDX]), method="harmonic", neighbours=24)
    assert r.report["cloud"]["neighbours"] == 24
    with pytest.raises(OptionError, match="no cells"):
        r.gradient(at="cells")


def test_two_separate_clouds_are_two_pieces():
    P = np.vstack([V, V + [5.0, 0, 0]])
    with pytest.raises(manifill.errors.SolveError):
        reconstruct(P, None, IDX, field(V[IDX]), method="harmonic")
    r = reconstruct(P, None, IDX, field(V[IDX]), method="harmonic", on_empty="nan")
    assert np.isnan(r.values[len(V):]).all() and np.isfinite(r.values[:len(V)]).all()
    assert r.report["cloud"]["components"] == 2


def test_a_cloud_result_goes_out_as_points(tmp_path):
    r = reconstruct(V, None, IDX, field(V[IDX]), method="biharmonic")
    m = r.to_meshio(["t"])
    assert [c.type for c in m.cells] == ["vertex"] and np.allclose(m.point_data["t"], r.values)
    pytest.importorskip("pyvista")
    p = r.to_pyvista(["t"])
    assert p.n_points == len(V) and p.n_cells == len(V) and np.allclose(p.point_data["t"], r.values)
    r.save(tmp_path / "r.vtp", names=["t"])
    back = manifill.read_mesh_file(tmp_path / "r.vtp", points=True)
    assert back.F is None and np.allclose(back.point_data["t"], r.values)
