"""Point clouds as surfaces: neighbours, normals, a Laplacian and mass, a graph, gradients -- no triangles.

A scan gives points, not faces. Everything manifill's methods need of a surface is built here from the
points alone, in one pass over each point's ``k`` nearest neighbours (:class:`Cloud`):

- **normals** by principal components of the neighbourhood, oriented consistently by a breadth-first walk;
- **the local Delaunay umbrella** of every point: its neighbours projected on its tangent plane, kept
  where they are Delaunay neighbours of the point in that plane (the vertices of the convex hull of the
  neighbours inverted about it), joined in angular order into a fan of triangles;
- **the cotangent Laplacian and lumped mass** of those fans (each point's row from its own fan, the matrix
  made symmetric by averaging the two ends' weights; a third of each fan's area as the mass). In a plane
  the fans are the Delaunay triangulation's, so the weights are non-negative (a maximum principle) and
  linear functions are harmonic;
- **the graph** of the pipeline (the fans' edges: the k-nearest-neighbour graph pruned to local Delaunay
  neighbours, so that a path of points separates the cloud as a curve separates a mesh);
- **the gradient** at every point by a least-squares plane through its neighbours, tangent to the surface.

Vectorised over all points (no Python loop over points): about one second for 163,842 points, where
``robust_laplacian.point_cloud_laplacian`` (Sharp & Crane's tufted cover, ``weights='robust'``) takes 5-10 s.
"""

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, connected_components
from scipy.spatial import cKDTree

from ..errors import MeshError
from ..tolerances import TOL
from ..validate.options import first_entries
from ..validate.scale import bbox_diagonal, check_size, unit_scale
from .graph import edge_graph, graph_laplacian, quantised_lengths

__all__ = ["NEIGHBOURS", "RAY", "Cloud", "cloud_neighbours"]

#: Angles (radians) closer than this are one ray from a point (collinear neighbours of a regular grid).
RAY = 1e-9
#: Neighbours per point by default: enough for the local Delaunay umbrella of irregular scans (about 6 of them
#: are kept), few enough to stay local.
NEIGHBOURS = 16


#: Neighbours looked at beyond the ``k`` nearest, so that points at one distance (a regular grid's rings) are
#: chosen by their index, not by round-off, which changes with the cloud's units.
TIE_SPARE = 8


def cloud_neighbours(P, k):
    """``(nbr, dist)``: each point's ``k`` nearest other points, nearest first, and their distances.

    Distances equal to a relative ``TOL.graph_length_quantum`` of the nearest one's are ties, broken by the
    points' indices: the neighbours are the same in any units.
    """
    tree = cKDTree(P)
    m = min(k + 1 + TIE_SPARE, len(P))
    dist, nbr = tree.query(P, k=m, workers=-1)
    self_ = nbr == np.arange(len(P))[:, None]
    unit = np.maximum(dist[:, 1:2], TOL.tiny) * TOL.graph_length_quantum
    key = np.round(dist / unit)
    key[self_] = -1.0  # the point itself first, even where another coincides with it
    order = np.lexsort((nbr, key), axis=1)[:, 1:k + 1]
    return np.take_along_axis(nbr, order, 1).astype(np.int64), np.take_along_axis(dist, order, 1)


class Cloud:
    """A point cloud's neighbourhoods and the operators built on them.

    Parameters
    ----------
    P : (n, 3) array_like of float
        The points (finite, at least 4, no two equal).
    neighbours : int, optional
        How many nearest neighbours each point looks at (:data:`NEIGHBOURS`).

    Attributes
    ----------
    P : (n, 3) numpy array
    k : int
    nbr : (n, k) int64 numpy array
        Nearest neighbours, nearest first.
    normals : (n, 3) numpy array
        Unit normals, oriented consistently on each connected piece.
    L : (n, n) scipy.sparse.csr_array
        The cotangent Laplacian of the local Delaunay fans (positive semi-definite, zero row sums).
    M : (n,) numpy array
        The lumped mass (area per point).
    E : (e, 2) int64 numpy array
        The graph's edges (``i < j``).
    components : int
        Connected pieces of the graph.

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> V, _ = grid(6)
    >>> c = Cloud(V)
    >>> inside = np.flatnonzero((V[:, :2].min(axis=1) > 0.01) & (V[:, :2].max(axis=1) < 0.99))
    >>> round(float(c.M.sum()), 12), bool(np.allclose((c.L @ V[:, 0])[inside], 0.0)), c.components
    (1.0, True, 1)
    """

    def __init__(self, P, neighbours=NEIGHBOURS):
        P = np.asarray(P, dtype=np.float64)
        check_size(P, 2, "the point cloud", "areas", "give its points in other units (e.g. km or mm)")
        self.n, self.k = len(P), int(min(neighbours, len(P) - 1))
        self.scale = unit_scale(P)  # a power of two: lengths, areas, cotangents exact in any units
        self.P = P
        Pu = P / self.scale
        self.nbr, dist = cloud_neighbours(Pu, self.k)
        same = np.flatnonzero(dist[:, 0] <= 0.0)
        if same.size:
            raise MeshError(f"the point cloud has {same.size} points at the same position as another (point "
                            f"{first_entries(same)}); merge duplicate points before reconstructing")
        self.spacing = float(np.median(dist[:, 0])) * self.scale
        _refuse_clusters(dist[:, 0] * self.scale, self.nbr[:, 0], self.spacing, P)
        frame = _frames(Pu, self.nbr)  # the fans need a tangent plane, not its orientation
        fan_a, fan_b = _umbrellas(Pu, self.nbr, frame)
        L, M = _cotan(Pu, self.nbr, fan_a, fan_b, self.n)
        self.L, M = _join_lone(L, M, self.nbr)
        self.M = M * self.scale ** 2
        U = sp.triu(self.L, k=1).tocoo()
        keep = U.data != 0.0
        self.E = np.column_stack([U.row[keep], U.col[keep]]).astype(np.int64)  # points in no fan included
        G = self.graph("hops")
        count, label = connected_components(G, directed=False)
        self.components = int(count)
        self.normals = _oriented(Pu, frame[:, 2], G, label)
        frame[:, 2] = self.normals
        frame[:, 1] = np.cross(frame[:, 2], frame[:, 0])
        self.frame = frame

    def graph(self, distance="length"):
        """The (n, n) symmetric graph on :attr:`E`: unit lengths (``'hops'``) or lengths over their mean."""
        E = self.E
        if distance == "hops":
            return edge_graph(self.n, E, np.ones(len(E)))
        Pu = self.P / self.scale
        return edge_graph(self.n, E, quantised_lengths(np.linalg.norm(Pu[E[:, 0]] - Pu[E[:, 1]], axis=1)))

    def uniform_laplacian(self):
        """The graph Laplacian of :attr:`E` (unit weights)."""
        return graph_laplacian(self.graph("hops"))

    def laplacian(self, weights):
        """The stiffness for a weight name: the fans' cotangents, or the graph's ``uniform`` weights.

        ``robust`` is Sharp & Crane's point-cloud Laplacian (the robust-laplacian package, with its own
        mass: the pair is kept for :meth:`mass`).
        """
        if weights == "uniform":
            return self.uniform_laplacian()
        if weights == "robust":
            return self._robust()[0]
        return self.L

    def _robust(self):
        if not hasattr(self, "_robust_pair"):
            try:
                import robust_laplacian
            except ImportError:
                raise ImportError("weights='robust' on a point cloud needs the robust-laplacian package: pip install "
                                  "'manifill[robust]' (or leave weights out: the cloud's own cotangent "
                                  "weights)") from None
            L, M = robust_laplacian.point_cloud_laplacian(self.P / self.scale, n_neighbors=max(self.k, 8))
            L = sp.csr_array(L)
            L.sort_indices()
            self._robust_pair = (L, np.asarray(M.diagonal()) * self.scale ** 2)
        return self._robust_pair

    def mass(self, weights=None):
        """The (n, n) diagonal lumped mass (the robust Laplacian's own for ``weights='robust'``)."""
        M = self._robust()[1] if weights == "robust" else self.M
        return sp.diags_array(M).tocsr()

    def gradient_operator(self):
        """``(3n, n)`` sparse ``G``: ``(G @ x).reshape(n, 3)`` is each point's tangent gradient of ``x``.

        A least-squares plane through the point and its neighbours in its tangent frame (weights falling
        with distance), exact for a linear field on a flat cloud.
        """
        Pu = self.P / self.scale
        n, k = self.n, self.k
        d = Pu[self.nbr] - Pu[:, None, :]  # (n, k, 3)
        t = np.einsum("nkc,nac->nka", d, self.frame[:, :2])  # tangent coordinates (n, k, 2)
        h = np.linalg.norm(t, axis=2)
        w = 1.0 / np.maximum(h / np.maximum(h[:, :1], TOL.tiny), 1.0) ** 2
        A = np.einsum("nk,nka,nkb->nab", w, t, t)
        inv = np.linalg.pinv(A)
        C = np.einsum("nab,nkb,nk->nka", inv, t, w)  # g2 = sum_k C[:, k] (x_nbr - x_self)
        C3 = np.einsum("nka,nac->nkc", C, self.frame[:, :2]) / self.scale  # (n, k, 3)
        rows = (3 * np.arange(n)[:, None, None] + np.arange(3)[None, None, :])
        rows = np.broadcast_to(rows, (n, k, 3))
        cols = np.broadcast_to(self.nbr[:, :, None], (n, k, 3))
        G = sp.coo_array((C3.ravel(), (rows.ravel(), cols.ravel())), shape=(3 * n, n)).tocsr()
        self_rows = 3 * np.arange(n)[:, None] + np.arange(3)
        diag = sp.coo_array((-C3.sum(axis=1).ravel(), (self_rows.ravel(), np.repeat(np.arange(n), 3))),
                            shape=(3 * n, n)).tocsr()
        return sp.csr_array(G + diag)

    def report(self):
        """What the command line and ``report['cloud']`` say about the construction."""
        return {"points": self.n, "neighbours": self.k, "graph": "local Delaunay neighbours among the "
                f"{self.k} nearest", "edges": int(len(self.E)), "components": self.components,
                "spacing": self.spacing}


def _refuse_clusters(nearest, which, spacing, P):
    """Refuse points much nearer to another than the cloud's spacing (``TOL.cloud_cluster`` of it), before any
    operator is built on them: their fans are needles whose weights make the fills singular or wrong. The spacing
    is the median nearest distance, or a tenth of the size over the square root of the count where that is larger
    (a cluster holding most of the points makes the median its own)."""
    spacing = max(spacing, 0.1 * bbox_diagonal(P) / np.sqrt(len(P)))
    limit = TOL.cloud_cluster * spacing
    near = np.flatnonzero(nearest < limit)
    if near.size:
        i = int(near[0])
        raise MeshError(f"the point cloud has {near.size} points nearer than {limit:.3g} to another "
                        f"({TOL.cloud_cluster:g} of its spacing {spacing:.3g}; point {i} is {nearest[i]:.3g} from "
                        f"point {int(which[i])}): merge or drop such clusters (keep one point of each) before "
                        f"reconstructing")


def _frames(Pu, nbr):
    """``(n, 3, 3)`` rows ``e1, e2, normal`` from the covariance of each point and its neighbours (all of them: the
    nearest ten alone, lopsided on an icosphere, tilted the plane and raised the gradient's error)."""
    X = np.concatenate([Pu[:, None, :], Pu[nbr]], axis=1)
    X = X - X.mean(axis=1, keepdims=True)
    _, vecs = np.linalg.eigh(np.einsum("nki,nkj->nij", X, X))  # ascending: the smallest is the normal
    return np.ascontiguousarray(np.stack([vecs[:, :, 2], vecs[:, :, 1], vecs[:, :, 0]], axis=1))


def _oriented(Pu, normals, G, label):
    """Normals flipped to agree along a breadth-first tree of the graph ``G`` (pieces ``label``), each piece's
    tree rooted at its point farthest from the piece's centre, whose normal is turned away from it (outward when
    closed)."""
    n = len(Pu)
    count = int(label.max()) + 1
    centre = np.zeros((count, 3))
    np.add.at(centre, label, Pu)
    centre /= np.bincount(label, minlength=count)[:, None]
    out = Pu - centre[label]
    far = np.einsum("ij,ij->i", out, out)
    order = np.lexsort((far, label))  # by piece, then distance from the centre
    roots = order[np.r_[np.flatnonzero(np.diff(label[order])), n - 1]]  # each piece's last: its farthest point
    parent = np.arange(n)
    sign = np.ones(n)
    for r in roots:
        members, pred = breadth_first_order(G, r, directed=False)
        parent[members[1:]] = pred[members[1:]]
        sign[r] = 1.0 if normals[r] @ out[r] >= 0 else -1.0
    # each point's sign: the product of the agreements up its tree (pointer jumping: log2(depth) rounds, with
    # S[i] = acc[i] S[up[i]] for the points not done and S[i] = acc[i] for those done)
    acc = np.sign(np.einsum("ij,ij->i", normals, normals[parent]) + TOL.tiny)
    acc[roots] = sign[roots]
    up, done = parent.copy(), parent == np.arange(n)
    while not done.all():
        todo = np.flatnonzero(~done)
        j = up[todo]
        acc[todo], done[todo], up[todo] = acc[todo] * acc[j], done[j], up[j]
    agree = acc
    return normals * agree[:, None]


def _umbrellas(Pu, nbr, frame):
    """Each point's local Delaunay fan: ``(a, b)`` neighbour indices of its triangles ``(i, a, b)``, ``(n, k)``
    each, -1 where no triangle."""
    n, k = nbr.shape
    d = Pu[nbr] - Pu[:, None, :]
    x = np.einsum("nkc,nc->nk", d, frame[:, 0])
    y = np.einsum("nkc,nc->nk", d, frame[:, 1])
    theta = np.arctan2(y, x)
    ray = np.round(theta / RAY)  # directions equal to round-off: one ray
    r2 = x ** 2 + y ** 2
    # by angle; on one ray, nearest first (a fraction below 1/2 breaks the ties of whole rays: one sort)
    order = np.argsort(ray + 0.25 * r2 / r2.max(axis=1, keepdims=True), axis=1, kind="stable")
    theta = np.take_along_axis(theta, order, 1)
    # a point behind a nearer one on the same ray is inside every circle through both and the point itself
    shadowed = np.zeros((n, k), dtype=bool)
    shadowed[:, 1:] = np.diff(np.take_along_axis(ray, order, 1), axis=1) == 0
    gap = np.diff(np.concatenate([theta, theta[:, :1] + 2 * np.pi], axis=1), axis=1)
    start = (np.argmax(gap, axis=1) + 1) % k  # the widest gap last: an open fan (a boundary point) ends there
    open_ = gap.max(axis=1) > np.pi
    order = np.take_along_axis(order, (start[:, None] + np.arange(k)) % k, 1)
    r2 = np.maximum(r2, TOL.tiny)
    px = np.take_along_axis(x / r2, order, 1)  # inverted about the point: Delaunay neighbours <-> hull vertices
    py = np.take_along_axis(y / r2, order, 1)
    keep = ~np.take_along_axis(shadowed, (np.arange(k)[None, :] + start[:, None]) % k, 1)
    cols = np.arange(k)
    rows = np.arange(n)  # the fans still changing: a round looks at those alone
    for _ in range(k):
        kp, X, Y, op = keep[rows], px[rows], py[rows], open_[rows, None]
        prev, nxt = _prev_next(kp)
        ax, ay = np.take_along_axis(X, prev, 1), np.take_along_axis(Y, prev, 1)
        bx, by = np.take_along_axis(X, nxt, 1), np.take_along_axis(Y, nxt, 1)
        # an open fan's ends have the point itself (the origin) beside them
        first = op & (cols[None, :] == np.argmax(kp, axis=1)[:, None])
        last = op & (cols[None, :] == (k - 1 - np.argmax(kp[:, ::-1], axis=1))[:, None])
        ax, ay = np.where(first, 0.0, ax), np.where(first, 0.0, ay)
        bx, by = np.where(last, 0.0, bx), np.where(last, 0.0, by)
        turn = (X - ax) * (by - Y) - (Y - ay) * (bx - X)
        reflex = kp & (turn <= 0.0) & (kp.sum(axis=1) > 2)[:, None]
        changed = reflex.any(axis=1)
        if not changed.any():
            break
        keep[rows] = kp & ~reflex
        rows = rows[changed]
    _, nxt = _prev_next(keep)
    a = np.take_along_axis(nbr, order, 1)
    b = np.take_along_axis(a, nxt, 1)
    tri = keep & ~(open_[:, None] & (cols[None, :] == (k - 1 - np.argmax(keep[:, ::-1], axis=1))[:, None]))
    # a closed fan's triangles span less than half a turn each (the widest gap is at most pi)
    return np.where(tri, a, -1), np.where(tri, b, -1)


def _join_lone(L, M, nbr):
    """Points in no fan (on a line: a wire leaving a scan) joined to their two nearest neighbours by unit weights,
    with the median point's mass, so that no point is cut off or massless."""
    lone = np.flatnonzero(M <= 0)
    if lone.size == 0:
        return L, M
    n = len(M)
    A = sp.coo_array((np.ones(2 * lone.size), (np.repeat(lone, 2), nbr[lone, :2].ravel())), shape=(n, n)).tocsr()
    L = sp.csr_array(L + graph_laplacian(sp.csr_array((A + A.T) > 0).astype(np.float64)))
    L.sort_indices()
    M = M.copy()
    M[lone] = np.median(M[M > 0]) if np.any(M > 0) else 1.0
    return L, M


def _prev_next(keep):
    """For each slot, the previous and next kept slot in cyclic order (``(n, k)`` indices each; 0 in a row
    with none kept)."""
    n, k = keep.shape
    cols = np.arange(k)
    full = keep.all(axis=1)
    if full.any():  # rows with every slot kept (most, in the first round): the neighbours in the cycle
        prev = np.broadcast_to((cols - 1) % k, (n, k)).copy()
        nxt = np.broadcast_to((cols + 1) % k, (n, k)).copy()
        if not full.all():
            rest = np.flatnonzero(~full)
            prev[rest], nxt[rest] = _prev_next(keep[rest])
        return prev, nxt
    prev = np.full((n, k), -1, dtype=np.int64)
    nxt = np.full((n, k), -1, dtype=np.int64)
    for d in range(1, k + 1):  # the nearest kept slot d places away, d growing until every slot has one
        prev = np.where((prev < 0) & np.roll(keep, d, axis=1), (cols - d) % k, prev)
        nxt = np.where((nxt < 0) & np.roll(keep, -d, axis=1), (cols + d) % k, nxt)
        if d % 2 == 0 and (prev >= 0).all() and (nxt >= 0).all():
            break
    return np.maximum(prev, 0), np.maximum(nxt, 0)


def _cotan(Pu, nbr, fan_a, fan_b, n):
    """The symmetric cotangent Laplacian and the lumped mass of the fans (rows from each point's own fan)."""
    i, c = np.nonzero(fan_a >= 0)
    a, b = fan_a[i, c], fan_b[i, c]
    pi, pa, pb = Pu[i], Pu[a], Pu[b]
    ea, eb, eab = pa - pi, pb - pi, pb - pa
    area2 = np.linalg.norm(np.cross(ea, eb), axis=1)
    ok = area2 > TOL.tiny
    i, a, b, ea, eb, eab, area2 = i[ok], a[ok], b[ok], ea[ok], eb[ok], eab[ok], area2[ok]
    cot_b = np.einsum("ij,ij->i", -eb, -eab) / area2  # the angle at b, opposite the edge (i, a)
    cot_a = np.einsum("ij,ij->i", -ea, eab) / area2  # the angle at a, opposite the edge (i, b)
    w = sp.coo_array((np.concatenate([cot_b, cot_a]) / 2.0, (np.concatenate([i, i]), np.concatenate([a, b]))),
                     shape=(n, n)).tocsr()
    w = sp.csr_array(w.maximum(0.0))  # a boundary fan's obtuse corner: no negative weight
    # symmetric: the mean of the two ends' weights where each end looked at the other, else the one that did
    k = nbr.shape[1]
    looked = sp.csr_array((np.ones(n * k), (np.repeat(np.arange(n), k), nbr.ravel())), shape=(n, n))
    both = sp.csr_array(looked.multiply(looked.T))
    W = sp.csr_array(w + w.T)
    L = graph_laplacian(sp.csr_array(W - 0.5 * W.multiply(both)))
    # Meyer's mixed area of each fan triangle at its point: the circumcentric part where no angle is obtuse,
    # else half or a quarter of the triangle (the same for either diagonal of four points on a circle)
    la, lb = np.einsum("ij,ij->i", ea, ea), np.einsum("ij,ij->i", eb, eb)
    cos_i = np.einsum("ij,ij->i", ea, eb)
    part = (cot_b * la + cot_a * lb) / 8.0
    area = area2 / 2.0
    part = np.where(cos_i < 0, area / 2.0, np.where((cot_a < 0) | (cot_b < 0), area / 4.0, part))
    M = np.bincount(i, weights=part, minlength=n)
    return L, M
