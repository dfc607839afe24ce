"""Step 0 of issue 37: one code path per energy leaves the accuracy benchmark unchanged to 4 digits.

``python -m bench.energy_parity --old /path/to/old/src [--new src] [--smoke]``

Runs the accuracy benchmark's cases (:mod:`bench.fields`, every k and seed) for the energy methods and the
paper's pipeline with two versions of manifill, each in a child process with its own ``src`` first on the path
(e.g. ``git worktree add /tmp/before <commit>``), and prints every (case, k, method) cell whose relative RMSE
differs in the 4th significant digit, and the largest relative difference over all cells.
"""

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

#: The configurations compared (explicit options: the default itself changed after step 0).
CONFIGS = {
    "harmonic": {"method": "harmonic"},
    "biharmonic": {"method": "biharmonic"},
    "triharmonic": {"method": "triharmonic"},
    "gvf-harmonic": {"method": "gvf-harmonic"},
    "pipeline, monotone, bounded": {"method": "gvf-harmonic", "curve_values": "monotone", "bounds": "samples"},
}

CHILD = """
import json, sys
import numpy as np
from manifill import reconstruct
from bench import fields
from bench.accuracy import case_ks, metrics, KS_FULL, KS_SMOKE, SEEDS_FULL, SEEDS_SMOKE
configs, smoke = json.loads(sys.argv[1]), sys.argv[2] == "1"
cases, _ = fields.cases(smoke, log=lambda m: None)
out = {}
for case in cases:
    for k in case_ks(case, KS_SMOKE if smoke else KS_FULL):
        seeds = [0] if case.layouts is not None else (SEEDS_SMOKE if smoke else SEEDS_FULL)
        for seed in seeds:
            idx = fields.draw_samples(case, k, seed)
            vals = fields.sample_values(case, idx, seed)
            for name, opts in configs.items():
                try:
                    x = reconstruct(case.V, case.F, idx, vals, **opts).values
                    out[f"{case.key}|{k}|{seed}|{name}"] = metrics(x, case.truth, idx, vals)["rmse"]
                except Exception as e:
                    out[f"{case.key}|{k}|{seed}|{name}"] = str(e)
print(json.dumps(out))
"""


def run(src, smoke):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(Path(src).resolve()), str(Path.cwd())]))
    p = subprocess.run([sys.executable, "-c", CHILD, json.dumps(CONFIGS), "1" if smoke else "0"], env=env,
                       capture_output=True, text=True)
    if p.returncode:
        raise RuntimeError(p.stderr[-3000:])
    return json.loads(p.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", required=True)
    ap.add_argument("--new", default="src")
    ap.add_argument("--smoke", action="store_true")
    args = ap.parse_args(argv)
    old, new = run(args.old, args.smoke), run(args.new, args.smoke)
    worst, changed = 0.0, []
    for key in sorted(old):
        a, b = old[key], new.get(key)
        if isinstance(a, str) or isinstance(b, str):
            if a != b:
                changed.append(f"| {key} | {a} | {b} |")
            continue
        rel = abs(a - b) / max(abs(a), 1e-300)
        worst = max(worst, rel)
        if f"{a:.4g}" != f"{b:.4g}":
            changed.append(f"| {key} | {a:.6g} | {b:.6g} |")
    print(f"{len(old)} cells; largest relative difference {worst:.2e}; {len(changed)} differ in 4 digits")
    if changed:
        print("| case, k, seed, method | old | new |\n|---|---|---|\n" + "\n".join(changed))


if __name__ == "__main__":
    main()
