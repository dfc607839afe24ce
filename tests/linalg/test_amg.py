"""The surface AMG hierarchy on systems large enough to coarsen twice: levels, the cycle, the iteration."""

import functools

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import cg, splu

from conftest import grid, icosphere
from manifill.mesh.laplacian import laplacian
from manifill.linalg.amg import Multigrid
from manifill.linalg.backends import AMGSolver
from manifill.tolerances import TOL

#: Dirichlet problems on surfaces: a closed sphere and a flat square, a few fixed vertices each.
SURFACES = {"icosphere5": lambda: icosphere(5), "grid150": lambda: grid(150)}


@functools.lru_cache(maxsize=None)
def problem(name, fixed=8):
    """The reduced cotan system ``A x = r`` for ``fixed`` random fixed vertices with random values."""
    V, F = SURFACES[name]()
    L = sp.csr_matrix(laplacian(V, F, weights="cotan"))
    rng = np.random.default_rng(0)
    b = np.sort(rng.choice(len(V), fixed, replace=False))
    free = np.setdiff1d(np.arange(len(V)), b)
    A = L[free][:, free].tocsr()
    R = -(L[free][:, b] @ rng.standard_normal((fixed, 3)))
    return A, R


@functools.lru_cache(maxsize=None)
def direct(name):
    A, R = problem(name)
    return splu(sp.csc_matrix(A)).solve(R)


names = pytest.mark.parametrize("name", sorted(SURFACES))


@names
def test_hierarchy_has_three_levels_of_galerkin_products(name):
    A, _ = problem(name)
    solver = AMGSolver(A)
    assert solver.blocks == 1
    assert solver.levels >= 3, "two coarsenings and the factorised level"
    mg = Multigrid(solver.A, solver)
    assert len(mg.levels) + 1 == len(mg.nnz) == solver.levels
    sizes = [Ak.shape[0] for Ak, _, _, _ in mg.levels]
    assert sizes[0] == A.shape[0] and all(a > b for a, b in zip(sizes, sizes[1:]))
    assert all(n > AMGSolver.MAX_COARSE for n in sizes)  # every coarsened level was larger than the coarsest
    assert mg.lu.shape[0] <= AMGSolver.MAX_COARSE
    assert solver.operator_complexity == pytest.approx(sum(mg.nnz) / A.nnz)
    assert 1.0 < solver.operator_complexity < 1.6
    # each coarse matrix is R A P with R = P^T (all in float32, A scaled by its largest diagonal entry)
    for (Ak, _, Rk, Pk), nxt in zip(mg.levels, mg.levels[1:]):
        assert Rk.shape == Pk.T.shape and abs(Rk - Pk.T).max() == 0
        Ac = sp.csr_matrix(Rk.astype(np.float64) @ Ak.astype(np.float64) @ Pk.astype(np.float64))
        assert abs(nxt[0].astype(np.float64) - Ac).max() <= 1e-5 * abs(Ac).max()


@names
def test_cycle_is_a_symmetric_positive_definite_preconditioner(name):
    A, _ = problem(name)
    solver = AMGSolver(A)
    mg = Multigrid(solver.A, solver)
    assert len(mg.levels) >= 2, "the cycle recurses below the finest level"
    rng = np.random.default_rng(1)
    X = rng.standard_normal((A.shape[0], 4))
    MX = np.column_stack([mg._precondition(X[:, j], 1.0) for j in range(X.shape[1])])  # M x
    G = X.T @ MX  # the Gram matrix x_i^T M x_j
    assert (np.diag(G) > 0).all()
    scale = np.sqrt(np.outer(np.diag(G), np.diag(G)))
    # symmetric to float32 rounding (a forward sweep after the coarse correction instead of a backward one,
    # or a restriction that is not P^T, leaves 4e-3 here)
    assert np.abs(G - G.T).max() <= 1e-5 * scale.max()
    assert np.linalg.eigvalsh(0.5 * (G + G.T)).min() > 0
    # linear: M (a x + y) = a M x + M y
    z = mg._precondition(2.5 * X[:, 0] + X[:, 1], 1.0)
    np.testing.assert_allclose(z, 2.5 * MX[:, 0] + MX[:, 1], rtol=0, atol=1e-5 * np.abs(z).max())


@names
def test_pcg_converges_to_the_direct_solution_faster_than_plain_cg(name):
    A, R = problem(name)
    X, info = AMGSolver(A).solve(R)
    Xd = direct(name)
    assert info["levels"] >= 3
    np.testing.assert_allclose(X, Xd, rtol=0, atol=1e-10 * np.abs(Xd).max())
    for j in range(R.shape[1]):
        assert np.linalg.norm(A @ X[:, j] - R[:, j]) <= TOL.amg_rtol * np.linalg.norm(R[:, j])
    count = [0]

    def step(_):
        count[0] += 1

    x, flag = cg(A, R[:, 0], rtol=TOL.amg_rtol, maxiter=20_000, callback=step)
    assert flag == 0
    its = info["iterations"]
    assert max(its) <= 30, "a multigrid rate: an iteration count independent of the size"
    assert 10 * max(its) < count[0], (its, count[0])


@names
def test_many_columns_equal_column_by_column(name):
    A, R = problem(name)
    solver = AMGSolver(A)
    X, info = solver.solve(R)
    assert len(info["iterations"]) == R.shape[1]
    for j in range(R.shape[1]):
        xj, infoj = solver.solve(R[:, j])
        assert xj.shape == (A.shape[0], 1)
        np.testing.assert_array_equal(X[:, j], xj[:, 0])
        assert infoj["iterations"] == [info["iterations"][j]]
    # and a start x0 = the answer needs no iteration
    X0, info0 = solver.solve(R, x0=X)
    assert info0["iterations"] == [0] * R.shape[1]
    np.testing.assert_array_equal(X0, X)


@names
def test_blocks_of_rows_in_the_set_up_change_no_bit(name, monkeypatch):
    # the row sums of |A| and S = A T are built block of rows by block: any block size, the same hierarchy
    import manifill.linalg.amg as amg

    A, _ = problem(name)
    solver = AMGSolver(A)
    whole = Multigrid(solver.A, solver)
    monkeypatch.setattr(amg, "_BLOCK", 1000)
    blocked = Multigrid(solver.A, solver)
    assert len(whole.levels) == len(blocked.levels)
    for one, other in zip(whole.levels, blocked.levels):
        for X, Y in zip(one, other):
            if X is None:
                assert Y is None
                continue
            assert X.shape == Y.shape and (X != Y).nnz == 0
            np.testing.assert_array_equal(sp.csr_matrix(X).indptr, sp.csr_matrix(Y).indptr)
