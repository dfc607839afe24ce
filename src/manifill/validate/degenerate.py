"""Degenerate geometry, measured at any scale: zero-area faces and coinciding vertices.

The checks :func:`manifill.validate.as_mesh` makes (and
:func:`manifill.mesh.clean.clean_mesh` repairs), with twice the triangle areas they are
measured by. All run on positions divided by :func:`~manifill.validate.unit_scale`,
so they mean the same for a mesh in nanometres as in light years.
"""

import numpy as np
from scipy.spatial import cKDTree

from ..tolerances import TOL
from .scale import scale_and_diagonal, unit_scale

__all__ = ["double_areas", "zero_area_faces", "duplicate_vertex_pairs"]


def _double_areas(V, F, inv=1.0):
    """Twice the triangle areas of the positions ``V * inv`` (``inv`` a power of two)."""
    a, b, c = (np.ascontiguousarray(F[:, k]) for k in range(3))
    cols = [np.ascontiguousarray(V[:, k]) for k in range(3)]
    if inv != 1.0:
        cols = [x * inv for x in cols]
    u = [x[b] - x[a] for x in cols]
    v = [x[c] - x[a] for x in cols]
    cx = u[1] * v[2] - u[2] * v[1]
    cy = u[2] * v[0] - u[0] * v[2]
    cz = u[0] * v[1] - u[1] * v[0]
    return np.sqrt(cx * cx + cy * cy + cz * cz)


def double_areas(V, F):
    """Twice the area of every triangle.

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions.
    F : (m, 3) numpy array of int
        Triangles.

    Returns
    -------
    (m,) numpy array
        Computed on positions of about unit size (see :func:`unit_scale`) and
        scaled back, so only areas that are themselves beyond the float range
        overflow (to ``inf``) or underflow (to 0).

    See Also
    --------
    manifill.mesh.geometry.face_areas : the areas of a validated mesh.

    Examples
    --------
    >>> V = 1e150 * np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> double_areas(V, np.array([[0, 1, 2]])) / 1e300
    array([1.])
    """
    s = unit_scale(V)
    A = _double_areas(V, F, 1.0 / s)
    return A if s == 1.0 else (A * s) * s


def zero_area_faces(V, F):
    """Faces whose area is at most ``TOL.degenerate_area * diag**2``, at any scale.

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions.
    F : (m, 3) numpy array of int
        Triangles.

    Returns
    -------
    (m,) bool numpy array
        True for a zero-area face; the test runs on positions of about unit size,
        so it means the same for a mesh in nanometres as in light years.

    Examples
    --------
    >>> V = 1e-200 * np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]])
    >>> zero_area_faces(V, np.array([[0, 1, 2], [0, 1, 3]])).tolist()
    [False, True]
    """
    s, diag = scale_and_diagonal(V)
    return _double_areas(V, F, 1.0 / s) <= 2 * TOL.degenerate_area * diag * diag


def duplicate_vertex_pairs(V, tol=None):
    """Pairs of vertices that coincide up to ``tol * diag``.

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions.
    tol : float, optional
        Relative distance; defaults to ``TOL.weld``.

    Returns
    -------
    (k, 2) numpy array
        Index pairs ``i < j`` of coinciding vertices.

    Examples
    --------
    >>> duplicate_vertex_pairs(np.array([[0.0, 0, 0], [1, 0, 0], [0, 0, 0]])).tolist()
    [[0, 2]]
    """
    tol = TOL.weld if tol is None else tol
    # everything in units of s (a power of two): the KD-tree compares squared distances
    s, diag = scale_and_diagonal(V)
    inv = 1.0 / s
    eps = tol * (diag if diag > 0 else inv)
    # Coinciding points have nearly equal projections on any direction: only the
    # runs of nearly equal projections need a closer look.
    direction = np.array([0.5773502691896258, 0.6030226891555273, 0.5504818825631803])
    proj = V @ direction
    if inv != 1.0:
        proj *= inv
    order = np.argsort(proj, kind="stable")
    close = np.diff(proj[order]) <= eps * 1.0000001
    if not close.any():
        return np.empty((0, 2), dtype=np.int64)
    cand = np.unique(np.concatenate([order[:-1][close], order[1:][close]]))
    pairs = cKDTree(V[cand] * inv if inv != 1.0 else V[cand]).query_pairs(eps, output_type="ndarray")
    if len(pairs) == 0:
        return np.empty((0, 2), dtype=np.int64)
    pairs = np.sort(cand[pairs], axis=1)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
