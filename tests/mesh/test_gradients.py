"""Gradients of reconstructed fields (manifill.mesh.gradients, ``Result.gradient``).

Exact for linear fields (per triangle, per tetrahedron, per vertex on flat meshes and inside solids, on voxel
grids); per triangle the same as libigl's ``grad``; per vertex on the sphere the tangent gradient, with an error
that falls with the edge length; invariant under relabelling and scaled by ``1 / c`` when the mesh is.
"""

import numpy as np
import pytest

import manifill
from conftest import icosphere, irregular
from manifill.errors import OptionError
from manifill.mesh.gradients import (cell_gradients, gradient_operator, grid_gradients, tet_gradient_operator,
                                     vertex_gradients)
from manifill.surface.curve_values import vertex_normals
from solid.solids import needs_tetgen, tet_ball

A = np.array([0.7, -1.3, 0.4])


def _linear(P):
    return 2.0 + P @ A


def test_linear_fields_on_a_flat_irregular_mesh_are_exact_per_face_and_vertex():
    V, F = irregular()  # in the plane z = 0
    X = np.column_stack([_linear(V), 3.0 * V[:, 0]])
    G, area = gradient_operator(V, F)
    g = cell_gradients(G, X)
    want = np.array([[A[0], A[1], 0.0], [3.0, 0.0, 0.0]])
    assert g.shape == (len(F), 2, 3) and np.abs(g - want).max() < 1e-10
    gv = vertex_gradients(F, area, g, len(V), normals=np.tile([0.0, 0.0, 1.0], (len(V), 1)))
    assert np.abs(gv - want).max() < 1e-10
    assert cell_gradients(G, X[:, 0]).shape == (len(F), 3)


def test_per_face_gradient_is_libigls():
    igl = pytest.importorskip("igl")
    V, F = icosphere(3)
    V = V * (1 + 0.2 * np.random.default_rng(0).random((len(V), 1)))
    x = np.sin(3 * V[:, 0]) + V[:, 1] * V[:, 2]
    G, _ = gradient_operator(V, F)
    ours = cell_gradients(G, x)
    theirs = np.asarray(igl.grad(V, F) @ x).reshape(3, len(F)).T  # igl stacks x, then y, then z components
    assert np.abs(ours - theirs).max() < 1e-10 * np.abs(theirs).max()


@pytest.mark.parametrize("field", ["z", "xy"])
def test_vertex_gradient_on_the_sphere_converges_under_refinement(field):
    errors = []
    for level in (2, 3, 4, 5):
        V, F = icosphere(level)
        n = V / np.linalg.norm(V, axis=1, keepdims=True)
        if field == "z":
            x, ambient = V[:, 2], np.tile([0.0, 0.0, 1.0], (len(V), 1))
        else:
            x, ambient = V[:, 0] * V[:, 1], np.column_stack([V[:, 1], V[:, 0], np.zeros(len(V))])
        want = ambient - np.sum(ambient * n, axis=1, keepdims=True) * n  # the tangent gradient
        G, area = gradient_operator(V, F)
        gv = vertex_gradients(F, area, cell_gradients(G, x), len(V), normals=vertex_normals(V, F))
        assert np.abs(np.sum(gv * n, axis=1)).max() < 0.05  # tangent to the surface (to the vertex normal's plane)
        errors.append(np.abs(gv - want).max())
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))  # the edge length halves per level
    assert np.all(rates > 0.9), (errors, rates)


def test_relabelling_permutes_and_scaling_divides():
    V, F = icosphere(2)
    x = np.cos(2 * V[:, 0]) + V[:, 2]
    perm = np.random.default_rng(1).permutation(len(V))
    inv = np.argsort(perm)
    r = manifill.reconstruct(V, F, np.arange(len(V)), x, method="harmonic")
    rp = manifill.reconstruct(V[perm], inv[F], np.arange(len(V)), x[perm], method="harmonic")
    assert np.abs(rp.gradient()[inv] - r.gradient()).max() < 1e-12
    for c in (1e-6, 1e3, 1e9):  # the mesh in other units
        rs = manifill.reconstruct(V * c, F, np.arange(len(V)), x, method="harmonic")
        assert np.abs(rs.gradient() * c - r.gradient()).max() < 1e-9 * np.abs(r.gradient()).max()
        assert np.abs(rs.gradient("cells") * c - r.gradient("cells")).max() < 1e-9


def test_a_reconstruction_gives_its_gradient_and_the_gps_std_from_draws():
    V, F = icosphere(3)
    idx = np.sort(np.random.default_rng(2).choice(len(V), 200, replace=False))
    y = np.column_stack([V[idx, 2], V[idx, 0]])
    r = manifill.reconstruct(V, F, idx, y, method="gp", gp={"range": 1.0, "sigma": 1.0})
    g, s = r.gradient(return_std=True, draws=40)
    assert g.shape == (len(V), 2, 3) and s.shape == g.shape and np.all(s >= 0) and np.isfinite(s).all()
    # on a triangle whose corners are all observed exactly the gradient is known: no spread; elsewhere some
    gc, sc = r.gradient("cells", return_std=True, draws=40)
    known = np.isin(F, idx).all(axis=1)
    assert known.any() and (~known).any()
    assert np.abs(sc[known]).max() < 1e-9 * sc.max() and np.all(sc[~known].max(axis=(1, 2)) > 1e-6 * sc.max())
    # the draws scatter about the mean's gradient: their mean within 5 standard errors nearly everywhere
    D = r.sample(400, seed=1)
    Gd = np.stack([r._gradient(D[:, :, k], "cells") for k in range(400)])
    off = np.abs(Gd.mean(axis=0) - gc) > 5 * Gd.std(axis=0, ddof=1) / np.sqrt(400) + 1e-12
    assert off.mean() < 0.01
    with pytest.raises(OptionError, match="no fitted probability model"):
        manifill.reconstruct(V, F, idx, y, method="harmonic").gradient(return_std=True)
    with pytest.raises(OptionError, match="'vertices' or 'cells'"):
        r.gradient("faces")


def test_linear_fields_in_tets_and_voxels_are_exact():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1], [1, 1, 0]])
    T = np.array([[0, 1, 2, 3], [1, 2, 3, 4], [1, 5, 2, 4]])
    G, vol = tet_gradient_operator(V, T)
    g = cell_gradients(G, _linear(V))
    assert np.abs(g - A).max() < 1e-12 and np.all(vol > 0)
    assert np.abs(vertex_gradients(T, vol, g, len(V)) - A).max() < 1e-12
    mask = np.zeros((7, 7, 8), dtype=bool)
    mask[1:6, 1:6, 1:7] = True
    mask[3, 3, 4] = False  # a hole: one-sided differences around it
    h = np.array([0.5, 1.0, 2.0])
    P = np.moveaxis(np.indices(mask.shape), 0, -1) * h
    gg = grid_gradients(np.where(mask, _linear(P), np.nan), mask, h)
    assert np.abs(gg[mask] - A).max() < 1e-12 and np.isnan(gg[~mask]).all()
    # a voxel with no neighbour in the solid along an axis has no gradient along it
    mask[3, 3, 5] = False  # (3, 3, 6) is now alone along z: the wall above, the removed voxel below
    gg = grid_gradients(np.where(mask, _linear(P), np.nan), mask, h)
    assert np.isnan(gg[3, 3, 6, 2]) and np.abs(gg[3, 3, 6, :2] - A[:2]).max() < 1e-12


@needs_tetgen
def test_a_tet_reconstruction_gives_its_gradient():
    """Every boundary vertex sampled with a linear field: the harmonic fill inside is that field (the P1 stiffness
    reproduces linear functions), so its gradient is the slope in every tet and at every vertex."""
    from manifill.solid.tets import boundary_vertices

    TV, TT = tet_ball(2)
    idx = boundary_vertices(TT)
    r = manifill.reconstruct_volume_tets(TV, TT, idx, _linear(TV[idx]), method="harmonic")
    gv, gc = r.gradient(), r.gradient("cells")
    assert gv.shape == (len(TV), 3) and gc.shape == (len(TT), 3)
    assert np.abs(gc - A).max() < 1e-8 and np.abs(gv - A).max() < 1e-8


def test_a_digital_surface_has_no_triangles_to_take_a_gradient_on():
    r = manifill.results.Result.__new__(manifill.surface.reconstruction.Reconstruction)
    r.F, r.values, r.V = None, np.zeros(3), np.zeros((3, 3))
    with pytest.raises(OptionError, match="no triangles"):
        r.gradient()
