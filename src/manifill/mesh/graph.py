"""Distances on the mesh graph: shortest paths from many sources at once, Voronoi cells.

The machinery under Step 1 (envelopes for the gradual variation condition) and
Steps 2-3 (paths between samples, the geodesic Delaunay graph). Every function
works on the mesh graph ``G`` of :func:`mesh_graph`, whose edge lengths realise
one of the two distances:

``hops``
    Number of edges (the paper's graph distance).
``length``
    Sum of edge lengths along a path (approximating geodesics), in units of the
    mesh's mean edge length, so that one unit is one typical edge and levels mean
    the same as with ``hops`` on a regular mesh.
"""

from collections import namedtuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from ..tolerances import TOL
from ..validate import check_option, unit_scale
from .edges import EdgeIndex

__all__ = ["DISTANCES", "mesh_graph", "edge_graph", "graph_laplacian", "quantised_lengths", "offset_distances",
           "voronoi_pairs", "trace", "trace_paths"]

DISTANCES = ("hops", "length")

Voronoi = namedtuple("Voronoi", "p q length edge via dist root pred")


def mesh_graph(V, F, *, distance="length", index=None):
    """The mesh graph with edge lengths for the chosen distance.

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions (validated).
    F : (m, 3) numpy array of int
        Triangles (validated).
    distance : {'length', 'hops'}, optional
        Euclidean edge length divided by the mean edge length (the default, as
        everywhere in manifill), or edge length 1 (Step 1's hop distance).
    index : manifill.mesh.edges.EdgeIndex, optional
        The edge index of ``F``, when the caller has one already.

    Returns
    -------
    (n, n) scipy.sparse.csr_array
        Symmetric, positive off-diagonal weights, no diagonal.

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> V, F = grid(3)
    >>> G = mesh_graph(V, F, distance="hops")
    >>> int(G.nnz), float(G.max())
    (32, 1.0)
    """
    check_option("distance", distance, DISTANCES)
    if index is None:
        index = EdgeIndex(F, len(V))
    E = index.E
    if distance == "hops":
        w = np.ones(len(E))
    else:
        w = np.zeros(len(E))
        s = unit_scale(V)  # a power of two: squared lengths neither overflow nor underflow
        Vs = V if s == 1.0 else V * (1.0 / s)
        Vn = Vs - Vs.mean(axis=0)  # centred: lengths do not depend on a far origin
        for k in range(3):
            x = np.ascontiguousarray(Vn[:, k])
            w += (x[E[:, 0]] - x[E[:, 1]]) ** 2
        w = quantised_lengths(np.sqrt(w))
    return index.matrix(w)


def quantised_lengths(w):
    """Edge lengths over their mean, in multiples of ``TOL.graph_length_quantum`` (at least one): equal paths on
    regular meshes tie exactly, whatever round-off the positions carry.

    Examples
    --------
    >>> quantised_lengths(np.array([1.0, 1.0 + 1e-12, 2.0])).tolist() == [0.75, 0.75, 1.5]
    True
    """
    mean = w.mean() if w.size else 1.0
    q = TOL.graph_length_quantum
    return np.maximum(np.round(w / ((mean if mean > 0 else 1.0) * q)), 1.0) * q


def edge_graph(n, E, w):
    """The symmetric (n, n) graph of the pairs ``E`` (each once) with weights ``w`` (CSR, sorted)."""
    A = sp.csr_array((np.concatenate([w, w]), (np.concatenate([E[:, 0], E[:, 1]]),
                                              np.concatenate([E[:, 1], E[:, 0]]))), shape=(n, n))
    A.sum_duplicates()
    A.sort_indices()
    return A


def graph_laplacian(G):
    """``D - G``, ``D`` the weighted degrees: the Laplacian of a graph (CSR, sorted)."""
    L = sp.csr_array(sp.diags_array(np.asarray(G.sum(axis=1)).ravel()) - G)
    L.sort_indices()
    return L


def offset_distances(G, sources, offsets):
    """``min_q (offsets[q] + d(x, q))`` for every vertex ``x``, in one Dijkstra.

    Parameters
    ----------
    G : (n, n) scipy sparse matrix
        Graph with positive edge lengths (see :func:`mesh_graph`).
    sources : (k,) numpy array of int
        Source vertices ``q``.
    offsets : (k,) numpy array of float
        Start value of each source.

    Returns
    -------
    dist : (n,) numpy array
        The envelope; ``inf`` where no source is reachable.
    root : (n,) int64 numpy array
        Position in ``sources`` of the source attaining the minimum (``-1``
        where unreachable).
    pred : (n,) int numpy array
        Predecessor of each vertex on its shortest path (``-9999`` where the
        path starts, i.e. at a source that is its own root, and at unreachable
        vertices): following it from ``x`` leads to ``sources[root[x]]``.

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> V, F = grid(4)
    >>> d, root, _ = offset_distances(mesh_graph(V, F, distance="hops"), np.array([0, 15]), np.array([0.0, 10.0]))
    >>> d[15], root[15]
    (np.float64(3.0), np.int64(0))
    """
    n = G.shape[0]
    sources = np.asarray(sources, dtype=np.int64)
    offsets = np.asarray(offsets, dtype=np.float64)
    base = float(offsets.min())
    # a virtual vertex n joined to every source by an edge of positive length
    first = offsets - base + 1.0
    G = sp.csr_array(G)
    order = np.argsort(sources)
    indptr = np.concatenate([G.indptr, [G.indptr[-1] + sources.size]])
    indices = np.concatenate([G.indices, sources[order].astype(G.indices.dtype)])
    data = np.concatenate([G.data, first[order]])
    Gs = sp.csr_array((data, indices, indptr), shape=(n + 1, n + 1))
    dist, pred = csgraph.dijkstra(Gs, directed=True, indices=n, return_predecessors=True)
    dist = dist[:n] + base - 1.0
    pred = pred[:n].copy()
    # the source each shortest path starts from: pointer jumping up the tree
    hop = np.where(pred == n, np.arange(n), pred)
    unreachable = pred < 0
    hop[unreachable] = np.flatnonzero(unreachable)
    while True:
        nxt = hop[hop]
        if np.array_equal(nxt, hop):
            break
        hop = nxt
    where = np.full(n, -1, dtype=np.int64)
    where[sources] = np.arange(sources.size)
    root = where[hop]
    root[unreachable] = -1
    pred[pred == n] = -9999
    return dist, root, pred


def voronoi_pairs(G, sources):
    """Pairs of sources whose Voronoi cells touch, with the shortest path between them.

    One Dijkstra from all sources assigns every vertex to its nearest source;
    every edge ``(u, v)`` between two cells gives a path source-``u``-``v``-source,
    and per pair of cells the shortest such path is kept (the geodesic
    Delaunay graph of the sources).

    Parameters
    ----------
    G : (n, n) scipy sparse matrix
        Graph with positive edge lengths.
    sources : (k,) numpy array of int
        Source vertices.

    Returns
    -------
    Voronoi
        A named tuple: ``p, q`` ((e,) int64 numpy arrays) positions in
        ``sources`` of the two ends, ``p < q``; ``length`` (e,) the length of
        the path through the best crossing edge (an upper bound of the
        distance, usually equal to it); ``edge`` (e, 2) the crossing edge
        ``(u, v)``, ``u`` in the cell of ``p``; and the Dijkstra result
        ``dist``, ``root``, ``pred`` of :func:`offset_distances` with zero
        offsets (``root`` labels the cells).
    """
    sources = np.asarray(sources, dtype=np.int64)
    dist, root, pred = offset_distances(G, sources, np.zeros(sources.size))
    G = sp.csr_array(G)
    n = G.shape[0]
    rv = root[G.indices]
    ru = np.repeat(root, np.diff(G.indptr))
    cross = np.flatnonzero((ru >= 0) & (ru != rv))  # directed edges between two cells
    u = np.repeat(np.arange(n), np.diff(G.indptr))[cross]
    v = G.indices[cross].astype(np.int64)
    ru, rv, w = ru[cross], rv[cross], G.data[cross]
    # a vertex as near to two other cells as to its own joins them too (a tie of three sources)
    tu, tv, tx, tl, tp, tq = _tied_crossings(u, v, w, dist, root)
    at = ru < rv  # each crossing once: from a cell to a later one
    u, v, ru, rv = u[at], v[at], ru[at], rv[at]
    length = dist[u] + w[at] + dist[v]
    via = np.full(u.size, -1, dtype=np.int64)
    u, v, via, length = (np.concatenate(a) for a in ((u, tu), (v, tv), (via, tx), (length, tl)))
    ru, rv = np.concatenate([ru, tp]), np.concatenate([rv, tq])
    if length.size == 0:
        e = np.empty(0, dtype=np.int64)
        return Voronoi(e, e, np.empty(0), np.empty((0, 2), dtype=np.int64), e, dist, root, pred)
    # per pair of cells (in the order of (p, q)), the shortest crossing, the first among equals (an edge before
    # a crossing through a tied vertex)
    key = ru * sources.size + rv
    order = np.argsort(key, kind="stable")
    key, lo = key[order], length[order]
    start = np.flatnonzero(np.concatenate([[True], key[1:] != key[:-1]]))
    size = np.diff(np.append(start, key.size))
    best = np.flatnonzero(lo == np.repeat(np.minimum.reduceat(lo, start), size))
    pair = np.repeat(np.arange(start.size), size)[best]
    pick = order[best[np.concatenate([[True], pair[1:] != pair[:-1]])]]
    return Voronoi(ru[pick], rv[pick], length[pick], np.column_stack([u[pick], v[pick]]), via[pick], dist, root,
                   pred)


def _tied_crossings(a, x, w, dist, root):
    """Crossings between two cells through a vertex of a third at the same distance from both.

    A vertex ``x`` whose shortest paths come as short from cells ``p`` and ``q`` (through
    neighbours ``a`` in ``p`` and ``b`` in ``q``, ``dist[a] + |ax| == dist[x]``) lies where
    the three cells meet; ``p`` and ``q`` touch there, by the path ``p .. a, x, b .. q`` of
    length ``2 dist[x]``. Lengths are exact multiples of a power of two
    (:func:`mesh_graph`), so such ties are exact.

    Parameters
    ----------
    a, x, w : numpy arrays
        The directed edges ``a -> x`` between two cells, and their lengths.
    dist, root : numpy arrays
        Of :func:`offset_distances`.

    Returns
    -------
    u, v, x, length, p, q : numpy arrays
        Per crossing: ``a``, ``b``, the vertex ``x``, the length and the cells, ``p < q``.
    """
    tight = dist[a] + w == dist[x]  # only a tie can make a shortest path cross a cell's boundary
    a, x, ra = a[tight], x[tight], root[a[tight]]
    # one neighbour per (vertex, cell): the first
    order = np.lexsort((a, ra, x))
    a, x, ra = a[order], x[order], ra[order]
    first = np.concatenate([[True], (x[1:] != x[:-1]) | (ra[1:] != ra[:-1])]) if x.size else np.zeros(0, bool)
    a, x, ra = a[first], x[first], ra[first]
    out = [[] for _ in range(6)]
    starts = np.flatnonzero(np.concatenate([[True], x[1:] != x[:-1]])) if x.size else np.zeros(0, np.int64)
    ends = np.append(starts[1:], x.size)
    for s0, s1 in zip(starts[ends - starts >= 2], ends[ends - starts >= 2]):
        for i in range(s0, s1):
            for j in range(i + 1, s1):  # cells sorted: ra[i] < ra[j]
                for lst, val in zip(out, (a[i], a[j], x[i], 2.0 * dist[x[i]], ra[i], ra[j])):
                    lst.append(val)
    kinds = (np.int64, np.int64, np.int64, np.float64, np.int64, np.int64)
    return tuple(np.array(lst, dtype=k) for lst, k in zip(out, kinds))


def trace(pred, x):
    """The vertices from ``x`` back to the source of its shortest path.

    Parameters
    ----------
    pred : (n,) numpy array of int
        Predecessors from :func:`offset_distances` (negative at sources).
    x : int
        Start vertex.

    Returns
    -------
    (l,) int64 numpy array
        ``x`` first, the source last.
    """
    path = [int(x)]
    while pred[path[-1]] >= 0:
        path.append(int(pred[path[-1]]))
    return np.array(path, dtype=np.int64)


def trace_paths(pred, x):
    """:func:`trace` from many start vertices at once: every path, concatenated.

    All paths follow their predecessor pointers together, one step of all the
    paths still running at a time, so the work is the paths' total length and
    the number of numpy steps the longest path's.

    Parameters
    ----------
    pred : (n,) numpy array of int
        Predecessors from :func:`offset_distances` (negative at sources).
    x : (e,) numpy array of int
        Start vertices.

    Returns
    -------
    flat : (l,) int64 numpy array
        The paths one after another, each ``trace(pred, x[j])``: ``x[j]`` first,
        its source last.
    lens : (e,) int64 numpy array
        The length of every path (path ``j`` is ``flat[s[j]:s[j] + lens[j]]``
        with ``s`` the cumulative sum of ``lens`` before ``j``).

    Examples
    --------
    >>> pred = np.array([-9999, 0, 1, -9999, 3])
    >>> flat, lens = trace_paths(pred, np.array([2, 4, 0]))
    >>> flat.tolist(), lens.tolist()
    ([2, 1, 0, 4, 3, 0], [3, 2, 1])
    """
    pred = np.asarray(pred)
    cur = np.asarray(x, dtype=np.int64).ravel()
    e = cur.size
    ids = np.arange(e, dtype=np.int64)
    who, where, step = [], [], []
    s = 0
    while ids.size:
        who.append(ids)
        where.append(cur)
        step.append(np.full(ids.size, s, dtype=np.int64))
        nxt = pred[cur]
        go = nxt >= 0
        ids, cur = ids[go], nxt[go].astype(np.int64)
        s += 1
    lens = np.bincount(np.concatenate(who), minlength=e) if who else np.zeros(0, dtype=np.int64)
    flat = np.empty(int(lens.sum()), dtype=np.int64)
    if who:
        start = np.concatenate([[0], np.cumsum(lens)[:-1]])
        flat[start[np.concatenate(who)] + np.concatenate(step)] = np.concatenate(where)
    return flat, lens.astype(np.int64)
