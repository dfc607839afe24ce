"""The paper's reconstruction on a surface, Steps 1-6, composed of its public steps.

:func:`reconstruct` validates a mesh and samples, builds the
:class:`~manifill.surface.surface.Surface` (:mod:`manifill.surface.surface`) and runs
:func:`reconstruct_surface`, which composes the steps, each a public function:

1. Steps 2-3, :func:`manifill.surface.partition.partition`: curves through every
   sample cut the surface into patches (a :class:`~manifill.surface.partition.Partition`;
   run first, since its curves bound Step 1's Lipschitz constant from below).
2. Step 1, :func:`manifill.surface.gradual.check_gradual`: levels and the gradual
   variation condition, per field (a :class:`~manifill.surface.gradual.GradualCheck`).
3. Step 4, :func:`manifill.surface.curve_values.values_on_curves`: a value at every
   curve vertex (a :class:`~manifill.surface.curve_values.CurveValues`).
4. Steps 5-6, :func:`manifill.surface.fill.fill_patches`: the harmonic fill of every
   patch with the curve values fixed.

``gvf-harmonic`` (the default) runs them all; ``harmonic`` fixes only the samples (the
naive baseline: Step 1, then Steps 5-6); ``gvf`` stops at the gradually varied fit of
the whole surface (:func:`manifill.surface.fill.gvf_fill`). The result is a
:class:`Reconstruction`, of the result family of :mod:`manifill.results`.
"""

import time

import numpy as np

from ..errors import OptionError, SampleError
from ..progress import tick
from .curve_values import values_on_curves
from .curve_map import LINEAR_CURVE_VALUES, curve_map
from .energy_fill import ENERGY_METHODS, as_bounds, energy_fill
from .fill import INITS, fill_patches, gvf_fill, start_values
from .gradual import check_gradual, violation_message
from .partition import partition as _partition
from .points import points_report
from .methods import CHECK_FIELDS, DEFAULT, METHODS, STEPS, check_options, resolve_default, runs_check
from .prepared import cached
from ..linalg.gp import as_gp_options
from .gp import check_gp_for, check_uncertainty, energy_uncertainty, reconstruct_gp, trust_mask
from .reconstruction import Reconstruction

__all__ = ["METHODS", "STEPS", "INITS", "DEFAULT", "Reconstruction", "reconstruct", "reconstruct_surface",
           "check_options", "resolve_default"]

def reconstruct(V, F, idx, vals, *, method=None, partition="delaunay", weights="cotan",
                distance="length", levels=None, curve_values=None, solver="auto",
                on_empty="error", duplicates="error", iteration="gauss-seidel", init="gvf", seed=0,
                tol=None, maxiter=None, bounds=None, smoothing=None, sample_weights=None, max_distance=None,
                gp=None, uncertainty=None, trust=None, untrusted="mask", check=None, progress=None):
    """Reconstruct a field on a surface from a few samples (the paper's Steps 1-6).

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles, any integer dtype.
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
    method : {None, 'gvf-harmonic', 'harmonic', 'biharmonic', 'triharmonic', 'gvf', 'rbf', 'auto'}, optional
        None (the default): :data:`DEFAULT`, chosen by measurement: the paper's
        pipeline with ``curve_values='monotone'`` and ``bounds='samples'`` (each
        unless given; ``report['default']`` is True). The whole pipeline
        (the paper's method, unbounded unless ``bounds`` is given); harmonic, biharmonic or triharmonic with the
        samples alone fixed (the k-harmonic energy,
        :mod:`manifill.surface.energy_fill`); the gradually varied fit of
        the whole surface (every vertex but the samples on a level); the
        thin-plate spline on the positions, for fields that live in space
        (:mod:`manifill.surface.rbf`; ``smoothing`` a number); or the
        default candidate with the lowest 5-fold cross-validation error
        (:mod:`manifill.surface.crossval`; ``report['auto']`` gives the table).
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
        Per field (``'samples'``: each field's sample range). Energy methods: the
        minimiser of the energy subject to the bounds (an active set), not a
        clip. ``gvf-harmonic``: Step 4's curve values are projected onto the
        bounds, then the harmonic fill is the bounded minimiser (with negative
        cotangent weights the discrete maximum principle alone would not keep it
        inside). ``gvf``: checked only (its values are levels within the samples'
        range). ``rbf`` refuses bounds. Samples outside the bounds are refused.
    smoothing : None, float >= 0 or 'auto', optional
        Energy methods only: soft constraints with this lambda (``'auto'``:
        generalised cross-validation); ``report['harmonic']['smoothing']``
        gives lambda and the residuals at the samples.
    sample_weights : (k,) array_like of float, optional
        Weights of the soft constraints (with ``smoothing``).
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
    >>> bool(np.allclose(r.values[idx], V[idx, 0] + V[idx, 2])), r.report["partition"]["method"]
    (True, 'delaunay')
    """
    from .reconstructor import Reconstructor

    t0 = time.perf_counter()
    shape = np.shape(vals)
    fields = 1 if len(shape) < 2 else int(shape[1])
    tick(progress, "graph")  # the bar's first step (validation and the graph, in the Reconstructor)
    rec = Reconstructor(V, F, idx, method=method, partition=partition, weights=weights, distance=distance,
                        levels=levels, curve_values=curve_values, solver=solver, on_empty=on_empty,
                        duplicates=duplicates, iteration=iteration, init=init, seed=seed, tol=tol, maxiter=maxiter,
                        bounds=bounds, smoothing=smoothing, sample_weights=sample_weights, max_distance=max_distance,
                        gp=gp, uncertainty=uncertainty, trust=trust, untrusted=untrusted, check=check,
                        fields=max(fields, 1), prepare=False, progress=progress)
    r = rec.apply(vals, progress=progress)
    seconds = r.report["seconds"]
    prepared = dict(rec.seconds)
    prepared["validate"] += seconds.pop("validate", 0.0)
    r.report["seconds"] = {**prepared, **seconds}
    r.report["seconds"]["total"] = time.perf_counter() - t0
    return r


def reconstruct_surface(surface, idx, vals, *, method=None, partition="delaunay", weights="cotan",
                        levels=None, curve_values=None, solver="auto", on_empty="error",
                        iteration="gauss-seidel", init="gvf", seed=0, tol=None, maxiter=None, bounds=None,
                        smoothing=None, sample_weights=None, progress=None, seconds=None, points=None, gp=None,
                        uncertainty=None, trust=None, untrusted="mask", check=None, fields=None, prepared=None):
    """Steps 1-6 on a Surface and validated samples.

    Parameters
    ----------
    surface : Surface
        A mesh (:meth:`manifill.surface.surface.Surface.from_mesh`) or a digital surface.
    idx : (k,) int64 numpy array
        Sample vertices, sorted and unique (as :func:`manifill.validate.as_samples` returns them).
    vals : (k, p) float64 numpy array
        Sample values, one column per field (always two-dimensional).
    method, partition, weights, levels, curve_values, solver, on_empty, iteration, init, seed, tol, maxiter, progress
        As for :func:`reconstruct`.
    gp, uncertainty, trust, untrusted
        As for :func:`reconstruct`.
    points : PointSamples, optional
        Samples given as positions (:func:`manifill.surface.points.point_samples`);
        ``idx`` and ``vals`` are then their nearest vertices (the partition
        methods' samples), and the energy methods constrain the points themselves.
    check : None or bool, optional
        Step 1 (see :func:`reconstruct`).
    fields : int, optional
        How many fields will share the value-independent pieces (default: ``vals``'
        columns); with many, ``solver='auto'`` factorises and Step 4's linear curve
        values become one sparse map.
    prepared : Prepared, optional
        Keeps those pieces for the next call with the same samples
        (:mod:`manifill.surface.prepared`; what :class:`manifill.Reconstructor` passes).
    seconds : dict, optional
        Timings the caller measured before (e.g. ``validate``, ``graph``). The
        result's ``report['seconds']`` is this dict, filled in place with one
        entry per step run and ``total``: the given entries' sum plus the time
        spent here.

    Returns
    -------
    Reconstruction
        With ``values`` of shape (n, p), never squeezed: a caller with one
        field given as a (k,) array takes ``values[:, 0]`` (as :func:`reconstruct` does).

    Raises
    ------
    OptionError, SampleError, SolveError
        As for :func:`reconstruct`.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> from manifill.surface.surface import Surface
    >>> V, F = icosphere(2)
    >>> idx = np.array([0, 10, 50, 90, 120])
    >>> r = reconstruct_surface(Surface.from_mesh(V, F), idx, V[idx, :1] * 2.0)
    >>> r.values.shape, bool(np.allclose(r.values[idx, 0], V[idx, 0] * 2.0))
    ((162, 1), True)
    """
    t0 = time.perf_counter()
    seconds = {} if seconds is None else seconds
    before = sum(seconds.values())
    default = method is None
    method, curve_values, bounds = resolve_default(method, curve_values, bounds)
    check_options(method, partition, weights, "length", curve_values, solver, on_empty, iteration, init)
    uncertainty = check_uncertainty(method, uncertainty, trust, untrusted, None if default else bounds)
    check_gp_for(method, gp, uncertainty)
    if method == "rbf":  # the thin-plate spline in space (manifill.surface.rbf)
        from .rbf import reconstruct_rbf

        return reconstruct_rbf(surface, idx, vals, levels=levels, bounds=bounds, smoothing=smoothing,
                               sample_weights=sample_weights, progress=progress, seconds=seconds, points=points,
                               check=runs_check(check, method, None, solver, init, vals.shape[1]))
    if method == "auto":  # cross-validate the default candidates, fit the best (manifill.surface.crossval)
        from .crossval import reconstruct_auto

        options = dict(partition=partition, weights=weights, levels=levels, curve_values=curve_values, solver=solver,
                       on_empty=on_empty, iteration=iteration, init=init, seed=seed, tol=tol, maxiter=maxiter,
                       bounds=bounds, smoothing=smoothing, sample_weights=sample_weights)
        return reconstruct_auto(surface, idx, vals, options=options, progress=progress, seconds=seconds,
                                points=points)
    if method == "gp" and (bounds is not None or smoothing is not None or sample_weights is not None):
        raise OptionError("method='gp' takes its noise as gp={'noise': ...} and has no bounds; leave bounds, "
                          "smoothing and sample_weights out")
    if (smoothing is not None or sample_weights is not None) and method not in ENERGY_METHODS:
        raise OptionError(f"smoothing and sample_weights apply to the energy methods "
                          f"({', '.join(ENERGY_METHODS)}) and rbf, not to method={method!r}; pick one of those")
    # the partition methods' bounds: checked here, applied to the curve values and the fill below
    lohi = as_bounds(bounds, vals) if method in ("gvf-harmonic", "gvf") else None
    n = len(surface.V)
    report = {"method": method, "curve_values": curve_values if method == "gvf-harmonic" else None,
              "samples": int(idx.size), "vertices": n, "seconds": seconds}

    # Steps 2-3 first when they run: the hop length of every curve bounds the Lipschitz
    # constant of Step 1 from below, which saves Step 1 a shortest-path pass
    p = vals.shape[1]
    fields = p if fields is None else fields
    run_check = runs_check(check, method, curve_values, solver, init, p)
    part, starts = None, [None] * p
    if method == "gvf-harmonic":
        tick(progress, "partition")
        t = time.perf_counter()
        part = cached(prepared, "partition", lambda: _partition(surface.V, surface.F, idx, surface.G,
                                                                method=partition))
        seconds["partition"] = time.perf_counter() - t
        if run_check:
            starts = part.steepest(idx, vals)

    # Step 1: levels and the gradual variation condition (hop distance), per field
    tick(progress, "check")
    t = time.perf_counter()
    checks = []
    if run_check:
        checks = [check_gradual(surface.G_hops, idx, vals[:, j], levels=levels, distance="hops", start=starts[j])
                  for j in range(p)]
    else:
        report["check_skipped"] = (f"Step 1 was not run for {p} fields (more than {CHECK_FIELDS}); "
                                   f"pass check=True (CLI --check) to run it for every field")
    if method == "gvf" or curve_values == "gvf":
        for c in checks:
            if not c.holds:
                raise SampleError(violation_message(c))
    report["check"] = [c.summary() for c in checks]
    seconds["check"] = time.perf_counter() - t

    curves, components = [], np.zeros(n, dtype=np.int64)
    fixed = np.zeros(n, dtype=bool)
    fixed[idx] = True
    std = None
    if method == "gvf":
        tick(progress, "gvf")
        t = time.perf_counter()
        values = gvf_fill(surface, idx, vals, checks, on_empty=on_empty)
        seconds["gvf"] = time.perf_counter() - t
    elif method == "gp":  # the Matérn field's posterior (manifill.surface.gp)
        tick(progress, "gp")
        t = time.perf_counter()
        values, std, report["gp"] = reconstruct_gp(surface, idx, vals, gp=gp, weights=weights, solver=solver,
                                                   points=points, with_std=uncertainty)
        seconds["gp"] = time.perf_counter() - t
    elif method in ENERGY_METHODS and (method != "harmonic" or bounds is not None or smoothing is not None
                                       or (points is not None and points.inside)):
        # the samples alone as constraints, on the k-harmonic energy (bounded or smoothed if asked)
        step = f"{method} fill"
        tick(progress, step)
        t = time.perf_counter()
        eidx, evals, Aeq, beq, w = idx, vals, None, None, sample_weights
        if points is not None:  # the points themselves: vertex constraints and barycentric rows
            eidx, evals, w = points.idx, points.vals, None if w is None else points.weights(w)
            Aeq, beq = (points.Aeq, points.beq) if points.inside else (None, None)
        values, report["harmonic"] = energy_fill(
            surface, eidx, evals, k=ENERGY_METHODS[method], weights=weights, solver=solver, on_empty=on_empty,
            bounds=bounds, smoothing=smoothing, sample_weights=w, tol=tol, maxiter=maxiter, Aeq=Aeq, beq=beq,
            fields=fields, prepared=prepared)
        seconds["harmonic"] = time.perf_counter() - t
    else:
        b, bc = (idx, vals) if points is None or method not in ENERGY_METHODS else (points.idx, points.vals)
        if method == "gvf-harmonic":
            # Step 4: values on the curves of the partition (Steps 2-3, above)
            report["partition"] = part.report
            curves, components, fixed = part.curves, part.labels, part.on_curve.copy()
            tick(progress, "curve values")
            t = time.perf_counter()
            if curve_values in LINEAR_CURVE_VALUES and fields >= idx.size:
                # many fields: Step 4's linear curve values as one sparse map, built once
                b, C = cached(prepared, "curve map", lambda: curve_map(surface, part, idx, curve_values))
                bc = C @ vals
            else:
                b, bc = values_on_curves(surface, part, idx, vals, method=curve_values, checks=checks)
            if lohi is not None:  # curve values projected onto the bounds (the samples lie within them)
                cols = bc if bc.ndim == 2 else bc[:, None]
                clipped = np.clip(cols, lohi[0], lohi[1])
                report["bounds"] = {"lo": lohi[0].tolist(), "hi": lohi[1].tolist(),
                                    "clipped_curve_values": int((clipped != cols).sum())}
                bc = clipped.reshape(bc.shape)
            seconds["curve_values"] = time.perf_counter() - t
        # Steps 5-6: harmonic fill of every patch (bounded: the minimiser within the bounds, an active set that
        # stops at once where the maximum principle holds, i.e. without negative cotangent weights)
        tick(progress, "harmonic fill")
        t = time.perf_counter()
        values, report["harmonic"] = fill_patches(
            surface, b, bc, weights=weights, solver=solver, on_empty=on_empty, iteration=iteration,
            x0=lambda: start_values(init, surface, idx, vals, checks=checks, seed=seed), tol=tol, maxiter=maxiter,
            fields=fields, prepared=prepared,
            largest=max(part.report["patch_sizes"] or [0]) if part is not None else None,
            **({} if lohi is None or method != "gvf-harmonic" else {"lo": lohi[0], "hi": lohi[1]}))
        values = values if values.ndim == 2 else values[:, None]
        seconds["harmonic"] = time.perf_counter() - t
    if uncertainty and method != "gp":  # the energy method read as an intrinsic Gaussian field
        tick(progress, "uncertainty")
        t = time.perf_counter()
        o = as_gp_options(gp)
        std, report["uncertainty"] = energy_uncertainty(
            surface, ENERGY_METHODS[method], weights, idx, vals, points, values, report.get("harmonic", {}),
            sample_weights=(sample_weights if sample_weights is None or points is None
                            else points.weights(sample_weights)),
            solver="direct" if solver == "iterate" else solver,
            variance=o.variance, samples=o.samples, seed=o.seed)
        seconds["uncertainty"] = time.perf_counter() - t
    trusted = None
    if trust is not None:
        values, trusted, report["trust"] = _trusted(values, std, vals if points is None else points.values, trust,
                                                     untrusted)
    rng = vals if points is None else points.values
    lo, hi = rng.min(axis=0), rng.max(axis=0)
    # per column first (reductions, no (n, p) temporaries); fmax/fmin skip NaN (untrusted vertices)
    d = np.maximum(np.fmax.reduce(values, axis=0) - hi, lo - np.fmin.reduce(values, axis=0))
    over = float(np.nanmax(d)) if np.isfinite(d).any() else 0.0
    report["overshoot"] = over
    if points is not None:
        report["points"] = points_report(points, method in ENERGY_METHODS or method == "gp")
    seconds["total"] = before + time.perf_counter() - t0
    return Reconstruction(values=values, curves=curves, components=components, on_curve=fixed,
                          levels=[c.levels for c in checks], report=report, V=surface.V, F=surface.F, idx=idx,
                          points=None if points is None else points.located, std=std, trusted=trusted)


def _trusted(values, std, sample_vals, trust, untrusted):
    values, ok, threshold = trust_mask(values, std, sample_vals, trust, untrusted)
    return values, ok, {"threshold": threshold, "untrusted": int((~ok).sum()), "marked": untrusted}
