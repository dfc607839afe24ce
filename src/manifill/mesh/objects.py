"""Mesh objects of other libraries in and out: results as pyvista and meshio objects.

The way in (``mesh_arrays``, ``tet_arrays``, ``is_mesh_object``: a pyvista, trimesh or
meshio object as manifill's arrays) is part of the validation layer,
:mod:`manifill.validate.objects`, and re-exported here. The way out (:func:`to_pyvista`,
:func:`to_meshio`) imports pyvista or meshio when called.
"""

import numpy as np

from ..errors import MeshError
from ..validate.objects import is_mesh_object, mesh_arrays, tet_arrays

__all__ = ["mesh_arrays", "tet_arrays", "is_mesh_object", "to_pyvista", "to_meshio"]


def _cell_kind(C):
    width = np.shape(C)[1]
    if width not in (3, 4):
        raise MeshError(f"cells of width {width}; pass triangles (m, 3) or tetrahedra (m, 4)")
    return "triangle" if width == 3 else "tetra"


def _point_arrays(point_data):
    return {str(k): (np.asarray(a).astype(np.uint8) if np.asarray(a).dtype == bool else np.asarray(a))
            for k, a in (point_data or {}).items()}


def to_pyvista(V, C, point_data=None):
    """A ``pyvista.PolyData`` (triangles) or ``UnstructuredGrid`` (tetrahedra) with named point data.

    Parameters
    ----------
    V : (n, 3) numpy array
    C : (m, 3) or (m, 4) numpy array of int, or None
        Triangles or tetrahedra; None for a point cloud (its points alone).
    point_data : dict of str to (n,) or (n, p) numpy array, optional
        Masks (booleans) are stored as 0/1 bytes, as in manifill's files.

    Raises
    ------
    ImportError
        Without pyvista (the ``[viz]`` extra).
    """
    try:
        import pyvista as pv
    except ImportError:
        raise ImportError("converting to pyvista needs pyvista: pip install 'manifill[viz]'") from None
    V = np.asarray(V, dtype=np.float64)
    if C is None:  # a point cloud: its points (pyvista gives each a vertex cell)
        mesh = pv.PolyData(V)
        for name, arr in _point_arrays(point_data).items():
            mesh.point_data[name] = arr
        return mesh
    C = np.asarray(C, dtype=np.int64)
    if _cell_kind(C) == "triangle":
        mesh = pv.PolyData.from_regular_faces(V, C)
    else:
        mesh = pv.UnstructuredGrid({pv.CellType.TETRA: C}, V)
    for name, arr in _point_arrays(point_data).items():
        mesh.point_data[name] = arr
    return mesh


def to_meshio(V, C, point_data=None):
    """A ``meshio.Mesh`` of triangles or tetrahedra with named point data (see :func:`to_pyvista`)."""
    import meshio

    V = np.asarray(V, dtype=np.float64)
    if C is None:  # a point cloud: one vertex cell per point
        return meshio.Mesh(V, [("vertex", np.arange(len(V))[:, None])], point_data=_point_arrays(point_data))
    C = np.asarray(C, dtype=np.int64)
    return meshio.Mesh(V, [(_cell_kind(C), C)], point_data=_point_arrays(point_data))
