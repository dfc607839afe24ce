"""``manifill harmonic MESH SAMPLES -o OUT``: the harmonic fill from the samples alone."""

import time

from ..io import VALUE_FORMATS, write_values
from ..results import SAMPLE_MASK, sample_mask
from ..surface.harmonic import HarmonicSolver
from .common import check_names, load, pictures, print_ranges, surface_outputs, write_surface
from .options import fill_args, output_args, picture_args, sample_args

__all__ = ["add_parser", "run"]


def add_parser(sub):
    """Register ``manifill harmonic``."""
    s = sub.add_parser("harmonic", help="fill a field harmonically from samples",
                       description="Fix the sample values at their vertices and fill every other vertex "
                                   "with the weighted average of its neighbours (discrete harmonic).")
    sample_args(s)
    fill_args(s)
    picture_args(s)
    output_args(s)
    s.set_defaults(func=run)


def run(args):
    """``manifill harmonic MESH SAMPLES -o OUT``."""
    out = surface_outputs(args)
    ext = out.suffix.lower()
    V, F, S = load(args)
    check_names(args, S, out)
    t0 = time.perf_counter()
    solver = HarmonicSolver(V, F, S.idx, weights=args.weights, solver=args.solver, on_empty=args.on_empty)
    X = solver.solve(S.vals)
    seconds = time.perf_counter() - t0
    if ext in VALUE_FORMATS:
        write_values(out, X, names=S.names)
    else:
        fields = {name: X[:, j] for j, name in enumerate(S.names)}
        write_surface(out, V, F, {**fields, SAMPLE_MASK: sample_mask(len(V), S.idx)})
    rep = solver.report
    print(f"{len(V):,} vertices, {S.idx.size:,} samples ({len(S.names)} field(s): {', '.join(S.names)})"
          + (f", {S.merged} merged" if S.merged else ""))
    if S.snap_distance is not None:
        print(f"snapped positions to vertices: largest distance {S.snap_distance.max():.3g}")
    its = rep.get("iterations")
    print(f"harmonic fill: weights={rep['weights']}, solver={rep['solver']}"
          + (f", {', '.join(map(str, its))} iterations" if its else "") + f", {seconds:.2f} s")
    if rep["negative_weights"]:
        print(f"note: {rep['negative_weights']:,} edges have negative cotangent weights (obtuse triangles), "
              f"so values may overshoot the samples; --weights intrinsic avoids that")
    if rep["empty_components"]:
        print(f"note: {len(rep['empty_components'])} component(s) without samples left NaN")
    print_ranges(X, S, out)
    pictures(args, V, F, X, S.names, samples=S.idx, title=f"harmonic: {S.names[0]}")
    return 0
