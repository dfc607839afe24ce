"""Benchmark: accuracy of the reconstruction on a sphere, every method side by side.

A 40,962-vertex icosphere (coordinates in [-1, 1]), 100 random samples of
``f = sin(2x) + yz + 0.5 cos(3y)``, over several seeds. The error is the relative
RMSE: RMSE over the vertices that are not samples, divided by the range of ``f``.
libigl's biharmonic (``igl.harmonic`` with k = 2) is printed beside manifill's
methods when libigl is installed. Run from the repository root::

    python bench/reconstruct_accuracy.py [--seeds 8] [--samples 100] [--level 6]

The target for the default ``gvf-harmonic`` is a relative RMSE <= 0.028.
"""

import argparse
import time

import numpy as np

import manifill
from manifill.surface.reconstruct import reconstruct
from manifill.mesh.shapes import icosphere

CONFIGS = [
    ("harmonic (samples fixed)", dict(method="harmonic")),
    ("gvf (whole surface)", dict(method="gvf")),
    ("default (gvf-harmonic, monotone, bounds=samples)", dict()),
    ("gvf-harmonic, delaunay, hermite (the paper's pipeline)", dict(method="gvf-harmonic")),
    ("gvf-harmonic, delaunay, linear", dict(method="gvf-harmonic", curve_values="linear")),
    ("gvf-harmonic, delaunay, gvf", dict(method="gvf-harmonic", curve_values="gvf")),
    ("gvf-harmonic, tree, hermite", dict(method="gvf-harmonic", partition="tree")),
    ("gvf-harmonic, cycle, hermite", dict(method="gvf-harmonic", partition="cycle")),
]


def field(V):
    return np.sin(2 * V[:, 0]) + V[:, 1] * V[:, 2] + 0.5 * np.cos(3 * V[:, 1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--samples", type=int, default=100)
    ap.add_argument("--level", type=int, default=6)
    args = ap.parse_args(argv)
    V, F = icosphere(args.level)
    V = V / np.abs(V).max()
    f = field(V)
    try:
        import igl
    except ImportError:
        igl = None
    rows = {name: ([], [], []) for name, _ in CONFIGS}
    if igl is not None:
        rows["libigl biharmonic (k=2)"] = ([], [], [])
    for seed in range(args.seeds):
        rng = np.random.default_rng(seed)
        idx = np.sort(rng.choice(len(V), size=args.samples, replace=False))
        free = np.ones(len(V), dtype=bool)
        free[idx] = False
        results = []
        for name, kw in CONFIGS:
            t0 = time.perf_counter()
            x = reconstruct(V, F, idx, f[idx], **kw).values
            results.append((name, x, time.perf_counter() - t0))
        if igl is not None:
            t0 = time.perf_counter()
            x = igl.harmonic(V, F.astype(np.int64), idx, f[idx][:, None], 2).ravel()
            results.append(("libigl biharmonic (k=2)", x, time.perf_counter() - t0))
        for name, x, sec in results:
            rmse = np.sqrt(np.mean((x[free] - f[free]) ** 2)) / np.ptp(f)
            over = max(float(x.max() - f[idx].max()), float(f[idx].min() - x.min()), 0.0)
            rows[name][0].append(rmse)
            rows[name][1].append(over)
            rows[name][2].append(sec)
    print(f"manifill {manifill.__version__}: icosphere level {args.level} ({len(V):,} vertices), "
          f"{args.samples} samples, seeds 0..{args.seeds - 1}")
    print(f"{'method':45s} {'rel. RMSE mean':>14s} {'worst':>8s} {'overshoot':>10s} {'time s':>7s}")
    for name, (err, over, sec) in rows.items():
        print(f"{name:45s} {np.mean(err):14.4f} {np.max(err):8.4f} {np.max(over):10.4f} {np.mean(sec):7.2f}")


if __name__ == "__main__":
    main()
