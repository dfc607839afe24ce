"""
A cortical surface, written as GIfTI
====================================

Cortical maps are measured at some vertices of a subject's surface (electrode contacts, biopsies, a sparse
acquisition) and wanted at all of them. nilearn ships the fsaverage5 cortex with its package (10,242 vertices per
hemisphere, nothing downloaded); here its left pial surface carries the sulcal depth map that ships with it
(nilearn's file, arbitrary units) as a field known everywhere, sampled at 500 vertices.

The reconstruction runs on the folded pial surface, so values spread *along* the cortex and never jump across a
sulcus through the gap between its banks. The result is written with manifill's GIfTI writer (``r.save`` with a
``.func.gii`` name), read back with nibabel, and drawn on the inflated surface, which has the same vertices.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import nibabel as nib
import numpy as np
import pyvista as pv
from nilearn import datasets

import manifill

pv.OFF_SCREEN = True

# %%
# The fsaverage5 cortex that ships with nilearn
# ---------------------------------------------

fsaverage = datasets.fetch_surf_fsaverage("fsaverage5")  # paths inside the nilearn package
V, F = nib.load(fsaverage["pial_left"]).agg_data()  # pial surface: (10242, 3) mm, (20480, 3)
V_inflated, _ = nib.load(fsaverage["infl_left"]).agg_data()  # the same vertices, inflated (for the pictures)
truth = nib.load(fsaverage["sulc_left"]).agg_data().astype(np.float64)
print(manifill.mesh_info(V, F)["components"])

# %%
# 500 samples, the rest reconstructed, written as GIfTI
# -----------------------------------------------------

rng = np.random.default_rng(0)
idx = rng.choice(len(V), 500, replace=False)
r = manifill.reconstruct(V, F, idx, truth[idx])
r.names = ["sulc_reconstructed"]  # the data array's name in the file

folder = Path(tempfile.mkdtemp())
path = r.save(folder / "lh.sulc_reconstructed.func.gii")
# manifill writes GIfTI *data*; the geometry is already in nilearn's pial file. Write it beside for viewers:
surface = nib.gifti.GiftiImage(darrays=[
    nib.gifti.GiftiDataArray(V.astype(np.float32), intent="NIFTI_INTENT_POINTSET"),
    nib.gifti.GiftiDataArray(F.astype(np.int32), intent="NIFTI_INTENT_TRIANGLE")])
nib.save(surface, folder / "lh.pial.surf.gii")
print(sorted(p.name for p in folder.iterdir()))

# %%
# Read back with nibabel
# ----------------------

image = nib.load(path)
array = image.darrays[0]
back = array.data.astype(np.float64)
print(f"{len(image.darrays)} data array named {array.meta['Name']!r}, intent {array.intent}, dtype {array.data.dtype}")
print("same as the result (to float32):", np.allclose(back, r.values, atol=1e-6))
free = np.setdiff1d(np.arange(len(V)), idx)
rmse = np.sqrt(np.mean((back[free] - truth[free]) ** 2))
print(f"RMS error at the 9,742 unsampled vertices: {rmse:.3f} ({100 * rmse / np.ptp(truth):.1f}% of the range)")

# %%
# The map read back from the file, beside the true one
# ----------------------------------------------------
# Lateral view of the inflated left hemisphere (front to the left); the 500 sampled vertices in black.

mesh = pv.PolyData(V_inflated, np.column_stack([np.full(len(F), 3), F]).ravel())
mesh.point_data["true"] = truth
mesh.point_data["from the .func.gii"] = back
lim = (-1.5, 1.5)
pl = pv.Plotter(shape=(1, 2), window_size=(1400, 600), border=False)
for j, key in enumerate(["true", "from the .func.gii"]):
    pl.subplot(0, j)
    pl.add_mesh(mesh.copy(), scalars=key, cmap="RdBu_r", clim=lim, smooth_shading=True, show_scalar_bar=j == 1,
                scalar_bar_args=dict(title="sulcal depth (a.u.), both panels", vertical=False, position_x=0.15,
                                     position_y=0.02, width=0.7, height=0.1, n_labels=7, fmt="%.1f", color="black"))
    pl.add_points(V_inflated[idx] + [-1.0, 0, 0], color="black", point_size=6, render_points_as_spheres=True)
    pl.add_text(key if j else "the true map (nilearn's sulc file)", font_size=12, color="black",
                position="upper_edge")
    pl.view_vector((-1, 0, 0), viewup=(0, 0, 1))
    pl.camera.zoom(1.4)
    pl.set_background("white")
pl.link_views()
pl.show()

# %%
# Every unsampled vertex: reconstructed against true.

fig, ax = plt.subplots(figsize=(5, 4.5), layout="constrained")
h = ax.hexbin(truth[free], back[free], gridsize=50, mincnt=1, cmap="viridis", bins="log")
ax.plot(lim, lim, "r--", lw=1)
fig.colorbar(h, ax=ax, label="vertices per bin")
ax.set_xlabel("true sulcal depth (a.u.)")
ax.set_ylabel("reconstructed, read from the .func.gii")
ax.set_title(f"{len(free):,} unsampled vertices")
plt.show()
