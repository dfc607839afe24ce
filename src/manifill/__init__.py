"""manifill: reconstruct a smooth field over a surface or a solid from a few sample values.

The method of Chen & Luo, *Harmonic Functions for Data Reconstruction on 3D
Manifolds*, with the mesh left as it is. Every public name is importable from here;
the subpackages are the layers (``docs/ARCHITECTURE.md`` draws them):

- :mod:`manifill.mesh` - surfaces as arrays: edges, topology, geometry, cleaning,
  stiffness and mass matrices, graph distances, built-in shapes, subdivision
- :mod:`manifill.linalg` - the solve core: a quadratic energy with fixed values
  (:class:`QuadraticSolver`), its backends, the one PCG loop, AMG and voxel multigrid
- :mod:`manifill.surface` - Steps 1-6 on a surface: gradual variation (1), the
  partition (2-3), curve values (4), the harmonic fill of the patches (5-6)
- :mod:`manifill.solid` - Steps 7-8: the solid's boundary (voxelise, tetrahedralise,
  the digital surface) and the harmonic fill of the inside
- :mod:`manifill.io` - files in and out, one registry dispatched by suffix
- :mod:`manifill.viz` - pictures and the interactive viewer
- :mod:`manifill.cli` - the command line, one module per subcommand
- :mod:`manifill.cluster` - batches of jobs (command lines) on a Dask cluster
- base modules: :mod:`manifill.errors`, :mod:`manifill.tolerances`,
  :mod:`manifill.validate`, :mod:`manifill.results`, :mod:`manifill.memory`,
  :mod:`manifill.progress`, :mod:`manifill.report`, :mod:`manifill.version`
"""

import importlib

from .version import __version__  # noqa: F401 (the one source of the version)
from .errors import (ManifillError, MeshError, OptionError, ReadError, ResourceError, SampleError, SolveError,
                     WriteError)
from .io import (read_mesh, read_mesh_file, read_samples, read_tets, read_vti, write_mesh, write_tets, write_values,
                 write_vti)
from .linalg.quadratic import QuadraticSolver, min_quad_with_fixed
from .mesh.clean import clean_mesh
from .mesh.laplacian import laplacian, mass_matrix
from .mesh.topology import mesh_info
from .results import Result
from .solid.boundary import digital_surface
from .solid.fill import VoxelFill, harmonic_fill, tet_fill
from .solid.reconstruct_volume import (VolumeReconstruction, reconstruct_volume, reconstruct_volume_mask,
                                       reconstruct_volume_tets)
from .solid.tetrahedralize import tetrahedralize
from .solid.voxelize import voxelize
from .surface.crossval import CrossValidation, cross_validate
from .linalg.gp import GPOptions
from .solid.gp import gp_tets, gp_voxels
from .surface.curve_values import CurveValues, values_on_curves
from .surface.fill import fill_patches
from .surface.gradual import GradualCheck, check_gradual
from .surface.harmonic import HarmonicSolver, harmonic
from .surface.locate import SurfacePoints, locate_points
from .surface.polyharmonic import PolyharmonicSolver, biharmonic
from .surface.partition import Partition, partition
from .surface.reconstruct import Reconstruction, reconstruct, reconstruct_surface
from .surface.reconstructor import Reconstructor
from .surface.options import Options
from .surface.methods.registry import method_of
from .io.stream import reconstruct_series
from .surface.surface import Surface
from .vectors.options import VectorOptions
from .vectors.reconstruct import VectorReconstructor, reconstruct_vectors
from .vectors.result import VectorReconstruction

__all__ = [
    # errors
    "ManifillError", "MeshError", "SampleError", "OptionError", "SolveError", "ReadError", "WriteError",
    "ResourceError",
    # surfaces: the pipeline (Steps 1-6) and its steps
    "reconstruct", "Reconstruction", "Reconstructor", "Options", "method_of", "reconstruct_series", "batch",
    "BatchResult",
    "Surface", "reconstruct_surface", "check_gradual", "GradualCheck",
    "partition", "Partition", "values_on_curves", "CurveValues", "fill_patches", "cross_validate",
    "CrossValidation", "locate_points", "SurfacePoints", "GPOptions", "gp_tets", "gp_voxels",
    # tangent vector, line and cross fields on surfaces
    "reconstruct_vectors", "VectorReconstructor", "VectorReconstruction", "VectorOptions",
    # the harmonic problem and the operators
    "harmonic", "HarmonicSolver", "biharmonic", "PolyharmonicSolver", "laplacian", "mass_matrix", "QuadraticSolver",
    "min_quad_with_fixed",
    "mesh_info", "clean_mesh",
    # solids (Steps 7-8)
    "reconstruct_volume", "reconstruct_volume_tets", "reconstruct_volume_mask", "VolumeReconstruction",
    "voxelize", "tetrahedralize", "digital_surface", "harmonic_fill", "VoxelFill", "tet_fill",
    # results and files
    "Result", "read_mesh", "read_mesh_file", "write_mesh", "read_samples", "write_values", "read_tets",
    "write_tets", "read_vti", "write_vti",
]


#: Names of the public API loaded when first used: the batch layer sits above the command line (a job is a command
#: line), so ``import manifill`` would load the command line with it.
_LAZY = {"batch": "cluster", "BatchResult": "cluster"}


def __getattr__(name):
    """``manifill.batch`` and ``manifill.BatchResult``, imported on first use (PEP 562)."""
    if name in _LAZY:
        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'manifill' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
