"""Square roots of stiffness matrices: ``B`` with ``B' B = L``, for drawing Gaussian fields.

A Gaussian field with precision ``Q = B' B`` is sampled without a Cholesky factor by
solving ``Q x = B' w`` with white noise ``w`` (the covariance is ``Q^-1 B' B Q^-1 =
Q^-1``), and conditional samples are the same solve with the constraints kept
(:mod:`manifill.linalg.gaussian`). Two roots of a Laplacian:

- :func:`edge_root`: one row per edge, ``sqrt(w_ij) (e_i - e_j)``, for any Laplacian
  whose edge weights are all ``>= 0`` (uniform, intrinsic Delaunay, robust, voxels, a
  cotangent Laplacian without obtuse pairs);
- :func:`gradient_root`: the finite-element gradient, three rows per triangle,
  ``sqrt(area) grad(phi_j)`` (the cotangent stiffness is exactly ``sum_t area_t
  grad(phi_i) . grad(phi_j)``), for cotangent weights of either sign.
"""

import numpy as np
import scipy.sparse as sp

from .gradients import gradient_operator

__all__ = ["edge_root", "gradient_root", "laplacian_root"]


def edge_root(L):
    """``B`` (one row per edge) with ``B' B = L``, or None where an edge weight is negative.

    Parameters
    ----------
    L : (n, n) scipy sparse matrix
        Symmetric, zero row sums (a Laplacian ``D - W``).

    Returns
    -------
    (e, n) scipy.sparse.csr_array or None

    Examples
    --------
    >>> L = sp.csr_array(np.array([[1.0, -1, 0], [-1, 2, -1], [0, -1, 1]]))
    >>> B = edge_root(L)
    >>> bool(np.allclose((B.T @ B).toarray(), L.toarray()))
    True
    """
    U = sp.triu(sp.coo_array(L), k=1).tocoo()
    w = -U.data
    if np.any(w < 0):
        return None
    keep = w > 0
    i, j, s = U.row[keep], U.col[keep], np.sqrt(w[keep])
    e = np.arange(s.size)
    n = L.shape[0]
    return sp.csr_array((np.concatenate([s, -s]), (np.concatenate([e, e]), np.concatenate([i, j]))),
                        shape=(s.size, n))


def gradient_root(V, F):
    """``B`` (three rows per triangle) with ``B' B`` the cotangent stiffness of ``(V, F)``.

    Row ``3t + c`` holds coordinate ``c`` of ``sqrt(area_t) grad(phi_j)`` on triangle ``t``;
    ``x' B' B x`` is the Dirichlet energy ``sum_t area_t |grad x|^2`` of the linear
    interpolant, i.e. ``x' L x`` with ``L = manifill.mesh.laplacian.laplacian(V, F)``.

    Parameters
    ----------
    V : (n, 2) or (n, 3) numpy array
    F : (m, 3) int numpy array
        Triangles with positive area (zero-area triangles contribute no rows' worth).

    Returns
    -------
    (3m, n) scipy.sparse.csr_array

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> from manifill.mesh.laplacian import laplacian
    >>> V, F = icosphere(1)
    >>> B = gradient_root(V, F)
    >>> bool(abs(B.T @ B - laplacian(V, F)).max() < 1e-12)
    True
    """
    G, area = gradient_operator(V, F)
    return sp.csr_array(sp.diags_array(np.repeat(np.sqrt(area), 3)) @ G)


def laplacian_root(L, V=None, F=None):
    """A root of ``L``: :func:`edge_root` where its weights allow, else :func:`gradient_root` of ``(V, F)``.

    Returns
    -------
    scipy.sparse.csr_array or None
        None when the weights are of both signs and no triangles are given.
    """
    B = edge_root(L)
    if B is None and F is not None:
        B = gradient_root(V, F)
    return B
