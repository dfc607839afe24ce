"""Accuracy: every method on every known field, from k random samples, over fixed seeds.

For each case of :mod:`bench.fields`, each k and each seed, the same sample
vertices go to every method of :mod:`bench.peers`. Metrics, as fractions of the
range of the true field:

- relative RMSE: RMSE over the vertices that are not samples;
- maximum error over the same vertices;
- overshoot: how far the result leaves the range of the sample values,
  ``max(0, max(x) - max(samples), min(samples) - min(x))``;

and the wall time of the call. Cells are means over the seeds. A method that
raises, or returns non-finite values, is reported as failed with the reason.
"""

import time

import numpy as np

from . import fields, peers

__all__ = ["run_accuracy", "markdown", "plot", "leads_and_trails"]

KS_FULL = (10, 30, 100, 300)
KS_SMOKE = (10, 30)
SEEDS_FULL = (0, 1)
SEEDS_SMOKE = (0,)
OVER_ZERO = 1e-8  # overshoot below this fraction of the range is the iterative solver's tolerance: shown as 0


def metrics(x, truth, idx):
    """Relative RMSE and maximum error off the samples, and overshoot beyond the samples' range."""
    free = np.ones(len(truth), dtype=bool)
    free[idx] = False
    span = float(np.ptp(truth)) or 1.0
    err = np.abs(x[free] - truth[free])
    lo, hi = truth[idx].min(), truth[idx].max()
    over = max(0.0, float(x.max() - hi), float(lo - x.min()))
    return {"rmse": float(np.sqrt(np.mean(err**2))) / span, "max": float(err.max()) / span, "over": over / span}


def _warm_up(log):
    """One call of every method on a tiny sphere: imports and first-call set-up are not timed later."""
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(2)
    idx = np.arange(0, len(V), 9)
    for m in peers.METHODS:
        peers.run(m, V, F, idx, fields.smooth_field(V[idx]))
    log("  warmed up every method on a 162-vertex sphere")


def run_accuracy(smoke=False, log=print):
    """Run every method on every case; returns a JSON-able dict."""
    ks = KS_SMOKE if smoke else KS_FULL
    seeds = SEEDS_SMOKE if smoke else SEEDS_FULL
    t_start = time.perf_counter()
    _warm_up(log)
    t = time.perf_counter()
    all_cases = fields.cases(smoke)
    log(f"  built {len(all_cases)} cases in {time.perf_counter() - t:.1f} s")
    out = {"ks": list(ks), "seeds": list(seeds), "methods": [m.name for m in peers.METHODS],
           "short": {m.name: m.short for m in peers.METHODS},
           "family": {m.name: m.family for m in peers.METHODS}, "cases": []}
    for case in all_cases:
        t_case = time.perf_counter()
        rows = {}
        for m in peers.METHODS:
            rows[m.name] = {}
            for k in ks:
                runs, reasons = [], []
                for seed in seeds:
                    idx = fields.draw_samples(case, k, seed)
                    x, sec, why = peers.run(m, case.V, case.F, idx, case.truth[idx])
                    if why is not None:
                        reasons.append(why)
                        continue
                    r = metrics(x, case.truth, idx)
                    r["sec"] = sec
                    runs.append(r)
                cell = {"ok": len(runs), "of": len(seeds), "failed": reasons[0] if reasons else None}
                for key in ("rmse", "max", "over", "sec"):
                    cell[key] = float(np.mean([r[key] for r in runs])) if runs else None
                rows[m.name][str(k)] = cell
        out["cases"].append({"key": case.key, "title": case.title, "mesh": case.mesh, "field": case.field,
                             "vertices": case.n, "faces": len(case.F), "notes": case.notes, "rows": rows})
        log(f"  {case.key}: {case.n:,} vertices, {len(ks)} k x {len(seeds)} seeds x {len(peers.METHODS)} methods "
            f"in {time.perf_counter() - t_case:.1f} s")
    out["seconds"] = time.perf_counter() - t_start
    return out


# ---------------------------------------------------------------------------
# reporting
# ---------------------------------------------------------------------------


def _fmt(v, digits=3, zero=1e-12):
    if v is None:
        return "-"
    if abs(v) < zero:  # round-off or solver tolerance: zero in any meaningful sense
        return "0"
    if abs(v) < 10 ** -digits:
        return f"{v:.1e}"
    return f"{v:.{digits}f}"


def _cell_text(cell, best):
    if cell["ok"] == 0:
        return f"failed: {cell['failed']}"
    rmse = _fmt(cell["rmse"], 4)
    if best is not None and np.isclose(cell["rmse"], best, rtol=1e-9, atol=0):
        rmse = f"**{rmse}**"
    text = f"{rmse} / {_fmt(cell['max'])} / {_fmt(cell['over'], zero=OVER_ZERO)} / {cell['sec']:.2f}"
    if cell["ok"] < cell["of"]:
        text += f" (failed on {cell['of'] - cell['ok']} of {cell['of']} seeds: {cell['failed']})"
    return text


def _best(case, k):
    vals = [c[str(k)]["rmse"] for c in case["rows"].values() if c[str(k)]["ok"]]
    return min(vals) if vals else None


def k_ref(res):
    """The k of the summary: 100 when it was run, else the largest."""
    return 100 if 100 in res["ks"] else max(res["ks"])


def markdown(res, png_dir):
    """The accuracy section: one table per case, the summary, and links to the plots."""
    ks, seeds = res["ks"], res["seeds"]
    kr = k_ref(res)
    lines = ["## Accuracy", ""]
    lines += [f"Samples: k = {', '.join(map(str, ks))} random vertices, seeds {', '.join(map(str, seeds))} "
              f"(`numpy.random.default_rng([seed, k])`); every method gets the same samples. Each cell is the "
              f"mean over the seeds of **rel. RMSE** / max error / overshoot / seconds: RMSE and maximum error "
              f"over the vertices that are not samples, and overshoot beyond the range of the sample values, "
              f"all divided by the range of the true field (an overshoot below 1e-8 is the iterative solver's "
              f"tolerance and shows as 0). Bold: the lowest rel. RMSE in the column. "
              f"Total time of this part: {res['seconds']:.0f} s.", ""]

    lines += [f"### Summary: rel. RMSE at k = {kr}", ""]
    head = ["method"] + [c["key"] for c in res["cases"]] + [f"mean rank (all {len(ks)} k, all cases)",
                                                             f"step-field overshoot, k = {kr}"]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    ranks = mean_ranks(res)
    step = next((c for c in res["cases"] if c["key"] == "sphere-step"), None)
    for name in res["methods"]:
        row = [name]
        for case in res["cases"]:
            cell = case["rows"][name][str(kr)]
            best = _best(case, kr)
            if cell["ok"] == 0:
                row.append("failed")
            else:
                txt = _fmt(cell["rmse"], 4)
                row.append(f"**{txt}**" if np.isclose(cell["rmse"], best, rtol=1e-9, atol=0) else txt)
        row.append(f"{ranks[name][0]:.1f} ({ranks[name][1]} failed)" if ranks[name][1] else f"{ranks[name][0]:.1f}")
        if step is not None:
            cell = step["rows"][name][str(kr)]
            row.append(_fmt(cell["over"], zero=OVER_ZERO) if cell["ok"] else "failed")
        else:
            row.append("-")
        lines.append("| " + " | ".join(row) + " |")
    lines += ["", "Mean rank: the method's rank by rel. RMSE among the methods that succeeded, averaged over "
              "every (case, k) in which it succeeded (1 = best; ties share the mean rank).", ""]

    for case in res["cases"]:
        lines += [f"### {case['title']} (`{case['key']}`)", "",
                  f"Mesh: {case['mesh']}, {case['faces']:,} triangles. Field: {case['field']}."]
        for note in case["notes"]:
            lines.append(f"Note: {note}.")
        lines += ["", f"![rel. RMSE vs k, {case['key']}]({png_dir}/accuracy_{case['key']}.png)", ""]
        head = ["method"] + [f"k = {k}" for k in ks]
        lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for name in res["methods"]:
            row = [name] + [_cell_text(case["rows"][name][str(k)], _best(case, k)) for k in ks]
            lines.append("| " + " | ".join(row) + " |")
        lines.append("")
    return lines


def mean_ranks(res):
    """Per method: (mean rank by rel. RMSE over the (case, k) cells where it succeeded, number of failures)."""
    from scipy.stats import rankdata

    acc = {name: [] for name in res["methods"]}
    fails = {name: 0 for name in res["methods"]}
    for case in res["cases"]:
        for k in res["ks"]:
            ok = [(case["rows"][n][str(k)]["rmse"], n) for n in res["methods"] if case["rows"][n][str(k)]["ok"]]
            for n in res["methods"]:
                if not case["rows"][n][str(k)]["ok"]:
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

    paths = []
    styles = ["o", "s", "^", "v", "D", "P", "X", "*", "h", "<", ">"]
    for case in res["cases"]:
        fig, ax = plt.subplots(figsize=(7.5, 5))
        for i, name in enumerate(res["methods"]):
            ks = [k for k in res["ks"] if case["rows"][name][str(k)]["ok"]]
            ys = [case["rows"][name][str(k)]["rmse"] for k in ks]
            if not ks:
                continue
            peer = res["family"][name] == "peer"
            color = "black" if i == 0 else f"C{(i - 1) % 10}"
            ax.plot(ks, ys, linestyle="--" if peer else "-", marker=styles[i % len(styles)], color=color,
                    linewidth=2.4 if i == 0 else 1.2, label=res["short"][name])
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks(res["ks"])
        ax.set_xticklabels([str(k) for k in res["ks"]])
        ax.set_xlabel("samples k")
        ax.set_ylabel("rel. RMSE (off the samples)")
        ax.set_title(f"{case['key']}: {case['vertices']:,} vertices (solid: manifill, dashed: peers; "
                     f"igl harmonic coincides with mf harmonic)", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8, ncol=2)
        fig.tight_layout()
        path = outdir / f"accuracy_{case['key']}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


# ---------------------------------------------------------------------------
# where manifill leads and trails, from the numbers
# ---------------------------------------------------------------------------

DEFAULT = "manifill gvf-harmonic, delaunay, hermite (default)"
BIHARMONIC = "libigl biharmonic (k=2, points)"
RBF = "SciPy RBF thin-plate spline (xyz)"
HARMONIC = "libigl harmonic (k=1, points)"


def _rmse(case, name, k):
    cell = case["rows"][name][str(k)]
    return cell["rmse"] if cell["ok"] else None


def leads_and_trails(res):
    """Bullet lines comparing manifill's methods with the peers, computed from the results."""
    lines = []
    ks, kr = res["ks"], k_ref(res)
    mf = [n for n in res["methods"] if res["family"][n] == "manifill"]
    peers_ = [n for n in res["methods"] if res["family"][n] == "peer"]
    for case in res["cases"]:
        parts = []
        for k in ks:
            d = _rmse(case, DEFAULT, k)
            ok_peers = [(v, n) for n in peers_ if (v := _rmse(case, n, k)) is not None]
            ok_mf = [(v, n) for n in mf if (v := _rmse(case, n, k)) is not None]
            if not ok_peers and not ok_mf:
                parts.append(f"k = {k}: every method failed")
                continue
            if d is None:
                survivors = ", ".join(res["short"][n] for _, n in sorted(ok_peers + ok_mf))
                parts.append(f"k = {k}: the default failed (ran: {survivors or 'none'})")
                continue
            bp = min(ok_peers) if ok_peers else None
            bm = min(ok_mf)
            txt = f"k = {k}: default {d:.4f}"
            if bm[1] != DEFAULT:
                txt += f", best manifill {res['short'][bm[1]]} {bm[0]:.4f}"
            if bp is not None:
                txt += f", best peer {res['short'][bp[1]]} {bp[0]:.4f} (default / best peer = {d / bp[0]:.2f})"
            parts.append(txt)
        lines.append(f"- **{case['key']}**: " + "; ".join(parts) + ".")
    # head-to-head counts over all (case, k)
    lines.append("")
    for other in (BIHARMONIC, RBF, HARMONIC, "nearest sample (geodesic, Dijkstra)"):
        if other not in res["methods"]:
            continue
        wins, losses = [], []
        for case in res["cases"]:
            for k in ks:
                a, b = _rmse(case, DEFAULT, k), _rmse(case, other, k)
                if a is None or b is None:
                    continue
                (wins if a < b else losses).append(f"{case['key']} k={k}")
        total = len(wins) + len(losses)
        if not total:
            continue
        if losses and len(losses) <= len(wins):
            tail = f" (the peer is better on: {', '.join(losses)})"
        elif wins and len(wins) < len(losses):
            tail = f" (the default is better only on: {', '.join(wins)})"
        else:
            tail = ""
        lines.append(f"- manifill's default against {res['short'][other]}: lower rel. RMSE in {len(wins)} of "
                     f"{total} (case, k) cells where both ran{tail}.")
    step = next((c for c in res["cases"] if c["key"] == "sphere-step"), None)
    if step is not None:
        overs = sorted(((step["rows"][n][str(kr)]["over"], n) for n in res["methods"]
                        if step["rows"][n][str(kr)]["ok"]), key=lambda t: t[0])
        lines.append(f"- Step field, k = {kr}, overshoot beyond the samples' range (fraction of the jump): "
                     + ", ".join(f"{res['short'][n]} {_fmt(v, zero=OVER_ZERO)}" for v, n in overs) + ".")
    return lines


def _ratio_text(a, b):
    """``a / b`` as a factor with the direction in words."""
    if a is None or b is None or a <= 0 or b <= 0:
        return "n/a"
    r = a / b
    return f"{r:.1f}x higher" if r >= 1.05 else (f"{1 / r:.1f}x lower" if r <= 1 / 1.05 else "about equal")


def _geomean(xs):
    xs = [x for x in xs if x is not None and x > 0]
    return float(np.exp(np.mean(np.log(xs)))) if xs else None


def headlines(res):
    """The main findings, each a computed comparison (the wording follows the numbers)."""
    ks, kr = res["ks"], k_ref(res)
    cases = {c["key"]: c for c in res["cases"]}
    lines = []
    mf = [n for n in res["methods"] if res["family"][n] == "manifill"]
    linear = "manifill gvf-harmonic, delaunay, linear"
    naive = "manifill harmonic (point constraints)"

    # smooth fields: the higher-order peers
    smooth = [key for key in ("sphere-smooth", "airplane", "u-strip") if key in cases]
    if smooth:
        parts, bih_wins = [], []
        for key in smooth:
            c = cases[key]
            d = _rmse(c, DEFAULT, kr)
            parts.append(f"{key}: {_ratio_text(d, _rmse(c, BIHARMONIC, kr))} than libigl's biharmonic, "
                         f"{_ratio_text(d, _rmse(c, RBF, kr))} than the RBF")
            b = _rmse(c, BIHARMONIC, kr)
            best_mf = min((v for n in mf if (v := _rmse(c, n, kr)) is not None), default=None)
            bih_wins.append(b is not None and best_mf is not None and b < best_mf)
        text = f"- **Smooth fields, k = {kr}: the default's rel. RMSE is** " + "; ".join(parts) + "."
        if all(bih_wins):
            text += (" On every one of these, libigl's biharmonic interpolation beats every manifill method: a "
                     "fourth-order fill reproduces smooth fields better than harmonic patches.")
        elif any(bih_wins):
            text += (" libigl's biharmonic beats every manifill method on "
                     + ", ".join(k for k, w in zip(smooth, bih_wins) if w) + ".")
        lines.append(text)

    # intrinsic fields on non-convex surfaces: does straight-line distance mislead?
    geo = [key for key in ("u-strip", "airplane", "ant") if key in cases]
    if geo:
        parts = []
        for key in geo:
            c = cases[key]
            parts.append(f"{key}: " + ", ".join(f"k = {k} {_ratio_text(_rmse(c, RBF, k), _rmse(c, DEFAULT, k))}"
                                                for k in ks if _rmse(c, RBF, k) and _rmse(c, DEFAULT, k)))
        text = ("- **Geodesic fields: the RBF on xyz (straight-line distance) has rel. RMSE, against manifill's "
                "default,** " + "; ".join(parts) + ".")
        if "u-strip" in cases:
            c = cases["u-strip"]
            a, b = c["rows"][RBF][str(ks[-1])], c["rows"][DEFAULT][str(ks[-1])]
            if a["ok"] and b["ok"]:
                text += (f" On the U strip its maximum error at k = {ks[-1]} is {a['max']:.2f} of the range "
                         f"against the default's {b['max']:.2f}")
                text += (": values leak across the gap between the arms." if a["max"] > 1.5 * b["max"] else ".")
        lines.append(text)

    # the step: overshoot
    if "sphere-step" in cases:
        c = cases["sphere-step"]
        ok = [(c["rows"][n][str(kr)]["rmse"], c["rows"][n][str(kr)]["over"], n) for n in res["methods"]
              if c["rows"][n][str(kr)]["ok"]]
        if ok:
            lo, hi = min(o[0] for o in ok), max(o[0] for o in ok)
            bounded = [res["short"][n] for _, o, n in ok if o < OVER_ZERO]
            over = sorted(((o, n) for _, o, n in ok if o >= OVER_ZERO), reverse=True)
            lines.append(f"- **Step field, k = {kr}**: rel. RMSE from {lo:.3f} to {hi:.3f} across all methods (a "
                         f"jump is hard for every interpolant). Overshoot beyond the samples' range: none for "
                         f"{', '.join(bounded) or 'no method'}; "
                         + ", ".join(f"{res['short'][n]} {o:.2f}" for o, n in over) + " of the jump."
                         + (" The default's Hermite curve values overshoot like the higher-order peers; its linear "
                            "curve values do not." if c["rows"][DEFAULT][str(kr)]["ok"]
                            and c["rows"][DEFAULT][str(kr)]["over"] >= OVER_ZERO and res["short"][linear] in bounded
                            else ""))

    # manifill's own methods
    best_counts = {n: 0 for n in mf}
    cells = 0
    for c in res["cases"]:
        for k in ks:
            ok = [(_rmse(c, n, k), n) for n in mf if _rmse(c, n, k) is not None]
            if ok:
                best_counts[min(ok)[1]] += 1
                cells += 1
    if cells:
        order = sorted(best_counts.items(), key=lambda t: -t[1])
        lines.append("- **Among manifill's methods** the lowest rel. RMSE per (case, k) cell: "
                     + ", ".join(f"{res['short'][n]} {v}" for n, v in order if v) + f" of {cells} cells.")
    ratios = [(_rmse(c, DEFAULT, k), _rmse(c, naive, k)) for c in res["cases"] for k in ks]
    g = _geomean([a / b for a, b in ratios if a is not None and b is not None])
    pairs = [(_rmse(c, naive, k), _rmse(c, HARMONIC, k)) for c in res["cases"] for k in ks]
    pairs = [(a, b) for a, b in pairs if a is not None and b is not None]
    same = f"{sum(1 for a, b in pairs if abs(a - b) <= 1e-6 * b)} of {len(pairs)}"
    if g is not None:
        lines.append(f"- **Against harmonic interpolation from the samples alone** (manifill's "
                     f"`method='harmonic'`, the same rel. RMSE as `igl.harmonic` k=1 to 1e-6 in {same} cells): "
                     f"the default's rel. RMSE is {1 / g:.1f}x lower (geometric mean over every cell where both "
                     f"ran).")
    # where the Hermite default hurts
    bad = []
    for c in res["cases"]:
        for k in ks:
            a, b = _rmse(c, DEFAULT, k), _rmse(c, linear, k)
            if a is not None and b is not None and a > 1.25 * b:
                bad.append(f"{c['key']} k={k} ({a:.3f} vs {b:.3f})")
    if bad:
        lines.append("- **Where the default trails its own linear curve values** (by more than 25 %): "
                     + ", ".join(bad) + ". Hermite slopes come from gradients estimated at the samples; when "
                     "the samples are sparse against the field's variation the cubic along a long curve "
                     "overshoots (see the overshoot column), and the patches inherit it.")
    # components
    if "ant" in cases:
        c = cases["ant"]
        k0 = ks[0]
        failed = [res["short"][n] for n in res["methods"] if not c["rows"][n][str(k0)]["ok"]]
        ran = [res["short"][n] for n in res["methods"] if c["rows"][n][str(k0)]["ok"]]
        if failed:
            lines.append(f"- **Several components (the ant, k = {k0} < 15 components)**: {len(failed)} methods stop "
                         f"with an error naming the component without samples (manifill) or a bare failure "
                         f"(libigl); only {', '.join(ran) or 'none'} returned values, which on an unsampled "
                         f"component are extrapolated in space from other parts of the body.")
    return lines
