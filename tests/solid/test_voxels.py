"""Voxel solids: neighbours, stencil weights, the voxel Laplacian, components, centres (Step 7 is test_boundary)."""

import doctest
import itertools
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import manifill.solid.voxels
from manifill import MeshError, OptionError, SampleError
from manifill.solid.boundary import boundary_voxels
from manifill.solid.voxels import (
    as_connectivity,
    as_origin,
    as_spacing,
    neighbour_offsets,
    stencil_weights,
    voxel_centres,
    voxel_components,
    voxel_laplacian,
)

hsettings = settings(max_examples=30, deadline=None, derandomize=True, database=None,
                     suppress_health_check=[HealthCheck.too_slow])
CONNECTIVITIES = (6, 18, 26)
SPACINGS = [(1.0, 1.0, 1.0), (1.0, 1.0, 2.5), (0.5, 1.0, 3.0), (0.3, 2.0, 0.7)]
RANK = {6: 1, 18: 2, 26: 3}  # most nonzero entries of a neighbour offset

# ---------------------------------------------------------------------------
# obviously-correct helpers (no manifill code)
# ---------------------------------------------------------------------------


def all_neighbours(c):
    """Every offset to a neighbour, both signs, by enumeration."""
    return {d for d in itertools.product((-1, 0, 1), repeat=3) if 0 < sum(map(abs, d)) <= RANK[c]}


def in_mask(mask, v):
    return all(0 <= v[a] < mask.shape[a] for a in range(3)) and bool(mask[tuple(v)])


def slow_laplacian(mask, weight):
    """L = D - W voxel by voxel from a dict {offset (both signs): weight}, rows in C order."""
    voxels = [tuple(v) for v in np.argwhere(mask).tolist()]
    ids = {v: i for i, v in enumerate(voxels)}
    L = np.zeros((len(voxels), len(voxels)))
    for v, i in ids.items():
        for d, w in weight.items():
            u = tuple(v[a] + d[a] for a in range(3))
            if u in ids:
                L[i, ids[u]] -= w
                L[i, i] += w
    return L


def weight_dict(spacing, c):
    D, w = stencil_weights(spacing, c)
    out = {}
    for d, wd in zip(D.tolist(), w.tolist()):
        out[tuple(d)] = wd
        out[tuple(-x for x in d)] = wd
    return out


def one_line(info):
    msg = str(info.value)
    assert msg and "\n" not in msg
    return msg


def random_mask(shape, seed, fill=0.7):
    return np.random.default_rng(seed).random(shape) < fill


# ---------------------------------------------------------------------------
# neighbours and weights
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("c", CONNECTIVITIES)
def test_neighbour_offsets_are_one_of_each_opposite_pair(c):
    D = neighbour_offsets(c)
    assert D.shape == (c // 2, 3) and D.dtype == np.int64
    first = D[np.arange(len(D)), np.argmax(D != 0, axis=1)]
    assert (first == 1).all()  # the first nonzero entry is positive
    both = {tuple(d) for d in D.tolist()} | {tuple(d) for d in (-D).tolist()}
    assert len(both) == c and both == all_neighbours(c)


@pytest.mark.parametrize("spacing", SPACINGS)
@pytest.mark.parametrize("c", CONNECTIVITIES)
def test_stencil_weights_are_positive(spacing, c):
    D, w = stencil_weights(spacing, c)
    np.testing.assert_array_equal(D, neighbour_offsets(c))
    assert w.shape == (c // 2,) and (w > 0).all()


@pytest.mark.parametrize("spacing", SPACINGS)
def test_face_weights_are_inverse_squared_spacing(spacing):
    D, w = stencil_weights(spacing, 6)
    h = np.asarray(spacing)
    np.testing.assert_allclose(w, 1.0 / h[np.argmax(D != 0, axis=1)] ** 2, rtol=1e-15)


@pytest.mark.parametrize("spacing", SPACINGS)
@pytest.mark.parametrize("c", (18, 26))
def test_edge_and_corner_weights_are_inverse_squared_length(spacing, c):
    D, w = stencil_weights(spacing, c)
    P = D * np.asarray(spacing)
    diagonal = (D != 0).sum(axis=1) > 1
    np.testing.assert_allclose(w[diagonal], 1.0 / (P[diagonal] ** 2).sum(axis=1), rtol=1e-14)


@pytest.mark.parametrize("spacing", SPACINGS)
@pytest.mark.parametrize("c", CONNECTIVITIES)
def test_second_moments_are_isotropic(spacing, c):
    # M_ab = sum over +d and -d of w_d p_a p_b: a multiple of the identity, so sum_d w_d (u(x+p) + u(x-p) - 2u)
    # is that multiple times the Laplacian of u to second order
    D, w = stencil_weights(spacing, c)
    P = D * np.asarray(spacing)
    M = 2.0 * np.einsum("d,da,db->ab", w, P, P)
    assert M[0, 0] > 0
    np.testing.assert_allclose(np.diag(M), M[0, 0], rtol=1e-13)
    np.testing.assert_allclose(M - np.diag(np.diag(M)), 0.0, atol=1e-13 * M[0, 0])


@hsettings
@given(h=st.lists(st.floats(0.05, 20.0), min_size=3, max_size=3), c=st.sampled_from(CONNECTIVITIES))
def test_second_moments_on_any_spacing(h, c):
    D, w = stencil_weights(h, c)
    assert (w > 0).all()
    P = D * np.asarray(h)
    M = 2.0 * np.einsum("d,da,db->ab", w, P, P)
    np.testing.assert_allclose(M, M[0, 0] * np.eye(3), rtol=0, atol=1e-12 * M[0, 0])


@pytest.mark.parametrize("c", CONNECTIVITIES)
def test_cubic_stencil_is_the_same_on_every_axis(c):
    D, w = stencil_weights(2.0, c)  # one number means cubes
    by_kind = {}
    for d, wd in zip(D.tolist(), w.tolist()):
        by_kind.setdefault(sum(map(abs, d)), set()).add(wd)
    assert all(len(v) == 1 for v in by_kind.values())


@pytest.mark.parametrize("c", CONNECTIVITIES)
def test_uniform_scaling_of_spacing_scales_weights(c):
    _, w = stencil_weights((1.0, 1.0, 2.5), c)
    _, w2 = stencil_weights((1e3, 1e3, 2.5e3), c)
    np.testing.assert_allclose(w2, w * 1e-6, rtol=1e-13)


# ---------------------------------------------------------------------------
# the voxel Laplacian
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("spacing", SPACINGS[:3])
@pytest.mark.parametrize("c", CONNECTIVITIES)
@pytest.mark.parametrize("seed", [0, 1])
def test_laplacian_equals_slow_reference(spacing, c, seed):
    mask = random_mask((5, 6, 4), seed)
    L = voxel_laplacian(mask, spacing, c)
    assert L.shape == (int(mask.sum()),) * 2 and L.has_sorted_indices
    ref = slow_laplacian(mask, weight_dict(spacing, c))
    np.testing.assert_allclose(L.toarray(), ref, rtol=1e-14, atol=0)


@pytest.mark.parametrize("spacing", SPACINGS)
@pytest.mark.parametrize("c", CONNECTIVITIES)
def test_laplacian_symmetric_constants_in_null_space(spacing, c):
    mask = random_mask((7, 6, 8), 3, fill=0.8)
    L = voxel_laplacian(mask, spacing, c)
    assert abs(L - L.T).max() == 0.0
    assert np.abs(L @ np.ones(L.shape[0])).max() <= 1e-13 * abs(L).max()
    ev = np.linalg.eigvalsh(L.toarray())
    assert ev[0] >= -1e-12 * ev[-1]  # positive semi-definite


@pytest.mark.parametrize("spacing", SPACINGS)
@pytest.mark.parametrize("c", CONNECTIVITIES)
def test_interior_row_has_c_neighbours(spacing, c):
    mask = np.ones((3, 4, 5), dtype=bool)
    L = voxel_laplacian(mask, spacing, c).toarray()
    row = L[np.ravel_multi_index((1, 1, 2), mask.shape)]
    off = np.delete(row, np.ravel_multi_index((1, 1, 2), mask.shape))
    assert np.count_nonzero(off) == c and (off <= 0).all()
    _, w = stencil_weights(spacing, c)
    assert row[np.ravel_multi_index((1, 1, 2), mask.shape)] == pytest.approx(2 * w.sum(), rel=1e-14)


@pytest.mark.parametrize("spacing", SPACINGS)
@pytest.mark.parametrize("c", CONNECTIVITIES)
def test_laplacian_is_zero_on_linear_functions_at_whole_stencils(spacing, c):
    mask = np.ones((6, 5, 7), dtype=bool)
    X = voxel_centres(mask.shape, spacing, (0.3, -2.0, 5.0))
    u = 0.7 + 1.5 * X[:, 0] - 2.0 * X[:, 1] + 0.25 * X[:, 2]
    Lu = voxel_laplacian(mask, spacing, c) @ u
    inner = ~boundary_voxels(mask, c)[mask]
    assert np.abs(Lu[inner]).max() <= 1e-11 * np.abs(u).max() * abs(voxel_laplacian(mask, spacing, c)).max()


def test_laplacian_by_hand():
    L = voxel_laplacian(np.ones((1, 1, 3), dtype=bool), spacing=(1.0, 1.0, 2.0))
    np.testing.assert_array_equal(L.toarray(), [[0.25, -0.25, 0], [-0.25, 0.5, -0.25], [0, -0.25, 0.25]])


def test_laplacian_of_diagonal_touch_depends_on_connectivity():
    mask = np.zeros((2, 2, 2), dtype=bool)
    mask[0, 0, 0] = mask[1, 1, 0] = True  # edge neighbours
    assert np.count_nonzero(voxel_laplacian(mask, connectivity=6).toarray()) == 0
    assert np.count_nonzero(voxel_laplacian(mask, connectivity=18).toarray()) == 4
    mask[1, 1, 0], mask[1, 1, 1] = False, True  # corner neighbours
    assert np.count_nonzero(voxel_laplacian(mask, connectivity=18).toarray()) == 0
    assert np.count_nonzero(voxel_laplacian(mask, connectivity=26).toarray()) == 4


# ---------------------------------------------------------------------------
# components, centres
# ---------------------------------------------------------------------------



def test_components_follow_connectivity():
    mask = np.zeros((4, 4, 4), dtype=bool)
    mask[0, 0, 0] = mask[1, 1, 0] = True  # edge neighbours
    mask[3, 3, 3] = mask[2, 2, 2] = True  # corner neighbours
    assert voxel_components(mask, 6)[0] == 4
    assert voxel_components(mask, 18)[0] == 3
    count, labels = voxel_components(mask, 26)
    assert count == 2 and (labels[~mask] == 0).all()
    assert labels[0, 0, 0] == labels[1, 1, 0] != labels[3, 3, 3] == labels[2, 2, 2]


def test_voxel_centres():
    h, o = (0.5, 1.0, 2.5), (1.0, -2.0, 3.0)
    P = voxel_centres((2, 3, 4), h, o)
    assert P.shape == (24, 3)
    np.testing.assert_array_equal(P[np.ravel_multi_index((1, 2, 3), (2, 3, 4))], [1.5, 0.0, 10.5])
    where = np.zeros((2, 3, 4), dtype=bool)
    where[1, 0, 2] = where[0, 2, 1] = True
    np.testing.assert_array_equal(voxel_centres((2, 3, 4), h, o, where=where), [[1.0, 0.0, 5.5], [1.5, -2.0, 8.0]])


# ---------------------------------------------------------------------------
# options
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("good, c", [(6, 6), (18.0, 18), (np.int64(26), 26), (np.float32(18), 18)])
def test_as_connectivity(good, c):
    assert as_connectivity(good) == c and type(as_connectivity(good)) is int


@pytest.mark.parametrize("bad", [0, 4, 8, 27, True, None, 6.5, np.float32(6.5), Fraction(13, 2), float("inf"),
                                 float("nan"), "six", [6]])
def test_as_connectivity_errors(bad):
    with pytest.raises(OptionError) as info:
        as_connectivity(bad)
    assert "6, 18, 26" in one_line(info)
    with pytest.raises(OptionError):
        neighbour_offsets(bad)
    with pytest.raises(OptionError):
        voxel_laplacian(np.ones((2, 2, 2), dtype=bool), connectivity=bad)


def test_as_spacing():
    np.testing.assert_array_equal(as_spacing(2), [2.0, 2.0, 2.0])
    np.testing.assert_array_equal(as_spacing((1, 2, 3.5)), [1.0, 2.0, 3.5])
    assert as_spacing([1, 1, 1]).dtype == np.float64


@pytest.mark.parametrize("bad", [(1, 2), (1, 2, 3, 4), (0, 1, 1), (1, -1, 1), (np.inf, 1, 1), (np.nan, 1, 1), None,
                                 "abc", (1, "a", 2), 0.0, []])
def test_as_spacing_errors(bad):
    with pytest.raises(MeshError) as info:
        as_spacing(bad)
    assert "spacing" in one_line(info) and not isinstance(info.value, SampleError)
    with pytest.raises(MeshError):
        stencil_weights(bad, 6)


@pytest.mark.parametrize("bad", [(1, 2), (0, np.inf, 0), (np.nan, 0, 0), None, "abc"])
def test_as_origin_errors(bad):
    with pytest.raises(MeshError) as info:
        as_origin(bad)
    assert "origin" in one_line(info) and not isinstance(info.value, SampleError)



def test_doctests():
    result = doctest.testmod(manifill.solid.voxels, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0
