"""Samples: measured values at vertices, or at positions snapped to the nearest vertex."""

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from ..errors import SampleError
from ..results import field_names
from ..tolerances import TOL
from ..validate import first_entries, as_samples, as_values, bbox_diagonal, unit_scale

__all__ = ["Samples", "snap_to_vertices", "sample_positions", "distance_limit", "refuse_far", "position_span",
           "field_names"]


@dataclass
class Samples:
    """Samples ready for a mesh: unique vertex indices and their values.

    Attributes
    ----------
    idx : (k,) int64 numpy array
        Sorted unique vertex indices.
    vals : (k, p) float64 numpy array
        Values, one column per field.
    names : list of str
        The ``p`` field names.
    snap_distance : (k,) numpy array or None
        For samples given as positions, the distance from each position to the
        vertex it was snapped to (the largest one where several samples met at
        a vertex); ``None`` for samples given as vertex indices.
    merged : int
        How many input rows were merged into another sample on the same vertex.
    points : (k, 3) numpy array or None
        With ``keep_points``: the positions as given, one per input row (for
        the energy methods, which constrain the field exactly there,
        :func:`manifill.reconstruct`); ``None`` otherwise.
    point_vals : (k, p) numpy array or None
        Their values, one row per position.
    """

    idx: np.ndarray
    vals: np.ndarray
    names: list = field(default_factory=list)
    snap_distance: np.ndarray | None = None
    merged: int = 0
    points: np.ndarray | None = None
    point_vals: np.ndarray | None = None

    @classmethod
    def from_indices(cls, idx, vals, n, *, names=None, duplicates="error"):
        """Validate vertex-indexed samples (see :func:`manifill.validate.as_samples`).

        Parameters
        ----------
        idx : (k,) array_like of int
            Vertex of each sample.
        vals : (k,) or (k, p) array_like of float
            Values.
        n : int
            Number of vertices of the mesh.
        names : list of str, optional
            Field names; ``value``, ``value2``, ... by default.
        duplicates : {'error', 'mean'}, optional
            Conflicting values on one vertex: raise, or average.

        Returns
        -------
        Samples
        """
        k = len(np.asarray(idx).ravel())
        uidx, uvals, _ = as_samples(idx, vals, n, duplicates=duplicates)
        return cls(uidx, uvals, field_names(names, uvals.shape[1]), None, k - uidx.size)

    @classmethod
    def from_points(cls, V, points, vals, *, names=None, duplicates="error", max_distance=None, keep_points=False):
        """Snap sample positions to their nearest vertices, then validate.

        Parameters
        ----------
        V : (n, 3) numpy array
            Vertex positions of the mesh.
        points : (k, 3) array_like
            Sample positions.
        vals : (k,) or (k, p) array_like of float
            Values.
        names : list of str, optional
            Field names.
        duplicates : {'error', 'mean'}, optional
            Several samples snapped onto one vertex with different values:
            raise, or average.
        max_distance : float, optional
            Largest accepted snap distance, in the mesh's units (default: see
            :func:`snap_to_vertices`).
        keep_points : bool, optional
            Keep the positions and their values (:attr:`points`, :attr:`point_vals`)
            for a reconstruction that locates them on the surface itself: no
            distance is refused here (the surface's is checked there) and several
            samples nearest one vertex are averaged into ``idx``, ``vals``
            (which then only mark where the samples are).

        Returns
        -------
        Samples

        Raises
        ------
        SampleError
            A sample farther than ``max_distance`` from the mesh (the message
            gives the ratio to the mesh size and asks "wrong units?"), or
            conflicting values on one vertex.
        """
        idx, dist = snap_to_vertices(V, points, max_distance=np.inf if keep_points else max_distance)
        k = idx.size
        uidx, uvals, _ = as_samples(idx, vals, len(V), duplicates="mean" if keep_points else duplicates)
        worst = np.zeros(len(V))
        np.maximum.at(worst, idx, dist)
        S = cls(uidx, uvals, field_names(names, uvals.shape[1]), worst[uidx], k - uidx.size)
        if keep_points:
            S.points = sample_positions(np.asarray(V, dtype=np.float64), points)
            S.point_vals = as_values(vals, k)[0]
        return S


def snap_to_vertices(V, points, *, max_distance=None):
    """Nearest vertex of every point, with the distance (KD-tree).

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions.
    points : (k, 3) array_like
        Query positions (``(k, 2)`` for a flat mesh).
    max_distance : float, optional
        Largest accepted distance; by default ``TOL.snap`` times the
        bounding-box diagonal of ``V`` plus the largest distance from a vertex
        to its nearest other vertex (so that a sample anywhere on a coarse
        triangle is accepted).

    Returns
    -------
    idx : (k,) int64 numpy array
        Nearest vertex of each point.
    dist : (k,) numpy array
        Distance to it.

    Raises
    ------
    SampleError
        Malformed or non-finite positions, or a point farther than
        ``max_distance``: the message gives the distance as a multiple of the
        mesh size and suggests checking the units.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> idx, dist = snap_to_vertices(V, [[0.9, 0.05, 0]])
    >>> idx.tolist(), round(float(dist[0]), 4)
    ([1], 0.1118)
    >>> snap_to_vertices(V, [[900, 50, 0]])
    Traceback (most recent call last):
    ...
    manifill.errors.SampleError: 1 samples lie far from the mesh (row 0: 900 from the nearest vertex, ...
    """
    V = np.asarray(V, dtype=np.float64)
    P = sample_positions(V, points)
    diag = bbox_diagonal(V)
    # the KD-tree compares squared distances: query in units of a power of two near the
    # mesh's size (exact), so that they neither overflow nor underflow, and scale back
    sc = unit_scale(V)
    inv = 1.0 / sc
    tree = cKDTree(V if sc == 1.0 else V * inv)
    limit = distance_limit(tree, sc, diag, max_distance)
    with np.errstate(over="ignore"):
        Ps = P if sc == 1.0 else P * inv
    # positions so far out (in the mesh's units) that their squared distances would overflow:
    # far from every vertex, measured apart below
    out = ~(np.abs(Ps) < 2.0**500).all(axis=1)
    if out.any():
        Ps = Ps.copy()
        Ps[out] = tree.data[0]
    dist, idx = tree.query(Ps)
    if sc != 1.0:
        dist = dist * sc
    if out.any():
        d = P[out] - V[0]
        m = np.abs(d).max(axis=1, keepdims=True)
        dist[out] = m[:, 0] * np.linalg.norm(d / m, axis=1)
    refuse_far(dist, limit, diag, "the nearest vertex", span=position_span(P))
    return idx.astype(np.int64), dist


def position_span(P):
    """The positions' bounding-box diagonal (inf if it overflows)."""
    with np.errstate(all="ignore"):
        return float(np.linalg.norm(np.nanmax(P, axis=0) - np.nanmin(P, axis=0))) if len(P) > 1 else None


def sample_positions(V, points):
    """Validate sample positions for a mesh: ``(k, 3)`` finite floats (``(k, 2)`` get ``z = 0``).

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions.
    points : (k, 3) or (k, 2) array_like
        Positions.

    Returns
    -------
    (k, 3) float64 numpy array

    Raises
    ------
    SampleError
        Not numbers, a wrong shape, no rows, NaN or infinite coordinates.
    """
    try:
        P = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise SampleError("sample positions could not be read as numbers; pass a (k, 3) float array") from None
    if P.ndim == 2 and P.shape[1] == 2 and V.shape[1] == 3:
        P = np.column_stack([P, np.zeros(len(P))])
    if P.ndim != 2 or P.shape[1] != V.shape[1] or P.shape[0] == 0:
        raise SampleError(f"sample positions have shape {P.shape}; pass a (k, 3) array with at least one row")
    bad = ~np.isfinite(P).all(axis=1)
    if bad.any():
        rows = first_entries(np.flatnonzero(bad))
        raise SampleError(f"sample positions have NaN or infinite coordinates in rows {rows}")
    return P


def distance_limit(tree, sc, diag, max_distance=None):
    """The largest accepted distance from a sample position to the mesh.

    Parameters
    ----------
    tree : scipy.spatial.cKDTree
        The vertices, divided by ``sc``.
    sc : float
        Their unit scale (:func:`manifill.validate.unit_scale`).
    diag : float
        The mesh's bounding-box diagonal.
    max_distance : float, optional
        The caller's limit; by default ``TOL.snap * diag`` plus the largest
        distance from a vertex to its nearest other vertex (so that a sample
        anywhere on a coarse triangle is accepted).

    Returns
    -------
    float

    Raises
    ------
    SampleError
        ``max_distance`` negative or NaN.
    """
    if max_distance is None:
        # a sample anywhere on a coarse triangle may be an edge length from its vertex
        spacing = float(tree.query(tree.data, k=2)[0][:, 1].max()) * sc if tree.n > 1 else 0.0
        return TOL.snap * diag + spacing
    limit = float(max_distance)
    if not limit >= 0:
        raise SampleError(f"max_distance={max_distance!r} must be a distance >= 0 (inf for no limit)")
    return limit


def refuse_far(dist, limit, diag, what, *, lead="{n} samples lie far from the mesh", row="row",
               fix="Rescale the positions or the mesh, or raise the limit (max_distance, CLI: --max-distance)",
               error=SampleError, span=None):
    """Raise if a distance exceeds ``limit``: one line with the worst row, its ratio to the mesh and "wrong units?"
    (with ``span``, the positions' own size, the factor between the two: millimetres on a metre mesh say 0.001).

    Parameters
    ----------
    dist : (k,) numpy array
        Distance of each sample to ``what``.
    limit, diag : float
        The accepted distance, the mesh's size.
    what : str
        What the distance is measured to (``"the nearest vertex"``, ``"the surface"``).
    lead, row, fix : str, optional
        The message's opening (``{n}``: how many are far), what a position is called, and the fix: a barrier's
        positions say theirs.
    error : type, optional
        The exception raised.
    span : float, optional
        The positions' bounding-box diagonal: when it is a power of ten or more away from the mesh's, the message
        gives that factor.

    Raises
    ------
    SampleError
        (or ``error``)
    """
    far = np.flatnonzero(~(dist <= limit))
    if far.size:
        i = int(far[np.argmax(dist[far])])
        with np.errstate(over="ignore"):
            ratio = dist[i] / diag
        raise error(
            f"{lead.format(n=far.size)} ({row} {i}: {dist[i]:.3g} from {what}, "
            f"{ratio:.3g} x the mesh's size {diag:.3g}; accepted: {limit:.3g}); wrong units?{_units(span, diag)} {fix}"
        )


def _units(span, diag):
    """`` the positions span about 1000 x the mesh's size: scale them by 0.001 (e.g. mm to m)`` or ``""``."""
    with np.errstate(all="ignore"):
        r = None if span is None or not diag else float(span) / float(diag)
    if r is None or not np.isfinite(r) or r <= 0:
        return ""
    k = int(np.round(np.log10(r)))
    if abs(k) < 1 or abs(np.log10(r) - k) > 0.3:  # not near a power of ten
        return ""
    names = {3: " (e.g. mm to m)", 2: " (e.g. cm to m)", 1: " (e.g. mm to cm)", -3: " (e.g. m to mm)",
             -2: " (e.g. m to cm)", -1: " (e.g. cm to mm)"}
    return f" The positions span about {10.0 ** k:g} x the mesh's size: scale them by {10.0 ** -k:g}{names.get(k, '')}."


def weights_by_vertex(idx, w, vertices):
    """Per-row sample weights carried to the sorted unique sample vertices (rows on one vertex add up).

    Parameters
    ----------
    idx : (k,) array_like of int
        The caller's sample vertices, in the caller's order (validated).
    w : (k,) array_like of float
        One weight per row.
    vertices : (u,) int64 numpy array
        The sorted unique vertices (``manifill.validate.as_samples``'s ``idx``).

    Returns
    -------
    (u,) float64 numpy array

    Raises
    ------
    SampleError
        ``w`` is not one number per row.

    Examples
    --------
    >>> weights_by_vertex([7, 3, 7], [1.0, 2.0, 0.5], np.array([3, 7])).tolist()
    [2.0, 1.5]
    """
    idx = np.asarray(idx, dtype=np.int64).ravel()
    try:
        w = np.asarray(w, dtype=np.float64)
    except (TypeError, ValueError):
        raise SampleError("sample_weights could not be read as numbers; pass one weight > 0 per sample") from None
    if w.shape != idx.shape:
        raise SampleError(f"sample_weights has shape {w.shape} for {idx.size} samples; pass one weight per sample")
    out = np.zeros(vertices.size)
    np.add.at(out, np.searchsorted(vertices, idx), w)
    return out
