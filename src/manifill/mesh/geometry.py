"""Measures of a triangle mesh: the angles' cotangents, face areas and the area belonging to each vertex.

The cotangents are scale-free (the cotangent Laplacian's weights). The areas are
computed on positions divided by :func:`~manifill.validate.unit_scale` (a power of
two, exact) and scaled back by ``s**2``, so they are right for meshes of any size,
and depend on a translation only through rounding. The mass matrix built
from the vertex areas is :func:`manifill.mesh.laplacian.mass_matrix`; the checks for
zero-area faces and coinciding vertices are :mod:`manifill.validate.degenerate`.
"""

import numpy as np

from ..validate import as_mesh, check_option, double_areas, unit_scale
from ..validate.scale import check_size

__all__ = ["AREAS", "cotangents", "face_areas", "vertex_areas"]

#: The ways of sharing a triangle's area among its corners (see :func:`vertex_areas`).
AREAS = ("barycentric", "voronoi")


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
    C = np.empty((3, len(F))).T  # column-major: each column, and C.T.ravel(), contiguous
    # in blocks of faces whose temporaries stay in cache: faster, and no (m,)-sized temporaries
    for s in range(0, len(F), _BLOCK):
        _cotangents_block(x, y, z, F[s:s + _BLOCK], C[s:s + _BLOCK])
    return C


#: Faces per block of :func:`cotangents`.
_BLOCK = 16384


def _cotangents_block(x, y, z, F, out):
    """:func:`cotangents` of the faces ``F`` into ``out``, from the coordinate columns."""
    i0, i1, i2 = F[:, 0], F[:, 1], F[:, 2]

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
    for k in range(3):
        a, b = (k + 1) % 3, (k + 2) % 3
        # angle at corner k lies between edges -e_b (towards b's far end) and e_a
        out[:, k] = -(ex[a] * ex[b] + ey[a] * ey[b] + ez[a] * ez[b]) * inv


def face_areas(V, F):
    """The area of every triangle.

    Parameters
    ----------
    V : (n, 3) or (n, 2) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles, any integer dtype; zero-area ones are allowed.

    Returns
    -------
    (m,) float64 numpy array

    Raises
    ------
    MeshError
        If ``(V, F)`` is malformed (see :func:`manifill.validate.as_mesh`).

    See Also
    --------
    manifill.validate.double_areas : twice the areas, on arrays already validated.

    Examples
    --------
    >>> face_areas([[0, 0], [2, 0], [0, 3]], [[0, 1, 2]]).tolist()
    [3.0]
    """
    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True)
    return 0.5 * double_areas(V, F)


def _scaled(V):
    """``(V / s, s)`` with ``s`` the :func:`~manifill.validate.unit_scale` of ``V``."""
    s = unit_scale(V)
    return (V if s == 1.0 else V * (1.0 / s)), s


def vertex_areas(V, F, *, kind="barycentric"):
    """The area belonging to each vertex: the lumped mass of the piecewise-linear finite elements.

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions (validated, see :func:`manifill.validate.as_mesh`).
    F : (m, 3) numpy array of int
        Triangles (validated).
    kind : {'barycentric', 'voronoi'}, optional
        ``barycentric``: each corner gets one third of its triangle's area.
        ``voronoi``: each corner gets the part of its triangle nearer to it than
        to the other corners (``|e|**2 cot / 8`` summed over the two edges at the
        corner), except in an obtuse triangle, where the obtuse corner gets half
        the area and the two others a quarter each (Meyer, Desbrun, Schroeder and
        Barr 2003; libigl's ``MASSMATRIX_TYPE_VORONOI``).

    Returns
    -------
    (n,) float64 numpy array
        Non-negative, zero at vertices used by no face; it sums to the total area.

    Examples
    --------
    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> (vertex_areas(V, np.array([[0, 1, 2]])) * 6).tolist()
    [1.0, 1.0, 1.0]
    >>> vertex_areas(V, np.array([[0, 1, 2]]), kind="voronoi").tolist()
    [0.25, 0.125, 0.125]
    """
    check_option("kind", kind, AREAS)
    check_size(V, 2, "the mesh", "areas", "give its vertices in other units (e.g. km or mm)")
    n = len(V)
    Vs, s = _scaled(V)
    if kind == "barycentric":
        corner = np.repeat(double_areas(Vs, F)[:, None] / 6.0, 3, axis=1)
    else:
        C = cotangents(Vs, F)
        half = 0.5 * double_areas(Vs, F)
        # squared length of the edge opposite corner k, between corners k+1 and k+2
        L2 = np.column_stack([((Vs[F[:, (k + 2) % 3]] - Vs[F[:, (k + 1) % 3]]) ** 2).sum(axis=1)
                              for k in range(3)])
        part = L2 * C / 4.0  # |e_k|**2 cot_k / 8, which each end of edge k gets
        corner = np.column_stack([part[:, (k + 1) % 3] + part[:, (k + 2) % 3] for k in range(3)])
        obtuse = C < 0
        some = obtuse.any(axis=1)
        if some.any():
            share = np.where(obtuse[some], 0.5, 0.25) * half[some, None]
            corner[some] = share
    M = np.bincount(F.ravel(), weights=corner.ravel(), minlength=n)
    return M if s == 1.0 else (M * s) * s
