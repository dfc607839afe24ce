"""Closest points on a triangle mesh (manifill.surface.locate) against libigl and brute force."""

import igl
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import grid, icosphere
from manifill.errors import SampleError
from manifill.surface.locate import closest_on_triangles, locate_points
from manifill.tolerances import TOL
from manifill.validate import bbox_diagonal


def bumpy(seed=0):
    """An icosphere with random radii (non-convex, uneven faces)."""
    V, F = icosphere(3)
    r = 1.0 + 0.3 * np.random.default_rng(seed).random(len(V))
    return V * r[:, None], F


def uneven():
    """A fine grid beside one huge triangle: the largest circumradius is far above the typical one."""
    V, F = grid(12)
    big = np.array([[1.5, -3.0, 0.2], [9.0, 0.5, -0.4], [1.5, 4.0, 0.1]])
    return np.vstack([V, big]), np.vstack([F, [[len(V), len(V) + 1, len(V) + 2]]])


def normals(V, F, f):
    n = np.cross(V[F[f, 1]] - V[F[f, 0]], V[F[f, 2]] - V[F[f, 0]])
    return n / np.linalg.norm(n, axis=1)[:, None]


def adversarial(V, F, seed=0, k=300):
    """Points on, just above and below vertices, edge midpoints and faces; and far around."""
    rng = np.random.default_rng(seed)
    f = rng.integers(0, len(F), k)
    N = normals(V, F, f)
    edge = 0.5 * (V[F[f, 0]] + V[F[f, 1]])
    vert = V[F[f, 2]]
    face = V[F[f]].mean(axis=1)
    out = [edge, vert, face]
    for eps in (1e-12, 1e-9, 1e-6, 1e-2, -1e-9, -1e-3):
        out += [edge + eps * N, vert + eps * N, face + eps * N]
    out.append(vert + 1e-10 * rng.normal(size=(k, 3)))
    out.append(rng.normal(size=(k, 3)) * np.ptp(V, axis=0))
    return np.vstack(out)


def check_against_igl(V, F, P):
    s = locate_points(V, F, P, max_distance=np.inf)
    d2, face, C = igl.point_mesh_squared_distance(P, V, F)
    d = np.sqrt(d2)
    diag = bbox_diagonal(V)
    # 1e-12 relative to the distance (to a thousandth of the mesh's size for points on the surface)
    assert np.all(np.abs(s.distance - d) <= 1e-12 * np.maximum(d, 1e-3 * diag))
    # the result is consistent: the closest point is on its face, at the reported distance
    assert np.all(s.bary >= 0) and np.allclose(s.bary.sum(axis=1), 1.0, rtol=0, atol=1e-15)
    assert np.allclose(np.einsum("kj,kjd->kd", s.bary, V[F[s.faces]]), s.points, rtol=0,
                       atol=10 * TOL.bary_vertex * diag)
    assert np.allclose(np.linalg.norm(P - s.points, axis=1), s.distance, rtol=1e-12, atol=1e-15 * diag)
    # on the same face (not a tie between faces), the same closest point
    same = face == s.faces
    assert np.all(np.abs(s.points[same] - C[same]) <= 1e-14 * diag)
    return s


@pytest.mark.parametrize("mesh", [lambda: icosphere(3), bumpy, uneven, lambda: grid(9)])
def test_distances_agree_with_igl_on_random_and_adversarial_points(mesh):
    V, F = mesh()
    check_against_igl(V, F, adversarial(V, F))


def test_every_face_is_a_candidate_when_it_should_be():
    """Brute force over every face on the mesh whose huge face defeats a nearest-centroid guess."""
    V, F = uneven()
    rng = np.random.default_rng(3)
    P = np.vstack([rng.uniform([-1, -4, -1], [10, 5, 1], size=(400, 3)), adversarial(V, F, 1, 50)])
    s = locate_points(V, F, P, max_distance=np.inf)
    k, m = len(P), len(F)
    pi, fi = np.repeat(np.arange(k), m), np.tile(np.arange(m), k)
    b = closest_on_triangles(P[pi], V[F[fi, 0]], V[F[fi, 1]], V[F[fi, 2]])
    Q = np.einsum("kj,kjd->kd", b, V[F[fi]])
    brute = np.sqrt(((P[pi] - Q) ** 2).sum(axis=1)).reshape(k, m).min(axis=1)
    assert np.all(np.abs(s.distance - brute) <= 1e-12 * np.maximum(brute, 1e-3))


@settings(max_examples=60, deadline=None)
@given(face=st.integers(0, 319), u=st.floats(0, 1), v=st.floats(0, 1),
       h=st.sampled_from([0.0, 1e-13, 1e-8, 1e-4, 0.05, -1e-8, -0.05]), edge=st.booleans())
def test_hypothesis_points_near_the_surface(face, u, v, h, edge):
    V, F = icosphere(2)
    if u + v > 1:
        u, v = 1 - u, 1 - v
    if edge:
        v = 0.0
    p = (1 - u - v) * V[F[face, 0]] + u * V[F[face, 1]] + v * V[F[face, 2]] + h * normals(V, F, [face])[0]
    check_against_igl(V, F, p[None])


def test_points_on_the_surface_are_found_where_they_are():
    V, F = icosphere(2)
    rng = np.random.default_rng(0)
    b = rng.dirichlet([1, 1, 1], size=200)
    f = rng.integers(0, len(F), 200)
    P = np.einsum("kj,kjd->kd", b, V[F[f]])
    s = locate_points(V, F, P)
    assert s.distance.max() < 1e-15
    assert np.allclose(s.points, P, rtol=0, atol=1e-15)
    assert np.all(s.vertex == -1) and np.all(s.inside)


def test_vertex_tolerance():
    V, F = icosphere(1)
    f = 5
    a = V[F[f, 0]]
    near = a + 1e-3 * TOL.bary_vertex * (V[F[f, 1]] - a)
    off = a + 1e3 * TOL.bary_vertex * (V[F[f, 1]] - a)
    s = locate_points(V, F, [a, near, off])
    assert s.vertex[0] == F[f, 0] and s.vertex[1] == F[f, 0] and s.vertex[2] == -1
    assert np.allclose(s.bary[:2].max(axis=1), 1.0, rtol=0, atol=0)
    assert s.nearest_vertex.tolist() == [F[f, 0]] * 3
    # a coordinate below the tolerance is zero: the point is on the opposite edge
    assert np.count_nonzero(s.bary[2]) == 2


@pytest.mark.parametrize("scale", [1e-150, 1e-7, 3.0, 1e150])
def test_scale_invariance(scale):
    V, F = bumpy(1)
    P = adversarial(V, F, 2, 40)
    ref = locate_points(V, F, P, max_distance=np.inf)
    got = locate_points(V * scale, F, P * scale, max_distance=np.inf)
    assert np.all(np.abs(got.distance / scale - ref.distance) <= 1e-12 * np.maximum(ref.distance, 1e-3))
    assert np.array_equal(got.vertex, ref.vertex)
    assert np.allclose(got.points / scale, ref.points, rtol=0, atol=1e-12)


def test_far_points_refused_with_the_snap_limit():
    V, F = icosphere(2)
    with pytest.raises(SampleError, match=r"1 samples lie far from the mesh \(row 1: .* from the surface.*wrong units"):
        locate_points(V, F, [[0.0, 0.0, 1.0], [0.0, 0.0, 900.0]])
    d = 899.0
    s = locate_points(V, F, [[0.0, 0.0, 900.0]], max_distance=d * (1 + 1e-9))
    assert s.distance[0] == pytest.approx(d, rel=1e-12)
    with pytest.raises(SampleError, match="accepted: 899"):
        locate_points(V, F, [[0.0, 0.0, 900.0]], max_distance=d * (1 - 1e-9))
    with pytest.raises(SampleError, match="far from the mesh"):
        locate_points(V, F, [[0.0, 0.0, 1e300]], max_distance=np.inf)
    with pytest.raises(SampleError, match="NaN or infinite"):
        locate_points(V, F, [[0.0, np.nan, 1.0]])
    with pytest.raises(SampleError, match="shape"):
        locate_points(V, F, [[0.0, 1.0, 1.0, 2.0]])


def test_flat_mesh_takes_2d_points():
    V, F = grid(5)
    P2 = np.array([[0.3, 0.6], [0.5, 0.5], [1.0, 1.0]])
    s = locate_points(V, F, P2)
    assert np.allclose(s.points[:, :2], P2, rtol=0, atol=1e-15) and np.all(s.points[:, 2] == 0)
    assert s.vertex[2] == np.flatnonzero((V[:, 0] == 1) & (V[:, 1] == 1))[0]


def test_degenerate_triangle_gives_its_longest_side():
    z = np.zeros((1, 3))
    b = closest_on_triangles(np.array([[0.5, 1.0, 0.0]]), z, np.array([[1.0, 0, 0]]), np.array([[2.0, 0, 0]]))
    assert np.allclose(b @ np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), [[0.5, 0, 0]])


def test_rows_interpolate_a_linear_field_exactly():
    V, F = bumpy(2)
    rng = np.random.default_rng(1)
    P = rng.normal(size=(50, 3))
    P /= np.linalg.norm(P, axis=1)[:, None] / 1.1
    s = locate_points(V, F, P)
    f = V @ [1.0, -2.0, 0.5] + 3.0
    assert np.allclose(s.rows(len(V)) @ f, s.points @ [1.0, -2.0, 0.5] + 3.0, rtol=0, atol=1e-13)
    assert np.allclose(s.interpolate(np.column_stack([f, 2 * f]))[:, 1], 2 * (s.rows(len(V)) @ f), atol=1e-13)
