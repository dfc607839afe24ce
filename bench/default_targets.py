"""Issue 37's targets for the default, side by side in one process: time and error at 41k, 163k and 655k.

``python -m bench.default_targets [--levels 6,7,8] [--ks 100,1000] [--fields smooth,earth] [--repeat 1]
[--candidates default,biharmonic-project,hessian-project] [--no-igl] [--scipy]``

For every icosphere level, sample count and field (``smooth``: ``sin(2x) + yz + 0.5 cos(3y)``; ``earth``: the
day map's luminance, the accuracy benchmark's ``globe-image``), the same samples (``default_rng(0)``) go, one
after the other in this process (a warm-up call first), to: the paper's pipeline with monotone curves bounded by
the samples' range (the earlier default, ``method='gvf-harmonic', curve_values='monotone', bounds='samples'``),
each candidate of the default (:data:`CANDIDATES`), libigl's ``harmonic(k=1)`` and ``harmonic(k=2)``, the latter
clipped to the samples' range. With ``--scipy`` the candidates run again with ``MANIFILL_DIRECT=superlu`` (SciPy
alone: what a machine without MKL gets). A row gives seconds, the candidate/pipeline and candidate/libigl-k=2
time ratios (targets: at most 4 and 0.25), the relative RMSE off the samples and its ratio to the reference
(smooth: libigl's biharmonic clipped; earth: the better of libigl's harmonic and that; target at most 1.05), and
the largest value beyond the samples' range.
"""

import argparse
import os
import platform
import statistics
import time

import numpy as np

#: The default's candidates: label -> options of ``reconstruct``.
CANDIDATES = {
    "default": {},
    "biharmonic-project": dict(method="biharmonic", bounds="samples", bounds_mode="project"),
    "hessian-project": dict(method="hessian", bounds="samples", bounds_mode="project"),
    "biharmonic-exact": dict(method="biharmonic", bounds="samples"),
}
PIPELINE = dict(method="gvf-harmonic", curve_values="monotone", bounds="samples")


def _fields(V, which, level):
    from .fields import smooth_field
    from .fields_more import globe_case

    return {name: smooth_field(V / np.abs(V).max()) if name == "smooth" else globe_case(level).truth
            for name in which}


def _timed(call, repeat):
    times, result = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        result = call()
        times.append(time.perf_counter() - t)
    return statistics.median(times), result


def _err(x, truth, idx):
    free = np.ones(len(truth), dtype=bool)
    free[idx] = False
    return float(np.sqrt(np.mean((np.ravel(x)[free] - truth[free]) ** 2)) / np.ptp(truth))


def _igl(V, F, idx, vals, k):
    import igl

    return np.asarray(igl.harmonic(V, F.astype(np.int64), idx.astype(np.int64), vals[:, None], k)).ravel()


def main(argv=None):
    from manifill import reconstruct
    from manifill.linalg.factorise import DIRECT_ENV
    from manifill.mesh.shapes import icosphere

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", default="6,7,8")
    ap.add_argument("--ks", default="100,1000")
    ap.add_argument("--fields", default="smooth,earth")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--candidates", default="default,biharmonic-project")
    ap.add_argument("--no-igl", action="store_true", help="skip libigl (its k=2 solve is slow at 655k)")
    ap.add_argument("--scipy", action="store_true", help="also run the candidates with SciPy alone")
    args = ap.parse_args(argv)
    V, F = icosphere(2)
    reconstruct(V, F, np.arange(0, 162, 9), V[::9, 0], method="biharmonic", solver="direct")  # load Pardiso
    print(f"# the default's targets ({platform.machine()}, {time.strftime('%Y-%m-%d %H:%M')})")
    print("| vertices | samples | field | run | seconds | / pipeline | / libigl k=2 | rel. RMSE | / reference | "
          "overshoot |")
    print("|---|---|---|---|---|---|---|---|---|---|", flush=True)
    runs = [(c, False) for c in args.candidates.split(",")] + \
        ([(c, True) for c in args.candidates.split(",")] if args.scipy else [])
    for level in (int(v) for v in args.levels.split(",")):
        V, F = icosphere(level)
        fields = _fields(V, args.fields.split(","), level)
        for k in (int(v) for v in args.ks.split(",")):
            idx = np.sort(np.random.default_rng(0).choice(len(V), k, replace=False))
            for name, f in fields.items():
                vals = f[idx]
                lo, hi = vals.min(), vals.max()
                t_pipe, rp = _timed(lambda V=V, F=F, idx=idx, vals=vals: reconstruct(V, F, idx, vals, **PIPELINE),
                                        args.repeat)
                rows = [("pipeline (earlier default)", t_pipe, rp.values)]
                t_k2 = None
                if not args.no_igl:
                    t1, x1 = _timed(lambda V=V, F=F, idx=idx, vals=vals: _igl(V, F, idx, vals, 1), 1)
                    t_k2, x2 = _timed(lambda V=V, F=F, idx=idx, vals=vals: _igl(V, F, idx, vals, 2), 1)
                    rows += [("libigl harmonic k=1", t1, x1), ("libigl harmonic k=2", t_k2, x2),
                             ("libigl k=2 clipped", t_k2, np.clip(x2, lo, hi))]
                for cand, scipy_only in runs:
                    if scipy_only:
                        os.environ[DIRECT_ENV] = "superlu"
                    try:
                        t, r = _timed(lambda V=V, F=F, idx=idx, vals=vals, cand=cand: reconstruct(V, F, idx, vals,
                                                                                         **CANDIDATES[cand]),
                                  args.repeat)
                    finally:
                        os.environ.pop(DIRECT_ENV, None)
                    rows.append((cand + (" (SciPy alone)" if scipy_only else ""), t, r.values))
                ref = None
                if not args.no_igl:
                    clipped = _err(np.clip(x2, lo, hi), f, idx)
                    ref = clipped if name == "smooth" else min(clipped, _err(x1, f, idx))
                for label, t, x in rows:
                    e = _err(x, f, idx)
                    over = max(0.0, float(np.max(x) - hi), float(lo - np.min(x))) / (hi - lo)
                    k2 = "-" if t_k2 is None else f"{t / t_k2:.2f}"
                    rr = "-" if ref is None else f"{e / ref:.3f}"
                    print(f"| {len(V):,} | {k:,} | {name} | {label} | {t:.2f} | {t / t_pipe:.2f} | {k2} | {e:.4f} | "
                          f"{rr} | {over:.2g} |", flush=True)


if __name__ == "__main__":
    main()
