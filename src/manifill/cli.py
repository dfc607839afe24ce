"""The ``manifill`` command line: a thin shell over the library.

Subcommands: ``info`` (what is in a mesh), ``harmonic`` (fill a field from samples),
``demo`` (the built-in example). Bad input ends with exit code 2 and one line
``manifill: error: ...`` on standard error, never a traceback; nothing is left
half-written.
"""

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from . import __version__
from .errors import ManifillError, SampleError
from .harmonic import ON_EMPTY, HarmonicSolver
from .laplacian import WEIGHTS
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
    from .io import MESH_FORMATS, VALUE_FORMATS, write_mesh, write_values

    out = Path(args.output)
    ext = out.suffix.lower()
    if ext not in VALUE_FORMATS and not (ext in MESH_FORMATS and MESH_FORMATS[ext][1]):
        return _err(f"{out.name}: the output must be .ply, .vtu or .vtk (mesh with fields) or .csv/.npy (values)")
    if not out.parent.is_dir():
        return _err(f"folder {out.parent} does not exist; create it first or choose another output path")
    V, F, S = _load(args)
    t0 = time.perf_counter()
    solver = HarmonicSolver(V, F, S.idx, weights=args.weights, solver=args.solver, on_empty=args.on_empty)
    X = solver.solve(S.vals)
    seconds = time.perf_counter() - t0
    if ext in VALUE_FORMATS:
        write_values(out, X, S.names)
    else:
        fields = {name: X[:, j] for j, name in enumerate(S.names)}
        fixed = np.zeros(len(V), dtype=bool)
        fixed[S.idx] = True
        mask_name = next(m for m in ("fixed", "fixed_mask", "manifill_fixed") if m not in fields)
        fields[mask_name] = fixed
        written = write_mesh(out, V, F, fields)
        renamed = {a: b for a, b in written.items() if a != b}
        if renamed:
            print("note: fields renamed for the format: " + ", ".join(f"{a!r} -> {b!r}" for a, b in renamed.items()))
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
    lo, hi = np.nanmin(X, axis=0), np.nanmax(X, axis=0)
    for j, name in enumerate(S.names):
        print(f"  {name}: range [{lo[j]:.6g}, {hi[j]:.6g}]  (samples [{S.vals[:, j].min():.6g}, "
              f"{S.vals[:, j].max():.6g}])")
    print(f"wrote {out}")
    return 0


def cmd_demo(args):
    """``manifill demo``."""
    from .demo import run_demo

    report = run_demo(args.output)
    print(report["text"])
    return 0


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
    s.add_argument("mesh", help="mesh file (.off .obj .ply .stl .vtk .vtu)")
    s.add_argument("samples", help="samples: .csv with header vertex,value[,...] or x,y,z,value[,...]; .npz; .npy")
    s.add_argument("-o", "--output", required=True,
                   help="output: .ply/.vtu/.vtk (mesh with named fields) or .csv/.npy (values)")
    s.add_argument("--weights", choices=WEIGHTS, default="cotan", help="Laplacian weights (default: cotan)")
    s.add_argument("--solver", choices=SOLVERS, default="auto", help="linear solver (default: auto)")
    s.add_argument("--on-empty", choices=ON_EMPTY, default="error",
                   help="a component without samples: error (default) or fill with NaN")
    s.add_argument("--duplicates", choices=("error", "mean"), default="error",
                   help="two samples on one vertex with different values: error (default) or average")
    s.add_argument("--max-snap", type=float, default=None,
                   help="largest accepted distance from a sample position to its vertex "
                        "(default: 5%% of the mesh's bounding-box diagonal plus its vertex spacing)")
    s.add_argument("--clean", action="store_true",
                   help="weld coinciding vertices and drop unused vertices and zero-area faces first")
    s.set_defaults(func=cmd_harmonic)

    s = sub.add_parser("demo", help="run the built-in example (nothing downloaded)",
                       description="Reconstruct a known field on a generated sphere, write the results "
                                   "and print the error.")
    s.add_argument("-o", "--output", default="manifill-demo", help="output folder (default: ./manifill-demo)")
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


if __name__ == "__main__":
    sys.exit(main())
