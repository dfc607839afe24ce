"""The solve core: constrained quadratic energies, solver backends, PCG, algebraic and voxel multigrid."""
