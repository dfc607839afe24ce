"""Discrete harmonic extension (the Dirichlet problem) on a triangle mesh.

Given values ``bc`` at vertices ``b``, find ``x`` with ``x[b] = bc`` and
``(L x)_i = 0`` at every other vertex ``i``: each free value is the weighted
average of its neighbours (Steps 5-6 of the paper). With ``I`` the free vertices
this is the sparse symmetric positive definite system ``L_II x_I = -L_Ib bc``.
"""

import time

import numpy as np
import scipy.sparse as sp

from ..errors import SampleError, SolveError
from ..mesh.laplacian import WEIGHTS, assemble_laplacian
from ..linalg.backends import make_linear_solver
from ..mesh.topology import pattern_components
from ..validate import as_indices, as_mesh, as_values, check_option

__all__ = ["HarmonicSolver", "harmonic"]

ON_EMPTY = ("error", "nan")


class HarmonicSolver:
    """Harmonic extension from a fixed vertex set, precomputed once, solved many times.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles, any integer dtype.
    b : (k,) array_like of int
        Fixed vertices, each listed once.
    weights : {'cotan', 'uniform', 'intrinsic', 'robust'}, optional
        Laplacian weights (see :mod:`manifill.laplacian`). ``uniform`` and
        ``intrinsic`` always satisfy the maximum principle; ``cotan`` does on
        meshes without obtuse angle pairs and reproduces linear functions on any
        flat mesh.
    solver : {'auto', 'direct', 'amg', 'iterate'}, optional
        Linear solver (see :mod:`manifill.linalg.backends`).
    on_empty : {'error', 'nan'}, optional
        A connected component without any fixed vertex has no harmonic
        solution: raise :class:`~manifill.errors.SolveError` naming it, or fill
        it with NaN (listed in ``report["empty_components"]``).
    iteration : {'gauss-seidel', 'jacobi'}, optional
        Sweep type of ``solver="iterate"``.
    tol : float, optional
        Relative residual for ``amg``; largest change per sweep, relative to
        the range of the fixed values, for ``iterate``.
    maxiter : int, optional
        Iteration cap for ``amg`` and ``iterate``.

    Attributes
    ----------
    L : (n, n) scipy.sparse.csr_array
        The Laplacian.
    b : (k,) int64 numpy array
        Fixed vertices, in the given order.
    unknown : (N,) int64 numpy array
        Vertices solved for.
    empty : (n,) bool numpy array
        Vertices in components without a fixed vertex (NaN in the result).
    report : dict
        Sizes, weights, negative weight count, solver and timings; after each
        :meth:`solve`, its iterations too.

    Raises
    ------
    MeshError, SampleError, OptionError
        On malformed input (see :mod:`manifill.validate`).
    SolveError
        On a component without a fixed vertex when ``on_empty="error"``.

    See Also
    --------
    harmonic : the one-shot function.

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> V, F = grid(5)
    >>> left, right = np.flatnonzero(V[:, 0] == 0), np.flatnonzero(V[:, 0] == 1)
    >>> solver = HarmonicSolver(V, F, np.r_[left, right])
    >>> x = solver.solve(np.r_[np.zeros(5), np.ones(5)])
    >>> bool(np.allclose(x, V[:, 0]))
    True
    """

    def __init__(self, V, F, b, *, weights="cotan", solver="auto", on_empty="error",
                 iteration="gauss-seidel", tol=None, maxiter=None):
        t0 = time.perf_counter()
        check_option("on_empty", on_empty, ON_EMPTY)
        check_option("weights", weights, WEIGHTS)
        V, F = as_mesh(V, F, allow_degenerate=weights in ("uniform", "robust"))
        b = as_indices(b, len(V), what="b")
        t1 = time.perf_counter()
        L = assemble_laplacian(V, F, weights)
        t2 = time.perf_counter()
        self._setup(L, b, weights, solver, on_empty, iteration, tol, maxiter,
                    {"validate": t1 - t0, "laplacian": t2 - t1})

    @classmethod
    def from_laplacian(cls, L, b, *, solver="auto", on_empty="error", iteration="gauss-seidel",
                       tol=None, maxiter=None, symmetric_pattern=False):
        """Harmonic extension for a given Laplacian (a mesh's, a graph's, your own).

        Parameters
        ----------
        L : (n, n) scipy sparse matrix
            Symmetric positive semi-definite, ``L = D - W`` (e.g. from
            :func:`manifill.laplacian`).
        b : (k,) array_like of int
            Fixed vertices, each listed once.
        solver, on_empty, iteration, tol, maxiter
            As for the class.
        symmetric_pattern : bool, optional
            Promise that the sparsity pattern of ``L`` is symmetric (it is for
            :func:`manifill.laplacian`), which speeds up the component search.

        Returns
        -------
        HarmonicSolver

        Examples
        --------
        >>> import scipy.sparse as sp
        >>> W = sp.diags([1.0, 1.0], [-1, 1], shape=(5, 5))      # a path of 5 vertices
        >>> L = sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W
        >>> HarmonicSolver.from_laplacian(L, [0, 4]).solve([0.0, 8.0]).round(12).tolist()
        [0.0, 2.0, 4.0, 6.0, 8.0]
        """
        check_option("on_empty", on_empty, ON_EMPTY)
        try:
            L = sp.csr_array(L, dtype=np.float64)
        except (TypeError, ValueError):
            raise SampleError("L could not be read as a sparse matrix of numbers; pass a scipy.sparse matrix") from None
        if L.ndim != 2 or L.shape[0] != L.shape[1]:
            raise SampleError(f"L has shape {L.shape}; pass a square sparse matrix")
        if not np.isfinite(L.data).all():
            raise SampleError("L has NaN or infinite entries; check how it was built")
        obj = cls.__new__(cls)
        obj._setup(L, as_indices(b, L.shape[0], what="b"), "given", solver, on_empty, iteration, tol, maxiter,
                   {}, symmetric_pattern=symmetric_pattern)
        return obj

    def _setup(self, L, b, weights, solver, on_empty, iteration, tol, maxiter, seconds, symmetric_pattern=None):
        n = L.shape[0]
        self.b = b
        self.n = n
        self.L = L
        t2 = time.perf_counter()
        if symmetric_pattern is None:
            symmetric_pattern = weights in ("uniform", "cotan")
        ncomp, labels = pattern_components(L, symmetric=symmetric_pattern)
        has_fixed = np.bincount(labels[self.b], minlength=ncomp) > 0
        self.empty = ~has_fixed[labels]
        empty_components = []
        if self.empty.any():
            for c in np.flatnonzero(~has_fixed):
                members = np.flatnonzero(labels == c)
                empty_components.append({"vertices": int(members.size), "example_vertex": int(members[0])})
            empty_components.sort(key=lambda e: -e["vertices"])
            if on_empty == "error":
                e = empty_components[0]
                more = f" (and {len(empty_components) - 1} more)" if len(empty_components) > 1 else ""
                raise SolveError(
                    f"a connected component of {e['vertices']} vertices (e.g. vertex {e['example_vertex']}) "
                    f"has no fixed vertex{more}, so its values are undetermined; add a sample there, "
                    f"or pass on_empty='nan' (CLI: --on-empty nan) to leave it NaN"
                )
        known = self.empty.copy()
        known[self.b] = True
        self.unknown = np.flatnonzero(~known)
        rows = L[self.unknown]
        self._L_II = rows[:, self.unknown].tocsr()
        self._L_Ib = rows[:, self.b].tocsr()
        t3 = time.perf_counter()
        self._solver = make_linear_solver(self._L_II, solver, rtol=tol, iteration=iteration, tol=tol, maxiter=maxiter)
        if L.has_canonical_format:  # one stored entry per position: count the diagonal's apart
            positive = np.count_nonzero(L.data > 0) - np.count_nonzero(L.diagonal() > 0)
        else:
            positive = np.count_nonzero(L.data[L.indices != np.repeat(np.arange(n), np.diff(L.indptr))] > 0)
        self.report = {
            "vertices": n,
            "fixed": int(self.b.size),
            "unknowns": int(self.unknown.size),
            "components": int(ncomp),
            "empty_components": empty_components,
            "weights": weights,
            "negative_weights": int(positive) // 2,
            "solver": self._solver.name,
            "seconds": {
                **seconds,
                "partition": t3 - t2,
                "setup": self._solver.setup_seconds,
            },
        }

    def solve(self, bc, *, x0=None):
        """Values at every vertex, harmonic away from ``b``.

        Parameters
        ----------
        bc : (k,) or (k, p) array_like of float
            Values at ``b`` (in the order given), one column per field.
        x0 : (n,) or (n, p) array_like, optional
            Initial guess at every vertex, used by ``amg`` and ``iterate``
            (the paper starts from random values or from a GVF fit).

        Returns
        -------
        (n,) or (n, p) numpy array
            Shaped like ``bc``'s columns; exactly ``bc`` at ``b``; NaN on
            empty components.

        Raises
        ------
        SampleError
            If ``bc`` has the wrong shape or NaN/infinite values.
        """
        bc, squeeze = as_values(bc, self.b.size, what="bc")
        t0 = time.perf_counter()
        R = -(self._L_Ib @ bc)
        guess = None
        if x0 is not None:
            try:
                x0 = np.asarray(x0, dtype=np.float64)
            except (TypeError, ValueError):
                raise SampleError("x0 could not be read as numbers; pass an (n,) or (n, p) float array") from None
            x0 = x0[:, None] if x0.ndim == 1 else x0
            if x0.ndim != 2 or x0.shape[0] != self.n or x0.shape[1] not in (1, bc.shape[1]):
                raise SampleError(f"x0 has shape {x0.shape}; pass ({self.n},) or ({self.n}, {bc.shape[1]})")
            guess = np.broadcast_to(x0[self.unknown], R.shape)
            if not np.isfinite(guess).all():
                raise SampleError("x0 has NaN or infinite values at vertices to be solved for; give finite guesses")
        elif self._solver.name == "iterate":
            guess = np.broadcast_to(bc.mean(axis=0), R.shape)
        if self._solver.name == "iterate":
            X, info = self._solver.solve(R, guess, scale=np.ptp(bc, axis=0))
        else:
            X, info = self._solver.solve(R, guess)
        out = np.full((self.n, bc.shape[1]), np.nan)
        out[self.b] = bc
        out[self.unknown] = X
        self.report.update({k: v for k, v in info.items() if k != "solver"})
        self.report["seconds"]["solve"] = time.perf_counter() - t0
        return out[:, 0] if squeeze else out


def harmonic(V, F, b, bc, *, weights="cotan", solver="auto", on_empty="error",
             iteration="gauss-seidel", tol=None, maxiter=None):
    """Harmonic extension of values fixed at some vertices (one-shot).

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles, any integer dtype.
    b : (k,) array_like of int
        Fixed vertices, each listed once.
    bc : (k,) or (k, p) array_like of float
        Values at ``b``; ``p`` columns are ``p`` fields solved at once.
    weights, solver, on_empty, iteration, tol, maxiter
        As for :class:`HarmonicSolver`.

    Returns
    -------
    (n,) or (n, p) numpy array
        Equal to ``bc`` at ``b``; at every other vertex the weighted average of
        its neighbours.

    Raises
    ------
    MeshError, SampleError, OptionError, SolveError
        See :class:`HarmonicSolver`.

    See Also
    --------
    HarmonicSolver : precompute once, then solve for many ``bc``.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(2)
    >>> b = np.array([0, 1, 2, 3])
    >>> x = harmonic(V, F, b, [0.0, 1.0, 2.0, 3.0], weights="uniform")
    >>> bool(x.min() >= 0 and x.max() <= 3)
    True
    """
    return HarmonicSolver(V, F, b, weights=weights, solver=solver, on_empty=on_empty,
                          iteration=iteration, tol=tol, maxiter=maxiter).solve(bc)
