"""Tetrahedral meshes: the stiffness Laplacian, boundary faces, volumes, tetgen, bad input."""

import doctest
import functools
import importlib.util
import itertools
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial import Delaunay

import manifill.solid.tets
from manifill import HarmonicSolver, MeshError, OptionError
from manifill.mesh.shapes import icosphere
from manifill.solid.tetrahedralize import tetrahedralize
from manifill.solid.tets import boundary_faces, tet_laplacian, tet_volumes
from manifill.validate import as_tets

hsettings = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                     suppress_health_check=[HealthCheck.too_slow])
HAVE_TETGEN = importlib.util.find_spec("tetgen") is not None
needs_tetgen = pytest.mark.skipif(not HAVE_TETGEN, reason="tetgen is not installed")

# ---------------------------------------------------------------------------
# fixtures and obviously-correct helpers (no manifill code)
# ---------------------------------------------------------------------------


def volumes(V, T):
    """Signed tet volumes by numpy determinants."""
    V, T = np.asarray(V, float), np.asarray(T)
    return np.linalg.det(np.stack([V[T[:, k]] - V[T[:, 0]] for k in (1, 2, 3)], axis=1)) / 6.0


def tet_cube(n=3, *, jitter=0.0, seed=0):
    """Unit cube of n^3 cells, each split into the 6 Kuhn tets along its main diagonal, positively oriented.

    The Kuhn split is the same in every cell, so the mesh is conforming. ``jitter`` moves the
    interior vertices by up to that fraction of the cell size.
    """
    g = np.linspace(0.0, 1.0, n + 1)
    V = np.array([[x, y, z] for x in g for y in g for z in g])

    def idx(c):
        return (c[0] * (n + 1) + c[1]) * (n + 1) + c[2]

    T = []
    for cell in itertools.product(range(n), repeat=3):
        for perm in itertools.permutations(range(3)):
            c, tet = list(cell), [idx(cell)]
            for axis in perm:
                c[axis] += 1
                tet.append(idx(c))
            T.append(tet)
    T = np.array(T, dtype=np.int64)
    neg = volumes(V, T) < 0
    T[neg] = T[neg][:, [0, 1, 3, 2]]
    if jitter:
        inner = ((V > 0) & (V < 1)).all(axis=1)
        V[inner] += np.random.default_rng(seed).uniform(-jitter / n, jitter / n, size=(int(inner.sum()), 3))
    assert (volumes(V, T) > 0.05 / (6 * n**3)).all()  # the fixture is a valid positive mesh
    return V, T


def delaunay(k=60, seed=1):
    """The Delaunay tetrahedralisation of random points in the unit cube (irregular, some obtuse angles)."""
    V = np.random.default_rng(seed).random((k, 3))
    T = Delaunay(V).simplices.astype(np.int64)
    assert (np.abs(volumes(V, T)) > 1e-9).all()
    return V, T


@functools.lru_cache(maxsize=None)
def _ball(k):
    return tetrahedralize(*icosphere(k))


def ball(k=2):
    """The solid unit ball from tetgen on icosphere(k) (copies, the cache stays intact)."""
    TV, TT = _ball(k)
    return TV.copy(), TT.copy()


def edge_set(T):
    """The undirected edges of the tets as (i, j) tuples with i < j, tet by tet."""
    out = set()
    for t in np.asarray(T).tolist():
        for i, j in itertools.combinations(t, 2):
            out.add((min(i, j), max(i, j)))
    return out


def boundary_mask(T, n):
    """Vertices on a face used by exactly one tet, counted face by face."""
    count = {}
    for t in np.asarray(T).tolist():
        for f in itertools.combinations(t, 3):
            key = tuple(sorted(f))
            count[key] = count.get(key, 0) + 1
    mask = np.zeros(n, dtype=bool)
    for f, c in count.items():
        if c == 1:
            mask[list(f)] = True
    return mask


def enclosed_volume(V, F):
    """Divergence theorem: sum of the signed volumes of the cones (origin, face); positive when F is outward."""
    V = np.asarray(V)
    return float(np.einsum("ij,ij->i", np.cross(V[F[:, 0]], V[F[:, 1]]), V[F[:, 2]]).sum() / 6.0)


def one_line(info):
    msg = str(info.value)
    assert msg and "\n" not in msg
    return msg


def linear(X):
    return 0.25 + 2.0 * X[:, 0] - 1.5 * X[:, 1] + 0.5 * X[:, 2]


MESHES = {
    "single": lambda: (np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]), np.array([[0, 1, 2, 3]])),
    "cube1": lambda: tet_cube(1),
    "cube3": lambda: tet_cube(3),
    "jittered": lambda: tet_cube(3, jitter=0.15),
    "delaunay": delaunay,
}
TETGEN_MESHES = {"ball": lambda: ball(2)}
ALL = {**MESHES, **TETGEN_MESHES}


def all_params():
    return [pytest.param(k, marks=needs_tetgen) if k in TETGEN_MESHES else k for k in ALL]


mesh_params = pytest.mark.parametrize("mesh", all_params())
weight_params = pytest.mark.parametrize("weights", ["cotan", "uniform"])

# ---------------------------------------------------------------------------
# the Laplacian
# ---------------------------------------------------------------------------


def test_right_tet_by_hand():
    # barycentric coordinates 1-x-y-z, x, y, z; K = vol * grad . grad with vol = 1/6
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    L = tet_laplacian(V, [[0, 1, 2, 3]])
    expected = np.array([[3, -1, -1, -1], [-1, 1, 0, 0], [-1, 0, 1, 0], [-1, 0, 0, 1]]) / 6
    np.testing.assert_allclose(L.toarray(), expected, atol=1e-15)


def test_regular_tet_weight_is_length_cot_dihedral_over_6():
    # every edge of a regular tet of edge a: w = a cot(theta) / 6, with cos(theta) = 1/3 the dihedral angle
    a = 2.5
    V = a / np.sqrt(8) * np.array([[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    theta = np.arccos(1 / 3)
    w = a / np.tan(theta) / 6
    L = tet_laplacian(V, [[0, 1, 2, 3]]).toarray()
    np.testing.assert_allclose(L, 4 * w * np.eye(4) - w * np.ones((4, 4)), rtol=1e-13)


def exact_stiffness(V, T):
    """The P1 stiffness matrix in rational arithmetic, rounded once at the end (slow, obviously exact).

    With ``e_k = v_k - v_0``, ``c_1 = e_2 x e_3`` (and cyclically), ``c_0 = -c_1 - c_2 - c_3``:
    ``K_ij = c_i . c_j / (6 |e_1 . c_1|)`` per tet.
    """
    P = [[Fraction(x) for x in row] for row in np.asarray(V).tolist()]

    def sub(a, b):
        return [a[k] - b[k] for k in range(3)]

    def cross(a, b):
        return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]

    def dot(a, b):
        return sum(a[k] * b[k] for k in range(3))

    K = {}
    for t in np.asarray(T).tolist():
        e1, e2, e3 = (sub(P[t[k]], P[t[0]]) for k in (1, 2, 3))
        c = [None, cross(e2, e3), cross(e3, e1), cross(e1, e2)]
        c[0] = [-(c[1][k] + c[2][k] + c[3][k]) for k in range(3)]
        six_vol = 6 * abs(dot(e1, c[1]))
        for i, j in itertools.product(range(4), repeat=2):
            K[t[i], t[j]] = K.get((t[i], t[j]), 0) + dot(c[i], c[j]) / six_vol
    out = np.zeros((len(P), len(P)))
    for (i, j), k in K.items():
        out[i, j] = float(k)
    return out


@pytest.mark.parametrize("mesh", ["single", "cube1", "cube3", "jittered", pytest.param("ball", marks=needs_tetgen)])
def test_cotan_equals_igl(mesh):
    V, T = ALL[mesh]()
    L = tet_laplacian(V, T)
    igl = pytest.importorskip("igl")
    ref = -igl.cotmatrix(V, np.ascontiguousarray(T, dtype=np.int64))
    assert abs(L - ref).max() <= 1e-12 * abs(ref).max()


@pytest.mark.parametrize("mesh", ["jittered", "delaunay"])
def test_cotan_equals_exact_stiffness(mesh):
    # the random Delaunay mesh has slivers (volume ratio 1e-4): igl's own rounding reaches 1e-10 there
    V, T = MESHES[mesh]()
    L = tet_laplacian(V, T).toarray()
    K = exact_stiffness(V, T)
    assert np.abs(L - K).max() <= 1e-14 * np.abs(K).max()
    igl = pytest.importorskip("igl")
    ref = -igl.cotmatrix(V, np.ascontiguousarray(T, dtype=np.int64)).toarray()
    assert np.abs(L - ref).max() <= 1e-9 * np.abs(K).max()


@mesh_params
@weight_params
def test_symmetric_constants_in_null_space_sorted(mesh, weights):
    V, T = ALL[mesh]()
    L = tet_laplacian(V, T, weights=weights)
    assert L.has_sorted_indices
    assert abs(L - L.T).max() == 0.0
    assert np.abs(L @ np.ones(len(V))).max() <= 1e-13 * abs(L).max()


@mesh_params
@weight_params
def test_pattern_is_tet_edge_graph_plus_diagonal(mesh, weights):
    V, T = ALL[mesh]()
    L = tet_laplacian(V, T, weights=weights).tocoo()
    stored = {(int(i), int(j)) for i, j in zip(L.row, L.col)}
    edges = edge_set(T)
    assert stored == edges | {(j, i) for i, j in edges} | {(i, i) for i in range(len(V))}
    assert L.nnz == len(stored)  # no duplicates


def test_cube_keeps_zero_weights():
    # Kuhn cubes have edges whose cotan weight cancels to zero: they stay stored
    V, T = tet_cube(2)
    L = tet_laplacian(V, T)
    off = L.data[L.indices != np.repeat(np.arange(len(V)), np.diff(L.indptr))]
    assert np.count_nonzero(np.abs(off) < 1e-14) > 0
    assert off.size == 2 * len(edge_set(T))


@pytest.mark.parametrize("mesh", ["cube1", "jittered", "delaunay"])
@weight_params
def test_positive_semidefinite_with_one_dimensional_kernel(mesh, weights):
    V, T = MESHES[mesh]()
    ev = np.linalg.eigvalsh(tet_laplacian(V, T, weights=weights).toarray())
    assert ev[0] >= -1e-10 * ev[-1]
    assert ev[1] > 1e-8 * ev[-1]  # connected: only the constants


def test_uniform_weights_are_one_per_edge():
    V, T = tet_cube(2, jitter=0.1)
    L = tet_laplacian(V, T, weights="uniform").toarray()
    A = np.zeros_like(L)
    for i, j in edge_set(T):
        A[i, j] = A[j, i] = 1.0
    np.testing.assert_array_equal(L, np.diag(A.sum(axis=1)) - A)


def test_uniform_accepts_zero_volume_tets():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1]])
    T = [[0, 1, 2, 3], [0, 1, 2, 4]]  # the first is flat
    L = tet_laplacian(V, T, weights="uniform")
    assert L[0, 3] == -1 and L[3, 3] == 3
    with pytest.raises(MeshError) as info:
        tet_laplacian(V, T)
    assert "zero volume" in one_line(info) and "tetrahedra 0" in str(info.value)


@pytest.mark.parametrize("s", [1e-6, 1e6])
@pytest.mark.parametrize("mesh", ["jittered", "delaunay"])
def test_stiffness_scales_linearly_with_size(mesh, s):
    V, T = MESHES[mesh]()
    L, Ls = tet_laplacian(V, T), tet_laplacian(s * V, T)
    assert abs(Ls - s * L).max() <= 1e-12 * s * abs(L).max()


@pytest.mark.parametrize("shift", [1e6, -3e7, 1e9])
@pytest.mark.parametrize("mesh", ["jittered", "delaunay"])
def test_far_origin_costs_no_accuracy(mesh, shift):
    # V + shift rounds the geometry itself; (V + shift) - shift is exactly that rounded geometry
    V, T = MESHES[mesh]()
    far = V + shift
    L = tet_laplacian(far - shift, T)
    assert abs(tet_laplacian(far, T) - L).max() <= 1e-12 * abs(L).max()


def test_orientation_and_corner_order_do_not_matter():
    V, T = tet_cube(2, jitter=0.1)
    rng = np.random.default_rng(3)
    T2 = np.array([rng.permutation(t) for t in T])  # about half the tets now negatively oriented
    assert (volumes(V, T2) < 0).any()
    assert abs(tet_laplacian(V, T2) - tet_laplacian(V, T)).max() <= 1e-14 * abs(tet_laplacian(V, T)).max()


# ---------------------------------------------------------------------------
# the harmonic fill with it
# ---------------------------------------------------------------------------


def fill(V, T, weights="cotan", f=linear):
    """Harmonic fill of f from the boundary vertices: (solution, boundary mask)."""
    b = np.flatnonzero(boundary_mask(T, len(V)))
    L = tet_laplacian(V, T, weights=weights)
    return HarmonicSolver.from_laplacian(L, b).solve(f(V[b])), b


@pytest.mark.parametrize("mesh", ["cube3", "jittered", "delaunay", pytest.param("ball", marks=needs_tetgen)])
def test_cotan_reproduces_linear_functions(mesh):
    V, T = ALL[mesh]()
    x, b = fill(V, T)
    assert len(b) < len(V)  # there is an inside to fill
    np.testing.assert_allclose(x, linear(V), rtol=0, atol=1e-10)


def test_uniform_reproduces_linear_functions_on_the_symmetric_kuhn_grid_only():
    V, T = tet_cube(4)
    x, _ = fill(V, T, weights="uniform")
    np.testing.assert_allclose(x, linear(V), rtol=0, atol=1e-10)
    V, T = tet_cube(4, jitter=0.2)
    x, _ = fill(V, T, weights="uniform")
    assert np.abs(x - linear(V)).max() > 1e-3


JITTERED = tet_cube(3, jitter=0.2, seed=5)
JITTERED_B = np.flatnonzero(boundary_mask(JITTERED[1], len(JITTERED[0])))
UNIFORM_SOLVER = HarmonicSolver.from_laplacian(tet_laplacian(*JITTERED, weights="uniform"), JITTERED_B)


@hsettings
@given(bc=arrays(np.float64, len(JITTERED_B), elements=st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)))
def test_uniform_maximum_principle(bc):
    x = UNIFORM_SOLVER.solve(bc)
    slack = 1e-9 * max(1.0, float(np.abs(bc).max()))
    assert x.min() >= bc.min() - slack and x.max() <= bc.max() + slack
    # and each inner value is the plain average of its neighbours
    L = UNIFORM_SOLVER.L
    inner = np.setdiff1d(np.arange(len(x)), JITTERED_B)
    np.testing.assert_allclose((L @ x)[inner], 0.0, atol=1e-9 * max(1.0, float(np.abs(bc).max())))


def smooth(X):
    return np.sin(3 * X[:, 0]) * X[:, 1] + X[:, 2] ** 2


@pytest.mark.parametrize("transform", ["scale 1e-6", "scale 1e6", "shift 1e6"])
@pytest.mark.parametrize("mesh", ["jittered", "delaunay"])
def test_solution_invariant_under_scaling_and_translation(mesh, transform):
    V, T = MESHES[mesh]()
    b = np.flatnonzero(boundary_mask(T, len(V)))
    bc = smooth(V[b])
    x = HarmonicSolver.from_laplacian(tet_laplacian(V, T), b).solve(bc)
    kind, amount = transform.split()
    if kind == "scale":
        V2 = V * float(amount)
    else:  # compare with the geometry that V + amount actually holds
        V2 = V + float(amount)
        x = HarmonicSolver.from_laplacian(tet_laplacian(V2 - float(amount), T), b).solve(bc)
    x2 = HarmonicSolver.from_laplacian(tet_laplacian(V2, T), b).solve(bc)
    np.testing.assert_allclose(x2, x, rtol=0, atol=1e-11)


def test_solution_invariant_under_relabelling():
    V, T = tet_cube(3, jitter=0.15)
    rng = np.random.default_rng(7)
    perm = rng.permutation(len(V))  # new vertex i is old vertex perm[i]
    inv = np.empty_like(perm)
    inv[perm] = np.arange(len(perm))
    T2 = inv[T][rng.permutation(len(T))]
    b = np.flatnonzero(boundary_mask(T, len(V)))
    bc = smooth(V[b])
    x = HarmonicSolver.from_laplacian(tet_laplacian(V, T), b).solve(bc)
    x2 = HarmonicSolver.from_laplacian(tet_laplacian(V[perm], T2), inv[b]).solve(bc)
    np.testing.assert_allclose(x2, x[perm], rtol=0, atol=1e-12)


# ---------------------------------------------------------------------------
# volumes and boundary faces
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("mesh", ["cube1", "cube3", "jittered", "delaunay"])
def test_volumes_are_signed_determinants(mesh):
    V, T = MESHES[mesh]()
    np.testing.assert_allclose(tet_volumes(V, T), volumes(V, T), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(tet_volumes(V, T[:, [1, 0, 2, 3]]), -volumes(V, T), rtol=1e-12, atol=1e-15)
    if mesh != "delaunay":
        assert tet_volumes(V, T).sum() == pytest.approx(1.0, rel=1e-12)


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_boundary_faces_of_cube(n):
    V, T = tet_cube(n)
    F = boundary_faces(T)
    assert F.shape == (12 * n * n, 3) and F.dtype == np.int64
    # every face lies in one side of the cube, and its normal points away from the cube
    P, rows = V[F], np.arange(len(F))
    flat = np.ptp(P, axis=1) == 0  # the axes along which a face is constant
    assert (flat.sum(axis=1) == 1).all()
    axis = flat.argmax(axis=1)
    side = P[rows, 0, axis]
    assert np.isin(side, [0.0, 1.0]).all()
    normal = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    assert (normal[rows, axis] * np.where(side == 1, 1.0, -1.0) > 0).all()
    assert enclosed_volume(V, F) == pytest.approx(1.0, rel=1e-12)


@pytest.mark.parametrize("mesh", all_params())
def test_boundary_faces_enclose_the_volume(mesh):
    V, T = ALL[mesh]()
    F = boundary_faces(T, V=V)
    total = float(np.abs(volumes(V, T)).sum())
    assert total > 0 and enclosed_volume(V, F) == pytest.approx(total, rel=1e-12)
    assert {tuple(sorted(f)) for f in F.tolist()} == {
        f for f, c in _face_counts(T).items() if c == 1
    }


def _face_counts(T):
    count = {}
    for t in np.asarray(T).tolist():
        for f in itertools.combinations(t, 3):
            key = tuple(sorted(f))
            count[key] = count.get(key, 0) + 1
    return count


def test_boundary_faces_follow_orientation_only_when_told():
    V, T = tet_cube(2)
    flipped = T[:, [1, 0, 2, 3]]
    assert enclosed_volume(V, boundary_faces(flipped, V=V)) == pytest.approx(1.0, rel=1e-12)
    assert enclosed_volume(V, boundary_faces(flipped)) == pytest.approx(-1.0, rel=1e-12)  # taken as positive
    mixed = T.copy()
    mixed[::2] = flipped[::2]
    assert enclosed_volume(V, boundary_faces(mixed, V=V)) == pytest.approx(1.0, rel=1e-12)


def test_shared_face_is_not_on_the_boundary():
    F = boundary_faces([[0, 1, 2, 3], [1, 2, 3, 4]])
    assert len(F) == 6 and [1, 2, 3] not in np.sort(F, axis=1).tolist()


# ---------------------------------------------------------------------------
# bad input
# ---------------------------------------------------------------------------

UNIT = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])


@pytest.mark.parametrize(
    "V, T, words",
    [
        (UNIT, [[0, 1, 2]], "shape (1, 3)"),
        (UNIT, [[0, 1, 2, 4]], "outside 0..3"),
        (UNIT, [[0, -1, 2, 3]], "outside 0..3"),
        (UNIT, [[0.5, 1, 2, 3]], "integers"),
        (UNIT, np.empty((0, 4), int), "empty"),
        (np.r_[UNIT[:3], [[np.nan, 0, 0]]], [[0, 1, 2, 3]], "NaN"),
        (UNIT[:, :2], [[0, 1, 2, 3]], "(n, 3)"),
        (np.r_[UNIT[:3], [[1.0, 1.0, 0.0]]], [[0, 1, 2, 3]], "zero volume"),
        (UNIT, [[0, 1, 2, 3], [0, 1, 2, 2]], "zero volume"),
    ],
)
@pytest.mark.parametrize("func", ["tet_laplacian", "as_tets", "tet_volumes", "boundary_faces"])
def test_bad_tets(func, V, T, words):
    call = {
        "tet_laplacian": lambda: tet_laplacian(V, T),
        "as_tets": lambda: as_tets(V, T),
        "tet_volumes": lambda: tet_volumes(V, T),
        "boundary_faces": lambda: boundary_faces(T, V=V),
    }[func]
    if words == "zero volume" and func in ("tet_volumes", "boundary_faces"):
        call()  # volumes and faces are defined for flat tets
        return
    with pytest.raises(MeshError) as info:
        call()
    assert words in one_line(info)


def test_bad_tets_without_positions():
    for T, words in [([[0, 1, 2]], "shape"), ([[0, -1, 2, 3]], "outside"), ([[0.5, 1, 2, 3]], "integers"),
                     ([[np.nan, 1, 2, 3]], "integers"), ([[0, 1], [2]], "ragged")]:
        with pytest.raises(MeshError) as info:
            boundary_faces(T)
        assert words in one_line(info)


def test_unreferenced_vertices():
    V = np.r_[UNIT, [[5.0, 5, 5]]]
    with pytest.raises(MeshError) as info:
        as_tets(V, [[0, 1, 2, 3]])
    assert "vertices 4" in one_line(info)
    assert as_tets(V, [[0, 1, 2, 3]], allow_unreferenced=True)[0].shape == (5, 3)
    assert tet_laplacian(V, [[0, 1, 2, 3]]).shape == (5, 5)  # a lone vertex is its own component


def test_bad_weights():
    with pytest.raises(OptionError) as info:
        tet_laplacian(UNIT, [[0, 1, 2, 3]], weights="robust")
    assert "'cotan'" in one_line(info)


def test_doctests():
    flags = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    result = doctest.testmod(manifill.solid.tets, optionflags=flags)
    assert result.attempted > 0 and result.failed == 0


def test_surface_volume_is_the_volume_of_its_tets():
    from manifill.solid.tets import surface_volume

    if not HAVE_TETGEN:
        pytest.skip("needs tetgen")
    V, F = icosphere(2)
    TV, TT = tetrahedralize(V, F, max_volume=0.01)
    vol = tet_volumes(TV, TT).sum()  # the surface is kept, so the tets fill exactly the polyhedron
    assert surface_volume(V, F) == pytest.approx(vol, rel=1e-12)
    assert surface_volume(V, F[:, ::-1]) == pytest.approx(vol, rel=1e-12)  # either orientation
    assert surface_volume(V * [2.0, 1.0, 0.5] + 1e6, F) == pytest.approx(vol, rel=1e-9)  # scale, far origin
    cube = np.array([[x, y, z] for x in (0, 2) for y in (0, 3) for z in (0, 5)], dtype=float)
    hull = Delaunay(cube).convex_hull
    a, b, c = cube[hull[:, 0]], cube[hull[:, 1]], cube[hull[:, 2]]
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), a - cube.mean(axis=0)) < 0
    hull[inward] = hull[inward][:, ::-1]  # the hull's triangles come in either orientation
    assert surface_volume(cube, hull) == pytest.approx(30.0)


def test_surface_volume_matches_vtk():
    pv = pytest.importorskip("pyvista")
    from manifill.solid.tets import surface_volume

    V, F = icosphere(3)
    V = V * [1.0, 0.5, 2.0]
    mesh = pv.PolyData(V, np.column_stack([np.full(len(F), 3), F]).ravel())
    assert surface_volume(V, F) == pytest.approx(mesh.volume, rel=1e-9)
