"""The paper's reconstruction on a surface, Steps 1-6, as one call.

``gvf-harmonic`` (the default) runs the whole pipeline: check the gradual variation
condition and choose levels (Step 1, :mod:`manifill.surface.gradual`); cut the surface by
curves through every sample (Steps 2-3, :mod:`manifill.partition`); give every
curve vertex a value (Step 4, :mod:`manifill.surface.curve_values`); fill every patch
harmonically with the curve values fixed (Steps 5-6, :mod:`manifill.harmonic`).
``harmonic`` fixes only the samples (the naive baseline) and ``gvf`` stops at the
gradually varied fit of the whole surface.
"""

import time
from dataclasses import dataclass, field

import numpy as np

from .curve_values import CURVE_VALUES
from .curve_values import curve_values as _curve_values
from ..errors import SampleError
from ..mesh.graph import DISTANCES, mesh_graph
from .gradual import check_gradual, gvf, violation_message
from .harmonic import ON_EMPTY, HarmonicSolver
from ..mesh.laplacian import WEIGHTS, assemble_laplacian
from .partition import PARTITIONS
from .partition import partition as _partition
from ..progress import tick
from ..linalg.backends import ITERATIONS, SOLVERS
from ..mesh.topology import EdgeIndex
from ..validate import as_mesh, as_samples, check_option

__all__ = ["METHODS", "INITS", "Reconstruction", "reconstruct"]

METHODS = ("gvf-harmonic", "harmonic", "gvf")
INITS = ("gvf", "random", "mean")


@dataclass
class Reconstruction:
    """The result of :func:`reconstruct`.

    Attributes
    ----------
    values : (n,) or (n, p) numpy array
        The field at every vertex, equal to the samples at the samples.
    curves : list of (l,) int64 numpy arrays
        The partition curves (``gvf-harmonic``; empty otherwise).
    components : (n,) int64 numpy array
        Patch of every vertex, ``-1`` on the curves (all ``0`` for methods
        without a partition).
    on_curve : (n,) bool numpy array
        The vertices whose values were fixed before the harmonic fill.
    levels : list of (m,) numpy arrays
        The value levels of each field (Step 1).
    report : dict
        Diagnostics: the gradual variation check per field (Lipschitz
        constant, level step, violations), the partition's report, the
        harmonic solver's report, and ``seconds`` per step.
    V : (n, 3) numpy array
        The surface's vertices (as validated).
    F : (m, 3) int64 numpy array or None
        Its triangles (None on a digital surface, which has none).
    idx : (k,) int64 numpy array
        The sample vertices (sorted, unique).
    """

    values: np.ndarray
    curves: list
    components: np.ndarray
    on_curve: np.ndarray
    levels: list
    report: dict = field(default_factory=dict)
    V: np.ndarray = None
    F: np.ndarray = None
    idx: np.ndarray = None

    def point_data(self, names=None):
        """The fields and manifill's masks, named as in every output file.

        Parameters
        ----------
        names : list of str, optional
            One name per field (``value``, ``value2``, ... by default).

        Returns
        -------
        dict of str to (n,) numpy array
            The fields, ``sample_mask``, ``curve_mask`` and ``patch_label``.
        """
        from ..io.registry import CURVE_MASK, PATCH_LABEL, SAMPLE_MASK
        from .samples import field_names

        X = self.values if self.values.ndim == 2 else self.values[:, None]
        data = dict(zip(field_names(names, X.shape[1]), X.T))
        sample = np.zeros(len(X), dtype=bool)
        sample[self.idx] = True
        return {**data, SAMPLE_MASK: sample, CURVE_MASK: self.on_curve, PATCH_LABEL: self.components}

    def to_pyvista(self, names=None):
        """The surface with every field and mask as a ``pyvista.PolyData`` (needs the ``[viz]`` extra).

        Examples
        --------
        >>> from manifill.mesh.shapes import icosphere
        >>> V, F = icosphere(2)
        >>> r = reconstruct(V, F, [0, 10, 50, 90, 120], [1.0, 2.0, 3.0, 4.0, 5.0])
        >>> sorted(r.to_pyvista(["t"]).point_data.keys())
        ['curve_mask', 'patch_label', 'sample_mask', 't']
        """
        from ..mesh.objects import to_pyvista

        return to_pyvista(self.V, self.F, self.point_data(names))

    def to_meshio(self, names=None):
        """The surface with every field and mask as a ``meshio.Mesh``."""
        from ..mesh.objects import to_meshio

        return to_meshio(self.V, self.F, self.point_data(names))


def reconstruct(V, F, idx, vals, *, method="gvf-harmonic", partition="delaunay", weights="cotan",
                distance="length", levels=None, curve_values="hermite", solver="auto",
                on_empty="error", duplicates="error", iteration="gauss-seidel", init="gvf", seed=0,
                tol=None, maxiter=None, progress=None):
    """Reconstruct a field on a surface from a few samples (the paper's Steps 1-6).

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles, any integer dtype.
    idx : (k,) array_like of int
        Sample vertices.
    vals : (k,) or (k, p) array_like of float
        Sample values, one column per field.
    method : {'gvf-harmonic', 'harmonic', 'gvf'}, optional
        The whole pipeline; harmonic with the samples alone fixed; or the
        gradually varied fit of the whole surface (every vertex but the
        samples on a level).
    partition : {'delaunay', 'cycle', 'tree'}, optional
        How the curves are drawn (:mod:`manifill.partition`).
    weights : {'cotan', 'uniform', 'intrinsic', 'robust'}, optional
        Laplacian weights of the harmonic fill.
    distance : {'length', 'hops'}, optional
        What the partition's shortest paths minimise. Step 1 (levels and the
        Lipschitz constant in ``report['check']``) always measures hops, as the
        paper's gradual variation does.
    levels : None, int or (m,) array_like, optional
        Value levels for Step 1 (see :func:`manifill.surface.gradual.check_gradual`);
        by default the finest uniform step at which the samples satisfy the
        condition. With ``curve_values='gvf'`` or ``method='gvf'`` a
        violation is an error; otherwise it is reported.
    curve_values : {'hermite', 'linear', 'gvf'}, optional
        Step 4 (:mod:`manifill.surface.curve_values`): cubic along each path with slopes
        from estimated gradients (the most accurate on smooth fields; may
        overshoot slightly, reported as ``report['overshoot']``), linear in arc
        length (never leaves the samples' range), or the paper's gradually
        varied fit on the levels.
    solver : {'auto', 'direct', 'amg', 'iterate'}, optional
        Linear solver of the harmonic fill.
    on_empty : {'error', 'nan'}, optional
        A mesh component without samples: raise, or leave it NaN.
    duplicates : {'error', 'mean'}, optional
        Several samples on one vertex with different values: raise, or average.
    iteration : {'gauss-seidel', 'jacobi'}, optional
        Sweeps of ``solver='iterate'``.
    init : {'gvf', 'random', 'mean'}, optional
        Initial values of ``solver='iterate'`` (the paper's Step 5: random, or
        the GVF fit, which it says converges faster).
    seed : int, optional
        Seed of ``init='random'``.
    tol, maxiter : optional
        Passed to the solver.
    progress : callable, optional
        Called with the name of each step as it starts (e.g.
        :class:`manifill.progress.StepBar`).

    Returns
    -------
    Reconstruction

    Raises
    ------
    MeshError, SampleError, OptionError, SolveError
        On malformed input, broken gradual variation where it is required, or
        a component without samples (``on_empty='error'``).

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(3)
    >>> idx = np.arange(0, 642, 40)
    >>> r = reconstruct(V, F, idx, V[idx, 0] + V[idx, 2])
    >>> bool(np.allclose(r.values[idx], V[idx, 0] + V[idx, 2])), r.report["partition"]["method"]
    (True, 'delaunay')
    """
    t0 = time.perf_counter()
    _check_options(method, partition, weights, distance, curve_values, solver, on_empty, iteration, init)
    V, F = as_mesh(V, F, allow_degenerate=weights in ("uniform", "robust"))
    n = len(V)
    idx, vals, squeeze = as_samples(idx, vals, n, duplicates=duplicates)
    seconds = {"validate": time.perf_counter() - t0}

    tick(progress, "graph")
    t = time.perf_counter()
    index = EdgeIndex(F, n)
    G_hops = mesh_graph(V, F, distance="hops", index=index)
    G = G_hops if distance == "hops" else mesh_graph(V, F, distance="length", index=index)
    seconds["graph"] = time.perf_counter() - t
    surface = _Surface(V, G_hops, G, lambda w: assemble_laplacian(V, F, w, index), F=F)
    return _pipeline(surface, idx, vals, squeeze, seconds, t0, method=method, partition=partition, weights=weights,
                     levels=levels, curve_values=curve_values, solver=solver, on_empty=on_empty,
                     iteration=iteration, init=init, seed=seed, tol=tol, maxiter=maxiter, progress=progress)


def _check_options(method, partition, weights, distance, curve_values, solver, on_empty, iteration, init):
    check_option("method", method, METHODS)
    check_option("partition", partition, PARTITIONS)
    check_option("weights", weights, WEIGHTS)
    check_option("distance", distance, DISTANCES)
    check_option("curve_values", curve_values, CURVE_VALUES)
    check_option("solver", solver, SOLVERS)
    check_option("on_empty", on_empty, ON_EMPTY)
    check_option("iteration", iteration, ITERATIONS)
    check_option("init", init, INITS)


@dataclass
class _Surface:
    """What Steps 1-6 need of a surface: positions, the two graphs, a Laplacian, normals.

    A triangle mesh gives all of them from ``(V, F)``; a digital surface (the
    boundary voxels of a solid) gives graphs from voxel adjacency and normals
    from the solid, and has no triangles (``F`` is None).
    """

    V: np.ndarray
    G_hops: object
    G: object
    laplacian: object
    F: np.ndarray = None
    normals: np.ndarray = None


def _pipeline(surface, idx, vals, squeeze, seconds, t0, *, method, partition, weights, levels, curve_values,
              solver, on_empty, iteration, init, seed, tol, maxiter, progress=None):
    """Steps 1-6 on a validated surface and validated samples."""
    V, F, G_hops, G = surface.V, surface.F, surface.G_hops, surface.G
    n = len(V)
    report = {"method": method, "samples": int(idx.size), "vertices": n, "seconds": seconds}

    # Steps 2-3 first when they run: the hop length of every curve bounds the Lipschitz
    # constant of Step 1 from below, which saves Step 1 a shortest-path pass
    part, starts = None, [None] * vals.shape[1]
    if method == "gvf-harmonic":
        tick(progress, "partition")
        t = time.perf_counter()
        part = _partition(V, F, idx, G, method=partition)
        seconds["partition"] = time.perf_counter() - t
        if part.curves:
            pos = np.searchsorted(idx, part.ends)
            hops = np.array([len(c) - 1 for c in part.curves], dtype=np.float64)
            ok = hops > 0
            for j in range(vals.shape[1]):
                ratio = np.where(ok, np.abs(vals[pos[:, 0], j] - vals[pos[:, 1], j]) / np.maximum(hops, 1), 0.0)
                best = int(np.argmax(ratio))
                starts[j] = (float(ratio[best]), (int(pos[best, 0]), int(pos[best, 1])))

    # Step 1: levels and the gradual variation condition (hop distance), per field
    tick(progress, "check")
    t = time.perf_counter()
    checks = [check_gradual(G_hops, idx, vals[:, j], levels=levels, distance="hops", start=starts[j])
              for j in range(vals.shape[1])]
    strict = method == "gvf" or curve_values == "gvf"
    for c in checks:
        if strict and not c.holds:
            raise SampleError(violation_message(c))
    report["check"] = [
        {"holds": c.holds, "lipschitz_hops": c.lipschitz, "step": c.step, "levels": int(c.levels.size),
         "violations": int(len(c.violations)), "level_error": c.level_error}
        for c in checks
    ]
    seconds["check"] = time.perf_counter() - t
    levels_out = [c.levels for c in checks]

    def fit_gvf():
        """GVF of the whole surface: levels everywhere, the samples' own values at the samples."""
        X = np.empty((n, vals.shape[1]))
        for j, c in enumerate(checks):
            lev = gvf(G_hops, idx, c.level)
            X[:, j] = np.where(lev >= 0, c.levels[np.maximum(lev, 0)], np.nan)
        X[idx] = vals
        return X

    curves, components = [], np.zeros(n, dtype=np.int64)
    fixed = np.zeros(n, dtype=bool)
    fixed[idx] = True
    if method == "gvf":
        tick(progress, "gvf")
        t = time.perf_counter()
        X = fit_gvf()
        seconds["gvf"] = time.perf_counter() - t
        empty = np.isnan(X[:, 0])
        if empty.any() and on_empty == "error":
            from ..errors import SolveError

            v = int(np.flatnonzero(empty)[0])
            raise SolveError(
                f"{int(empty.sum())} vertices (e.g. vertex {v}) lie in components without samples, so their "
                f"values are undetermined; add a sample there, or pass on_empty='nan' to leave them NaN")
        values = X
    else:
        if method == "gvf-harmonic":
            # Step 4: values on the curves of the partition (Steps 2-3, above)
            report["partition"] = part.report
            curves, components, fixed = part.curves, part.labels, part.on_curve.copy()
            tick(progress, "curve values")
            t = time.perf_counter()
            if curve_values == "gvf":
                cols = [_curve_values(V, part.curve_edges(), idx, vals[:, j], method="gvf",
                                      levels=c.levels, level=c.level) for j, c in enumerate(checks)]
                b, bc = cols[0][0], np.column_stack([cv for _, cv in cols])
            else:
                b, bc = _curve_values(V, part.curve_edges(), idx, vals, method=curve_values, F=F,
                                      curves=part.curves, ends=part.ends, normals=surface.normals)
            seconds["curve_values"] = time.perf_counter() - t
        else:
            b, bc = idx, vals
        # Steps 5-6: harmonic fill of every patch
        tick(progress, "harmonic fill")
        t = time.perf_counter()
        L = surface.laplacian(weights)
        hs = HarmonicSolver.from_laplacian(L, b, solver=solver, on_empty=on_empty, iteration=iteration,
                                           tol=tol, maxiter=maxiter,
                                           symmetric_pattern=weights in ("uniform", "cotan"))
        hs.report["weights"] = weights
        x0 = None
        if hs.report["solver"] == "iterate":
            if init == "gvf":
                x0 = fit_gvf()
            elif init == "random":
                rng = np.random.default_rng(seed)
                lo, hi = vals.min(axis=0), vals.max(axis=0)
                x0 = lo + (hi - lo) * rng.random((n, vals.shape[1]))
        values = hs.solve(bc, x0=x0)
        values = values if values.ndim == 2 else values[:, None]
        seconds["harmonic"] = time.perf_counter() - t
        report["harmonic"] = {k: v for k, v in hs.report.items() if k != "seconds"}
        report["harmonic"]["seconds"] = dict(hs.report["seconds"])
    lo, hi = vals.min(axis=0), vals.max(axis=0)
    X = values if values.ndim == 2 else values[:, None]
    with np.errstate(invalid="ignore"):
        report["overshoot"] = float(np.nanmax(np.maximum(X - hi, lo - X))) if np.isfinite(X).any() else 0.0
    seconds["total"] = time.perf_counter() - t0
    return Reconstruction(
        values=values[:, 0] if squeeze else values,
        curves=curves,
        components=components,
        on_curve=fixed,
        levels=levels_out,
        report=report,
        V=V,
        F=F,
        idx=idx,
    )
