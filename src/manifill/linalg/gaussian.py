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
  ``exact``: the selected inverse (:mod:`manifill.linalg.selinv`) of the sparse Cholesky factor of
  the free block ``Q_ff`` (exact samples) or of ``P = Q + H' E^-1 H`` (noise), the factor the mean
  was solved with; exact points inside faces (constraints ``A x_f = b``) subtract the rank-``m``
  term ``diag(W (A W)^-1 W')``, ``W = Q_ff^-1 A'``; or ``sampled``: the Rao-Blackwellised Monte Carlo estimator
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
from ..tolerances import TOL
from .backends import make_linear_solver
from .quadratic import QuadraticSolver
from .cholesky import SAMPLES_LAST_MAX, Factor, SamplesLast, cholesky, cholmod_available
from .selinv import SelectedInverse
from .logdet import LOO_MAX, loo_residuals

__all__ = ["VARIANCES", "EXACT_MAX", "Conditional", "exact_by_default", "factoriser_for", "loo_summary",
           "observation_matrix", "variance_summary"]

#: How the variance is computed: ``auto`` is ``exact`` where :func:`exact_by_default` says so, else ``sampled``.
VARIANCES = ("auto", "exact", "sampled")

#: Largest number of unknowns for which ``variance='auto'`` is exact without CHOLMOD. SuperLU's Cholesky factor is
#: slow: at 41k unknowns (100 samples, a fresh ``[all]`` install) the exact std and its leave-one-out check took
#: 5-6 s where Pardiso's factor and the sampled std took 2-2.4 s; CHOLMOD's factor, the selected inversion and the
#: check together took 1.3 s at 41k and 8.8 s at 163k.
EXACT_MAX = 20_000

#: Bytes of the ``W = Q_ff^-1 A'`` columns held at once for exact points inside faces (two passes above).
_W_BYTES = 500_000_000

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

    def __init__(self, Q, B, idx, *, rows=None, eta=None, solver="auto", tol=None, maxiter=None, definite=False,
                 factoriser=None):
        self.Q = sp.csr_array(Q)
        self.B = None if B is None else sp.csr_array(B)
        self.n = self.Q.shape[0]
        self.idx = np.asarray(idx, dtype=np.int64)
        self.rows = None if rows is None else sp.csr_array(rows)
        self.k = self.idx.size
        self.m = self.k + (0 if rows is None else self.rows.shape[0])
        t0 = time.perf_counter()
        self._sl = None
        if eta is None and factoriser == "cholesky" and rows is None and definite and cholmod_available() \
                and 0 < self.k < self.n and self.k <= SAMPLES_LAST_MAX:  # one factor for mean, variance and check
            self.eta = None
            self._sl = SamplesLast(self.Q, self.idx)
            self._Qfs = sp.csr_array(self.Q[self._sl.free][:, self.idx])
            self.report = {"solver": "direct", "unknowns": self._sl.nf}
        elif eta is None:
            self.eta = None
            use = "direct" if rows is not None and solver != "direct" else solver
            self._qs = QuadraticSolver(self.Q, self.idx, solver=use, Aeq=self.rows,
                                       on_empty="solve" if definite else "error", tol=tol, maxiter=maxiter,
                                       symmetric_pattern=True, what="the precision",
                                       factoriser=factoriser if rows is None else None)
            self.report = {k: v for k, v in self._qs.report.items() if k in ("solver", "unknowns")}
        else:
            self.eta = np.broadcast_to(np.asarray(eta, dtype=np.float64), (self.m,)).copy()
            if not np.all(np.isfinite(self.eta) & (self.eta > 0)):
                raise OptionError("noise variances must be finite and > 0; pass noise=0 for exact samples")
            self.H = self.observation_matrix()
            self.P = sp.csr_array(self.Q + self.H.T @ sp.diags_array(1.0 / self.eta) @ self.H)
            self.P.sort_indices()
            rtol = TOL.polyharmonic_rtol if tol is None else tol
            self._backend = make_linear_solver(self.P, solver, rtol=rtol, maxiter=maxiter, factoriser=factoriser,
                                               spd=True)
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
        if self._sl is not None:
            X = np.empty((self.n, Y.shape[1]))
            X[self.idx] = Y
            X[self._sl.free] = -self._sl.solve_free(self._Qfs @ Y)
            return X
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
            ``how``, ``seconds``; for ``exact``: ``factor`` (what factorised) and ``factor_entries``; for
            ``sampled``: ``samples``, ``se`` ((n,) standard error of ``var``), ``rel_se_median``,
            ``rel_se_max``, and ``why`` where ``auto`` chose it.
        """
        if how not in VARIANCES:
            raise OptionError(f"variance={how!r} is not one of {', '.join(VARIANCES)}; pass one of those")
        u = self.unknowns()
        why, requested = None, how
        if how == "auto":
            how = "exact" if exact_by_default(u) else "sampled"
            if how == "sampled":
                why = (f"{u:,} unknowns, above {EXACT_MAX:,} without CHOLMOD; the [cholmod] extra makes it exact "
                       f"(pip install 'manifill[cholmod]', which needs libsuitesparse-dev)")
        t0 = time.perf_counter()
        if how == "exact":
            try:
                var, info = self._exact()
            except (ResourceError, SolveError) as exc:  # chosen by auto: the Monte Carlo estimate instead
                if why is not None or self.B is None or requested != "auto":
                    raise
                how, why = "sampled", f"the exact variance could not be read ({exc})"
                self._factor_used = None  # nor the leave-one-out check, which would factorise again
        if how == "sampled":
            samples = int(samples)
            if samples < 2:
                raise OptionError(f"samples={samples} is too few for a variance and its error; pass 2 or more")
            if self.B is None:
                raise OptionError("variance='sampled' needs a root of the precision, and this one has none "
                                  "(a Laplacian with weights of both signs and no triangles); pass variance='exact'")
            var, info = self._sampled(samples, seed)
            if why:
                info["why"] = why
        info["seconds"] = time.perf_counter() - t0
        return var, info

    def _factor(self, free):
        """The Cholesky :class:`~manifill.linalg.cholesky.Factor` of the unknowns' precision: the solver's own
        where it made one (``factoriser='cholesky'``), else a new one."""
        if self._sl is not None:
            return self._sl.free_factor()
        backend = self._backend if self.eta is not None else self._qs.backend
        own = getattr(backend, "factor", None)  # with rows the solver factorised the KKT system: no Factor
        if isinstance(own, Factor):
            return own
        M = self.P if self.eta is not None else self.Q[free][:, free]
        return cholesky(M)

    def loo(self, Y, mean="constant"):
        """Leave-one-out residuals of exact vertex data (:func:`~manifill.linalg.logdet.loo_residuals`, units
        of the scale), from the order of the exact variance's factor; None where not computed (noise, points
        inside faces, no exact variance yet, more than :data:`~manifill.linalg.logdet.LOO_MAX` samples)."""
        f = getattr(self, "_factor_used", None)
        if self.eta is not None or self.rows is not None or (f is None and self._sl is None) \
                or not 3 <= self.k <= LOO_MAX:
            return None
        if self._sl is not None:
            return loo_residuals(self.Q, self.idx, Y, self._sl.p_ff, mean, Lss=self._sl.schur_factor())
        return loo_residuals(self.Q, self.idx, Y, f.p, mean)

    def _exact(self):
        var = np.zeros(self.n)
        free = np.arange(self.n) if self.eta is not None else np.setdiff1d(np.arange(self.n), self.idx)
        if free.size == 0:  # every node observed exactly: nothing is uncertain
            return var, {"how": "exact"}
        f = self._factor_used = self._factor(free)
        var[free] = SelectedInverse(f).diagonal()
        info = {"how": "exact", "factor": f.name, "factor_entries": int(f.nnz)}
        if self.eta is None and self.rows is not None:
            var[free] = np.maximum(var[free] - _constraint_term(f, self.rows[:, free]), 0.0)
        return var, info

    def draws(self, c, rng):
        """``c`` draws of the conditional law of the zero-mean field given zero data (``(n, c)``, units of ``s``).

        ``W = B' z`` has covariance ``Q``, so ``E = Q_ff^-1 W_f`` (zero where observed exactly, and on the
        rows) has covariance ``Q_ff^-1``; with noise, ``P^-1 (W + H' e / eta)`` has covariance ``P^-1``.
        """
        if self.B is None:
            raise OptionError("drawing needs a root of the precision, and this one has none; use a triangle mesh")
        W = self.B.T @ rng.standard_normal((self.B.shape[0], c))
        if self._sl is not None:
            E = np.zeros((self.n, c))
            E[self._sl.free] = self._sl.solve_free(W[self._sl.free])
            return E
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


def exact_by_default(unknowns):
    """Whether ``variance='auto'`` is exact: always with CHOLMOD (the ``[cholmod]`` extra), else up to
    :data:`EXACT_MAX` unknowns (SuperLU's factor; above it a Monte Carlo estimate is faster)."""
    return unknowns <= EXACT_MAX or cholmod_available()


def factoriser_for(with_std, variance, unknowns):
    """``cholesky`` where the exact variance will be read from the factor the mean is solved with, else None."""
    exact = variance == "exact" or (variance == "auto" and exact_by_default(unknowns))
    return "cholesky" if with_std and exact else None


def variance_summary(infos):
    """One report of the variance computations of every group of fields (the worst Monte Carlo error; the
    leave-one-out check of every field, in the fields' order of the groups)."""
    if not infos:
        return {"how": None}
    out = {k: v for k, v in infos[0].items() if k not in ("se", "loo")}
    out["seconds"] = float(sum(i["seconds"] for i in infos))
    for key in ("rel_se_median", "rel_se_max"):
        if key in out:
            out[key] = float(max(i[key] for i in infos))
    if all("loo" in i for i in infos):  # in the fields' order (the groups hold fields of any order)
        out["loo"] = sorted((x for i in infos for x in i["loo"]), key=lambda x: x.get("field", 0))
    return out


#: The std is called off where the leave-one-out errors' RMS over the std is beyond these (about 1.33x either way).
LOO_STD_RATIO = (0.75, 1.33)


def loo_summary(z):
    """The calibration of the std on the samples themselves, from standardised leave-one-out residuals ``z``:
    ``samples``, ``rms_z`` (the errors' RMS over the std: 1 when calibrated), ``within_1.96`` (the share of
    ``|z| <= 1.96``: 0.95), ``verdict`` (``calibrated``, ``too wide`` or ``too narrow``, by :data:`LOO_STD_RATIO`)."""
    z = np.asarray(z, dtype=np.float64)
    rms = float(np.sqrt(np.mean(z * z)))
    verdict = "too wide" if rms < LOO_STD_RATIO[0] else "too narrow" if rms > LOO_STD_RATIO[1] else "calibrated"
    return {"samples": int(z.size), "rms_z": rms, "within_1.96": float(np.mean(np.abs(z) <= 1.96)),
            "verdict": verdict}


def _constraint_term(f, A):
    """``diag(W (A W)^+ W')``, ``W = F^-1 A'``: what exact constraints ``A x = b`` take from the variance of a
    field of precision ``F`` (a pseudo-inverse: points sharing a face row make the constraints dependent)."""
    n, m = A.shape[1], A.shape[0]
    chunk = max(1, int(_W_BYTES // (8 * max(n, 1))))
    At = A.T.tocsc()
    if m <= chunk:
        W = f.solve(At.toarray())
        S = A @ W
    else:
        S = np.column_stack([A @ f.solve(At[:, j:j + chunk].toarray()) for j in range(0, m, chunk)])
    e, U = la.eigh((S + S.T) * 0.5)
    keep = e > 1e-12 * max(float(e.max()), 0.0)
    Bm = U[:, keep] / np.sqrt(e[keep])  # S^+ = Bm Bm'
    if m <= chunk:
        G = W @ Bm
        return np.einsum("ij,ij->i", G, G)
    out = np.zeros(n)
    G = np.asarray(At @ Bm)  # A' Bm: the rank-m term is rowsum((F^-1 A' Bm)^2)
    for j in range(0, G.shape[1], chunk):
        X = f.solve(G[:, j:j + chunk])
        out += np.einsum("ij,ij->i", X, X)
    return out


