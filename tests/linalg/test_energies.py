"""The polyharmonic energy A = L (M^-1 L)^(k-1): its definition, symmetry, null space and bad input."""

import numpy as np
import pytest
import scipy.sparse as sp

from conftest import irregular
from manifill import MeshError, OptionError
from manifill.linalg.energies import polyharmonic_energy
from manifill.mesh.laplacian import laplacian, mass_matrix


def mesh_matrices():
    V, F = irregular()
    return laplacian(V, F), mass_matrix(V, F)


@pytest.mark.parametrize("k", [1, 2, 3])
def test_equals_the_dense_product(k):
    L, M = mesh_matrices()
    Ld, Mi = L.toarray(), np.diag(1.0 / M.diagonal())
    want = Ld.copy()
    for _ in range(k - 1):
        want = want @ Mi @ Ld
    A = polyharmonic_energy(L, M, k)
    np.testing.assert_allclose(A.toarray(), want, rtol=0, atol=1e-12 * np.abs(want).max())


@pytest.mark.parametrize("k", [2, 3])
def test_symmetric_psd_constants_in_null_space(k):
    L, M = mesh_matrices()
    A = polyharmonic_energy(L, M.diagonal(), k)  # the diagonal alone is accepted
    assert abs(A - A.T).max() == 0.0
    assert np.abs(A @ np.ones(A.shape[0])).max() <= 1e-12 * abs(A).max()
    w = np.linalg.eigvalsh(A.toarray())
    assert w.min() >= -1e-10 * w.max()
    assert A.has_sorted_indices


def test_biharmonic_energy_is_the_mass_norm_of_the_laplacian():
    # x^T A x = || M^-1 L x ||_M^2
    L, M = mesh_matrices()
    x = np.random.default_rng(0).standard_normal(L.shape[0])
    y = (L @ x) / M.diagonal()
    assert polyharmonic_energy(L, M) @ x @ x == pytest.approx(float(y @ (M.diagonal() * y)), rel=1e-12)


def test_massless_isolated_vertex_is_allowed_and_massless_used_vertex_refused():
    L, M = mesh_matrices()
    n = L.shape[0]
    L1 = sp.block_diag([L, sp.csr_array((1, 1))], format="csr")
    A = polyharmonic_energy(L1, np.r_[M.diagonal(), 0.0])
    assert A.shape == (n + 1, n + 1) and abs(A[[n]]).sum() == 0
    m = M.diagonal().copy()
    m[3] = 0.0
    with pytest.raises(MeshError, match="vertex 3 has zero mass"):
        polyharmonic_energy(L, m)


@pytest.mark.parametrize("M", [np.ones(5), -np.ones(128), np.full(128, np.nan)])
def test_bad_mass(M):
    L, _ = mesh_matrices()
    with pytest.raises(MeshError, match="mass"):
        polyharmonic_energy(L, M)


@pytest.mark.parametrize("k", [0, -1, 1.5, True, "2"])
def test_bad_order(k):
    L, M = mesh_matrices()
    with pytest.raises(OptionError, match="positive integer"):
        polyharmonic_energy(L, M, k)
