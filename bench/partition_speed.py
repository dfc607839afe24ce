"""Speed of Steps 1-4 of ``gvf-harmonic`` at scale (issue 14), beside ``igl.harmonic`` in the same run.

``python -m bench.partition_speed [--levels 7,8] [--ks 1000,50000] [--repeat 2] [--quick] [--save FILE]``

For each icosphere level (7: 163,842 vertices; 8: 655,362) and number ``k`` of random
samples (seed ``(0, k)``) of the smooth field of :mod:`bench.fields`
(``sin(2x) + yz + 0.5 cos(3y)``):

- ``manifill.reconstruct(V, F, idx, vals, method='gvf-harmonic', curve_values='hermite')``,
  with its ``report['seconds']`` per step (validate, graph, partition = Steps 2-3,
  check = Step 1, curve_values = Step 4, harmonic = Steps 5-6);
- the same steps alone on one :class:`manifill.Surface`, split further: the multi-source
  Dijkstra and Voronoi pairs (:func:`manifill.mesh.graph.voronoi_pairs`), the rest of the
  partition (path tracing, patches), the normals and gradient fits of Step 4
  (:func:`manifill.surface.slopes.sample_gradients`) and the rest of Step 4;
- ``igl.harmonic(V, F, b, bc, 1)`` on the same fixed set (``b`` the curve vertices
  ``r.on_curve``, ``bc = r.values[b]``), and the ratio of the whole reconstruction to it
  (issue 14's target: at most 1.5 with 50,000 samples on 655k vertices).

Runs alternate (reconstruction, libigl), ``--repeat`` times; the best of each counts. The
machine may be shared: compare the ratios of one run. Writes JSON to
``bench/results/partition_speed.json`` (or ``--save``).
"""

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np

import manifill
from manifill.mesh.graph import voronoi_pairs
from manifill.mesh.shapes import icosphere
from manifill.surface.curve_values import curve_values, vertex_normals
from manifill.surface.gradual import check_gradual
from manifill.surface.partition import partition
from manifill.surface.slopes import sample_gradients
from manifill.surface.surface import Surface
from manifill.validate import unit_scale

from .fields import smooth_field

OUT = Path(__file__).resolve().parent / "results" / "partition_speed.json"


def _best(fn, repeat):
    best, out = np.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def steps_alone(V, F, idx, vals, repeat):
    """Steps 1-4 one by one on a Surface: seconds per (sub)step, best of ``repeat``."""
    s = Surface.from_mesh(V, F)
    sec = {}
    sec["dijkstra+voronoi"], _ = _best(lambda: voronoi_pairs(s.G, idx), repeat)
    sec["partition"], part = _best(lambda: partition(s, idx), repeat)
    sec["paths+patches"] = sec["partition"] - sec["dijkstra+voronoi"]
    starts = part.steepest(idx, vals)
    sec["check"], _ = _best(lambda: [check_gradual(s.G_hops, idx, vals[:, j], distance="hops", start=starts[j])
                                     for j in range(vals.shape[1])], repeat)
    E = part.curve_edges()
    sec["curve_values"], _ = _best(lambda: curve_values(V, E, idx, vals, method="hermite", F=F, curves=part.curves,
                                                        ends=part.ends), repeat)
    sc = unit_scale(V)
    Vs = V if sc == 1.0 else V * (1.0 / sc)
    sec["normals"], nrm = _best(lambda: vertex_normals(Vs, F, idx), repeat)
    sec["gradients"], _ = _best(lambda: sample_gradients(Vs, nrm, part.ends, idx, vals), repeat)
    sec["hermite rest"] = sec["curve_values"] - sec["normals"] - sec["gradients"]
    info = {"curves": len(part.curves), "curve_vertices": int(part.on_curve.sum()),
            "patches": part.report["patches"]}
    return sec, info


def run(level, k, repeat, igl):
    V, F = icosphere(level)
    f = smooth_field(V)
    idx = np.sort(np.random.default_rng([0, k]).choice(len(V), size=k, replace=False))
    vals = f[idx][:, None]
    whole, libigl, report = np.inf, np.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        r = manifill.reconstruct(V, F, idx, vals, method="gvf-harmonic", curve_values="hermite")
        t = time.perf_counter() - t
        if t < whole:
            whole, report = t, dict(r.report["seconds"])
        if igl is not None:
            b = np.flatnonzero(r.on_curve).astype(np.int64)
            t = time.perf_counter()
            igl.harmonic(V, F.astype(np.int64), b, np.ascontiguousarray(r.values[b], dtype=np.float64), 1)
            libigl = min(libigl, time.perf_counter() - t)
    alone, info = steps_alone(V, F, idx, vals, repeat)
    return {"level": level, "vertices": len(V), "samples": k, "reconstruct": whole, "steps": report,
            "alone": alone, "igl_harmonic": None if igl is None else libigl,
            "ratio": None if igl is None else whole / libigl, **info}


def table(rows):
    lines = ["| vertices | k | reconstruct | validate | graph | Steps 2-3 | Step 1 | Step 4 | Steps 5-6 | "
             "igl.harmonic | ratio |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        s = r["steps"]
        ig = "-" if r["igl_harmonic"] is None else f"{r['igl_harmonic']:.2f}"
        ratio = "-" if r["ratio"] is None else f"{r['ratio']:.2f}"
        lines.append(f"| {r['vertices']:,} | {r['samples']:,} | {r['reconstruct']:.2f} | {s.get('validate', 0):.2f} | "
                     f"{s.get('graph', 0):.2f} | {s['partition']:.2f} | {s['check']:.2f} | {s['curve_values']:.2f} | "
                     f"{s['harmonic']:.2f} | {ig} | {ratio} |")
    lines += ["", "Steps alone (best of the repeats, seconds):", "",
              "| vertices | k | Dijkstra + Voronoi pairs | paths + patches | Step 1 | normals | gradients | "
              "Hermite rest | curves | curve vertices |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        a = r["alone"]
        lines.append(f"| {r['vertices']:,} | {r['samples']:,} | {a['dijkstra+voronoi']:.2f} | "
                     f"{a['paths+patches']:.2f} | {a['check']:.2f} | {a['normals']:.2f} | {a['gradients']:.2f} | "
                     f"{a['hermite rest']:.2f} | {r['curves']:,} | {r['curve_vertices']:,} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", default="7,8", help="icosphere levels (comma separated)")
    ap.add_argument("--ks", default="1000,50000", help="sample counts (comma separated)")
    ap.add_argument("--repeat", type=int, default=2, help="runs of each; the best counts")
    ap.add_argument("--quick", action="store_true", help="levels 4-5, k 100 and 1,000, no libigl (smoke run)")
    ap.add_argument("--save", default=None, help=f"JSON file (default {OUT.relative_to(OUT.parents[2])})")
    args = ap.parse_args(argv)
    levels = [4, 5] if args.quick else [int(x) for x in args.levels.split(",")]
    ks = [100, 1000] if args.quick else [int(x) for x in args.ks.split(",")]
    igl = None
    if not args.quick:
        import igl
    rows = []
    for level in levels:
        for k in ks:
            row = run(level, k, args.repeat, igl)
            rows.append(row)
            print(f"level {level} ({row['vertices']:,} vertices), k = {k:,}: reconstruct {row['reconstruct']:.2f} s, "
                  f"igl.harmonic {row['igl_harmonic'] or float('nan'):.2f} s, ratio {row['ratio'] or float('nan'):.2f}",
                  flush=True)
    print()
    print(table(rows))
    out = Path(args.save) if args.save else OUT
    out.parent.mkdir(parents=True, exist_ok=True)
    meta = {"manifill": manifill.__version__, "numpy": np.__version__, "python": platform.python_version(),
            "repeat": args.repeat, "date": time.strftime("%Y-%m-%d %H:%M:%S")}
    out.write_text(json.dumps({"meta": meta, "rows": rows}, indent=1) + "\n", encoding="utf-8")
    print(f"\nwrote {out}")


if __name__ == "__main__":
    main()
