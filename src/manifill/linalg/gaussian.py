"""A Gaussian field with a sparse precision, conditioned on observations: the mean and the variance everywhere.

The field is ``x ~ N(0, s^2 Q^-1)`` with ``Q`` sparse, symmetric positive (semi-)definite
(a Matérn SPDE precision, :mod:`manifill.linalg.spde`; or an energy ``L (M^-1 L)^(k-1)``,
whose null space, the constants, makes the field *intrinsic*) and a root ``B`` with ``B' B
= Q``. It is observed through rows ``H`` (unit rows at sample vertices, barycentric rows at
points inside faces) either exactly (``H x = y``) or with independent noise of variance
``s^2 eta_i`` per row. :class:`Conditional` gives, for any data columns,

- :meth:`Conditional.extend`: the conditional mean (the kriging predictor of a zero-mean
  field): with exact observations, the minimiser of ``x' Q x`` subject to them (one
  :class:`~manifill.linalg.quadratic.QuadraticSolver`); with noise, the solution of
  ``(Q + H' E^-1 H) x = H' E^-1 y``;
- :meth:`Conditional.gram`: ``u' S^-1 v`` with ``S = H Q^-1 H' + E`` the data covariance
  (shape), from those solves (``x_u' Q x_v`` with exact data), which gives the
  generalised least squares mean and the fitted scale ``s^2``;
- :meth:`Conditional.variance`: the diagonal of the conditional covariance (shape),
  ``exact`` (dense: the inverse of the free block of ``Q``, of its KKT matrix with rows,
  or of ``Q + H' E^-1 H``) or ``sampled``: the Rao-Blackwellised Monte Carlo estimator
  of Sidén et al. (2018) on conditional samples drawn by perturbation (``Q e = B' w``
  with the constraints, ``w`` white noise: no Cholesky factor is needed). At a node
  ``i`` whose conditional law given the others is ``N(mu_i - sum_j Q_ij e_j / Q_ii,
  1 / Q_ii)``, ``var_i = 1 / Q_ii + E[(e_i - (Q e)_i / Q_ii)^2]``; the second term is
  averaged over the samples, and its Monte Carlo standard error is returned with it
  (nodes inside a point's face: the plain average of ``e_i^2``).
"""

import time

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

from ..errors import OptionError, ResourceError, SolveError
from ..memory import check_fits
from ..tolerances import TOL
from .backends import make_linear_solver
from .quadratic import QuadraticSolver

__all__ = ["VARIANCES", "EXACT_MAX", "Conditional", "observation_matrix"]

#: How the variance is computed: ``auto`` is ``exact`` up to :data:`EXACT_MAX` unknowns, ``sampled`` above.
VARIANCES = ("auto", "exact", "sampled")

#: Largest number of unknowns for which ``variance='auto'`` inverts densely (about 1 s and 0.2 GB at 5,000).
EXACT_MAX = 5_000

#: Largest number of unknowns ``variance='exact'`` accepts (a dense ``n x n`` inverse in place: 3.2 GB at 20,000;
#: three such arrays with points inside faces, whose KKT matrix is solved against the identity).
EXACT_LIMIT = 20_000

_CHUNK = 50  # conditional samples solved at once


class Conditional:
    """``x ~ N(0, s^2 Q^-1)`` conditioned on ``H x = y`` (exact) or ``H x + e = y`` (noise ``s^2 eta``).

    Parameters
    ----------
    Q : (n, n) scipy sparse matrix
        Precision shape, symmetric positive semi-definite; positive definite on the
        unknowns once the observations are taken into account.
    B : (r, n) scipy sparse matrix
        A root, ``B' B = Q`` (for ``variance('sampled')``; may be None otherwise).
    idx : (k,) int64 numpy array
        Vertices observed (rows of one 1), sorted and unique.
    rows : (m, n) scipy sparse matrix, optional
        Further observation rows (barycentric points).
    eta : None, float or (k + m,) array_like of float > 0, optional
        None: exact observations. Else the noise variances of the rows (the vertices
        first, then ``rows``), in units of ``s^2``.
    solver : {'auto', 'direct', 'amg'}, optional
        Linear solver; exact observations with ``rows`` always factorise (KKT).
    tol, maxiter : optional
        For ``amg``.
    definite : bool, optional
        ``Q`` is positive definite (a Matérn precision): a part of the mesh without
        observations is solved too (its conditional law is the prior's).
    """

    def __init__(self, Q, B, idx, *, rows=None, eta=None, solver="auto", tol=None, maxiter=None, definite=False):
        self.Q = sp.csr_array(Q)
        self.B = None if B is None else sp.csr_array(B)
        self.n = self.Q.shape[0]
        self.idx = np.asarray(idx, dtype=np.int64)
        self.rows = None if rows is None else sp.csr_array(rows)
        self.k = self.idx.size
        self.m = self.k + (0 if rows is None else self.rows.shape[0])
        t0 = time.perf_counter()
        if eta is None:
            self.eta = None
            use = "direct" if rows is not None and solver != "direct" else solver
            self._qs = QuadraticSolver(self.Q, self.idx, solver=use, Aeq=self.rows,
                                       on_empty="solve" if definite else "error",
                                       tol=tol, maxiter=maxiter, symmetric_pattern=True, what="the precision")
            self.report = {k: v for k, v in self._qs.report.items() if k in ("solver", "unknowns")}
        else:
            self.eta = np.broadcast_to(np.asarray(eta, dtype=np.float64), (self.m,)).copy()
            if not np.all(np.isfinite(self.eta) & (self.eta > 0)):
                raise OptionError("noise variances must be finite and > 0; pass noise=0 for exact samples")
            self.H = self.observation_matrix()
            self.P = sp.csr_array(self.Q + self.H.T @ sp.diags_array(1.0 / self.eta) @ self.H)
            self.P.sort_indices()
            rtol = TOL.polyharmonic_rtol if tol is None else tol
            self._backend = make_linear_solver(self.P, solver, rtol=rtol, maxiter=maxiter)
            self.report = {"solver": self._backend.name, "unknowns": self.n}
        self.report["setup_seconds"] = time.perf_counter() - t0

    def observation_matrix(self):
        """``H`` (CSR, ``(k + m) x n``): the unit rows at ``idx``, then ``rows``."""
        return observation_matrix(self.n, self.idx, self.rows)

    def extend(self, Y):
        """The conditional mean of the zero-mean field for each data column.

        Parameters
        ----------
        Y : (k + m, p) numpy array
            Data: the vertex samples (in ``idx`` order), then the rows.

        Returns
        -------
        (n, p) numpy array
        """
        Y = np.asarray(Y, dtype=np.float64).reshape(self.m, -1)
        if self.eta is None:
            X = self._qs.solve(Y[:self.k], beq=None if self.rows is None else Y[self.k:])
            return X if X.ndim == 2 else X[:, None]
        X, _ = self._backend.solve(self.H.T @ (Y / self.eta[:, None]))
        return np.asarray(X).reshape(self.n, -1)

    def gram(self, Y, X):
        """``Y' S^-1 Y`` (``p x p``), ``S = H Q^-1 H' + diag(eta)``, from ``X = extend(Y)``."""
        if self.eta is None:
            G = X.T @ (self.Q @ X)
        else:
            G = Y.T @ ((Y - self.H @ X) / self.eta[:, None])
        return (G + G.T) * 0.5

    # ---- the variance -------------------------------------------------------------------------------------

    def unknowns(self):
        """Number of unknowns of the conditional law (``n - k`` with exact data, ``n`` with noise)."""
        return self.n - self.k if self.eta is None else self.n

    def variance(self, how="auto", samples=100, seed=0):
        """The diagonal of the conditional covariance (in units of ``s^2``).

        Parameters
        ----------
        how : {'auto', 'exact', 'sampled'}, optional
        samples : int, optional
            Conditional samples of ``sampled``.
        seed : int, optional

        Returns
        -------
        var : (n,) numpy array
            0 at exactly observed vertices.
        info : dict
            ``how``, ``seconds``; for ``sampled``: ``samples``, ``se`` ((n,) standard
            error of ``var``), ``rel_se_median``, ``rel_se_max``.
        """
        if how not in VARIANCES:
            raise OptionError(f"variance={how!r} is not one of {', '.join(VARIANCES)}; pass one of those")
        u = self.unknowns()
        if how == "auto":
            how = "exact" if u <= EXACT_MAX else "sampled"
        t0 = time.perf_counter()
        if how == "exact":
            need = 8.0 * u * u
            if u <= EXACT_LIMIT:
                check_fits(need, f"variance='exact' ({u:,} unknowns, a dense inverse)", "pass variance='sampled'")
            else:
                gb = need / 1e9
                raise ResourceError(f"variance='exact' inverts a dense {u} x {u} matrix ({gb:.1f} GB), beyond "
                                    f"{EXACT_LIMIT} unknowns; pass variance='sampled'")
            var, info = self._exact(), {"how": "exact"}
        else:
            samples = int(samples)
            if samples < 2:
                raise OptionError(f"samples={samples} is too few for a variance and its error; pass 2 or more")
            if self.B is None:
                raise OptionError("variance='sampled' needs a root of the precision, and this one has none "
                                  "(a Laplacian with weights of both signs and no triangles); pass variance='exact'")
            var, info = self._sampled(samples, seed)
        info["seconds"] = time.perf_counter() - t0
        return var, info

    def _exact(self):
        var = np.zeros(self.n)
        if self.eta is not None:
            var[:] = _inverse_diagonal(self.P.toarray())
            return var
        free = np.setdiff1d(np.arange(self.n), self.idx)
        if free.size == 0:  # every node observed exactly: nothing is uncertain
            return var
        Qff = self.Q[free][:, free].toarray()
        if self.rows is None:
            var[free] = _inverse_diagonal(Qff)
            return var
        # the points inside faces are exact linear constraints A x = b: the covariance is
        # Qff^-1 - W (A W)^-1 W' with W = Qff^-1 A' (one Cholesky factor; a KKT solve with n right-hand
        # sides took 60 times as long)
        A = self.rows[:, free].toarray()
        c, W = _factor_and_solve(Qff, A.T)
        S = A @ W
        try:
            Z = la.solve(S, W.T, assume_a="pos")
        except la.LinAlgError:  # points sharing a face row: the constraints are dependent
            Z = la.pinv(S, rtol=1e-12) @ W.T
        var[free] = np.maximum(_inverse_diagonal(c, factored=True) - np.einsum("ij,ji->i", W, Z), 0.0)
        return var

    def draws(self, c, rng):
        """``c`` draws of the conditional law of the zero-mean field given zero data (``(n, c)``, units of ``s``).

        ``W = B' z`` has covariance ``Q``, so ``E = Q_ff^-1 W_f`` (zero where observed exactly, and on the
        rows) has covariance ``Q_ff^-1``; with noise, ``P^-1 (W + H' e / eta)`` has covariance ``P^-1``.
        """
        if self.B is None:
            raise OptionError("drawing needs a root of the precision, and this one has none; use a triangle mesh")
        W = self.B.T @ rng.standard_normal((self.B.shape[0], c))
        if self.eta is None:
            E = self._qs.solve(np.zeros((self.k, c)), linear=-W,
                               beq=None if self.rows is None else np.zeros((self.rows.shape[0], c)))
            return E if E.ndim == 2 else E[:, None]
        W = W + self.H.T @ (rng.standard_normal((self.m, c)) / np.sqrt(self.eta)[:, None])
        E, _ = self._backend.solve(W)
        return np.asarray(E).reshape(self.n, c)

    def _sampled(self, S, seed):
        rng = np.random.default_rng(seed)
        M = self.Q if self.eta is None else self.P  # the precision of the law sampled
        d = M.diagonal()
        touched = np.zeros(self.n, dtype=bool)  # nodes inside a point's face, exactly observed: plain averages
        if self.eta is None and self.rows is not None:
            touched[self.rows.indices[self.rows.data != 0]] = True
        acc, acc2 = np.zeros(self.n), np.zeros(self.n)
        done = 0
        while done < S:
            c = min(_CHUNK, S - done)
            E = self.draws(c, rng)
            R = E - (M @ E) / d[:, None]
            R[touched] = E[touched]
            R2 = R * R
            acc += R2.sum(axis=1)
            acc2 += (R2 * R2).sum(axis=1)
            done += c
        mean = acc / S
        se = np.sqrt(np.maximum(acc2 / S - mean * mean, 0.0) / (S - 1))
        var = np.where(touched, 0.0, 1.0 / d) + mean
        if self.eta is None:
            var[self.idx], se[self.idx] = 0.0, 0.0
        with np.errstate(invalid="ignore", divide="ignore"):
            rel = np.where(var > 0, se / var, 0.0)
        return var, {"how": "sampled", "samples": S, "se": se, "rel_se_median": float(np.median(rel)),
                     "rel_se_max": float(rel.max()) if rel.size else 0.0}


def observation_matrix(n, idx, rows=None):
    """``H`` (CSR, ``(k + m) x n``): a unit row at each of the ``k`` vertices ``idx``, then the ``m`` ``rows``."""
    idx = np.asarray(idx, dtype=np.int64)
    E = sp.csr_array((np.ones(idx.size), (np.arange(idx.size), idx)), shape=(idx.size, n))
    return E if rows is None else sp.csr_array(sp.vstack([E, sp.csr_array(rows)]))


_NOT_DEFINITE = ("the precision is not positive definite to working precision (degenerate elements?); clean the "
                 "mesh, or pass variance='sampled'")


def _factor_and_solve(A, B):
    """``(c, A^-1 B)`` with ``c`` LAPACK's lower Cholesky factor of ``A``, in ``A``'s own array."""
    c, info = la.lapack.dpotrf(np.asfortranarray(A), lower=1, overwrite_a=1, clean=0)
    if info != 0:
        raise SolveError(_NOT_DEFINITE)
    X, info = la.lapack.dpotrs(c, np.asfortranarray(B), lower=1)
    return c, X


def _inverse_diagonal(A, factored=False):
    """``diag(A^-1)`` of a dense symmetric positive definite ``A`` (Cholesky), or of ``A``'s factor ``c``."""
    # in place (LAPACK's potrf then potri): one n x n array in all, A's own
    c, info = (A, 0) if factored else la.lapack.dpotrf(np.asfortranarray(A), lower=1, overwrite_a=1, clean=0)
    if info == 0:
        c, info = la.lapack.dpotri(c, lower=1, overwrite_c=1)
    if info != 0:
        raise SolveError(_NOT_DEFINITE)
    return np.diagonal(c).copy()
