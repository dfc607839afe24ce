"""The options of a reconstruction: one frozen object, built and checked once, grouped by concern.

:class:`Options` is what :func:`manifill.reconstruct`, :class:`manifill.Reconstructor`,
:func:`manifill.cross_validate`, the command line and the batch hand down; every step reads
its group and nothing copies the options by name again. The groups:

- ``fill`` (:class:`FillOptions`): how the surface is cut and filled -- ``partition``,
  ``weights``, ``distance``, ``curve_values``, ``solver``, ``iteration``, ``init``,
  ``seed``, ``tol``, ``maxiter``, ``on_empty``;
- ``step1`` (:class:`Step1Options`): Step 1's ``levels`` and whether it runs (``check``);
- ``fit`` (:class:`FitOptions`): ``bounds``, ``bounds_mode``, ``smoothing``, ``sample_weights``;
- ``points`` (:class:`PointOptions`): how samples are read -- ``duplicates``,
  ``max_distance``;
- ``uq`` (:class:`UncertaintyOptions`): the Gaussian process and the std -- ``gp``,
  ``uncertainty``, ``trust``, ``untrusted``.

:meth:`Options.build` takes the flat keywords users write (``solver='direct'``) and
checks each against its closed set; which method runs, and whether it can use what
was given, is the method registry's to say (:func:`manifill.surface.methods.registry.configure`).
"""

from __future__ import annotations

import difflib
import os
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from ..deprecation import renamed
from ..errors import OptionError
from ..linalg.backends import ITERATIONS, SOLVERS
from ..mesh.graph import DISTANCES
from ..mesh.laplacian import WEIGHTS
from ..linalg.gp import GPOptions
from ..validate.constraints import Flag, Kind, Number, OneOf, Pair, check_table
from .curve_values import CURVE_VALUES
from .fill import INITS
from .harmonic import ON_EMPTY
from .partition import PARTITIONS

__all__ = ["Options", "FillOptions", "Step1Options", "FitOptions", "PointOptions", "UncertaintyOptions",
           "DUPLICATES", "UNTRUSTED", "BOUNDS_MODES", "OPTION_NAMES", "CONSTRAINTS"]

#: Public names renamed, kept one release with a warning (:mod:`manifill.deprecation`): the group ``step1``'s class.
__getattr__ = renamed(__name__, {"CheckOptions": "manifill.surface.options:Step1Options"})

#: What several samples on one vertex with different values do: refuse, or average.
DUPLICATES = ("error", "mean")
#: What ``untrusted=`` does where the std exceeds the threshold: keep the value (the mask says), or NaN.
UNTRUSTED = ("mask", "nan")
#: How ``bounds`` are kept: the minimiser within them (an active set), or the unbounded field projected onto them.
BOUNDS_MODES = ("exact", "project")

_ARRAY = (list, tuple, np.ndarray)
_POSITIVE = Number(lo=0, lo_open=True)


@dataclass(frozen=True)
class FillOptions:
    """Steps 2-6: the partition, the curve values and the fill's solve (defaults as :func:`manifill.reconstruct`)."""

    partition: str = "delaunay"
    weights: str = "cotan"
    distance: str = "length"
    curve_values: object = None  # None: the method's own ('hermite' for the pipeline; the default preset's)
    solver: str = "auto"
    iteration: str = "gauss-seidel"
    init: str = "gvf"
    seed: int = 0
    tol: object = None
    maxiter: object = None
    on_empty: str = "error"
    neighbours: object = None  # a point cloud's nearest neighbours per point (None: mesh.pointcloud.NEIGHBOURS)
    barriers: object = None  # lines the field must not cross (surface.barriers), checked against the mesh

    #: What each option takes (:mod:`manifill.validate.constraints`): read by :meth:`validate`, the CLI, a test.
    CONSTRAINTS = {
        "partition": [OneOf(*PARTITIONS)], "weights": [OneOf(*WEIGHTS)], "distance": [OneOf(*DISTANCES)],
        "curve_values": [None, OneOf(*CURVE_VALUES)], "solver": [OneOf(*SOLVERS)],
        "iteration": [OneOf(*ITERATIONS)], "init": [OneOf(*INITS)], "seed": [Number(lo=0, integer=True)],
        "tol": [None, _POSITIVE], "maxiter": [None, Number(lo=1, integer=True)], "on_empty": [OneOf(*ON_EMPTY)],
        # how many nearest points each point of a cloud looks at
        "neighbours": [None, Number(lo=6, integer=True)],
        "barriers": [None, Kind((str, os.PathLike), "a file"),
                     Kind(_ARRAY, "a list of vertex paths, positions or per-face labels")],
    }

    def validate(self):
        check_table(self, self.CONSTRAINTS)


@dataclass(frozen=True)
class Step1Options:
    """Step 1: the value ``levels`` and whether the check runs (None: for up to a few fields)."""

    levels: object = None
    check: object = None

    CONSTRAINTS = {"levels": [None, Number(lo=1, integer=True), Kind(_ARRAY, "a list of increasing levels")],
                   "check": [None, Flag()]}

    def validate(self):
        check_table(self, self.CONSTRAINTS)


@dataclass(frozen=True)
class FitOptions:
    """How the samples bind the field: ``bounds`` on the values and how they are kept (``bounds_mode``),
    ``smoothing`` (soft constraints), their weights."""

    bounds: object = None
    bounds_mode: object = None  # None: 'exact' (a preset may set 'project')
    smoothing: object = None
    sample_weights: object = None

    CONSTRAINTS = {"bounds": [None, OneOf("samples"), Pair()], "bounds_mode": [None, OneOf(*BOUNDS_MODES)],
                   "smoothing": [None, OneOf("auto"), Number(lo=0)],
                   "sample_weights": [None, Kind(_ARRAY, "an array of weights > 0, one per sample")]}

    def validate(self):
        check_table(self, self.CONSTRAINTS)

    @property
    def projected(self):
        """Whether the bounds are kept by projecting the unbounded field onto them (any method with values)."""
        return self.bounds is not None and self.bounds_mode == "project"

    @property
    def exact(self):
        """Whether the bounds are kept by the minimiser within them (only the methods that can bound)."""
        return self.bounds is not None and not self.projected


@dataclass(frozen=True)
class PointOptions:
    """How samples are read: repeated vertices (``duplicates``) and positions far from the surface."""

    duplicates: str = "error"
    max_distance: object = None

    CONSTRAINTS = {"duplicates": [OneOf(*DUPLICATES)], "max_distance": [None, _POSITIVE]}

    def validate(self):
        check_table(self, self.CONSTRAINTS)


@dataclass(frozen=True)
class UncertaintyOptions:
    """The Gaussian process's options (``gp``), the std (``uncertainty``) and the trust mask."""

    gp: object = None
    uncertainty: object = None
    trust: object = None
    untrusted: str = "mask"

    #: ``gp``'s own names are checked by :data:`manifill.GPOptions.CONSTRAINTS` (the method decides which it takes);
    #: ``trust`` is a multiple of the samples' standard deviation.
    CONSTRAINTS = {"gp": [None, Kind((dict,), "a dict of gp options"), Kind((GPOptions,), "a GPOptions")],
                   "uncertainty": [None, Flag()], "trust": [None, _POSITIVE], "untrusted": [OneOf(*UNTRUSTED)]}

    def validate(self):
        check_table(self, self.CONSTRAINTS)


#: The groups of :class:`Options` by attribute name, and each flat keyword's group.
GROUPS = {"fill": FillOptions, "step1": Step1Options, "fit": FitOptions, "points": PointOptions,
          "uq": UncertaintyOptions}
OPTION_GROUP = {f.name: g for g, cls in GROUPS.items() for f in fields(cls)}
#: Every keyword :meth:`Options.build` takes (besides ``method``).
OPTION_NAMES = tuple(OPTION_GROUP)
#: Every flat keyword's forms (the groups' tables in one view).
CONSTRAINTS = {name: forms for cls in GROUPS.values() for name, forms in cls.CONSTRAINTS.items()}  # type: ignore[attr-defined]


@dataclass(frozen=True, kw_only=True)
class Options:
    """Everything a reconstruction is asked, checked once (see the module docstring).

    Attributes
    ----------
    method : str
        The method that runs (a name of the registry, :mod:`manifill.surface.methods`).
    preset : str or None
        The preset it came from (``'default'`` for ``method=None``), or None.
    fill, step1, fit, points, uq
        The groups.
    given : frozenset of str
        The keywords the caller gave, other than None (a preset fills in only the others).
    checked : bool
        Resolved and checked by the registry's ``configure`` (a copy changed by :meth:`replace` is not).

    Examples
    --------
    >>> o = Options.build(method="biharmonic", solver="direct", bounds="samples")
    >>> o.method, o.fill.solver, o.fit.bounds, o.fill.weights
    ('biharmonic', 'direct', 'samples', 'cotan')
    >>> o.replace(solver="amg").fill.solver
    'amg'
    >>> Options.build(sovler="direct")
    Traceback (most recent call last):
    ...
    manifill.errors.OptionError: no option 'sovler' (did you mean 'solver'?); see help(manifill.reconstruct)
    """

    method: object = None
    preset: object = None
    fill: FillOptions = field(default_factory=FillOptions)
    step1: Step1Options = field(default_factory=Step1Options)
    fit: FitOptions = field(default_factory=FitOptions)
    points: PointOptions = field(default_factory=PointOptions)
    uq: UncertaintyOptions = field(default_factory=UncertaintyOptions)
    given: frozenset = frozenset()
    checked: bool = False

    @classmethod
    def build(cls, *, method: str | None = None, **keywords: Any) -> Options:
        """Options from flat keywords (those of :func:`manifill.reconstruct`), each checked against its set."""
        return cls(method=method).replace(**keywords)

    def replace(self, **keywords: Any) -> Options:
        """A copy with these flat keywords (and ``method``/``preset``) changed, checked again."""
        top = {key: keywords.pop(key) for key in ("method", "preset") if key in keywords}
        per: dict[str, dict[str, Any]] = {}
        for key, value in keywords.items():
            if key not in OPTION_GROUP:
                close = difflib.get_close_matches(key, OPTION_NAMES + ("method",), n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise OptionError(f"no option {key!r}{hint}; see help(manifill.reconstruct)")
            per.setdefault(OPTION_GROUP[key], {})[key] = value
        groups = {g: replace(getattr(self, g), **kw) for g, kw in per.items()}
        # None is "not given" (a preset fills it in), as in every keyword's default
        given = self.given | frozenset(k for k, v in keywords.items() if v is not None)
        out = replace(self, **top, **groups, given=given, checked=False)
        for g in per:
            getattr(getattr(out, g), "validate", lambda: None)()
        return out

    def get(self, name: str) -> Any:
        """One option by its flat keyword (``o.get('solver') == o.fill.solver``)."""
        if name in ("method", "preset"):
            return getattr(self, name)
        return getattr(getattr(self, OPTION_GROUP[name]), name)

    def keywords(self, *, given_only: bool = False) -> dict[str, Any]:
        """The flat keywords (all, or those the caller gave), as :meth:`build` takes them."""
        names = [n for n in OPTION_NAMES if not given_only or n in self.given]
        return {n: self.get(n) for n in names}
