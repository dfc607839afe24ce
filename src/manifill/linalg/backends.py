"""Linear solvers for the symmetric positive definite systems ``A x = r`` of a Dirichlet problem.

Three backends, each an object built once from ``A`` (the expensive part) whose
``solve`` is then called for any number of right-hand sides:

``direct``
    A sparse factorisation (SuperLU, or Pardiso: :mod:`manifill.linalg.factorise`).
    Exact to rounding; best for small systems and for many right-hand sides.
``amg``
    CG preconditioned by one cycle of smoothed-aggregation AMG (pyamg's kernels), linear in the
    size; independent blocks side by side in threads. With candidates (a k-harmonic energy's
    linear functions): :class:`manifill.linalg.amg_candidates.CandidateAMG`.
``iterate``
    The paper's own scheme: every unknown replaced by the weighted average of its
    neighbours, sweep after sweep (Jacobi, or Gauss-Seidel which uses new values
    at once), until the largest change in a sweep is below a tolerance.

A backend is any object with ``name``, ``setup_seconds`` and ``solve(R, x0)`` returning ``(X, info)``; the
solve core (:class:`manifill.linalg.quadratic.QuadraticSolver`) builds one with :func:`make_linear_solver`; the
voxel fill uses the matrix-free :class:`manifill.linalg.gridmg.GridMultigrid`.
"""

import time

import numpy as np
import scipy.sparse as sp

from ..errors import SolveError
from ..memory import available_bytes, check_fits, lu_memory
from ..tolerances import TOL
from ..validate import check_option
from .amg_candidates import CandidateAMG
from .amgcg import AMGSolver, as_columns
from .factorise import DIRECT_ENV, direct_factoriser, factorise

__all__ = ["SOLVERS", "ITERATIONS", "AUTO_DIRECT_FIELDS", "auto_backend", "solve_block",
           "make_linear_solver", "DirectSolver", "AMGSolver", "IterateSolver", "direct_factoriser", "DIRECT_ENV"]

SOLVERS = ("auto", "direct", "amg", "iterate")
ITERATIONS = ("gauss-seidel", "jacobi")

#: ``solver="auto"`` factorises systems with at most this many unknowns and uses AMG above.
AUTO_DIRECT_MAX = 20_000
#: ... and larger ones made of such blocks when at least this many fields share the system and its factors fit:
#: one factorisation and a pair of triangular solves per field beat a CG run per field (measured at 163,842
#: vertices: factorising the pipeline's fill ~1 s, 11-20 ms per field, against ~0.15 s per field for AMG).
AUTO_DIRECT_FIELDS = 8
#: Right-hand sides go to the factorisation in blocks of at most this many bytes: SuperLU's solve is 10x slower per
#: column out of cache (150k unknowns: 10-20 ms per column in blocks of 8-32, 100 ms in one of 100); Pardiso takes
#: 4x larger blocks (163k unknowns, Cholesky: 43 ms per column in blocks of 12, 32 in blocks of 64).
SOLVE_BLOCK_BYTES = 16 * 2**20


class DirectSolver:
    """Sparse LU factorisation of ``A``, reused for every right-hand side.

    SuperLU from SciPy, or Intel MKL's Pardiso when the optional ``pypardiso`` is
    installed (:func:`direct_factoriser`; ``factoriser`` says which ran).

    Parameters
    ----------
    A : (N, N) scipy sparse matrix
        Square and non-singular.
    factoriser, spd : optional
        As for :func:`make_linear_solver`.

    Raises
    ------
    ResourceError
        The factors are predicted not to fit in the memory available
        (:func:`manifill.memory.lu_memory`, as on a curve for at most 3.5
        entries per row and on a surface otherwise: solids fill in more, and
        their fills check before).
    """

    name = "direct"

    def __init__(self, A, factoriser=None, spd=False):
        self.shape = A.shape
        n = A.shape[0]
        if n:
            check_fits(lu_memory(n, A.nnz, dim=1 if A.nnz <= 3.5 * n else 2),
                       f"the sparse LU factorisation of {n:,} unknowns (solver='direct')",
                       "use solver='amg' (CLI --solver amg, or --fill-solver amg for a volume fill)")
        self.factoriser, self._lu = factorise(A, factoriser, spd=spd) if n else ("superlu", None)

    factor = property(lambda self: self._lu, doc="The factorisation (``solve(B)``; a selinv ``Factor``: 'cholesky').")

    def solve(self, R, x0=None):
        """Solve ``A X = R``.

        Parameters
        ----------
        R : (N,) or (N, p) numpy array
            Right-hand side(s).
        x0 : ignored
            Accepted for a uniform interface.

        Returns
        -------
        X : (N, p) numpy array
        info : dict
            ``{"solver": "direct"}``.
        """
        R = as_columns(R)
        if R.shape[0] == 0:
            return np.zeros(R.shape), {"solver": self.name}
        step = solve_block(R.shape[0], 4 if self.factoriser.startswith("pardiso") else 1)
        X = np.empty(R.shape)
        for s in range(0, R.shape[1], step):  # one block when it fits
            part = np.asfortranarray(R[:, s:s + step])
            X[:, s:s + step] = self._lu.solve(part).reshape(part.shape)
        return X, {"solver": self.name}

    def precondition(self, r):
        """``A^-1 r`` for one (N,) vector: the exact inverse, as a preconditioner of a restriction of ``A``."""
        return self._lu.solve(r) if self.shape[0] else np.zeros_like(r)


class IterateSolver:
    """The paper's averaging iteration (Jacobi or Gauss-Seidel sweeps).

    Parameters
    ----------
    A : (N, N) scipy sparse matrix
        Symmetric with a positive diagonal.
    iteration : {'gauss-seidel', 'jacobi'}, optional
        Sweep type.
    tol : float, optional
        Stop when the largest change in a sweep is at most ``tol`` times the
        scale given to :meth:`solve`; defaults to ``TOL.iterate_tol``.
    maxiter : int, optional
        Sweep cap; not converging within it is an error.
    """

    name = "iterate"

    def __init__(self, A, *, iteration="gauss-seidel", tol=None, maxiter=None):
        self.iteration = check_option("iteration", iteration, ITERATIONS)
        self.tol = TOL.iterate_tol if tol is None else float(tol)
        self.maxiter = 1_000_000 if maxiter is None else int(maxiter)
        self.A = sp.csr_matrix(A, dtype=np.float64)
        self.shape = A.shape
        self.diag = self.A.diagonal()
        self.off = self.A - sp.diags(self.diag)

    def _sweep(self, x, r):
        if self.iteration == "jacobi":
            return (r - self.off @ x) / self.diag
        from pyamg.relaxation.relaxation import gauss_seidel

        y = x.copy()
        gauss_seidel(self.A, y, r, iterations=1, sweep="forward")
        return y

    def solve(self, R, x0=None, scale=1.0):
        """Sweep from ``x0`` until the largest change is below ``tol * scale``.

        Parameters
        ----------
        R : (N,) or (N, p) numpy array
            Right-hand side(s).
        x0 : (N,) or (N, p) numpy array, optional
            Initial values (zeros by default).
        scale : float or (p,) array_like, optional
            Size of the values of each column (e.g. the range of its fixed
            values).

        Returns
        -------
        X : (N, p) numpy array
        info : dict
            ``solver``, ``iteration`` and ``iterations`` (list, one per column).

        Raises
        ------
        SolveError
            If a column does not converge within ``maxiter`` sweeps.
        """
        R = as_columns(R)
        X = np.zeros(R.shape) if x0 is None else np.array(as_columns(x0), dtype=np.float64)
        info = {"solver": self.name, "iteration": self.iteration, "iterations": []}
        scales = np.broadcast_to(np.asarray(scale, dtype=np.float64), (R.shape[1],))
        for j in range(R.shape[1]):
            thresh = self.tol * (scales[j] if scales[j] > 0 else 1.0)
            x, r = np.ascontiguousarray(X[:, j]), np.ascontiguousarray(R[:, j])
            its, change = 0, np.inf
            while change > thresh and R.shape[0]:
                if its >= self.maxiter:
                    raise SolveError(
                        f"the averaging iteration did not settle in {self.maxiter} sweeps (last change "
                        f"{change:.1e}, asked {thresh:.1e}); raise maxiter or use solver='amg'"
                    )
                y = self._sweep(x, r)
                change = float(np.abs(y - x).max())
                if not np.isfinite(change):
                    raise SolveError("the averaging iteration produced NaN or infinite values; "
                                     "check the initial guess x0 and the weights")
                x = y
                its += 1
            X[:, j] = x
            info["iterations"].append(its)
        return X, info


def solve_block(rows, scale=1):
    """Columns per block of right-hand sides for a factorisation of ``rows`` unknowns (``scale`` x
    :data:`SOLVE_BLOCK_BYTES`, at most 64).

    >>> solve_block(163_842), solve_block(163_842, 4), solve_block(100), solve_block(10**8)
    (12, 51, 64, 1)
    """
    return int(max(1, min(64, scale * SOLVE_BLOCK_BYTES // (8 * max(int(rows), 1)))))


def auto_backend(unknowns, nnz, fields=1, dim=2, largest=None, spd=False, rows=False):
    """The backend ``solver='auto'`` picks for a system of ``unknowns`` shared by ``fields`` fields.

    A factorisation up to :data:`AUTO_DIRECT_MAX` unknowns. Above, for at least :data:`AUTO_DIRECT_FIELDS` fields,
    when the system falls apart into independent blocks (``largest``: the most unknowns of one, e.g. the pipeline's
    largest patch) of at most :data:`AUTO_DIRECT_MAX` unknowns and the factors fit in the memory available
    (:func:`manifill.memory.lu_memory`): the factors of small blocks fill in little, and
    each field costs a pair of triangular solves. So is one connected symmetric positive
    definite (``spd``) system when Pardiso is installed: its Cholesky factor of 163k unknowns took 1.3 s and 31 ms per
    field against AMG-CG's 100-130 ms per field (SuperLU filled the same system in to 36M entries, as slow as CG). So
    is a 4th-order KKT system (``rows``), with either factoriser (AMG-CG on its rows eliminated: 0.9-9 s per field at
    41k-163k; docs/NOTES.md). AMG-CG otherwise.

    Examples
    --------
    >>> auto_backend(5_000, 35_000), auto_backend(100_000, 700_000, fields=100)
    ('direct', 'amg')
    >>> auto_backend(100_000, 700_000, fields=100, largest=3_000), auto_backend(100_000, 700_000, largest=3_000)
    ('direct', 'amg')
    """
    if unknowns <= AUTO_DIRECT_MAX:
        return "direct"
    small = (unknowns if largest is None else largest) <= AUTO_DIRECT_MAX
    one = spd and direct_factoriser() == "pardiso"
    avail = available_bytes()
    fits = fields >= AUTO_DIRECT_FIELDS and (avail is None or lu_memory(unknowns, nnz, dim=dim) <= 0.5 * avail)
    return "direct" if fits and (small or one or rows) else "amg"


def make_linear_solver(A, solver="auto", *, rtol=None, iteration="gauss-seidel", tol=None, maxiter=None,
                       factoriser=None, spd=False, candidates=None):
    """Build the solver object for ``A`` named by ``solver``.

    Parameters
    ----------
    A : (N, N) scipy sparse matrix
        Symmetric positive definite.
    solver : {'auto', 'direct', 'amg', 'iterate'}, optional
        ``auto`` factorises up to ``AUTO_DIRECT_MAX`` unknowns and uses AMG above.
    rtol : float, optional
        Relative residual for ``amg``.
    iteration : {'gauss-seidel', 'jacobi'}, optional
        Sweep type for ``iterate``.
    tol : float, optional
        Change tolerance for ``iterate``.
    maxiter : int, optional
        Iteration cap for ``amg`` and ``iterate``.
    factoriser : {None, 'superlu', 'pardiso', 'cholesky'}, optional
        What factorises for ``direct`` (see :func:`manifill.linalg.factorise.factorise`).
    spd : bool, optional
        ``A`` is symmetric positive definite, as every caller's but a KKT system's is
        (``direct``: Pardiso may factorise it as such).
    candidates : (N, c) numpy array, optional
        ``amg``: vectors ``A`` nearly annihilates besides constants (:class:`.amg_candidates.CandidateAMG`).

    Returns
    -------
    DirectSolver or AMGSolver or CandidateAMG or IterateSolver
        With ``.solve(R, x0=None)`` returning ``(X, info)``; ``.setup_seconds``
        records the set-up time.
    """
    check_option("solver", solver, SOLVERS)
    check_option("iteration", iteration, ITERATIONS)
    t0 = time.perf_counter()
    if solver == "auto":
        solver = "direct" if A.shape[0] <= AUTO_DIRECT_MAX else "amg"
    if solver == "direct":
        obj = DirectSolver(A, factoriser, spd)
    elif solver == "amg" and candidates is not None:
        obj = CandidateAMG(A, candidates, rtol=rtol, maxiter=maxiter)
    elif solver == "amg":
        obj = AMGSolver(A, rtol=rtol, maxiter=maxiter)
    else:
        obj = IterateSolver(A, iteration=iteration, tol=tol, maxiter=maxiter)
    obj.setup_seconds = time.perf_counter() - t0
    return obj
