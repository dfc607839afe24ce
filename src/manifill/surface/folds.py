"""K-fold cross-validation on the samples themselves, with any reconstruction as the fit.

:func:`fold_labels` splits the samples at random (seeded); :func:`run_folds` fits every
candidate on all folds but one, measures it at the held-out samples and gathers a
:class:`~manifill.surface.crossval_result.CrossValidation`. The fit is handed in
(``reconstruct``, the engine :func:`manifill.surface.reconstruct.reconstruct_surface`), so
that ``method='auto'`` (:mod:`manifill.surface.methods.auto`) and
:func:`manifill.cross_validate` share this loop without importing each other.
"""

import time

import numpy as np

from ..errors import ManifillError, OptionError, SampleError
from .crossval_result import CrossValidation
from .methods.base import overshoot_by_field
from .points import point_samples

__all__ = ["MIN_SAMPLES", "fold_labels", "label_of", "run_folds"]

#: Fewest samples cross-validation accepts (every fit then has at least two).
MIN_SAMPLES = 3


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


def label_of(name, own):
    """A candidate's label: its method and its own options (``"biharmonic bounds=samples"``)."""
    return " ".join([name] + [f"{k}={v}" for k, v in own.items()])


def run_folds(surface, idx, vals, candidates, *, folds, seed, options, reconstruct, positions=None, lookup=None,
              groups=None):
    """Cross-validate validated samples on a Surface.

    Parameters
    ----------
    surface : Surface
    idx : (k,) int64 numpy array
        Sorted unique sample vertices.
    vals : (k, p) numpy array
    candidates : dict of str to (str, dict)
        Label -> ``(method, its own options)``.
    folds, seed
        As for :func:`manifill.cross_validate`.
    options : Options
        The options of every fit (a candidate's own override them; ``on_empty`` is set to ``'nan'``).
    reconstruct : callable
        The fit: ``reconstruct(surface, idx, vals, options=..., points=...)`` -> Reconstruction.
    positions : (P, SurfacePoints, duplicates, at_points), optional
        Samples given as positions ``P`` (``(k, 3)``), located; ``idx`` is then their nearest vertices.
    lookup : callable, optional
        A method by name (the registry's ``method_of``): its ``cv_hint`` goes into the result's hints.
    groups : (k,) int numpy array, optional
        Samples that are one (the sides of a sample on a barrier): each group held out together.

    Returns
    -------
    CrossValidation
    """
    k, p = vals.shape
    labels = fold_labels(k, folds, seed) if groups is None else fold_labels(int(groups.max()) + 1, folds, seed)[groups]
    nf = int(labels.max()) + 1
    span = vals.max(axis=0) - vals.min(axis=0)
    span = np.where(span > 0, span, 1.0)  # a constant field: absolute errors
    sw = options.fit.sample_weights
    res = {key: {} for key in ("errors", "field_errors", "fold_errors", "field_fold_errors", "seconds", "failures",
                               "excluded", "overshoot")}
    for label, (name, own) in candidates.items():
        fit = options.replace(method=name, preset=None, on_empty="nan", seed=seed, **own)
        pred = np.full((k, p), np.nan)
        failures, t0, over = {}, time.perf_counter(), 0.0
        for f in range(nf):
            train = labels != f
            try:
                o = fit if sw is None else fit.replace(sample_weights=sw[train])
                pred[~train], fold_over = _fit(surface, idx, vals, train, o, reconstruct, positions)
                over = max(over, fold_over)
            except (ManifillError, ArithmeticError, np.linalg.LinAlgError) as e:
                failures[f] = _one_line(e)
        seconds = time.perf_counter() - t0
        ran = np.isin(labels, [f for f in range(nf) if f not in failures])
        miss = ran & np.isnan(pred).any(axis=1)
        use = ran & ~miss
        rel = (pred - vals) / span
        with np.errstate(invalid="ignore"):
            fe = np.sqrt(np.mean(rel[use] ** 2, axis=0)) if use.any() else np.full(p, np.nan)
            per_field = np.array([np.sqrt(np.mean(rel[use & (labels == f)] ** 2, axis=0)) if (use & (labels == f)).any()
                                  else np.full(p, np.nan) for f in range(nf)])
            folds_e = np.sqrt(np.mean(per_field ** 2, axis=1))  # every field has the fold's rows: the fields' RMS
        res["errors"][label] = float(np.sqrt(np.mean(fe ** 2)))
        res["field_errors"][label] = fe
        res["fold_errors"][label] = folds_e
        res["field_fold_errors"][label] = per_field
        res["seconds"][label] = seconds
        res["failures"][label] = failures
        res["excluded"][label] = int(miss.sum())
        res["overshoot"][label] = over
    hints = {} if lookup is None else {label: lookup(name).cv_hint for label, (name, _) in candidates.items()}
    return CrossValidation(methods=list(candidates), candidates=candidates, folds=nf, loo=folds == "loo",
                           seed=seed, samples=k, labels=labels, hints=hints, **res)


def _fit(surface, idx, vals, train, options, reconstruct, positions):
    """One fold's fit on the training samples: ``(its values at the held-out ones, its overshoot)``.

    The overshoot is the farthest the fit leaves its training samples' range, anywhere on the surface, as a
    fraction of that range (the largest over the fields).
    """
    test = ~train
    if positions is None:
        r = reconstruct(surface, idx[train], vals[train], options=options)
        at = r.values[idx[test]]
    else:
        P, loc, duplicates, at_points = positions
        ps = point_samples(surface.V, surface.F, P[train], vals[train], duplicates=duplicates,
                           nearest_only=not at_points(options.method))
        r = reconstruct(surface, ps.nearest, ps.nearest_vals, options=options, points=ps)
        at = np.einsum("tj,tjp->tp", loc.bary[test], r.values[loc.corners[test]])
    span = np.ptp(vals[train], axis=0)
    out = overshoot_by_field(r.values, vals[train]) / np.where(span > 0, span, 1.0)
    return at, float(np.nanmax(np.maximum(out, 0.0), initial=0.0))


def _one_line(exc):
    text = " ".join(str(exc).split()) or type(exc).__name__
    text = text if isinstance(exc, ManifillError) else f"{type(exc).__name__}: {text}"
    return text if len(text) <= 160 else text[:157] + "..."
