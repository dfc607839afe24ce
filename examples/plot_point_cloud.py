"""
A point cloud: no triangles needed
==================================

A laser scan, a digitised head or a cloud of sensor positions comes as points without faces. Pass them with
``F=None``: every method runs on them. Each point's nearest neighbours (16 by default), projected on its tangent
plane, give a small Delaunay fan, and the fans give the Laplacian and mass matrices the surface methods need.
Distances stay *along* the sampled surface: the field does not leak between two sheets of the cloud that are close
in space, as a fit in 3D space would.

The cloud here is a scan-like sampling of a torus (a jittered grid of 6,000 points with a little measurement
noise), carrying a known field; 150 of the points are samples.
"""

import matplotlib.pyplot as plt
import numpy as np
import pyvista as pv

import manifill

pv.OFF_SCREEN = True

# %%
# The cloud
# ---------

rng = np.random.default_rng(2)
nu, nv = 120, 50  # around the ring, around the tube
u = (np.arange(nu)[:, None] + rng.uniform(-0.3, 0.3, (nu, nv))).ravel() * 2 * np.pi / nu
v = (np.arange(nv)[None, :] + rng.uniform(-0.3, 0.3, (nu, nv))).ravel() * 2 * np.pi / nv
R, a = 1.0, 0.35
P = np.column_stack([(R + a * np.cos(v)) * np.cos(u), (R + a * np.cos(v)) * np.sin(u), a * np.sin(v)])
P += rng.normal(0, 0.002, P.shape)  # scanner noise
truth = np.sin(2 * u) * np.cos(v) + 0.5 * np.cos(3 * u + v)

idx = rng.choice(len(P), 150, replace=False)
print(len(P), "points,", len(idx), "samples")

# %%
# Reconstruct with ``F=None``
# ---------------------------

r = manifill.reconstruct(P, None, idx, truth[idx], method="biharmonic")
print(r.report["cloud"])
free = np.setdiff1d(np.arange(len(P)), idx)
err = r.values - truth
print(f"RMS error at the other points: {np.sqrt(np.mean(err[free] ** 2)):.3f} "
      f"({100 * np.sqrt(np.mean(err[free] ** 2)) / np.ptp(truth):.1f}% of the range)")

# for comparison: SciPy's thin-plate spline in space (method="rbf") on the same samples
s = manifill.reconstruct(P, None, idx, truth[idx], method="rbf")
print(f"rbf (in space): {np.sqrt(np.mean((s.values - truth)[free] ** 2)):.3f}")

# %%
# The cloud coloured by the reconstruction
# ----------------------------------------
# ``r.to_pyvista()`` gives the points with the field and the sample mask (a point cloud's points as vertex cells);
# the samples are drawn larger, in red.

cloud = r.to_pyvista(["field"])
pl = pv.Plotter(window_size=(900, 650))
pl.add_mesh(cloud, scalars="field", cmap="viridis", clim=(-1.5, 1.5), point_size=7, render_points_as_spheres=True,
            scalar_bar_args=dict(title="reconstructed field", vertical=False, position_x=0.2, position_y=0.04,
                                 width=0.6, height=0.1, n_labels=7, fmt="%.1f", color="black"))
pl.add_points(P[idx], color="red", point_size=14, render_points_as_spheres=True)
pl.add_text("6,000 points, no faces; 150 samples in red", font_size=12, color="black")
pl.view_vector((0.5, -1.0, 0.9), viewup=(0, 0, 1))
pl.camera.zoom(1.15)
pl.set_background("white")
pl.show()

# %%
# The error along the ring: the reconstruction follows the field around the tube and the ring, with the largest
# errors where the samples are sparse.

fig, ax = plt.subplots(figsize=(9, 3.6), layout="constrained")
sc = ax.scatter(np.degrees(u), np.degrees(v), c=err, cmap="PuOr_r", vmin=-0.3, vmax=0.3, s=4)
ax.scatter(np.degrees(u[idx]), np.degrees(v[idx]), facecolors="none", edgecolors="red", s=30, label="samples")
fig.colorbar(sc, ax=ax, label="reconstructed - true")
ax.set_xlabel("angle around the ring (°)")
ax.set_ylabel("angle around the tube (°)")
ax.set_title("error at every point of the cloud, unrolled")
ax.legend(loc="upper right", framealpha=0.9)
plt.show()
