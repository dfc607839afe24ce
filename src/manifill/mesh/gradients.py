"""Gradients of piecewise-linear fields: per triangle, per tetrahedron, per vertex; and on voxel grids.

A field ``x`` at the vertices of a triangle mesh is linear on each triangle; its gradient there is
``sum_i x_i grad(phi_i)`` with ``grad(phi_i) = (n x e_i) / (2 area)``, ``n`` the unit normal and ``e_i`` the edge
opposite vertex ``i`` (counter-clockwise): :func:`gradient_operator` is that map as a sparse ``(3m, n)`` matrix
(row ``3t + c``: coordinate ``c`` on triangle ``t``), the same as libigl's ``grad``. On tetrahedra the gradient
solves ``[v1 - v0, v2 - v0, v3 - v0] g = [x1 - x0, x2 - x0, x3 - x0]`` (:func:`tet_gradient_operator`). Both are
exact for linear fields.

Per vertex, :func:`vertex_gradients` averages the gradients of the cells around it weighted by their areas (or
volumes) and, on a surface, keeps the part tangent to the surface (the vertex normal's plane): on a
sphere the error falls with the edge length. On a voxel grid, :func:`grid_gradients` takes central differences
where both neighbours are in the solid and one-sided ones at its wall (exact for linear fields too).

The :mod:`manifill.mesh.roots` scale these operators by the square roots of the cells' measures.
"""

import numpy as np
import scipy.sparse as sp

from ..validate.scale import unit_scale

__all__ = ["gradient_operator", "tet_gradient_operator", "cell_gradients", "vertex_gradients", "grid_gradients"]


def _assemble(cells, coeffs, n):
    """The ``(3m, n)`` matrix with ``coeffs[k]`` ((m, 3)) in the three rows of cell ``t`` and column ``cells[t, k]``.

    Built as CSR directly (``k`` entries per row, in the cell's order): a COO matrix summed over duplicates took
    three times libigl's ``grad`` at 655k vertices.
    """
    m, k = cells.shape
    it = np.int32 if max(3 * m * k, n) < 2**31 - 1 else np.int64  # scipy's own index type: no conversion
    indices = np.repeat(cells.astype(it, copy=False), 3, axis=0).ravel()
    data = np.stack(coeffs, axis=-1).ravel()  # (m, 3, k): row 3t + c, entry k
    indptr = np.arange(0, 3 * m * k + 1, k, dtype=it)
    return sp.csr_array((data, indices, indptr), shape=(3 * m, n))


def _cross(a, b):
    """Row-wise cross products of (m, 3) arrays (np.cross is several times slower on many short rows)."""
    return np.column_stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1], a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                            a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]])


def gradient_operator(V, F):
    """``(G, area)``: the ``(3m, n)`` gradient of linear fields on the triangles, and the triangles' areas.

    Triangles of zero area get zero rows (their gradient is undefined).

    Examples
    --------
    >>> V = np.array([[0.0, 0, 0], [2, 0, 0], [0, 1, 0]])
    >>> G, area = gradient_operator(V, [[0, 1, 2]])
    >>> (G @ np.array([1.0, 3.0, 4.0])).tolist(), area.tolist()  # x = 1 + x + 3 y
    ([1.0, 3.0, 0.0], [1.0])
    """
    V = np.asarray(V, dtype=np.float64)
    if V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    F = np.asarray(F, dtype=np.int64)
    s = unit_scale(V)  # a power of two: on V / s the products neither overflow nor underflow, and are exact
    V = V if s == 1.0 else V * (1.0 / s)
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    N = _cross(b - a, c - a)
    dbl = np.linalg.norm(N, axis=1)  # twice the area
    ok = dbl > 0
    unit = np.zeros_like(N)
    unit[ok] = N[ok] / dbl[ok, None]
    inv = np.zeros_like(dbl)
    inv[ok] = 1.0 / dbl[ok]
    coeffs = [_cross(unit, e) * (inv / s)[:, None] for e in (c - b, a - c, b - a)]
    return _assemble(F, coeffs, len(V)), (0.5 * dbl * s) * s


def tet_gradient_operator(V, T):
    """``(G, volume)``: the ``(3m, n)`` gradient of linear fields on the tetrahedra (either orientation), and
    their volumes; zero rows for tets of zero volume.

    Examples
    --------
    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> G, vol = tet_gradient_operator(V, [[0, 1, 2, 3]])
    >>> (G @ (V @ [2.0, -1.0, 0.5])).tolist(), round(float(vol[0]), 6)
    ([2.0, -1.0, 0.5], 0.166667)
    """
    V = np.asarray(V, dtype=np.float64)
    T = np.asarray(T, dtype=np.int64)
    a = V[T[:, 0]]
    e1, e2, e3 = V[T[:, 1]] - a, V[T[:, 2]] - a, V[T[:, 3]] - a
    c = [None, _cross(e2, e3), _cross(e3, e1), _cross(e1, e2)]
    c[0] = -(c[1] + c[2] + c[3])
    det = np.einsum("ij,ij->i", e1, c[1])  # six times the signed volume
    inv = np.zeros_like(det)
    inv[det != 0] = 1.0 / det[det != 0]
    return _assemble(T, [ck * inv[:, None] for ck in c], len(V)), np.abs(det) / 6.0


def cell_gradients(G, X):
    """The gradient on every cell: ``(m, 3)`` for a field ``(n,)``, ``(m, p, 3)`` for fields ``(n, p)``."""
    X = np.asarray(X, dtype=np.float64)
    Y = G @ X.reshape(len(X), -1)
    out = np.moveaxis(Y.reshape(G.shape[0] // 3, 3, -1), 1, -1)  # (m, p, 3)
    return out[:, 0, :] if X.ndim == 1 else out


def vertex_gradients(cells, measure, grads, n, normals=None):
    """Per vertex: the gradients of its cells weighted by their measures (areas or volumes).

    Parameters
    ----------
    cells : (m, k) int array
    measure : (m,) array
    grads : (m, 3) or (m, p, 3) array
        :func:`cell_gradients`.
    n : int
        Vertices.
    normals : (n, 3) array, optional
        Unit vertex normals (surfaces: e.g. the area-weighted ones of
        :func:`manifill.surface.curve_values.vertex_normals`): the average is projected onto their planes, so that
        the vertex gradient is tangent to the surface.

    Returns
    -------
    (n, 3) or (n, p, 3) array
        NaN at vertices in no cell of positive measure.
    """
    cells = np.asarray(cells, dtype=np.int64)
    k = cells.shape[1]
    W = sp.csr_array((np.repeat(measure, k), (cells.ravel(), np.repeat(np.arange(len(cells)), k))),
                     shape=(n, len(cells)))
    total = np.asarray(W.sum(axis=1)).ravel()
    flat = grads.reshape(len(cells), -1)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = (W @ flat) / total[:, None]
        out = out.reshape((n,) + grads.shape[1:])
        if normals is not None:
            Nb = normals if grads.ndim == 2 else normals[:, None, :]
            out = out - np.sum(out * Nb, axis=-1, keepdims=True) * Nb
    out[total <= 0] = np.nan
    return out


def grid_gradients(values, mask, spacing):
    """The gradient at every voxel of ``mask`` (NaN outside): central differences inside, one-sided at the wall,
    NaN along an axis where a voxel has no neighbour in the solid.

    Parameters
    ----------
    values : (n0, n1, n2) or (n0, n1, n2, p) array
    mask : (n0, n1, n2) bool array
    spacing : (3,) array

    Returns
    -------
    values' shape plus a last axis of 3
    """
    values = np.asarray(values, dtype=np.float64)
    out = np.full(values.shape + (3,), np.nan)
    for axis in range(3):
        h = float(spacing[axis])
        fwd = np.zeros_like(mask)
        bwd = np.zeros_like(mask)
        sl = [slice(None)] * 3
        sl_hi, sl_lo = list(sl), list(sl)
        sl_hi[axis], sl_lo[axis] = slice(1, None), slice(None, -1)
        fwd[tuple(sl_lo)] = mask[tuple(sl_hi)]  # the next voxel along the axis is in the solid
        bwd[tuple(sl_hi)] = mask[tuple(sl_lo)]
        fwd &= mask
        bwd &= mask
        nxt = np.roll(values, -1, axis=axis)
        prv = np.roll(values, 1, axis=axis)
        g = np.full(values.shape, np.nan)
        both, only_f, only_b = fwd & bwd, fwd & ~bwd, bwd & ~fwd
        for sel, d in ((both, (nxt - prv) / (2 * h)), (only_f, (nxt - values) / h), (only_b, (values - prv) / h)):
            g[sel] = d[sel]
        out[..., axis] = g
    out[~mask] = np.nan
    return out
