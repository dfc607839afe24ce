"""Closest points on a triangle mesh: the face, barycentric coordinates and distance of many query points.

:func:`locate_points` finds, for every query point ``p``, the point ``q`` of the surface
closest to it (exactly: the point-triangle distance of Ericson's *Real-Time Collision
Detection*, 5.1.5, vectorised), its face and barycentric coordinates, so that a sample
measured anywhere on (or near) the surface can be constrained exactly there, as a linear
combination of its face's three vertex values (:meth:`SurfacePoints.rows`).

Candidates come from a KD-tree of the face centroids, and are provably enough: every
point of face ``f`` lies within ``r_f`` (the largest centroid-to-corner distance) of its
centroid ``c_f``, so with ``d`` the exact distance to a few faces near ``p``, only faces
with ``|p - c_f| <= d + r_f`` can hold a closer point; they are all within ``d + max r_f``
of ``p``, a ball query. Coordinates are divided by the mesh's unit scale
(:func:`manifill.validate.unit_scale`, a power of two, exact) first, so meshes at 1e-150
or 1e150 work as at 1. Points farther from the surface than the limit of
:func:`manifill.surface.samples.snap_to_vertices` are refused ("wrong units?").
"""

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike
from scipy.spatial import cKDTree

from ..errors import SampleError
from ..tolerances import TOL
from ..validate import bbox_diagonal, unit_scale
from .samples import distance_limit, position_span, refuse_far, sample_positions

__all__ = ["SurfacePoints", "locate_points", "closest_on_triangles"]

#: Query points handled at once (bounds the memory of the candidate pairs).
CHUNK = 512


@dataclass
class SurfacePoints:
    """Query points located on a triangle mesh (the result of :func:`locate_points`).

    Attributes
    ----------
    faces : (k,) int64 numpy array
        The face holding each closest point.
    corners : (k, 3) int64 numpy array
        That face's vertices (``F[faces]``).
    bary : (k, 3) float64 numpy array
        Barycentric coordinates of the closest point on its face, as constrained
        (rows sum to 1; coordinates below ``TOL.bary_vertex`` are set to 0, so a
        point on an edge has a zero on the opposite corner, and one within it of
        1 is exactly 1).
    points : (k, 3) float64 numpy array
        The exact closest points (``bary`` applied to the face's corners is
        within ``TOL.bary_vertex`` times the face's size of them).
    distance : (k,) float64 numpy array
        Distance from each query point to its closest point.
    nearest_vertex : (k,) int64 numpy array
        The vertex nearest to each query point (what the partition methods use).
    vertex_distance : (k,) float64 numpy array
        Distance from each query point to that vertex.
    vertex : (k,) int64 numpy array
        The vertex a closest point sits at (a barycentric coordinate within
        ``TOL.bary_vertex`` of 1), ``-1`` for points inside a face or on an edge.
    """

    faces: np.ndarray
    corners: np.ndarray
    bary: np.ndarray
    points: np.ndarray
    distance: np.ndarray
    nearest_vertex: np.ndarray
    vertex: np.ndarray
    vertex_distance: np.ndarray | None = None

    @property
    def inside(self) -> np.ndarray:
        """(k,) bool numpy array: True for points not at a vertex (inside a face or on an edge)."""
        return self.vertex < 0

    def rows(self, n: int, which: np.ndarray | Sequence[int] | None = None) -> sp.csr_array:
        """The barycentric rows: ``(rows @ x)[i]`` is the field ``x`` interpolated at point ``i``.

        Parameters
        ----------
        n : int
            Number of vertices.
        which : (j,) array_like of int or bool, optional
            The points to take (all by default).

        Returns
        -------
        (j, n) scipy.sparse.csr_array
            Three entries a row (zeros dropped).
        """
        c, b = self.corners, self.bary
        if which is not None:
            c, b = c[which], b[which]
        r = np.repeat(np.arange(len(c)), 3)
        S = sp.csr_array((b.ravel(), (r, c.ravel())), shape=(len(c), n))
        S.eliminate_zeros()
        return S

    def interpolate(self, X: ArrayLike) -> np.ndarray:
        """A field at the vertices, ``(n,)`` or ``(n, p)``, interpolated at the closest points."""
        X = np.asarray(X, dtype=np.float64)
        return np.einsum("kj,kj...->k...", self.bary, X[self.corners])


def locate_points(V: ArrayLike, F: ArrayLike | None, points: ArrayLike, *,
                  max_distance: float | None = None) -> SurfacePoints:
    """The closest surface point of every query point: face, barycentric coordinates, distance.

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions (validated, e.g. by :func:`manifill.validate.as_mesh`).
    F : (m, 3) int numpy array or None
        Triangles; None for a point cloud, whose query points are located at their nearest point
        (``faces`` -1, ``vertex`` that point).
    points : (k, 3) array_like
        Query points (``(k, 2)`` for a flat mesh: ``z = 0``).
    max_distance : float, optional
        Largest accepted distance from a point to the surface; by default the
        limit of :func:`manifill.surface.samples.snap_to_vertices`
        (``TOL.snap`` times the bounding-box diagonal plus the largest
        nearest-neighbour distance of the vertices).

    Returns
    -------
    SurfacePoints

    Raises
    ------
    SampleError
        Malformed positions, a mesh without triangles, or a point farther than
        ``max_distance`` from the surface (the message gives the ratio to the
        mesh size and asks "wrong units?").

    See Also
    --------
    manifill.surface.samples.snap_to_vertices : the nearest vertex only.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> s = locate_points(V, np.array([[0, 1, 2]]), [[0.25, 0.25, 0.5], [1e-13, 0, 0]])
    >>> s.bary[0].tolist(), float(s.distance[0]), s.vertex.tolist()
    ([0.5, 0.25, 0.25], 0.5, [-1, 0])
    """
    V = np.asarray(V, dtype=np.float64)
    cloud = F is None  # a point cloud (or a digital surface): each point at its nearest vertex
    F = np.zeros((0, 3), np.int64) if cloud else np.asarray(F, dtype=np.int64)
    if not cloud and (F.ndim != 2 or F.shape[1] != 3 or len(F) == 0):
        raise SampleError("sample positions are located on triangles, and this mesh has none; give vertex indices")
    P = sample_positions(V, points)
    if V.shape[1] == 2:
        V, P = np.column_stack([V, np.zeros(len(V))]), np.column_stack([P, np.zeros(len(P))])
    diag = bbox_diagonal(V)
    sc = unit_scale(V)
    inv = 1.0 / sc
    Vs = V * inv
    vtree = cKDTree(Vs)
    limit = distance_limit(vtree, sc, diag, max_distance)
    with np.errstate(over="ignore"):
        Ps = P * inv
    out = ~(np.abs(Ps) < 2.0**500).all(axis=1)
    if out.any():  # so far out that squared distances would overflow: far from everything
        dist = np.zeros(len(P))
        dist[out] = np.inf
        refuse_far(dist, min(limit, np.finfo(float).max), diag, "the surface")
    vdist, nearest_vertex = vtree.query(Ps)
    if cloud:
        refuse_far(vdist * sc, limit, diag, "the point cloud", span=position_span(P))
        k, nv = len(P), nearest_vertex.astype(np.int64)
        bary = np.zeros((k, 3))
        bary[:, 0] = 1.0
        return SurfacePoints(faces=np.full(k, -1, np.int64), corners=np.repeat(nv[:, None], 3, axis=1), bary=bary,
                             points=V[nv], distance=vdist * sc, nearest_vertex=nv, vertex=nv,
                             vertex_distance=vdist * sc)

    T = Vs[F]  # (m, 3, 3)
    cent = T.mean(axis=1)
    radius = np.sqrt(((T - cent[:, None, :]) ** 2).sum(axis=2)).max(axis=1)
    R = float(radius.max())
    ftree = cKDTree(cent)
    k = len(P)
    faces = np.empty(k, dtype=np.int64)
    bary = np.empty((k, 3))
    d2 = np.empty(k)
    near = min(8, len(F))
    for s in range(0, k, CHUNK):
        p = Ps[s:s + CHUNK]
        # an upper bound: the exact distance to the faces of a few nearest centroids
        _, cand = ftree.query(p, k=near)
        cand = cand.reshape(len(p), near)
        _, _, dd = _closest_pairs(p, T, np.repeat(np.arange(len(p)), near), cand.ravel())
        up = np.sqrt(dd.reshape(len(p), near).min(axis=1))
        # every face that may hold a closer point: |p - c_f| <= up + r_f <= up + R (slack for round-off)
        slack = 1e-9 * (up + R) + 1e-300
        balls = ftree.query_ball_point(p, up + R + slack)
        pi = np.repeat(np.arange(len(p)), [len(b) for b in balls])
        fi = np.fromiter((f for b in balls for f in b), dtype=np.int64, count=pi.size)
        keep = np.sqrt(((p[pi] - cent[fi]) ** 2).sum(axis=1)) <= up[pi] + radius[fi] + slack[pi]
        # with the first few (so that no point is left without one)
        pi = np.concatenate([np.repeat(np.arange(len(p)), near), pi[keep]])
        fi = np.concatenate([cand.ravel(), fi[keep]])
        bb, _, dd = _closest_pairs(p, T, pi, fi)
        # per point, the pair with the least squared distance (ties: the lowest face)
        order = np.lexsort((fi, dd, pi))
        first = order[np.r_[True, pi[order][1:] != pi[order][:-1]]]
        faces[s:s + len(p)] = fi[first]
        bary[s:s + len(p)] = bb[first]
        d2[s:s + len(p)] = dd[first]
    Q = np.einsum("kj,kjd->kd", bary, T[faces])
    dist = np.sqrt(d2) * sc
    bary[bary < TOL.bary_vertex] = 0.0
    bary /= bary.sum(axis=1, keepdims=True)
    top = bary.argmax(axis=1)
    at = bary[np.arange(k), top] >= 1.0 - TOL.bary_vertex
    bary[at] = 0.0
    bary[at, top[at]] = 1.0
    corners = F[faces]
    vertex = np.where(at, corners[np.arange(k), top], -1)
    refuse_far(dist, limit, diag, "the surface", span=position_span(P))
    return SurfacePoints(faces=faces, corners=corners, bary=bary, points=Q * sc, distance=dist,
                         nearest_vertex=nearest_vertex.astype(np.int64), vertex=vertex.astype(np.int64),
                         vertex_distance=vdist * sc)


def _closest_pairs(p, T, pi, fi):
    """Closest points of ``p[pi]`` on triangles ``T[fi]``: (bary, points, squared distances)."""
    P = p[pi]
    bary = closest_on_triangles(P, T[fi, 0], T[fi, 1], T[fi, 2])
    Q = np.einsum("kj,kjd->kd", bary, T[fi])
    return bary, Q, ((P - Q) ** 2).sum(axis=1)


def closest_on_triangles(p, a, b, c):
    """Barycentric coordinates of the point of each triangle ``abc`` closest to ``p`` (all ``(N, 3)``).

    Ericson's Voronoi-region test (*Real-Time Collision Detection*, 5.1.5), vectorised;
    a degenerate (zero-area) triangle gives the closest point of its longest side.

    Parameters
    ----------
    p, a, b, c : (N, 3) numpy arrays
        Query points and the triangles' corners.

    Returns
    -------
    (N, 3) numpy array
        Barycentric coordinates (non-negative, summing to 1).

    Examples
    --------
    >>> z = np.zeros((1, 3))
    >>> closest_on_triangles(np.array([[2.0, 2, 1]]), z, np.array([[1.0, 0, 0]]), np.array([[0.0, 1, 0]])).tolist()
    [[0.0, 0.5, 0.5]]
    """
    ab, ac, ap = b - a, c - a, p - a
    bp, cp = p - b, p - c

    def dot(x, y):
        return np.einsum("ij,ij->i", x, y)

    d1, d2 = dot(ab, ap), dot(ac, ap)
    d3, d4 = dot(ab, bp), dot(ac, bp)
    d5, d6 = dot(ab, cp), dot(ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    out = np.zeros((len(p), 3))
    done = np.zeros(len(p), dtype=bool)

    def take(mask, u, v, w):
        m = mask & ~done
        out[m, 0], out[m, 1], out[m, 2] = u[m], v[m], w[m]
        done[m] = True

    one, zero = np.ones(len(p)), np.zeros(len(p))
    with np.errstate(divide="ignore", invalid="ignore"):
        take((d1 <= 0) & (d2 <= 0), one, zero, zero)  # vertex a
        take((d3 >= 0) & (d4 <= d3), zero, one, zero)  # vertex b
        take((d6 >= 0) & (d5 <= d6), zero, zero, one)  # vertex c
        v = d1 / (d1 - d3)
        take((vc <= 0) & (d1 >= 0) & (d3 <= 0) & (d1 > d3), 1 - v, v, zero)  # edge ab
        w = d2 / (d2 - d6)
        take((vb <= 0) & (d2 >= 0) & (d6 <= 0) & (d2 > d6), 1 - w, zero, w)  # edge ac
        e, f = d4 - d3, d5 - d6
        w = e / (e + f)
        take((va <= 0) & (e >= 0) & (f >= 0) & (e + f > 0), zero, 1 - w, w)  # edge bc
        den = va + vb + vc
        take(den > 0, va / den, vb / den, vc / den)  # inside the face
    rest = ~done
    if rest.any():  # degenerate triangles (or round-off at the regions' borders): the best of the three sides
        out[rest] = _closest_on_sides(p[rest], a[rest], b[rest], c[rest])
    return np.clip(out, 0.0, 1.0) / np.clip(out, 0.0, 1.0).sum(axis=1, keepdims=True)


def _closest_on_sides(p, a, b, c):
    best, bd = None, None
    for i, j in ((0, 1), (0, 2), (1, 2)):
        x, y = (a, b, c)[i], (a, b, c)[j]
        e = y - x
        ee = np.einsum("ij,ij->i", e, e)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(ee > 0, np.einsum("ij,ij->i", p - x, e) / ee, 0.0)
        t = np.clip(np.nan_to_num(t), 0.0, 1.0)
        q = x + t[:, None] * e
        d = ((p - q) ** 2).sum(axis=1)
        bc = np.zeros((len(p), 3))
        bc[:, i], bc[:, j] = 1 - t, t
        if best is None:
            best, bd = bc, d
        else:
            better = d < bd
            best[better], bd[better] = bc[better], d[better]
    return best
