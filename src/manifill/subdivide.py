"""Loop subdivision that carries fields along: a smoother surface for a reconstruction.

The paper: "if we need a smoothed surface ... apply subdivision algorithms". Every
level splits each triangle into four; new vertices sit on the edges, and every
vertex, old and new, moves to a fixed average of its neighbours (Loop's rules,
with the boundary rules for open surfaces). The rules form one sparse matrix
``S`` per level, applied alike to the positions and to every field, so a field
is refined with exactly the smoothing that refines the surface. Loop
subdivision approximates: the old vertices move, and so do their values.
"""

import numpy as np
import scipy.sparse as sp

from .errors import OptionError
from .topology import EdgeIndex
from .validate import as_mesh

__all__ = ["subdivide", "loop_matrix"]


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
    # even (old) vertices: Loop's beta on the inside, 3/4 and 1/8 + 1/8 on the boundary
    valence = np.bincount(E.ravel(), minlength=n)
    bnd_edges = E[~inner]
    on_bnd = np.bincount(bnd_edges.ravel(), minlength=n)
    boundary = on_bnd > 0
    nv = np.maximum(valence, 1)
    beta = (5 / 8 - (3 / 8 + np.cos(2 * np.pi / nv) / 4) ** 2) / nv
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

    Examples
    --------
    >>> from manifill.shapes import icosphere
    >>> V, F = icosphere(1)
    >>> V2, F2, x2 = subdivide(V, F, V[:, 2], levels=2)
    >>> len(F2) == 16 * len(F), bool(np.allclose(x2, V2[:, 2]))
    (True, True)
    """
    if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)) or levels < 0:
        raise OptionError(f"levels={levels!r} is not a non-negative integer; pass e.g. levels=2")
    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    X = None
    if values is not None:
        from .validate import as_values

        X, squeeze = as_values(values, len(V), what="values")
    for _ in range(int(levels)):
        S, F = loop_matrix(F, len(V))
        V = S @ V
        if X is not None:
            X = S @ X
    if X is None:
        return V, F
    return V, F, (X[:, 0] if squeeze else X)
