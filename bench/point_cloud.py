"""Point clouds against meshes: every method's error on the sphere's points without faces, and the time.

``python -m bench.point_cloud [--levels 5,7] [--k 300] [--methods ...]``: on icospheres, the field
``f = sin(3x) + yz`` sampled at ``k`` random vertices; every method run on the mesh ``(V, F)`` and on the cloud
``(V, None)`` (the same points, no faces), in one process, alternating, each timed end to end (the cloud's
Laplacian, mass and graph included). Prints the RMS error over all vertices relative to the field's range, the
ratio cloud / mesh, and the seconds. ``--random`` also runs a cloud of uniformly random points on the sphere
(no mesh of the same points to compare with; its error beside the mesh's of the same size), and
``--robust`` the robust-laplacian package's point-cloud Laplacian (``weights='robust'``) beside manifill's.
``--timing --levels 7``: the biharmonic alone, mesh and cloud alternated four times (the target's ratio).
"""

import argparse
import time

import numpy as np

import manifill
from manifill.mesh.pointcloud import Cloud
from manifill.mesh.shapes import icosphere

METHODS = ("default", "gvf-harmonic", "gvf", "harmonic", "biharmonic", "triharmonic", "rbf", "gp")


def field(P):
    return np.sin(3 * P[:, 0]) + P[:, 1] * P[:, 2]


def error(values, truth):
    return float(np.sqrt(np.nanmean((values - truth) ** 2)) / np.ptp(truth))


def timed(V, F, idx, method, **kw):
    t = time.perf_counter()
    r = manifill.reconstruct(V, F, idx, field(V[idx]), method=None if method == "default" else method, **kw)
    return error(r.values, field(V)), time.perf_counter() - t


def sphere_points(n, seed):
    P = np.random.default_rng(seed).normal(size=(n, 3))
    return P / np.linalg.norm(P, axis=1, keepdims=True)


def run(level, k, methods, repeats, robust, random):
    V, F = icosphere(level)
    idx = np.sort(np.random.default_rng(level).choice(len(V), k, replace=False))
    t = time.perf_counter()
    c = Cloud(V)
    build = time.perf_counter() - t
    print(f"\n{len(V):,} points, {k} samples; the cloud's operators alone: {build:.2f} s "
          f"({len(c.E):,} edges, {c.components} piece)")
    print(f"{'method':<14} {'mesh err':>9} {'cloud err':>9} {'ratio':>6} {'mesh s':>7} {'cloud s':>8} {'s ratio':>7}")
    rows = []
    for m in methods:
        mesh, cloud = [], []
        for _ in range(repeats):  # alternated: the machine's noise falls on both
            mesh.append(timed(V, F, idx, m))
            cloud.append(timed(V, None, idx, m))
        em, ec = mesh[0][0], cloud[0][0]
        tm, tc = min(s for _, s in mesh), min(s for _, s in cloud)
        rows.append(dict(method=m, n=len(V), mesh_err=em, cloud_err=ec, mesh_s=tm, cloud_s=tc))
        print(f"{m:<14} {em:>9.5f} {ec:>9.5f} {ec / em:>6.3f} {tm:>7.2f} {tc:>8.2f} {tc / tm:>7.2f}")
        if robust and m in ("harmonic", "biharmonic"):
            er, tr = timed(V, None, idx, m, weights="robust")
            print(f"{m + ' robust':<14} {'':>9} {er:>9.5f} {er / em:>6.3f} {'':>7} {tr:>8.2f} {tr / tm:>7.2f}")
    if random:
        P = sphere_points(len(V), level)
        ridx = np.sort(np.random.default_rng(level + 1).choice(len(P), k, replace=False))
        print(f"uniformly random points on the sphere ({len(P):,}; no mesh: errors beside the icosphere mesh's)")
        for row in rows:
            if row["method"] in ("biharmonic", "harmonic", "gvf-harmonic", "gp", "rbf"):
                e, s = timed(P, None, ridx, row["method"])
                print(f"{row['method']:<14} {row['mesh_err']:>9.5f} {e:>9.5f} {e / row['mesh_err']:>6.3f} "
                      f"{'':>7} {s:>8.2f}")
    return rows


def timing(level, k, repeats, method="biharmonic"):
    """The target's figure: ``method`` on the mesh and on the cloud, alternated ``repeats`` times, minimum each."""
    V, F = icosphere(level)
    idx = np.sort(np.random.default_rng(7).choice(len(V), k, replace=False))
    mesh, cloud = [], []
    for _ in range(repeats):
        mesh.append(timed(V, F, idx, method)[1])
        cloud.append(timed(V, None, idx, method)[1])
        print(f"{method} at {len(V):,}: mesh {mesh[-1]:.2f} s, cloud {cloud[-1]:.2f} s, {cloud[-1] / mesh[-1]:.2f}x",
              flush=True)
    ratios = np.array(cloud) / np.array(mesh)
    print(f"minimum: mesh {min(mesh):.2f} s, cloud {min(cloud):.2f} s, {min(cloud) / min(mesh):.2f}x; median ratio "
          f"{np.median(ratios):.2f}")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--levels", default="5,7")
    p.add_argument("--k", type=int, default=300)
    p.add_argument("--methods", default=",".join(METHODS))
    p.add_argument("--repeats", type=int, default=2)
    p.add_argument("--robust", action="store_true")
    p.add_argument("--random", action="store_true")
    p.add_argument("--timing", action="store_true", help="only the biharmonic's time, mesh and cloud alternated")
    a = p.parse_args(argv)
    if a.timing:
        for level in (int(x) for x in a.levels.split(",")):
            timing(level, a.k, max(a.repeats, 4))
        return
    for level in (int(x) for x in a.levels.split(",")):
        run(level, a.k, a.methods.split(","), a.repeats, a.robust, a.random)


if __name__ == "__main__":
    main()
