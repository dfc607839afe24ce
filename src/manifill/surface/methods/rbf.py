"""``method='rbf'``: the thin-plate spline on the positions, for fields that live in space.

SciPy's thin-plate RBF through the samples (:func:`manifill.surface.rbf.thin_plate_rbf`):
through the closest surface points of samples given as positions when every point was
located, else through their nearest vertices. ``smoothing`` a number gives a smoothing
spline; it has no mesh energy to minimise within ``bounds`` and refuses them. Linear in the
values unless ``smoothing='auto'``.
"""

import numpy as np

from ...errors import OptionError
from ..rbf import thin_plate_rbf
from .base import Method

__all__ = ["RBF", "ThinPlate"]


def _constrained(points):
    """Whether every point got its constraint (it lies on the surface where it was located)."""
    return points is not None and points.constraint.size and (points.constraint >= 0).all()


class ThinPlate(Method):
    """The thin-plate spline in space (see the module docstring)."""

    name = "rbf"
    summary = "SciPy's thin-plate spline on the positions: fields that live in space; leaks across gaps"
    can_smooth = True
    smooth_gradient = True
    at_points = True  # through the points themselves when every one was located (exact_at says)
    cv_hint = "the field looks like it lives in space rather than on the surface"
    step_names = ("check", "rbf")

    def check(self, options):
        if options.fit.exact:
            raise OptionError("method='rbf' has no mesh energy to minimise within bounds; pass bounds=None, or use an "
                              "energy method (e.g. method='biharmonic', bounds='samples'), or "
                              "bounds_mode='project' to clip the spline to them")
        super().check(options)

    def linear(self, options):
        return options.fit.smoothing != "auto", "smoothing='auto' picks lambda per field"

    def exact_at(self, run):
        return bool(_constrained(run.points))

    def fill(self, run):
        run.step1(self)
        points, w = run.points, run.options.fit.sample_weights
        cut = run.surface.cut
        if cut is not None:  # in space it sees through barriers: one spline per piece they part the surface into
            if not cut.parted:
                raise OptionError("method='rbf' works in space and follows barriers only where they part the surface "
                                  "into pieces, and these leave it in one piece; use an energy method or gp (e.g. "
                                  "method='biharmonic'), which follow the surface round the barriers' ends")
            with run.step("rbf"):
                return _by_piece(run, cut.piece, w), None
        with run.step("rbf"):
            X, Y = run.surface.V[run.idx], run.vals
            if _constrained(points):
                Y = points.values
                X = np.empty((len(Y), run.surface.V.shape[1]))
                X[points.constraint] = points.located.points
                if w is not None:
                    w = points.weights(w)
            values, run.report["rbf"] = thin_plate_rbf(run.surface.V, X, Y, smoothing=run.options.fit.smoothing,
                                                   sample_weights=w)
        return values, None


def _by_piece(run, piece, w):
    """The spline of each piece through its own samples (the nearest vertices), NaN on a piece with none."""
    V, idx, vals = run.surface.V, run.idx, run.vals
    out = np.full((len(V), vals.shape[1]), np.nan)
    reports = []
    for q in np.unique(piece[idx]):
        rows, mine = np.flatnonzero(piece == q), piece[idx] == q
        out[rows], rep = thin_plate_rbf(V[rows], V[idx[mine]], vals[mine], smoothing=run.options.fit.smoothing,
                                    sample_weights=None if w is None else np.asarray(w)[mine])
        reports.append(rep)
    run.report["rbf"] = {**reports[0], "pieces": len(reports)}
    return out


RBF = ThinPlate()
