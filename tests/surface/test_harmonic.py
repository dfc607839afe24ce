"""The harmonic fill: exactness, maximum principle, linear precision, references, invariances."""

import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import (
    MESHES,
    boundary_vertices,
    grid,
    icosphere,
    irregular,
    lattice,
    nonmanifold,
    obtuse,
    relabel,
    two_components,
)
from manifill import HarmonicSolver, ManifillError, MeshError, SampleError, SolveError, harmonic, laplacian

WEIGHTS = ("uniform", "cotan", "intrinsic", "robust")
SOLVERS = ("direct", "amg", "iterate")
hsettings = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                     suppress_health_check=[HealthCheck.too_slow])


def random_problem(V, seed, k=None, p=None):
    """A seeded random fixed set b (unsorted) and values bc."""
    rng = np.random.default_rng(seed)
    k = max(3, len(V) // 6) if k is None else k
    b = rng.choice(len(V), size=k, replace=False)
    bc = rng.uniform(-2.0, 3.0, size=k if p is None else (k, p))
    return b, bc


def assert_max_principle(x, bc, slack=1e-10):
    lo, hi = float(np.min(bc)), float(np.max(bc))
    eps = slack * max(1.0, hi - lo)
    assert x.min() >= lo - eps, f"undershoot {lo - x.min():.3g}"
    assert x.max() <= hi + eps, f"overshoot {x.max() - hi:.3g}"


def overshoot(x, bc):
    return max(float(x.max() - np.max(bc)), float(np.min(bc) - x.min()))


# ---------------------------------------------------------------------------
# exactness and the defining equations
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("weights", WEIGHTS)
@pytest.mark.parametrize("solver", SOLVERS)
def test_exact_at_fixed_vertices(weights, solver):
    V, F = irregular(7)
    b, bc = random_problem(V, seed=1)
    x = harmonic(V, F, b, bc, weights=weights, solver=solver, tol=1e-12)
    np.testing.assert_array_equal(x[b], bc)


@pytest.mark.parametrize("weights", WEIGHTS)
def test_harmonic_at_free_vertices(weights):
    # (L x)_i = 0 away from b: every free value is the weighted mean of its neighbours
    V, F = irregular()
    b, bc = random_problem(V, seed=2)
    x = harmonic(V, F, b, bc, weights=weights)
    free = np.setdiff1d(np.arange(len(V)), b)
    L = laplacian(V, F, weights=weights)
    assert np.abs((L @ x)[free]).max() <= 1e-11 * abs(L).max() * np.abs(bc).max()


def test_fixed_order_does_not_matter():
    V, F = irregular()
    b, bc = random_problem(V, seed=3, p=2)
    order = np.random.default_rng(0).permutation(len(b))
    np.testing.assert_allclose(harmonic(V, F, b[order], bc[order]), harmonic(V, F, b, bc), rtol=0, atol=1e-14)


@pytest.mark.parametrize("solver", SOLVERS)
def test_all_vertices_fixed(solver):
    V, F = grid(4)
    bc = np.linspace(0.0, 1.0, len(V))
    b = np.arange(len(V))[::-1]
    np.testing.assert_array_equal(harmonic(V, F, b, bc, solver=solver), bc[::-1])


def test_one_fixed_vertex_gives_a_constant():
    V, F = icosphere(1)
    np.testing.assert_allclose(harmonic(V, F, [5], [2.5]), 2.5, rtol=0, atol=1e-13)


# ---------------------------------------------------------------------------
# maximum principle
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("mesh", [m for m in MESHES if m != "two_components"])
@pytest.mark.parametrize("seed", [0, 1])
def test_max_principle_uniform_on_every_mesh(mesh, seed):
    V, F = MESHES[mesh]()
    b, bc = random_problem(V, seed, k=min(3, len(V) - 1))
    assert_max_principle(harmonic(V, F, b, bc, weights="uniform"), bc)


@pytest.mark.parametrize(
    "mesh",
    [lambda: icosphere(2), lambda: lattice(7), lambda: grid(7), lambda: grid(7, diagonal="right")],
    ids=["icosphere", "equilateral_lattice", "grid", "grid_right"],
)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_max_principle_cotan_on_non_obtuse_mesh(mesh, seed):
    V, F = mesh()
    b, bc = random_problem(V, seed)
    assert_max_principle(harmonic(V, F, b, bc, weights="cotan"), bc)


@pytest.mark.parametrize("mesh", [obtuse, irregular, lambda: lattice(8, squash=0.15)],
                         ids=["obtuse", "irregular", "flatter"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_max_principle_intrinsic_on_obtuse_mesh(mesh, seed):
    V, F = mesh()
    b, bc = random_problem(V, seed)
    assert_max_principle(harmonic(V, F, b, bc, weights="intrinsic"), bc)


def test_cotan_breaks_the_max_principle_on_the_obtuse_mesh(obtuse_mesh):
    # the control for the two tests above: the same problems, with cotan weights, overshoot
    V, F = obtuse_mesh
    worst = 0.0
    for seed in range(5):
        b, bc = random_problem(V, seed)
        assert overshoot(harmonic(V, F, b, bc, weights="intrinsic"), bc) <= 1e-12
        worst = max(worst, overshoot(harmonic(V, F, b, bc, weights="cotan"), bc))
    assert worst > 0.05


@st.composite
def fixed_sets(draw, n):
    b = draw(st.lists(st.integers(0, n - 1), min_size=1, max_size=n, unique=True))
    bc = draw(st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=len(b), max_size=len(b)))
    return np.array(b), np.array(bc)


OBTUSE5 = lattice(5, squash=0.25)
IRREGULAR5 = irregular(5, seed=9)


@hsettings
@given(problem=fixed_sets(len(OBTUSE5[0])))
def test_uniform_exact_and_max_principle_any_fixed_set(problem):
    b, bc = problem
    x = harmonic(*OBTUSE5, b, bc, weights="uniform")
    np.testing.assert_array_equal(x[b], bc)
    assert_max_principle(x, bc)


@hsettings
@given(problem=fixed_sets(len(IRREGULAR5[0])))
def test_intrinsic_exact_and_max_principle_any_fixed_set(problem):
    b, bc = problem
    x = harmonic(*IRREGULAR5, b, bc, weights="intrinsic")
    np.testing.assert_array_equal(x[b], bc)
    assert_max_principle(x, bc)


# ---------------------------------------------------------------------------
# linear precision
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "mesh", [irregular, lambda: irregular(7, seed=1), obtuse, lambda: grid(6)],
    ids=["irregular", "irregular1", "obtuse", "grid"],
)
def test_cotan_reproduces_linear_functions(mesh):
    V, F = mesh()
    b = np.flatnonzero(boundary_vertices(F, len(V)))
    f = V @ np.array([1.5, -2.0, 0.0]) + 0.5
    x = harmonic(V, F, b, f[b], weights="cotan")
    np.testing.assert_allclose(x, f, rtol=0, atol=1e-12)


def test_uniform_reproduces_linear_functions_on_regular_grid():
    V, F = grid(7, diagonal="right")
    b = np.flatnonzero(boundary_vertices(F, len(V)))
    f = np.column_stack([V[:, 0], 3 * V[:, 1] - V[:, 0], np.ones(len(V))])
    np.testing.assert_allclose(harmonic(V, F, b, f[b], weights="uniform"), f, rtol=0, atol=1e-12)


@pytest.mark.parametrize("mesh", [irregular, lambda: irregular(7, seed=1)], ids=["irregular", "irregular1"])
def test_uniform_does_not_reproduce_linear_functions_on_irregular_mesh(mesh):
    # the control: uniform weights are exact only where every neighbourhood is point-symmetric
    V, F = mesh()
    b = np.flatnonzero(boundary_vertices(F, len(V)))
    f = V[:, 0] + 2 * V[:, 1]
    assert np.abs(harmonic(V, F, b, f[b], weights="uniform") - f).max() > 1e-3


# ---------------------------------------------------------------------------
# reference: libigl
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "mesh", [lambda: icosphere(2), lambda: grid(8), irregular, obtuse, two_components],
    ids=["icosphere", "grid", "irregular", "obtuse", "two_components"],
)
@pytest.mark.parametrize("seed", [0, 1])
def test_agrees_with_igl_harmonic(mesh, seed):
    V, F = mesh()
    b, bc = random_problem(V, seed, k=max(4, len(V) // 8), p=2)
    if mesh is two_components:
        b = np.r_[b, 0, len(V) - 1]  # one fixed vertex in each component at least
        b = np.unique(b)
        bc = np.random.default_rng(seed).normal(size=(len(b), 2))
    igl = pytest.importorskip("igl")
    ref = igl.harmonic(V, np.asarray(F, np.int64), b.astype(np.int64), bc.astype(np.float64), 1)
    x = harmonic(V, F, b, bc, weights="cotan")
    np.testing.assert_allclose(x, ref, rtol=0, atol=1e-8 * np.abs(bc).max())


# ---------------------------------------------------------------------------
# solvers and the solver object
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("weights", ["cotan", "uniform"])
def test_all_solvers_agree(weights):
    V, F = irregular(7)
    b, bc = random_problem(V, seed=4, p=2)
    ref = harmonic(V, F, b, bc, weights=weights, solver="direct")
    for solver, iteration in [("auto", None), ("amg", None), ("iterate", "jacobi"), ("iterate", "gauss-seidel")]:
        kw = {"iteration": iteration} if iteration else {}
        x = harmonic(V, F, b, bc, weights=weights, solver=solver, tol=1e-13, **kw)
        np.testing.assert_allclose(x, ref, rtol=0, atol=1e-9, err_msg=f"{solver} {iteration}")


@pytest.mark.parametrize("solver", SOLVERS)
def test_solver_object_equals_one_shot(solver):
    V, F = icosphere(2)
    b, _ = random_problem(V, seed=5)
    hs = HarmonicSolver(V, F, b, solver=solver, tol=1e-12)
    for seed in range(3):
        bc = np.random.default_rng(seed).normal(size=len(b))
        np.testing.assert_allclose(hs.solve(bc), harmonic(V, F, b, bc, solver=solver, tol=1e-12), rtol=0, atol=1e-12)


@pytest.mark.parametrize("solver", SOLVERS)
def test_many_columns_equal_column_by_column(solver):
    V, F = irregular(7)
    b, bc = random_problem(V, seed=6, p=4)
    hs = HarmonicSolver(V, F, b, solver=solver, tol=1e-13)
    X = hs.solve(bc)
    assert X.shape == (len(V), 4)
    for j in range(4):
        xj = hs.solve(bc[:, j])
        assert xj.shape == (len(V),)
        np.testing.assert_allclose(X[:, j], xj, rtol=0, atol=1e-10)
    assert hs.solve(bc[:, :1]).shape == (len(V), 1)


def test_iterate_reports_iterations_and_a_good_start_helps():
    V, F = lattice(7)
    b, bc = random_problem(V, seed=7)
    hs = HarmonicSolver(V, F, b, solver="iterate", iteration="jacobi", tol=1e-12)
    x = hs.solve(bc)
    cold = hs.report["iterations"]
    assert len(cold) == 1 and cold[0] > 10
    near = x + 1e-6 * np.random.default_rng(0).normal(size=len(V))
    x2 = hs.solve(bc, x0=near)
    warm = hs.report["iterations"]
    assert 0 < warm[0] < cold[0]
    np.testing.assert_allclose(x2, x, rtol=0, atol=1e-9)


@pytest.mark.parametrize("iteration", ["jacobi", "gauss-seidel"])
def test_iterate_non_convergence_raises(iteration):
    V, F = lattice(6)
    b, bc = random_problem(V, seed=8)
    with pytest.raises(SolveError, match="1 sweeps") as exc:
        harmonic(V, F, b, bc, solver="iterate", iteration=iteration, maxiter=1)
    assert "\n" not in str(exc.value)


def test_amg_non_convergence_raises():
    V, F = icosphere(4)  # 2562 vertices: a real multilevel hierarchy, not one exact coarse solve
    b, bc = random_problem(V, seed=9, k=20)
    with pytest.raises(SolveError, match="1 iterations") as exc:
        harmonic(V, F, b, bc, solver="amg", maxiter=1)
    assert "\n" not in str(exc.value)


# ---------------------------------------------------------------------------
# components without a fixed vertex
# ---------------------------------------------------------------------------


def test_empty_component_raises_naming_size_and_vertex(two_component_mesh):
    V, F = two_component_mesh
    b, bc = [0, 3, 12, 15], [0.0, 1.0, 2.0, 3.0]  # all in the 16-vertex grid
    with pytest.raises(SolveError) as exc:
        harmonic(V, F, b, bc)
    msg = str(exc.value)
    assert "\n" not in msg
    assert "component of 9 vertices" in msg
    vertex = int(re.search(r"vertex (\d+)", msg).group(1))
    assert 16 <= vertex < 25  # a vertex of the empty 3x3 grid
    assert isinstance(exc.value, ManifillError) and isinstance(exc.value, ValueError)


@pytest.mark.parametrize("solver", SOLVERS)
@pytest.mark.parametrize("weights", ["cotan", "uniform", "intrinsic"])
def test_empty_component_nan(two_component_mesh, solver, weights):
    V, F = two_component_mesh
    b, bc = np.array([0, 3, 12, 15, 5]), np.array([0.0, 1.0, 2.0, 3.0, -1.0])
    hs = HarmonicSolver(V, F, b, weights=weights, solver=solver, on_empty="nan", tol=1e-13)
    x = hs.solve(bc)
    assert np.isnan(x[16:]).all()
    assert np.isfinite(x[:16]).all()
    alone = harmonic(V[:16], F[F.max(axis=1) < 16], b, bc, weights=weights)
    np.testing.assert_allclose(x[:16], alone, rtol=0, atol=1e-9)
    (empty,) = hs.report["empty_components"]
    assert empty["vertices"] == 9 and 16 <= empty["example_vertex"] < 25


# ---------------------------------------------------------------------------
# invariances
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("weights", WEIGHTS)
@pytest.mark.parametrize("s", [1e-6, 1e6])
def test_invariant_under_scaling(weights, s):
    V, F = irregular()
    b, bc = random_problem(V, seed=10)
    np.testing.assert_allclose(
        harmonic(V * s, F, b, bc, weights=weights), harmonic(V, F, b, bc, weights=weights), rtol=0, atol=1e-10
    )


@pytest.mark.parametrize("weights", WEIGHTS)
def test_invariant_under_translation(weights):
    V, F = icosphere(2)
    b, bc = random_problem(V, seed=11)
    x = harmonic(V, F, b, bc, weights=weights)
    xt = harmonic(V + np.array([1e6, 2e6, -1e6]), F, b, bc, weights=weights)
    np.testing.assert_allclose(xt, x, rtol=0, atol=1e-6)


@pytest.mark.parametrize("weights", WEIGHTS)
def test_invariant_under_relabelling(weights):
    V, F = irregular()
    b, bc = random_problem(V, seed=12, p=2)
    rng = np.random.default_rng(13)
    perm = rng.permutation(len(V))
    V2, F2, inv = relabel(V, F, perm, rng)
    x = harmonic(V, F, b, bc, weights=weights)
    np.testing.assert_allclose(harmonic(V2, F2, inv[b], bc, weights=weights), x[perm], rtol=0, atol=1e-12)


@hsettings
@given(perm=st.permutations(range(len(IRREGULAR5[0]))), seed=st.integers(0, 2**32 - 1))
def test_relabelling_any_permutation(perm, seed):
    V, F = IRREGULAR5
    b, bc = random_problem(V, seed=5, k=5)
    perm = np.array(perm)
    V2, F2, inv = relabel(V, F, perm, np.random.default_rng(seed))
    x = harmonic(V, F, b, bc)
    np.testing.assert_allclose(harmonic(V2, F2, inv[b], bc), x[perm], rtol=0, atol=1e-12)


# ---------------------------------------------------------------------------
# odd meshes
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("weights", WEIGHTS)
def test_nonmanifold_edge_does_not_crash(weights):
    V, F = nonmanifold()
    b, bc = [2, 3, 4], [0.0, 1.0, 2.0]
    x = harmonic(V, F, b, bc, weights=weights)
    np.testing.assert_array_equal(x[b], bc)
    assert np.isfinite(x).all()
    if weights != "cotan":
        assert_max_principle(x, bc)


def test_iterate_gives_each_column_its_own_accuracy():
    V, F = icosphere(3)
    b = np.arange(0, len(V), 25)
    bc = np.column_stack([V[b, 0] * 1e6, V[b, 1] * 1e-3])
    exact = HarmonicSolver(V, F, b, solver="direct").solve(bc)
    x = HarmonicSolver(V, F, b, solver="iterate", tol=1e-12).solve(bc)
    for j in range(2):
        assert np.abs(x[:, j] - exact[:, j]).max() <= 1e-6 * np.ptp(bc[:, j])


@pytest.mark.parametrize("x0", [np.zeros(5), np.zeros((7, 2)), "abc"])
def test_bad_initial_guess_is_a_sample_error(x0):
    V, F = icosphere(1)
    hs = HarmonicSolver(V, F, [0, 5, 9], solver="iterate")
    with pytest.raises(SampleError):
        hs.solve([1.0, 2.0, 3.0], x0=x0)


def test_nan_initial_guess_is_refused():
    V, F = icosphere(1)
    hs = HarmonicSolver(V, F, [0, 5, 9], solver="iterate")
    with pytest.raises(SampleError, match="x0"):
        hs.solve([1.0, 2.0, 3.0], x0=np.full(len(V), np.nan))


def test_from_laplacian_accepts_integer_matrices_and_refuses_nan():
    import scipy.sparse as sp
    W = sp.diags([1, 1], [-1, 1], shape=(6, 6), dtype=np.int64)
    L = (sp.diags(np.asarray(W.sum(axis=1)).ravel(), dtype=np.int64) - W).astype(np.int64)
    for solver in ("direct", "iterate", "amg"):
        x = HarmonicSolver.from_laplacian(L, [0, 5], solver=solver, tol=1e-12).solve([0.0, 5.0])
        np.testing.assert_allclose(x, np.arange(6.0), atol=1e-8)
    Ln = sp.csr_array(L, dtype=float)
    Ln.data[0] = np.nan
    with pytest.raises(MeshError, match="NaN"):
        HarmonicSolver.from_laplacian(Ln, [0, 5])
    with pytest.raises(MeshError, match="square"):
        HarmonicSolver.from_laplacian(sp.csr_array(np.ones((3, 4))), [0])
    with pytest.raises(MeshError, match="sparse matrix"):
        HarmonicSolver.from_laplacian("abc", [0])


# ---------------------------------------------------------------------------
# tetrahedra (V, T): the same call, told apart by the width of the element array
# ---------------------------------------------------------------------------


def kuhn_cube(n=5):
    """The unit cube's n^3 lattice, each cell cut into the 6 Kuhn tets along its diagonal (no obtuse dihedral angle)."""
    import itertools

    g = np.linspace(0.0, 1.0, n)
    V = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    T = []
    for cell in itertools.product(range(n - 1), repeat=3):
        for order in itertools.permutations(range(3)):
            p, tet = np.array(cell), []
            tet.append(int(np.ravel_multi_index(p, (n, n, n))))
            for axis in order:
                p = p.copy()
                p[axis] += 1
                tet.append(int(np.ravel_multi_index(p, (n, n, n))))
            T.append(tet)
    return V, np.array(T, dtype=np.int64)


def jittered_cube(n=6, seed=0):
    """Delaunay tets of the cube's lattice with the inner points moved: no two tets alike, obtuse angles."""
    from scipy.spatial import Delaunay

    from manifill.mesh.tetmesh import tet_volumes

    V, _ = kuhn_cube(n)
    inner = ((V > 0) & (V < 1)).all(axis=1)
    V[inner] += np.random.default_rng(seed).uniform(-0.25, 0.25, (int(inner.sum()), 3)) / (n - 1)
    T = Delaunay(V).simplices.astype(np.int64)
    return V, T[np.abs(tet_volumes(V, T)) > 1e-9]


def cube_boundary(V):
    return np.flatnonzero(((V == 0) | (V == 1)).any(axis=1))


@pytest.mark.parametrize("solver", SOLVERS)
def test_tets_reproduce_a_linear_function(solver):
    # the P1 stiffness is exact for linear functions: fixed on the cube's faces, one is reproduced inside
    V, T = jittered_cube()
    b = cube_boundary(V)
    u = V @ np.array([1.5, -2.0, 0.7]) + 0.3
    x = harmonic(V, T, b, u[b], solver=solver, tol=1e-13, maxiter=20000)
    assert b.size < len(V) - 50  # many vertices inside
    np.testing.assert_allclose(x, u, rtol=0, atol=1e-8 if solver != "direct" else 1e-12)
    # uniform weights ignore geometry: not exact on this mesh (the test can tell the weights apart)
    assert np.abs(harmonic(V, T, b, u[b], weights="uniform") - u).max() > 1e-3


def test_tets_equal_biharmonic_k1_and_the_solid_fill():
    from manifill import biharmonic
    from manifill.solid.fill import tet_fill

    V, T = jittered_cube(seed=4)
    b, bc = random_problem(V, seed=7, p=2)
    for weights in ("cotan", "uniform"):
        x = harmonic(V, T, b, bc, weights=weights)
        np.testing.assert_array_equal(x[b], bc)
        np.testing.assert_allclose(x, biharmonic(V, T, b, bc, k=1, weights=weights), rtol=0, atol=1e-10)
        np.testing.assert_allclose(x, tet_fill(V, T, b, bc, weights=weights), rtol=0, atol=1e-10)
    assert np.abs(harmonic(V, T, b, bc) - harmonic(V, T, b, bc, weights="uniform")).max() > 1e-3


@pytest.mark.parametrize("mesh, weights", [(kuhn_cube, "cotan"), (kuhn_cube, "uniform"), (jittered_cube, "uniform")])
def test_tets_maximum_principle_where_the_weights_are_non_negative(mesh, weights):
    V, T = mesh()
    solver = HarmonicSolver(V, T, random_problem(V, seed=2)[0], weights=weights)
    W = solver.L.tocoo()
    assert (W.data[W.row != W.col] <= 1e-12).all()  # every weight w_ij = -L_ij >= 0: the principle must hold
    for seed in range(3):
        bc = np.random.default_rng(seed).uniform(-2.0, 3.0, solver.idx.size)
        x = solver.solve(bc)
        assert_max_principle(x, bc)
        free = np.setdiff1d(np.arange(len(V)), solver.idx)
        assert np.ptp(x[free]) > 0  # a real fill, not constants


def test_tets_solver_object_and_report():
    V, T = kuhn_cube(4)
    b = cube_boundary(V)
    s = HarmonicSolver(V, T, b)
    assert s.L.shape == (64, 64) and s.report["weights"] == "cotan" and s.report["unknowns"] == 8
    bc = np.column_stack([V[b, 0], V[b, 1] * V[b, 2]])
    np.testing.assert_array_equal(s.solve(bc)[:, 1], s.solve(bc[:, 1]))
    np.testing.assert_allclose(s.solve(bc[:, 0]), V[:, 0], rtol=0, atol=1e-13)


@pytest.mark.parametrize("width", [1, 2, 5])
def test_element_widths_other_than_3_or_4_are_a_clear_error(width):
    V, T = kuhn_cube(3)
    F = np.tile(T, 2)[:, :width]
    for call in (lambda: harmonic(V, F, [0, 26], [0.0, 1.0]), lambda: HarmonicSolver(V, F, [0, 26])):
        with pytest.raises(MeshError) as info:
            call()
        msg = str(info.value)
        assert f", {width})" in msg and "(m, 3)" in msg and "(m, 4)" in msg and "\n" not in msg


@pytest.mark.parametrize("weights", ["intrinsic", "robust"])
def test_tets_refuse_triangle_only_weights(weights):
    from manifill import OptionError

    V, T = kuhn_cube(3)
    with pytest.raises(OptionError, match="tetrahedra take 'cotan' or 'uniform'"):
        harmonic(V, T, [0, 26], [0.0, 1.0], weights=weights)
