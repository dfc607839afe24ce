"""Step 7 for the voxel form: the solid bounded by a closed triangle mesh, as voxels (winding numbers).

:func:`voxel_grid` chooses the grid (cubes, ``resolution`` of them along the
longest side of the bounding box), :func:`voxelize` marks the voxels whose
centres the surface winds around, and :func:`voxelize_memory` estimates its
peak memory before anything grid-sized is made. The voxel solid's own
arithmetic (neighbours, weights, the Laplacian) is :mod:`manifill.solid.voxels`;
its boundary surface D is :mod:`manifill.solid.boundary`.
"""

import math
import numbers

import numpy as np
from numpy.typing import ArrayLike
from scipy import ndimage

from ..errors import MeshError, OptionError, ResourceError, SampleError
from ..memory import check_fits
from ..tolerances import TOL
from ..mesh.edges import edges
from ..validate import as_mesh, unit_scale
from .tets import unit_volume

__all__ = ["voxel_grid", "voxelize", "voxelize_memory", "voxelize_memory_on_grid", "solid_voxels", "grid_words"]


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
    count3 = [max(int(math.ceil(float(x) / h - TOL.grid_count)), 1) + 2 * int(padding) for x in hi - lo]
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


def voxelize_memory_on_grid(V, F, shape, h):
    """:func:`voxelize_memory` on arrays :func:`manifill.validate.as_mesh` returned and a chosen grid.

    Parameters
    ----------
    V : (n, 3) float64 numpy array
    F : (m, 3) int64 numpy array
    shape : tuple of 3 int
        The grid (:func:`voxel_grid`).
    h : float
        The voxel size.

    Returns
    -------
    bytes : float
        The estimated peak memory of :func:`voxelize`.
    band : float
        The estimated voxels in the band around the surface.
    """
    s = unit_scale(V)  # areas and squared lengths of a mesh of size 1e150 overflow; their ratios to h do not
    V, h = V / s, h / s
    N = float(np.prod(np.array(shape, dtype=np.float64)))
    band = min(N, _BAND_THICKNESS * _surface_area(V, F) / h ** 2 + 27.0)
    spread = _VOX_FACE * len(F) + _VOX_POINT * _band_points(V, F, h) + 3.0 * N
    return _VOX_FIXED + max(spread, _VOX_GRID * N, 6.0 * N + _VOX_BAND * band), band


def solid_voxels(V, F, h):
    """Voxels of size ``h`` in the volume that a closed mesh encloses, at any scale (a float).

    ``surface_volume(V, F) / h**3`` (:func:`manifill.solid.tets.surface_volume`) with
    both on ``V / unit_scale(V)``: for a mesh of size ``1e150`` the volume and
    ``h**3`` overflow, for ``1e-150`` they underflow, their ratio does neither.
    ``V`` and ``F`` as :func:`manifill.validate.as_mesh` returns them.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> round(solid_voxels(*icosphere(3), 0.1))  # its volume 4.153, over 0.1**3
    4153
    """
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
    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    shape, h, _ = voxel_grid(V, resolution, padding=padding)
    return voxelize_memory_on_grid(V, F, shape, h)[0]


def grid_words(resolution, shape):
    """What a voxel grid is, for messages.

    Examples
    --------
    >>> grid_words(3000, (3002, 3002, 3002))
    'resolution 3000 (grid 3002 x 3002 x 3002, 27,054,036,008 voxels)'
    """
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


def voxelize(V: ArrayLike, F: ArrayLike, *, resolution: int = 128, allow_open: bool = False,
             padding: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
    V, F = as_mesh(V, F, allow_degenerate=True)
    resolution = _as_resolution(resolution)
    _, count = edges(F)
    if not allow_open and (count == 1).any():
        raise MeshError(
            f"the surface is open ({int((count == 1).sum())} boundary edges), so it bounds no solid; close its holes "
            f"(e.g. with a hole-filling tool) or pass allow_open=True (CLI: --allow-open) to let winding numbers decide"
        )
    shape, h, origin = voxel_grid(V, resolution, padding=padding)
    check_fits(voxelize_memory_on_grid(V, F, shape, h)[0], f"voxelising at {grid_words(resolution, shape)}",
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
