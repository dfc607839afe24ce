"""
The paper's figures, redrawn
============================

Chen & Luo's *Harmonic Functions for Data Reconstruction on 3D Manifolds* illustrates its pipeline with a few
figures: samples joined by curves that cut the surface into patches, values given to the curves (the gradually
varied fit, GVF), and every patch filled harmonically. :mod:`manifill.viz.figures` redraws them on meshes that ship
inside pyvista (``manifill demo`` writes them all); this example builds the same figures from its pieces at a
smaller resolution: :func:`~manifill.viz.figures.example_mesh` (a pyvista mesh, welded, Loop-subdivided and scaled
to unit diagonal), :func:`~manifill.viz.figures.far_points` (well-spread samples) and
:func:`~manifill.viz.render.render_panels` (panels side by side in one PNG, with the samples in red, the curves in
black and a colour bar each).

The paper's pipeline is ``method="gvf-harmonic"``; the default of :func:`manifill.reconstruct` (the biharmonic
fill kept within the samples' range) is drawn beside it in the last figure.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pyvista as pv

import manifill
from manifill.viz.figures import example_mesh, far_points
from manifill.viz.render import render_panels

pv.OFF_SCREEN = True
folder = Path(tempfile.mkdtemp())


def field(P):
    """The known field the demo uses, at 3x the unit-diagonal mesh's positions."""
    P = 3 * P
    return np.sin(2 * P[:, 0]) + P[:, 1] * P[:, 2] + 0.5 * np.cos(3 * P[:, 1])


def show_png(path, title):
    """The PNG render_panels wrote, as a matplotlib figure (what the gallery shows)."""
    pv.close_all()  # render_panels' own plotter, closed after its screenshot: not one for the gallery to capture
    image = plt.imread(path)
    h, w = image.shape[:2]
    fig, ax = plt.subplots(figsize=(w / 100, h / 100 + 0.4), layout="constrained")
    ax.imshow(image)
    ax.set_axis_off()
    ax.set_title(title)


pipeline = dict(method="gvf-harmonic", curve_values="monotone", bounds="samples")

# %%
# Fig. 4.1: five samples, one cycle
# ---------------------------------
# Five samples on a sphere, joined by one closed cycle of shortest paths (``partition="cycle"``), which cuts the
# sphere into two patches; each is filled harmonically with the cycle's values fixed.

V, F = example_mesh("sphere.ply", 1)
idx = far_points(V, 5, 1)
r = manifill.reconstruct(V, F, idx, field(V)[idx], partition="cycle", **pipeline)
print(r.report["partition"]["patches"], "patches,", len(r.curves), "paths;", len(V), "vertices")
path = folder / "fig4_1.png"
render_panels([dict(V=V, F=F, values=r.components.astype(float), samples=idx, curves=r.curves, name="patch",
                    kind="category", title="the patches"),
               dict(V=V, F=F, values=r.values, samples=idx, curves=r.curves, name="value",
                    title="gvf-harmonic")], path, size=(900, 420), same_scale=False, view=(0.3, -0.6, 1.0))
show_png(path, "Fig. 4.1: five samples joined by one cycle")

# %%
# Fig. 4.3: GVF against harmonic fitting
# --------------------------------------
# Seven points on a closed model of genus 1 (pyvista's nut): the gradually varied fit alone (``method="gvf"``), a
# harmonic fill from the seven points alone, the paper's pipeline (harmonic on the GVF paths), and the truth.

V, F = example_mesh("nut.ply", 1)
truth = field(V)
idx = far_points(V, 7, 2)
g = manifill.reconstruct(V, F, idx, truth[idx], method="gvf")
h = manifill.reconstruct(V, F, idx, truth[idx], method="harmonic")
p = manifill.reconstruct(V, F, idx, truth[idx], **pipeline)
print(manifill.mesh_info(V, F)["components"][0]["genus"], "= genus;", len(V), "vertices")
path = folder / "fig4_3.png"
render_panels([dict(V=V, F=F, values=g.values, samples=idx, title="(a) GVF"),
               dict(V=V, F=F, values=h.values, samples=idx, title="harmonic from the points"),
               dict(V=V, F=F, values=p.values, samples=idx, curves=p.curves, title="(b) harmonic on GVF paths"),
               dict(V=V, F=F, values=truth, title="the true field")], path, size=(1600, 460))
show_png(path, "Fig. 4.3: seven points on a torus-like nut")

# %%
# Figs. 4.5-4.7: twelve guiding points
# ------------------------------------
# Twelve points, the partition paths joining them, the pipeline's reconstruction, and manifill's default on the
# same samples.

V, F = example_mesh("sphere.ply", 2)
truth = field(V)
idx = far_points(V, 12, 3)
p = manifill.reconstruct(V, F, idx, truth[idx], **pipeline)
d = manifill.reconstruct(V, F, idx, truth[idx])
free = np.setdiff1d(np.arange(len(V)), idx)
for name, x in [("gvf-harmonic", p.values), ("default", d.values)]:
    print(f"{name}: relative RMSE {np.sqrt(np.mean((x - truth)[free] ** 2)) / np.ptp(truth):.3f}")
path = folder / "fig4_5_7.png"
render_panels([dict(V=V, F=F, values=None, samples=idx, title="Fig. 4.5: 12 guiding points"),
               dict(V=V, F=F, values=None, samples=idx, curves=p.curves, title="Fig. 4.6: partition paths"),
               dict(V=V, F=F, values=p.values, samples=idx, curves=p.curves, title="Fig. 4.7: reconstruction"),
               dict(V=V, F=F, values=d.values, samples=idx, title="the default (biharmonic)")],
              path, size=(1600, 460))
show_png(path, f"Figs. 4.5-4.7 on a sphere of {len(V):,} vertices")
plt.show()
