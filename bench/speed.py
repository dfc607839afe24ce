"""Speed and scaling: manifill and libigl on icospheres of growing size, each tool in a fresh process.

For every icosphere level, 100 random samples of the smooth field, these
processes run one after another, each under ``/usr/bin/time -v`` (whose
"Maximum resident set size" is the peak memory):

``baseline``
    imports (numpy, scipy, pyamg, manifill, igl) and the mesh, nothing else;
``reconstruct``
    ``manifill.reconstruct`` (the default pipeline) ``repeat`` times, each
    followed by ``igl.harmonic`` (k = 1) on the same fixed set (the curve
    network and its values), interleaved in the one process, so their ratio
    is a same-run ratio; libigl is imported only after the first
    reconstruction, whose peak memory is recorded on its own;
``igl-fixed``
    ``igl.harmonic`` on that fixed set alone, for its peak memory;
``harmonic-points`` / ``igl-points`` / ``igl-biharmonic``
    the point-constraint problems: ``manifill.harmonic`` and ``igl.harmonic``
    with k = 1 (the same linear system) and k = 2, from the 100 samples alone.

Times are the best of up to ``repeat`` runs (fewer for slow ones). A tool is
skipped at a size where its time, extrapolated from the smaller sizes, would
exceed the cap. Run a child by hand with ``python -m bench.speed TOOL LEVEL K
WORKDIR REPEAT``.
"""

import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

__all__ = ["sweep", "speed_markdown", "scaling_markdown", "plot_scaling", "leads", "TOOLS"]

ROOT = Path(__file__).resolve().parents[1]
LEVELS_FULL = (5, 6, 7, 8)
LEVELS_SMOKE = (2, 3)
K = 100
CAP_FULL = 150.0  # seconds: skip a tool whose extrapolated time exceeds this
CAP_SMOKE = 20.0
TOOLS = ("baseline", "reconstruct", "igl-fixed", "harmonic-points", "igl-points", "igl-biharmonic")
STEPS = ("validate", "graph", "partition", "check", "curve_values", "harmonic")


# ---------------------------------------------------------------------------
# the child process: one tool at one size
# ---------------------------------------------------------------------------


def _problem(level, k):
    from manifill.mesh.shapes import icosphere

    from .fields import smooth_field

    V, F = icosphere(level)
    f = smooth_field(V)
    idx = np.sort(np.random.default_rng([0, k]).choice(len(V), size=k, replace=False))
    return V, F, idx, f[idx]


def _rss_kb():
    import resource

    return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)  # kilobytes on Linux


def _repeat(fn, repeat, budget=10.0):
    """Run ``fn`` up to ``repeat`` times, stopping once ``budget`` seconds are spent; (times, last result)."""
    times, out = [], None
    while len(times) < repeat:
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
        if sum(times) > budget:
            break
    return times, out


def child(tool, level, k, workdir, repeat):
    """Run one tool at one size in this process; returns a JSON-able dict."""
    import manifill

    level, k, repeat = int(level), int(k), int(repeat)
    V, F, idx, vals = _problem(level, k)
    out = {"tool": tool, "level": level, "vertices": len(V), "k": k}
    fixed_file = Path(workdir) / f"fixed_{level}.npz"
    if tool == "baseline":
        import igl  # noqa: F401 - the import is what is measured
        import pyamg  # noqa: F401
        import scipy.sparse  # noqa: F401
    elif tool == "reconstruct":
        totals, steps, igl_times = [], [], []
        t0 = time.perf_counter()
        r = manifill.reconstruct(V, F, idx, vals)
        totals.append(time.perf_counter() - t0)
        steps.append(dict(r.report["seconds"]))
        out["rss_first_run_kb"] = _rss_kb()  # before libigl is imported
        import igl

        F64 = F.astype(np.int64)
        b = np.flatnonzero(r.on_curve)
        z = None
        for i in range(repeat):
            if i:
                t0 = time.perf_counter()
                r = manifill.reconstruct(V, F, idx, vals)
                totals.append(time.perf_counter() - t0)
                steps.append(dict(r.report["seconds"]))
            t0 = time.perf_counter()
            z = igl.harmonic(V, F64, b, r.values[b][:, None], 1).ravel()
            igl_times.append(time.perf_counter() - t0)
        best = int(np.argmin(totals))
        out.update(totals=totals, steps=steps[best], igl_fixed_times=igl_times,
                   fixed=int(b.size), curves=r.report["partition"]["curves"],
                   patches=r.report["partition"]["patches"], solver=r.report["fill"]["solver"],
                   max_diff=float(np.abs(z - r.values).max()))
        np.savez(fixed_file, b=b, bc=r.values[b])
    elif tool == "igl-fixed":
        import igl

        d = np.load(fixed_file)
        F64 = F.astype(np.int64)
        times, _ = _repeat(lambda: igl.harmonic(V, F64, d["b"], d["bc"][:, None], 1), 1)
        out["times"] = times
    elif tool == "harmonic-points":
        times, _ = _repeat(lambda: manifill.harmonic(V, F, idx, vals), repeat)
        out["times"] = times
    elif tool in ("igl-points", "igl-biharmonic"):
        import igl

        F64 = F.astype(np.int64)
        order = 1 if tool == "igl-points" else 2
        times, _ = _repeat(lambda: igl.harmonic(V, F64, idx, vals[:, None], order), repeat)
        out["times"] = times
    else:
        raise SystemExit(f"unknown tool {tool!r}; pass one of {', '.join(TOOLS)}")
    out["rss_self_kb"] = _rss_kb()
    return out


# ---------------------------------------------------------------------------
# the parent: the sweep
# ---------------------------------------------------------------------------


def _spawn(tool, level, k, workdir, repeat, timeout):
    """One child under /usr/bin/time -v; its JSON, with ``rss_kb`` (peak memory) and ``wall``."""
    cmd = [sys.executable, "-m", "bench.speed", tool, str(level), str(k), str(workdir), str(repeat)]
    if Path("/usr/bin/time").exists():
        cmd = ["/usr/bin/time", "-v"] + cmd
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    t0 = time.perf_counter()
    try:
        p = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"tool": tool, "level": level, "failed": f"timed out after {timeout:.0f} s"}
    wall = time.perf_counter() - t0
    lines = [ln for ln in p.stdout.splitlines() if ln.startswith("{")]
    if p.returncode != 0 or not lines:
        err = [ln for ln in p.stderr.splitlines() if ln.strip() and not ln.startswith("\t")]
        return {"tool": tool, "level": level, "failed": f"exit {p.returncode}: {(err or ['?'])[-1][:120]}"}
    out = json.loads(lines[-1])
    m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", p.stderr)
    out["rss_kb"] = int(m.group(1)) if m else out["rss_self_kb"]
    out["rss_source"] = "/usr/bin/time -v" if m else "getrusage"
    out["wall"] = wall
    return out


def best_time(r):
    """The best time of a child's result (reconstruct: the best total)."""
    if r is None or "failed" in r or "skipped" in r:
        return None
    if r["tool"] == "reconstruct":
        return min(r["totals"])
    return min(r["times"]) if r.get("times") else None


def _estimate(sizes_times, n_next):
    """Extrapolated time at ``n_next`` from the measured (n, t), with a slope of at least 1."""
    if not sizes_times:
        return None
    if len(sizes_times) >= 2:
        (n0, t0), (n1, t1) = sizes_times[-2], sizes_times[-1]
        slope = max(1.0, np.log(max(t1, 1e-6) / max(t0, 1e-6)) / np.log(n1 / n0))
    else:
        slope = 1.5
    n1, t1 = sizes_times[-1]
    return t1 * (n_next / n1) ** slope


def sweep(smoke=False, log=print, repeat=3):
    """Every tool at every size; returns a JSON-able dict."""
    levels = LEVELS_SMOKE if smoke else LEVELS_FULL
    cap = CAP_SMOKE if smoke else CAP_FULL
    t_start = time.perf_counter()
    results = {tool: [] for tool in TOOLS}
    history = {tool: [] for tool in TOOLS}
    with tempfile.TemporaryDirectory(prefix="manifill-bench-") as workdir:
        for level in levels:
            n = 10 * 4**level + 2
            for tool in TOOLS:
                est = _estimate(history[tool], n)
                if est is not None and est > cap:
                    results[tool].append({"tool": tool, "level": level, "vertices": n,
                                          "skipped": f"estimated {est:.0f} s > cap {cap:.0f} s"})
                    log(f"  level {level} {tool}: skipped (estimated {est:.0f} s)")
                    continue
                if tool == "igl-fixed" and best_time(results["reconstruct"][-1]) is None:
                    results[tool].append({"tool": tool, "level": level, "vertices": n,
                                          "failed": "no fixed set (reconstruct did not run)"})
                    continue
                timeout = max(120.0, 4 * cap)
                r = _spawn(tool, level, K, workdir, repeat, timeout)
                r.setdefault("vertices", n)
                results[tool].append(r)
                t = best_time(r)
                if t is not None:
                    history[tool].append((n, t))
                msg = r.get("failed") or (f"best {t:.3f} s, peak {r['rss_kb'] / 1024:.0f} MB, "
                                          f"process {r['wall']:.1f} s" if t is not None else
                                          f"peak {r['rss_kb'] / 1024:.0f} MB")
                log(f"  level {level} ({n:,} vertices) {tool}: {msg}")
    return {"levels": list(levels), "k": K, "repeat": repeat, "cap": cap, "results": results,
            "seconds": time.perf_counter() - t_start}


# ---------------------------------------------------------------------------
# reporting
# ---------------------------------------------------------------------------


def series(res):
    """Time series for the slopes and the plot: name -> (vertices, seconds)."""
    out = {}
    rec = [r for r in res["results"]["reconstruct"] if best_time(r) is not None]
    out["manifill reconstruct, total"] = ([r["vertices"] for r in rec], [min(r["totals"]) for r in rec])
    for s in STEPS:
        out[f"  step: {s}"] = ([r["vertices"] for r in rec], [r["steps"].get(s, 0.0) for r in rec])
    out["igl.harmonic, same fixed set (in-process)"] = ([r["vertices"] for r in rec],
                                                        [min(r["igl_fixed_times"]) for r in rec])
    names = {"harmonic-points": "manifill.harmonic, 100 points", "igl-points": "igl.harmonic k=1, 100 points",
             "igl-biharmonic": "igl.harmonic k=2 (biharmonic), 100 points"}
    for tool, name in names.items():
        ok = [r for r in res["results"][tool] if best_time(r) is not None]
        out[name] = ([r["vertices"] for r in ok], [best_time(r) for r in ok])
    return out


def slope(ns, ts):
    """Least-squares slope of log(time) against log(vertices); None with fewer than two points."""
    ok = [(n, t) for n, t in zip(ns, ts) if t and t > 0]
    if len(ok) < 2:
        return None
    n, t = np.array(ok, dtype=float).T
    return float(np.polyfit(np.log(n), np.log(t), 1)[0])


def _by_level(res, tool):
    return {r["level"]: r for r in res["results"][tool]}


def _t(v):
    return "-" if v is None else (f"{v:.3f}" if v < 10 else f"{v:.1f}")


def _status(r):
    if r is None:
        return "-"
    if "skipped" in r:
        return f"skipped ({r['skipped']})"
    if "failed" in r:
        return f"failed: {r['failed']}"
    return _t(best_time(r))


def speed_markdown(res):
    lines = ["## Speed", ""]
    lines += [f"Icospheres (`manifill.mesh.shapes.icosphere(level)`), levels {', '.join(map(str, res['levels']))}, "
              f"{res['k']} random samples of the smooth field. Every tool runs in a fresh process; times are the "
              f"best of up to {res['repeat']} runs inside that process (slow ones fewer), mesh building excluded. "
              f"`manifill.reconstruct` and `igl.harmonic` on the same fixed set (its curve network and values) "
              f"alternate in one process, so their ratio is a same-run ratio; the other ratios compare processes "
              f"run back to back. The machine has {os.cpu_count()} cores and other load, so read the ratios, not "
              f"the absolute times. A tool is skipped where its time, extrapolated from the smaller sizes, would "
              f"pass {res['cap']:.0f} s. Total time of this part: {res['seconds']:.0f} s.", ""]
    rec, pts = _by_level(res, "reconstruct"), _by_level(res, "igl-points")
    hp, bh = _by_level(res, "harmonic-points"), _by_level(res, "igl-biharmonic")
    head = ["level", "vertices", *STEPS, "**total**", "igl.harmonic same fixed set", "total / igl",
            "max abs diff", "curves / patches / fixed"]
    lines += ["### manifill.reconstruct per step (seconds), beside libigl on the same fixed set", "",
              "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for lv in res["levels"]:
        r = rec.get(lv)
        if r is None or best_time(r) is None:
            lines.append(f"| {lv} | - | {_status(r)} |" + " |" * (len(head) - 3))
            continue
        tot, ig = min(r["totals"]), min(r["igl_fixed_times"])
        lines.append("| " + " | ".join([str(lv), f"{r['vertices']:,}"] + [_t(r["steps"].get(s)) for s in STEPS]
                                       + [f"**{_t(tot)}**", _t(ig), f"{tot / ig:.2f}", f"{r['max_diff']:.1e}",
                                          f"{r['curves']} / {r['patches']} / {r['fixed']:,}"]) + " |")
    lines += ["", "Steps are those of the best run (`report['seconds']`); `harmonic` is the fill with the curve "
              "network fixed, the problem libigl solves in the next column; max abs diff compares the two answers.",
              ""]
    head = ["level", "vertices", "manifill reconstruct", "manifill.harmonic (points)", "igl.harmonic k=1 (points)",
            "igl biharmonic k=2 (points)", "reconstruct / igl k=1", "reconstruct / igl k=2",
            "manifill.harmonic / igl k=1"]
    lines += ["### Beside the point-constraint peers (seconds)", "",
              "The peers of the accuracy tables, as a user would call them: the 100 samples as the only "
              "constraints.", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for lv in res["levels"]:
        r = rec.get(lv)
        n = (r or {}).get("vertices", 10 * 4**lv + 2)
        a, b, c, d = best_time(r), best_time(hp.get(lv)), best_time(pts.get(lv)), best_time(bh.get(lv))
        lines.append("| " + " | ".join([str(lv), f"{n:,}", _status(r), _status(hp.get(lv)), _status(pts.get(lv)),
                                        _status(bh.get(lv)),
                                        f"{a / c:.2f}" if a and c else "-", f"{a / d:.3f}" if a and d else "-",
                                        f"{b / c:.2f}" if b and c else "-"]) + " |")
    lines.append("")
    return lines


def scaling_markdown(res, png_dir):
    lines = ["## Scaling", "", f"![time and peak memory against vertices]({png_dir}/scaling.png)", "",
             "Slope of log(time) against log(vertices) (`np.polyfit`, degree 1, over the sizes each series ran "
             "at); 1 is linear.", "", "| series | slope | sizes | time at the largest size (s) |", "|---|---|---|---|"]
    for name, (ns, ts) in series(res).items():
        s = slope(ns, ts)
        label = name.strip()
        lines.append(f"| {label} | {'-' if s is None else f'{s:.2f}'} | "
                     f"{', '.join(f'{n:,}' for n in ns) or '-'} | {_t(ts[-1]) if ts else '-'} |")
    lines += ["", "### Peak memory (MB, maximum resident set size of each process)", ""]
    head = ["level", "vertices", "baseline (imports + mesh)", "reconstruct (first run, before libigl)",
            "reconstruct process (+ igl.harmonic fixed set)", "igl.harmonic fixed set", "manifill.harmonic points",
            "igl.harmonic k=1 points", "igl biharmonic k=2 points"]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    src = set()
    for lv in res["levels"]:
        row = [str(lv), f"{10 * 4**lv + 2:,}"]
        for tool in ("baseline", "reconstruct-first", "reconstruct", "igl-fixed", "harmonic-points", "igl-points",
                     "igl-biharmonic"):
            r = _by_level(res, "reconstruct" if tool == "reconstruct-first" else tool).get(lv)
            if r is None or "rss_kb" not in r:
                row.append("-" if r is None else ("skipped" if "skipped" in r else "failed"))
                continue
            src.add(r.get("rss_source", "?"))
            kb = r["rss_first_run_kb"] if tool == "reconstruct-first" else r["rss_kb"]
            row.append(f"{kb / 1024:.0f}")
        lines.append("| " + " | ".join(row) + " |")
    lines += ["", f"Peak memory read from: {', '.join(sorted(src)) or '-'} (the first-run column from `getrusage` "
              f"inside the process). The limit: levels up to {max(res['levels'])} "
              f"({10 * 4**max(res['levels']) + 2:,} vertices); level 9 (2.6 M vertices) is left out to keep the "
              f"run within minutes.", ""]
    return lines


def plot_scaling(res, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 5))
    main_colors = iter(["black", "C1", "C2", "C3", "C4", "C5"])
    all_series = series(res)
    n_steps = sum(1 for name in all_series if name.startswith("  "))
    i_step = 0
    for name, (ns, ts) in all_series.items():
        if not ns:
            continue
        step = name.startswith("  ")
        if step:
            color = plt.cm.viridis(i_step / max(1, n_steps - 1))
            i_step += 1
        else:
            color = next(main_colors)
        s = slope(ns, ts)
        label = f"{name.strip()} (slope {s:.2f})" if s is not None else name.strip()
        ax.plot(ns, ts, marker="." if step else "o", linestyle=":" if step else "-", linewidth=0.9 if step else 1.8,
                color=color, label=label)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("vertices")
    ax.set_ylabel("seconds (best run)")
    ax.set_title(f"time, {res['k']} samples", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    mem = (("reconstruct", "rss_first_run_kb", "manifill reconstruct (first run)", "black"),
           ("igl-fixed", "rss_kb", "igl.harmonic fixed set", "C1"),
           ("harmonic-points", "rss_kb", "manifill.harmonic points", "C2"),
           ("igl-points", "rss_kb", "igl.harmonic k=1 points", "C3"),
           ("igl-biharmonic", "rss_kb", "igl biharmonic points", "C4"),
           ("baseline", "rss_kb", "baseline (imports + mesh)", "gray"))
    for tool, key, label, color in mem:
        ok = [r for r in res["results"][tool] if key in r]
        if ok:
            bx.plot([r["vertices"] for r in ok], [r[key] / 1024 for r in ok], marker="o", color=color, label=label)
    bx.set_xscale("log")
    bx.set_yscale("log")
    bx.set_xlabel("vertices")
    bx.set_ylabel("peak resident memory (MB)")
    bx.set_title("peak memory per process", fontsize=10)
    bx.grid(True, which="both", alpha=0.3)
    bx.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def leads(res):
    """Bullet lines on speed and memory, computed from the sweep."""
    rec, pts = _by_level(res, "reconstruct"), _by_level(res, "igl-points")
    hp, bh = _by_level(res, "harmonic-points"), _by_level(res, "igl-biharmonic")
    ran = [lv for lv in res["levels"] if best_time(rec.get(lv)) is not None]
    if not ran:
        return ["- Speed: manifill.reconstruct did not run."]
    top = ran[-1]
    r = rec[top]
    tot, ig = min(r["totals"]), min(r["igl_fixed_times"])
    lines = [f"- **Speed** at {r['vertices']:,} vertices, 100 samples: the whole pipeline takes {tot:.2f} s, "
             f"{tot / ig:.2f}x libigl's solve of its final harmonic fill alone (same fixed set, same process; "
             f"answers equal to {r['max_diff']:.0e})."]
    a, c = best_time(hp.get(top)), best_time(pts.get(top))
    if c:
        lines.append(f"- The same size from the 100 points alone: igl.harmonic k=1 {c:.2f} s, so reconstruct "
                     f"takes {tot / c:.2f}x its time" + (f"; manifill.harmonic on that same point problem "
                                                         f"{a:.2f} s ({a / c:.2f}x)." if a else "."))
    low = ran[0]
    a0, c0 = best_time(hp.get(low)), best_time(pts.get(low))
    if a0 and c0 and a0 > 1.05 * c0:
        lines.append(f"- At the smallest size ({rec[low]['vertices']:,} vertices) manifill.harmonic on the point "
                     f"problem is the slower one: {a0:.3f} s against igl's {c0:.3f} s ({a0 / c0:.2f}x)"
                     + ("; `solver='auto'` factorises systems up to 20,000 unknowns, and on one large patch the "
                        "factorisation costs more than AMG would." if 5000 <= rec[low]["vertices"] <= 20000
                        else "."))
    both = [lv for lv in ran if best_time(bh.get(lv)) is not None]
    if both:
        lv = both[-1]
        t_b = best_time(bh[lv])
        lines.append(f"- libigl's biharmonic, the most accurate peer on smooth fields, took {t_b:.2f} s at "
                     f"{rec[lv]['vertices']:,} vertices, {t_b / min(rec[lv]['totals']):.3g}x reconstruct's time "
                     f"there" + (f"; it was skipped above {rec[lv]['vertices']:,} vertices (extrapolated time over "
                                 f"the cap)." if lv != top else "."))
    sl = {name: slope(ns, ts) for name, (ns, ts) in series(res).items()}
    parts = [f"{name.strip()} {v:.2f}" for name, v in sl.items() if v is not None and not name.startswith("  ")]
    if parts:
        lines.append("- Log-log slopes of time against vertices: " + "; ".join(parts) + ".")
    m1 = r.get("rss_first_run_kb")
    mp = pts.get(top, {}).get("rss_kb")
    if m1 and mp:
        lines.append(f"- Peak memory at {r['vertices']:,} vertices: reconstruct {m1 / 1024:.0f} MB, "
                     f"igl.harmonic k=1 from the points {mp / 1024:.0f} MB.")
    return lines


if __name__ == "__main__":
    if len(sys.argv) != 6:
        raise SystemExit("usage: python -m bench.speed TOOL LEVEL K WORKDIR REPEAT")
    print(json.dumps(child(*sys.argv[1:])))
