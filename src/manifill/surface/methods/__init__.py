"""The reconstruction methods on a surface, one module each, and their registry.

- :mod:`.base`: :class:`Method` (capabilities, ``check``, ``linear``, ``fill``) and
  :class:`Run` (one call: the report, timings, Step 1, the result);
- :mod:`.pipeline`: ``gvf-harmonic``, the paper's Steps 1-6;
- :mod:`.gvf`: ``gvf``, the gradually varied fit of every vertex;
- :mod:`.energy`: ``harmonic``, ``biharmonic``, ``triharmonic``;
- :mod:`.rbf`: ``rbf``, the thin-plate spline in space;
- :mod:`.matern`: ``gp``, the Matérn Gaussian process;
- :mod:`.auto`: ``auto``, cross-validation's choice;
- :mod:`.default`: the default preset (``method=None``);
- :mod:`.registry`: every method and preset by name, :func:`method_of`, :func:`configure`.
"""
