"""Loop subdivision's weights at irregular vertices: Warren's beta, as libigl's ``igl.loop``."""

import numpy as np
import pytest
from scipy.spatial import Delaunay, cKDTree

from conftest import icosphere
from manifill.mesh.subdivide import loop_matrix, subdivide


def warren_beta(n):
    """Warren's weight of each neighbour of an inner vertex of valence n."""
    return 3 / 16 if n == 3 else 3 / (8 * n)


def loop_beta(n):
    """Loop's original weight (the rule this module does not use)."""
    return (5 / 8 - (3 / 8 + np.cos(2 * np.pi / n) / 4) ** 2) / n


def fan(n):
    """A flat disk: vertex 0 at the centre, joined to a ring of n boundary vertices (inner valence n)."""
    t = 2 * np.pi * np.arange(n) / n
    V = np.vstack([[0.0, 0.0, 0.0], np.column_stack([np.cos(t), np.sin(t), 0.3 * np.sin(2 * t)])])
    F = np.array([[0, 1 + i, 1 + (i + 1) % n] for i in range(n)], dtype=np.int64)
    return V, F


def delaunay_patch(m=60, seed=3):
    """A random Delaunay triangulation of the unit square, lifted onto a smooth height: valences 3 to 9 inside."""
    rng = np.random.default_rng(seed)
    P = np.vstack([[[0, 0], [1, 0], [0, 1], [1, 1]], rng.random((m, 2))])
    F = Delaunay(P).simplices.astype(np.int64)
    V = np.column_stack([P, 0.3 * np.sin(3 * P[:, 0]) * np.cos(2 * P[:, 1])])
    return V, F


def cap():
    """An icosphere of 162 vertices less its southern cap: open, with valence-5 vertices inside."""
    V, F = icosphere(2)
    F = F[V[F].mean(axis=1)[:, 2] > -0.4]
    used = np.unique(F)
    remap = np.full(len(V), -1)
    remap[used] = np.arange(used.size)
    return V[used], remap[F]


def inner_valences(F, n):
    """Valence of every vertex not on the boundary."""
    E = np.sort(np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    E, count = np.unique(E, axis=0, return_counts=True)
    valence = np.bincount(E.ravel(), minlength=n)
    boundary = np.zeros(n, dtype=bool)
    boundary[E[count == 1].ravel()] = True
    return valence[~boundary & (valence > 0)]


# ---------------------------------------------------------------------------
# the rule, by hand (no libigl needed)
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("n", [3, 4, 5, 7, 8, 9])
def test_inner_vertex_weights_are_warrens_beta(n):
    V, F = fan(n)
    S, _ = loop_matrix(F, len(V))
    row = S[[0]].toarray().ravel()
    beta = warren_beta(n)
    np.testing.assert_allclose(row[1:n + 1], beta, rtol=0, atol=1e-15)
    assert row[0] == pytest.approx(1 - n * beta, abs=1e-15)  # 5/8 of itself, 7/16 at valence 3
    assert row[0] == pytest.approx(5 / 8 if n != 3 else 7 / 16, abs=1e-15)


@pytest.mark.parametrize("n", [5, 7])
def test_loops_original_beta_would_differ(n):
    # the hand-computed Loop values: 0.0840919 at valence 5 and 0.0513142 at valence 7; Warren's 3/40, 3/56
    V, F = fan(n)
    S, _ = loop_matrix(F, len(V))
    row = S[[0]].toarray().ravel()
    assert abs(loop_beta(n) - warren_beta(n)) > 4e-3
    assert abs(row[1] - loop_beta(n)) > 4e-3
    assert row[1] == pytest.approx(3 / (8 * n), abs=1e-15)


def test_the_two_betas_agree_at_valence_3_and_6():
    # why a regular mesh cannot tell them apart (test_pictures compares with libigl on a grid)
    for n in (3, 6):
        assert loop_beta(n) == pytest.approx(warren_beta(n), abs=1e-15)
    for n in (4, 5, 7, 8, 12):
        assert abs(loop_beta(n) - warren_beta(n)) > 1e-3


def test_irregular_icosphere_vertex_row_by_hand():
    V, F = icosphere(1)
    S, _ = loop_matrix(F, len(V))
    E = np.unique(np.sort(np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0)
    valence = np.bincount(E.ravel(), minlength=len(V))
    five = np.flatnonzero(valence == 5)
    assert five.size == 12
    D = S[:len(V)].toarray()
    for v in five:
        nb = np.unique(E[(E == v).any(axis=1)])
        nb = nb[nb != v]
        np.testing.assert_allclose(D[v, nb], 3 / 40, rtol=0, atol=1e-15)
        assert D[v, v] == pytest.approx(5 / 8, abs=1e-15)


# ---------------------------------------------------------------------------
# libigl as the reference
# ---------------------------------------------------------------------------


def igl_matrix(F, n):
    """libigl's one-level subdivision matrix: igl.loop applied to the n x n identity."""
    igl = pytest.importorskip("igl")
    W, G = igl.loop(np.eye(n), F.astype(np.int64), 1)
    return W, G


#: Meshes with irregular inner vertices, closed and open.
IRREGULAR = {"icosphere": lambda: icosphere(2), "cap": cap, "delaunay": delaunay_patch, "fan7": lambda: fan(7),
             "fan3": lambda: fan(3)}


@pytest.mark.parametrize("name", sorted(IRREGULAR))
def test_matrix_equals_igl_loop(name):
    V, F = IRREGULAR[name]()
    n = len(V)
    assert (inner_valences(F, n) != 6).any(), "precondition: irregular inner vertices"
    W, G = igl_matrix(F, n)
    S, F2 = loop_matrix(F, n)
    S = S.toarray()
    assert S.shape == W.shape
    # old vertices keep their numbers in both; the edge vertices are matched by their two ends
    np.testing.assert_allclose(S[:n], W[:n], rtol=0, atol=1e-12)

    def ends(M):
        rows = M[n:]
        big = rows > 0.3  # 3/8 or 1/2 at the ends, 1/8 at the opposite corners
        assert (big.sum(axis=1) == 2).all()
        return np.sort(np.nonzero(big)[1].reshape(-1, 2), axis=1)

    ours, theirs = ends(S), ends(W)
    key = lambda E: E[:, 0] * n + E[:, 1]  # noqa: E731
    order_ours, order_theirs = np.argsort(key(ours)), np.argsort(key(theirs))
    np.testing.assert_array_equal(ours[order_ours], theirs[order_theirs])
    np.testing.assert_allclose(S[n:][order_ours], W[n:][order_theirs], rtol=0, atol=1e-12)
    # the same oriented triangles, once our edge vertices are renumbered as libigl's
    to_igl = np.arange(len(S))
    to_igl[n + order_ours] = n + order_theirs

    def oriented(T):
        T = np.asarray(T)
        r = np.argmin(T, axis=1)
        T = np.stack([np.roll(t, -k) for t, k in zip(T, r)])
        return T[np.lexsort(T.T[::-1])]

    np.testing.assert_array_equal(oriented(to_igl[F2]), oriented(G))


@pytest.mark.parametrize("name", ["icosphere", "cap", "delaunay"])
def test_two_levels_with_a_field_equal_igl_loop(name):
    igl = pytest.importorskip("igl")
    V, F = IRREGULAR[name]()
    X = np.random.default_rng(0).standard_normal((len(V), 2))
    V2, F2, X2 = subdivide(V, F, X, levels=2)
    W, G = igl.loop(np.column_stack([V, X]), F.astype(np.int64), 2)  # libigl refines every column alike
    assert len(F2) == len(G) == 16 * len(F) and len(V2) == len(W)
    d, j = cKDTree(W[:, :3]).query(V2)
    assert np.unique(j).size == len(W), "a one-to-one match of the vertices"
    assert d.max() < 1e-12
    np.testing.assert_allclose(X2, W[j, 3:], rtol=0, atol=1e-12)
