"""Benchmark: the bounded biharmonic (``bounds="samples"``) beside the unbounded one and the default.

For every problem, one run of each, from the mesh: ``reconstruct(V, F, idx, vals,
method="biharmonic")``, the same with ``bounds="samples"`` (the active-set solve of
:mod:`manifill.linalg.active_set`), and the default ``reconstruct()``. Prints one row per
problem: seconds of each, the bounded/unbounded and bounded/default ratios, the
active-set iterations (face solves), the backend set-ups among them, the indices at a
bound and the KKT residual. Problems: the accuracy benchmark's cases with its own samples
(``bench.fields``: sphere-smooth, sphere-step, u-strip at full size, ``--k`` samples,
``--seeds``), and an icosphere of level 8 (655,362 vertices, 100 samples, the field
``sin(2x) + yz + 0.5 cos(3y)`` with coordinates scaled into [-1, 1]). Run from the
repository root::

    python -m bench.bounded_speed [--k 10,100] [--seeds 0] [--cases sphere-smooth,sphere-step,u-strip]
    python -m bench.bounded_speed --big-only       # just the 655k icosphere
    python -m bench.bounded_speed --quick          # small meshes (a smoke run)
"""

import argparse
import platform
import time

import numpy as np


def _run(V, F, idx, vals):
    from manifill import reconstruct

    row = {}
    for name, kw in (("unbounded", {"method": "biharmonic"}),
                     ("bounded", {"method": "biharmonic", "bounds": "samples"}), ("default", {})):
        t = time.perf_counter()
        try:
            r = reconstruct(V, F, idx, vals, **kw)
        except ValueError as e:  # manifill's errors: one line in the table
            row[name] = (time.perf_counter() - t, None)
            row[name + "_error"] = " ".join(str(e).split())[:90]
            continue
        row[name] = (time.perf_counter() - t, r)
    return row


def _problems(args):
    from bench.fields import draw_samples, sphere_cases, u_case
    from manifill.mesh.shapes import icosphere

    keys = args.cases.split(",")
    if not args.big_only:
        built = [*sphere_cases(3 if args.quick else 6), u_case(0.1 if args.quick else 0.02)]
        for case in built:
            if case.key not in keys:
                continue
            for k in (int(v) for v in args.k.split(",")):
                for seed in (int(v) for v in args.seeds.split(",")):
                    idx = draw_samples(case, k, seed)
                    yield f"{case.key} ({case.n:,}), k={k}, seed {seed}", case.V, case.F, idx, case.truth[idx]
    if not args.no_big:
        V, F = icosphere(4 if args.quick else 8)
        V = V / np.abs(V).max()
        f = np.sin(2 * V[:, 0]) + V[:, 1] * V[:, 2] + 0.5 * np.cos(3 * V[:, 1])
        idx = np.sort(np.random.default_rng(0).choice(len(V), 100, replace=False))
        yield f"icosphere ({len(V):,}), smooth, k=100", V, F, idx, f[idx]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--k", default="10,100", help="samples per case, comma-separated")
    parser.add_argument("--seeds", default="0", help="sample seeds, comma-separated")
    parser.add_argument("--cases", default="sphere-smooth,sphere-step,u-strip", help="accuracy cases")
    parser.add_argument("--big-only", action="store_true", help="only the 655k icosphere")
    parser.add_argument("--no-big", action="store_true", help="skip the 655k icosphere")
    parser.add_argument("--quick", action="store_true", help="small meshes (smoke run)")
    args = parser.parse_args(argv)
    print(f"# bounded biharmonic speed ({platform.processor() or platform.machine()}, "
          f"{time.strftime('%Y-%m-%d %H:%M')})")
    print("| problem | unbounded s | bounded s | default s | bounded/unbounded | bounded/default | backend | "
          "iterations | set-ups | at a bound | KKT residual |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for title, V, F, idx, vals in _problems(args):
        row = _run(V, F, idx, vals)
        (tu, _), (tb, rb), (td, _) = row["unbounded"], row["bounded"], row["default"]
        if rb is None:
            print(f"| {title} | {tu:.1f} | failed: {row['bounded_error']} | {td:.1f} | | | | | | | |", flush=True)
            continue
        h = rb.report["fill"]
        b = h["bounds"]
        print(f"| {title} | {tu:.1f} | {tb:.1f} | {td:.1f} | {tb / tu:.1f}x | {tb / td:.1f}x | {h['solver']} | "
              f"{sum(b['iterations'])} | {sum(b.get('setups', [0]))} | "
              f"{sum(b['active_lo']) + sum(b['active_hi']):,} | {b['kkt_residual']:.1e} |", flush=True)


if __name__ == "__main__":
    main()
