"""The built-in demonstration: a known field reconstructed on a generated sphere.

Nothing is downloaded. The demo samples ``f = sin(2x) + yz + 0.5 cos(3y)`` on a
40,962-vertex icosphere in two ways, fills the rest harmonically and reports the
error against the known field:

- at 100 scattered vertices with the paper's pipeline (``reconstruct``: gradual
  variation check, Delaunay partition through the samples, values on the
  curves, harmonic patches);
- at the same 100 vertices with point constraints only (the naive baseline);
- on three whole great circles (values known along a curve network): every
  patch is filled from exact values all around its boundary.

It writes the sphere with all fields (``sphere.vtu``, ``sphere.ply``), the scattered
samples as a CSV of positions (to try the command line on), and ``report.txt``.

With pyvista installed (the ``[viz]`` extra) it also redraws the paper's examples on
the real meshes that ship inside pyvista (nothing is downloaded), Loop-subdivided:
five samples joined by one cycle on a sphere (Fig. 4.1); seven points on a closed
model, GVF against harmonic (Fig. 4.3); three components (Fig. 4.4); twelve guiding
points, their partition paths and the harmonic reconstruction (Figs. 4.5-4.7);
and one solid, filled from its surface. It writes them as PNGs and the last
surface as an interactive page, ``viewer.html``.
"""

import time
from pathlib import Path

import numpy as np

from .surface.harmonic import HarmonicSolver
from .surface.reconstruct import reconstruct
from .errors import WriteError
from .io.registry import CURVE_MASK, PATCH_LABEL, SAMPLE_MASK, write_mesh
from .mesh.shapes import great_circle_vertices, icosphere

__all__ = ["run_demo", "demo_field"]


def demo_field(V):
    """The demo's known field ``sin(2x) + yz + 0.5 cos(3y)``.

    Parameters
    ----------
    V : (n, 3) numpy array
        Positions.

    Returns
    -------
    (n,) numpy array
    """
    x, y, z = V[:, 0], V[:, 1], V[:, 2]
    return np.sin(2 * x) + y * z + 0.5 * np.cos(3 * y)


def _relative_rmse(x, truth, free):
    return float(np.sqrt(np.mean((x[free] - truth[free]) ** 2)) / np.ptp(truth))


def run_demo(outdir="manifill-demo", *, level=6, samples=100, seed=0):
    """Run the demonstration and write its files.

    Parameters
    ----------
    outdir : str or Path, optional
        Output folder, created if missing.
    level : int, optional
        Icosphere subdivisions (6: 40,962 vertices).
    samples : int, optional
        Number of scattered samples for the point-constrained baseline.
    seed : int, optional
        Seed of the scattered samples.

    Returns
    -------
    dict
        ``vertices``, the relative RMSE (RMSE over the unfixed vertices divided
        by the range of the field) and time of each reconstruction, and the
        ``files`` written.
    """
    out = Path(outdir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise WriteError(f"cannot use {out} as the demo's output folder ({exc.strerror}); choose another with -o") \
            from None
    V, F = icosphere(level)
    truth = demo_field(V)
    report = {"vertices": len(V), "faces": len(F)}
    fields = {"truth": truth}
    rng = np.random.default_rng(seed)
    scattered = np.sort(rng.choice(len(V), size=samples, replace=False))
    t0 = time.perf_counter()
    rec = reconstruct(V, F, scattered, truth[scattered])
    free = np.ones(len(V), dtype=bool)
    free[scattered] = False
    report["pipeline"] = {
        "fixed": int(scattered.size),
        "relative_rmse": _relative_rmse(rec.values, truth, free),
        "max_error": float(np.abs(rec.values - truth).max()),
        "seconds": time.perf_counter() - t0,
        "solver": rec.report["harmonic"]["solver"],
    }
    fields["reconstruct_points"] = rec.values
    fields[CURVE_MASK] = rec.on_curve
    fields[PATCH_LABEL] = rec.components
    for name, b in (("curves", great_circle_vertices(V, F)), ("points", scattered)):
        t0 = time.perf_counter()
        solver = HarmonicSolver(V, F, b)
        x = solver.solve(truth[b])
        seconds = time.perf_counter() - t0
        free = np.ones(len(V), dtype=bool)
        free[b] = False
        report[name] = {
            "fixed": int(b.size),
            "relative_rmse": _relative_rmse(x, truth, free),
            "max_error": float(np.abs(x - truth).max()),
            "seconds": seconds,
            "solver": solver.report["solver"],
        }
        fields[f"harmonic_{name}"] = x
        fields[SAMPLE_MASK if name == "points" else "circle_mask"] = ~free
    files = [out / "sphere.vtu", out / "sphere.ply", out / "samples.csv", out / "report.txt"]
    write_mesh(files[0], V, F, fields)
    write_mesh(files[1], V, F, fields)
    pts = V[scattered]
    table = np.column_stack([pts, truth[scattered]])
    np.savetxt(files[2], table, fmt="%.17g", delimiter=",", header="x,y,z,value", comments="")
    lines = [
        f"manifill demo: f = sin(2x) + yz + 0.5 cos(3y) on an icosphere with {len(V):,} vertices",
        *(
            f"  from {report[k]['fixed']:>5,} vertices ({label:<20s}): relative RMSE "
            f"{report[k]['relative_rmse']:.4f}, max error {report[k]['max_error']:.4f}, "
            f"{report[k]['seconds']:.2f} s ({report[k]['solver']})"
            for k, label in (("pipeline", "100 points, pipeline"), ("points", "100 points, harmonic"),
                             ("curves", "three great circles"))
        ),
        "  (relative RMSE: RMSE over the unfixed vertices divided by the range of f)",
        f"  wrote {', '.join(str(f) for f in files)}",
        f"  try: manifill reconstruct {files[1]} {files[2]} -o {out / 'mine.vtu'}",
    ]
    try:
        figures = paper_figures(out)
    except ImportError:
        figures = None
        lines.insert(-2, "  pictures: install pyvista (pip install 'manifill[viz]') for the paper's figures")
    if figures:
        lines[-2:-2] = figures["lines"]
        files += [Path(f) for f in figures["files"]]
    lines[-2] = f"  wrote {', '.join(str(f) for f in files)}"
    files[3].write_text("\n".join(lines) + "\n")
    report["files"] = [str(f) for f in files]
    report["text"] = "\n".join(lines)
    return report


def _example_mesh(name, levels):
    """A mesh that ships inside pyvista, welded and Loop-subdivided, centred and scaled to unit diagonal."""
    import pyvista.examples as ex

    from .io.registry import read_mesh
    from .mesh.subdivide import subdivide
    from .mesh.topology import clean_mesh
    from .validate import bbox_diagonal

    V, F = read_mesh(Path(ex.__file__).with_name(name))
    V, F, _ = clean_mesh(V, F)
    V, F = subdivide(V, F, levels=levels)
    return (V - V.mean(axis=0)) / bbox_diagonal(V), F


def _far_points(V, k, seed):
    """``k`` well spread vertices (farthest-point sampling from a random start)."""
    rng = np.random.default_rng(seed)
    chosen = [int(rng.integers(len(V)))]
    d = np.linalg.norm(V - V[chosen[0]], axis=1)
    for _ in range(k - 1):
        chosen.append(int(np.argmax(d)))
        d = np.minimum(d, np.linalg.norm(V - V[chosen[-1]], axis=1))
    return np.array(sorted(chosen))


def paper_figures(out):
    """The paper's examples on pyvista's meshes, as PNGs, plus ``viewer.html``; returns files and report lines.

    Raises
    ------
    ImportError
        Without pyvista.
    """
    from .viz.render import render_panels, render_slices
    from .solid.reconstruct_volume import reconstruct_volume
    from .viz.viewer import write_html

    _ = __import__("pyvista")
    out = Path(out)
    files, lines = [], ["  the paper's examples on pyvista's meshes (field sin(2x) + yz + 0.5 cos(3y)):"]

    def err(x, truth, fixed):
        free = np.ones(len(truth), dtype=bool)
        free[fixed] = False
        ok = free & np.isfinite(x)
        return float(np.sqrt(np.mean((x[ok] - truth[ok]) ** 2)) / np.ptp(truth))

    # Fig. 4.1: five samples on a sphere joined by one closed cycle, which splits it in two
    V, F = _example_mesh("sphere.ply", 2)
    truth = demo_field(3 * V)
    idx = _far_points(V, 5, 1)
    r = reconstruct(V, F, idx, truth[idx], partition="cycle")
    path = out / "fig4_1_cycle.png"
    render_panels([dict(V=V, F=F, values=r.components.astype(float), samples=idx, curves=r.curves, name="patch",
                        title="5 samples, one cycle: the patches"),
                   dict(V=V, F=F, values=r.values, samples=idx, curves=r.curves, title="gvf-harmonic")],
                  path, size=(1100, 500), same_scale=False)
    files.append(path)
    lines.append(f"    Fig. 4.1 sphere ({len(V):,} vertices): 5 samples, {len(r.curves)} cycle paths, "
                 f"{r.report['partition']['patches']} patches -> {path.name}")

    # Fig. 4.3: seven points on a closed model (the nut, genus 1): GVF against harmonic fitting
    V, F = _example_mesh("nut.ply", 2)
    truth = demo_field(3 * V)
    idx = _far_points(V, 7, 2)
    g = reconstruct(V, F, idx, truth[idx], method="gvf")
    h = reconstruct(V, F, idx, truth[idx], method="harmonic")
    r = reconstruct(V, F, idx, truth[idx])
    path = out / "fig4_3_gvf_vs_harmonic.png"
    render_panels([dict(V=V, F=F, values=g.values, samples=idx, title="(a) GVF"),
                   dict(V=V, F=F, values=h.values, samples=idx, title="harmonic from the points"),
                   dict(V=V, F=F, values=r.values, samples=idx, curves=r.curves, title="(b) harmonic on GVF paths"),
                   dict(V=V, F=F, values=truth, title="the true field")], path, size=(1600, 450))
    files.append(path)
    lines.append(f"    Fig. 4.3 nut ({len(V):,} vertices, genus 1): 7 points; rel. RMSE GVF {err(g.values, truth, idx):.3f}, "
                 f"harmonic {err(h.values, truth, idx):.3f}, gvf-harmonic {err(r.values, truth, idx):.3f} -> {path.name}")

    # Fig. 4.4: a surface of three components; GVF on the paths, then the harmonic fitting
    parts = [_example_mesh("sphere.ply", 2), _example_mesh("nut.ply", 1), _example_mesh("sphere.ply", 1)]
    Vs, Fs, base = [], [], 0
    for j, (Vj, Fj) in enumerate(parts):
        Vs.append(Vj * (1.0 if j != 2 else 0.6) + np.array([1.3 * j, 0.0, 0.0]))
        Fs.append(Fj + base)
        base += len(Vj)
    V, F = np.concatenate(Vs), np.concatenate(Fs)
    truth = demo_field(2 * V)
    idx = np.concatenate([_far_points(Vs[j], 4, j) + sum(len(v) for v in Vs[:j]) for j in range(3)])
    r = reconstruct(V, F, idx, truth[idx], partition="cycle", curve_values="gvf")
    on_paths = np.where(r.on_curve, r.values, np.nan)
    path = out / "fig4_4_three_components.png"
    render_panels([dict(V=V, F=F, values=on_paths, samples=idx, curves=r.curves, colour_curves=True,
                        title="(a) GVF on the paths"),
                   dict(V=V, F=F, values=r.values, samples=idx, title="(b) harmonic fitting")],
                  path, size=(1400, 550), view=(0.2, -1.0, 0.6))
    files.append(path)
    lines.append(f"    Fig. 4.4 three components ({len(V):,} vertices): 12 samples, {len(r.curves)} paths, "
                 f"rel. RMSE {err(r.values, truth, idx):.3f} -> {path.name}")

    # Figs. 4.5-4.7: twelve guiding points, the partition paths joining them, the harmonic reconstruction
    V, F = _example_mesh("sphere.ply", 3)
    truth = demo_field(3 * V)
    idx = _far_points(V, 12, 3)
    r = reconstruct(V, F, idx, truth[idx])
    path = out / "fig4_5_7_guiding_points.png"
    render_panels([dict(V=V, F=F, values=None, samples=idx, title="Fig. 4.5: 12 guiding points"),
                   dict(V=V, F=F, values=None, samples=idx, curves=r.curves, title="Fig. 4.6: partition paths"),
                   dict(V=V, F=F, values=r.values, samples=idx, curves=r.curves, title="Fig. 4.7: reconstruction")],
                  path, size=(1500, 500))
    files.append(path)
    html_path = out / "viewer.html"
    write_html(html_path, V, F, r.values, samples=idx, curves=r.curves, title="manifill: 12 guiding points")
    files.append(html_path)
    lines.append(f"    Figs. 4.5-4.7 sphere ({len(V):,} vertices): 12 points, {len(r.curves)} paths, "
                 f"{r.report['partition']['patches']} patches, rel. RMSE {err(r.values, truth, idx):.3f} "
                 f"-> {path.name}, {html_path.name}")

    # one solid: the nut filled from samples on its surface, as voxels
    V, F = _example_mesh("nut.ply", 1)
    truth = demo_field(3 * V)
    idx = _far_points(V, 40, 4)
    vol = reconstruct_volume(V, F, idx, truth[idx], resolution=64)
    path = out / "solid_slices.png"
    render_slices(vol.values, vol.spacing, vol.origin, path)
    files.append(path)
    fill = vol.report["fill"]
    lines.append(f"    solid: the nut voxelised at {vol.values.shape}, {fill['voxels']:,} voxels filled from "
                 f"{fill['fixed']:,} boundary voxels ({fill['iterations'][0]} multigrid iterations) -> {path.name}")
    return {"files": [str(f) for f in files], "lines": lines}
