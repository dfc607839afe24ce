"""``manifill volume MESH SAMPLES -o OUT``: Steps 1-8 inside a solid (surface, tetrahedra or voxel mask)."""

from pathlib import Path

from ..errors import ReadError, SampleError, WriteError
from ..io import (GRID_FORMATS, TET_FORMATS, has_tets, read_mask, read_mesh_file, read_samples, read_tets, write_tets,
                  write_vti)
from ..report import value_ranges
from ..solid.boundary import digital_surface
from ..solid import reconstruct_volume as rv  # called through the module: a test may replace an entry point
from ..solid.tets import boundary_faces, boundary_vertices
from ..surface.methods.registry import method_of
from ..viz.render import render, render_slices
from .common import (add_draws, check_draws, check_names, check_outputs, chosen_field, levels, print_time,
                     print_uncertainty, std_names, step_bar, uncertainty_opts)
from ..io.formats import find_format
from .gradients import add_gradient
from ..solid.estimates import VOLUME_CONSTRAINTS
from ..validate.constraints import choices
from .options import (choices_of, default_of, gradient_args, max_distance_arg, output_args, pipeline_args,
                      uncertainty_args)

__all__ = ["add_parser", "run"]


def add_parser(sub):
    """Register ``manifill volume``."""
    s = sub.add_parser("volume", help="reconstruct inside a solid from samples on its boundary (Steps 1-8)",
                       description="MESH is a closed surface (.off .obj .ply .stl .vtk .vtu; filled as voxels or "
                                   "tets, see --form), a tetrahedral mesh (.vtu .vtk .msh) or a voxel mask (.vti "
                                   ".npy). The samples lie on the boundary. Steps 1-6 run on the boundary surface, "
                                   "Step 8 fills the inside harmonically. Writes .vti/.npy (voxels) or .vtu/.vtk/.msh "
                                   "(tets) with the field and the boundary mask.")
    s.add_argument("mesh", help="closed surface, tetrahedral mesh, or voxel mask (.vti .npy)")
    s.add_argument("samples", help="samples: .csv with header vertex,value[,...] or x,y,z,value[,...]; .npz; .npy "
                                   "(for a mask, vertices are boundary voxels in C order; positions are simpler)")
    s.add_argument("-o", "--output", required=True, help="output: .vti/.npy (voxels) or .vtu/.vtk/.msh (tets)")
    s.add_argument("--form", choices=choices(VOLUME_CONSTRAINTS["form"]), default="voxels",
                   help="how to fill a closed surface (default: voxels)")
    s.add_argument("--resolution", type=int, default=128, help="voxels along the longest side (default: 128)")
    s.add_argument("--connectivity", type=int, choices=choices(VOLUME_CONSTRAINTS["connectivity"]), default=6,
                   help="voxel neighbours (default: 6)")
    s.add_argument("--max-volume", type=float, default=None, help="largest tetrahedron volume (--form tets)")
    s.add_argument("--fill-solver", choices=choices(VOLUME_CONSTRAINTS["fill_solver"]), default="auto",
                   help="solver of the inside: multigrid (voxels only), amg or direct (default: auto = multigrid "
                        "for voxels; for tets direct up to a size, then amg)")
    s.add_argument("--fill-weights", choices=choices(VOLUME_CONSTRAINTS["fill_weights"]), default="cotan",
                   help="weights of the inside's tetrahedral Laplacian (tets only; default: cotan)")
    s.add_argument("--allow-open", action="store_true", help="voxelise an open surface by winding numbers")
    s.add_argument("--spacing", default=None, help="voxel size of a mask, e.g. 1,1,2.5 (default: from .vti, or 1)")
    s.add_argument("--origin", default=None, help="centre of voxel (0,0,0) of a mask (default: from .vti, or 0)")
    s.add_argument("--mask-field", default=None, help="the .vti field holding the mask (default: 'mask' or the only)")
    s.add_argument("--duplicates", choices=choices_of("duplicates"), default=default_of("duplicates"),
                   help="two samples on one vertex with different values: error (default) or average")
    max_distance_arg(s, help="largest accepted snap distance of a position")
    s.add_argument("--weights", choices=choices_of("weights"), default=None,
                   help="surface Laplacian weights (default: cotan; uniform on a voxel mask, whose digital surface "
                        "has no triangles)")
    s.add_argument("--solver", choices=choices_of("solver"), default=default_of("solver"),
                   help=f"surface linear solver (default: {default_of('solver')})")
    pipeline_args(s, method_help="surface method (default: the measured default, gvf-harmonic with monotone curve "
                                     "values and --bounds samples); gp: a Matern Gaussian process over the whole "
                                     "solid (no surface pass; --fill-solver its solver), with its std")
    uncertainty_args(s)
    gradient_args(s)
    s.add_argument("--render", default=None, metavar="OUT.png",
                   help="also render three slices through the solid (voxels) or its boundary (tets) as a PNG")
    s.add_argument("--field", default=None, metavar="NAME",
                   help="the field --render draws (default: the first; <field>_std or trusted with --method gp)")
    output_args(s)
    s.set_defaults(func=run)


def _triple(text, what):
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        vals = []
    if len(vals) == 1:
        vals *= 3
    if len(vals) != 3:
        raise SampleError(f"--{what} {text!r} is not three comma-separated numbers; write e.g. --{what} 1,1,2.5")
    return vals


def run(args):
    """``manifill volume MESH SAMPLES -o OUT.vti|OUT.vtu``."""
    src = Path(args.mesh).suffix.lower()
    if (src in GRID_FORMATS or src in TET_FORMATS) and not Path(args.mesh).is_file():
        raise ReadError(f"{args.mesh}: no such file")  # before its kind (and the output's) is guessed from it
    kind = "mask" if src in GRID_FORMATS else ("tets" if src in TET_FORMATS and has_tets(args.mesh) else "surface")
    form = "voxels" if kind == "mask" else ("tets" if kind == "tets" else args.form)
    allowed = GRID_FORMATS if form == "voxels" else tuple(TET_FORMATS)
    if Path(args.output).suffix.lower() not in allowed:
        raise WriteError(f"{Path(args.output).name}: a {form} result is written as {' or '.join(allowed)}; change "
                         f"the output name")
    out, _ = check_outputs([("-o", args.output, allowed), ("--render", args.render, (".png",))],
                           [args.mesh, args.samples])
    std_opts = uncertainty_opts(args, in_solid=True)
    check_draws(args, args.method)
    # the mask's digital surface is built without a "graph" step; a surface is first voxelised or tetrahedralised
    solid = {"mask": (), "tets": ()}.get(kind, ("voxelize",) if form == "voxels" else ("tetrahedralize",))
    method = method_of(args.method)
    steps = ("graph",) * (kind != "mask") + method.step_names + solid + ("fill",)
    bar = step_bar(args, () if method.gp_mean else steps)  # the solid's gp has no surface steps
    surface_opts = _surface_options(args, bar, std_opts)
    try:
        r, S, form = _volume_run(args, kind, form, surface_opts)
    finally:
        bar.close()
    return _volume_write(args, out, out.suffix.lower(), r, S, form)


#: The surface step's flags at their defaults. With --method gp (no surface step in a solid) only those set
#: otherwise reach the library, which refuses them; --weights None is the library's default for the solid.
_SURFACE_DEFAULTS = {"partition": "delaunay", "distance": "length", "levels": None, "curve_values": None,
                     "solver": "auto", "weights": None}


def _surface_options(args, bar, std_opts):
    """The keywords of the surface step (Steps 1-6), as ``manifill.reconstruct`` takes them."""
    opts = dict(partition=args.partition, distance=args.distance, levels=levels(args.levels),
                curve_values=args.curve_values, solver=args.solver, weights=args.weights)
    gp = method_of(args.method).gp_mean
    given = {k: v for k, v in opts.items() if v is not None and (not gp or v != _SURFACE_DEFAULTS[k])}
    return {"method": args.method, **given, "duplicates": args.duplicates, "progress": bar, **std_opts}


def _check_samples(args, S):
    """What the samples' names and count allow for the output, before the work."""
    check_names(args, S, args.output)
    if not getattr(find_format("grid", args.output, writing=True), "fields", True) and len(S.names) > 1:
        raise WriteError(f"{Path(args.output).name}: .npy holds one field but the samples have {len(S.names)} "
                         f"({', '.join(S.names)}); write .vti")


def _volume_run(args, kind, form, surface_opts):
    """Read the solid and the samples, run Steps 1-8; print what was read."""
    if kind == "mask":
        mask, h, o = read_mask(args.mesh, field=args.mask_field)
        h = _triple(args.spacing, "spacing") if args.spacing else (h if h is not None else [1.0, 1.0, 1.0])
        o = _triple(args.origin, "origin") if args.origin else (o if o is not None else [0.0, 0.0, 0.0])
        voxels, P, _, _ = digital_surface(mask, spacing=h, origin=o, connectivity=args.connectivity)
        S = read_samples(args.samples, P, duplicates=args.duplicates, max_distance=args.max_distance)
        _check_samples(args, S)
        r = rv.reconstruct_volume_mask(mask, voxels[S.idx], S.vals, spacing=h, origin=o,
                                       connectivity=args.connectivity, fill_solver=args.fill_solver,
                                       fill_weights=args.fill_weights, **surface_opts)
        print(f"voxel mask {mask.shape}, {int(mask.sum()):,} voxels; digital surface {len(voxels):,} voxels")
    elif kind == "tets":
        V, T = read_tets(args.mesh)
        on_d = boundary_vertices(T, V=V)
        # positions snap to the boundary, not to inner vertices
        S = read_samples(args.samples, V, duplicates=args.duplicates, max_distance=args.max_distance, snap_to=on_d)
        _check_samples(args, S)
        r = rv.reconstruct_volume_tets(V, T, S.idx, S.vals, fill_solver=args.fill_solver,
                                       fill_weights=args.fill_weights, **surface_opts)
        print(f"tetrahedral mesh: {len(V):,} vertices, {len(T):,} tets, {on_d.size:,} on the boundary")
    else:
        mesh = read_mesh_file(args.mesh)
        V, F = mesh.V, mesh.F
        S = read_samples(args.samples, V, duplicates=args.duplicates, max_distance=args.max_distance,
                         vertex_numbering=mesh.vertex_numbering)
        _check_samples(args, S)
        r = rv.reconstruct_volume(V, F, S.idx, S.vals, form=form, resolution=args.resolution,
                                  connectivity=args.connectivity, max_volume=args.max_volume,
                                  fill_solver=args.fill_solver, fill_weights=args.fill_weights,
                                  allow_open=args.allow_open, **surface_opts)
        print(f"surface: {len(V):,} vertices, {len(F):,} faces")
    return r, S, form


def _volume_write(args, out, ext, r, S, form):
    """Write the volume result (and its picture), print the summary."""
    X = r.fields()
    data = r.point_data(S.names)
    add_draws(args, r, S.names, data)
    grads = add_gradient(args, r, S.names, data, args.output)
    if form == "voxels":
        # a .npy holds the one field alone
        named = find_format("grid", out, writing=True).fields
        write_vti(out, data if named else {S.names[0]: X[..., 0]}, spacing=r.spacing, origin=r.origin)
        added = [k for k in std_names(args, S.names) if k in data] + grads
        if not named and added:
            print(f"note: {out.name} holds the values alone; {', '.join(added)} are not written (write .vti for "
                  f"them)")
        spacing = [round(float(v), 6) for v in r.spacing]
        fill = r.report.get("fill")
        if fill is not None:
            print(f"voxels: grid {X.shape[:3]}, spacing {spacing}, {fill['voxels']:,} inside, "
                  f"{fill['fixed']:,} on the boundary D, {fill['unknowns']:,} filled ({fill['solver']}, "
                  f"connectivity {fill['connectivity']}, iterations {fill['iterations']})")
        else:  # method='gp': no fill, the posterior over every voxel
            print(f"voxels: grid {X.shape[:3]}, spacing {spacing}, the gp over every voxel of the solid")
    else:
        write_tets(out, r.TV, r.TT, data)
        print(f"tets: {len(r.TV):,} vertices, {len(r.TT):,} tetrahedra")
    print_uncertainty(r.report, getattr(r, "std", None), getattr(r, "trusted", None), r.point_ndim)
    print_time(args, r.report.get("seconds", r.report.get("gp", {}).get("seconds", {})))
    field = chosen_field(args, S.names)
    if getattr(args, "render", None):
        if form == "voxels":
            render_slices(data[field], r.spacing, r.origin, args.render, name=field)
        else:
            render(r.TV, boundary_faces(r.TT), data[field], args.render, name=field, title="boundary of the solid")
        print(f"rendered {args.render} ({field})")
    (lo, hi), (vlo, vhi) = value_ranges(S.vals), value_ranges(X, r.point_ndim)
    for j, name in enumerate(S.names):
        print(f"{name}: samples in [{lo[j]:.4g}, {hi[j]:.4g}], solid in [{vlo[j]:.4g}, {vhi[j]:.4g}]")
    print(f"wrote {out}")
    return 0
