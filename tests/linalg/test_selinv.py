"""Selected inversion (manifill.linalg.selinv) against the dense inverse.

``Sigma = A^-1`` on the pattern of the Cholesky factor ``L`` of ``A`` (after its permutation): every entry the
recursions produce equals the dense inverse's there, the diagonal is the marginal variance, and
``tr(A^-1 D)`` for ``D`` on ``A``'s pattern is the dense trace. Checked on the precisions manifill conditions
(Matérn of order 1 and 2, an intrinsic Laplacian's free block, a noisy posterior's), on random sparse SPD
matrices (hypothesis), for both factorisations (SuperLU always; CHOLMOD where the extra is installed).
"""

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import icosphere
from manifill.errors import SolveError
from manifill.linalg import selinv
from manifill.linalg.cholesky import cholesky, cholmod_available
from manifill.linalg.selinv import SelectedInverse
from manifill.linalg.spde import MaternShape
from manifill.mesh.laplacian import laplacian, mass_matrix
from manifill.mesh.roots import gradient_root

BACKENDS = ["superlu", pytest.param("cholmod", marks=pytest.mark.skipif(
    not cholmod_available(), reason="the [cholmod] extra (scikit-sparse) is not installed"))]


def _irregular_sphere(level=3, seed=0):
    V, F = icosphere(level)
    V = V * (1.0 + 0.15 * np.random.default_rng(seed).random((len(V), 1)))  # uneven edges and angles
    return V, F


def _precisions():
    V, F = _irregular_sphere()
    n = len(V)
    G, c, root = laplacian(V, F), mass_matrix(V, F, mass="barycentric").diagonal(), gradient_root(V, F)
    rng = np.random.default_rng(1)
    idx = np.sort(rng.choice(n, 40, replace=False))
    free = np.setdiff1d(np.arange(n), idx)
    out = {}
    for alpha in (1, 2):
        Q = sp.csc_matrix(MaternShape(G, c, root, alpha, 2).precision(2.5))
        out[f"matern{alpha}-free"] = Q[free][:, free]
        H = sp.csr_matrix((np.ones(idx.size), (np.arange(idx.size), idx)), shape=(idx.size, n))
        out[f"matern{alpha}-noisy"] = sp.csc_matrix(Q + H.T @ sp.diags(1.0 / rng.uniform(0.01, 0.1, idx.size)) @ H)
    out["laplacian-free"] = sp.csc_matrix(G)[free][:, free]
    return out


PRECISIONS = _precisions()


def _pattern_entries(s):
    """(rows, cols) of the factor's pattern, in A's own numbering."""
    L = s.factor.L.tocoo()
    p = s.factor.p
    return p[L.row], p[L.col]


@pytest.mark.parametrize("name", sorted(PRECISIONS))
@pytest.mark.parametrize("backend", BACKENDS)
def test_every_selected_entry_is_the_dense_inverses(name, backend):
    A = PRECISIONS[name]
    dense = np.linalg.inv(A.toarray())
    s = SelectedInverse(cholesky(A, backend))
    assert s.factor.name == backend
    i, j = _pattern_entries(s)
    scale = np.abs(dense).max()
    assert np.abs(s.values - dense[i, j]).max() < 1e-10 * scale
    d = s.diagonal()
    assert np.abs(d / np.diag(dense) - 1.0).max() < 1e-8
    # the factor solves and gives log det A
    b = np.random.default_rng(3).standard_normal((A.shape[0], 2))
    assert np.abs(s.factor.solve(b) - dense @ b).max() < 1e-9 * np.abs(dense @ b).max()
    assert s.factor.logdet == pytest.approx(np.linalg.slogdet(A.toarray())[1], rel=1e-10, abs=1e-8)


@pytest.mark.parametrize("backend", BACKENDS)
def test_trace_of_the_inverse_times_a_matrix_on_the_pattern(backend):
    A = PRECISIONS["matern2-free"]
    D = sp.csc_matrix(A, copy=True)
    D.data = np.random.default_rng(4).standard_normal(D.nnz)
    D = (D + D.T).tocsc()  # symmetric, on A's pattern: the derivative of a precision along a parameter
    want = np.trace(np.linalg.solve(A.toarray(), D.toarray()))
    got = SelectedInverse(cholesky(A, backend)).trace_product(D)
    assert got == pytest.approx(want, rel=1e-9)


def test_relabelling_the_unknowns_permutes_the_variances():
    A = PRECISIONS["matern1-free"]
    perm = np.random.default_rng(5).permutation(A.shape[0])
    d = SelectedInverse(cholesky(A, "superlu")).diagonal()
    dp = SelectedInverse(cholesky(A[perm][:, perm], "superlu")).diagonal()
    assert np.abs(dp - d[perm]).max() < 1e-10 * d.max()


def test_scaling_the_precision_scales_the_variances_inversely():
    A = PRECISIONS["laplacian-free"]
    d = SelectedInverse(cholesky(A, "superlu")).diagonal()
    for c in (1e-6, 1e9):
        dc = SelectedInverse(cholesky(A * c, "superlu")).diagonal()
        assert np.abs(dc * c / d - 1.0).max() < 1e-10


@st.composite
def _spd(draw):
    """A random sparse SPD matrix: a weighted graph's Laplacian (random edges) plus a positive diagonal."""
    n = draw(st.integers(2, 60))
    seed = draw(st.integers(0, 2**31 - 1))
    density = draw(st.floats(0.02, 0.4))
    rng = np.random.default_rng(seed)
    E = sp.random(n, n, density=density, random_state=rng, data_rvs=lambda k: rng.uniform(0.1, 2.0, k))
    W = sp.triu(E + E.T, 1)
    W = W + W.T
    L = sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W
    return sp.csc_matrix(L + sp.diags(rng.uniform(0.01, 1.0, n)))


@settings(max_examples=60, deadline=None)
@given(_spd())
def test_random_sparse_spd_matrices(A):
    dense = np.linalg.inv(A.toarray())
    s = SelectedInverse(cholesky(A, "superlu"))
    i, j = _pattern_entries(s)
    assert np.abs(s.values - dense[i, j]).max() <= 1e-9 * np.abs(dense).max()


def test_supernodes_are_runs_with_nested_structures():
    # a dense 4 x 4 block is one supernode; a diagonal matrix has one per column
    dense = cholesky(sp.csc_matrix(np.full((4, 4), 1.0) + 4 * np.eye(4)), "superlu")
    assert selinv._supernodes(dense.L).tolist() == [0, 4]
    diag = cholesky(sp.diags([1.0, 2.0, 3.0]).tocsc(), "superlu")
    assert selinv._supernodes(diag.L).tolist() == [0, 1, 2, 3]


def test_an_indefinite_matrix_is_refused_with_the_cause():
    A = sp.csc_matrix(np.array([[1.0, 2.0], [2.0, 1.0]]))
    with pytest.raises(SolveError, match="not positive definite"):
        cholesky(A, "superlu")


def test_a_factor_that_lost_entries_of_its_pattern_is_refused_not_misread():
    # L[2, 1] = 0 exactly: SuperLU drops it, and the pattern is no longer closed under elimination
    A = sp.csc_matrix(np.array([[1.0, 1, 1, 0], [1, 3, 1, 0], [1, 1, 3, 1], [0, 0, 1, 3]]))
    with pytest.raises(SolveError, match="lost entries of its pattern"):
        SelectedInverse(cholesky(A, "superlu", order=np.arange(4)))
    if cholmod_available():  # CHOLMOD keeps the zero
        d = SelectedInverse(cholesky(A, "cholmod")).diagonal()
        assert np.allclose(d, np.diag(np.linalg.inv(A.toarray())))
