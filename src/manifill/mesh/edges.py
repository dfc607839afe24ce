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
    E : (e, 2) int64 numpy array
        Edges ``(i, j)`` with ``i < j``, sorted.
    count : (e,) int64 numpy array
        Faces on each edge: 1 on the boundary, 2 inside a manifold surface.
    face_edges : (m, 3) int64 numpy array
        The edge opposite each corner, ``-1`` where a face repeats a vertex.

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
        small = np.int32 if n < 2**31 - 1 else np.int64
        F = F.astype(small, copy=False)
        # half-edge k * m + f is the edge opposite corner k of face f
        i = np.concatenate([F[:, 1], F[:, 2], F[:, 0]]) if m else np.empty(0, small)
        j = np.concatenate([F[:, 2], F[:, 0], F[:, 1]]) if m else np.empty(0, small)
        a = np.minimum(i, j).astype(np.int64)
        key = a * n + np.maximum(i, j)
        real = i != j
        h = key.size
        shift = max(int(h).bit_length(), 1)
        if n and (2 * int(n).bit_length() + shift) <= _PACK_BITS:
            # one sort of (edge key, half-edge) packed in an int64 beats an argsort
            packed = (key << shift) | np.arange(h, dtype=np.int64)
            packed = packed[real]
            packed.sort()
            half = packed & ((1 << shift) - 1)
            keys = packed >> shift
        else:
            half = np.flatnonzero(real)
            half = half[np.argsort(key[half], kind="stable")]
            keys = key[half]
        new = np.empty(keys.size, dtype=bool)
        new[:1] = True
        np.not_equal(keys[1:], keys[:-1], out=new[1:])
        ids = np.cumsum(new, dtype=np.int64 if keys.size >= 2**31 - 1 else np.int32) - 1
        inv = np.full(h, -1, dtype=ids.dtype)
        inv[half] = ids
        uniq = keys[new]
        self.E = np.column_stack(np.divmod(uniq, n)) if n else np.empty((0, 2), np.int64)
        self.count = np.diff(np.append(np.flatnonzero(new), keys.size))
        self.face_edges = inv.reshape(3, m).T
        self._layout = {}

    def __len__(self):
        return len(self.E)

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
        """CSR ``indptr``, ``indices`` and the slots of the upper, lower and diagonal entries."""
        if diagonal in self._layout:
            return self._layout[diagonal]
        n, E = self.n, self.E
        e = len(E)
        if not diagonal:
            # drop the diagonal from the layout that has it: every slot moves back by its row
            indptr, indices, pos_u, pos_l, dpos = self._positions(True)
            keep = np.ones(indices.size, dtype=bool)
            keep[dpos] = False
            layout = (indptr - np.arange(n + 1, dtype=indptr.dtype), indices[keep],
                      pos_u - E[:, 0] - 1, pos_l - E[:, 1], dpos - np.arange(n))
            self._layout[False] = layout
            return layout
        small = np.int32 if 2 * e + n < 2**31 - 1 else np.int64
        e0, e1 = E[:, 0].astype(small), E[:, 1].astype(small)
        cu = np.bincount(e0, minlength=n)
        start = np.zeros(n + 1, dtype=small)
        np.cumsum(cu, out=start[1:])
        # the lower entries (j, i) in (j, i) order: a transpose, O(e)
        U = sp.csr_array((np.arange(e, dtype=small), e1, start), shape=(n, n))
        Lo = U.T.tocsr()
        cl = np.diff(Lo.indptr)
        indptr = np.zeros(n + 1, dtype=small)
        np.cumsum(cl + cu + 1, out=indptr[1:])
        dpos = indptr[:-1] + cl  # the diagonal, or the first upper entry of each row
        ramp = np.arange(e, dtype=small)
        pos_u = np.repeat(dpos + 1 - start[:-1], cu) + ramp
        pos_l = np.empty(e, dtype=small)
        pos_l[Lo.data] = np.repeat(indptr[:-1] - Lo.indptr[:-1].astype(small), cl) + ramp
        indices = np.empty(indptr[-1], dtype=small)
        indices[pos_u] = e1
        indices[pos_l] = e0
        indices[dpos] = np.arange(n, dtype=small)
        self._layout[True] = (indptr, indices, pos_u, pos_l, dpos)
        return self._layout[True]

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
    return ix.E, ix.count


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
