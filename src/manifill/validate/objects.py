"""Mesh objects of other libraries as manifill's arrays: what every function taking ``(V, F)`` accepts.

Every public function that takes a surface ``(V, F)`` (or a solid ``(V, T)``) also
takes a ``pyvista.PolyData`` / ``pyvista.UnstructuredGrid``, a ``trimesh.Trimesh``
or a ``meshio.Mesh`` as ``V`` with ``F=None``. The objects are recognised by their
type's module, so none of these libraries is imported (the user already has one of
their objects). Part of the base layer, so that :func:`manifill.validate.as_mesh`
and :func:`~manifill.validate.as_tets` accept them; the way back (arrays to objects)
is :mod:`manifill.mesh.objects`.
"""

import numpy as np

from ..errors import MeshError

__all__ = ["mesh_arrays", "tet_arrays", "is_mesh_object"]

_KNOWN = "a pyvista.PolyData, a trimesh.Trimesh or a meshio.Mesh"


def _library(obj):
    return type(obj).__module__.split(".")[0]


def is_mesh_object(obj):
    """Whether ``obj`` is a pyvista, trimesh or meshio mesh object."""
    return _library(obj) in ("pyvista", "trimesh", "meshio") and not isinstance(obj, np.ndarray)


def _pyvista_cells(obj, cell_type, width):
    """Cells of one VTK type of a pyvista dataset as an (m, width) array."""
    cells = getattr(obj, "cells_dict", None)
    if cells is None:
        return np.empty((0, width), np.int64)
    return np.asarray(cells.get(cell_type, np.empty((0, width))), dtype=np.int64).reshape(-1, width)


def mesh_arrays(V, F=None):
    """``(V, F)`` arrays of a surface given as arrays or as a mesh object.

    Parameters
    ----------
    V : (n, 3) array_like, or a mesh object
        Vertex positions, or a ``pyvista.PolyData`` (all triangles),
        ``pyvista.UnstructuredGrid`` (its triangles), ``trimesh.Trimesh`` or
        ``meshio.Mesh`` (its ``triangle`` cells).
    F : (m, 3) array_like of int, optional
        Triangles; must be None when ``V`` is a mesh object.

    Returns
    -------
    V, F
        Arrays (not yet validated: :func:`manifill.validate.as_mesh` does that),
        or the inputs unchanged when they are not mesh objects.

    Raises
    ------
    MeshError
        A mesh object together with ``F``, ``F=None`` with plain arrays, an
        object without triangles, or pyvista's flat padded ``faces`` array
        passed as ``F`` (the message names what to pass instead).

    Examples
    --------
    >>> import meshio
    >>> m = meshio.Mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [("triangle", [[0, 1, 2]])])
    >>> V, F = mesh_arrays(m)
    >>> V.shape, F.tolist()
    ((3, 3), [[0, 1, 2]])
    """
    lib = _library(V)
    if not is_mesh_object(V):
        if F is None:
            raise MeshError(f"F is None but V is a {type(V).__name__}; pass (V, F) arrays, or {_KNOWN} as V with "
                            f"F=None")
        if is_mesh_object(F):
            raise MeshError(f"F is a {type(F).__module__}.{type(F).__name__}; pass the mesh object as V with F=None")
        _check_padded(F)
        return V, F
    if F is not None:
        raise MeshError(f"V is a {lib} mesh and F is given too; pass the mesh alone with F=None")
    kind = type(V).__name__
    if lib == "pyvista":
        if kind == "PolyData":
            if np.asarray(V.faces).size == 0:
                raise MeshError("the pyvista.PolyData has no faces (points or lines only); pass a surface mesh")
            if not V.is_all_triangles:
                raise MeshError("the pyvista.PolyData has faces that are not triangles; pass mesh.triangulate()")
            faces = V.regular_faces if hasattr(V, "regular_faces") else np.asarray(V.faces).reshape(-1, 4)[:, 1:]
            return np.asarray(V.points, dtype=np.float64), np.asarray(faces, dtype=np.int64)
        if hasattr(V, "cells_dict"):
            tri = _pyvista_cells(V, 5, 3)
            if len(tri) == 0:
                hint = "; for a tetrahedral solid use the volume functions" if len(_pyvista_cells(V, 10, 4)) else ""
                raise MeshError(f"the pyvista.{kind} has no triangle cells{hint}; pass a triangle surface "
                                f"(e.g. mesh.extract_surface().triangulate())")
            return np.asarray(V.points, dtype=np.float64), tri
        raise MeshError(f"a pyvista.{kind} is not a surface mesh; pass a pyvista.PolyData of triangles")
    if lib == "trimesh":
        faces = getattr(V, "faces", None)
        if faces is None or len(faces) == 0:
            raise MeshError(f"the trimesh.{kind} has no faces; pass a trimesh.Trimesh surface")
        return np.asarray(V.vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64)
    tri = _meshio_cells(V, "triangle", 3)
    if tri is None:
        types = ", ".join(sorted({b.type for b in V.cells})) or "none"
        raise MeshError(f"the meshio.Mesh has no triangle cells (cells: {types}); pass a triangle surface")
    return np.asarray(V.points, dtype=np.float64), tri


def _meshio_cells(mesh, kind, width):
    blocks = [np.asarray(b.data, dtype=np.int64).reshape(-1, width) for b in mesh.cells if b.type == kind]
    return np.concatenate(blocks) if blocks else None


def tet_arrays(V, T=None):
    """``(V, T)`` arrays of a tetrahedral mesh given as arrays or as a mesh object.

    Parameters
    ----------
    V : (n, 3) array_like, or a ``pyvista.UnstructuredGrid`` / ``meshio.Mesh``
    T : (m, 4) array_like of int, optional
        Must be None when ``V`` is a mesh object.

    Returns
    -------
    V, T

    Raises
    ------
    MeshError
        As :func:`mesh_arrays`, for tetrahedra.
    """
    if not is_mesh_object(V):
        if T is None:
            raise MeshError(f"T is None but V is a {type(V).__name__}; pass (V, T) arrays, or a "
                            f"pyvista.UnstructuredGrid or meshio.Mesh of tetrahedra as V with T=None")
        return V, T
    if T is not None:
        raise MeshError(f"V is a {_library(V)} mesh and T is given too; pass the mesh alone with T=None")
    lib, kind = _library(V), type(V).__name__
    if lib == "pyvista" and hasattr(V, "cells_dict"):
        tet = _pyvista_cells(V, 10, 4)
        if len(tet):
            return np.asarray(V.points, dtype=np.float64), tet
    elif lib == "meshio":
        tet = _meshio_cells(V, "tetra", 4)
        if tet is not None:
            return np.asarray(V.points, dtype=np.float64), tet
    raise MeshError(f"the {lib}.{kind} has no tetrahedra; pass a pyvista.UnstructuredGrid or meshio.Mesh with "
                    f"tetra cells (e.g. from manifill's tetrahedralisation or TetGen)")


def _check_padded(F):
    """Refuse pyvista's flat ``[3, a, b, c, 3, ...]`` face array passed as ``F``."""
    try:
        F = np.asarray(F) if not isinstance(F, np.ndarray) else F
    except (TypeError, ValueError):
        return  # ragged: the validator names it
    if F.ndim == 1 and F.size >= 4 and F.size % 4 == 0 and np.issubdtype(F.dtype, np.integer) and (F[::4] == 3).all():
        raise MeshError("F is a flat array [3, a, b, c, 3, ...] like pyvista's `faces`; pass `mesh.regular_faces` "
                        "(an (m, 3) array), or the pyvista mesh itself with F=None")
