"""The paper's Steps 1-6 on a surface, one public step per module.

- :mod:`manifill.surface.surface` - :class:`~manifill.surface.surface.Surface`: a validated
  mesh (or digital surface), its two graphs and its cached Laplacians
- :mod:`manifill.surface.samples` - samples at vertices, or at positions snapped to them
- :mod:`manifill.surface.gradual` - Step 1: levels and the gradual variation condition
  (:func:`~manifill.surface.gradual.check_gradual` gives a ``GradualCheck``), GVF
- :mod:`manifill.surface.partition` - Steps 2-3: curves through the samples
  (:func:`~manifill.surface.partition.partition` gives a ``Partition``)
- :mod:`manifill.surface.curve_values` - Step 4: values on the curves
  (:func:`~manifill.surface.curve_values.values_on_curves` gives ``CurveValues``)
- :mod:`manifill.surface.fill` - Steps 5-6: the harmonic fill of the patches
  (:func:`~manifill.surface.fill.fill_patches`), its starting values, the whole-surface GVF
- :mod:`manifill.surface.harmonic` - the Dirichlet problem on a mesh (``HarmonicSolver``, ``harmonic``)
- :mod:`manifill.surface.reconstruct` - Steps 1-6 composed: ``reconstruct`` (a mesh) and
  ``reconstruct_surface`` (a Surface), giving a ``Reconstruction``
"""
