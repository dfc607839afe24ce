"""
MEG: a magnetic field over the sensor helmet
============================================

MEG sensors sit in a rigid helmet around the head, and the field they measure varies smoothly over the helmet's
inner surface. MNE-Python ships the helmet surfaces of the common systems (``mne/data/helmets``); here the
Elekta/Neuromag VectorView helmet (``306m.fif.gz``, an open surface) is Loop-subdivided to a finer mesh, the
radial magnetic field of two current dipoles is "measured" at 60 well-spread helmet vertices, and
:func:`manifill.reconstruct` fills in the rest of the helmet.

(The MNE adapter refuses MEG *channels* for bad-channel repair, on purpose: MEG sensors measure a field outside the
head, which needs a field model rather than a surface fill. Here the field is wanted *on the helmet itself*, which
is a surface like any other.)
"""

from pathlib import Path

import matplotlib.pyplot as plt
import mne
import numpy as np
import pyvista as pv

import manifill
from manifill.mesh.subdivide import subdivide
from manifill.viz.figures import far_points

pv.OFF_SCREEN = True

# %%
# The helmet surface that ships with MNE
# --------------------------------------

helmet_file = Path(mne.__file__).parent / "data" / "helmets" / "306m.fif.gz"
surf = mne.read_bem_surfaces(helmet_file, s_id=mne.io.constants.FIFF.FIFFV_MNE_SURF_MEG_HELMET, verbose=False)
V, F = subdivide(surf["rr"], surf["tris"], levels=2)  # 304 vertices -> about 4,800
print(manifill.mesh_info(V, F)["boundary_loops"], "boundary loop;", len(V), "vertices")

# %%
# A known field: the radial field of two current dipoles
# ------------------------------------------------------
# In a spherically symmetric conductor the volume currents add nothing to the radial component of the magnetic
# field, so for a current dipole ``q`` at ``r0`` it is ``B_r = mu0 / (4 pi) (q x r0) . r_hat / |r - r0|^3``,
# with positions taken from the centre of the sphere (here 4 cm above the helmet's device origin).

centre = np.array([0.0, 0.0, 0.04])
mu0 = 4e-7 * np.pi


def radial_field(r, r0, q):
    """Radial magnetic field (tesla) at positions r of a current dipole q (A m) at r0 (metres, from the centre)."""
    r = r - centre
    d = np.linalg.norm(r - r0, axis=1)
    return mu0 / (4 * np.pi) * (np.cross(q, r0) @ (r / np.linalg.norm(r, axis=1)[:, None]).T) / d**3


truth = (radial_field(V, np.array([0.01, 0.0, 0.04]), np.array([20e-9, 0.0, 0.0]))  # 20 nA m, 4 cm deep
         + radial_field(V, np.array([-0.045, -0.01, 0.0]), np.array([0.0, 20e-9, 5e-9]))) * 1e15  # femtotesla

# %%
# 60 sensors, the rest filled in
# ------------------------------

idx = far_points(V, 60, seed=0)  # well-spread vertices, like the sensors of a helmet
r = manifill.reconstruct(V, F, idx, truth[idx])  # the default: biharmonic, kept within the samples' range
free = np.setdiff1d(np.arange(len(V)), idx)
rmse = np.sqrt(np.mean((r.values[free] - truth[free]) ** 2))
print(r)
print(f"RMS error off the sensors: {rmse:.1f} fT ({100 * rmse / np.ptp(truth):.1f}% of the field's range)")

# %%
# Seen from above, the nose at the top: the true field, the field reconstructed from the 60 sensors (red), and
# the difference, all on one colour scale.

lim = float(np.ceil(np.abs(truth).max() / 100) * 100)
mesh = r.to_pyvista(["reconstructed"])
mesh.point_data["true"] = truth
mesh.point_data["error"] = r.values - truth
pl = pv.Plotter(shape=(1, 3), window_size=(1500, 560), border=False)
for j, (key, title) in enumerate([("true", "the true field"), ("reconstructed", "from 60 helmet vertices"),
                                  ("error", "reconstructed - true")]):
    pl.subplot(0, j)
    pl.add_mesh(mesh.copy(), scalars=key, cmap="RdBu_r", clim=(-lim, lim), smooth_shading=True, ambient=0.2,
                show_scalar_bar=j == 1,  # one colour bar, under the middle panel, for all three
                scalar_bar_args=dict(title="radial field Br (fT), all three panels", vertical=False, position_x=0.1,
                                     position_y=0.04, width=0.8, height=0.1, n_labels=5, fmt="%.0f", color="black"))
    pl.add_points(V[idx], color="red", point_size=10, render_points_as_spheres=True)
    pl.add_text(title, font_size=12, color="black", position="upper_edge")
    pl.view_vector((0, -0.4, 1.0), viewup=(0, 1, 0))
    pl.camera.zoom(1.25)
    pl.set_background("white")
pl.link_views()
pl.show()

# %%
# The error along the helmet, against the distance to the nearest sensor: it is largest where the field is steep
# and the sensors far apart.

d_near = np.min(np.linalg.norm(V[:, None, :] - V[idx][None, :, :], axis=2), axis=1) * 100
fig, ax = plt.subplots(figsize=(6, 4), layout="constrained")
sc = ax.scatter(d_near, np.abs(r.values - truth), c=np.abs(truth), s=4, cmap="viridis")
fig.colorbar(sc, ax=ax, label="|true field| (fT)")
ax.set_xlabel("distance to the nearest sensor (cm)")
ax.set_ylabel("|error| (fT)")
ax.set_title("error of the default reconstruction per vertex")
plt.show()
