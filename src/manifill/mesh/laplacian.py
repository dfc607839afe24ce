"""Discrete Laplacians of a triangle mesh: uniform, cotangent, intrinsic Delaunay, robust.

All are returned as the symmetric positive semi-definite matrix ``L = D - W`` with
``(L x)_i = sum_j w_ij (x_i - x_j)``: a function is discretely harmonic at ``i``
exactly when ``(L x)_i = 0``, i.e. when ``x_i`` is the ``w``-weighted average of its
neighbours. Constants are in the null space of every one of them.

Which weights when
------------------
``uniform``
    ``w_ij = 1`` on every edge: the paper's "average of the adjacent vertices".
    Never negative, so the maximum principle always holds; ignores geometry, so it
    reproduces linear functions only on regular grids.
``cotan``
    ``w_ij = (cot a_ij + cot b_ij) / 2``, the angles opposite the edge: the
    standard finite-element Laplacian, exact for linear functions on any flat
    mesh. A weight turns negative where the two opposite angles sum to more than
    pi (obtuse triangles), and the maximum principle can then fail.
``intrinsic``
    Cotangent weights of the intrinsic Delaunay triangulation of the same
    surface (Bobenko-Springborn; computed by the ``robust-laplacian`` package
    with no mollification). Never negative on a manifold mesh, so the maximum
    principle holds on any mesh; equal to ``cotan`` where the mesh is already
    Delaunay. Its sparsity can include flipped edges between vertices that are
    not neighbours in ``F``.
``robust``
    The tufted-cover Laplacian of Sharp and Crane (the ``robust-laplacian``
    package, default mollification): for non-manifold meshes and near-degenerate
    triangles.
"""

import numpy as np
import scipy.sparse as sp

from .topology import EdgeIndex
from ..validate import scale_and_diagonal, as_mesh, check_option

__all__ = ["laplacian", "cotangents", "WEIGHTS"]

WEIGHTS = ("uniform", "cotan", "intrinsic", "robust")


def _normalised(V):
    """Positions centred and scaled to unit bounding-box diagonal (conditioning).

    Positions far outside unit size are first divided by a power of two (exact), so
    that neither the mean nor the diagonal overflows or underflows.
    """
    s, diag = scale_and_diagonal(V)  # diag in units of s
    if s != 1.0:
        V = V * (1.0 / s)
    return (V - V.mean(axis=0)) / (diag if diag > 0 else 1.0)


def cotangents(V, F):
    """Half cotangents of the angles of every triangle.

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions.
    F : (m, 3) numpy array of int
        Triangles.

    Returns
    -------
    (m, 3) numpy array
        Column ``k`` is ``cot(angle at corner k) / 2``: the weight that face
        gives to the edge opposite corner ``k``. Zero for a zero-area face.

    Examples
    --------
    >>> C = cotangents(np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    >>> (np.round(C, 12) + 0.0).tolist()
    [[0.0, 0.5, 0.5]]
    """
    x, y, z = (np.ascontiguousarray(V[:, k]) for k in range(3))
    i0, i1, i2 = (np.ascontiguousarray(F[:, k]) for k in range(3))
    # edge vectors opposite each corner: e0 = v2 - v1, e1 = v0 - v2, e2 = v1 - v0
    def opposite(c):
        """The three edge vectors' components along one axis, each corner gathered once."""
        c0, c1, c2 = c[i0], c[i1], c[i2]
        return [c2 - c1, c0 - c2, c1 - c0]

    ex, ey, ez = opposite(x), opposite(y), opposite(z)
    cx = ey[0] * ez[1] - ez[0] * ey[1]
    cy = ez[0] * ex[1] - ex[0] * ez[1]
    cz = ex[0] * ey[1] - ey[0] * ex[1]
    dbl = np.sqrt(cx * cx + cy * cy + cz * cz)
    inv = np.divide(0.5, dbl, out=np.zeros_like(dbl), where=dbl > 0)
    C = np.empty((len(F), 3))
    for k in range(3):
        a, b = (k + 1) % 3, (k + 2) % 3
        # angle at corner k lies between edges -e_b (towards b's far end) and e_a
        C[:, k] = -(ex[a] * ex[b] + ey[a] * ey[b] + ez[a] * ez[b]) * inv
    return C


def _assemble(V, F, n, weights, index=None):
    """``D - W`` for ``uniform`` or ``cotan`` weights on the mesh's edge index.

    The weights are summed per edge and placed straight into the CSR layout of
    :class:`~manifill.mesh.topology.EdgeIndex`; every edge stays stored, zero weights
    included, so the pattern is the mesh graph plus the diagonal.
    """
    index = EdgeIndex(F, n) if index is None else index
    if weights == "uniform":
        w = np.ones(len(index))  # every edge counts once, however many faces share it
    else:
        w = index.per_edge(cotangents(V, F))
    return index.matrix(-w, diagonal=index.degree(w))


def _robust(V, F, mollify):
    try:
        import robust_laplacian
    except ImportError:
        raise ImportError(
            "weights='intrinsic' and 'robust' need the robust-laplacian package: "
            "pip install 'manifill[robust]'"
        ) from None
    L, _ = robust_laplacian.mesh_laplacian(np.ascontiguousarray(V), np.ascontiguousarray(F), mollify_factor=mollify)
    L = sp.csr_array(L)
    L.sum_duplicates()
    L.sort_indices()
    return L


def laplacian(V, F, *, weights="cotan"):
    """Symmetric positive semi-definite Laplacian ``L = D - W`` of a triangle mesh.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles, any integer dtype.
    weights : {'cotan', 'uniform', 'intrinsic', 'robust'}, optional
        Edge weights; see the module docstring for which one when.

    Returns
    -------
    (n, n) scipy.sparse.csr_array
        ``L`` with sorted indices. For ``uniform`` and ``cotan`` its sparsity is
        exactly the mesh graph plus the diagonal (zero weights stay stored), so
        the connected components of its pattern are those of the mesh.

    Raises
    ------
    MeshError
        If ``(V, F)`` is malformed (see :func:`manifill.validate.as_mesh`).
    OptionError
        If ``weights`` is not one of the names above.

    See Also
    --------
    manifill.harmonic : solves ``L x = 0`` with fixed values.

    Notes
    -----
    Positions are centred and scaled to a unit bounding-box diagonal before the
    weights are computed, so the result does not depend on units or on a far
    origin (cotangent weights are scale-invariant anyway).

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> L = laplacian(V, np.array([[0, 1, 2]]), weights="uniform")
    >>> L.toarray().tolist()
    [[2.0, -1.0, -1.0], [-1.0, 2.0, -1.0], [-1.0, -1.0, 2.0]]
    """
    check_option("weights", weights, WEIGHTS)
    V, F = as_mesh(V, F, allow_degenerate=weights in ("uniform", "robust"), allow_unreferenced=True)
    return assemble_laplacian(V, F, weights)


def assemble_laplacian(V, F, weights, index=None):
    """:func:`laplacian` on arrays that have passed :func:`~manifill.validate.as_mesh`.

    ``index`` (an :class:`~manifill.mesh.topology.EdgeIndex` of ``F``) is reused when given.
    """
    n = len(V)
    if weights in ("intrinsic", "robust"):
        return _robust(_normalised(V), F, 0.0 if weights == "intrinsic" else 1e-5)
    return _assemble(_normalised(V), F, n, weights, index)
