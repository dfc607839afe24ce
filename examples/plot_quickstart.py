"""
Quickstart: a field over a sphere from 60 samples
=================================================

The shortest path through manifill: a mesh as arrays (``V`` positions, ``F`` triangles), the vertices that were
measured and their values, and :func:`manifill.reconstruct`. The default fills the surface with the biharmonic
energy (smooth through the samples) and keeps every value within the samples' range; ``method="gvf-harmonic"`` is
the paper's pipeline, which cuts the surface by curves through the samples and fills each patch harmonically.
"""

import tempfile
from pathlib import Path

import numpy as np
import pyvista as pv

import manifill
from manifill.mesh.shapes import icosphere

pv.OFF_SCREEN = True

# %%
# Samples and the default reconstruction
# --------------------------------------

V, F = icosphere(5)  # (10242, 3) positions, (20480, 3) triangles
idx = np.random.default_rng(0).choice(len(V), 60, replace=False)  # sampled vertices
vals = np.sin(3 * V[idx, 0]) + V[idx, 2]  # their values

r = manifill.reconstruct(V, F, idx, vals)
assert np.allclose(r.values[idx], vals)  # exact at the samples
assert vals.min() <= r.values.min() and r.values.max() <= vals.max()  # never beyond their range
print(r)
print("fill:", {k: r.report["fill"][k] for k in ("unknowns", "solver", "energy")})
print(r.report["bounds"]["projected"][0], "values projected onto the samples' range")

# %%
# The paper's pipeline
# --------------------
# Its report says how the surface was cut; ``p.curves`` are the curves (vertex paths) and ``p.components`` the
# patch of every vertex.

p = manifill.reconstruct(V, F, idx, vals, method="gvf-harmonic")
print(p.report["partition"]["patches"], "patches,", len(p.curves), "curves")

truth = np.sin(3 * V[:, 0]) + V[:, 2]
free = np.setdiff1d(np.arange(len(V)), idx)
for name, x in [("default", r.values), ("gvf-harmonic", p.values)]:
    print(f"{name:>12}: relative RMS error {np.sqrt(np.mean((x - truth)[free] ** 2)) / np.ptp(truth):.4f}")

# %%
# Values anywhere, files for other tools
# --------------------------------------

print("at two points near the surface:", r.at([[0.0, 0.0, 1.001], [1.0, 0.0, 0.0]]))
out = r.save(Path(tempfile.mkdtemp()) / "field.vtp")  # fields and masks, for pyvista and ParaView
print("wrote", out.name, "with", list(pv.read(out).point_data.keys()))

# %%
# Both side by side
# -----------------
# ``r.to_pyvista()`` is the surface with the field and the sample mask as point data; the pipeline's curves are
# drawn as black lines, the samples in red.

mesh = r.to_pyvista(["default"])
mesh.point_data["gvf-harmonic"] = p.values
pl = pv.Plotter(shape=(1, 2), window_size=(1300, 600), border=False)
for j, key in enumerate(["default", "gvf-harmonic"]):
    pl.subplot(0, j)
    pl.add_mesh(mesh.copy(), scalars=key, cmap="viridis", clim=(-1.5, 2.0), smooth_shading=True,
                show_scalar_bar=j == 0,
                scalar_bar_args=dict(title="value (both panels)", vertical=False, position_x=0.15, position_y=0.03,
                                     width=0.7, height=0.11, n_labels=8, fmt="%.1f", color="black"))
    if key == "gvf-harmonic":
        for c in p.curves:
            pl.add_mesh(pv.lines_from_points(V[c] * 1.002), color="black", line_width=2)
    pl.add_points(V[idx] * 1.01, color="red", point_size=10, render_points_as_spheres=True)
    pl.add_text(key if j else "the default (biharmonic, bounded)", font_size=12, color="black",
                position="upper_edge")
    pl.view_vector((1.0, -0.6, 0.6), viewup=(0, 0, 1))
    pl.camera.zoom(1.2)
    pl.set_background("white")
pl.link_views()
pl.show()
