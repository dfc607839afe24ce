"""Lipschitz constants and extensions of samples on a mesh graph: the exact constant :func:`lipschitz_constant`
(which Step 1's :func:`manifill.surface.gradual.check_gradual` starts from) and the real-valued extensions
:func:`lipschitz_extension`, both by Dijkstra passes from the samples (:func:`manifill.mesh.graph.offset_distances`).
"""

import numpy as np

from ..mesh.graph import offset_distances, voronoi_pairs
from ..tolerances import TOL
from ..validate import check_option

__all__ = ["lipschitz_constant", "EXTENSIONS", "lipschitz_extension"]


def lipschitz_constant(G, idx, vals, *, start=None):
    """Smallest ``K`` with ``|f_p - f_q| <= K d(p, q)`` for all samples, exactly.

    A Dinkelbach iteration on envelopes: for a trial ``K`` one Dijkstra gives
    ``U(x) = min_q (f_q + K d(x, q))``; a sample with ``U(p) < f_p`` has a
    partner with a larger ratio, and ``K`` jumps to the largest such ratio. Every
    step raises ``K`` to the ratio of an actual pair, so it ends, in a few
    passes, on the exact maximum.

    Parameters
    ----------
    G : (n, n) scipy sparse matrix
        Graph with positive edge lengths.
    idx : (k,) numpy array of int
        Sample vertices (unique).
    vals : (k,) numpy array of float
        Sample values.
    start : tuple (K0, (a, b)), optional
        A known lower bound ``K0 = |f_a - f_b| / l`` with ``l`` the length of
        some path from ``idx[a]`` to ``idx[b]`` (e.g. a partition curve):
        saves the first pass.

    Returns
    -------
    K : float
        The constant (0 for fewer than two samples or equal values).
    pair : tuple of int
        Positions in ``idx`` of a pair attaining it (``(-1, -1)`` if ``K = 0``).
    passes : int
        Dijkstra passes used.

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> from manifill.mesh.graph import mesh_graph
    >>> V, F = grid(5)
    >>> G = mesh_graph(V, F, distance="hops")
    >>> K, pair, _ = lipschitz_constant(G, np.array([0, 4, 24]), np.array([0.0, 2.0, 3.0]))
    >>> float(K), pair
    (0.75, (0, 2))
    """
    vals = np.asarray(vals, dtype=np.float64)
    if vals.size < 2 or np.ptp(vals) == 0:
        return 0.0, (-1, -1), 0
    # start just below the answer: the steepest pair of neighbouring Voronoi
    # cells, over an upper bound of their distance
    if start is not None and start[0] > 0:
        K, pair, passes = float(start[0]), tuple(start[1]), 0
    else:
        p, q, length = voronoi_pairs(G, idx)[:3]
        if p.size == 0:
            return 0.0, (-1, -1), 1  # no two samples share a component
        ratio = np.abs(vals[p] - vals[q]) / length
        j = int(np.argmax(ratio))
        K, pair, passes = float(ratio[j]), (int(p[j]), int(q[j])), 1
    if K == 0:
        # neighbouring cells agree everywhere, so every component is constant
        return 0.0, (-1, -1), passes
    while True:
        passes += 1
        U, root, _ = offset_distances(G, idx, vals / K)
        U = U[idx] * K
        viol = np.flatnonzero(U < vals - TOL.lipschitz_rtol * max(1.0, float(np.abs(vals).max())))
        if viol.size == 0:
            return K, pair, passes
        q = root[idx[viol]]
        d = (U[viol] - vals[q]) / K
        ratio = (vals[viol] - vals[q]) / np.maximum(d, TOL.tiny)
        j = int(np.argmax(ratio))
        if ratio[j] <= K * (1 + TOL.lipschitz_rtol):
            return K, pair, passes
        K, pair = float(ratio[j]), (int(viol[j]), int(q[j]))


EXTENSIONS = ("midpoint", "mcshane", "whitney")


def lipschitz_extension(G, idx, vals, *, kind="midpoint", K=None):
    """Real-valued Lipschitz extension of the samples to every vertex.

    Parameters
    ----------
    G : (n, n) scipy sparse matrix
        The mesh graph for the chosen distance.
    idx : (k,) numpy array of int
        Sample vertices (unique).
    vals : (k,) numpy array of float
        Sample values.
    kind : {'midpoint', 'mcshane', 'whitney'}, optional
        ``mcshane``: ``max_q (f_q - K d(x, q))``, the smallest K-Lipschitz
        extension; ``whitney``: ``min_q (f_q + K d(x, q))``, the largest;
        ``midpoint``: their mean.
    K : float, optional
        Lipschitz constant, at least the samples' own (default: exactly theirs,
        :func:`lipschitz_constant`).

    Returns
    -------
    (n,) numpy array
        Equal to ``vals`` at ``idx``; NaN where no sample is reachable.

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> from manifill.mesh.graph import mesh_graph
    >>> V, F = grid(5, diagonal="right")
    >>> x = lipschitz_extension(mesh_graph(V, F, distance="hops"), np.array([0, 24]), np.array([0.0, 4.0]))
    >>> x.reshape(5, 5)[0].tolist()
    [0.0, 0.5, 1.0, 1.5, 2.0]
    """
    check_option("kind", kind, EXTENSIONS)
    idx = np.asarray(idx, dtype=np.int64)
    vals = np.asarray(vals, dtype=np.float64)
    if K is None:
        K = lipschitz_constant(G, idx, vals)[0]
    if K <= 0:
        # constant on each component: the value of its samples
        d, root, _ = offset_distances(G, idx, np.zeros(idx.size))
        out = np.where(np.isfinite(d), vals[np.maximum(root, 0)], np.nan)
        out[idx] = vals
        return out
    up = K * offset_distances(G, idx, vals / K)[0]
    reach = np.isfinite(up)
    lo = np.full(up.shape, np.nan)
    lo[reach] = -K * offset_distances(G, idx, -vals / K)[0][reach]
    up[~reach] = np.nan
    out = {"whitney": up, "mcshane": lo, "midpoint": (up + lo) / 2}[kind]
    out[idx] = vals
    return out
