"""clean_mesh: welding coinciding vertices, dropping unused vertices and zero-area faces."""

import numpy as np
import pytest

from conftest import grid, icosphere, irregular, torus
from manifill import clean_mesh, harmonic, mesh_info
from manifill.validate import as_mesh, as_samples


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
    def corners(P, G):
        return {tuple(sorted(map(tuple, P[f].tolist()))) for f in G}

    assert corners(V2, F2) == corners(V, F)


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
