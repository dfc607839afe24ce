"""The grids of :mod:`manifill.linalg.gridmg`: one level's stencil passes, transfers between levels.

A level holds its masks, stencil and diagonal as flat arrays of the grid padded
by one zero layer, so that a neighbour is a fixed shift of the flat index and
every stencil term one contiguous slice operation, run on ranges of the grid in
threads (:class:`Chunks`). Transfers are full weighting and linear
interpolation along the coarsened axes; :func:`wall_weights` keeps the
Dirichlet walls that fall between coarse points. The stencil itself comes from
the caller (``stencil(spacing, connectivity)``, see
:class:`manifill.linalg.gridmg.GridMultigrid`).
"""

from functools import partial

import numpy as np
import scipy.sparse as sp

__all__ = ["Chunks", "Level", "coarse_axes", "wall_weights", "restrict_axis", "prolong_axis", "free_matrix",
           "OMEGA", "SWEEPS", "RB_SWEEPS", "CHUNK"]

#: Damping of the Jacobi smoother used with 18 and 26 neighbours.
OMEGA = 0.7
#: Jacobi sweeps before and after the coarse-grid correction (18 and 26 neighbours).
SWEEPS = 2
#: Red-black Gauss-Seidel sweeps before and after (6 neighbours).
RB_SWEEPS = 2
#: Grid points per thread below which a level runs on one thread.
CHUNK = 1_000_000


class Chunks:
    """The index range of a flat padded grid that holds voxels, split for threads.

    Each stencil pass is a handful of NumPy operations on contiguous slices,
    which release the GIL; a level with several million points runs them on
    every core, one range per thread.
    """

    def __init__(self, size, margin, pool):
        lo, hi = margin, size - margin
        k = max(1, min(pool._max_workers if pool else 1, (hi - lo) // CHUNK))
        bounds = np.linspace(lo, hi, k + 1).astype(np.int64)
        self.ranges = list(zip(bounds[:-1].tolist(), bounds[1:].tolist()))
        self.pool = pool if k > 1 else None

    def run(self, fn):
        if self.pool is None:
            return [fn(lo, hi) for lo, hi in self.ranges]
        return list(self.pool.map(lambda r: fn(*r), self.ranges))


class Level:
    """One grid: masks, stencil and diagonal as flat arrays of the grid padded by a zero layer.

    On the flat padded array a neighbour offset is a fixed shift of the index, so
    every stencil term is one contiguous slice operation. The first and last
    ``margin`` entries are padding, so shifted reads never leave the array.
    """

    def __init__(self, domain, free, spacing, connectivity, stencil, dtype, pool, extra=None):
        self.shape = domain.shape
        self.padded = tuple(n + 2 for n in domain.shape)
        self.spacing = np.asarray(spacing, dtype=np.float64)
        self.dtype = dtype
        offsets, w = stencil(self.spacing, connectivity)
        strides = np.array([self.padded[1] * self.padded[2], self.padded[2], 1])
        shifts = offsets @ strides
        # offsets of equal weight share one multiply
        self.groups = [(dtype(wd), [int(o) for o in shifts[w == wd]]) for wd in np.unique(w)]
        size = int(np.prod(self.padded))
        self.chunks = Chunks(size, int(strides.sum()), pool)
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


def coarse_axes(spacing, shape):
    """Axes to coarsen: the finer ones (within a factor 1.5 of the finest), if long enough."""
    h = np.asarray(spacing)
    long = np.array([n > 4 for n in shape])
    if not long.any():
        return np.zeros(3, dtype=bool)
    finest = h[long].min()
    return long & (h <= 1.5 * finest)


def wall_weights(fixed, free_c, axes, h_c, connectivity, stencil):
    """Extra coarse diagonal where a fixed fine voxel lies halfway to a coarse neighbour.

    A coarse point two fine steps from its neighbour sees the Dirichlet wall at the
    neighbour; when the wall is really at the fine voxel in between (half the
    distance), the link is twice as stiff. Without this the coarse problem is too
    soft next to the boundary and over-corrects there.
    """
    offsets, w = stencil(h_c, connectivity)
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


def restrict_axis(f, axis):
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


def prolong_axis(c, axis, n):
    """Linear interpolation along one axis onto ``n`` fine points (the transpose of the above, times 2)."""
    c = np.moveaxis(c, axis, 0)
    f = np.empty((n,) + c.shape[1:], dtype=c.dtype)
    no = n // 2
    f[0::2] = c
    f[1::2] = c[:no]
    f[1:2 * (c.shape[0] - 1):2] += c[1:]
    f[1::2] *= 0.5
    return np.moveaxis(f, 0, axis)


def free_matrix(free, spacing, connectivity, stencil, diag):
    """The free points' matrix of the coarsest level: ``-w`` between stencil neighbours, ``diag`` on the diagonal.

    The same entries, in the same canonical CSR order, as the graph Laplacian of
    the free points with its diagonal replaced by ``diag`` (weights towards
    fixed points included).
    """
    D, w = stencil(spacing, connectivity)
    n = int(free.sum())
    ids = np.full(free.shape, -1, dtype=np.int64)
    ids[free] = np.arange(n)
    rows, cols, vals = [], [], []
    for d, wd in zip(D, w):
        src = tuple(slice(max(0, -int(s)), m - max(0, int(s))) for s, m in zip(d, free.shape))
        dst = tuple(slice(max(0, int(s)), m - max(0, -int(s))) for s, m in zip(d, free.shape))
        a, b = ids[src], ids[dst]
        both = (a >= 0) & (b >= 0)
        rows.append(a[both])
        cols.append(b[both])
        vals.append(np.full(int(both.sum()), wd))
    r, c, v = np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
    W = sp.csr_array((np.concatenate([v, v]), (np.concatenate([r, c]), np.concatenate([c, r]))), shape=(n, n))
    A = sp.csr_array(sp.diags_array(diag) - W)
    A.sort_indices()
    return A
