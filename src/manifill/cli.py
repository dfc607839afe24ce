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
import signal
import sys
import threading
import time

import numpy as np

from . import __version__
from .cli_common import check_outputs, err, levels, load, pictures, print_time, step_bar, write_surface
from .errors import ManifillError
from .harmonic import ON_EMPTY, HarmonicSolver
from .curves import CURVE_VALUES
from .geodesic import DISTANCES
from .laplacian import WEIGHTS
from .partition import PARTITIONS
from .reconstruct import METHODS
from .cli_volume import cmd_volume
from .solvers import SOLVERS

__all__ = ["main"]


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


def _surface_outputs(args, pictures=True):
    """-o (and --render/--html) of a surface command, checked before any work."""
    from .io import MESH_FORMATS
    from .sampleio import VALUE_FORMATS

    meshes = tuple(e for e, f in MESH_FORMATS.items() if f.write and f.fields)
    outs = [("-o", args.output, meshes + VALUE_FORMATS)]
    if pictures:
        outs += [("--render", getattr(args, "render", None), (".png",)),
                 ("--html", getattr(args, "html", None), (".html",))]
    return check_outputs(outs, [args.mesh, args.samples])[0]


def _check_names(args, S, out):
    """The field names against the output's format and manifill's masks, and --field, before the work."""
    from .cli_common import chosen_field
    from .io import check_field_names

    check_field_names(S.names, out)
    chosen_field(args, S.names)


def _masks(n, idx, **extra):
    """manifill's mask arrays of a surface result, under their fixed names."""
    from .io import SAMPLE_MASK

    sample = np.zeros(n, dtype=bool)
    sample[idx] = True
    return {SAMPLE_MASK: sample, **extra}


def cmd_harmonic(args):
    """``manifill harmonic MESH SAMPLES -o OUT``."""
    from .sampleio import VALUE_FORMATS, write_values

    out = _surface_outputs(args)
    ext = out.suffix.lower()
    V, F, S = load(args)
    _check_names(args, S, out)
    t0 = time.perf_counter()
    solver = HarmonicSolver(V, F, S.idx, weights=args.weights, solver=args.solver, on_empty=args.on_empty)
    X = solver.solve(S.vals)
    seconds = time.perf_counter() - t0
    if ext in VALUE_FORMATS:
        write_values(out, X, S.names)
    else:
        write_surface(out, V, F, {name: X[:, j] for j, name in enumerate(S.names)}, _masks(len(V), S.idx))
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
    pictures(args, V, F, X, S.names, samples=S.idx, title=f"harmonic: {S.names[0]}")
    return 0


def _print_ranges(X, S, out):
    """Each field's range beside the samples' (overshoot shows), and the output path."""
    lo, hi = np.nanmin(X, axis=0), np.nanmax(X, axis=0)
    for j, name in enumerate(S.names):
        print(f"  {name}: range [{lo[j]:.6g}, {hi[j]:.6g}]  (samples [{S.vals[:, j].min():.6g}, "
              f"{S.vals[:, j].max():.6g}])")
    print(f"wrote {out}")


def cmd_check(args):
    """``manifill check MESH SAMPLES``: exit 0 if the condition holds, 1 if not."""
    from .geodesic import mesh_graph
    from .gradual import check_gradual
    from .validate import as_mesh

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
            worst = c.violations[np.argsort(c.violations[:, 2] - c.violations[:, 3])]
            for p, q, d, k in worst[:10]:
                print(f"    {int(p):>8} {int(q):>8} {d:>10.4g} {int(k):>6}")
            if len(worst) > 10:
                print(f"    ... and {len(worst) - 10} more")
    return 0 if all(c.holds for c in checks) else 1


def cmd_reconstruct(args):
    """``manifill reconstruct MESH SAMPLES -o OUT``."""
    from .io import CURVE_MASK, PATCH_LABEL
    from .reconstruct import reconstruct
    from .sampleio import VALUE_FORMATS, write_values

    out = _surface_outputs(args)
    V, F, S = load(args)
    _check_names(args, S, out)
    if args.subdivide:
        from .subdivide import check_subdivide

        check_subdivide(len(V), len(F), args.subdivide, len(S.names))
    bar = step_bar(args, 5)
    try:
        r = reconstruct(V, F, S.idx, S.vals, method=args.method, partition=args.partition, weights=args.weights,
                        distance=args.distance, levels=levels(args.levels), curve_values=args.curve_values,
                        solver=args.solver, on_empty=args.on_empty, duplicates=args.duplicates, progress=bar)
    finally:
        bar.close()
    X = r.values if r.values.ndim == 2 else r.values[:, None]
    if args.subdivide:
        from .subdivide import subdivide

        V2, F2, X2 = subdivide(V, F, X, levels=args.subdivide)
        if out.suffix.lower() in VALUE_FORMATS:
            write_values(out, X2, S.names)
        else:
            write_surface(out, V2, F2, {name: X2[:, j] for j, name in enumerate(S.names)}, {})
        print(f"subdivided {args.subdivide} time(s): {len(V2):,} vertices, {len(F2):,} faces (fields carried along; "
              f"the masks are not written)")
    elif out.suffix.lower() in VALUE_FORMATS:
        write_values(out, X, S.names)
    else:
        fields = {name: X[:, j] for j, name in enumerate(S.names)}
        write_surface(out, V, F, fields, _masks(len(V), S.idx, **{CURVE_MASK: r.on_curve, PATCH_LABEL: r.components}))
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
    print_time(args, rep["seconds"])
    _print_ranges(X, S, out)
    pictures(args, V, F, X, S.names, samples=S.idx, curves=r.curves, title=f"{args.method}")
    return 0


def cmd_demo(args):
    """``manifill demo``."""
    from .demo import run_demo

    report = run_demo(args.output)
    print(report["text"])
    return 0


_MESH_HELP = ".vtu .vtp .vtk .ply .off .obj .stl .surf.gii, or a FreeSurfer surface such as lh.pial"


def _sample_args(s):
    """MESH SAMPLES and the options of reading them, shared by the subcommands."""
    s.add_argument("mesh", help=f"mesh file ({_MESH_HELP})")
    s.add_argument("samples", help="samples: .csv with header vertex,value[,...] or x,y,z,value[,...]; .npz; .npy; "
                                   "per-vertex data with NaN where unmeasured (.func.gii, .shape.gii, .mgh, "
                                   "FreeSurfer lh.thickness ...); FreeSurfer .label")
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
                   help="output: .vtu/.vtp/.vtk/.ply (mesh with named fields) or .csv/.npy (values)")
    s.add_argument("--weights", choices=WEIGHTS, default="cotan", help="Laplacian weights (default: cotan)")
    s.add_argument("--solver", choices=SOLVERS, default="auto", help="linear solver (default: auto)")
    s.add_argument("--on-empty", choices=ON_EMPTY, default="error",
                   help="a component without samples: error (default) or fill with NaN")


def _picture_args(s):
    s.add_argument("--render", default=None, metavar="OUT.png",
                   help="also render the result (field, samples, curves) as a PNG, off-screen (needs pyvista)")
    s.add_argument("--html", default=None, metavar="OUT.html",
                   help="also write an interactive viewer: one self-contained HTML file that opens offline, "
                        "with a menu of every field")
    s.add_argument("--field", default=None, metavar="NAME",
                   help="the field --render draws and --html shows first (default: the first value column)")


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
    s.add_argument("mesh", help=f"mesh file ({_MESH_HELP})")
    s.add_argument("--json", action="store_true", help="print as JSON")
    s.set_defaults(func=cmd_info)

    s = sub.add_parser("harmonic", help="fill a field harmonically from samples",
                       description="Fix the sample values at their vertices and fill every other vertex "
                                   "with the weighted average of its neighbours (discrete harmonic).")
    _sample_args(s)
    _fill_args(s)
    _picture_args(s)
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
    s.add_argument("--field", default=None, metavar="NAME", help="the field --render draws (default: the first)")
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
    with _terminate_as_interrupt():
        try:
            if getattr(args, "quiet", False):
                with contextlib.redirect_stdout(io.StringIO()):
                    return args.func(args)
            return args.func(args)
        except BrokenPipeError:
            # the reader went away (e.g. `manifill info --json m.ply | head`): stop quietly
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return 1
        except _Terminated:
            print("manifill: terminated; no output was left half-written", file=sys.stderr)
            return 143
        except KeyboardInterrupt:
            print("manifill: interrupted; no output was left half-written", file=sys.stderr)
            return 130
        except ManifillError as exc:
            return err(str(exc))
        except ImportError as exc:
            return err(str(exc).splitlines()[0])
        except MemoryError:
            return err("out of memory during the computation; try a smaller mesh, a lower resolution or solver='amg'")
        except OSError as exc:
            return err(f"{exc.strerror or exc}: {exc.filename or ''}".rstrip(": "))
        except Exception as exc:  # noqa: BLE001 - a bug of manifill's: one line, the traceback on request
            if os.environ.get("MANIFILL_DEBUG"):
                raise
            text = " ".join(str(exc).split())[:200]
            print(f"manifill: internal error: {type(exc).__name__}: {text} (a bug; MANIFILL_DEBUG=1 shows the "
                  f"traceback)", file=sys.stderr)
            return 1


class _Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the program is so that temporary files are removed on the way out."""


@contextlib.contextmanager
def _terminate_as_interrupt():
    """While the command runs, SIGTERM unwinds like Ctrl-C (only in the main thread, where signals arrive)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def raise_terminated(signum, frame):
        raise _Terminated()

    previous = signal.signal(signal.SIGTERM, raise_terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
