"""Benchmark: ``manifill.reconstruct`` (the default method) from 163k to 2.6M vertices, time and peak memory.

For each icosphere level (7, 8, 9: 163,842, 655,362 and 2,621,442 vertices) one
child process, under ``/usr/bin/time -v``, loads the mesh from a cache of
``.npy`` files (built first, in a process of its own, so that building the mesh
is not in the peak), draws 1,000 random samples of the smooth field and runs
``manifill.reconstruct`` ``--repeat`` times. Reported per size: the best total,
the per-step times of that run (``r.report["seconds"]``), the iterations, the
peak resident set size of the whole child process ("Maximum resident set
size": interpreter, imports, the mesh and the reconstruction) and the same
before the first reconstruction (``ru_maxrss`` after imports and the mesh), each
also in bytes per vertex. Between consecutive sizes: the time slope
``log(t_big / t_small) / log(n_big / n_small)`` of the total and of each step.

Run from the repository root::

    python -m bench.scale_speed [--levels 7 8 9] [--samples 1000] [--repeat 2]
                                [--cache /tmp] [--out bench/results/scale_speed.json]

A child alone: ``python -m bench.scale_speed --child LEVEL`` (prints its JSON).
Targets (issue 14): slope of the total from 655k to 2.6M <= 1.15; peak <= 900
bytes per vertex at 2.6M.
"""

import argparse
import json
import math
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _mesh_files(cache, level):
    return Path(cache) / f"manifill_ico{level}_V.npy", Path(cache) / f"manifill_ico{level}_F.npy"


def build_cache(cache, level):
    """Write ``icosphere(level)`` to ``cache`` as two ``.npy`` files, unless they are there."""
    fv, ff = _mesh_files(cache, level)
    if fv.is_file() and ff.is_file():
        return
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(level)
    np.save(fv, V)
    np.save(ff, F)


def _rss_kb():
    import resource

    return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)  # kilobytes on Linux


def child(level, samples, repeat, cache):
    """One size in this process: a JSON-able dict."""
    import manifill

    from .fields import smooth_field

    fv, ff = _mesh_files(cache, level)
    V, F = np.load(fv), np.load(ff)
    n = len(V)
    f = smooth_field(V)
    idx = np.sort(np.random.default_rng([0, samples]).choice(n, size=samples, replace=False))
    vals = f[idx]
    rss_before = _rss_kb()
    totals, steps, r = [], [], None
    for _ in range(repeat):
        r = None  # the peak is one reconstruction's, not two results side by side
        t0 = time.perf_counter()
        r = manifill.reconstruct(V, F, idx, vals)
        totals.append(time.perf_counter() - t0)
        steps.append({k: float(v) for k, v in r.report["seconds"].items()})
    best = int(np.argmin(totals))
    h = r.report["fill"]
    return {"level": level, "vertices": n, "samples": samples, "totals": totals, "total": totals[best],
            "steps": steps[best], "rss_before_kb": rss_before, "solver": h.get("solver"),
            "iterations": h.get("iterations"), "levels": h.get("levels"), "blocks": h.get("blocks"),
            "fixed": int(r.on_curve.sum()), "patches": r.report["partition"]["patches"],
            "checksum": float(np.nansum(r.values))}


def run_child(level, samples, repeat, cache):
    """The child under ``/usr/bin/time -v``: its dict plus ``peak_rss_kb``."""
    cmd = ["/usr/bin/time", "-v", sys.executable, "-m", "bench.scale_speed", "--child", str(level),
           "--samples", str(samples), "--repeat", str(repeat), "--cache", str(cache)]
    p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"level {level} failed:\n{p.stdout[-2000:]}\n{p.stderr[-4000:]}")
    out = json.loads(p.stdout.strip().splitlines()[-1])
    out["peak_rss_kb"] = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", p.stderr).group(1))
    return out


def slopes(rows):
    """Time slopes between consecutive sizes, of the total and of every step both runs have."""
    out = []
    for a, b in zip(rows, rows[1:]):
        ratio = math.log(b["vertices"] / a["vertices"])
        s = {"from": a["vertices"], "to": b["vertices"],
             "total": math.log(b["total"] / a["total"]) / ratio}
        for step, t in b["steps"].items():
            t0 = a["steps"].get(step)
            if t0 and t and t0 > 0.005:
                s[step] = math.log(t / t0) / ratio
        out.append(s)
    return out


def table(rows, slope_rows):
    steps = [s for s in rows[-1]["steps"] if s != "total"]
    lines = ["| vertices | total s | " + " | ".join(steps) + " | its | peak MB | B/vertex | before B/vertex |",
             "|---" * (len(steps) + 6) + "|"]
    for r in rows:
        n = r["vertices"]
        its = r["iterations"][0] if r["iterations"] else "-"
        lines.append(f"| {n:,} | {r['total']:.2f} | " + " | ".join(f"{r['steps'].get(s, 0):.2f}" for s in steps)
                     + f" | {its} | {r['peak_rss_kb'] / 1024:.0f} | {r['peak_rss_kb'] * 1024 / n:.0f}"
                     + f" | {r['rss_before_kb'] * 1024 / n:.0f} |")
    for s in slope_rows:
        lines.append(f"| slope {s['from']:,} -> {s['to']:,} | {s['total']:.2f} | "
                     + " | ".join(f"{s[k]:.2f}" if k in s else "-" for k in steps) + " | | | | |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", type=int, nargs="+", default=[7, 8, 9])
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=2, help="reconstructions per size; the best counts")
    ap.add_argument("--cache", default="/tmp", help="directory of the meshes' .npy files")
    ap.add_argument("--out", default=str(ROOT / "bench" / "results" / "scale_speed.json"))
    ap.add_argument("--child", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child is not None:
        print(json.dumps(child(args.child, args.samples, args.repeat, args.cache)))
        return
    for level in args.levels:  # in a process of its own: the mesh's construction is not in any peak
        subprocess.run([sys.executable, "-c", f"from bench.scale_speed import build_cache; "
                        f"build_cache({str(args.cache)!r}, {level})"], cwd=ROOT, check=True)
    rows = []
    for level in args.levels:
        rows.append(run_child(level, args.samples, args.repeat, args.cache))
        r = rows[-1]
        print(f"level {level}: {r['vertices']:,} vertices, total {r['total']:.2f} s, "
              f"peak {r['peak_rss_kb'] * 1024 / r['vertices']:.0f} B/vertex", flush=True)
    slope_rows = slopes(rows)
    print(table(rows, slope_rows))
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps({"command": "python -m bench.scale_speed " + " ".join(argv or sys.argv[1:]),
                                          "sizes": rows, "slopes": slope_rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
