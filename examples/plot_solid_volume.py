"""
Inside a solid: from samples on its surface to every voxel
==========================================================

:func:`manifill.reconstruct_volume` carries the paper's method into the solid a closed surface bounds (Steps 7-8):
it reconstructs the field over the surface from the samples, voxelises the solid (or tetrahedralises it,
``form="tets"``), fixes the voxels of its boundary to the surface's values and fills the inside harmonically (a
matrix-free multigrid on the voxels). The result holds a value per voxel, NaN outside.

The solid here is pyvista's nut (genus 1), with 40 samples on its surface of a field that is harmonic in space
(``x^2 - y^2 + z``), so the inside's true values are known.
"""

import matplotlib.pyplot as plt
import numpy as np
import pyvista as pv

import manifill
from manifill.viz.figures import example_mesh, far_points

pv.OFF_SCREEN = True

# %%
# The solid and its samples
# -------------------------

V, F = example_mesh("nut.ply", 1)  # a closed surface: pyvista's nut, scaled to unit diagonal


def field(P):
    """Harmonic in space: its values inside follow from those on the surface."""
    P = 3 * np.asarray(P)
    return P[..., 0] ** 2 - P[..., 1] ** 2 + P[..., 2]


idx = far_points(V, 40, seed=4)
vol = manifill.reconstruct_volume(V, F, idx, field(V[idx]), resolution=48)
print(vol)
fill = vol.report["fill"]
print(f"{fill['voxels']:,} voxels filled from {fill['fixed']:,} boundary voxels")

# %%
# How close the inside is to the truth (the voxel at ``(i, j, k)`` sits at ``origin + (i, j, k) * spacing``):

ii = np.indices(vol.values.shape).reshape(3, -1).T
centres = vol.origin + ii * vol.spacing
truth = field(centres).reshape(vol.values.shape)
inside = np.isfinite(vol.values)
rmse = np.sqrt(np.mean((vol.values[inside] - truth[inside]) ** 2))
print(f"RMS error inside {rmse:.3f} ({100 * rmse / np.ptp(truth[inside]):.1f}% of the range)")

# %%
# Three slices through the solid
# ------------------------------
# ``vol.to_pyvista()`` is the voxel grid (``pyvista.ImageData``) with the field and the boundary mask; here sliced
# through its middle along x, y and z, with the solid's surface as a wireframe and the 40 samples in red.

grid = vol.to_pyvista(["field"])
# the cells with a corner outside the solid (NaN) left out:
slices = grid.slice_orthogonal().combine().threshold(value=(-1e9, 1e9), scalars="field", all_scalars=True)
surface = pv.PolyData(V, np.column_stack([np.full(len(F), 3), F]).ravel())
lim = (-1.5, 1.5)
pl = pv.Plotter(window_size=(900, 750))
pl.add_mesh(slices, scalars="field", cmap="coolwarm", clim=lim, lighting=False,
            scalar_bar_args=dict(title="field inside the solid", vertical=False, position_x=0.2, position_y=0.04,
                                 width=0.6, height=0.1, n_labels=7, fmt="%.1f", color="black"))
pl.add_mesh(surface, style="wireframe", color="grey", opacity=0.15)
pl.add_points(V[idx], color="red", point_size=12, render_points_as_spheres=True)
pl.add_text("voxels at resolution 48: three middle slices", font_size=11, color="black")
pl.view_vector((1.0, -1.2, 0.8), viewup=(0, 0, 1))
pl.camera.zoom(0.95)
pl.set_background("white")
pl.show()

# %%
# The middle slices as images
# ---------------------------
# The same three slices as plain arrays (NaN outside, drawn white), next to the true field on the middle y slice.

mid = [s // 2 for s in vol.values.shape]
o, h = vol.origin, vol.spacing
n = vol.values.shape
extent = {"x": (o[1], o[1] + (n[1] - 1) * h[1], o[2], o[2] + (n[2] - 1) * h[2]),
          "y": (o[0], o[0] + (n[0] - 1) * h[0], o[2], o[2] + (n[2] - 1) * h[2]),
          "z": (o[0], o[0] + (n[0] - 1) * h[0], o[1], o[1] + (n[1] - 1) * h[1])}
cuts = [("x", vol.values[mid[0], :, :], "y", "z"), ("y", vol.values[:, mid[1], :], "x", "z"),
        ("z", vol.values[:, :, mid[2]], "x", "y"), ("y", np.where(inside, truth, np.nan)[:, mid[1], :], "x", "z")]
fig, axes = plt.subplots(1, 4, figsize=(14, 3.8), layout="constrained")
for ax, (normal, A, a, b) in zip(axes, cuts):
    im = ax.imshow(A.T, origin="lower", extent=extent[normal], cmap="coolwarm", vmin=lim[0], vmax=lim[1])
    ax.set_xlabel(a)
    ax.set_ylabel(b)
for ax, title in zip(axes, ["x slice", "y slice", "z slice", "y slice: the truth"]):
    ax.set_title(title)
fig.colorbar(im, ax=axes, shrink=0.8, label="field (reconstructed; last: true)")
plt.show()
