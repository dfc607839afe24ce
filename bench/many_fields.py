"""Many fields on one mesh (issue 14): ``reconstruct`` and ``Reconstructor`` beside ``igl.harmonic``, 1,000 columns.

``python -m bench.many_fields [--smoke] [--level 7] [--ks 100,1000] [--fields 1000] [--chunk 100]
[--methods default,gvf-harmonic,harmonic] [--out FILE] [--profile STAGE]``

On ``icosphere(level)`` (7: 163,842 vertices), ``k`` random sample vertices (seed ``(0, k)``)
and ``p`` fields of a smooth time series, ``f_t(x) = sin(3 (x cos t + y sin t)) + z t / 10``
for ``t`` in ``linspace(0, 2 pi, p)``, each configuration (k, method) runs in a fresh child
process, one after another (the machine is shared: compare the ratios of one child):

1. ``manifill.reconstruct(V, F, idx, vals)`` with ``vals`` (k, p);
2. ``manifill.Reconstructor(V, F, idx, ...)``: its build, then ``.apply`` on all ``p`` fields at
   once, in chunks of ``--chunk`` columns (the first ``--chunks-max`` chunks), and on one field (five
   single fields, the median; also without Step 1, which ``check=None`` runs for up to 10 fields);
3. ``igl.harmonic(V, F, b, bc, 1)`` with ``p`` columns on the same fixed set: for the
   pipeline (``gvf-harmonic``) ``b`` = the curve vertices (``r.on_curve``) and ``bc = r.values[b]``;
   for ``harmonic`` ``b = idx`` and ``bc = vals``; for the default (the biharmonic projected onto the
   samples' range) ``igl.harmonic(..., 2)`` from the samples, clipped to each field's range; also with one
   column (its factorisation plus one solve).

Checks: the largest ``|apply - reconstruct|`` (over all, the chunks and the single fields) and
the largest ``|manifill - igl|`` off the fixed set (both solve the same cotangent Dirichlet
problem; bounded fills agree where no bound is active). Peak memory: ``ru_maxrss`` of the child
after each stage (a running peak: the stage that raised it shows). Targets: one field's
``apply`` <= 20 ms; manifill <= 2 x ``igl.harmonic`` with ``p`` columns. Writes JSON
(``bench/results/many_fields.json``, or ``--out``) and prints markdown tables. ``--smoke``: a
tiny mesh and few fields, in seconds (for the tests). ``--profile STAGE`` (``reconstruct``,
``build``, ``all``, ``one``) prints the child's cProfile of that stage to stderr.

A child alone: ``python -m bench.many_fields --child '{"level": 7, "k": 100, "method": "harmonic", ...}'``.
"""

import argparse
import cProfile
import importlib.metadata as md
import json
import platform
import pstats
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import manifill
from manifill.mesh.shapes import icosphere

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "bench" / "results" / "many_fields.json"
METHODS = ("gvf-harmonic", "harmonic", "default")
SINGLE = 5  # single fields timed one by one; the median counts


def series(P, p):
    """The ``p`` fields at points ``P``: ``sin(3 (x cos t + y sin t)) + z t / 10``, ``t`` in ``[0, 2 pi]``, (n, p)."""
    t = np.linspace(0.0, 2.0 * np.pi, p)
    return np.sin(3.0 * (np.outer(P[:, 0], np.cos(t)) + np.outer(P[:, 1], np.sin(t)))) + np.outer(P[:, 2], t / 10)


def _rss_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # kilobytes on Linux


def _maxdiff(a, b):
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape or not np.array_equal(np.isnan(a), np.isnan(b)):
        return float("inf")
    d = np.abs(a - b)
    return float(np.nanmax(d)) if d.size else 0.0


class _Stages:
    """Times and running peaks of memory by stage; one stage under cProfile if asked."""

    def __init__(self, profile):
        self.seconds, self.rss, self.profile = {}, {}, profile

    def run(self, name, fn):
        prof = None
        if name == self.profile:
            prof = cProfile.Profile()
            prof.enable()
        t = time.perf_counter()
        out = fn()
        self.seconds[name] = time.perf_counter() - t
        if prof is not None:
            prof.disable()
            print(f"--- cProfile of stage {name!r} ---", file=sys.stderr)
            pstats.Stats(prof, stream=sys.stderr).sort_stats("cumulative").print_stats(35)
        self.rss[name] = _rss_mb()
        print(f"  {name}: {self.seconds[name]:.2f} s, peak {self.rss[name]:,.0f} MB", file=sys.stderr, flush=True)
        return out


def child(cfg):
    """One configuration in this process: a JSON-able dict."""
    try:
        import igl
    except ImportError:
        igl = None
    level, k, p, chunk, method = cfg["level"], cfg["k"], cfg["fields"], cfg["chunk"], cfg["method"]
    opts = {} if method == "default" else {"method": method}
    # warm up (imports, first calls) on a tiny mesh, so the first stage does not pay for them
    Vw, Fw = icosphere(2)
    iw = np.arange(0, len(Vw), 9)
    manifill.Reconstructor(Vw, Fw, iw, **opts).apply(series(Vw[iw], 12))
    manifill.reconstruct(Vw, Fw, iw, series(Vw[iw], 12), **opts)
    V, F = icosphere(level)
    n = len(V)
    idx = np.sort(np.random.default_rng([0, k]).choice(n, size=k, replace=False))
    vals = series(V[idx], p)
    st = _Stages(cfg.get("profile"))
    st.rss["mesh"] = _rss_mb()
    out = {"level": level, "vertices": n, "k": k, "fields": p, "chunk": chunk, "method": method}

    r = st.run("reconstruct", lambda: manifill.reconstruct(V, F, idx, vals, **opts))
    X = r.values
    h = r.report["fill"]
    out.update(method_run=r.report["method"], solver=h.get("solver"), unknowns=h.get("unknowns"),
               fixed=int(r.on_curve.sum()), reconstruct_steps={s: float(v) for s, v in r.report["seconds"].items()},
               check_skipped="check_skipped" in r.report)

    rec = st.run("build", lambda: manifill.Reconstructor(V, F, idx, **opts))
    out.update(linear=bool(rec.linear), build_steps={s: float(v) for s, v in rec.seconds.items()})
    a = st.run("all", lambda: rec.apply(vals))
    out["apply_all_steps"] = {s: float(v) for s, v in a.report["seconds"].items()}
    diffs = {"all": _maxdiff(a.values, X)}
    del a

    def chunks():
        d = 0.0
        for s in range(0, min(p, chunk * cfg.get("chunks_max", p)), chunk):
            d = max(d, _maxdiff(rec.apply(vals[:, s:s + chunk]).values, X[:, s:s + chunk]))
        return d

    diffs["chunks"] = st.run("chunks", chunks)
    out["chunked_fields"] = min(p, chunk * cfg.get("chunks_max", p))
    single, step1, d1 = [], [], 0.0
    for j in np.linspace(0, p - 1, SINGLE).astype(int):
        if st.profile == "one" and not single:
            st.run("one", lambda j=j: rec.apply(vals[:, j]))
        t = time.perf_counter()
        a1 = rec.apply(vals[:, j])
        single.append(time.perf_counter() - t)
        step1.append(a1.report["seconds"].get("check", 0.0))  # Step 1 runs for <= 10 fields unless check=False
        d1 = max(d1, _maxdiff(a1.values, X[:, j]))
    st.seconds["one"] = float(np.median(single))
    st.seconds["one without step 1"] = float(np.median(np.subtract(single, step1)))
    out["one_steps"] = {s: float(v) for s, v in a1.report["seconds"].items()}
    st.rss["one"] = _rss_mb()
    print(f"  one: {1e3 * st.seconds['one']:.1f} ms (median of {SINGLE}), without Step 1 "
          f"{1e3 * st.seconds['one without step 1']:.1f} ms", file=sys.stderr, flush=True)
    out["one_runs"], out["one_step1"] = single, step1
    diffs["one"] = d1
    out["apply_vs_reconstruct"] = diffs

    if igl is not None:
        # the pipeline: the harmonic fill from its curves; harmonic: from the samples; the default: the biharmonic
        # from the samples, clipped to each field's range (k = 2)
        order = 2 if method == "default" else 1
        b = np.flatnonzero(r.on_curve) if method == "gvf-harmonic" else idx
        b = np.ascontiguousarray(b, dtype=np.int64)
        bc = np.ascontiguousarray(X[b] if method == "gvf-harmonic" else vals, dtype=np.float64)
        F64 = np.ascontiguousarray(F, dtype=np.int64)
        V64 = np.ascontiguousarray(V, dtype=np.float64)
        st.run("igl one", lambda: igl.harmonic(V64, F64, b, np.ascontiguousarray(bc[:, :1]), order))
        Z = st.run("igl", lambda: igl.harmonic(V64, F64, b, bc, order))
        if method == "default":
            Z = np.clip(Z, vals.min(axis=0), vals.max(axis=0))
        free = np.ones(n, dtype=bool)
        free[b] = False
        out["igl_fixed"] = int(b.size)
        out["igl_vs_manifill"] = _maxdiff(np.asarray(Z)[free], X[free])
        out["bc_vs_vals"] = _maxdiff(X[idx], vals)  # manifill keeps the samples exactly
        del Z
    out["seconds"], out["peak_mb"] = st.seconds, st.rss
    out["scale"] = float(np.abs(vals).max())
    return out


def run_child(cfg):
    """The configuration in a fresh child; its stage lines and any profile go to this process's stderr."""
    p = subprocess.run([sys.executable, "-m", "bench.many_fields", "--child", json.dumps(cfg)], cwd=ROOT,
                       stdout=subprocess.PIPE, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"{cfg} failed (exit {p.returncode}):\n{p.stdout[-2000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def _ratio(a, b):
    return f"{a / b:.2f}" if a and b else "-"


def tables(rows):
    """Markdown: times, ratios and checks, one row per configuration."""
    s = [r["seconds"] for r in rows]
    lines = ["| k | method | solver | fixed | reconstruct s | build s | apply all s | chunks s (fields) | "
             "one field ms | ... without Step 1 | all ms/field | chunks ms/field | igl 1 col s | igl p cols s | "
             "igl ms/col | peak MB |", "|---" * 16 + "|"]
    for r, t in zip(rows, s):
        p, c = r["fields"], r.get("chunked_fields", r["fields"])
        lines.append(f"| {r['k']:,} | {r['method']} | {r['solver']} | {r['fixed']:,} | {t['reconstruct']:.2f} | "
                     f"{t['build']:.2f} | {t['all']:.2f} | {t['chunks']:.2f} ({c}) | {1e3 * t['one']:.1f} | "
                     f"{1e3 * t.get('one without step 1', t['one']):.1f} | {1e3 * t['all'] / p:.1f} | "
                     f"{1e3 * t['chunks'] / c:.1f} | "
                     + (f"{t['igl one']:.2f} | {t['igl']:.2f} | {1e3 * t['igl'] / p:.1f}" if "igl" in t
                        else "- | - | -")
                     + f" | {max(r['peak_mb'].values()):,.0f} |")
    lines += ["", "Ratios within each child (targets: manifill <= 2 x igl.harmonic with all columns; one field's "
              "apply <= 20 ms). Chunks: their time per field times the fields:", "",
              "| k | method | reconstruct / igl | (build + apply all) / igl | apply all / igl | chunks / igl | "
              "reconstruct / (build + apply all) | one field <= 20 ms |", "|---" * 8 + "|"]
    for r, t in zip(rows, s):
        ig = t.get("igl")
        chunks = t["chunks"] * r["fields"] / r.get("chunked_fields", r["fields"])
        one, bare = t["one"], t.get("one without step 1", t["one"])
        lines.append(f"| {r['k']:,} | {r['method']} | {_ratio(t['reconstruct'], ig)} | "
                     f"{_ratio(t['build'] + t['all'], ig)} | {_ratio(t['all'], ig)} | {_ratio(chunks, ig)} | "
                     f"{_ratio(t['reconstruct'], t['build'] + t['all'])} | "
                     f"{'pass' if one <= 0.020 else '**fail**'} ({1e3 * one:.0f} ms; without Step 1 "
                     f"{1e3 * bare:.0f} ms) |")
    lines += ["", "Checks (max abs difference; field scale ~ 1) and peak memory by stage (running ru_maxrss, MB):",
              "", "| k | method | apply all vs reconstruct | chunks vs reconstruct | one vs reconstruct | "
              "manifill vs igl off the fixed set | mesh | reconstruct | build | all | chunks | one | igl |",
              "|---" * 13 + "|"]
    for r in rows:
        d, m = r["apply_vs_reconstruct"], r["peak_mb"]
        iv = r.get("igl_vs_manifill")
        lines.append(f"| {r['k']:,} | {r['method']} | {d['all']:.1e} | {d['chunks']:.1e} | {d['one']:.1e} | "
                     + ("-" if iv is None else f"{iv:.1e}") + " | "
                     + " | ".join(f"{m[x]:,.0f}" if x in m else "-"
                                  for x in ("mesh", "reconstruct", "build", "all", "chunks", "one", "igl")) + " |")
    lines += ["", "Steps (s) of `reconstruct` / of the build / of `apply` on all fields:", "",
              "| k | method | reconstruct steps | build steps | apply-all steps |", "|---" * 5 + "|"]
    for r in rows:
        def fmt(d):
            return ", ".join(f"{k} {v:.2f}" for k, v in d.items() if v >= 0.005)

        lines.append(f"| {r['k']:,} | {r['method']} | {fmt(r['reconstruct_steps'])} | {fmt(r['build_steps'])} | "
                     f"{fmt(r['apply_all_steps'])} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--smoke", action="store_true", help="a tiny mesh and few fields (seconds; for the tests)")
    ap.add_argument("--level", type=int, default=7, help="icosphere subdivisions (7: 163,842 vertices)")
    ap.add_argument("--ks", default="100,1000", help="sample counts, comma-separated")
    ap.add_argument("--fields", type=int, default=1000)
    ap.add_argument("--chunk", type=int, default=100, help="columns per apply in the chunked run")
    ap.add_argument("--chunks-max", type=int, help="time only the first N chunks (default: all)")
    ap.add_argument("--methods", default=",".join(METHODS), help="in this order (one child per method and k)")
    ap.add_argument("--out", help=f"JSON file (default {OUT.relative_to(ROOT)}; smoke: a temporary file)")
    ap.add_argument("--profile", choices=("reconstruct", "build", "all", "chunks", "one"),
                    help="print the cProfile of one stage of every child")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child is not None:
        print(json.dumps(child(json.loads(args.child))))
        return
    if args.smoke:
        args.level, args.ks, args.fields, args.chunk = 3, "12", 24, 8
    out = Path(args.out) if args.out else (Path(tempfile.gettempdir()) / "many_fields_smoke.json" if args.smoke
                                           else OUT)
    started = time.time()
    rows = []
    for method in args.methods.split(","):
        for k in (int(x) for x in args.ks.split(",")):
            cfg = {"level": args.level, "k": k, "fields": args.fields, "chunk": args.chunk, "method": method,
                   "profile": args.profile, "chunks_max": args.chunks_max or args.fields}
            print(f"k={k} {method}: a child on {args.fields} fields ...", file=sys.stderr, flush=True)
            rows.append(run_child(cfg))
            t = rows[-1]["seconds"]
            print(f"k={k} {method}: reconstruct {t['reconstruct']:.2f} s, build {t['build']:.2f} s, apply all "
                  f"{t['all']:.2f} s, one {1e3 * t['one']:.1f} ms, igl {t.get('igl', float('nan')):.2f} s",
                  flush=True)
            save(out, rows, argv, started)  # after every child: a partial run keeps what it measured
    print()
    print(tables(rows))


def save(out, rows, argv, started):
    """The JSON of the rows so far: command, machine, versions, rows and their markdown."""
    versions = {"python": platform.python_version()}
    for name in ("numpy", "scipy", "libigl", "manifill", "pypardiso"):
        try:
            versions[name] = md.version(name)
        except md.PackageNotFoundError:
            versions[name] = "not installed"
    out.parent.mkdir(parents=True, exist_ok=True)
    cmd = "python -m bench.many_fields " + " ".join(sys.argv[1:] if argv is None else argv)
    out.write_text(json.dumps({"command": cmd, "machine": platform.platform(), "versions": versions,
                               "elapsed": time.time() - started, "rows": rows, "markdown": tables(rows)},
                              indent=1) + "\n")


if __name__ == "__main__":
    main()
