"""The one preconditioned conjugate gradient loop of manifill.

Both iterative solvers run it: the surface AMG
(:class:`manifill.linalg.amg.Multigrid`, float32 cycle, flexible ``beta``) and the
voxel multigrid (:class:`manifill.linalg.gridmg.GridMultigrid`, matrix-free
stencil, threaded vector updates). What differs between them is passed in as
callables: the operator, the preconditioner, the inner product and the two
vector updates; the loop itself (step length, stopping tests, direction) is
written once, here.

The loop works on a residual ``r`` and a correction ``x`` that it updates in
place, so a caller may solve for ``x0 + s e`` with ``r`` scaled to unit norm
(the AMG does, to keep every quantity of order one) or for ``x`` itself from
``x = 0`` (the voxel multigrid does).
"""

import math
from dataclasses import dataclass, field

import numpy as np

from ..tolerances import TOL

__all__ = ["PCGResult", "Kernels", "pcg", "dot", "nrm2"]


def dot(x, y):
    """Inner product of two float64 vectors.

    ``einsum`` rather than ``x @ y``: BLAS may run a level-1 product on several
    threads, which on a busy machine costs more in waiting than it saves.

    Examples
    --------
    >>> dot(np.array([1.0, 2.0]), np.array([3.0, 4.0]))
    11.0
    """
    return float(np.einsum("i,i->", x, y))


def nrm2(x):
    """Euclidean norm of a float64 vector, rescaled where the plain sum of squares may over- or underflow.

    The plain sum is used inside ``(TOL.norm_tiny, TOL.norm_huge)``.

    Examples
    --------
    >>> nrm2(np.array([3e200, 4e200])) / 1e200
    5.0
    """
    ss = dot(x, x)
    if TOL.norm_tiny < ss < TOL.norm_huge:
        return math.sqrt(ss)
    m = float(np.abs(x).max()) if x.size else 0.0
    if m == 0.0 or not math.isfinite(m):
        return m
    y = x / m
    return m * math.sqrt(dot(y, y))


@dataclass
class PCGResult:
    """How :func:`pcg` ended.

    Attributes
    ----------
    iterations : int
        Steps taken.
    residual : float
        Last residual norm over ``norm0``.
    status : {'converged', 'maxiter', 'stalled', 'breakdown', 'diverged'}
        ``converged``: ``residual <= rtol``; ``maxiter``: the cap was reached;
        ``stalled``: the residual did not halve in ``stall`` steps;
        ``breakdown``: ``p.Ap`` or ``r.z`` not positive (an operator or
        preconditioner that is not positive definite); ``diverged``: a NaN or
        infinite residual.
    history : list of float
        The relative residual after every step.
    """

    iterations: int
    residual: float
    status: str
    history: list = field(default_factory=list)

    @property
    def converged(self):
        return self.status == "converged"


@dataclass(frozen=True)
class Kernels:
    """The vector operations of :func:`pcg`, for a caller that runs them its own way (threads, chunks).

    Attributes
    ----------
    inner : callable
        ``inner(u, v)``, the inner product (default :func:`dot`).
    update : callable or None
        ``update(alpha, p, Ap)`` does ``x += alpha p``, ``r -= alpha Ap`` and
        returns ``||r||``; None: with numpy and :func:`nrm2`.
    direction : callable or None
        ``direction(beta, p, z)`` does ``p = z + beta p`` in place; None: with numpy.
    """

    inner: object = dot
    update: object = None
    direction: object = None


def pcg(matvec, r, x, *, precondition=None, rtol, maxiter, norm0=1.0, flexible=False, stall=None,
        breakdown=True, kernels=None):
    """Preconditioned conjugate gradients for ``A x = b`` from the residual ``r = b - A x``.

    Parameters
    ----------
    matvec : callable
        ``matvec(p)`` returns ``A p`` (it may reuse one output array).
    r : (N,) float64 numpy array
        The initial residual; overwritten by the last one.
    x : (N,) float64 numpy array
        The initial iterate; updated in place (``x += alpha p`` every step).
    precondition : callable, optional
        ``precondition(r, rnorm)`` returns ``M r`` (``rnorm`` is the current
        residual norm, for a preconditioner that scales its input); the identity
        by default.
    rtol : float
        Stop when ``||r|| / norm0 <= rtol``.
    maxiter : int
        Most steps.
    norm0 : float, optional
        The norm the residual is measured against (the right-hand side's).
    flexible : bool, optional
        Polak-Ribiere ``beta = z_new . (r_new - r_old) / (r_old . z_old)``
        (for a preconditioner symmetric only to rounding) instead of
        Fletcher-Reeves ``beta = r_new . z_new / (r_old . z_old)``.
    stall : int, optional
        Stop (status ``stalled``) when, after more than ``stall`` steps, the
        residual is above half of what it was ``stall`` steps before.
    breakdown : bool, optional
        Stop (status ``breakdown``) when ``p.Ap`` or ``r.z`` is not positive;
        without, such a step is taken and a ``stall`` test ends the loop.
    kernels : Kernels, optional
        The inner product and the two vector updates (default: numpy's, on
        this thread).

    Returns
    -------
    PCGResult

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> A = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(50, 50), format="csr")
    >>> b = np.ones(50)
    >>> x = np.zeros(50)
    >>> res = pcg(lambda p: A @ p, b.copy(), x, rtol=1e-12, maxiter=100, norm0=nrm2(b))
    >>> res.status, res.iterations <= 25, bool(np.linalg.norm(A @ x - b) <= 1e-10)
    ('converged', True, True)
    """
    kernels = Kernels() if kernels is None else kernels
    inner, update, direction = kernels.inner, kernels.update, kernels.direction
    if precondition is None:
        def precondition(v, _):
            return v.copy()
    tmp = np.empty_like(r)
    if update is None:
        def update(alpha, p, Ap):
            np.add(x, np.multiply(p, alpha, out=tmp), out=x)
            np.subtract(r, np.multiply(Ap, alpha, out=tmp), out=r)
            return nrm2(r)
    if direction is None:
        def direction(beta, p, z):
            np.multiply(p, beta, out=p)
            np.add(p, z, out=p)
    z = precondition(r, norm0)
    p = z.copy()
    rz = inner(r, z)
    its, rel, history = 0, 1.0, []
    while its < maxiter:
        Ap = matvec(p)
        pAp = inner(p, Ap)
        if breakdown and not (pAp > 0 and rz > 0):
            return PCGResult(its, rel, "breakdown", history)
        alpha = rz / pAp
        rnorm = update(alpha, p, Ap)
        its += 1
        rel = rnorm / norm0
        history.append(rel)
        if rel <= rtol:
            return PCGResult(its, rel, "converged", history)
        if not math.isfinite(rel):
            return PCGResult(its, rel, "diverged", history)
        if stall is not None and its > stall and rel > 0.5 * history[-1 - stall]:
            return PCGResult(its, rel, "stalled", history)
        z = precondition(r, rnorm)
        rz_new = inner(r, z)
        beta = -alpha * inner(z, Ap) / rz if flexible else rz_new / rz
        rz = rz_new
        direction(beta, p, z)
    return PCGResult(its, rel, "maxiter", history)
