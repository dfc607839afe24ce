"""``manifill reconstruct MESH SAMPLES -o OUT``: the paper's pipeline (Steps 1-6); a time series with
``-o OUT.xdmf|.pvd|.h5`` (:mod:`manifill.cli.series`); a tangent vector field when the samples are arrows
(columns ``vx, vy, vz``: :mod:`manifill.cli.vectors`)."""

from pathlib import Path

from ..errors import OptionError
from ..io import write_values
from ..io.formats import find_format
from ..io.vector_files import holds_vectors
from ..mesh.subdivide import check_subdivide, subdivide
from ..report import value_columns
from ..surface.methods.registry import configure, method_of
from ..surface.reconstruct import reconstruct
from .common import (add_draws, barriers_arg, bounds_arg, check_draws, check_names, field_list, levels, smoothing_arg,
                     load, pictures, print_ranges, print_time, step_bar, print_uncertainty, std_names,
                     surface_outputs, uncertainty_opts, write_surface)
from .series import SERIES_OUTPUTS, is_series, run_series
from .vectors import refuse_vector_flags, run_vectors, vector_args
from .gradients import add_gradient
from .options import (cloud_args, energy_args, fill_args, gradient_args, output_args, picture_args, pipeline_args,
                      sample_args, series_args, uncertainty_args)

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
    cloud_args(s)
    energy_args(s)
    uncertainty_args(s)
    gradient_args(s)
    series_args(s)
    s.add_argument("--subdivide", type=int, default=0, metavar="K",
                   help="Loop-subdivide the result K times before writing it (a smoother surface)")
    vector_args(s)
    picture_args(s)
    output_args(s)
    s.set_defaults(func=run)


def options_of(args):
    """The reconstruction's options from the command line, built and checked once (an Options)."""
    return configure(method=args.method, partition=args.partition, weights=args.weights, distance=args.distance,
                     levels=levels(args.levels), curve_values=args.curve_values, solver=args.solver,
                     on_empty=args.on_empty, duplicates=args.duplicates, bounds=bounds_arg(args.bounds),
                     bounds_mode=getattr(args, "bounds_mode", None),
                     neighbours=getattr(args, "neighbours", None), barriers=barriers_arg(args),
                     smoothing=smoothing_arg(args.smoothing), check=True if getattr(args, "check", False) else None,
                     **uncertainty_opts(args))


def run(args):
    """``manifill reconstruct MESH SAMPLES -o OUT``."""
    out = surface_outputs(args, extra=SERIES_OUTPUTS)
    if holds_vectors(args.samples):  # arrows (vx, vy, vz): a tangent vector field (cli/vectors.py)
        return run_vectors(args, out)
    refuse_vector_flags(args)
    options = options_of(args)
    # the methods that take points constrain positions exactly where they are, the others use the nearest vertices
    # (auto hands the positions on: its choice uses them as the library's auto does)
    exact = method_of(options.method).at_points
    check_draws(args, options.method)
    if args.gradient and args.subdivide:
        raise OptionError("--gradient and --subdivide: the gradient is of the field on the mesh as given; leave one "
                          "out")
    if args.draws and args.subdivide:
        raise OptionError("--draws and --subdivide: the draws are on the mesh as given; leave one out")
    if is_series(args.samples, out, args.chunk):
        if args.gradient:
            raise OptionError(f"--gradient writes one result's gradient, and -o {out.name} writes a time series; "
                              f"leave --gradient out, or write one result (-o OUT.vtu, .vtp, .ply or .csv)")
        if find_format("series", out, writing=True) is None:
            raise OptionError(f"{Path(args.samples).name} holds a time series; write it as .xdmf, .pvd, .h5, .func.gii "
                              f"or .npy (-o OUT.xdmf)")
        return run_series(args, out, {"options": options.replace(check=None)}, exact)
    for flag in ("workers", "scheduler"):
        if getattr(args, flag, None) is not None:
            raise OptionError(f"--{flag} runs the chunks of a time series (-o OUT.xdmf, .pvd, .h5 or .npy) on Dask "
                              f"workers; {out.name} is one result: leave --{flag} out, or batch many meshes with "
                              f"'manifill batch'")
    V, F, S, options = load(args, keep_points=exact, points=True, options=options)
    check_names(args, S, out)
    if F is None and args.subdivide:
        raise OptionError("--subdivide refines triangles, and a point cloud has none; leave it out")
    if args.subdivide:
        check_subdivide(len(V), len(F), args.subdivide, len(S.names))
    method = method_of(options.method)
    steps = method.steps(options) + (("uncertainty",) if options.uq.uncertainty and not method.gp_mean else ())
    bar = step_bar(args, ("graph",) + steps)
    try:
        where = dict(idx=S.idx, vals=S.vals) if S.points is None else dict(idx=S.points, vals=S.point_vals,
                                                                             max_distance=args.max_distance)
        r = reconstruct(V, F, **where, options=options, progress=bar)
    finally:
        bar.close()
    X = r.fields()
    data = r.point_data(S.names)
    add_draws(args, r, S.names, data)
    added = {key: data[key] for key in std_names(args, S.names) if key in data}
    grads = add_gradient(args, r, S.names, data, out)
    if grads and not method.smooth_gradient and not method.delegates:
        kinks = "samples and curves" if method.partitions else "samples"
        print(f"note: {r.report.get('method', options.method)} gives a field with kinks at its {kinks}, so its "
              f"gradient jumps there; --method biharmonic, triharmonic or gp give smooth gradients")
    _write(args, out, V, F, X, S, data, {**added, **{key: data[key] for key in grads}})
    _summary(args, r, V, S)
    print_uncertainty(r.report, r.std, r.trusted)
    print_time(args, r.report["seconds"])
    print_ranges(X, S, out)
    norms = {key: data[key] for key in grads if key.endswith("_norm")}  # scalars a picture can show
    pictures(args, V, F, X, S.names, samples=S.idx, curves=r.curves, title=f"{args.method or 'default'}",
             extra={**added, **norms})
    return 0


def _write(args, out, V, F, X, S, data, added):
    """Write the result as the output's format asks (subdivided first with --subdivide)."""
    if args.subdivide:
        V2, F2, X2 = subdivide(V, F, X, levels=args.subdivide)
        if find_format("values", out, writing=True) is not None:
            write_values(out, X2, names=S.names)
        else:
            write_surface(out, V2, F2, {name: X2[:, j] for j, name in enumerate(S.names)})
        print(f"subdivided {args.subdivide} time(s): {len(V2):,} vertices, {len(F2):,} faces (fields carried along; "
              f"the masks{' and the std' if added else ''} are not written)")
    elif getattr(find_format("values", out, writing=True), "fields", False) and added:  # std, trusted: columns
        columns = list(S.names) + list(added)
        write_values(out, value_columns(data, columns), names=columns)
    elif find_format("values", out, writing=True) is not None:
        write_values(out, X, names=S.names)
        if added:
            print(f"note: {out.name} holds the values alone; {', '.join(added)} are not written (write .csv or "
                  f".vtu for them)")
    else:
        write_surface(out, V, F, data)


def _summary(args, r, V, S):
    """The lines that say what ran: samples, Step 1, the method, the partition, the fill."""
    rep = r.report
    print(f"{len(V):,} {'points' if 'cloud' in rep else 'vertices'}, {S.idx.size:,} samples ({len(S.names)} field(s): "
          f"{field_list(S.names)})")
    if "cloud" in rep:
        c = rep["cloud"]
        print(f"point cloud joined by the {c['graph']} ({c['edges']:,} edges, {c['components']} piece"
              f"{'' if c['components'] == 1 else 's'}, median spacing {c['spacing']:.3g}); --neighbours K changes it")
    if "barriers" in rep:
        b = rep["barriers"]
        print(f"barriers: {b['edges']:,} edges, {b['split_vertices']:,} vertices split, {b['pieces']} piece"
              f"{'' if b['pieces'] == 1 else 's'} (a split vertex's value: the mean of its sides')")
    dropped = rep.get("mesh", {}).get("unreferenced_vertices")
    if dropped:
        print(f"{dropped:,} {'vertex is' if dropped == 1 else 'vertices are'} used by no face: left out, NaN in the "
              f"output (--clean removes them)")
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
    if "auto" in rep:  # method='auto': the cross-validation table and the choice, before the fill it chose
        print(rep["auto"]["table"])
        fields = rep["auto"].get("fields") or [rep["auto"]["chosen"]]
        if len(set(fields)) > 1:
            print("auto: chose " + "; ".join(f"{f} for field {j + 1}" for j, f in enumerate(fields))
                  + " (the default unless another was better by more than one standard error)")
        else:
            print(f"auto: chose {fields[0]} (the default unless another was better by more than one standard error)")
        advice = rep["auto"]["recommendation"].split(". ", 1)  # what it says beyond the choice: overshoot, fields
        if len(advice) > 1 and advice[1].strip():
            print(f"  {advice[1].strip()}")
    if rep.get("default") and method_of(rep["method"]).partitions:  # a surface without triangles: the pipeline
        print(f"method: the default on a surface without triangles ({rep['method']}, {rep.get('curve_values')} curve "
              f"values, bounded by the samples' range)")
    elif rep.get("default"):
        print(f"method: the default ({rep['method']}, projected onto the samples' range; --method gvf-harmonic for "
              f"the paper's pipeline)")
    if "partition" in rep:
        pr = rep["partition"]
        print(f"steps 2-3: {pr['method']} partition, {pr['curves']} curves through {pr['curve_vertices']:,} "
              f"vertices, {pr['patches']} patches (largest {max(pr['patch_sizes'] or [0]):,})")
    if "fill" in rep:
        _fill_line(args, rep)
    if rep.get("bounds", {}).get("mode") == "project":
        b = rep["bounds"]
        print(f"bounds: projected {sum(b['projected']):,} values onto them (largest overshoot before: "
              f"{max(b['overshoot'], default=0.0):.4g})")
    if rep.get("rbf"):
        print(f"rbf: thin-plate spline through the sample positions ({rep['rbf']['dims']}-D)")


def _fill_line(args, rep):
    h = rep["fill"]
    its = h.get("iterations")
    m = rep["method"]
    what = "steps 5-6: harmonic fill" if method_of(m).partitions else f"{m} fill (samples fixed)"
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
