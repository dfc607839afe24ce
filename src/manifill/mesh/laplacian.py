"""Discrete Laplacians of a triangle mesh (uniform, cotangent, intrinsic Delaunay, robust) and its mass matrix.

The tetrahedral stiffness and mass are :mod:`manifill.mesh.tetmesh`'s; :func:`mass_matrix` serves both.

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

import warnings
from typing import Literal

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike

from ..errors import OptionError
from ..tolerances import TOL
from ..validate import as_mesh, check_option, scale_and_diagonal
from .edges import EdgeIndex
from .geometry import AREAS, cotangents, vertex_areas
from .tetmesh import cell_width, tet_mass_matrix

__all__ = ["laplacian", "mass_matrix", "WEIGHTS", "MASS"]

WEIGHTS = ("uniform", "cotan", "intrinsic", "robust")

#: The lumped mass matrices :func:`mass_matrix` builds (keyword ``mass``; the first is the default everywhere:
#: :func:`mass_matrix`, :func:`manifill.biharmonic`, :class:`manifill.PolyharmonicSolver`).
MASS = AREAS


def _normalised(V):
    """Positions centred and scaled to unit bounding-box diagonal (conditioning).

    Positions far outside unit size are first divided by a power of two (exact), so
    that neither the mean nor the diagonal overflows or underflows.
    """
    s, diag = scale_and_diagonal(V)  # diag in units of s
    if s != 1.0:
        V = V * (1.0 / s)
    return (V - V.mean(axis=0)) / (diag if diag > 0 else 1.0)


def _assemble(V, F, n, weights, index=None):
    """``D - W`` for ``uniform`` or ``cotan`` weights on the mesh's edge index.

    The weights are summed per edge and placed straight into the CSR layout of
    :class:`~manifill.mesh.edges.EdgeIndex`; every edge stays stored, zero weights
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


def laplacian(V: ArrayLike, F: ArrayLike, *,
              weights: Literal["uniform", "cotan", "intrinsic", "robust"] = "cotan") -> sp.csr_array:
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

    ``index`` (an :class:`~manifill.mesh.edges.EdgeIndex` of ``F``) is reused when given.
    """
    n = len(V)
    if weights in ("intrinsic", "robust"):
        return _robust(_normalised(V), F, 0.0 if weights == "intrinsic" else TOL.robust_mollify)
    return _assemble(_normalised(V), F, n, weights, index)


def mass_matrix(V: ArrayLike, F: ArrayLike, *, mass: Literal["barycentric", "voronoi"] | None = None,
                kind: Literal["barycentric", "voronoi"] | None = None) -> sp.csr_array:
    """The lumped (diagonal) mass matrix ``M`` of a triangle or tetrahedral mesh: the area or volume of each vertex.

    With the stiffness matrix :func:`laplacian` (``weights='cotan'``) it makes the
    linear finite elements: ``L x = M f`` is the Poisson problem, ``x' M x`` the
    squared L2 norm of a field, ``M^-1 L`` the pointwise Laplace-Beltrami operator.

    Parameters
    ----------
    V : (n, 3) or (n, 2) array_like
        Vertex positions.
    F : (m, 3) or (m, 4) array_like of int
        Triangles, or tetrahedra (told apart by the width, as
        :func:`manifill.harmonic` does), any integer dtype; zero-area faces are
        allowed (they weigh nothing).
    mass : {None, 'voronoi', 'barycentric'}, optional
        The mixed Voronoi area (see :func:`manifill.mesh.geometry.vertex_areas`),
        or one third of every incident triangle's area. None (the default, as
        libigl's ``massmatrix``): Voronoi on triangles; tetrahedra have the
        barycentric mass alone (a quarter of every incident tet's volume,
        :func:`manifill.mesh.tetmesh.tet_mass_matrix`).
    kind : {'barycentric', 'voronoi'}, optional
        The old name of ``mass``: still accepted for one release, with a
        ``DeprecationWarning``.

    Returns
    -------
    (n, n) scipy.sparse.csr_array
        Diagonal, non-negative, summing to the total area; it scales as ``s**2``
        when ``V`` scales by ``s``, at any scale (computed on positions of unit
        size), and a vertex used by no face gets a stored 0.

    Raises
    ------
    MeshError
        If ``(V, F)`` is malformed (see :func:`manifill.validate.as_mesh`).
    OptionError
        If ``mass`` is not one of the names above, ``'voronoi'`` for tetrahedra, or
        ``kind`` and ``mass`` disagree.

    See Also
    --------
    laplacian : the stiffness matrix.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    >>> M = mass_matrix(V, np.array([[0, 1, 2], [1, 3, 2]]), mass="barycentric")
    >>> (M.diagonal() * 6).tolist(), round(float(M.sum()), 12)
    ([1.0, 2.0, 2.0, 1.0], 1.0)
    >>> (mass_matrix(V[[0, 1, 2]] + [0, 0, 1], [[0, 1, 2]], mass="voronoi").diagonal() * 8).tolist()
    [2.0, 1.0, 1.0]
    """
    mass = _mass_name(mass, kind)
    tets = cell_width(F) == 4
    mass = ("barycentric" if tets else "voronoi") if mass is None else mass
    check_option("mass", mass, MASS)
    if tets:
        if mass != "barycentric":
            raise OptionError(f"mass={mass!r} is for triangles; tetrahedra have the barycentric mass alone (a "
                              f"quarter volume per corner): pass mass='barycentric'")
        return tet_mass_matrix(V, F)
    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    n = len(V)
    ramp = np.arange(n + 1, dtype=np.int32 if n < 2**31 - 1 else np.int64)
    M = sp.csr_array((vertex_areas(V, F, kind=mass), ramp[:-1], ramp), shape=(n, n))
    M.has_sorted_indices = True
    return M


def _mass_name(mass, kind):
    """``mass``, or the old keyword ``kind`` when it is given (with a ``DeprecationWarning``)."""
    if kind is None:
        return mass
    warnings.warn("mass_matrix(kind=...) is now mass_matrix(mass=...); kind will be removed in the next release",
                  DeprecationWarning, stacklevel=3)
    if mass is not None and mass != kind:
        raise OptionError(f"kind={kind!r} and mass={mass!r} disagree; pass mass alone (kind is its old name)")
    return kind
