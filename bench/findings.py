"""Where manifill leads and trails, and the main findings, computed from the accuracy results.

Cells are looked up per case: a case has its own k (the EEG montages' sizes on
``head-eeg``), and a cell that is missing, failed or skipped gives ``None``.
"""

import numpy as np

__all__ = ["leads_and_trails", "headlines", "rmse", "cell", "fmt", "k_ref", "case_kref", "DEFAULT", "BIHARMONIC", "RBF",
           "HARMONIC", "OVER_ZERO"]

OVER_ZERO = 1e-8  # overshoot below this fraction of the range is the iterative solver's tolerance: shown as 0


def fmt(v, digits=3, zero=1e-12):
    if v is None:
        return "-"
    if abs(v) < zero:  # round-off or solver tolerance: zero in any meaningful sense
        return "0"
    if abs(v) < 10 ** -digits:
        return f"{v:.1e}"
    return f"{v:.{digits}f}"


def k_ref(res):
    """The k of the summary: 100 when it was run, else the largest."""
    return 100 if 100 in res["ks"] else max(res["ks"])


def case_kref(res, case):
    """The summary's k for one case: :func:`k_ref`, or the case's own k closest to it (fixed layouts)."""
    kr = k_ref(res)
    ks = case.get("ks", res["ks"])
    return kr if kr in ks else min(ks, key=lambda k: (abs(k - kr), -k))


def cell(case, name, k):
    """The cell that ran, or None (missing, failed or skipped)."""
    c = case["rows"].get(name, {}).get(str(k))
    return c if c is not None and c["ok"] else None


# ---------------------------------------------------------------------------
# where manifill leads and trails, from the numbers
# ---------------------------------------------------------------------------

DEFAULT = "manifill default (biharmonic, projected onto the samples' range)"
BIHARMONIC = "libigl biharmonic (k=2, points)"
RBF = "SciPy RBF thin-plate spline (xyz)"
HARMONIC = "libigl harmonic (k=1, points)"


def rmse(case, name, k):
    """Rel. RMSE of a cell, or None."""
    c = cell(case, name, k)
    return c["rmse"] if c is not None else None


_rmse = rmse


def leads_and_trails(res):
    """Bullet lines comparing manifill's methods with the peers, computed from the results."""
    lines = []
    ks, kr = res["ks"], k_ref(res)
    mf = [n for n in res["methods"] if res["family"][n] == "manifill"]
    peers_ = [n for n in res["methods"] if res["family"][n] == "peer"]
    for case in res["cases"]:
        parts = []
        for k in case.get("ks", ks):
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
    for other in (BIHARMONIC, RBF, HARMONIC, "nearest sample (geodesic, Dijkstra)",
                  "potpourri3d vector heat extend_scalar", "pyvista Gaussian kernel interpolate"):
        if other not in res["methods"]:
            continue
        wins, losses = [], []
        for case in res["cases"]:
            for k in case.get("ks", ks):
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
                     + ", ".join(f"{res['short'][n]} {fmt(v, zero=OVER_ZERO)}" for v, n in overs) + ".")
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
    smooth = [key for key in ("sphere-smooth", "airplane", "u-strip", "head-eeg") if key in cases]
    if smooth:
        parts, bih_wins = [], []
        for key in smooth:
            c = cases[key]
            kc = case_kref(res, c)
            d = _rmse(c, DEFAULT, kc)
            parts.append(f"{key}{'' if kc == kr else f' (k = {kc})'}: {_ratio_text(d, _rmse(c, BIHARMONIC, kc))} "
                         f"than libigl's biharmonic, {_ratio_text(d, _rmse(c, RBF, kc))} than the RBF")
            b = _rmse(c, BIHARMONIC, kc)
            best_mf = min((v for n in mf if (v := _rmse(c, n, kc)) is not None), default=None)
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
                         + (" The default overshoots like the higher-order peers; the pipeline's linear "
                            "curve values do not." if c["rows"][DEFAULT][str(kr)]["ok"]
                            and c["rows"][DEFAULT][str(kr)]["over"] >= OVER_ZERO and res["short"][linear] in bounded
                            else ""))

    # manifill's own methods
    best_counts = {n: 0 for n in mf}
    cells = 0
    for c in res["cases"]:
        for k in c.get("ks", ks):
            ok = [(_rmse(c, n, k), n) for n in mf if _rmse(c, n, k) is not None]
            if ok:
                best_counts[min(ok)[1]] += 1
                cells += 1
    if cells:
        order = sorted(best_counts.items(), key=lambda t: -t[1])
        lines.append("- **Among manifill's methods** the lowest rel. RMSE per (case, k) cell: "
                     + ", ".join(f"{res['short'][n]} {v}" for n, v in order if v) + f" of {cells} cells.")
    ratios = [(_rmse(c, DEFAULT, k), _rmse(c, naive, k)) for c in res["cases"] for k in c.get("ks", ks)]
    g = _geomean([a / b for a, b in ratios if a is not None and b is not None])
    pairs = [(_rmse(c, naive, k), _rmse(c, HARMONIC, k)) for c in res["cases"] for k in c.get("ks", ks)]
    pairs = [(a, b) for a, b in pairs if a is not None and b is not None]
    same = f"{sum(1 for a, b in pairs if abs(a - b) <= 1e-6 * b)} of {len(pairs)}"
    if g is not None:
        lines.append(f"- **Against harmonic interpolation from the samples alone** (manifill's "
                     f"`method='harmonic'`, the same rel. RMSE as `igl.harmonic` k=1 to 1e-6 in {same} cells): "
                     f"the default's rel. RMSE is {1 / g:.1f}x lower (geometric mean over every cell where both "
                     f"ran).")
    # where the default's cubic curves hurt
    bad = []
    for c in res["cases"]:
        for k in c.get("ks", ks):
            a, b = _rmse(c, DEFAULT, k), _rmse(c, linear, k)
            if a is not None and b is not None and a > 1.25 * b:
                bad.append(f"{c['key']} k={k} ({a:.3f} vs {b:.3f})")
    if bad:
        lines.append("- **Where the default trails its own linear curve values** (by more than 25 %): "
                     + ", ".join(bad) + ". Cubic curve values take their slopes from gradients estimated at the "
                     "samples; when the samples are sparse against the field's variation that estimate misleads the "
                     "cubic along a long curve, and the patches inherit it.")
    # components
    if "ant" in cases:
        c = cases["ant"]
        k0 = ks[0]
        failed = [res["short"][n] for n in res["methods"]
                  if not c["rows"][n][str(k0)]["ok"] and not c["rows"][n][str(k0)].get("skipped")]
        ran = [res["short"][n] for n in res["methods"] if c["rows"][n][str(k0)]["ok"]]
        if failed:
            lines.append(f"- **Several components (the ant, k = {k0} < 15 components)**: {len(failed)} methods stop "
                         f"with an error naming the component without samples (manifill) or a bare failure "
                         f"(libigl); only {', '.join(ran) or 'none'} returned values, which on an unsampled "
                         f"component are extrapolated in space from other parts of the body.")
    lines += _new_case_lines(res, cases)
    from .accuracy import targets_headline

    lines.append(targets_headline(res))
    return lines


def _ranked(res, case, k):
    return sorted((v, n) for n in res["methods"] if (v := rmse(case, n, k)) is not None)


def _new_case_lines(res, cases):
    """The noisy case, the rough image and the EEG head: who is best there, in numbers."""
    lines = []
    short = res["short"]
    if "sphere-noisy" in cases:
        c = cases["sphere-noisy"]
        kc = case_kref(res, c)
        parts = []
        for smooth, exact in (("manifill biharmonic, smoothing=auto", "manifill biharmonic (point constraints)"),
                              ("manifill harmonic, smoothing=auto", "manifill harmonic (point constraints)")):
            a, b = rmse(c, smooth, kc), rmse(c, exact, kc)
            if a is not None and b is not None:
                parts.append(f"{short[smooth]} {a:.4f} against {short[exact]} {b:.4f} ({_ratio_text(a, b)})")
        r = _ranked(res, c, kc)
        if parts or r:
            lines.append(f"- **Noisy samples (sigma = 5 % of the range), k = {kc}**: " + "; ".join(parts)
                         + (f"; the best row is {short[r[0][1]]} ({r[0][0]:.4f})." if r else "."))
    if "globe-image" in cases:
        c = cases["globe-image"]
        kc = case_kref(res, c)
        r = _ranked(res, c, kc)
        d = cell(c, DEFAULT, kc)
        if r:
            top = ", ".join(f"{short[n]} {v:.4f}" for v, n in r[:3])
            lines.append(f"- **Rough real field (image luminance), k = {kc}**: best {top}"
                         + (f"; the default {d['rmse']:.4f}, overshooting by {fmt(d['over'], zero=OVER_ZERO)} of "
                            f"the range" if d else "") + ".")
    if "head-eeg" in cases:
        c = cases["head-eeg"]
        parts = []
        for k in c["ks"]:
            r = _ranked(res, c, k)
            m = rmse(c, "MNE spherical spline (interpolate_bads, reg 1e-5)", k)
            m0 = rmse(c, "MNE spherical spline, reg 0 (exact)", k)
            if r:
                parts.append(f"k = {k} ({c['layouts'][str(k)]}): best {short[r[0][1]]} {r[0][0]:.4f}"
                             + (f", MNE's spline {m:.4f}" if m is not None else "")
                             + (f" ({m0:.4f} without its regularisation)" if m0 is not None else "")
                             + (f", default {d:.4f}" if (d := rmse(c, DEFAULT, k)) is not None else ""))
        if parts:
            lines.append("- **EEG on a head**: " + "; ".join(parts) + ".")
    return lines
