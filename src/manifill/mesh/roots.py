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
    V = np.asarray(V, dtype=np.float64)
    if V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    F = np.asarray(F, dtype=np.int64)
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    N = np.cross(b - a, c - a)
    dbl = np.linalg.norm(N, axis=1)  # twice the area
    ok = dbl > 0
    unit = np.zeros_like(N)
    unit[ok] = N[ok] / dbl[ok, None]
    # grad(phi_i) = (n x e_i) / (2 area), e_i the edge opposite vertex i, oriented
    grads = [np.cross(unit, c - b), np.cross(unit, a - c), np.cross(unit, b - a)]
    scale = np.zeros_like(dbl)
    scale[ok] = 1.0 / np.sqrt(2.0 * dbl[ok])  # sqrt(area) / (2 area), with dbl = 2 area
    m = len(F)
    rows = (3 * np.arange(m)[:, None] + np.arange(3)[None, :])  # (m, 3): the three coordinates
    R, C, D = [], [], []
    for v in range(3):
        g = grads[v] * scale[:, None]
        R.append(rows.ravel())
        C.append(np.repeat(F[:, v], 3))
        D.append(g.ravel())
    B = sp.csr_array((np.concatenate(D), (np.concatenate(R), np.concatenate(C))), shape=(3 * m, len(V)))
    B.sum_duplicates()
    return B


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
