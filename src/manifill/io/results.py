"""A result to a file: :meth:`manifill.results.Result.save`, dispatched on the file's extension.

Surfaces go to any mesh format of :data:`manifill.io.registry.MESH_FORMATS` with their fields,
standard deviations and masks (``.csv`` holds the fields and stds as columns, ``.npy`` the
fields alone); voxel results to ``.vti`` (every array) or ``.npy`` (the first field); tetrahedral
ones to :data:`manifill.io.solids.TET_FORMATS`; vector fields as :func:`manifill.io.vector_files.save_vectors`
says. Registered with :mod:`manifill.results` when
:mod:`manifill.io` is imported (results sit below ``io`` in the layers).
"""

from pathlib import Path

import numpy as np

from ..errors import OptionError
from ..report import value_columns
from ..results import RESERVED_NAMES, register_saver
from .formats import find_format
from .registry import write_mesh
from .samples import VALUE_FORMATS, write_values
from .solids import GRID_FORMATS, TET_FORMATS, write_tets, write_vti
from .vector_files import save_vectors

__all__ = ["save_result"]


def save_result(result, path, names):
    """Write ``result`` to ``path`` (see the module docstring); returns the path written."""
    path = Path(path)
    ext = path.suffix.lower()
    form = getattr(result, "form", "surface")
    if form == "vectors":  # a tangent field: 3-vectors per vertex and per face (io/vector_files.py)
        return save_vectors(result, path, names)
    data = result.point_data(names)
    if form == "voxels":
        if ext not in GRID_FORMATS:
            raise OptionError(f"a voxel result is written as {' or '.join(GRID_FORMATS)}, not {ext or 'no extension'}"
                              f"; name the file e.g. out.vti")
        named = find_format("grid", path, writing=True).fields  # .vti: every field; .npy: the first alone
        write_vti(path, data if named else {names[0]: result.fields()[..., 0]}, spacing=result.spacing,
                  origin=result.origin)
    elif form == "tets":
        if ext not in TET_FORMATS:
            raise OptionError(f"a tetrahedral result is written as {', '.join(TET_FORMATS)}, not "
                              f"{ext or 'no extension'}; name the file e.g. out.vtu")
        write_tets(path, result.TV, result.TT, data)
    elif getattr(find_format("values", path, writing=True), "fields", False):  # fields and stds as named columns
        columns = [key for key in data if key not in RESERVED_NAMES]
        write_values(path, value_columns(data, columns), names=columns)
    elif ext in VALUE_FORMATS:
        write_values(path, result.fields().reshape(len(result.values), -1), names=names)
    elif result.F is None and getattr(result, "cloud", None) is not None:  # a point cloud: its points
        write_mesh(path, np.asarray(result.V), None, data)
    elif result.F is None:
        raise OptionError(f"a digital surface has no triangles to write as {ext or 'a mesh'}; write .csv or .npy "
                          f"(values per vertex)")
    else:
        write_mesh(path, np.asarray(result.V), result.F, data)
    return path


register_saver(save_result)
