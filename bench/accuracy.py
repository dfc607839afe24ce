"""Accuracy: every method on every known field, from k random samples, over fixed seeds.

For each case of :mod:`bench.fields`, each k and each seed, the same sample
vertices go to every method of :mod:`bench.peers`. Metrics, as fractions of the
range of the true field:

- relative RMSE: RMSE over the vertices that are not samples;
- maximum error over the same vertices;
- overshoot: how far the result leaves the range of the sample values,
  ``max(0, max(x) - max(samples), min(samples) - min(x))``;

and the wall time of the call. Cells are means over the seeds. A method that
raises, or returns non-finite values, is reported as failed with the reason; a
peer that is not installed, or meant for another case, is "skipped" (no
failure, left out of the ranks). A case with fixed sample layouts (the EEG
montages of ``head-eeg``) has its own k columns, one run each; a noisy case
gives every method the same noisy sample values, and the errors are against
the noise-free truth. :func:`targets` checks the issue's targets against the
results (:func:`targets_markdown`, :func:`targets_headline`); the findings in
words are in :mod:`bench.findings`.
"""

import time

import numpy as np

from . import fields, peers
from .findings import OVER_ZERO, case_kref, cell, fmt, headlines, k_ref, leads_and_trails, rmse

__all__ = ["run_accuracy", "markdown", "plot", "leads_and_trails", "headlines", "targets", "targets_markdown"]

KS_FULL = (10, 30, 100, 300)
KS_SMOKE = (10, 30)
SEEDS_FULL = (0, 1)
SEEDS_SMOKE = (0,)


def metrics(x, truth, idx, vals=None):
    """Relative RMSE and maximum error off the samples, and overshoot beyond the sample values' range."""
    free = np.ones(len(truth), dtype=bool)
    free[idx] = False
    span = float(np.ptp(truth)) or 1.0
    err = np.abs(x[free] - truth[free])
    vals = truth[idx] if vals is None else vals
    lo, hi = vals.min(), vals.max()
    over = max(0.0, float(x.max() - hi), float(lo - x.min()))
    return {"rmse": float(np.sqrt(np.mean(err**2))) / span, "max": float(err.max()) / span, "over": over / span}


def _warm_up(log):
    """One call of every method on a tiny sphere: imports and first-call set-up are not timed later."""
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(2)
    idx = np.arange(0, len(V), 9)
    for m in peers.METHODS:
        try:
            peers.run(m, V, F, idx, fields.smooth_field(V[idx]))
        except peers.Skip:
            pass
    log("  warmed up every method on a 162-vertex sphere")


def case_ks(case, ks):
    """The k columns of a case: its fixed layouts' sizes, else the run's k."""
    return sorted(case.layouts) if case.layouts is not None else list(ks)


def _run_cell(case, m, k, seeds, smoke=False):
    """One (method, k) cell: means over the seeds, or the failure, or the reason it was skipped."""
    if m.cases is not None and case.key not in m.cases:
        return {"ok": 0, "of": 0, "failed": None, "skipped": "not run (" + ", ".join(m.cases) + " only)"}
    if smoke and m.smoke is not None and case.key not in m.smoke:
        return {"ok": 0, "of": 0, "failed": None, "skipped": "not run in --smoke (slow; " + ", ".join(m.smoke)
                + " only)"}
    if not smoke and m.ks is not None and case.layouts is None and k not in m.ks:
        return {"ok": 0, "of": 0, "failed": None, "skipped": "not run (slow; k = " + ", ".join(map(str, m.ks))
                + " only)"}
    seeds = seeds if case.layouts is None else seeds[:1]  # a fixed layout: one run
    runs, reasons = [], []
    for seed in seeds:
        idx = fields.draw_samples(case, k, seed)
        vals = fields.sample_values(case, idx, seed)
        try:
            x, sec, why = peers.run(m, case.V, case.F, idx, vals)
        except peers.Skip as exc:
            return {"ok": 0, "of": 0, "failed": None, "skipped": str(exc)}
        if why is not None:
            reasons.append(why)
            continue
        r = metrics(x, case.truth, idx, vals)
        r["sec"] = sec
        runs.append(r)
    cell = {"ok": len(runs), "of": len(seeds), "failed": reasons[0] if reasons else None, "skipped": None}
    for key in ("rmse", "max", "over", "sec"):
        cell[key] = float(np.mean([r[key] for r in runs])) if runs else None
    return cell


def run_accuracy(smoke=False, log=print, only=None, methods=None):
    """Run every method on every case (or the cases keyed in ``only``, the methods whose short names are in
    ``methods``); returns a JSON-able dict."""
    ks = KS_SMOKE if smoke else KS_FULL
    seeds = SEEDS_SMOKE if smoke else SEEDS_FULL
    t_start = time.perf_counter()
    _warm_up(log)
    t = time.perf_counter()
    all_cases, notes = fields.cases(smoke, log=log)
    if only:
        all_cases = [c for c in all_cases if c.key in only]
    log(f"  built {len(all_cases)} cases in {time.perf_counter() - t:.1f} s")
    chosen = [m for m in peers.METHODS if methods is None or m.short in methods]
    out = {"ks": list(ks), "seeds": list(seeds), "methods": [m.name for m in chosen],
           "short": {m.name: m.short for m in chosen},
           "family": {m.name: m.family for m in chosen}, "cases": [], "notes": notes}
    for case in all_cases:
        t_case = time.perf_counter()
        cks = case_ks(case, ks)
        rows = {m.name: {str(k): _run_cell(case, m, k, seeds, smoke) for k in cks} for m in chosen}
        layouts = {str(k): v[0] for k, v in case.layouts.items()} if case.layouts is not None else None
        out["cases"].append({"key": case.key, "title": case.title, "mesh": case.mesh, "field": case.field,
                             "vertices": case.n, "faces": len(case.F), "notes": case.notes, "rows": rows,
                             "ks": cks, "layouts": layouts})
        log(f"  {case.key}: {case.n:,} vertices, {len(cks)} k x {len(seeds) if layouts is None else 1} seeds x "
            f"{len(chosen)} methods in {time.perf_counter() - t_case:.1f} s")
    out["seconds"] = time.perf_counter() - t_start
    return out


# ---------------------------------------------------------------------------
# reporting
# ---------------------------------------------------------------------------


def _cell_text(c, best):
    if c.get("skipped"):
        return c["skipped"]
    if c["ok"] == 0:
        return f"failed: {c['failed']}"
    txt = fmt(c["rmse"], 4)
    if best is not None and np.isclose(c["rmse"], best, rtol=1e-9, atol=0):
        txt = f"**{txt}**"
    text = f"{txt} / {fmt(c['max'])} / {fmt(c['over'], zero=OVER_ZERO)} / {c['sec']:.2f}"
    if c["ok"] < c["of"]:
        text += f" (failed on {c['of'] - c['ok']} of {c['of']} seeds: {c['failed']})"
    return text


def _best(case, k):
    vals = [v for n in case["rows"] if (v := rmse(case, n, k)) is not None]
    return min(vals) if vals else None


def _k_label(case, k):
    lay = case.get("layouts")
    return f"k = {k} ({lay[str(k)]})" if lay else f"k = {k}"


def markdown(res, png_dir):
    """The accuracy section: the summary, the targets, one table per case, and links to the plots."""
    ks, seeds = res["ks"], res["seeds"]
    kr = k_ref(res)
    lines = ["## Accuracy", ""]
    lines += [f"Samples: k = {', '.join(map(str, ks))} random vertices, seeds {', '.join(map(str, seeds))} "
              f"(`numpy.random.default_rng([seed, k])`), except where a case says otherwise (the EEG montages of "
              f"`head-eeg`: one fixed layout per k); every method gets the same samples and the same sample "
              f"values. Each cell is the "
              f"mean over the seeds of **rel. RMSE** / max error / overshoot / seconds: RMSE and maximum error "
              f"over the vertices that are not samples, and overshoot beyond the range of the sample values, "
              f"all divided by the range of the true field (an overshoot below 1e-8 is the iterative solver's "
              f"tolerance and shows as 0). Bold: the lowest rel. RMSE in the column. \"not installed\" and "
              f"\"not run\" cells are peers missing here, rows meant for another case, or a slow row kept to "
              f"some k (`manifill auto`: k = 100 and the montages in the full run); they are no failures. "
              f"Total time of this part: {res['seconds']:.0f} s.", ""]
    lines += [f"- {note}." for note in res.get("notes", [])]
    own = [f"{c['key']}: k = {case_kref(res, c)}" for c in res["cases"] if case_kref(res, c) != kr]
    lines += [f"### Summary: rel. RMSE at k = {kr}" + (f" ({'; '.join(own)})" if own else ""), ""]
    head = ["method"] + [c["key"] for c in res["cases"]] + ["mean rank (all k, all cases)",
                                                             f"step-field overshoot, k = {kr}"]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    ranks = mean_ranks(res)
    step = next((c for c in res["cases"] if c["key"] == "sphere-step"), None)
    for name in res["methods"]:
        row = [name]
        for case in res["cases"]:
            k = case_kref(res, case)
            c = case["rows"][name][str(k)]
            if c.get("skipped"):
                row.append("-")
            elif c["ok"] == 0:
                row.append("failed")
            else:
                txt = fmt(c["rmse"], 4)
                row.append(f"**{txt}**" if np.isclose(c["rmse"], _best(case, k), rtol=1e-9, atol=0) else txt)
        r, nfail = ranks[name]
        row.append(("-" if np.isnan(r) else f"{r:.1f}") + (f" ({nfail} failed)" if nfail else ""))
        c = step["rows"][name][str(kr)] if step is not None else None
        row.append("-" if c is None or c.get("skipped") else (fmt(c["over"], zero=OVER_ZERO) if c["ok"] else "failed"))
        lines.append("| " + " | ".join(row) + " |")
    lines += ["", "Mean rank: the method's rank by rel. RMSE among the methods that succeeded, averaged over "
              "every (case, k) in which it succeeded (1 = best; ties share the mean rank). \"-\": not run "
              "there.", ""]
    lines += targets_markdown(res)

    for case in res["cases"]:
        lines += [f"### {case['title']} (`{case['key']}`)", "",
                  f"Mesh: {case['mesh']}, {case['faces']:,} triangles. Field: {case['field']}."]
        for note in case["notes"]:
            lines.append(f"Note: {note}.")
        lines += ["", f"![rel. RMSE vs k, {case['key']}]({png_dir}/accuracy_{case['key']}.png)", ""]
        cks = case.get("ks", ks)
        head = ["method"] + [_k_label(case, k) for k in cks]
        lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for name in res["methods"]:
            row = [name] + [_cell_text(case["rows"][name][str(k)], _best(case, k)) for k in cks]
            lines.append("| " + " | ".join(row) + " |")
        lines.append("")
    return lines


def mean_ranks(res):
    """Per method: (mean rank by rel. RMSE over the (case, k) cells where it succeeded, number of failures)."""
    from scipy.stats import rankdata

    acc = {name: [] for name in res["methods"]}
    fails = {name: 0 for name in res["methods"]}
    for case in res["cases"]:
        for k in case.get("ks", res["ks"]):
            ok = [(v, n) for n in res["methods"] if (v := rmse(case, n, k)) is not None]
            for n in res["methods"]:
                c = case["rows"][n][str(k)]
                if not c["ok"] and not c.get("skipped"):
                    fails[n] += 1
            if ok:
                ranks = rankdata([float(f"{v:.9g}") for v, _ in ok], method="average")  # ties share their rank
                for rank, (_, n) in zip(ranks, ok):
                    acc[n].append(float(rank))
    return {n: (float(np.mean(acc[n])) if acc[n] else float("nan"), fails[n]) for n in res["methods"]}


def plot(res, outdir):
    """One log-log PNG per case: rel. RMSE against k, a line per method. Returns the paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    paths = []
    styles = ["o", "s", "^", "v", "D", "P", "X", "*", "h", "<", ">"]
    colors = plt.get_cmap("tab20").colors
    for case in res["cases"]:
        fig, ax = plt.subplots(figsize=(9.5, 5.2))
        cks = case.get("ks", res["ks"])
        for i, name in enumerate(res["methods"]):
            ks = [k for k in cks if rmse(case, name, k) is not None]
            ys = [rmse(case, name, k) for k in ks]
            if not ks:
                continue
            peer = res["family"][name] == "peer"
            color = "black" if i == 0 else colors[(i - 1) % len(colors)]
            ax.plot(ks, ys, linestyle="--" if peer else "-", marker=styles[i % len(styles)], color=color,
                    linewidth=2.4 if i == 0 else 1.2, label=res["short"][name])
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks(cks)
        ax.set_xticklabels([str(k) for k in cks])
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("samples k")
        ax.set_ylabel("rel. RMSE (off the samples)")
        ax.set_title(f"{case['key']}: {case['vertices']:,} vertices (solid: manifill, dashed: peers; "
                     f"igl harmonic coincides with mf harmonic)", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, ncol=1, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
        fig.tight_layout()
        path = outdir / f"accuracy_{case['key']}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths




# ---------------------------------------------------------------------------
# the targets of issue 12
# ---------------------------------------------------------------------------

BOUNDED = "manifill biharmonic, bounds=samples"
LIBIGL_BIH = "libigl biharmonic (k=2, points)"
AUTO = "manifill auto"
NOT_SMOOTH = ("sphere-step", "sphere-noisy", "globe-image")
SMOOTHING = (("manifill biharmonic, smoothing=auto", "manifill biharmonic (point constraints)"),
             ("manifill harmonic, smoothing=auto", "manifill harmonic (point constraints)"))


def _target_ks(res, case):
    """k = 100 (or the run's summary k) on random samples; every montage's k on fixed layouts."""
    return case["ks"] if case.get("layouts") else [case_kref(res, case)]


def _worst(res, case, num, den):
    """The largest ratio ``num(k) / den(k)`` over the target k; (ratio, k, why-missing)."""
    best = None
    for k in _target_ks(res, case):
        a, (b, who) = num(k), den(k)
        if a is None or b is None or b <= 0:
            return None, k, "no result" + ("" if a is not None else " for the method") + \
                ("" if b is not None else " for the reference")
        if best is None or a / b > best[0]:
            best = (a / b, k, who)
    return best


def targets(res):
    """The issue's targets, one dict per (target, case): ratio, limit, k, ``pass`` (None: no result)."""
    from .findings import DEFAULT

    out = []
    mf = [n for n in res["methods"] if res["family"][n] == "manifill" and n != AUTO]
    pe = [n for n in res["methods"] if res["family"][n] == "peer"]

    def best_of(names, case):
        def f(k):
            ok = [(v, n) for n in names if (v := rmse(case, n, k)) is not None]
            return min(ok) if ok else (None, None)
        return f

    def one(name, case):
        return lambda k: rmse(case, name, k)

    def add(target, case, limit, got, extra=None):
        ratio, k, who = got
        row = {"target": target, "case": case["key"], "k": k, "ratio": ratio, "limit": limit,
               "pass": None if ratio is None else bool(ratio <= limit and (extra is None or extra[0])),
               "vs": who if ratio is not None else None, "note": None if ratio is not None else who}
        if extra is not None:
            row["note"] = extra[1]
        out.append(row)

    for case in res["cases"]:
        if case["key"] in NOT_SMOOTH:
            continue
        got = _worst(res, case, one(BOUNDED, case), lambda k, c=case: (rmse(c, LIBIGL_BIH, k), LIBIGL_BIH))
        overs = [cl["over"] for k in _target_ks(res, case) if (cl := cell(case, BOUNDED, k)) is not None]
        extra = (bool(overs) and max(overs) < OVER_ZERO, f"overshoot {fmt(max(overs), zero=OVER_ZERO)}") \
            if overs else None
        add("bounded biharmonic / libigl biharmonic, zero overshoot", case, 1.1, got, extra)
    for case in res["cases"]:
        add("default / best peer", case, 1.3, _worst(res, case, one(DEFAULT, case), best_of(pe, case)))
    for case in res["cases"]:
        add("auto / best other manifill method", case, 1.1, _worst(res, case, one(AUTO, case), best_of(mf, case)))
    for case in res["cases"]:
        if case["key"] != "sphere-noisy":
            continue
        for smooth, exact in SMOOTHING:
            if smooth not in res["short"] or exact not in res["short"]:  # a run of some methods only
                continue
            got = _worst(res, case, one(smooth, case), lambda k, c=case, e=exact: (rmse(c, e, k), e))
            add(f"{res['short'][smooth]} / {res['short'][exact]} (must be < 1)", case, 1.0 - 1e-12, got)
    return out


def targets_markdown(res):
    """The "Targets" table: a line per (target, case) with the measured ratio and pass / fail."""
    rows = targets(res)
    kr = k_ref(res)
    lines = ["### Targets (issue 12)", "",
             f"Ratios of rel. RMSE at k = {kr} on the random-sample cases and, on cases with fixed layouts "
             f"(`head-eeg`), the worst ratio over every layout's k (the k column says which). Smooth cases: all "
             f"but {', '.join(NOT_SMOOTH)}. \"best peer\" / \"best other manifill method\": the lowest rel. RMSE "
             f"among the rows of that family that ran on the case at that k (named in the last column).", "",
             "| target | case | k | measured | limit | result | against |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        res_txt = "no result" if r["pass"] is None else ("pass" if r["pass"] else "**fail**")
        meas = "-" if r["ratio"] is None else f"{r['ratio']:.2f}"
        vs = res["short"].get(r["vs"], "") if r["vs"] else ""
        note = f" ({r['note']})" if r["note"] else ""
        limit = "< 1" if r["limit"] < 1 else f"<= {r['limit']:.2g}"
        lines.append(f"| {r['target']} | {r['case']} | {r['k']} | {meas}{note} | {limit} | {res_txt} | {vs} |")
    lines.append("")
    return lines


def targets_headline(res):
    """One bullet: how many targets are met, and which are not."""
    rows = targets(res)
    met = [r for r in rows if r["pass"]]
    miss = [r for r in rows if r["pass"] is False]
    none = [r for r in rows if r["pass"] is None]
    text = f"- **Targets of issue 12**: {len(met)} of {len(rows)} met"
    if miss:
        text += "; missed: " + ", ".join(f"{r['target'].split(' (')[0]} on {r['case']} ({r['ratio']:.2f})"
                                         for r in miss)
    if none:
        text += f"; {len(none)} without a result (a method failed or did not run)"
    return text + " (the table under \"Targets\")."
