"""Coordinates at any scale: results at 1e+-150 equal the unit-scale ones.

Every quantity manifill computes from positions is either scale-free (Laplacian
weights, normals, reconstructed values: the same for ``V * s`` as for ``V``) or
has units (lengths scale by ``s``, areas by ``s**2``). Products of coordinates
overflow at ``1e155`` and underflow at ``1e-155`` in floating point, so these
properties hold only if the positions are normalised internally; each test here
compares a scaled mesh with the unscaled one (or with libigl / plain numpy on the
unscaled mesh), to ``1e-10`` relative to the range of the result.
"""

import math
import re

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from conftest import dense
from manifill import HarmonicSolver, MeshError, SampleError, harmonic, laplacian, reconstruct
from manifill.surface.curve_values import curve_graph, vertex_normals
from manifill.mesh.graph import mesh_graph
from manifill.surface.samples import Samples, snap_to_vertices
from manifill.mesh.shapes import icosphere
from manifill.mesh.clean import clean_mesh
from manifill.mesh.topology import mesh_info
from manifill.validate import (
    UNIT_WINDOW,
    as_mesh,
    as_tets,
    bbox_diagonal,
    double_areas,
    duplicate_vertex_pairs,
    unit_scale,
    zero_area_faces,
)

SCALES = [1e-150, 1e-30, 1.0, 1e30, 1e150]
EXTREME = [1e-300, 1e-200, 1e-160, 1e160, 1e200, 1e300]
hsettings = settings(max_examples=25, deadline=None, derandomize=True, database=None)
scale_exponent = st.floats(min_value=-150, max_value=150, allow_nan=False)


def jittered_sphere(k=2, seed=1):
    """An icosphere with every vertex moved a little: no two triangles alike, no ties in distances."""
    V, F = icosphere(k)
    V = V + 0.01 * np.random.default_rng(seed).standard_normal(V.shape)
    return V, F


V0, F0 = jittered_sphere()
IDX = np.arange(0, len(V0), 9)


def field(V):
    return np.sin(2 * V[:, 0]) + V[:, 1] * V[:, 2] + 0.5 * V[:, 2]


VALS = field(V0)[IDX]


def assert_same(x, ref, rtol=1e-10):
    """``x`` equals ``ref`` to ``rtol`` times the range of ``ref``, NaN where ``ref`` is NaN."""
    x, ref = np.asarray(x), np.asarray(ref)
    assert x.shape == ref.shape
    assert np.array_equal(np.isnan(x), np.isnan(ref))
    ok = ~np.isnan(ref)
    span = max(float(np.ptp(ref[ok])), float(np.abs(ref[ok]).max()), 1e-300)
    np.testing.assert_allclose(x[ok], ref[ok], rtol=0, atol=rtol * span)


def naive_double_areas(V, F):
    u, v = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    return np.linalg.norm(np.cross(u, v), axis=1)


# ---------------------------------------------------------------------------
# the scale itself, and the measures with units
# ---------------------------------------------------------------------------


@given(scale_exponent)
@hsettings
def test_unit_scale_is_a_power_of_two_that_brings_the_mesh_to_unit_size(e):
    s = 10.0**e
    V = V0 * s
    u = unit_scale(V)
    assert math.frexp(u)[0] == 0.5  # a power of two: dividing by it is exact
    half = 0.5 * float(np.ptp(V, axis=0).max())
    if -UNIT_WINDOW <= math.frexp(half)[1] <= UNIT_WINDOW:
        assert u == 1.0  # meshes of ordinary size are used bit for bit as they are
    else:
        assert 0.5 <= half / u < 1.0
    assert np.array_equal((V / u) * u, V)


def test_unit_scale_is_one_for_ordinary_meshes_and_far_origins():
    assert unit_scale(V0) == 1.0
    assert unit_scale(V0 * 1e-6) == 1.0  # micrometres
    assert unit_scale(V0 + 1e6) == 1.0  # the extent decides, not the origin
    assert unit_scale(np.zeros((3, 3))) == 1.0
    assert unit_scale(np.full((2, 3), 1e200)) == 2.0**665  # coinciding points: their size decides


@pytest.mark.parametrize("s", SCALES + EXTREME)
def test_bbox_diagonal_scales_by_s_and_matches_hypot(s):
    V = V0 * s
    ref = math.hypot(*(float(V[:, k].max()) - float(V[:, k].min()) for k in range(3)))  # overflow-safe
    assert bbox_diagonal(V) == pytest.approx(ref, rel=1e-15)
    assert bbox_diagonal(V) == pytest.approx(s * bbox_diagonal(V0), rel=1e-15)


@pytest.mark.parametrize("s", SCALES)
def test_double_areas_scale_by_s_squared(s):
    ref = naive_double_areas(V0, F0)
    np.testing.assert_allclose(double_areas(V0 * s, F0), ref * s * s, rtol=1e-13)


def test_double_areas_exact_under_powers_of_two():
    for k in (-498, -300, 0, 300, 498):
        s = 2.0**k
        A = double_areas(V0 * s, F0)
        assert np.array_equal(A, naive_double_areas(V0, F0) * s * s)


# ---------------------------------------------------------------------------
# validation: no false zero-area faces, real ones found at every scale
# ---------------------------------------------------------------------------


def mesh_with_degenerate_faces():
    """The sphere plus a collinear face (a vertex in the middle of an edge) and a sliver of area 1e-17."""
    V, F = V0.copy(), F0.copy()
    a, b = F[0, 0], F[0, 1]
    mid = 0.5 * (V[a] + V[b])
    sliver = V[a] + 0.3 * (V[b] - V[a]) + 1e-17 * np.cross(V[b] - V[a], V[a])
    V = np.vstack([V, mid, sliver])
    n = len(V0)
    F = np.vstack([F, [[a, n, b], [a, n + 1, b]]])
    return V, F, [len(F0), len(F0) + 1]


@pytest.mark.parametrize("s", SCALES + EXTREME)
def test_as_mesh_reports_no_false_zero_area_faces(s):
    V, F = as_mesh(V0 * s, F0)
    assert not zero_area_faces(V, F).any()
    assert mesh_info(V, F)["zero_area_faces"] == 0
    assert laplacian(V, F, weights="cotan").shape == (len(V0), len(V0))


@pytest.mark.parametrize("s", SCALES + EXTREME)
def test_degenerate_faces_are_found_at_every_scale(s):
    V, F, bad = mesh_with_degenerate_faces()
    V = V * s
    assert np.flatnonzero(zero_area_faces(V, F)).tolist() == bad
    with pytest.raises(MeshError, match=f"2 faces have zero area \\(faces {bad[0]}, {bad[1]}\\)"):
        as_mesh(V, F)
    assert mesh_info(V, F)["zero_area_faces"] == 2
    V2, F2, vmap = clean_mesh(V, F)
    assert len(F2) == len(F0) and len(V2) == len(V0)
    assert np.array_equal(vmap[: len(V0)], np.arange(len(V0)))


@pytest.mark.parametrize("s", SCALES + EXTREME)
def test_degenerate_tets_are_found_at_every_scale(s):
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.3, 0.3, 0]]) * s
    as_tets(V[:4], [[0, 1, 2, 3]])  # a real tetrahedron is no false alarm
    with pytest.raises(MeshError, match=r"1 tetrahedra have zero volume \(tetrahedra 1\)"):
        as_tets(V, [[0, 1, 2, 3], [0, 1, 2, 4]])  # vertex 4 lies in the plane of 0, 1, 2


@pytest.mark.parametrize("s", SCALES + EXTREME)
def test_duplicates_keep_their_relative_tolerance_at_every_scale(s):
    diag = bbox_diagonal(V0)
    V = np.vstack([V0, V0[7] + [1e-14 * diag, 0, 0], V0[9] + [1e-9 * diag, 0, 0]]) * s
    assert duplicate_vertex_pairs(V).tolist() == [[7, len(V0)]]
    F = np.vstack([F0, F0[:1]])
    F[-1] = [len(V0), len(V0) + 1, F0[0, 2]]
    with pytest.raises(MeshError, match=f"1 pairs of vertices coincide \\(first: 7 and {len(V0)}\\)"):
        as_mesh(V, F)
    V2, F2, vmap = clean_mesh(V, F)
    assert vmap[len(V0)] == 7 and len(V2) == len(V0) + 1


@pytest.mark.parametrize("s", SCALES)
def test_mesh_info_and_clean_mesh_at_scale(s):
    ref = mesh_info(V0, F0)
    info = mesh_info(V0 * s, F0)
    assert info["diagonal"] == pytest.approx(s * ref["diagonal"], rel=1e-14)
    np.testing.assert_allclose(info["bbox_min"], np.array(ref["bbox_min"]) * s, rtol=1e-15)
    for key in ("vertices", "faces", "edges", "unreferenced_vertices", "coinciding_vertex_pairs",
                "zero_area_faces", "nonmanifold_edges", "boundary_loops", "components"):
        assert info[key] == ref[key], key
    V2, F2, vmap = clean_mesh(V0 * s, F0)
    assert np.array_equal(F2, F0) and np.array_equal(vmap, np.arange(len(V0)))
    assert np.array_equal(V2, V0 * s)


# ---------------------------------------------------------------------------
# Laplacians, graphs, normals
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("weights", ["uniform", "cotan", "intrinsic", "robust"])
@pytest.mark.parametrize("s", SCALES + [1e-300, 1e300])
def test_laplacian_is_scale_free(weights, s):
    ref = dense(laplacian(V0, F0, weights=weights))
    L = dense(laplacian(V0 * s, F0, weights=weights))
    assert np.isfinite(L).all()
    np.testing.assert_allclose(L, ref, rtol=0, atol=1e-10 * np.abs(ref).max())
    if weights == "cotan":  # and equal to libigl's on the unscaled mesh
        igl = pytest.importorskip("igl")
        C = dense(igl.cotmatrix(V0, F0.astype(np.int64)))
        np.testing.assert_allclose(L, -C, rtol=0, atol=1e-10 * np.abs(C).max())


@given(scale_exponent)
@hsettings
def test_cotan_laplacian_is_scale_free_for_any_scale(e):
    L = dense(laplacian(V0 * 10.0**e, F0))
    ref = dense(laplacian(V0, F0))
    np.testing.assert_allclose(L, ref, rtol=0, atol=1e-10 * np.abs(ref).max())


def test_anisotropic_scale_keeps_its_shape():
    """Axes of 1e150, 1e148, 1e149 give the Laplacian of axes 100, 1, 10: the normalisation is one factor."""
    A = V0 * [100.0, 1.0, 10.0]
    ref = dense(laplacian(A, F0))
    L = dense(laplacian(V0 * [1e150, 1e148, 1e149], F0))
    np.testing.assert_allclose(L, ref, rtol=0, atol=1e-10 * np.abs(ref).max())
    assert not np.allclose(ref, dense(laplacian(V0, F0)))  # the shape does change the weights


@pytest.mark.parametrize("s", SCALES + EXTREME)
def test_length_graph_and_normals_are_scale_free(s):
    G, ref = mesh_graph(V0 * s, F0, distance="length"), mesh_graph(V0, F0, distance="length")
    assert_same(G.toarray(), ref.toarray())
    assert_same(vertex_normals(V0 * s, F0), vertex_normals(V0, F0))
    E = np.array([[0, 1], [2, 5], [3, 4]])
    lengths = curve_graph(V0 * s, E, len(V0))[E[:, 0], E[:, 1]]
    np.testing.assert_allclose(lengths / s, np.linalg.norm(V0[E[:, 0]] - V0[E[:, 1]], axis=1), rtol=1e-14)


# ---------------------------------------------------------------------------
# harmonic extension and reconstruction
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("weights", ["uniform", "cotan", "intrinsic", "robust"])
@pytest.mark.parametrize("s", SCALES)
def test_harmonic_is_scale_free(weights, s):
    ref = harmonic(V0, F0, IDX, VALS, weights=weights)
    assert_same(harmonic(V0 * s, F0, IDX, VALS, weights=weights), ref)
    solver = HarmonicSolver(V0 * s, F0, IDX, weights=weights)
    assert_same(solver.solve(np.column_stack([VALS, -VALS])), np.column_stack([ref, -ref]))


RECONSTRUCTIONS = [
    {},
    {"method": "harmonic"},
    {"method": "gvf"},
    {"method": "hessian"},
    *({"method": "gvf-harmonic", "curve_values": c, "partition": p, "distance": d}
      for c in ("hermite", "linear", "gvf") for p in ("delaunay", "cycle", "tree") for d in ("length", "hops")),
]

_reference = {}


def reference(opts):
    key = tuple(sorted(opts.items()))
    if key not in _reference:
        _reference[key] = reconstruct(V0, F0, IDX, VALS, **opts).values
    return _reference[key]


@pytest.mark.parametrize("opts", RECONSTRUCTIONS, ids=lambda o: "-".join(o.values()) or "default")
@pytest.mark.parametrize("s", [1e-150, 1e-30, 1e30, 1e150])
def test_reconstruct_is_scale_free(opts, s):
    r = reconstruct(V0 * s, F0, IDX, VALS, **opts)
    assert_same(r.values, reference(opts))
    assert np.array_equal(r.values[IDX], VALS)


@pytest.mark.parametrize("opts", [{}, {"method": "gvf-harmonic", "partition": "cycle"},
                                  {"method": "gvf-harmonic", "curve_values": "linear", "weights": "intrinsic"}])
def test_reconstruct_far_from_the_origin(opts):
    """A translation by 1e6 changes nothing but the rounding of the positions themselves."""
    W = V0 + [1e6, -2e6, 3e5]
    back = W - [1e6, -2e6, 3e5]  # exact: the same rounded positions, near the origin
    assert_same(reconstruct(W, F0, IDX, VALS, **opts).values, reconstruct(back, F0, IDX, VALS, **opts).values)
    assert_same(laplacian(W, F0).toarray(), laplacian(back, F0).toarray())


# ---------------------------------------------------------------------------
# samples given as positions
# ---------------------------------------------------------------------------


def sample_points(rng):
    """Points near random vertices, off the surface by up to a fifth of an edge."""
    idx = rng.choice(len(V0), 20, replace=False)
    return idx, V0[idx] + rng.uniform(-0.02, 0.02, (idx.size, 3))


def nearest_vertex(P):
    return np.array([int(np.argmin(((V0 - p) ** 2).sum(axis=1))) for p in P])


@given(scale_exponent)
@hsettings
def test_snapped_points_land_on_the_same_vertices_at_any_scale(e):
    s = 10.0**e
    _, P = sample_points(np.random.default_rng(5))
    idx, dist = snap_to_vertices(V0 * s, P * s)
    assert np.array_equal(idx, nearest_vertex(P))
    np.testing.assert_allclose(dist / s, np.linalg.norm(P - V0[idx], axis=1), rtol=1e-10)


@pytest.mark.parametrize("s", SCALES + EXTREME)
def test_samples_from_points_scale(s):
    rng = np.random.default_rng(2)
    _, P = sample_points(rng)
    vals = rng.standard_normal(len(P))
    ref = Samples.from_points(V0, P, vals)
    got = Samples.from_points(V0 * s, P * s, vals)
    assert np.array_equal(got.idx, ref.idx) and np.array_equal(got.vals, ref.vals)
    np.testing.assert_allclose(got.snap_distance, ref.snap_distance * s, rtol=1e-10)


@pytest.mark.parametrize("s", SCALES + EXTREME)
def test_max_distance_is_in_the_users_units(s):
    P = (V0[3] + [0.3, 0.0, 0.0])[None] * s
    d = float(np.linalg.norm(V0 - V0[3] - [0.3, 0, 0], axis=1).min()) * s
    idx, dist = snap_to_vertices(V0 * s, P, max_distance=1.01 * d)
    assert dist[0] == pytest.approx(d, rel=1e-12)
    with pytest.raises(SampleError, match="1 samples lie far from the mesh"):
        snap_to_vertices(V0 * s, P, max_distance=0.99 * d)


def test_far_points_of_a_tiny_mesh_are_reported_not_crashed():
    """Positions whose squared distances overflow in the mesh's units are far, with their true distance."""
    for s, far in ((1e-200, 1e200), (1e-150, 1e150), (1.0, 1e300)):
        with pytest.raises(SampleError, match=re.escape(f"row 1: {far:.3g} from the nearest vertex")):
            snap_to_vertices(V0 * s, [V0[0] * s, [far, 0.0, 0.0]])


# ---------------------------------------------------------------------------
# solids: voxelisation, tetrahedralisation, the harmonic fill
# ---------------------------------------------------------------------------

from manifill.linalg import gridmg as gridsolver  # noqa: E402
from manifill.errors import ResourceError  # noqa: E402
from manifill.solid.boundary import boundary_voxels, surface_to_points  # noqa: E402
from manifill.solid.estimates import reconstruct_volume_memory  # noqa: E402
from manifill.solid.reconstruct_volume import reconstruct_volume  # noqa: E402
from manifill.solid.tetrahedralize import tet_count, tetrahedralize, tetrahedralize_memory  # noqa: E402
from manifill.solid.tets import boundary_faces, tet_volumes  # noqa: E402
from manifill.solid.fill import VoxelFill, harmonic_fill, tet_fill  # noqa: E402
from manifill.solid.voxelize import voxelize, voxelize_memory  # noqa: E402

_solid_reference = {}


def solid_reference(key, make):
    """``make()`` at unit scale, computed once per key."""
    if key not in _solid_reference:
        _solid_reference[key] = make()
    return _solid_reference[key]


def sorted_rows(F):
    F = np.sort(np.asarray(F), axis=1)
    return F[np.lexsort(F.T[::-1])]


@pytest.mark.parametrize("s", SCALES)
def test_voxelize_is_scale_free(s):
    """The same voxels at every scale; the grid's spacing and origin scale by s, the memory estimate not at all."""
    mask0, h0, o0 = solid_reference("voxelize", lambda: voxelize(V0, F0, resolution=24))
    mask, h, origin = voxelize(V0 * s, F0, resolution=24)
    assert np.array_equal(mask, mask0) and 2000 < mask.sum() < mask.size / 2
    np.testing.assert_allclose(h, h0 * s, rtol=1e-14)
    np.testing.assert_allclose(origin, o0 * s, rtol=1e-14)
    for res in (24, 300):  # the band of winding numbers holds at every scale (areas over h^2)
        assert voxelize_memory(V0 * s, F0, res) == pytest.approx(voxelize_memory(V0, F0, res), rel=1e-9)


def test_voxelize_far_from_the_origin():
    """A solid at 1e9 of size 1 (libigl's winding numbers are single precision) gives the voxels of the same
    solid at the origin, translated exactly."""
    shift = np.array([1e9, -2e9, 3e9])
    W = V0 + shift
    back = W - shift  # exact
    mask, h, origin = voxelize(W, F0, resolution=24)
    mask0, h0, o0 = voxelize(back, F0, resolution=24)
    assert np.array_equal(mask, mask0) and mask.any()
    assert np.array_equal(h, h0)
    np.testing.assert_allclose(origin - shift, o0, rtol=0, atol=1e-6)


def voxel_ball(shape=(16, 14, 18)):
    """An ellipsoid of voxels filling about half of the box, and its boundary voxels."""
    x = np.indices(shape).T - (np.array(shape) - 1) / 2
    mask = ((x / (np.array(shape) / 2 - 1)) ** 2).sum(axis=-1).T < 1
    return mask, boundary_voxels(mask)


@pytest.mark.parametrize("solver", ["auto", "amg", "direct"])
@pytest.mark.parametrize("c", [6, 26])
@pytest.mark.parametrize("s", SCALES + [1e-300, 1e300])
def test_harmonic_fill_is_scale_free(monkeypatch, s, c, solver):
    """Only the ratios of the spacing matter; weights of 1/h^2 in single precision vanish at h = 1e30."""
    monkeypatch.setattr(gridsolver, "COARSE_MAX", 60)  # several multigrid levels on a small grid
    mask, fixed = voxel_ball()
    g = np.random.default_rng(4).standard_normal(mask.shape + (2,))
    h = np.array([1.0, 2.0, 1.5])
    voxels = np.argwhere(fixed)
    ref = solid_reference(("fill", c, solver), lambda: harmonic_fill(mask, voxels, g[fixed], spacing=h,
                                                                     connectivity=c, solver=solver))
    assert_same(harmonic_fill(mask, voxels, g[fixed], spacing=h * s, connectivity=c, solver=solver), ref)
    fill = VoxelFill(mask, voxels, spacing=h * s, connectivity=c, solver=solver)
    assert_same(fill.solve(g[fixed][:, 0]), ref[..., 0])
    assert fill.report["spacing"] == (h * s).tolist()  # reported in the user's units
    if solver != "direct":
        assert fill.report.get("levels", 2) >= 2 and "fallback" not in fill.report


@pytest.mark.parametrize("s", SCALES)
def test_surface_to_points_is_scale_free(s):
    """The closest surface point's linear interpolation: a linear field there is its value at the closest point
    (libigl on the unscaled mesh), the distance scales by s."""
    rng = np.random.default_rng(6)
    P = V0[::4] * rng.uniform(0.6, 1.4, (len(V0[::4]), 1)) + rng.normal(0, 0.02, (len(V0[::4]), 3))
    igl = pytest.importorskip("igl")
    d2, _, C = igl.point_mesh_squared_distance(P, V0, F0.astype(np.int64))
    a = np.array([[1.0, -2.0], [0.5, 3.0], [2.0, 1.0]])
    vals, dist = surface_to_points(V0 * s, F0, V0 @ a, P * s)
    assert_same(vals, C @ a)
    np.testing.assert_allclose(dist / s, np.sqrt(d2), rtol=1e-10)
    one, _ = surface_to_points(V0 * s, F0, V0 @ a[:, 0], P * s)
    assert_same(one, C @ a[:, 0])


# Until reconstruct_volume's memory estimate divides the volume by h**3 scale-free, it overflows (1e150) or
# divides by zero (1e-150) before anything else runs; the rest of the voxel path is checked there.

@pytest.mark.parametrize("s", [1e-30, 1.0, 1e30, 1e-150, 1e150])
def test_reconstruct_volume_voxels_is_scale_free(s):
    ref = solid_reference("rv-voxels", lambda: reconstruct_volume(V0, F0, IDX, VALS, resolution=24))
    r = reconstruct_volume(V0 * s, F0, IDX, VALS, resolution=24)
    assert np.array_equal(r.mask, ref.mask) and np.array_equal(r.fixed, ref.fixed)
    np.testing.assert_allclose(r.spacing, ref.spacing * s, rtol=1e-14)
    np.testing.assert_allclose(r.origin, ref.origin * s, rtol=1e-14)
    assert_same(r.values, ref.values)  # NaN outside the same solid
    assert_same(r.values[r.fixed], ref.values[ref.fixed])
    assert r.report["boundary_distance_max"] == pytest.approx(ref.report["boundary_distance_max"], rel=1e-9)
    assert r.report["fill"]["levels"] == ref.report["fill"]["levels"] >= 2
    assert reconstruct_volume_memory(V0 * s, F0, resolution=24) == pytest.approx(
        reconstruct_volume_memory(V0, F0, resolution=24), rel=1e-9)


@pytest.mark.parametrize("s", SCALES)
def test_reconstruct_volume_tets_is_scale_free(s):
    """TetGen meshes V / s (exactly): the surface vertices come back as they were, the tets are positive, the
    values equal the unscaled ones at the surface, and on the unscaled tet mesh scaled by s everywhere."""
    ref = solid_reference("rv-tets", lambda: reconstruct_volume(V0, F0, IDX, VALS, form="tets"))
    r = reconstruct_volume(V0 * s, F0, IDX, VALS, form="tets")
    n = len(V0)
    assert np.array_equal(r.TV[:n], V0 * s)
    assert (tet_volumes(r.TV / s, r.TT) > 0).all()
    assert np.array_equal(sorted_rows(boundary_faces(r.TT)), sorted_rows(F0))
    assert abs(len(r.TV) - len(ref.TV)) <= 0.1 * len(ref.TV)
    assert_same(r.values[:n], ref.values[:n])
    everywhere = tet_fill(ref.TV * s, ref.TT, np.arange(n), r.values[:n])
    assert_same(everywhere, ref.values)
    assert reconstruct_volume_memory(V0 * s, F0, form="tets") == pytest.approx(
        reconstruct_volume_memory(V0, F0, form="tets"), rel=1e-9)


@pytest.mark.parametrize("s", SCALES)
def test_tetrahedralize_and_its_estimate_are_scale_free(s):
    """max_volume is in the units of V: scaled by s**3 it gives the mesh of the unscaled bound."""
    n = len(V0)
    bounded = abs(math.log10(s)) < 100  # 1e-3 * s**3 is a float
    mv = 1e-2 * s**3 if bounded else None
    TV0, TT0 = solid_reference(("tetgen", bounded), lambda: tetrahedralize(V0, F0, max_volume=1e-2 if bounded
                                                                            else None))
    TV, TT = tetrahedralize(V0 * s, F0, max_volume=mv)
    assert np.array_equal(TV[:n], V0 * s) and (tet_volumes(TV / s, TT) > 0).all()
    assert abs(len(TT) - len(TT0)) <= 0.05 * len(TT0)
    assert tet_volumes(TV / s, TT).sum() == pytest.approx(tet_volumes(TV0, TT0).sum(), rel=1e-9)
    ref = 1e-2 if bounded else None
    assert tet_count(V0 * s, F0, max_volume=mv) == pytest.approx(tet_count(V0, F0, max_volume=ref), abs=1)
    assert tetrahedralize_memory(V0 * s, F0, max_volume=mv) == pytest.approx(
        tetrahedralize_memory(V0, F0, max_volume=ref), rel=1e-9)


def test_max_volume_beyond_the_floats_of_the_mesh():
    """A bound larger than the whole solid is no bound; one that is nothing next to it is refused up front."""
    for bound in (1e300, 5e-324):  # the solid of 1e-150 has a volume of 4e-450: any float bound is beyond it
        assert tet_count(V0 * 1e-150, F0, max_volume=bound) == tet_count(V0, F0)
        assert tetrahedralize_memory(V0 * 1e-150, F0, max_volume=bound) == tetrahedralize_memory(V0, F0)
    assert tet_count(V0 * 1e150, F0, max_volume=1e300) == tet_count(V0, F0, max_volume=4.2e-150)
    assert tet_count(V0 * 1e150, F0, max_volume=1.0) == 2**62  # 1e-450 of the solid's volume
    with pytest.raises(ResourceError, match=r"max_volume=1 \(more than 1e308 tets\).*raise max_volume"):
        tetrahedralize(V0 * 1e150, F0, max_volume=1.0)


@pytest.mark.parametrize("weights", ["cotan", "uniform"])
@pytest.mark.parametrize("s", SCALES + [1e-300, 1e300])
def test_tet_fill_and_boundary_faces_are_scale_free(s, weights):
    TV, TT = solid_reference(("tetgen", False), lambda: tetrahedralize(V0, F0))
    n = len(V0)
    bc = np.column_stack([field(V0), V0[:, 0]])
    ref = tet_fill(TV, TT, np.arange(n), bc, weights=weights)
    assert_same(tet_fill(TV * s, TT, np.arange(n), bc, weights=weights), ref)
    if weights == "cotan":  # reproduces linear functions on any tet mesh
        assert_same(ref[:, 1], TV[:, 0], rtol=1e-9)
    flipped = TT.copy()
    flipped[::3] = flipped[::3][:, [1, 0, 2, 3]]  # negatively oriented: the faces must be flipped back
    assert np.array_equal(rotated(boundary_faces(flipped, V=TV * s)), rotated(boundary_faces(TT)))


def rotated(F):
    """Each triangle turned to start at its smallest vertex (the same triangle, the same orientation), sorted."""
    F = np.asarray(F)
    k = np.argmin(F, axis=1)
    F = F[np.arange(len(F))[:, None], (k[:, None] + np.arange(3)) % 3]
    return F[np.lexsort(F.T[::-1])]


# ---------------------------------------------------------------------------
# every method, at any scale between 1e-8 and 1e8 (not only powers of two)
# ---------------------------------------------------------------------------

_RNG = np.random.default_rng(1)
_V3, _F3 = icosphere(3)
IRREGULAR = _V3 * (1 + 0.05 * _RNG.normal(size=(len(_V3), 1)))  # no two edges alike
IDX40 = np.sort(np.random.default_rng(0).choice(len(_V3), 40, replace=False))
UNIT = {}


PARTITIONED = ("default", "gvf-harmonic", "gvf")


@pytest.mark.parametrize("mesh, method", [(mesh, method) for method in PARTITIONED + ("harmonic", "biharmonic",
                                                                                     "triharmonic", "rbf", "gp")
                                           for mesh in ("regular", "irregular")])
@given(st.floats(-8.0, 8.0))
@example(-8.0)
@example(8.0)
@settings(max_examples=6, deadline=None, derandomize=True, database=None)
def test_every_method_is_invariant_to_the_meshs_units(mesh, method, e):
    # the default moved by 0.036 of the range at 1e8: Step 4's slopes (a quadratic fit whose conditioning test saw
    # the units), the vertex "a third along" a curve and, on regular meshes, the partition's equal shortest paths
    # were decided by rounding, which differs with the units (powers of two never showed it)
    V = _V3 if mesh == "regular" else IRREGULAR
    vals = np.sin(2 * V[IDX40, 0]) + V[IDX40, 1] * V[IDX40, 2]
    if (mesh, method) not in UNIT:
        UNIT[mesh, method] = reconstruct(V, _F3, IDX40, vals, method=method)
    ref = UNIT[mesh, method]
    s = 10.0 ** e * 1.2345  # never a power of two
    got = reconstruct(V * s, _F3, IDX40, vals, method=method)
    assert np.abs(got.values - ref.values).max() <= 1e-10 * np.ptp(vals)
    if ref.std is not None:  # the gp's std too (its scale was searched in fixed bounds: wrong at 1e8)
        assert np.abs(got.std - ref.std).max() <= 1e-9 * ref.std.max()


def test_partition_ties_on_a_regular_mesh():
    """Equal shortest paths (a regular mesh has many) are tied exactly and broken the same way at every scale."""
    V, F = icosphere(4)
    idx = np.random.default_rng(0).choice(len(V), 100, replace=False)
    vals = np.sin(2 * V[idx, 0]) + V[idx, 1] * V[idx, 2]
    got, ref = reconstruct(V * 3.0, F, idx, vals).values, reconstruct(V, F, idx, vals).values
    assert np.abs(got - ref).max() <= 1e-10 * np.ptp(vals)


@pytest.mark.parametrize("s", [1e-6, 1e9])
def test_the_gp_fit_and_std_follow_the_values_not_the_meshs_units(s):
    # the gp's error was 0.30 of the range on the Earth in millimetres (0.0108 at unit radius): its scale was
    # searched in fixed bounds. The same mesh in other units gives the same values and std; values x 1e3 give
    # the std x 1e3
    vals = np.sin(2 * IRREGULAR[IDX40, 0]) + IRREGULAR[IDX40, 1] * IRREGULAR[IDX40, 2]
    ref = reconstruct(IRREGULAR, _F3, IDX40, vals, method="gp")
    got = reconstruct(IRREGULAR * s, _F3, IDX40, vals, method="gp")
    assert np.abs(got.values - ref.values).max() <= 1e-8 * np.ptp(vals)
    assert np.abs(got.std - ref.std).max() <= 1e-8 * ref.std.max()
    big = reconstruct(IRREGULAR * s, _F3, IDX40, vals * 1e3, method="gp")
    np.testing.assert_allclose(big.std, 1e3 * ref.std, rtol=1e-8, atol=1e-8 * 1e3 * ref.std.max())
