"""
How sure is each value: the Gaussian process's standard deviation
=================================================================

``method="gp"`` fits a Gaussian process on the mesh itself (a Matérn field, distances along the surface) and
returns, besides the posterior mean in ``r.values``, the posterior standard deviation in ``r.std``: 0 at exact
samples, growing away from them up to the prior's. ``trust=t`` marks the vertices whose std exceeds ``t`` times
the samples' standard deviation (``r.trusted``), so that a map need not show values invented far from every
sample.

Here the samples cover the northern hemisphere densely and the southern one hardly at all.
"""

import matplotlib.pyplot as plt
import numpy as np
import pyvista as pv

import manifill
from manifill.mesh.shapes import icosphere

pv.OFF_SCREEN = True

# %%
# Samples where the stations are
# ------------------------------

V, F = icosphere(4)  # 2,562 vertices
truth = np.sin(4 * V[:, 0]) * np.cos(3 * V[:, 1]) + np.sin(3 * V[:, 2])
rng = np.random.default_rng(5)
north = rng.choice(np.flatnonzero(V[:, 2] > 0.1), 90, replace=False)
south = rng.choice(np.flatnonzero(V[:, 2] < -0.1), 6, replace=False)
idx = np.concatenate([north, south])

# %%
# The Gaussian process: range and sigma fitted by restricted likelihood
# ---------------------------------------------------------------------

r = manifill.reconstruct(V, F, idx, truth[idx], method="gp", trust=0.5)
gp = r.report["gp"]  # range, sigma, ...: one entry per field
print(f"fitted range {gp['range'][0]:.2f}, sigma {gp['sigma'][0]:.2f}, log-likelihood {gp['loglik']:.1f}")
print("the std checked by leaving out each sample:", gp["variance"]["loo"][0]["verdict"])
print(r)
print(f"{np.count_nonzero(~r.trusted)} of {len(V)} vertices have a std above 0.5 x the samples' std")

# a 90% band everywhere: does it hold the truth?
inside = np.abs(truth - r.values) <= 1.645 * r.std
free = np.setdiff1d(np.arange(len(V)), idx)
print(f"the 90% band holds the true value at {100 * inside[free].mean():.0f}% of the unsampled vertices")

# %%
# The mean and its standard deviation
# -----------------------------------
# ``r.to_pyvista()`` carries ``value``, ``value_std``, ``trusted`` and ``sample_mask``. Left: the mean, grey where
# it is not trusted; right: the std. The samples in red.

mesh = r.to_pyvista()
mesh.point_data["mean where trusted"] = np.where(r.trusted, r.values, np.nan)
pl = pv.Plotter(shape=(1, 2), window_size=(1400, 640), border=False)
bar = dict(vertical=False, position_x=0.15, position_y=0.03, width=0.7, height=0.1, color="black")
pl.subplot(0, 0)
pl.add_mesh(mesh.copy(), scalars="mean where trusted", cmap="viridis", clim=(-2, 2), nan_color="lightgrey",
            smooth_shading=True,
            scalar_bar_args=dict(title="posterior mean (grey: not trusted)", n_labels=5, fmt="%.0f", **bar))
pl.add_points(V[idx] * 1.01, color="red", point_size=10, render_points_as_spheres=True)
pl.add_text("method='gp', trust=0.5", font_size=12, color="black", position="upper_edge")
pl.subplot(0, 1)
pl.add_mesh(mesh.copy(), scalars="value_std", cmap="YlGnBu", clim=(0, 0.5), smooth_shading=True,
            scalar_bar_args=dict(title="posterior standard deviation", n_labels=6, fmt="%.1f", **bar))
pl.add_points(V[idx] * 1.01, color="red", point_size=10, render_points_as_spheres=True)
pl.add_text("r.std: 0 at the samples, large in the south", font_size=12, color="black", position="upper_edge")
for j in range(2):
    pl.subplot(0, j)
    pl.view_vector((1.0, -0.4, -0.25), viewup=(0, 0, 1))  # the equator across the middle, the south below
    pl.camera.zoom(1.2)
    pl.set_background("white")
pl.link_views()
pl.show()

# %%
# Where the std is large
# ----------------------
# The std against the distance along the sphere to the nearest sample, and the actual error beside it: the std
# grows with the distance as the errors do. Errors above the grey points fall outside the 90% band.

cos = np.clip(V @ V[idx].T, -1, 1)
dist = np.degrees(np.arccos(cos.max(axis=1)))
fig, axes = plt.subplots(1, 2, figsize=(11, 4), layout="constrained", sharex=True)
sc = axes[0].scatter(dist, r.std, c=V[:, 2], cmap="viridis", s=6, vmin=-1, vmax=1)
axes[0].set_ylabel("posterior std")
axes[0].set_title("r.std")
axes[1].scatter(dist, np.abs(r.values - truth), c=V[:, 2], cmap="viridis", s=6, vmin=-1, vmax=1)
axes[1].scatter(dist, 1.645 * r.std, color="black", s=2, label="1.645 std: half the 90% band")
axes[1].legend(loc="upper left")
axes[1].set_ylabel("|mean - truth|")
axes[1].set_title("the actual error")
for ax in axes:
    ax.set_xlabel("distance to the nearest sample along the sphere (°)")
fig.colorbar(sc, ax=axes, label="z (north +1, south -1)")
plt.show()
