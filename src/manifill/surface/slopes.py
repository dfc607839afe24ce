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
    or more are well spread (all such fits in one batched SVD), linear
    (minimum-norm) with two to seven, dropping a direction the neighbours
    barely span (``TOL.gradient_line_rcond``: two neighbours nearly in line
    with the sample would otherwise give a huge gradient across that line).
    The choice of fit and the pseudo-inverses' cut-offs look at the positions
    only: the result is linear in ``vals``.

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
    off &= np.einsum("ij,ij->i", nrm[rows], nrm[A2.indices]) >= np.cos(np.pi / 4)
    rows, nbrs = rows[off], A2.indices[off].astype(np.int64)
    count = np.bincount(rows, minlength=k)
    start = np.concatenate([[0], np.cumsum(count)])
    slot = np.arange(rows.size) - start[rows]
    # a tangent frame at every sample
    ref = np.where(np.abs(nrm[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    e1 = np.cross(nrm, ref)
    e1 /= np.maximum(np.linalg.norm(e1, axis=1, keepdims=True), TOL.tiny)
    e2 = np.cross(nrm, e1)
    m = int(count.max()) if k else 0
    d = V[idx[nbrs]] - V[idx[rows]]
    D = np.zeros((k, m, 2))
    D[rows, slot, 0] = np.einsum("ij,ij->i", d, e1[rows])
    D[rows, slot, 1] = np.einsum("ij,ij->i", d, e2[rows])
    Y = np.zeros((k, m, p))
    Y[rows, slot] = vals[nbrs] - vals[rows]
    w = np.zeros((k, m))
    w[rows, slot] = 1.0 / np.maximum(np.hypot(D[rows, slot, 0], D[rows, slot, 1]), TOL.tiny)
    coef = np.zeros((k, 2, p))
    done = np.zeros(k, dtype=bool)
    quad = np.flatnonzero(count >= 8)
    if quad.size:
        Dq = D[quad]
        Q = np.concatenate([Dq, 0.5 * Dq[..., :1] ** 2, Dq[..., :1] * Dq[..., 1:], 0.5 * Dq[..., 1:] ** 2], axis=2)
        Qw = Q * w[quad][..., None]
        U, S, Vt = np.linalg.svd(Qw, full_matrices=False)
        good = S[:, -1] * (1 / TOL.gradient_rcond) > S[:, 0]
        sol = np.einsum("kji,kj,klj,klp->kip", Vt, 1.0 / np.where(S > 0, S, np.inf), U, Y[quad] * w[quad][..., None])
        coef[quad[good]] = sol[good, :2]
        done[quad[good]] = True
    for i in np.flatnonzero(~done & (count >= 2)):
        c = count[i]
        # minimum-norm when the neighbours line up: exact along that line
        coef[i] = np.linalg.lstsq(D[i, :c] * w[i, :c, None], Y[i, :c] * w[i, :c, None],
                                  rcond=TOL.gradient_line_rcond)[0]
        done[i] = True
    grads = e1[:, :, None] * coef[:, None, 0, :] + e2[:, :, None] * coef[:, None, 1, :]
    return grads, done
