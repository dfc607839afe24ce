"""Benchmark: the harmonic solve on a 655,362-vertex icosphere beside libigl, in one run.

The fixed set is a curve network like the one the paper's pipeline produces: the
vertices along three great circles (the planes x = 0, y = 0, z = 0), which cut the
sphere into eight patches. Both tools solve the same cotangent Dirichlet problem;
the script prints both times, their ratio and the relative difference of the
answers. Run from the repository root::

    python bench/harmonic_icosphere.py [--level 8] [--repeat 3]

Times are the best of ``--repeat`` runs of each tool, interleaved, so that a noisy
machine affects both alike. The target is manifill <= 0.35 x libigl's time with
the same answer to 1e-8 relative.
"""

import argparse
import platform
import time

import numpy as np

import manifill
from manifill.mesh.shapes import icosphere
from manifill.mesh.edges import adjacency


def great_circle_network(V, F):
    """Vertices on the non-negative side of an edge crossing x = 0, y = 0 or z = 0."""
    A = adjacency(F, len(V)).tocoo()
    fixed = np.zeros(len(V), dtype=bool)
    for axis in range(3):
        side = V[:, axis] >= 0
        crossing = side[A.row] & ~side[A.col]
        fixed[A.row[crossing]] = True
    return np.flatnonzero(fixed)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--level", type=int, default=8, help="icosphere subdivisions (8: 655,362 vertices)")
    parser.add_argument("--repeat", type=int, default=3, help="runs of each tool; the best is reported")
    parser.add_argument("--no-igl", action="store_true", help="skip libigl (smoke runs)")
    args = parser.parse_args(argv)

    V, F = icosphere(args.level)
    b = great_circle_network(V, F)
    f = np.sin(2 * V[:, 0]) + V[:, 1] * V[:, 2] + 0.5 * np.cos(3 * V[:, 1])
    bc = f[b]
    print(f"manifill {manifill.__version__}, numpy {np.__version__}, python {platform.python_version()}")
    print(f"icosphere level {args.level}: {len(V):,} vertices, {len(F):,} faces, {len(b):,} fixed")

    igl = None
    if not args.no_igl:
        import igl  # test-only oracle
        F64 = F.astype(np.int64)
    t_mf, t_igl = [], []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        solver = manifill.HarmonicSolver(V, F, b)
        x = solver.solve(bc)
        t_mf.append(time.perf_counter() - t0)
        if igl is not None:
            t0 = time.perf_counter()
            z = igl.harmonic(V, F64, b, bc[:, None], 1).ravel()
            t_igl.append(time.perf_counter() - t0)
    print("manifill steps (last run):", {k: round(v, 3) for k, v in solver.report["seconds"].items()},
          "iterations", solver.report.get("iterations"), "solver", solver.report["solver"],
          "blocks", solver.report.get("blocks"))
    print(f"manifill.HarmonicSolver + solve: best {min(t_mf):.2f} s  (runs: {', '.join(f'{t:.2f}' for t in t_mf)})")
    if igl is not None:
        rel = np.linalg.norm(x - z) / np.linalg.norm(z)
        runs = ", ".join(f"{t:.2f}" for t in t_igl)
        print(f"igl.harmonic(k=1):               best {min(t_igl):.2f} s  (runs: {runs})")
        print(f"ratio manifill / libigl: {min(t_mf) / min(t_igl):.3f}  (target <= 0.35)")
        print(f"relative difference ||x - x_igl|| / ||x_igl||: {rel:.2e}  (target <= 1e-8)")


if __name__ == "__main__":
    main()
