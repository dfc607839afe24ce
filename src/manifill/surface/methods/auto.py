"""``method='auto'``: cross-validate candidates on the samples, each field reconstructed by its own choice.

:data:`AUTO_CANDIDATES` (the default, the projected triharmonic, the Hessian, rbf; on a digital surface or a point
cloud only those it can run) are each fitted on :data:`AUTO_FOLDS` folds (leave-one-out below that many samples;
the split seeded by ``seed``) by :func:`manifill.surface.folds.run_folds`. Each field then keeps the default
unless another candidate's cross-validated error is lower by more than one standard error of its fold errors
(the one-standard-error rule, :meth:`manifill.surface.crossval_result.CrossValidation.one_se`): ``auto`` leaves
the default only on evidence. Fields that chose the same candidate run together on all samples, so each field
equals ``reconstruct(..., method=<its choice>, <its options>)``; ``report['auto']`` holds the table and
``report['auto']['fields']`` the candidate of every field. Samples given as positions take one candidate for all
fields (the rule applied to the fields' combined error).
"""

import numpy as np

from ...errors import OptionError, SampleError, SolveError
from ...progress import tick
from ..folds import MIN_SAMPLES, label_of, run_folds
from ..points import points_report
from .base import Method

__all__ = ["AUTO", "AUTO_CANDIDATES", "AUTO_FOLDS", "Auto"]

#: The candidates of ``method="auto"``: ``(method or preset, options)``, the default first (the one kept unless
#: the cross-validation says otherwise); the exact bounded minimisers are left out (an active set per fold).
AUTO_CANDIDATES: tuple = (("default", {}), ("triharmonic", {"bounds": "samples", "bounds_mode": "project"}),
                   ("hessian", {}), ("rbf", {}))
#: Folds of ``method="auto"``.
AUTO_FOLDS = 5


class Auto(Method):
    """Cross-validation's choice per field (see the module docstring)."""

    name = "auto"
    summary = "cross-validation picks, field by field, among the default and a few others; the default unless " \
              "another is better by more than one standard error"
    can_bound = True
    can_smooth = True
    at_points = True
    delegates = True
    step_names = ("cross-validate", "fill")

    def check(self, options):
        if options.fit.sample_weights is not None and options.fit.smoothing is None:
            raise OptionError("method='auto': sample_weights weigh soft constraints; pass smoothing= too, or leave "
                              "them out")

    def reconstruct(self, run):
        surface, idx, vals, points, o = run.surface, run.idx, run.vals, run.points, run.options
        k = len(idx)
        if k < MIN_SAMPLES:
            raise SampleError(f"method='auto' cross-validates and needs at least {MIN_SAMPLES} samples, got {k}; "
                              f"add samples or pick a method (e.g. method='harmonic')")
        if points is not None and o.fit.sample_weights is not None:
            raise OptionError("method='auto' with samples at positions takes no sample_weights yet; pick a method, "
                              "or pass the samples at vertices")
        base = o.replace(check=None)
        with run.step("cross-validate", "cross_validate"):
            # on a digital surface only those without a mass matrix, on a cloud only those without faces; with
            # exact bounds only those that hold them (projected bounds were taken off by the engine)
            usable = [(name, own) for name, own in AUTO_CANDIDATES
                      if not (surface.mass is None and run.lookup(name).needs_triangles)
                      and not (surface.F is None and run.lookup(name).needs_faces)
                      and (o.fit.bounds is None or "bounds" in own or run.lookup(name).can_bound)]
            cands = {label_of(name, own): (name, own) for name, own in usable}
            cv = run_folds(surface, idx, vals, cands, folds=AUTO_FOLDS if k >= AUTO_FOLDS else "loo",
                           seed=o.fill.seed, options=base, reconstruct=run.reconstruct, lookup=run.lookup)
        if cv.best is None:
            first = next(iter(cv.failures[cv.ranking()[0]].values()), "no prediction")
            raise SolveError(f"method='auto': no candidate ran on every fold (e.g. {cv.ranking()[0]}: {first}); "
                             f"pick a method")
        default = label_of(*AUTO_CANDIDATES[0])
        # samples at positions: one candidate for all fields (the rule on their combined error)
        chosen = cv.one_se(default, combined=points is not None)
        tick(run.progress, "fill")
        built = points is not None and points.constraint.size and (points.constraint >= 0).all()
        r, values = None, None
        for label in dict.fromkeys(chosen):  # each candidate once, in the fields' order
            cols = [j for j, c in enumerate(chosen) if c == label]
            name, own = cv.candidates[label]
            part = run.reconstruct(surface, idx, vals[:, cols], options=base.replace(method=name, preset=None, **own),
                                   points=points if built else None, seconds=run.seconds)
            if r is None:
                r, values = part, np.empty((part.values.shape[0], vals.shape[1]))
            values[:, cols] = part.values
        r.values = values
        if len(set(chosen)) > 1:  # a mix: the first group's report stands for the method, the fields say the rest
            r.std = None
            r.report["method"] = "auto"
        if points is not None and not built:
            r.report["points"] = points_report(points, False)
        r.report["auto"] = {**cv.summary(), "fields": chosen, "default": default}
        return r


AUTO = Auto()
