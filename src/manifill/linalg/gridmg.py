"""Geometric multigrid on a voxel grid: the harmonic fill of large solids in little memory.

The Dirichlet problem on the voxels of a mask (Step 8) is solved by conjugate
gradients preconditioned with a geometric V-cycle, all matrix-free on 3-D
arrays: no sparse matrix of the fine grid is ever built. Every level is the same
stencil on a grid twice as coarse along the axes that are coarsened
(:mod:`manifill.linalg.gridlevels`); anisotropic spacing coarsens only the finer
axes until the voxels are nearly cubic (semi-coarsening). Transfers are
trilinear interpolation and its transpose (full weighting); the smoother is
damped Jacobi; the coarsest grid is solved exactly by a sparse LU. The cycle is
symmetric, so plain CG applies. The cycle runs in single precision and CG in
double, which keeps the result to the requested residual. The spacing is first
divided by a power of two that brings it to about unit size: a common factor of
all weights does not change the solution, and weights of ``1 / h**2`` for voxels
of ``1e30`` (or ``1e-30``) would be beyond single precision.

The stencil is the caller's: a function ``stencil(spacing, connectivity)``
returning the neighbour offsets and their weights
(:func:`manifill.solid.voxels.stencil_weights` for the fill of Step 8), so this
module knows grids and multigrid, not the geometry of voxels. The conjugate
gradients are the loop of :func:`manifill.linalg.pcg.pcg`, with this module's
threaded inner products and vector updates; the threads are those of
:func:`manifill.linalg.threads.workers`.

:class:`GridMultigrid` is a solver backend like those of
:mod:`manifill.linalg.backends` (``name``, ``setup_seconds``, ``solve(R, x0)``
returning ``(X, info)``), for the Dirichlet problem of
:class:`manifill.solid.fill.VoxelFill`, on vectors of the padded grid.
"""

import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import scipy.sparse as sp
from scipy import ndimage
from scipy.sparse.linalg import splu

from ..tolerances import TOL
from ..validate import unit_scale
from .gridlevels import Level, coarse_axes, free_matrix, prolong_axis, restrict_axis, wall_weights
from .pcg import Kernels, pcg
from .threads import workers as thread_count

__all__ = ["GridMultigrid"]

#: Unknowns at or below which a level is solved directly.
COARSE_MAX = 4000
#: CG iterations over which the residual must at least halve (else the solve stops as stalled).
STALL = 20


class GridMultigrid:
    """CG with a geometric multigrid V-cycle for ``A x = r`` on the free voxels of a mask.

    A solver backend (as those of :mod:`manifill.linalg.backends`) whose
    vectors are flat padded grids (:meth:`pad`, :meth:`unpad`).

    Parameters
    ----------
    domain : (n0, n1, n2) bool numpy array
        The solid: voxels that exist (edges to voxels outside it are absent).
    free : (n0, n1, n2) bool numpy array
        The unknown voxels, a subset of ``domain``; the others in ``domain``
        are fixed (Dirichlet).
    spacing : (3,) array_like of float
        Voxel size per axis, positive, of any magnitude: the operator is built
        on the spacing divided by a power of two of about its size (the same
        solution).
    connectivity : {6, 18, 26}
        Neighbours per voxel; with 6, the smoother is red-black Gauss-Seidel.
    stencil : callable
        ``stencil(spacing, connectivity)`` returns ``(offsets, w)``: the
        ``(c // 2, 3)`` integer offsets ``d`` (one of each pair ``+-d``) and
        their positive weights (e.g. :func:`manifill.solid.voxels.stencil_weights`).
    rtol : float, optional
        Relative residual ``|r - A x| / |r|`` at which :meth:`solve` stops;
        defaults to ``TOL.grid_rtol``.
    maxiter : int, optional
        Iteration cap of :meth:`solve` (default 200).
    workers : int, optional
        Threads for the stencil passes (default
        :func:`manifill.linalg.threads.workers`).

    Attributes
    ----------
    name : str
        ``"multigrid"``.
    levels : list
        The grids, finest first.
    report : dict
        ``levels`` and ``unknowns`` per level.
    setup_seconds : float
        Time to build the hierarchy.
    """

    name = "multigrid"

    def __init__(self, domain, free, spacing=(1.0, 1.0, 1.0), connectivity=6, *, stencil, rtol=None,
                 maxiter=None, workers=None):
        t0 = time.perf_counter()
        self.rtol = TOL.grid_rtol if rtol is None else float(rtol)
        self.maxiter = 200 if maxiter is None else int(maxiter)
        workers = workers or thread_count()
        self._pool = ThreadPoolExecutor(workers) if workers > 1 else None
        self.shape = domain.shape
        # weights of about unit size: A and rhs() are the physical ones times one power of four
        spacing = np.asarray(spacing, dtype=np.float64)
        spacing = spacing / unit_scale(spacing[None])
        self.fine = Level(domain, free, spacing, connectivity, stencil, np.float64, self._pool)
        self.levels = [Level(domain, free, spacing, connectivity, stencil, np.float32, self._pool)]
        self.axes = []
        dom, fr, h = domain, free, np.asarray(spacing, dtype=np.float64)
        while self.levels[-1].unknowns > COARSE_MAX:
            ax = coarse_axes(h, dom.shape)
            if not ax.any():
                break
            sl = tuple(slice(0, None, 2) if a else slice(None) for a in ax)
            # a coarse point is in the solid when a fine point next to it is: the fixed
            # layer around the free voxels, one voxel thick, then stays a Dirichlet wall
            # on the coarse grid instead of vanishing into "outside" (which would let
            # the coarse problem float and the cycle diverge)
            fixed = dom & ~fr
            dom = ndimage.binary_dilation(dom, ndimage.generate_binary_structure(3, 1))[sl]
            fr = fr[sl]
            h = np.where(ax, 2 * h, h)
            self.axes.append(ax)
            self.levels.append(Level(dom, fr, h, connectivity, stencil, np.float32, self._pool,
                                      extra=wall_weights(fixed, fr, ax, h, connectivity, stencil)))
        last = self.levels[-1]
        self._coarse_ids = np.flatnonzero(last.free)
        self._coarse_lu = None
        if self._coarse_ids.size:
            # the free voxels' matrix, with the full diagonal: weights towards fixed voxels included
            inner = last.free.reshape(last.padded)[1:-1, 1:-1, 1:-1]
            d = last.diag[self._coarse_ids].astype(np.float64)
            self._coarse_lu = splu(sp.csc_matrix(free_matrix(inner, last.spacing, connectivity, stencil, d)))
        self.report = {"levels": len(self.levels), "unknowns": [lv.unknowns for lv in self.levels]}
        self.setup_seconds = time.perf_counter() - t0

    def __del__(self):
        if getattr(self, "_pool", None) is not None:
            self._pool.shutdown(wait=False)

    def pad(self, a, dtype=np.float64):
        """An (n0, n1, n2) array as a flat padded vector."""
        return np.pad(np.asarray(a, dtype=dtype), 1).ravel()

    def unpad(self, x):
        """A flat padded vector as an (n0, n1, n2) array."""
        return x.reshape(tuple(n + 2 for n in self.shape))[1:-1, 1:-1, 1:-1]

    def rhs(self, g):
        """Right-hand side from fixed values: ``sum_d w_d g[i + d]`` at the free voxels (``-A_Ib g``).

        Parameters
        ----------
        g : flat padded numpy array
            Values at the fixed voxels, zero elsewhere.
        """
        return self.fine.apply(g, sign=-1.0)  # the diagonal is zero where g is not

    # -- the V-cycle (single precision) -----------------------------------------------
    def _buffers(self, lv):
        """Work arrays of a level, allocated once (fresh large arrays cost page faults every cycle)."""
        if not hasattr(lv, "bx"):
            lv.bx = np.zeros(lv.free.size, dtype=lv.dtype)   # the level's correction
            lv.bres = np.zeros(lv.free.size, dtype=lv.dtype)  # its residual
            lv.br = np.zeros(lv.free.size, dtype=lv.dtype)    # its right-hand side (coarse levels)
        return lv.bx, lv.bres, lv.br

    def _cycle(self, k, r):
        lv = self.levels[k]
        x, res, _ = self._buffers(lv)
        if k == len(self.levels) - 1:
            x.fill(0)
            if self._coarse_lu is not None:
                x[self._coarse_ids] = self._coarse_lu.solve(r[self._coarse_ids].astype(np.float64))
            return x
        if lv.colours is None:
            x.fill(0)
        lv.smooth(x, r, +1, zero=True)
        lv.apply(x, out=res)
        np.subtract(r, res, out=res)
        c = res.reshape(lv.padded)[1:-1, 1:-1, 1:-1]
        for a in np.flatnonzero(self.axes[k]):
            c = restrict_axis(c, a)
        nxt = self.levels[k + 1]
        rc = self._buffers(nxt)[2]
        rc.reshape(nxt.padded)[1:-1, 1:-1, 1:-1] = c  # the zero border stays
        rc *= nxt.free_f
        xc = self._cycle(k + 1, rc).reshape(nxt.padded)[1:-1, 1:-1, 1:-1]
        for a in np.flatnonzero(self.axes[k])[::-1]:
            xc = prolong_axis(xc, a, lv.shape[a])
        x.reshape(lv.padded)[1:-1, 1:-1, 1:-1] += xc
        x *= lv.free_f
        lv.smooth(x, r, -1)
        return x

    def precondition(self, r, out=None):
        """One V-cycle applied to a residual (double in, double out)."""
        if not hasattr(self, "_r32"):
            self._r32 = np.empty(r.size, dtype=np.float32)
        self.fine.chunks.run(lambda lo, hi: np.copyto(self._r32[lo:hi], r[lo:hi], casting="same_kind"))
        lo, hi = self.fine.chunks.ranges[0][0], self.fine.chunks.ranges[-1][1]
        self._r32[:lo] = 0
        self._r32[hi:] = 0
        z = self._cycle(0, self._r32)
        out = np.empty(r.size) if out is None else out
        self.fine.chunks.run(lambda lo, hi: np.copyto(out[lo:hi], z[lo:hi]))
        out[:lo] = 0
        out[hi:] = 0
        return out

    def _dot(self, a, b):
        return float(sum(self.fine.chunks.run(lambda lo, hi: np.dot(a[lo:hi], b[lo:hi]))))

    def pcg(self, rhs):
        """CG preconditioned by one V-cycle for ``A x = rhs``, from ``x = 0``: ``(x, PCGResult)``.

        The loop of :func:`manifill.linalg.pcg.pcg`, with inner products and
        vector updates on the threads' ranges of the grid; it stops at
        ``rtol``, at ``maxiter``, or when the residual did not halve in
        ``STALL`` iterations (``status='stalled'``; a singular coarse problem,
        whose cycle is then only semi-definite, ends so too).
        """
        A = self.fine
        x = np.zeros_like(rhs)
        r = rhs.copy()
        norm0 = np.sqrt(self._dot(r, r))
        if norm0 == 0:
            return x, None
        q = np.empty_like(r)
        scratch = np.empty_like(r)
        z = [None]  # one buffer, allocated by the first cycle

        def precondition(v, _):
            z[0] = self.precondition(v, out=z[0])
            return z[0]

        def matvec(v):
            return A.apply(v, out=q)

        def update(alpha, p, q):
            def part(lo, hi):
                t = np.multiply(p[lo:hi], alpha, out=scratch[lo:hi])
                x[lo:hi] += t
                np.multiply(q[lo:hi], alpha, out=t)
                r[lo:hi] -= t
                return np.dot(r[lo:hi], r[lo:hi])

            return float(np.sqrt(sum(A.chunks.run(part))))

        def direction(beta, p, z):
            def part(lo, hi):
                p[lo:hi] *= beta
                p[lo:hi] += z[lo:hi]

            A.chunks.run(part)

        res = pcg(matvec, r, x, precondition=precondition, rtol=self.rtol, maxiter=self.maxiter, norm0=norm0,
                  stall=STALL, breakdown=False, kernels=Kernels(inner=self._dot, update=update, direction=direction))
        return x, res

    def solve(self, R, x0=None):
        """Solve ``A X = R`` on the free voxels, column by column.

        Parameters
        ----------
        R : (P,) or (P, p) numpy array
            Right-hand side(s) on the padded grid, flat (C order, ``P = (n0 +
            2) (n1 + 2) (n2 + 2)``), zero outside the free voxels (e.g.
            :meth:`rhs`).
        x0 : ignored
            The iteration starts from zero (accepted for a uniform interface).

        Returns
        -------
        X : (P, p) numpy array
            Flat and padded like ``R``, zero outside the free voxels.
        info : dict
            ``solver``; ``iterations``, ``residuals`` (relative, reached) and
            ``status`` (of :class:`manifill.linalg.pcg.PCGResult`), one per
            column. A column that stalled or hit ``maxiter`` is reported, not
            raised: the caller decides (:class:`manifill.solid.fill.VoxelFill`
            falls back to AMG).
        """
        R = np.asarray(R, dtype=np.float64)
        single = R.ndim == 1
        R = R[:, None] if single else R
        X = None if single else np.zeros(R.shape)
        info = {"solver": self.name, "iterations": [], "residuals": [], "status": []}
        for j in range(R.shape[1]):
            x, res = self.pcg(np.ascontiguousarray(R[:, j]))
            if single:
                X = x[:, None]
            else:
                X[:, j] = x
            info["iterations"].append(0 if res is None else res.iterations)
            info["residuals"].append(0.0 if res is None else res.residual)
            info["status"].append("converged" if res is None else res.status)
        return X, info
