"""Benchmark: biharmonic interpolation on a 163,842-vertex icosphere, manifill's solvers beside libigl.

The same problem for every tool: ``--samples`` random vertices (seeded) carrying a
smooth field, the cotangent bilaplacian with Voronoi mass (libigl's
``igl.harmonic(V, F, b, bc, 2)``). Prints one table: each solver's time (set-up
and solve, from the mesh), its ratio to libigl's, and its largest difference from
libigl's answer relative to the range of the samples. Run from the repository
root::

    python bench/biharmonic_speed.py [--level 7] [--samples 1000] [--repeat 1] [--k 2]
    python bench/biharmonic_speed.py --quick     # a small mesh, for a smoke run

Target: the ``auto`` solver at most 0.3x libigl's time, equal to 1e-8 relative.
"""

import argparse
import platform
import time

import numpy as np
import scipy

import manifill
from manifill.mesh.shapes import icosphere
from manifill.surface.polyharmonic import PolyharmonicSolver


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--level", type=int, default=7, help="icosphere subdivisions (7: 163,842 vertices)")
    parser.add_argument("--samples", type=int, default=1000, help="random fixed vertices")
    parser.add_argument("--k", type=int, default=2, help="order (2 biharmonic, 3 triharmonic)")
    parser.add_argument("--repeat", type=int, default=1, help="runs of each tool; the best is reported")
    parser.add_argument("--solvers", default="auto,direct,amg", help="manifill solvers, comma-separated")
    parser.add_argument("--quick", action="store_true", help="level 4, 100 samples (smoke run)")
    parser.add_argument("--no-igl", action="store_true", help="skip libigl")
    args = parser.parse_args(argv)
    if args.quick:
        args.level, args.samples = 4, 100

    V, F = icosphere(args.level)
    rng = np.random.default_rng(0)
    b = rng.choice(len(V), size=args.samples, replace=False)
    f = np.sin(2 * V[:, 0]) + V[:, 1] * V[:, 2] + 0.5 * np.cos(3 * V[:, 1])
    bc = f[b]
    print(f"manifill {manifill.__version__}, numpy {np.__version__}, scipy {scipy.__version__}, "
          f"python {platform.python_version()}")
    print(f"icosphere level {args.level}: {len(V):,} vertices, {len(F):,} faces, {len(b):,} samples, k = {args.k}")

    tools = []
    if not args.no_igl:
        import igl  # the reference

        F64, b64 = F.astype(np.int64), b.astype(np.int64)
        tools.append(("libigl harmonic(k)", lambda: (None, igl.harmonic(V, F64, b64, bc[:, None], args.k)[:, 0])))
    for name in args.solvers.split(","):
        def run(name=name):
            s = PolyharmonicSolver(V, F, b, k=args.k, solver=name, mass="voronoi")  # libigl's mass
            return s, s.solve(bc)

        tools.append((f"manifill solver={name}", run))
    best = {name: (np.inf, None) for name, _ in tools}
    for _ in range(args.repeat):  # interleaved, so that a busy machine slows every tool alike
        for name, fn in tools:
            t0 = time.perf_counter()
            out = fn()
            t = time.perf_counter() - t0
            if t < best[name][0]:
                best[name] = (t, out)
    rows = []
    ref = t_igl = None
    if not args.no_igl:
        t_igl, (_, ref) = best[tools[0][0]]
        rows.append((tools[0][0], t_igl, None, None, 0.0, ""))
    for name, _ in tools[len(rows):]:
        t, (s, x) = best[name]
        sec = s.report["seconds"]
        its = s.report.get("iterations")
        note = f"{s.report['solver']}" + (f", {its[0]} iterations" if its else "")
        err = None if ref is None else float(np.abs(x - ref).max() / np.ptp(bc))
        rows.append((name, t, sec.get("setup", 0.0) + sec["energy"] + sec["partition"], sec["solve"], err, note))

    print()
    print("| tool | seconds | x libigl | set-up s | solve s | max diff / range | notes |")
    print("|---|---|---|---|---|---|---|")
    for name, t, setup, solve, err, note in rows:
        ratio = "" if t_igl is None else f"{t / t_igl:.2f}"
        print(f"| {name} | {t:.2f} | {ratio} | {'' if setup is None else f'{setup:.2f}'} | "
              f"{'' if solve is None else f'{solve:.2f}'} | {'' if err is None else f'{err:.1e}'} | {note} |")


if __name__ == "__main__":
    main()
