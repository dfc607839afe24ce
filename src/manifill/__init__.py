"""manifill: reconstruct a smooth field over a surface or a solid from a few sample values.

The method of Chen & Luo, *Harmonic Functions for Data Reconstruction on 3D
Manifolds*, with the mesh left as it is. The modules follow the pipeline:

- :mod:`manifill.validate` - the one validation layer (meshes, samples, options)
- :mod:`manifill.mesh.topology` - edges, components, boundary loops, genus, cleaning
- :mod:`manifill.surface.samples` - sample positions snapped to vertices
- :mod:`manifill.mesh.graph` - many-source shortest paths and Voronoi cells
- :mod:`manifill.surface.gradual` - Step 1: gradual variation, levels, GVF
- :mod:`manifill.partition` - Steps 2-3: curves through the samples
- :mod:`manifill.surface.curve_values` - Step 4: values on the curves
- :mod:`manifill.laplacian` - uniform, cotangent, intrinsic Delaunay and robust weights
- :mod:`manifill.linalg.backends`, :mod:`manifill.linalg.amg` - direct, AMG and the paper's iteration
- :mod:`manifill.harmonic` - Steps 5-6: the harmonic (Dirichlet) fill
- :mod:`manifill.reconstruct` - Steps 1-6 in one call
- :mod:`manifill.solid.voxels`, :mod:`manifill.solid.tets` - solids as voxels and as tetrahedra
- :mod:`manifill.solid.fill`, :mod:`manifill.linalg.gridmg` - Step 8: the harmonic fill of a solid
- :mod:`manifill.solid.reconstruct_volume` - Steps 1-8 on a solid in one call
- :mod:`manifill.memory` - memory estimates before large solves
- :mod:`manifill.io.registry` - the format registry: meshes and fields on disk; :mod:`manifill.io.samples` - samples
- :mod:`manifill.io.vtkxml`, :mod:`manifill.io.vtklegacy`, :mod:`manifill.io.neuro` - VTK XML, legacy VTK, GIfTI/FreeSurfer
- :mod:`manifill.mesh.objects` - pyvista, trimesh and meshio objects in and out
- :mod:`manifill.cli` - the command line, one module per subcommand
"""

__version__ = "0.1.0"

from .errors import (  # noqa: F401
    ManifillError,
    MeshError,
    OptionError,
    ReadError,
    ResourceError,
    SampleError,
    SolveError,
    WriteError,
)
from .surface.harmonic import HarmonicSolver, harmonic  # noqa: F401
from .mesh.laplacian import laplacian  # noqa: F401
from .surface.reconstruct import Reconstruction, reconstruct  # noqa: F401
from .solid.reconstruct_volume import (  # noqa: F401
    VolumeReconstruction,
    reconstruct_volume,
    reconstruct_volume_mask,
    reconstruct_volume_tets,
)
from .mesh.topology import clean_mesh, mesh_info  # noqa: F401
from .solid.fill import VoxelFill, harmonic_fill, tet_fill  # noqa: F401
