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

import igl
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import dense
from manifill import HarmonicSolver, MeshError, SampleError, harmonic, laplacian, reconstruct
from manifill.curves import curve_graph, vertex_normals
from manifill.geodesic import mesh_graph
from manifill.samples import Samples, snap_to_vertices
from manifill.shapes import icosphere
from manifill.topology import clean_mesh, mesh_info
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
    *({"curve_values": c, "partition": p, "distance": d}
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


@pytest.mark.parametrize("opts", [{}, {"partition": "cycle"}, {"curve_values": "linear", "weights": "intrinsic"}])
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
