"""The precomputed penalised fit :class:`SmoothingFit` (the Demmler-Reinsch basis of the samples' Schur complement),
for any values and ``lam``, and its choice of ``lam`` by GCV or leave-one-out. The method is described in
:mod:`manifill.linalg.smoothing`, whose one-shot :func:`~manifill.linalg.smoothing.smooth` uses it.
"""

import numpy as np
import scipy.linalg
import scipy.sparse as sp

from ..errors import MeshError, OptionError, ResourceError, SampleError, SolveError
from ..mesh.topology import pattern_components
from ..tolerances import TOL
from ..validate import as_laplacian, as_values, check_option
from .lamsearch import as_grid, check_lam, log_grid
from .search import grid_search
from .quadratic import QuadraticSolver

__all__ = ["SELECT_METHODS", "SmoothingFit"]

#: How ``lam="auto"`` chooses the smoothing parameter.
SELECT_METHODS = ("gcv", "loo")

#: The default grid: ``lam0 * 10**GRID_DECADES[0] .. lam0 * 10**GRID_DECADES[1]``, ``GRID_PER_DECADE`` a decade.
GRID_DECADES = (-6.0, 4.0)
GRID_PER_DECADE = 4
#: Bytes of dense right-hand sides per block of the Schur complement's Dirichlet solves.
BLOCK_BYTES = 64 * 2**20


class SmoothingFit:
    """Minimise ``sum_i w_i ((S x)_i - y_i)^2 + lam x^T A x``, precomputed once for any ``y`` and ``lam``.

    Parameters
    ----------
    A : (n, n) scipy sparse matrix
        The energy: symmetric positive semi-definite, its null space the
        constants on each connected component of its graph (a Laplacian, a
        biharmonic ``L M^-1 L``).
    S : (k, n) scipy sparse matrix
        Observation rows, each with at least one non-zero entry (one 1 at a
        sample vertex, or a point's barycentric coordinates on its face).
    w : (k,) array_like of float, optional
        Positive weights of the samples (1 by default).
    solver : {'auto', 'direct', 'amg', 'iterate'}, optional
        Backend of the Dirichlet solves (``m`` of them once, then one per
        fit); ``'auto'`` factorises when the factors fit in memory (fastest for
        many right-hand sides), else as :class:`~manifill.linalg.quadratic.QuadraticSolver`.

    Attributes
    ----------
    A : (n, n) scipy.sparse.csr_array
    S : (k, n) scipy.sparse.csr_array
    w : (k,) numpy array
    lam0 : float
        The data-independent scale ``tr(S^T W S) / tr(A)`` of ``lam``.

    Raises
    ------
    MeshError
        ``A`` not square, not finite, not symmetric, or zero.
    SampleError
        ``S`` or ``w`` of the wrong shape, not finite, an empty row of ``S``,
        or a weight <= 0.
    SolveError
        A connected component of ``A``'s graph with no sample.

    See Also
    --------
    smooth : the one-shot function.
    manifill.linalg.quadratic.QuadraticSolver : the exact interpolation (``lam = 0``).

    Examples
    --------
    A path of 5 vertices, samples at its ends and middle, a noisy middle value:

    >>> import scipy.sparse as sp
    >>> A = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(5, 5)).tolil()
    >>> A[0, 0] = A[4, 4] = 1.0
    >>> S = sp.csr_array((np.ones(3), ([0, 1, 2], [0, 2, 4])), shape=(3, 5))
    >>> fit = SmoothingFit(A, S)
    >>> x, info = fit.solve([0.0, 1.0, 0.0], 0.0)
    >>> x.round(12).tolist()
    [0.0, 0.5, 1.0, 0.5, 0.0]
    >>> x, info = fit.solve([0.0, 1.0, 0.0], 1e9)
    >>> bool(np.allclose(x, 1 / 3, atol=1e-6))
    True
    """

    def __init__(self, A, S, *, w=None, solver="auto"):
        A = as_laplacian(A, what="A")
        n = A.shape[0]
        asym = abs(A - A.T).max() if A.nnz else 0.0
        scale = abs(A).max() if A.nnz else 0.0
        if scale == 0 or asym > TOL.energy_symmetry * scale:
            raise MeshError(f"A is {'zero' if scale == 0 else 'not symmetric'}; pass a symmetric positive "
                            f"semi-definite energy (a Laplacian, or L M^-1 L)")
        try:
            S = sp.csr_array(S, dtype=np.float64)
        except (TypeError, ValueError):
            raise SampleError("S could not be read as a sparse matrix of numbers; pass a scipy.sparse matrix") \
                from None
        if S.ndim != 2 or S.shape[1] != n or S.shape[0] == 0 or not np.isfinite(S.data).all():
            raise SampleError(f"S has shape {S.shape} or entries that are not finite; pass (k, {n}) finite "
                              f"observation rows, k >= 1")
        S.eliminate_zeros()
        S.sort_indices()
        k = S.shape[0]
        empty = np.flatnonzero(np.diff(S.indptr) == 0)
        if empty.size:
            raise SampleError(f"row {int(empty[0])} of S has no non-zero entry ({empty.size} such rows); "
                              f"give every sample at least one vertex")
        if w is None:
            w = np.ones(k)
        else:
            try:
                w = np.asarray(w, dtype=np.float64)
            except (TypeError, ValueError):
                raise SampleError("w could not be read as numbers; pass (k,) positive weights") from None
            if w.shape != (k,) or not np.isfinite(w).all() or (w <= 0).any():
                raise SampleError(f"w has shape {w.shape} or entries that are not finite and > 0; pass {k} "
                                  f"positive weights, one per sample")
        ncomp, labels = pattern_components(A, symmetric=False)
        seen = np.bincount(labels[S.indices], minlength=ncomp) > 0
        if not seen.all():
            sizes = np.bincount(labels, minlength=ncomp)
            c = int(np.flatnonzero(~seen)[np.argmax(sizes[~seen])])
            more = int((~seen).sum()) - 1
            raise SolveError(f"a connected component of {int(sizes[c])} vertices of A's graph (e.g. vertex "
                             f"{int(np.flatnonzero(labels == c)[0])}) has no sample"
                             f"{f' (and {more} more)' if more else ''}, so S'WS + lam A is singular there; "
                             f"add a sample there, or smooth each component apart")
        self.A, self.S, self.w = A, S, w
        self.n, self.k = n, k
        self.components = int(ncomp)
        self.support = np.unique(S.indices)  # the m vertices b that S touches
        Sb = S[:, self.support].toarray()  # (k, m)
        G = (Sb.T * w) @ Sb  # S_b^T W S_b
        self.lam0 = float(np.trace(G) / A.diagonal().sum())
        if not (np.isfinite(self.lam0) and self.lam0 > 0):
            raise MeshError(f"A has trace {A.diagonal().sum():g}; pass a positive semi-definite energy with a "
                            f"positive diagonal")
        try:
            self._dirichlet = QuadraticSolver(A, self.support, solver="direct" if solver == "auto" else solver)
        except ResourceError:  # the LU would not fit: AMG
            self._dirichlet = QuadraticSolver(A, self.support, solver="auto")
        m = self.support.size
        sigma = np.empty((m, m))
        b = max(1, min(m, BLOCK_BYTES // (8 * max(n, 1))))
        for i in range(0, m, b):  # Sigma's columns: A applied to the harmonic extensions of unit vectors
            E = np.zeros((m, min(b, m - i)))
            E[np.arange(i, i + E.shape[1]), np.arange(E.shape[1])] = 1.0
            sigma[:, i:i + E.shape[1]] = (A @ self._dirichlet.solve(E))[self.support]
        sigma = self.lam0 * (sigma + sigma.T) / 2
        try:
            theta, phi = scipy.linalg.eigh(sigma, G + sigma)
        except np.linalg.LinAlgError:
            raise SolveError("S'WS + lam A is singular: the samples do not pin down the energy's null space "
                             "(a sample row spanning two components?); add samples or check A") from None
        # lam0 Sigma -> theta, S_b'WS_b -> 1 - theta, in the basis phi; the null space's theta is 0, not rounding
        self._theta = np.where(theta < TOL.smoothing_null, 0.0, np.clip(theta, 0.0, 1.0))
        self._phi = phi
        self._psi = Sb @ phi  # (k, m)
        self._interp = None

    def _d(self, lam):
        """The diagonal of ``(S_b'WS_b + lam Sigma)^-1`` in the basis ``phi``."""
        return 1.0 / (1.0 + (lam / self.lam0 - 1.0) * self._theta)

    def _coefficients(self, Y, lam):
        """``D Psi^T W Y`` (m, p), column by column (the same rounding for a column alone or among others)."""
        d = self._d(lam)
        return np.column_stack([d * (self._psi.T @ (self.w * Y[:, j])) for j in range(Y.shape[1])])

    def _fit(self, Y, lam):
        """The minimiser (n, p) at one ``lam > 0`` for (k, p) values: x_b, then its Dirichlet extension."""
        C = self._coefficients(Y, lam)
        return self._dirichlet.solve(np.column_stack([self._phi @ C[:, j] for j in range(C.shape[1])]))

    def _fitted(self, Y, lam):
        """``S x = H y`` (k, p) without the extension."""
        C = self._coefficients(Y, lam)
        return np.column_stack([self._psi @ C[:, j] for j in range(C.shape[1])])

    def leverage(self, lam):
        """The diagonal of the influence matrix ``H(lam)``.

        Parameters
        ----------
        lam : float
            ``> 0``.

        Returns
        -------
        (k,) numpy array
            ``H_ii = w_i s_i^T (S^T W S + lam A)^-1 s_i``, in ``[0, 1]``.
        """
        return self.w * ((self._psi**2) @ self._d(self._positive(lam)))

    def influence(self, lam):
        """The influence matrix ``H(lam) = S (S^T W S + lam A)^-1 S^T W``, dense ``(k, k)``.

        Parameters
        ----------
        lam : float
            ``> 0``.

        Returns
        -------
        (k, k) numpy array
            ``S x = H y`` for the minimiser ``x``; symmetric when all weights are equal.
        """
        return (self._psi * self._d(self._positive(lam))) @ self._psi.T * self.w

    def edf(self, lam):
        """The effective degrees of freedom ``tr H(lam)`` (``lam = 0``: the number of independent constraints)."""
        lam = check_lam(lam, 1)
        if lam == 0:
            single = np.diff(self.S.indptr) == 1
            return float(np.unique(self.S.indices[self.S.indptr[:-1][single]]).size + (~single).sum())
        return float(self._d(lam) @ (1.0 - self._theta))

    def _positive(self, lam):
        lam = check_lam(lam, 1)
        if lam == 0:
            raise OptionError("the influence matrix at lam=0 is the interpolation's; pass lam > 0")
        return lam

    # -- lam = 0: the constrained problem --------------------------------------------------------------------
    def _interpolate(self, Y):
        S, w = self.S, self.w
        nnz = np.diff(S.indptr)
        single = np.flatnonzero(nnz == 1)
        multi = np.flatnonzero(nnz > 1)
        if single.size == 0:
            raise SolveError("lam=0 (interpolation) with only barycentric rows needs at least one sample at a "
                             "vertex; pass lam > 0")
        v = S.indices[S.indptr[single]]
        a = S.data[S.indptr[single]]
        verts, inv = np.unique(v, return_inverse=True)
        den = np.bincount(inv, weights=w[single] * a * a, minlength=verts.size)
        vals = np.zeros((verts.size, Y.shape[1]))
        np.add.at(vals, inv, (w[single] * a)[:, None] * Y[single])
        vals /= den[:, None]
        if self._interp is None:
            self._interp = (QuadraticSolver(self.A, verts, solver="direct", Aeq=S[multi]) if multi.size
                            else self._dirichlet)  # all rows single: verts is the support
        return self._interp.solve(vals, beq=Y[multi] if multi.size else None)

    # -- the public solves -----------------------------------------------------------------------------------
    def solve(self, y, lam, *, edf=False):
        """The minimiser for values ``y`` at smoothing ``lam``.

        Parameters
        ----------
        y : (k,) or (k, p) array_like of float
            Observations, one row per row of ``S``.
        lam : float >= 0, or (p,) array_like of them
            Smoothing (one per field, or one for all); 0 interpolates.
        edf : bool, optional
            Also compute ``tr H`` (``k`` solves per distinct ``lam``).

        Returns
        -------
        x : (n,) or (n, p) numpy array
        info : dict
            ``lambda`` (float, or (p,) array), ``residuals`` (``S x - y``,
            shaped like ``y``), and with ``edf`` the ``edf`` (float, or (p,)).

        Raises
        ------
        SampleError
            ``y`` of the wrong shape or not finite.
        OptionError
            ``lam`` negative, NaN, infinite or of the wrong length.
        """
        Y, squeeze = as_values(y, self.k, what="y")
        p = Y.shape[1]
        lam = check_lam(lam, p)
        lams = np.broadcast_to(np.asarray(lam, dtype=np.float64), (p,))
        X = np.empty((self.n, p))
        dof = np.empty(p)
        for value in np.unique(lams):
            cols = np.flatnonzero(lams == value)
            X[:, cols] = self._interpolate(Y[:, cols]) if value == 0 else self._fit(Y[:, cols], value)
            if edf:
                dof[cols] = self.edf(value)
        R = self.S @ X - Y
        one = squeeze or np.ndim(lam) == 0
        info = {"lambda": float(lams[0]) if one else lams.copy(), "residuals": R[:, 0] if squeeze else R}
        if edf:
            info["edf"] = float(dof[0]) if one else dof
        return (X[:, 0] if squeeze else X), info

    def scores(self, y, lam, *, method="gcv"):
        """The GCV or LOO score of every column of ``y`` at one ``lam > 0``.

        Parameters
        ----------
        y : (k,) or (k, p) array_like of float
        lam : float
            ``> 0``.
        method : {'gcv', 'loo'}, optional

        Returns
        -------
        (p,) numpy array
            ``inf`` where undefined (``tr H`` within ``TOL.smoothing_leverage``
            of ``k``, or a leverage that close to 1: a sample alone on its component).
        """
        check_option("method", method, SELECT_METHODS)
        Y, _ = as_values(y, self.k, what="y")
        self._enough()
        return self._scores(Y, self._positive(lam), method)

    def _enough(self):
        if self.k < 3:
            raise SampleError(f"choosing lam by cross-validation needs at least 3 samples, got {self.k}; pass a "
                              f"fixed lam")

    def _scores(self, Y, lam, method):
        h = self.leverage(lam)
        R = self._fitted(Y, lam) - Y
        eps = TOL.smoothing_leverage
        with np.errstate(divide="ignore", invalid="ignore"):
            if method == "gcv":
                slack = self.k - h.sum()
                if slack <= eps * self.k:
                    return np.full(Y.shape[1], np.inf)
                return self.k * (self.w @ R**2) / slack**2
            if (1 - h <= eps).any():
                return np.full(Y.shape[1], np.inf)
            return np.mean(self.w[:, None] * (R / (1 - h)[:, None]) ** 2, axis=0)

    def default_grid(self):
        """The default ``lam`` grid: ``lam0 * 10**t`` for ``t`` in ``-6 .. 4``, four a decade."""
        return log_grid(self.lam0, GRID_DECADES, GRID_PER_DECADE)

    def select(self, y, method="gcv", lams=None, *, refine=True, curve=False):
        """The ``lam`` minimising the GCV or LOO score, per column of ``y``.

        Parameters
        ----------
        y : (k,) or (k, p) array_like of float
        method : {'gcv', 'loo'}, optional
        lams : (m,) array_like of float > 0, optional
            The grid searched (:meth:`default_grid` by default).
        refine : bool, optional
            Refine by golden-section search on ``log lam`` between the best
            grid point's neighbours (:func:`manifill.linalg.search.grid_search`).
        curve : bool, optional
            Also return the curve.

        Returns
        -------
        lam : float, or (p,) numpy array
        curve : dict, only with ``curve=True``
            ``lambdas`` (sorted, every ``lam`` evaluated), ``scores``
            (``(M,)`` or ``(M, p)``), ``grid`` (bool: a grid point, not a
            refinement), ``method``, ``at_edge`` (bool per field: the best grid
            point is an end of the grid: GCV/LOO prefer the grid's end).

        Raises
        ------
        SampleError
            Fewer than 3 samples, or bad ``y``.
        OptionError
            Bad ``method`` or ``lams``.
        """
        check_option("method", method, SELECT_METHODS)
        Y, squeeze = as_values(y, self.k, what="y")
        self._enough()
        grid = self.default_grid() if lams is None else as_grid(lams)
        chosen, out = grid_search(lambda lam: self._scores(Y, lam, method), grid, refine=refine)
        if not curve:
            return float(chosen[0]) if squeeze else chosen
        out["method"] = method
        if squeeze:
            out["scores"], out["at_edge"] = out["scores"][:, 0], bool(out["at_edge"][0])
        return (float(chosen[0]) if squeeze else chosen), out
