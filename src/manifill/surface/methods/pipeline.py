"""``method='gvf-harmonic'``: the paper's pipeline, Steps 1-6, with any of Step 4's curve values.

Steps 2-3 (:func:`manifill.surface.partition.partition`) cut the surface by curves through
every sample; Step 1 (:func:`manifill.surface.gradual.check_gradual`) checks gradual
variation per field (run after the partition: its curves bound the Lipschitz constant from
below); Step 4 (:func:`manifill.surface.curve_values.values_on_curves`) gives the curves
values -- ``hermite`` (the pipeline's own default), ``monotone``, ``linear`` or the paper's
``gvf``; Steps 5-6 (:func:`manifill.surface.fill.fill_patches`) fill every patch
harmonically. With ``bounds`` the curve values are projected onto the bounds and the fill
is the bounded minimiser. Linear in the values for ``hermite`` and ``linear`` curve values
without bounds (a sparse map: each vertex depends on the samples around its patch).
"""

import numpy as np

from ..curve_map import LINEAR_CURVE_VALUES, curve_map
from ..curve_values import values_on_curves
from ..energy_fill import as_bounds
from ..fill import fill_patches, start_values
from ..partition import partition
from ..prepared import cached
from .base import Method

__all__ = ["PIPELINE", "Pipeline"]


class Pipeline(Method):
    """The paper's pipeline (see the module docstring)."""

    name = "gvf-harmonic"
    summary = "the paper's pipeline: curves through every sample, values on the curves, harmonic patches"
    can_bound = True
    sparse_map = True
    partitions = True
    step_names = ("partition", "check", "curve values", "harmonic fill")

    def linear(self, options):
        cv = options.fill.curve_values
        return cv in LINEAR_CURVE_VALUES, f"curve_values={cv!r} is not linear in the values; 'hermite' and 'linear' are"

    def preparable(self, options):
        return options.fit.smoothing is None

    def needs_levels(self, options):
        return options.fill.curve_values == "gvf"

    def needs_gradual(self, options):
        return options.fill.curve_values == "gvf"

    def fill(self, run):
        o, surface, idx, vals = run.options, run.surface, run.idx, run.vals
        lohi = as_bounds(o.fit.bounds, vals)  # checked before the work
        run.report["curve_values"] = o.fill.curve_values
        with run.step("partition"):
            part = cached(run.prepared, "partition", lambda: partition(surface, idx, method=o.fill.partition))
        # Step 1 after Steps 2-3: the hop length of every curve bounds its Lipschitz constant from below
        run.step1(self, lambda: part.steepest(idx, vals))
        run.report["partition"] = part.report
        run.curves, run.components, run.on_curve = part.curves, part.labels, part.on_curve.copy()
        with run.step("curve values", "curve_values"):
            b, bc = self.curve_values(run, part)
            if lohi is not None:  # curve values projected onto the bounds (the samples lie within them)
                cols = bc if bc.ndim == 2 else bc[:, None]
                clipped = np.clip(cols, lohi[0], lohi[1])
                run.report["bounds"] = {"lo": lohi[0].tolist(), "hi": lohi[1].tolist(),
                                        "clipped_curve_values": int((clipped != cols).sum())}
                bc = clipped.reshape(bc.shape)
        # Steps 5-6: the harmonic fill of every patch (bounded: the minimiser within the bounds, an active set that
        # stops at once where the maximum principle holds, i.e. without negative cotangent weights)
        largest = max(part.report["patch_sizes"] or [0])
        values = patch_fill(run, b, bc, largest=largest, lohi=lohi)
        return values, None

    @staticmethod
    def curve_values(run, part):
        """Step 4: ``(curve vertices, their values)``; many fields of a linear kind go through one sparse map."""
        o, surface, idx, vals = run.options, run.surface, run.idx, run.vals
        cv = o.fill.curve_values
        if cv in LINEAR_CURVE_VALUES and run.fields >= idx.size:
            b, C = cached(run.prepared, "curve map", lambda: curve_map(surface, part, idx, cv))
            return b, C @ vals
        return values_on_curves(surface, part, idx, vals, method=cv, checks=run.checks)


def patch_fill(run, b, bc, *, largest=None, lohi=None):
    """Steps 5-6 with the values ``bc`` at ``b`` fixed (the curves, or the samples alone); ``(n, p)`` values."""
    o, surface = run.options, run.surface
    f = o.fill
    with run.step("harmonic fill", "harmonic"):
        values, run.report["fill"] = fill_patches(
            surface, b, bc, weights=f.weights, solver=f.solver, on_empty=f.on_empty,
            x0=lambda: start_values(f.init, surface, run.idx, run.vals, checks=run.checks, seed=f.seed),
            bounds=lohi, fields=run.fields, prepared=run.prepared, largest=largest, iteration=f.iteration, tol=f.tol,
            maxiter=f.maxiter)
    return values if values.ndim == 2 else values[:, None]


PIPELINE = Pipeline()
