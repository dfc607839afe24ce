"""Meshes built in code: icospheres, latitude-longitude spheres and flat grids, for examples, tests and
benchmarks."""

import numpy as np

from .edges import adjacency

__all__ = ["icosphere", "uv_sphere", "grid", "great_circle_vertices", "torus", "spherical_cap"]


def icosphere(k=3, *, radius=1.0):
    """Unit icosphere: an icosahedron subdivided ``k`` times, projected to the sphere.

    Parameters
    ----------
    k : int, optional
        Number of 1-to-4 subdivisions; the mesh has ``10 * 4**k + 2`` vertices
        (``k = 6``: 40,962; ``k = 8``: 655,362).
    radius : float, optional
        Sphere radius.

    Returns
    -------
    V : (n, 3) float64 numpy array
    F : (m, 3) int64 numpy array
        Triangles, outward oriented.

    Examples
    --------
    >>> V, F = icosphere(1)
    >>> V.shape, F.shape
    ((42, 3), (80, 3))
    """
    t = (1 + 5**0.5) / 2
    V = np.array(
        [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
         [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]],
        dtype=np.float64,
    )
    F = np.array(
        [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]],
        dtype=np.int64,
    )
    V /= np.linalg.norm(V, axis=1)[:, None]
    for _ in range(int(k)):
        n, m = len(V), len(F)
        half = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
        half.sort(axis=1)
        uniq, inv = np.unique(half[:, 0] * n + half[:, 1], return_inverse=True)
        a, b = uniq // n, uniq % n
        mid = V[a] + V[b]
        mid /= np.linalg.norm(mid, axis=1)[:, None]
        V = np.vstack([V, mid])
        e01, e12, e20 = (n + inv[j * m:(j + 1) * m] for j in range(3))
        F = np.vstack([
            np.column_stack([F[:, 0], e01, e20]),
            np.column_stack([F[:, 1], e12, e01]),
            np.column_stack([F[:, 2], e20, e12]),
            np.column_stack([e01, e12, e20]),
        ])
    return V * radius, F


def grid(n=10, m=None, *, size=(1.0, 1.0), diagonal="alternate"):
    """Flat triangulated rectangle ``[0, sx] x [0, sy]`` in the plane ``z = 0``.

    Parameters
    ----------
    n, m : int, optional
        Vertices along x and y (``m`` defaults to ``n``); at least 2.
    size : (2,) tuple of float, optional
        Side lengths.
    diagonal : {'alternate', 'right'}, optional
        ``'right'`` splits every square along the same diagonal (a regular,
        translation-invariant grid: uniform weights reproduce linear functions);
        ``'alternate'`` alternates the diagonal (a "union jack" pattern).

    Returns
    -------
    V : (n*m, 3) float64 numpy array
    F : (2*(n-1)*(m-1), 3) int64 numpy array

    Examples
    --------
    >>> V, F = grid(3)
    >>> V.shape, F.shape
    ((9, 3), (8, 3))
    """
    m = n if m is None else m
    xs = np.linspace(0.0, size[0], n)
    ys = np.linspace(0.0, size[1], m)
    X, Y = np.meshgrid(xs, ys, indexing="xy")
    V = np.column_stack([X.ravel(), Y.ravel(), np.zeros(n * m)])
    i, j = np.meshgrid(np.arange(n - 1), np.arange(m - 1), indexing="xy")
    i, j = i.ravel(), j.ravel()
    a = j * n + i
    b, c, d = a + 1, a + n, a + n + 1
    flip = ((i + j) % 2 == 1) if diagonal == "alternate" else np.zeros(a.size, bool)
    F1 = np.where(flip[:, None], np.column_stack([a, b, c]), np.column_stack([a, b, d]))
    F2 = np.where(flip[:, None], np.column_stack([b, d, c]), np.column_stack([a, d, c]))
    return V, np.vstack([F1, F2]).astype(np.int64)


def uv_sphere(rings=16, segments=32, *, radius=1.0):
    """A latitude-longitude sphere: ``rings - 1`` circles of latitude, ``segments`` meridians, one vertex per pole.

    Its meridians and parallels are paths of edges (a globe's grid: a barrier along a meridian follows edges).
    Vertex 0 is the south pole, the last the north pole; ring ``i`` (``1 .. rings - 1``) holds vertices
    ``1 + (i - 1) segments + j`` at longitude ``2 pi j / segments``; faces point outward.

    Examples
    --------
    >>> V, F = uv_sphere(4, 8)
    >>> len(V), len(F), bool(np.allclose(np.linalg.norm(V, axis=1), 1.0))
    (26, 48, True)
    """
    theta = np.pi * np.arange(1, rings) / rings - np.pi / 2  # latitudes
    phi = 2 * np.pi * np.arange(segments) / segments
    t, p = np.meshgrid(theta, phi, indexing="ij")
    ring = np.column_stack([np.cos(t.ravel()) * np.cos(p.ravel()), np.cos(t.ravel()) * np.sin(p.ravel()),
                            np.sin(t.ravel())])
    V = np.vstack([[0.0, 0.0, -1.0], ring, [0.0, 0.0, 1.0]]) * radius
    j = np.arange(segments)
    k = (j + 1) % segments
    faces = [np.column_stack([np.zeros(segments, np.int64), 1 + k, 1 + j])]  # the south cap
    for i in range(rings - 2):
        a, b = 1 + i * segments, 1 + (i + 1) * segments
        faces += [np.column_stack([a + j, a + k, b + k]), np.column_stack([a + j, b + k, b + j])]
    top = 1 + (rings - 2) * segments
    faces.append(np.column_stack([top + j, top + k, np.full(segments, len(V) - 1)]))
    return V, np.vstack(faces).astype(np.int64)


def great_circle_vertices(V, F, axes=(0, 1, 2)):
    """Vertices along the great circles where a sphere meets the planes ``x_axis = 0``.

    For each axis, every edge that crosses the plane contributes its endpoint on
    the non-negative side; the result is a closed, connected band one vertex wide
    that cuts a sphere like the curve network of the paper's partition (three
    axes: eight patches).

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions (centred at the origin).
    F : (m, 3) numpy array of int
        Triangles.
    axes : sequence of int, optional
        Which coordinate planes.

    Returns
    -------
    (k,) int64 numpy array
        Sorted vertex indices.

    Examples
    --------
    >>> V, F = icosphere(3)
    >>> b = great_circle_vertices(V, F)
    >>> bool(0 < b.size < len(V) // 4)
    True
    """
    A = adjacency(F, len(V)).tocoo()
    fixed = np.zeros(len(V), dtype=bool)
    for axis in axes:
        side = V[:, axis] >= 0
        crossing = side[A.row] & ~side[A.col]
        fixed[A.row[crossing]] = True
    return np.flatnonzero(fixed)


def torus(rings=32, segments=64, *, major=1.0, minor=0.4):
    """A torus about the z axis (genus 1: Euler characteristic 0), ``rings`` around its tube.

    Returns
    -------
    V : (rings * segments, 3) float64 numpy array
    F : (2 * rings * segments, 3) int64 numpy array
        Triangles, outward oriented.

    Examples
    --------
    >>> V, F = torus(8, 16)
    >>> len(V) - len(F) // 2 * 3 + len(F)  # V - E + F
    0
    """
    u = np.arange(segments) * (2 * np.pi / segments)  # around the z axis
    v = np.arange(rings) * (2 * np.pi / rings)  # around the tube
    U, W = np.meshgrid(u, v, indexing="ij")
    r = major + minor * np.cos(W)
    V = np.column_stack([(r * np.cos(U)).ravel(), (r * np.sin(U)).ravel(), (minor * np.sin(W)).ravel()])
    i, j = np.meshgrid(np.arange(segments), np.arange(rings), indexing="ij")
    a = i * rings + j
    b = ((i + 1) % segments) * rings + j
    c = ((i + 1) % segments) * rings + (j + 1) % rings
    d = i * rings + (j + 1) % rings
    F = np.concatenate([np.column_stack([a.ravel(), b.ravel(), c.ravel()]),
                        np.column_stack([a.ravel(), c.ravel(), d.ravel()])])
    return V, F.astype(np.int64)


def spherical_cap(k=5, *, height=0.0, radius=1.0):
    """The part of an icosphere above ``z = height * radius``: an open cap (a disk, Euler characteristic 1).

    Returns
    -------
    V, F
        The cap's vertices (those of a face kept) and triangles, outward oriented.

    Examples
    --------
    >>> V, F = spherical_cap(2)
    >>> bool((V[:, 2] > -0.5).all())
    True
    """
    V, F = icosphere(k, radius=radius)
    keep = (V[F, 2].mean(axis=1) > height * radius)
    F = F[keep]
    used = np.unique(F)
    new = np.full(len(V), -1, dtype=np.int64)
    new[used] = np.arange(len(used))
    return V[used], new[F]
