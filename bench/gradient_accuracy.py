"""Gradients of fields on the sphere: the per-vertex gradient's error under refinement, and the time per size.

``python -m bench.gradient_accuracy [--levels 3,4,5,6,7,8]``: on icospheres, the field ``f = sin(3x) + yz`` at the
vertices; the per-vertex gradient (``manifill.mesh.gradients``, area-weighted, tangent) against the exact tangent
gradient (max and RMS of the error's length, relative to the largest true gradient), the observed rate per
halving of the edge, and the seconds of the per-face and per-vertex gradients beside libigl's ``grad`` (build
and apply) in the same run.
"""

import argparse
import time

import numpy as np

from manifill.mesh.gradients import cell_gradients, gradient_operator, vertex_gradients
from manifill.mesh.shapes import icosphere
from manifill.surface.curve_values import vertex_normals


def exact(V):
    n = V / np.linalg.norm(V, axis=1, keepdims=True)
    x, y, z = V.T
    g = np.column_stack([3 * np.cos(3 * x), z, y])
    return np.sin(3 * x) + y * z, g - np.sum(g * n, axis=1, keepdims=True) * n


def run(level):
    V, F = icosphere(level)
    f, want = exact(V)
    t = time.perf_counter()
    G, area = gradient_operator(V, F)
    gf = cell_gradients(G, f)
    t_face = time.perf_counter() - t
    gv = vertex_gradients(F, area, gf, len(V), normals=vertex_normals(V, F))
    t_vertex = time.perf_counter() - t
    err = np.linalg.norm(gv - want, axis=1) / np.linalg.norm(want, axis=1).max()
    out = {"n": len(V), "max": float(err.max()), "rms": float(np.sqrt(np.mean(err ** 2))), "face_s": t_face,
           "vertex_s": t_vertex}
    try:
        import igl
    except ImportError:
        return out
    t = time.perf_counter()
    Gi = igl.grad(V, F)
    gi = np.asarray(Gi @ f).reshape(3, len(F)).T
    out["igl_s"] = time.perf_counter() - t
    out["igl_diff"] = float(np.abs(gi - gf).max() / np.abs(gi).max())
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--levels", default="3,4,5,6,7,8")
    a = p.parse_args(argv)
    prev = None
    for level in (int(x) for x in a.levels.split(",")):
        r = run(level)
        rate = "" if prev is None else (f", rate {np.log2(prev['rms'] / r['rms']):.2f} (RMS) "
                                        f"{np.log2(prev['max'] / r['max']):.2f} (max)")
        igl = f", igl.grad {r['igl_s']:.3f} s (per face equal to {r['igl_diff']:.1e})" if "igl_s" in r else ""
        print(f"n={r['n']:,}: per-vertex error max {r['max']:.2e}, RMS {r['rms']:.2e}{rate}; per face "
              f"{r['face_s']:.3f} s, per vertex {r['vertex_s']:.3f} s{igl}", flush=True)
        prev = r


if __name__ == "__main__":
    main()
