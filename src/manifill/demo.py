"""The built-in demonstration: a known field reconstructed on a generated sphere.

Nothing is downloaded. The demo samples ``f = sin(2x) + yz + 0.5 cos(3y)`` on a
40,962-vertex icosphere, reconstructs the rest and reports the error against the
known field:

- at 100 scattered vertices with the default (``reconstruct``: the biharmonic fill
  projected onto the samples' range);
- at the same vertices with the paper's pipeline (``method='gvf-harmonic'``: gradual
  variation check, Delaunay partition through the samples, values on the curves,
  harmonic patches);
- at the same vertices with the Gaussian process (a mean and a std);
- at the same 100 vertices with point constraints only (the naive baseline);
- on three whole great circles (values known along a curve network): every
  patch is filled from exact values all around its boundary.

It writes the sphere with all fields (``sphere.vtu``, ``sphere.ply``), the scattered
samples as a CSV of positions (to try the command line on), and ``report.txt``.

With pyvista installed (the ``[viz]`` extra) it also redraws the paper's examples
(:func:`manifill.viz.figures.paper_figures`) on the real meshes that ship inside
pyvista (nothing is downloaded), Loop-subdivided:
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
from .io import CURVE_MASK, PATCH_LABEL, SAMPLE_MASK, write_mesh
from .mesh.shapes import great_circle_vertices, icosphere
from .viz.figures import paper_figures

__all__ = ["run_demo", "demo_field"]


#: The extra that installs a module the pictures need.
EXTRA_OF = {"pyvista": "viz", "vtk": "viz", "vtkmodules": "viz", "igl": "volume", "tetgen": "volume"}


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


def run_demo(outdir="manifill-demo", *, level=6, samples=100, seed=0, pictures=True):
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
    pictures : bool, optional
        Also the paper's figures and the viewer (they need the ``[viz]`` and ``[volume]`` extras).

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
    free = np.ones(len(V), dtype=bool)
    free[scattered] = False
    for key, options in (("default", {}), ("pipeline", {"method": "gvf-harmonic"})):
        t0 = time.perf_counter()
        rec = reconstruct(V, F, scattered, truth[scattered], **options)
        report[key] = {
            "fixed": int(scattered.size),
            "relative_rmse": _relative_rmse(rec.values, truth, free),
            "max_error": float(np.abs(rec.values - truth).max()),
            "seconds": time.perf_counter() - t0,
            "solver": rec.report["fill"]["solver"],
        }
        fields[key] = rec.values
    fields[CURVE_MASK] = rec.on_curve  # the pipeline's curves and patches
    fields[PATCH_LABEL] = rec.components
    t0 = time.perf_counter()
    # the Gaussian process, a mean and a std; the range given (fitting it costs a factorisation per trial range)
    gp = reconstruct(V, F, scattered, truth[scattered], method="gp", gp={"range": 1.0})
    inside = np.abs(gp.values - truth)[free] <= 1.645 * gp.std[free]
    report["gp"] = {"fixed": int(scattered.size), "relative_rmse": _relative_rmse(gp.values, truth, free),
                    "max_error": float(np.abs(gp.values - truth).max()), "seconds": time.perf_counter() - t0,
                    "solver": "range 1 given, sigma fitted", "coverage90": float(inside.mean())}
    fields["gp"], fields["gp_std"] = gp.values, gp.std
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
            for k, label in (("default", f"{samples} points, default"), ("pipeline", f"{samples} points, pipeline"),
                             ("points", f"{samples} points, harmonic"), ("gp", f"{samples} points, gp"),
                             ("curves", "three great circles"))
        ),
        f"  gp's 90% band (mean +/- 1.645 std) holds the truth at {report['gp']['coverage90']:.1%} of the "
        f"unsampled vertices (a smooth field: the band is wide)",
        "  (relative RMSE: RMSE over the unfixed vertices divided by the range of f)",
        f"  wrote {', '.join(str(f) for f in files)}",
        f"  try: manifill reconstruct {files[1]} {files[2]} -o {out / 'mine.vtu'}",
    ]
    figures = {}
    try:
        if pictures:
            paper_figures(out, demo_field, "sin(2x) + yz + 0.5 cos(3y)", into=figures)
    except ImportError as exc:  # what is missing, by name, and what was written before it
        missing = exc.name or str(exc)
        extra = EXTRA_OF.get((exc.name or "").split(".")[0], "all")
        what = "the rest need" if figures.get("files") else "the paper's figures need"
        figures.setdefault("lines", []).append(f"  pictures: {what} {missing} (pip install 'manifill[{extra}]')")
    lines[-2:-2] = figures.get("lines", [])
    files += [Path(f) for f in figures.get("files", [])]
    lines[-2] = f"  wrote {', '.join(str(f) for f in files)}"
    files[3].write_text("\n".join(lines) + "\n")
    report["files"] = [str(f) for f in files]
    report["text"] = "\n".join(lines)
    return report
