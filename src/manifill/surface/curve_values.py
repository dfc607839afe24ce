"""Step 4 of the paper: a value at every curve vertex, from the samples on the curves.

The curve network of :mod:`manifill.surface.partition` is a graph of its own (consecutive
path vertices are joined). Two ways to fill it:

``gvf``
    Gradually varied fitting on the curve graph (the paper's choice): levels
    change by at most one per curve edge. The samples satisfy the condition on
    the curves whenever they do on the mesh, since curve distances are never
    shorter than mesh distances.
``linear``
    Linear in arc length between consecutive samples along each path: the
    one-dimensional harmonic function on the curve graph with edge weights
    ``1 / length``. Where paths meet away from a sample, the junction takes the
    weighted average of its neighbours, so the values agree at junctions. Never
    leaves the range of the samples.
``hermite``
    Cubic in arc length along each path, matching the samples' values at both
    ends and slopes taken from a gradient estimated at every sample
    (:func:`manifill.surface.slopes.sample_gradients`: a weighted least-squares
    fit, in its tangent plane, to the samples within two steps of it in the
    curve network whose normals are within 45 degrees of its own). Where an end
    has fewer than two such neighbours the path gets the secant slope, and on a
    path that wanders (arc length far beyond the distance between its ends, as
    the ``cycle`` partition's detours) the slopes blend towards the secant by
    :func:`straightness_weight`. Every step depends on the positions only, so
    the values are **linear in the data** (an interpolation matrix exists).
    Exact for linear fields along straight paths on flat meshes; much closer
    than ``linear`` on smooth fields, but a cubic can overshoot the samples'
    range. Vertices shared by several paths take the mean of their values.
``monotone``
    ``hermite``'s slopes limited per path by Fritsch and Carlson's condition
    relative to the path's secant: a monotone cubic, so every value lies
    between the values at its path's two ends (the mean of such values where
    paths share a vertex) and never outside the samples' range. Equal to
    ``hermite`` where the limiter does not bind (linear fields on straight
    paths); **not linear** in the data (the limiter looks at the values).
"""

from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.sparse as sp

from .gradual import GradualCheck, gvf
from .partition import Partition
from .slopes import sample_gradients
from ..linalg.backends import make_linear_solver
from ..tolerances import TOL
from ..validate import scale_of, check_option, unit_scale
from .surface import Surface

__all__ = ["CURVE_VALUES", "CurveValues", "values_on_curves", "curve_graph", "curve_values", "vertex_normals",
           "straightness_weight"]

CURVE_VALUES = ("hermite", "monotone", "linear", "gvf")


def curve_graph(V, edges, n, *, distance="length"):
    """The curve network as a weighted graph on all ``n`` vertices.

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions.
    edges : (e, 2) numpy array of int
        Unique curve edges (:meth:`manifill.surface.partition.Partition.curve_edges`).
    n : int
        Number of mesh vertices.
    distance : {'length', 'hops'}, optional
        Edge length: Euclidean, or 1.

    Returns
    -------
    (n, n) scipy.sparse.csr_array
        Symmetric edge lengths; vertices off the curves have no edges.
    """
    i, j = edges[:, 0], edges[:, 1]
    if distance == "hops":
        w = np.ones(len(edges))
    else:
        D = V[i] - V[j]
        sc = unit_scale(D)  # a power of two: the squares in the norm neither overflow nor underflow
        w = np.maximum(np.linalg.norm(D if sc == 1.0 else D * (1.0 / sc), axis=1), TOL.tiny) * sc
    return sp.csr_array((np.concatenate([w, w]), (np.concatenate([i, j]), np.concatenate([j, i]))), shape=(n, n))


def vertex_normals(V, F, where=None):
    """Area-weighted unit vertex normals.

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions.
    F : (m, 3) numpy array of int
        Triangles.
    where : (k,) numpy array of int, optional
        Only these vertices need normals (the others are left zero); only the
        faces around them are visited.

    Returns
    -------
    (n, 3) numpy array
        Unit normals (zero where undefined), computed on positions of about unit
        size (see :func:`manifill.validate.unit_scale`), so at any scale.
    """
    return _vertex_normals(V, F, where, unit_scale(V))


def _vertex_normals(V, F, where, sc):
    """:func:`vertex_normals` of the positions ``V / sc`` (``sc`` a power of two)."""
    n = len(V)
    need = np.ones(n, dtype=bool)
    if where is not None:
        need = np.zeros(n, dtype=bool)
        need[where] = True
        F = F[need[F].any(axis=1)]
    d1, d2 = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    if sc != 1.0:
        d1 *= 1.0 / sc
        d2 *= 1.0 / sc
    N = np.cross(d1, d2)
    corners = F.ravel()
    # the sums at the needed vertices only, over their faces in order
    at = need[corners]
    u = np.flatnonzero(need)
    pos = np.zeros(n, dtype=np.int64)
    pos[u] = np.arange(u.size)
    c = pos[corners[at]]
    sums = np.column_stack([np.bincount(c, weights=np.repeat(N[:, j], 3)[at], minlength=u.size) for j in range(3)])
    norm = np.linalg.norm(sums, axis=1, keepdims=True)
    out = np.zeros((n, 3))
    out[u] = np.divide(sums, norm, out=np.zeros_like(sums), where=norm > 0)
    return out


#: Where a path wanders (its arc length ``L`` well beyond the straight distance ``c``
#: between its ends), the end slopes are blended towards the secant: weight
#: ``w(c / L)`` on the gradient's slope, 1 for ``c / L >= STRAIGHT_FULL``, 0 for
#: ``c / L <= STRAIGHT_NONE``, a smoothstep in between. A property of the path alone,
#: so the values stay linear in the data. Measured (smooth field, 40,962-vertex sphere,
#: k = 100): ``cycle`` curve-value overshoot 0.40 -> 0.00 of the range, ``delaunay``
#: unchanged (its paths have ``c / L`` above 0.5).
STRAIGHT_FULL, STRAIGHT_NONE = 0.5, 0.25


def straightness_weight(chord, length):
    """Weight of the gradients' end slopes on a path of arc length ``length`` between ends ``chord`` apart.

    Parameters
    ----------
    chord, length : (c,) numpy arrays
        Straight distance between each path's ends and its arc length (positive).

    Returns
    -------
    (c,) numpy array
        In ``[0, 1]``: 1 on paths with ``chord / length >= STRAIGHT_FULL`` (every
        shortest path on a smooth surface up to a half turn of a sphere, zig-zag
        along mesh edges included), 0 at or below
        ``STRAIGHT_NONE``, a smoothstep in between.

    Examples
    --------
    >>> straightness_weight(np.array([1.0, 0.375, 0.2]), np.ones(3)).tolist()
    [1.0, 0.5, 0.0]
    """
    t = np.clip((chord / length - STRAIGHT_NONE) / (STRAIGHT_FULL - STRAIGHT_NONE), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _sample_position(idx, v):
    """Position of each vertex ``v`` in the sorted ``idx``, ``-1`` where it is not a sample."""
    pos = np.minimum(np.searchsorted(idx, v), len(idx) - 1)
    return np.where(idx[pos] == v, pos, -1)


def _fritsch_carlson(ma, mb, secant):
    """End slopes limited so that the cubic is monotone between its ends (Fritsch and Carlson, 1980).

    Relative to the secant ``d``: slopes against it become 0, and the pair
    ``(ma / d, mb / d)`` is scaled into the disc of radius 3 (a sufficient
    condition for a monotone cubic); on a flat secant both are 0.
    """
    flat = secant == 0
    d = np.where(flat, 1.0, secant)
    alpha, beta = np.maximum(ma / d, 0.0), np.maximum(mb / d, 0.0)
    r = np.hypot(alpha, beta)
    scale = np.where(r > 3.0, 3.0 / np.where(r > 3.0, r, 1.0), 1.0)
    alpha, beta = alpha * scale, beta * scale
    return np.where(flat, 0.0, alpha * d), np.where(flat, 0.0, beta * d)


def _hermite(V, F, curves, ends, idx, vals, normals=None, monotone=False):
    """Cubic Hermite values along every curve, all curves at once on the concatenated paths."""
    n, p = len(V), vals.shape[1]
    total, count = np.zeros((n, p)), np.zeros(n)
    if not curves:
        return total, count
    sc = unit_scale(V)
    if sc != 1.0:
        # lengths, offsets and gradients in units of sc (a power of two): the values, slopes
        # times lengths, are the same, and the quadratic fits are as well conditioned as at unit size
        V = V * (1.0 / sc)
    if normals is None:
        normals = _vertex_normals(V, F, idx, 1.0)
    grads, known = sample_gradients(V, normals, ends, idx, vals)
    lens = np.array([len(c) for c in curves])
    first = np.concatenate([[0], np.cumsum(lens)[:-1]])
    last = first + lens - 1
    flat = np.concatenate(curves)
    cid = np.repeat(np.arange(len(curves)), lens)
    # arc length from the start of each curve
    seg = np.zeros(flat.size)
    step = np.diff(V[flat], axis=0)
    seg[1:] = np.sqrt(step[:, 0] ** 2 + step[:, 1] ** 2 + step[:, 2] ** 2)
    seg[first] = 0.0
    s = np.cumsum(seg)
    s -= s[first][cid]
    ell = s[last]
    a, b = _sample_position(idx, flat[first]), _sample_position(idx, flat[last])
    ok = (a >= 0) & (b >= 0) & (ell > 0)
    a, b, ell_ok = a[ok], b[ok], ell[ok]

    def start_direction(start, through):
        """Unit tangent at ``flat[start]`` towards ``flat[through]``, in the tangent plane."""
        nrm = normals[flat[start]]
        d = V[flat[through]] - V[flat[start]]
        d -= np.einsum("ij,ij->i", d, nrm)[:, None] * nrm
        nd = np.linalg.norm(d, axis=1, keepdims=True)
        return np.divide(d, nd, out=np.zeros_like(d), where=nd > 0)

    # the vertex a third of the way along, from either end (at least one step in)
    # (a vertex at a third, common on regular meshes, counts as short of it: rounding, which differs with the
    # mesh's units, must not decide which vertex gives the end's direction)
    third = ell[cid] * (1.0 / 3.0 - TOL.tie_rtol)
    ja = np.clip(np.bincount(cid, weights=s < third, minlength=len(curves)).astype(np.int64), 1, lens - 1)
    jb = np.clip(np.bincount(cid, weights=(ell[cid] - s) < third, minlength=len(curves)).astype(np.int64),
                 1, lens - 1)
    ta = start_direction(first[ok], (first + ja)[ok])
    tb = start_direction(last[ok], (last - jb)[ok])
    secant = (vals[b] - vals[a]) / ell_ok[:, None]
    # slope leaving a and arriving at b, per unit arc length: the gradient's along the
    # path's end directions, blended towards the secant (a straight line in arc length)
    # on wandering paths, the secant alone where an end has too few usable neighbours
    chord = np.linalg.norm(V[flat[last[ok]]] - V[flat[first[ok]]], axis=1)
    w = straightness_weight(chord, ell_ok)
    wa, wb = (np.where(known[e], w, 0.0)[:, None] for e in (a, b))
    ma = wa * np.einsum("ij,ijp->ip", ta, grads[a]) + (1.0 - wa) * secant
    mb = -wb * np.einsum("ij,ijp->ip", tb, grads[b]) + (1.0 - wb) * secant
    if monotone:
        ma, mb = _fritsch_carlson(ma, mb, secant)
    # interior vertices of the usable curves
    c_of = np.full(len(curves), -1)
    c_of[ok] = np.arange(int(ok.sum()))
    inner = np.ones(flat.size, dtype=bool)
    inner[first] = inner[last] = False
    inner &= ok[cid]
    c = c_of[cid[inner]]
    t = (s[inner] / ell[cid[inner]])[:, None]
    h00, h10 = 2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t
    h01, h11 = -2 * t**3 + 3 * t**2, t**3 - t**2
    L = ell_ok[c][:, None]
    ya, yb = vals[a[c]], vals[b[c]]
    vals_path = h00 * ya + h10 * L * ma[c] + h01 * yb + h11 * L * mb[c]
    if monotone:
        # monotone in exact arithmetic: keep rounding from leaving the ends' interval
        vals_path = np.clip(vals_path, np.minimum(ya, yb), np.maximum(ya, yb))
    v = flat[inner]
    for j in range(p):
        total[:, j] = np.bincount(v, weights=vals_path[:, j], minlength=n)
    count[:] = np.bincount(v, minlength=n)
    return total, count


def curve_values(V, edges, idx, vals, *, method="linear", levels=None, level=None, F=None, curves=None,
                 ends=None, normals=None):
    """Values at every curve vertex, equal to the samples at the samples.

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions.
    edges : (e, 2) numpy array of int
        Unique curve edges.
    idx : (k,) numpy array of int
        Sample vertices (all on the curves).
    vals : (k,) or (k, p) numpy array of float
        Sample values (for ``gvf``: one column; the samples keep them, every
        other curve vertex gets a level).
    method : {'linear', 'hermite', 'monotone', 'gvf'}, optional
        See the module docstring.
    levels : (m,) numpy array, optional
        The value levels (``gvf``; from :func:`manifill.surface.gradual.check_gradual`).
    level : (k,) numpy array of int, optional
        Level index of every sample (``gvf``).
    F : (m, 3) numpy array of int, optional
        Triangles, for the normals (``hermite``).
    normals : (n, 3) numpy array, optional
        Unit normals at the samples (``hermite``, ``monotone``), instead of ``F`` (e.g. on a
        digital surface, which has no triangles).
    curves : list of (l,) numpy arrays, optional
        The ordered paths between samples (``hermite``).
    ends : (c, 2) numpy array of int, optional
        The samples at the ends of each path (``hermite``).

    Returns
    -------
    cv : (c,) int64 numpy array
        The curve vertices (sorted).
    values : (c,) or (c, p) numpy array
        Their values.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [3, 0, 0], [4, 0, 0]])
    >>> cv, x = curve_values(V, np.array([[0, 1], [1, 2], [2, 3]]), np.array([0, 3]), np.array([0.0, 8.0]))
    >>> cv.tolist(), x.tolist()
    ([0, 1, 2, 3], [0.0, 2.0, 6.0, 8.0])
    """
    check_option("curve_values", method, CURVE_VALUES)
    n = len(V)
    idx = np.asarray(idx, dtype=np.int64)
    on = np.zeros(n, dtype=bool)
    on[edges.ravel()] = True
    on[idx] = True
    cv = np.flatnonzero(on)
    if method == "gvf":
        G = curve_graph(V, edges, n, distance="hops")
        fit = gvf(G, idx, level)
        out = np.asarray(levels)[fit[cv]]
        out[np.searchsorted(cv, idx)] = vals if vals is not None else out[np.searchsorted(cv, idx)]
        return cv, out
    vals = np.asarray(vals, dtype=np.float64)
    squeeze = vals.ndim == 1
    vals2 = vals[:, None] if squeeze else vals
    if method in ("hermite", "monotone"):
        total, count = _hermite(V, F, curves, ends, idx, vals2, normals, monotone=method == "monotone")
        total[idx] = vals2
        count[idx] = 1
        lone = cv[count[cv] == 0]
        if lone.size:  # a curve vertex on no sample-to-sample path: fall back to linear
            _, lin = curve_values(V, edges, idx, vals2, method="linear")
            total[lone] = lin[np.searchsorted(cv, lone)]
            count[lone] = 1
        out = total[cv] / count[cv][:, None]
        return cv, out[:, 0] if squeeze else out
    G = curve_graph(V, edges, n)[cv][:, cv]
    W = G.copy()
    # weights 1 / length in units of a power of two near the longest edge: the same
    # solution, and no overflow of the weights of a tiny mesh
    W.data = (scale_of(float(W.data.max())) if W.nnz else 1.0) / W.data
    L = (sp.diags_array(np.asarray(W.sum(axis=1)).ravel()) - W).tocsr()
    pos = np.searchsorted(cv, idx)
    free = np.ones(cv.size, dtype=bool)
    free[pos] = False
    out = np.empty((cv.size, vals2.shape[1]))
    out[pos] = vals2
    if free.any():
        fi = np.flatnonzero(free)
        # every curve component holds a sample, so the reduced system is definite
        solver = make_linear_solver(L[fi][:, fi], "direct")
        out[fi] = solver.solve(-(L[fi][:, pos] @ vals2))[0]
    return cv, out[:, 0] if squeeze else out


@dataclass
class CurveValues:
    """The result of Step 4 (:func:`values_on_curves`): fixed values for the harmonic fill.

    Unpacks as ``idx, vals = cv``.

    Attributes
    ----------
    idx : (c,) int64 numpy array
        The curve vertices, sorted (every sample among them).
    vals : (c, p) numpy array
        Their values, one column per field; the samples' own at the samples.
    method : str
        How they were drawn (one of :data:`CURVE_VALUES`).
    """

    idx: np.ndarray
    vals: np.ndarray
    method: str

    def __iter__(self):
        return iter((self.idx, self.vals))


def values_on_curves(surface: Surface, part: Partition, idx: np.ndarray, vals: np.ndarray, *,
                     method: Literal["hermite", "monotone", "linear", "gvf"] = "hermite",
                     checks: list[GradualCheck] | None = None) -> CurveValues:
    """Step 4 on a partition: a value at every vertex of its curves, all fields at once.

    Parameters
    ----------
    surface : Surface
        The surface (:class:`manifill.surface.surface.Surface`): ``V``, and ``F``
        or ``normals`` for ``hermite``.
    part : Partition
        Steps 2-3 (:func:`manifill.surface.partition.partition`) through ``idx``.
    idx : (k,) int64 numpy array
        Sample vertices, sorted and unique.
    vals : (k, p) numpy array
        Sample values, one column per field.
    method : {'hermite', 'monotone', 'linear', 'gvf'}, optional
        See the module docstring.
    checks : list of p GradualCheck, optional
        Step 1 per field (:func:`manifill.surface.gradual.check_gradual`); ``gvf``
        needs them for the levels.

    Returns
    -------
    CurveValues

    Raises
    ------
    SampleError
        ``gvf`` with samples that break the gradual variation condition.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> from manifill.surface.partition import partition
    >>> from manifill.surface.surface import Surface
    >>> V, F = icosphere(2)
    >>> s, idx = Surface.from_mesh(V, F), np.array([0, 10, 50, 90, 120])
    >>> cv = values_on_curves(s, partition(s, idx), idx, V[idx, :1])
    >>> bool(np.isin(idx, cv.idx).all()), cv.vals.shape[1]
    (True, 1)
    """
    check_option("curve_values", method, CURVE_VALUES)
    if method == "gvf":
        cols = [curve_values(surface.V, part.curve_edges(), idx, vals[:, j], method="gvf",
                             levels=c.levels, level=c.level)
                for j, c in enumerate(checks)]  # type: ignore[arg-type]  # gvf is given its checks
        return CurveValues(cols[0][0], np.column_stack([cv for _, cv in cols]), method)
    b, bc = curve_values(surface.V, part.curve_edges(), idx, vals, method=method, F=surface.F,
                         curves=part.curves, ends=part.ends, normals=surface.normals)
    return CurveValues(b, bc, method)
