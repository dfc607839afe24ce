"""The one place where manifill's numerical tolerances live."""

from dataclasses import dataclass

__all__ = ["TOL"]


@dataclass(frozen=True)
class Tolerances:
    """Numerical tolerances, all relative to a scale stated per field.

    Attributes
    ----------
    weld : float
        Two vertices closer than ``weld * diag`` are duplicates (``diag`` is the
        bounding-box diagonal).
    degenerate_area : float
        A face with area below ``degenerate_area * diag**2`` has zero area.
    snap : float
        A sample position farther than ``snap * diag`` from its nearest vertex
        is rejected ("wrong units?").
    amg_rtol : float
        Relative residual at which the AMG-preconditioned conjugate gradient stops.
    iterate_tol : float
        The paper's averaging iteration stops when the largest change in one sweep
        falls below ``iterate_tol`` times the range of the fixed values.
    """

    weld: float = 1e-12
    degenerate_area: float = 1e-14
    snap: float = 0.05
    amg_rtol: float = 1e-10
    iterate_tol: float = 1e-10


TOL = Tolerances()
