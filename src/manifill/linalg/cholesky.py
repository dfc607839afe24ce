"""The sparse Cholesky factorisations of symmetric positive definite matrices: one module for every caller.

:func:`cholesky` gives a :class:`Factor` (``A[p][:, p] = L L'``, its log-determinant and its solve) from CHOLMOD
(scikit-sparse, the ``[cholmod]`` extra) where it is installed, else from SuperLU in symmetric mode (``A = L D L'``
with diagonal pivots, ``L sqrt(D)`` the Cholesky factor), which needs nothing beyond SciPy; :class:`SamplesLast`
is one CHOLMOD factorisation with the observed nodes last. The direct solves (:mod:`manifill.linalg.factorise`),
the Gaussian fields (:mod:`manifill.linalg.gaussian`), the likelihood's factors (:mod:`manifill.linalg.logdet`)
and the selected inversion (:mod:`manifill.linalg.selinv`) take their factors here.
"""

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..errors import SolveError

__all__ = ["Factor", "cholesky", "cholmod_available", "cholmod_module", "from_cholmod", "superlu_spd", "SamplesLast",
           "SAMPLES_LAST_MAX", "NOT_DEFINITE"]

#: The one message of a precision that will not factorise.
NOT_DEFINITE = ("the precision is not positive definite to working precision (degenerate elements?); clean the "
                 "mesh (or, for the std, pass variance='sampled')")


class Factor:
    """``A[p][:, p] = L L'``: ``L`` lower triangular (CSC, sorted, the diagonal first in each column), ``p``.

    ``name`` is ``cholmod`` or ``superlu``; ``logdet`` is ``log det A``; :meth:`solve` solves ``A X = B`` with the
    factorisation that gave ``L`` (so the mean and the variances of a Gaussian field share one factorisation).
    """

    def __init__(self, L, p, name, solve):
        self.L = sp.csc_matrix(L)
        self.L.sort_indices()
        self.p = np.asarray(p, dtype=np.int64)
        self.name = name
        self._solve = solve
        d = self.L.data[self.L.indptr[:-1]]
        self.logdet = float(2.0 * np.log(d).sum())

    @property
    def nnz(self):
        """Entries of ``L``."""
        return self.L.nnz

    def solve(self, B):
        """``A^-1 B`` for a vector or the columns of a matrix."""
        B = np.asarray(B, dtype=np.float64)
        return np.asarray(self._solve(B)).reshape(B.shape)


def cholmod_module():
    """scikit-sparse's ``cholmod`` (the ``[cholmod]`` extra), or None."""
    try:
        from sksparse import cholmod
    except ImportError:
        return None
    return cholmod


def cholmod_available():
    """Whether scikit-sparse's CHOLMOD (the ``[cholmod]`` extra) imports."""
    return cholmod_module() is not None


def from_cholmod(f):
    """The :class:`Factor` of a scikit-sparse CHOLMOD factor ``f`` (its supernodes converted to CSC)."""
    return Factor(f.L(), f.P(), "cholmod", f.solve_A)


def superlu_spd(A, natural=False):
    """``(lu, d)``: SuperLU's ``A[p][:, p] = L D L'`` of a symmetric positive definite CSC ``A`` (symmetric mode, no
    pivoting off the diagonal, so ``U = D L'``; ``natural``: ``A``'s own order), ``d`` the pivots."""
    lu = splu(A, permc_spec="NATURAL" if natural else "MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
              options={"SymmetricMode": True})
    d = lu.U.diagonal()
    if not (np.all(d > 0) and np.array_equal(lu.perm_r, lu.perm_c)):
        raise SolveError(NOT_DEFINITE)
    return lu, d


def cholesky(A, backend="auto", order=None):
    """The :class:`Factor` of a sparse symmetric positive definite ``A``.

    Parameters
    ----------
    A : (n, n) scipy sparse matrix
    backend : {'auto', 'cholmod', 'superlu'}, optional
        ``auto``: CHOLMOD where the ``[cholmod]`` extra is installed, else SuperLU.
    order : (n,) int array, optional
        The elimination order to keep (e.g. some unknowns last); default: a fill-reducing one.
    """
    A = sp.csc_matrix(A)
    if order is not None:
        order = np.asarray(order, dtype=np.int64)
        A = sp.csc_matrix(A[order][:, order])
    cholmod = cholmod_module() if backend in ("auto", "cholmod") else None
    if cholmod is not None:
        try:
            f = from_cholmod(cholmod.cholesky(A, ordering_method="natural" if order is not None else "default"))
        except cholmod.CholmodNotPositiveDefiniteError:
            raise SolveError(NOT_DEFINITE) from None
    else:
        lu, d = superlu_spd(A, natural=order is not None)
        # Pr A Pc = L U with Pr = Pc' from the same permutation, and U = D L'
        p = np.empty_like(lu.perm_c)
        p[lu.perm_c] = np.arange(len(p))
        f = Factor(sp.csc_matrix(lu.L) @ sp.diags_array(np.sqrt(d)), p, "superlu", lu.solve)
    if order is None:
        return f
    return Factor(f.L, order[f.p], f.name, _reordered(f._solve, order))


def _reordered(solve, order):
    """``B -> A^-1 B`` from ``solve`` of ``A[order][:, order]``."""
    def out(B):
        X = np.empty_like(B)
        X[order] = np.asarray(solve(B[order])).reshape(B[order].shape)
        return X
    return out


#: Most observed nodes :class:`SamplesLast` orders last: their block of the factor is dense, ``m^2`` entries and
#: ``m^3 / 3`` flops, and the rows above it fill in (41k vertices, 10,000 samples: 21.8 s and 2.5 GB against
#: 0.83 s and 0.3 GB for the factor of ``Q_ff`` alone; at 1,000 samples it saved a quarter of a fit's trial).
SAMPLES_LAST_MAX = 2_000


class SamplesLast:
    """One CHOLMOD factorisation of a precision ``Q`` with the observed nodes ``idx`` eliminated last.

    The others (``free``) come first in a fill-reducing order of ``Q_ff`` (METIS's, from CHOLMOD's analysis of
    ``Q_ff``), so the factor is ``L = [[L_ff, 0], [L_sf, L_ss]]`` with ``L_ff L_ff' = Q_ff`` and ``L_ss L_ss' = S``,
    the Schur complement ``Q_ss - Q_sf Q_ff^-1 Q_fs`` (the observed values' precision). One factorisation then
    gives the conditional mean and draws (:meth:`solve_free`: ``Q_ff^-1 b`` by the two triangular solves of
    ``L_ff``), the exact variance (:meth:`free_factor`, for a selected inversion) and every sample's
    leave-one-out residual (``L_ss``), where separate factorisations of ``Q_ff`` and of ``Q`` in this order took
    30% longer (163k vertices, 1,000 samples). Needs the ``[cholmod]`` extra.
    """

    def __init__(self, Q, idx, symbolic=None):
        cholmod = cholmod_module()
        Q = sp.csc_matrix(Q)
        n = Q.shape[0]
        self.idx = np.asarray(idx, dtype=np.int64)
        self.free = np.setdiff1d(np.arange(n), self.idx)
        self.nf = len(self.free)
        symbolic = {} if symbolic is None else symbolic  # kept by the caller across precisions of one pattern
        try:
            if "p_ff" not in symbolic:
                symbolic["p_ff"] = cholmod.analyze(sp.csc_matrix(Q[self.free][:, self.free])).P()
            self.p_ff = symbolic["p_ff"]
            order = np.concatenate([self.free[self.p_ff], self.idx])
            A = sp.csc_matrix(Q[order][:, order])
            if "natural" not in symbolic:
                symbolic["natural"] = cholmod.analyze(A, ordering_method="natural")
            self._f = symbolic["natural"].cholesky(A)
        except cholmod.CholmodNotPositiveDefiniteError:
            raise SolveError(NOT_DEFINITE) from None
        self._L = None

    @property
    def L(self):
        """The factor (CSC; CHOLMOD's supernodes converted on first use)."""
        if self._L is None:
            self._L = self._f.L()
        return self._L

    @property
    def nnz(self):
        """Entries of ``L``'s first ``nf`` columns (``L_ff`` and ``L_sf``)."""
        return int(self.L.indptr[self.nf])

    def logdet_schur(self):
        """``log det S`` (``S`` the Schur complement on the samples) from the factor's diagonal alone."""
        return float(np.log(np.asarray(self._f.D())[self.nf:]).sum())

    def solve_free(self, B):
        """``Q_ff^-1 B`` for the rows of ``B`` in ``free``'s order (a vector or columns)."""
        B = np.asarray(B, dtype=np.float64)
        Z = np.zeros((len(self.idx) + self.nf,) + B.shape[1:])
        Z[:self.nf] = B[self.p_ff]
        Z = np.asarray(self._f.solve_L(Z, use_LDLt_decomposition=False)).reshape(Z.shape)
        Z[self.nf:] = 0.0  # L' w = [z_f; 0] leaves w_s = 0 and L_ff' w_f = z_f
        W = np.asarray(self._f.solve_Lt(Z, use_LDLt_decomposition=False)).reshape(Z.shape)
        X = np.empty_like(B)
        X[self.p_ff] = W[:self.nf]
        return X

    def free_factor(self):
        """The :class:`Factor` of ``Q_ff`` (``L_ff`` and its order), for :class:`SelectedInverse`."""
        return Factor(self.L[:self.nf, :self.nf], self.p_ff, "cholmod", self.solve_free)

    def schur_factor(self):
        """``L_ss`` (dense lower triangular, the samples in ``idx``'s order): ``L_ss L_ss'`` is the Schur complement."""
        return self.L[self.nf:, self.nf:].toarray()
