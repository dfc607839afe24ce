"""Noisy samples: a penalised fit with a chosen or automatic smoothing parameter.

Domain-free: given an energy ``A`` (``n x n`` sparse, symmetric positive
semi-definite: a Laplacian, or a biharmonic ``L M^-1 L``), an observation
matrix ``S`` (``k x n`` sparse: rows of one 1 at sample vertices, or
barycentric rows for points inside faces), observations ``y`` (``(k,)`` or
``(k, p)``), weights ``w > 0`` and ``lam >= 0``, minimise

    sum_i w_i ((S x)_i - y_i)^2 + lam x^T A x,

that is, solve ``(S^T W S + lam A) x = S^T W y``. The influence matrix
``H(lam) = S (S^T W S + lam A)^-1 S^T W`` (``k x k``) maps ``y`` to the fitted
values ``S x``; its trace is the fit's effective degrees of freedom.

Choosing ``lam``:

``gcv``
    Generalised cross-validation, ``V(lam) = k ||W^1/2 (I - H) y||^2 / (k - tr H)^2``.
``loo``
    Leave-one-out, ``mean_i w_i ((y_i - yhat_i) / (1 - H_ii))^2``, exact for
    this linear smoother (Sherman-Morrison: it equals refitting without
    sample ``i``).

Both need ``diag H``, here exact and for every ``lam`` at once. The data term
reads ``x`` only at the ``m`` vertices ``b`` that ``S`` touches, and for fixed
``x_b`` the rest is the energy's Dirichlet problem: the fit is ``min ||W^1/2
(S_b x_b - y)||^2 + lam x_b^T Sigma x_b`` with the Schur complement ``Sigma =
A_bb - A_bI A_II^-1 A_Ib`` (``m`` solves of one
:class:`~manifill.linalg.quadratic.QuadraticSolver`, once). One dense
generalised eigendecomposition ``lam0 Sigma phi = theta (S_b^T W S_b + lam0
Sigma) phi`` diagonalises both terms (the Demmler-Reinsch basis); then ``H``,
its trace and diagonal cost ``O(k m)`` per ``lam``, and ``x`` one Dirichlet
solve. Set-up is ``O(m^3)``: fine up to a few thousand samples, slow beyond
(no stochastic trace estimator). The search
(:mod:`manifill.linalg.lamsearch`) is a log grid ``10^-6 .. 10^4`` times the
data-independent scale ``lam0 = tr(S^T W S) / tr(A)`` (four a decade), then a
golden-section refinement on ``log lam``; each field gets its own ``lam``.

``lam = 0`` is interpolation, the limit ``lam -> 0``: the penalised system
is singular there, so it is solved exactly as a constrained problem by
:class:`manifill.linalg.quadratic.QuadraticSolver`: rows with one entry fix
their vertex (samples at one vertex to their weighted mean), rows with
several are equality rows ``S_j x = y_j``. ``lam -> inf`` tends to the
energy's null space (for a Laplacian, one constant per component: the
weighted mean of its samples). With barycentric rows a tiny ``lam > 0`` loses
digits as ``1 / lam`` in the directions only the rows' vertices see: use 0.
With the harmonic energy and samples sparse on a surface, GCV/LOO often prefer
the grid's low end (point-constrained harmonic fits are spiky; the curve's
``at_edge`` says so); the biharmonic energy suits smoothing better.

A connected component of ``A``'s graph without a sample makes the system
singular: :class:`~manifill.errors.SolveError` names it.
"""

import numpy as np

from ..validate import as_values, check_option
from .lamsearch import check_lam
from .smoothfit import SELECT_METHODS, SmoothingFit
from .smoothfit import BLOCK_BYTES, GRID_DECADES, GRID_PER_DECADE  # noqa: F401 (re-exported from their old home)

__all__ = ["SELECT_METHODS", "SmoothingFit", "smooth"]


def smooth(A, S, y, lam="auto", *, w=None, method="gcv", lams=None, solver="auto"):
    """The penalised fit ``min sum_i w_i ((S x)_i - y_i)^2 + lam x^T A x``, with ``lam`` given or chosen.

    Parameters
    ----------
    A : (n, n) scipy sparse matrix
        Symmetric positive semi-definite energy.
    S : (k, n) scipy sparse matrix
        Observation rows.
    y : (k,) or (k, p) array_like of float
        Observations.
    lam : 'auto' or float >= 0 or (p,) array_like, optional
        ``'auto'`` chooses it per field by ``method``; 0 interpolates.
    w : (k,) array_like of float > 0, optional
        Sample weights.
    method : {'gcv', 'loo'}, optional
        The score minimised by ``lam='auto'`` (and reported).
    lams : (m,) array_like of float > 0, optional
        The grid of ``lam='auto'``.
    solver : {'auto', 'direct', 'amg', 'iterate'}, optional
        As :class:`SmoothingFit`.

    Returns
    -------
    x : (n,) or (n, p) numpy array
    report : dict
        ``lambda``, ``lambda0`` (the scale ``tr(S'WS) / tr(A)``),
        ``residuals`` (``S x - y``), ``rms_residual`` (weighted, per field),
        ``edf`` (``tr H``), ``method``, ``score`` (at the ``lam`` used; NaN at
        0 or with fewer than 3 samples) and ``curve`` (:meth:`SmoothingFit.select`'s,
        with ``lam='auto'``; None otherwise).

    Raises
    ------
    MeshError, SampleError, OptionError, SolveError
        As :class:`SmoothingFit` and its methods.

    See Also
    --------
    SmoothingFit : precomputed, for many ``y`` or ``lam``.

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> A = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(6, 6)).tolil()
    >>> A[0, 0] = A[5, 5] = 1.0
    >>> x, rep = smooth(A, sp.eye(6), [0.0, 1.1, 1.9, 3.2, 3.9, 5.0])
    >>> rep["lambda"] > 0, round(rep["edf"], 6) < 6
    (True, True)
    """
    check_option("method", method, SELECT_METHODS)
    fit = SmoothingFit(A, S, w=w, solver=solver)
    Y, squeeze = as_values(y, fit.k, what="y")
    curve = None
    if isinstance(lam, str):
        check_option("lam", lam, ("auto",))
        lam, curve = fit.select(Y[:, 0] if squeeze else Y, method=method, lams=lams, curve=True)
    lam = check_lam(lam, Y.shape[1])
    x, info = fit.solve(Y, lam, edf=True)
    lv = np.broadcast_to(np.asarray(lam, dtype=np.float64), (Y.shape[1],))
    score, dof = np.full(Y.shape[1], np.nan), np.broadcast_to(info["edf"], lv.shape)
    for value in np.unique(lv[lv > 0]) if fit.k >= 3 else ():
        cols = np.flatnonzero(lv == value)
        score[cols] = fit._scores(Y[:, cols], float(value), method)
    R = info["residuals"]
    rms = np.sqrt(fit.w @ R**2 / fit.w.sum())
    pick = (lambda a: float(a[0])) if squeeze else (lambda a: np.array(a))
    report = {"lambda": pick(lv), "lambda0": fit.lam0, "residuals": R[:, 0] if squeeze else R,
              "rms_residual": pick(rms), "edf": pick(dof), "method": method, "score": pick(score), "curve": curve}
    return (x[:, 0] if squeeze else x), report
