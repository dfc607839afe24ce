"""Loop subdivision that carries fields along: a smoother surface for a reconstruction.

The paper: "if we need a smoothed surface ... apply subdivision algorithms". Every
level splits each triangle into four; new vertices sit on the edges, and every
vertex, old and new, moves to a fixed average of its neighbours (Loop's rules,
with the boundary rules for open surfaces). The rules form one sparse matrix
``S`` per level, applied alike to the positions and to every field, so a field
is refined with exactly the smoothing that refines the surface. Loop
subdivision approximates: the old vertices move, and so do their values.

An old inner vertex of valence ``n`` keeps ``1 - n beta`` of itself and takes
``beta`` of each neighbour, with Warren's ``beta = 3 / (8 n)`` (``3 / 16`` for
``n = 3``), the weights of libigl's ``igl.loop``, rather than Loop's original
``(5/8 - (3/8 + cos(2 pi / n) / 4)^2) / n``. The two agree at valence 3 and 6
(so on regular meshes) and both keep every weight positive (values never leave
their range); Warren's is a simplification of Loop's that still gives a smooth
limit surface, the surfaces differ by about 1e-3 of the size near irregular
vertices, and matching libigl makes ``igl.loop`` a reference to compare against,
to rounding, on any manifold mesh.

Every level multiplies the faces by four, so twelve levels make 16 million
faces of each one: a subdivision predicted not to fit in the memory available
is refused before the first level (:func:`check_subdivide`).
"""

import numpy as np
import scipy.sparse as sp

from ..errors import OptionError, ResourceError
from ..memory import check_fits
from ..validate import as_mesh, as_values
from .edges import EdgeIndex

__all__ = ["subdivide", "loop_matrix", "subdivided_size", "subdivide_memory", "check_subdivide"]

#: Peak bytes per face of the last level's output (its matrix, edge index and triangles: 198 measured),
#: and a fixed part.
_BYTES_PER_FACE, _FIXED_BYTES = 200, 5e5
#: Levels beyond which the counts are not worked out: 4^200 faces fit in no memory.
_MAX_EXACT_LEVELS = 200


def _as_levels(levels):
    if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)) or levels < 0:
        raise OptionError(f"levels={levels!r} is not a non-negative integer; pass e.g. levels=2 (CLI --subdivide)")
    return int(levels)


def _sizes(n_vertices, n_faces, levels):
    """Vertices, edges and faces after each level: a list of ``levels + 1`` Python-int triples."""
    n, m = int(n_vertices), int(n_faces)
    e = max(min(3 * m, n + m - 2), 0)  # Euler: e = n + m - chi (2 for a sphere), and at most 3 per face
    out = [(n, e, m)]
    for _ in range(levels):
        n, e, m = n + e, 2 * e + 3 * m, 4 * m  # a vertex per edge; edges split, 3 new in each face
        out.append((n, e, m))
    return out


def subdivided_size(n_vertices, n_faces, levels):
    """Vertices and faces after ``levels`` Loop subdivisions (vertices estimated from Euler's formula).

    Parameters
    ----------
    n_vertices, n_faces : int
        The mesh before.
    levels : int

    Returns
    -------
    vertices, faces : int
        ``faces = 4**levels * n_faces`` exactly; ``n + e`` vertices per
        level (``e`` the edges), with ``e`` from Euler's formula: exact for a
        closed surface of genus 0, within a few of the truth for other
        connected surfaces, more for many pieces.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(1)
    >>> subdivided_size(len(V), len(F), 2), (len(icosphere(3)[0]), len(icosphere(3)[1]))
    ((642, 1280), (642, 1280))
    """
    levels = _as_levels(levels)
    if levels > _MAX_EXACT_LEVELS:
        return float("inf"), float("inf")
    n, _, m = _sizes(n_vertices, n_faces, levels)[-1]
    return n, m


def subdivide_memory(n_vertices, n_faces, levels, n_fields=1):
    """Estimated peak memory of :func:`subdivide`, in bytes.

    The last level dominates: its subdivision matrix, edge index and new
    triangles (about 200 bytes per new face), and the positions and fields
    before and after it.

    Parameters
    ----------
    n_vertices, n_faces : int
        The mesh before.
    levels : int
    n_fields : int, optional
        Fields carried along.

    Returns
    -------
    float
        ``inf`` for absurdly many levels.

    Examples
    --------
    >>> from manifill.memory import human
    >>> human(subdivide_memory(642, 1280, 2)), human(subdivide_memory(642, 1280, 12))
    ('5 MB', '4.4 TB')
    """
    levels = _as_levels(levels)
    if levels == 0:
        return 0.0
    if levels > _MAX_EXACT_LEVELS:
        return float("inf")
    sizes = _sizes(n_vertices, n_faces, levels)
    (n0, _, _), (n1, _, m1) = sizes[-2], sizes[-1]
    return float(_BYTES_PER_FACE * m1 + 8 * int(n_fields) * (n0 + n1) + _FIXED_BYTES)


def check_subdivide(n_vertices, n_faces, levels, n_fields=1, *, available=None):
    """Refuse (:class:`~manifill.errors.ResourceError`) a subdivision predicted not to fit in memory.

    Parameters
    ----------
    n_vertices, n_faces : int
        The mesh before.
    levels : int
    n_fields : int, optional
        Fields carried along.
    available : int, optional
        Bytes available; :func:`manifill.memory.available_bytes` by default.

    Raises
    ------
    OptionError
        ``levels`` not a non-negative integer.
    ResourceError
        ``"subdividing 12 times (~21,474,836,480 faces) needs about 4.4 TB but only 24.0 GB of memory is
        available; use fewer levels (CLI --subdivide)"``.

    Examples
    --------
    >>> check_subdivide(642, 1280, 2, available=10**9)
    >>> check_subdivide(642, 1280, 12, available=10**9)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    manifill.errors.ResourceError: subdividing 12 times (~21,474,836,480 faces) needs about 4.4 TB but only ...
    """
    levels = _as_levels(levels)
    if levels == 0:
        return
    if levels > _MAX_EXACT_LEVELS:
        raise ResourceError(f"subdividing {levels:,} times makes 4^{levels:,} times as many faces, more than any "
                            f"memory holds; use fewer levels (CLI --subdivide)")
    faces = subdivided_size(n_vertices, n_faces, levels)[1]
    count = f"{faces:,}" if faces < 10**15 else f"{float(faces):.2g}"
    check_fits(subdivide_memory(n_vertices, n_faces, levels, n_fields),
               f"subdividing {levels} time{'s' if levels > 1 else ''} (~{count} faces)",
               "use fewer levels (CLI --subdivide)", available=available)


def loop_matrix(F, n):
    """One level of Loop subdivision as a matrix, and the new triangles.

    Parameters
    ----------
    F : (m, 3) numpy array of int
        Triangles.
    n : int
        Number of vertices.

    Returns
    -------
    S : (n + e, n) scipy.sparse.csr_array
        New vertices (the ``n`` old ones first, then one per edge) as
        averages of the old ones; every row sums to 1.
    F2 : (4 m, 3) int64 numpy array
        The new triangles, oriented as ``F``.
    """
    ix = EdgeIndex(F, n)
    E, count, fe = ix.E, ix.count, ix.face_edges
    e = len(E)
    rows, cols, vals = [], [], []
    # odd (edge) vertices: 3/8 of each end and 1/8 of each opposite vertex; 1/2 and 1/2 on a
    # boundary (or non-manifold) edge
    inner = count == 2
    end_w = np.where(inner, 3 / 8, 1 / 2)
    for k in range(2):
        rows.append(n + np.arange(e))
        cols.append(E[:, k])
        vals.append(end_w)
    f, k = np.nonzero(fe >= 0)
    edge = fe[f, k]
    keep = inner[edge]
    rows.append(n + edge[keep])
    cols.append(F[f[keep], k[keep]])
    vals.append(np.full(int(keep.sum()), 1 / 8))
    # even (old) vertices: Warren's beta on the inside (as igl.loop), 3/4 and 1/8 + 1/8 on the boundary
    valence = np.bincount(E.ravel(), minlength=n)
    bnd_edges = E[~inner]
    on_bnd = np.bincount(bnd_edges.ravel(), minlength=n)
    boundary = on_bnd > 0
    nv = np.maximum(valence, 1)
    beta = np.where(valence == 3, 3 / 16, 3 / (8 * nv))
    corner = boundary & (on_bnd != 2)  # a pinched or non-manifold boundary vertex stays put
    self_w = np.where(boundary, np.where(corner, 1.0, 3 / 4), 1 - valence * beta)
    rows.append(np.arange(n))
    cols.append(np.arange(n))
    vals.append(self_w)
    for a, b in ((0, 1), (1, 0)):
        i, j = E[:, a], E[:, b]
        interior_i = ~boundary[i]
        rows.append(i[interior_i])
        cols.append(j[interior_i])
        vals.append(beta[i[interior_i]])
    for a, b in ((0, 1), (1, 0)):
        i, j = bnd_edges[:, a], bnd_edges[:, b]
        smooth = ~corner[i]
        rows.append(i[smooth])
        cols.append(j[smooth])
        vals.append(np.full(int(smooth.sum()), 1 / 8))
    S = sp.csr_array((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n + e, n))
    S.sum_duplicates()
    # the new triangles: corner k's opposite edge gives the midpoint between the other two corners
    mid = n + fe  # mid[:, k] lies on the edge opposite corner k
    a, b, c = F[:, 0], F[:, 1], F[:, 2]
    ab, bc, ca = mid[:, 2], mid[:, 0], mid[:, 1]
    F2 = np.concatenate([np.column_stack([a, ab, ca]), np.column_stack([b, bc, ab]),
                         np.column_stack([c, ca, bc]), np.column_stack([ab, bc, ca])])
    return S, F2.astype(np.int64)


def subdivide(V, F, values=None, *, levels=1):
    """Loop-subdivide a triangle mesh ``levels`` times, carrying per-vertex values along.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles.
    values : (n,) or (n, p) array_like, optional
        Fields at the vertices (e.g. ``Reconstruction.values``).
    levels : int, optional
        Number of subdivisions (each multiplies the triangles by 4).

    Returns
    -------
    V2 : (n2, 3) numpy array
    F2 : (4**levels * m, 3) int64 numpy array
    values2 : (n2,) or (n2, p) numpy array
        Only when ``values`` is given.

    Raises
    ------
    MeshError
        A malformed mesh.
    OptionError
        ``levels`` not a non-negative integer.
    ResourceError
        The result is predicted not to fit in the memory available
        (:func:`check_subdivide`); checked before any level is made.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(1)
    >>> V2, F2, x2 = subdivide(V, F, V[:, 2], levels=2)
    >>> len(F2) == 16 * len(F), bool(np.allclose(x2, V2[:, 2]))
    (True, True)
    """
    levels = _as_levels(levels)
    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    X = None
    if values is not None:
        X, squeeze = as_values(values, len(V), what="values")
    check_subdivide(len(V), len(F), levels, 0 if X is None else X.shape[1])
    for _ in range(int(levels)):
        S, F = loop_matrix(F, len(V))
        V = S @ V
        if X is not None:
            X = S @ X
    if X is None:
        return V, F
    return V, F, (X[:, 0] if squeeze else X)
