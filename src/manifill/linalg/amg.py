"""Smoothed-aggregation multigrid for the Laplacian systems of :mod:`manifill.linalg.backends`.

The hierarchy is built in CSR around pyamg's aggregation and Gauss-Seidel
kernels; the cycle runs in float32 inside float64 conjugate gradients
(:func:`manifill.linalg.pcg.pcg`); independent blocks of a system are dealt to
threads (:func:`manifill.linalg.threads.workers`). :class:`manifill.linalg.backends.AMGSolver`
documents every setting and why.
"""

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..errors import SolveError
from ..mesh.topology import pattern_components
from .pcg import nrm2, pcg

__all__ = ["Multigrid", "canonical_csr", "independent_blocks"]


def canonical_csr(A):
    """``A`` as a float64 CSR matrix with summed duplicates, sorted indices and one index dtype."""
    if sp.issparse(A) and A.format == "csr" and A.dtype == np.float64:
        A = sp.csr_matrix((A.data, A.indices, A.indptr), shape=A.shape)  # no copy
    else:
        A = sp.csr_matrix(A, dtype=np.float64)
    if not A.has_canonical_format:
        A = A.copy()
        A.sum_duplicates()
    idx = np.int32 if A.nnz < 2**31 - 1 and A.shape[0] < 2**31 - 1 else np.int64
    if A.indptr.dtype != idx or A.indices.dtype != idx:
        A = sp.csr_matrix((A.data, A.indices.astype(idx), A.indptr.astype(idx)), shape=A.shape)
        A.has_canonical_format = True
    return A


def _strict_upper(A):
    """Strictly upper triangular part of a CSR matrix."""
    n = A.shape[0]
    keep = A.indices > np.repeat(np.arange(n, dtype=A.indices.dtype), np.diff(A.indptr))
    indptr = np.concatenate([[0], np.cumsum(keep)])[A.indptr].astype(A.indptr.dtype)
    return sp.csr_matrix((A.data[keep], A.indices[keep], indptr), shape=A.shape)


#: Stored entries per block of rows in the set-up's passes over a matrix: the temporaries stay small.
_BLOCK = 1 << 20


def _row_sums_and_aggregate(A, t, agg, nagg):
    """The row sums of ``|A|`` and ``S = A T`` (``T`` the tentative prolongator ``t`` at columns ``agg``).

    ``T`` has one entry per row, so row ``i`` of ``S`` sums ``A_ij t_j`` into column
    ``agg_j``: no general product, only each row's entries merged (sorted, duplicates
    summed). Block of rows by block, so that no temporary has ``A``'s size.
    """
    n = A.shape[0]
    ones = np.ones(n)
    rowabs = np.empty(n)
    data, indices, counts = [], [], []
    step = max(1, int(_BLOCK * n / max(A.nnz, 1)))
    for r0 in range(0, n, step):
        r1 = min(n, r0 + step)
        p0, p1 = A.indptr[r0], A.indptr[r1]
        ptr = A.indptr[r0:r1 + 1] - p0
        cols, vals = A.indices[p0:p1], A.data[p0:p1]
        rowabs[r0:r1] = sp.csr_matrix((np.abs(vals), cols, ptr), shape=(r1 - r0, n)) @ ones
        part = sp.csr_matrix((vals * t[cols], agg[cols], ptr), shape=(r1 - r0, nagg))
        part.sum_duplicates()  # in place, on this block's own ptr
        data.append(part.data)
        indices.append(part.indices)
        counts.append(np.diff(part.indptr))
    indptr = np.zeros(n + 1, dtype=A.indptr.dtype)
    if counts:
        np.cumsum(np.concatenate(counts), out=indptr[1:])
    S = sp.csr_matrix((np.concatenate(data) if data else np.zeros(0), np.concatenate(indices) if indices else
                       np.zeros(0, A.indices.dtype), indptr), shape=(n, nagg))
    S.has_canonical_format = True
    return rowabs, S


def _coarsen(A, B, omega):
    """One level of smoothed aggregation: ``(P, R, A_c, B_c)``, or ``None`` if ``A`` does not coarsen.

    ``A`` is canonical CSR (float64) and ``B`` the near-null-space vector on its
    unknowns; ``B_c`` is its coarse representation (``T B_c = B``).
    """
    from pyamg.amg_core import standard_aggregation

    n = A.shape[0]
    C = A
    if not np.all(A.data):  # a stored zero is not a connection
        C = A.copy()
        C.eliminate_zeros()
    agg = np.empty(n, dtype=C.indptr.dtype)
    roots = np.empty(n, dtype=C.indptr.dtype)
    nagg = standard_aggregation(n, C.indptr, C.indices, agg, roots)
    if nagg == 0 or nagg >= n:
        return None
    isolated = agg < 0  # rows without neighbours: Gauss-Seidel solves them exactly
    if isolated.any():
        B = np.where(isolated, 0.0, B)
        agg = np.where(isolated, 0, agg)
    norms = np.sqrt(np.bincount(agg, weights=B * B, minlength=nagg))
    t = B / norms[agg]
    T = sp.csr_matrix((t, agg, np.arange(n + 1, dtype=agg.dtype)), shape=(n, nagg))  # orthonormal columns
    # P = T - omega D_l^{-1} A T, D_l the row sums of |A| (a local Gershgorin bound)
    rowabs, S = _row_sums_and_aggregate(A, t, agg, nagg)
    scale = np.divide(-omega, rowabs, out=np.zeros(n), where=rowabs > 0)
    S.data *= np.repeat(scale, np.diff(S.indptr))
    P = sp.csr_matrix(S + T)
    P.eliminate_zeros()
    R = P.T.tocsr()
    return P, R, canonical_csr(R @ (A @ P)), norms


class Multigrid:
    """The hierarchy of one matrix, its float32 cycle and the conjugate gradients on it.

    ``settings`` is the :class:`~manifill.linalg.backends.AMGSolver`, whose class attributes and notes
    say what is done and why.
    """

    def __init__(self, A, settings):
        from pyamg.amg_core import gauss_seidel

        self._gauss_seidel = gauss_seidel
        self.A = A
        self.rtol, self.maxiter = settings.rtol, settings.maxiter
        self.fine_sweeps = settings.FINE_SWEEPS
        self.coarse_sweeps, self.coarse_cycles = settings.COARSE_SWEEPS, settings.COARSE_CYCLES
        self.levels = []  # (A, U or None, R, P) in float32, finest first
        self.nnz = []  # stored entries of every level's matrix, the factorised one last
        # the cycle works on A / scale, whose largest diagonal entry is 1: float32 range
        diagonal = A.diagonal()
        self.scale = float(diagonal.max()) if diagonal.size and diagonal.max() > 0 else 1.0
        Ak, B = A, np.ones(A.shape[0])
        while True:
            self.nnz.append(Ak.nnz)
            step = None
            if Ak.shape[0] > settings.MAX_COARSE and len(self.nnz) < settings.MAX_LEVELS:
                step = _coarsen(Ak, B, settings.OMEGA)
            if step is None:
                self.lu = splu(sp.csc_matrix(Ak) * (1.0 / self.scale))
                break
            P, R, Ac, B = step
            data = (Ak.data * (1.0 / self.scale)).astype(np.float32)
            Ak32 = sp.csr_matrix((data, Ak.indices, Ak.indptr), shape=Ak.shape)
            U = _strict_upper(Ak32) if not self.levels and self.fine_sweeps == 1 else None
            P32 = P.astype(np.float32)
            del P, R
            # the restriction is P's transpose as a view (CSC): the same sums in the same order as R's rows
            self.levels.append((Ak32, U, P32.T, P32))
            Ak = Ac

    def _cycle(self, k, b):
        """Float32 approximation of ``A_k^{-1} b``: one cycle from level ``k``."""
        if k == len(self.levels):
            return self.lu.solve(b.astype(np.float64)).astype(np.float32)
        A, U, R, P = self.levels[k]
        n = A.shape[0]
        Ap, Aj, Ax, gs = A.indptr, A.indices, A.data, self._gauss_seidel
        sweeps, cycles = (self.fine_sweeps, 1) if k == 0 else (self.coarse_sweeps, self.coarse_cycles)
        x = np.zeros(n, dtype=np.float32)
        for _ in range(sweeps):
            gs(Ap, Aj, Ax, x, b, 0, n, 1)
        if U is not None:  # one forward sweep from zero leaves (D + L) x = b, so b - A x = -U x
            r = U @ x
            np.negative(r, out=r)
        else:
            r = b - A @ x
        for c in range(cycles):
            if c:
                r = b - A @ x
            x += P @ self._cycle(k + 1, R @ r)
        for _ in range(sweeps):
            gs(Ap, Aj, Ax, x, b, n - 1, -1, -1)
        return x

    def _precondition(self, r, rnorm):
        """``M r`` in float64, by a float32 cycle for ``A / scale`` on ``r / ||r||``."""
        b = np.empty(r.shape, dtype=np.float32)
        np.multiply(r, 1.0 / rnorm, out=b, casting="same_kind")
        z = np.empty(r.shape)
        np.multiply(self._cycle(0, b), rnorm / self.scale, out=z, dtype=np.float64)
        return z

    def precondition(self, r, rnorm):
        """``M r`` (one float32 cycle), for conjugate gradients on this matrix or a restriction of it."""
        return self._precondition(r, rnorm)

    def pcg(self, r0, x0):
        """Solve ``A x = r0`` from ``x0`` until ``||r|| <= rtol ||r0||``: ``(x, iterations)``.

        Flexible PCG (the loop of :func:`manifill.linalg.pcg.pcg`) on the
        correction ``e = (x - x0) / s``, ``s`` the initial residual norm, so
        that every quantity is of order one whatever the scale of ``r0`` (no
        under- or overflow in the inner products). ``x0`` is overwritten.
        """
        A = self.A
        r0norm = nrm2(r0)
        if r0norm == 0.0:
            return np.zeros_like(r0), 0  # the exact answer, from any x0
        r = r0 - A @ x0 if x0.any() else r0.copy()
        s = nrm2(r)
        target = self.rtol * r0norm
        if s <= target:
            return x0, 0
        r *= 1.0 / s
        target /= s
        e = np.zeros_like(r)
        res = pcg(lambda p: A @ p, r, e, precondition=self._precondition, rtol=target, maxiter=self.maxiter,
                  flexible=True)
        if res.converged:
            x0 += np.multiply(e, s, out=r)
            return x0, res.iterations
        raise SolveError(
            f"AMG-preconditioned CG did not reach rtol={self.rtol:g} in {self.maxiter} iterations "
            f"(residual {res.residual * s / r0norm:.1e}); use solver='direct' or check the weights"
        )

    def solve(self, R, X):
        """:meth:`pcg` on every column of ``R`` from those of ``X`` (overwritten): ``(X, iterations)``."""
        its = []
        for j in range(R.shape[1]):
            X[:, j], k = self.pcg(np.ascontiguousarray(R[:, j]), np.array(X[:, j]))
            its.append(k)
        return X, its


def independent_blocks(A, k):
    """Split the unknowns of ``A`` into 2 to ``k`` sets with no entry of ``A`` between them.

    Whole connected components of ``A``'s graph are dealt, largest first, to
    the set with the fewest stored entries so far; the most sets are used for
    which every set gets at least half an equal share. Returns a list of
    sorted index arrays, or ``None`` (a single component, or one that holds
    nearly all the work).
    """
    ncomp, labels = pattern_components(A)
    if ncomp < 2:
        return None
    work = np.bincount(labels, weights=np.diff(A.indptr), minlength=ncomp)
    order = np.argsort(-work, kind="stable")
    for sets in range(min(k, ncomp), 1, -1):
        load = np.zeros(sets)
        owner = np.empty(ncomp, dtype=np.intp)
        for c in order:
            owner[c] = j = int(np.argmin(load))
            load[j] += work[c]
        if load.min() >= 0.5 * load.sum() / sets:
            part = owner[labels]
            return [np.flatnonzero(part == j) for j in range(sets)]
    return None
