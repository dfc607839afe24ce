"""The default at 2,621,442 vertices (icosphere 9, 1,000 samples): time, error and peak memory of one run.

``python -m bench.default_at_scale pipeline|default|scipy [--level 9] [--k 1000]``

One process per run (the peak memory is the process's): ``pipeline`` is the paper's pipeline with monotone curves,
bounded (the default before issue 37); ``default`` the default (Pardiso where installed); ``scipy`` the default with
``MANIFILL_DIRECT=superlu`` (SciPy alone). The smooth field of ``bench.default_targets``. Prints seconds, the relative
RMSE off the samples, the solver and its CG steps, and the peak resident memory in GB.
"""

import argparse
import os
import resource
import time

import numpy as np


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mode", choices=("pipeline", "default", "scipy"))
    ap.add_argument("--level", type=int, default=9)
    ap.add_argument("--k", type=int, default=1000)
    args = ap.parse_args(argv)
    if args.mode == "scipy":
        os.environ["MANIFILL_DIRECT"] = "superlu"
    import manifill
    from manifill.mesh.shapes import icosphere

    from .fields import smooth_field

    V, F = icosphere(args.level)
    idx = np.sort(np.random.default_rng(0).choice(len(V), args.k, replace=False))
    f = smooth_field(V / np.abs(V).max())
    opts = dict(method="gvf-harmonic", curve_values="monotone", bounds="samples") if args.mode == "pipeline" else {}
    t = time.perf_counter()
    try:
        r = manifill.reconstruct(V, F, idx, f[idx], **opts)
    except manifill.ManifillError as e:  # a refusal before the work, with its estimate
        print(f"{args.mode}: refused after {time.perf_counter() - t:.1f} s: {e}")
        return
    seconds = time.perf_counter() - t
    free = np.ones(len(V), dtype=bool)
    free[idx] = False
    err = float(np.sqrt(np.mean((r.values[free] - f[free]) ** 2)) / np.ptp(f))
    h = r.report["fill"]
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    print(f"{args.mode}: {len(V):,} vertices, {args.k:,} samples: {seconds:.1f} s, rel. RMSE {err:.5f}, solver "
          f"{h.get('solver')} ({h.get('iterations')} steps), peak {peak:.2f} GB")


if __name__ == "__main__":
    main()
