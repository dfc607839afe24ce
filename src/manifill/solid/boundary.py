"""Step 7: the boundary surface D of a solid, where Steps 1-6 run and Step 8's fill is fixed.

A voxel solid's D is its boundary voxels (:func:`boundary_voxels`): the voxels
of the mask with a neighbour outside it (or on the border of the array). Every
other voxel of the mask then has all its neighbours in the mask, so fixing D
encloses the inside for every connectivity. As a surface for Steps 1-6, D is a
digital surface (:func:`digital_surface`, :func:`digital_surface_graph`): a graph
joining boundary voxels that touch, with normals from the smoothed mask.
A voxelised triangle mesh gets its values on D from the surface's field at the
closest surface point (:func:`surface_to_points`).

A tetrahedral solid's D is its boundary triangles
(:func:`manifill.solid.tets.boundary_faces`, :func:`manifill.solid.tets.boundary_vertices`).
"""

import numpy as np
from numpy.typing import ArrayLike
from scipy import ndimage

from ..errors import SampleError
from ..mesh.graph import DISTANCES, edge_graph, graph_laplacian
from ..surface.surface import Surface
from ..validate import as_mask, as_voxels, check_option, unit_scale
from .voxels import as_origin, as_spacing, neighbour_offsets, shifted_views, voxel_centres

__all__ = ["boundary_voxels", "digital_surface", "digital_surface_graph", "surface_vertex_of_voxels",
           "surface_to_points"]


def boundary_voxels(mask, connectivity=6):
    """The boundary surface D: voxels of ``mask`` with a neighbour outside it.

    Parameters
    ----------
    mask : (n0, n1, n2) bool numpy array
    connectivity : {6, 18, 26}, optional
        Which neighbours count. Fixing D then leaves every other voxel of the
        mask with all its neighbours in the mask, so the stencil there is whole
        (and reproduces linear functions).

    Returns
    -------
    (n0, n1, n2) bool numpy array
        Voxels on the border of the array count as boundary.

    Examples
    --------
    >>> m = np.ones((3, 3, 3), dtype=bool)
    >>> int(boundary_voxels(m).sum()), bool(boundary_voxels(m)[1, 1, 1])
    (26, False)
    """
    mask = np.asarray(mask, dtype=bool)
    inner = np.zeros_like(mask)
    inner[1:-1, 1:-1, 1:-1] = mask[1:-1, 1:-1, 1:-1]  # the border layers have neighbours outside the array
    for d in neighbour_offsets(connectivity):
        for s in (d, -d):
            shifted_views(inner, s)[0][...] &= shifted_views(mask, s)[1]  # the neighbour at x + s is in the mask
    return mask & ~inner


def digital_surface(mask: ArrayLike, *, spacing: ArrayLike = (1.0, 1.0, 1.0), origin: ArrayLike = (0.0, 0.0, 0.0),
                    connectivity: int = 6) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The boundary voxels of a mask as a surface graph with positions and normals.

    Parameters
    ----------
    mask : (n0, n1, n2) bool array_like
    spacing, origin : (3,) array_like of float, optional
    connectivity : {6, 18, 26}, optional
        Which neighbours outside the mask make a voxel a boundary voxel.

    Returns
    -------
    voxels : (d, 3) int64 numpy array
        The boundary voxels, C order.
    P : (d, 3) numpy array
        Their centres.
    E : (e, 2) int64 numpy array
        Pairs of boundary voxels that touch (26 neighbours), ``i < j``.
    normals : (d, 3) numpy array
        Outward unit normals from the gradient of the smoothed mask.

    Raises
    ------
    MeshError
        A malformed ``spacing`` or ``origin``.
    OptionError
        ``connectivity`` not one of 6, 18, 26.

    See Also
    --------
    digital_surface_graph : the digital surface as the Surface of Steps 1-6.

    Examples
    --------
    >>> voxels, P, E, normals = digital_surface(np.ones((3, 3, 3), dtype=bool), spacing=2.0)
    >>> len(voxels), P[-1].tolist(), bool((voxels[1:] > voxels[:-1]).any(axis=1).all())
    (26, [4.0, 4.0, 4.0], True)
    """
    mask = as_mask(mask)
    h = as_spacing(spacing)
    origin = as_origin(origin)
    D = boundary_voxels(mask, connectivity)
    voxels = np.argwhere(D)
    P = voxel_centres(mask.shape, h, origin, where=D)
    ids = np.full(mask.shape, -1, dtype=np.int64)
    ids[D] = np.arange(len(voxels))
    pad = np.pad(ids, 1, constant_values=-1)
    E = []
    for d in neighbour_offsets(26):
        there = pad[tuple(slice(1 + s, 1 + s + n) for s, n in zip(d, mask.shape))]
        both = D & (there >= 0)
        E.append(np.column_stack([ids[both], there[both]]))
    E = np.sort(np.concatenate(E), axis=1)
    smooth = ndimage.gaussian_filter(mask.astype(np.float64), sigma=1.0 / h * h.min(), mode="constant")
    # an axis one voxel thick has no difference along it (np.gradient needs two)
    # in units of the smallest spacing: only the direction matters, and 1 / h overflows its square at h = 1e-300
    grad = np.stack([np.gradient(smooth, h[a] / h.min(), axis=a)[D] if mask.shape[a] > 1 else np.zeros(len(voxels))
                     for a in range(3)], axis=1)
    norm = np.linalg.norm(grad, axis=1, keepdims=True)
    normals = np.divide(-grad, norm, out=np.zeros_like(grad), where=norm > 0)
    return voxels, P, E, normals


def digital_surface_graph(P, E, normals=None, *, distance="length"):
    """A digital surface (:func:`digital_surface`) as the :class:`~manifill.surface.surface.Surface` of Steps 1-6.

    Parameters
    ----------
    P : (d, 3) numpy array
        Positions of the boundary voxels.
    E : (e, 2) int64 numpy array
        Pairs of boundary voxels that touch.
    normals : (d, 3) numpy array, optional
        Outward unit normals (Step 4's Hermite slopes).
    distance : {'length', 'hops'}, optional
        Edge lengths of the partition's graph ``G``: the distance between voxel
        centres in units of its mean, or 1 per edge.

    Returns
    -------
    Surface
        ``F`` is None (no triangles); its Laplacian is the graph Laplacian of
        ``G_hops`` whatever weight name is asked for (the paper's uniform
        average: a digital surface has no triangles for cotangents).

    Examples
    --------
    >>> voxels, P, E, normals = digital_surface(np.ones((3, 3, 3), dtype=bool))
    >>> s = digital_surface_graph(P, E, normals)
    >>> s.n, float(s.laplacian("uniform").sum())
    (26, 0.0)
    """
    check_option("distance", distance, DISTANCES)
    n = len(P)
    Pu = np.asarray(P, dtype=np.float64) / unit_scale(P)  # a power of two: at 1e-300 the squares underflow
    length = np.linalg.norm(Pu[E[:, 0]] - Pu[E[:, 1]], axis=1)
    G_hops = edge_graph(n, E, np.ones(len(E)))
    G = G_hops if distance == "hops" else edge_graph(n, E, length / length.mean() if len(E) else length)

    def laplacian(weights):
        return graph_laplacian(G_hops)

    return Surface(P, G_hops, G, laplacian, normals=normals)


def surface_vertex_of_voxels(voxels, ijk, shape):
    """The vertex of a digital surface at each of some voxels: samples given as voxels, as surface vertices.

    Parameters
    ----------
    voxels : (d, 3) int64 numpy array
        The voxel of each vertex of the digital surface (:func:`digital_surface`).
    ijk : (k, 3) array_like of int
        Grid indices of the sampled voxels.
    shape : tuple of 3 int
        The grid.

    Returns
    -------
    (k,) int64 numpy array
        Row of ``voxels`` equal to each row of ``ijk``.

    Raises
    ------
    SampleError
        ``ijk`` not (k, 3) integers, outside the grid, or not a boundary voxel.

    Examples
    --------
    >>> voxels = np.array([[0, 0, 0], [0, 0, 1]])
    >>> surface_vertex_of_voxels(voxels, [[0, 0, 1]], (1, 1, 2)).tolist()
    [1]
    """
    ijk = as_voxels(ijk, shape, unique=False)
    pos = np.full(shape, -1, dtype=np.int64)
    pos[tuple(voxels.T)] = np.arange(len(voxels))
    where = pos[tuple(ijk.T)]
    if (where < 0).any():
        v = tuple(int(c) for c in ijk[np.flatnonzero(where < 0)[0]])
        raise SampleError(f"{int((where < 0).sum())} samples are not on boundary voxels of the mask (e.g. voxel {v}); "
                          f"place them on manifill.solid.boundary.boundary_voxels(mask)")
    return where


def surface_to_points(V, F, values, P):
    """Values of a surface field at the closest surface point of each query point.

    Parameters
    ----------
    V : (n, 3) numpy array
    F : (m, 3) numpy array of int
    values : (n,) or (n, p) numpy array
        The field at the vertices (linear on each triangle).
    P : (q, 3) numpy array
        Query points.

    Returns
    -------
    values : (q,) or (q, p) numpy array
    distance : (q,) numpy array
        From each point to the surface.

    Notes
    -----
    The closest points and their barycentric coordinates are computed on
    ``V / s`` and ``P / s``, ``s`` the power of two of
    :func:`manifill.validate.unit_scale` (1 for meshes of the usual sizes), and
    the distances multiplied back by ``s``: squared lengths of a mesh of size
    ``1e-150`` underflow and of ``1e150`` overflow, their ratios do not.
    """
    import igl

    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    s = unit_scale(V)
    V = V / s  # exact
    P = np.asarray(P, dtype=np.float64) / s
    d2, face, C = igl.point_mesh_squared_distance(np.ascontiguousarray(P), np.ascontiguousarray(V),
                                                  np.ascontiguousarray(F))
    tri = F[face]
    a, b, c = V[tri[:, 0]], V[tri[:, 1]], V[tri[:, 2]]
    # barycentric coordinates of the closest point (which lies on the triangle)
    v0, v1, v2 = b - a, c - a, C - a
    d00 = np.einsum("ij,ij->i", v0, v0)
    d01 = np.einsum("ij,ij->i", v0, v1)
    d11 = np.einsum("ij,ij->i", v1, v1)
    d20 = np.einsum("ij,ij->i", v2, v0)
    d21 = np.einsum("ij,ij->i", v2, v1)
    den = d00 * d11 - d01 * d01
    den = np.where(den > 0, den, 1.0)
    wb = np.clip((d11 * d20 - d01 * d21) / den, 0, 1)
    wc = np.clip((d00 * d21 - d01 * d20) / den, 0, 1)
    wa = np.clip(1.0 - wb - wc, 0, 1)
    total = wa + wb + wc
    w = np.column_stack([wa, wb, wc]) / total[:, None]
    vals = np.asarray(values, dtype=np.float64)
    X = vals[:, None] if vals.ndim == 1 else vals
    out = np.einsum("qk,qkp->qp", w, X[tri])
    return (out[:, 0] if vals.ndim == 1 else out), np.sqrt(d2) * s
