"""The edges of a triangle mesh, indexed once: :class:`EdgeIndex`, edge lists, adjacency.

Every symmetric matrix on the mesh graph (Laplacians, hop and length graphs, the
adjacency) is laid out by one :class:`EdgeIndex`. Everything here depends only on
the faces ``F`` (and the vertex count), never on positions.
"""

import numpy as np
import scipy.sparse as sp

__all__ = ["EdgeIndex", "edges", "adjacency"]


#: Bits an edge key and a half-edge number may fill together in one int64 sort key.
_PACK_BITS = 62


def _index_dtype(size):
    """int32 when every index up to ``size`` fits in it (as SciPy keeps it), else int64."""
    return np.int32 if size < 2**31 - 1 else np.int64


def _sort_half_edges(a, b, n, real, small):
    """The half-edges where ``real``, sorted by edge key ``a * n + b`` (ties by number): ``(half, keys)``.

    One sort of int64 words that pack the key with the half-edge's number, much
    faster than an argsort. Where the two do not fit in ``_PACK_BITS`` together
    (from about a million vertices), the half-edges are first dealt into groups by
    the top ``g`` bits of ``a`` (one stable radix pass), so that within a group the
    rest of the key and a number local to the group fit; the groups one after
    another are the whole order.
    """
    members = None if real.all() else np.flatnonzero(real).astype(small, copy=False)
    h = a.size if members is None else members.size
    nb = max(int(n).bit_length(), 1)  # bits of a vertex number
    g, counts, top = 0, np.array([h]), None
    while (2 * nb - g) + max(int(counts.max()).bit_length(), 1) > _PACK_BITS and g < nb:
        g += 1
        top = (a if members is None else a[members]) >> (nb - g)
        counts = np.bincount(top, minlength=1 << g)
    shift = max(int(counts.max()).bit_length(), 1)
    if top is None:
        order = None
    else:
        order = np.argsort(top.astype(np.uint16 if g <= 16 else np.int64), kind="stable").astype(small)
        del top
    bounds = np.zeros(counts.size + 1, dtype=np.int64)
    np.cumsum(counts, out=bounds[1:])
    half = np.empty(h, dtype=small)
    keys = np.empty(h, dtype=np.int64)
    low = (1 << (nb - g)) - 1
    for group in np.flatnonzero(counts):
        lo, hi = int(bounds[group]), int(bounds[group + 1])
        ids = np.arange(h, dtype=small) if order is None else order[lo:hi]
        ids = ids if members is None else members[ids]
        ag, bg = (a, b) if order is None and members is None else (a[ids], b[ids])
        packed = (ag & low).astype(np.int64)
        packed *= n
        packed += bg
        packed <<= shift
        packed |= np.arange(hi - lo, dtype=np.int64)
        del ag, bg
        packed.sort()
        half[lo:hi] = ids[packed & ((1 << shift) - 1)]
        packed >>= shift
        packed += (int(group) << (nb - g)) * n
        keys[lo:hi] = packed
    return half, keys


class EdgeIndex:
    """The undirected edges of a triangle mesh, indexed once, and the CSR layout of matrices on them.

    Every symmetric matrix of the mesh graph (the Laplacians, the hop and length
    graphs, the adjacency) shares one sparsity pattern; this object finds the
    edges with one sort and places per-edge values straight into CSR arrays,
    instead of every matrix sorting its own 6 entries per face.

    Parameters
    ----------
    F : (m, 3) numpy array of int
        Triangles (indices in ``0..n-1``).
    n : int
        Number of vertices.

    Attributes
    ----------
    E : (e, 2) int32 numpy array
        Edges ``(i, j)`` with ``i < j``, sorted.
    count : (e,) int32 numpy array
        Faces on each edge: 1 on the boundary, 2 inside a manifold surface
        (counted from ``face_edges`` on each access, not stored).
    face_edges : (m, 3) int32 numpy array
        The edge opposite each corner, ``-1`` where a face repeats a vertex.

    All three are int64 instead on a mesh with ``3 m + n >= 2**31`` (the index
    arrays of the matrices are int32 while their sizes fit, as SciPy keeps them).

    Examples
    --------
    >>> ix = EdgeIndex(np.array([[0, 1, 2], [2, 1, 3]]), 4)
    >>> ix.E.tolist(), ix.count.tolist(), ix.face_edges.tolist()
    ([[0, 1], [0, 2], [1, 2], [1, 3], [2, 3]], [1, 1, 2, 1, 1], [[2, 1, 0], [3, 4, 2]])
    >>> ix.matrix(np.arange(1.0, 6.0)).toarray().tolist()[0]
    [0.0, 1.0, 2.0, 0.0]
    """

    def __init__(self, F, n):
        F = np.asarray(F)
        m, n = len(F), int(n)
        self.n = n
        small = _index_dtype(3 * m + n)
        F = F.astype(small, copy=False)
        # half-edge k * m + f is the edge opposite corner k of face f, from a to b > a
        i = np.concatenate([F[:, 1], F[:, 2], F[:, 0]]) if m else np.empty(0, small)
        j = np.concatenate([F[:, 2], F[:, 0], F[:, 1]]) if m else np.empty(0, small)
        real = i != j
        a, b = np.minimum(i, j), np.maximum(i, j)
        del i, j
        h = a.size
        half, keys = _sort_half_edges(a, b, n, real, small)
        del a, b, real
        new = np.empty(keys.size, dtype=bool)
        new[:1] = True
        np.not_equal(keys[1:], keys[:-1], out=new[1:])
        ids = np.cumsum(new, dtype=small)
        ids -= 1
        inv = np.full(h, -1, dtype=small)
        inv[half] = ids
        del half, ids
        first = np.flatnonzero(new).astype(small, copy=False)
        uniq = keys[first]
        del keys
        self.E = np.empty((uniq.size, 2), dtype=small)
        self.E[:, 0], self.E[:, 1] = np.divmod(uniq, n) if n else (uniq, uniq)
        self.face_edges = inv.reshape(3, m).T
        self._layout = {}

    def __len__(self):
        return len(self.E)

    @property
    def count(self):
        """Faces on each edge, counted from :attr:`face_edges` when asked (not stored): (e,) numpy array."""
        fe = self.face_edges.T.ravel()
        return np.bincount(fe[fe >= 0], minlength=len(self.E)).astype(self.E.dtype)

    def per_edge(self, C):
        """Sum a value per face corner onto the edge opposite it.

        Parameters
        ----------
        C : (m, 3) numpy array
            One value per corner (e.g. half cotangents).

        Returns
        -------
        (e,) numpy array
        """
        fe = self.face_edges.T.ravel()
        c = np.asarray(C, dtype=np.float64).T.ravel()
        ok = fe >= 0
        if not ok.all():
            fe, c = fe[ok], c[ok]
        return np.bincount(fe, weights=c, minlength=len(self.E))

    def degree(self, w):
        """``sum_j w_ij`` at every vertex for per-edge weights ``w``: (n,) numpy array."""
        return (np.bincount(self.E[:, 0], weights=w, minlength=self.n)
                + np.bincount(self.E[:, 1], weights=w, minlength=self.n))

    def _positions(self, diagonal):
        """CSR ``indptr``, ``indices`` and the slots of the upper, lower and diagonal entries.

        Only the lower and diagonal slots of the layout with the diagonal are kept;
        the upper slots, and the layout without the diagonal's, are derived on each
        call (O(e), cheaper than storing them).
        """
        for which in (True, diagonal):
            if which not in self._layout:
                self._layout[which] = self._pattern(which)
        E = self.E
        full_indptr, full_indices, offset, pos_l, dpos = self._layout[True]
        # the upper entries of a row follow its diagonal in the order of E: slot = row's offset + edge number
        pos_u = offset[E[:, 0]]
        pos_u += np.arange(len(E), dtype=pos_u.dtype)
        if diagonal:
            return full_indptr, full_indices, pos_u, pos_l, dpos
        indptr, indices = self._layout[False]
        # without the diagonal every slot of row r moves back by r, and an upper slot by one more
        pos_u -= E[:, 0]
        pos_u -= 1
        return indptr, indices, pos_u, pos_l - E[:, 1], None

    def _pattern(self, diagonal):
        """The layout with the diagonal ``(indptr, indices, offset, pos_l, dpos)``, or ``(indptr, indices)`` without.

        The upper slot of edge ``k = (i, j)`` is ``offset[i] + k``; it is not stored.
        """
        n, E = self.n, self.E
        e = len(E)
        if not diagonal:
            indptr, indices, _, _, dpos = self._layout[True]
            keep = np.ones(indices.size, dtype=bool)
            keep[dpos] = False
            return indptr - np.arange(n + 1, dtype=indptr.dtype), indices[keep]
        small = _index_dtype(2 * e + n)
        e0, e1 = E[:, 0].astype(small), E[:, 1].astype(small)
        cu = np.bincount(e0, minlength=n).astype(small, copy=False)
        start = np.zeros(n + 1, dtype=small)
        np.cumsum(cu, out=start[1:])
        # the lower entries (j, i) in (j, i) order: a transpose, O(e)
        U = sp.csr_array((np.arange(e, dtype=small), e1, start), shape=(n, n))
        Lo = U.T.tocsr()
        cl = np.diff(Lo.indptr).astype(small, copy=False)
        indptr = np.zeros(n + 1, dtype=small)
        np.cumsum(cl + cu + 1, out=indptr[1:])
        dpos = indptr[:-1] + cl  # the diagonal, or the first upper entry of each row
        ramp = np.arange(e, dtype=small)
        offset = dpos + 1 - start[:-1]
        pos_u = offset[e0] + ramp
        pos_l = np.empty(e, dtype=small)
        pos_l[Lo.data] = np.repeat(indptr[:-1] - Lo.indptr[:-1].astype(small), cl) + ramp
        indices = np.empty(indptr[-1], dtype=small)
        indices[pos_u] = e1
        indices[pos_l] = e0
        indices[dpos] = np.arange(n, dtype=small)
        return indptr, indices, offset, pos_l, dpos

    def matrix(self, w, diagonal=None):
        """The symmetric (n, n) CSR matrix with ``w[k]`` at both ``(i, j)`` and ``(j, i)`` of edge ``k``.

        Parameters
        ----------
        w : (e,) numpy array
            Per-edge values; zeros stay stored, so the pattern is always the
            mesh graph.
        diagonal : (n,) numpy array, optional
            Diagonal entries, stored; without it there is no diagonal.

        Returns
        -------
        scipy.sparse.csr_array
            With sorted indices.
        """
        indptr, indices, pos_u, pos_l, dpos = self._positions(diagonal is not None)
        w = np.asarray(w)
        data = np.empty(indices.size, dtype=np.result_type(w.dtype, np.float64))
        data[pos_u] = w
        data[pos_l] = w
        if diagonal is not None:
            data[dpos] = diagonal
        A = sp.csr_array((data, indices, indptr), shape=(self.n, self.n))
        A.has_sorted_indices = True
        return A


def edges(F):
    """Unique undirected edges of a triangle mesh and how many faces use each.

    Parameters
    ----------
    F : (m, 3) numpy array of int
        Triangles.

    Returns
    -------
    E : (e, 2) int64 numpy array
        Edges ``(i, j)`` with ``i < j``, sorted.
    count : (e,) int64 numpy array
        Number of faces on each edge: 1 on the boundary, 2 inside a manifold
        surface, more on a non-manifold edge.

    Examples
    --------
    >>> E, count = edges(np.array([[0, 1, 2], [2, 1, 3]]))
    >>> E.tolist(), count.tolist()
    ([[0, 1], [0, 2], [1, 2], [1, 3], [2, 3]], [1, 1, 2, 1, 1])
    """
    F = np.asarray(F, dtype=np.int64)
    ix = EdgeIndex(F, int(F.max()) + 1 if F.size else 0)
    return ix.E.astype(np.int64), ix.count.astype(np.int64)


def adjacency(F, n):
    """Vertex adjacency matrix of a triangle mesh.

    Parameters
    ----------
    F : (m, 3) numpy array of int
        Triangles.
    n : int
        Number of vertices.

    Returns
    -------
    (n, n) scipy.sparse.csr_array
        Symmetric 0/1 matrix, 1 where two vertices share an edge.
    """
    ix = EdgeIndex(F, n)
    return ix.matrix(np.ones(len(ix)))
