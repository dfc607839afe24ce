"""The biharmonic with SciPy alone beside Pardiso: the projected biharmonic, the pipeline, the old AMG.

``python -m bench.biharmonic_scipy [--levels 6,7,8] [--ks 100,1000] [--repeat 1]``

For each icosphere level and sample count (``default_rng(0)``, the smooth field of
``bench.default_targets``), one process times, one after the other: the default (the paper's
pipeline, monotone curves, bounded), ``method='biharmonic', bounds='samples',
bounds_mode='project'`` with Pardiso (``[fast]``), the same with SciPy alone
(``MANIFILL_DIRECT=superlu``: ``solver='auto'`` then takes AMG with the positions as candidates,
:mod:`manifill.linalg.amg_candidates`), and the AMG without candidates that ``auto`` used before
(the core's :class:`~manifill.linalg.backends.AMGSolver` on the same reduced system). The row gives
seconds, the SciPy/Pardiso ratio (issue 37's target: at most 2), the projected/pipeline ratio with
each, CG steps, and the largest difference between the Pardiso and the SciPy fields.
"""

import argparse
import os
import platform
import time

import numpy as np

from .default_targets import _timed


def main(argv=None):
    from manifill import reconstruct
    from manifill.linalg.backends import AMGSolver
    from manifill.linalg.factorise import DIRECT_ENV
    from manifill.linalg.quadratic import QuadraticSolver
    from manifill.mesh.laplacian import laplacian, mass_matrix
    from manifill.linalg.energies import polyharmonic_energy
    from manifill.mesh.shapes import icosphere

    from .fields import smooth_field

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", default="6,7,8")
    ap.add_argument("--ks", default="100,1000")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--old-amg", action="store_true", help="also time the AMG without candidates (slow)")
    args = ap.parse_args(argv)
    V, F = icosphere(2)
    reconstruct(V, F, np.arange(0, 162, 9), V[::9, 0], method="biharmonic", solver="direct")  # load Pardiso
    print(f"# SciPy alone against Pardiso ({platform.machine()}, {time.strftime('%Y-%m-%d %H:%M')})")
    print("| vertices | samples | pipeline s | projected, Pardiso s | projected, SciPy s | SciPy/Pardiso | "
          "Pardiso/pipeline | SciPy/pipeline | CG steps | old AMG s (steps) | max diff |")
    print("|---|---|---|---|---|---|---|---|---|---|---|", flush=True)
    proj = dict(method="biharmonic", bounds="samples", bounds_mode="project", check=False)
    for level in (int(v) for v in args.levels.split(",")):
        V, F = icosphere(level)
        f = smooth_field(V / np.abs(V).max())
        for k in (int(v) for v in args.ks.split(",")):
            idx = np.sort(np.random.default_rng(0).choice(len(V), k, replace=False))
            vals = f[idx]
            t_pipe, _ = _timed(lambda: reconstruct(V, F, idx, vals), args.repeat)
            os.environ.pop(DIRECT_ENV, None)
            t_par, a = _timed(lambda: reconstruct(V, F, idx, vals, **proj), args.repeat)
            os.environ[DIRECT_ENV] = "superlu"
            try:
                t_sci, b = _timed(lambda: reconstruct(V, F, idx, vals, **proj), args.repeat)
            finally:
                os.environ.pop(DIRECT_ENV, None)
            old = "-"
            if args.old_amg:
                A = polyharmonic_energy(laplacian(V, F), mass_matrix(V, F), 2)
                t0 = time.perf_counter()
                q = QuadraticSolver(A, idx, solver="amg", tol=1e-12, maxiter=5000, symmetric_pattern=True)
                assert isinstance(q.backend, AMGSolver)
                q.solve(vals)
                old = f"{time.perf_counter() - t0:.2f} ({q.report['iterations'][0]})"
            steps = b.report["harmonic"].get("iterations", ["-"])[0]
            diff = float(np.abs(a.values - b.values).max())
            print(f"| {len(V):,} | {k:,} | {t_pipe:.2f} | {t_par:.2f} | {t_sci:.2f} | {t_sci / t_par:.2f} | "
                  f"{t_par / t_pipe:.2f} | {t_sci / t_pipe:.2f} | {steps} | {old} | {diff:.1e} |", flush=True)


if __name__ == "__main__":
    main()
