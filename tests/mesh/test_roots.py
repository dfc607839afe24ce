"""Square roots of Laplacians (manifill.mesh.roots): ``B' B = L`` exactly.

The cotangent stiffness is ``L_ij = sum_t area_t grad(phi_i) . grad(phi_j)``, so the
finite-element gradient scaled by ``sqrt(area)`` is a root of it on any triangle mesh
(curved or flat, with cotangent weights of either sign); a Laplacian ``D - W`` with
``W >= 0`` has the edge root ``sqrt(w_ij) (e_i - e_j)``.
"""

import numpy as np
import pytest
import scipy.sparse as sp

from conftest import grid, icosphere, lattice
from manifill.mesh.laplacian import laplacian
from manifill.mesh.roots import edge_root, gradient_root, laplacian_root


def _gap(B, L):
    return float(abs(sp.csr_array(B.T @ B) - sp.csr_array(L)).max()) / float(abs(L).max())


MESHES = {
    "sphere": lambda: icosphere(2),
    "grid": lambda: grid(8),
    "obtuse-lattice": lambda: lattice(6, squash=0.25),  # negative cotangent weights
    "bumpy": lambda: _bumpy(),
}


def _bumpy():
    V, F = icosphere(2)
    r = 1.0 + 0.3 * np.sin(3 * V[:, 0]) * np.cos(2 * V[:, 1])
    return V * r[:, None], F


@pytest.mark.parametrize("name", sorted(MESHES))
@pytest.mark.parametrize("scale", [1.0, 1e-3, 250.0])
def test_gradient_root_squares_to_the_cotangent_laplacian(name, scale):
    V, F = MESHES[name]()
    V = V * scale
    B = gradient_root(V, F)
    assert B.shape == (3 * len(F), len(V))
    assert _gap(B, laplacian(V, F)) < 1e-12


def test_gradient_root_of_a_planar_mesh_given_in_2d():
    V, F = grid(7)
    B2 = gradient_root(V[:, :2], F)
    assert _gap(B2, laplacian(V, F)) < 1e-12


def test_gradient_root_is_the_dirichlet_energy_of_a_linear_function():
    # on a flat grid the linear function a.x has |grad|^2 = |a|^2 everywhere: x'B'Bx = |a|^2 * area
    V, F = grid(9, size=(2.0, 3.0))
    a = np.array([0.7, -1.3, 0.0])
    x = V @ a
    B = gradient_root(V, F)
    assert abs(float(np.sum((B @ x) ** 2)) - (a @ a) * 6.0) < 1e-10


@pytest.mark.parametrize("mesh", ["grid", "sphere"])
def test_edge_root_of_uniform_weights(mesh):
    V, F = grid(8) if mesh == "grid" else icosphere(2)
    L = laplacian(V, F, weights="uniform")
    B = edge_root(L)
    assert B is not None
    # one row per edge, two entries +-1 (uniform weights are 1)
    Bc = sp.csr_array(B)
    assert Bc.shape[0] == sp.triu(sp.csr_array(L), k=1).nnz
    assert np.allclose(np.sort(np.abs(Bc.data)), 1.0)
    assert np.allclose(np.asarray(Bc.sum(axis=1)).ravel(), 0.0)
    assert _gap(B, L) < 1e-14


def test_edge_root_of_acute_cotangent_weights():
    V, F = icosphere(2)  # all triangles acute: every cotangent weight > 0
    L = laplacian(V, F)
    assert _gap(edge_root(L), L) < 1e-12


def test_edge_root_refuses_a_negative_weight():
    V, F = lattice(6, squash=0.25)
    L = laplacian(V, F)
    assert (sp.triu(L, k=1).data > 0).any()  # some weight negative
    assert edge_root(L) is None
    # laplacian_root then falls back on the gradient root, and is None without triangles
    assert _gap(laplacian_root(L, V, F), L) < 1e-12
    assert laplacian_root(L) is None


def test_edge_root_of_a_hand_laplacian_with_one_negative_weight():
    W = np.array([[0, 1.0, 2.0], [1.0, 0, -0.5], [2.0, -0.5, 0]])
    L = sp.csr_array(np.diag(W.sum(axis=1)) - W)
    assert edge_root(L) is None
    W[1, 2] = W[2, 1] = 0.5
    L = sp.csr_array(np.diag(W.sum(axis=1)) - W)
    assert _gap(edge_root(L), L) < 1e-15
