"""Benchmark: end-to-end reconstruction speed on a 655,362-vertex icosphere, beside libigl.

For 100 and 1,000 random samples of a smooth field, ``manifill.reconstruct`` (the
default ``gvf-harmonic`` pipeline: check, partition, curve values, harmonic fill)
is timed per step, and ``igl.harmonic`` (k = 1) solves the same Dirichlet problem
(the same fixed curve vertices and values) in the same run. Also measured:

- the gradual variation check alone for 1,000 samples, against the paper's way
  (one Dijkstra per sample, extrapolated from 20 of them);
- the harmonic fill of the patches solved as one system (AMG, the default) and
  patch by patch (one sparse LU per patch, on two threads);
- the paper's averaging iteration started from random values and from the GVF
  fit (iteration counts), on a 10,242-vertex icosphere.

Run from the repository root::

    python bench/reconstruct_speed.py [--level 8] [--repeat 3] [--quick]

Targets: total <= 0.6 x libigl's solve alone; the check <= 1 s for 1,000 samples.
"""

import argparse
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph
from scipy.sparse.linalg import splu

import manifill
from manifill.mesh.graph import mesh_graph
from manifill.surface.gradual import check_gradual
from manifill.surface.harmonic import HarmonicSolver
from manifill.surface.reconstruct import reconstruct
from manifill.mesh.shapes import icosphere


def field(V):
    return np.sin(2 * V[:, 0]) + V[:, 1] * V[:, 2] + 0.5 * np.cos(3 * V[:, 1])


def patchwise(L, fixed, bc_full):
    """Harmonic fill patch by patch: one LU factorisation per patch, on two threads."""
    free = np.flatnonzero(~fixed)
    Lff = L[free][:, free].tocsr()
    rhs = -(L[free][:, np.flatnonzero(fixed)] @ bc_full[fixed])
    ncomp, lab = csgraph.connected_components(Lff, directed=False)
    order = np.argsort(lab, kind="stable")
    bounds = np.searchsorted(lab[order], np.arange(ncomp + 1))
    x = np.empty(free.size)

    def one(c):
        rows = order[bounds[c]:bounds[c + 1]]
        x[rows] = splu(sp.csc_matrix(Lff[rows][:, rows])).solve(rhs[rows])

    with ThreadPoolExecutor(2) as pool:
        list(pool.map(one, range(ncomp)))
    out = bc_full.copy()
    out[free] = x
    return out, ncomp


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--level", type=int, default=8)
    ap.add_argument("--quick", action="store_true", help="smaller mesh, no libigl (smoke run)")
    ap.add_argument("--repeat", type=int, default=3, help="runs of each, alternating; the best counts")
    args = ap.parse_args(argv)
    level = 5 if args.quick else args.level
    igl = None
    if not args.quick:
        import igl
    V, F = icosphere(level)
    f = field(V)
    print(f"manifill {manifill.__version__}: icosphere level {level}, {len(V):,} vertices")
    for k in (100, 1000):
        rng = np.random.default_rng(0)
        idx = np.sort(rng.choice(len(V), size=k, replace=False))
        runs, igl_runs = [], []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            r = reconstruct(V, F, idx, f[idx])
            runs.append(time.perf_counter() - t0)
            b = np.flatnonzero(r.on_curve)
            if igl is not None:
                t0 = time.perf_counter()
                z = igl.harmonic(V, F.astype(np.int64), b, r.values[b][:, None], 1).ravel()
                igl_runs.append(time.perf_counter() - t0)
        total = min(runs)
        steps = ", ".join(f"{s} {v:.2f}" for s, v in r.report["seconds"].items() if s != "total")
        print(f"\n{k} samples: reconstruct best {total:.2f} s (runs {', '.join(f'{t:.2f}' for t in runs)}; "
              f"last run: {steps})")
        print(f"  partition: {r.report['partition']['curves']} curves, {r.report['partition']['patches']} patches, "
              f"{r.report['partition']['curve_vertices']:,} curve vertices")
        if igl is not None:
            t_igl = min(igl_runs)
            print(f"  igl.harmonic on the same fixed set: best {t_igl:.2f} s (runs "
                  f"{', '.join(f'{t:.2f}' for t in igl_runs)}); ratio best / best {total / t_igl:.2f} "
                  f"(target <= 0.6); max difference {np.abs(z - r.values).max():.1e}")
        # the fill as one system vs patch by patch
        L = manifill.laplacian(V, F)
        t0 = time.perf_counter()
        x1 = HarmonicSolver.from_laplacian(L, b, symmetric_pattern=True).solve(r.values[b])
        t_one = time.perf_counter() - t0
        t0 = time.perf_counter()
        x2, npatch = patchwise(L, r.on_curve, r.values)
        t_patch = time.perf_counter() - t0
        print(f"  harmonic fill, one system (default): {t_one:.2f} s; patch by patch ({npatch} LU "
              f"factorisations, 2 threads): {t_patch:.2f} s; max difference {np.abs(x1 - x2).max():.1e}")

    # the check alone, 1,000 samples, against one Dijkstra per sample
    rng = np.random.default_rng(0)
    idx = np.sort(rng.choice(len(V), size=1000, replace=False))
    G = mesh_graph(V, F, distance="hops")
    t0 = time.perf_counter()
    c = check_gradual(G, idx, f[idx])
    t_check = time.perf_counter() - t0
    t0 = time.perf_counter()
    csgraph.dijkstra(G, indices=idx[:20], unweighted=True)
    t_pair = (time.perf_counter() - t0) / 20 * idx.size
    print(f"\ncheck, 1,000 samples: {t_check:.2f} s (target <= 1 s; {c.levels.size} levels, holds={c.holds}); "
          f"one Dijkstra per sample would take about {t_pair:.0f} s")

    # the paper's iteration: random start vs GVF start
    Vs, Fs = icosphere(5)
    fs = field(Vs)
    rng = np.random.default_rng(1)
    idx = np.sort(rng.choice(len(Vs), size=100, replace=False))
    print(f"\naveraging iteration (Gauss-Seidel) on {len(Vs):,} vertices, 100 samples, tol 1e-8:")
    for init in ("random", "gvf", "mean"):
        t0 = time.perf_counter()
        r = reconstruct(Vs, Fs, idx, fs[idx], solver="iterate", init=init, tol=1e-8)
        print(f"  init={init:6s}: {r.report['fill']['iterations'][0]:5d} sweeps, {time.perf_counter() - t0:.2f} s")


if __name__ == "__main__":
    main()
