"""The Laplacians L = D - W and the lumped mass matrix M: null space, symmetry, references, invariances."""


import numpy as np
import pytest
import scipy.sparse as sp

from conftest import (
    FLAT,
    MESHES,
    adjacency_dense,
    boundary_vertices,
    dense,
    edge_set,
    grid,
    icosphere,
    irregular,
    lattice,
    nonmanifold,
    obtuse,
    relabel,
)
from manifill import MeshError, OptionError, laplacian
from manifill.mesh.geometry import cotangents, face_areas, vertex_areas
from manifill.mesh.laplacian import mass_matrix

WEIGHTS = ("uniform", "cotan", "intrinsic", "robust")
mesh_params = pytest.mark.parametrize("mesh", list(MESHES), ids=list(MESHES))
weight_params = pytest.mark.parametrize("weights", WEIGHTS)


def offdiag(L):
    """Dense off-diagonal part of L."""
    D = dense(L).copy()
    np.fill_diagonal(D, 0.0)
    return D


# ---------------------------------------------------------------------------
# hand-computed cases
# ---------------------------------------------------------------------------


def test_cotan_single_right_triangle(single_triangle):
    # angles 90 (at 0), 45, 45: w_01 = w_02 = cot(45)/2 = 1/2, w_12 = cot(90)/2 = 0
    L = laplacian(*single_triangle, weights="cotan")
    expected = [[1.0, -0.5, -0.5], [-0.5, 0.5, 0.0], [-0.5, 0.0, 0.5]]
    np.testing.assert_allclose(dense(L), expected, atol=1e-15)


def test_cotan_equilateral_triangle():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, np.sqrt(3) / 2, 0]])
    w = 1 / (2 * np.sqrt(3))  # cot(60 deg) / 2
    L = laplacian(V, [[0, 1, 2]], weights="cotan")
    np.testing.assert_allclose(dense(L), [[2 * w, -w, -w], [-w, 2 * w, -w], [-w, -w, 2 * w]], atol=1e-15)


def test_two_triangles_sum_their_weights():
    # unit square split along 0-2: both angles opposite the diagonal are right angles
    V = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    L = laplacian(V, [[0, 1, 2], [0, 2, 3]], weights="cotan")
    assert L[0, 2] == 0.0 and L[1, 3] == 0.0
    np.testing.assert_allclose(L[0, 1], -0.5, atol=1e-15)
    np.testing.assert_allclose(L[0, 0], 1.0, atol=1e-15)


# ---------------------------------------------------------------------------
# properties of every weight on every mesh
# ---------------------------------------------------------------------------


@mesh_params
@weight_params
def test_constants_in_null_space(mesh, weights):
    V, F = MESHES[mesh]()
    L = laplacian(V, F, weights=weights)
    scale = abs(L).max()
    assert scale > 0
    np.testing.assert_allclose(L @ np.ones(len(V)), 0.0, atol=1e-12 * scale)
    np.testing.assert_allclose(L @ np.full(len(V), -7.25), 0.0, atol=1e-11 * scale)


@mesh_params
@weight_params
def test_symmetric(mesh, weights):
    V, F = MESHES[mesh]()
    L = laplacian(V, F, weights=weights)
    assert L.shape == (len(V), len(V))
    assert abs(L - L.T).max() <= 1e-14 * abs(L).max()


@mesh_params
@weight_params
def test_positive_semidefinite(mesh, weights):
    V, F = MESHES[mesh]()
    L = dense(laplacian(V, F, weights=weights))
    lam = np.linalg.eigvalsh((L + L.T) / 2)
    assert lam[0] >= -1e-10
    # the null space is exactly the constants per component: one zero eigenvalue each
    ncomp = 2 if mesh == "two_components" else 1
    assert np.count_nonzero(lam < 1e-9) == ncomp


@mesh_params
def test_cotan_equals_minus_igl_cotmatrix(mesh):
    V, F = MESHES[mesh]()
    L = dense(laplacian(V, F, weights="cotan"))
    igl = pytest.importorskip("igl")
    C = dense(igl.cotmatrix(V, np.asarray(F, dtype=np.int64)))
    np.testing.assert_allclose(L, -C, rtol=0, atol=1e-12 * abs(C).max())


@mesh_params
def test_uniform_is_degree_minus_adjacency(mesh):
    V, F = MESHES[mesh]()
    A = adjacency_dense(F, len(V))
    L = dense(laplacian(V, F, weights="uniform"))
    np.testing.assert_array_equal(L, np.diag(A.sum(axis=1)) - A)


# ---------------------------------------------------------------------------
# intrinsic Delaunay weights
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "mesh",
    [lambda: icosphere(1), lambda: icosphere(2), lambda: lattice(6)],
    ids=["icosphere1", "icosphere2", "equilateral_lattice"],
)
def test_intrinsic_equals_cotan_on_acute_mesh(mesh):
    V, F = mesh()
    Lc = dense(laplacian(V, F, weights="cotan"))
    Li = dense(laplacian(V, F, weights="intrinsic"))
    i, j = np.array(sorted(edge_set(F))).T
    assert Lc[i, j].max() < 0  # the mesh is Delaunay: every cotan weight positive
    np.testing.assert_allclose(Li, Lc, rtol=0, atol=1e-12 * abs(Lc).max())


def test_intrinsic_has_no_negative_weight_where_cotan_does(obtuse_mesh):
    V, F = obtuse_mesh
    Wc = -offdiag(laplacian(V, F, weights="cotan"))
    Wi = -offdiag(laplacian(V, F, weights="intrinsic"))
    assert Wc.min() < -0.1  # the obtuse mesh is far from Delaunay
    assert Wi.min() >= -1e-12
    # the flips do not change the operator's action on constants or its definiteness
    assert np.linalg.eigvalsh(-Wi + np.diag(Wi.sum(axis=1)))[0] >= -1e-10


# ---------------------------------------------------------------------------
# invariances
# ---------------------------------------------------------------------------


@weight_params
@pytest.mark.parametrize("s", [1e-6, 1e6])
def test_invariant_under_scaling(weights, s):
    V, F = irregular()
    V = V @ np.array([[0.8, 0.6, 0.0], [-0.6, 0.8, 0.0], [0.0, 0.0, 1.0]])  # not axis-aligned
    L = dense(laplacian(V, F, weights=weights))
    Ls = dense(laplacian(V * s, F, weights=weights))
    np.testing.assert_allclose(Ls, L, rtol=0, atol=1e-10 * abs(L).max())


@weight_params
def test_invariant_under_translation(weights):
    V, F = irregular()
    L = dense(laplacian(V, F, weights=weights))
    Lt = dense(laplacian(V + np.array([1e6, -1e6, 1e6]), F, weights=weights))
    # V + 1e6 keeps ~10 significant digits of the coordinates, and no more
    np.testing.assert_allclose(Lt, L, rtol=0, atol=1e-6 * abs(L).max())


@weight_params
@pytest.mark.parametrize("mesh", [irregular, lambda: icosphere(1), obtuse], ids=["irregular", "icosphere", "obtuse"])
def test_relabelling_permutes_L(weights, mesh):
    V, F = mesh()
    rng = np.random.default_rng(7)
    perm = rng.permutation(len(V))
    V2, F2, _ = relabel(V, F, perm, rng)
    L = dense(laplacian(V, F, weights=weights))
    L2 = dense(laplacian(V2, F2, weights=weights))
    np.testing.assert_allclose(L2, L[np.ix_(perm, perm)], rtol=0, atol=1e-12 * abs(L).max())


# ---------------------------------------------------------------------------
# linear precision of the cotan Laplacian
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("mesh", list(FLAT), ids=list(FLAT))
def test_cotan_linear_precision(mesh):
    V, F = FLAT[mesh]()
    rng = np.random.default_rng(3)
    a, c = rng.normal(size=3), rng.normal()
    interior = ~boundary_vertices(F, len(V))
    assert interior.any()
    L = laplacian(V, F, weights="cotan")
    f = V @ a + c
    r = L @ f
    assert np.abs(r[interior]).max() <= 1e-12 * np.abs(f).max() * abs(L).max()


def test_cotan_linear_precision_on_a_tilted_plane():
    V, F = irregular()
    Q, _ = np.linalg.qr(np.random.default_rng(4).normal(size=(3, 3)))  # a rotation (or reflection)
    V3 = V @ Q.T + np.array([0.3, -2.0, 5.0])
    interior = ~boundary_vertices(F, len(V))
    a, c = np.array([1.5, -0.5, 2.0]), 0.25
    r = laplacian(V3, F, weights="cotan") @ (V3 @ a + c)
    assert np.abs(r[interior]).max() <= 1e-11


def test_uniform_lacks_linear_precision_on_irregular_mesh():
    # the control for the test above: geometry-blind weights do not reproduce x
    V, F = irregular()
    interior = ~boundary_vertices(F, len(V))
    r = laplacian(V, F, weights="uniform") @ V[:, 0]
    assert np.abs(r[interior]).max() > 1e-3


# ---------------------------------------------------------------------------
# sparsity pattern
# ---------------------------------------------------------------------------


def stored_pattern(L):
    """Stored (i, j) positions of a CSR matrix, off the diagonal, and the stored diagonal."""
    L = sp.csr_array(L)
    rows = np.repeat(np.arange(L.shape[0]), np.diff(L.indptr))
    off = {(int(i), int(j)) for i, j in zip(rows, L.indices) if i != j}
    diag = {int(i) for i, j in zip(rows, L.indices) if i == j}
    return off, diag


@pytest.mark.parametrize("weights", ["uniform", "cotan"])
@pytest.mark.parametrize("mesh", ["grid_right", "irregular", "obtuse", "two_components"])
def test_pattern_is_mesh_adjacency(weights, mesh):
    V, F = MESHES[mesh]()
    L = laplacian(V, F, weights=weights)
    off, diag = stored_pattern(L)
    E = edge_set(F)
    assert off == E | {(j, i) for i, j in E}
    assert diag == set(range(len(V)))


def test_zero_cotan_weights_stay_stored():
    # on the right-diagonal grid every diagonal edge has two right angles opposite:
    # weight exactly 0, but the edge is still there
    V, F = grid(5, diagonal="right")
    L = sp.csr_array(laplacian(V, F, weights="cotan"))
    assert np.count_nonzero(L.data == 0.0) == 2 * 16  # 16 diagonal edges, stored both ways
    off, _ = stored_pattern(L)
    E = edge_set(F)
    assert off == E | {(j, i) for i, j in E}


def test_cotan_equals_face_by_face_reference():
    # slow reference: every face adds its three half cotangents to both entries of its edges
    V, F = irregular(12, seed=5)
    C = cotangents(V, F)
    n = len(V)
    ref = np.zeros((n, n))
    for f, c in zip(F, C):
        for k in range(3):
            i, j = f[(k + 1) % 3], f[(k + 2) % 3]
            ref[i, j] -= c[k]
            ref[j, i] -= c[k]
    ref[np.diag_indices(n)] = -ref.sum(axis=1)
    np.testing.assert_allclose(dense(laplacian(V, F, weights="cotan")), ref, rtol=0, atol=1e-13)


# ---------------------------------------------------------------------------
# input handling
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("dtype", [np.int8, np.int16, np.int32, np.uint32, np.int64])
@weight_params
def test_face_integer_dtypes_accepted(dtype, weights):
    V, F = grid(5)
    L = laplacian(V, F.astype(np.int64), weights=weights)
    Ld = laplacian(V, F.astype(dtype), weights=weights)
    np.testing.assert_array_equal(dense(Ld), dense(L))


def test_flat_2d_input_equals_z0():
    V, F = irregular()
    np.testing.assert_array_equal(dense(laplacian(V[:, :2], F)), dense(laplacian(V, F)))


def test_unknown_weights_is_an_option_error(single_triangle):
    with pytest.raises(OptionError, match="weights='cot'.*'uniform'.*'cotan'"):
        laplacian(*single_triangle, weights="cot")


def with_degenerate_face():
    V, F = grid(3)
    V = np.vstack([V, [[2.0, 0.0, 0.0], [3.0, 0.0, 0.0]]])  # 9, 10 collinear with vertex 2
    return V, np.vstack([F, [[2, 9, 10]]])


@pytest.mark.parametrize("weights", ["uniform", "robust"])
def test_degenerate_faces_tolerated_by_uniform_and_robust(weights):
    V, F = with_degenerate_face()
    L = laplacian(V, F, weights=weights)
    assert np.isfinite(L.data).all()
    np.testing.assert_allclose(L @ np.ones(len(V)), 0.0, atol=1e-12 * abs(L).max())
    assert np.linalg.eigvalsh(dense(L))[0] >= -1e-10


@pytest.mark.parametrize("weights", ["cotan", "intrinsic"])
def test_degenerate_faces_rejected_by_cotan_and_intrinsic(weights):
    V, F = with_degenerate_face()
    with pytest.raises(MeshError, match="zero area.*faces 8"):
        laplacian(V, F, weights=weights)


@weight_params
def test_nonmanifold_edge(weights):
    V, F = nonmanifold()
    L = dense(laplacian(V, F, weights=weights))
    assert np.isfinite(L).all()
    np.testing.assert_allclose(L, L.T, atol=1e-14)
    np.testing.assert_allclose(L.sum(axis=1), 0.0, atol=1e-12 * abs(L).max())
    assert np.linalg.eigvalsh(L)[0] >= -1e-10


@pytest.mark.parametrize("weights", ["uniform", "cotan"])
def test_unreferenced_vertex_gets_an_empty_row(weights):
    V, F = grid(4)
    V = np.vstack([V, [[5.0, 5.0, 0.0]]])
    L = dense(laplacian(V, F, weights=weights))
    assert not L[-1].any() and not L[:, -1].any()
    np.testing.assert_allclose(L[:-1, :-1], dense(laplacian(V[:-1], F, weights=weights)), rtol=0, atol=1e-14)


# ---------------------------------------------------------------------------
# the lumped mass matrix
# ---------------------------------------------------------------------------

MASS = ("barycentric", "voronoi")
mass_params = pytest.mark.parametrize("mass", MASS)


def jitter(V, F, seed=3, amount=0.05):
    """The mesh with every vertex moved a little: no two triangles alike."""
    return V + amount * np.random.default_rng(seed).standard_normal(V.shape), F


def naive_areas(V, F):
    return 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)


def test_mass_single_right_triangle(single_triangle):
    # area 1/2: a third per corner; Voronoi: the right angle is not obtuse, the circumcentre is the
    # hypotenuse's midpoint, so the right-angled corner gets 1/4 and the two others 1/8 each
    V, F = single_triangle
    np.testing.assert_allclose(mass_matrix(V, F, mass="barycentric").diagonal(), [1 / 6] * 3, rtol=1e-15)
    np.testing.assert_allclose(mass_matrix(V, F, mass="voronoi").diagonal(), [1 / 4, 1 / 8, 1 / 8], rtol=1e-15)


def test_mass_voronoi_equilateral_and_obtuse():
    # equilateral: the Voronoi parts are the thirds; obtuse: half to the obtuse corner, quarters to the others
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, np.sqrt(3) / 2, 0]])
    np.testing.assert_allclose(mass_matrix(V, [[0, 1, 2]], mass="voronoi").diagonal(), [np.sqrt(3) / 12] * 3,
                               rtol=1e-14)
    V = np.array([[0.0, 0, 0], [4, 0, 0], [2, 0.5, 0]])  # obtuse at vertex 2, area 1
    np.testing.assert_allclose(mass_matrix(V, [[0, 1, 2]], mass="voronoi").diagonal(), [0.25, 0.25, 0.5],
                               rtol=1e-15)
    np.testing.assert_allclose(mass_matrix(V, [[0, 1, 2]], mass="barycentric").diagonal(), [1 / 3] * 3, rtol=1e-15)


@pytest.mark.parametrize("mass, igl_kind", [("barycentric", "MASSMATRIX_TYPE_BARYCENTRIC"),
                                            ("voronoi", "MASSMATRIX_TYPE_VORONOI")])
@pytest.mark.parametrize("mesh", [irregular, obtuse, lambda: jitter(*icosphere(2)), lambda: jitter(*grid(6))],
                         ids=["irregular", "obtuse", "icosphere", "grid"])
def test_mass_equals_igl_massmatrix(mass, igl_kind, mesh):
    igl = pytest.importorskip("igl")
    V, F = mesh()
    M = mass_matrix(V, F, mass=mass)
    R = sp.csr_array(igl.massmatrix(V, F.astype(np.int64), getattr(igl, igl_kind)))
    assert M.shape == R.shape
    np.testing.assert_allclose(M.toarray(), R.toarray(), rtol=0, atol=1e-12 * R.diagonal().max())
    np.testing.assert_allclose(M.diagonal(), R.diagonal(), rtol=1e-12)


@mass_params
@mesh_params
def test_mass_is_diagonal_nonnegative_and_sums_to_the_area(mass, mesh):
    V, F = MESHES[mesh]()
    M = mass_matrix(V, F, mass=mass)
    assert M.nnz == len(V) and (M.indices == np.arange(len(V))).all()
    assert (M.diagonal() >= 0).all()
    np.testing.assert_allclose(M.sum(), naive_areas(V, F).sum(), rtol=1e-13)
    np.testing.assert_allclose(face_areas(V, F), naive_areas(V, F), rtol=1e-13)


@mass_params
@pytest.mark.parametrize("s", [1e-150, 1e-6, 3.0, 1e6, 1e150])
def test_mass_scales_as_s_squared_at_any_scale(mass, s):
    V, F = jitter(*icosphere(2))
    M = mass_matrix(V, F, mass=mass).diagonal()
    Ms = mass_matrix(V * s, F, mass=mass).diagonal()
    np.testing.assert_allclose(Ms / s / s, M, rtol=1e-12)


@mass_params
def test_mass_invariant_under_translation_and_relabelling(mass):
    V, F = irregular()
    M = mass_matrix(V, F, mass=mass).diagonal()
    np.testing.assert_allclose(mass_matrix(V + np.array([3.0, -2.0, 5.0]), F, mass=mass).diagonal(), M, rtol=1e-12)
    perm = np.random.default_rng(5).permutation(len(V))
    inv = np.argsort(perm)  # new vertex inv[i] is old vertex i
    Mp = mass_matrix(V[perm], inv[F], mass=mass).diagonal()
    np.testing.assert_allclose(Mp[inv], M, rtol=1e-15)


def test_mass_unreferenced_vertex_and_degenerate_face_weigh_nothing():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0], [9, 9, 9]])
    F = np.array([[0, 1, 2], [0, 1, 3]])  # face 1 is collinear: zero area; vertex 4 is used by no face
    for mass in MASS:
        d = mass_matrix(V, F, mass=mass).diagonal()
        assert d[3] == 0 and d[4] == 0
        np.testing.assert_allclose(d.sum(), 0.5, rtol=1e-15)
        np.testing.assert_allclose(vertex_areas(V, F, kind=mass), d, rtol=0)


def test_mass_with_cotan_stiffness_integrates_the_dirichlet_energy():
    # x' L x for the linear f = a.x on a flat mesh is |a|**2 times the area, and 1' M 1 is the area
    V, F = irregular()
    a = np.array([0.3, -1.2, 0.0])
    f = V @ a
    L = laplacian(V, F, weights="cotan")
    M = mass_matrix(V, F, mass="barycentric")
    np.testing.assert_allclose(f @ (L @ f), (a @ a) * M.sum(), rtol=1e-12)


def test_mass_rejects_bad_input(single_triangle):
    V, F = single_triangle
    with pytest.raises(OptionError, match="mass"):
        mass_matrix(V, F, mass="full")
    with pytest.raises(MeshError, match="outside"):
        mass_matrix(V, [[0, 1, 3]])
    with pytest.raises(MeshError, match="NaN"):
        mass_matrix(np.where(V == 1, np.nan, V), F)


def test_mass_old_keyword_kind_still_works_for_one_release(single_triangle):
    V, F = single_triangle
    with pytest.warns(DeprecationWarning, match="mass="):
        old = mass_matrix(V, F, kind="voronoi").diagonal()
    np.testing.assert_array_equal(old, mass_matrix(V, F, mass="voronoi").diagonal())
    assert not np.array_equal(old, mass_matrix(V, F, mass="barycentric").diagonal())  # the old keyword is not dropped
    with pytest.warns(DeprecationWarning), pytest.raises(OptionError, match="disagree"):
        mass_matrix(V, F, mass="voronoi", kind="barycentric")


def test_mass_of_tetrahedra_is_the_quarter_volume():
    # a unit cube cut into 6 tets around the diagonal 0-7: each tet of volume 1/6 gives 1/24 to each corner
    V = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], dtype=float)
    T = np.array([[0, 1, 3, 7], [0, 3, 2, 7], [0, 2, 6, 7], [0, 6, 4, 7], [0, 4, 5, 7], [0, 5, 1, 7]])
    d = mass_matrix(V, T).diagonal()
    np.testing.assert_allclose(d, np.bincount(T.ravel(), minlength=8) / 24, rtol=1e-14)
    assert d.sum() == pytest.approx(1.0, rel=1e-14)
    with pytest.raises(OptionError, match="mass='barycentric'"):
        mass_matrix(V, T, mass="voronoi")
    with pytest.raises(MeshError, match=r"shape \(6, 5\)"):
        mass_matrix(V, np.c_[T, T[:, :1]])


def test_cotangents_in_blocks_change_no_bit(monkeypatch):
    # the faces are processed block by block: any block size gives the same numbers
    import manifill.mesh.geometry as geometry

    V, F = icosphere(3)
    V = V * (1 + 0.1 * np.random.default_rng(0).standard_normal((len(V), 1)))
    whole, L = cotangents(V, F), laplacian(V, F)
    monkeypatch.setattr(geometry, "_BLOCK", 37)
    np.testing.assert_array_equal(cotangents(V, F), whole)
    np.testing.assert_array_equal(laplacian(V, F).data, L.data)
