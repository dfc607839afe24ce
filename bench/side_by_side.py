"""Two versions of manifill side by side: the same calls timed in alternating child processes.

``python -m bench.side_by_side --old /path/to/old/src [--new src] [--repeat 3] [--save FILE]``

A refactor must not cost time. Each case runs in a fresh process of each version in turn
(old, new, old, new, ...), so that the machine's noise falls on both alike; the table gives
the median seconds of each and their ratio (new / old). ``--old`` is the ``src`` folder of
another checkout (e.g. ``git worktree add /tmp/before HEAD~1``). The mesh is built and the
samples drawn before the clock starts; the clock covers the one call named in the case.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

#: ``name -> (icosphere level, samples, fields, call)``; the call sees V, F, idx, vals and manifill as ``mf``.
CASES = {
    "default, 41k": (6, 100, 1, "mf.reconstruct(V, F, idx, vals)"),
    "default, 163k": (7, 100, 1, "mf.reconstruct(V, F, idx, vals)"),
    "default, 655k": (8, 100, 1, "mf.reconstruct(V, F, idx, vals)"),
    "default, 163k, 1,000 samples": (7, 1000, 1, "mf.reconstruct(V, F, idx, vals)"),
    "gvf-harmonic, 163k": (7, 100, 1, "mf.reconstruct(V, F, idx, vals, method='gvf-harmonic')"),
    "harmonic, 163k": (7, 100, 1, "mf.reconstruct(V, F, idx, vals, method='harmonic')"),
    "biharmonic, 41k": (6, 100, 1, "mf.reconstruct(V, F, idx, vals, method='biharmonic')"),
    "biharmonic bounded, 41k": (6, 100, 1, "mf.reconstruct(V, F, idx, vals, method='biharmonic', bounds='samples')"),
    "biharmonic bounded, 41k, 1,000 samples": (6, 1000, 1, "mf.reconstruct(V, F, idx, vals, method='biharmonic', "
                                                          "bounds='samples')"),
    "biharmonic bounded, 163k": (7, 100, 1, "mf.reconstruct(V, F, idx, vals, method='biharmonic', bounds='samples')"),
    "rbf, 41k": (6, 100, 1, "mf.reconstruct(V, F, idx, vals, method='rbf')"),
    "auto, 10k": (5, 100, 1, "mf.reconstruct(V, F, idx, vals, method='auto')"),
    "Reconstructor, 100 fields, 41k": (6, 100, 100, "mf.Reconstructor(V, F, idx).apply(vals)"),
}

CHILD = """
import json, sys, time
import numpy as np
import manifill as mf
from manifill.mesh.shapes import icosphere
level, k, p, call = json.loads(sys.argv[1])
V, F = icosphere(level)
idx = np.random.default_rng([level, k]).choice(len(V), k, replace=False)
x = V[idx]
vals = np.column_stack([np.sin(3 * x[:, 0] + j) + x[:, 2] for j in range(p)])
vals = vals[:, 0] if p == 1 else vals
t = time.perf_counter()
eval(call)
print(json.dumps(time.perf_counter() - t))
"""


def run_one(src, case):
    env = dict(os.environ, PYTHONPATH=str(src))
    out = subprocess.run([sys.executable, "-c", CHILD, json.dumps(case)], env=env, capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m bench.side_by_side", description=__doc__.splitlines()[0])
    ap.add_argument("--old", required=True, help="the src folder of the other version")
    ap.add_argument("--new", default=str(Path(__file__).resolve().parents[1] / "src"), help="default: this checkout")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--cases", default=None, help="case names separated by semicolons (default: all)")
    ap.add_argument("--save", default=None)
    args = ap.parse_args(argv)
    names = args.cases.split(";") if args.cases else list(CASES)
    rows = {}
    print("| case | old s | new s | new / old |\n|---|---|---|---|", flush=True)
    for name in names:
        times = {"old": [], "new": []}
        for _ in range(args.repeat):
            for which in ("old", "new"):
                times[which].append(run_one(getattr(args, which), CASES[name]))
        old, new = statistics.median(times["old"]), statistics.median(times["new"])
        rows[name] = {"old": times["old"], "new": times["new"], "ratio": new / old}
        print(f"| {name} | {old:.3f} | {new:.3f} | {new / old:.2f} |", flush=True)
    if args.save:
        Path(args.save).write_text(json.dumps(rows, indent=1), encoding="utf-8")


if __name__ == "__main__":
    main()
