"""Step 1 of the paper: the gradual variation condition, value levels, Lipschitz constants.

Samples ``f(p) = A_{i_p}`` on the levels ``A_1 < ... < A_n`` satisfy the gradual
variation condition when ``d(p, q) >= |i_p - i_q|`` for every pair of samples, with
``d`` the distance in the mesh graph (Chen 1989: exactly then a gradually varied
extension exists).

The paper checks it with one Dijkstra per sample (its Lemma 3.3). manifill needs one shortest-path pass: the
upper envelope ``U(x) = min_q (i_q + d(x, q))`` is computed for all ``x`` at once by a Dijkstra from a virtual
source joined to every sample ``q`` by an edge of length ``i_q`` (shifted to be positive); the condition holds
exactly when ``U(p) = i_p`` at every sample ``p``, and where it fails, the sample ``q`` that attains ``U(p)`` is
the worst partner of ``p``.

Distances are ``hops`` or ``length`` (:mod:`manifill.mesh.graph`); the integer gradually varied fit works on hops.
"""

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike
from scipy.sparse import csgraph

from ..errors import OptionError, SampleError
from ..mesh.graph import offset_distances
from ..tolerances import TOL
from ..validate import check_magnitude, check_option
from .lipschitz import EXTENSIONS, lipschitz_constant, lipschitz_extension
from .surface import Surface

__all__ = ["lipschitz_constant", "GradualCheck", "check_gradual", "violation_message", "gvf", "lipschitz_extension",
           "EXTENSIONS"]


@dataclass
class GradualCheck:
    """The result of :func:`check_gradual`.

    Attributes
    ----------
    holds : bool
        Whether the samples satisfy the gradual variation condition.
    levels : (m,) numpy array
        The value levels ``A_1 < ... < A_m``.
    level : (k,) int64 numpy array
        Level index ``i_p`` of every sample (0-based).
    step : float or None
        Level spacing for uniform levels.
    lipschitz : float
        Smallest ``K`` with ``|f_p - f_q| <= K d(p, q)`` (values per unit of
        distance).
    lipschitz_pair : tuple of int
        Sample vertices attaining it.
    violations : (v, 4) numpy array
        Rows ``(p, q, d(p, q), |i_p - i_q|)`` with ``d < |i_p - i_q|``: every
        violating sample ``p`` with its worst partner ``q`` (vertex indices).
    distance : str
        ``'hops'`` or ``'length'``.
    level_error : float
        Largest ``|f_p - A_{i_p}|``: how far samples moved onto their levels.
    """

    holds: bool
    levels: np.ndarray
    level: np.ndarray
    step: float | None
    lipschitz: float
    lipschitz_pair: tuple
    violations: np.ndarray
    distance: str
    level_error: float

    def worst(self, k: int | None = None) -> np.ndarray:
        """The violations, most negative slack ``d(p, q) - |i_p - i_q|`` first.

        Parameters
        ----------
        k : int, optional
            How many rows (all by default).

        Returns
        -------
        (min(k, v), 4) numpy array
            Rows of :attr:`violations` ordered by
            ``numpy.argsort(violations[:, 2] - violations[:, 3])``.

        Examples
        --------
        >>> from manifill.mesh.shapes import grid
        >>> from manifill.mesh.graph import mesh_graph
        >>> G = mesh_graph(*grid(5), distance="hops")
        >>> c = check_gradual(G, np.array([0, 1, 24]), np.array([0.0, 3.0, 4.0]), levels=5)
        >>> c.worst(1).tolist()
        [[1.0, 0.0, 1.0, 3.0]]
        """
        rows = self.violations[np.argsort(self.violations[:, 2] - self.violations[:, 3])]
        return rows if k is None else rows[:k]

    def summary(self) -> dict[str, Any]:
        """The check as a small dict (a reconstruction's ``report['check']`` entries).

        ``holds``, ``lipschitz_<distance>``, ``step``, ``levels`` (count), ``violations``
        (count), ``level_error``.
        """
        return {"holds": self.holds, f"lipschitz_{self.distance}": self.lipschitz, "step": self.step,
                "levels": int(self.levels.size), "violations": int(len(self.violations)),
                "level_error": self.level_error}


def _violations(G, idx, level):
    """Samples ``p`` with ``U(p) < i_p``, each with its worst partner."""
    U, root, _ = offset_distances(G, idx, level.astype(np.float64))
    U = U[idx]
    bad = np.flatnonzero(U < level - TOL.level_slack)
    q = root[idx[bad]]
    d = U[bad] - level[q]
    return np.column_stack([idx[bad], idx[q], d, np.abs(level[bad] - level[q])])


def _snap_levels(vals, levels):
    """Index of the nearest level of every value."""
    pos = np.clip(np.searchsorted(levels, vals), 1, max(len(levels) - 1, 1))
    if len(levels) == 1:
        return np.zeros(vals.size, dtype=np.int64)
    left = levels[pos - 1]
    right = levels[pos]
    return np.where(np.abs(vals - left) <= np.abs(right - vals), pos - 1, pos).astype(np.int64)


def _uniform(vals, step):
    lo = float(vals.min())
    m = int(np.floor(np.ptp(vals) / step + 0.5)) + 1
    # the top level rounds to within half a step of the largest sample, possibly above it: cap it there,
    # so that no level (and no gradually varied value) leaves the samples' range
    levels = np.minimum(lo + step * np.arange(m), float(vals.max()))
    return levels, np.floor((vals - lo) / step + 0.5).astype(np.int64)


def check_gradual(surface: Surface | sp.sparray | sp.spmatrix, idx: np.ndarray, vals: np.ndarray, *,
                  levels: int | ArrayLike | None = None, distance: Literal["hops", "length"] | None = None,
                  start: tuple | None = None) -> GradualCheck:
    """Choose value levels and check the gradual variation condition.

    Parameters
    ----------
    surface : Surface or (n, n) scipy sparse matrix
        A Surface (its hop graph, the paper's measure), or a graph for ``distance`` (:func:`mesh_graph`).
    idx : (k,) numpy array of int
        Sample vertices (unique, validated).
    vals : (k,) numpy array of float
        Sample values.
    levels : None, int or (m,) array_like, optional
        ``None``: uniform levels with the finest step at which the samples
        satisfy the condition: the Lipschitz constant, coarsened by factors of
        1.5 where rounding onto the levels breaks it (with ``hops`` it cannot,
        distances being whole numbers, and the verifying pass is skipped
        unless a value sits on a rounding tie); an ``int``: that
        many uniform levels from the smallest to the largest value; an array:
        these levels (strictly increasing), each sample going to the nearest.
    distance : {'hops', 'length'} or None, optional
        The distance ``G`` measures (for the report; with ``hops`` the levels
        need no verifying pass). ``None``: read from ``G``, ``hops`` when every
        edge has length 1.
    start : tuple, optional
        A lower bound of the Lipschitz constant (see :func:`lipschitz_constant`).

    Returns
    -------
    GradualCheck

    Raises
    ------
    SampleError
        Levels not strictly increasing, or fewer than 1.

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> from manifill.mesh.graph import mesh_graph
    >>> V, F = grid(5)
    >>> G = mesh_graph(V, F, distance="hops")
    >>> c = check_gradual(G, np.array([0, 4, 24]), np.array([0.0, 2.0, 3.0]))
    >>> c.holds, float(c.step), c.level.tolist()
    (True, 0.75, [0, 3, 4])
    >>> check_gradual(G, np.array([0, 1]), np.array([0.0, 3.0]), levels=4).violations.tolist()
    [[1.0, 0.0, 1.0, 3.0]]
    """
    G: Any = getattr(surface, "G_hops", surface)
    if distance is None:
        distance = "length" if G.nnz and not np.all(sp.csr_array(G).data == 1.0) else "hops"
    check_option("distance", distance, ("hops", "length"))
    idx = np.asarray(idx, dtype=np.int64)
    vals = np.asarray(vals, dtype=np.float64)
    K, pair, _ = lipschitz_constant(G, idx, vals, start=start)
    step = None
    if levels is None:
        if K == 0:
            A, level = np.array([float(vals.min())]), np.zeros(vals.size, dtype=np.int64)
            viol = np.empty((0, 4))
        else:
            step = K
            for _ in range(60):
                A, level = _uniform(vals, step)
                x = (vals - A[0]) / step
                if distance == "hops" and np.all(np.abs(x - np.floor(x) - 0.5) > TOL.level_tie):
                    # whole-number distances: |a - b| <= d implies |round(a) - round(b)| <= d, so
                    # the levels hold without a verifying pass unless a value sits on a rounding tie
                    viol = np.empty((0, 4))
                    break
                viol = _violations(G, idx, level)
                if len(viol) == 0:
                    break
                step *= 1.5
    else:
        if np.isscalar(levels) or np.ndim(levels) == 0:
            m = int(levels)  # type: ignore[arg-type]  # a scalar: the count of levels
            if m < 1:
                raise SampleError(f"levels={levels} asks for no levels; pass a count of at least 1")
            if m == 1 or np.ptp(vals) == 0:
                A = np.full(1, float(vals.min()))
            else:
                step = float(np.ptp(vals)) / (m - 1)
                A = float(vals.min()) + step * np.arange(m)
        else:
            A = np.asarray(levels, dtype=np.float64).ravel()
            check_magnitude(A[np.isfinite(A)], "levels", "pass levels within the values' scale")
            if A.size == 0 or not np.all(np.isfinite(A)) or np.any(np.diff(A) <= 0):
                raise SampleError("levels must be finite and strictly increasing; sort them and drop repeats")
        level = _snap_levels(vals, A)
        viol = _violations(G, idx, level)
    return GradualCheck(
        holds=len(viol) == 0,
        levels=A,
        level=level,
        step=step,
        lipschitz=K,
        lipschitz_pair=(int(idx[pair[0]]), int(idx[pair[1]])) if pair[0] >= 0 else (-1, -1),
        violations=viol,
        distance=distance,
        level_error=float(np.abs(vals - A[level]).max()),
    )


def violation_message(check, limit=3):
    """One line describing the violations of a failed check.

    Parameters
    ----------
    check : GradualCheck
        A check whose condition fails.
    limit : int, optional
        How many pairs to show.

    Returns
    -------
    str
    """
    rows = check.worst(limit)
    pairs = "; ".join(f"vertices {int(p)} and {int(q)} are {d:g} apart but {int(k)} levels apart"
                      for p, q, d, k in rows)
    return (f"{len(check.violations)} samples break the gradual variation condition ({pairs}); "
            f"use fewer levels (levels=None picks a step that works) or check those samples")


def _require_hops(G):
    if G.nnz and not np.all(G.data == 1.0):
        raise OptionError("gradually varied fitting works on graph hops; build the graph with distance='hops'")


def gvf(G, idx, level, *, method="envelope"):
    """Gradually varied fitting: a level at every vertex, changing by at most 1 per edge.

    Chen's theorem (1989) says such a fit through the samples exists exactly when
    they satisfy the gradual variation condition; both methods construct one.

    Parameters
    ----------
    G : (n, n) scipy sparse matrix
        The hop graph (unit edge lengths; :func:`manifill.mesh.graph.mesh_graph`
        with ``distance='hops'``).
    idx : (k,) numpy array of int
        Sample vertices (unique).
    level : (k,) numpy array of int
        Their level indices.
    method : {'envelope', 'chen'}, optional
        ``envelope``: the rounded-down midpoint of the upper and lower
        envelopes ``U(x) = min_q (i_q + d(x, q))`` and
        ``L(x) = max_q (i_q - d(x, q))``, two Dijkstra passes,
        O(|E| + |D| log |D|). Both envelopes change by at most 1 per edge and
        meet at the samples, so their midpoint does too, and rounding down
        keeps it so. ``chen``: Chen's constructive proof, growing the fitted set
        one adjacent vertex at a time and giving each the level in its feasible
        interval ``[L_J(x), U_J(x)]`` (over the fitted set ``J``) nearest to the
        mean of its fitted neighbours; one breadth-first search per vertex,
        O(|D| |E|): a reference for small meshes.

    Returns
    -------
    (n,) int64 numpy array
        Level index of every vertex; ``-1`` on vertices no sample can reach.

    Raises
    ------
    SampleError
        If the samples break the condition (the message names the worst
        pairs).
    OptionError
        If ``G`` is not a hop graph or ``method`` is unknown.

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> from manifill.mesh.graph import mesh_graph
    >>> V, F = grid(4, diagonal="right")
    >>> fit = gvf(mesh_graph(V, F, distance="hops"), np.array([0, 15]), np.array([0, 2]))
    >>> fit.reshape(4, 4).tolist()
    [[0, 0, 0, 1], [0, 0, 1, 1], [0, 1, 1, 2], [1, 1, 2, 2]]
    """
    check_option("method", method, ("envelope", "chen"))
    _require_hops(G)
    idx = np.asarray(idx, dtype=np.int64)
    level = np.asarray(level, dtype=np.int64)
    viol = _violations(G, idx, level)
    if len(viol):
        raise SampleError(violation_message(_as_check(viol)))
    if method == "envelope":
        U = offset_distances(G, idx, level.astype(np.float64))[0]
        L = -offset_distances(G, idx, -level.astype(np.float64))[0]
        out = np.full(G.shape[0], -1, dtype=np.int64)
        ok = np.isfinite(U)
        out[ok] = np.floor((U[ok] + L[ok]) / 2 + TOL.level_slack).astype(np.int64)
        return out
    return _gvf_chen(G, idx, level)


def _as_check(viol):
    return GradualCheck(False, np.empty(0), np.empty(0, np.int64), None, 0.0, (-1, -1), viol, "hops", 0.0)


def _gvf_chen(G, idx, level):

    n = G.shape[0]
    G = sp.csr_array(G)
    out = np.full(n, -1, dtype=np.int64)
    out[idx] = level
    U = np.full(n, np.inf)
    L = np.full(n, -np.inf)
    for q, i in zip(idx, level):
        d = csgraph.shortest_path(G, unweighted=True, indices=q)
        U = np.minimum(U, i + d)
        L = np.maximum(L, i - d)
    # breadth-first order from the samples: each vertex is adjacent to the fitted set
    order = []
    seen = np.zeros(n, dtype=bool)
    seen[idx] = True
    frontier = list(idx)
    while frontier:
        nxt = []
        for x in frontier:
            for y in G.indices[G.indptr[x]:G.indptr[x + 1]]:
                if not seen[y]:
                    seen[y] = True
                    order.append(int(y))
                    nxt.append(int(y))
        frontier = nxt
    for x in order:
        nb = G.indices[G.indptr[x]:G.indptr[x + 1]]
        fitted = out[nb][out[nb] >= 0]
        lo, hi = int(np.ceil(L[x] - TOL.level_slack)), int(np.floor(U[x] + TOL.level_slack))
        out[x] = int(np.clip(np.round(fitted.mean()), lo, hi))
        d = csgraph.shortest_path(G, unweighted=True, indices=x)
        U = np.minimum(U, out[x] + d)
        L = np.maximum(L, out[x] - d)
    return out
