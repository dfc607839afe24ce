"""Issue 25's time targets: the bounded biharmonic beside the default, at 41k, 163k and 655k vertices.

``python -m bench.default_targets [--levels 6,7,8] [--ks 100,1000] [--fields smooth,earth] [--repeat 1]``

For every icosphere level, sample count and field (``smooth``: ``sin(2x) + yz + 0.5 cos(3y)``;
``earth``: the day map's luminance, as the accuracy benchmark's ``globe-image``), the same samples
(``default_rng(0)``) go to the default ``reconstruct()`` (the pipeline, monotone curves,
``bounds="samples"``), ``method="biharmonic"`` and ``method="biharmonic", bounds="samples"``, one
after the other in this process (a warm-up call first, so no one pays for loading Pardiso). The row
gives the median seconds of each over ``--repeat`` runs, the bounded/default ratio (target <= 3), the
bounded/unbounded ratio, and the active set's faces, factorisations, Schur columns and size.
"""

import argparse
import platform
import statistics
import time

import numpy as np


def _fields(V, which, level):
    from .fields import smooth_field
    from .fields_more import globe_case

    out = {}
    for name in which:
        out[name] = smooth_field(V / np.abs(V).max()) if name == "smooth" else globe_case(level).truth
    return out


def _timed(call, repeat):
    times, result = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        result = call()
        times.append(time.perf_counter() - t)
    return statistics.median(times), result


def main(argv=None):
    from manifill import reconstruct
    from manifill.mesh.shapes import icosphere

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", default="6,7,8")
    parser.add_argument("--ks", default="100,1000")
    parser.add_argument("--fields", default="smooth,earth")
    parser.add_argument("--repeat", type=int, default=1)
    args = parser.parse_args(argv)
    V, F = icosphere(2)
    reconstruct(V, F, np.arange(0, 162, 9), V[::9, 0], method="biharmonic", bounds="samples", solver="direct")
    print(f"# bounded biharmonic against the default ({platform.machine()}, {time.strftime('%Y-%m-%d %H:%M')})")
    print("| vertices | samples | field | default s | biharmonic s | bounded s | bounded/default | "
          "bounded/unbounded | faces | factorisations | columns | at a bound |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for level in (int(v) for v in args.levels.split(",")):
        V, F = icosphere(level)
        fields = _fields(V, args.fields.split(","), level)
        for k in (int(v) for v in args.ks.split(",")):
            idx = np.sort(np.random.default_rng(0).choice(len(V), k, replace=False))
            for name, f in fields.items():
                vals = f[idx]
                t_def, _ = _timed(lambda: reconstruct(V, F, idx, vals), args.repeat)
                t_un, _ = _timed(lambda: reconstruct(V, F, idx, vals, method="biharmonic"), args.repeat)
                t_b, r = _timed(lambda: reconstruct(V, F, idx, vals, method="biharmonic", bounds="samples"),
                                args.repeat)
                b = r.report["harmonic"]["bounds"]
                print(f"| {len(V):,} | {k:,} | {name} | {t_def:.2f} | {t_un:.2f} | {t_b:.2f} | {t_b / t_def:.1f} | "
                      f"{t_b / t_un:.2f} | {b['iterations'][0]} | {b['setups'][0]} | {b['columns'][0]} | "
                      f"{b['active_lo'][0] + b['active_hi'][0]} |", flush=True)


if __name__ == "__main__":
    main()
