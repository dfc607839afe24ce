"""``method='auto'`` on fields of different character on one mesh: each field against its own best method.

``python -m bench.auto_fields [--level 6] [--k 300] [--seeds 0,1]``

On one icosphere (41k vertices at level 6) and one set of ``k`` random samples, two fields at once: a smooth
field (the accuracy benchmark's ``sphere-smooth``) and the Earth's luminance (``globe-image``). ``auto`` runs
once on both (each field its own choice by the one-standard-error rule); the default and every single
candidate of ``auto`` run on each field alone. The row gives each field's relative RMSE off the samples for
``auto``, the default and each candidate, ``auto``'s choice, and ``auto``'s error over the better of the
default and the best single method for that field (issue 37's target: at most 1.05).
"""

import argparse
import time

import numpy as np


def main(argv=None):
    from manifill import reconstruct
    from manifill.mesh.shapes import icosphere
    from manifill.surface.methods.auto import AUTO_CANDIDATES

    from .fields import smooth_field
    from .fields_more import globe_case

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--level", type=int, default=6)
    ap.add_argument("--k", type=int, default=300)
    ap.add_argument("--seeds", default="0,1")
    args = ap.parse_args(argv)
    V, F = icosphere(args.level)
    truths = {"smooth": smooth_field(V / np.abs(V).max()), "earth": globe_case(args.level).truth}
    print(f"# auto on two fields at once ({len(V):,} vertices, {args.k} samples, {time.strftime('%Y-%m-%d %H:%M')})")
    labels = [" ".join([n] + [f"{a}={b}" for a, b in o.items()]) for n, o in AUTO_CANDIDATES]
    print("| seed | field | auto | auto's choice | " + " | ".join(labels) + " | auto / best of default and single |")
    print("|---|---|---|---|" + "---|" * len(labels) + "---|", flush=True)
    for seed in (int(s) for s in args.seeds.split(",")):
        idx = np.sort(np.random.default_rng(seed).choice(len(V), args.k, replace=False))
        free = np.ones(len(V), dtype=bool)
        free[idx] = False
        Y = np.column_stack([t[idx] for t in truths.values()])
        r = reconstruct(V, F, idx, Y, method="auto", seed=seed)
        for j, (name, t) in enumerate(truths.items()):
            def err(x, t=t, free=free):
                return float(np.sqrt(np.mean((x[free] - t[free]) ** 2)) / np.ptp(t))
            single = [err(reconstruct(V, F, idx, Y[:, j], method=n, **o).values) for n, o in AUTO_CANDIDATES]
            a = err(r.values[:, j])
            ref = min(single)  # the default is the first candidate
            print(f"| {seed} | {name} | {a:.4f} | {r.report['auto']['fields'][j]} | "
                  + " | ".join(f"{e:.4f}" for e in single) + f" | {a / ref:.3f} |", flush=True)


if __name__ == "__main__":
    main()
