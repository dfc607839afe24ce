"""``method='gp'``: the Matérn Gaussian process on the mesh, a posterior mean with a std everywhere.

The SPDE field of :func:`manifill.surface.gp.reconstruct_gp` (cotangent stiffness, lumped
mass), hyperparameters given or fitted (``gp=``, :class:`manifill.GPOptions`), conditioned
on the samples at vertices or at points inside faces; its noise is ``gp={'noise': ...}``, so
``bounds``, ``smoothing`` and ``sample_weights`` are refused. Linear in the values when the
range, sigma and noise are all given.
"""

from ...errors import OptionError
from ...linalg.gp import as_gp_options
from ..gp import gp_draws, reconstruct_gp
from .base import Method

__all__ = ["GP", "Matern"]


class Matern(Method):
    """The Matérn Gaussian process (see the module docstring)."""

    name = "gp"
    summary = "a Matérn Gaussian process on the mesh: mean and std; range, sigma and noise fitted or given"
    at_points = True
    smooth_gradient = True
    gives_std = True
    gp_mean = True
    needs_triangles = True
    step_names = ("check", "gp")
    barrier_models = ("cut", "bakka")  # with barriers=: the mesh cut, or whole with Bakka's barrier faces

    def check(self, options):
        fit = options.fit
        if fit.exact or fit.smoothing is not None or fit.sample_weights is not None:
            raise OptionError("method='gp' takes its noise as gp={'noise': ...} and no exact bounds (bounds_mode="
                              "'project' clips its mean); leave bounds, "
                              "smoothing and sample_weights out")

    def linear(self, options):
        o = as_gp_options(options.uq.gp)
        given = not any(isinstance(x, str) for x in (o.range, o.sigma, o.noise))
        return given, "the gp's hyperparameters are fitted per call; give gp={'range', 'sigma', 'noise'}"

    def fill(self, run):
        run.step1(self)
        o = run.options
        with run.step("gp"):
            values, std, run.report["gp"] = reconstruct_gp(run.surface, run.idx, run.vals, gp=o.uq.gp,
                                                           weights=o.fill.weights, solver=o.fill.solver,
                                                           points=run.points, with_std=o.uq.uncertainty)
        return values, std

    def draws(self, result, count, seed):
        if result.F is None and result.cloud is None:
            raise OptionError("drawing from a gp needs the triangle mesh it ran on")
        return gp_draws(result, count, seed)


GP = Matern()
