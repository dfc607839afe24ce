"""The solve core: minimise a quadratic energy subject to constraints, precomputed once, solved many times.

Every fill of manifill is one problem,

    minimise  E(x) = 1/2 x^T A x + c^T x   subject to  x[idx] = vals  (and Aeq x = beq),

with ``A`` (n x n, sparse, symmetric positive semi-definite) the energy of a
domain: a surface Laplacian (:func:`manifill.mesh.laplacian.laplacian`), a tet
stiffness (:func:`manifill.solid.tets.tet_laplacian`) or a voxel Laplacian
(:func:`manifill.solid.voxels.voxel_laplacian`). With ``I`` the free indices
and ``b = idx`` the fixed ones, the minimiser solves the reduced system

    A_II x_I = -A_Ib vals - c_I,

which :class:`QuadraticSolver` sets up once (the split, the components, the
backend's factorisation or hierarchy) and solves for any number of ``vals``
(``(k,)`` or ``(k, p)``, ``p`` fields at once), in the shape of gpytoolbox's
``min_quad_with_fixed`` precompute-then-solve. The backend is one of
:mod:`manifill.linalg.backends` (``direct``, ``amg``, ``iterate``); a backend
is any object with ``name``, ``setup_seconds`` and ``solve(R, x0) -> (X,
info)`` (the voxel multigrid :class:`manifill.linalg.gridmg.GridMultigrid` is
one, matrix-free, used by :class:`manifill.solid.fill.VoxelFill`).

A connected component of ``A``'s graph without a fixed index has no unique
minimiser (constants are free there): ``on_empty='error'`` raises
:class:`~manifill.errors.SolveError` naming it, ``on_empty='nan'`` leaves it
NaN.

What the constructor takes besides ``A`` and ``idx``:

- *Linear equality rows* ``Aeq x = beq`` (``Aeq=``: barycentric points on faces)
  for the ``direct`` backend: ``Aeq`` is reduced like ``A`` (``Aeq_I``,
  ``beq - Aeq_b vals``) and the KKT system ``[[A_II, Aeq_I^T], [Aeq_I, 0]]``
  (symmetric indefinite) is factorised. The iterative backends take points
  after :func:`manifill.surface.points.eliminate_rows` has solved the rows for
  one free vertex each (the energies' methods do this).
- ``candidates=``: the near null space of a 4th-order energy (the positions) for
  :class:`manifill.linalg.amg_candidates.CandidateAMG`.
- *Bounds* ``lo <= x <= hi`` (``solve(vals, lo=..., hi=...)``): the
  active-set loop of :mod:`manifill.linalg.active_set` around
  :meth:`QuadraticSolver.solve`; it moves violated indices into ``idx`` at
  their bound (:meth:`QuadraticSolver.fixing`, the same reduction), and
  releases those whose multiplier ``(A x + c)_i`` has the wrong sign
  (primal-dual steps, then a monotone loop that always settles).

Soft constraints (noisy samples, ``1/2 sum_j w_j ((S x)_j - y_j)^2`` beside
``lam x^T A x``) are not taken here: :class:`manifill.linalg.smoothing.SmoothingFit`
solves them, with its own Dirichlet solves through this class.
"""

import time
from typing import Any, TypeVar

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike

from ..errors import OptionError, SampleError, SolveError
from ..validate import as_indices, as_laplacian, as_values, check_option
from .active_set import MAX_ITERATIONS, bounds_per_field, solve_bounded
from .backends import SOLVERS, make_linear_solver
from .dirichlet import split_rows, unanchored

__all__ = ["ON_EMPTY", "QuadraticSolver", "min_quad_with_fixed"]

#: What to do with a component without a fixed index.
ON_EMPTY = ("error", "nan")

_Solver = TypeVar("_Solver", bound="QuadraticSolver")


class QuadraticSolver:
    """Minimise ``1/2 x^T A x + c^T x`` with ``x[idx] = vals``, precomputed once, solved many times.

    Parameters
    ----------
    A : (n, n) scipy sparse matrix
        Symmetric positive semi-definite, positive definite on every component
        once its fixed indices are removed (a Laplacian or stiffness).
    idx : (k,) array_like of int
        Fixed indices, each listed once (may be empty when ``Aeq`` anchors every component).
    solver : {'auto', 'direct', 'amg', 'iterate'}, optional
        Backend (see :mod:`manifill.linalg.backends`).
    on_empty : {'error', 'nan', 'solve'}, optional
        A connected component of ``A``'s graph without a fixed index: raise
        :class:`~manifill.errors.SolveError` naming it, or leave it NaN (listed
        in ``report["empty_components"]``); ``'solve'``: ``A`` is positive definite
        (a Gaussian precision), so such a component is solved like the others.
    iteration : {'gauss-seidel', 'jacobi'}, optional
        Sweep type of ``solver="iterate"``.
    tol : float, optional
        Relative residual for ``amg``; largest change per sweep, relative to
        the range of the fixed values, for ``iterate``.
    maxiter : int, optional
        Iteration cap for ``amg`` and ``iterate``.
    symmetric_pattern : bool, optional
        Promise that the sparsity pattern of ``A`` is symmetric (it is for
        manifill's Laplacians), which speeds up the component search.
    Aeq : (m, n) scipy sparse matrix, optional
        Linear equality rows ``Aeq x = beq`` (``beq`` given to :meth:`solve`),
        linearly independent on the unknowns; a component touched by a row
        counts as anchored. Only with ``solver='direct'`` (or ``'auto'``, which
        then factorises).
    what : str, optional
        The name of ``A`` in error messages.
    factoriser : {None, 'superlu', 'pardiso', 'cholesky'}, optional
        What factorises for ``direct`` (None: :func:`manifill.linalg.factorise.factorise`'s choice);
        many right-hand sides on small blocks are faster with SuperLU.
    candidates : (n, c) numpy array, optional
        Besides the constants, vectors ``A`` nearly annihilates (the positions, for a k-harmonic energy):
        ``amg`` then aggregates with them (:class:`manifill.linalg.amg_candidates.CandidateAMG`).

    Attributes
    ----------
    A : (n, n) scipy.sparse.csr_array
        The energy matrix.
    idx : (k,) int64 numpy array
        Fixed indices, in the given order.
    unknown : (N,) int64 numpy array
        Indices solved for.
    empty : (n,) bool numpy array
        Indices in components without a fixed index (NaN in the result).
    Aeq : (m, n) scipy.sparse.csr_array or None
        The equality rows.
    report : dict
        ``vertices`` (n), ``fixed``, ``unknowns``, ``components``,
        ``empty_components`` (list of ``{"vertices", "example_vertex"}``,
        largest first), ``negative_weights`` (positive off-diagonal pairs of
        ``A``), ``equality_rows`` (with ``Aeq``), ``solver`` and ``seconds`` (``partition``, ``setup``); after
        each :meth:`solve` also ``seconds["solve"]`` and the backend's
        ``iterations``; after a :meth:`solve` with bounds also ``bounds``
        (see :func:`manifill.linalg.active_set.solve_bounded`).
    eq_multipliers : (m, p) numpy array or None
        After a :meth:`solve` with ``Aeq``: the multipliers ``mu`` of the
        equality rows (``A x + c + Aeq^T mu = 0`` at the unknowns).

    Raises
    ------
    MeshError
        ``A`` not a square sparse matrix of finite numbers.
    SampleError, OptionError
        Bad ``idx`` or options.
    SolveError
        A component without a fixed index when ``on_empty="error"``.

    See Also
    --------
    min_quad_with_fixed : the one-shot function.
    manifill.surface.harmonic.HarmonicSolver : this, for a mesh's Laplacian.

    Examples
    --------
    A path of 5 vertices, its ends fixed:

    >>> import scipy.sparse as sp
    >>> A = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(5, 5)).tolil()
    >>> A[0, 0] = A[4, 4] = 1.0
    >>> q = QuadraticSolver(A, [0, 4])
    >>> q.solve([0.0, 8.0]).round(12).tolist()
    [0.0, 2.0, 4.0, 6.0, 8.0]
    >>> q.solve([[0.0, 1.0], [8.0, 1.0]])[2].round(12).tolist()
    [4.0, 1.0]
    """

    def __init__(self, A: sp.sparray | sp.spmatrix, idx: ArrayLike, *, solver: str = "auto", on_empty: str = "error",
                 iteration: str = "gauss-seidel", tol: float | None = None, maxiter: int | None = None,
                 symmetric_pattern: bool = False, Aeq: sp.sparray | sp.spmatrix | None = None, what: str = "A",
                 factoriser: str | None = None, candidates: np.ndarray | None = None) -> None:
        check_option("on_empty", on_empty, ON_EMPTY + ("solve",))
        A = as_laplacian(A, what=what)
        if Aeq is not None:
            Aeq = self._equality_rows(Aeq, A.shape[0], solver)
        self._options = {"solver": solver, "on_empty": on_empty, "iteration": iteration, "tol": tol,
                         "maxiter": maxiter, "symmetric_pattern": symmetric_pattern, "factoriser": factoriser,
                         "candidates": candidates}
        if Aeq is not None and np.size(idx) == 0:  # the rows alone may anchor every component
            idx = np.zeros(0, dtype=np.int64)
        else:
            idx = as_indices(idx, A.shape[0], what="idx")
        self._reduce(A, idx, Aeq=Aeq, **self._options)

    def fixing(self: _Solver, extra: ArrayLike) -> _Solver:
        """The same problem with the indices ``extra`` fixed too (after ``idx``), reduced and set up anew.

        Parameters
        ----------
        extra : (e,) array_like of int
            Indices among :attr:`unknown`, each listed once.

        Returns
        -------
        QuadraticSolver
            Its ``idx`` is ``[idx, extra]``; same options, backend, ``Aeq``.
            Costs one reduction and one backend setup (a factorisation for
            ``direct``).

        Examples
        --------
        >>> import scipy.sparse as sp
        >>> A = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(5, 5))
        >>> QuadraticSolver(A, [0, 4]).fixing([2]).solve([0.0, 0.0, 1.0]).tolist()
        [0.0, 0.5, 1.0, 0.5, 0.0]
        """
        extra = np.asarray(extra, dtype=np.int64).ravel()
        sub = type(self).__new__(type(self))
        sub._options = self._options
        sub._reduce(self.A, np.concatenate([self.idx, extra]), Aeq=self.Aeq, **self._options)
        return sub

    @property
    def backend(self) -> Any:
        """The linear solver of the reduced system (:mod:`manifill.linalg.backends`), e.g. to precondition
        a restriction of it (:mod:`manifill.linalg.active_set` reuses it across the active set's solves)."""
        return self._solver

    @staticmethod
    def _equality_rows(Aeq, n, solver):
        check_option("solver", solver, SOLVERS)
        if solver not in ("auto", "direct"):
            raise OptionError(f"equality rows (Aeq) are solved by factorising their KKT system, not with "
                              f"solver={solver!r}; pass solver='direct'")
        try:
            Aeq = sp.csr_array(Aeq, dtype=np.float64)
        except (TypeError, ValueError):
            raise SampleError("Aeq could not be read as a sparse matrix of numbers; pass a scipy.sparse matrix") \
                from None
        if Aeq.ndim != 2 or Aeq.shape[1] != n or not np.isfinite(Aeq.data).all():
            raise SampleError(f"Aeq has shape {Aeq.shape} or entries that are not finite; pass (m, {n}) finite rows")
        return Aeq

    def _reduce(self, A, idx, solver="auto", on_empty="error", iteration="gauss-seidel", tol=None, maxiter=None,
                symmetric_pattern=False, Aeq=None, factoriser=None, candidates=None):
        """The Dirichlet reduction: components, ``A_II``, ``A_Ib``, the backend, the report."""
        n = A.shape[0]
        self.idx = idx
        self.n = n
        self.A = A
        self.Aeq = Aeq
        self.eq_multipliers = None
        t2 = time.perf_counter()
        ncomp, self.empty, empty_components = unanchored(A, self.idx, Aeq, on_empty, symmetric_pattern)
        known = self.empty.copy()
        known[self.idx] = True
        self.unknown = np.flatnonzero(~known)
        self._A_II, self._A_Ib = split_rows(A, self.unknown, self.idx)
        K = self._A_II
        if Aeq is not None:
            self._Aeq_I, self._Aeq_b = Aeq[:, self.unknown].tocsr(), Aeq[:, self.idx].tocsr()
            K, solver = sp.csr_array(sp.bmat([[K, self._Aeq_I.T], [self._Aeq_I, None]])), "direct"
        t3 = time.perf_counter()
        try:
            self._solver = make_linear_solver(K, solver, rtol=tol, iteration=iteration, tol=tol, maxiter=maxiter,
                                              factoriser=factoriser, spd=Aeq is None,  # KKT: indefinite
                                              candidates=None if candidates is None or Aeq is not None
                                              or solver in ("direct", "iterate") else candidates[self.unknown])
        except RuntimeError as e:  # SuperLU: "Factor is exactly singular"
            if Aeq is None:
                raise
            raise SolveError(f"the KKT system of the equality rows is singular ({e}); pass rows that are "
                             f"linearly independent on the vertices solved for") from None
        if A.has_canonical_format:  # one stored entry per position: count the diagonal's apart
            positive = np.count_nonzero(A.data > 0) - np.count_nonzero(A.diagonal() > 0)
        else:
            positive = np.count_nonzero(A.data[A.indices != np.repeat(np.arange(n), np.diff(A.indptr))] > 0)
        self.report = {
            "vertices": n,
            "fixed": int(self.idx.size),
            "unknowns": int(self.unknown.size),
            "components": int(ncomp),
            "empty_components": empty_components,
            "negative_weights": int(positive) // 2,
            **({} if Aeq is None else {"equality_rows": int(Aeq.shape[0])}),
            "solver": self._solver.name,
            "seconds": {"partition": t3 - t2, "setup": self._solver.setup_seconds},
        }

    def solve(self, vals: ArrayLike, *, linear: ArrayLike | None = None, x0: ArrayLike | None = None,
              beq: ArrayLike | None = None, lo: ArrayLike | None = None, hi: ArrayLike | None = None,
              bound_iterations: int = MAX_ITERATIONS) -> np.ndarray:
        """The minimiser for the given fixed values (and bounds).

        Parameters
        ----------
        vals : (k,) or (k, p) array_like of float
            Values at ``idx`` (in the order given), one column per field.
        linear : (n,) or (n, p) array_like of float, optional
            The linear term ``c`` of the energy (zero by default); read at the
            unknowns only.
        x0 : (n,) or (n, p) array_like, optional
            Initial guess at every index, used by ``amg`` and ``iterate``
            (``iterate`` starts from the mean of ``vals`` otherwise).
        beq : (m,) or (m, p) array_like of float
            Right-hand sides of the equality rows (required with ``Aeq``).
        lo, hi : float or (p,) array_like of float, optional
            Bounds per field on the solved-for indices, None (or ``-inf`` /
            ``inf``) for none on that side: the result is then the minimiser
            of the energy subject to ``lo <= x <= hi`` (a box-constrained QP,
            :mod:`manifill.linalg.active_set`), not a clip, each field with its
            own active set; ``report["bounds"]`` gives the bounds, the
            iterations, the counts at ``lo`` and ``hi`` and the largest KKT
            residual. Each iteration sets the backend up anew for its fixed
            set (one factorisation with ``direct``).
        bound_iterations : int, optional
            Cap on the active-set iterations per field.

        Returns
        -------
        (n,) or (n, p) numpy array
            Shaped like ``vals``'s columns; exactly ``vals`` at ``idx``; NaN on
            empty components.

        Raises
        ------
        SampleError
            If ``vals``, ``linear`` or ``x0`` has the wrong shape or NaN or
            infinite values; bounds with NaN, ``lo > hi``, or sample values
            outside the bounds.
        SolveError
            If an iterative backend does not converge, or the active set does
            not settle in ``bound_iterations``.

        Examples
        --------
        A constant load on a path with its ends at 0 bulges to 4; bounded by 3:

        >>> import scipy.sparse as sp
        >>> A = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(5, 5))
        >>> q = QuadraticSolver(A, [0, 4])
        >>> q.solve([0.0, 0.0], linear=-2 * np.ones(5), hi=3.0).round(12).tolist()
        [0.0, 2.5, 3.0, 2.5, 0.0]
        >>> q.report["bounds"]["active_hi"], q.report["bounds"]["iterations"]
        ([1], [1])
        """
        vals, squeeze = as_values(vals, self.idx.size, what="vals")
        if lo is not None or hi is not None:
            t0 = time.perf_counter()
            lo, hi = bounds_per_field(lo, hi, vals.shape[1])
            X, bounds = solve_bounded(self, vals, lo, hi, linear=linear, x0=x0, beq=beq, maxiter=bound_iterations)
            self.report["bounds"] = bounds
            self.report["seconds"]["solve"] = time.perf_counter() - t0
            return X[:, 0] if squeeze else X
        self.report.pop("bounds", None)
        t0 = time.perf_counter()
        R = -(self._A_Ib @ vals)
        if linear is not None:
            R -= self._at_unknowns(linear, "linear", vals.shape[1])
        guess = None
        if x0 is not None:
            guess = self._at_unknowns(x0, "x0", vals.shape[1])
        elif self._solver.name == "iterate":
            guess = np.broadcast_to(vals.mean(axis=0), R.shape)
        if self.Aeq is not None:
            if beq is None:
                raise SampleError("beq is missing; pass the right-hand side of the equality rows Aeq x = beq")
            beq, _ = as_values(beq, self.Aeq.shape[0], what="beq")
            if beq.shape[1] not in (1, vals.shape[1]):
                raise SampleError(f"beq has {beq.shape[1]} columns for {vals.shape[1]} fields; pass one per field")
            R = np.vstack([R, beq - self._Aeq_b @ vals])
            guess = None
        if self._solver.name == "iterate":
            X, info = self._solver.solve(R, guess, scale=np.ptp(vals, axis=0))
        else:
            X, info = self._solver.solve(R, guess)
        if self.Aeq is not None:
            self.eq_multipliers = X[self.unknown.size:]
        X = X[:self.unknown.size]
        out = np.full((self.n, vals.shape[1]), np.nan)
        out[self.idx] = vals
        out[self.unknown] = X
        self.report.update({k: v for k, v in info.items() if k != "solver"})
        self.report["seconds"]["solve"] = time.perf_counter() - t0
        return out[:, 0] if squeeze else out

    def _at_unknowns(self, a, what, p):
        """An (n,) or (n, p) array read at the unknowns, broadcast to (N, p); finite there."""
        try:
            a = np.asarray(a, dtype=np.float64)
        except (TypeError, ValueError):
            raise SampleError(f"{what} could not be read as numbers; pass an (n,) or (n, p) float array") from None
        a = a[:, None] if a.ndim == 1 else a
        if a.ndim != 2 or a.shape[0] != self.n or a.shape[1] not in (1, p):
            raise SampleError(f"{what} has shape {a.shape}; pass ({self.n},) or ({self.n}, {p})")
        a = np.broadcast_to(a[self.unknown], (self.unknown.size, p))
        if not np.isfinite(a).all():
            raise SampleError(f"{what} has NaN or infinite values at vertices to be solved for; give finite "
                              f"{'guesses' if what == 'x0' else 'values'}")
        return a


def min_quad_with_fixed(A: sp.sparray | sp.spmatrix, idx: ArrayLike, vals: ArrayLike, *,
                        linear: ArrayLike | None = None, **kwargs: Any) -> np.ndarray:
    """Minimise ``1/2 x^T A x + c^T x`` with ``x[idx] = vals`` (one-shot).

    Parameters
    ----------
    A : (n, n) scipy sparse matrix
        Symmetric positive semi-definite.
    idx : (k,) array_like of int
        Fixed indices, each listed once.
    vals : (k,) or (k, p) array_like of float
        Values at ``idx``.
    linear : (n,) or (n, p) array_like of float, optional
        The linear term ``c``.
    **kwargs
        ``solver``, ``on_empty``, ``iteration``, ``tol``, ``maxiter``,
        ``symmetric_pattern``: as for :class:`QuadraticSolver`.

    Returns
    -------
    (n,) or (n, p) numpy array

    Examples
    --------
    ``x'' = -2`` on ``[0, 4]`` with ``x(0) = x(4) = 0`` (a constant load):

    >>> import scipy.sparse as sp
    >>> A = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(5, 5))
    >>> min_quad_with_fixed(A, [0, 4], [0.0, 0.0], linear=-2 * np.ones(5)).round(12).tolist()
    [0.0, 3.0, 4.0, 3.0, 0.0]
    """
    return QuadraticSolver(A, idx, **kwargs).solve(vals, linear=linear)
