"""
Gradients of a reconstructed field
==================================

The gradient of a reconstruction tells where the field changes fastest and in which direction: the slope of a
terrain, a heat flux, the inverse of a conduction velocity. ``r.gradient()`` gives it per vertex (the faces'
gradients weighted by their areas, projected on the tangent plane), ``r.gradient("cells")`` per triangle, and
``r.gradient_data()`` names them as files hold them (``grad_<field>`` and ``grad_<field>_norm``).

A gradient is only as smooth as the method: the harmonic fill has kinks at the samples, so its gradient is rough;
the bi- and triharmonic fills (and ``gp``, ``rbf``) are smooth through them.
"""

import matplotlib.pyplot as plt
import numpy as np
import pyvista as pv

import manifill
from manifill.mesh.shapes import icosphere
from manifill.viz.figures import far_points

pv.OFF_SCREEN = True

# %%
# A field with a known gradient
# -----------------------------
# ``f = sin(3x) + z`` on the unit sphere; its gradient along the sphere is the gradient in space with the normal
# component taken out.

V, F = icosphere(4)  # 2,562 vertices
truth = np.sin(3 * V[:, 0]) + V[:, 2]
g_space = np.column_stack([3 * np.cos(3 * V[:, 0]), np.zeros(len(V)), np.ones(len(V))])
g_true = g_space - np.sum(g_space * V, axis=1)[:, None] * V  # the normal of the unit sphere is V itself

rng = np.random.default_rng(3)
idx = rng.choice(len(V), 150, replace=False)

# %%
# The gradient of each method's reconstruction
# --------------------------------------------

errors = {}
for method in ["harmonic", "default", "biharmonic", "triharmonic"]:
    r = manifill.reconstruct(V, F, idx, truth[idx], method=method)
    g = r.gradient()  # (n, 3), tangent to the sphere
    errors[method] = np.sqrt(np.mean(np.sum((g - g_true) ** 2, axis=1))) / np.sqrt(np.mean(np.sum(g_true**2, 1)))
    print(f"{method:>12}: relative RMS error of the gradient {errors[method]:.3f}")

# %%
# The biharmonic's gradient, named as in the files it writes:

r = manifill.reconstruct(V, F, idx, truth[idx], method="biharmonic")
r.names = ["f"]
data = r.gradient_data()
print({k: v.shape for k, v in data.items()})

# %%
# The gradient drawn on the sphere
# --------------------------------
# Colour: the gradient's magnitude ``grad_f_norm``; arrows: the gradient (uphill) at 400 well-spread vertices;
# red: the 150 samples.

mesh = r.to_pyvista()
for key, value in data.items():
    mesh.point_data[key] = value
some = far_points(V, 400, seed=0)
tails = pv.PolyData(V[some] * 1.005)
tails.point_data["grad_f"] = data["grad_f"][some]
tails.point_data["grad_f_norm"] = data["grad_f_norm"][some]
arrows = tails.glyph(orient="grad_f", scale="grad_f_norm", factor=0.05)
pl = pv.Plotter(window_size=(850, 750))
pl.add_mesh(mesh, scalars="grad_f_norm", cmap="magma", clim=(0, 3), smooth_shading=True,
            scalar_bar_args=dict(title="magnitude of the gradient of f", vertical=False, position_x=0.2,
                                 position_y=0.04, width=0.6, height=0.1, n_labels=7, fmt="%.1f", color="black"))
pl.add_mesh(arrows, color="deepskyblue")
pl.add_points(V[idx] * 1.01, color="red", point_size=11, render_points_as_spheres=True)
pl.add_text("biharmonic reconstruction from 150 samples:\nits gradient (arrows) and magnitude (colour)",
            font_size=11, color="black")
pl.view_vector((1.0, -0.6, 0.5), viewup=(0, 0, 1))
pl.camera.zoom(1.15)
pl.set_background("white")
pl.show()

# %%
# Which method for gradients
# --------------------------

fig, ax = plt.subplots(figsize=(6, 3.4), layout="constrained")
names = list(errors)
ax.barh(names, [errors[m] for m in names], color=["C3", "C0", "C0", "C0"])
ax.set_xlabel("relative RMS error of the gradient")
ax.set_title("the same 150 samples, four methods")
for j, m in enumerate(names):
    ax.text(errors[m], j, f" {errors[m]:.3f}", va="center")
ax.set_xlim(0, max(errors.values()) * 1.2)
plt.show()
