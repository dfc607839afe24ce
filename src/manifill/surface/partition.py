"""Steps 2-3 of the paper: cut the surface by curves through all samples into patches.

Three ways to draw the curves, each a set of shortest paths between samples:

``delaunay``
    The paper's "geodesic-like partition" (its Sub-algorithm 2), made precise as
    the geodesic Delaunay graph of the samples: one Dijkstra from all samples
    grows their Voronoi cells, and two samples whose cells touch are joined by the
    shortest path through the touching edge. Every patch is then a geodesic
    polygon with samples at its corners.
``cycle``
    The paper's Sub-algorithm 1: samples are linked one by one (each to the
    nearest one not yet linked) by shortest paths that avoid the curve drawn so
    far where they can, and the chain is closed into a cycle back to the first.
    Five samples on a sphere give one closed curve and two patches (Fig. 4.1).
``tree``
    A minimum-length variant (the paper's open problem 2): the minimum spanning
    tree of the samples under geodesic distance, taken from the Delaunay graph.
    Its complement is one patch whose boundary is the tree walked around on both
    sides: the shortest network that reaches every sample.

Pathological cases are handled, not left to the user: paths that overlap are
merged (the network is a set of vertices), patches with no interior vertex simply
do not appear, curves that do not separate the surface (on a torus, or a single
open path) leave a patch bounded on both sides by the same curve, which the
harmonic fill handles like any other. The report counts all of these.
"""

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from ..mesh.graph import trace, trace_paths, voronoi_pairs
from ..mesh.topology import pattern_components
from ..validate import check_option, unit_scale
from .surface import Surface

__all__ = ["PARTITIONS", "Partition", "partition"]

PARTITIONS = ("delaunay", "cycle", "tree")


@dataclass
class Partition:
    """Curves through the samples and the patches they cut out.

    Attributes
    ----------
    curves : list of (l,) int64 numpy arrays
        Ordered vertex paths, each from one sample to another.
    ends : (c, 2) int64 numpy array
        The samples at the two ends of each curve.
    on_curve : (n,) bool numpy array
        Vertices on some curve (all samples included).
    labels : (n,) int64 numpy array
        Patch of every vertex off the curves, numbered by decreasing size;
        ``-1`` on the curves.
    boundaries : list of (b,) int64 numpy arrays
        For each patch, the curve vertices adjacent to it.
    report : dict
        ``method``, ``curves``, ``curve_vertices``, ``curve_length`` (sum of
        the edge lengths of the network, in the graph's units), ``patches``,
        ``patch_sizes`` (largest first), ``inner_points`` (vertices off the
        curves), ``balance`` (largest patch over the mean), ``merged_vertices``
        (path vertices shared by two or more curves).
    """

    curves: list
    ends: np.ndarray
    on_curve: np.ndarray
    labels: np.ndarray
    boundaries: list
    report: dict = field(default_factory=dict)
    _edges: np.ndarray | None = field(default=None, init=False, repr=False)
    _flat: tuple | None = field(default=None, init=False, repr=False)  # (all curves concatenated, their lengths)

    def curve_edges(self) -> np.ndarray:
        """Unique edges ``(i, j)``, ``i < j``, of the curve network, as an (e, 2) array."""
        if self._edges is None:
            self._edges = self._curve_edges()
        return self._edges

    def steepest(self, idx: np.ndarray, vals: np.ndarray) -> list[tuple[float, tuple[int, int]] | None]:
        """Per field, the steepest curve: a lower bound of Step 1's Lipschitz constant in hops.

        A curve of ``h`` edges joins two samples, so their hop distance is at most
        ``h`` and ``|f_a - f_b| / h`` bounds the constant from below; Step 1
        (:func:`manifill.surface.gradual.check_gradual`, ``start=``) starts there
        and saves a shortest-path pass.

        Parameters
        ----------
        idx : (k,) int64 numpy array
            The sample vertices (sorted, unique) the partition was drawn through.
        vals : (k, p) numpy array
            Their values, one column per field.

        Returns
        -------
        list of p (K0, (a, b)) tuples, or of None without curves
            ``K0`` the largest ratio, ``a, b`` positions in ``idx`` of its ends.
        """
        if not self.curves:
            return [None] * vals.shape[1]
        pos = np.searchsorted(idx, self.ends)
        hops = (self._flat_curves()[1] - 1).astype(np.float64)
        ok = hops > 0
        starts: list[tuple[float, tuple[int, int]] | None] = []
        for j in range(vals.shape[1]):
            ratio = np.where(ok, np.abs(vals[pos[:, 0], j] - vals[pos[:, 1], j]) / np.maximum(hops, 1), 0.0)
            best = int(np.argmax(ratio))
            starts.append((float(ratio[best]), (int(pos[best, 0]), int(pos[best, 1]))))
        return starts

    def _flat_curves(self):
        """All curves concatenated, and their lengths (kept from :func:`partition`, else built once)."""
        if self._flat is None:
            lens = np.array([len(c) for c in self.curves], dtype=np.int64)
            flat = np.concatenate(self.curves).astype(np.int64) if self.curves else np.empty(0, np.int64)
            self._flat = (flat, lens)
        return self._flat

    def _curve_edges(self):
        flat, lens = self._flat_curves()
        if flat.size < 2:
            return np.empty((0, 2), dtype=np.int64)
        # consecutive vertices of the concatenation, less the pairs that straddle two curves
        inside = np.ones(flat.size - 1, dtype=bool)
        ends = np.cumsum(lens)[:-1]
        inside[ends[(ends > 0) & (ends < flat.size)] - 1] = False
        E = np.column_stack([flat[:-1][inside], flat[1:][inside]])
        E.sort(axis=1)
        if not len(E):
            return E
        m = int(E.max()) + 1
        key = _unique(E[:, 0] * m + E[:, 1])
        return np.column_stack([key // m, key % m])


def _unique(key):
    """The sorted distinct values of an integer array (``numpy.unique``, by one sort)."""
    key = np.sort(key)
    keep = np.ones(key.size, dtype=bool)
    keep[1:] = key[1:] != key[:-1]
    return key[keep]


def _paths_between(pred, edge, via=None):
    """Per edge ``(u, v)``: source-of-u ... u, [via,] v ... source-of-v, from one multi-source Dijkstra.

    All paths at once (:func:`manifill.mesh.graph.trace_paths`): the concatenation
    and the lengths. ``via`` (``-1`` for none) is a vertex between ``u`` and ``v``.
    """
    flat, clens, lu = _halves(pred, edge)
    if via is None or not (via >= 0).any():
        return flat, clens
    has = via >= 0
    lens = clens + has
    start = np.cumsum(lens) - lens
    j = np.repeat(np.arange(len(edge)), clens)
    t = np.arange(flat.size) - np.repeat(np.cumsum(clens) - clens, clens)
    out = np.empty(int(lens.sum()), dtype=np.int64)
    out[start[j] + t + (has[j] & (t >= lu[j]))] = flat
    out[start[has] + lu[has]] = via[has]
    return out, lens


def _halves(pred, edge):
    """The paths of :func:`_paths_between` without ``via``, and the lengths of their ``u`` halves."""
    e = len(edge)
    flat, lens = trace_paths(pred, np.concatenate([edge[:, 0], edge[:, 1]]))
    lu, lv = lens[:e], lens[e:]
    clens = lu + lv
    cstart = np.cumsum(clens) - clens
    out = np.empty(flat.size, dtype=np.int64)
    nu = int(lu.sum())
    # the u half of every path reversed (source first), then the v half as traced
    j = np.repeat(np.arange(e), lu)
    t = np.arange(nu) - (np.cumsum(lu) - lu)[j]
    out[cstart[j] + lu[j] - 1 - t] = flat[:nu]
    j = np.repeat(np.arange(e), lv)
    t = np.arange(flat.size - nu) - (np.cumsum(lv) - lv)[j]
    out[cstart[j] + lu[j] + t] = flat[nu:]
    return out, clens, lu


def _split(flat, lens):
    """The list of paths (views of ``flat``)."""
    cut = np.cumsum(lens).tolist()
    return [flat[a:b] for a, b in zip([0] + cut[:-1], cut)]


def _delaunay_paths(G, idx):
    vor = voronoi_pairs(G, idx)
    flat, lens = _paths_between(vor.pred, vor.edge, vor.via)
    ends = np.column_stack([idx[vor.p], idx[vor.q]]) if len(vor.p) else np.empty((0, 2), np.int64)
    return (flat, lens), ends, vor


def _tree_paths(G, idx):
    vor = voronoi_pairs(G, idx)
    k = idx.size
    if len(vor.p) == 0:
        return (np.empty(0, np.int64), np.empty(0, np.int64)), np.empty((0, 2), np.int64)
    W = sp.csr_array((vor.length, (vor.p, vor.q)), shape=(k, k))
    T = csgraph.minimum_spanning_tree(W).tocoo()
    lo, hi = np.minimum(T.row, T.col).astype(np.int64), np.maximum(T.row, T.col).astype(np.int64)
    sel = np.flatnonzero(np.isin(vor.p * k + vor.q, lo * k + hi))
    return _paths_between(vor.pred, vor.edge[sel], vor.via[sel]), np.column_stack([idx[vor.p[sel]], idx[vor.q[sel]]])


def _cycle_paths(V, G, idx):
    """Nearest-neighbour chain of the samples by shortest paths, closed into a cycle."""
    k = idx.size
    G = sp.csr_array(G, copy=True)
    # entries of G by column, to make vertices on the curve expensive to cross
    by_col = np.argsort(G.indices, kind="stable")
    colptr = np.concatenate([[0], np.cumsum(np.bincount(G.indices, minlength=G.shape[0]))])
    penalty = 1e6 * float(G.data.sum() + 1.0)

    def block(vertices):
        for v in vertices:
            G.data[by_col[colptr[v]:colptr[v + 1]]] = penalty

    # one cycle per mesh component; visiting order: greedy nearest neighbour in space
    _, comp = pattern_components(G)
    curves, ends = [], []
    P = V[idx]
    sc = unit_scale(P)  # a power of two: squared distances neither overflow nor underflow
    if sc != 1.0:
        P = P * (1.0 / sc)
    for c in np.unique(comp[idx]):
        members = np.flatnonzero(comp[idx] == c)
        if members.size < 2:
            continue
        order = [members[0]]
        left = np.zeros(k, dtype=bool)
        left[members[1:]] = True
        for _ in range(members.size - 1):
            d = np.linalg.norm(P - P[order[-1]], axis=1)
            d[~left] = np.inf
            j = int(np.argmin(d))
            order.append(j)
            left[j] = False
        if members.size > 2:
            order.append(order[0])
        block([idx[order[0]]])
        for a, b in zip(order[:-1], order[1:]):
            src, dst = idx[a], idx[b]
            _, pred = csgraph.dijkstra(G, indices=src, return_predecessors=True)
            path = trace(pred, dst)[::-1]
            curves.append(path)
            ends.append((src, dst))
            block(path[1:])
    return curves, np.array(ends, dtype=np.int64).reshape(-1, 2)


def partition(surface: Surface, idx: np.ndarray, *, method: Literal["delaunay", "cycle", "tree"] = "delaunay",
              graph: sp.sparray | sp.spmatrix | None = None) -> Partition:
    """Cut the surface by curves through every sample into patches.

    Parameters
    ----------
    surface : Surface
        The surface (:class:`manifill.surface.surface.Surface`): its positions and its graph
        ``surface.G``, whose edge lengths the paths minimise.
    idx : (k,) numpy array of int
        Sample vertices (unique).
    method : {'delaunay', 'cycle', 'tree'}, optional
        How to draw the curves (see the module docstring).
    graph : (n, n) scipy sparse matrix, optional
        Another graph for the paths (e.g. :func:`manifill.mesh.graph.mesh_graph` with
        ``distance='hops'``); default ``surface.G``.

    Returns
    -------
    Partition

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> from manifill.surface.surface import Surface
    >>> V, F = icosphere(3)
    >>> idx = np.array([0, 1, 2, 3, 4])
    >>> part = partition(Surface.from_mesh(V, F), idx, method="cycle")
    >>> bool(part.on_curve[idx].all()), part.report["patches"]
    (True, 2)
    """
    check_option("method", method, PARTITIONS)
    idx = np.asarray(idx, dtype=np.int64)
    V = surface.V
    G = sp.csr_array(surface.G if graph is None else graph)
    n = G.shape[0]
    if method == "delaunay":
        (flat, lens), ends, _ = _delaunay_paths(G, idx)
    elif method == "tree":
        (flat, lens), ends = _tree_paths(G, idx)
    else:
        curves, ends = _cycle_paths(V, G, idx)
        lens = np.array([len(c) for c in curves], dtype=np.int64)
        flat = np.concatenate(curves) if curves else np.empty(0, np.int64)
    curves = _split(flat, lens)
    on_curve = np.zeros(n, dtype=bool)
    on_curve[idx] = True
    on_curve[flat] = True
    # shortest paths are simple: a vertex inside two or more of them is where paths merged
    inner = np.ones(flat.size, dtype=bool)
    stop = np.cumsum(lens)
    inner[stop[lens > 0] - lens[lens > 0]] = False
    inner[stop[lens > 0] - 1] = False
    uses = np.bincount(flat[inner], minlength=n)
    part = Partition(curves, np.asarray(ends, dtype=np.int64).reshape(-1, 2), on_curve,
                     np.full(n, -1, dtype=np.int64), [])
    part._flat = (flat, lens)
    _label_patches(part, G)
    E = part.curve_edges()
    length = float(G[E[:, 0], E[:, 1]].sum()) if len(E) else 0.0
    sizes = np.bincount(part.labels[part.labels >= 0]) if (part.labels >= 0).any() else np.zeros(0, np.int64)
    part.report = {
        "method": method,
        "curves": len(curves),
        "curve_vertices": int(on_curve.sum()),
        "curve_length": length,
        "patches": int(sizes.size),
        "patch_sizes": sizes.tolist(),
        "inner_points": int((~on_curve).sum()),
        "balance": float(sizes.max() / sizes.mean()) if sizes.size else 0.0,
        "merged_vertices": int((uses > 1).sum()),
    }
    return part


def _label_patches(part, G):
    """Connected components of the vertices off the curves, and their boundaries."""
    G = sp.csr_array(G)
    n = G.shape[0]
    free = ~part.on_curve
    rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(G.indptr))
    cols = G.indices.astype(np.int64)
    # the mesh graph with every edge at a curve vertex cut (its pattern is symmetric)
    keep = free[rows] & free[cols]
    indptr = np.concatenate([[0], np.cumsum(np.bincount(rows[keep], minlength=n))])
    _, lab = pattern_components(sp.csr_array((np.ones(int(keep.sum())), cols[keep], indptr), shape=(n, n)))
    labels = np.full(n, -1, dtype=np.int64)
    if free.any():
        # patches numbered by decreasing size (ties: by first vertex); curve vertices are
        # components of their own in ``lab`` and get no number
        sizes = np.bincount(lab[free], minlength=n)
        used = np.flatnonzero(sizes)
        rank = np.full(n, -1, dtype=np.int64)
        rank[used[np.argsort(-sizes[used], kind="stable")]] = np.arange(used.size)
        labels[free] = rank[lab[free]]
    part.labels = labels
    touch = free[rows] & part.on_curve[cols]
    key = _unique(labels[rows[touch]] * n + cols[touch])
    pl, pv = key // n, key % n
    npatch = int(labels.max()) + 1
    split = np.searchsorted(pl, np.arange(npatch + 1))
    part.boundaries = [pv[split[j]:split[j + 1]] for j in range(npatch)]
