"""Biharmonic and triharmonic interpolation: libigl's numbers, exactness, linear precision, invariances.

Linear precision, as it holds exactly: with cotangent weights ``L u = 0`` at every
interior vertex for a linear ``u`` on a flat mesh (or any tet mesh), but not at
the mesh's boundary vertices, so ``A u = L (M^-1 L)^(k-1) u`` vanishes at every
vertex at least ``k`` rings away from the boundary. Hence the k-harmonic fill
reproduces a linear field exactly when the outer ``k`` rings of vertices are
fixed (and whatever is fixed inside); fixing the boundary alone does not (the
natural boundary conditions bend it), which is checked too.
"""

import importlib.util

import numpy as np
import pytest
import scipy.sparse as sp

from conftest import icosphere, irregular, relabel, two_components
from manifill import MeshError, OptionError, SampleError, SolveError
from manifill.solid.tets import tet_mass_matrix, tet_volumes
from manifill.surface.polyharmonic import PolyharmonicSolver, biharmonic

igl = pytest.importorskip("igl")
HAVE_TETGEN = importlib.util.find_spec("tetgen") is not None
needs_tetgen = pytest.mark.skipif(not HAVE_TETGEN, reason="tetgen is not installed")


def curved():
    """An irregular closed surface: icosphere(3) with every vertex moved radially at random."""
    V, F = icosphere(3)
    r = 1.0 + 0.15 * np.random.default_rng(4).uniform(-1.0, 1.0, len(V))
    return V * r[:, None], F


_BALL = {}


def ball():
    """The solid ball from tetgen on icosphere(2) (cached; copies returned)."""
    if not _BALL:
        from manifill.mesh.shapes import icosphere as ico
        from manifill.solid.tetrahedralize import tetrahedralize

        _BALL["m"] = tetrahedralize(*ico(2))
    V, T = _BALL["m"]
    return np.array(V, dtype=np.float64), np.array(T, dtype=np.int64)


def cube(n=6, seed=0):
    """Delaunay tetrahedra of an n^3 lattice of the unit cube, interior points jittered (no tetgen needed)."""
    from scipy.spatial import Delaunay

    g = np.linspace(0.0, 1.0, n)
    V = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    inner = ((V > 0) & (V < 1)).all(axis=1)
    V[inner] += np.random.default_rng(seed).uniform(-0.2, 0.2, (int(inner.sum()), 3)) / (n - 1)
    T = Delaunay(V).simplices.astype(np.int64)
    return V, T[np.abs(tet_volumes(V, T)) > 1e-12]


def problem(V, seed=0, frac=0.1, p=None):
    rng = np.random.default_rng(seed)
    b = rng.choice(len(V), size=max(6, int(frac * len(V))), replace=False)
    bc = rng.uniform(-2.0, 3.0, size=len(b) if p is None else (len(b), p))
    return b, bc


def igl_harmonic(V, F, b, bc, k):
    bc = np.asarray(bc, dtype=np.float64)
    out = igl.harmonic(V, np.asarray(F, dtype=np.int64), np.asarray(b, dtype=np.int64),
                       bc[:, None] if bc.ndim == 1 else bc, k)
    return out[:, 0] if bc.ndim == 1 else out


MESHES = {"flat": irregular, "curved": curved, "cube": cube,
          "ball": pytest.param(ball, marks=needs_tetgen)}


@pytest.mark.parametrize("k", [2, 3])
@pytest.mark.parametrize("mesh", MESHES.values(), ids=MESHES.keys())
def test_equals_libigl(mesh, k):
    V, F = mesh()
    b, bc = problem(V, seed=k)
    x = biharmonic(V, F, b, bc, k=k, mass="voronoi")  # libigl's mass on triangles (tets: the quarter volume)
    want = igl_harmonic(V, F, b, bc, k)
    assert np.abs(x - want).max() <= 1e-8 * np.ptp(bc)
    assert np.abs(x - want).max() > 0 or k == 1  # not trivially equal: the fill is non-trivial
    assert np.ptp(x) > 0


@pytest.mark.parametrize("mesh", MESHES.values(), ids=MESHES.keys())
def test_barycentric_surface_mass_is_a_different_energy(mesh):
    # the option is honoured (and on tets ignored: always a quarter volume)
    V, F = mesh()
    b, bc = problem(V, seed=5)
    x, y = biharmonic(V, F, b, bc, mass="voronoi"), biharmonic(V, F, b, bc, mass="barycentric")
    if F.shape[1] == 4:
        np.testing.assert_array_equal(x, y)
    else:
        assert np.abs(x - y).max() > 1e-6 * np.ptp(bc)


@pytest.mark.parametrize("solver", ["direct", "amg", "auto"])
@pytest.mark.parametrize("k", [2, 3])
def test_exact_at_idx(solver, k):
    V, F = curved()
    b, bc = problem(V, seed=7)
    x = biharmonic(V, F, b, bc, k=k, solver=solver, tol=1e-12)
    np.testing.assert_array_equal(x[b], bc)
    np.testing.assert_allclose(x, biharmonic(V, F, b, bc, k=k, solver="direct"), rtol=0, atol=1e-8 * np.ptp(bc))


def rings(F, n, count):
    """The vertices at most ``count - 1`` edges from the mesh boundary (faces: triangles or tets)."""
    F = np.asarray(F)
    if F.shape[1] == 4:
        faces = np.sort(np.concatenate([F[:, [0, 1, 2]], F[:, [0, 1, 3]], F[:, [0, 2, 3]], F[:, [1, 2, 3]]]), axis=1)
        u, c = np.unique(faces, axis=0, return_counts=True)
        near = np.zeros(n, bool)
        near[u[c == 1].ravel()] = True
    else:
        e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
        u, c = np.unique(e, axis=0, return_counts=True)
        near = np.zeros(n, bool)
        near[u[c == 1].ravel()] = True
    rows = np.repeat(np.arange(F.shape[0]), F.shape[1])
    cells = sp.csr_array((np.ones(F.size), (rows, F.ravel())), shape=(F.shape[0], n))
    adj = (cells.T @ cells) > 0
    for _ in range(count - 1):
        near = near | ((adj @ near.astype(float)) > 0)
    return near


@pytest.mark.parametrize("k", [2, 3])
@pytest.mark.parametrize("mesh", [irregular, cube], ids=["flat", "cube"])
def test_linear_precision_with_the_outer_k_rings_fixed(mesh, k):
    V, F = mesh()
    u = 0.3 + 2.0 * V[:, 0] - 1.5 * V[:, 1] + (0.7 * V[:, 2] if F.shape[1] == 4 else 0.0)
    inner = np.flatnonzero(~rings(F, len(V), k))
    b = np.r_[np.flatnonzero(rings(F, len(V), k)), inner[::7]]
    x = biharmonic(V, F, b, u[b], k=k)
    assert np.abs(x - u).max() <= 1e-10 * np.ptp(u)
    # with fewer rings fixed the natural boundary conditions bend the field
    b1 = np.flatnonzero(rings(F, len(V), k - 1))
    assert np.abs(biharmonic(V, F, b1, u[b1], k=k) - u).max() > 1e-4 * np.ptp(u)


@pytest.mark.parametrize("s", [1e-3, 1e3, 1e-120, 1e120])
@pytest.mark.parametrize("mesh", MESHES.values(), ids=MESHES.keys())
def test_scale_invariant(mesh, s):
    V, F = mesh()
    b, bc = problem(V, seed=9)
    shift = np.array([5.0, -3.0, 2.0])
    np.testing.assert_allclose(biharmonic(V * s + shift * s, F, b, bc), biharmonic(V, F, b, bc),
                               rtol=0, atol=1e-10 * np.ptp(bc))


def test_relabelling_invariant_triangles():
    V, F = curved()
    b, bc = problem(V, seed=11)
    perm = np.random.default_rng(1).permutation(len(V))
    V2, F2, inv = relabel(V, F, perm, rng=np.random.default_rng(2))
    x2 = biharmonic(V2, F2, inv[b], bc, k=3)
    np.testing.assert_allclose(x2[inv], biharmonic(V, F, b, bc, k=3), rtol=0, atol=1e-10 * np.ptp(bc))


@needs_tetgen
def test_relabelling_invariant_tets():
    V, T = ball()
    b, bc = problem(V, seed=12)
    rng = np.random.default_rng(3)
    perm = rng.permutation(len(V))
    inv = np.empty_like(perm)
    inv[perm] = np.arange(len(V))
    T2 = inv[T][rng.permutation(len(T))][:, [1, 0, 2, 3]]  # reordered, reflected: orientation does not matter
    x2 = biharmonic(V[perm], T2, inv[b], bc)
    np.testing.assert_allclose(x2[inv], biharmonic(V, T, b, bc), rtol=0, atol=1e-10 * np.ptp(bc))


@pytest.mark.parametrize("solver", ["direct", "amg"])
def test_many_columns_equal_column_by_column(solver):
    V, F = curved()
    b, bc = problem(V, seed=13, p=3)
    X = biharmonic(V, F, b, bc, solver=solver, tol=1e-12)
    assert X.shape == (len(V), 3)
    for j in range(3):
        np.testing.assert_allclose(X[:, j], biharmonic(V, F, b, bc[:, j], solver=solver, tol=1e-12),
                                   rtol=0, atol=1e-9 * np.ptp(bc))


@pytest.mark.parametrize("mesh", MESHES.values(), ids=MESHES.keys())
def test_solver_equals_function(mesh):
    V, F = mesh()
    b, bc = problem(V, seed=14, p=2)
    s = PolyharmonicSolver(V, F, b, k=3)
    np.testing.assert_array_equal(s.solve(bc), biharmonic(V, F, b, bc, k=3))
    np.testing.assert_array_equal(s.solve(bc[:, 1]), biharmonic(V, F, b, bc[:, 1], k=3))
    assert s.report["k"] == 3 and s.report["cells"] == ("tets" if F.shape[1] == 4 else "triangles")
    assert s.report["fixed"] == len(b) and s.report["solver"] == "direct"


def test_constants_are_kept_and_data_enter_linearly():
    V, F = curved()
    b, bc = problem(V, seed=15)
    np.testing.assert_allclose(biharmonic(V, F, b, np.full(len(b), 2.5)), 2.5, rtol=0, atol=1e-12)
    b2 = problem(V, seed=16)[1]
    np.testing.assert_allclose(biharmonic(V, F, b, 2 * bc - 3 * b2),
                               2 * biharmonic(V, F, b, bc) - 3 * biharmonic(V, F, b, b2), rtol=0, atol=1e-10)


def test_k1_is_the_harmonic_fill():
    from manifill.surface.harmonic import harmonic

    V, F = curved()
    b, bc = problem(V, seed=17)
    np.testing.assert_allclose(biharmonic(V, F, b, bc, k=1), harmonic(V, F, b, bc), rtol=0, atol=1e-12)


def test_empty_component():
    V, F = two_components()
    with pytest.raises(SolveError, match="no fixed vertex"):
        biharmonic(V, F, [0, 5], [0.0, 1.0])
    x = biharmonic(V, F, [0, 5], [0.0, 1.0], on_empty="nan")
    assert np.isnan(x[16:]).all() and np.isfinite(x[:16]).all()


def test_bad_input():
    V, F = curved()
    with pytest.raises(OptionError, match="solver"):
        biharmonic(V, F, [0, 1], [0.0, 1.0], solver="iterate")
    with pytest.raises(OptionError, match="mass"):
        biharmonic(V, F, [0, 1], [0.0, 1.0], mass="lumped")
    with pytest.raises(OptionError, match="positive integer"):
        biharmonic(V, F, [0, 1], [0.0, 1.0], k=0)
    with pytest.raises(SampleError):
        biharmonic(V, F, [0, 0], [0.0, 1.0])
    with pytest.raises(SampleError):
        biharmonic(V, F, [0, 1], [0.0, np.nan])
    with pytest.raises(MeshError):
        biharmonic(V, F[:, :2], [0, 1], [0.0, 1.0])


@pytest.mark.parametrize("mesh", [cube, pytest.param(ball, marks=needs_tetgen)], ids=["cube", "ball"])
def test_tet_mass_matrix(mesh):
    V, T = mesh()
    M = tet_mass_matrix(V, T)
    want = igl.massmatrix(V, T, igl.MASSMATRIX_TYPE_BARYCENTRIC).diagonal()
    np.testing.assert_allclose(M.diagonal(), want, rtol=1e-12)
    vol = np.abs(tet_volumes(V, T))
    assert M.sum() == pytest.approx(vol.sum(), rel=1e-13)
    one = np.zeros(len(V))
    np.add.at(one, T[:, 2], vol / 4)  # one corner's share
    assert (M.diagonal() >= one - 1e-15).all()
    for s in (1e-100, 1e100):
        np.testing.assert_allclose(tet_mass_matrix(V * s, T).diagonal(), want * s**3, rtol=1e-12)


def test_auto_factorises_the_biharmonic_wherever_pardisos_factor_fits(monkeypatch):
    # with Pardiso, `auto` factorises a biharmonic system of any size whose predicted factor takes at most half the
    # memory available (12.5 s against AMG's 74 s at 655k vertices); without it, AMG above AUTO_DIRECT_MAX unknowns
    from manifill.surface import polyharmonic as ph

    big = 655_000
    monkeypatch.setattr(ph, "direct_factoriser", lambda: "pardiso")
    monkeypatch.setattr(ph, "available_bytes",
                        lambda: 2 * ph.lu_memory(big, ph.PolyharmonicSolver.BIHARMONIC_ROW * big))
    assert ph.PolyharmonicSolver.settings(2, big)[0] == "direct"
    assert ph.PolyharmonicSolver.settings(2, 2 * big)[0] == "amg"  # its factor would take more than half
    monkeypatch.setattr(ph, "direct_factoriser", lambda: "superlu")
    assert ph.PolyharmonicSolver.settings(2, big)[0] == "amg"
    assert ph.PolyharmonicSolver.settings(2, ph.PolyharmonicSolver.AUTO_DIRECT_MAX)[0] == "direct"
    assert ph.PolyharmonicSolver.settings(3, big)[0] == "direct"  # the triharmonic is always factorised
