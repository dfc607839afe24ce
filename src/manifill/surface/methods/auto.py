"""``method='auto'``: cross-validate the cheaper candidates on the samples, reconstruct with the best.

:data:`AUTO_CANDIDATES` (the paper's pipeline with Hermite and monotone curve values,
harmonic, biharmonic, triharmonic, rbf; the bi- and triharmonic left out on a digital
surface; with ``bounds`` only the candidates that hold them) are each fitted on
:data:`AUTO_FOLDS` folds (leave-one-out below that many samples; the split seeded by ``seed``)
by :func:`manifill.surface.folds.run_folds`; the lowest-error one then runs on all samples, so
the result equals ``reconstruct(..., method=<chosen>, <its options>)``, and ``report['auto']``
holds the table.
"""

from ...errors import OptionError, SampleError, SolveError
from ...progress import tick
from ..folds import MIN_SAMPLES, label_of, run_folds
from ..points import points_report
from .base import Method

__all__ = ["AUTO", "AUTO_CANDIDATES", "AUTO_FOLDS", "Auto"]

#: The candidates of ``method="auto"``: ``(method, options)``; the bounded biharmonic is left out (its active set
#: costs 5-20x the others per fold at 41k vertices, docs/NOTES.md), so that ``auto`` costs a few times one fit.
AUTO_CANDIDATES = (("gvf-harmonic", {}), ("gvf-harmonic", {"curve_values": "monotone"}), ("harmonic", {}),
                   ("biharmonic", {}), ("triharmonic", {}), ("rbf", {}))
#: Folds of ``method="auto"``.
AUTO_FOLDS = 5


class Auto(Method):
    """Cross-validation's choice (see the module docstring)."""

    name = "auto"
    summary = "cross-validation picks among the cheaper candidates on your own samples"
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
            # on a digital surface only those without a mass matrix; with bounds only those that hold them
            usable = [(name, own) for name, own in AUTO_CANDIDATES
                      if not (surface.mass is None and run.lookup(name).needs_triangles)
                      and (o.fit.bounds is None or run.lookup(name).can_bound)]
            cands = {label_of(name, own): (name, own) for name, own in usable}
            cv = run_folds(surface, idx, vals, cands, folds=AUTO_FOLDS if k >= AUTO_FOLDS else "loo",
                           seed=o.fill.seed, options=base, reconstruct=run.reconstruct, lookup=run.lookup)
        if cv.best is None:
            first = next(iter(cv.failures[cv.ranking()[0]].values()), "no prediction")
            raise SolveError(f"method='auto': no candidate ran on every fold (e.g. {cv.ranking()[0]}: {first}); "
                             f"pick a method")
        name, own = cv.candidates[cv.best]
        tick(run.progress, "fill")
        built = points is not None and points.constraint.size and (points.constraint >= 0).all()
        r = run.reconstruct(surface, idx, vals, options=base.replace(method=name, preset=None, **own),
                            points=points if built else None, seconds=run.seconds)
        if points is not None and not built:
            r.report["points"] = points_report(points, False)
        r.report["auto"] = cv.summary()
        return r


AUTO = Auto()
