"""manifill: reconstruct a smooth field over a surface or a solid from a few sample values.

The method of Chen & Luo, *Harmonic Functions for Data Reconstruction on 3D
Manifolds*, with the mesh left as it is. The modules follow the pipeline:

- :mod:`manifill.validate` - the one validation layer (meshes, samples, options)
- :mod:`manifill.topology` - edges, components, boundary loops, genus, cleaning
- :mod:`manifill.samples` - sample positions snapped to vertices
- :mod:`manifill.geodesic` - many-source shortest paths and Voronoi cells
- :mod:`manifill.gradual` - Step 1: gradual variation, levels, GVF
- :mod:`manifill.partition` - Steps 2-3: curves through the samples
- :mod:`manifill.curves` - Step 4: values on the curves
- :mod:`manifill.laplacian` - uniform, cotangent, intrinsic Delaunay and robust weights
- :mod:`manifill.solvers`, :mod:`manifill.multigrid` - direct, AMG and the paper's iteration
- :mod:`manifill.harmonic` - Steps 5-6: the harmonic (Dirichlet) fill
- :mod:`manifill.reconstruct` - Steps 1-6 in one call
- :mod:`manifill.voxels`, :mod:`manifill.tets` - solids as voxels and as tetrahedra
- :mod:`manifill.volume`, :mod:`manifill.gridsolver` - Step 8: the harmonic fill of a solid
- :mod:`manifill.solid` - Steps 1-8 on a solid in one call
- :mod:`manifill.memory` - memory estimates before large solves
- :mod:`manifill.io` - the format registry: meshes and fields on disk; :mod:`manifill.sampleio` - samples
- :mod:`manifill.vtkxml`, :mod:`manifill.vtklegacy`, :mod:`manifill.neuro` - VTK XML, legacy VTK, GIfTI/FreeSurfer
- :mod:`manifill.meshobj` - pyvista, trimesh and meshio objects in and out
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
from .harmonic import HarmonicSolver, harmonic  # noqa: F401
from .laplacian import laplacian  # noqa: F401
from .reconstruct import Reconstruction, reconstruct  # noqa: F401
from .solid import (  # noqa: F401
    VolumeReconstruction,
    reconstruct_volume,
    reconstruct_volume_mask,
    reconstruct_volume_tets,
)
from .topology import clean_mesh, mesh_info  # noqa: F401
from .volume import VoxelFill, harmonic_fill, tet_fill  # noqa: F401
