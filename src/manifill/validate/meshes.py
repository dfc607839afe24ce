"""Meshes: triangle and tetrahedral meshes checked and returned as clean arrays.

Positions become ``(n, 3)`` float64 (a flat ``(n, 2)`` mesh gets ``z = 0``), cells
``(m, 3)`` or ``(m, 4)`` int64; every malformed input raises a
:class:`~manifill.errors.MeshError` whose one-line message names the fix.
"""

import numpy as np
import scipy.sparse as sp

from ..errors import MeshError
from ..tolerances import TOL
from .degenerate import duplicate_vertex_pairs, zero_area_faces
from .objects import mesh_arrays, tet_arrays
from .options import first_entries, integral_floats
from .scale import scale_and_diagonal

__all__ = ["as_vertices", "as_cells", "as_mesh", "as_points", "as_tets", "as_laplacian"]


def as_vertices(V):
    """Validate vertex positions: ``(n, 3)`` (or flat ``(n, 2)``, padded with ``z = 0``) finite floats.

    Parameters
    ----------
    V : (n, 3) or (n, 2) array_like
        Vertex positions.

    Returns
    -------
    (n, 3) float64 numpy array

    Raises
    ------
    MeshError
        Not numbers, the wrong shape, empty, or NaN or infinite coordinates (the rows are named).

    Examples
    --------
    >>> as_vertices([[0, 1]]).tolist()
    [[0.0, 1.0, 0.0]]
    """
    try:
        V = np.asarray(V, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise MeshError(f"V could not be read as numbers ({exc}); pass an (n, 3) float array") from None
    if V.ndim != 2 or V.shape[1] not in (2, 3):
        raise MeshError(f"V has shape {V.shape}; pass an (n, 3) array of vertex positions (or (n, 2) for a flat mesh)")
    if V.shape[0] == 0:
        raise MeshError("V is empty; pass at least one triangle's vertices")
    if not np.isfinite(V).all():
        bad = ~np.isfinite(V).all(axis=1)
        raise MeshError(
            f"{int(bad.sum())} vertices have NaN or infinite coordinates (rows {first_entries(np.flatnonzero(bad))}); "
            f"remove or fix them"
        )
    if V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    return np.ascontiguousarray(V)


def as_cells(F, n, width=3, what="F", kind="triangles"):
    """Validate cells (triangles or tetrahedra) as 0-based vertex indices.

    Parameters
    ----------
    F : (m, width) array_like of int
        Cells, any integer dtype (integral floats are accepted).
    n : int
        Number of vertices.
    width : int, optional
        Vertices per cell: 3 for triangles, 4 for tetrahedra.
    what, kind : str, optional
        The argument's name and what its rows are, for the messages.

    Returns
    -------
    (m, width) int64 numpy array

    Raises
    ------
    MeshError
        Ragged, the wrong shape, empty, not integers, or indices outside ``0..n-1``
        (either end; the rows are named).

    Examples
    --------
    >>> as_cells([[0.0, 1, 2]], 3).tolist()
    [[0, 1, 2]]
    """
    try:
        F = np.asarray(F)
    except (TypeError, ValueError):
        raise MeshError(f"{what} is ragged or not an array; pass an (m, {width}) integer array of {kind}") from None
    if F.ndim != 2 or F.shape[1] != width:
        raise MeshError(f"{what} has shape {F.shape}; pass an (m, {width}) integer array of {kind}")
    if F.shape[0] == 0:
        raise MeshError(f"{what} is empty; pass at least one of the {kind}")
    if not np.issubdtype(F.dtype, np.integer):
        if integral_floats(F):
            F = F.astype(np.int64)
        else:
            raise MeshError(f"{what} has dtype {F.dtype}; pass vertex indices as integers")
    F = F.astype(np.int64, copy=False)
    lo, hi = int(F.min()), int(F.max())
    if lo < 0 or hi >= n:
        bad = np.flatnonzero(((F < 0) | (F >= n)).any(axis=1))
        raise MeshError(
            f"{what} refers to vertex {lo if lo < 0 else hi}, outside 0..{n - 1} (rows {first_entries(bad)}); "
            f"indices must be 0-based and below the number of vertices"
        )
    return np.ascontiguousarray(F)


def as_mesh(V, F, *, allow_degenerate=False, allow_unreferenced=False, allow_unwelded=False):
    """Validate a triangle mesh and return it as clean arrays.

    Parameters
    ----------
    V : (n, 3) or (n, 2) array_like
        Vertex positions; a flat ``(n, 2)`` mesh gets ``z = 0``.
    F : (m, 3) array_like of int
        Triangles as 0-based vertex indices, any integer dtype.
    allow_degenerate : bool, optional
        Accept faces of zero area (harmless for uniform and robust weights).
    allow_unreferenced : bool, optional
        Accept vertices used by no face.
    allow_unwelded : bool, optional
        Accept coinciding vertices.

    Returns
    -------
    V : (n, 3) float64 numpy array
    F : (m, 3) int64 numpy array

    Raises
    ------
    MeshError
        Wrong shapes or dtypes, indices outside ``0..n-1``, NaN or infinite
        coordinates, zero-area faces, vertices used by no face, or coinciding
        vertices that leave the mesh unwelded. Each message names the fix.

    See Also
    --------
    manifill.clean_mesh : welds duplicates and drops unreferenced vertices.

    Examples
    --------
    >>> V, F = as_mesh([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    >>> V.shape, F.dtype
    ((3, 3), dtype('int64'))
    """
    V, F = mesh_arrays(V, F)
    V = as_vertices(V)
    n = len(V)
    F = as_cells(F, n)
    used = np.zeros(n, dtype=bool)
    used[F.ravel()] = True
    if not allow_unreferenced and not used.all():
        unused = np.flatnonzero(~used)
        raise MeshError(
            f"{unused.size} vertices are used by no face (vertices {first_entries(unused)}); "
            f"remove them with manifill.clean_mesh (CLI: --clean)"
        )
    if not allow_degenerate:
        bad = np.flatnonzero(zero_area_faces(V, F))
        if bad.size:
            raise MeshError(
                f"{bad.size} faces have zero area (faces {first_entries(bad)}); remove them "
                f"(manifill.clean_mesh, CLI: --clean) or use weights='uniform' or 'robust', which tolerate them"
            )
    dup = np.empty((0, 2), np.int64) if allow_unwelded else duplicate_vertex_pairs(V)
    if len(dup):
        both = used[dup[:, 0]] & used[dup[:, 1]]
        dup = dup[both]
        if len(dup):
            i, j = dup[0]
            raise MeshError(
                f"{len(dup)} pairs of vertices coincide (first: {i} and {j}), so the mesh is not welded "
                f"and falls apart into pieces; merge them with manifill.clean_mesh (CLI: --clean)"
            )
    return V, F


def as_points(P):
    """Validate a point cloud (a surface given by its points, no faces): ``(n, 3)`` finite floats, distinct.

    Parameters
    ----------
    P : (n, 3) or (n, 2) array_like
        Positions (a flat ``(n, 2)`` cloud gets ``z = 0``).

    Returns
    -------
    (n, 3) float64 numpy array

    Raises
    ------
    MeshError
        As :func:`as_vertices`; fewer than 7 points; points that coincide (named, with the fix).

    Examples
    --------
    >>> as_points(np.arange(21.0).reshape(7, 3) ** 2).shape
    (7, 3)
    """
    P = as_vertices(P)
    if len(P) < 7:
        raise MeshError(f"the point cloud has {len(P)} points; a surface needs at least 7 (each point is joined to "
                        f"its nearest neighbours); pass more points, or faces")
    dup = duplicate_vertex_pairs(P)
    if len(dup):
        i, j = dup[0]
        raise MeshError(f"{len(dup)} pairs of points coincide (first: {i} and {j}); a point cloud needs distinct "
                        f"points: merge them (e.g. numpy.unique(P, axis=0)) before reconstructing")
    return P


def as_tets(V, T, *, allow_degenerate=False, allow_unreferenced=False):
    """Validate a tetrahedral mesh and return it as clean arrays.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    T : (m, 4) array_like of int
        Tetrahedra as 0-based vertex indices, any integer dtype, either orientation.
    allow_degenerate : bool, optional
        Accept tetrahedra of zero volume (harmless for uniform weights).
    allow_unreferenced : bool, optional
        Accept vertices used by no tetrahedron.

    Returns
    -------
    V : (n, 3) float64 numpy array
    T : (m, 4) int64 numpy array

    Raises
    ------
    MeshError
        Wrong shapes or dtypes, flat ``(n, 2)`` positions, indices outside
        ``0..n-1``, NaN or infinite coordinates, tetrahedra of zero volume
        (``|volume| <= TOL.degenerate_area * diag**3``) or vertices used by no
        tetrahedron. Each message names the fix.

    See Also
    --------
    as_mesh : the same for triangle meshes.

    Examples
    --------
    >>> V, T = as_tets([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]])
    >>> V.dtype, T.shape, T.dtype
    (dtype('float64'), (1, 4), dtype('int64'))
    """
    V, T = tet_arrays(V, T)
    V3 = as_vertices(V)
    if np.shape(V)[1] != 3:  # as_vertices pads a flat (n, 2) mesh, which has no volume
        raise MeshError(f"V has shape {np.shape(V)}; a tetrahedral mesh needs an (n, 3) array of vertex positions")
    V = V3
    n = len(V)
    T = as_cells(T, n, width=4, what="T", kind="tetrahedra")
    used = np.zeros(n, dtype=bool)
    used[T.ravel()] = True
    if not allow_unreferenced and not used.all():
        unused = np.flatnonzero(~used)
        raise MeshError(
            f"{unused.size} vertices are used by no tetrahedron (vertices {first_entries(unused)}); "
            f"remove them and renumber T"
        )
    if not allow_degenerate:
        s, diag = scale_and_diagonal(V)  # volumes in units of s**3: no overflow or underflow at any scale
        Vs = V if s == 1.0 else V * (1.0 / s)
        a = Vs[T[:, 0]]
        u, v, w = Vs[T[:, 1]] - a, Vs[T[:, 2]] - a, Vs[T[:, 3]] - a
        vol = np.einsum("ij,ij->i", np.cross(u, v), w) / 6.0
        bad = np.flatnonzero(np.abs(vol) <= TOL.degenerate_area * diag**3)
        if bad.size:
            raise MeshError(
                f"{bad.size} tetrahedra have zero volume (tetrahedra {first_entries(bad)}); remove them "
                f"or use weights='uniform', which tolerates them"
            )
    return V, T


def as_laplacian(L, *, what="L"):
    """Validate a user's Laplacian: a square sparse matrix of finite numbers.

    Parameters
    ----------
    L : (n, n) scipy sparse matrix or array_like
        The matrix (any format; a dense array is accepted).
    what : str, optional
        The argument's name, for the messages.

    Returns
    -------
    (n, n) scipy.sparse.csr_array of float64

    Raises
    ------
    MeshError
        Not a matrix of numbers, not square, or NaN or infinite entries.

    Examples
    --------
    >>> as_laplacian([[1, -1], [-1, 1]]).toarray().tolist()
    [[1.0, -1.0], [-1.0, 1.0]]
    """
    try:
        L = sp.csr_array(L, dtype=np.float64)
    except (TypeError, ValueError):
        raise MeshError(f"{what} could not be read as a sparse matrix of numbers; pass a scipy.sparse matrix") from None
    if L.ndim != 2 or L.shape[0] != L.shape[1]:
        raise MeshError(f"{what} has shape {L.shape}; pass a square sparse matrix")
    if not np.isfinite(L.data).all():
        raise MeshError(f"{what} has NaN or infinite entries; check how it was built")
    return L
