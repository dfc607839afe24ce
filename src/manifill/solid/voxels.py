"""Voxel solids (the paper's "cubical form"): neighbours, weights, the boundary surface, voxelisation.

A solid in voxel form is a boolean ``mask`` on a regular grid with a per-axis
``spacing`` (voxel size, anisotropic as medical volumes are) and an ``origin``
(the centre of voxel ``(0, 0, 0)``): voxel ``(i, j, k)`` sits at
``origin + (i, j, k) * spacing``, so array axis ``a`` is coordinate ``a``.

Neighbours and weights
----------------------
Two voxels of the mask are neighbours when they share a face (``connectivity=6``),
also an edge (18), or also a corner (26). The weight of the neighbour at
physical offset ``p`` is ``1 / |p|^2`` for edge and corner neighbours, and the
face weights are then chosen per axis so that the second moments
``sum_d w_d p_a p_b`` of the stencil are equal on every axis (they vanish off the
diagonal by symmetry). The stencil is then, to second order, a multiple of the
physical Laplacian on any spacing, all weights are positive (so the maximum
principle holds), and like every symmetric stencil it reproduces linear
functions exactly. With 6 neighbours this is the usual ``1 / h_a^2`` per axis.

The boundary surface D
----------------------
The voxels of the mask with a face neighbour outside it (or on the border of
the array). Every other voxel of the mask has all its face neighbours in the
mask, so fixing D encloses the inside for every connectivity.
"""

import itertools
import math
import numbers

import numpy as np
import scipy.sparse as sp

from ..errors import MeshError, OptionError, ResourceError, SampleError
from ..memory import check_fits
from ..validate import unit_scale

__all__ = [
    "CONNECTIVITY",
    "as_connectivity",
    "as_spacing",
    "as_origin",
    "neighbour_offsets",
    "stencil_weights",
    "boundary_voxels",
    "voxel_laplacian",
    "voxel_components",
    "voxel_centres",
    "voxelize",
    "voxel_grid",
    "voxelize_memory",
]

CONNECTIVITY = (6, 18, 26)


def as_connectivity(connectivity):
    """``connectivity`` as an int from ``CONNECTIVITY``, or :class:`~manifill.errors.OptionError`."""
    try:
        c = int(connectivity)
    except (TypeError, ValueError, OverflowError):
        c = None
    if c not in CONNECTIVITY or (isinstance(connectivity, numbers.Real) and connectivity != c):  # 6.5 is not 6
        raise OptionError(f"connectivity={connectivity!r} is not one of 6, 18, 26; pass one of those")
    return c


def neighbour_offsets(connectivity=6):
    """One offset of every opposite pair of neighbours.

    Parameters
    ----------
    connectivity : {6, 18, 26}, optional

    Returns
    -------
    (c // 2, 3) int64 numpy array
        Offsets ``d`` whose first nonzero entry is positive; the neighbours of a
        voxel are at ``+d`` and ``-d``.

    Examples
    --------
    >>> neighbour_offsets(6).tolist()
    [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    >>> len(neighbour_offsets(18)), len(neighbour_offsets(26))
    (9, 13)
    """
    most = {6: 1, 18: 2, 26: 3}[as_connectivity(connectivity)]
    out = []
    for d in itertools.product((-1, 0, 1), repeat=3):
        nz = np.flatnonzero(d)
        if 0 < nz.size <= most and d[nz[0]] > 0:
            out.append(d)
    out.sort(key=lambda d: (sum(map(abs, d)), [-x for x in d]))
    return np.array(out, dtype=np.int64)


def as_spacing(spacing):
    """``spacing`` as three positive floats (one number means cubes), or :class:`~manifill.errors.SampleError`."""
    try:
        h = np.asarray(spacing, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise SampleError(f"spacing {spacing!r} is not three numbers; pass e.g. spacing=(1.0, 1.0, 2.5)") from None
    if h.size == 1:
        h = np.repeat(h, 3)
    if h.size != 3 or not np.isfinite(h).all() or (h <= 0).any():
        raise SampleError(f"spacing {spacing!r} must be three positive voxel sizes, e.g. spacing=(1.0, 1.0, 2.5)")
    return h


def as_origin(origin):
    """``origin`` as three finite floats, or :class:`~manifill.errors.SampleError`."""
    try:
        o = np.asarray(origin, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        o = np.empty(0)
    if o.size != 3 or not np.isfinite(o).all():
        raise SampleError(f"origin {origin!r} is not three finite numbers; pass the centre of voxel (0, 0, 0), "
                          f"e.g. origin=(0.0, 0.0, 0.0)")
    return o


def stencil_weights(spacing=(1.0, 1.0, 1.0), connectivity=6):
    """Weight of each neighbour offset (see the module docstring).

    Parameters
    ----------
    spacing : (3,) array_like of float, optional
        Voxel size along each axis.
    connectivity : {6, 18, 26}, optional

    Returns
    -------
    offsets : (c // 2, 3) int64 numpy array
        As :func:`neighbour_offsets`.
    w : (c // 2,) numpy array
        Positive weights, the same for ``+d`` and ``-d``.

    Examples
    --------
    >>> _, w = stencil_weights((1.0, 2.0, 4.0), 6)
    >>> w.tolist()
    [1.0, 0.25, 0.0625]
    """
    h = as_spacing(spacing)
    D = neighbour_offsets(connectivity)
    P = D * h
    w = np.zeros(len(D))
    face = (D != 0).sum(axis=1) == 1
    w[~face] = 1.0 / (P[~face] ** 2).sum(axis=1)
    # second moment per axis of the edge and corner neighbours (both signs)
    moment = 2.0 * (w[~face, None] * P[~face] ** 2).sum(axis=0)
    target = (moment + 2.0).max()
    axis = np.argmax(D[face] != 0, axis=1)
    w[face] = (target - moment[axis]) / (2.0 * h[axis] ** 2)
    return D, w


def unit_spacing(spacing):
    """``spacing`` divided by a power of two that brings it to about unit size (unchanged in the usual range).

    The stencil weights are homogeneous of degree -2 in the spacing, so this
    multiplies every weight by the same power of four, exactly, and leaves the
    harmonic solution as it is; but ``1 / h**2`` of a spacing of ``1e30`` (or
    ``1e-30``) is beyond single precision, which the multigrid cycle runs in,
    and of ``1e160`` beyond double. See :func:`manifill.validate.unit_scale`.
    """
    h = as_spacing(spacing)
    return h / unit_scale(h[None])


def _shifted(a, d):
    """Views ``(a[x], a[x + d])`` over all ``x`` where both lie in the array."""
    src, dst = [], []
    for k, s in enumerate(d):
        n = a.shape[k]
        src.append(slice(max(0, -s), n - max(0, s)))
        dst.append(slice(max(0, s), n - max(0, -s)))
    return a[tuple(src)], a[tuple(dst)]


def boundary_voxels(mask, connectivity=6):
    """The boundary surface D: voxels of ``mask`` with a neighbour outside it.

    Parameters
    ----------
    mask : (n0, n1, n2) bool numpy array
    connectivity : {6, 18, 26}, optional
        Which neighbours count. Fixing D then leaves every other voxel of the
        mask with all its neighbours in the mask, so the stencil there is whole
        (and reproduces linear functions).

    Returns
    -------
    (n0, n1, n2) bool numpy array
        Voxels on the border of the array count as boundary.

    Examples
    --------
    >>> m = np.ones((3, 3, 3), dtype=bool)
    >>> int(boundary_voxels(m).sum()), bool(boundary_voxels(m)[1, 1, 1])
    (26, False)
    """
    mask = np.asarray(mask, dtype=bool)
    inner = np.zeros_like(mask)
    inner[1:-1, 1:-1, 1:-1] = mask[1:-1, 1:-1, 1:-1]  # the border layers have neighbours outside the array
    for d in neighbour_offsets(connectivity):
        for s in (d, -d):
            _shifted(inner, s)[0][...] &= _shifted(mask, s)[1]  # the neighbour at x + s is in the mask
    return mask & ~inner


def voxel_components(mask, connectivity=6):
    """Connected components of the mask under the given neighbourhood.

    Parameters
    ----------
    mask : (n0, n1, n2) bool numpy array
    connectivity : {6, 18, 26}, optional

    Returns
    -------
    count : int
    labels : (n0, n1, n2) int numpy array
        ``0`` outside the mask, ``1..count`` inside.
    """
    from scipy import ndimage

    rank = {6: 1, 18: 2, 26: 3}[as_connectivity(connectivity)]
    labels, count = ndimage.label(mask, structure=ndimage.generate_binary_structure(3, rank))
    return int(count), labels


def voxel_laplacian(mask, spacing=(1.0, 1.0, 1.0), connectivity=6):
    """The graph Laplacian ``L = D - W`` of the voxels of ``mask``.

    Parameters
    ----------
    mask : (n0, n1, n2) bool numpy array
    spacing : (3,) array_like of float, optional
    connectivity : {6, 18, 26}, optional

    Returns
    -------
    (n, n) scipy.sparse.csr_array
        Rows and columns follow ``np.flatnonzero(mask)`` (C order); symmetric
        positive semi-definite, constants in its null space.

    Examples
    --------
    >>> L = voxel_laplacian(np.ones((1, 1, 3), dtype=bool))
    >>> L.toarray().tolist()
    [[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]]
    """
    mask = np.asarray(mask, dtype=bool)
    D, w = stencil_weights(spacing, connectivity)
    n = int(mask.sum())
    ids = np.full(mask.shape, -1, dtype=np.int64)
    ids[mask] = np.arange(n)
    rows, cols, vals = [], [], []
    for d, wd in zip(D, w):
        a, b = _shifted(ids, d)
        both = (a >= 0) & (b >= 0)
        rows.append(a[both])
        cols.append(b[both])
        vals.append(np.full(int(both.sum()), wd))
    r, c, v = np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
    W = sp.csr_array((np.concatenate([v, v]), (np.concatenate([r, c]), np.concatenate([c, r]))), shape=(n, n))
    deg = np.asarray(W.sum(axis=1)).ravel()
    L = sp.csr_array(sp.diags_array(deg) - W)
    L.sort_indices()
    return L


def voxel_centres(shape, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0), where=None):
    """Positions of voxel centres.

    Parameters
    ----------
    shape : tuple of 3 int
    spacing, origin : (3,) array_like of float, optional
    where : (n0, n1, n2) bool numpy array, optional
        Only these voxels (C order); all voxels by default.

    Returns
    -------
    (k, 3) numpy array
    """
    h = as_spacing(spacing)
    o = as_origin(origin)
    if where is None:
        where = np.ones(shape, dtype=bool)
    return o + np.argwhere(where) * h


def _surface_band(V, F, shape, h, origin):
    """Voxels within one voxel of the surface: points spread over every triangle at most h/2 apart, dilated.

    Lengths are squared: pass positions of about unit size (``V``, ``h`` and
    ``origin`` divided by :func:`~manifill.validate.unit_scale`), which gives
    the same band.
    """
    band = np.zeros(shape, dtype=bool)
    A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    longest = np.sqrt(np.maximum.reduce([((B - A) ** 2).sum(1), ((C - B) ** 2).sum(1), ((A - C) ** 2).sum(1)]))
    steps = np.maximum(np.ceil(longest / (0.5 * h)).astype(np.int64), 1)
    for s in np.unique(steps):
        sel = np.flatnonzero(steps == s)
        i, j = np.meshgrid(np.arange(s + 1), np.arange(s + 1), indexing="ij")
        keep = i + j <= s
        u, v = i[keep] / s, j[keep] / s
        for lo in range(0, sel.size, max(1, 2_000_000 // u.size)):
            f = sel[lo:lo + max(1, 2_000_000 // u.size)]
            P = (A[f, None] + u[None, :, None] * (B[f, None] - A[f, None])
                 + v[None, :, None] * (C[f, None] - A[f, None])).reshape(-1, 3)
            ijk = np.rint((P - origin) / h).astype(np.int64)
            ijk = np.clip(ijk, 0, np.array(shape) - 1)
            band[ijk[:, 0], ijk[:, 1], ijk[:, 2]] = True
    from scipy import ndimage

    return ndimage.binary_dilation(band, np.ones((3, 3, 3), dtype=bool))


class _ResolutionError(OptionError, SampleError):
    """A resolution that is not an integer of at least 2: an option error (and a SampleError, as it was)."""


def _as_resolution(resolution):
    """``resolution`` as an int >= 2, or :class:`~manifill.errors.OptionError` naming the fix."""
    r = None
    if isinstance(resolution, numbers.Integral) and not isinstance(resolution, bool):
        r = int(resolution)
    elif isinstance(resolution, numbers.Real) and not isinstance(resolution, bool):
        if math.isfinite(resolution) and float(resolution).is_integer():
            r = int(resolution)
    if r is None:
        raise _ResolutionError(f"resolution {resolution!r} is not an integer; pass the number of voxels along "
                               f"the longest side, e.g. resolution=128 (CLI --resolution)")
    if r < 2:
        raise _ResolutionError(f"resolution {r} is too small; pass at least 2 voxels along the longest side "
                               f"(CLI --resolution)")
    return r


def voxel_grid(V, resolution=128, *, padding=1):
    """The grid :func:`voxelize` uses: cubes, ``resolution`` of them along the longest side of the box of ``V``.

    Parameters
    ----------
    V : (n, 3) float64 numpy array
        Vertex positions (finite).
    resolution : int, optional
    padding : int, optional
        Empty voxel layers around the bounding box.

    Returns
    -------
    shape : tuple of 3 int
        Voxels per axis (Python ints: a huge grid does not overflow).
    h : float
        Voxel size.
    origin : (3,) numpy array
        Centre of voxel ``(0, 0, 0)``.

    Raises
    ------
    OptionError
        ``resolution`` not an integer >= 2.
    MeshError
        All vertices coincide.
    ResourceError
        A resolution above 10^12 (more voxels than any memory holds).

    Examples
    --------
    >>> shape, h, origin = voxel_grid(np.array([[0.0, 0, 0], [2, 1, 1]]), 4)
    >>> shape, h, origin.tolist()
    ((6, 4, 4), 0.5, [-0.25, -0.25, -0.25])
    """
    resolution = _as_resolution(resolution)
    if resolution > 10**12:  # beyond float arithmetic on the grid, and 10^36 voxels fit in no memory
        raise ResourceError(f"resolution {resolution} makes more than 10^36 voxels, more than any memory holds; "
                            f"lower the resolution (CLI --resolution)")
    V = np.asarray(V, dtype=np.float64)
    lo, hi = V.min(axis=0), V.max(axis=0)
    h = float((hi - lo).max()) / resolution
    if not h > 0:
        raise MeshError("the surface has no extent (all vertices coincide); pass a surface that encloses a solid")
    count3 = [max(int(math.ceil(float(x) / h - 1e-9)), 1) + 2 * int(padding) for x in hi - lo]
    origin = (lo + hi) / 2 - (np.array(count3, dtype=np.float64) - 1) * h / 2
    return tuple(count3), h, origin


#: Bytes per voxel of the grid-wide arrays of :func:`voxelize` at its peak (the band, the region
#: labels, the index of every voxel outside the band, the mask), per band voxel (query points and
#: winding numbers), per face (validation, edges) and per point spread over the triangles in one
#: chunk, and a fixed part; measured with tracemalloc (17, 96, 200-300, 40-70, 1 MB), rounded up.
_VOX_GRID, _VOX_BAND, _VOX_FACE, _VOX_POINT, _VOX_FIXED = 18, 110, 300, 70, 1.5e6
#: Band voxels per (surface area / h^2): the band of spread points dilated by one voxel (4.2 measured).
_BAND_THICKNESS = 4.5
#: Points spread over the triangles per chunk of :func:`_surface_band`.
_BAND_CHUNK = 2_000_000


def _band_points(V, F, h):
    """The most points :func:`_surface_band` holds at once for voxel size ``h``."""
    A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    longest = np.sqrt(np.maximum.reduce([((B - A) ** 2).sum(1), ((C - B) ** 2).sum(1), ((A - C) ** 2).sum(1)]))
    steps = np.maximum(np.ceil(np.minimum(longest / (0.5 * h), 1e12)), 1)
    s, count = np.unique(steps, return_counts=True)
    per_face = (s + 1) * (s + 2) / 2
    per_chunk = np.maximum(1, _BAND_CHUNK // per_face)
    return float((np.minimum(count, per_chunk) * per_face).max()) if len(s) else 0.0


def _surface_area(V, F):
    """Total area of the triangles."""
    A = V[F[:, 0]]
    return float(np.linalg.norm(np.cross(V[F[:, 1]] - A, V[F[:, 2]] - A), axis=1).sum() / 2)


def _voxelize_memory(V, F, shape, h):
    """:func:`voxelize_memory` on validated arrays and a chosen grid: (bytes, band voxels)."""
    s = unit_scale(V)  # areas and squared lengths of a mesh of size 1e150 overflow; their ratios to h do not
    V, h = V / s, h / s
    N = float(np.prod(np.array(shape, dtype=np.float64)))
    band = min(N, _BAND_THICKNESS * _surface_area(V, F) / h ** 2 + 27.0)
    spread = _VOX_FACE * len(F) + _VOX_POINT * _band_points(V, F, h) + 3.0 * N
    return _VOX_FIXED + max(spread, _VOX_GRID * N, 6.0 * N + _VOX_BAND * band), band


def _solid_voxels(V, F, h):
    """Voxels of size ``h`` in the volume that validated arrays enclose, at any scale.

    ``surface_volume(V, F) / h**3`` (:func:`manifill.solid.tets.surface_volume`) with
    both on ``V / unit_scale(V)``: for a mesh of size ``1e150`` the volume and
    ``h**3`` overflow, for ``1e-150`` they underflow, their ratio does neither.
    """
    from .tets import unit_volume

    vol, s = unit_volume(V, F)
    return vol / (h / s) ** 3


def voxelize_memory(V, F, resolution=128, *, padding=1):
    """Estimated peak memory of :func:`voxelize`, in bytes.

    The grid-wide arrays (about 18 bytes per voxel of the box, from the
    bounding box and ``resolution``), the band of voxels around the surface
    where winding numbers are evaluated (about 110 bytes per band voxel; the
    band is about 4.5 voxels thick), and the points spread over the triangles.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles.
    resolution : int, optional
        Voxels along the longest side.
    padding : int, optional

    Returns
    -------
    float

    Raises
    ------
    MeshError, OptionError
        As :func:`voxelize`.

    Examples
    --------
    >>> from manifill.memory import human
    >>> from manifill.mesh.shapes import icosphere
    >>> small, big = voxelize_memory(*icosphere(2), 64), voxelize_memory(*icosphere(2), 3000)
    >>> human(small), human(big)  # 3002^3 voxels at 18 bytes
    ('9 MB', '487.0 GB')
    """
    from ..validate import as_mesh

    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    shape, h, _ = voxel_grid(V, resolution, padding=padding)
    return _voxelize_memory(V, F, shape, h)[0]


def _grid_words(resolution, shape):
    """``'resolution 3000 (grid 3002 x 3002 x 3002, 27,054,036,008 voxels)'``."""
    total = math.prod(shape)
    return f"resolution {resolution} (grid {' x '.join(str(c) for c in shape)}, {total:,} voxels)"


def _exact_shift(V, Q):
    """A translation ``c`` (per axis the centre of the box of ``V`` and ``Q``, or 0) that is exact for both.

    libigl's winding numbers work in single precision, so a solid far from the
    origin (a box at 1e9 of size 1) loses its inside. Along an axis where every
    coordinate lies within a factor 2 of the centre, subtracting the centre is
    exact (Sterbenz), so the translated solid is the same solid; elsewhere (a
    box around the origin, the usual case) nothing is subtracted.
    """
    X = np.concatenate([V, Q])
    lo, hi = X.min(axis=0), X.max(axis=0)
    c = (lo + hi) / 2
    ok = np.where(c > 0, (lo >= c / 2) & (hi <= 2 * c), (hi <= c / 2) & (lo >= 2 * c)) & np.isfinite(c)
    return np.where(ok, c, 0.0)


def voxelize(V, F, resolution=128, *, allow_open=False, padding=1):
    """Voxelise the solid bounded by a closed triangle mesh.

    A voxel is inside when the generalised winding number of the surface at its
    centre is at least 1/2 (libigl's fast winding number), which is robust to
    small holes, self-intersections and inconsistent pieces: they do not flood
    the volume as a parity or ray test would.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles, oriented consistently (outward or inward: both work).
    resolution : int, optional
        Voxels along the longest side of the bounding box; voxels are cubes.
    allow_open : bool, optional
        Accept a surface with boundary edges: the winding number then decides
        what the holes let in (a nearly closed surface still gives its solid; a
        sheet gives little or nothing). By default an open surface is an error.
    padding : int, optional
        Empty voxel layers around the bounding box.

    Returns
    -------
    mask : (n0, n1, n2) bool numpy array
    spacing : (3,) numpy array
    origin : (3,) numpy array
        Centre of voxel ``(0, 0, 0)``.

    Raises
    ------
    MeshError
        A malformed or open surface, or one that encloses no voxel at this
        resolution.
    OptionError
        ``resolution`` not an integer of at least 2.
    ResourceError
        The voxelisation is predicted not to fit in the memory available
        (:func:`voxelize_memory`); checked before anything grid-sized is made.
    ImportError
        Without libigl (``pip install 'manifill[volume]'``).

    Notes
    -----
    The winding numbers are evaluated on the positions divided by
    :func:`~manifill.validate.unit_scale` (exact) and, along the axes where it
    is exact, moved to the origin, so a solid of size ``1e-150`` or ``1e150``,
    or one far from the origin, gives the voxels of the same solid at unit size.
    """
    from ..mesh.topology import edges
    from ..validate import as_mesh

    V, F = as_mesh(V, F, allow_degenerate=True)
    resolution = _as_resolution(resolution)
    _, count = edges(F)
    if not allow_open and (count == 1).any():
        raise MeshError(
            f"the surface is open ({int((count == 1).sum())} boundary edges), so it bounds no solid; close its holes "
            f"(e.g. with a hole-filling tool) or pass allow_open=True (CLI: --allow-open) to let winding numbers decide"
        )
    shape, h, origin = voxel_grid(V, resolution, padding=padding)
    check_fits(_voxelize_memory(V, F, shape, h)[0], f"voxelising at {_grid_words(resolution, shape)}",
               "lower the resolution (CLI --resolution)")
    try:
        import igl
    except ImportError:
        raise ImportError("voxelize needs libigl for winding numbers: pip install 'manifill[volume]'") from None
    # the winding number is constant away from the surface: evaluate it in a band of voxels
    # around the surface, and once per connected region of the voxels outside the band.
    # Positions of about unit size (libigl's winding numbers vanish for a mesh of size 1e30 and
    # crash at 1e150); dividing by the power of two s is exact, so the band and mask do not change
    s = unit_scale(V)
    band = _surface_band(V / s, F, shape, h / s, origin / s)
    from scipy import ndimage

    labels, count = ndimage.label(~band)
    first = np.full(count + 1, -1, dtype=np.int64)
    flat = labels.ravel()
    order = np.flatnonzero(flat)
    first[flat[order[::-1]]] = order[::-1]  # the first voxel of every region
    where = np.concatenate([np.flatnonzero(band.ravel()), first[1:]])
    Q = origin + np.column_stack(np.unravel_index(where, shape)) * h
    c = _exact_shift(V, Q)
    wn = igl.fast_winding_number(np.ascontiguousarray((V - c) / s), np.ascontiguousarray(F, dtype=np.int64),
                                 np.ascontiguousarray((Q - c) / s))
    inside = np.abs(wn) >= 0.5
    nb = int(band.sum())
    region_inside = np.concatenate([[False], inside[nb:]])
    mask = region_inside[labels]
    mask[band] = inside[:nb]
    if not mask.any():
        raise MeshError(
            f"no voxel centre lies inside the surface at resolution {resolution}; raise the resolution "
            f"or check that the surface is closed"
        )
    return mask, np.full(3, h), origin
