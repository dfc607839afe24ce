"""Linear solvers for the symmetric positive definite systems ``A x = r`` of a Dirichlet problem.

Three backends, each an object built once from ``A`` (the expensive part) whose
``solve`` is then called for any number of right-hand sides:

``direct``
    Sparse LU factorisation (SuperLU, from SciPy). Exact to rounding; best for
    small systems and for many right-hand sides.
``amg``
    Conjugate gradients preconditioned by one V-cycle of smoothed-aggregation
    algebraic multigrid (pyamg). Linear in the size of the system.
``iterate``
    The paper's own scheme: every unknown replaced by the weighted average of its
    neighbours, sweep after sweep (Jacobi, or Gauss-Seidel which uses new values
    at once), until the largest change in a sweep is below a tolerance.
"""

import time

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from .errors import SolveError
from .tolerances import TOL
from .validate import check_option

__all__ = ["SOLVERS", "ITERATIONS", "make_linear_solver", "DirectSolver", "AMGSolver", "IterateSolver"]

SOLVERS = ("auto", "direct", "amg", "iterate")
ITERATIONS = ("gauss-seidel", "jacobi")

#: ``solver="auto"`` factorises systems with at most this many unknowns and uses AMG above.
AUTO_DIRECT_MAX = 20_000


def _columns(R):
    R = np.asarray(R, dtype=np.float64)
    return R[:, None] if R.ndim == 1 else R


class DirectSolver:
    """Sparse LU factorisation of ``A``, reused for every right-hand side.

    Parameters
    ----------
    A : (N, N) scipy sparse matrix
        Symmetric positive definite.
    """

    name = "direct"

    def __init__(self, A):
        self.shape = A.shape
        self._lu = splu(sp.csc_matrix(A)) if A.shape[0] else None

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
        R = _columns(R)
        if R.shape[0] == 0:
            return np.zeros(R.shape), {"solver": self.name}
        return self._lu.solve(np.asfortranarray(R)).reshape(R.shape), {"solver": self.name}


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

    Notes
    -----
    The hierarchy is pyamg's smoothed aggregation with symmetric strength and
    Jacobi prolongation smoothing whose weight comes from a local (Gershgorin)
    bound on the spectral radius: this skips the eigenvalue estimates that
    otherwise dominate the set-up. All levels are stored as CSR, whose kernels
    are faster than the block format pyamg returns for coarse levels.
    """

    name = "amg"

    def __init__(self, A, *, rtol=None, maxiter=None):
        import pyamg

        self.rtol = TOL.amg_rtol if rtol is None else float(rtol)
        self.maxiter = 500 if maxiter is None else int(maxiter)
        self.A = sp.csr_matrix(A)
        self.shape = A.shape
        self._ml = None
        if A.shape[0] == 0:
            return
        ml = pyamg.smoothed_aggregation_solver(
            self.A,
            symmetry="symmetric",
            strength="symmetric",
            smooth=("jacobi", {"weighting": "local"}),
            presmoother=("gauss_seidel", {"sweep": "symmetric"}),
            postsmoother=("gauss_seidel", {"sweep": "symmetric"}),
            max_coarse=500,
            coarse_solver="splu",
        )
        for level in ml.levels:
            level.A = sp.csr_matrix(level.A)
            if hasattr(level, "P"):
                level.P = sp.csr_matrix(level.P)
                level.R = sp.csr_matrix(level.R)
        self._ml = ml
        self._M = ml.aspreconditioner(cycle="V")

    def _pcg(self, r0, x):
        A, M = self.A, self._M
        r = r0 - A @ x if x.any() else r0.copy()
        target = self.rtol * np.linalg.norm(r0)
        rnorm = np.linalg.norm(r)
        its = 0
        if rnorm <= target:
            return x, its, rnorm
        z = M @ r
        p = z.copy()
        rz = r @ z
        while its < self.maxiter:
            Ap = A @ p
            alpha = rz / (p @ Ap)
            x += alpha * p
            r -= alpha * Ap
            its += 1
            rnorm = np.linalg.norm(r)
            if rnorm <= target:
                return x, its, rnorm
            z = M @ r
            rz_new = r @ z
            p *= rz_new / rz
            p += z
            rz = rz_new
        raise SolveError(
            f"AMG-preconditioned CG did not reach rtol={self.rtol:g} in {self.maxiter} iterations "
            f"(residual {rnorm / max(np.linalg.norm(r0), 1e-300):.1e}); use solver='direct' or check the weights"
        )

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
            ``solver``, ``iterations`` (list, one per column), ``levels`` and
            ``operator_complexity`` of the hierarchy.

        Raises
        ------
        SolveError
            If a column does not converge within ``maxiter`` iterations.
        """
        R = _columns(R)
        X = np.zeros(R.shape) if x0 is None else np.array(_columns(x0), dtype=np.float64)
        info = {"solver": self.name, "iterations": []}
        if R.shape[0] == 0:
            return X, info
        for j in range(R.shape[1]):
            xj, its, _ = self._pcg(np.ascontiguousarray(R[:, j]), np.ascontiguousarray(X[:, j]))
            X[:, j] = xj
            info["iterations"].append(its)
        info["levels"] = len(self._ml.levels)
        info["operator_complexity"] = float(self._ml.operator_complexity())
        return X, info


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
        self.A = sp.csr_matrix(A)
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
        scale : float, optional
            Size of the values (e.g. the range of the fixed values).

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
        R = _columns(R)
        X = np.zeros(R.shape) if x0 is None else np.array(_columns(x0), dtype=np.float64)
        info = {"solver": self.name, "iteration": self.iteration, "iterations": []}
        thresh = self.tol * (scale if scale > 0 else 1.0)
        for j in range(R.shape[1]):
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
                x = y
                its += 1
            X[:, j] = x
            info["iterations"].append(its)
        return X, info


def make_linear_solver(A, solver="auto", *, rtol=None, iteration="gauss-seidel", tol=None, maxiter=None):
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

    Returns
    -------
    DirectSolver or AMGSolver or IterateSolver
        With ``.solve(R, x0=None)`` returning ``(X, info)``; ``.setup_seconds``
        records the set-up time.
    """
    check_option("solver", solver, SOLVERS)
    t0 = time.perf_counter()
    if solver == "auto":
        solver = "direct" if A.shape[0] <= AUTO_DIRECT_MAX else "amg"
    if solver == "direct":
        obj = DirectSolver(A)
    elif solver == "amg":
        obj = AMGSolver(A, rtol=rtol, maxiter=maxiter)
    else:
        obj = IterateSolver(A, iteration=iteration, tol=tol, maxiter=maxiter)
    obj.setup_seconds = time.perf_counter() - t0
    return obj
