"""AMG for the 4th- and 6th-order energies: smoothed aggregation that knows their near null space.

A Laplacian's near null space is the constants, which the piecewise-constant aggregates of
:class:`manifill.linalg.backends.AMGSolver` reproduce. The bi- and triharmonic energies
``L (M^-1 L)^(k-1)`` also nearly annihilate the linear functions of the positions (exactly on
a flat mesh, away from its boundary): an aggregation that interpolates only constants leaves
them to the smoother, and conjugate gradients then need hundreds of steps (401 at 41k vertices,
~680 at 163k with 100 samples fixed). Here pyamg's smoothed aggregation gets ``B = [1, x, y, z]``
as its candidates and energy-minimising prolongation smoothing (Olson, Schroder, Tuminaro 2011),
with symmetric Gauss-Seidel: 70 steps at 163k, 112 at 655k, and the hierarchy costs a few
seconds. This is the k >= 2 backend ``solver='auto'`` takes without Pardiso (measured by
``python -m bench.default_targets --scipy``); the conjugate gradient loop is :func:`manifill.linalg.pcg.pcg`.
"""

import time

import numpy as np

from ..errors import SolveError
from ..tolerances import TOL
from .pcg import nrm2, pcg

__all__ = ["CandidateAMG"]


class CandidateAMG:
    """Conjugate gradients preconditioned by smoothed aggregation with given near-null-space candidates.

    Parameters
    ----------
    A : (N, N) scipy sparse matrix
        Symmetric positive definite.
    candidates : (N, c) numpy array
        Vectors ``A`` nearly annihilates besides the constants (the unit-size positions ``x, y, z`` for a
        k-harmonic energy); the constants are added here.
    rtol : float, optional
        Stop when ``||r|| <= rtol * ||R||`` (``TOL.polyharmonic_rtol`` by default).
    maxiter : int, optional
        Most steps per column; not converging within them is an error.

    Examples
    --------
    A biharmonic system of a flat grid, its corners fixed:

    >>> import scipy.sparse as sp
    >>> from pyamg.gallery import poisson
    >>> L = poisson((40, 40)).tocsr()
    >>> A = (L @ L).tocsr()
    >>> xy = np.indices((40, 40)).reshape(2, -1).T / 40.0
    >>> s = CandidateAMG(A, xy)
    >>> X, info = s.solve(np.ones(1600))
    >>> bool(np.linalg.norm(A @ X[:, 0] - 1) <= 1e-10 * 40), info["solver"]
    (True, 'amg')
    """

    name = "amg"
    #: Unknowns at or below which the coarsest level is factorised.
    MAX_COARSE = 500
    #: Steps of the energy-minimising prolongation smoother (4: 70 CG steps at 163k against 118 with 2).
    ENERGY_STEPS = 4

    def __init__(self, A, candidates, *, rtol=None, maxiter=None):
        import pyamg

        t0 = time.perf_counter()
        self.rtol = TOL.polyharmonic_rtol if rtol is None else float(rtol)
        self.maxiter = 5000 if maxiter is None else int(maxiter)
        self.A = A.tocsr()
        self.shape = A.shape
        C = np.asarray(candidates, dtype=np.float64).reshape(A.shape[0], -1)
        B = np.column_stack([np.ones(A.shape[0]), C - C.mean(axis=0)]) if A.shape[0] else C
        self.ml = None
        if A.shape[0]:
            sweep = ("gauss_seidel", {"sweep": "symmetric", "iterations": 1})
            self.ml = pyamg.smoothed_aggregation_solver(
                self.A, B=B, symmetry="symmetric", strength=("symmetric", {"theta": 0.0}),
                smooth=("energy", {"maxiter": self.ENERGY_STEPS, "degree": 1}),
                presmoother=sweep, postsmoother=sweep, max_coarse=self.MAX_COARSE, coarse_solver="splu")
            self._cycle = self.ml.aspreconditioner(cycle="V")
        self.levels = 0 if self.ml is None else len(self.ml.levels)
        self.operator_complexity = 0.0 if self.ml is None else float(self.ml.operator_complexity())
        self.setup_seconds = time.perf_counter() - t0

    def precondition(self, r):
        """``M r``: one V-cycle of the hierarchy (symmetric positive definite)."""
        return self._cycle @ r

    def solve(self, R, x0=None):
        """Solve ``A X = R`` column by column.

        Returns
        -------
        X : (N, p) numpy array
        info : dict
            ``solver``, ``iterations`` (one per column), ``levels``, ``operator_complexity``, ``candidates``.

        Raises
        ------
        SolveError
            A column that does not converge within ``maxiter`` steps.
        """
        R = np.asarray(R, dtype=np.float64).reshape(self.shape[0], -1)
        X = np.zeros(R.shape) if x0 is None else np.array(np.broadcast_to(
            np.asarray(x0, dtype=np.float64).reshape(self.shape[0], -1), R.shape))
        info = {"solver": self.name, "iterations": [], "levels": self.levels,
                "operator_complexity": self.operator_complexity, "candidates": True}
        for j in range(R.shape[1]):
            norm0 = nrm2(R[:, j])
            if norm0 == 0 or self.shape[0] == 0:
                X[:, j] = 0.0 if norm0 == 0 else X[:, j]
                info["iterations"].append(0)
                continue
            x = X[:, j].copy()
            r = R[:, j] - self.A @ x
            out = pcg(lambda p: self.A @ p, r, x, precondition=lambda v, _n: self.precondition(v), rtol=self.rtol,
                      maxiter=self.maxiter, norm0=norm0)
            if out.status != "converged":
                raise SolveError(f"AMG-preconditioned CG did not reach the relative residual {self.rtol:g} in "
                                 f"{out.iterations} steps; pass solver='direct'")
            X[:, j] = x
            info["iterations"].append(int(out.iterations))
        return X, info
