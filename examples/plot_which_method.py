"""
Which method when: cross-validation on your own samples
=======================================================

manifill has several ways to fill a surface: the default (the biharmonic fill kept within the samples' range),
the paper's pipeline (``gvf-harmonic``), the harmonic, bi- and triharmonic energies, the thin-plate spline in space
(``rbf``), a Gaussian process. Which is best depends on the field. :func:`manifill.cross_validate` answers on the
samples themselves: it leaves out each of ``folds`` groups in turn, fits every candidate on the rest and measures
its error at the held-out samples (as a fraction of the samples' range), and how far its fits left the samples'
range (``overshoot``). ``method="auto"`` does the same and fits the winner.

Two fields on one sphere, measured at the same 200 vertices: a smooth one, and one with a sharp front.
"""

import matplotlib.pyplot as plt
import numpy as np
import pyvista as pv

import manifill
from manifill.mesh.shapes import icosphere

pv.OFF_SCREEN = True

# %%
# Two fields, one set of samples
# ------------------------------

V, F = icosphere(4)
smooth = np.sin(3 * V[:, 0]) + V[:, 2]
front = np.tanh(12 * (V[:, 0] + 0.3 * V[:, 1] - 0.2))  # a step, about 0.1 wide
rng = np.random.default_rng(8)
idx = rng.choice(len(V), 200, replace=False)
vals = np.column_stack([smooth[idx], front[idx]])  # (200, 2): one column per field

# %%
# Cross-validate the candidates
# -----------------------------
# ``methods=`` lists the candidates (names, or ``(name, options)`` pairs); without it a fixed list runs, which
# includes the exact bounded biharmonic (an active set per fold: slower) but not the default itself.

candidates = ["default", "gvf-harmonic", "harmonic", "biharmonic", "triharmonic", "hessian", "rbf"]
cv = manifill.cross_validate(V, F, idx, vals, methods=candidates, folds=5)
print(cv.table())
print(cv.recommendation)

# %%
# Each method's held-out error, field by field
# --------------------------------------------

methods = cv.ranking()
E = np.array([cv.field_errors[m] for m in methods])  # (methods, 2)
fig, ax = plt.subplots(figsize=(9, 4.2), layout="constrained")
y = np.arange(len(methods))
for j, (name, colour) in enumerate([("smooth field", "C0"), ("sharp front", "C1")]):
    ax.barh(y + (j - 0.5) * 0.38, 100 * E[:, j], height=0.38, color=colour, label=name)
for i, m in enumerate(methods):
    if cv.overshoot.get(m, 0) > 1e-6:
        ax.text(100 * E[i].max(), i, f"  overshoots by {100 * cv.overshoot[m]:.0f}% of the range", va="center",
                fontsize=8, color="0.3")
ax.set_yticks(y, methods)
ax.invert_yaxis()
ax.set_xlabel("error at held-out samples (% of the samples' range)")
ax.set_title(f"{cv.what} cross-validation, 200 samples; best first (both fields combined)")
ax.legend(loc="lower right")
ax.set_xlim(0, 100 * E.max() * 1.6)
plt.show()

# %%
# ``method="auto"``: the winner, field by field
# ---------------------------------------------
# ``method="auto"`` cross-validates the default, the projected triharmonic, the Hessian energy and ``rbf``, and
# keeps the default for a field unless another candidate beats it by more than one standard error of its fold
# errors. ``report["auto"]["fields"]`` says what each field got.

r = manifill.reconstruct(V, F, idx, vals, method="auto")
chosen = r.report["auto"]["fields"]
print(dict(zip(["smooth", "front"], chosen)))

mesh = r.to_pyvista(["smooth", "front"])
pl = pv.Plotter(shape=(1, 2), window_size=(1300, 600), border=False)
for j, (key, cmap) in enumerate([("smooth", "viridis"), ("front", "coolwarm")]):
    pl.subplot(0, j)
    pl.add_text(f"{key}: {chosen[j].split()[0]}", font_size=12, color="black", position="upper_edge")
    lim = (-2, 2) if key == "smooth" else (-1, 1)
    pl.add_mesh(mesh.copy(), scalars=key, cmap=cmap, clim=lim, smooth_shading=True,
                scalar_bar_args=dict(title=f"{key} (method='auto')", vertical=False, position_x=0.15,
                                     position_y=0.03, width=0.7, height=0.11, n_labels=5, fmt="%.1f", color="black"))
    pl.add_points(V[idx] * 1.01, color="red", point_size=8, render_points_as_spheres=True)
    pl.view_vector((1.0, -0.5, 0.5), viewup=(0, 0, 1))
    pl.camera.zoom(1.2)
    pl.set_background("white")
pl.link_views()
pl.show()
