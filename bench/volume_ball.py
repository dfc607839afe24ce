"""Benchmark: the harmonic fill of a voxel ball (Step 8) at 128^3 and 256^3: time and peak memory.

A ball of diameter N - 2 voxels in an N^3 grid, its boundary voxels fixed to the
harmonic polynomial ``x^2 - y^2 + z / 2`` (which the 7-point stencil reproduces
exactly, so the error measures the solver), every other voxel filled by
``manifill.harmonic_fill`` (geometric multigrid, relative residual 1e-10). Each
run is a fresh process under ``/usr/bin/time -v``, whose "Maximum resident set
size" is the peak memory. ``--baseline`` also runs pyamg's default smoothed
aggregation with CG on the assembled Laplacian, in the same way.

Run from the repository root::

    python bench/volume_ball.py [--sizes 128 256] [--baseline] [--quick]

Target: the 256^3 fill in <= 30 s and <= 4 GB.
"""

import argparse
import json
import os
import re
import subprocess
import sys
import time

import numpy as np


def ball(n):
    c = (n - 1) / 2
    x, y, z = np.ogrid[:n, :n, :n]
    return (x - c) ** 2 + (y - c) ** 2 + (z - c) ** 2 <= (n / 2 - 1) ** 2


def exact(n):
    i, j, k = np.indices((n, n, n), dtype=np.float64) / n
    return i**2 - j**2 + 0.5 * k


def one(n, solver):
    """One fill in this process; prints a JSON line."""
    from manifill.solid.boundary import boundary_voxels

    mask = ball(n)
    fixed = boundary_voxels(mask)
    f = exact(n)
    out = {"n": n, "solver": solver, "voxels": int(mask.sum()), "unknowns": int((mask & ~fixed).sum())}
    if solver == "pyamg":
        import pyamg

        from manifill.solid.voxels import voxel_laplacian

        t0 = time.perf_counter()
        L = voxel_laplacian(mask)
        b = fixed[mask]
        A = L[~b][:, ~b].tocsr()
        rhs = -(L[~b][:, b] @ f[fixed])
        t1 = time.perf_counter()
        ml = pyamg.smoothed_aggregation_solver(A)
        t2 = time.perf_counter()
        res = []
        x = ml.solve(rhs, tol=1e-10, accel="cg", residuals=res)
        t3 = time.perf_counter()
        err = float(np.abs(x - f[mask & ~fixed]).max())
        out.update(seconds=t3 - t0, assemble=t1 - t0, setup=t2 - t1, solve=t3 - t2, iterations=len(res) - 1)
    else:
        from manifill import VoxelFill

        voxels, vals = np.argwhere(fixed), f[fixed]  # the samples, as every solve takes them
        t0 = time.perf_counter()
        fill = VoxelFill(mask, voxels, solver=solver)
        x = fill.solve(vals)
        out["seconds"] = time.perf_counter() - t0
        err = float(np.nanmax(np.abs(x - f)[mask]))
        out.update(setup=fill.report["seconds"]["check"] + fill.report["seconds"]["setup"],
                   solve=fill.report["seconds"]["solve"], iterations=fill.report["iterations"][0],
                   levels=fill.report.get("levels"))
    out["max_error"] = err
    print(json.dumps(out))


def measured(n, solver):
    """Run :func:`one` in a fresh process under /usr/bin/time -v."""
    cmd = [sys.executable, os.path.abspath(__file__), "--one", str(n), "--solver", solver]
    timer = ["/usr/bin/time", "-v"] if os.path.exists("/usr/bin/time") else []
    proc = subprocess.run(timer + cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise SystemExit(f"run failed ({' '.join(cmd)}):\n{proc.stderr[-2000:]}")
    row = json.loads(proc.stdout.strip().splitlines()[-1])
    m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", proc.stderr)
    row["peak_gb"] = int(m.group(1)) / 1e6 if m else float("nan")
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[128, 256])
    ap.add_argument("--baseline", action="store_true", help="also pyamg's default SA + CG")
    ap.add_argument("--quick", action="store_true", help="a 48^3 ball only (smoke run)")
    ap.add_argument("--one", type=int, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--solver", default="multigrid", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one:
        one(args.one, args.solver)
        return
    import manifill

    sizes = [48] if args.quick else args.sizes
    print(f"manifill {manifill.__version__}, numpy {np.__version__}, python {sys.version.split()[0]}")
    print(f"{'grid':>6} {'solver':>10} {'unknowns':>11} {'total s':>8} {'setup s':>8} {'solve s':>8} "
          f"{'iters':>6} {'peak GB':>8} {'max error':>10}")
    for n in sizes:
        for solver in ["multigrid"] + (["pyamg"] if args.baseline else []):
            r = measured(n, solver)
            print(f"{n:>4}^3 {solver:>10} {r['unknowns']:>11,} {r['seconds']:>8.1f} {r['setup']:>8.1f} "
                  f"{r['solve']:>8.1f} {r['iterations']:>6} {r['peak_gb']:>8.2f} {r['max_error']:>10.1e}")
            if n == 256 and solver == "multigrid":
                print(f"       target <= 30 s and <= 4 GB: time {r['seconds'] / 30:.2f} of the budget, "
                      f"memory {r['peak_gb'] / 4:.2f} of the budget")


if __name__ == "__main__":
    main()
