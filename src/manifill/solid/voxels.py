"""Voxel solids (the paper's "cubical form"): neighbours, stencil weights, components, the Laplacian.

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

Making a voxel solid from a closed surface and its boundary surface D are
Step 7 (:mod:`manifill.solid.voxelize`, :mod:`manifill.solid.boundary`); this
module is the voxel solid's own arithmetic.
"""

import itertools
import numbers

import numpy as np
import scipy.sparse as sp
from scipy import ndimage

from ..errors import OptionError
from ..validate import as_origin, as_spacing, unit_scale

__all__ = [
    "CONNECTIVITY",
    "as_connectivity",
    "as_spacing",
    "as_origin",
    "neighbour_offsets",
    "stencil_weights",
    "unit_spacing",
    "shifted_views",
    "voxel_laplacian",
    "voxel_components",
    "voxel_centres",
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


def shifted_views(a, d):
    """Views ``(a[x], a[x + d])`` over all ``x`` where both lie in the array.

    Parameters
    ----------
    a : (n0, n1, n2) numpy array
    d : (3,) sequence of int
        An offset (:func:`neighbour_offsets`).

    Returns
    -------
    tuple of two (views of) numpy arrays
        Of one shape; writing into them writes into ``a``.

    Examples
    --------
    >>> here, there = shifted_views(np.arange(3).reshape(1, 1, 3), (0, 0, 1))
    >>> here.ravel().tolist(), there.ravel().tolist()
    ([0, 1], [1, 2])
    """
    src, dst = [], []
    for k, s in enumerate(d):
        n = a.shape[k]
        src.append(slice(max(0, -s), n - max(0, s)))
        dst.append(slice(max(0, s), n - max(0, -s)))
    return a[tuple(src)], a[tuple(dst)]


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
        a, b = shifted_views(ids, d)
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
