"""The one validation layer: every array that enters manifill passes through here.

Each function converts dtypes, checks shapes, index ranges (both ends), finiteness
and duplicates, and raises one of manifill's errors whose one-line message names the
bad thing and the fix. Core functions call these and then trust their arrays.
"""

import math

import numpy as np
from scipy.spatial import cKDTree

from .errors import MeshError, OptionError, SampleError
from .tolerances import TOL

__all__ = [
    "as_mesh",
    "as_tets",
    "as_mask",
    "as_indices",
    "as_values",
    "as_samples",
    "check_option",
    "bbox_diagonal",
    "unit_scale",
    "double_areas",
    "zero_area_faces",
    "duplicate_vertex_pairs",
]


def first_entries(idx, k=5):
    """Format the first ``k`` entries of an index list for a message."""
    idx = np.asarray(idx).ravel()
    head = ", ".join(str(int(i)) for i in idx[:k])
    return head + (", ..." if idx.size > k else "")


def _integral_floats(a):
    """True for a float array of whole numbers small enough to be indices."""
    return (np.issubdtype(a.dtype, np.floating) and bool(np.all(np.isfinite(a)))
            and bool(np.all(a == np.round(a))) and bool(np.all(np.abs(a) < 2.0**62)))


def check_option(name, value, allowed):
    """Check that a keyword option is one of a closed set of strings.

    Parameters
    ----------
    name : str
        The option's name, for the message.
    value : object
        The value given.
    allowed : sequence of str
        The allowed values.

    Returns
    -------
    str
        ``value``, unchanged.

    Raises
    ------
    OptionError
        If ``value`` is not in ``allowed``.

    Examples
    --------
    >>> check_option("weights", "cotan", ("uniform", "cotan"))
    'cotan'
    """
    if not isinstance(value, str) or value not in allowed:
        raise OptionError(
            f"{name}={value!r} is not one of {', '.join(repr(a) for a in allowed)}; "
            f"pass one of those"
        )
    return value


#: Positions whose largest bounding-box half-extent has a binary exponent within
#: ``-UNIT_WINDOW .. UNIT_WINDOW`` (about 2e-10 to 4e9) are used as they are: products of
#: such coordinates neither overflow nor underflow, and the results stay bit for bit.
UNIT_WINDOW = 32


def _half_extents(V):
    """Half the bounding-box extent of ``V`` along every axis, as floats (no overflow)."""
    # column by column: a strided reduction per column is ~10x faster than axis=0 on (n, 3)
    return [0.5 * float(V[:, k].max()) - 0.5 * float(V[:, k].min()) for k in range(V.shape[1])]


def scale_of(h):
    """The power of two ``2**e`` with ``h = m 2**e``, ``0.5 <= m < 1``; 1.0 inside the window or for ``h = 0``."""
    if not (h > 0 and np.isfinite(h)):
        return 1.0
    e = math.frexp(h)[1]
    if -UNIT_WINDOW <= e <= UNIT_WINDOW:
        return 1.0
    return math.ldexp(1.0, min(max(e, -1020), 1020))


def unit_scale(V):
    """A power of two ``s`` that brings the positions ``V / s`` to about unit size.

    Dividing by a power of two is exact, so lengths, areas and volumes computed on
    ``V / s`` and multiplied back by ``s``, ``s**2``, ``s**3`` equal the ones computed
    on ``V`` wherever the latter do not overflow or underflow, and angles, cotangent
    weights and normals are unchanged. Meshes in metres at the size of a planet or in
    nanometres thus work like unit ones.

    Parameters
    ----------
    V : (n, d) numpy array
        Points (or difference vectors).

    Returns
    -------
    float
        ``1.0`` when the largest half-extent of the bounding box has a binary exponent
        within ``-UNIT_WINDOW .. UNIT_WINDOW`` (then ``V`` is used as it is); otherwise
        the power of two that brings it into ``[0.5, 1)``. If all points coincide,
        their largest absolute coordinate decides instead.

    Examples
    --------
    >>> unit_scale(np.array([[0.0, 0, 0], [1e150, 0, 0]])) == 2.0**498
    True
    >>> unit_scale(np.array([[0.0, 0, 0], [1e6, 0, 0]]))
    1.0
    """
    V = np.asarray(V, dtype=np.float64)
    if V.size == 0:
        return 1.0
    V = V.reshape(len(V), -1)
    h = max(_half_extents(V))
    if not h > 0:
        h = max(float(np.abs(V[:, k]).max()) for k in range(V.shape[1]))
    return scale_of(h)


def scale_and_diagonal(V):
    """``(s, diag)``: :func:`unit_scale` of ``V`` and its bounding-box diagonal in units of ``s``."""
    if len(V) == 0:
        return 1.0, 1.0
    h = _half_extents(V)
    s = scale_of(max(h))
    inv = 1.0 / s
    # (2 h)**2 summed as in the plain formula, on extents of about unit size
    d = float(np.sqrt(sum((2.0 * x * inv) ** 2 for x in h)))
    if not d > 0:
        return unit_scale(V), 0.0
    return s, d


def bbox_diagonal(V):
    """Length of the diagonal of the axis-aligned bounding box of ``V``.

    Parameters
    ----------
    V : (n, d) numpy array
        Points.

    Returns
    -------
    float
        The diagonal length (computed on extents of about unit size, so it neither
        overflows nor underflows where the length itself is a float); 1.0 if ``V``
        is empty or all points coincide.
    """
    s, d = scale_and_diagonal(V)
    return d * s if d > 0 else 1.0


def _as_vertices(V):
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
    try:
        F = np.asarray(F)
    except (TypeError, ValueError):
        raise MeshError(f"{what} is ragged or not an array; pass an (m, {width}) integer array of {kind}") from None
    if F.ndim != 2 or F.shape[1] != width:
        raise MeshError(f"{what} has shape {F.shape}; pass an (m, {width}) integer array of {kind}")
    if F.shape[0] == 0:
        raise MeshError(f"{what} is empty; pass at least one of the {kind}")
    if not np.issubdtype(F.dtype, np.integer):
        if _integral_floats(F):
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
    from .mesh.objects import mesh_arrays

    V, F = mesh_arrays(V, F)
    V = _as_vertices(V)
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
    from .mesh.objects import tet_arrays

    V, T = tet_arrays(V, T)
    V3 = _as_vertices(V)
    if np.shape(V)[1] != 3:  # _as_vertices pads a flat (n, 2) mesh, which has no volume
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


def as_mask(mask, *, what="mask", shape=None):
    """Validate a voxel mask: a non-empty 3-D boolean array.

    Parameters
    ----------
    mask : (n0, n1, n2) array_like of bool
        Booleans, or integers / floats that are all 0 or 1.
    what : str, optional
        The argument's name, for the messages.
    shape : tuple of 3 int, optional
        The shape it must have (that of the solid's mask).

    Returns
    -------
    (n0, n1, n2) bool numpy array

    Raises
    ------
    SampleError
        Not 3-D, the wrong shape, values other than 0 and 1, or no voxel set.

    Examples
    --------
    >>> as_mask([[[0, 1]]]).tolist()
    [[[False, True]]]
    """
    try:
        m = np.asarray(mask)
    except (TypeError, ValueError):
        raise SampleError(f"{what} is ragged or not an array; pass a 3-D boolean array") from None
    if m.ndim != 3:
        raise SampleError(f"{what} has shape {m.shape}; pass a 3-D boolean array (add an axis of length 1 for a slice)")
    if shape is not None and m.shape != tuple(shape):
        raise SampleError(f"{what} has shape {m.shape} but the mask has {tuple(shape)}; pass one of the same shape")
    if m.dtype != bool:
        if not (np.issubdtype(m.dtype, np.number) and np.isin(m, (0, 1)).all()):
            raise SampleError(f"{what} holds values other than 0 and 1 ({m.dtype}); pass a boolean array")
        m = m.astype(bool)
    if not m.any():
        raise SampleError(f"{what} has no voxel set; pass a mask with at least one True voxel")
    return np.ascontiguousarray(m)


def as_indices(b, n, *, what="b", unique=True):
    """Validate vertex indices.

    Parameters
    ----------
    b : (k,) array_like of int
        0-based vertex indices, any integer dtype (integral floats are accepted).
    n : int
        Number of vertices of the mesh.
    what : str, optional
        The argument's name, for the messages.
    unique : bool, optional
        Reject an index listed twice.

    Returns
    -------
    (k,) int64 numpy array
        The indices, in the given order.

    Raises
    ------
    SampleError
        Not 1-D, empty, not integers, outside ``0..n-1`` or (with ``unique``)
        listed twice.

    Examples
    --------
    >>> as_indices([3.0, 1], 5).tolist()
    [3, 1]
    """
    try:
        b = np.asarray(b)
    except (TypeError, ValueError):
        raise SampleError(f"{what} is ragged or not an array; pass a 1-D array of vertex indices") from None
    if b.ndim != 1:
        raise SampleError(f"{what} has shape {b.shape}; pass a 1-D array of vertex indices")
    if b.size == 0:
        raise SampleError(f"{what} is empty; fix at least one vertex")
    if not np.issubdtype(b.dtype, np.integer):
        if _integral_floats(b):
            b = b.astype(np.int64)
        else:
            raise SampleError(f"{what} has dtype {b.dtype}; pass vertex indices as integers")
    b = b.astype(np.int64, copy=False)
    lo, hi = int(b.min()), int(b.max())
    if lo < 0 or hi >= n:
        bad = np.flatnonzero((b < 0) | (b >= n))
        raise SampleError(
            f"{what} holds vertex {lo if lo < 0 else hi}, outside 0..{n - 1} (entries {first_entries(bad)}); "
            f"indices must be 0-based and below the number of vertices"
        )
    if unique:
        srt = np.sort(b)
        rep = srt[1:][srt[1:] == srt[:-1]]
        if rep.size:
            raise SampleError(
                f"{what} lists vertex {int(rep[0])} more than once ({np.unique(rep).size} repeated vertices); "
                f"list each vertex once"
            )
    return b


def as_values(bc, k, *, what="bc"):
    """Validate the values at ``k`` vertices: ``(k,)`` or ``(k, p)`` finite floats.

    Parameters
    ----------
    bc : (k,) or (k, p) array_like of float
        One value, or one row of ``p`` values, per vertex.
    k : int
        Number of vertices the values belong to.
    what : str, optional
        The argument's name, for the messages.

    Returns
    -------
    bc : (k, p) float64 numpy array
        Always two-dimensional.
    squeeze : bool
        True if ``bc`` was one-dimensional.

    Raises
    ------
    SampleError
        Wrong shape, non-numeric, NaN or infinite values (the rows are named).

    Examples
    --------
    >>> bc, squeeze = as_values([1, 2], 2)
    >>> bc.shape, squeeze
    ((2, 1), True)
    """
    try:
        raw = np.asarray(bc)
        complex_values = np.iscomplexobj(raw)
        bc = raw.astype(np.float64) if not complex_values else raw
    except (TypeError, ValueError):
        raise SampleError(f"{what} could not be read as numbers; pass a (k,) or (k, p) float array") from None
    if complex_values:
        raise SampleError(f"{what} holds complex numbers; pass real values (e.g. their .real or abs)")
    squeeze = bc.ndim == 1
    if squeeze:
        bc = bc[:, None]
    if bc.ndim != 2 or bc.shape[0] != k:
        raise SampleError(f"{what} has shape {bc.shape[:1] if squeeze else bc.shape} for {k} vertices; pass one value (or one row) per vertex")
    if bc.shape[1] == 0:
        raise SampleError(f"{what} has no columns; pass at least one field")
    bad = ~np.isfinite(bc).all(axis=1)
    if bad.any():
        raise SampleError(f"{what} has NaN or infinite values in rows {first_entries(np.flatnonzero(bad))}; remove those samples")
    return np.ascontiguousarray(bc), squeeze


def as_samples(idx, vals, n, *, duplicates="error"):
    """Validate samples ``(idx, vals)``, merging repeated vertices.

    Parameters
    ----------
    idx : (k,) array_like of int
        Vertex of each sample, 0-based, any integer dtype.
    vals : (k,) or (k, p) array_like of float
        Value(s) of each sample: one column per field.
    n : int
        Number of vertices of the mesh.
    duplicates : {'error', 'mean'}, optional
        What to do when a vertex carries two different values: raise, or
        average them. Repeats with equal values are merged silently.

    Returns
    -------
    idx : (k',) int64 numpy array
        Sorted unique vertex indices.
    vals : (k', p) float64 numpy array
        Their values, always two-dimensional.
    squeeze : bool
        True if ``vals`` was one-dimensional.

    Raises
    ------
    SampleError
        Wrong shapes, indices outside ``0..n-1``, NaN or infinite values, or one
        vertex with two different values (listed, with the fix).

    Examples
    --------
    >>> idx, vals, squeeze = as_samples([2, 0, 2], [1.0, 3.0, 1.0], 4)
    >>> idx.tolist(), vals.ravel().tolist(), squeeze
    ([0, 2], [3.0, 1.0], True)
    """
    check_option("duplicates", duplicates, ("error", "mean"))
    idx = as_indices(idx, n, what="idx", unique=False)
    vals, squeeze = as_values(vals, idx.size, what="vals")
    uniq, inv, counts = np.unique(idx, return_inverse=True, return_counts=True)
    if uniq.size == idx.size:
        order = np.argsort(idx)
        return idx[order], np.ascontiguousarray(vals[order]), squeeze
    sums = np.zeros((uniq.size, vals.shape[1]))
    np.add.at(sums, inv, vals)
    mean = sums / counts[:, None]
    spread = np.abs(vals - mean[inv]).max(axis=1)
    conflict = spread > 1e-12 * float(np.abs(vals).max())
    if conflict.any() and duplicates == "error":
        v = int(idx[np.flatnonzero(conflict)[0]])
        rows = np.flatnonzero(idx == v)
        shown = ", ".join(f"{vals[r, 0]:g}" for r in rows[:4])
        nv = np.unique(idx[conflict]).size
        raise SampleError(
            f"{nv} vertices get two different values (vertex {v}: rows {first_entries(rows)} = {shown}); "
            f"remove the conflicting samples, or average them (duplicates='mean', CLI: --duplicates mean)"
        )
    return uniq, mean, squeeze
