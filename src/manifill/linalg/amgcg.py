"""The ``amg`` backend of :mod:`manifill.linalg.backends`: :class:`AMGSolver`, conjugate gradients
preconditioned by one cycle of smoothed-aggregation multigrid (:class:`manifill.linalg.amg.Multigrid`), independent
blocks side by side in threads. :func:`manifill.linalg.backends.make_linear_solver` builds it; :func:`as_columns`
shapes the right-hand sides of every backend there.
"""

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import scipy.sparse as sp

from ..tolerances import TOL
from .amg import Multigrid, canonical_csr, independent_blocks
from .pcg import nrm2
from .threads import workers

__all__ = ["AMGSolver", "as_columns"]


def as_columns(R):
    """``R`` as float64 columns: an (N,) right-hand side as (N, 1), an (N, p) one as it is."""
    R = np.asarray(R, dtype=np.float64)
    return R[:, None] if R.ndim == 1 else R


class AMGSolver:
    """Conjugate gradients preconditioned by smoothed-aggregation AMG.

    Parameters
    ----------
    A : (N, N) scipy sparse matrix
        Symmetric positive definite.
    rtol : float, optional
        Stop when ``||r|| <= rtol * ||R||``; defaults to ``TOL.amg_rtol``.
    maxiter : int, optional
        Iteration cap per column; not converging within it is an error.

    Attributes
    ----------
    blocks : int
        Independent sets of unknowns solved side by side (see Notes).
    levels : int
        Levels of the (deepest) hierarchy, the factorised one included.
    operator_complexity : float
        Stored entries of the matrices of all levels over those of ``A``.

    Notes
    -----
    *Hierarchy.* Smoothed aggregation, assembled in CSR around pyamg's
    aggregation kernel: every stored non-zero off-diagonal entry is a strong
    connection (pyamg's symmetric strength with ``theta=0``, less stored
    zeros); aggregates are pyamg's standard aggregation; the tentative
    prolongator ``T`` is the normalised piecewise constant; ``P = T - OMEGA
    D_l^{-1} A T`` with ``D_l`` the row sums of ``|A|``, a local Gershgorin
    bound that needs no eigenvalue estimate; ``R = P^T`` and ``A_c = R A P``.
    Apart from ``OMEGA``, this is what ``pyamg.smoothed_aggregation_solver(
    strength="symmetric", smooth=("jacobi", {"weighting": "local"}),
    improve_candidates=None)`` builds, without the block-sparse (BSR)
    intermediates that were half of its set-up time (pre-smoothing the
    constant, pyamg's default, saved no iteration here). Coarsening stops at
    ``MAX_COARSE`` unknowns, which are factorised (SuperLU).

    *Weight.* The usual weight is ``4/3`` over the spectral radius of
    ``D_l^{-1} A``. The Gershgorin bound (1 for this scaling) overestimates
    that radius on triangle meshes, where it is nearer 0.85 (0.87 on the
    benchmark's icosphere), so ``OMEGA = 1.6`` over the bound is about
    ``4/3`` over the radius, for free. On the 650k-unknown benchmark
    (``bench/harmonic_icosphere.py``) it takes the iterations from 25
    (``4/3``) to 21; on grids, jittered grids and icospheres with other fixed
    sets it was never worse than ``4/3``.

    *Cycle.* On the finest level, one forward Gauss-Seidel sweep before and
    one backward sweep after the coarse correction: a symmetric
    preconditioner at half the cost of pyamg's symmetric sweeps; after a
    forward sweep from zero the residual is ``-U x`` (``U`` the strictly
    upper triangle), half a product. The finest level is nearly all the work,
    so below it the cycle does ``COARSE_SWEEPS`` sweeps each side and
    ``COARSE_CYCLES`` coarse corrections (a W-cycle): this nearly exact
    coarse solve takes the benchmark from 21 iterations to 16, the count with
    an exact one, for a few per cent more work per iteration. More sweeps on
    the finest level saved iterations but not time.

    *Precision.* The cycle runs in float32, which cuts the memory traffic of
    its sparse products by a third, for ``A`` scaled to a largest diagonal
    entry of 1 and on the residual scaled to unit norm (no under- or
    overflow); conjugate gradients, residuals and the stopping test
    stay in float64, so the answer is as accurate as with a float64 cycle, in
    as many iterations. The preconditioner is then symmetric only to float32
    rounding, which the flexible (Polak-Ribiere) ``beta`` of the search
    directions absorbs for one more inner product per iteration. Inner
    products use ``einsum``, not BLAS, whose threads cost more in waiting
    than they save on a busy machine.

    *Blocks.* When ``A`` is block diagonal up to a permutation (fixed
    vertices that cut the mesh into patches) and has at least ``MIN_SPLIT``
    unknowns, its connected components are dealt into as many balanced sets
    as there are CPUs (:func:`manifill.linalg.threads.workers`, at most
    ``MAX_THREADS``), and each set gets its own
    hierarchy and conjugate gradients, built and run in a thread of its own.
    SciPy's sparse kernels and NumPy's vector operations release the GIL
    (pyamg's Gauss-Seidel, a fifth of the time, does not), so on two idle
    CPUs set-up and solve take about 0.65 of the time of one hierarchy for
    all (0.8 when another process keeps one CPU busy); processes instead of
    threads were only 10 % faster, as both CPUs share the memory bandwidth.
    Each set stops at ``||r_k|| <= rtol ||R_k||``, which implies the
    criterion above for the whole system.

    Examples
    --------
    Two independent Poisson problems, 54,900 unknowns (two blocks on two CPUs):

    >>> from pyamg.gallery import poisson
    >>> A = sp.block_diag([poisson((180, 180)), poisson((150, 150))], format="csr")
    >>> r = np.ones(A.shape[0])
    >>> X, info = AMGSolver(A).solve(r)
    >>> bool(np.linalg.norm(A @ X[:, 0] - r) <= 1e-10 * np.linalg.norm(r))
    True
    """

    name = "amg"

    #: Unknowns at or below which a level is factorised instead of coarsened.
    MAX_COARSE = 500
    #: Most levels of a hierarchy.
    MAX_LEVELS = 10
    #: Jacobi weight of the prolongation smoother, over the Gershgorin bound.
    OMEGA = 1.6
    #: Gauss-Seidel sweeps before (forward) and after (backward) the coarse correction, finest level.
    FINE_SWEEPS = 1
    #: The same below the finest level.
    COARSE_SWEEPS = 2
    #: Coarse corrections per visit below the finest level (2: W-cycle).
    COARSE_CYCLES = 2
    #: Fewest unknowns for which independent blocks are solved in threads.
    MIN_SPLIT = 50_000
    #: Most threads.
    MAX_THREADS = 4

    def __init__(self, A, *, rtol=None, maxiter=None):
        self.rtol = TOL.amg_rtol if rtol is None else float(rtol)
        self.maxiter = 500 if maxiter is None else int(maxiter)
        self.A = canonical_csr(A)
        self.shape = A.shape
        self._parts = []  # (rows or None for all, _Multigrid)
        self.blocks = self.levels = 0
        self.operator_complexity = 0.0
        if A.shape[0] == 0:
            return
        threads = workers(self.MAX_THREADS)
        blocks = independent_blocks(self.A, threads) if threads > 1 and A.shape[0] >= self.MIN_SPLIT else None
        if blocks is None:
            self._parts = [(None, Multigrid(self.A, self))]
        else:
            position = np.empty(A.shape[0], dtype=self.A.indices.dtype)  # of each unknown in its block
            for rows in blocks:
                position[rows] = np.arange(rows.size, dtype=position.dtype)

            def build(rows):
                # no entry leaves the block, so its rows need only renumbered columns (still sorted)
                sub = self.A[rows]
                sub = sp.csr_matrix((sub.data, position[sub.indices], sub.indptr), shape=(rows.size, rows.size))
                sub.has_canonical_format = True
                return rows, Multigrid(sub, self)

            with ThreadPoolExecutor(len(blocks)) as pool:
                self._parts = list(pool.map(build, blocks))
        self.blocks = len(self._parts)
        self.levels = max(len(mg.nnz) for _, mg in self._parts)
        self.operator_complexity = sum(sum(mg.nnz) for _, mg in self._parts) / max(self.A.nnz, 1)

    def precondition(self, r):
        """``M r`` for one (N,) vector: one cycle of every block's hierarchy (symmetric positive definite to
        float32 rounding), as a preconditioner of ``A`` or of a restriction of it."""
        z = np.zeros_like(r)
        for rows, mg in self._parts:
            part = r if rows is None else r[rows]
            norm = nrm2(part)
            if norm > 0:
                if rows is None:
                    z = mg.precondition(part, norm)
                else:
                    z[rows] = mg.precondition(part, norm)
        return z

    def solve(self, R, x0=None):
        """Solve ``A X = R`` column by column.

        Parameters
        ----------
        R : (N,) or (N, p) numpy array
            Right-hand side(s).
        x0 : (N,) or (N, p) numpy array, optional
            Initial guess.

        Returns
        -------
        X : (N, p) numpy array
        info : dict
            ``solver``; ``iterations`` (list, one per column: with several
            blocks, the most that one of them needed); ``levels``,
            ``operator_complexity`` and ``blocks`` of the hierarchy.

        Raises
        ------
        SolveError
            If a column does not converge within ``maxiter`` iterations.
        """
        R = as_columns(R)
        X = np.zeros(R.shape) if x0 is None else np.array(np.broadcast_to(as_columns(x0), R.shape), dtype=np.float64)
        info = {"solver": self.name, "iterations": []}
        if R.shape[0] == 0:
            return X, info
        if len(self._parts) == 1:
            X, info["iterations"] = self._parts[0][1].solve(R, X)
        else:
            with ThreadPoolExecutor(len(self._parts)) as pool:
                done = list(pool.map(lambda part: part[1].solve(R[part[0]], X[part[0]]), self._parts))
            for (rows, _), (Xk, _) in zip(self._parts, done):
                X[rows] = Xk
            info["iterations"] = [max(its) for its in zip(*(its for _, its in done))]
        info["levels"] = self.levels
        info["operator_complexity"] = self.operator_complexity
        info["blocks"] = self.blocks
        return X, info
