"""``method='gvf'``: the gradually varied fit of the whole surface (Step 1's levels at every vertex).

Every vertex but the samples gets a level (:func:`manifill.surface.fill.gvf_fill`), so the
result never leaves the samples' range; it needs Step 1's levels, and a broken gradual
variation condition is an error. ``bounds`` are checked only (levels lie within the range).
"""

from ..energy_fill import as_bounds
from ..fill import gvf_fill
from .base import Method

__all__ = ["GVF", "GradualFit"]


class GradualFit(Method):
    """The gradually varied fit (see the module docstring)."""

    name = "gvf"
    summary = "the paper's gradually varied fit of every vertex: levels, never outside the samples' range"
    can_bound = True
    step_names = ("check", "gvf")

    def needs_levels(self, options):
        return True

    def needs_gradual(self, options):
        return True

    def fill(self, run):
        as_bounds(run.options.fit.bounds, run.vals)  # checked only: levels lie within the samples' range
        run.step1(self)
        with run.step("gvf"):
            values = gvf_fill(run.surface, run.idx, run.vals, run.checks, on_empty=run.options.fill.on_empty)
        return values, None


GVF = GradualFit()
