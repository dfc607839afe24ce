"""The surface methods by name: what each runs, what ``method=None`` means, and the check of every option.

:data:`METHODS` lists the methods of :func:`manifill.surface.reconstruct.reconstruct`,
:data:`STEPS` the steps each runs (a progress bar's total), :data:`DEFAULT` what the
default (``method=None``) runs, chosen by measurement, and :func:`check_options` checks
every option against its closed set.
"""

import numpy as np

from ..errors import OptionError
from ..linalg.backends import ITERATIONS, SOLVERS
from ..mesh.graph import DISTANCES
from ..mesh.laplacian import WEIGHTS
from ..validate import check_option
from .curve_values import CURVE_VALUES
from .fill import INITS
from .harmonic import ON_EMPTY
from .partition import PARTITIONS

__all__ = ["METHODS", "STEPS", "DEFAULT", "CHECK_FIELDS", "resolve_default", "check_options", "runs_check"]

METHODS = ("gvf-harmonic", "harmonic", "biharmonic", "triharmonic", "gvf", "rbf", "gp", "auto")

#: The steps each method runs, in order, under the names it passes to ``progress``
#: (:func:`reconstruct` runs ``graph`` before them; a progress bar's total is their count).
STEPS = {"gvf-harmonic": ("partition", "check", "curve values", "harmonic fill"),
         "harmonic": ("check", "harmonic fill"),
         "biharmonic": ("check", "biharmonic fill"),
         "triharmonic": ("check", "triharmonic fill"),
         "gvf": ("check", "gvf"),
         "rbf": ("check", "rbf"),
         "gp": ("check", "gp"),
         "auto": ("cross-validate", "fill")}

#: What ``method=None`` (the default) runs, chosen by measurement (README, "Which method when"): among the
#: methods that never leave the samples' range and take at most 4x the earlier default's time at 655k
#: vertices, the lowest median relative RMSE over the whole accuracy benchmark (``python -m bench accuracy``).
#: The paper's pipeline with monotone cubic curve values, its fill bounded by the samples' range.
DEFAULT = {"method": "gvf-harmonic", "curve_values": "monotone", "bounds": "samples"}


#: ``check=None`` runs Step 1 (the gradual variation report) for every field when there are at most this many
#: fields, and skips it for more (each field costs a few shortest-path passes); ``check=True`` runs it always.
CHECK_FIELDS = 10


def runs_check(check, method, curve_values, solver, init, fields):
    """Whether Step 1 runs for ``fields`` fields: always where its levels are needed (``method='gvf'``,
    ``curve_values='gvf'``, the iteration's GVF start), else as ``check`` says (None: up to :data:`CHECK_FIELDS`).

    Examples
    --------
    >>> runs_check(None, "harmonic", None, "auto", "gvf", 3), runs_check(None, "harmonic", None, "auto", "gvf", 100)
    (True, False)
    >>> runs_check(False, "gvf", None, "auto", "gvf", 1)
    True
    """
    if method == "gvf" or curve_values == "gvf" or (solver == "iterate" and init == "gvf"):
        return True
    if check is None:
        return fields <= CHECK_FIELDS
    if not isinstance(check, (bool, np.bool_)):
        raise OptionError(f"check={check!r} is not True, False or None; pass one of those")
    return bool(check)


def resolve_default(method, curve_values=None, bounds=None):
    """``(method, curve_values, bounds)`` with ``method=None`` resolved to :data:`DEFAULT`.

    ``method=None`` takes :data:`DEFAULT`'s method, its curve values unless ``curve_values``
    is given, and its bounds unless ``bounds`` is given; an explicit method keeps
    ``bounds`` as given and ``curve_values=None`` means ``'hermite'`` (the pipeline's own
    default).

    Examples
    --------
    >>> resolve_default(None)
    ('gvf-harmonic', 'monotone', 'samples')
    >>> resolve_default("gvf-harmonic")
    ('gvf-harmonic', 'hermite', None)
    """
    if method is None:
        return (DEFAULT["method"], DEFAULT["curve_values"] if curve_values is None else curve_values,
                DEFAULT["bounds"] if bounds is None else bounds)
    return method, "hermite" if curve_values is None else curve_values, bounds



def check_options(method="gvf-harmonic", partition="delaunay", weights="cotan", distance="length",
                  curve_values="hermite", solver="auto", on_empty="error", iteration="gauss-seidel", init="gvf"):
    """Check the options of :func:`reconstruct` against their closed sets (defaults as there).

    Raises
    ------
    OptionError
        An option outside its set; the message lists the allowed values.

    Examples
    --------
    >>> check_options(method="gvf", distance="hops")
    >>> check_options(method="fast")
    Traceback (most recent call last):
    ...
    manifill.errors.OptionError: method='fast' is not one of 'gvf-harmonic', 'harmonic', ... pass one of those
    """
    if method is not None:  # None: the default (DEFAULT)
        check_option("method", method, METHODS)
    check_option("partition", partition, PARTITIONS)
    check_option("weights", weights, WEIGHTS)
    check_option("distance", distance, DISTANCES)
    if curve_values is not None:  # None: the method's own (resolve_default)
        check_option("curve_values", curve_values, CURVE_VALUES)
    check_option("solver", solver, SOLVERS)
    check_option("on_empty", on_empty, ON_EMPTY)
    check_option("iteration", iteration, ITERATIONS)
    check_option("init", init, INITS)
