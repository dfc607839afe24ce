"""Which method to trust: K-fold cross-validation on the samples themselves, and ``method="auto"``.

:func:`cross_validate` splits the samples into ``folds`` groups at random (seeded), fits
every candidate method on all groups but one and measures it at the held-out samples:
the error is the root mean square there divided by each field's sample range (a
:class:`CrossValidation`, with ``.best``, ``.table()`` and ``.recommendation``). The
surface (graphs, Laplacians) is built once and every fold goes through
:func:`manifill.surface.reconstruct.reconstruct_surface`.

The default candidates (:data:`CANDIDATES`) are ``gvf-harmonic`` (the default
pipeline), ``gvf-harmonic`` with ``curve_values='monotone'``, ``harmonic``,
``biharmonic``, ``biharmonic`` with ``bounds='samples'``, ``triharmonic`` and ``rbf``
(the thin-plate spline in space, :mod:`manifill.surface.rbf`: it wins where the field
lives in space rather than on the surface); the bi- and triharmonic ones are left out
on a digital surface (no triangles). Options given to :func:`cross_validate` go to every
candidate; a candidate's own options override them. Samples may be vertex indices or
positions (``(k, 3)``, located on the surface as :func:`manifill.reconstruct` locates them).

``reconstruct(..., method="auto")`` cross-validates :data:`AUTO_CANDIDATES` (the default
candidates less the bounded biharmonic, which costs most) with
:data:`AUTO_FOLDS` folds (leave-one-out below that many samples; the split seeded by
``seed``), then reconstructs with the lowest-error one on all samples: the result equals
``reconstruct(..., method=<chosen>, <its options>)``, and ``report['auto']`` holds the
table. For other folds or candidates, call :func:`cross_validate` and pass
``**cv.best_options`` to :func:`manifill.reconstruct`.
"""

import time

import numpy as np

from ..errors import ManifillError, OptionError, SampleError, SolveError
from ..progress import tick
from ..validate import check_option
from .crossval_result import CrossValidation
from .energy_fill import ENERGY_METHODS
from .locate import locate_points
from .points import is_positions, point_samples
from .reconstruct import METHODS, check_options, reconstruct_surface
from .surface import Surface

__all__ = ["CANDIDATES", "AUTO_CANDIDATES", "AUTO_FOLDS", "MIN_SAMPLES", "CrossValidation", "cross_validate",
           "fold_labels", "reconstruct_auto"]

#: The default candidates: ``(method, options)``.
CANDIDATES = (("gvf-harmonic", {}), ("gvf-harmonic", {"curve_values": "monotone"}), ("harmonic", {}),
              ("biharmonic", {}), ("biharmonic", {"bounds": "samples"}), ("triharmonic", {}), ("rbf", {}))
#: The candidates of ``method="auto"``: the default ones less the bounded biharmonic, whose active set costs
#: 5-20x the others per fold at 41k vertices (docs/NOTES.md), so that ``auto`` costs a few times one fit.
AUTO_CANDIDATES = tuple(c for c in CANDIDATES if c != ("biharmonic", {"bounds": "samples"}))
#: Folds of ``method="auto"``.
AUTO_FOLDS = 5
#: Fewest samples cross-validation accepts (every fit then has at least two).
MIN_SAMPLES = 3
#: The options of :func:`cross_validate` besides its own, passed to every fit.
FIT_OPTIONS = ("partition", "weights", "levels", "curve_values", "solver", "iteration", "init", "tol", "maxiter",
               "bounds", "smoothing", "sample_weights")
#: Options that shape the surface or the samples, not a fit (refused per candidate).
SURFACE_OPTIONS = ("distance", "duplicates", "max_distance")
#: The methods that constrain samples given as positions where they are (the others use the nearest vertex).
AT_POINTS = tuple(ENERGY_METHODS) + ("rbf",)


def fold_labels(k, folds, seed=0):
    """The fold of each of ``k`` samples: a seeded random split into near-equal groups, or one each (``"loo"``).

    Parameters
    ----------
    k : int
        Number of samples.
    folds : int >= 2 or 'loo'
    seed : int, optional

    Returns
    -------
    (k,) int64 numpy array
        Values ``0 .. folds-1``, each used ``k // folds`` or ``k // folds + 1`` times.

    Raises
    ------
    OptionError
        ``folds`` not an int >= 2 or ``'loo'``.
    SampleError
        Fewer samples than folds (or than :data:`MIN_SAMPLES`), naming the number needed.

    Examples
    --------
    >>> np.bincount(fold_labels(11, 3)).tolist(), fold_labels(4, "loo").tolist()
    ([4, 4, 3], [0, 1, 2, 3])
    """
    loo = isinstance(folds, str)
    if loo and folds != "loo" or not loo and (isinstance(folds, bool) or not isinstance(folds, (int, np.integer))
                                              or folds < 2):
        raise OptionError(f"folds={folds!r} is not an integer >= 2 or 'loo'; pass one of those")
    need = MIN_SAMPLES if loo else max(int(folds), MIN_SAMPLES)
    if k < need:
        fix = (f"use {k} folds or fewer, or leave-one-out ('loo')" if k >= MIN_SAMPLES else
               f"add samples (cross-validation needs at least {MIN_SAMPLES})")
        raise SampleError(f"{'leave-one-out' if loo else f'{folds}-fold'} cross-validation needs at least {need} "
                          f"samples, got {k}; {fix}")
    if loo:
        return np.arange(k, dtype=np.int64)
    labels = np.empty(k, dtype=np.int64)
    labels[np.random.default_rng(seed).permutation(k)] = np.arange(k) % int(folds)
    return labels


def candidates_of(methods, digital=False):
    """``{label: (method, options)}`` from names or ``(name, options)`` pairs (None: :data:`CANDIDATES`)."""
    given = methods is not None
    if methods is None:
        methods = [c for c in CANDIDATES if not (digital and c[0] in ("biharmonic", "triharmonic"))]
    if isinstance(methods, str) or isinstance(methods, tuple) and len(methods) == 2 and isinstance(methods[1], dict):
        methods = [methods]  # one candidate alone
    out = {}
    allowed = [m for m in METHODS if m != "auto"]
    for c in methods:
        name, opts = (c, {}) if isinstance(c, str) else (tuple(c) if isinstance(c, (tuple, list)) else (None, None))
        if not isinstance(name, str) or not isinstance(opts, dict):
            raise OptionError(f"methods entry {c!r} is neither a method name nor a (name, options-dict) pair; "
                              f"pass e.g. ['harmonic', ('biharmonic', {{'bounds': 'samples'}})]")
        if name == "auto":
            raise OptionError("method='auto' is what cross-validation chooses for; list actual methods as candidates")
        check_option("method", name, allowed)
        bad = [key for key in opts if key not in FIT_OPTIONS]
        if bad:
            raise OptionError(f"candidate {name!r} has option {bad[0]!r}, not one a fit takes "
                              f"({', '.join(FIT_OPTIONS)}); pass surface options to cross_validate itself")
        label = " ".join([name] + [f"{k}={v}" for k, v in opts.items()])
        if label in out:
            raise OptionError(f"candidate {label!r} is listed twice; list each once")
        out[label] = (name, dict(opts))
    if not out:
        raise OptionError("methods is empty; pass at least one candidate (or None for the defaults)")
    if given and digital:
        for label, (name, _) in out.items():
            if name in ("biharmonic", "triharmonic"):
                raise OptionError(f"candidate {label!r} needs triangles; a digital surface has none: leave it out")
    return out


def cross_validate(V, F, idx, vals, methods=None, folds=10, seed=0, **options):
    """Each method's K-fold (or leave-one-out) error on the samples themselves.

    Parameters
    ----------
    V : (n, 3) array_like, or Surface
        Vertex positions; or a built :class:`manifill.surface.surface.Surface`
        (e.g. a digital surface) with ``F`` None.
    F : (m, 3) array_like of int or None
        Triangles.
    idx : (k,) array_like of int, or (k, 3) array_like of float
        Sample vertices; or sample positions, each located at its closest surface
        point (:mod:`manifill.surface.points`): every fold's fit gets its training
        points as :func:`manifill.reconstruct` would (exactly there for the energy
        methods and ``rbf``, at the nearest vertex for the others), and is measured
        at the held-out points by barycentric interpolation on their faces.
    vals : (k,) or (k, p) array_like of float
        Sample values, one column per field.
    methods : list, optional
        Candidates: method names of :func:`manifill.reconstruct` or ``(name, options)``
        pairs, e.g. ``["harmonic", ("biharmonic", {"bounds": "samples"})]``; by default
        :data:`CANDIDATES` (the bi- and triharmonic ones left out on a digital surface).
    folds : int >= 2 or 'loo', optional
        Number of groups of the random split, or leave-one-out.
    seed : int, optional
        Seed of the split (and of ``init='random'``).
    **options
        ``distance``, ``duplicates``, ``max_distance`` (how the surface and the samples are read) and the
        options of :func:`manifill.reconstruct` every fit gets (``weights``, ``solver``,
        ``partition``, ``bounds``, ...); a candidate's own options override them. Every
        fold is fitted with ``on_empty='nan'``: a held-out sample in a mesh component
        without training samples has no prediction, is left out and counted.

    Returns
    -------
    CrossValidation

    Raises
    ------
    MeshError, SampleError
        Malformed input; fewer samples than folds (the message names how many are needed).
    OptionError
        An unknown method or option, ``folds`` not an int >= 2 or ``'loo'``.

    See Also
    --------
    manifill.reconstruct : ``method='auto'`` picks by this.

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> V, F = grid(8)
    >>> idx = np.arange(0, 64, 5)
    >>> cv = cross_validate(V, F, idx, 2 * V[idx, 0] - V[idx, 1], methods=["harmonic", "rbf"], folds=4)
    >>> cv.best, cv.errors["rbf"] < 1e-9
    ('rbf', True)
    """
    from ..validate import as_mesh, as_samples, as_values

    bad = [key for key in options if key not in FIT_OPTIONS + SURFACE_OPTIONS]
    if bad:
        raise OptionError(f"cross_validate takes no option {bad[0]!r}; pass those of reconstruct "
                          f"({', '.join(FIT_OPTIONS + SURFACE_OPTIONS)})")
    distance, duplicates = options.pop("distance", "length"), options.pop("duplicates", "error")
    max_distance = options.pop("max_distance", None)
    check_options(**{key: options[key] for key in ("partition", "weights", "curve_values", "solver", "iteration",
                                                   "init") if key in options}, distance=distance)
    if isinstance(V, Surface):
        if F is not None:
            raise OptionError("pass F=None with a Surface (it has its own triangles, or none)")
        surface = V
    else:
        V, F = as_mesh(V, F, allow_degenerate=options.get("weights", "cotan") in ("uniform", "robust"))
        surface = Surface.from_mesh(V, F, distance=distance, check=False)
    cands = candidates_of(methods, digital=surface.F is None)
    if is_positions(idx):
        if surface.F is None:
            raise SampleError("samples as positions need triangles to be located on; pass vertex indices")
        P = np.asarray(idx, dtype=np.float64)
        vals, _ = as_values(vals, len(P))
        loc = locate_points(surface.V, surface.F, P, max_distance=max_distance)
        return run_folds(surface, loc.nearest_vertex, vals, cands, folds=folds, seed=seed, options=options,
                         positions=(P, loc, duplicates))
    if max_distance is not None:
        raise OptionError("max_distance applies to samples given as positions, not vertex indices; leave it out")
    raw = np.asarray(idx)
    idx, vals, _ = as_samples(idx, vals, surface.n, duplicates=duplicates)
    if options.get("sample_weights") is not None:
        if idx.size != raw.size:
            raise SampleError("sample_weights with repeated sample vertices: merge the samples first, one per vertex")
        options["sample_weights"] = np.asarray(options["sample_weights"], dtype=np.float64)[np.argsort(raw)]
    return run_folds(surface, idx, vals, cands, folds=folds, seed=seed, options=options)


def run_folds(surface, idx, vals, candidates, *, folds, seed, options, positions=None):
    """Cross-validate validated samples on a Surface (what :func:`cross_validate` does after validation).

    Parameters
    ----------
    surface : Surface
    idx : (k,) int64 numpy array
        Sorted unique sample vertices.
    vals : (k, p) numpy array
    candidates : dict of str to (str, dict)
        Label -> ``(method, options)``.
    folds, seed
        As for :func:`cross_validate`.
    options : dict
        Options of every fit (a candidate's override them; ``on_empty`` is set to ``'nan'``).
    positions : (P, SurfacePoints, duplicates), optional
        Samples given as positions ``P`` (``(k, 3)``), located; ``idx`` is then unused.

    Returns
    -------
    CrossValidation
    """
    k, p = vals.shape
    labels = fold_labels(k, folds, seed)
    nf = int(labels.max()) + 1
    span = vals.max(axis=0) - vals.min(axis=0)
    span = np.where(span > 0, span, 1.0)  # a constant field: absolute errors
    sw = options.get("sample_weights")
    res = {key: {} for key in ("errors", "field_errors", "fold_errors", "seconds", "failures", "excluded")}
    for label, (name, own) in candidates.items():
        fit = {**options, **own, "on_empty": "nan", "seed": seed}
        pred = np.full((k, p), np.nan)
        failures, t0 = {}, time.perf_counter()
        for f in range(nf):
            test = labels == f
            train = ~test
            if sw is not None:
                fit["sample_weights"] = sw[train]
            try:
                pred[test] = _fit(surface, idx, vals, train, name, fit, positions)
            except (ManifillError, ArithmeticError, np.linalg.LinAlgError) as e:
                failures[f] = _one_line(e)
        seconds = time.perf_counter() - t0
        ran = np.isin(labels, [f for f in range(nf) if f not in failures])
        miss = ran & np.isnan(pred).any(axis=1)
        use = ran & ~miss
        rel = (pred - vals) / span
        with np.errstate(invalid="ignore"):
            fe = np.sqrt(np.mean(rel[use] ** 2, axis=0)) if use.any() else np.full(p, np.nan)
            folds_e = np.array([np.sqrt(np.mean(rel[use & (labels == f)] ** 2)) if (use & (labels == f)).any()
                                else np.nan for f in range(nf)])
        res["errors"][label] = float(np.sqrt(np.mean(fe ** 2)))
        res["field_errors"][label] = fe
        res["fold_errors"][label] = folds_e
        res["seconds"][label] = seconds
        res["failures"][label] = failures
        res["excluded"][label] = int(miss.sum())
    return CrossValidation(methods=list(candidates), candidates=candidates, folds=nf, loo=folds == "loo",
                           seed=seed, samples=k, labels=labels, **res)


def _fit(surface, idx, vals, train, name, fit, positions):
    """One fold's fit on the training samples, evaluated at the held-out ones."""
    test = ~train
    if positions is None:
        r = reconstruct_surface(surface, idx[train], vals[train], method=name, **fit)
        return r.values[idx[test]]
    P, loc, duplicates = positions
    ps = point_samples(surface.V, surface.F, P[train], vals[train], duplicates=duplicates,
                       nearest_only=name not in AT_POINTS)
    r = reconstruct_surface(surface, ps.nearest, ps.nearest_vals, method=name, points=ps, **fit)
    return np.einsum("tj,tjp->tp", loc.bary[test], r.values[loc.corners[test]])


def _one_line(exc):
    text = " ".join(str(exc).split()) or type(exc).__name__
    text = text if isinstance(exc, ManifillError) else f"{type(exc).__name__}: {text}"
    return text if len(text) <= 160 else text[:157] + "..."


def reconstruct_auto(surface, idx, vals, *, options, progress=None, seconds=None, points=None):
    """``method="auto"``: cross-validate the default candidates, reconstruct with the best on all samples.

    Parameters
    ----------
    surface : Surface
    idx : (k,) int64 numpy array
        Sorted unique sample vertices.
    vals : (k, p) numpy array
    options : dict
        The options of :func:`manifill.reconstruct_surface` (everything but ``method``,
        ``progress`` and ``seconds``); ``seed`` seeds the split as well.
    progress : callable, optional
        Told ``cross-validate`` and ``fill``.
    seconds : dict, optional
        Timings so far, filled in place (``cross_validate``, then the chosen method's steps).
    points : PointSamples, optional
        Samples given as positions: the folds use their nearest vertices ``idx``, ``vals``;
        the final fit gets the points when their constraints were built (every point
        has one), else the nearest vertices too.

    Returns
    -------
    Reconstruction
        Equal to ``reconstruct_surface(surface, idx, vals, method=<chosen>, **options,
        **<its options>)``, with ``report['auto']`` (:meth:`CrossValidation.summary`) and
        ``report['method']`` the chosen method.

    Raises
    ------
    SampleError
        Fewer than :data:`MIN_SAMPLES` samples.
    SolveError
        No candidate ran on every fold.
    """
    seconds = {} if seconds is None else seconds
    k = len(idx)
    if k < MIN_SAMPLES:
        raise SampleError(f"method='auto' cross-validates and needs at least {MIN_SAMPLES} samples, got {k}; "
                          f"add samples or pick a method (e.g. method='harmonic')")
    if options.get("sample_weights") is not None and options.get("smoothing") is None:
        raise OptionError("method='auto': sample_weights weigh soft constraints; pass smoothing= too, or leave "
                          "them out")
    if points is not None and options.get("sample_weights") is not None:
        raise OptionError("method='auto' with samples at positions takes no sample_weights yet; pick a method, "
                          "or pass the samples at vertices")
    folds = AUTO_FOLDS if k >= AUTO_FOLDS else "loo"
    tick(progress, "cross-validate")
    t = time.perf_counter()
    fit = {key: v for key, v in options.items() if key != "on_empty"}
    digital = surface.F is None  # no triangles: no mass matrix for the biharmonic energy
    auto = [c for c in AUTO_CANDIDATES if not (digital and c[0] in ("biharmonic", "triharmonic"))]
    cv = run_folds(surface, idx, vals, candidates_of(auto, digital=digital), folds=folds,
                   seed=options.get("seed", 0), options={key: v for key, v in fit.items() if key != "seed"})
    seconds["cross_validate"] = time.perf_counter() - t
    if cv.best is None:
        first = next(iter(cv.failures[cv.ranking()[0]].values()), "no prediction")
        raise SolveError(f"method='auto': no candidate ran on every fold (e.g. {cv.ranking()[0]}: {first}); "
                         f"pick a method")
    name, own = cv.candidates[cv.best]
    tick(progress, "fill")
    built = points is not None and points.constraint.size and (points.constraint >= 0).all()
    r = reconstruct_surface(surface, idx, vals, method=name, **{**options, **own}, seconds=seconds,
                            points=points if built else None)
    if points is not None and not built:
        from .points import points_report

        r.report["points"] = points_report(points, False)
    r.report["auto"] = cv.summary()
    return r
