"""Combinatorics of a triangle mesh: components, boundary loops, genus, and the mesh report.

Everything here but :func:`mesh_info` depends only on the faces ``F`` (and the
vertex count), never on positions, so it can be checked exactly. The edges
themselves are :mod:`manifill.mesh.edges`; repairing a mesh is
:mod:`manifill.mesh.clean`.
"""

from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike
from scipy.sparse import csgraph

from ..validate import as_mesh, bbox_diagonal, duplicate_vertex_pairs, zero_area_faces
from .edges import adjacency, edges

__all__ = [
    "connected_components",
    "pattern_components",
    "boundary_loops",
    "mesh_info",
]


def connected_components(F, n):
    """Connected components of the mesh graph.

    Parameters
    ----------
    F : (m, 3) numpy array of int
        Triangles.
    n : int
        Number of vertices.

    Returns
    -------
    count : int
        Number of components.
    labels : (n,) int numpy array
        Component of each vertex; components are numbered by decreasing size.
    """
    count, labels = pattern_components(adjacency(F, n))
    return count, _relabel_by_size(labels, count)


def pattern_components(A, *, symmetric=True):
    """Connected components of the sparsity pattern of a square matrix: ``(count, labels)``.

    Labels are numbered in the order of each component's first vertex, as by
    ``scipy.sparse.csgraph.connected_components(A, directed=False)``, which
    builds ``A``'s transpose first. When the pattern is known to be symmetric
    (every Laplacian and mesh graph here stores both ``(i, j)`` and ``(j, i)``),
    a search on ``A`` alone (pyamg's kernel) finds the same components in a
    fraction of the time. Stored zeros count as connections in both.

    Parameters
    ----------
    A : (n, n) scipy sparse matrix
        CSR (or convertible to it).
    symmetric : bool, optional
        Promise that the pattern is symmetric.

    Returns
    -------
    count : int
    labels : (n,) int numpy array
    """
    if not symmetric:
        count, labels = csgraph.connected_components(A, directed=False)
        return int(count), labels
    from pyamg.amg_core import connected_components as _search

    A = sp.csr_array(A)
    n = A.shape[0]
    indptr = np.asarray(A.indptr)
    indices = np.asarray(A.indices).astype(indptr.dtype, copy=False)
    labels = np.empty(n, dtype=indptr.dtype)
    count = _search(n, indptr, indices, labels) if n else 0
    return int(count), labels


def _relabel_by_size(labels, count):
    sizes = np.bincount(labels, minlength=count)
    order = np.argsort(-sizes, kind="stable")
    rank = np.empty(count, dtype=np.int64)
    rank[order] = np.arange(count)
    return rank[labels]


def boundary_loops(F):
    """Closed loops of boundary edges (edges used by exactly one face).

    Parameters
    ----------
    F : (m, 3) numpy array of int
        Triangles, consistently oriented or not.

    Returns
    -------
    list of (k,) int64 numpy arrays
        Each loop as its vertex sequence (the first vertex is not repeated),
        longest loop first. Where boundary edges meet at a vertex used more than
        twice (a pinched boundary) the loops are split there. On a non-manifold
        mesh a "loop" may be an open chain of boundary edges.

    Examples
    --------
    >>> [loop.tolist() for loop in boundary_loops(np.array([[0, 1, 2], [0, 2, 3]]))]
    [[0, 1, 2, 3]]
    """
    E, count = edges(F)
    B = E[count == 1]
    if len(B) == 0:
        return []
    nbrs = {}
    for i, j in B.tolist():
        nbrs.setdefault(i, []).append(j)
        nbrs.setdefault(j, []).append(i)
    unused = {(min(i, j), max(i, j)) for i, j in B.tolist()}
    loops = []
    for i, j in B.tolist():
        if (i, j) not in unused:
            continue
        unused.discard((i, j))
        loop = [i, j]
        while True:
            cur = loop[-1]
            nxt = None
            for k in nbrs[cur]:
                if (min(cur, k), max(cur, k)) in unused:
                    nxt = k
                    break
            if nxt is None:
                break
            unused.discard((min(cur, nxt), max(cur, nxt)))
            if nxt == loop[0]:
                break
            loop.append(nxt)
        loops.append(np.array(loop, dtype=np.int64))
    loops.sort(key=len, reverse=True)
    return loops


def mesh_info(V: ArrayLike, F: ArrayLike) -> dict[str, Any]:
    """Counts, components, boundary loops, non-manifold edges and genus of a mesh.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles.

    Returns
    -------
    dict
        ``vertices``, ``faces``, ``edges``, ``bbox_min``, ``bbox_max``,
        ``diagonal``, ``unreferenced_vertices``, ``coinciding_vertex_pairs``
        (an unwelded mesh), ``zero_area_faces``, ``nonmanifold_edges`` (count),
        ``boundary_loops`` (count) and ``components``: a list with, per component
        (largest first), its ``vertices``, ``faces``, ``boundary_loops``,
        ``euler`` characteristic, whether it is ``closed`` and, for a closed
        orientable-looking component, its ``genus`` ``(2 - euler) / 2``.

    Raises
    ------
    MeshError
        If the arrays are malformed (see :func:`manifill.validate.as_mesh`).
        Unreferenced vertices, zero-area faces and duplicates are reported, not
        raised.
    """
    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    n = len(V)
    E, count = edges(F)
    loops = boundary_loops(F)
    used = np.zeros(n, dtype=bool)
    used[F.ravel()] = True
    ncomp, labels = connected_components(F, n)
    face_comp = labels[F[:, 0]]
    edge_comp = labels[E[:, 0]]
    loop_comp = np.array([labels[loop[0]] for loop in loops], dtype=np.int64)
    comps = []
    for c in range(ncomp):
        nv = int(np.count_nonzero(labels == c))
        if nv == 1 and not used[labels == c].any():
            continue
        nf = int(np.count_nonzero(face_comp == c))
        ne = int(np.count_nonzero(edge_comp == c))
        nl = int(np.count_nonzero(loop_comp == c))
        chi = nv - ne + nf
        entry = {"vertices": nv, "faces": nf, "boundary_loops": nl, "euler": chi, "closed": nl == 0}
        if nl == 0 and chi % 2 == 0:
            entry["genus"] = (2 - chi) // 2
        comps.append(entry)
    return {
        "vertices": n,
        "faces": len(F),
        "edges": len(E),
        "bbox_min": V.min(axis=0).tolist(),
        "bbox_max": V.max(axis=0).tolist(),
        "diagonal": bbox_diagonal(V),
        "unreferenced_vertices": int(np.count_nonzero(~used)),
        "coinciding_vertex_pairs": int(len(duplicate_vertex_pairs(V))),
        "zero_area_faces": int(np.count_nonzero(zero_area_faces(V, F))),
        "nonmanifold_edges": int(np.count_nonzero(count > 2)),
        "boundary_loops": len(loops),
        "components": comps,
    }
