"""Step 4's slopes: a gradient of every field at every sample, linear in the values.

The gradients feed the ``hermite`` and ``monotone`` curve values of
:mod:`manifill.surface.curve_values`. Which neighbours a fit uses, its weights
and whether it is quadratic or linear depend on the positions and normals only,
so the gradients are a fixed linear map of the sample values.
"""

import numpy as np
import scipy.sparse as sp

from ..tolerances import TOL

__all__ = ["sample_gradients"]


def sample_gradients(V, normals, ends, idx, vals):
    """Gradient (in the tangent plane) of every field at every sample.

    A weighted least-squares fit at each sample to the samples within two
    steps of it in the curve network (its neighbours and theirs) whose normals
    lie within 45 degrees of its own, placed by their offsets projected onto its
    tangent plane, weights one over the offset's length: quadratic where eight
    or more are well spread (condition below ``1 / TOL.gradient_rcond``),
    linear (minimum-norm) with two to seven or where the quadratic fit is not,
    dropping a direction the neighbours barely span
    (``TOL.gradient_line_rcond``: two neighbours nearly in line with the
    sample would otherwise give a huge gradient across that line).
    The choice of fit and the pseudo-inverses' cut-offs look at the positions
    only: the result is linear in ``vals``. All fits with the same number of
    neighbours are solved as one batch, without padding (a Householder QR of the
    quadratic fits, an SVD of the linear ones).

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions (of about unit size: the fits' conditioning is judged
        on them).
    normals : (n, 3) numpy array
        Unit normals, needed at the samples.
    ends : (c, 2) numpy array of int
        The samples at the two ends of every path (which samples are neighbours).
    idx : (k,) int64 numpy array
        Sample vertices, sorted and unique.
    vals : (k, p) numpy array
        Sample values, one column per field.

    Returns
    -------
    grads : (k, 3, p) numpy array
        The gradient of every field at every sample (zero where unknown).
    known : (k,) bool numpy array
        The samples with two or more usable neighbours (a gradient).

    See Also
    --------
    manifill.surface.curve_values.curve_values : where the slopes are used.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]])
    >>> normals = np.tile([0., 0, 1], (5, 1))
    >>> ends = np.array([[0, 1], [0, 2], [0, 3], [0, 4]])
    >>> g, known = sample_gradients(V, normals, ends, np.arange(5), 2 * V[:, :1] - V[:, 1:2])
    >>> np.round(g[0, :2, 0], 12).tolist(), bool(known.all())
    ([2.0, -1.0], True)
    """
    k, p = vals.shape
    pos = np.searchsorted(idx, ends)
    A = sp.csr_array((np.ones(2 * len(pos)), (np.concatenate([pos[:, 0], pos[:, 1]]),
                                             np.concatenate([pos[:, 1], pos[:, 0]]))), shape=(k, k))
    A2 = sp.csr_array(A + A @ A)
    A2.sort_indices()
    rows = np.repeat(np.arange(k), np.diff(A2.indptr))
    off = A2.indices != rows
    # a neighbour whose surface turns away (normals more than 45 degrees apart) does not
    # sit in the tangent plane: leave it out of the fit
    nrm = normals[idx]
    off &= np.einsum("ij,ij->i", np.repeat(nrm, np.diff(A2.indptr), axis=0), nrm[A2.indices]) >= np.cos(np.pi / 4)
    rows, nbrs = rows[off], A2.indices[off].astype(np.int64)
    count = np.bincount(rows, minlength=k)
    # the fits on ragged arrays, no padding: the entries grouped by their sample's neighbour count
    # (each group a contiguous (samples, count) block, samples in order), one batch per count
    order = np.argsort(count[rows], kind="stable")
    rows, nbrs = rows[order], nbrs[order]
    # a tangent frame at every sample
    ref = np.where(np.abs(nrm[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    e1 = np.cross(nrm, ref)
    e1 /= np.maximum(np.linalg.norm(e1, axis=1, keepdims=True), TOL.tiny)
    e2 = np.cross(nrm, e1)
    Vs = V[idx]
    d = Vs[nbrs] - Vs[rows]
    d1 = np.einsum("ij,ij->i", d, e1[rows])
    d2 = np.einsum("ij,ij->i", d, e2[rows])
    y = vals[nbrs] - vals[rows]
    # offsets in units of each sample's mean neighbour distance: the quadratic fit's columns (lengths and squared
    # lengths) then keep their ratio whatever the mesh's units, and so does its conditioning test
    dist = np.hypot(d1, d2)
    h = np.bincount(rows, weights=dist, minlength=k) / np.maximum(count, 1)
    h = np.where(h > 0, h, 1.0)
    d1, d2 = d1 / h[rows], d2 / h[rows]
    w = 1.0 / np.maximum(dist / h[rows], TOL.tiny)
    coef = np.zeros((k, 2, p))
    done = np.zeros(k, dtype=bool)
    sizes = count[rows]
    cuts = np.flatnonzero(np.diff(sizes)) + 1
    for lo, hi in zip([0, *cuts.tolist()], [*cuts.tolist(), sizes.size]):
        c = int(sizes[lo]) if hi > lo else 0
        if c < 2:
            continue
        group = rows[lo:hi:c]
        D1, D2, W = (x[lo:hi].reshape(-1, c) for x in (d1, d2, w))
        Yw = y[lo:hi].reshape(-1, c, p) * W[..., None]
        if c >= 8:
            Q = np.stack([D1, D2, 0.5 * D1 ** 2, D1 * D2, 0.5 * D2 ** 2], axis=2)
            sol, good = _least_squares(Q * W[..., None], Yw, TOL.gradient_rcond)
            coef[group[good]] = sol[good, :2]
            done[group[good]] = True
            line = ~good
        else:
            line = np.ones(group.size, dtype=bool)
        if line.any():
            # minimum-norm when the neighbours line up: exact along that line (singular values at or
            # below gradient_line_rcond times the largest count as zero)
            U, S, Vt = np.linalg.svd(np.stack([D1[line], D2[line]], axis=2) * W[line][..., None], full_matrices=False)
            inv = np.where(S > TOL.gradient_line_rcond * S[:, :1], 1.0 / np.where(S > 0, S, 1.0), 0.0)
            coef[group[line]] = np.einsum("kji,kj,klj,klp->kip", Vt, inv, U, Yw[line])
            done[group[line]] = True
    coef /= h[:, None, None]  # back to the mesh's units
    grads = e1[:, :, None] * coef[:, None, 0, :] + e2[:, :, None] * coef[:, None, 1, :]
    return grads, done


def _least_squares(A, B, rcond):
    """Least-squares solutions of a stack of systems ``A x = B``, and which have condition below ``1 / rcond``.

    Householder QR of all the stack at once (``A`` is (s, c, q) with ``c >= q``), then
    back substitution in the triangle ``R``. The condition ``S_max / S_min`` of ``A``
    (that of ``R``) lies between ``b / q`` and ``b = |R|_F |R^-1|_F``: only where that
    interval straddles ``1 / rcond`` are the singular values computed.

    Returns
    -------
    x : (s, q, p) numpy array
        The solutions (meaningful where ``good``).
    good : (s,) bool numpy array
        ``S_min / rcond > S_max``: full rank, well enough conditioned.
    """
    s, c, q = A.shape
    A, B = A.copy(), B.copy()
    for j in range(q):
        v = A[:, j:, j].copy()
        norm = np.sqrt(np.einsum("ki,ki->k", v, v))
        v[:, 0] += np.where(v[:, 0] >= 0, norm, -norm)
        vv = np.einsum("ki,ki->k", v, v)
        v *= np.sqrt(np.divide(2.0, vv, out=np.zeros_like(vv), where=vv > 0))[:, None]
        A[:, j:, j:] -= v[:, :, None] * np.einsum("ki,kij->kj", v, A[:, j:, j:])[:, None, :]
        B[:, j:] -= v[:, :, None] * np.einsum("ki,kip->kp", v, B[:, j:])[:, None, :]
    R, x = np.triu(A[:, :q]), B[:, :q]
    Rinv = np.zeros((s, q, q))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for i in range(q - 1, -1, -1):
            x[:, i] = (x[:, i] - np.einsum("kj,kjp->kp", R[:, i, i + 1:], x[:, i + 1:])) / R[:, i, i, None]
            Rinv[:, i] = -np.einsum("kj,kjm->km", R[:, i, i + 1:], Rinv[:, i + 1:])
            Rinv[:, i, i] += 1.0
            Rinv[:, i] /= R[:, i, i, None]
        bound = np.sqrt(np.einsum("kij,kij->k", R, R) * np.einsum("kij,kij->k", Rinv, Rinv))
    limit = 1.0 / rcond
    good = bound < limit * (1 - 1e-6)
    unsure = ~good & ~(bound > q * limit * (1 + 1e-6))
    if unsure.any():
        S = np.linalg.svd(R[unsure], compute_uv=False)
        good[unsure] = S[:, -1] * limit > S[:, 0]
    return x, good
