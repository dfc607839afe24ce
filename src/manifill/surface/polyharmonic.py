"""Biharmonic and k-harmonic interpolation on a triangle mesh or a tetrahedral solid.

Given values ``vals`` at vertices ``idx``, minimise the k-harmonic energy
``x^T A x`` with ``A = L (M^-1 L)^(k-1)`` (:func:`manifill.linalg.energies.polyharmonic_energy`:
``L`` the stiffness, ``M`` the lumped mass) subject to ``x[idx] = vals``; ``k = 2``
is the biharmonic fill (the discrete integral of the squared Laplacian), ``k = 3``
the triharmonic. This is libigl's ``igl::harmonic(V, F, b, bc, k)``, on triangles
``(m, 3)`` and tetrahedra ``(m, 4)`` alike, and the same numbers: cotangent
stiffness and the barycentric (quarter-volume) mass on tets, libigl's Voronoi mass on
triangles by default (``mass=None``, as everywhere in manifill; ``mass='barycentric'``
for a third of each triangle per corner). The minimiser is smooth (C1-like) across the samples,
where the harmonic fill has a kink, and it may leave the samples' range.

Which solver when (``bench/biharmonic_speed.py``: random samples on icospheres,
two CPUs, one field). For ``k = 2`` at level 7 (163,842 vertices, 1,000 samples)
libigl takes 32 s, a sparse LU of the reduced system (``direct``, SuperLU) 23 s,
because the bilaplacian's 2-ring pattern fills in a lot, and AMG-preconditioned
conjugate gradients (``amg``) 5 s, 0.16x libigl's time (266 iterations to a
residual of ``TOL.polyharmonic_rtol``: multigrid is poor on a 4th-order operator,
but each iteration is cheap), within 1e-10 of the range of libigl's answer. AMG
already wins at 10,242 vertices (0.2 s against 0.56 s), so ``auto`` factorises a
biharmonic system only up to 5,000 unknowns (where a factorisation also pays for
many fields). For ``k = 3`` AMG needs thousands of iterations (2,756 at 40,962
vertices, 12 s against 9 s for ``direct``), so ``auto`` always factorises.
"""

import time

import numpy as np
from numpy.typing import ArrayLike

from ..linalg.backends import direct_factoriser
from ..linalg.energies import polyharmonic_energy
from ..linalg.quadratic import ON_EMPTY, QuadraticSolver
from ..mesh.laplacian import MASS, assemble_laplacian, mass_matrix
from ..deprecation import renamed
from ..mesh.tetmesh import TET_WEIGHTS, assemble_tet_laplacian, cell_width, tet_mass_matrix
from ..errors import MeshError
from ..memory import available_bytes, lu_memory
from ..tolerances import TOL
from ..validate import as_indices, as_mesh, as_tets, check_option, unit_scale

__all__ = ["PolyharmonicSolver", "biharmonic", "energy_matrix", "positions", "polyharmonic_matrix",
           "POLYHARMONIC_SOLVERS", "MASS"]

#: Solvers of the reduced system (see :mod:`manifill.linalg.backends`).
POLYHARMONIC_SOLVERS = ("auto", "direct", "amg")
# the stiffness weights: manifill.mesh.tetmesh.TET_WEIGHTS, those of triangles and tets alike (``uniform`` ignores
# geometry; no linear precision)

#: Public names renamed, kept one release with a warning (:mod:`manifill.deprecation`).
__getattr__ = renamed(__name__, {"SOLVERS": "manifill.surface.polyharmonic:POLYHARMONIC_SOLVERS",
                                 "WEIGHTS": "manifill.mesh.tetmesh:TET_WEIGHTS"})
# MASS (imported): the lumped masses of triangles, the default first; tets always use the quarter volume


def _unit(V):
    """Positions divided by a power of two to about unit size (exact: the solution does not change).

    Lengths, areas and volumes on ``V / s`` are those on ``V`` over ``s``, ``s**2``, ``s**3`` to the bit, so the
    energy here is a power of two times the one a :class:`~manifill.surface.surface.Surface` of the same mesh gives
    (:func:`manifill.surface.energy_fill.energy_fill`), and the two minimisers agree to the last bit.
    """
    return V / unit_scale(V)


def positions(V, k):
    """The candidates of AMG on a k-harmonic energy: the positions (linear functions), for ``k >= 2``; else None.

    The energy nearly annihilates the linear functions as well as the constants, and an aggregation that
    interpolates them needs 4-10x fewer steps (:mod:`manifill.linalg.amg_candidates`).
    """
    return _unit(V) if k > 1 else None


def energy_matrix(L, M, k):
    """The k-harmonic energy ``L (M^-1 L)^(k-1)`` of a stiffness and a lumped mass: the one place it is composed.

    Every k-harmonic fill builds its energy here: :func:`biharmonic` and :class:`PolyharmonicSolver` (triangles or
    tetrahedra) and the methods ``harmonic``, ``biharmonic``, ``triharmonic`` (a mesh, a point cloud:
    :func:`manifill.surface.energy_fill.energy_fill`).

    Parameters
    ----------
    L : (n, n) scipy sparse matrix
        The stiffness (a Laplacian).
    M : (n, n) scipy sparse matrix or None
        The lumped mass (diagonal); not used for ``k = 1``.
    k : int
        The order.

    Returns
    -------
    (n, n) scipy sparse matrix
        ``L`` itself for ``k = 1``.

    Raises
    ------
    MeshError
        A vertex with no area or volume around it (``k >= 2`` divides by it).
    """
    if k == 1:
        return L
    if (M.diagonal() <= 0).any():
        raise MeshError(f"vertex {int(np.flatnonzero(M.diagonal() <= 0)[0])} has zero area or volume around it, "
                        f"so the {'bi' if k == 2 else 'k-'}harmonic energy (which divides by it) is undefined; remove "
                        f"degenerate cells (or points that coincide)")
    return polyharmonic_energy(L, M, k)


def polyharmonic_matrix(V, F, *, k=2, weights="cotan", mass=None):
    """The k-harmonic energy matrix of a triangle or tetrahedral mesh, on unit-size positions.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) or (m, 4) array_like of int
        Triangles or tetrahedra.
    k, weights, mass
        As for :class:`PolyharmonicSolver`.

    Returns
    -------
    (n, n) scipy.sparse.csr_array
        ``A = L (M^-1 L)^(k-1)`` for ``V`` centred and scaled to a unit
        bounding-box diagonal (a positive multiple of the matrix at the true
        scale, so with the same minimisers).

    Raises
    ------
    MeshError, OptionError
        Malformed mesh or options.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> A = polyharmonic_matrix(*icosphere(1))
    >>> A.shape, bool(abs(A @ np.ones(42)).max() < 1e-12)
    ((42, 42), True)
    """
    check_option("weights", weights, TET_WEIGHTS)
    if mass is not None:
        check_option("mass", mass, MASS)
    if cell_width(F) == 4:
        V, T = as_tets(V, F, allow_degenerate=weights == "uniform")
        U = _unit(V)
        L, M = assemble_tet_laplacian(U, T, weights), tet_mass_matrix(U, T)
    else:
        V, F = as_mesh(V, F, allow_degenerate=weights == "uniform")
        U = _unit(V)
        L, M = assemble_laplacian(U, F, weights), mass_matrix(U, F, mass=mass)
    return energy_matrix(L, M, k)


class PolyharmonicSolver(QuadraticSolver):
    """Biharmonic (k = 2) or k-harmonic interpolation from a fixed vertex set, precomputed once, solved many times.

    The solve core :class:`~manifill.linalg.quadratic.QuadraticSolver` on the
    energy ``A = L (M^-1 L)^(k-1)`` of a triangle or tetrahedral mesh.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) or (m, 4) array_like of int
        Triangles, or tetrahedra (either orientation).
    idx : (s,) array_like of int
        Fixed vertices, each listed once.
    k : int, optional
        Order: 2 biharmonic, 3 triharmonic (1 is the harmonic fill).
    weights : {'cotan', 'uniform'}, optional
        Stiffness weights (:func:`manifill.mesh.laplacian.laplacian`,
        :func:`manifill.mesh.tetmesh.tet_laplacian`); ``cotan`` is libigl's.
    mass : {None, 'voronoi', 'barycentric'}, optional
        Lumped mass of a triangle mesh (:func:`manifill.mesh.laplacian.mass_matrix`,
        the same keyword and default there: None is libigl's ``voronoi`` on triangles).
        Tetrahedra always use a quarter of each tet's volume per corner
        (:func:`manifill.mesh.tetmesh.tet_mass_matrix`), whichever name is given.
    solver : {'auto', 'direct', 'amg'}, optional
        Backend for the reduced system; ``auto`` uses AMG-preconditioned CG
        for ``k = 2`` above ``AUTO_DIRECT_MAX`` unknowns and factorises
        otherwise (see the module docstring for the measurement).
    on_empty : {'error', 'nan'}, optional
        A connected component without any fixed vertex: raise
        :class:`~manifill.errors.SolveError` naming it, or leave it NaN. One
        fixed vertex per component suffices: ``x^T A x = |M^-1/2 L x|^2``
        vanishes only for ``L x = 0``, constants on each component.
    tol : float, optional
        Relative residual for ``amg`` (``TOL.polyharmonic_rtol`` by default).
    maxiter : int, optional
        Iteration cap for ``amg`` (``MAXITER`` by default).

    Attributes
    ----------
    A : (n, n) scipy.sparse.csr_array
        The energy matrix (on unit-size positions).
    idx, unknown, empty, report
        As for :class:`~manifill.linalg.quadratic.QuadraticSolver`; the report
        also has ``k``, ``weights``, ``mass`` and ``cells`` (``triangles`` or
        ``tets``), and ``seconds["energy"]``.

    Raises
    ------
    MeshError, SampleError, OptionError
        On malformed input (see :mod:`manifill.validate`).
    SolveError
        On a component without a fixed vertex when ``on_empty="error"``, or an
        AMG solve that does not converge.

    See Also
    --------
    biharmonic : the one-shot function.
    manifill.surface.harmonic.HarmonicSolver : the harmonic (k = 1) fill.

    Examples
    --------
    A linear field on a flat grid, fixed on the two outer rings of vertices, is
    reproduced:

    >>> from manifill.mesh.shapes import grid
    >>> V, F = grid(9)
    >>> ring = np.flatnonzero(np.abs(V[:, :2] - 0.5).max(axis=1) >= 0.37)
    >>> x = PolyharmonicSolver(V, F, ring).solve(2 * V[ring, 0] - V[ring, 1])
    >>> bool(np.abs(x - (2 * V[:, 0] - V[:, 1])).max() < 1e-12)
    True
    """

    #: ``solver="auto"`` factorises a biharmonic system of at most this many unknowns, and every triharmonic one.
    AUTO_DIRECT_MAX = 5_000
    #: When Pardiso factorises (:func:`manifill.linalg.backends.direct_factoriser`), ``auto`` factorises every
    #: system whose factor is predicted (:func:`manifill.memory.lu_memory`, about this many entries per row of
    #: the biharmonic system) to take at most half the memory available: measured 3.6 s against 7.3 s for AMG at
    #: 41k vertices, 25 s against 102 s at 164k (one loaded machine) and 12.5 s against 74 s at 655k (biharmonic,
    #: 100 samples; the bounded one sets AMG up anew for every face of its active set, so it gains more).
    BIHARMONIC_ROW = 19
    #: Default iteration cap of ``amg`` (a 4th-order operator needs hundreds of iterations on large meshes).
    MAXITER = 5000

    def __init__(self, V: ArrayLike, F: ArrayLike, idx: ArrayLike, *, k: int = 2, weights: str = "cotan",
                 mass: str | None = None, solver: str = "auto", on_empty: str = "error", tol: float | None = None,
                 maxiter: int | None = None) -> None:
        t0 = time.perf_counter()
        check_option("on_empty", on_empty, ON_EMPTY)
        check_option("solver", solver, POLYHARMONIC_SOLVERS)
        A = polyharmonic_matrix(V, F, k=k, weights=weights, mass=mass)
        idx = as_indices(idx, A.shape[0], what="idx")
        t1 = time.perf_counter()
        solver, tol, maxiter = self.settings(k, A.shape[0] - idx.size, solver, tol, maxiter)
        super().__init__(A, idx, solver=solver, on_empty=on_empty, tol=tol, maxiter=maxiter,
                         symmetric_pattern=True, what="A", candidates=positions(np.asarray(V, dtype=np.float64), k))
        tets = np.shape(F)[1] == 4
        r = self.report
        if k > 1:  # a bilaplacian has positive off-diagonal entries by nature: the core's count means nothing here
            r.pop("negative_weights", None)
        order = ["vertices", "fixed", "unknowns", "components", "empty_components"]
        self.report = {**{key: r.pop(key) for key in order}, "k": int(k), "weights": weights,
                       "mass": "barycentric" if tets else (mass or "voronoi"),
                       "cells": "tets" if tets else "triangles", **r,
                       "seconds": {"energy": t1 - t0, **r["seconds"]}}

    @classmethod
    def settings(cls, k: int, free: int, solver: str = "auto", tol: float | None = None,
                 maxiter: int | None = None) -> tuple[str, float, int]:
        """The backend, tolerance and iteration cap for a k-harmonic system of ``free`` unknowns.

        ``auto`` is AMG-preconditioned CG for ``k = 2`` above :attr:`AUTO_DIRECT_MAX`
        unknowns and a factorisation otherwise, or with Pardiso a factorisation wherever
        its factor fits (:attr:`BIHARMONIC_ROW`; measured: ``bench/biharmonic_speed.py``);
        the tolerance defaults to ``TOL.polyharmonic_rtol``, the cap to :attr:`MAXITER`.
        Shared by every k-harmonic solve (:mod:`manifill.surface.energy_fill` too).

        Returns
        -------
        solver : str
        tol : float
        maxiter : int
        """
        if k == 1:  # the harmonic fill's own policy (QuadraticSolver's auto), as HarmonicSolver's
            pass
        elif solver == "auto" and direct_factoriser() == "pardiso":
            avail = available_bytes()
            fits = avail is None or lu_memory(free, cls.BIHARMONIC_ROW * free) <= 0.5 * avail
            solver = "direct" if k != 2 or free <= cls.AUTO_DIRECT_MAX or fits else "amg"
        elif solver == "auto":
            solver = "amg" if k == 2 and free > cls.AUTO_DIRECT_MAX else "direct"
        return (solver, TOL.polyharmonic_rtol if tol is None else tol,
                cls.MAXITER if maxiter is None else maxiter)

    # no linear term, equality rows nor bounds here (the core takes them): a narrower solve than the core's
    def solve(self, vals: ArrayLike, *, x0: ArrayLike | None = None) -> np.ndarray:  # type: ignore[override]
        """Values at every vertex, k-harmonic away from ``idx``.

        Parameters
        ----------
        vals : (s,) or (s, p) array_like of float
            Values at ``idx`` (in the order given), one column per field.
        x0 : (n,) or (n, p) array_like, optional
            Initial guess at every vertex, used by ``amg``.

        Returns
        -------
        (n,) or (n, p) numpy array
            Shaped like ``vals``'s columns; exactly ``vals`` at ``idx``; NaN on
            empty components.

        Raises
        ------
        SampleError
            If ``vals`` has the wrong shape or NaN/infinite values.
        SolveError
            If ``amg`` does not converge.
        """
        return super().solve(vals, x0=x0)


def biharmonic(V: ArrayLike, F: ArrayLike, idx: ArrayLike, vals: ArrayLike, *, k: int = 2, weights: str = "cotan",
               mass: str | None = None, solver: str = "auto", on_empty: str = "error", tol: float | None = None,
               maxiter: int | None = None) -> np.ndarray:
    """Biharmonic (or k-harmonic) interpolation of values fixed at some vertices (one-shot).

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) or (m, 4) array_like of int
        Triangles or tetrahedra.
    idx : (s,) array_like of int
        Fixed vertices, each listed once.
    vals : (s,) or (s, p) array_like of float
        Values at ``idx``; ``p`` columns are ``p`` fields solved at once.
    k, weights, mass, solver, on_empty, tol, maxiter
        As for :class:`PolyharmonicSolver`.

    Returns
    -------
    (n,) or (n, p) numpy array
        Equal to ``vals`` at ``idx``; elsewhere the minimiser of the k-harmonic
        energy; with the default mass (libigl's) equal to
        ``igl.harmonic(V, F, idx, vals, k)``.

    Raises
    ------
    MeshError, SampleError, OptionError, SolveError
        See :class:`PolyharmonicSolver`.

    See Also
    --------
    PolyharmonicSolver : precompute once, then solve for many ``vals``.
    manifill.surface.harmonic.harmonic : the harmonic (k = 1) fill.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(2)
    >>> x = biharmonic(V, F, [0, 1, 2, 3], [0.0, 1.0, 2.0, 3.0])
    >>> x[[0, 1, 2, 3]].tolist(), x.shape
    ([0.0, 1.0, 2.0, 3.0], (162,))
    """
    return PolyharmonicSolver(V, F, idx, k=k, weights=weights, mass=mass, solver=solver, on_empty=on_empty,
                              tol=tol, maxiter=maxiter).solve(vals)
