"""``manifill reconstruct MESH SAMPLES -o OUT``: the paper's pipeline (Steps 1-6); a time series with
``-o OUT.xdmf|.pvd|.h5`` (:mod:`manifill.cli.series`)."""

from pathlib import Path

from ..errors import OptionError

from ..surface.energy_fill import ENERGY_METHODS
from ..surface.reconstruct import STEPS
from .common import (bounds_arg, check_names, levels, smoothing_arg, load, pictures, print_ranges, print_time, step_bar,
                     print_uncertainty, std_names, surface_outputs, uncertainty_opts, wants_std, write_surface)
from .options import (energy_args, fill_args, output_args, picture_args, pipeline_args, sample_args, series_args,
                      uncertainty_args)

__all__ = ["add_parser", "run"]


def add_parser(sub):
    """Register ``manifill reconstruct``."""
    s = sub.add_parser("reconstruct", help="the paper's reconstruction: partition, curve values, harmonic patches",
                       description="Reconstruct a field from samples: check the gradual variation condition, "
                                   "cut the surface by curves through every sample, give the curves values and "
                                   "fill every patch harmonically. Writes the field, the curve mask and the "
                                   "patch labels.")
    sample_args(s)
    fill_args(s)
    pipeline_args(s)
    energy_args(s)
    uncertainty_args(s)
    series_args(s)
    s.add_argument("--subdivide", type=int, default=0, metavar="K",
                   help="Loop-subdivide the result K times before writing it (a smoother surface)")
    picture_args(s)
    output_args(s)
    s.set_defaults(func=run)


def run(args):
    """``manifill reconstruct MESH SAMPLES -o OUT``."""
    from ..io import VALUE_FORMATS, write_values
    from ..surface.reconstruct import reconstruct

    from .series import SERIES_OUTPUTS, is_series, run_series

    out = surface_outputs(args, extra=SERIES_OUTPUTS)
    std_opts = uncertainty_opts(args)
    # the energy methods and gp constrain positions exactly where they are, the others use the nearest vertices
    exact = args.method in ENERGY_METHODS or args.method == "gp"
    if is_series(args.samples, out, args.chunk):
        if out.suffix.lower() not in SERIES_OUTPUTS + (".npy",):
            raise OptionError(f"{Path(args.samples).name} holds a time series; write it as .xdmf, .pvd, .h5 or .npy "
                              f"(-o OUT.xdmf)")
        options = dict(method=args.method, partition=args.partition, weights=args.weights, distance=args.distance,
                       levels=levels(args.levels), curve_values=args.curve_values, solver=args.solver,
                       on_empty=args.on_empty, duplicates=args.duplicates, bounds=bounds_arg(args.bounds),
                       smoothing=smoothing_arg(args.smoothing), **std_opts)
        return run_series(args, out, options, exact)
    for flag in ("workers", "scheduler"):
        if getattr(args, flag, None) is not None:
            raise OptionError(f"--{flag} runs the chunks of a time series (-o OUT.xdmf, .pvd, .h5 or .npy) on Dask "
                              f"workers; {out.name} is one result: leave --{flag} out, or batch many meshes with "
                              f"'manifill batch'")
    V, F, S = load(args, keep_points=exact)
    check_names(args, S, out)
    if args.subdivide:
        from ..mesh.subdivide import check_subdivide

        check_subdivide(len(V), len(F), args.subdivide, len(S.names))
    steps = STEPS[args.method or "gvf-harmonic"] + (("uncertainty",) if wants_std(args) and args.method != "gp"
                                                     else ())
    bar = step_bar(args, ("graph",) + steps)
    try:
        where = dict(idx=S.idx, vals=S.vals) if S.points is None else dict(idx=S.points, vals=S.point_vals,
                                                                             max_distance=args.max_snap)
        r = reconstruct(V, F, **where, method=args.method, partition=args.partition, weights=args.weights,
                        distance=args.distance, levels=levels(args.levels), curve_values=args.curve_values,
                        solver=args.solver, on_empty=args.on_empty, duplicates=args.duplicates,
                        bounds=bounds_arg(args.bounds), smoothing=smoothing_arg(args.smoothing), progress=bar,
                        check=True if args.check else None, **std_opts)
    finally:
        bar.close()
    X = r.fields()
    data = r.point_data(S.names)
    added = {key: data[key] for key in std_names(args, S.names) if key in data}
    if args.subdivide:
        from ..mesh.subdivide import subdivide

        V2, F2, X2 = subdivide(V, F, X, levels=args.subdivide)
        if out.suffix.lower() in VALUE_FORMATS:
            write_values(out, X2, S.names)
        else:
            write_surface(out, V2, F2, {name: X2[:, j] for j, name in enumerate(S.names)})
        print(f"subdivided {args.subdivide} time(s): {len(V2):,} vertices, {len(F2):,} faces (fields carried along; "
              f"the masks{' and the std' if added else ''} are not written)")
    elif out.suffix.lower() == ".csv" and added:  # the std and trusted columns after the values
        from ..report import value_columns

        columns = list(S.names) + list(added)
        write_values(out, value_columns(data, columns), columns)
    elif out.suffix.lower() in VALUE_FORMATS:
        write_values(out, X, S.names)
        if added:
            print(f"note: {out.name} holds the values alone; {', '.join(added)} are not written (write .csv or "
                  f".vtu for them)")
    else:
        write_surface(out, V, F, data)
    rep = r.report
    print(f"{len(V):,} vertices, {S.idx.size:,} samples ({len(S.names)} field(s): {', '.join(S.names)})")
    if "points" in rep and rep["points"]["located"] != "nearest vertex":
        pt = rep["points"]
        print(f"located {pt['points']:,} positions on the surface: {pt['inside_faces']:,} inside faces, "
              f"{pt['at_vertices']:,} at vertices; largest distance {pt['max_distance']:.3g}")
    elif S.snap_distance is not None:
        print(f"snapped positions to vertices: largest distance {S.snap_distance.max():.3g}")
    for name, c in zip(S.names, rep["check"]):
        state = "holds" if c["holds"] else f"fails for {c['violations']} samples"
        print(f"step 1 ({name}): {c['levels']} levels, Lipschitz {c['lipschitz_hops']:.4g} per hop; "
              f"gradual variation {state}")
    if rep.get("default"):
        print(f"method: the default (gvf-harmonic, {rep.get('curve_values')} curve values, bounded by the samples' "
              f"range; --method gvf-harmonic for the paper's pipeline alone)")
    if "partition" in rep:
        pr = rep["partition"]
        print(f"steps 2-3: {pr['method']} partition, {pr['curves']} curves through {pr['curve_vertices']:,} "
              f"vertices, {pr['patches']} patches (largest {max(pr['patch_sizes'] or [0]):,})")
    if "harmonic" in rep:
        h = rep["harmonic"]
        its = h.get("iterations")
        m = rep["method"]
        what = "steps 5-6: harmonic fill" if m == "gvf-harmonic" else f"{m} fill (samples fixed)"
        extra = ""
        if "bounds" in h:
            at = sum(h["bounds"]["active_lo"]) + sum(h["bounds"]["active_hi"])
            extra += f", bounded ({at:,} vertices at a bound)"
        if "smoothing" in h:
            lams = h["smoothing"]["lambda"]
            lam = ", ".join(f"{float(x):.3g}" for x in (lams if hasattr(lams, "__len__") else [lams]))
            extra += f", smoothing lambda {lam}"
        print(f"{what}, weights={h.get('weights', args.weights)}, solver={h.get('solver', 'direct')}"
              + (f", {', '.join(map(str, its))} iterations" if its else "") + extra)
    if "rbf" in rep:
        print(f"rbf: thin-plate spline through the sample positions ({rep['rbf']['dims']}-D)")
    if "auto" in rep:  # method='auto': the cross-validation table and the choice
        print(rep["auto"]["table"])
        print(f"auto: chose {rep['auto']['chosen']} (lowest {rep['auto']['what']} error)")
    print_uncertainty(rep, r.std, r.trusted)
    print_time(args, rep["seconds"])
    print_ranges(X, S, out)
    pictures(args, V, F, X, S.names, samples=S.idx, curves=r.curves, title=f"{args.method or 'default'}", extra=added)
    return 0
