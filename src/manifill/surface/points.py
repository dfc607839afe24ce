"""Samples at surface points: located, merged, and split into vertex constraints and barycentric rows.

A sample given as a position is located at its closest surface point
(:func:`manifill.surface.locate.locate_points`). Points at one location (closer than
``TOL.weld`` times the mesh's size) are one sample (``duplicates``: equal values merge,
different ones raise or are averaged, as for vertices). A point at a vertex then
constrains that vertex; any other point is one linear equality row on its face's three
vertices, ``sum_j b_j x[v_j] = y`` (:class:`PointSamples`). The rows must be independent
on the vertices left free (no four points in one triangle, no three on one edge, no row
whose vertices are all samples): a dependent set is refused with a
:class:`~manifill.errors.SampleError` naming rows, before any solve.
"""

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.linalg as sl
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..errors import OptionError, SampleError
from ..tolerances import TOL
from ..validate import as_samples, as_values, check_option, first_entries, unit_scale
from .locate import locate_points

__all__ = ["PointSamples", "point_samples", "is_positions", "points_report", "eliminate_rows"]

#: Coupled blocks of rows up to this size are checked for independence by an SVD (larger ones by the solve).
RANK_BLOCK = 2000


@dataclass
class PointSamples:
    """Samples at surface points, ready for the solve (the result of :func:`point_samples`).

    Attributes
    ----------
    located : SurfacePoints
        Every input point, located (:class:`manifill.surface.locate.SurfacePoints`).
    idx : (a,) int64 numpy array
        Vertices constrained by points at them, sorted and unique.
    vals : (a, p) float64 numpy array
        Their values.
    Aeq : (m, n) scipy.sparse.csr_array
        The barycentric rows of the points inside faces (or on edges).
    beq : (m, p) float64 numpy array
        Their values.
    constraint : (k,) int64 numpy array
        For every input point, its constraint: ``i < a`` the vertex ``idx[i]``,
        ``a + j`` the row ``j``.
    nearest : (b,) int64 numpy array
        The points' nearest vertices, sorted and unique (the partition methods'
        samples, and the sample mask).
    nearest_vals : (b, p) float64 numpy array
        Their values (several points at one vertex: ``duplicates`` rule).
    squeeze : bool
        True if the values were given one-dimensional.
    """

    located: object
    idx: np.ndarray
    vals: np.ndarray
    Aeq: object
    beq: np.ndarray
    constraint: np.ndarray
    nearest: np.ndarray
    nearest_vals: np.ndarray
    squeeze: bool = False

    @property
    def inside(self):
        """Number of points constrained inside faces (the equality rows)."""
        return int(self.Aeq.shape[0])

    @property
    def values(self):
        """(c, p) numpy array: the values of every constraint (the nearest vertices' without constraints)."""
        if self.idx.size + self.inside == 0:
            return self.nearest_vals
        return np.vstack([self.vals, self.beq])

    def weights(self, w):
        """Per-point weights ``(k,)`` summed per constraint: ``(a + m,)``, vertices first, then rows."""
        try:
            w = np.asarray(w, dtype=np.float64)
        except (TypeError, ValueError):
            raise SampleError("sample_weights could not be read as numbers; pass one weight > 0 per sample") from None
        if w.shape != self.constraint.shape:
            raise SampleError(f"sample_weights has shape {w.shape} for {self.constraint.size} sample points; "
                              f"pass one weight per point")
        out = np.zeros(self.idx.size + self.inside)
        np.add.at(out, self.constraint, w)
        return out


def is_positions(idx):
    """Whether ``idx`` gives sample positions (a 2-D float array of 2 or 3 columns) rather than vertex indices.

    Examples
    --------
    >>> is_positions([[0.5, 0.1, 0.0]]), is_positions([3, 4]), is_positions(np.array([[1, 2, 3]]))
    (True, False, False)
    """
    try:
        a = np.asarray(idx)
    except (TypeError, ValueError):
        return False
    return a.ndim == 2 and a.shape[1] in (2, 3) and np.issubdtype(a.dtype, np.floating)


def points_report(points, exact):
    """``report['points']`` of a reconstruction: how the points were used, how many, the largest distance.

    Parameters
    ----------
    points : PointSamples
    exact : bool
        True for the energy methods (the closest surface points), False for
        the partition methods (the nearest vertices).

    Returns
    -------
    dict
        ``located`` ('closest surface point' or 'nearest vertex'), ``points``,
        ``max_distance``; for the energy methods also ``at_vertices`` and
        ``inside_faces``.
    """
    s = points.located
    if not exact:
        return {"located": "nearest vertex", "points": int(s.faces.size),
                "max_distance": float(s.vertex_distance.max())}
    return {"located": "closest surface point", "points": int(s.faces.size), "at_vertices": int(points.idx.size),
            "inside_faces": points.inside, "max_distance": float(s.distance.max())}


def point_samples(V, F, points, vals, *, duplicates="error", max_distance=None, nearest_only=False, located=None):
    """Locate sample positions on a mesh and turn them into constraints.

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions (validated).
    F : (m, 3) int64 numpy array
        Triangles.
    points : (k, 3) array_like
        Sample positions (``(k, 2)`` on a flat mesh).
    vals : (k,) or (k, p) array_like of float
        Values.
    duplicates : {'error', 'mean'}, optional
        Points at one location (or at one nearest vertex, for the partition
        methods) with different values: raise, or average.
    max_distance : float, optional
        Largest accepted distance to the surface (see :func:`manifill.surface.locate.locate_points`).
    nearest_only : bool, optional
        Only the nearest vertices are needed (the partition methods): the rows
        are not built nor checked (``idx``, ``Aeq`` empty).
    located : SurfacePoints, optional
        ``locate_points(V, F, points, max_distance=max_distance)`` computed before
        (a prepared reconstruction locates its points once).

    Returns
    -------
    PointSamples

    Raises
    ------
    SampleError
        Bad positions or values, far points, conflicting values at one location,
        or rows that are not independent.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    >>> F = np.array([[0, 1, 2], [1, 3, 2]])
    >>> s = point_samples(V, F, [[0.25, 0.25, 0], [1, 1, 0]], [1.0, 2.0])
    >>> s.idx.tolist(), s.Aeq.toarray().round(2).tolist(), s.beq.ravel().tolist()
    ([3], [[0.5, 0.25, 0.25, 0.0]], [1.0])
    """
    check_option("duplicates", duplicates, ("error", "mean"))
    n = len(V)
    P = np.asarray(points, dtype=np.float64) if not isinstance(points, np.ndarray) else points
    vals, squeeze = as_values(vals, len(P) if P.ndim >= 1 else 0, what="vals")
    loc = locate_points(V, F, P, max_distance=max_distance) if located is None else located
    # the partition methods' samples follow the duplicates rule; for the others they only mark the points
    rule = duplicates if nearest_only else "mean"
    nearest, nearest_vals, _ = as_samples(loc.nearest_vertex, vals, n, duplicates=rule)
    empty = sp.csr_array((0, n))
    if nearest_only:
        return PointSamples(loc, np.zeros(0, np.int64), np.zeros((0, vals.shape[1])), empty,
                            np.zeros((0, vals.shape[1])), np.full(len(P), -1), nearest, nearest_vals, squeeze)
    group, gvals = _merge_locations(loc.points, vals, V, duplicates)
    rep = np.zeros(group.max() + 1, dtype=np.int64)
    rep[group[::-1]] = np.arange(len(group))[::-1]  # the first point of each group stands for it
    at_vertex = loc.vertex[rep] >= 0
    # points at vertices: vertex constraints (several groups at one vertex: the duplicates rule)
    vg = np.flatnonzero(at_vertex)
    if vg.size:
        idx, ivals, _ = as_samples(loc.vertex[rep[vg]], gvals[vg], n, duplicates=duplicates)
    else:
        idx, ivals = np.zeros(0, np.int64), np.zeros((0, vals.shape[1]))
    rg = np.flatnonzero(~at_vertex)
    Aeq = loc.rows(n, rep[rg])
    beq = gvals[rg]
    where = np.empty(len(rep), dtype=np.int64)
    where[vg] = np.searchsorted(idx, loc.vertex[rep[vg]])
    where[rg] = idx.size + np.arange(rg.size)
    _check_rows(Aeq, idx, rep[rg])
    return PointSamples(loc, idx, ivals, Aeq, beq, where[group], nearest, nearest_vals, squeeze)


def _merge_locations(Q, vals, V, duplicates):
    """Group points closer than ``TOL.weld * size``: (group of each point, values per group)."""
    sc = unit_scale(V)
    tree = cKDTree(Q / sc)
    size = float(np.sqrt(((V.max(axis=0) / sc - V.min(axis=0) / sc) ** 2).sum())) or 1.0
    pairs = tree.query_pairs(TOL.weld * size, output_type="ndarray")
    k = len(Q)
    if pairs.size == 0:
        return np.arange(k), vals
    G = sp.coo_array((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(k, k))
    _, group = connected_components(G, directed=False)
    # renumber groups by their first point, so that groups keep the points' order
    first = np.full(group.max() + 1, k)
    np.minimum.at(first, group, np.arange(k))
    group = np.argsort(np.argsort(first))[group]
    counts = np.bincount(group)
    sums = np.zeros((counts.size, vals.shape[1]))
    np.add.at(sums, group, vals)
    mean = sums / counts[:, None]
    spread = np.abs(vals - mean[group]).max(axis=1)
    conflict = spread > TOL.sample_conflict * float(np.abs(vals).max())
    if conflict.any() and duplicates == "error":
        rows = np.flatnonzero(group == group[np.flatnonzero(conflict)[0]])
        shown = ", ".join(f"{vals[r, 0]:g}" for r in rows[:4])
        raise SampleError(
            f"{np.unique(group[conflict]).size} locations get two different values (rows {first_entries(rows)} "
            f"= {shown}, at one surface point); remove the conflicting samples, or average them "
            f"(duplicates='mean', CLI: --duplicates mean)"
        )
    return group, mean


def _check_rows(Aeq, idx, points):
    """Refuse rows that are dependent on the free vertices (the KKT system would be singular)."""
    m, n = Aeq.shape
    if m == 0:
        return
    free = np.ones(n, dtype=bool)
    free[idx] = False
    R = Aeq[:, np.flatnonzero(free)].tocsr()
    R.eliminate_zeros()
    none = np.flatnonzero(np.diff(R.indptr) == 0)
    if none.size:
        raise SampleError(
            f"{none.size} sample points lie on an edge or face whose vertices are all samples (input rows "
            f"{first_entries(points[none])}), so their values are already fixed; remove those points or those "
            f"vertex samples")
    # blocks of rows coupled through shared free vertices
    N = R.shape[1]
    B = sp.bmat([[None, R], [R.T, None]]).tocsr()
    _, lab = connected_components(B, directed=False)
    rlab, clab = lab[:m], lab[m:]
    nrows = np.bincount(rlab, minlength=lab.max() + 1)
    ncols = np.bincount(clab, minlength=lab.max() + 1) if N else np.zeros_like(nrows)
    # a lone row with a free vertex (all have one, above) has rank one: only blocks of several rows are checked
    for b in np.flatnonzero(nrows > 1):
        rows = np.flatnonzero(rlab == b)
        bad = nrows[b] > ncols[b]
        if not bad and rows.size <= RANK_BLOCK:
            block = R[rows][:, np.flatnonzero(clab == b)].toarray()
            s = np.linalg.svd(block, compute_uv=False)
            bad = s[-1] <= TOL.point_rank * s[0]
        if bad:
            raise SampleError(
                f"{rows.size} sample points inside faces constrain {int(ncols[b])} vertices and are not independent "
                f"(input rows {first_entries(points[rows])}: more than three in one triangle, three on one edge, or "
                f"in line with sample vertices); remove some of them, or give them as vertex samples")


def eliminate_rows(Aeq, beq, idx, n):
    """Every ``x`` with ``Aeq x = beq`` as ``x = T z + t``: one free pivot vertex solved for per row.

    The rows are split into blocks coupled through shared vertices; in each, a QR with
    column pivoting picks as many well-conditioned pivots among the free vertices (not in
    ``idx``) as it has rows, and ``x_P = C_P^-1 (beq - C_N x_N)``. The reduced energy
    ``T' A T`` is then symmetric positive definite like ``A``, so CG and AMG apply.

    Parameters
    ----------
    Aeq : (m, n) scipy sparse matrix
        Independent rows on the free vertices (as :func:`point_samples` checks them).
    beq : (m, p) numpy array
        Their values.
    idx : (a,) int64 numpy array
        Vertices with fixed values (never pivots).
    n : int
        Number of vertices.

    Returns
    -------
    T : (n, n - m) scipy.sparse.csr_array
        The identity on the kept vertices, ``-C_P^-1 C_N`` on the pivots.
    t : (n, p) numpy array
        ``C_P^-1 beq`` on the pivots, 0 elsewhere.
    kept : (n - m,) int64 numpy array
        The vertices ``z`` stands for (``z = x[kept]``).

    Raises
    ------
    OptionError
        A block of more than ``RANK_BLOCK`` coupled rows (too dense for the elimination).

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> T, t, kept = eliminate_rows(sp.csr_array([[0.25, 0.75, 0.0]]), np.array([[1.0]]), np.array([2]), 3)
    >>> kept.tolist(), (T @ np.array([[4.0], [5.0]]) + t).ravel().tolist()
    ([0, 2], [4.0, 0.0, 5.0])
    """
    Aeq = sp.csr_array(Aeq)
    m = Aeq.shape[0]
    free = np.ones(n, dtype=bool)
    free[idx] = False
    _, lab = connected_components(sp.bmat([[None, Aeq], [Aeq.T, None]]).tocsr(), directed=False)
    rlab = lab[:m]
    order = np.argsort(rlab, kind="stable")
    starts = np.flatnonzero(np.r_[True, rlab[order][1:] != rlab[order][:-1]])
    pivots = np.empty(m, dtype=np.int64)
    t = np.zeros((n, beq.shape[1]))
    ti, tj, tv = [], [], []
    for a, b in zip(starts, np.r_[starts[1:], m]):
        rows = order[a:b]
        if rows.size > RANK_BLOCK:
            raise OptionError(f"{rows.size} sample points inside faces are coupled through shared vertices, too many "
                              f"to eliminate for an iterative solver; pass solver='direct'")
        sub = Aeq[rows]
        cols = np.unique(sub.indices)
        D = sub[:, cols].toarray()
        fc = np.flatnonzero(free[cols])
        piv = fc[sl.qr(D[:, fc], pivoting=True, mode="r")[1][:rows.size]]
        other = np.setdiff1d(np.arange(cols.size), piv)
        inv = np.linalg.inv(D[:, piv])
        t[cols[piv]] = inv @ beq[rows]
        ti.append(np.repeat(cols[piv], other.size))
        tj.append(np.tile(cols[other], piv.size))
        tv.append((-inv @ D[:, other]).ravel())
        pivots[a:b] = cols[piv]
    keep = np.ones(n, dtype=bool)
    keep[pivots] = False
    kept = np.flatnonzero(keep)
    pos = np.full(n, -1, dtype=np.int64)
    pos[kept] = np.arange(kept.size)
    ti, tj = np.concatenate(ti + [kept]), np.concatenate(tj + [kept])
    T = sp.csr_array((np.concatenate(tv + [np.ones(kept.size)]), (ti, pos[tj])), shape=(n, kept.size))
    return T, t, kept
