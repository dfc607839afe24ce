"""``method='gp'`` fitted against given against the pipeline, in one process: the fit's cost at scale.

``python -m bench.gp_fit_speed [--levels 6,7] [--k 1000] [--label NAME]``: per mesh, the seconds of the
pipeline (``gvf-harmonic``, monotone curve values, bounded), the gp with range and sigma given, and the gp
with them fitted, with the ratios and the fitted gp's error; one line each. Run it from two trees
(``PYTHONPATH=<tree>/src``) to compare commits side by side.
"""

import argparse
import time

import numpy as np

import manifill
from manifill.mesh.shapes import icosphere


def _timed(fn):
    t = time.perf_counter()
    r = fn()
    return time.perf_counter() - t, r


def run(level, k, seed=0):
    """``dict`` of seconds and errors on the icosphere of ``level`` with ``k`` samples of a smooth field."""
    V, F = icosphere(level)
    idx = np.sort(np.random.default_rng(seed).choice(len(V), k, replace=False))
    f = np.sin(3 * V[:, 0]) + V[:, 1] * V[:, 2] + 0.5 * np.cos(4 * V[:, 2])
    vals = f[idx]
    pipe, _ = _timed(lambda: manifill.reconstruct(V, F, idx, vals, method="gvf-harmonic", curve_values="monotone",
                                                  bounds="samples"))
    fitted_s, fitted = _timed(lambda: manifill.reconstruct(V, F, idx, vals, method="gp"))
    g = fitted.report["gp"]
    given_s, given = _timed(lambda: manifill.reconstruct(V, F, idx, vals, method="gp",
                                                         gp=dict(range=g["range"][0], sigma=g["sigma"][0])))
    var = given.report["gp"]["variance"]
    err = float(np.sqrt(np.mean((fitted.values - f) ** 2)) / np.ptp(f))
    return {"n": len(V), "k": k, "pipeline": pipe, "given": given_s, "fitted": fitted_s, "error": err,
            "fit_samples": g["fit"]["samples"], "likelihood": g["fit"].get("likelihood", "dense covariance"),
            "variance": f"{var['how']} {var['seconds']:.2f} s"}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--levels", default="6,7")
    p.add_argument("--k", type=int, default=1000)
    p.add_argument("--label", default="this tree")
    a = p.parse_args(argv)
    for level in (int(x) for x in a.levels.split(",")):
        r = run(level, a.k)
        print(f"{a.label}: n={r['n']:,} k={r['k']}: pipeline {r['pipeline']:.2f} s, gp given {r['given']:.2f} s "
              f"({r['given'] / r['pipeline']:.1f}x), fitted {r['fitted']:.2f} s ({r['fitted'] / r['given']:.2f}x "
              f"given) on {r['fit_samples']} samples ({r['likelihood']}), rel. RMSE {r['error']:.4f}, "
              f"variance {r['variance']}", flush=True)


if __name__ == "__main__":
    main()
