"""Step 8: the harmonic fill of a solid, in voxel form and in tetrahedral form.

With the values fixed on some voxels (usually the boundary surface D, from
Steps 1-6), every other voxel of the solid gets the weighted average of its
neighbours (:mod:`manifill.solid.voxels` for the neighbours and weights): the discrete
Dirichlet problem, solved by geometric multigrid on the grid
(:mod:`manifill.linalg.gridmg`) or, on request, by the sparse solvers of the
surface. Tetrahedral solids use the tetrahedral Laplacians of
:mod:`manifill.solid.tets` and the surface's solver.

Before a large solve the memory it needs is estimated, and a problem that would
not fit is refused (:class:`~manifill.errors.ResourceError`) instead of being
killed by the system.
"""

import time

import numpy as np

from ..errors import SampleError, SolveError
from ..linalg.gridmg import GridMultigrid
from ..surface.harmonic import ON_EMPTY, HarmonicSolver
from ..linalg.backends import SOLVERS
from ..memory import check_fits, lu_memory
from .tets import tet_laplacian
from ..validate import as_indices, as_mask, as_values, as_tets, check_option, unit_scale
from .voxels import unit_spacing, as_connectivity, as_spacing, voxel_components, voxel_laplacian

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
    fixed : (n0, n1, n2) bool array_like
        Voxels whose values are given, inside ``mask``.
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
        assemble the sparse Laplacian and use the surface's solvers.
    on_empty : {'error', 'nan'}, optional
        A connected part of the solid with no fixed voxel: raise, or leave it NaN.
    tol : float, optional
        Relative residual (default ``1e-10``).
    maxiter : int, optional

    Attributes
    ----------
    free : (n0, n1, n2) bool numpy array
        The voxels that are solved for.
    report : dict
        Counts, the solver, levels, iterations and seconds.

    Raises
    ------
    SampleError, OptionError
        Malformed masks, spacing or options; fixed voxels outside the mask.
    SolveError
        A connected part without fixed voxels (``on_empty='error'``).
    ResourceError
        The solve is predicted not to fit in the available memory.

    Examples
    --------
    >>> mask = np.ones((5, 5, 5), dtype=bool)
    >>> fixed = np.zeros_like(mask); fixed[0] = fixed[-1] = True
    >>> x = VoxelFill(mask, fixed).solve(np.indices(mask.shape)[0] * 1.0)
    >>> x[:, 2, 2].round(10).tolist()
    [0.0, 1.0, 2.0, 3.0, 4.0]
    """

    def __init__(self, mask, fixed, *, spacing=(1.0, 1.0, 1.0), connectivity=6, solver="auto", on_empty="error",
                 tol=None, maxiter=None):
        t0 = time.perf_counter()
        check_option("solver", solver, FILL_SOLVERS)
        check_option("on_empty", on_empty, ON_EMPTY)
        self.connectivity = as_connectivity(connectivity)
        self.spacing = as_spacing(spacing)
        self.mask = as_mask(mask)
        self.fixed = as_mask(fixed, what="fixed", shape=self.mask.shape)
        outside = self.fixed & ~self.mask
        if outside.any():
            v = tuple(int(c) for c in np.argwhere(outside)[0])
            raise SampleError(f"{int(outside.sum())} fixed voxels lie outside the mask (e.g. voxel {v}); "
                              f"fix only voxels of the solid")
        self.tol = 1e-10 if tol is None else float(tol)
        self.maxiter = 500 if maxiter is None else int(maxiter)
        self.solver = "multigrid" if solver == "auto" else solver
        # before anything grid-sized: at most the voxels of the mask that are not fixed are unknown
        unknowns = int(np.count_nonzero(self.mask)) - int(np.count_nonzero(self.fixed))
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
        self._mg = self._hs = None
        if unknowns and self.solver == "multigrid":
            # the grid cropped to the solid: empty margins cost memory and time in every pass
            solid = self.mask & ~empty
            nz = [np.flatnonzero(solid.any(axis=tuple(b for b in range(3) if b != a))) for a in range(3)]
            self._crop = tuple(slice(int(z[0]), int(z[-1]) + 1) for z in nz)
            self._mg = GridMultigrid(solid[self._crop], self.free[self._crop], self.spacing, self.connectivity)
            self.report["levels"] = self._mg.report["levels"]
        elif unknowns:
            self._sparse(self.solver)
        self.report["seconds"] = {"check": t - t0, "setup": time.perf_counter() - t}

    def _sparse(self, solver):
        """The sparse Laplacian of the solid and a surface-style solver on it (built once)."""
        if self._hs is None:
            solid = self.mask & ~self.empty
            unknowns = int(self.free.sum())
            check_fits(fill_memory(self.mask.shape, unknowns, solver, self.connectivity),
                       f"the harmonic fill of {unknowns:,} voxels ({solver})",
                       "lower the resolution (CLI --resolution) or crop the grid to the solid")
            # the spacing brought to about unit size: the same solution, weights that neither
            # overflow nor underflow for voxels of 1e-150 or 1e150
            L = voxel_laplacian(solid, unit_spacing(self.spacing), self.connectivity)
            b = np.flatnonzero(self.fixed[solid])
            self._hs = HarmonicSolver.from_laplacian(L, b, solver=solver, tol=self._tol_arg,
                                                     maxiter=self._maxiter_arg, symmetric_pattern=True)
            self._solid = solid

    def solve(self, values):
        """The harmonic fill for the given fixed values.

        Parameters
        ----------
        values : array_like of float
            Shaped like the mask (read at the fixed voxels), optionally with a
            trailing axis of ``p`` fields; or ``(k,)`` / ``(k, p)`` with one row
            per fixed voxel in C order (``np.argwhere(fixed)``).

        Returns
        -------
        (n0, n1, n2) or (n0, n1, n2, p) float64 numpy array
            Equal to ``values`` at the fixed voxels, harmonic at the free ones,
            NaN outside the mask (and in parts without fixed voxels).
        """
        t = time.perf_counter()
        k = int(self.fixed.sum())
        try:
            arr = np.asarray(values, dtype=np.float64) if not isinstance(values, np.ndarray) else values
        except (TypeError, ValueError):
            raise SampleError("values could not be read as numbers; pass a float array shaped like the mask, "
                              "or (k,) / (k, p) values per fixed voxel") from None
        if arr.shape[:3] == self.mask.shape and arr.ndim in (3, 4):
            arr = arr[self.fixed]
        bc, squeeze = as_values(arr, k, what="values")
        out = np.full(self.mask.shape + (bc.shape[1],), np.nan)
        out[self.fixed] = bc
        iterations = []
        for j in range(bc.shape[1]):
            x = None
            if self._mg is not None:
                g = np.zeros(self.mask.shape)
                g[self.fixed] = bc[:, j]
                x, it, rel = self._mg.solve(self._mg.rhs(self._mg.pad(g[self._crop])), tol=self.tol,
                                            maxiter=self.maxiter)
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
            if x is None and self._hs is not None:
                xs = self._hs.solve(bc[:, j])
                field = out[..., j]
                field[self._solid] = xs
                iterations.extend(self._hs.report.get("iterations", []))
        self.report["iterations"] = iterations
        self.report["seconds"]["solve"] = time.perf_counter() - t
        return out[..., 0] if squeeze else out


def harmonic_fill(mask, fixed, values, *, spacing=(1.0, 1.0, 1.0), connectivity=6, solver="auto", on_empty="error",
                  tol=None, maxiter=None):
    """Fill a voxel solid harmonically from fixed voxels (the paper's Step 8).

    Parameters
    ----------
    mask : (n0, n1, n2) bool array_like
        The solid.
    fixed : (n0, n1, n2) bool array_like
        Voxels with given values (e.g. :func:`manifill.solid.voxels.boundary_voxels`).
    values : array_like of float
        Shaped like ``mask`` (read at ``fixed``; a trailing axis for several
        fields), or ``(k,)`` / ``(k, p)`` per fixed voxel in C order.
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
    >>> x = harmonic_fill(mask, fixed, z, spacing=(1, 1, 2.5))
    >>> bool(np.allclose(x, z))
    True
    """
    return VoxelFill(mask, fixed, spacing=spacing, connectivity=connectivity, solver=solver, on_empty=on_empty,
                     tol=tol, maxiter=maxiter).solve(values)


def tet_fill(V, T, b, bc, *, weights="cotan", solver="auto", on_empty="error", tol=None, maxiter=None):
    """Fill a tetrahedral solid harmonically from fixed vertices.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    T : (m, 4) array_like of int
        Tetrahedra.
    b : (k,) array_like of int
        Fixed vertices (e.g. the vertices of :func:`manifill.solid.tets.boundary_faces`).
    bc : (k,) or (k, p) array_like of float
        Their values.
    weights : {'cotan', 'uniform'}, optional
        The finite-element stiffness (reproduces linear functions on any tet
        mesh) or 1 per edge (the paper's average; keeps the maximum principle).
    solver, on_empty, tol, maxiter
        As :class:`manifill.HarmonicSolver`.

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
    >>> from manifill.solid.tets import tetrahedralize
    >>> V, F = icosphere(2)
    >>> TV, TT = tetrahedralize(V, F)
    >>> x = tet_fill(TV, TT, np.arange(len(V)), V[:, 0])
    >>> bool(np.allclose(x, TV[:, 0]))
    True
    """
    V, T = as_tets(V, T, allow_degenerate=weights == "uniform")
    b = as_indices(b, len(V))
    check_option("solver", solver, SOLVERS)
    n_fixed = len(np.unique(b))
    free = len(V) - n_fixed
    coarser = "a coarser tetrahedral mesh (CLI: raise --max-volume)"
    factorised = solver == "direct" or (solver == "auto" and free <= _AUTO_DIRECT_MAX)
    check_fits(tet_fill_memory(len(V), len(T), n_fixed, solver), f"the harmonic fill of {free:,} tet vertices "
               f"({solver})", f"use solver='amg' (CLI --fill-solver amg) or {coarser}" if factorised
               else f"use {coarser}")
    # the stiffness has units of length: on V / s (s a power of two, 1 for the usual sizes) it is the
    # same matrix divided by s, exactly, with the same solution and entries of about unit size
    L = tet_laplacian(V / unit_scale(V), T, weights=weights)
    return HarmonicSolver.from_laplacian(L, b, solver=solver, on_empty=on_empty, tol=tol, maxiter=maxiter,
                                         symmetric_pattern=True).solve(bc)
