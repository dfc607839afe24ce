"""What a reconstruction method is: :class:`Method` (what it can do, how it fills) and :class:`Run` (one call).

A method is one object. Generic code (:func:`manifill.reconstruct_surface`,
:class:`manifill.Reconstructor`, cross-validation, the command line) asks it, never its
name:

- its capabilities: ``can_bound``, ``can_smooth``, ``at_points`` (samples inside faces
  constrained where they are, not at the nearest vertex), ``gives_std`` (a std through
  ``uncertainty``), ``gp_mean`` (the Gaussian process's own mean and std),
  ``needs_triangles``, ``sparse_map`` (its linear map is sparse), ``partitions`` (it runs
  Steps 2-3), ``smooth_gradient`` (its gradient has no jumps at the samples or curves);
- :meth:`Method.steps`: the steps it runs (a progress bar's total);
- :meth:`Method.check`: refuse an option it cannot use, with a one-line error;
- :meth:`Method.linear`: whether its result is linear in the values (then it has a map), and
  :meth:`Method.linearity`: the same under the options every method shares (bounds, projection, trust);
- :meth:`Method.barrier_model`: how it sees ``barriers=`` (``barrier_models``: the mesh cut, or the gp's
  Bakka faces);
- :meth:`Method.preparable`: whether a zero run builds its value-independent pieces;
- :meth:`Method.needs_levels`: whether Step 1's levels are needed whatever ``check`` says;
- :meth:`Method.fill`: the values (and a std, if it makes one) for one :class:`Run`.

:class:`Run` holds one call's surface, samples and options and what the steps write:
the report, the timings, Step 1's checks, the curves; :meth:`Run.finish` gives the
:class:`~manifill.surface.reconstruction.Reconstruction` every method returns.
"""

import time
from contextlib import contextmanager

import numpy as np

from ...errors import OptionError, SampleError
from ...linalg.gp import as_gp_options
from ...progress import tick
from ...report import Report
from ..gp import trust_mask
from ..gradual import check_gradual, violation_message
from ..points import points_report
from ..reconstruction import Reconstruction

__all__ = ["Method", "Run", "CHECK_FIELDS", "overshoot_by_field"]

#: ``check=None`` runs Step 1 (the gradual variation report) for every field when there are at most this many
#: fields, and skips it for more (each field costs a few shortest-path passes); ``check=True`` runs it always.
CHECK_FIELDS = 10


class Method:
    """A reconstruction method: its name, capabilities and fill (see the module docstring).

    Subclasses set the class attributes and implement :meth:`fill`; the defaults describe a
    method that takes none of the optional constraints.
    """

    name: str | None = None
    #: One line for the docs and ``--help``.
    summary = ""
    can_bound = False
    can_smooth = False
    at_points = False
    gives_std = False
    gp_mean = False
    needs_triangles = False
    #: It needs a mesh's faces (not a point cloud's or a digital surface's neighbourhoods).
    needs_faces = False
    sparse_map = False
    partitions = False
    #: Its field's gradient is free of jumps at the samples and curves (harmonic fills have kinks there: on a
    #: smooth field their gradients were 10x further off than the biharmonic's, docs/benchmarks.md).
    smooth_gradient = False
    #: It runs other methods and returns their result (``auto``): no candidate of cross-validation itself.
    delegates = False
    #: What it suggests when it wins a cross-validation (appended to the recommendation), or "".
    cv_hint = ""
    #: The steps after ``graph``, by the names passed to ``progress``.
    step_names: tuple[str, ...] = ()
    #: The models of ``barriers=`` it takes (``gp={'barrier': ...}``): ``'cut'``, the mesh cut along them (any
    #: method), or ``'bakka'``, the gp's own (the mesh whole, the faces along them of a short range).
    barrier_models: tuple[str, ...] = ("cut",)
    #: Step 4's curve values when none are given (a preset may give others: the default's ``'monotone'``).
    default_curve_values = "hermite"

    def steps(self, options):
        """The progress steps this method runs with ``options`` (after ``graph``)."""
        return self.step_names

    def check(self, options):
        """Refuse an option this method cannot use (:class:`~manifill.errors.OptionError`, one line)."""
        fit = options.fit
        if fit.exact and not self.can_bound:
            raise OptionError(f"method={self.name!r} takes no bounds; pass bounds=None, or use a method that holds "
                              f"them (e.g. method='biharmonic', bounds='samples'), or bounds_mode='project'")
        if options.preset is not None and "curve_values" in options.given and not self.partitions:
            # the default was the paper's pipeline before issue 37: its curve values are not dropped in silence
            raise OptionError(f"curve_values are Step 4's, the values on the paper's pipeline's curves, and the "
                              f"default ({self.name}) draws no curves; pass method='gvf-harmonic' too, or leave "
                              f"curve_values out")
        if (fit.smoothing is not None or fit.sample_weights is not None) and not self.can_smooth:
            raise OptionError(f"smoothing and sample_weights apply to the energy methods (harmonic, biharmonic, "
                              f"triharmonic) and rbf, not to method={self.name!r}; pick one of those")

    def linear(self, options):
        """``(linear, why not)``: whether the result is linear in the sample values, for this method's options."""
        return False, f"method={self.name!r} is not linear in the values"

    def linearity(self, options):
        """``(linear, why not)`` for this configuration: first what every method shares, then :meth:`linear`.

        Trust with ``untrusted='nan'``, ``bounds_mode='project'`` and bounds make any method non-linear in the
        values (a mask by the std, a clip, an active set).

        Examples
        --------
        >>> from manifill.surface.methods.registry import configure, method_of
        >>> method_of("harmonic").linearity(configure(method="harmonic"))[0]
        True
        >>> method_of("harmonic").linearity(configure(method="harmonic", bounds="samples"))[1]
        'bounds make an active set, which depends on the values'
        """
        o = options
        if o.uq.trust is not None and o.uq.untrusted == "nan":
            return False, "trust with untrusted='nan' blanks values by their std"
        if o.fit.projected:
            return False, "bounds_mode='project' clips each field onto its bounds (the map before the clip is "\
                          "the method's: pass bounds=None for it)"
        if o.fit.bounds is not None:
            return False, "bounds make an active set, which depends on the values"
        return self.linear(options)

    def barrier_model(self, options):
        """How this method sees ``barriers=``: ``'cut'`` (the mesh cut along them) or ``'bakka'`` (the gp's model).

        Raises
        ------
        OptionError
            A model of its own (``gp={'barrier': 'bakka'}``) without ``barriers=``, or by a method that does
            not take it (:attr:`barrier_models`).

        Examples
        --------
        >>> from manifill.surface.methods.registry import configure, method_of
        >>> method_of("gp").barrier_model(configure(method="gp", barriers=[[0, 1]], gp={"barrier": "bakka"}))
        'bakka'
        >>> method_of("harmonic").barrier_model(configure(method="harmonic", barriers=[[0, 1]]))
        'cut'
        """
        model = as_gp_options(options.uq.gp).barrier
        if model not in self.barrier_models or (model != "cut" and options.fill.barriers is None):
            raise OptionError(f"gp barrier={model!r} is the gp's model of barriers=: give barriers= and "
                              f"method='gp', or leave it out")
        return model

    def preparable(self, options):
        """Whether a run on zero values builds pieces worth keeping (a partition, a factorisation)."""
        return False

    def needs_levels(self, options):
        """Whether Step 1 must run (its levels are used), whatever ``check`` says."""
        return False

    def needs_gradual(self, options):
        """Whether a broken gradual variation condition is an error (not only reported)."""
        return False

    def exact_at(self, run):
        """Whether samples given as positions were constrained where they are (for ``report['points']``)."""
        return self.at_points

    def fill(self, run):
        """``(values (n, p), std (n, p) or None)`` for one :class:`Run`; writes its report into ``run``."""
        raise NotImplementedError

    def uncertainty(self, run, values):
        """``(std, report)`` of the result read as a Gaussian field (methods with ``gives_std``)."""
        raise OptionError(f"method={self.name!r} has no probability model for a std")

    def draws(self, result, count, seed):
        """``(n, p, count)`` draws of the posterior field of ``result`` (methods with a fitted probability model)."""
        raise OptionError(f"method={self.name!r} has no fitted probability model to draw from; use method='gp'")

    def reconstruct(self, run):
        """The whole reconstruction for one :class:`Run` (a method that delegates overrides this)."""
        values, std = self.fill(run)
        return run.finish(self, values, std)

    def __repr__(self):
        return f"<manifill method {self.name!r}>"


class Run:
    """One reconstruction in progress (see the module docstring).

    Parameters
    ----------
    surface : Surface
    idx : (k,) int64 numpy array
        Sorted unique sample vertices (the nearest vertices when ``points`` is given).
    vals : (k, p) numpy array
    options : Options
        Configured (:func:`manifill.surface.methods.registry.configure`).
    points : PointSamples or None
    fields : int
        How many fields share the value-independent pieces.
    prepared : Prepared or None
    progress : callable or None
    seconds : dict
        Timings so far, filled in place.
    reconstruct : callable
        ``reconstruct(surface, idx, vals, options=..., points=..., seconds=...)``: the engine itself, for a
        method that runs others (``auto``).
    lookup : callable
        A method by name (the registry's ``method_of``), for the same.
    """

    def __init__(self, surface, idx, vals, options, *, points, fields, prepared, progress, seconds, reconstruct,
                 lookup):
        self.surface, self.idx, self.vals, self.options, self.points = surface, idx, vals, options, points
        self.fields, self.prepared, self.progress, self.seconds = fields, prepared, progress, seconds
        self.reconstruct, self.lookup = reconstruct, lookup
        self.t0 = time.perf_counter()
        self.before = sum(seconds.values())
        n = surface.n
        self.report = Report(method=options.method, curve_values=None, samples=int(idx.size), vertices=n,
                             seconds=seconds)
        if options.preset is not None:
            self.report["preset"] = options.preset
        self.checks = []
        self.curves, self.components = [], np.zeros(n, dtype=np.int64)
        self.on_curve = np.zeros(n, dtype=bool)
        self.on_curve[idx] = True

    @property
    def p(self):
        """Number of fields."""
        return self.vals.shape[1]

    @contextmanager
    def step(self, name, key=None):
        """Tell ``progress`` the step ``name`` starts and time it into ``seconds[key or name]``."""
        tick(self.progress, name)
        t = time.perf_counter()
        yield
        self.seconds[key or name] = time.perf_counter() - t

    def _check_runs(self, method):
        """Whether Step 1 runs: always where its levels are needed, else as ``check`` says (None: a few fields)."""
        o = self.options
        if method.needs_levels(o) or (o.fill.solver == "iterate" and o.fill.init == "gvf"):
            return True
        if o.step1.check is None:
            return self.p <= CHECK_FIELDS
        return bool(o.step1.check)

    def step1(self, method, starts=None):
        """Step 1 per field: levels, Lipschitz constant, gradual variation (``report['check']``).

        ``starts``, a callable, gives each field's lower bound of the Lipschitz constant (the partition's
        steepest curve); it is called only when Step 1 runs.
        """
        p = self.p
        with self.step("check"):
            if self._check_runs(method):
                starts = [None] * p if starts is None else starts()
                self.checks = [check_gradual(self.surface, self.idx, self.vals[:, j],
                                             levels=self.options.step1.levels, distance="hops", start=starts[j])
                               for j in range(p)]
            else:
                self.report["check_skipped"] = (f"Step 1 was not run for {p} fields (more than {CHECK_FIELDS}); "
                                                f"pass check=True (CLI --check) to run it for every field")
            if method.needs_gradual(self.options):
                for c in self.checks:
                    if not c.holds:
                        raise SampleError(violation_message(c))
            self.report["check"] = [c.summary() for c in self.checks]

    def finish(self, method, values, std=None):
        """The :class:`Reconstruction`: the std (if asked), the trust mask, overshoot, points, timings."""
        o, report, points = self.options, self.report, self.points
        if o.uq.uncertainty and std is None:  # the method read as a Gaussian field
            with self.step("uncertainty"):
                std, report["uncertainty"] = method.uncertainty(self, values)
        sample_vals = self.vals if points is None else points.values
        trusted = None
        if o.uq.trust is not None:
            values, trusted, threshold = trust_mask(values, std, sample_vals, o.uq.trust, o.uq.untrusted)
            report["trust"] = {"threshold": threshold, "untrusted": int((~trusted).sum()), "marked": o.uq.untrusted}
        d = overshoot_by_field(values, sample_vals)
        report["overshoot"] = float(np.nanmax(d)) if np.isfinite(d).any() else 0.0
        if points is not None:
            report["points"] = points_report(points, method.exact_at(self))
        self.seconds["total"] = self.before + time.perf_counter() - self.t0
        s = self.surface
        if s.cloud is not None:
            report["cloud"] = s.cloud.report()
        return Reconstruction(values=values, curves=self.curves, components=self.components, on_curve=self.on_curve,
                              levels=[c.levels for c in self.checks], report=report, V=s.V, F=s.F, idx=self.idx,
                              points=None if points is None else points.located, std=std, trusted=trusted,
                              made_by=method, cloud=s.cloud, barrier_faces=s.barrier_faces)



def overshoot_by_field(values, sample_vals):
    """``(p,)``: how far each field's ``values`` leave its samples' range (<= 0 inside; NaN values skipped).

    Per column first (reductions, no ``(n, p)`` temporaries); ``fmax``/``fmin`` skip NaN (untrusted vertices,
    components without samples).
    """
    lo, hi = sample_vals.min(axis=0), sample_vals.max(axis=0)
    with np.errstate(invalid="ignore"):
        return np.maximum(np.fmax.reduce(values, axis=0) - hi, lo - np.fmin.reduce(values, axis=0))
