"""The point cloud's operators: the local Delaunay fans' Laplacian and mass, normals, graph and gradients."""

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import Delaunay

from manifill.errors import MeshError
from manifill.mesh.laplacian import laplacian, mass_matrix
from manifill.mesh.pointcloud import Cloud
from manifill.mesh.shapes import icosphere
from manifill.validate import as_points


def jittered_grid(n=24, jitter=0.15, seed=0):
    """A flat (n x n) grid of the unit square, each point moved by up to ``jitter`` of the spacing."""
    rng = np.random.default_rng(seed)
    h = 1.0 / (n - 1)
    P = np.mgrid[0:n, 0:n].reshape(2, -1).T * h
    P = P + rng.uniform(-jitter * h, jitter * h, P.shape)
    return np.column_stack([P, np.zeros(len(P))])


def interior(P, margin=0.12):
    return np.flatnonzero((P[:, :2].min(axis=1) > margin) & (P[:, :2].max(axis=1) < 1 - margin))


def test_on_a_delaunay_mesh_s_vertices_the_fans_are_its_triangles():
    """Sampled at an icosphere's vertices (a Delaunay mesh), the cloud's Laplacian and mass are the mesh's own."""
    V, F = icosphere(3)
    c = Cloud(V)
    assert abs(c.L - laplacian(V, F)).max() < 1e-12
    assert np.abs(c.M - mass_matrix(V, F, mass="voronoi").diagonal()).max() < 1e-14
    edges = {tuple(e) for e in np.sort(np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1).tolist()}
    assert {tuple(e) for e in c.E.tolist()} == edges
    assert c.components == 1


def test_flat_fans_are_the_delaunay_triangulation():
    """On a flat jittered grid every interior point's fan is its Delaunay 1-ring."""
    P = jittered_grid(16, 0.3, seed=3)
    c = Cloud(P)
    indptr, ind = Delaunay(P[:, :2]).vertex_neighbor_vertices
    for i in interior(P, 0.2):
        nbrs = set(c.E[c.E[:, 0] == i, 1].tolist()) | set(c.E[c.E[:, 1] == i, 0].tolist())
        assert nbrs == set(ind[indptr[i]:indptr[i + 1]].tolist()), i


@pytest.mark.parametrize("seed", range(4))
def test_linear_precision_symmetry_and_sign(seed):
    """Linear functions are harmonic at interior points; L is symmetric with zero row sums and no positive
    off-diagonal entry (a maximum principle); the mass is the Delaunay triangulation's Voronoi area."""
    P = jittered_grid(20, 0.3, seed=seed)
    c = Cloud(P)
    L = c.L
    inside = interior(P)
    for x in (P[:, 0], P[:, 1], 2 * P[:, 0] - 3 * P[:, 1] + 1):
        assert np.abs((L @ x)[inside]).max() < 1e-11
    assert abs(L - L.T).max() < 1e-14
    assert np.abs(L @ np.ones(len(P))).max() < 1e-12
    off = sp.coo_array(L - sp.diags_array(L.diagonal()))
    assert off.data.max() <= 0.0
    # away from the boundary the mass is the Delaunay triangulation's mixed Voronoi area
    F = Delaunay(P[:, :2]).simplices
    M = mass_matrix(P, F, mass="voronoi").diagonal()
    assert np.abs(c.M - M)[inside].max() < 1e-14
    assert c.M.sum() == pytest.approx(1.0, abs=0.03)  # the square, less slivers of its jittered edge


@pytest.mark.parametrize("n", [6, 11, 30])
def test_a_regular_grid_s_cocircular_squares_keep_linear_precision(n):
    """Four points on a circle (every square of a regular grid) and collinear neighbours on each ray: whatever
    diagonal round-off picks, linear functions stay harmonic and the mass is the square's."""
    P = jittered_grid(n, 0.0)
    c = Cloud(P @ np.array([[0.6, 0.8, 0.0], [-0.8, 0.6, 0.0], [0.0, 0.0, 1.0]]))  # turned: round-off everywhere
    inside = interior(P, 0.01)
    assert np.abs((c.L @ P[:, 0])[inside]).max() < 1e-12
    assert c.M.sum() == pytest.approx(1.0, rel=1e-12)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10**6), scale=st.sampled_from([1e-6, 1e-3, 1.0, 37.0, 1e5]),
       shift=st.floats(-1e3, 1e3))
def test_invariant_under_rotation_translation_scaling_and_relabelling(seed, scale, shift):
    rng = np.random.default_rng(seed)
    P = jittered_grid(10, 0.3, seed=seed)
    P[:, 2] = 0.1 * np.sin(3 * P[:, 0]) * np.cos(2 * P[:, 1])  # a curved sheet
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    perm = rng.permutation(len(P))
    a, b = Cloud(P), Cloud(((P @ Q.T + shift) * scale)[perm])  # a shift of up to 1000 sizes
    inv = np.argsort(perm)
    Lb = b.L[inv][:, inv]
    assert abs(a.L - Lb).max() < 1e-8 * abs(a.L).max()
    assert np.allclose(a.M * scale ** 2, b.M[inv], rtol=1e-8)
    # normals turn with the points (each piece's orientation is a choice; within a piece they agree)
    turned = b.normals[inv] @ Q
    dots = np.einsum("ij,ij->i", a.normals, turned)
    assert np.allclose(np.abs(dots), 1.0, atol=1e-6)
    assert np.all(dots > 0) or np.all(dots < 0)


def test_normals_point_outward_on_a_closed_surface():
    V, _ = icosphere(3)
    c = Cloud(V * [1.0, 2.0, 0.5])
    assert np.all(np.einsum("ij,ij->i", c.normals, V * [1.0, 0.5, 2.0]) > 0)  # the ellipsoid's outward normal


def test_gradient_exact_for_linear_fields_and_tangent_on_a_sphere():
    P = jittered_grid(14, 0.3, seed=1)
    c = Cloud(P * 1e-3)
    G = c.gradient_operator()
    g = (G @ (2 * P[:, 0] * 1e-3 - 5 * P[:, 1] * 1e-3 + 7)).reshape(-1, 3)
    assert np.abs(g - [2, -5, 0]).max() < 1e-9
    V, _ = icosphere(4)
    cs = Cloud(V)
    gs = (cs.gradient_operator() @ V[:, 2]).reshape(-1, 3)
    assert np.abs(np.einsum("ij,ij->i", gs, cs.normals)).max() < 1e-12
    truth = np.array([0.0, 0.0, 1.0]) - V[:, 2:] * V  # the tangent part of grad z
    assert np.sqrt(np.mean(np.sum((gs - truth) ** 2, axis=1))) < 0.01


def test_bad_clouds_are_refused_in_one_line():
    V, _ = icosphere(1)
    with pytest.raises(MeshError, match="coincide.*merge them"):
        as_points(np.vstack([V, V[:1]]))
    with pytest.raises(MeshError, match="at least 7"):
        as_points(V[:5])
    bad = V.copy()
    bad[3, 1] = np.nan
    with pytest.raises(MeshError, match="NaN"):
        as_points(bad)


def test_a_boundary_point_s_open_fan_ends_at_its_extreme_neighbours():
    """The corner of a square grid joins its two edge neighbours (and the diagonal, of zero weight, is not
    a fan edge): collinear neighbours on one ray keep only the nearest."""
    P = jittered_grid(6, 0.0)
    c = Cloud(P)
    row = c.L[[0]].toarray().ravel()
    assert set(np.flatnonzero(row).tolist()) == {0, 1, 6}
    assert row[1] == pytest.approx(-0.5) and row[6] == pytest.approx(-0.5)
    assert c.M[0] == pytest.approx(0.2 ** 2 / 4)


def test_points_in_no_fan_are_joined_and_have_mass():
    """A wire leaving a flat scan (points on a line have no fan): each joined to its two nearest neighbours, the
    median mass, so the cloud stays one piece and every method runs."""
    P = jittered_grid(12, 0.0)
    tail = np.column_stack([1 + 0.09 * np.arange(1, 31), np.full(30, 0.5), np.zeros(30)])
    c = Cloud(np.vstack([P, tail]))
    assert np.all(c.M > 0) and c.components == 1
    wire = np.arange(len(P), len(P) + 30)
    assert np.all(c.L.diagonal()[wire] > 0) and np.abs(c.L @ np.ones(len(c.M))).max() < 1e-12
