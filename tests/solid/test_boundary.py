"""Step 7: a solid's boundary surface D (boundary voxels, the digital surface), voxelisation, tetrahedralisation."""

import doctest
import itertools
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import manifill.solid.boundary
import manifill.solid.estimates
import manifill.solid.tetrahedralize
import manifill.solid.voxelize
from manifill import MeshError, OptionError, SampleError
from manifill.mesh.shapes import icosphere
from manifill.solid.boundary import (boundary_voxels, digital_surface, digital_surface_graph,
                                     surface_vertex_of_voxels)
from manifill.solid.tetrahedralize import tetrahedralize
from manifill.solid.tets import boundary_faces, boundary_vertices
from manifill.solid.voxels import voxel_centres
from manifill.solid.voxelize import voxel_grid, voxelize
from solids import HAVE_TETGEN, SPACINGS, ball, needs_tetgen, one_line

hsettings = settings(max_examples=30, deadline=None, derandomize=True, database=None,
                     suppress_health_check=[HealthCheck.too_slow])
CONNECTIVITIES = (6, 18, 26)
RANK = {6: 1, 18: 2, 26: 3}  # most nonzero entries of a neighbour offset

# ---------------------------------------------------------------------------
# obviously-correct helpers (no manifill code)
# ---------------------------------------------------------------------------


def all_neighbours(c):
    """Every offset to a neighbour, both signs, by enumeration."""
    return {d for d in itertools.product((-1, 0, 1), repeat=3) if 0 < sum(map(abs, d)) <= RANK[c]}


def in_mask(mask, v):
    return all(0 <= v[a] < mask.shape[a] for a in range(3)) and bool(mask[tuple(v)])


def random_mask(shape, seed, fill=0.7):
    return np.random.default_rng(seed).random(shape) < fill


def volumes(V, T):
    """Signed tet volumes by numpy determinants."""
    V, T = np.asarray(V, float), np.asarray(T)
    return np.linalg.det(np.stack([V[T[:, k]] - V[T[:, 0]] for k in (1, 2, 3)], axis=1)) / 6.0


def enclosed_volume(V, F):
    """Divergence theorem: sum of the signed volumes of the cones (origin, face); positive when F is outward."""
    V = np.asarray(V)
    return float(np.einsum("ij,ij->i", np.cross(V[F[:, 0]], V[F[:, 1]]), V[F[:, 2]]).sum() / 6.0)


def mask_ball(spacing=(1.0, 1.0, 1.0)):
    return ball(spacing, size=16.0, radius=6.6)


# ---------------------------------------------------------------------------
# the boundary voxels D
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("shape", [(3, 3, 3), (5, 4, 6), (1, 4, 4), (2, 5, 5), (8, 8, 8)])
@pytest.mark.parametrize("c", CONNECTIVITIES)
def test_boundary_of_full_box_is_box_minus_interior(shape, c):
    D = boundary_voxels(np.ones(shape, dtype=bool), c)
    inner = np.prod([max(n - 2, 0) for n in shape])
    assert D.dtype == bool and D.shape == shape
    assert int(D.sum()) == np.prod(shape) - inner
    assert not D[1:-1, 1:-1, 1:-1].any()


@hsettings
@given(seed=st.integers(0, 2**32 - 1), c=st.sampled_from(CONNECTIVITIES),
       shape=st.tuples(st.integers(1, 7), st.integers(1, 7), st.integers(1, 7)), fill=st.floats(0.3, 0.95))
def test_boundary_is_exactly_the_voxels_missing_a_neighbour(seed, c, shape, fill):
    mask = random_mask(shape, seed, fill)
    D = boundary_voxels(mask, c)
    assert not (D & ~mask).any()
    for v in np.argwhere(mask).tolist():
        whole = all(in_mask(mask, [v[a] + d[a] for a in range(3)]) for d in all_neighbours(c))
        assert D[tuple(v)] == (not whole), v  # off D: all c neighbours are in the mask


def test_boundary_grows_with_connectivity():
    x, y, z = np.indices((11, 11, 11)) - 5
    ball = x**2 + y**2 + z**2 <= 16
    D6, D18, D26 = (boundary_voxels(ball, c) for c in CONNECTIVITIES)
    assert (D6 <= D18).all() and (D18 <= D26).all() and D26.sum() > D6.sum()


# ---------------------------------------------------------------------------
# the digital surface
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("spacing", SPACINGS)
@pytest.mark.parametrize("c", CONNECTIVITIES)
def test_digital_surface_of_a_ball(spacing, c):
    mask = mask_ball(spacing)
    origin = np.array([1.0, -2.0, 0.5])
    voxels, P, E, normals = digital_surface(mask, spacing=spacing, origin=origin, connectivity=c)
    np.testing.assert_array_equal(voxels, np.argwhere(boundary_voxels(mask, c)))
    np.testing.assert_allclose(P, origin + voxels * np.asarray(spacing), rtol=0, atol=1e-12)
    # edges: distinct pairs i < j of boundary voxels that touch
    assert (E[:, 0] < E[:, 1]).all() and len(np.unique(E, axis=0)) == len(E)
    assert np.abs(voxels[E[:, 0]] - voxels[E[:, 1]]).max() == 1
    deg = np.bincount(E.ravel(), minlength=len(voxels))
    assert deg.min() >= 1  # no surface voxel is isolated
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, rtol=1e-12)
    centre = origin + (np.array(mask.shape) - 1) * np.asarray(spacing) / 2
    outward = np.einsum("ij,ij->i", normals, P - centre) > 0
    assert outward.mean() > 0.95  # measured: all of them



def test_digital_surface_graph_is_the_graph_of_touching_boundary_voxels():
    mask = mask_ball((1.0, 1.0, 2.5))
    voxels, P, E, normals = digital_surface(mask, spacing=(1.0, 1.0, 2.5))
    s = digital_surface_graph(P, E, normals)
    hops = digital_surface_graph(P, E, normals, distance="hops")
    n = len(voxels)
    assert s.F is None and s.normals is normals and s.n == n
    A = s.G_hops.toarray()
    assert (A == A.T).all() and set(np.unique(A)) == {0.0, 1.0} and A.sum() == 2 * len(E)
    assert all(A[i, j] == 1.0 for i, j in E)
    # G measures distances between voxel centres, in units of their mean; hops counts edges
    G = s.G.toarray()
    d = np.linalg.norm(P[E[:, 0]] - P[E[:, 1]], axis=1)
    np.testing.assert_allclose(G[E[:, 0], E[:, 1]], d / d.mean(), rtol=1e-14)
    assert hops.G is hops.G_hops
    # the Laplacian is the uniform one of the voxel graph, whatever the weight name
    L = s.laplacian("uniform").toarray()
    np.testing.assert_array_equal(L, np.diag(A.sum(axis=1)) - A)
    with pytest.raises(OptionError):
        digital_surface_graph(P, E, distance="euclid")


def test_surface_vertex_of_voxels_finds_each_boundary_voxel():
    mask = mask_ball()
    voxels, _, _, _ = digital_surface(mask)
    pick = np.array([5, 0, len(voxels) - 1, 5])
    np.testing.assert_array_equal(surface_vertex_of_voxels(voxels, voxels[pick], mask.shape), pick)
    with pytest.raises(SampleError, match="not on boundary voxels"):
        surface_vertex_of_voxels(voxels, [[8, 8, 8]], mask.shape)
    with pytest.raises(SampleError, match="outside the grid"):
        surface_vertex_of_voxels(voxels, [[0, 0, 99]], mask.shape)


@pytest.mark.parametrize("bad", [(1.0, 2.0), (np.nan, 0.0, 0.0), "abc", None])
def test_bad_spacing_and_origin_are_mesh_errors(bad):
    mask = mask_ball()
    with pytest.raises(MeshError) as info:
        digital_surface(mask, origin=bad)
    assert "origin" in one_line(info) and not isinstance(info.value, SampleError)
    with pytest.raises(MeshError) as info:
        digital_surface(mask, spacing=bad)
    assert "spacing" in one_line(info) and not isinstance(info.value, SampleError)


# ---------------------------------------------------------------------------
# voxelisation
# ---------------------------------------------------------------------------


SPHERE5 = icosphere(5)


def test_voxelize_sphere_volume():
    V, F = SPHERE5
    mask, h, origin = voxelize(V, F, resolution=64)
    assert mask.dtype == bool and mask.ndim == 3
    assert h.shape == (3,) and (h == h[0]).all() and h[0] == pytest.approx(2.0 / 64, rel=1e-6)
    volume = mask.sum() * h[0] ** 3
    # measured 1.0009 of the ball; the polyhedron (inscribed in the unit sphere) is 0.9995 of it
    assert abs(volume / (4 / 3 * np.pi) - 1) < 0.02
    assert abs(volume / enclosed_volume(V, F) - 1) < 0.02
    assert enclosed_volume(V, F) < 4 / 3 * np.pi


def test_voxelize_inside_is_inside():
    V, F = SPHERE5
    mask, h, origin = voxelize(V, F, resolution=32)
    r = np.linalg.norm(voxel_centres(mask.shape, h, origin), axis=1).reshape(mask.shape)
    # the polyhedron lies in the unit ball and contains the ball of radius 0.999
    assert mask[r < 1 - 0.25 * h[0]].all()
    assert not mask[r > 1 + 0.25 * h[0]].any()
    for a in range(3):  # the padding layers are empty
        assert not np.take(mask, [0, -1], axis=a).any()


def test_voxelize_open_surface():
    V, F = SPHERE5
    with pytest.raises(MeshError) as info:
        voxelize(V, F[1:], resolution=16)
    msg = one_line(info)
    assert "open" in msg and "3 boundary edges" in msg and "allow_open" in msg


def test_voxelize_small_hole_with_allow_open():
    V, F = SPHERE5
    # one triangle missing: winding numbers barely notice
    mask, h, _ = voxelize(V, F[1:], resolution=64, allow_open=True)
    assert abs(mask.sum() * h[0] ** 3 / (4 / 3 * np.pi) - 1) < 0.03


@pytest.mark.parametrize("bad", [1, 0, -5, "many", None])
def test_voxelize_bad_resolution(bad):
    with pytest.raises(SampleError) as info:
        voxelize(*icosphere(1), resolution=bad)
    assert "resolution" in one_line(info)



@pytest.mark.parametrize("res, stretch", [(8, (1.0, 1.0, 1.0)), (17, (1.0, 0.4, 2.5)), (30, (0.3, 1.0, 0.7))])
def test_voxel_grid_is_the_grid_voxelize_uses(res, stretch):
    V, F = icosphere(2)
    V = V * stretch + [3.0, -1.0, 0.5]
    mask, h, origin = voxelize(V, F, resolution=res)
    shape, h2, origin2 = voxel_grid(V, res)
    assert shape == mask.shape and max(shape) == res + 2  # the longest side, padded by one layer each end
    assert np.array_equal(h, np.full(3, h2)) and np.array_equal(origin, origin2)
    # the grid is centred on the bounding box and covers it
    lo, hi = V.min(axis=0), V.max(axis=0)
    far = origin + (np.array(shape) - 1) * h2
    assert np.allclose((origin + far) / 2, (lo + hi) / 2)
    assert (origin < lo).all() and (far > hi).all()

# ---------------------------------------------------------------------------
# tetrahedralisation (tetgen), and the boundary vertices of a tet solid
# ---------------------------------------------------------------------------


def cyclic(F):
    """Oriented triangles as a set, each rotated to start at its smallest vertex."""
    out = set()
    for f in np.asarray(F).tolist():
        k = f.index(min(f))
        out.add(tuple(f[k:] + f[:k]))
    return out


@needs_tetgen
@pytest.mark.parametrize("kwargs", [{}, {"quality": False}, {"max_volume": 0.002}])
def test_tetrahedralize_ball_keeps_the_surface(kwargs):
    V, F = icosphere(3)
    TV, TT = tetrahedralize(V, F, **kwargs)
    assert TV.dtype == np.float64 and TT.dtype == np.int64 and TT.shape[1] == 4
    np.testing.assert_array_equal(TV[:len(V)], V)
    vol = volumes(TV, TT)
    assert (vol > 0).all()
    assert vol.sum() == pytest.approx(enclosed_volume(V, F), rel=1e-12)  # exactly the polyhedron
    assert abs(vol.sum() / (4 / 3 * np.pi) - 1) < 0.015
    assert cyclic(boundary_faces(TT)) == cyclic(F)  # the input triangles, outward like icosphere's
    if kwargs.get("quality") is False:
        assert len(TV) == len(V)


@needs_tetgen
def test_tetrahedralize_max_volume_refines_the_inside():
    V, F = icosphere(3)
    _, coarse = tetrahedralize(V, F)
    TV, TT = tetrahedralize(V, F, max_volume=0.001)
    assert len(TT) > 2 * len(coarse)
    inside = ~np.isin(TT, np.arange(len(V))).any(axis=1)
    assert np.median(volumes(TV, TT)[inside]) <= 0.001


@needs_tetgen
def test_tetrahedralize_is_in_the_units_of_V():
    V, F = icosphere(2)
    s = 2.0**-10  # exact in floating point: tetgen sees the same problem, scaled
    TV, TT = tetrahedralize(V * s, F, max_volume=0.002 * s**3)
    TV1, TT1 = tetrahedralize(V, F, max_volume=0.002)
    assert len(TT1) > 2 * len(tetrahedralize(V, F)[1])
    np.testing.assert_array_equal(TT, TT1)
    np.testing.assert_array_equal(TV, TV1 * s)


@needs_tetgen
def test_tetrahedralize_open_surface():
    V, F = icosphere(2)
    with pytest.raises(MeshError) as info:
        tetrahedralize(V, F[1:])
    msg = one_line(info)
    assert "3 boundary edges" in msg and "close the holes" in msg


@needs_tetgen
def test_tetrahedralize_self_intersecting_surface(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    V, F = icosphere(2)
    V2, F2 = np.vstack([V, V + [0.5, 0.0, 0.0]]), np.vstack([F, F + len(V)])  # two overlapping spheres
    with pytest.raises(MeshError) as info:
        tetrahedralize(V2, F2)
    assert "self-intersection" in one_line(info)
    assert list(tmp_path.iterdir()) == []  # tetgen's leftover files stay in its own temporary directory


@needs_tetgen
@pytest.mark.parametrize("bad", [0, -1.0, np.inf, float("nan"), "big"])
def test_tetrahedralize_bad_max_volume(bad):
    with pytest.raises(OptionError) as info:
        tetrahedralize(*icosphere(1), max_volume=bad)
    assert "max_volume" in one_line(info)


def test_tetrahedralize_without_tetgen(monkeypatch):
    monkeypatch.setitem(sys.modules, "tetgen", None)
    with pytest.raises(ImportError, match=r"pip install 'manifill\[volume\]'"):
        tetrahedralize(*icosphere(1))


@needs_tetgen
def test_boundary_vertices_are_the_vertices_of_the_boundary_faces():
    V, F = icosphere(2)
    TV, TT = tetrahedralize(V, F, max_volume=0.01)
    b = boundary_vertices(TT)
    np.testing.assert_array_equal(b, np.arange(len(V)))  # tetgen keeps the surface, and adds nothing on it
    np.testing.assert_array_equal(boundary_vertices(TT, V=TV), b)
    # every other vertex is surrounded: the tets around it close up (no face on the boundary)
    inner = np.setdiff1d(np.arange(len(TV)), b)
    assert inner.size and not np.isin(boundary_faces(TT), inner).any()


def test_boundary_vertices_of_a_tet_fan():
    V = np.array([[0.0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2], [0.4, 0.4, 0.4]])
    T = [[0, 1, 2, 4], [0, 1, 4, 3], [0, 4, 2, 3], [4, 1, 2, 3]]  # four tets around the inner vertex 4
    assert boundary_vertices(T).tolist() == [0, 1, 2, 3]
    assert boundary_vertices(np.array(T)[:, [1, 0, 2, 3]], V=V).tolist() == [0, 1, 2, 3]  # either orientation
    assert boundary_vertices(T[:3]).tolist() == [0, 1, 2, 3, 4]  # one tet gone: 4 is on the boundary
    with pytest.raises(MeshError):
        boundary_vertices([[0, 1, 2]])


@pytest.mark.parametrize("module", ["boundary", "voxelize", "tetrahedralize", "estimates"])
def test_doctests(module):
    if module == "tetrahedralize" and not HAVE_TETGEN:
        pytest.skip("the tetrahedralize example needs tetgen")
    mod = getattr(manifill.solid, module)
    result = doctest.testmod(mod, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0
