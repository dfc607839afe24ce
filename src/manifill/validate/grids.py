"""Voxel grids: masks, voxel spacings and origins, checked and returned as clean arrays.

A malformed grid raises a :class:`~manifill.errors.MeshError` (the mask and its
geometry are the domain, as ``(V, F)`` is for a surface), except where the caller
names another class: a mask of fixed voxels is samples. Voxel samples, ``(k, 3)``
grid indices (:func:`as_voxels`), are samples: a :class:`~manifill.errors.SampleError`.
"""

import numpy as np

from ..errors import MeshError, SampleError
from .options import first_entries

__all__ = ["as_mask", "as_spacing", "as_origin", "as_voxels"]


def as_mask(mask, *, what="mask", shape=None, error=MeshError):
    """Validate a voxel mask: a non-empty 3-D boolean array.

    Parameters
    ----------
    mask : (n0, n1, n2) array_like of bool
        Booleans, or integers / floats that are all 0 or 1.
    what : str, optional
        The argument's name, for the messages.
    shape : tuple of 3 int, optional
        The shape it must have (that of the solid's mask).
    error : type, optional
        The error class to raise: :class:`~manifill.errors.MeshError` for the
        solid's mask (the default), :class:`~manifill.errors.SampleError` for a
        mask of fixed voxels.

    Returns
    -------
    (n0, n1, n2) bool numpy array

    Raises
    ------
    MeshError
        (or ``error``) Not 3-D, the wrong shape, values other than 0 and 1, or no voxel set.

    Examples
    --------
    >>> as_mask([[[0, 1]]]).tolist()
    [[[False, True]]]
    """
    try:
        m = np.asarray(mask)
    except (TypeError, ValueError):
        raise error(f"{what} is ragged or not an array; pass a 3-D boolean array") from None
    if m.ndim != 3:
        raise error(f"{what} has shape {m.shape}; pass a 3-D boolean array (add an axis of length 1 for a slice)")
    if shape is not None and m.shape != tuple(shape):
        raise error(f"{what} has shape {m.shape} but the mask has {tuple(shape)}; pass one of the same shape")
    if m.dtype != bool:
        if not (np.issubdtype(m.dtype, np.number) and np.isin(m, (0, 1)).all()):
            raise error(f"{what} holds values other than 0 and 1 ({m.dtype}); pass a boolean array")
        m = m.astype(bool)
    if not m.any():
        raise error(f"{what} has no voxel set; pass a mask with at least one True voxel")
    return np.ascontiguousarray(m)


def as_spacing(spacing):
    """Validate a voxel size: three positive finite floats (one number means cubes).

    Parameters
    ----------
    spacing : float or (3,) array_like of float
        The voxel's size along each axis.

    Returns
    -------
    (3,) float64 numpy array

    Raises
    ------
    MeshError
        Not numbers, not one or three of them, or not all positive and finite.

    Examples
    --------
    >>> as_spacing(2).tolist(), as_spacing((1, 1, 2.5)).tolist()
    ([2.0, 2.0, 2.0], [1.0, 1.0, 2.5])
    """
    try:
        h = np.asarray(spacing, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise MeshError(f"spacing {spacing!r} is not three numbers; pass e.g. spacing=(1.0, 1.0, 2.5)") from None
    if h.size == 1:
        h = np.repeat(h, 3)
    if h.size != 3 or not np.isfinite(h).all() or (h <= 0).any():
        raise MeshError(f"spacing {spacing!r} must be three positive voxel sizes, e.g. spacing=(1.0, 1.0, 2.5)")
    return h


def as_origin(origin):
    """Validate a grid origin (the centre of voxel ``(0, 0, 0)``): three finite floats.

    Parameters
    ----------
    origin : (3,) array_like of float
        The position of the first voxel's centre.

    Returns
    -------
    (3,) float64 numpy array

    Raises
    ------
    MeshError
        Not three numbers, or not all finite.

    Examples
    --------
    >>> as_origin([0, 0, -1]).tolist()
    [0.0, 0.0, -1.0]
    """
    try:
        o = np.asarray(origin, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        o = np.empty(0)
    if o.size != 3 or not np.isfinite(o).all():
        raise MeshError(f"origin {origin!r} is not three finite numbers; pass the centre of voxel (0, 0, 0), "
                        f"e.g. origin=(0.0, 0.0, 0.0)")
    return o


def as_voxels(voxels, shape, *, what="voxels", mask=None, unique=True):
    """Validate voxel samples: ``(k, 3)`` integer grid indices inside the grid (and the mask).

    Parameters
    ----------
    voxels : (k, 3) array_like of int
        0-based grid indices ``(i, j, k)`` of the sampled voxels, any integer dtype.
    shape : tuple of 3 int
        The grid.
    what : str, optional
        The argument's name, for the messages.
    mask : (n0, n1, n2) bool numpy array, optional
        If given, every voxel must be one of its True voxels.
    unique : bool, optional
        Reject a voxel listed twice.

    Returns
    -------
    (k, 3) int64 numpy array
        The voxels, in the given order.

    Raises
    ------
    SampleError
        Not ``(k, 3)``, empty, not integers, outside the grid at either end of
        an axis, outside ``mask``, or (with ``unique``) listed twice.

    Examples
    --------
    >>> as_voxels([[0, 1, 2], [1, 0, 0]], (2, 2, 3)).tolist()
    [[0, 1, 2], [1, 0, 0]]
    """
    try:
        v = np.asarray(voxels)
    except (TypeError, ValueError):
        raise SampleError(f"{what} is ragged or not an array; pass (k, 3) integer grid indices") from None
    if v.ndim != 2 or v.shape[1] != 3:
        raise SampleError(f"{what} has shape {v.shape}; pass (k, 3) integer grid indices, one row per voxel "
                          f"(of a boolean mask: np.argwhere(mask))")
    if v.shape[0] == 0:
        raise SampleError(f"{what} is empty; give at least one voxel")
    if not np.issubdtype(v.dtype, np.integer):
        raise SampleError(f"{what} has dtype {v.dtype}; pass (k, 3) integer grid indices (e.g. np.argwhere(mask))")
    v = np.ascontiguousarray(v, dtype=np.int64)
    n = np.asarray(shape, dtype=np.int64)
    out = ((v < 0) | (v >= n)).any(axis=1)
    if out.any():
        rows = np.flatnonzero(out)
        e = tuple(int(c) for c in v[rows[0]])
        raise SampleError(f"{what} holds voxel {e}, outside the grid {tuple(int(c) for c in n)} (rows "
                          f"{first_entries(rows)}); pass 0-based grid indices inside it")
    if mask is not None:
        off = ~mask[tuple(v.T)]
        if off.any():
            e = tuple(int(c) for c in v[np.flatnonzero(off)[0]])
            raise SampleError(f"{int(off.sum())} of {what} lie outside the mask (e.g. voxel {e}); "
                              f"give only voxels of the solid")
    if unique:
        lin = np.sort(np.ravel_multi_index(tuple(v.T), tuple(int(c) for c in n)))
        rep = lin[1:][lin[1:] == lin[:-1]]
        if rep.size:
            e = tuple(int(c) for c in np.unravel_index(int(rep[0]), tuple(int(c) for c in n)))
            raise SampleError(f"{what} lists voxel {e} more than once ({np.unique(rep).size} repeated voxels); "
                              f"list each voxel once")
    return v
