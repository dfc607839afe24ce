"""Combinatorics: edges, components, boundary loops, Euler characteristic and genus, cleaning."""

import numpy as np
import pytest

from conftest import adjacency_dense, annulus, boundary_vertices, dense, edge_set, grid, icosphere, irregular, nonmanifold, torus, two_components
from manifill import clean_mesh, harmonic, laplacian, mesh_info
import manifill.mesh.topology as topology
from hypothesis import given, settings
from hypothesis import strategies as st
from manifill.mesh.topology import EdgeIndex, adjacency, boundary_loops, connected_components, edges
from manifill.validate import as_mesh, as_samples

TET_V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
TET_F = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])


# ---------------------------------------------------------------------------
# edges and adjacency
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "F, E, count",
    [
        ([[0, 1, 2]], [[0, 1], [0, 2], [1, 2]], [1, 1, 1]),
        ([[2, 1, 0]], [[0, 1], [0, 2], [1, 2]], [1, 1, 1]),
        ([[0, 1, 2], [2, 1, 3]], [[0, 1], [0, 2], [1, 2], [1, 3], [2, 3]], [1, 1, 2, 1, 1]),
        (TET_F, [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]], [2] * 6),
        (nonmanifold()[1], [[0, 1], [0, 2], [0, 3], [0, 4], [1, 2], [1, 3], [1, 4]], [3, 1, 1, 1, 1, 1, 1]),
        ([[5, 7, 9]], [[5, 7], [5, 9], [7, 9]], [1, 1, 1]),  # indices need not start at 0
    ],
    ids=["triangle", "reversed", "two_triangles", "tetrahedron", "nonmanifold", "offset"],
)
def test_edges_hand_made(F, E, count):
    E2, count2 = edges(np.array(F))
    assert E2.tolist() == E
    assert count2.tolist() == count


def _edge_reference(F, n):
    """Slow reference: a dict from each undirected edge to the corners opposite it."""
    corners = {}
    for f, face in enumerate(F.tolist()):
        for k in range(3):
            i, j = face[(k + 1) % 3], face[(k + 2) % 3]
            if i != j:
                corners.setdefault((min(i, j), max(i, j)), []).append((f, k))
    return corners


@st.composite
def face_soups(draw):
    n = draw(st.integers(2, 12))
    m = draw(st.integers(1, 25))
    F = np.array(draw(st.lists(st.lists(st.integers(0, n - 1), min_size=3, max_size=3), min_size=m, max_size=m)))
    return F, n


@pytest.mark.parametrize("pack", [True, False], ids=["packed-sort", "argsort"])
@settings(max_examples=60, deadline=None)
@given(data=face_soups())
def test_edge_index_matches_reference(data, pack):
    # any face soup (repeated vertices, non-manifold edges, unused vertices), both sort paths
    F, n = data
    old = topology._PACK_BITS
    topology._PACK_BITS = 62 if pack else 0
    try:
        ix = EdgeIndex(F, n)
    finally:
        topology._PACK_BITS = old
    ref = _edge_reference(F, n)
    assert ix.E.tolist() == [list(e) for e in sorted(ref)]
    assert ix.count.tolist() == [len(ref[e]) for e in sorted(ref)]
    for e, (i, j) in enumerate(ix.E.tolist()):
        for f, k in ref[(i, j)]:
            assert ix.face_edges[f, k] == e
    assert (ix.face_edges == -1).sum() == sum(1 for face in F.tolist() for k in range(3)
                                               if face[(k + 1) % 3] == face[(k + 2) % 3])
    # the matrices: per-edge values at (i, j) and (j, i), diagonal only when asked for
    w = np.arange(1.0, len(ix) + 1)
    dense_ref = np.zeros((n, n))
    for e, (i, j) in enumerate(ix.E.tolist()):
        dense_ref[i, j] = dense_ref[j, i] = w[e]
    A = ix.matrix(w)
    np.testing.assert_array_equal(A.toarray(), dense_ref)
    assert A.nnz == 2 * len(ix) and A.has_canonical_format
    d = np.arange(n) + 0.5
    B = ix.matrix(-w, diagonal=d)
    np.testing.assert_array_equal(B.toarray(), np.diag(d) - dense_ref)
    assert B.nnz == 2 * len(ix) + n and B.has_canonical_format
    np.testing.assert_allclose(ix.degree(w), dense_ref.sum(axis=1))
    C = np.arange(F.size, dtype=float).reshape(F.shape)
    per_edge = np.zeros(len(ix))
    for e, key in enumerate(sorted(ref)):
        per_edge[e] = sum(C[f, k] for f, k in ref[key])
    np.testing.assert_allclose(ix.per_edge(C), per_edge)


@pytest.mark.parametrize("k", [0, 1, 2])
def test_icosphere_edges_all_shared_by_two_faces(k):
    V, F = icosphere(k)
    E, count = edges(F)
    assert len(E) == 30 * 4**k == 3 * len(F) // 2
    assert (count == 2).all()
    assert {tuple(e) for e in E.tolist()} == edge_set(F)


@pytest.mark.parametrize("mesh", [irregular, two_components, nonmanifold, torus], ids=["irregular", "two", "nonmanifold", "torus"])
def test_edges_and_adjacency_match_a_slow_count(mesh):
    V, F = mesh()
    E, count = edges(F)
    assert {tuple(e) for e in E.tolist()} == edge_set(F)
    assert count.sum() == 3 * len(F)  # every face contributes its 3 edges
    np.testing.assert_array_equal(dense(adjacency(F, len(V))), adjacency_dense(F, len(V)))


def test_connected_components_largest_first():
    V, F = two_components()
    count, labels = connected_components(F, len(V))
    assert count == 2
    assert (labels[:16] == 0).all() and (labels[16:] == 1).all()
    # the same after swapping the two parts: numbering follows size, not order
    F2 = np.where(F < 16, F + 9, F - 16)
    count, labels = connected_components(F2, len(V))
    assert (labels[9:] == 0).all() and (labels[:9] == 1).all()


# ---------------------------------------------------------------------------
# boundary loops
# ---------------------------------------------------------------------------


def assert_is_boundary_cycle(loop, F):
    """Consecutive loop vertices (cyclically) are joined by edges used by one face."""
    E, count = edges(F)
    boundary = {tuple(e) for e in E[count == 1].tolist()}
    assert len(set(loop.tolist())) == len(loop)
    for a, b in zip(loop, np.roll(loop, -1)):
        assert (min(a, b), max(a, b)) in boundary


@pytest.mark.parametrize("n", [2, 3, 5, 8])
@pytest.mark.parametrize("diagonal", ["alternate", "right"])
def test_square_grid_has_one_loop_of_4n_minus_4(n, diagonal):
    V, F = grid(n, diagonal=diagonal)
    loops = boundary_loops(F)
    assert len(loops) == 1
    (loop,) = loops
    assert len(loop) == 4 * (n - 1)
    assert_is_boundary_cycle(loop, F)
    assert set(loop.tolist()) == set(np.flatnonzero(boundary_vertices(F, len(V))).tolist())


def test_annulus_has_two_loops():
    V, F = annulus(nt=16, nr=4)
    loops = boundary_loops(F)
    assert [len(loop) for loop in loops] == [16, 16]
    radii = sorted(float(np.linalg.norm(V[loop, :2], axis=1).mean()) for loop in loops)
    np.testing.assert_allclose(radii, [1.0, 2.0])
    for loop in loops:
        assert_is_boundary_cycle(loop, F)
        np.testing.assert_allclose(np.linalg.norm(V[loop, :2], axis=1), np.linalg.norm(V[loop[0], :2]))


def test_loops_sorted_longest_first():
    V1, F1 = grid(3)
    V2, F2 = grid(5)
    loops = boundary_loops(np.vstack([F1, F2 + len(V1)]))
    assert [len(loop) for loop in loops] == [16, 8]


@pytest.mark.parametrize("mesh", [lambda: icosphere(1), torus, lambda: (TET_V, TET_F)], ids=["icosphere", "torus", "tet"])
def test_closed_meshes_have_no_loops(mesh):
    assert boundary_loops(mesh()[1]) == []


# ---------------------------------------------------------------------------
# mesh_info
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("k", [0, 1, 2, 3])
def test_icosphere_is_a_sphere(k):
    info = mesh_info(*icosphere(k))
    assert info["vertices"] == 10 * 4**k + 2
    assert info["faces"] == 20 * 4**k
    assert info["edges"] == 30 * 4**k
    assert info["boundary_loops"] == 0 and info["nonmanifold_edges"] == 0 and info["unreferenced_vertices"] == 0
    (comp,) = info["components"]
    assert comp["euler"] == 2 and comp["genus"] == 0 and comp["closed"] and comp["boundary_loops"] == 0
    np.testing.assert_allclose(info["bbox_min"], -np.array(info["bbox_max"]), atol=1e-12)


def test_tetrahedron_is_a_sphere():
    (comp,) = mesh_info(TET_V, TET_F)["components"]
    assert (comp["vertices"], comp["faces"], comp["euler"], comp["genus"]) == (4, 4, 2, 0)


@pytest.mark.parametrize("nu, nv", [(12, 8), (9, 5)])
def test_torus_has_genus_one(nu, nv):
    info = mesh_info(*torus(nu, nv))
    (comp,) = info["components"]
    assert comp["euler"] == 0 and comp["genus"] == 1 and comp["closed"]
    assert info["edges"] == 3 * nu * nv


def test_two_tori_and_a_sphere():
    V1, F1 = torus()
    V2, F2 = icosphere(1)
    V3, F3 = torus(9, 5)
    V = np.vstack([V1, V2 + 10, V3 - 10])
    F = np.vstack([F1, F2 + len(V1), F3 + len(V1) + len(V2)])
    info = mesh_info(V, F)
    comps = info["components"]
    assert [c["vertices"] for c in comps] == [96, 45, 42]
    assert [c["genus"] for c in comps] == [1, 1, 0]
    assert sum(c["euler"] for c in comps) == len(V) - info["edges"] + len(F)


def test_disk_and_annulus():
    (disk,) = mesh_info(*grid(5))["components"]
    assert disk["euler"] == 1 and disk["boundary_loops"] == 1 and not disk["closed"] and "genus" not in disk
    (ring,) = mesh_info(*annulus())["components"]
    assert ring["euler"] == 0 and ring["boundary_loops"] == 2 and not ring["closed"]


def test_two_components_counted_and_sized():
    info = mesh_info(*two_components())
    assert info["vertices"] == 25 and info["faces"] == 26 and info["boundary_loops"] == 2
    big, small = info["components"]
    assert (big["vertices"], big["faces"], big["boundary_loops"], big["euler"]) == (16, 18, 1, 1)
    assert (small["vertices"], small["faces"], small["boundary_loops"], small["euler"]) == (9, 8, 1, 1)


def test_unreferenced_vertices_reported_not_listed():
    V, F = grid(3)
    info = mesh_info(np.vstack([V, [[7.0, 7, 7], [8.0, 8, 8]]]), F)
    assert info["unreferenced_vertices"] == 2
    assert len(info["components"]) == 1 and info["components"][0]["vertices"] == 9


def test_nonmanifold_edge_counted_and_solvable():
    V, F = nonmanifold()
    info = mesh_info(V, F)
    assert info["nonmanifold_edges"] == 1 and info["edges"] == 7 and info["faces"] == 3
    assert len(info["components"]) == 1
    for weights in ("uniform", "cotan", "intrinsic", "robust"):
        L = laplacian(V, F, weights=weights)
        np.testing.assert_allclose(L @ np.ones(5), 0.0, atol=1e-12 * abs(L).max())
        x = harmonic(V, F, [2, 3, 4], [0.0, 1.0, 2.0], weights=weights)
        assert np.isfinite(x).all()


def test_mesh_info_reports_what_as_mesh_would_reject():
    # unwelded, degenerate and unreferenced input is described, not refused
    soup_V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [9, 9, 9]])
    soup_F = np.array([[0, 1, 2], [3, 4, 5], [1, 6, 3]])  # face 2 has zero area
    info = mesh_info(soup_V, soup_F)
    assert info["unreferenced_vertices"] == 1 and info["faces"] == 3


# ---------------------------------------------------------------------------
# clean_mesh
# ---------------------------------------------------------------------------


def soup(V, F):
    """Every face with its own three vertices."""
    return V[F].reshape(-1, 3), np.arange(3 * len(F)).reshape(-1, 3)


@pytest.mark.parametrize(
    "mesh, euler", [(lambda: grid(4), 1), (lambda: icosphere(1), 2), (torus, 0)], ids=["grid", "icosphere", "torus"]
)
def test_clean_mesh_welds_a_soup(mesh, euler):
    V, F = mesh()
    Vs, Fs = soup(V, F)
    assert len(mesh_info(Vs, Fs)["components"]) == len(F)
    V2, F2, vmap = clean_mesh(Vs, Fs)
    assert len(V2) == len(V) and len(F2) == len(F)
    # vmap renumbers: old vertex i is new vertex vmap[i], and the faces follow
    np.testing.assert_array_equal(V2[vmap], Vs)
    np.testing.assert_array_equal(F2, vmap[Fs])
    info = mesh_info(V2, F2)
    assert len(info["components"]) == 1 and info["components"][0]["euler"] == euler
    as_mesh(V2, F2)  # now valid as it stands
    # the welded mesh is the original up to renumbering
    assert {tuple(sorted(map(tuple, V2[f].tolist()))) for f in F2} == {tuple(sorted(map(tuple, V[f].tolist()))) for f in F}


def test_clean_mesh_drops_unreferenced_and_zero_area():
    V = np.array([
        [0.0, 0, 0], [1, 0, 0], [0, 1, 0],  # face 0
        [7.0, 7, 7],                        # 3: used by no face
        [1, 1, 0],                          # 4: face 1 with 1, 2
        [2, 0, 0], [3, 0, 0],               # 5, 6: only in the collinear face 2 with 1
        [1, 0, 0],                          # 7: duplicate of 1
    ])
    F = np.array([[0, 1, 2], [7, 4, 2], [1, 5, 6], [0, 0, 2]])
    V2, F2, vmap = clean_mesh(V, F)
    assert vmap.tolist() == [0, 1, 2, -1, 3, -1, -1, 1]
    np.testing.assert_array_equal(V2, V[[0, 1, 2, 4]])  # kept vertices stay in order
    assert F2.tolist() == [[0, 1, 2], [1, 3, 2]]
    kept = vmap >= 0
    np.testing.assert_array_equal(V2[vmap[kept]], V[kept])


def test_clean_mesh_leaves_a_clean_mesh_alone():
    V, F = irregular()
    V2, F2, vmap = clean_mesh(V, F)
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(F2, F)
    np.testing.assert_array_equal(vmap, np.arange(len(V)))


def test_clean_mesh_weld_tolerance():
    V, F = grid(3)
    Vs, Fs = soup(V, F)
    rng = np.random.default_rng(0)
    noisy = Vs + rng.uniform(-1e-9, 1e-9, size=Vs.shape)  # far above the default weld distance
    assert len(clean_mesh(noisy, Fs)[0]) == len(Vs)
    V2, F2, _ = clean_mesh(noisy, Fs, tol=1e-6)
    assert len(V2) == 9 and len(mesh_info(V2, F2)["components"]) == 1


def test_clean_mesh_then_solve():
    # samples indexed on the soup, renumbered through vmap, solve on the welded mesh
    V, F = grid(5)
    Vs, Fs = soup(V, F)
    V2, F2, vmap = clean_mesh(Vs, Fs)
    on_edge = np.flatnonzero((Vs[:, 0] % 1 == 0) | (Vs[:, 1] % 1 == 0))  # soup copies of boundary vertices
    f = lambda P: 2 * P[:, 0] - P[:, 1] + 0.5  # noqa: E731
    b, bc, _ = as_samples(vmap[on_edge], f(Vs[on_edge]), len(V2))  # equal repeats merge
    assert len(b) == 16
    np.testing.assert_allclose(harmonic(V2, F2, b, bc[:, 0]), f(V2), rtol=0, atol=1e-12)
