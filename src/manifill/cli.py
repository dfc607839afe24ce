"""The ``manifill`` command line: a thin shell over the library.

Subcommands: ``info`` (what is in a mesh), ``check`` (the gradual variation
condition of samples), ``reconstruct`` (the paper's pipeline), ``harmonic`` (fill a
field from the samples alone), ``volume`` (Steps 1-8 inside a solid), ``demo`` (the
built-in example). Bad input ends with exit code 2 and one line
``manifill: error: ...`` on standard error, never a traceback; nothing is left
half-written.
"""

import argparse
import contextlib
import io
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from . import __version__
from .errors import ManifillError, SampleError
from .harmonic import ON_EMPTY, HarmonicSolver
from .curves import CURVE_VALUES
from .geodesic import DISTANCES
from .laplacian import WEIGHTS
from .partition import PARTITIONS
from .reconstruct import METHODS
from .cli_volume import cmd_volume
from .solvers import SOLVERS

__all__ = ["main"]


def _err(msg):
    print(f"manifill: error: {msg}", file=sys.stderr)
    return 2


def _load(args):
    """Read mesh and samples, optionally cleaning the mesh first."""
    from .io import read_mesh, read_samples
    from .samples import Samples
    from .topology import clean_mesh

    V, F = read_mesh(args.mesh)
    # vertex indices refer to the file's numbering, so samples are read against it
    S = read_samples(args.samples, V, duplicates=args.duplicates, max_distance=args.max_snap)
    if args.clean:
        n0 = len(V)
        V, F, vmap = clean_mesh(V, F)
        print(f"cleaned mesh: {n0:,} -> {len(V):,} vertices, {len(F):,} faces")
        if S.snap_distance is None:
            new = vmap[S.idx]
            if (new < 0).any():
                raise SampleError(
                    f"{int((new < 0).sum())} samples sit on vertices that --clean removed (e.g. vertex "
                    f"{int(S.idx[new < 0][0])}, used by no face); sample vertices of the surface only")
            S = Samples.from_indices(new, S.vals, len(V), names=S.names, duplicates=args.duplicates)
        else:
            S = read_samples(args.samples, V, duplicates=args.duplicates, max_distance=args.max_snap)
    return V, F, S


def _check_output(path):
    """The output path, checked before any work is done."""
    from .io import MESH_FORMATS, VALUE_FORMATS
    from .errors import WriteError

    out = Path(path)
    ext = out.suffix.lower()
    if ext not in VALUE_FORMATS and not (ext in MESH_FORMATS and MESH_FORMATS[ext][1]):
        raise WriteError(f"{out.name}: the output must be .ply, .vtu or .vtk (mesh with fields) or .csv/.npy (values)")
    if not out.parent.is_dir():
        raise WriteError(f"folder {out.parent} does not exist; create it first or choose another output path")
    return out


def _write_with_masks(out, V, F, fields, extra, idx):
    """Write the fields plus label fields (a sample mask, curve mask, components) under free names."""
    from .io import write_mesh

    fixed = np.zeros(len(V), dtype=bool)
    fixed[idx] = True
    for base, arr in [("fixed", fixed), *extra.items()]:
        name = next(m for m in (base, f"{base}_mask", f"manifill_{base}") if m not in fields)
        fields[name] = arr
    written = write_mesh(out, V, F, fields)
    renamed = {a: b for a, b in written.items() if a != b}
    if renamed:
        print("note: fields renamed for the format: " + ", ".join(f"{a!r} -> {b!r}" for a, b in renamed.items()))


def cmd_info(args):
    """``manifill info MESH``."""
    from .io import read_mesh
    from .topology import mesh_info

    V, F = read_mesh(args.mesh)
    info = mesh_info(V, F)
    if args.json:
        print(json.dumps(info, indent=2))
        return 0
    lo, hi = info["bbox_min"], info["bbox_max"]
    print(f"{args.mesh}: {info['vertices']:,} vertices, {info['faces']:,} faces, {info['edges']:,} edges")
    print(f"  bounding box  [{lo[0]:.4g}, {hi[0]:.4g}] x [{lo[1]:.4g}, {hi[1]:.4g}] x [{lo[2]:.4g}, {hi[2]:.4g}]"
          f"  (diagonal {info['diagonal']:.4g})")
    print(f"  components    {len(info['components'])}")
    for i, c in enumerate(info["components"][:10]):
        kind = f"closed, genus {c['genus']}" if "genus" in c else (
            "closed" if c["closed"] else f"open, {c['boundary_loops']} boundary loop(s)")
        print(f"    #{i}: {c['vertices']:,} vertices, {c['faces']:,} faces, Euler characteristic {c['euler']}, {kind}")
    if len(info["components"]) > 10:
        print(f"    ... and {len(info['components']) - 10} more")
    print(f"  boundary loops       {info['boundary_loops']}")
    print(f"  non-manifold edges   {info['nonmanifold_edges']}")
    print(f"  unreferenced vertices {info['unreferenced_vertices']}")
    print(f"  coinciding vertex pairs {info['coinciding_vertex_pairs']}")
    print(f"  zero-area faces      {info['zero_area_faces']}")
    if info["unreferenced_vertices"] or info["coinciding_vertex_pairs"] or info["zero_area_faces"]:
        print("  (manifill harmonic --clean welds, drops unused vertices and zero-area faces)")
    return 0


def cmd_harmonic(args):
    """``manifill harmonic MESH SAMPLES -o OUT``."""
    from .io import VALUE_FORMATS, write_values

    out = _check_output(args.output)
    ext = out.suffix.lower()
    V, F, S = _load(args)
    t0 = time.perf_counter()
    solver = HarmonicSolver(V, F, S.idx, weights=args.weights, solver=args.solver, on_empty=args.on_empty)
    X = solver.solve(S.vals)
    seconds = time.perf_counter() - t0
    if ext in VALUE_FORMATS:
        write_values(out, X, S.names)
    else:
        fields = {name: X[:, j] for j, name in enumerate(S.names)}
        _write_with_masks(out, V, F, fields, {}, S.idx)
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
    _print_ranges(X, S, out)
    return 0


def _print_ranges(X, S, out):
    """Each field's range beside the samples' (overshoot shows), and the output path."""
    lo, hi = np.nanmin(X, axis=0), np.nanmax(X, axis=0)
    for j, name in enumerate(S.names):
        print(f"  {name}: range [{lo[j]:.6g}, {hi[j]:.6g}]  (samples [{S.vals[:, j].min():.6g}, "
              f"{S.vals[:, j].max():.6g}])")
    print(f"wrote {out}")


def _levels(text):
    """``--levels``: a count, or comma-separated explicit levels."""
    if text is None:
        return None
    try:
        if "," in text:
            return np.array([float(t) for t in text.split(",") if t.strip()])
        return int(text)
    except ValueError:
        raise SampleError(f"--levels {text!r} is neither a count nor a comma-separated list of numbers") from None


def cmd_check(args):
    """``manifill check MESH SAMPLES``: exit 0 if the condition holds, 1 if not."""
    from .geodesic import mesh_graph
    from .gradual import check_gradual
    from .validate import as_mesh

    V, F, S = _load(args)
    V, F = as_mesh(V, F, allow_degenerate=True)
    G = mesh_graph(V, F, distance=args.distance)
    t0 = time.perf_counter()
    checks = [check_gradual(G, S.idx, S.vals[:, j], levels=_levels(args.levels), distance=args.distance)
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
            worst = c.violations[np.argsort(c.violations[:, 2] - c.violations[:, 3])]
            for p, q, d, k in worst[:10]:
                print(f"    {int(p):>8} {int(q):>8} {d:>10.4g} {int(k):>6}")
            if len(worst) > 10:
                print(f"    ... and {len(worst) - 10} more")
    return 0 if all(c.holds for c in checks) else 1


def cmd_reconstruct(args):
    """``manifill reconstruct MESH SAMPLES -o OUT``."""
    from .io import write_values
    from .reconstruct import reconstruct

    out = _check_output(args.output)
    _check_pictures(args)
    V, F, S = _load(args)
    bar = _bar(args, 5)
    try:
        r = reconstruct(V, F, S.idx, S.vals, method=args.method, partition=args.partition, weights=args.weights,
                        distance=args.distance, levels=_levels(args.levels), curve_values=args.curve_values,
                        solver=args.solver, on_empty=args.on_empty, duplicates=args.duplicates, progress=bar)
    finally:
        bar.close()
    X = r.values if r.values.ndim == 2 else r.values[:, None]
    if args.subdivide:
        from .subdivide import subdivide

        V2, F2, X2 = subdivide(V, F, X, levels=args.subdivide)
        if out.suffix.lower() in (".csv", ".npy"):
            write_values(out, X2, S.names)
        else:
            from .io import write_mesh

            write_mesh(out, V2, F2, {name: X2[:, j] for j, name in enumerate(S.names)})
        print(f"subdivided {args.subdivide} time(s): {len(V2):,} vertices, {len(F2):,} faces (fields carried along; "
              f"the curve and patch masks are not written)")
    elif out.suffix.lower() in (".csv", ".npy"):
        write_values(out, X, S.names)
    else:
        fields = {name: X[:, j] for j, name in enumerate(S.names)}
        extra = {"curve": r.on_curve, "component": r.components}
        _write_with_masks(out, V, F, fields, extra, S.idx)
    rep = r.report
    print(f"{len(V):,} vertices, {S.idx.size:,} samples ({len(S.names)} field(s): {', '.join(S.names)})")
    if S.snap_distance is not None:
        print(f"snapped positions to vertices: largest distance {S.snap_distance.max():.3g}")
    for name, c in zip(S.names, rep["check"]):
        state = "holds" if c["holds"] else f"fails for {c['violations']} samples"
        print(f"step 1 ({name}): {c['levels']} levels, Lipschitz {c['lipschitz_hops']:.4g} per hop; "
              f"gradual variation {state}")
    if "partition" in rep:
        pr = rep["partition"]
        print(f"steps 2-3: {pr['method']} partition, {pr['curves']} curves through {pr['curve_vertices']:,} "
              f"vertices, {pr['patches']} patches (largest {max(pr['patch_sizes'] or [0]):,})")
    if "harmonic" in rep:
        h = rep["harmonic"]
        its = h.get("iterations")
        print(f"steps 5-6: harmonic fill, weights={h['weights']}, solver={h['solver']}"
              + (f", {', '.join(map(str, its))} iterations" if its else ""))
    _print_time(args, rep["seconds"])
    _print_ranges(X, S, out)
    _pictures(args, V, F, X[:, 0], S, curves=r.curves, title=f"{args.method}: {S.names[0]}")
    return 0


def _bar(args, total):
    from .progress import StepBar

    return StepBar(total, enabled=not getattr(args, "quiet", False), desc=f"manifill {args.command}")


def _print_time(args, seconds):
    """The total time, and with --verbose every step's."""
    if getattr(args, "verbose", False):
        print("time: " + ", ".join(f"{k} {v:.2f} s" for k, v in seconds.items()))
    else:
        print(f"time: {seconds.get('total', sum(seconds.values())):.2f} s (--verbose: per step)")


def _check_pictures(args):
    """The picture outputs' names, checked before any work is done."""
    from .errors import WriteError

    for opt, ext in (("render", ".png"), ("html", ".html")):
        path = getattr(args, opt, None)
        if path is None:
            continue
        p = Path(path)
        if p.suffix.lower() != ext:
            raise WriteError(f"{p.name}: --{opt} writes a {ext} file; change the name")
        if not p.parent.is_dir():
            raise WriteError(f"folder {p.parent} does not exist; create it first or choose another path for --{opt}")


def _pictures(args, V, F, values, S, curves=None, title=None):
    """--render PNG and --html viewer of a surface result."""
    if getattr(args, "render", None):
        from .render import render

        render(V, F, values, args.render, samples=S.idx, curves=curves, title=title, name=S.names[0])
        print(f"rendered {args.render}")
    if getattr(args, "html", None):
        from .viewer import write_html

        write_html(args.html, V, F, values, samples=S.idx, curves=curves, title=title or "manifill",
                   name=S.names[0])
        print(f"wrote the viewer {args.html}")


def cmd_demo(args):
    """``manifill demo``."""
    from .demo import run_demo

    report = run_demo(args.output)
    print(report["text"])
    return 0


def _sample_args(s):
    """MESH SAMPLES and the options of reading them, shared by the subcommands."""
    s.add_argument("mesh", help="mesh file (.off .obj .ply .stl .vtk .vtu)")
    s.add_argument("samples", help="samples: .csv with header vertex,value[,...] or x,y,z,value[,...]; .npz; .npy")
    s.add_argument("--duplicates", choices=("error", "mean"), default="error",
                   help="two samples on one vertex with different values: error (default) or average")
    s.add_argument("--max-snap", type=float, default=None,
                   help="largest accepted distance from a sample position to its vertex "
                        "(default: 5%% of the mesh's bounding-box diagonal plus its vertex spacing)")
    s.add_argument("--clean", action="store_true",
                   help="weld coinciding vertices and drop unused vertices and zero-area faces first")


def _fill_args(s):
    """-o OUT and the options of the harmonic fill, shared by harmonic and reconstruct."""
    s.add_argument("-o", "--output", required=True,
                   help="output: .ply/.vtu/.vtk (mesh with named fields) or .csv/.npy (values)")
    s.add_argument("--weights", choices=WEIGHTS, default="cotan", help="Laplacian weights (default: cotan)")
    s.add_argument("--solver", choices=SOLVERS, default="auto", help="linear solver (default: auto)")
    s.add_argument("--on-empty", choices=ON_EMPTY, default="error",
                   help="a component without samples: error (default) or fill with NaN")


def _picture_args(s):
    s.add_argument("--render", default=None, metavar="OUT.png",
                   help="also render the result (field, samples, curves) as a PNG, off-screen (needs pyvista)")
    s.add_argument("--html", default=None, metavar="OUT.html",
                   help="also write an interactive viewer: one self-contained HTML file that opens offline")


def _output_args(s):
    g = s.add_mutually_exclusive_group()
    g.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors (no progress bar)")
    g.add_argument("-v", "--verbose", action="store_true", help="also print the time of every step")


class _Parser(argparse.ArgumentParser):
    """argparse with manifill's one-line errors (exit status 2)."""

    def error(self, message):
        self.exit(2, f"manifill: error: {message} (see '{self.prog} --help')\n")


def build_parser():
    """The argument parser (exposed for documentation and tests)."""
    p = _Parser(
        prog="manifill",
        description="Reconstruct a smooth field over a surface from a few sample values, without changing the mesh.",
    )
    p.add_argument("--version", action="version", version=f"manifill {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    s = sub.add_parser("info", help="counts, components, boundary loops, genus of a mesh",
                       description="Print what is in a mesh: counts, connected components with sizes, "
                                   "boundary loops, non-manifold edges, bounding box, Euler characteristic "
                                   "and genus per closed component.")
    s.add_argument("mesh", help="mesh file (.off .obj .ply .stl .vtk .vtu)")
    s.add_argument("--json", action="store_true", help="print as JSON")
    s.set_defaults(func=cmd_info)

    s = sub.add_parser("harmonic", help="fill a field harmonically from samples",
                       description="Fix the sample values at their vertices and fill every other vertex "
                                   "with the weighted average of its neighbours (discrete harmonic).")
    _sample_args(s)
    _fill_args(s)
    _output_args(s)
    s.set_defaults(func=cmd_harmonic)

    s = sub.add_parser("check", help="check the gradual variation condition of samples (Step 1)",
                       description="Choose value levels, report the Lipschitz constant and any sample pairs "
                                   "that break the gradual variation condition d(p, q) >= |i_p - i_q|. Exit "
                                   "status 0 when it holds, 1 when it does not, 2 on bad input.")
    _sample_args(s)
    s.add_argument("--levels", default=None,
                   help="a count of uniform levels, or comma-separated levels (write --levels=-1,0,1 when "
                        "the first is negative; default: the finest step that works)")
    s.add_argument("--distance", choices=DISTANCES, default="hops", help="graph distance (default: hops)")
    s.set_defaults(func=cmd_check)

    s = sub.add_parser("reconstruct", help="the paper's reconstruction: partition, curve values, harmonic patches",
                       description="Reconstruct a field from samples: check the gradual variation condition, "
                                   "cut the surface by curves through every sample, give the curves values and "
                                   "fill every patch harmonically. Writes the field, the curve mask and the "
                                   "patch labels.")
    _sample_args(s)
    _fill_args(s)
    s.add_argument("--method", choices=METHODS, default="gvf-harmonic", help="default: gvf-harmonic")
    s.add_argument("--partition", choices=PARTITIONS, default="delaunay", help="default: delaunay")
    s.add_argument("--curve-values", choices=CURVE_VALUES, default="hermite", help="default: hermite")
    s.add_argument("--distance", choices=DISTANCES, default="length", help="default: length")
    s.add_argument("--levels", default=None, help="a count of uniform levels, or comma-separated levels")
    s.add_argument("--subdivide", type=int, default=0, metavar="K",
                   help="Loop-subdivide the result K times before writing it (a smoother surface)")
    _picture_args(s)
    _output_args(s)
    s.set_defaults(func=cmd_reconstruct)

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
    s.add_argument("--form", choices=("voxels", "tets"), default="voxels",
                   help="how to fill a closed surface (default: voxels)")
    s.add_argument("--resolution", type=int, default=128, help="voxels along the longest side (default: 128)")
    s.add_argument("--connectivity", type=int, choices=(6, 18, 26), default=6, help="voxel neighbours (default: 6)")
    s.add_argument("--max-volume", type=float, default=None, help="largest tetrahedron volume (--form tets)")
    s.add_argument("--fill-solver", choices=("auto", "multigrid", "amg", "direct"), default="auto",
                   help="solver of the inside (default: auto = multigrid for voxels, AMG for tets)")
    s.add_argument("--fill-weights", choices=("cotan", "uniform"), default="cotan",
                   help="tetrahedral weights (default: cotan)")
    s.add_argument("--allow-open", action="store_true", help="voxelise an open surface by winding numbers")
    s.add_argument("--spacing", default=None, help="voxel size of a mask, e.g. 1,1,2.5 (default: from .vti, or 1)")
    s.add_argument("--origin", default=None, help="centre of voxel (0,0,0) of a mask (default: from .vti, or 0)")
    s.add_argument("--mask-field", default=None, help="the .vti field holding the mask (default: 'mask' or the only)")
    s.add_argument("--duplicates", choices=("error", "mean"), default="error",
                   help="two samples on one vertex with different values: error (default) or average")
    s.add_argument("--max-snap", type=float, default=None, help="largest accepted snap distance of a position")
    s.add_argument("--weights", choices=WEIGHTS, default="cotan", help="surface Laplacian weights (default: cotan)")
    s.add_argument("--solver", choices=SOLVERS, default="auto", help="surface linear solver (default: auto)")
    s.add_argument("--method", choices=METHODS, default="gvf-harmonic", help="surface method (default: gvf-harmonic)")
    s.add_argument("--partition", choices=PARTITIONS, default="delaunay", help="default: delaunay")
    s.add_argument("--curve-values", choices=CURVE_VALUES, default="hermite", help="default: hermite")
    s.add_argument("--distance", choices=DISTANCES, default="length", help="default: length")
    s.add_argument("--levels", default=None, help="a count of uniform levels, or comma-separated levels")
    s.add_argument("--render", default=None, metavar="OUT.png",
                   help="also render three slices through the solid (voxels) or its boundary (tets) as a PNG")
    _output_args(s)
    s.set_defaults(func=cmd_volume)

    s = sub.add_parser("demo", help="run the built-in example (nothing downloaded)",
                       description="Reconstruct a known field on a generated sphere, write the results "
                                   "and print the error.")
    s.add_argument("-o", "--output", default="manifill-demo", help="output folder (default: ./manifill-demo)")
    _output_args(s)
    s.set_defaults(func=cmd_demo)
    return p


def main(argv=None):
    """Run the command line.

    Parameters
    ----------
    argv : list of str, optional
        Arguments without the program name; ``sys.argv[1:]`` by default.

    Returns
    -------
    int
        0 on success, 2 on bad input (argparse's usage errors included).
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:
        return int(exc.code or 0)
    try:
        if getattr(args, "quiet", False):
            with contextlib.redirect_stdout(io.StringIO()):
                return args.func(args)
        return args.func(args)
    except BrokenPipeError:
        # the reader went away (e.g. `manifill info --json m.ply | head`): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except ManifillError as exc:
        return _err(str(exc))
    except ImportError as exc:
        return _err(str(exc).splitlines()[0])
    except MemoryError:
        return _err("out of memory; try a smaller mesh or solver='amg'")
    except OSError as exc:
        return _err(f"{exc.strerror or exc}: {exc.filename or ''}".rstrip(": "))


if __name__ == "__main__":
    sys.exit(main())
