"""Speed of ``method='gp'`` on large icospheres, beside the harmonic fill alone, in the same run.

``python -m bench.gp_speed [--levels 7,8] [--k 1000] [--save FILE]``

For each level (7: 163,842 vertices; 8: 655,362), ``k`` random samples of a smooth field
(``sin(2x) + yz + 0.5 cos(3y)``):

- ``manifill.harmonic(V, F, idx, vals)``: the harmonic fill alone (timed first and last; the
  faster counts);
- ``manifill.reconstruct(..., method='gp', gp={'range': R, 'sigma': S, 'noise': 0})``:
  hyperparameters given (R, S: those the fitted run finds when it ran first, else
  ``--range`` and the samples' standard deviation), mean and std;
- ``manifill.reconstruct(..., method='gp')``: defaults, hyperparameters fitted;
- ``--order`` entries ending in ``-direct`` (or ``-amg``) run the same with that ``solver=``
  (default: ``given-direct`` too, the posterior with the precision factorised).

Reported: seconds, the ratio to the harmonic fill (target <= 10), and the breakdowns
``report['gp']['seconds']`` (fit, posterior) and ``report['seconds']``, with the variance's
own seconds and the fit's number of likelihood evaluations.
"""

import argparse
import sys
import time

import numpy as np

from .gp_common import Saver, random_samples


def field(V):
    return np.sin(2 * V[:, 0]) + V[:, 1] * V[:, 2] + 0.5 * np.cos(3 * V[:, 1])


def _gp_row(r, sec):
    g = r.report["gp"]
    return {"seconds": sec, "gp_seconds": g["seconds"], "report_seconds": r.report["seconds"],
            "variance": g["variance"], "solver": g.get("solver"), "fit": g.get("fit"),
            "range": g["range"][0], "sigma": g["sigma"][0]}


def one_level(level, k, order, rho, log):
    import manifill
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(level)
    f = field(V)
    idx = random_samples(len(V), k, 0)
    vals = f[idx]
    out = {"level": level, "vertices": len(V), "k": k}

    def harm(tag):
        t0 = time.perf_counter()
        manifill.harmonic(V, F, idx, vals)
        out[tag] = time.perf_counter() - t0
        log(f"    harmonic ({tag}): {out[tag]:.2f} s")

    harm("harmonic_first")
    hyper = {"range": rho, "sigma": float(np.std(vals)), "noise": 0}
    for what in order:
        base, _, solver = what.partition("-")
        solver = solver or "auto"
        t0 = time.perf_counter()
        if base == "fitted":
            r = manifill.reconstruct(V, F, idx, vals, method="gp", solver=solver)
            out[what] = _gp_row(r, time.perf_counter() - t0)
            hyper = {"range": out[what]["range"], "sigma": out[what]["sigma"], "noise": 0}
        else:
            r = manifill.reconstruct(V, F, idx, vals, method="gp", gp=hyper, solver=solver)
            out[what] = {**_gp_row(r, time.perf_counter() - t0), "gp": dict(hyper)}
        log(f"    gp {what}: {out[what]['seconds']:.1f} s; gp seconds {out[what]['gp_seconds']}; "
            f"variance {out[what]['variance']}")
        yield out
    harm("harmonic_last")
    out["harmonic"] = min(out["harmonic_first"], out["harmonic_last"])
    for what in order:
        out[what]["ratio_to_harmonic"] = out[what]["seconds"] / out["harmonic"]
    log("    ratios to harmonic: " + ", ".join(f"{w} {out[w]['ratio_to_harmonic']:.1f}x" for w in order))
    yield out


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    ap = argparse.ArgumentParser(prog="python -m bench.gp_speed", description=__doc__.splitlines()[0])
    ap.add_argument("--levels", default="7,8")
    ap.add_argument("--k", type=int, default=1000)
    ap.add_argument("--order", default="fitted,given,given-direct",
                    help="the gp runs, in order: fitted or given, '-direct' / '-amg' for that solver (else 'auto')")
    ap.add_argument("--range", type=float, default=1.0, help="range of the 'given' run when it runs first")
    ap.add_argument("--save", default=None, help="JSON file, rewritten after every step")
    args = ap.parse_args(argv)
    save = Saver(args.save, "python -m bench.gp_speed " + " ".join(argv))

    def log(msg):
        print(msg, flush=True)

    for level in map(int, args.levels.split(",")):
        log(f"level {level}, {args.k} samples:")
        for partial in one_level(level, args.k, args.order.split(","), args.range, log):
            save.put(f"level {level}", partial)


if __name__ == "__main__":
    main()
