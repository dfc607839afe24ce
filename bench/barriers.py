"""Barriers: every method's error on a field that jumps across a wall, with the wall given and without it.

``python -m bench.barriers [--n 61] [--level 5] [--k 150]``: two cases, each method run without and with
``barriers=`` in one process:

Rows: every method, and ``gp-bakka`` (the gp with ``gp={'barrier': 'bakka'}``: the mesh whole, the faces along
the barrier at a tenth of the range).

- *plane*: the unit square (an n x n grid), ``f = y + [x > 1/2]`` (a step of 1 across the wall x = 1/2, which
  spans the square), the wall's vertices as one barrier path;
- *sphere*: a latitude-longitude sphere (``uv_sphere(12 level, 24 level)``: a globe's grid, whose meridians are
  paths of edges), the longitude times the squared distance from the axis, ``f = atan2(y, x) (1 - z^2)``,
  which jumps by ``2 pi (1 - z^2)`` across the half-meridian ``y = 0, x < 0`` and is smooth elsewhere: the
  barrier is that arc from pole to pole (a line that does not part the sphere: the field goes round its ends).

Errors are RMS over the vertices off the wall (where the field has one value) relative to the field's range.
Also the *slit* check: a square with a slit from its edge to its middle, given as a barrier on the whole mesh
and as the mesh cut by hand (its vertices duplicated along the slit): the largest difference of the values off
the slit.
"""

import argparse
import time

import numpy as np

import manifill
from manifill.mesh.shapes import grid, uv_sphere
from manifill.surface.engine import reconstruct_surface
from manifill.surface.surface import Surface

METHODS = ("default", "gvf-harmonic", "gvf", "harmonic", "biharmonic", "triharmonic", "gp", "gp-bakka", "rbf")
#: a row's method and options (gp-bakka: the gp with Bakka's barrier model instead of the cut)
RUNS = {"default": (None, {}), "gp-bakka": ("gp", {"gp": {"barrier": "bakka"}})}


def plane(n):
    V, F = grid(n)
    wall = np.flatnonzero(np.isclose(V[:, 0], 0.5))
    return V, F, V[:, 1] + (V[:, 0] > 0.5), [wall[np.argsort(V[wall, 1])]], ~np.isclose(V[:, 0], 0.5)


def sphere(level):
    V, F = uv_sphere(12 * level, 24 * level)  # a globe's grid: its meridians are paths of edges
    arc = np.flatnonzero(np.isclose(V[:, 1], 0.0, atol=1e-9) & (V[:, 0] <= 1e-9))
    off = ~np.isin(np.arange(len(V)), arc)
    return V, F, np.arctan2(V[:, 1], V[:, 0]) * (1 - V[:, 2] ** 2), [arc[np.argsort(V[arc, 2])]], off


def slit_mesh(n):
    """A grid with a slit along x = 1/2 from y = 0 to y = 1/2, cut by hand: the faces right of the slit take new
    copies of its vertices (all but the tip), numbered after the grid's."""
    V, F = grid(n)
    slit = np.flatnonzero(np.isclose(V[:, 0], 0.5) & (V[:, 1] < 0.5 - 1e-9))
    new = {int(v): len(V) + j for j, v in enumerate(slit[np.argsort(V[slit, 1])])}
    right = V[F].mean(axis=1)[:, 0] > 0.5
    F2 = F.copy()
    for f in np.flatnonzero(right):
        F2[f] = [new.get(int(v), v) for v in F[f]]
    V2 = np.vstack([V, V[sorted(new, key=new.get)]])
    tip = np.flatnonzero(np.isclose(V[:, 0], 0.5) & np.isclose(V[:, 1], 0.5))
    path = np.concatenate([slit[np.argsort(V[slit, 1])], tip])  # the barrier runs up to the tip
    return V, F, V2, F2, [path], ~np.isin(np.arange(len(V)), slit)


def error(x, truth, off):
    return float(np.sqrt(np.mean((x[off] - truth[off]) ** 2)) / np.ptp(truth))


def run_case(name, V, F, f, barriers, off, k, methods):
    rng = np.random.default_rng(1)
    idx = np.sort(rng.choice(np.flatnonzero(off), k, replace=False))
    print(f"\n{name}: {len(V):,} vertices, {k} samples")
    print(f"{'method':<14} {'without':>9} {'with':>9} {'ratio':>7} {'s without':>10} {'s with':>8}")
    for m in methods:
        row = []
        for b in (None, barriers):
            t = time.perf_counter()
            method, kw = RUNS.get(m, (m, {}))
            r = manifill.reconstruct(V, F, idx, f[idx], method=method, barriers=b, **kw)
            row.append((error(r.values, f, off), time.perf_counter() - t))
        (e0, t0), (e1, t1) = row
        print(f"{m:<14} {e0:>9.4f} {e1:>9.4f} {e1 / e0:>7.3f} {t0:>10.2f} {t1:>8.2f}")


def slit(n, k, methods):
    V, F, V2, F2, barriers, off = slit_mesh(n)
    f = np.where((V[:, 0] > 0.5) & (V[:, 1] < 0.5), 1.0, 0.0) + V[:, 0]
    rng = np.random.default_rng(2)
    idx = np.sort(rng.choice(np.flatnonzero(off), k, replace=False))
    print(f"\nslit: {len(V):,} vertices, the slit's {len(barriers[0])} vertices; barrier vs the mesh cut by hand")
    for m in methods:
        if m in ("rbf", "gp-bakka"):
            continue  # the slit leaves one piece: rbf refuses the barrier (it works in space); bakka does not cut
        a = manifill.reconstruct(V, F, idx, f[idx], method=None if m == "default" else m, barriers=barriers)
        # the hand-cut mesh is unwelded (its copies coincide), which reconstruct refuses: the engine takes it
        b = reconstruct_surface(Surface.from_mesh(V2, F2, check=False), idx, f[idx][:, None],
                                method=None if m == "default" else m)
        d = float(np.abs(a.values[off] - b.values[:len(V), 0][off]).max())
        print(f"{m:<14} max difference off the slit {d:.1e}; errors {error(a.values, f, off):.6f} / "
              f"{error(b.values[:len(V), 0], f, off):.6f}")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=61)
    p.add_argument("--level", type=int, default=5)
    p.add_argument("--k", type=int, default=150)
    p.add_argument("--methods", default=",".join(METHODS))
    a = p.parse_args(argv)
    methods = a.methods.split(",")
    run_case("plane", *plane(a.n), a.k, methods)
    run_case("sphere", *sphere(a.level), a.k, [m for m in methods if m != "rbf"])
    slit(a.n, a.k, methods)


if __name__ == "__main__":
    main()
