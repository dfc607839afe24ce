"""The edge index: edges, their face counts, the CSR layout of matrices on them, adjacency."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import manifill.mesh.edges as edges_module
from conftest import adjacency_dense, dense, edge_set, icosphere, irregular, nonmanifold, torus, two_components
from manifill.mesh.edges import EdgeIndex, adjacency, edges

TET_F = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])


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


@pytest.mark.parametrize("pack", [62, 12, 0], ids=["one-sort", "groups", "a-groups"])
@settings(max_examples=60, deadline=None)
@given(data=face_soups())
def test_edge_index_matches_reference(data, pack):
    # any face soup (repeated vertices, non-manifold edges, unused vertices); one packed sort, or half-edges
    # grouped by the top bits of their first vertex first (as on large meshes), down to one group per vertex
    F, n = data
    old = edges_module._PACK_BITS
    edges_module._PACK_BITS = pack
    try:
        ix = EdgeIndex(F, n)
    finally:
        edges_module._PACK_BITS = old
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


@pytest.mark.parametrize("mesh", [irregular, two_components, nonmanifold, torus],
                         ids=["irregular", "two", "nonmanifold", "torus"])
def test_edges_and_adjacency_match_a_slow_count(mesh):
    V, F = mesh()
    E, count = edges(F)
    assert {tuple(e) for e in E.tolist()} == edge_set(F)
    assert count.sum() == 3 * len(F)  # every face contributes its 3 edges
    np.testing.assert_array_equal(dense(adjacency(F, len(V))), adjacency_dense(F, len(V)))


def test_index_arrays_are_int32_and_edges_int64():
    # the edge index keeps int32 indices (as SciPy keeps them for these sizes); edges() returns int64
    V, F = icosphere(2)
    ix = EdgeIndex(F, len(V))
    assert ix.E.dtype == ix.count.dtype == ix.face_edges.dtype == np.int32
    for diagonal in (None, np.ones(len(V))):
        A = ix.matrix(np.ones(len(ix)), diagonal=diagonal)
        assert A.indices.dtype == A.indptr.dtype == np.int32
    E, count = edges(F)
    assert E.dtype == count.dtype == np.int64
    np.testing.assert_array_equal(E, ix.E)
