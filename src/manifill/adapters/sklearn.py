"""A scikit-learn estimator over a fixed mesh or point cloud: :class:`SurfaceRegressor`.

The mesh (or cloud) is the estimator's own parameter, fixed as a kernel's domain is; the samples are the data:
``X`` holds where each sample is -- one column of vertex indices, or three of positions on (or near) the surface
-- and ``y`` its value(s). ``fit`` prepares a :class:`manifill.Reconstructor` and reconstructs the field;
``predict`` reads it where asked (at vertices, or linearly on the faces at positions; on a point cloud, the
nearest point), with the std for ``method='gp'`` (or ``uncertainty=True``) by ``return_std=True``. Everything is a
constructor parameter, so ``get_params``/``set_params``, ``clone``, ``cross_val_score``, pipelines and
``GridSearchCV`` (e.g. over ``smoothing`` or the gp's ``range``) work as for any regressor.

Needs the ``[sklearn]`` extra (scikit-learn).
"""

import os
from collections.abc import Sequence
from typing import Literal, TypeVar, overload

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial import cKDTree

from ..errors import OptionError, SampleError
from ..linalg.gp import GPOptions
from ..surface.reconstructor import Reconstructor

try:
    from sklearn.base import BaseEstimator, RegressorMixin
    from sklearn.utils.validation import check_is_fitted
except ImportError:  # the extra, named when used
    raise ImportError("manifill.adapters.sklearn needs scikit-learn: pip install 'manifill[sklearn]'") from None

__all__ = ["SurfaceRegressor"]

_Regressor = TypeVar("_Regressor", bound="SurfaceRegressor")


class SurfaceRegressor(RegressorMixin, BaseEstimator):
    """Reconstruct a field on a fixed surface from samples, as a scikit-learn regressor.

    Parameters
    ----------
    V : (n, 3) array_like
        The mesh's vertices (or the cloud's points).
    F : (m, 3) array_like of int, optional
        Its triangles; None for a point cloud.
    method : str, optional
        Any method of :func:`manifill.reconstruct` (None: the default preset).
    smoothing, bounds, weights, gp, uncertainty, neighbours, barriers
        As for :func:`manifill.reconstruct`.

    Attributes
    ----------
    result_ : Reconstruction
        The field fitted (``result_.values`` at every vertex).
    n_features_in_ : int
        1 (vertex indices) or 3 (positions).

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(3)
    >>> X = np.arange(0, len(V), 7)[:, None]
    >>> est = SurfaceRegressor(V, F, method="biharmonic").fit(X, V[X[:, 0], 2])
    >>> round(est.score(np.arange(len(V))[:, None], V[:, 2]), 3)
    1.0
    """

    def __init__(self, V: ArrayLike | None = None, F: ArrayLike | None = None, *, method: str | None = None,
                 smoothing: float | str | None = None, bounds: str | tuple | None = None, weights: str = "cotan",
                 gp: GPOptions | dict | None = None, uncertainty: bool | None = None, neighbours: int | None = None,
                 barriers: Sequence[ArrayLike] | ArrayLike | str | os.PathLike[str] | None = None) -> None:
        self.V = V
        self.F = F
        self.method = method
        self.smoothing = smoothing
        self.bounds = bounds
        self.weights = weights
        self.gp = gp
        self.uncertainty = uncertainty
        self.neighbours = neighbours
        self.barriers = barriers

    def _where(self, X, fitting):
        """``X`` as vertex indices ``(k,)`` or positions ``(k, 3)``, checked against the surface."""
        if self.V is None:
            raise OptionError("SurfaceRegressor needs the surface: SurfaceRegressor(V, F) (F None for a point cloud)")
        if hasattr(X, "toarray") or np.iscomplexobj(np.asarray(X)):
            raise SampleError("X is sparse or complex; pass a dense real (k, 1) array of vertex indices or (k, 3) "
                              "array of positions")
        try:
            A = np.asarray(X, dtype=np.float64)
        except (TypeError, ValueError):
            raise SampleError("X could not be read as numbers; pass (k, 1) vertex indices or (k, 3) positions") \
                from None
        if A.ndim != 2 or A.shape[1] not in (1, 3) or len(A) == 0:
            raise SampleError(f"X has shape {A.shape}; pass (k, 1) vertex indices or (k, 3) positions on the "
                              f"surface")
        if not np.isfinite(A).all():
            raise SampleError("X holds NaN or infinite entries; pass finite vertex indices or positions")
        if not fitting and A.shape[1] != self.n_features_in_:
            raise SampleError(f"X has {A.shape[1]} columns and the estimator was fitted on {self.n_features_in_}; "
                              f"pass the same kind (vertex indices or positions)")
        if A.shape[1] == 1:
            if np.any(A != np.round(A)):
                raise SampleError("X's single column holds vertex indices: whole numbers; pass (k, 3) for positions")
            return A[:, 0].astype(np.int64)
        return A

    def fit(self: _Regressor, X: ArrayLike, y: ArrayLike) -> _Regressor:
        """Reconstruct the field from samples at ``X`` (vertex indices or positions) with values ``y``."""
        where = self._where(X, fitting=True)
        vals = np.asarray(y, dtype=np.float64)
        if vals.ndim not in (1, 2) or len(vals) != len(where):
            raise SampleError(f"y has shape {vals.shape} for {len(where)} samples; pass (k,) or (k, p) values")
        options = {key: getattr(self, key) for key in ("method", "smoothing", "bounds", "weights", "gp",
                                                         "uncertainty", "neighbours", "barriers")}
        try:  # (self.V is not None: _where refused that)
            self.result_ = Reconstructor(self.V, self.F, where, **options, duplicates="mean").apply(vals)  # type: ignore[arg-type]
        except SampleError as exc:  # more positions in a triangle than its corners hold apart: nearest vertices
            if where.ndim == 1 or "not independent" not in str(exc):
                raise
            near = cKDTree(np.asarray(self.V, dtype=np.float64)).query(where)[1]
            self.result_ = Reconstructor(self.V, self.F, near, **options, duplicates="mean").apply(vals)  # type: ignore[arg-type]
        self.n_features_in_ = 1 if where.ndim == 1 else 3
        return self

    @overload
    def predict(self, X: ArrayLike, return_std: Literal[False] = ...) -> np.ndarray: ...
    @overload
    def predict(self, X: ArrayLike, return_std: Literal[True]) -> tuple[np.ndarray, np.ndarray]: ...
    @overload
    def predict(self, X: ArrayLike, return_std: bool) -> np.ndarray | tuple[np.ndarray, np.ndarray]: ...

    def predict(self, X: ArrayLike, return_std: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """The field at ``X`` (vertex indices or positions): ``(k,)`` or ``(k, p)``, and its std with ``return_std``."""
        check_is_fitted(self, "result_")
        where = self._where(X, fitting=False)
        r = self.result_
        if return_std and r.std is None:
            raise OptionError("this fit has no std; use method='gp' (or uncertainty=True with an energy method)")
        if where.ndim == 1:
            bad = where[(where < 0) | (where >= len(r.values))]
            if bad.size:
                raise SampleError(f"X holds vertex {int(bad[0])}, outside 0..{len(r.values) - 1}; pass vertices of "
                                  f"the surface")
            # (r.std is not None with return_std: refused above)
            return (r.values[where], r.std[where]) if return_std else r.values[where]  # type: ignore[index]
        return r.at(where, return_std=return_std)
