"""The smoothing's ``lam``: checked, and its log grid (the search itself is :mod:`manifill.linalg.search`'s).

:meth:`manifill.linalg.smoothing.SmoothingFit.select` chooses ``lam`` by GCV or leave-one-out with
:func:`manifill.linalg.search.grid_search` on :func:`log_grid` or a user's grid (:func:`as_grid`); every field gets
its own minimiser, found among the grid and its own refinement points only.
"""



import numpy as np

from ..deprecation import renamed
from ..errors import OptionError

__all__ = ["check_lam", "log_grid", "as_grid"]

def check_lam(lam, p):
    """``lam`` as a float, or an array of ``p`` floats, each finite and >= 0 (:class:`~manifill.errors.OptionError`)."""
    try:
        a = np.asarray(lam, dtype=np.float64)
    except (TypeError, ValueError):
        raise OptionError(f"lam={lam!r} is not a number; pass lam >= 0 (0 interpolates) or 'auto'") from None
    if a.ndim > 1 or (a.ndim == 1 and a.size != p):
        raise OptionError(f"lam has shape {a.shape} for {p} fields; pass one number, or one per field")
    if not np.isfinite(a).all():
        raise OptionError(f"lam={lam!r} is NaN or infinite; pass a finite lam >= 0 (0 interpolates) or 'auto'")
    if (a < 0).any():
        raise OptionError(f"lam={lam!r} is negative; pass lam >= 0 (0 interpolates) or 'auto'")
    return float(a) if a.ndim == 0 else a


def log_grid(scale, decades=(-6.0, 4.0), per_decade=4):
    """``scale * 10**t`` for ``t`` from ``decades[0]`` to ``decades[1]``, ``per_decade`` points a decade.

    >>> log_grid(2.0, (0, 1), 2).tolist()
    [2.0, 6.324555320336759, 20.0]
    """
    lo, hi = decades
    return scale * 10.0 ** np.linspace(lo, hi, int(round((hi - lo) * per_decade)) + 1)


def as_grid(lams, what="lams"):
    """A user's grid: sorted, unique, finite values > 0 (:class:`~manifill.errors.OptionError` otherwise)."""
    try:
        grid = np.atleast_1d(np.asarray(lams, dtype=np.float64)).ravel()
    except (TypeError, ValueError):
        grid = np.empty(0)
    if grid.size == 0 or not np.isfinite(grid).all() or (grid <= 0).any():
        raise OptionError(f"{what} must be finite values > 0; pass a grid such as np.logspace(-3, 3, 13)")
    return np.unique(grid)


#: Public names moved, kept one release with a warning (:mod:`manifill.deprecation`).
__getattr__ = renamed(__name__, {"grid_search": "manifill.linalg.search:grid_search"})
