"""Which method to trust: K-fold cross-validation on the samples themselves, and ``method="auto"``.

:func:`cross_validate` splits the samples into ``folds`` groups at random (seeded), fits
every candidate method on all groups but one and measures it at the held-out samples:
the error is the root mean square there divided by each field's sample range (a
:class:`CrossValidation`, with ``.best``, ``.table()`` and ``.recommendation``). The
surface (graphs, Laplacians) is built once and every fold goes through
:func:`manifill.surface.reconstruct.reconstruct_surface`.

The default candidates (:data:`CANDIDATES`) are ``gvf-harmonic`` (the default
pipeline), ``gvf-harmonic`` with ``curve_values='monotone'``, ``harmonic``,
``biharmonic``, ``biharmonic`` with ``bounds='samples'``, ``triharmonic`` and ``rbf``
(the thin-plate spline in space, :mod:`manifill.surface.rbf`: it wins where the field
lives in space rather than on the surface); the bi- and triharmonic ones are left out
on a digital surface (no triangles). Options given to :func:`cross_validate` go to every
candidate; a candidate's own options override them. Samples may be vertex indices or
positions (``(k, 3)``, located on the surface as :func:`manifill.reconstruct` locates them).

``reconstruct(..., method="auto")`` cross-validates :data:`AUTO_CANDIDATES` (the default
candidates less the bounded biharmonic, which costs most) with
:data:`AUTO_FOLDS` folds (leave-one-out below that many samples; the split seeded by
``seed``), then reconstructs with the lowest-error one on all samples: the result equals
``reconstruct(..., method=<chosen>, <its options>)``, and ``report['auto']`` holds the
table. For other folds or candidates, call :func:`cross_validate` and pass
``**cv.best_options`` to :func:`manifill.reconstruct`.
"""

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import OptionError, SampleError
from ..validate import as_indices, as_mesh, as_points, as_samples, as_values, check_option, is_mesh_object
from .crossval_result import CrossValidation
from .engine import reconstruct_surface
from .folds import MIN_SAMPLES, fold_labels, label_of, run_folds
from .locate import locate_points
from .methods.auto import AUTO_CANDIDATES, AUTO_FOLDS
from .methods.registry import configure, method_of, names
from .points import is_positions
from .barriers import Cut, renumber
from .surface import Surface
from .unreferenced import compact

__all__ = ["CANDIDATES", "AUTO_CANDIDATES", "AUTO_FOLDS", "MIN_SAMPLES", "CrossValidation", "cross_validate",
           "fold_labels", "candidates_of"]

#: The default candidates: ``(method, options)``.
CANDIDATES: tuple = (("gvf-harmonic", {}), ("gvf-harmonic", {"curve_values": "monotone"}), ("harmonic", {}),
              ("biharmonic", {}), ("biharmonic", {"bounds": "samples"}), ("triharmonic", {}), ("rbf", {}))
#: The options of :func:`cross_validate` besides its own, passed to every fit.
FIT_OPTIONS = ("partition", "weights", "levels", "curve_values", "solver", "iteration", "init", "tol", "maxiter",
               "bounds", "bounds_mode", "smoothing", "sample_weights")
#: Options that shape the surface or the samples, not a fit (refused per candidate).
SURFACE_OPTIONS = ("distance", "duplicates", "max_distance", "neighbours", "barriers")


def candidates_of(methods, digital=False):
    """``{label: (method, options)}`` from names or ``(name, options)`` pairs (None: :data:`CANDIDATES`)."""
    given = methods is not None
    if methods is None:
        methods = [c for c in CANDIDATES if not (digital and method_of(c[0]).needs_triangles)]
    if isinstance(methods, str) or isinstance(methods, tuple) and len(methods) == 2 and isinstance(methods[1], dict):
        methods = [methods]  # one candidate alone
    out = {}
    allowed = [m for m in names() if not method_of(m).delegates]  # a preset (the default) is a candidate too
    for c in methods:
        name, opts = (c, {}) if isinstance(c, str) else (tuple(c) if isinstance(c, (tuple, list)) else (None, None))
        if not isinstance(name, str) or not isinstance(opts, dict):
            raise OptionError(f"methods entry {c!r} is neither a method name nor a (name, options-dict) pair; "
                              f"pass e.g. ['harmonic', ('biharmonic', {{'bounds': 'samples'}})]")
        if name in names() and method_of(name).delegates:
            raise OptionError(f"method={name!r} is what cross-validation chooses for; list actual methods as "
                              f"candidates")
        check_option("method", name, allowed)
        bad = [key for key in opts if key not in FIT_OPTIONS]
        if bad:
            raise OptionError(f"candidate {name!r} has option {bad[0]!r}, not one a fit takes "
                              f"({', '.join(FIT_OPTIONS)}); pass surface options to cross_validate itself")
        label = label_of(name, opts)
        if label in out:
            raise OptionError(f"candidate {label!r} is listed twice; list each once")
        out[label] = (name, dict(opts))
    if not out:
        raise OptionError("methods is empty; pass at least one candidate (or None for the defaults)")
    if given and digital:
        for label, (name, _) in out.items():
            if method_of(name).needs_triangles:
                raise OptionError(f"candidate {label!r} needs triangles; a digital surface has none: leave it out")
    return out


def cross_validate(V: ArrayLike | Surface, F: ArrayLike | None, idx: ArrayLike, vals: ArrayLike, *,
                   methods: list | None = None, folds: int = 10, seed: int = 0, **options: Any) -> CrossValidation:
    """Each method's K-fold (or leave-one-out) error on the samples themselves.

    Parameters
    ----------
    V : (n, 3) array_like, or Surface
        Vertex positions; or a built :class:`manifill.surface.surface.Surface`
        (e.g. a digital surface) with ``F`` None.
    F : (m, 3) array_like of int or None
        Triangles.
    idx : (k,) array_like of int, or (k, 3) array_like of float
        Sample vertices; or sample positions, each located at its closest surface
        point (:mod:`manifill.surface.points`): every fold's fit gets its training
        points as :func:`manifill.reconstruct` would (exactly there for the energy
        methods and ``rbf``, at the nearest vertex for the others), and is measured
        at the held-out points by barycentric interpolation on their faces.
    vals : (k,) or (k, p) array_like of float
        Sample values, one column per field.
    methods : list, optional
        Candidates: method names of :func:`manifill.reconstruct` or ``(name, options)``
        pairs, e.g. ``["harmonic", ("biharmonic", {"bounds": "samples"})]``; by default
        :data:`CANDIDATES` (the bi- and triharmonic ones left out on a digital surface).
    folds : int >= 2 or 'loo', optional
        Number of groups of the random split, or leave-one-out.
    seed : int, optional
        Seed of the split (and of ``init='random'``).
    **options
        ``distance``, ``duplicates``, ``max_distance`` (how the surface and the samples are read) and the
        options of :func:`manifill.reconstruct` every fit gets (``weights``, ``solver``,
        ``partition``, ``bounds``, ...); a candidate's own options override them. Every
        fold is fitted with ``on_empty='nan'``: a held-out sample in a mesh component
        without training samples has no prediction, is left out and counted.

    Returns
    -------
    CrossValidation

    Raises
    ------
    MeshError, SampleError
        Malformed input; fewer samples than folds (the message names how many are needed).
    OptionError
        An unknown method or option, ``folds`` not an int >= 2 or ``'loo'``.

    See Also
    --------
    manifill.reconstruct : ``method='auto'`` picks by this.

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> V, F = grid(8)
    >>> idx = np.arange(0, 64, 5)
    >>> cv = cross_validate(V, F, idx, 2 * V[idx, 0] - V[idx, 1], methods=["harmonic", "rbf"], folds=4)
    >>> cv.best, cv.errors["rbf"] < 1e-9
    ('rbf', True)
    """
    bad = [key for key in options if key not in FIT_OPTIONS + SURFACE_OPTIONS]
    if bad:
        raise OptionError(f"cross_validate takes no option {bad[0]!r}; pass those of reconstruct "
                          f"({', '.join(FIT_OPTIONS + SURFACE_OPTIONS)})")
    base = configure(method="harmonic", **options)  # every option checked once; each candidate sets its method
    if base.fill.barriers is not None and (isinstance(V, Surface) or F is None and not is_mesh_object(V)):
        raise OptionError("barriers cut a mesh along its edges: give the mesh (V, F), not a Surface or a point cloud")
    if isinstance(V, Surface):
        if F is not None:
            raise OptionError("pass F=None with a Surface (it has its own triangles, or none)")
        surface = V
    elif F is None and not is_mesh_object(V):  # a point cloud
        surface = Surface.from_points(as_points(V), neighbours=base.fill.neighbours, distance=base.fill.distance,
                                      check=False)
    else:
        V, F = as_mesh(V, F, allow_degenerate=base.fill.weights in ("uniform", "robust"), allow_unreferenced=True)
        cm = compact(V, F)  # vertices used by no face take no part (the held-out samples are on faces)
        if cm is not None:
            V, F = cm.V, cm.F
            if not is_positions(idx):
                idx = cm.indices(as_indices(idx, cm.n, what="idx", unique=False))
        barriers = base.fill.barriers
        if barriers is not None and cm is not None:  # paths in the caller's numbering
            barriers = renumber(barriers, cm.new)
        cut = None if barriers is None else Cut(V, F, barriers)
        surface = Surface.from_mesh(V, F, distance=base.fill.distance, check=False, cut=cut)
    cands = candidates_of(methods, digital=surface.mass is None)
    duplicates, max_distance = base.points.duplicates, base.points.max_distance
    if is_positions(idx):
        if surface.F is None and surface.cloud is None:
            raise SampleError("samples as positions need triangles to be located on; pass vertex indices")
        P = np.asarray(idx, dtype=np.float64)
        vals, _ = as_values(vals, len(P))
        loc = locate_points(surface.V, surface.F, P, max_distance=max_distance)
        return run_folds(surface, loc.nearest_vertex, vals, cands, folds=folds, seed=seed, options=base,
                         reconstruct=reconstruct_surface, lookup=method_of,
                         positions=(P, loc, duplicates, lambda name: method_of(name).at_points))
    if max_distance is not None:
        raise OptionError("max_distance applies to samples given as positions, not vertex indices; leave it out")
    raw = np.asarray(idx)
    idx, vals, _ = as_samples(idx, vals, surface.n if surface.cut is None else surface.cut.n, duplicates=duplicates)
    if base.fit.sample_weights is not None:
        if idx.size != raw.size:
            raise SampleError("sample_weights with repeated sample vertices: merge the samples first, one per vertex")
        base = base.replace(sample_weights=np.asarray(base.fit.sample_weights, dtype=np.float64)[np.argsort(raw)])
    groups = None
    if surface.cut is not None:  # a sample on a barrier holds on each side: its copies, held out together
        copies, rows = surface.cut.copies(idx)
        order = np.argsort(copies, kind="stable")
        idx, vals, groups = copies[order], vals[rows[order]], rows[order]
        surface.cut.check_pieces(idx, base.fill.on_empty)
        if base.fit.sample_weights is not None:
            base = base.replace(sample_weights=np.asarray(base.fit.sample_weights)[groups])
    return run_folds(surface, idx, vals, cands, folds=folds, seed=seed, options=base, reconstruct=reconstruct_surface,
                     lookup=method_of, groups=groups)
