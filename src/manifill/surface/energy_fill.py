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

import time

import numpy as np
import scipy.sparse as sp

from ..errors import OptionError, SampleError, SolveError
from ..linalg.active_set import bounds_per_field
from ..linalg.active_set import check_samples
from ..linalg.backends import AUTO_DIRECT_FIELDS, AUTO_DIRECT_MAX, auto_backend, make_linear_solver
from ..linalg.quadratic import QuadraticSolver
from ..linalg.smoothing import smooth
from ..mesh.topology import pattern_components
from ..tolerances import TOL
from ..validate.scale import LOW_DECADES, check_size
from .options import FitOptions
from .points import eliminate_rows
from .polyharmonic import PolyharmonicSolver, energy_matrix, positions
from .prepared import cached

__all__ = ["ENERGY_METHODS", "energy_fill", "as_bounds", "smoothing_value"]

#: The energy methods and their order k.
ENERGY_METHODS = {"harmonic": 1, "biharmonic": 2, "triharmonic": 3}


def as_bounds(bounds: str | tuple | None, vals: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
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


def energy_fill(surface, idx, vals, *, k=1, weights="cotan", solver="auto", on_empty="error", fit=None, rows=None,
                fields=None, prepared=None, **settings):
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
    weights, solver, on_empty
        As for :func:`manifill.reconstruct`.
    fit : FitOptions, optional
        ``bounds`` (None, 'samples' or (lo, hi), see :func:`as_bounds`), ``smoothing`` (None, a
        lambda >= 0 or 'auto': soft constraints, lambda chosen by generalised cross-validation)
        and ``sample_weights`` ((k,) or (k + m,) weights ``w_i`` of the soft constraints: the
        vertex samples, then the rows of ``Aeq``) (:class:`manifill.surface.options.FitOptions`).
    rows : (Aeq, beq), optional
        ``Aeq`` ((m, n) scipy sparse matrix): samples at points inside faces, one barycentric row each
        (:meth:`manifill.surface.locate.SurfacePoints.rows`), constrained exactly,
        or softly with ``smoothing``; ``idx`` may then be empty. ``solver='direct'``
        factorises the KKT system (and holds bounds); ``'amg'`` eliminates one free
        vertex per row (:func:`manifill.surface.points.eliminate_rows`) and runs
        AMG-preconditioned CG on the reduced, still positive definite, energy (no
        bounds); ``'auto'`` picks between them by size as for vertex samples, and factorises
        a k >= 2 system of many fields wherever it fits.
        ``beq`` ((m, p) numpy array): their values.
    fields : int, optional
        How many fields will share these samples (default: ``vals``' columns); with
        many, ``solver='auto'`` factorises larger systems too.
    prepared : Prepared, optional
        Keeps the energy and the solve core (its factorisation or hierarchy) for the
        next call with the same samples (:mod:`manifill.surface.prepared`); the bounded
        active set's own solves and the smoothing fit are made anew at every call.
    **settings
        ``tol``, ``maxiter`` of the solver; ``energy``: a callable ``energy(surface)`` giving another energy
        matrix of order ``k`` (the Hessian energies, :mod:`manifill.mesh.hessian`, with ``k = 2``) in place of the
        k-harmonic one (the solver policy, bounds and smoothing are those of order ``k``).

    Returns
    -------
    values : (n, p) numpy array
    report : dict
        The solver's report, with ``energy`` (k), and ``bounds`` / ``smoothing`` when used.

    Raises
    ------
    OptionError
        ``k >= 2`` on a surface without triangles; ``bounds`` with ``smoothing``;
        ``Aeq`` with ``solver='iterate'``, or with bounds and ``solver='amg'``.
    SampleError, SolveError
        As for the solve core.
    """
    fit = FitOptions() if fit is None else fit
    bounds, smoothing, sample_weights = fit.bounds, fit.smoothing, fit.sample_weights
    Aeq, beq = (None, None) if rows is None else rows
    tol, maxiter, energy = settings.pop("tol", None), settings.pop("maxiter", None), settings.pop("energy", None)
    if settings:
        raise OptionError(f"energy_fill takes no setting {next(iter(settings))!r}; pass tol, maxiter or energy")
    A = cached(prepared, "energy matrix", lambda: _energy(surface, weights, k) if energy is None else energy(surface))
    fields = vals.shape[1] if fields is None else fields
    lohi = as_bounds(bounds, vals if Aeq is None else np.vstack([vals, beq]))
    if smoothing is not None:
        if lohi is not None:
            raise OptionError("bounds and smoothing together are not supported yet; pass one of them")
        values, report = _smoothed(A, surface.n, idx, vals, smoothing, sample_weights, k, Aeq, beq)
        report.update(weights=weights, solver="direct")
        return values, report
    if sample_weights is not None:
        raise OptionError("sample_weights weigh soft constraints; pass smoothing= too, or leave them out")
    auto = solver == "auto"
    if auto and fields >= AUTO_DIRECT_FIELDS and (Aeq is None or lohi is None):
        # many fields: a factorisation if it fits (a symmetric positive definite one without rows; a k >= 2 KKT one),
        # and wherever one field of a k >= 2 energy would factorise
        free = A.shape[0] - idx.size
        one = k > 1 and PolyharmonicSolver.settings(k, free)[0] == "direct"
        solver = "direct" if one else auto_backend(free, A.nnz, fields, spd=Aeq is None, rows=Aeq is not None and k > 1)
    if Aeq is not None:
        solver, tol, maxiter = _row_solver(k, surface.n - idx.size - Aeq.shape[0], solver, lohi, tol, maxiter)
    elif k > 1:  # the k-harmonic systems' own backend policy and tolerance
        solver, tol, maxiter = PolyharmonicSolver.settings(k, surface.n - idx.size, solver, tol, maxiter)

    def run(backend):
        if Aeq is not None and backend == "amg":
            return _eliminated(A, idx, vals, Aeq, beq, tol=tol, maxiter=maxiter, on_empty=on_empty,
                               symmetric_pattern=weights in ("uniform", "cotan"))
        if Aeq is not None and lohi is not None:
            return _bounded_rows(A, idx, vals, Aeq, beq, lohi, on_empty=on_empty,
                                 symmetric_pattern=weights in ("uniform", "cotan"))
        qs = cached(prepared, ("energy", backend), lambda: QuadraticSolver(
            A, idx, solver=backend, on_empty=on_empty, tol=tol, maxiter=maxiter,
            symmetric_pattern=weights in ("uniform", "cotan"), Aeq=Aeq, what="the energy",
            candidates=positions(surface.V, k)))
        X = qs.solve(vals, beq=beq) if lohi is None else qs.solve(vals, beq=beq, lo=lohi[0], hi=lohi[1])
        if Aeq is not None:
            X = _refine(qs, X, vals, beq)
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
    if k > 1:  # a k-harmonic energy has positive off-diagonal entries by nature: they are no obtuse triangles
        report.pop("negative_weights", None)
    return (X if X.ndim == 2 else X[:, None]), report


def _energy(surface, weights, k):
    L = surface.laplacian(weights)
    if k == 1:
        return energy_matrix(L, None, 1)
    if surface.mass is None:
        raise OptionError(f"the {'bi' if k == 2 else 'tri'}harmonic energy needs triangles (a mass matrix); "
                          f"a digital surface has none: use method='harmonic' or a tetrahedral solid")
    if k > 2:  # the energy divides by the areas k - 1 times: a size whose powers leave floating point is refused
        check_size(surface.V, 2 * (k - 1), "the surface",
                   f"areas to the power {k - 1} (the {_ORDER.get(k, 'k-')}harmonic energy divides by them)",
                   "use a lower order, or give the positions in other units", decades=LOW_DECADES)
    # the Voronoi mass, as igl.harmonic(V, F, b, bc, k) uses (manifill.surface.polyharmonic.biharmonic's default);
    # a point cloud's own (its fans' mixed areas)
    return energy_matrix(L, surface.mass("voronoi", weights), k)


_ORDER = {3: "tri"}


def _smoothed(A, n, idx, vals, smoothing, sample_weights, k, Aeq=None, beq=None):

    lam = smoothing_value(smoothing, idx.size + (0 if Aeq is None else Aeq.shape[0]))
    S = sp.csr_array((np.ones(idx.size), (np.arange(idx.size), idx)), shape=(idx.size, n))
    if Aeq is not None:  # points inside faces: their barycentric rows
        S, vals = sp.csr_array(sp.vstack([S, sp.csr_array(Aeq)])), np.vstack([vals, beq])
    X, rep = smooth(A, S, vals, lam, w=sample_weights)
    X = np.asarray(X, dtype=np.float64)
    return (X if X.ndim == 2 else X[:, None]), {"energy": k, "smoothing": rep}


def smoothing_value(smoothing, k):
    """``smoothing`` checked, in its own name: ``'auto'`` (with at least 3 samples) or a finite float >= 0.

    Raises
    ------
    OptionError
        Not ``'auto'`` nor a finite number >= 0.
    SampleError
        ``'auto'`` with fewer than 3 samples.

    Examples
    --------
    >>> smoothing_value(0.5, 10), smoothing_value("auto", 10)
    (0.5, 'auto')
    >>> smoothing_value(-1, 10)
    Traceback (most recent call last):
    ...
    manifill.errors.OptionError: smoothing=-1 is not a finite number >= 0 or 'auto'; pass one of those
    """
    if isinstance(smoothing, str):
        if smoothing != "auto":
            raise OptionError(f"smoothing={smoothing!r} is not a finite number >= 0 or 'auto'; pass one of those")
        if k < 3:
            raise SampleError(f"smoothing='auto' chooses lambda by cross-validation and needs at least 3 samples, "
                              f"got {k}; pass a fixed smoothing=lambda")
        return "auto"
    try:
        lam = float(smoothing)
    except (TypeError, ValueError):
        lam = float("nan")
    if not (np.isfinite(lam) and lam >= 0):
        raise OptionError(f"smoothing={smoothing!r} is not a finite number >= 0 or 'auto'; pass one of those")
    return lam


def _refine(qs, X, vals, beq):
    """One step of iterative refinement of the KKT solve (the rows then hold to round-off, even for k = 3)."""
    X = X if X.ndim == 2 else X[:, None]
    g = qs.A @ np.nan_to_num(X) + qs.Aeq.T @ qs.eq_multipliers
    mu = qs.eq_multipliers
    D = qs.solve(np.zeros_like(vals), linear=g, beq=beq - qs.Aeq @ np.nan_to_num(X))
    qs.eq_multipliers = mu + qs.eq_multipliers
    return X + np.where(np.isnan(X), 0.0, D)


def _bounded_rows(A, idx, vals, Aeq, beq, lohi, *, on_empty, symmetric_pattern):
    """Bounds with points inside faces, one field at a time (factorised).

    A point whose value is at a bound pins its face's vertices (those with a weight) at that
    bound: the bounds leave no other way to meet the row, and as a row it would be dependent on
    them in the active set. The other rows stay equality rows.
    """
    lo, hi = lohi
    n, p = A.shape[0], vals.shape[1]
    X = np.empty((n, p))
    merged, report = {}, None
    for j in range(p):
        scale = max(float(np.abs(np.concatenate([vals[:, j], beq[:, j]])).max()), 1e-300)
        at_lo = beq[:, j] <= lo[j] + TOL.bound_rtol * scale
        at_hi = beq[:, j] >= hi[j] - TOL.bound_rtol * scale
        pins = {}
        for rows, bound in ((np.flatnonzero(at_lo), lo[j]), (np.flatnonzero(at_hi), hi[j])):
            for v in Aeq[rows].indices[Aeq[rows].data != 0]:
                if pins.get(int(v), bound) != bound:
                    raise SampleError(f"sample points at both bounds of field {j} share vertex {int(v)}; "
                                      f"no field within the bounds meets both: widen the bounds")
                pins[int(v)] = bound
        sample = dict(zip(idx.tolist(), vals[:, j].tolist()))
        clash = [v for v, b in pins.items() if v in sample and sample[v] != b]
        if clash:
            raise SampleError(f"a sample point at a bound of field {j} needs vertex {clash[0]} at that bound, and "
                              f"it is a sample with another value; widen the bounds or check the samples")
        extra = np.array(sorted(v for v in pins if v not in sample), dtype=np.int64)
        fidx = np.concatenate([idx, extra])
        fvals = np.concatenate([vals[:, j], [pins[v] for v in extra.tolist()]])
        keep = np.flatnonzero(~(at_lo | at_hi))
        rows = Aeq[keep] if keep.size else None
        qs = QuadraticSolver(A, fidx, solver="direct", on_empty=on_empty, symmetric_pattern=symmetric_pattern,
                             Aeq=rows, what="the energy")
        X[:, j] = qs.solve(fvals, beq=beq[keep, j] if keep.size else None, lo=lo[j], hi=hi[j])
        report = qs.report
        for key, v in report.get("bounds", {}).items():
            if isinstance(v, list):
                merged.setdefault(key, []).extend(v)
            else:
                merged[key] = max(merged.get(key, 0.0), v)
    report["bounds"] = merged
    return X, report


def _row_solver(k, free, solver, lohi, tol, maxiter):
    """The backend for samples inside faces: the KKT factorisation, or AMG on the rows eliminated."""

    if solver == "iterate":
        raise OptionError("samples inside faces are equality rows, which solver='iterate' cannot hold; "
                          "pass solver='direct', 'amg' or 'auto'")
    if solver == "auto" and k > 1:  # the vertex samples' policy (bench/biharmonic_speed.py): Pardiso where it fits
        solver = "direct" if lohi is not None else PolyharmonicSolver.settings(k, free)[0]
    elif solver == "auto":
        solver = "amg" if free > AUTO_DIRECT_MAX and lohi is None else "direct"
    if solver == "amg" and lohi is not None:
        raise OptionError("bounds with samples inside faces are solved by factorising their KKT system; "
                          "pass solver='direct' (or 'auto')")
    if solver == "amg" and k > 1:
        _, tol, maxiter = PolyharmonicSolver.settings(k, free, "amg", tol, maxiter)
    return solver, tol, maxiter


def _eliminated(A, idx, vals, Aeq, beq, *, tol, maxiter, on_empty, symmetric_pattern):
    """Samples inside faces with AMG-preconditioned CG: ``x = T z + t`` meets the rows, ``T' A T`` is SPD."""


    t0 = time.perf_counter()
    n, p = A.shape[0], vals.shape[1]
    ncomp, labels = pattern_components(A, symmetric=symmetric_pattern)
    anchored = np.bincount(np.concatenate([labels[idx], labels[Aeq.indices]]), minlength=ncomp) > 0
    empty = ~anchored[labels]
    comps = sorted(({"vertices": int((labels == c).sum()), "example_vertex": int(np.flatnonzero(labels == c)[0])}
                    for c in np.flatnonzero(~anchored)), key=lambda e: -e["vertices"])
    if comps and on_empty == "error":
        e = comps[0]
        raise SolveError(f"a connected component of {e['vertices']} vertices (e.g. vertex {e['example_vertex']}) "
                         f"has no sample, so its values are undetermined; add a sample there, or pass "
                         f"on_empty='nan' (CLI: --on-empty nan) to leave it NaN")
    T, t, kept = eliminate_rows(Aeq, beq, idx, n)
    pos = np.full(n, -1, dtype=np.int64)
    pos[kept] = np.arange(kept.size)
    Ar = (T.T @ A @ T).tocsr()
    fixed = pos[idx]
    free = np.ones(kept.size, dtype=bool)
    free[fixed] = False
    free[empty[kept]] = False
    fz = np.flatnonzero(free)
    rows = Ar[fz]
    R = -(rows[:, fixed] @ vals) - (T.T @ (A @ t))[fz]
    t1 = time.perf_counter()
    backend = make_linear_solver(rows[:, fz].tocsr(), "amg", rtol=tol, maxiter=maxiter)
    Zf, info = backend.solve(R, None)
    Z = np.zeros((kept.size, p))
    Z[fixed], Z[fz] = vals, Zf
    X = T @ Z + t
    X[empty] = np.nan
    report = {"vertices": n, "fixed": int(idx.size), "unknowns": int(fz.size), "components": int(ncomp),
              "empty_components": comps, "equality_rows": int(Aeq.shape[0]), "eliminated": True,
              "solver": backend.name, **{k: v for k, v in info.items() if k != "solver"},
              "seconds": {"partition": t1 - t0, "setup": backend.setup_seconds, "solve": time.perf_counter() - t1}}
    return X, report
