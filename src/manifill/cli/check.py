"""``manifill check MESH SAMPLES``: the gradual variation condition (Step 1)."""

import time

from ..mesh.graph import mesh_graph
from ..surface.gradual import check_gradual
from ..validate import as_mesh
from .common import levels, load
from .options import choices_of, sample_args

__all__ = ["add_parser", "run"]


def add_parser(sub):
    """Register ``manifill check``."""
    s = sub.add_parser("check", help="check the gradual variation condition of samples (Step 1)",
                       description="Choose value levels, report the Lipschitz constant and any sample pairs "
                                   "that break the gradual variation condition d(p, q) >= |i_p - i_q|. Exit "
                                   "status 0 when it holds, 1 when it does not, 2 on bad input.")
    sample_args(s)
    s.add_argument("--levels", default=None,
                   help="a count of uniform levels, or comma-separated levels (write --levels=-1,0,1 when "
                        "the first is negative; default: the finest step that works)")
    s.add_argument("--distance", choices=choices_of("distance"), default="hops", help="graph distance (default: hops)")
    s.set_defaults(func=run)


def run(args):
    """``manifill check MESH SAMPLES``: exit 0 if the condition holds, 1 if not."""
    V, F, S = load(args)
    V, F = as_mesh(V, F, allow_degenerate=True)
    G = mesh_graph(V, F, distance=args.distance)
    t0 = time.perf_counter()
    checks = [check_gradual(G, S.idx, S.vals[:, j], levels=levels(args.levels), distance=args.distance)
              for j in range(S.vals.shape[1])]
    seconds = time.perf_counter() - t0
    unit = "hop" if args.distance == "hops" else "mean edge length"
    print(f"{len(V):,} vertices, {S.idx.size:,} samples; distance: {args.distance}; checked in {seconds:.2f} s")
    for name, c in zip(S.names, checks):
        step = f", step {c.step:.6g}" if c.step is not None else ""
        print(f"{name}: {c.levels.size} levels from {c.levels[0]:.6g} to {c.levels[-1]:.6g}{step}; "
              f"largest move onto a level {c.level_error:.3g}")
        p, q = c.lipschitz_pair
        print(f"  Lipschitz constant {c.lipschitz:.6g} per {unit}" + (f" (vertices {p} and {q})" if p >= 0 else ""))
        if c.holds:
            print("  gradual variation condition: holds")
        else:
            print(f"  gradual variation condition: FAILS for {len(c.violations)} samples "
                  f"(vertex p, worst partner q, distance, levels apart):")
            worst = c.worst()
            for p, q, d, k in worst[:10]:
                print(f"    {int(p):>8} {int(q):>8} {d:>10.4g} {int(k):>6}")
            if len(worst) > 10:
                print(f"    ... and {len(worst) - 10} more")
    return 0 if all(c.holds for c in checks) else 1
