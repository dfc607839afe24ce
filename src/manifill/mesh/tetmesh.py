"""Tetrahedral meshes ``(V, T)`` as arrays: signed volumes, the P1 stiffness, the lumped mass, the gradient root.

The volume counterpart of :mod:`manifill.mesh.laplacian` (and of
:func:`manifill.mesh.roots.gradient_root`): a solid ``(V, T)``, ``T`` an ``(m, 4)``
array of tetrahedra, has the same kind of Laplacian ``L = D - W``, so
:func:`manifill.harmonic`, :func:`manifill.biharmonic` and
:meth:`manifill.HarmonicSolver.from_laplacian` fill a solid as they fill a surface.
The solid's own arithmetic (boundary faces and vertices, the volume a closed surface
encloses) is :mod:`manifill.solid.tets`.

Which weights when
------------------
``cotan``
    The P1 finite-element stiffness matrix ``K_ij = integral grad phi_i . grad phi_j``:
    ``w_ij = sum over the tets on edge ij of l_kl cot(theta_kl) / 6``, with ``l_kl``
    the length of the opposite edge and ``theta_kl`` the dihedral angle there.
    Exact for linear functions on any tet mesh. Weights can be negative (obtuse
    dihedral angles), and then the maximum principle can fail.
``uniform``
    ``w_ij = 1`` on every tet edge: never negative, so the maximum principle holds;
    reproduces linear functions only on symmetric grids.

Unlike the 2D cotangent Laplacian, the 3D stiffness has units of length: scaling
``V`` by ``s`` scales ``L`` by ``s`` (the harmonic solution does not change).

Orientations are computed on the positions divided by
:func:`~manifill.validate.unit_scale` (a power of two, exact), so solids of size
``1e-150`` or ``1e150``, whose tet volumes underflow or overflow, are oriented like
unit ones.
"""

import numpy as np
import scipy.sparse as sp

from ..errors import MeshError
from ..deprecation import renamed
from ..validate import as_tets, bbox_diagonal, check_option, unit_scale
from .edges import EdgeIndex
from .gradients import tet_gradient_operator

__all__ = ["TET_WEIGHTS", "cell_width", "tet_laplacian", "assemble_tet_laplacian", "tet_mass_matrix",
           "tet_gradient_root", "tet_volumes", "negative_tets"]

#: Stiffness weights of tetrahedra.
TET_WEIGHTS = ("cotan", "uniform")

#: Public names renamed, kept one release with a warning (:mod:`manifill.deprecation`).
__getattr__ = renamed(__name__, {"WEIGHTS": "manifill.mesh.tetmesh:TET_WEIGHTS"})

#: The corner pairs of a tet's six edges, in the column order used below.
_PAIRS = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))


def cell_width(F, what="F"):
    """3 for triangles, 4 for tetrahedra: how the functions that take either tell them apart.

    Parameters
    ----------
    F : (m, 3) or (m, 4) array_like of int
        Triangles or tetrahedra (libigl's one ``harmonic`` reads the width the same way).
    what : str, optional
        The argument's name, for the message.

    Returns
    -------
    int
        3 or 4; also 3 for anything not two-dimensional, which the triangle
        validation (:func:`manifill.validate.as_mesh`) then names.

    Raises
    ------
    MeshError
        A two-dimensional ``F`` of another width.

    Examples
    --------
    >>> cell_width([[0, 1, 2, 3]]), cell_width(np.zeros((0, 3), dtype=int))
    (4, 3)
    >>> cell_width([[0, 1]])
    Traceback (most recent call last):
    ...
    manifill.errors.MeshError: F has shape (1, 2); pass triangles (m, 3) or tetrahedra (m, 4)
    """
    try:
        shape = np.shape(F)
    except ValueError:  # ragged rows: the triangle validation names them
        return 3
    if len(shape) != 2:
        return 3
    if shape[1] not in (3, 4):
        raise MeshError(f"{what} has shape {shape}; pass triangles (m, 3) or tetrahedra (m, 4)")
    return int(shape[1])


def _volumes(V, T):
    """Signed volumes of validated arrays: positive when ``(b-a, c-a, d-a)`` is right-handed."""
    a = V[T[:, 0]]
    return np.einsum("ij,ij->i", np.cross(V[T[:, 1]] - a, V[T[:, 2]] - a), V[T[:, 3]] - a) / 6.0


def negative_tets(V, T):
    """Which tets are negatively oriented, at any scale (the volumes of ``V / unit_scale(V)``).

    Parameters
    ----------
    V : (n, 3) float64 numpy array
    T : (m, 4) int64 numpy array
        As :func:`manifill.validate.as_tets` returns them (not checked here).

    Returns
    -------
    (m,) bool numpy array
        ``tet_volumes(V, T) < 0``, also where those volumes would underflow.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]) * 1e-150
    >>> negative_tets(V, np.array([[0, 1, 2, 3], [1, 0, 2, 3]])).tolist()
    [False, True]
    """
    return _volumes(V / unit_scale(V), T) < 0


def tet_volumes(V, T):
    """Signed volume of every tetrahedron.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    T : (m, 4) array_like of int
        Tetrahedra ``(a, b, c, d)``.

    Returns
    -------
    (m,) numpy array
        ``det(b - a, c - a, d - a) / 6``: positive when ``d`` lies on the side of
        the triangle ``(a, b, c)`` that its right-hand normal points to.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> (tet_volumes(V, [[0, 1, 2, 3], [1, 0, 2, 3]]) * 6).tolist()
    [1.0, -1.0]
    """
    V, T = as_tets(V, T, allow_degenerate=True, allow_unreferenced=True)
    return _volumes(V, T)


def _edge_index(T, n):
    """The edges of the tets and, per tet, the edge id of its pairs 01, 02, 03, 12, 13, 23: ``(index, (m, 6))``.

    Three faces per tet cover its six edges, so :class:`~manifill.mesh.edges.EdgeIndex`
    of those triangles has exactly the tet edge graph.
    """
    m = len(T)
    index = EdgeIndex(np.concatenate([T[:, [0, 1, 2]], T[:, [0, 1, 3]], T[:, [0, 2, 3]]]), n)
    fe = index.face_edges  # column k: the edge opposite corner k of the triangle
    A, B, C = fe[:m], fe[m:2 * m], fe[2 * m:]
    return index, np.column_stack([A[:, 2], A[:, 1], B[:, 1], A[:, 0], B[:, 0], C[:, 0]])


def _stiffness_weights(V, T):
    """Off-diagonal weights ``w_ij = -K_ij`` of every tet, for the pairs 01, 02, 03, 12, 13, 23: (m, 6).

    With ``e_k = v_k - v_0`` the gradient of the barycentric coordinate of corner
    ``k`` is ``c_k / det`` (``c_1 = e_2 x e_3`` and cyclically, ``c_0 = -c_1 - c_2 - c_3``,
    ``det = e_1 . c_1``), so ``K_ij = |det| / 6 * c_i . c_j / det**2``.
    """
    a = V[T[:, 0]]
    e1, e2, e3 = V[T[:, 1]] - a, V[T[:, 2]] - a, V[T[:, 3]] - a
    c = [None, np.cross(e2, e3), np.cross(e3, e1), np.cross(e1, e2)]
    c[0] = -(c[1] + c[2] + c[3])
    six_vol = np.abs(np.einsum("ij,ij->i", e1, c[1])) * 6.0
    dots = np.column_stack([np.einsum("ij,ij->i", c[i], c[j]) for i, j in _PAIRS])
    return -np.divide(dots, six_vol[:, None], out=np.zeros_like(dots), where=six_vol[:, None] > 0)


def tet_laplacian(V, T, *, weights="cotan"):
    """Symmetric positive semi-definite Laplacian ``L = D - W`` of a tetrahedral mesh.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    T : (m, 4) array_like of int
        Tetrahedra, any integer dtype, either orientation.
    weights : {'cotan', 'uniform'}, optional
        ``cotan``: the P1 finite-element stiffness matrix (equal to
        ``-igl.cotmatrix(V, T)``); ``uniform``: 1 on every tet edge. See the
        module docstring for which one when.

    Returns
    -------
    (n, n) scipy.sparse.csr_array
        ``L`` with sorted indices; its pattern is exactly the tet edge graph
        plus the diagonal (zero weights stay stored).

    Raises
    ------
    MeshError
        If ``(V, T)`` is malformed (see :func:`manifill.validate.as_tets`);
        zero-volume tets are accepted only with ``uniform`` weights.
    OptionError
        If ``weights`` is not one of the names above.

    Notes
    -----
    The weights are computed on positions centred and scaled to a unit
    bounding-box diagonal, then multiplied by that diagonal (the stiffness
    scales linearly with size), so a far origin costs no accuracy.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> L = tet_laplacian(V, [[0, 1, 2, 3]])
    >>> (6 * L.toarray()).round(12).tolist()
    [[3.0, -1.0, -1.0, -1.0], [-1.0, 1.0, 0.0, 0.0], [-1.0, 0.0, 1.0, 0.0], [-1.0, 0.0, 0.0, 1.0]]
    >>> L.nnz  # the zero weights between corners 1, 2, 3 are stored
    16
    """
    check_option("weights", weights, TET_WEIGHTS)
    V, T = as_tets(V, T, allow_degenerate=weights == "uniform", allow_unreferenced=True)
    return assemble_tet_laplacian(V, T, weights)


def assemble_tet_laplacian(V, T, weights="cotan"):
    """:func:`tet_laplacian` on arrays that have passed :func:`~manifill.validate.as_tets`."""
    index, ids = _edge_index(T, len(V))
    if weights == "uniform":
        w = np.ones(len(index))
    else:
        scale = bbox_diagonal(V)
        W = _stiffness_weights((V - V.mean(axis=0)) / scale, T)
        ok = ids >= 0  # a tet repeating a vertex has no edge there (and zero weight)
        w = np.bincount(ids[ok], weights=W[ok], minlength=len(index)) * scale
    return index.matrix(-w, diagonal=index.degree(w))


def tet_mass_matrix(V, T):
    """The lumped (diagonal) mass matrix of a tetrahedral mesh: a quarter of each incident tet's volume per vertex.

    With :func:`tet_laplacian` it makes the P1 finite elements of a solid (the
    barycentric lumping, libigl's ``massmatrix`` of tets).

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    T : (m, 4) array_like of int
        Tetrahedra, any integer dtype, either orientation; zero-volume tets are
        allowed (they weigh nothing).

    Returns
    -------
    (n, n) scipy.sparse.csr_array
        Diagonal, non-negative, summing to the total (unsigned) volume; computed
        on positions centred and scaled to a unit bounding-box diagonal, then
        multiplied by that diagonal cubed, like :func:`tet_laplacian`. A vertex
        used by no tet gets a stored 0.

    Raises
    ------
    MeshError
        If ``(V, T)`` is malformed (see :func:`manifill.validate.as_tets`).

    See Also
    --------
    tet_laplacian : the stiffness matrix.
    manifill.mesh.laplacian.mass_matrix : the same for triangles.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> (tet_mass_matrix(V, [[0, 1, 2, 3]]).diagonal() * 24).round(12).tolist()
    [1.0, 1.0, 1.0, 1.0]
    """
    V, T = as_tets(V, T, allow_degenerate=True, allow_unreferenced=True)
    n = len(V)
    scale = bbox_diagonal(V)
    scale = scale if scale > 0 else 1.0
    vol = np.abs(_volumes((V - V.mean(axis=0)) / scale, T)) / 4.0
    m = np.bincount(T.ravel(), weights=np.repeat(vol, 4), minlength=n) * scale**3
    ramp = np.arange(n + 1, dtype=np.int32 if n < 2**31 - 1 else np.int64)
    M = sp.csr_array((m, ramp[:-1], ramp), shape=(n, n))
    M.has_sorted_indices = True
    return M


def tet_gradient_root(V, T):
    """``B`` (three rows per tet) with ``B' B`` the cotan stiffness :func:`tet_laplacian` of ``(V, T)``.

    Row ``3t + c`` holds coordinate ``c`` of ``sqrt(volume_t) grad(phi_j)`` on tet ``t``, so
    ``x' B' B x = sum_t volume_t |grad x|^2`` is the Dirichlet energy of the linear
    interpolant. Used to draw Gaussian fields whose precision holds the stiffness
    (:mod:`manifill.mesh.roots` has the roots of surface Laplacians).

    Parameters
    ----------
    V : (n, 3) array_like
    T : (m, 4) array_like of int
        Tetrahedra of nonzero volume, either orientation.

    Returns
    -------
    (3m, n) scipy.sparse.csr_array
        Computed on positions centred and scaled to a unit bounding-box diagonal,
        then multiplied by the square root of that diagonal, as the stiffness is.

    Raises
    ------
    MeshError
        If ``(V, T)`` is malformed or has a zero-volume tet.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]])
    >>> T = [[0, 1, 2, 3], [1, 2, 3, 4]]
    >>> B = tet_gradient_root(V, T)
    >>> B.shape, bool(abs(B.T @ B - tet_laplacian(V, T)).max() < 1e-12)
    ((6, 5), True)
    """
    V, T = as_tets(V, T, allow_unreferenced=True)
    scale = bbox_diagonal(V)
    G, vol = tet_gradient_operator((V - V.mean(axis=0)) / scale, T)
    # sqrt(volume) grad(phi), times sqrt(scale) for the stiffness' units of length
    return sp.csr_array(sp.diags_array(np.repeat(np.sqrt(vol * scale), 3)) @ G)


