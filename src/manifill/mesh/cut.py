"""Cutting a triangle mesh along edges: the vertices on the cut split into one copy per side.

:func:`cut_mesh` gives every face corner the vertex of its side of the cut: two corners of one vertex share a
copy when a path of faces around the vertex joins them without crossing a cut edge. A cut that ends inside the
surface leaves its tip whole (the faces around it still connect round the other side); a closed cut, or one
from boundary to boundary, parts the surface in two. Vertices away from the cut keep one copy (even where the
mesh is not a manifold), and the faces keep their order.
"""

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .edges import EdgeIndex

__all__ = ["cut_mesh"]


def cut_mesh(F, n, cut, index=None):
    """The mesh cut along the edges ``cut``: ``(F2, orig)``.

    Parameters
    ----------
    F : (m, 3) int numpy array
        Triangles, every vertex used.
    n : int
        Vertices.
    cut : (c,) int numpy array
        Edge ids of ``index`` (:class:`manifill.mesh.edges.EdgeIndex`) to cut along.
    index : EdgeIndex, optional
        The edge index of ``F`` (built when not given).

    Returns
    -------
    F2 : (m, 3) int64 numpy array
        The same faces on the copies.
    orig : (n2,) int64 numpy array
        The vertex each copy is of (``n2 >= n``; copies ``0 .. n-1`` are the first of each vertex, in order).

    Examples
    --------
    >>> F = np.array([[0, 1, 2], [0, 2, 3]])    # two triangles sharing the edge (0, 2), cut along it
    >>> ix = EdgeIndex(F, 4)
    >>> F2, orig = cut_mesh(F, 4, np.flatnonzero((ix.E == [0, 2]).all(axis=1)), ix)
    >>> F2.tolist(), orig.tolist()
    ([[0, 1, 2], [4, 5, 3]], [0, 1, 2, 3, 0, 2])
    """
    F = np.asarray(F, dtype=np.int64)
    m = len(F)
    index = EdgeIndex(F, n) if index is None else index
    is_cut = np.zeros(len(index.E), dtype=bool)
    is_cut[np.asarray(cut, dtype=np.int64)] = True
    corner_vertex = F.ravel()
    # half-edge (f, c): the edge opposite corner c of face f, between corners c+1 and c+2 of f
    f = np.repeat(np.arange(m), 3)
    c = np.tile(np.arange(3), m)
    e = np.asarray(index.face_edges, dtype=np.int64).ravel()
    keep = (e >= 0) & ~is_cut[np.maximum(e, 0)]
    f, c, e = f[keep], c[keep], e[keep]
    cu, cw = 3 * f + (c + 1) % 3, 3 * f + (c + 2) % 3  # the two corners on the edge
    # each half-edge linked to the first half-edge of its edge, corner to corner of the same vertex
    order = np.argsort(e, kind="stable")
    e_sorted = e[order]
    first = np.empty(e.size, dtype=np.int64)
    starts = np.flatnonzero(np.r_[True, e_sorted[1:] != e_sorted[:-1]])
    first[order] = order[starts[np.cumsum(np.r_[True, e_sorted[1:] != e_sorted[:-1]]) - 1]]
    u0, w0 = cu[first], cw[first]
    same = corner_vertex[cu] == corner_vertex[u0]
    a = np.concatenate([cu, cw])
    b = np.concatenate([np.where(same, u0, w0), np.where(same, w0, u0)])
    # vertices on no cut edge stay whole: all their corners linked to one
    on_cut = np.zeros(n, dtype=bool)
    on_cut[index.E[is_cut].ravel()] = True
    whole = np.flatnonzero(~on_cut[corner_vertex])
    rep = np.full(n, -1, dtype=np.int64)
    rep[corner_vertex[whole[::-1]]] = whole[::-1]  # each vertex's first corner
    a = np.concatenate([a, whole])
    b = np.concatenate([b, rep[corner_vertex[whole]]])
    G = sp.coo_array((np.ones(a.size), (a, b)), shape=(3 * m, 3 * m))
    _, label = connected_components(G, directed=False)
    # copies numbered: each vertex's first copy keeps its number, the others follow
    first_corner = np.full(label.max() + 1, 3 * m, dtype=np.int64)
    np.minimum.at(first_corner, label, np.arange(3 * m))
    owner = corner_vertex[first_corner]
    lead = np.full(n, -1, dtype=np.int64)
    by_corner = np.argsort(first_corner, kind="stable")
    lead[owner[by_corner[::-1]]] = by_corner[::-1]  # the copy of each vertex whose first corner comes first
    new = np.full(label.max() + 1, -1, dtype=np.int64)
    new[lead] = np.arange(n)
    extra = np.flatnonzero(new < 0)
    new[extra] = n + np.arange(extra.size)
    orig = np.concatenate([np.arange(n), owner[extra]])
    return new[label].reshape(m, 3), orig
