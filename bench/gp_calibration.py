"""Calibration of ``method='gp'``: fields from its own prior, and the accuracy benchmark's cases.

``python -m bench.gp_calibration [--draws 20] [--ranges 0.5,1.0] [--parts prior,noise,exact,cases]
[--cases sphere-smooth,...] [--save FILE]``

Parts:

``prior``
    On the unit icosphere (level 5: 10,242 vertices), ``--draws`` fields of the Matérn prior
    (``alpha = 2``, range ``rho`` for each of ``--ranges``, sigma 1, mean 2; drawn through the
    precision's factorisation, :mod:`bench.gp_common`), ``k`` random sample vertices each;
    ``manifill.reconstruct(..., method='gp')`` with its defaults (range and sigma fitted,
    variance ``auto``: sampled above 5,000 unknowns). Per draw: coverage of the 90 % interval
    and mean standardised squared error over the vertices that are not samples, NLPD, rel.
    RMSE, fitted range / true range, fitted sigma, seconds. Targets: coverage in [0.85, 0.95],
    mean z^2 in 1 +/- 0.15.
``noise``
    The same with noisy samples, ``y = x + N(0, 0.1^2)``, and ``gp={'noise': 'auto'}``:
    coverage of the latent field (the std returned) and of new noisy observations at the
    other vertices (std ``sqrt(std^2 + noise^2)`` with the fitted noise).
``oracle``
    As ``prior``, with the true range and sigma given (the constant mean still estimated):
    what is left of a miscalibration once the hyperparameters are right.
``exact``
    One draw: the sampled variance (what users get at this size) against ``variance='exact'``
    with the same hyperparameters: relative difference of the std (median, 95th percentile,
    max), and the coverage with each.
``cases``
    The accuracy benchmark's cases (:mod:`bench.fields`, :mod:`bench.fields_more`, built by
    their own builders at full size; samples drawn by :func:`bench.fields.draw_samples`, seed
    0): ``method='gp'`` (with ``noise='auto'`` on the noisy case) beside ``biharmonic`` with
    ``uncertainty=True`` and ``rbf``: rel. RMSE, coverage, NLPD.
"""

import argparse
import sys
import time

import numpy as np

from .gp_common import PriorSampler, Saver, matern_shape, random_samples, scores

MEAN = 2.0  # the prior draws' mean (non-zero: the constant mean is estimated)
NOISE = 0.1


def _summary(rows, rho):
    def med(key):
        v = [r[key] for r in rows if r.get(key) is not None]
        return float(np.median(v)) if v else None

    def mean(key):
        v = [r[key] for r in rows if r.get(key) is not None]
        return float(np.mean(v)) if v else None

    out = {"draws": len(rows), "coverage90_mean": mean("coverage90"), "z2_mean": mean("z2"),
           "z2_median": med("z2"), "nlpd_mean": mean("nlpd"), "rmse_mean": mean("rmse"),
           "range_ratio_median": med("range_ratio"), "sigma_median": med("sigma"),
           "seconds_mean": mean("seconds"), "loo_rms_z_median": med("loo_rms_z")}
    cov = [r["coverage90"] for r in rows]
    out["coverage90_min"], out["coverage90_max"] = float(np.min(cov)), float(np.max(cov))
    if rows and "noise" in rows[0]:
        out["noise_median"] = med("noise")
        out["coverage90_new_mean"] = mean("coverage90_new")
        out["z2_new_mean"] = mean("z2_new")
    return out


def prior_part(V, F, rho, draws, k, noisy, log, oracle=False):
    """``draws`` prior fields, reconstructed with fitted hyperparameters (``oracle``: the true ones given)."""
    import manifill

    sampler = PriorSampler(matern_shape(V, F), rho, 1.0, MEAN)
    rows = []
    for d in range(draws):
        rng = np.random.default_rng([int(d), int(rho * 1000), 13])
        x = sampler.draw(rng)
        idx = random_samples(len(V), k, d)
        y = x[idx] + (rng.normal(0.0, NOISE, k) if noisy else 0.0)
        t0 = time.perf_counter()
        gp = {"range": rho, "sigma": 1.0} if oracle else None
        if noisy:
            gp = {**(gp or {}), "noise": NOISE if oracle else "auto"}
        r = manifill.reconstruct(V, F, idx, y, method="gp", gp=gp)
        sec = time.perf_counter() - t0
        g = r.report["gp"]
        row = {"draw": d, **scores(x, r.values, r.std, idx), "range": g["range"][0],
               "range_ratio": g["range"][0] / rho, "sigma": g["sigma"][0], "mean": g["mean"][0],
               "seconds": sec, "gp_seconds": g["seconds"], "variance": g["variance"],
               "loo_rms_z": (g["variance"].get("loo") or [{}])[0].get("rms_z")}
        if noisy:
            nz = g["noise"][0]
            ynew = x + rng.normal(0.0, NOISE, len(x))
            s_new = scores(ynew, r.values, np.sqrt(r.std ** 2 + nz ** 2), idx)
            row.update({"noise": nz, "coverage90_new": s_new["coverage90"], "z2_new": s_new["z2"],
                        "nlpd_new": s_new["nlpd"]})
        rows.append(row)
        log(f"    draw {d}: coverage {row['coverage90']:.3f}, z2 {row['z2']:.3f}, range {row['range']:.3f} "
            f"({row['range_ratio']:.2f} x), sigma {row['sigma']:.3f}"
            + (f", noise {row['noise']:.3f}, new-obs coverage {row['coverage90_new']:.3f}" if noisy else "")
            + (f", leave-one-out RMS z {row['loo_rms_z']:.2f}" if row["loo_rms_z"] else "")
            + f", {sec:.1f} s")
    return {"rho": rho, "sigma": 1.0, "mean": MEAN, "k": k, "noise": NOISE if noisy else 0.0, "oracle": oracle,
            "summary": _summary(rows, rho), "rows": rows}


def exact_part(V, F, rho, k, log):
    import manifill

    sampler = PriorSampler(matern_shape(V, F), rho, 1.0, MEAN)
    rng = np.random.default_rng([0, int(rho * 1000), 13])
    x = sampler.draw(rng)
    idx = random_samples(len(V), k, 0)
    r0 = manifill.reconstruct(V, F, idx, x[idx], method="gp")
    hyper = {"range": r0.report["gp"]["range"][0], "sigma": r0.report["gp"]["sigma"][0]}
    out = {"rho": rho, "k": k, "hyper": hyper}
    runs = {}
    for how in ("sampled", "exact"):
        t0 = time.perf_counter()
        r = manifill.reconstruct(V, F, idx, x[idx], method="gp", gp={**hyper, "variance": how})
        runs[how] = r
        out[how] = {"seconds": time.perf_counter() - t0, **scores(x, r.values, r.std, idx),
                    "variance": r.report["gp"]["variance"]}
        log(f"    {how}: {out[how]['seconds']:.1f} s, coverage {out[how]['coverage90']:.3f}, z2 {out[how]['z2']:.3f}")
    free = np.ones(len(V), dtype=bool)
    free[idx] = False
    se, ex = runs["sampled"].std[free], runs["exact"].std[free]
    rel = np.abs(se - ex) / ex
    out["std_rel_diff"] = {"median": float(np.median(rel)), "p95": float(np.percentile(rel, 95)),
                           "max": float(rel.max()), "mean_signed": float(np.mean((se - ex) / ex))}
    log(f"    sampled vs exact std: median rel. diff {out['std_rel_diff']['median']:.3f}, "
        f"95th pct {out['std_rel_diff']['p95']:.3f}")
    return out


def build_cases(keys, log):
    from . import fields, fields_more

    out = []
    for key in keys:
        t0 = time.perf_counter()
        if key == "sphere-smooth":
            c = fields.sphere_cases(6)[0]
        elif key == "sphere-noisy":
            c = fields_more.noisy_case(6)
        elif key == "globe-image":
            c = fields_more.globe_case(6)
        elif key == "airplane":
            c = fields.airplane_case(2)
        elif key == "u-strip":
            c = fields.u_case(0.02)
        elif key == "ant":
            c = fields.ant_case(2)
        elif key == "head-eeg":
            c = fields_more.head_case(6)
        else:
            raise SystemExit(f"unknown case {key!r}")
        log(f"  built {key}: {c.n:,} vertices in {time.perf_counter() - t0:.1f} s")
        out.append(c)
    return out


def case_part(case, k, seed, log):
    import manifill

    from . import fields

    idx = fields.draw_samples(case, k, seed)
    vals = fields.sample_values(case, idx, seed)
    V, F = case.V, case.F
    runs = [("gp", dict(method="gp", gp={"noise": "auto"} if case.noise else None)),
            ("biharmonic, uncertainty", dict(method="biharmonic", uncertainty=True)),
            ("rbf", dict(method="rbf"))]
    if case.noise:
        runs.insert(2, ("biharmonic smoothing=auto, uncertainty",
                        dict(method="biharmonic", smoothing="auto", uncertainty=True)))
    out = {"case": case.key, "k": k, "seed": seed, "vertices": case.n, "methods": {}}
    for name, kw in runs:
        t0 = time.perf_counter()
        try:
            r = manifill.reconstruct(V, F, idx, vals, **kw)
        except Exception as exc:  # a failure is a result
            out["methods"][name] = {"failed": f"{type(exc).__name__}: {exc}"}
            log(f"    {case.key} k={k} {name}: FAILED {type(exc).__name__}: {exc}")
            continue
        sec = time.perf_counter() - t0
        std = getattr(r, "std", None)
        row = {"seconds": sec, **scores(case.truth, np.asarray(r.values).ravel(), None if std is None else
                                         np.asarray(std).ravel(), idx)}
        if name == "gp":
            g = r.report["gp"]
            loo = g["variance"].get("loo")
            row.update({"range": g["range"][0], "sigma": g["sigma"][0], "noise": g["noise"][0],
                        "gp_seconds": g["seconds"], "variance": g["variance"]["how"],
                        "loo_rms_z": None if not loo else loo[0]["rms_z"],
                        "loo_verdict": None if not loo else loo[0]["verdict"]})
        out["methods"][name] = row
        log(f"    {case.key} k={k} {name}: rmse {row['rmse']:.4f}"
            + (f", coverage {row['coverage90']:.3f}, within 1.96 std {row['within196']:.3f}, RMS z "
               f"{np.sqrt(row['z2']):.2f}, nlpd {row['nlpd']:.3f}" if "coverage90" in row else "")
            + (f", leave-one-out RMS z {row['loo_rms_z']:.2f} ({row['loo_verdict']})" if row.get("loo_rms_z") else "")
            + f", {sec:.1f} s")
    return out


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    ap = argparse.ArgumentParser(prog="python -m bench.gp_calibration", description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=20)
    ap.add_argument("--ranges", default="0.5,1.0", help="true ranges of the prior draws (unit sphere)")
    ap.add_argument("--noise-ranges", default="0.5", help="ranges of the noisy part")
    ap.add_argument("--level", type=int, default=5, help="icosphere level of the prior part (5: 10,242 vertices)")
    ap.add_argument("--k", type=int, default=100)
    ap.add_argument("--parts", default="prior,noise,exact,cases")
    ap.add_argument("--cases", default="sphere-smooth,head-eeg,globe-image,airplane,sphere-noisy")
    ap.add_argument("--ks", default="100", help="k of the random-sample cases (head-eeg: --head-ks)")
    ap.add_argument("--head-ks", default="min,max",
                    help="montage sizes of head-eeg (default: the smallest and largest)")
    ap.add_argument("--save", default=None, help="JSON file, rewritten after every step")
    args = ap.parse_args(argv)
    from manifill.mesh.shapes import icosphere

    parts = args.parts.split(",")
    save = Saver(args.save, "python -m bench.gp_calibration " + " ".join(argv))

    def log(msg):
        print(msg, flush=True)

    t_all = time.perf_counter()
    V, F = icosphere(args.level)
    log(f"icosphere level {args.level}: {len(V):,} vertices, {args.k} samples")
    if "prior" in parts:
        for rho in map(float, args.ranges.split(",")):
            log(f"  prior, range {rho}:")
            save.put(f"prior rho={rho:g}", prior_part(V, F, rho, args.draws, args.k, False, log))
    if "noise" in parts:
        for rho in map(float, args.noise_ranges.split(",")):
            log(f"  noisy samples (sd {NOISE}), range {rho}:")
            save.put(f"noise rho={rho:g}", prior_part(V, F, rho, args.draws, args.k, True, log))
    if "oracle" in parts:
        for rho in map(float, args.ranges.split(",")):
            log(f"  prior, range {rho}, the true range and sigma given:")
            save.put(f"oracle rho={rho:g}", prior_part(V, F, rho, args.draws, args.k, False, log, oracle=True))
    if "exact" in parts:
        log("  sampled vs exact variance, one draw, range 0.5:")
        save.put("exact vs sampled", exact_part(V, F, 0.5, args.k, log))
    if "cases" in parts:
        cases = build_cases(args.cases.split(","), log)
        res = []
        for case in cases:
            if case.layouts:  # the montages' sizes: "min,max" or given sizes
                have = sorted(case.layouts)
                ks = [have[0], have[-1]] if args.head_ks == "min,max" else \
                    [int(k) for k in args.head_ks.split(",") if int(k) in case.layouts]
            else:
                ks = [int(k) for k in args.ks.split(",")]
            for k in ks:
                res.append(case_part(case, k, 0, log))
                save.put("cases", res)
    save.doc["seconds"] = time.perf_counter() - t_all
    save.write()
    log(f"done in {time.perf_counter() - t_all:.0f} s")


if __name__ == "__main__":
    main()
