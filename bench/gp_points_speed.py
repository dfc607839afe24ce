"""``method='gp'`` with electrodes given as positions (inside faces): the time of the mean and exact std.

``python -m bench.gp_points_speed [--level 4] [--k 64] [--label NAME]``: one line, ``label seconds max-std``.
Run it from two trees side by side (``PYTHONPATH=<tree>/src``), a fresh process each, to compare commits.
"""

import argparse
import time

import numpy as np

import manifill
from manifill.mesh.shapes import icosphere


def run(level=4, k=64, seed=0):
    """``(seconds, max std)`` of the gp on a head-sized ellipsoid with ``k`` positions 0.1 mm off its vertices."""
    V, F = icosphere(level)
    V = V * np.array([0.09, 0.11, 0.10])  # metres: a head
    rng = np.random.default_rng(seed)
    P = V[rng.choice(len(V), k, replace=False)] + 1e-4 * rng.normal(size=(k, 3))
    vals = np.sin(20 * P[:, 0]) + 10 * P[:, 2]
    t = time.perf_counter()
    r = manifill.reconstruct(V, F, P, vals, method="gp")
    return time.perf_counter() - t, float(r.std.max())


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--level", type=int, default=4)
    p.add_argument("--k", type=int, default=64)
    p.add_argument("--label", default="this tree")
    a = p.parse_args(argv)
    seconds, top = run(a.level, a.k)
    print(f"{a.label} {seconds:.2f} {top!r}")


if __name__ == "__main__":
    main()
