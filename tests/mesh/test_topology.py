"""Combinatorics: components, boundary loops, Euler characteristic and genus, the mesh report."""

import numpy as np
import pytest

from conftest import annulus, boundary_vertices, grid, icosphere, nonmanifold, torus, two_components
from manifill import harmonic, laplacian, mesh_info
from manifill.mesh.edges import edges
from manifill.mesh.topology import boundary_loops, connected_components

TET_V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
TET_F = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])


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


@pytest.mark.parametrize("mesh", [lambda: icosphere(1), torus, lambda: (TET_V, TET_F)],
                         ids=["icosphere", "torus", "tet"])
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
