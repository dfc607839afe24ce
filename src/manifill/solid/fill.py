"""Step 8: the harmonic fill of a solid, in voxel form and in tetrahedral form.

With the values fixed on some voxels (usually the boundary surface D, from
Steps 1-6), every other voxel of the solid gets the weighted average of its
neighbours (:mod:`manifill.solid.voxels` for the neighbours and weights): the discrete
Dirichlet problem. Its sparse form goes through the solve core
(:class:`manifill.linalg.quadratic.QuadraticSolver` on the voxel Laplacian, with
the ``amg`` or ``direct`` backend); its matrix-free form uses the backend made for
grids, the geometric multigrid :class:`manifill.linalg.gridmg.GridMultigrid`,
with the stencil of :func:`manifill.solid.voxels.stencil_weights`. Tetrahedral
solids use the tetrahedral Laplacians of :mod:`manifill.mesh.tetmesh` and the
same core.

Before a large solve the memory it needs is estimated, and a problem that would
not fit is refused (:class:`~manifill.errors.ResourceError`) instead of being
killed by the system.
"""

import time

import numpy as np
from numpy.typing import ArrayLike

from ..errors import SolveError
from ..linalg.backends import SOLVERS
from ..linalg.gridmg import GridMultigrid
from ..linalg.quadratic import ON_EMPTY, QuadraticSolver
from ..memory import check_fits, lu_memory
from ..surface.harmonic import HarmonicSolver
from ..tolerances import TOL
from ..validate import as_indices, as_mask, as_tets, as_values, as_voxels, check_option
from .voxels import as_connectivity, as_spacing, stencil_weights, unit_spacing, voxel_components, voxel_laplacian

__all__ = ["FILL_SOLVERS", "VoxelFill", "harmonic_fill", "tet_fill", "fill_memory", "tet_fill_memory"]

FILL_SOLVERS = ("auto", "multigrid", "amg", "direct")

#: Bytes per padded grid point of one multigrid fill (measured peak 2.8 GB for
#: a 258^3 grid, rounded up), and per stored entry of a sparse AMG solve
#: (7.2 GB for 8.6 M unknowns with 7 entries per row).
_MG_BYTES, _AMG_BYTES = 170, 125


def fill_memory(shape, unknowns, solver="multigrid", connectivity=6):
    """Estimated peak memory of a voxel fill, in bytes.

    Parameters
    ----------
    shape : tuple of 3 int
        The grid.
    unknowns : int
        Free voxels.
    solver : {'multigrid', 'amg', 'direct'}, optional
    connectivity : {6, 18, 26}, optional

    Returns
    -------
    float
        ``multigrid``: 170 bytes per point of the padded grid; ``amg``: 125
        bytes per stored entry of the Laplacian; ``direct``: the LU factors of
        a solid (:func:`manifill.memory.lu_memory`, growing like
        ``unknowns^1.5``) and the Laplacian.
    """
    box = float(np.prod(np.asarray(shape, dtype=np.float64) + 2))
    unknowns = float(unknowns)
    if solver == "multigrid":
        return _MG_BYTES * box
    nnz = unknowns * (connectivity + 1.0)
    if solver == "amg":
        return _AMG_BYTES * nnz + 16 * box
    return lu_memory(unknowns, nnz, dim=3) + 40 * nnz + 16 * box


#: Peak bytes per tet of :func:`tet_fill` up to its solver (the tet Laplacian's assembly: 680
#: measured), stored entries of the Laplacian per vertex (15), and ``solver='auto'``'s limit.
_TET_FILL_BYTES, _TET_NNZ_PER_VERTEX, _AUTO_DIRECT_MAX = 700, 15.5, 20_000
#: Free vertices up to which ``solver='auto'`` of :func:`tet_fill` factorises (direct); AMG above.
AUTO_DIRECT_MAX = _AUTO_DIRECT_MAX


def tet_fill_memory(n_vertices, n_tets, n_fixed=0, solver="auto"):
    """Estimated peak memory of :func:`tet_fill`, in bytes.

    Parameters
    ----------
    n_vertices, n_tets : int
        Size of the tetrahedral mesh.
    n_fixed : int, optional
        Fixed vertices.
    solver : {'auto', 'direct', 'amg', 'iterate'}, optional
        ``auto`` factorises up to 20,000 unknowns, like the solver it picks.

    Returns
    -------
    float
        About 700 bytes per tet (assembling the tet Laplacian), and with
        ``direct`` the LU factors of a solid (:func:`manifill.memory.lu_memory`).

    Examples
    --------
    >>> from manifill.memory import human
    >>> human(tet_fill_memory(50_000, 300_000)), human(tet_fill_memory(50_000, 300_000, solver="direct"))
    ('211 MB', '2.5 GB')
    """
    free = max(float(n_vertices) - float(n_fixed), 0.0)
    out = _TET_FILL_BYTES * float(n_tets) + 16.0 * float(n_vertices)
    if solver == "direct" or (solver == "auto" and free <= _AUTO_DIRECT_MAX):
        out += lu_memory(free, _TET_NNZ_PER_VERTEX * free, dim=3)
    return out


class VoxelFill:
    """Harmonic fill of a voxel solid from fixed voxels, precomputed once, solved for many fields.

    Parameters
    ----------
    mask : (n0, n1, n2) bool array_like
        The solid.
    voxels : (k, 3) array_like of int
        Grid indices of the voxels whose values are given (the samples), each
        inside ``mask`` and listed once, in any order: :meth:`solve` takes one
        value (or row) per voxel in this order. From a boolean mask of fixed
        voxels: ``np.argwhere(fixed)``.
    spacing : (3,) array_like of float, optional
        Voxel size along each axis, of any magnitude (only the ratios of the
        axes change the result).
    connectivity : {6, 18, 26}, optional
        Face, edge or corner neighbours (:mod:`manifill.solid.voxels`).
    solver : {'auto', 'multigrid', 'amg', 'direct'}, optional
        ``auto`` is ``multigrid``: matrix-free, the least memory and the
        fastest on large grids; should it stall (a grid hierarchy that loses
        the fixed voxels, e.g. a few isolated ones), ``auto`` falls back to
        ``amg`` and says so in ``report["fallback"]``. ``amg`` and ``direct``
        assemble the sparse Laplacian and solve it with the solve core
        (:class:`manifill.linalg.quadratic.QuadraticSolver`).
    on_empty : {'error', 'nan'}, optional
        A connected part of the solid with no fixed voxel: raise, or leave it NaN.
    tol : float, optional
        Relative residual (default ``TOL.grid_rtol``, ``1e-10``).
    maxiter : int, optional
        Iteration cap (default 500).

    Attributes
    ----------
    voxels : (k, 3) int64 numpy array
        The fixed voxels, as validated, in the given order.
    fixed : (n0, n1, n2) bool numpy array
        The same voxels as a mask.
    free : (n0, n1, n2) bool numpy array
        The voxels that are solved for.
    report : dict
        Counts, the solver, levels, iterations and seconds.

    Raises
    ------
    MeshError
        A malformed mask or spacing.
    SampleError
        ``voxels`` not ``(k, 3)`` integers, outside the grid or the mask, or
        listed twice.
    OptionError
        An option outside its set.
    SolveError
        A connected part without fixed voxels (``on_empty='error'``).
    ResourceError
        The solve is predicted not to fit in the available memory.

    Examples
    --------
    >>> mask = np.ones((5, 5, 5), dtype=bool)
    >>> fixed = np.zeros_like(mask); fixed[0] = fixed[-1] = True
    >>> voxels = np.argwhere(fixed)
    >>> x = VoxelFill(mask, voxels).solve(voxels[:, 0] * 1.0)
    >>> x[:, 2, 2].round(10).tolist()
    [0.0, 1.0, 2.0, 3.0, 4.0]
    """

    def __init__(self, mask: ArrayLike, voxels: ArrayLike, *, spacing: ArrayLike = (1.0, 1.0, 1.0),
                 connectivity: int = 6, solver: str = "auto", on_empty: str = "error", tol: float | None = None,
                 maxiter: int | None = None) -> None:
        t0 = time.perf_counter()
        check_option("solver", solver, FILL_SOLVERS)
        check_option("on_empty", on_empty, ON_EMPTY)
        self.connectivity = as_connectivity(connectivity)
        self.spacing = as_spacing(spacing)
        self.mask = as_mask(mask)
        self.voxels = as_voxels(voxels, self.mask.shape, mask=self.mask)
        # the samples in C order (that of np.argwhere(fixed)), in which the solve reads them
        self._order = np.argsort(np.ravel_multi_index(tuple(self.voxels.T), self.mask.shape))
        self.fixed = np.zeros(self.mask.shape, dtype=bool)
        self.fixed[tuple(self.voxels.T)] = True
        self.tol = TOL.grid_rtol if tol is None else float(tol)
        self.maxiter = 500 if maxiter is None else int(maxiter)
        self.solver = "multigrid" if solver == "auto" else solver
        # before anything grid-sized: at most the voxels of the mask that are not fixed are unknown
        unknowns = int(np.count_nonzero(self.mask)) - len(self.voxels)
        check_fits(fill_memory(self.mask.shape, unknowns, self.solver, self.connectivity),
                   f"the harmonic fill of {unknowns:,} voxels ({self.solver})",
                   "lower the resolution (CLI --resolution), crop the grid to the solid, or use solver='multigrid' "
                   "(CLI --fill-solver multigrid)")
        # parts of the solid that no fixed voxel reaches have no harmonic solution
        count, labels = voxel_components(self.mask, self.connectivity)
        reached = np.zeros(count + 1, dtype=bool)
        reached[np.unique(labels[self.fixed])] = True
        empty = self.mask & ~reached[labels]
        del labels
        if empty.any() and on_empty == "error":
            v = tuple(int(c) for c in np.argwhere(empty)[0])
            parts = int(count - reached[1:].sum())
            raise SolveError(
                f"{int(empty.sum())} voxels in {parts} connected part(s) of the solid have no fixed voxel (e.g. voxel "
                f"{v}), so their values are undetermined; fix a voxel there, or pass on_empty='nan' to leave them NaN")
        self.empty = empty
        self.free = self.mask & ~self.fixed & ~empty
        self._auto = solver == "auto"
        self._tol_arg, self._maxiter_arg = tol, maxiter
        unknowns = int(self.free.sum())
        self.report = {"voxels": int(self.mask.sum()), "fixed": int(self.fixed.sum()), "unknowns": unknowns,
                       "empty": int(empty.sum()), "connectivity": self.connectivity, "solver": self.solver,
                       "spacing": self.spacing.tolist(), "iterations": [], "seconds": {}}
        t = time.perf_counter()
        self._mg = self._quad = None
        if unknowns and self.solver == "multigrid":
            # the grid cropped to the solid: empty margins cost memory and time in every pass
            solid = self.mask & ~empty
            nz = [np.flatnonzero(solid.any(axis=tuple(b for b in range(3) if b != a))) for a in range(3)]
            self._crop = tuple(slice(int(z[0]), int(z[-1]) + 1) for z in nz)
            self._mg = GridMultigrid(solid[self._crop], self.free[self._crop], self.spacing, self.connectivity,
                                     stencil=stencil_weights, rtol=self.tol, maxiter=self.maxiter)
            self.report["levels"] = self._mg.report["levels"]
        elif unknowns:
            self._sparse(self.solver)
        self.report["seconds"] = {"check": t - t0, "setup": time.perf_counter() - t}

    def _sparse(self, solver):
        """The sparse Laplacian of the solid and the solve core on it (built once)."""
        if self._quad is None:
            solid = self.mask & ~self.empty
            unknowns = int(self.free.sum())
            check_fits(fill_memory(self.mask.shape, unknowns, solver, self.connectivity),
                       f"the harmonic fill of {unknowns:,} voxels ({solver})",
                       "lower the resolution (CLI --resolution) or crop the grid to the solid")
            # the spacing brought to about unit size: the same solution, weights that neither
            # overflow nor underflow for voxels of 1e-150 or 1e150
            L = voxel_laplacian(solid, unit_spacing(self.spacing), self.connectivity)
            idx = np.flatnonzero(self.fixed[solid])
            self._quad = QuadraticSolver(L, idx, solver=solver, tol=self._tol_arg, maxiter=self._maxiter_arg,
                                       symmetric_pattern=True, what="the voxel Laplacian")
            self._solid = solid

    def solve(self, vals: ArrayLike) -> np.ndarray:
        """The harmonic fill for the given values at the fixed voxels.

        Parameters
        ----------
        vals : (k,) or (k, p) array_like of float
            One value, or one row of ``p`` fields, per voxel of ``voxels``, in
            its order.

        Returns
        -------
        (n0, n1, n2) or (n0, n1, n2, p) float64 numpy array
            Equal to ``vals`` at the fixed voxels, harmonic at the free ones,
            NaN outside the mask (and in parts without fixed voxels).

        Raises
        ------
        SampleError
            ``vals`` not one finite value (or row) per voxel.
        SolveError
            The multigrid did not converge (not with ``solver='auto'``, which
            falls back to ``amg``).
        """
        t = time.perf_counter()
        bc, squeeze = as_values(vals, len(self.voxels), what="vals")
        bc = bc[self._order]
        out = np.full(self.mask.shape + (bc.shape[1],), np.nan)
        out[self.fixed] = bc
        iterations = []
        for j in range(bc.shape[1]):
            x = None
            if self._mg is not None:
                g = np.zeros(self.mask.shape)
                g[self.fixed] = bc[:, j]
                X, info = self._mg.solve(self._mg.rhs(self._mg.pad(g[self._crop])))
                x, it, rel = X[:, 0], info["iterations"][0], info["residuals"][0]
                iterations.append(it)
                if rel <= self.tol:
                    free = self.free[self._crop]
                    out[..., j][self._crop][free] = self._mg.unpad(x)[free]
                elif not self._auto or it >= self.maxiter:
                    raise SolveError(f"the multigrid fill stopped at relative residual {rel:.1e} after {it} "
                                     f"iterations (asked: {self.tol:.0e}); use solver='amg', raise maxiter or "
                                     f"loosen tol")
                else:
                    # the grid hierarchy lost the fixed voxels (e.g. a few isolated ones): sparse AMG instead
                    x = None
                    self._sparse("amg")
                    self.report["fallback"] = f"amg (multigrid stalled at {rel:.1e} after {it} iterations)"
            if x is None and self._quad is not None:
                xs = self._quad.solve(bc[:, j])
                field = out[..., j]
                field[self._solid] = xs
                iterations.extend(self._quad.report.get("iterations", []))
        self.report["iterations"] = iterations
        self.report["seconds"]["solve"] = time.perf_counter() - t
        return out[..., 0] if squeeze else out


def harmonic_fill(mask: ArrayLike, voxels: ArrayLike, vals: ArrayLike, *, spacing: ArrayLike = (1.0, 1.0, 1.0),
                  connectivity: int = 6, solver: str = "auto", on_empty: str = "error", tol: float | None = None,
                  maxiter: int | None = None) -> np.ndarray:
    """Fill a voxel solid harmonically from fixed voxels (the paper's Step 8).

    Parameters
    ----------
    mask : (n0, n1, n2) bool array_like
        The solid.
    voxels : (k, 3) array_like of int
        Grid indices of the voxels with given values, inside ``mask``, each
        once (e.g. ``np.argwhere(boundary_voxels(mask))``, from
        :func:`manifill.solid.boundary.boundary_voxels`).
    vals : (k,) or (k, p) array_like of float
        Their values, in the order of ``voxels``: one column per field.
    spacing, connectivity, solver, on_empty, tol, maxiter
        See :class:`VoxelFill`.

    Returns
    -------
    (n0, n1, n2) or (n0, n1, n2, p) float64 numpy array
        NaN outside the mask.

    See Also
    --------
    VoxelFill : the same, precomputed for several fields.
    manifill.solid.reconstruct_volume : Steps 1-8 from samples on a surface.

    Examples
    --------
    >>> mask = np.ones((4, 4, 9), dtype=bool)
    >>> fixed = np.zeros_like(mask); fixed[..., 0] = fixed[..., -1] = True
    >>> z = np.indices(mask.shape)[2] * 2.5
    >>> x = harmonic_fill(mask, np.argwhere(fixed), z[fixed], spacing=(1, 1, 2.5))
    >>> bool(np.allclose(x, z))
    True
    """
    return VoxelFill(mask, voxels, spacing=spacing, connectivity=connectivity, solver=solver, on_empty=on_empty,
                     tol=tol, maxiter=maxiter).solve(vals)


def tet_fill(V: ArrayLike, T: ArrayLike, idx: ArrayLike, vals: ArrayLike, *, weights: str = "cotan",
             solver: str = "auto", on_empty: str = "error", tol: float | None = None,
             maxiter: int | None = None) -> np.ndarray:
    """Fill a tetrahedral solid harmonically from fixed vertices.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    T : (m, 4) array_like of int
        Tetrahedra.
    idx : (k,) array_like of int
        Fixed vertices (e.g. the vertices of :func:`manifill.solid.tets.boundary_faces`).
    vals : (k,) or (k, p) array_like of float
        Their values.
    weights : {'cotan', 'uniform'}, optional
        The finite-element stiffness (reproduces linear functions on any tet
        mesh) or 1 per edge (the paper's average; keeps the maximum principle).
    solver, on_empty, tol, maxiter
        As :class:`manifill.HarmonicSolver` (the fill is the solve core,
        :class:`manifill.linalg.quadratic.QuadraticSolver`, on the tet Laplacian).

    Returns
    -------
    (n,) or (n, p) float64 numpy array

    Raises
    ------
    ResourceError
        The fill is predicted not to fit in the memory available
        (:func:`tet_fill_memory`); checked before the Laplacian is built.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> from manifill.solid.tetrahedralize import tetrahedralize
    >>> V, F = icosphere(2)
    >>> TV, TT = tetrahedralize(V, F)
    >>> x = tet_fill(TV, TT, np.arange(len(V)), V[:, 0])
    >>> bool(np.allclose(x, TV[:, 0]))
    True
    """
    V, T = as_tets(V, T, allow_degenerate=weights == "uniform")
    idx = as_indices(idx, len(V), what="idx")
    check_option("solver", solver, SOLVERS)
    n_fixed = len(np.unique(idx))
    free = len(V) - n_fixed
    coarser = "a coarser tetrahedral mesh (CLI: raise --max-volume)"
    factorised = solver == "direct" or (solver == "auto" and free <= _AUTO_DIRECT_MAX)
    check_fits(tet_fill_memory(len(V), len(T), n_fixed, solver), f"the harmonic fill of {free:,} tet vertices "
               f"({solver})", f"use solver='amg' (CLI --fill-solver amg) or {coarser}" if factorised
               else f"use {coarser}")
    # the one harmonic fill of tetrahedra (manifill.harmonic(V, T) is the same solver)
    return HarmonicSolver(V, T, idx, weights=weights, solver=solver, on_empty=on_empty, tol=tol,
                          maxiter=maxiter).solve(vals)
