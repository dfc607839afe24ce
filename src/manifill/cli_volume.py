"""The ``manifill volume`` subcommand: Steps 1-8 inside a solid (surface, tetrahedra or voxel mask)."""

from pathlib import Path

import numpy as np

from .errors import SampleError

__all__ = ["cmd_volume"]


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


def cmd_volume(args):
    """``manifill volume MESH SAMPLES -o OUT.vti|OUT.vtu``."""
    from .cli_common import check_outputs, levels, step_bar
    from .errors import ReadError, WriteError
    from .volio import GRID_FORMATS, TET_FORMATS, has_tets

    src = Path(args.mesh).suffix.lower()
    if src in GRID_FORMATS + tuple(TET_FORMATS) and not Path(args.mesh).is_file():
        raise ReadError(f"{args.mesh}: no such file")  # before its kind (and the output's) is guessed from it
    kind = "mask" if src in GRID_FORMATS else ("tets" if src in TET_FORMATS and has_tets(args.mesh) else "surface")
    form = "voxels" if kind == "mask" else ("tets" if kind == "tets" else args.form)
    allowed = GRID_FORMATS if form == "voxels" else tuple(TET_FORMATS)
    if Path(args.output).suffix.lower() not in allowed:
        raise WriteError(f"{Path(args.output).name}: a {form} result is written as {' or '.join(allowed)}; change "
                         f"the output name")
    out, _ = check_outputs([("-o", args.output, allowed), ("--render", args.render, (".png",))],
                           [args.mesh, args.samples])
    bar = step_bar(args, 7)
    surface_opts = dict(method=args.method, partition=args.partition, distance=args.distance,
                        levels=levels(args.levels), curve_values=args.curve_values, duplicates=args.duplicates,
                        progress=bar)
    try:
        r, S, form = _volume_run(args, kind, form, surface_opts)
    finally:
        bar.close()
    return _volume_write(args, out, out.suffix.lower(), r, S, form)


def _check_samples(args, S):
    """What the samples' names and count allow for the output, before the work."""
    from .cli_common import chosen_field
    from .errors import WriteError
    from .io import check_field_names

    check_field_names(S.names, args.output)
    chosen_field(args, S.names)
    if Path(args.output).suffix.lower() == ".npy" and len(S.names) > 1:
        raise WriteError(f"{Path(args.output).name}: .npy holds one field but the samples have {len(S.names)} "
                         f"({', '.join(S.names)}); write .vti")


def _volume_run(args, kind, form, surface_opts):
    """Read the solid and the samples, run Steps 1-8; print what was read."""
    from .io import read_mesh_file
    from .sampleio import read_samples
    from .solid import digital_surface, reconstruct_volume, reconstruct_volume_mask, reconstruct_volume_tets
    from .tets import boundary_faces
    from .volio import read_mask, read_tets

    if kind == "mask":
        mask, h, o = read_mask(args.mesh, field=args.mask_field)
        h = _triple(args.spacing, "spacing") if args.spacing else (h if h is not None else [1.0, 1.0, 1.0])
        o = _triple(args.origin, "origin") if args.origin else (o if o is not None else [0.0, 0.0, 0.0])
        voxels, P, _, _ = digital_surface(mask, h, o, args.connectivity)
        S = read_samples(args.samples, P, duplicates=args.duplicates, max_distance=args.max_snap)
        _check_samples(args, S)
        r = reconstruct_volume_mask(mask, voxels[S.idx], S.vals, spacing=h, origin=o, connectivity=args.connectivity,
                                    fill_solver=args.fill_solver, **surface_opts)
        print(f"voxel mask {mask.shape}, {int(mask.sum()):,} voxels; digital surface {len(voxels):,} voxels")
    elif kind == "tets":
        V, T = read_tets(args.mesh)
        on_d = np.unique(boundary_faces(T, V=V))
        S = read_samples(args.samples, V, duplicates=args.duplicates, max_distance=args.max_snap)
        _check_samples(args, S)
        if S.snap_distance is not None:  # positions: snap to the boundary, not to inner vertices
            S = read_samples(args.samples, V[on_d], duplicates=args.duplicates, max_distance=args.max_snap)
            S.idx = on_d[S.idx]
        r = reconstruct_volume_tets(V, T, S.idx, S.vals, fill_weights=args.fill_weights,
                                    fill_solver="auto" if args.fill_solver == "multigrid" else args.fill_solver,
                                    weights=args.weights, solver=args.solver, **surface_opts)
        print(f"tetrahedral mesh: {len(V):,} vertices, {len(T):,} tets, {on_d.size:,} on the boundary")
    else:
        mesh = read_mesh_file(args.mesh)
        V, F = mesh.V, mesh.F
        S = read_samples(args.samples, V, duplicates=args.duplicates, max_distance=args.max_snap,
                         vertex_numbering=mesh.vertex_numbering)
        _check_samples(args, S)
        r = reconstruct_volume(V, F, S.idx, S.vals, form=form, resolution=args.resolution,
                               connectivity=args.connectivity, max_volume=args.max_volume,
                               fill_solver=args.fill_solver, fill_weights=args.fill_weights,
                               allow_open=args.allow_open, weights=args.weights, solver=args.solver, **surface_opts)
        print(f"surface: {len(V):,} vertices, {len(F):,} faces")
    return r, S, form


def _volume_write(args, out, ext, r, S, form):
    """Write the volume result (and its picture), print the summary."""
    from .cli_common import chosen_field, print_time
    from .io import BOUNDARY_MASK, SAMPLE_MASK
    from .tets import boundary_faces
    from .volio import write_tets, write_vti

    X = r.values if r.values.ndim == (4 if form == "voxels" else 2) else r.values[..., None]
    fields = {name: X[..., j] for j, name in enumerate(S.names)}
    if form == "voxels":
        if ext == ".vti":
            fields[BOUNDARY_MASK] = r.fixed
        write_vti(out, fields, r.spacing, r.origin)
        fill = r.report["fill"]
        print(f"voxels: grid {X.shape[:3]}, spacing {np.round(r.spacing, 6).tolist()}, {fill['voxels']:,} inside, "
              f"{fill['fixed']:,} on the boundary D, {fill['unknowns']:,} filled ({fill['solver']}, "
              f"connectivity {fill['connectivity']}, iterations {fill['iterations']})")
    else:
        boundary = np.zeros(len(r.TV), dtype=bool)
        boundary[np.unique(boundary_faces(r.TT))] = True
        fields[BOUNDARY_MASK] = boundary
        sample = np.zeros(len(r.TV), dtype=bool)
        sample[S.idx] = True  # tet vertices (a surface keeps its vertices first in the tetrahedralisation)
        fields[SAMPLE_MASK] = sample
        write_tets(out, r.TV, r.TT, fields)
        print(f"tets: {len(r.TV):,} vertices, {len(r.TT):,} tetrahedra")
    print_time(args, r.report["seconds"])
    j = S.names.index(chosen_field(args, S.names))
    if getattr(args, "render", None):
        if form == "voxels":
            from .render import render_slices

            render_slices(X[..., j], r.spacing, r.origin, args.render, name=S.names[j])
        else:
            from .render import render

            render(r.TV, boundary_faces(r.TT), X[:, j], args.render, name=S.names[j], title="boundary of the solid")
        print(f"rendered {args.render} ({S.names[j]})")
    finite = X[np.isfinite(X[..., 0])]
    lo, hi = S.vals.min(axis=0), S.vals.max(axis=0)
    for j, name in enumerate(S.names):
        print(f"{name}: samples in [{lo[j]:.4g}, {hi[j]:.4g}], solid in [{finite[:, j].min():.4g}, "
              f"{finite[:, j].max():.4g}]")
    print(f"wrote {out}")
    return 0
