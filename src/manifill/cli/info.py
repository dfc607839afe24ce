"""``manifill info MESH``: what is in a mesh."""

import json

from ..io import read_mesh
from ..mesh.topology import mesh_info
from .options import MESH_HELP

__all__ = ["add_parser", "run"]


def add_parser(sub):
    """Register ``manifill info``."""
    s = sub.add_parser("info", help="counts, components, boundary loops, genus of a mesh",
                       description="Print what is in a mesh: counts, connected components with sizes, "
                                   "boundary loops, non-manifold edges, bounding box, Euler characteristic "
                                   "and genus per closed component.")
    s.add_argument("mesh", help=f"mesh file ({MESH_HELP})")
    s.add_argument("--json", action="store_true", help="print as JSON")
    s.set_defaults(func=run)


def run(args):
    """``manifill info MESH``."""
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
