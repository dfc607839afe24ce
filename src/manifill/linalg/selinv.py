"""Selected inversion: the entries of ``A^-1`` on the pattern of ``A``'s sparse Cholesky factor.

For ``A = L L'`` (after a fill-reducing permutation), ``Sigma = A^-1`` satisfies ``Sigma L = L^-T``. Reading it
block by block from the last supernode to the first (Takahashi, Fagan & Chen 1973; the supernodal form of
Lin et al.'s SelInv, 2011), a supernode with columns ``S`` and row structure ``R`` below them needs ``Sigma`` only
on ``R x R``, which the factor's pattern holds because it is closed under elimination:

    Sigma_RS = -Sigma_RR L_RS L_SS^-1,          Sigma_SS = L_SS^-T (L_SS^-1 - L_RS' Sigma_RS).

So the exact marginal variances (the diagonal) of a Gaussian field with sparse precision ``A``, and
``tr(A^-1 dA)`` for any ``dA`` on ``A``'s pattern (the gradient of a log-determinant), cost a few times one
factorisation, where a dense inverse costs ``n^3`` and a Monte Carlo estimate has an error of ``1/sqrt(samples)``.

The factor comes from CHOLMOD (the ``[cholmod]`` extra) where it is installed, else from SuperLU in symmetric
mode (``A = L D L'`` with diagonal pivots, ``L sqrt(D)`` the Cholesky factor), which needs nothing beyond SciPy.
The supernodes are the runs of columns with nested structures (``struct(j+1) = struct(j) - {j+1}``); each is
handled with dense BLAS blocks, and ``Sigma_RR`` is gathered from the blocks computed before by one vectorised
search over the factor's row lists.
"""

import contextlib

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..errors import SolveError
from ..memory import check_fits

__all__ = ["Factor", "cholesky", "cholmod_available", "cholmod_module", "from_cholmod", "superlu_spd", "SamplesLast",
           "SAMPLES_LAST_MAX", "SelectedInverse", "inverse_diagonal", "NOT_DEFINITE"]

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


@contextlib.contextmanager
def _one_blas_thread():
    """BLAS held to one thread where threadpoolctl is installed (the ``[cholmod]`` extra brings it): the many small
    blocks of a selected inversion ran 3.7x slower with OpenBLAS's threads (163k unknowns: 8.2-9.1 s against
    2.2-2.5 s, side by side on 2 cores)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        yield
        return
    with threadpool_limits(1, user_api="blas"):
        yield


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


def _supernodes(L):
    """Start columns of the supernodes of ``L`` (with ``n`` appended): runs with nested structures."""
    n = L.shape[0]
    count = np.diff(L.indptr)
    parent = np.full(n, -1, dtype=np.int64)
    has = count > 1
    parent[has] = L.indices[L.indptr[:-1][has] + 1]
    j = np.arange(n - 1)
    joins = (parent[:-1] == j + 1) & (count[1:] == count[:-1] - 1)
    return np.concatenate([[0], j[~joins] + 1, [n]]).astype(np.int64)


class SelectedInverse:
    """``A^-1`` on the pattern of the Cholesky factor of ``A`` (see the module's text).

    Every supernode ``T`` (columns ``t0..t1-1``, ``s`` of them, row list of length ``h``: the columns, then the
    rows below) keeps ``L`` and ``Sigma`` as dense column-major ``h x s`` blocks, one after the other.

    Parameters
    ----------
    factor : Factor

    Examples
    --------
    >>> A = sp.csc_matrix(np.array([[4.0, 1, 0], [1, 3, 1], [0, 1, 2]]))
    >>> s = SelectedInverse(cholesky(A, backend="superlu"))
    >>> bool(np.allclose(s.diagonal(), np.diag(np.linalg.inv(A.toarray()))))
    True
    """

    def __init__(self, factor):
        self.factor = factor
        L = factor.L
        n = L.shape[0]
        lay = _Layout(L)
        big = int((lay.h_of.astype(np.float64) ** 2).max()) if len(lay.h_of) else 0
        check_fits(8.0 * (2 * lay.boff[-1] + 2 * L.nnz + 2 * big), f"the selected inversion of {n:,} unknowns "
                   f"({L.nnz:,} entries in the factor)", "pass variance='sampled'")
        # column c of supernode T starts at boff[T] + (c - t0) h; its entries from the diagonal on
        sn, starts, h_of = lay.sn, lay.starts, lay.h_of
        self._where = lay.boff[sn] + (np.arange(n) - starts[sn]) * (h_of[sn] + 1)  # each column's diagonal
        lb = np.zeros(lay.boff[-1])
        lb[self._positions()] = L.data
        self._blocks = np.zeros(lay.boff[-1])
        with _one_blas_thread():
            _sweep(lay, lb, self._blocks)

    def _positions(self):
        """Where ``L``'s entries (CSC order) sit in the blocks."""
        ip = self.factor.L.indptr
        pos = np.repeat(self._where - ip[:-1], np.diff(ip))
        pos += np.arange(len(pos))
        return pos

    @property
    def values(self):
        """``Sigma``'s entries in the layout of ``factor.L``'s (CSC) entries."""
        return self._blocks[self._positions()]

    def diagonal(self):
        """``diag(A^-1)`` in ``A``'s own order."""
        d = np.empty(len(self.factor.p))
        d[self.factor.p] = self._blocks[self._where]
        return d

    def trace_product(self, D):
        """``tr(A^-1 D)`` for a symmetric sparse ``D`` whose pattern lies in ``A``'s."""
        f = self.factor
        Dl = sp.tril(sp.csc_matrix(D)[f.p][:, f.p], format="csc")
        pat = f.L.copy()
        pat.data = self.values
        W = Dl.multiply(pat)  # Sigma at D's lower entries (within L's pattern)
        return float(2.0 * W.sum() - W.diagonal().sum())


class _Layout:
    """The supernodes of ``L`` and where their dense blocks sit: ``starts`` (first columns, ``n`` appended),
    ``s_of`` (columns), ``h_of`` (rows of the row list), ``sn`` (each column's supernode), ``rows`` and ``roff``
    (the row lists, one after the other), ``keys`` (``supernode * n + row``, sorted), ``boff`` (block offsets)."""

    def __init__(self, L):
        n = self.n = L.shape[0]
        ip = L.indptr
        self.starts = _supernodes(L)
        ns = len(self.starts) - 1
        self.s_of = np.diff(self.starts)
        self.sn = np.repeat(np.arange(ns), self.s_of)
        self.h_of = np.diff(ip)[self.starts[:-1]]
        self.roff = np.concatenate([[0], np.cumsum(self.h_of)])
        self.rows = L.indices[np.repeat(ip[self.starts[:-1]] - self.roff[:-1], self.h_of) + np.arange(self.roff[-1])]
        self.keys = np.repeat(np.arange(ns, dtype=np.int64) * n, self.h_of) + self.rows
        self.boff = np.concatenate([[0], np.cumsum(self.h_of * self.s_of)])

    def gather(self, R, sb):
        """``Sigma[R, R]`` from the blocks ``sb`` computed so far (F-ordered; its lower triangle only).

        ``R`` (sorted) falls into runs of columns of one supernode each; the entry ``(a, b)``, ``a >= b``, sits in
        ``b``'s supernode ``T`` at the row where ``a`` is in ``T``'s row list, found by one search per row and run.
        """
        T = self.sn[R]
        change = np.diff(T) != 0
        run_of = np.concatenate([[0], np.cumsum(change)])
        Tr = T[np.concatenate([[0], np.flatnonzero(change) + 1])]
        query = Tr[None, :] * self.n + R[:, None]
        at = np.searchsorted(self.keys, query)  # (r, runs)
        # rows from the run's first column on must be in the run's row list (the pattern closed under elimination)
        need = np.arange(len(R))[:, None] >= np.flatnonzero(np.concatenate([[True], change]))[None, :]
        if not np.all(self.keys[np.minimum(at, len(self.keys) - 1)][need] == query[need]):
            raise SolveError("the Cholesky factor lost entries of its pattern (exact zeros that SuperLU drops), so "
                             "its selected inverse cannot be read from it; install the [cholmod] extra, or pass "
                             "variance='sampled'")
        loc = at - self.roff[Tr][None, :]
        colbase = self.boff[T] + (R - self.starts[T]) * self.h_of[T]
        idx = colbase[:, None] + loc[:, run_of].T  # [j, i]: entry (R[i], R[j]), meaningful where i >= j
        return sb.take(idx, mode="clip").T


def _sweep(lay, lb, sb):
    """``Sigma``'s blocks ``sb`` from ``L``'s ``lb``, from the last supernode to the first."""
    for t in range(len(lay.s_of) - 1, -1, -1):
        s, h, o = lay.s_of[t], lay.h_of[t], lay.boff[t]
        Lb = lb[o:o + h * s].reshape((s, h)).T
        Sb = sb[o:o + h * s].reshape((s, h)).T
        Linv, info = la.lapack.dtrtri(Lb[:s], lower=1)  # (OpenBLAS's threaded trsm took 20x as long here)
        if info != 0:
            raise SolveError(NOT_DEFINITE)
        if h == s:
            Sb[:] = Linv.T @ Linv
            continue
        Lrs = Lb[s:]
        Srr = lay.gather(lay.rows[lay.roff[t] + s:lay.roff[t + 1]], sb)
        Srs = la.blas.dsymm(-1.0, Srr, Lrs, side=0, lower=1) @ Linv
        Sb[s:] = Srs
        Sb[:s] = Linv.T @ (Linv - Lrs.T @ Srs)


def inverse_diagonal(A, backend="auto"):
    """``diag(A^-1)`` of a sparse symmetric positive definite ``A``, exactly, by selected inversion."""
    return SelectedInverse(cholesky(A, backend)).diagonal()
