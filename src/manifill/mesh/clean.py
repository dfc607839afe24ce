"""Repairing a triangle mesh: weld coinciding vertices, drop unused vertices and zero-area faces."""

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike
from scipy.sparse import csgraph

from ..validate import as_mesh, duplicate_vertex_pairs, zero_area_faces

__all__ = ["clean_mesh"]


def clean_mesh(V: ArrayLike, F: ArrayLike, *, tol: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weld coinciding vertices, drop unused vertices and zero-area faces.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles.
    tol : float, optional
        Relative weld distance (times the bounding-box diagonal); defaults to
        ``TOL.weld``.

    Returns
    -------
    V : (n', 3) float64 numpy array
        Kept vertices, in their original order.
    F : (m', 3) int64 numpy array
        Faces on the new numbering, degenerate ones removed.
    vmap : (n,) int64 numpy array
        New index of every old vertex, ``-1`` for a dropped one: use it to
        renumber sample indices, ``vmap[idx]``.

    Examples
    --------
    >>> V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0], [5, 5, 5]]
    >>> V2, F2, vmap = clean_mesh(V, [[0, 1, 2], [3, 4, 2]])
    >>> len(V2), F2.tolist(), vmap.tolist()
    (4, [[0, 1, 2], [1, 3, 2]], [0, 1, 2, 1, 3, -1])
    """
    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    n = len(V)
    pairs = duplicate_vertex_pairs(V, tol)
    rep = np.arange(n)
    if len(pairs):
        G = sp.csr_array((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        _, lab = csgraph.connected_components(G, directed=False)
        first = np.full(lab.max() + 1, n, dtype=np.int64)
        np.minimum.at(first, lab, np.arange(n))
        rep = first[lab]
    F = rep[F]
    keep_face = (F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 2] != F[:, 0])
    F = F[keep_face]
    if len(F):
        F = F[~zero_area_faces(V, F)]
    used = np.zeros(n, dtype=bool)
    used[F.ravel()] = True
    newidx = np.full(n, -1, dtype=np.int64)
    newidx[used] = np.arange(int(used.sum()))
    vmap = newidx[rep]
    return V[used], newidx[F], vmap
