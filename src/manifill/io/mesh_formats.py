"""The mesh formats' readers and writers, registered in :mod:`manifill.io.formats` (the ``mesh`` and ``points``
kinds): VTU, VTP, legacy VTK, PLY, OFF, OBJ, STL, GIfTI, points as ``.xyz``/CSV, and FreeSurfer surfaces (by their
first bytes). :mod:`manifill.io.registry` reads and writes meshes through them; the cell writers serve tetrahedra
too (:mod:`manifill.io.solids`).
"""

import numpy as np

from .files import no_triangles, reading
from .formats import Format, FormatView, register_format
from .meshio_files import read_meshio, write_meshio
from .neuro import read_freesurfer_surface, read_gifti
from .points import read_csv_points, read_xyz
from .vtklegacy_read import read_legacy
from .vtklegacy_write import write_legacy
from .vtkxml_read import read_polydata, read_unstructured
from .vtkxml_write import write_polydata, write_unstructured

__all__ = ["CELL_WRITERS", "MESH_FORMATS", "POINT_FORMATS", "FREESURFER", "ply_reserved", "vtk_reserved"]


def _read_meshio(path, fmt):
    return read_meshio(path, fmt)


def _read_vtp(path, fmt):
    return read_polydata(path)


def _read_vtu(path, fmt):
    return read_unstructured(path)


def _read_legacy(path, fmt):
    V, cells, point_data = read_legacy(path)
    F = cells.get("triangle")
    if F is None or len(F) == 0:
        kinds = sorted(k for k, c in cells.items() if len(c))
        no_triangles(path, kinds, None if "tetra" in kinds else V, point_data)
    return V, F, point_data


def _read_gifti(path, fmt):
    return read_gifti(path)


def _read_freesurfer(path, fmt):
    V, F = read_freesurfer_surface(path)
    return V, F, {}


def _points_reader(read):
    """A reader of points alone (``.xyz``, ``.csv``): ``F`` None, and refused where a mesh is asked."""

    def read_points(path, fmt):
        with reading(path, fmt.name):
            P, point_data = read(path)
        return P, None, point_data

    return read_points


def _write_vtp(path, V, kind, C, data, fmt, cell_data=None):
    write_polydata(path, V, None if kind == "vertex" else C, data, cell_data)


def _write_vtu(path, V, kind, C, data, fmt, cell_data=None):
    write_unstructured(path, V, C, data, cell_data=cell_data)


def _write_legacy(path, V, kind, C, data, fmt, cell_data=None):
    write_legacy(path, V, kind, C, data, cell_data)


def _write_meshio(path, V, kind, C, data, fmt):
    cells = [] if kind == "vertex" else [(kind, C.astype(np.int32))]  # a cloud's PLY: its vertices alone
    write_meshio(path, V, cells, data, fmt.meshio)


def ply_reserved(name):
    """PLY's reader takes ``x``, ``y``, ``z`` for the positions, and a name must not start with a digit."""
    return name in ("x", "y", "z") or name[0].isdigit()


def vtk_reserved(name):
    """Legacy VTK's reader takes a line starting ``METADATA`` (or ``NULL_ARRAY``) for a section of its own."""
    return name.lower().startswith("metadata") or name == "NULL_ARRAY"


#: The writers of cells (triangles, tetrahedra, a cloud's vertex cells) by format, shared by every kind that
#: writes cells: ``write(path, V, cell kind, C, fields, format)``; those of a format with ``cell_fields`` also take
#: ``cell_data=`` (fields per cell).
CELL_WRITERS = {"vtp": _write_vtp, "vtu": _write_vtu, "legacy": _write_legacy, "meshio": _write_meshio}

# the mesh formats: read(path, format) -> (V, F or None, point_data); write as CELL_WRITERS
for _fmt in (
    Format("VTU", "mesh", (".vtu",), _read_vtu, _write_vtu, fields=True, seen_by=("meshio", "pyvista"),
           vectors=True, cell_fields=True),
    Format("VTP", "mesh", (".vtp",), _read_vtp, _write_vtp, fields=True, seen_by=("pyvista",), vectors=True,
           cell_fields=True),
    Format("legacy VTK", "mesh", (".vtk",), _read_legacy, _write_legacy, fields=True,
           seen_by=("meshio", "pyvista"), vectors=True, cell_fields=True, plain_names=True, reserved=vtk_reserved),
    Format("PLY", "mesh", (".ply",), _read_meshio, _write_meshio, fields=True, seen_by=("meshio",), columns=True,
           plain_names=True, reserved=ply_reserved, meshio="ply"),
    Format("OFF", "mesh", (".off",), _read_meshio, _write_meshio, meshio="off"),
    Format("OBJ", "mesh", (".obj",), _read_meshio, _write_meshio, meshio="obj"),
    Format("STL", "mesh", (".stl",), _read_meshio, _write_meshio, vertex_numbering=False, meshio="stl"),
    Format("GIfTI", "mesh", (".gii",), _read_gifti, fields=True, seen_by=("nibabel",), extra="neuro"),
    Format("XYZ points", "mesh", (".xyz",), _points_reader(read_xyz), cells=False),
    Format("CSV points", "mesh", (".csv",), _points_reader(read_csv_points), cells=False, text=True),
    # a point cloud (points, no faces) is written as one vertex cell per point (PLY: the vertices alone)
    Format("VTP", "points", (".vtp",), write=_write_vtp, fields=True, vectors=True),
    Format("VTU", "points", (".vtu",), write=_write_vtu, fields=True, vectors=True),
    Format("legacy VTK", "points", (".vtk",), write=_write_legacy, fields=True, vectors=True, plain_names=True,
           reserved=vtk_reserved),
    Format("PLY", "points", (".ply",), write=_write_meshio, fields=True, columns=True, plain_names=True,
           reserved=ply_reserved, meshio="ply"),
):
    register_format(_fmt)

#: The mesh formats (a view of :mod:`manifill.io.formats`' registry).
MESH_FORMATS = FormatView("mesh")
#: The formats a point cloud is written as (a view of the registry).
POINT_FORMATS = FormatView("points", writing=True)
#: FreeSurfer triangle surfaces, recognised by their magic number (no suffix)
FREESURFER = Format("FreeSurfer surface", "mesh", (), _read_freesurfer, extra="neuro")
