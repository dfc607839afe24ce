"""``method='harmonic'``, ``'biharmonic'``, ``'triharmonic'``: the k-harmonic energy with the samples alone fixed.

The minimiser of ``x' L (M^-1 L)^(k-1) x`` (cotangent or other Laplacian ``L``, lumped
mass ``M``) with the samples as constraints (:func:`manifill.surface.energy_fill.energy_fill`):
exactly at vertices or at points inside faces, within ``bounds`` (an active set), or as
soft constraints with ``smoothing``. The plain harmonic fill of vertex samples is the
patch fill of Steps 5-6 with the samples fixed. Each is the conditional mean of an
intrinsic Gaussian field, whose std ``uncertainty=True`` gives
(:func:`manifill.surface.gp.energy_uncertainty`). Linear in the values without bounds
and unless ``smoothing='auto'`` chooses lambda per field.
"""

from dataclasses import replace

from ...linalg.gp import as_gp_options
from ..energy_fill import energy_fill
from ..gp import energy_uncertainty
from .base import Method
from .pipeline import patch_fill

__all__ = ["Energy", "HARMONIC", "BIHARMONIC", "TRIHARMONIC"]


class Energy(Method):
    """The k-harmonic energy of order ``k`` (see the module docstring)."""

    can_bound = True
    can_smooth = True
    at_points = True
    gives_std = True
    #: ``energy_of(surface)``: the energy matrix, where it is not the k-harmonic one (the Hessian energies)
    energy_of = None

    def __init__(self, name, k, summary):
        self.name, self.k, self.summary = name, k, summary
        self.needs_triangles = self.smooth_gradient = k > 1
        self.step_names = ("check", f"{name} fill")

    def linear(self, options):
        return options.fit.smoothing != "auto", "smoothing='auto' picks lambda per field"

    def preparable(self, options):
        return options.fit.smoothing is None

    def fill(self, run):
        o, points = run.options, run.points
        run.step1(self)
        plain = self.k == 1 and self.energy_of is None
        if plain and o.fit.bounds is None and o.fit.smoothing is None and not (points and points.inside):
            # the harmonic fill with the samples (or the points' vertices) fixed: Steps 5-6 on their own
            b, bc = (run.idx, run.vals) if points is None else (points.idx, points.vals)
            return patch_fill(run, b, bc), None
        with run.step(f"{self.name} fill", "harmonic"):
            idx, vals, Aeq, beq, w = run.idx, run.vals, None, None, o.fit.sample_weights
            if points is not None:  # the points themselves: vertex constraints and barycentric rows
                idx, vals, w = points.idx, points.vals, None if w is None else points.weights(w)
                Aeq, beq = (points.Aeq, points.beq) if points.inside else (None, None)
            f = o.fill
            values, run.report["fill"] = energy_fill(
                run.surface, idx, vals, k=self.k, weights=f.weights, solver=f.solver, on_empty=f.on_empty,
                fit=replace(o.fit, sample_weights=w), rows=None if Aeq is None else (Aeq, beq), fields=run.fields,
                prepared=run.prepared, tol=f.tol, maxiter=f.maxiter, energy=self.energy_of)
        return values, None

    def uncertainty(self, run, values):
        o, points = run.options, run.points
        w = o.fit.sample_weights
        return energy_uncertainty(
            run.surface, self.k, values, (run.idx, run.vals, points), weights=o.fill.weights,
            fill_report=run.report.get("fill", {}), gp=as_gp_options(o.uq.gp),
            sample_weights=w if w is None or points is None else points.weights(w),
            solver="direct" if o.fill.solver == "iterate" else o.fill.solver)


HARMONIC = Energy("harmonic", 1, "harmonic with the samples alone fixed: the naive baseline, flat at the samples")
BIHARMONIC = Energy("biharmonic", 2, "the biharmonic energy with the samples fixed: smooth, may overshoot")
TRIHARMONIC = Energy("triharmonic", 3, "the triharmonic energy: smoother still, overshoots most")
