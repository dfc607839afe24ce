"""Files in and out: one front door to manifill's readers and writers, dispatched by suffix.

Surfaces (:func:`read_mesh`, :func:`read_mesh_file`, :func:`write_mesh`; the table
:data:`MESH_FORMATS` says what each format holds and who reads its fields):

- ``.vtu`` VTK XML UnstructuredGrid, ``.vtp`` VTK XML PolyData, ``.vtk`` legacy VTK:
  read and written with named per-vertex fields;
- ``.ply`` (fields), ``.off``, ``.obj``, ``.stl`` (no fields; STL renumbers vertices);
- ``.surf.gii`` GIfTI and FreeSurfer surfaces (``lh.pial`` ...): read only, with the
  ``[neuro]`` extra.

Samples and values (:func:`read_samples`, :func:`write_values`): ``.csv``, ``.npz``,
``.npy``, per-vertex GIfTI / MGH / FreeSurfer morphometry data, FreeSurfer ``.label``.

Fields in time (:func:`read_series`, :class:`SeriesWriter`, :func:`write_series`,
:func:`read_series_values`): samples with many time steps (wide, long or per-time files);
``(n, T)`` values streamed to ``.xdmf`` (+ ``.h5``), ``.pvd`` (+ VTU), ``.npy`` or ``.h5``.

Solids: tetrahedral meshes (:func:`read_tets`, :func:`write_tets`: ``.vtu``, ``.vtk``,
``.msh``), voxel grids (:func:`read_vti`, :func:`write_vti`, :func:`read_mask`:
``.vti``, ``.npy``).

Mask arrays are written under one set of names (:data:`SAMPLE_MASK`,
:data:`CURVE_MASK`, :data:`PATCH_LABEL`, :data:`BOUNDARY_MASK`). Every write is
atomic; every damaged file ends in one :class:`~manifill.errors.ReadError` naming it.
The modules: :mod:`manifill.io.registry` (the format table and dispatch),
:mod:`manifill.io.field_names`, :mod:`manifill.io.samples`, :mod:`manifill.io.series`,
:mod:`manifill.io.series_write`, :mod:`manifill.io.solids`,
:mod:`manifill.io.vtkxml_decode`, :mod:`manifill.io.vtkxml_read`,
:mod:`manifill.io.vtkxml_write`, :mod:`manifill.io.vtklegacy_scan`,
:mod:`manifill.io.vtklegacy_read`, :mod:`manifill.io.vtklegacy_write`,
:mod:`manifill.io.meshio_files`, :mod:`manifill.io.neuro`, :mod:`manifill.io.files`.

Examples
--------
>>> import os, tempfile
>>> from manifill.io import read_mesh_file, write_mesh
>>> path = os.path.join(tempfile.mkdtemp(), "t.vtu")
>>> write_mesh(path, [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], {"u": [1.0, 2.0, 3.0]})
{'u': 'u'}
>>> m = read_mesh_file(path)
>>> m.F.tolist(), m.point_data["u"].tolist()
([[0, 1, 2]], [1.0, 2.0, 3.0])
"""

from .field_names import (BOUNDARY_MASK, CURVE_MASK, PATCH_LABEL, RESERVED_NAMES, SAMPLE_MASK, check_field_names,
                          stored_names)
from ..deprecation import renamed
from .files import atomic_path
from .formats import KINDS, Format, find_format, formats_of, register_format
from .points import BARRIER_FORMATS, read_barriers
from .registry import (MESH_FORMATS, POINT_FORMATS, MeshFile, format_note, read_mesh, read_mesh_file, write_cells,
                       write_mesh)
from .samples import SAMPLE_FORMATS, VALUE_FORMATS, read_samples, write_values
from .series import SERIES_FORMATS, SampleSeries, read_series, read_series_values
from .series_write import SeriesWriter, write_series
from .solids import GRID_FORMATS, TET_FORMATS, has_tets, read_mask, read_tets, read_vti, write_tets, write_vti
from .results import save_result

__all__ = ["KINDS", "Format", "find_format", "formats_of", "register_format", "MESH_FORMATS", "POINT_FORMATS",
           "MeshFile", "read_mesh", "read_mesh_file", "write_mesh",
           "write_cells", "BARRIER_FORMATS", "read_barriers", "format_note", "SAMPLE_MASK", "CURVE_MASK",
           "PATCH_LABEL", "BOUNDARY_MASK", "RESERVED_NAMES", "check_field_names", "stored_names", "SAMPLE_FORMATS",
           "VALUE_FORMATS", "read_samples", "write_values", "save_result", "TET_FORMATS", "GRID_FORMATS", "has_tets",
           "read_tets", "write_tets", "read_vti", "write_vti", "read_mask", "atomic_path", "SERIES_FORMATS",
           "SampleSeries", "read_series", "read_series_values", "SeriesWriter", "write_series"]

#: Public names renamed, kept one release with a warning (:mod:`manifill.deprecation`): one class for the formats
#: of every kind.
__getattr__ = renamed(__name__, {"MeshFormat": "manifill.io:Format"})
