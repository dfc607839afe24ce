"""The paper's reconstruction on a surface (Steps 1-6), in one call: :func:`reconstruct`.

:func:`reconstruct` validates a mesh and samples and runs a
:class:`~manifill.surface.reconstructor.Reconstructor` once. The steps it composes are
public functions, each taking a :class:`~manifill.surface.surface.Surface` first:

1. Steps 2-3, :func:`manifill.surface.partition.partition`: curves through every
   sample cut the surface into patches (a :class:`~manifill.surface.partition.Partition`;
   run first, since its curves bound Step 1's Lipschitz constant from below).
2. Step 1, :func:`manifill.surface.gradual.check_gradual`: levels and the gradual
   variation condition, per field (a :class:`~manifill.surface.gradual.GradualCheck`).
3. Step 4, :func:`manifill.surface.curve_values.values_on_curves`: a value at every
   curve vertex (a :class:`~manifill.surface.curve_values.CurveValues`).
4. Steps 5-6, :func:`manifill.surface.fill.fill_patches`: the harmonic fill of every
   patch with the curve values fixed.

Which of them run is the method's to say (:mod:`manifill.surface.methods`: one module per
method, one registry); :func:`manifill.surface.engine.reconstruct_surface` runs any method
on a built Surface. The result is a :class:`Reconstruction`, of the result family of
:mod:`manifill.results`.
"""

import time
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..deprecation import renamed
from ..progress import tick
from .engine import reconstruct_surface
from .methods.base import CHECK_FIELDS
from .methods.default import DEFAULT
from .methods.registry import METHODS as REGISTRY
from .methods.registry import names
from .options import Options
from .reconstruction import Reconstruction
from .reconstructor import Reconstructor

__all__ = ["METHOD_NAMES", "STEPS", "DEFAULT", "CHECK_FIELDS", "Reconstruction", "reconstruct", "reconstruct_surface"]

#: The names of the methods (the registry's, :mod:`manifill.surface.methods.registry`, whose ``METHODS`` maps
#: them to their objects; ``names()`` adds the presets).
METHOD_NAMES = names(presets=False)
#: The steps each method runs by default, in order, under the names it passes to ``progress``
#: (:func:`reconstruct` runs ``graph`` before them; a progress bar's total is their count).
STEPS = {name: m.step_names for name, m in REGISTRY.items()}


def reconstruct(V: ArrayLike, F: ArrayLike | None, idx: ArrayLike, vals: ArrayLike, *, options: Options | None = None,
                progress: Callable[[str], object] | None = None, **keywords: Any) -> Reconstruction:
    """Reconstruct a field on a surface from a few samples (the paper's Steps 1-6).

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int, or None
        Triangles, any integer dtype; None for a point cloud (points without faces: its operators come from each
        point's nearest neighbours, see ``neighbours``; ``report['cloud']`` describes them).
    idx : (k,) array_like of int, or (k, 3) array_like of float
        Sample vertices, or sample positions (``(k, 2)`` on a flat mesh), each
        located at its closest surface point (:func:`manifill.surface.locate.locate_points`;
        far points are refused, see ``max_distance``). The energy methods
        constrain the field exactly there (a point inside a face: a linear
        constraint on the face's three vertices: 'direct' factorises its KKT
        system, 'amg' eliminates it, 'iterate' is refused); the partition methods
        (``gvf-harmonic``, ``gvf``) use the nearest vertex. ``report['points']``
        says which, with the largest distance; :attr:`Reconstruction.points`
        keeps the located points.
    vals : (k,) or (k, p) array_like of float
        Sample values, one column per field.
    options : Options, optional
        All the options below as one object, built and checked once
        (:class:`manifill.surface.options.Options`); keywords given beside it change it.
    method : {None, 'default', 'gvf-harmonic', 'harmonic', 'biharmonic', 'triharmonic', 'hessian', \
'hessian-curved', 'gvf', 'rbf', 'gp', 'auto'}
        Each method is one object of the registry (:mod:`manifill.surface.methods.registry`):

        - None or ``'default'``: the default preset, chosen by measurement
          (:mod:`manifill.surface.methods.default`): the biharmonic with ``bounds='samples'`` and
          ``bounds_mode='project'`` (each unless given); on a surface without triangles, the paper's pipeline
          with monotone curve values, bounded. ``report['preset']`` is ``'default'``.
        - ``'gvf-harmonic'``: the paper's whole pipeline (Steps 1-6), unbounded unless ``bounds`` is given.
        - ``'harmonic'``, ``'biharmonic'``, ``'triharmonic'``: the k-harmonic energy with the samples alone
          fixed (:mod:`manifill.surface.energy_fill`).
        - ``'hessian'``, ``'hessian-curved'``: the squared Hessian with the samples fixed (flat; libigl's
          curved one, the ``[hessian]`` extra: no bending at a surface's boundary, :mod:`manifill.mesh.hessian`).
        - ``'gvf'``: the gradually varied fit of the whole surface (every vertex but the samples on a level).
        - ``'rbf'``: the thin-plate spline on the positions, for fields that live in space
          (:mod:`manifill.surface.rbf`; ``smoothing`` a number).
        - ``'gp'``: a Matérn Gaussian process: its mean, and its std (see ``gp``).
        - ``'auto'``: the default unless another candidate's 5-fold cross-validation error is lower by more
          than one standard error, field by field (:mod:`manifill.surface.methods.auto`; ``report['auto']``
          gives the table and the choice of every field).
    partition : {'delaunay', 'cycle', 'tree'}, optional
        How the curves are drawn (:mod:`manifill.surface.partition`).
    weights : {'cotan', 'uniform', 'intrinsic', 'robust'}, optional
        Laplacian weights of the harmonic fill.
    distance : {'length', 'hops'}, optional
        What the partition's shortest paths minimise. Step 1 (levels and the
        Lipschitz constant in ``report['check']``) always measures hops, as the
        paper's gradual variation does.
    levels : None, int or (m,) array_like, optional
        Value levels for Step 1 (see :func:`manifill.surface.gradual.check_gradual`);
        by default the finest uniform step at which the samples satisfy the
        condition. With ``curve_values='gvf'`` or ``method='gvf'`` a
        violation is an error; otherwise it is reported.
    curve_values : {None, 'hermite', 'monotone', 'linear', 'gvf'}, optional
        Step 4 (:mod:`manifill.surface.curve_values`): cubic along each path with slopes
        from estimated gradients (linear in the data; may overshoot, reported as
        ``report['overshoot']``), the monotone cubic (never outside the neighbouring
        samples), linear in arc length, or the paper's gradually varied fit on the
        levels. None: ``'monotone'`` for the default method, ``'hermite'`` for an
        explicit ``method='gvf-harmonic'``.
    solver : {'auto', 'direct', 'amg', 'iterate'}, optional
        Linear solver of the harmonic fill.
    on_empty : {'error', 'nan'}, optional
        A mesh component without samples: raise, or leave it NaN.
    duplicates : {'error', 'mean'}, optional
        Several samples on one vertex with different values: raise, or average.
    iteration : {'gauss-seidel', 'jacobi'}, optional
        Sweeps of ``solver='iterate'``.
    init : {'gvf', 'random', 'mean'}, optional
        Initial values of ``solver='iterate'`` (the paper's Step 5: random, or
        the GVF fit, which it says converges faster).
    seed : int, optional
        Seed of ``init='random'``.
    tol, maxiter : optional
        Passed to the solver.
    bounds : None, 'samples' or (lo, hi), optional
        Per field (``'samples'``: each field's sample range), kept as ``bounds_mode`` says. Samples outside
        the bounds are refused.
    bounds_mode : {None, 'exact', 'project'}, optional
        ``'project'`` (the default preset's): the field without bounds, each value beyond them set to the
        bound (any method; ``report['bounds']`` counts them and says how far they went). ``'exact'`` (None):
        energy methods: the minimiser of the energy subject to the bounds (an active set), not a clip;
        ``gvf-harmonic``: Step 4's curve values projected onto the bounds, then the bounded harmonic fill;
        ``gvf``: checked only (its values are levels within the samples' range); ``rbf`` and ``gp`` refuse
        exact bounds.
    smoothing : None, float >= 0 or 'auto', optional
        Energy methods only: soft constraints with this lambda (``'auto'``:
        generalised cross-validation); ``report['fill']['smoothing']``
        gives lambda and the residuals at the samples.
    sample_weights : (k,) array_like of float, optional
        Weights of the soft constraints (with ``smoothing``).
    neighbours : int, optional
        A point cloud's nearest neighbours per point (at least 6; default 16), for its Laplacian, mass and graph.
    barriers : list of (l,) int arrays, list of (l, 3) arrays, (m,) int array, str or Path, optional
        Lines the field must not cross: paths of vertex indices, polylines of positions (snapped to vertices), per-face
        labels (a barrier between faces of different labels), or a file of them
        (:func:`manifill.io.read_barriers`). The mesh is cut along them (:mod:`manifill.surface.barriers`); a sample
        on a barrier holds on both sides; with ``method='gp'`` and ``gp={'barrier': 'bakka'}``, Bakka's model
        instead.
    max_distance : float, optional
        For sample positions: the largest accepted distance to the surface (the
        default as for :func:`manifill.surface.samples.snap_to_vertices`).
    gp : None, dict or GPOptions, optional
        ``method='gp'``'s options (:class:`manifill.GPOptions`: alpha, range, sigma,
        noise, mean, share, variance, samples, seed, fit_samples); ``report['gp']``
        gives the hyperparameters, the likelihood and how the variance was computed.
        With ``uncertainty`` for an energy method, only ``variance``, ``samples`` and
        ``seed`` apply.
    uncertainty : None or bool, optional
        Compute :attr:`Reconstruction.std`. None: True for ``method='gp'`` (or with
        ``trust``). For harmonic, biharmonic and triharmonic: the std of the intrinsic
        Gaussian field whose conditional mean the method's result is
        (:mod:`manifill.surface.gp`); refused for the other methods and with ``bounds``.
    trust : float, optional
        Mark as not trusted every vertex where a field's std exceeds ``trust`` times
        the standard deviation of its samples (:attr:`Reconstruction.trusted`).
    untrusted : {'mask', 'nan'}, optional
        What ``trust`` does there: only the mask, or the value NaN too.
    check : None or bool, optional
        Step 1 (levels, Lipschitz constant, gradual variation: ``report['check']``)
        per field: None runs it for up to :data:`~manifill.surface.methods.CHECK_FIELDS`
        fields and skips it for more (``report['check_skipped']`` says so); True for
        every field; False for none. It runs whatever this says where its levels are
        needed (``method='gvf'``, ``curve_values='gvf'``).
    progress : callable, optional
        Called with the name of each step as it starts (e.g.
        :class:`manifill.progress.StepBar`).

    Returns
    -------
    Reconstruction

    Raises
    ------
    MeshError, SampleError, OptionError, SolveError
        On malformed input, broken gradual variation where it is required, or
        a component without samples (``on_empty='error'``).

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(3)
    >>> idx = np.arange(0, 642, 40)
    >>> r = reconstruct(V, F, idx, V[idx, 0] + V[idx, 2])
    >>> bool(np.allclose(r.values[idx], V[idx, 0] + V[idx, 2])), r.report["method"], r.report["bounds"]["mode"]
    (True, 'biharmonic', 'project')
    >>> reconstruct(V, F, idx, V[idx, 0] + V[idx, 2], method="gvf-harmonic").report["partition"]["method"]
    'delaunay'
    """
    t0 = time.perf_counter()
    shape = np.shape(vals)
    fields = 1 if len(shape) < 2 else int(shape[1])
    tick(progress, "graph")  # the bar's first step (validation and the graph, in the Reconstructor)
    rec = Reconstructor(V, F, idx, options=options, fields=max(fields, 1), prepare=False, progress=progress,
                        **keywords)
    r = rec.apply(vals, progress=progress)
    seconds = r.report["seconds"]
    prepared = dict(rec.seconds)
    prepared["validate"] += seconds.pop("validate", 0.0)
    r.report["seconds"] = {**prepared, **seconds}
    r.report["seconds"]["total"] = time.perf_counter() - t0
    return r


#: Public names renamed, kept one release with a warning (:mod:`manifill.deprecation`).
__getattr__ = renamed(__name__, {"METHODS": "manifill.surface.reconstruct:METHOD_NAMES"})
