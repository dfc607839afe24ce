"""Selected inversion: the entries of ``A^-1`` on the pattern of ``A``'s sparse Cholesky factor.

For ``A = L L'`` (after a fill-reducing permutation), ``Sigma = A^-1`` satisfies ``Sigma L = L^-T``. Reading it
block by block from the last supernode to the first (Takahashi, Fagan & Chen 1973; the supernodal form of
Lin et al.'s SelInv, 2011), a supernode with columns ``S`` and row structure ``R`` below them needs ``Sigma`` only
on ``R x R``, which the factor's pattern holds because it is closed under elimination:

    Sigma_RS = -Sigma_RR L_RS L_SS^-1,          Sigma_SS = L_SS^-T (L_SS^-1 - L_RS' Sigma_RS).

So the exact marginal variances (the diagonal) of a Gaussian field with sparse precision ``A``, and
``tr(A^-1 dA)`` for any ``dA`` on ``A``'s pattern (the gradient of a log-determinant), cost a few times one
factorisation, where a dense inverse costs ``n^3`` and a Monte Carlo estimate has an error of ``1/sqrt(samples)``.

The factor comes from :mod:`manifill.linalg.cholesky` (CHOLMOD with the ``[cholmod]`` extra, else SuperLU in
symmetric mode).
The supernodes are the runs of columns with nested structures (``struct(j+1) = struct(j) - {j+1}``); each is
handled with dense BLAS blocks, and ``Sigma_RR`` is gathered from the blocks computed before by one vectorised
search over the factor's row lists.
"""

import contextlib

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

from ..errors import SolveError
from ..memory import check_fits
from .cholesky import NOT_DEFINITE, cholesky

__all__ = ["SelectedInverse", "inverse_diagonal"]

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
