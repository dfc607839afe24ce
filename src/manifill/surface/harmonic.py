"""Discrete harmonic extension (the Dirichlet problem) on a triangle mesh or a tetrahedral solid.

Given values ``vals`` at vertices ``idx``, find ``x`` with ``x[idx] = vals`` and
``(L x)_i = 0`` at every other vertex ``i``: each free value is the weighted
average of its neighbours (Steps 5-6 of the paper). With ``I`` the free vertices
and ``b = idx`` this is the sparse symmetric positive definite system
``L_II x_I = -L_Ib vals``: the minimiser of the Dirichlet energy ``1/2 x^T L x``,
set up and solved by the solve core :class:`manifill.linalg.quadratic.QuadraticSolver`.
Triangles ``(m, 3)`` and tetrahedra ``(m, 4)`` are told apart by the width of the
element array, as libigl's one ``harmonic`` does and as :func:`manifill.biharmonic`
does: a solid's ``L`` is the tet stiffness of :mod:`manifill.mesh.tetmesh`.
"""

import time
from typing import Any, TypeVar

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike

from ..errors import OptionError
from ..linalg.quadratic import ON_EMPTY, QuadraticSolver
from ..mesh.laplacian import WEIGHTS, assemble_laplacian
from ..mesh.tetmesh import TET_WEIGHTS
from ..mesh.tetmesh import assemble_tet_laplacian, cell_width
from ..validate import as_indices, as_laplacian, as_mesh, as_tets, check_option, unit_scale

__all__ = ["HarmonicSolver", "harmonic", "ON_EMPTY"]

_Harmonic = TypeVar("_Harmonic", bound="HarmonicSolver")


class HarmonicSolver(QuadraticSolver):
    """Harmonic extension from a fixed vertex set, precomputed once, solved many times.

    The solve core :class:`~manifill.linalg.quadratic.QuadraticSolver` on the
    mesh's Laplacian.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) or (m, 4) array_like of int
        Triangles, or tetrahedra (either orientation), any integer dtype.
    idx : (k,) array_like of int
        Fixed vertices, each listed once.
    weights : {'cotan', 'uniform', 'intrinsic', 'robust'}, optional
        Laplacian weights (see :mod:`manifill.mesh.laplacian`). ``uniform`` and
        ``intrinsic`` always satisfy the maximum principle; ``cotan`` does on
        meshes without obtuse angle pairs and reproduces linear functions on any
        flat mesh. Tetrahedra take ``cotan`` (the P1 stiffness, linear precision
        on any tet mesh) or ``uniform`` (:func:`manifill.mesh.tetmesh.tet_laplacian`).
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
        The Laplacian (also ``A``, the core's name).
    idx : (k,) int64 numpy array
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
        On malformed input (see :mod:`manifill.validate`): ``F`` of a width other
        than 3 or 4, or ``intrinsic``/``robust`` weights for tetrahedra.
    SolveError
        On a component without a fixed vertex when ``on_empty="error"``.

    See Also
    --------
    harmonic : the one-shot function.
    manifill.surface.polyharmonic.PolyharmonicSolver : ``k = 1`` is this fill, on the same cells.

    Examples
    --------
    >>> import numpy as np
    >>> from manifill.mesh.shapes import grid
    >>> V, F = grid(5)
    >>> left, right = np.flatnonzero(V[:, 0] == 0), np.flatnonzero(V[:, 0] == 1)
    >>> solver = HarmonicSolver(V, F, np.r_[left, right])
    >>> x = solver.solve(np.r_[np.zeros(5), np.ones(5)])
    >>> bool(np.allclose(x, V[:, 0]))
    True
    """

    def __init__(self, V: ArrayLike, F: ArrayLike, idx: ArrayLike, *, weights: str = "cotan", solver: str = "auto",
                 on_empty: str = "error", iteration: str = "gauss-seidel", tol: float | None = None,
                 maxiter: int | None = None) -> None:
        t0 = time.perf_counter()
        check_option("on_empty", on_empty, ON_EMPTY)
        check_option("weights", weights, WEIGHTS)
        tets = cell_width(F) == 4
        if tets and weights not in TET_WEIGHTS:
            raise OptionError(f"weights={weights!r} is for triangles; tetrahedra take 'cotan' or 'uniform': pass "
                              f"one of those")
        if tets:
            V, F = as_tets(V, F, allow_degenerate=weights == "uniform")
        else:
            V, F = as_mesh(V, F, allow_degenerate=weights in ("uniform", "robust"))
        idx = as_indices(idx, len(V), what="idx")
        t1 = time.perf_counter()
        # a tet stiffness has units of length: on V / s (s a power of two, 1 for the usual sizes) it is the same
        # matrix divided by s, exactly, with the same solution and entries of about unit size
        L = assemble_tet_laplacian(V / unit_scale(V), F, weights) if tets else assemble_laplacian(V, F, weights)
        t2 = time.perf_counter()
        super().__init__(L, idx, solver=solver, on_empty=on_empty, iteration=iteration, tol=tol, maxiter=maxiter,
                         symmetric_pattern=weights in ("uniform", "cotan"), what="L")
        self._name_weights(weights, {"validate": t1 - t0, "laplacian": t2 - t1})

    @classmethod
    def from_laplacian(cls: type[_Harmonic], L: sp.sparray | sp.spmatrix, idx: ArrayLike, *, solver: str = "auto",
                       on_empty: str = "error", iteration: str = "gauss-seidel", tol: float | None = None,
                       maxiter: int | None = None, symmetric_pattern: bool = False,
                       factoriser: str | None = None) -> _Harmonic:
        """Harmonic extension for a given Laplacian (a mesh's, a graph's, your own).

        Parameters
        ----------
        L : (n, n) scipy sparse matrix
            Symmetric positive semi-definite, ``L = D - W`` (e.g. from
            :func:`manifill.laplacian`).
        idx : (k,) array_like of int
            Fixed vertices, each listed once.
        solver, on_empty, iteration, tol, maxiter
            As for the class.
        symmetric_pattern : bool, optional
            Promise that the sparsity pattern of ``L`` is symmetric (it is for
            :func:`manifill.laplacian`), which speeds up the component search.
        factoriser : {None, 'superlu', 'pardiso'}, optional
            What factorises for ``direct`` (:class:`~manifill.linalg.quadratic.QuadraticSolver`).

        Returns
        -------
        HarmonicSolver

        Raises
        ------
        MeshError
            ``L`` not a square sparse matrix of finite numbers.

        Examples
        --------
        >>> import numpy as np
        >>> import scipy.sparse as sp
        >>> W = sp.diags([1.0, 1.0], [-1, 1], shape=(5, 5))      # a path of 5 vertices
        >>> L = sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W
        >>> HarmonicSolver.from_laplacian(L, [0, 4]).solve([0.0, 8.0]).round(12).tolist()
        [0.0, 2.0, 4.0, 6.0, 8.0]
        """
        check_option("on_empty", on_empty, ON_EMPTY)
        L = as_laplacian(L, what="L")
        obj = cls.__new__(cls)
        QuadraticSolver.__init__(obj, L, idx, solver=solver, on_empty=on_empty, iteration=iteration, tol=tol,
                                 maxiter=maxiter, symmetric_pattern=symmetric_pattern, what="L",
                                 factoriser=factoriser)
        obj._name_weights("given", {})
        return obj

    @property
    def L(self) -> sp.csr_array:
        """The Laplacian (the core's ``A``)."""
        return self.A

    def _name_weights(self, weights, seconds):
        """The core's report with the weights and the timings before it, in the report's order."""
        r = self.report
        order = ["vertices", "fixed", "unknowns", "components", "empty_components"]
        self.report = {**{k: r.pop(k) for k in order}, "weights": weights, **r,
                       "seconds": {**seconds, **r["seconds"]}}

    def solve(self, vals: ArrayLike, *, x0: ArrayLike | None = None, lo: ArrayLike | None = None,
              hi: ArrayLike | None = None, **kwargs: Any) -> np.ndarray:
        """Values at every vertex, harmonic away from ``idx``.

        Parameters
        ----------
        vals : (k,) or (k, p) array_like of float
            Values at ``idx`` (in the order given), one column per field.
        x0 : (n,) or (n, p) array_like, optional
            Initial guess at every vertex, used by ``amg`` and ``iterate``
            (the paper starts from random values or from a GVF fit).
        lo, hi : float or (p,) array_like, optional
            Bounds: the minimiser of the Dirichlet energy subject to ``lo <= x <= hi``
            (:func:`manifill.linalg.active_set.solve_bounded`); with non-negative
            weights the maximum principle already holds and the loop stops at once.
        **kwargs
            Passed to :meth:`manifill.linalg.quadratic.QuadraticSolver.solve` (``linear``, ``beq``).

        Returns
        -------
        (n,) or (n, p) numpy array
            Shaped like ``vals``'s columns; exactly ``vals`` at ``idx``; NaN on
            empty components.

        Raises
        ------
        SampleError
            If ``vals`` has the wrong shape or NaN/infinite values, or lies outside the bounds.
        """
        if lo is None and hi is None:
            return super().solve(vals, x0=x0, **kwargs)
        return super().solve(vals, x0=x0, lo=lo, hi=hi, **kwargs)


def harmonic(V: ArrayLike, F: ArrayLike, idx: ArrayLike, vals: ArrayLike, *, weights: str = "cotan",
             solver: str = "auto", on_empty: str = "error", iteration: str = "gauss-seidel", tol: float | None = None,
             maxiter: int | None = None) -> np.ndarray:
    """Harmonic extension of values fixed at some vertices (one-shot).

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) or (m, 4) array_like of int
        Triangles or tetrahedra, any integer dtype.
    idx : (k,) array_like of int
        Fixed vertices, each listed once.
    vals : (k,) or (k, p) array_like of float
        Values at ``idx``; ``p`` columns are ``p`` fields solved at once.
    weights, solver, on_empty, iteration, tol, maxiter
        As for :class:`HarmonicSolver`.

    Returns
    -------
    (n,) or (n, p) numpy array
        Equal to ``vals`` at ``idx``; at every other vertex the weighted average of
        its neighbours.

    Raises
    ------
    MeshError, SampleError, OptionError, SolveError
        See :class:`HarmonicSolver`.

    See Also
    --------
    HarmonicSolver : precompute once, then solve for many ``vals``.
    manifill.linalg.quadratic.QuadraticSolver : the solve core, for any energy matrix.

    Examples
    --------
    >>> import numpy as np
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(2)
    >>> idx = np.array([0, 1, 2, 3])
    >>> x = harmonic(V, F, idx, [0.0, 1.0, 2.0, 3.0], weights="uniform")
    >>> bool(x.min() >= 0 and x.max() <= 3)
    True

    Tetrahedra (a fifth vertex inside a tet) take the same call:

    >>> V = np.array([[0., 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2], [0.4, 0.4, 0.4]])
    >>> T = [[0, 1, 2, 4], [0, 1, 4, 3], [0, 4, 2, 3], [4, 1, 2, 3]]
    >>> round(float(harmonic(V, T, [0, 1, 2, 3], V[:4, 0])[4]), 12)  # linear precision: x at the inner vertex
    0.4
    """
    return HarmonicSolver(V, F, idx, weights=weights, solver=solver, on_empty=on_empty,
                          iteration=iteration, tol=tol, maxiter=maxiter).solve(vals)
