"""The numbers of a run's summary: the range of each field, for the lines the command line prints.

The command line holds no numerics: what it prints about values (each field's
range beside the samples', so that overshoot shows) is computed here.
"""

import numpy as np

__all__ = ["value_ranges"]


def value_ranges(values, point_ndim=1):
    """The smallest and largest value of each field, NaN (outside a solid, empty components) left out.

    Parameters
    ----------
    values : array_like
        Values at points: shape ``points`` (one field) or ``points + (p,)``
        (``p`` fields), where ``points`` has ``point_ndim`` axes (1 for
        vertices or samples, 3 for voxels).
    point_ndim : int, optional
        How many leading axes index points.

    Returns
    -------
    lo, hi : (p,) float64 numpy arrays
        Per field; NaN for a field without a finite value.

    Examples
    --------
    >>> lo, hi = value_ranges([[0.0, 5.0], [np.nan, np.nan], [2.0, -1.0]])
    >>> lo.tolist(), hi.tolist()
    ([0.0, -1.0], [2.0, 5.0])
    >>> [v.tolist() for v in value_ranges(np.full((2, 2, 2), np.nan), point_ndim=3)]
    [[nan], [nan]]
    """
    X = np.asarray(values, dtype=np.float64)
    X = X.reshape(-1, 1) if X.ndim == point_ndim else X.reshape(-1, X.shape[-1])
    lo = np.full(X.shape[1], np.nan)
    hi = np.full(X.shape[1], np.nan)
    some = ~np.isnan(X).all(axis=0)
    lo[some] = np.nanmin(X[:, some], axis=0)
    hi[some] = np.nanmax(X[:, some], axis=0)
    return lo, hi
