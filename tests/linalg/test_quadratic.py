"""The solve core: minimise 1/2 x'Ax + c'x with x[idx] = vals, against a dense solve of its KKT system."""

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from manifill import ManifillError, MeshError, OptionError, SampleError, SolveError
from manifill.linalg.quadratic import QuadraticSolver, min_quad_with_fixed

SOLVERS = ("direct", "amg", "iterate")
hsettings = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                     suppress_health_check=[HealthCheck.too_slow])


def graph_laplacian(n, seed, extra=None, components=1):
    """A random connected weighted graph Laplacian (a path plus ``extra`` random edges), per component."""
    rng = np.random.default_rng(seed)
    blocks = []
    for _ in range(components):
        rows, cols = list(range(n - 1)), list(range(1, n))
        k = n if extra is None else extra
        rows += list(rng.integers(0, n, k))
        cols += list(rng.integers(0, n, k))
        W = sp.coo_matrix((rng.uniform(0.1, 2.0, len(rows)), (rows, cols)), shape=(n, n)).tocsr()
        W = W + W.T
        W.setdiag(0)
        W.eliminate_zeros()
        blocks.append(sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W)
    return sp.csr_array(sp.block_diag(blocks))


def kkt_dense(A, idx, vals, linear=None):
    """The minimiser by a dense solve of the KKT system [[A, C^T], [C, 0]] [x; l] = [-c; vals], C = I[idx]."""
    A = A.toarray()
    n, k = A.shape[0], len(idx)
    C = np.zeros((k, n))
    C[np.arange(k), idx] = 1.0
    K = np.block([[A, C.T], [C, np.zeros((k, k))]])
    vals = np.asarray(vals, float).reshape(k, -1)
    c = np.zeros((n, vals.shape[1])) if linear is None else np.asarray(linear, float).reshape(n, -1)
    return np.linalg.solve(K, np.vstack([-c, vals]))[:n]


@pytest.mark.parametrize("solver", SOLVERS)
def test_exact_at_fixed_and_equal_to_the_dense_kkt_solve(solver):
    A = graph_laplacian(40, 0)
    rng = np.random.default_rng(1)
    idx = rng.choice(40, 7, replace=False)
    vals = rng.normal(size=(7, 2))
    q = QuadraticSolver(A, idx, solver=solver, tol=1e-13)
    x = q.solve(vals)
    np.testing.assert_array_equal(x[idx], vals)
    np.testing.assert_allclose(x, kkt_dense(A, idx, vals), rtol=0, atol=1e-9)
    assert q.report["fixed"] == 7 and q.report["unknowns"] == 33 and q.report["solver"] == solver
    assert q.report["components"] == 1 and q.report["empty_components"] == []


@pytest.mark.parametrize("solver", ["direct", "amg"])
def test_linear_term_against_the_dense_kkt_solve(solver):
    A = graph_laplacian(30, 2)
    rng = np.random.default_rng(3)
    idx = np.array([0, 29, 11])
    vals, c = rng.normal(size=3), rng.normal(size=30)
    x = min_quad_with_fixed(A, idx, vals, linear=c, solver=solver, tol=1e-13)
    np.testing.assert_allclose(x, kkt_dense(A, idx, vals, c)[:, 0], rtol=0, atol=1e-9)
    # the gradient A x + c vanishes at every free index
    free = np.setdiff1d(np.arange(30), idx)
    assert np.abs((A @ x + c)[free]).max() <= 1e-9


@pytest.mark.parametrize("solver", SOLVERS)
def test_many_columns_equal_column_by_column(solver):
    A = graph_laplacian(50, 4)
    rng = np.random.default_rng(5)
    idx = rng.choice(50, 6, replace=False)
    vals = rng.normal(size=(6, 4))
    q = QuadraticSolver(A, idx, solver=solver, tol=1e-13)
    X = q.solve(vals)
    assert X.shape == (50, 4)
    for j in range(4):
        xj = q.solve(vals[:, j])
        assert xj.shape == (50,)
        np.testing.assert_allclose(X[:, j], xj, rtol=0, atol=1e-10)
    assert q.solve(vals[:, :1]).shape == (50, 1)


@pytest.mark.parametrize("solver", SOLVERS)
def test_empty_components_error_or_nan(solver):
    A = graph_laplacian(12, 6, components=3)  # vertices 0-11, 12-23, 24-35
    idx, vals = np.array([0, 5, 30]), np.array([1.0, 2.0, -1.0])
    with pytest.raises(SolveError) as info:
        QuadraticSolver(A, idx, solver=solver)
    msg = str(info.value)
    assert "component of 12 vertices (e.g. vertex 12)" in msg and "on_empty='nan'" in msg and "\n" not in msg
    q = QuadraticSolver(A, idx, solver=solver, on_empty="nan", tol=1e-13)
    x = q.solve(vals)
    assert np.isnan(x[12:24]).all() and np.isfinite(x[:12]).all() and np.isfinite(x[24:]).all()
    assert q.report["empty_components"] == [{"vertices": 12, "example_vertex": 12}]
    assert q.empty.sum() == 12 and q.report["unknowns"] == 36 - 12 - 3
    keep = np.r_[0:12, 24:36]
    np.testing.assert_allclose(x[keep], kkt_dense(A[keep][:, keep], [0, 5, 18], vals)[:, 0], rtol=0, atol=1e-9)


def test_two_empty_components_are_counted():
    A = graph_laplacian(5, 7, components=3)
    with pytest.raises(SolveError, match=r"\(and 1 more\)"):
        QuadraticSolver(A, [2])


def test_x0_is_used_and_checked():
    A = graph_laplacian(40, 8)
    idx, vals = np.array([0, 39]), np.array([0.0, 1.0])
    q = QuadraticSolver(A, idx, solver="iterate", iteration="jacobi", tol=1e-12)
    x = q.solve(vals)
    cold = q.report["iterations"][0]
    q.solve(vals, x0=x)
    assert q.report["iterations"][0] < cold
    for bad in (np.zeros(5), np.zeros((40, 3)), "abc", np.full(40, np.nan)):
        with pytest.raises(SampleError, match="x0"):
            q.solve(vals, x0=bad)
    with pytest.raises(SampleError, match="linear"):
        q.solve(vals, linear=np.ones(3))


@pytest.mark.parametrize("A, words", [
    (sp.csr_array(np.ones((3, 4))), "square"),
    (sp.csr_array(np.array([[1.0, np.nan], [np.nan, 1.0]])), "NaN"),
    ("abc", "sparse matrix"),
])
def test_a_bad_matrix_is_a_mesh_error(A, words):
    with pytest.raises(MeshError, match=words) as info:
        QuadraticSolver(A, [0])
    assert isinstance(info.value, ManifillError)


def test_bad_indices_values_and_options():
    A = graph_laplacian(10, 9)
    with pytest.raises(SampleError, match="idx"):
        QuadraticSolver(A, [0, 10])
    with pytest.raises(OptionError, match="on_empty"):
        QuadraticSolver(A, [0], on_empty="zero")
    with pytest.raises(OptionError, match="solver"):
        QuadraticSolver(A, [0], solver="cg")
    with pytest.raises(SampleError, match="vals"):
        QuadraticSolver(A, [0, 3]).solve([1.0])


@st.composite
def problems(draw):
    n = draw(st.integers(3, 25))
    seed = draw(st.integers(0, 2**32 - 1))
    idx = draw(st.lists(st.integers(0, n - 1), min_size=1, max_size=n, unique=True))
    vals = draw(st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=len(idx), max_size=len(idx)))
    return graph_laplacian(n, seed, extra=draw(st.integers(0, 2 * n))), np.array(idx), np.array(vals)


@hsettings
@given(problem=problems())
def test_property_exact_optimal_and_bounded(problem):
    # exact at idx; zero gradient at the free indices; a graph Laplacian keeps the maximum principle;
    # the dense KKT solve agrees
    A, idx, vals = problem
    x = QuadraticSolver(A, idx, symmetric_pattern=True).solve(vals)
    np.testing.assert_array_equal(x[idx], vals)
    scale = max(1.0, float(np.abs(vals).max()))
    free = np.setdiff1d(np.arange(A.shape[0]), idx)
    if free.size:
        assert np.abs((A @ x)[free]).max() <= 1e-9 * scale * abs(A).max()
    assert x.min() >= vals.min() - 1e-9 * scale and x.max() <= vals.max() + 1e-9 * scale
    np.testing.assert_allclose(x, kkt_dense(A, idx, vals)[:, 0], rtol=0, atol=1e-7 * scale)


# ---------------------------------------------------------------------------
# linear equality rows: barycentric points, against the dense KKT system
# ---------------------------------------------------------------------------


def kkt_dense_eq(A, idx, vals, Aeq, beq):
    """The minimiser with x[idx] = vals and Aeq x = beq by one dense KKT solve."""
    A, E = A.toarray(), Aeq.toarray()
    n, k, m = A.shape[0], len(idx), E.shape[0]
    C = np.zeros((k, n))
    C[np.arange(k), idx] = 1.0
    B = np.vstack([C, E])
    K = np.block([[A, B.T], [B, np.zeros((k + m, k + m))]])
    rhs = np.vstack([np.zeros((n, 1)), np.reshape(vals, (k, 1)), np.reshape(beq, (m, 1))])
    return np.linalg.solve(K, rhs)[:n, 0]


def barycentric_rows(n, rng, m, avoid):
    """``m`` rows, each a random point of a random triangle of free vertices (weights >= 0 summing to 1)."""
    free = np.setdiff1d(np.arange(n), avoid)
    rows = []
    for _ in range(m):
        tri = rng.choice(free, 3, replace=False)
        rows.append(sp.coo_array((rng.dirichlet(np.ones(3)), (np.zeros(3, int), tri)), shape=(1, n)))
    return sp.csr_array(sp.vstack(rows))


@pytest.mark.parametrize("seed", range(4))
def test_equality_rows_against_the_dense_kkt_solve(seed):
    rng = np.random.default_rng(seed)
    A = graph_laplacian(40, seed)
    idx = rng.choice(40, 3, replace=False)
    vals = rng.normal(size=3)
    Aeq = barycentric_rows(40, rng, 4, idx)
    beq = rng.normal(size=4)
    q = QuadraticSolver(A, idx, Aeq=Aeq)
    x = q.solve(vals, beq=beq)
    np.testing.assert_array_equal(x[idx], vals)
    np.testing.assert_allclose(Aeq @ x, beq, rtol=0, atol=1e-10)  # the points take their values
    np.testing.assert_allclose(x, kkt_dense_eq(A, idx, vals, Aeq, beq), rtol=0, atol=1e-9)
    assert q.report["equality_rows"] == 4 and q.report["solver"] == "direct"
    # several fields at once, column by column
    X = q.solve(np.column_stack([vals, 2 * vals]), beq=np.column_stack([beq, -beq]))
    np.testing.assert_allclose(X[:, 1], kkt_dense_eq(A, idx, 2 * vals, Aeq, -beq), rtol=0, atol=1e-9)


def test_an_equality_row_anchors_a_component():
    A = graph_laplacian(10, 1, components=2)  # the second component has no fixed vertex, one barycentric point
    rng = np.random.default_rng(2)
    Aeq = barycentric_rows(20, rng, 1, np.arange(10))
    x = QuadraticSolver(A, [0, 9], Aeq=Aeq).solve([1.0, 2.0], beq=[5.0])
    np.testing.assert_allclose(x[10:], 5.0, rtol=0, atol=1e-12)  # one row pins that component's constant
    with pytest.raises(SolveError, match="component of 10 vertices"):
        QuadraticSolver(A, [0, 9])


def test_equality_rows_need_the_direct_solver_and_beq():
    A = graph_laplacian(10, 3)
    Aeq = barycentric_rows(10, np.random.default_rng(0), 2, [0])
    with pytest.raises(OptionError, match="solver='direct'"):
        QuadraticSolver(A, [0], Aeq=Aeq, solver="amg")
    with pytest.raises(SampleError, match="Aeq"):
        QuadraticSolver(A, [0], Aeq=sp.csr_array(np.ones((2, 9))))
    q = QuadraticSolver(A, [0], Aeq=Aeq)
    with pytest.raises(SampleError, match="beq"):
        q.solve([1.0])
    with pytest.raises(SampleError, match="beq"):
        q.solve([1.0], beq=[1.0, 2.0, 3.0])
    with pytest.raises(SolveError, match="singular"):  # the same row twice
        QuadraticSolver(A, [0], Aeq=sp.csr_array(sp.vstack([Aeq[[0]], Aeq[[0]]])))


# ---------------------------------------------------------------------------
# the pieces the bounds' active set uses: fixing more indices, the equality multipliers
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("solver", ["direct", "amg"])
def test_fixing_more_indices_is_the_same_reduction(solver):
    A = graph_laplacian(30, 11)
    rng = np.random.default_rng(12)
    idx, extra = np.array([0, 7]), np.array([20, 3, 14])
    vals = rng.normal(size=5)
    q = QuadraticSolver(A, idx, solver=solver, tol=1e-13)
    sub = q.fixing(extra)
    np.testing.assert_array_equal(sub.idx, np.r_[idx, extra])
    assert sub.report["unknowns"] == q.report["unknowns"] - 3 and sub.report["solver"] == solver
    np.testing.assert_allclose(sub.solve(vals), kkt_dense(A, np.r_[idx, extra], vals)[:, 0], rtol=0, atol=1e-9)
    assert q.report["unknowns"] == 28  # the original is untouched


def test_equality_multipliers_make_the_gradient_vanish():
    rng = np.random.default_rng(13)
    A = graph_laplacian(30, 13)
    idx = np.array([0, 29])
    Aeq = barycentric_rows(30, rng, 3, idx)
    q = QuadraticSolver(A, idx, Aeq=Aeq)
    c = rng.normal(size=30)
    x = q.solve([1.0, -1.0], beq=[0.5, 0.0, 2.0], linear=c)
    assert q.eq_multipliers.shape == (3, 1)
    g = A @ x + c + Aeq.T @ q.eq_multipliers[:, 0]
    assert np.abs(g[q.unknown]).max() <= 1e-9
    assert QuadraticSolver(A, idx).eq_multipliers is None


@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(n=st.integers(2, 30), seed=st.integers(0, 10_000), components=st.integers(1, 3), data=st.data())
def test_reduction_blocks_equal_fancy_indexing(n, seed, components, data):
    # A_II = A[I][:, I] and A_Ib = A[I][:, idx] exactly (values, order, int32 indices), for fixed indices in
    # any order, components left empty (on_empty='nan') and stored zeros
    A = sp.csr_array(graph_laplacian(n, seed, extra=n // 2, components=components))
    A.data[::7] = 0.0  # stored zeros stay stored
    N = A.shape[0]
    idx = np.array(data.draw(st.lists(st.integers(0, n - 1), min_size=1, max_size=n, unique=True)))
    q = QuadraticSolver(A, idx, solver="iterate", on_empty="nan")  # no factorisation of a singular A_II
    rows = A[q.unknown]
    for got, want in ((q._A_II, rows[:, q.unknown]), (q._A_Ib, rows[:, idx])):
        want = sp.csr_array(want)
        assert got.shape == want.shape
        np.testing.assert_array_equal(got.indptr, want.indptr)
        np.testing.assert_array_equal(got.indices, want.indices)
        np.testing.assert_array_equal(got.data, want.data)
        assert got.indices.dtype == np.int32
    assert q.unknown.size + idx.size + int(q.empty.sum()) == N
