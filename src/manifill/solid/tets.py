"""The solid's side of a tetrahedral mesh: boundary faces and vertices, the volume a closed surface encloses.

Making a tetrahedral mesh from a closed surface (TetGen) is Step 7,
:mod:`manifill.solid.tetrahedralize`; the boundary of a tet solid is its surface D.
The tet matrices (signed volumes, the stiffness Laplacian, the lumped mass, the
gradient root) live one layer down, in :mod:`manifill.mesh.tetmesh`, beside the
triangle ones; they are re-exported here, so ``from manifill.solid.tets import
tet_laplacian`` keeps working.

Volumes and orientations are computed on the positions divided by
:func:`~manifill.validate.unit_scale` (a power of two, exact), so solids of size
``1e-150`` or ``1e150``, whose tet volumes underflow or overflow, are
tetrahedralised and oriented like unit ones.
"""

import numpy as np

from ..mesh.tetmesh import (negative_tets, tet_gradient_root, tet_laplacian, tet_mass_matrix,
                            tet_volumes)
from ..deprecation import renamed
from ..validate import as_cells, as_mesh, as_tets, unit_scale

__all__ = ["tet_laplacian", "tet_mass_matrix", "tet_gradient_root", "boundary_faces", "boundary_vertices",
           "tet_volumes", "negative_tets", "rows_once", "surface_volume", "unit_volume"]

#: Public names moved, kept one release with a warning (:mod:`manifill.deprecation`).
__getattr__ = renamed(__name__, {"WEIGHTS": "manifill.mesh.tetmesh:TET_WEIGHTS"})

#: The faces of a positively oriented tet, outward, each opposite the corner of its row.
_OUTWARD = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])


def rows_once(S):
    """Which rows of ``S`` (sorted vertex triples) occur exactly once.

    Parameters
    ----------
    S : (f, 3) int64 numpy array
        Each row sorted (``np.sort(faces, axis=1)``), entries ``>= 0``.

    Returns
    -------
    (f,) bool numpy array

    Examples
    --------
    >>> rows_once(np.array([[0, 1, 2], [1, 2, 3], [0, 1, 2]])).tolist()
    [False, True, False]
    """
    n = int(S.max()) + 1
    if n < 2**20:  # pack the triple into one int64 key
        key = (S[:, 0] * n + S[:, 1]) * n + S[:, 2]
        order = np.argsort(key, kind="stable")
        step = key[order][1:] != key[order][:-1]
    else:
        order = np.lexsort(S.T[::-1])
        step = (S[order][1:] != S[order][:-1]).any(axis=1)
    single = np.r_[True, step] & np.r_[step, True]
    mask = np.zeros(len(S), dtype=bool)
    mask[order[single]] = True
    return mask


def boundary_faces(T, *, V=None):
    """The triangles on the boundary of a tetrahedral mesh, oriented outward.

    Parameters
    ----------
    T : (m, 4) array_like of int
        Tetrahedra.
    V : (n, 3) array_like, optional
        Vertex positions. With them, the faces of negatively oriented tets are
        flipped, so the result is outward for either orientation; without them
        every tet is taken as positively oriented (``tet_volumes > 0``, as
        :func:`manifill.solid.tetrahedralize.tetrahedralize` returns them).

    Returns
    -------
    (f, 3) int64 numpy array
        The faces used by exactly one tet, in tet order, each with its normal
        (right-hand rule) pointing out of that tet, hence out of the solid.

    Raises
    ------
    MeshError
        If ``T`` (or ``(V, T)``) is malformed.

    Examples
    --------
    >>> boundary_faces([[0, 1, 2, 3]]).tolist()
    [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]]
    >>> len(boundary_faces([[0, 1, 2, 3], [1, 2, 3, 4]]))  # the shared face is inside
    6
    """
    if V is None:
        try:
            n = max(int(np.max(T)) + 1, 1)
        except (TypeError, ValueError, OverflowError):
            n = 1  # as_cells names the problem
        T = as_cells(T, n, width=4, what="T", kind="tetrahedra")
        flip = np.zeros(len(T), dtype=bool)
    else:
        V, T = as_tets(V, T, allow_degenerate=True, allow_unreferenced=True)
        flip = negative_tets(V, T)
    faces = T[:, _OUTWARD]  # (m, 4, 3)
    faces[flip] = faces[flip][:, :, [0, 2, 1]]
    faces = faces.reshape(-1, 3)
    return np.ascontiguousarray(faces[rows_once(np.sort(faces, axis=1))])


def boundary_vertices(T, *, V=None):
    """The vertices on the boundary of a tetrahedral mesh (the boundary surface D of a tet solid).

    Parameters
    ----------
    T : (m, 4) array_like of int
        Tetrahedra.
    V : (n, 3) array_like, optional
        Vertex positions, validated with ``T`` when given (as :func:`boundary_faces`).

    Returns
    -------
    (d,) int64 numpy array
        The vertices of :func:`boundary_faces`, sorted and unique.

    Raises
    ------
    MeshError
        If ``T`` (or ``(V, T)``) is malformed.

    See Also
    --------
    boundary_faces : the boundary triangles.

    Examples
    --------
    >>> boundary_vertices([[0, 1, 2, 3], [1, 2, 3, 4]]).tolist()
    [0, 1, 2, 3, 4]
    >>> V = np.array([[0., 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2], [0.4, 0.4, 0.4]])
    >>> T = [[0, 1, 2, 4], [0, 1, 4, 3], [0, 4, 2, 3], [4, 1, 2, 3]]  # vertex 4 inside
    >>> boundary_vertices(T, V=V).tolist()
    [0, 1, 2, 3]
    """
    return np.unique(boundary_faces(T, V=V))


def surface_volume(V, F):
    """Volume enclosed by a closed triangle mesh (divergence theorem).

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles, oriented consistently.

    Returns
    -------
    float
        ``|sum over triangles of a . (b x c)| / 6``: the volume for either
        orientation; exact for a closed surface (and independent of the origin).

    Raises
    ------
    MeshError
        If ``(V, F)`` is malformed.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> round(surface_volume(*icosphere(4)), 3)  # the ball's 4.189, less the chords
    4.18
    """
    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    vol, s = unit_volume(V, F)
    return vol * s * s * s  # inf only when the volume itself overflows


def unit_volume(V, F):
    """``(vol, s)``: the volume enclosed by validated arrays is ``vol * s**3``, ``vol`` computed on ``V / s``.

    ``s`` is :func:`~manifill.validate.unit_scale` of ``V`` (1 for the usual
    sizes), so the triple products neither overflow nor underflow.
    """
    s = unit_scale(V)
    P = V / s
    P = P - P.mean(axis=0) if len(P) else P  # centred: no cancellation for a far origin
    return float(abs(np.einsum("ij,ij->i", P[F[:, 0]], np.cross(P[F[:, 1]], P[F[:, 2]])).sum()) / 6.0), s
