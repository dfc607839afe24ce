"""The paper's figures redrawn on the real meshes that ship inside pyvista (the ``[viz]`` extra; nothing downloaded).

:func:`paper_figures` samples a known field on pyvista's meshes, Loop-subdivided,
and draws: five samples joined by one cycle on a sphere (Fig. 4.1); seven points
on a closed model, GVF against harmonic (Fig. 4.3); three components (Fig. 4.4);
twelve guiding points, their partition paths and the harmonic reconstruction
(Figs. 4.5-4.7); and one solid, filled from its surface. It writes them as PNGs
and the last surface as an interactive page, ``viewer.html``. The demo
(:func:`manifill.demo.run_demo`) calls it with its own field.
"""

from pathlib import Path

import numpy as np

from ..io import read_mesh
from ..mesh.clean import clean_mesh
from ..mesh.subdivide import subdivide
from ..solid.reconstruct_volume import reconstruct_volume
from ..surface.reconstruct import reconstruct
from ..validate import bbox_diagonal
from .render import render_panels, render_slices
from .viewer import write_html

__all__ = ["paper_figures", "example_mesh", "far_points"]


def example_mesh(name, levels):
    """A mesh that ships inside pyvista, welded and Loop-subdivided, centred and scaled to unit diagonal.

    Parameters
    ----------
    name : str
        A file of ``pyvista.examples`` (``"sphere.ply"``, ``"nut.ply"``).
    levels : int
        Loop subdivisions.

    Returns
    -------
    V : (n, 3) float64 numpy array
    F : (m, 3) int64 numpy array

    Raises
    ------
    ImportError
        Without pyvista.
    """
    import pyvista.examples as ex

    V, F = read_mesh(Path(ex.__file__).with_name(name))
    V, F, _ = clean_mesh(V, F)
    V, F = subdivide(V, F, levels=levels)
    return (V - V.mean(axis=0)) / bbox_diagonal(V), F


def far_points(V, k, seed):
    """``k`` well spread vertices (farthest-point sampling from a random start).

    Parameters
    ----------
    V : (n, 3) numpy array
    k : int
    seed : int
        Seed of the random start.

    Returns
    -------
    (k,) int numpy array
        Sorted vertex indices.

    Examples
    --------
    >>> x = np.array([0.0, 1.0, 0.1, 0.5, 0.45])  # from vertex 4: then the ends 0 and 1
    >>> far_points(np.column_stack([x, 0 * x, 0 * x]), 3, 0).tolist()
    [0, 1, 4]
    """
    rng = np.random.default_rng(seed)
    chosen = [int(rng.integers(len(V)))]
    d = np.linalg.norm(V - V[chosen[0]], axis=1)
    for _ in range(k - 1):
        chosen.append(int(np.argmax(d)))
        d = np.minimum(d, np.linalg.norm(V - V[chosen[-1]], axis=1))
    return np.array(sorted(chosen))


def paper_figures(out, field, label, *, into=None):
    """The paper's examples on pyvista's meshes, as PNGs, plus ``viewer.html``; returns files and report lines.

    Parameters
    ----------
    out : str or Path
        An existing folder.
    field : callable
        The known field: ``(n, 3)`` positions to ``(n,)`` values (it is sampled
        at a few vertices and the error of each reconstruction is measured on it).
    label : str
        The field's formula, for the report lines.
    into : dict, optional
        Filled as the work goes (``files``, ``lines``): what was written before an ImportError stops it.

    Returns
    -------
    dict
        ``files`` (the paths written, as text) and ``lines`` (the report lines).

    Raises
    ------
    ImportError
        Without pyvista.
    """
    into = {} if into is None else into
    files, lines = into.setdefault("files", []), into.setdefault("lines", [])
    _ = __import__("pyvista")
    out = Path(out)
    lines.append(f"  the paper's examples on pyvista's meshes (field {label}):")

    def err(x, truth, fixed):
        free = np.ones(len(truth), dtype=bool)
        free[fixed] = False
        ok = free & np.isfinite(x)
        return float(np.sqrt(np.mean((x[ok] - truth[ok]) ** 2)) / np.ptp(truth))

    # the paper's pipeline (as the default was before issue 37: monotone curve values, bounded by the samples)
    pipe = dict(method="gvf-harmonic", curve_values="monotone", bounds="samples")

    # Fig. 4.1: five samples on a sphere joined by one closed cycle, which splits it in two
    V, F = example_mesh("sphere.ply", 2)
    truth = field(3 * V)
    idx = far_points(V, 5, 1)
    r = reconstruct(V, F, idx, truth[idx], partition="cycle", **pipe)
    path = out / "fig4_1_cycle.png"
    render_panels([dict(V=V, F=F, values=r.components.astype(float), samples=idx, curves=r.curves, name="patch",
                        kind="category", title="5 samples, one cycle: the patches"),
                   dict(V=V, F=F, values=r.values, samples=idx, curves=r.curves, title="gvf-harmonic")],
                  path, size=(1100, 500), same_scale=False)
    files.append(path)
    lines.append(f"    Fig. 4.1 sphere ({len(V):,} vertices): 5 samples, {len(r.curves)} cycle paths, "
                 f"{r.report['partition']['patches']} patches -> {path.name}")

    # Fig. 4.3: seven points on a closed model (the nut, genus 1): GVF against harmonic fitting
    V, F = example_mesh("nut.ply", 2)
    truth = field(3 * V)
    idx = far_points(V, 7, 2)
    g = reconstruct(V, F, idx, truth[idx], method="gvf")
    h = reconstruct(V, F, idx, truth[idx], method="harmonic")
    r = reconstruct(V, F, idx, truth[idx], **pipe)
    path = out / "fig4_3_gvf_vs_harmonic.png"
    render_panels([dict(V=V, F=F, values=g.values, samples=idx, title="(a) GVF"),
                   dict(V=V, F=F, values=h.values, samples=idx, title="(b) harmonic from the points"),
                   dict(V=V, F=F, values=r.values, samples=idx, curves=r.curves, title="(c) harmonic on GVF paths"),
                   dict(V=V, F=F, values=truth, title="(d) the true field")], path, size=(1600, 480))
    files.append(path)
    lines.append(f"    Fig. 4.3 nut ({len(V):,} vertices, genus 1): 7 points; rel. RMSE GVF "
                 f"{err(g.values, truth, idx):.3f}, harmonic {err(h.values, truth, idx):.3f}, gvf-harmonic "
                 f"{err(r.values, truth, idx):.3f} -> {path.name}")

    # Fig. 4.4: a surface of three components; GVF on the paths, then the harmonic fitting
    parts = [example_mesh("sphere.ply", 2), example_mesh("nut.ply", 1), example_mesh("sphere.ply", 1)]
    Vs, Fs, base = [], [], 0
    for j, (Vj, Fj) in enumerate(parts):
        # side by side, the small sphere below between them: a compact group that fills its panel
        Vs.append(Vj * (1.0 if j != 2 else 0.6) + np.array([[0.0, 0.0, 0.0], [1.35, 0.0, 0.0], [0.7, 0.0, -1.05]][j]))
        Fs.append(Fj + base)
        base += len(Vj)
    V, F = np.concatenate(Vs), np.concatenate(Fs)
    truth = field(2 * V)
    view = np.array([0.3, -1.0, 0.45])
    idx = np.concatenate([_facing(Vs[j], view, 4, j) + sum(len(v) for v in Vs[:j]) for j in range(3)])
    r = reconstruct(V, F, idx, truth[idx], method="gvf-harmonic", partition="cycle", curve_values="gvf")
    on_paths = np.where(r.on_curve, r.values, np.nan)
    path = out / "fig4_4_three_components.png"
    render_panels([dict(V=V, F=F, values=on_paths, samples=idx, curves=r.curves, colour_curves=True,
                        title="(a) GVF on the paths (grey: no value yet)"),
                   dict(V=V, F=F, values=r.values, samples=idx, title="(b) harmonic fitting")],
                  path, size=(1400, 560), view=tuple(view))
    files.append(path)
    lines.append(f"    Fig. 4.4 three components ({len(V):,} vertices): 12 samples, {len(r.curves)} paths, "
                 f"rel. RMSE {err(r.values, truth, idx):.3f} -> {path.name}")

    # Figs. 4.5-4.7: twelve guiding points, the partition paths joining them, the harmonic reconstruction
    V, F = example_mesh("sphere.ply", 3)
    truth = field(3 * V)
    idx = far_points(V, 12, 3)
    r = reconstruct(V, F, idx, truth[idx], **pipe)
    d = reconstruct(V, F, idx, truth[idx])  # the default beside the paper's pipeline
    path = out / "fig4_5_7_guiding_points.png"
    render_panels([dict(V=V, F=F, values=None, samples=idx, title="Fig. 4.5: 12 guiding points"),
                   dict(V=V, F=F, values=None, samples=idx, curves=r.curves, title="Fig. 4.6: partition paths"),
                   dict(V=V, F=F, values=r.values, samples=idx, curves=r.curves, title="Fig. 4.7: reconstruction"),
                   dict(V=V, F=F, values=d.values, samples=idx, title="the default (biharmonic, projected)")],
                  path, size=(2000, 500))
    files.append(path)
    html_path = out / "viewer.html"
    write_html(html_path, V, F, r.values, samples=idx, curves=r.curves, title="manifill: 12 guiding points")
    files.append(html_path)
    lines.append(f"    Figs. 4.5-4.7 sphere ({len(V):,} vertices): 12 points, {len(r.curves)} paths, "
                 f"{r.report['partition']['patches']} patches, rel. RMSE {err(r.values, truth, idx):.3f} (the "
                 f"default: {err(d.values, truth, idx):.3f}) -> {path.name}, {html_path.name}")

    # one solid: the nut filled from samples on its surface, as voxels
    V, F = example_mesh("nut.ply", 1)
    truth = field(3 * V)
    idx = far_points(V, 40, 4)
    vol = reconstruct_volume(V, F, idx, truth[idx], resolution=64)
    path = out / "solid_slices.png"
    render_slices(vol.values, vol.spacing, vol.origin, path)
    files.append(path)
    fill = vol.report["fill"]
    lines.append(f"    solid: the nut voxelised at {vol.values.shape}, {fill['voxels']:,} voxels filled from "
                 f"{fill['fixed']:,} boundary voxels ({fill['iterations'][0]} multigrid iterations) -> {path.name}")
    into["files"] = [str(f) for f in files]
    return into


def _facing(V, view, k, seed):
    """``k`` well-spread vertices of the part of ``V`` that faces the camera (``view``: towards it), so that a
    figure's samples and the paths between them are in sight."""
    front = np.flatnonzero((V - V.mean(axis=0)) @ (view / np.linalg.norm(view)) > 0.25 * np.ptp(V, axis=0).max() / 2)
    return front[far_points(V[front], k, seed)]

