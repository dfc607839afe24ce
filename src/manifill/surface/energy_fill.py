"""Fills that minimise an energy with the samples alone as constraints: harmonic, biharmonic, triharmonic.

Beside the paper's pipeline (which fixes whole curves before a harmonic fill), these
methods constrain only the samples and minimise the k-harmonic energy
``x' L (M^-1 L)^(k-1) x`` (``L`` the surface Laplacian, ``M`` its lumped mass matrix;
:func:`manifill.linalg.energies.polyharmonic_energy`, the Voronoi mass): ``k = 1`` harmonic, ``k = 2`` biharmonic
(``igl.harmonic(V, F, b, bc, 2)``), ``k = 3`` triharmonic. Two options change the
constraints, not the energy:

- ``bounds``: the minimiser subject to ``lo <= x <= hi`` (an active-set solve of the
  bounded problem, :meth:`manifill.linalg.quadratic.QuadraticSolver.solve`), not a clip;
  ``"samples"`` bounds each field by its samples' range.
- ``smoothing``: the samples become soft constraints, ``sum_i w_i (x(s_i) - y_i)^2 +
  lambda x' A x`` (:mod:`manifill.linalg.smoothing`); ``"auto"`` picks lambda by
  generalised cross-validation. The result then differs from the samples at the samples
  (``report['smoothing']['residuals']``).
"""

import numpy as np
import scipy.sparse as sp

from ..errors import OptionError, SolveError
from ..linalg.active_set import as_bounds as bounds_per_field
from ..linalg.active_set import check_samples
from ..linalg.quadratic import QuadraticSolver
from .polyharmonic import PolyharmonicSolver

__all__ = ["ENERGY_METHODS", "energy_fill", "as_bounds"]

#: The energy methods and their order k.
ENERGY_METHODS = {"harmonic": 1, "biharmonic": 2, "triharmonic": 3}


def as_bounds(bounds, vals):
    """``(lo, hi)`` per field, each ``(p,)``, from ``None``, ``"samples"`` or ``(lo, hi)``.

    Parameters
    ----------
    bounds : None, 'samples' or (lo, hi)
        ``lo``, ``hi`` scalars or ``(p,)`` per field; ``None`` on one side leaves it open.
    vals : (k, p) numpy array
        The sample values.

    Returns
    -------
    None or (lo, hi) of (p,) float64 numpy arrays (``-inf``/``inf`` where open)

    Raises
    ------
    OptionError
        ``bounds`` is not one of the forms above.
    SampleError
        ``lo > hi``, or samples outside the bounds.

    Examples
    --------
    >>> lo, hi = as_bounds("samples", np.array([[0.0, 1.0], [2.0, -1.0]]))
    >>> lo.tolist(), hi.tolist()
    ([0.0, -1.0], [2.0, 1.0])
    """
    if bounds is None:
        return None
    if isinstance(bounds, str):
        if bounds != "samples":
            raise OptionError(f"bounds={bounds!r} is not 'samples' or a (lo, hi) pair; pass one of those")
        return vals.min(axis=0).astype(np.float64), vals.max(axis=0).astype(np.float64)
    try:
        lo, hi = bounds
    except (TypeError, ValueError):
        raise OptionError(f"bounds must be 'samples' or a (lo, hi) pair; got {bounds!r}") from None
    # the solve core's own checks, here before any set-up: shapes, NaN, lo <= hi, samples inside
    lo, hi = bounds_per_field(lo, hi, vals.shape[1])
    check_samples(vals, lo, hi)
    return lo, hi


def energy_fill(surface, idx, vals, *, k=1, weights="cotan", solver="auto", on_empty="error", bounds=None,
                smoothing=None, sample_weights=None, tol=None, maxiter=None):
    """Minimise the k-harmonic energy on a Surface with the samples as constraints.

    Parameters
    ----------
    surface : Surface
        A triangle mesh (``k >= 2`` needs its triangles for the mass matrix).
    idx : (k,) int64 numpy array
        Sample vertices, sorted and unique.
    vals : (k, p) float64 numpy array
        Sample values.
    k : {1, 2, 3}, optional
        Order of the energy.
    weights, solver, on_empty, tol, maxiter
        As for :func:`manifill.reconstruct`.
    bounds : None, 'samples' or (lo, hi), optional
        See :func:`as_bounds`.
    smoothing : None, float >= 0 or 'auto', optional
        Soft constraints with this lambda (``'auto'``: chosen by generalised cross-validation).
    sample_weights : (k,) array_like of float > 0, optional
        Weights ``w_i`` of the soft constraints.

    Returns
    -------
    values : (n, p) numpy array
    report : dict
        The solver's report, with ``energy`` (k), and ``bounds`` / ``smoothing`` when used.

    Raises
    ------
    OptionError
        ``k >= 2`` on a surface without triangles; ``bounds`` with ``smoothing``.
    SampleError, SolveError
        As for the solve core.
    """
    L = surface.laplacian(weights)
    A = _energy(surface, L, k)
    lohi = as_bounds(bounds, vals)
    if smoothing is not None:
        if lohi is not None:
            raise OptionError("bounds and smoothing together are not supported yet; pass one of them")
        values, report = _smoothed(A, surface.n, idx, vals, smoothing, sample_weights, k)
        report.update(weights=weights, solver="direct")
        return values, report
    if sample_weights is not None:
        raise OptionError("sample_weights weigh soft constraints; pass smoothing= too, or leave them out")
    auto = solver == "auto"
    if k > 1:  # the k-harmonic systems' own backend policy and tolerance
        solver, tol, maxiter = PolyharmonicSolver.settings(k, surface.n - idx.size, solver, tol, maxiter)

    def run(backend):
        qs = QuadraticSolver(A, idx, solver=backend, on_empty=on_empty, tol=tol, maxiter=maxiter,
                             symmetric_pattern=weights in ("uniform", "cotan"), what="the energy")
        X = qs.solve(vals) if lohi is None else qs.solve(vals, lo=lohi[0], hi=lohi[1])
        return X, qs.report

    try:
        X, rep = run(solver)
        fallback = None
    except SolveError as e:
        # auto picked CG and it stalled (a poorly conditioned bilaplacian, e.g. small parts of a mesh): factorise
        if not (auto and solver == "amg" and "did not reach" in str(e)):
            raise
        X, rep = run("direct")
        fallback = f"direct (AMG-preconditioned CG stalled: {e})"
    report = {key: v for key, v in rep.items()}
    if fallback:
        report["fallback"] = fallback
    report["weights"] = weights
    report["energy"] = k
    return (X if X.ndim == 2 else X[:, None]), report


def _energy(surface, L, k):
    if k == 1:
        return L
    if surface.F is None:
        raise OptionError(f"the {'bi' if k == 2 else 'tri'}harmonic energy needs triangles (a mass matrix); "
                          f"a digital surface has none: use method='harmonic' or a tetrahedral solid")
    from ..linalg.energies import polyharmonic_energy
    from ..mesh.laplacian import mass_matrix

    # the Voronoi mass, as igl.harmonic(V, F, b, bc, k) uses (manifill.surface.polyharmonic.biharmonic's default)
    return polyharmonic_energy(L, mass_matrix(surface.V, surface.F, kind="voronoi"), k)


def _smoothed(A, n, idx, vals, smoothing, sample_weights, k):
    from ..linalg.smoothing import smooth

    if isinstance(smoothing, str):
        if smoothing != "auto":
            raise OptionError(f"smoothing={smoothing!r} is not a number >= 0 or 'auto'; pass one of those")
        lam = "auto"
    else:
        try:
            lam = float(smoothing)
        except (TypeError, ValueError):
            raise OptionError(f"smoothing={smoothing!r} is not a number >= 0 or 'auto'; pass one of those") from None
    S = sp.csr_array((np.ones(idx.size), (np.arange(idx.size), idx)), shape=(idx.size, n))
    X, rep = smooth(A, S, vals, lam, w=sample_weights)
    X = np.asarray(X, dtype=np.float64)
    return (X if X.ndim == 2 else X[:, None]), {"energy": k, "smoothing": rep}
