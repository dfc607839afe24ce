"""Geometric multigrid on a voxel grid: the harmonic fill of large solids in little memory.

The Dirichlet problem on the voxels of a mask (Step 8) is solved by conjugate
gradients preconditioned with a geometric V-cycle, all matrix-free on 3-D
arrays: no sparse matrix of the fine grid is ever built. Every level is the same
stencil (:func:`manifill.solid.voxels.stencil_weights`) on a grid twice as coarse
along the axes that are coarsened; anisotropic spacing coarsens only the finer
axes until the voxels are nearly cubic (semi-coarsening). Transfers are
trilinear interpolation and its transpose (full weighting); the smoother is
damped Jacobi; the coarsest grid is solved exactly by a sparse LU. The cycle is
symmetric, so plain CG applies. The cycle runs in single precision and CG in
double, which keeps the result to the requested residual. The spacing is first
divided by a power of two that brings it to about unit size: a common factor of
all weights does not change the solution, and weights of ``1 / h**2`` for voxels
of ``1e30`` (or ``1e-30``) would be beyond single precision.
"""

import os
from concurrent.futures import ThreadPoolExecutor
from functools import partial

import numpy as np
import scipy.sparse as sp
from scipy import ndimage
from scipy.sparse.linalg import splu

from ..solid.voxels import unit_spacing, stencil_weights, voxel_laplacian

__all__ = ["GridMultigrid"]

#: Damping of the Jacobi smoother used with 18 and 26 neighbours.
OMEGA = 0.7
#: Unknowns at or below which a level is solved directly.
COARSE_MAX = 4000
#: Jacobi sweeps before and after the coarse-grid correction (18 and 26 neighbours).
SWEEPS = 2
#: Red-black Gauss-Seidel sweeps before and after (6 neighbours).
RB_SWEEPS = 2
#: CG iterations over which the residual must at least halve (else the solve stops as stalled).
STALL = 20
#: Grid points per thread below which a level runs on one thread.
_CHUNK = 1_000_000


class _Chunks:
    """The index range of a flat padded grid that holds voxels, split for threads.

    Each stencil pass is a handful of NumPy operations on contiguous slices,
    which release the GIL; a level with several million points runs them on
    every core, one range per thread.
    """

    def __init__(self, size, margin, pool):
        lo, hi = margin, size - margin
        k = max(1, min(pool._max_workers if pool else 1, (hi - lo) // _CHUNK))
        bounds = np.linspace(lo, hi, k + 1).astype(np.int64)
        self.ranges = list(zip(bounds[:-1].tolist(), bounds[1:].tolist()))
        self.pool = pool if k > 1 else None

    def run(self, fn):
        if self.pool is None:
            return [fn(lo, hi) for lo, hi in self.ranges]
        return list(self.pool.map(lambda r: fn(*r), self.ranges))


class _Level:
    """One grid: masks, stencil and diagonal as flat arrays of the grid padded by a zero layer.

    On the flat padded array a neighbour offset is a fixed shift of the index, so
    every stencil term is one contiguous slice operation. The first and last
    ``margin`` entries are padding, so shifted reads never leave the array.
    """

    def __init__(self, domain, free, spacing, connectivity, dtype, pool, extra=None):
        self.shape = domain.shape
        self.padded = tuple(n + 2 for n in domain.shape)
        self.spacing = np.asarray(spacing, dtype=np.float64)
        self.dtype = dtype
        offsets, w = stencil_weights(self.spacing, connectivity)
        strides = np.array([self.padded[1] * self.padded[2], self.padded[2], 1])
        shifts = offsets @ strides
        # offsets of equal weight share one multiply
        self.groups = [(dtype(wd), [int(o) for o in shifts[w == wd]]) for wd in np.unique(w)]
        size = int(np.prod(self.padded))
        self.chunks = _Chunks(size, int(strides.sum()), pool)
        self.free = np.pad(free, 1).ravel()
        self.free_f = self.free.astype(dtype)
        self._tmp = np.zeros(size, dtype=dtype)
        diag = np.zeros(size, dtype=dtype)
        dom = np.pad(domain, 1).ravel().astype(dtype)
        self.diag = np.zeros(size, dtype=dtype)
        self.apply(dom, out=diag, sign=-1.0, masked=False)  # sum of the weights towards the solid
        if extra is not None:
            diag += np.pad(extra, 1).ravel().astype(dtype)
        self.diag = diag * self.free_f
        self.inv_diag = np.divide(1.0, self.diag, out=np.zeros_like(diag), where=self.diag > 0)
        self.unknowns = int(free.sum())
        self.colours = None
        self.sweeps = SWEEPS
        if connectivity == 6:
            self.sweeps = RB_SWEEPS
            # red-black Gauss-Seidel: with face neighbours only, a colour's voxels are independent,
            # and one colour's update is x = (r + sum_d w_d x[i + d]) / diag there
            i, j, k = np.indices(self.padded, sparse=True)
            even = ((i + j + k) % 2 == 0).ravel()
            self.colours = [(even, (even * self.inv_diag).astype(dtype)),
                            (~even, (~even * self.inv_diag).astype(dtype))]

    def _apply_range(self, x, y, lo, hi, sign=1.0, masked=True):
        ys = y[lo:hi]
        np.multiply(self.diag[lo:hi], x[lo:hi], out=ys)
        t = self._neighbours_range(x, lo, hi)
        if sign > 0:
            ys -= t
        else:
            ys += t
        if masked:
            ys *= self.free_f[lo:hi]
        return ys

    def apply(self, x, out=None, sign=1.0, masked=True):
        """``A x`` on the free voxels for ``x`` zero elsewhere (fixed values move to the right side).

        With ``sign=-1`` and ``masked=False``: ``sum_d w_d (x[i + d] + x[i - d])`` everywhere.
        """
        y = np.zeros_like(x) if out is None else out
        lo, hi = self.chunks.ranges[0][0], self.chunks.ranges[-1][1]
        y[:lo] = 0
        y[hi:] = 0
        self.chunks.run(lambda lo, hi: self._apply_range(x, y, lo, hi, sign, masked))
        return y

    def _neighbours_range(self, x, lo, hi):
        """``sum_d w_d (x[i + d] + x[i - d])`` on ``lo:hi``, in the scratch array."""
        t = self._tmp[lo:hi]
        for g, (wd, shifts) in enumerate(self.groups):
            part = t if g == 0 else np.empty_like(t)
            np.add(x[lo + shifts[0]:hi + shifts[0]], x[lo - shifts[0]:hi - shifts[0]], out=part)
            for o in shifts[1:]:
                part += x[lo + o:hi + o]
                part += x[lo - o:hi - o]
            part *= wd
            if g:
                t += part
        return t

    def smooth(self, x, r, order, zero=False):
        """Half of the symmetric smoothing: red then black (``order=+1``) or back, or damped Jacobi.

        ``zero`` says that ``x`` is zero on entry (the first sweep is then one product).
        """
        if self.colours is not None:
            colours = self.colours[::order]

            def sweep(lo, hi, colour, scale):
                # updating one colour reads only the other: the ranges may run at once
                t = self._neighbours_range(x, lo, hi)
                t += r[lo:hi]
                t *= scale[lo:hi]
                np.copyto(x[lo:hi], t, where=colour[lo:hi])

            for s in range(self.sweeps):
                for c, (colour, scale) in enumerate(colours):
                    if zero and s == 0 and c == 0:
                        self.chunks.run(lambda lo, hi, scale=scale: np.multiply(r[lo:hi], scale[lo:hi],
                                                                                  out=x[lo:hi]))
                    else:
                        self.chunks.run(partial(sweep, colour=colour, scale=scale))
            return x
        res = np.empty_like(x)
        for _ in range(self.sweeps):
            self.apply(x, out=res)
            np.subtract(r, res, out=res)
            res *= self.inv_diag
            res *= OMEGA
            x += res
        return x


def _coarse_axes(spacing, shape):
    """Axes to coarsen: the finer ones (within a factor 1.5 of the finest), if long enough."""
    h = np.asarray(spacing)
    long = np.array([n > 4 for n in shape])
    if not long.any():
        return np.zeros(3, dtype=bool)
    finest = h[long].min()
    return long & (h <= 1.5 * finest)


def _wall_weights(fixed, free_c, axes, h_c, connectivity):
    """Extra coarse diagonal where a fixed fine voxel lies halfway to a coarse neighbour.

    A coarse point two fine steps from its neighbour sees the Dirichlet wall at the
    neighbour; when the wall is really at the fine voxel in between (half the
    distance), the link is twice as stiff. Without this the coarse problem is too
    soft next to the boundary and over-corrects there.
    """
    offsets, w = stencil_weights(h_c, connectivity)
    extra = np.zeros(free_c.shape)
    others = [slice(0, None, 2) if a else slice(None) for a in axes]
    for a in np.flatnonzero(axes):
        wa = w[(offsets[:, a] == 1) & ((offsets != 0).sum(axis=1) == 1)][0]
        sl = list(others)
        sl[a] = slice(1, None, 2)
        mid = np.moveaxis(fixed[tuple(sl)], a, 0)  # fine 2k + 1, for coarse k
        fc = np.moveaxis(free_c, a, 0)
        ex = np.moveaxis(extra, a, 0)
        m = fc.shape[0]
        k = mid.shape[0]
        # towards k + 1 through fine 2k + 1 (also when k + 1 is free: the wall between them must not vanish,
        # or a solid fixed only at odd voxels, e.g. one plane, has a singular coarse problem)
        plus = mid[:min(k, m - 1)]
        ex[:plus.shape[0]] += wa * plus
        if k >= m:  # a last fine point beyond the last coarse one
            ex[m - 1] += wa * mid[m - 1]
        # towards k - 1 through fine 2k - 1
        minus = mid[:m - 1]
        ex[1:1 + minus.shape[0]] += wa * minus
    return extra * free_c


def _restrict_axis(f, axis):
    """Full weighting along one axis: coarse ``k`` gathers fine ``2k`` and half of ``2k +- 1``.

    The coarse grid has ``ceil(n / 2)`` points (fine ``0, 2, 4, ...``); a last odd
    fine point has no coarse point beyond it and gives only to the one before.
    """
    f = np.moveaxis(f, axis, 0)
    n = f.shape[0]
    m = (n + 1) // 2
    c = f[0::2].copy()
    odd = f[1::2]
    c[:odd.shape[0]] += 0.5 * odd
    c[1:] += 0.5 * odd[:m - 1]
    c *= 0.5
    return np.moveaxis(c, 0, axis)


def _prolong_axis(c, axis, n):
    """Linear interpolation along one axis onto ``n`` fine points (the transpose of the above, times 2)."""
    c = np.moveaxis(c, axis, 0)
    f = np.empty((n,) + c.shape[1:], dtype=c.dtype)
    no = n // 2
    f[0::2] = c
    f[1::2] = c[:no]
    f[1:2 * (c.shape[0] - 1):2] += c[1:]
    f[1::2] *= 0.5
    return np.moveaxis(f, 0, axis)


class GridMultigrid:
    """CG with a geometric multigrid V-cycle for ``A x = r`` on the free voxels of a mask.

    Parameters
    ----------
    domain : (n0, n1, n2) bool numpy array
        The solid: voxels that exist (edges to voxels outside it are absent).
    free : (n0, n1, n2) bool numpy array
        The unknown voxels, a subset of ``domain``; the others in ``domain``
        are fixed (Dirichlet).
    spacing : (3,) array_like of float
        Voxel size per axis, of any magnitude: the operator is built on the
        spacing divided by a power of two of about its size (the same solution).
    connectivity : {6, 18, 26}
    workers : int, optional
        Threads for the stencil passes (default: up to 4, one per core).

    Attributes
    ----------
    levels : list
        The grids, finest first.
    report : dict
        ``levels`` and ``unknowns`` per level.

    Notes
    -----
    Vectors are flat arrays of the grid padded by one zero layer on every side
    (:meth:`pad`, :meth:`unpad`).
    """

    def __init__(self, domain, free, spacing=(1.0, 1.0, 1.0), connectivity=6, *, workers=None):
        workers = workers or min(os.cpu_count() or 1, 4)
        self._pool = ThreadPoolExecutor(workers) if workers > 1 else None
        self.shape = domain.shape
        # weights of about unit size: A and rhs() are the physical ones times one power of four
        spacing = unit_spacing(spacing)
        self.fine = _Level(domain, free, spacing, connectivity, np.float64, self._pool)
        self.levels = [_Level(domain, free, spacing, connectivity, np.float32, self._pool)]
        self.axes = []
        dom, fr, h = domain, free, np.asarray(spacing, dtype=np.float64)
        while self.levels[-1].unknowns > COARSE_MAX:
            ax = _coarse_axes(h, dom.shape)
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
            self.levels.append(_Level(dom, fr, h, connectivity, np.float32, self._pool,
                                      extra=_wall_weights(fixed, fr, ax, h, connectivity)))
        last = self.levels[-1]
        self._coarse_ids = np.flatnonzero(last.free)
        self._coarse_lu = None
        if self._coarse_ids.size:
            # the free voxels' Laplacian, with the full diagonal: weights towards fixed voxels included
            inner = last.free.reshape(last.padded)[1:-1, 1:-1, 1:-1]
            L = voxel_laplacian(inner, last.spacing, connectivity)
            d = last.diag[self._coarse_ids].astype(np.float64)
            L = L - sp.diags_array(L.diagonal()) + sp.diags_array(d)
            self._coarse_lu = splu(sp.csc_matrix(L))
        self.report = {"levels": len(self.levels), "unknowns": [lv.unknowns for lv in self.levels]}

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
        """Right-hand side from fixed values: ``sum_d w_d g[i + d]`` at the free voxels.

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
            c = _restrict_axis(c, a)
        nxt = self.levels[k + 1]
        rc = self._buffers(nxt)[2]
        rc.reshape(nxt.padded)[1:-1, 1:-1, 1:-1] = c  # the zero border stays
        rc *= nxt.free_f
        xc = self._cycle(k + 1, rc).reshape(nxt.padded)[1:-1, 1:-1, 1:-1]
        for a in np.flatnonzero(self.axes[k])[::-1]:
            xc = _prolong_axis(xc, a, lv.shape[a])
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

    def solve(self, rhs, *, tol=1e-10, maxiter=200):
        """Solve ``A x = rhs`` on the free voxels by preconditioned CG.

        Parameters
        ----------
        rhs : ((n0 + 2) * (n1 + 2) * (n2 + 2),) numpy array
            The padded grid, flat (C order), zero outside the free voxels.
        tol : float, optional
            Relative residual ``|rhs - A x| / |rhs|`` to stop at.
        maxiter : int, optional

        Returns
        -------
        x : numpy array
            Flat and padded like ``rhs``.
        iterations : int
        residual : float
            Relative residual reached; above ``tol`` when the iteration stalled
            (the residual did not halve in ``STALL`` iterations) or hit ``maxiter``.
        """
        A = self.fine
        x = np.zeros_like(rhs)
        r = rhs.copy()
        norm0 = np.sqrt(self._dot(r, r))
        if norm0 == 0:
            return x, 0, 0.0
        z = self.precondition(r)
        p = z.copy()
        rz = self._dot(r, z)
        q = np.empty_like(r)
        scratch = np.empty_like(r)
        it, rel, history = 0, 1.0, []
        while it < maxiter:
            it += 1
            A.apply(p, out=q)
            alpha = rz / self._dot(p, q)

            def update(lo, hi, alpha=alpha):
                t = np.multiply(p[lo:hi], alpha, out=scratch[lo:hi])
                x[lo:hi] += t
                np.multiply(q[lo:hi], alpha, out=t)
                r[lo:hi] -= t
                return np.dot(r[lo:hi], r[lo:hi])

            rel = float(np.sqrt(sum(A.chunks.run(update)))) / norm0
            history.append(rel)
            if rel <= tol or not np.isfinite(rel):
                break
            if it > STALL and rel > 0.5 * history[-1 - STALL]:
                break  # stalled: the caller decides (manifill.solid.fill falls back to AMG)
            self.precondition(r, out=z)
            rz_new = self._dot(r, z)
            beta = rz_new / rz

            def direction(lo, hi, beta=beta):
                p[lo:hi] *= beta
                p[lo:hi] += z[lo:hi]

            A.chunks.run(direction)
            rz = rz_new
        return x, it, rel
