"""The one validation layer: every array that enters manifill passes through here.

Each function converts dtypes, checks shapes, index ranges (both ends), finiteness
and duplicates, and raises one of manifill's errors whose one-line message names the
bad thing and the fix: :class:`~manifill.errors.MeshError` for a bad mesh, voxel
mask, spacing, origin or Laplacian, :class:`~manifill.errors.SampleError` for bad
samples, :class:`~manifill.errors.OptionError` for an option outside its set. Core
functions call these and then trust their arrays.

The layer is part of the base: it imports only :mod:`manifill.errors` and
:mod:`manifill.tolerances` (``as_mesh`` and ``as_tets`` accept pyvista, trimesh and
meshio objects through :mod:`manifill.validate.objects`, which imports none of those
libraries). It is one package of modules by concept, all re-exported here:

- :mod:`manifill.validate.options` - ``check_option`` and the messages' helpers
- :mod:`manifill.validate.scale` - ``unit_scale`` and the bounding-box diagonal
- :mod:`manifill.validate.degenerate` - zero-area faces, coinciding vertices
- :mod:`manifill.validate.meshes` - ``as_mesh``, ``as_tets``, ``as_laplacian``
- :mod:`manifill.validate.objects` - ``mesh_arrays``, ``tet_arrays``: pyvista, trimesh, meshio objects as arrays
- :mod:`manifill.validate.grids` - ``as_mask``, ``as_spacing``, ``as_origin``, ``as_voxels``
- :mod:`manifill.validate.samples` - ``as_indices``, ``as_values``, ``as_samples``
"""

from .degenerate import double_areas, duplicate_vertex_pairs, zero_area_faces
from .grids import as_mask, as_origin, as_spacing, as_voxels
from .meshes import as_cells, as_laplacian, as_mesh, as_points, as_tets, as_vertices
from .objects import is_mesh_object, mesh_arrays, tet_arrays
from .options import check_option, first_entries, integral_floats
from .samples import as_indices, as_samples, as_values, check_magnitude
from .scale import UNIT_WINDOW, bbox_diagonal, scale_and_diagonal, scale_of, unit_scale

__all__ = [
    "as_mesh",
    "as_points",
    "as_tets",
    "as_vertices",
    "as_cells",
    "as_laplacian",
    "mesh_arrays",
    "tet_arrays",
    "is_mesh_object",
    "as_mask",
    "as_spacing",
    "as_origin",
    "as_voxels",
    "as_indices",
    "as_values",
    "as_samples",
    "check_option",
    "check_magnitude",
    "first_entries",
    "integral_floats",
    "UNIT_WINDOW",
    "scale_of",
    "unit_scale",
    "scale_and_diagonal",
    "bbox_diagonal",
    "double_areas",
    "zero_area_faces",
    "duplicate_vertex_pairs",
]
