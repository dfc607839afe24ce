"""Steps 1-6 on a Surface and validated samples, for any method of the registry.

:func:`reconstruct_surface` configures the options once
(:func:`manifill.surface.methods.registry.configure`), looks the method up and lets it
run (:meth:`manifill.surface.methods.base.Method.reconstruct`): the method runs its steps
(for the paper's pipeline: Steps 2-3, Step 1, Step 4, Steps 5-6) into a
:class:`~manifill.surface.methods.base.Run`, which then adds what every method shares --
the std when asked, the trust mask, the overshoot, the points' report, the timings -- and
gives the :class:`~manifill.surface.reconstruction.Reconstruction`. With ``bounds_mode='project'`` the
method fills without bounds and :func:`project` clips its field onto them: any method, one solve.
"""

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from .energy_fill import as_bounds
from .methods.base import Run, overshoot_by_field
from .methods.registry import configure, for_surface, method_of
from .options import Options
from .points import PointSamples
from .prepared import Prepared
from .reconstruction import Reconstruction
from .surface import Surface

__all__ = ["reconstruct_surface", "project"]


def reconstruct_surface(surface: Surface, idx: np.ndarray, vals: np.ndarray, *, options: Options | None = None,
                        points: PointSamples | None = None, fields: int | None = None, prepared: Prepared | None = None,
                        progress: Callable[[str], object] | None = None, seconds: dict[str, float] | None = None,
                        **keywords: Any) -> Reconstruction:
    """Steps 1-6 on a Surface and validated samples, by any method.

    Parameters
    ----------
    surface : Surface
        A mesh (:meth:`manifill.surface.surface.Surface.from_mesh`) or a digital surface.
    idx : (k,) int64 numpy array
        Sample vertices, sorted and unique (as :func:`manifill.validate.as_samples` returns them).
    vals : (k, p) float64 numpy array
        Sample values, one column per field (always two-dimensional).
    options : Options, optional
        The options (:class:`manifill.surface.options.Options`), built once.
    **keywords
        The options of :func:`manifill.reconstruct` (``method``, ``solver``, ``bounds``, ...): they build the
        options, or change the given ones.
    points : PointSamples, optional
        Samples given as positions (:func:`manifill.surface.points.point_samples`);
        ``idx`` and ``vals`` are then their nearest vertices (the partition
        methods' samples), and the methods that take points constrain the points themselves.
    fields : int, optional
        How many fields will share the value-independent pieces (default: ``vals``'
        columns); with many, ``solver='auto'`` factorises and Step 4's linear curve
        values become one sparse map.
    prepared : Prepared, optional
        Keeps those pieces for the next call with the same samples
        (:mod:`manifill.surface.prepared`; what :class:`manifill.Reconstructor` passes).
    progress : callable, optional
        Called with the name of each step as it starts.
    seconds : dict, optional
        Timings the caller measured before (e.g. ``validate``, ``graph``). The
        result's ``report['seconds']`` is this dict, filled in place with one
        entry per step run and ``total``: the given entries' sum plus the time
        spent here.

    Returns
    -------
    Reconstruction
        With ``values`` of shape (n, p), never squeezed.

    Raises
    ------
    OptionError, SampleError, SolveError
        As for :func:`manifill.reconstruct`.

    Examples
    --------
    >>> import numpy as np
    >>> from manifill.mesh.shapes import icosphere
    >>> from manifill.surface.surface import Surface
    >>> V, F = icosphere(2)
    >>> idx = np.array([0, 10, 50, 90, 120])
    >>> r = reconstruct_surface(Surface.from_mesh(V, F), idx, V[idx, :1] * 2.0)
    >>> r.values.shape, bool(np.allclose(r.values[idx, 0], V[idx, 0] * 2.0)), r.report["preset"]
    ((162, 1), True, 'default')
    """
    options = for_surface(configure(options, **keywords), surface)
    method = method_of(options.method)
    lohi, sample_vals = None, vals if points is None else points.values
    if options.fit.projected:  # the method fills without bounds; its field is projected onto them after
        lohi = as_bounds(options.fit.bounds, sample_vals)
        options = replace(options, fit=replace(options.fit, bounds=None))
    run = Run(surface, idx, vals, options, points=points, fields=vals.shape[1] if fields is None else fields,
              prepared=prepared, progress=progress, seconds={} if seconds is None else seconds,
              reconstruct=reconstruct_surface, lookup=method_of)
    result = method.reconstruct(run)
    return result if lohi is None else project(result, *lohi, sample_vals)


def project(result, lo, hi, sample_vals):
    """Clip a result's fields onto ``[lo, hi]`` (``bounds_mode='project'``) and say so in its report.

    The values that left the bounds, and only those, are set to the bound they crossed; NaN stays NaN. The
    report's ``bounds`` holds the mode, the bounds, the values projected per field and the largest distance
    beyond the bounds before (``overshoot``); ``report['overshoot']`` is measured again. Samples inside faces stay
    exact where their face's corners stayed within the bounds; a point whose face had a corner beyond them moves
    with it (``points_moved``, ``points_largest_move``: at most that corner's overshoot). The exact minimiser
    (``bounds_mode='exact'``) keeps every point.

    Parameters
    ----------
    result : Reconstruction
        Values ``(n, p)``.
    lo, hi : (p,) numpy arrays
        Per field (``-inf``/``inf`` where open).
    sample_vals : (k, p) numpy array
        The sample values (``report['overshoot']`` is measured against their range again).

    Returns
    -------
    Reconstruction
        The same object, its values clipped.
    """
    X = result.values
    at = None if result.points is None else result.points.interpolate(X)
    with np.errstate(invalid="ignore"):
        below, above = X < lo, X > hi
        before = np.maximum(np.fmax.reduce(np.where(above, X - hi, 0.0), axis=0),
                            np.fmax.reduce(np.where(below, lo - X, 0.0), axis=0))
    np.clip(X, lo, hi, out=X)
    result.report["bounds"] = {"mode": "project", "lo": lo.tolist(), "hi": hi.tolist(),
                               "projected": (below.sum(axis=0) + above.sum(axis=0)).tolist(),
                               "overshoot": before.tolist()}
    if at is not None:  # a point whose face has a corner beyond the bounds moves with that corner
        moved = np.abs(result.points.interpolate(X) - at)
        moved = moved.reshape(len(moved), -1).max(axis=1)
        result.report["bounds"]["points_moved"] = int((moved > 0).sum())
        result.report["bounds"]["points_largest_move"] = float(moved.max(initial=0.0))
    d = overshoot_by_field(X, sample_vals)
    result.report["overshoot"] = float(np.nanmax(d)) if np.isfinite(d).any() else 0.0
    return result
