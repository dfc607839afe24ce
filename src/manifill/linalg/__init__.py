"""The solve core: constrained quadratic energies, solver backends, PCG, algebraic and voxel multigrid.

- :mod:`manifill.linalg.quadratic` - ``QuadraticSolver``: minimise ``1/2 x'Ax + c'x`` with ``x[idx] = vals``
  (the Dirichlet reduction, components without a fixed index); every fill goes through it
- :mod:`manifill.linalg.backends` - the backends ``direct``, ``amg``, ``iterate`` of the reduced system
- :mod:`manifill.linalg.pcg` - the one preconditioned conjugate gradient loop
- :mod:`manifill.linalg.threads` - the one thread policy
- :mod:`manifill.linalg.amg` - the smoothed-aggregation hierarchy of the ``amg`` backend
- :mod:`manifill.linalg.gridmg`, :mod:`manifill.linalg.gridlevels` - the voxel geometric multigrid, a
  matrix-free backend for grids
- :mod:`manifill.linalg.smoothing` - ``SmoothingFit``, ``smooth``: the penalised fit to noisy samples,
  ``lam`` given or chosen by GCV / leave-one-out
- :mod:`manifill.linalg.lamsearch` - a log grid and golden-section search of a score over ``lam``
"""
