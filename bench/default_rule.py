"""The default's rule on the accuracy benchmark: the candidates that never leave the samples' range, side by side.

``python -m bench.default_rule [--smoke] [--cases KEYS] [--save FILE] [--load FILE]``

Runs the accuracy benchmark's cases (:mod:`bench.fields`: the sphere's smooth, step and noisy fields, the
Earth's luminance, geodesic fields on the U strip, the airplane and the ant, the open cap, the closed head and
the open scalp with EEG montages) for the candidates of the default and the references (:data:`CANDIDATES`,
short names of :mod:`bench.peers`), every k and seed as ``python -m bench accuracy`` does, and prints per
candidate: the median relative RMSE over every (case, k) cell, the median over the closed and over the open
surfaces, the largest overshoot beyond the samples' range, and the ratio of its RMSE to libigl's biharmonic
clipped to the samples' range (median and worst cell). Issue 37's rule takes, among the candidates that never
leave the range and meet the time limits of ``bench.default_targets``, the lowest median.
"""

import argparse
import json
import statistics
from pathlib import Path

from . import accuracy
from .findings import cell

#: The default's candidates (bounded: never leave the samples' range) and the references, by short name.
CANDIDATES = ("mf default", "mf pipeline bounded",
              "mf projected biharmonic", "mf projected hessian", "mf projected curved hessian",
              "mf projected triharmonic", "mf bounded biharmonic")
REFERENCES = ("igl biharmonic clipped", "igl biharmonic", "igl harmonic", "RBF TPS")
OPEN = ("u-strip", "cap-dipoles", "scalp-eeg")
CLIPPED = "igl biharmonic clipped"


def _median(values):
    return statistics.median(values) if values else float("nan")


def summary(res):
    """Rows ``(short, median, median closed, median open, max overshoot, median ratio, worst ratio, cells)``."""
    name_of = {short: name for name, short in res["short"].items()}
    ref = name_of.get(CLIPPED)
    rows = []
    for short in [s for s in CANDIDATES + REFERENCES if s in name_of]:
        name = name_of[short]
        errs, closed, opened, overs, ratios = [], [], [], [], []
        for case in res["cases"]:
            for k in case["ks"]:
                c = cell(case, name, k)
                if c is None:
                    continue
                errs.append(c["rmse"])
                (opened if case["key"] in OPEN else closed).append(c["rmse"])
                overs.append(c["over"])
                r = cell(case, ref, k) if ref else None
                if r is not None and r["rmse"] > 0:
                    ratios.append(c["rmse"] / r["rmse"])
        rows.append((short, _median(errs), _median(closed), _median(opened), max(overs, default=float("nan")),
                     _median(ratios), max(ratios, default=float("nan")), len(errs)))
    return rows


def per_case(res, shorts):
    """Rel. RMSE at the reference k per case for the given methods."""
    from .findings import case_kref

    name_of = {short: name for name, short in res["short"].items()}
    out = []
    for case in res["cases"]:
        k = case_kref(res, case)
        out.append((case["key"], k, [(c["rmse"] if (c := cell(case, name_of[s], k)) else None) for s in shorts]))
    return out


def markdown(res):
    lines = ["| method | median rel. RMSE (cells) | closed surfaces | open surfaces | max overshoot | "
             "/ libigl biharmonic clipped: median | worst |", "|---|---|---|---|---|---|---|"]
    for s, m, c, o, over, rm, rw, n in summary(res):
        lines.append(f"| {s} | {m:.4f} ({n}) | {c:.4f} | {o:.4f} | {over:.2g} | {rm:.3f} | {rw:.2f} |")
    shorts = [s for s in CANDIDATES + REFERENCES if s in res["short"].values()]
    lines += ["", "| case | k | " + " | ".join(shorts) + " |", "|---|---|" + "---|" * len(shorts)]
    for key, k, vals in per_case(res, shorts):
        lines.append(f"| {key} | {k} | " + " | ".join("-" if v is None else f"{v:.4f}" for v in vals) + " |")
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--smoke", action="store_true")
    ap.add_argument("--cases", default=None)
    ap.add_argument("--save", default=None)
    ap.add_argument("--load", default=None)
    args = ap.parse_args(argv)
    if args.load:
        res = json.loads(Path(args.load).read_text(encoding="utf-8"))
    else:
        res = accuracy.run_accuracy(args.smoke, only=args.cases.split(",") if args.cases else None,
                                    methods=CANDIDATES + REFERENCES)
    if args.save:
        Path(args.save).write_text(json.dumps(res, default=float), encoding="utf-8")
    print("\n".join(markdown(res)))


if __name__ == "__main__":
    main()
