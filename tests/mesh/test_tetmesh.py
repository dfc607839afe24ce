"""The tet matrices live in mesh/ (beside the triangle ones); the solid's old imports still reach them."""

import doctest

import numpy as np
import pytest

import manifill.mesh.tetmesh as tetmesh
import manifill.solid.tets as solid_tets
from manifill import MeshError
from manifill.mesh.laplacian import mass_matrix
from manifill.mesh.tetmesh import cell_width, tet_laplacian, tet_mass_matrix, tet_volumes


def test_old_imports_are_the_same_functions():
    for name in ("tet_laplacian", "tet_mass_matrix", "tet_gradient_root", "tet_volumes", "negative_tets", "WEIGHTS"):
        assert getattr(solid_tets, name) is getattr(tetmesh, name), name


def test_doctests():
    result = doctest.testmod(tetmesh, optionflags=doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0


def test_mass_matrix_of_tets_is_the_tet_mass_and_integrates_constants():
    # the unit cube in 5 tets (a corner cut off four times, one tet in the middle): 1' M 1 is the volume
    V = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], dtype=float)
    T = np.array([[0, 1, 2, 4], [3, 1, 2, 7], [5, 1, 4, 7], [6, 2, 4, 7], [1, 2, 4, 7]])
    assert np.abs(tet_volumes(V, T)).sum() == pytest.approx(1.0, rel=1e-14)
    np.testing.assert_array_equal(mass_matrix(V, T).diagonal(), tet_mass_matrix(V, T).diagonal())
    assert mass_matrix(V, T).sum() == pytest.approx(1.0, rel=1e-14)
    # constants are in the stiffness' null space; the linear x has energy |grad x|^2 * volume = 1
    L = tet_laplacian(V, T)
    np.testing.assert_allclose(L @ np.ones(8), 0, atol=1e-14)
    assert V[:, 0] @ (L @ V[:, 0]) == pytest.approx(1.0, rel=1e-13)


@pytest.mark.parametrize("shape, width", [((2, 3), 3), ((2, 4), 4), ((0, 4), 4), ((3,), 3)])
def test_cell_width(shape, width):
    assert cell_width(np.zeros(shape, dtype=int)) == width


@pytest.mark.parametrize("cols", [1, 2, 5, 8])
def test_cell_width_refuses_other_widths(cols):
    with pytest.raises(MeshError, match=rf"T has shape \(2, {cols}\); pass triangles"):
        cell_width(np.zeros((2, cols), dtype=int), what="T")
