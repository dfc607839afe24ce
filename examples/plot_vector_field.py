"""
Wind on the globe from a few stations: a tangent vector field
=============================================================

Arrows measured at 80 stations (a wind, a current) and a smooth tangent field wanted everywhere.
``manifill.reconstruct_vectors`` fills the field itself, with the sphere's own notion of parallel (its
connection), so the result is tangent everywhere and exact at the stations -- unlike interpolating the three
components as scalars and projecting afterwards, or the vector heat method's nearest-station transport.

The field here is known: a smooth function's gradient plus a rotation of it (a flow with both divergence and
curl), so the errors can be measured.
"""

import matplotlib.pyplot as plt
import numpy as np
import pyvista as pv

import manifill
from manifill.mesh.shapes import icosphere
from manifill.viz.figures import far_points

pv.OFF_SCREEN = True

# %%
# The globe and the stations
# --------------------------

V, F = icosphere(5)  # 10,242 vertices
N = V / np.linalg.norm(V, axis=1, keepdims=True)


def wind(P):
    """A smooth tangent field: grad f + n x grad f for f = x y + z^2 + sin(2 x), on the unit sphere."""
    g = np.column_stack([P[:, 1] + 2 * np.cos(2 * P[:, 0]), P[:, 0], 2 * P[:, 2]])
    g -= np.sum(g * P, axis=1)[:, None] * P
    return g + np.cross(P, g)


truth = wind(N)
rng = np.random.default_rng(7)
stations = rng.choice(len(V), 80, replace=False)

# %%
# The reconstruction
# ------------------

r = manifill.reconstruct_vectors(V, F, stations, truth[stations], normal="drop")
print(r)
t = truth - np.sum(truth * r.normals, axis=1)[:, None] * r.normals  # the truth in the mesh's tangent planes
error = np.sqrt(np.mean(np.sum((r.values - t) ** 2, axis=1)) / np.mean(np.sum(t**2, axis=1)))
print(f"relative RMS error of the vectors: {error:.3f}")
print("singularities' indices sum to", sum(r.singularities[0]["index"]), "(the sphere's Euler characteristic)")

# %%
# Against the per-component scalar fill, projected
# -------------------------------------------------
# The same stations, each component filled by the biharmonic scalar method and the result projected onto the
# tangent planes afterwards.

c = manifill.reconstruct(V, F, stations, truth[stations], method="biharmonic").values
c -= np.sum(c * r.normals, axis=1)[:, None] * r.normals
error_c = np.sqrt(np.mean(np.sum((c - t) ** 2, axis=1)) / np.mean(np.sum(t**2, axis=1)))
print(f"per component, projected: {error_c:.3f}")

# %%
# The field drawn: its magnitude and arrows
# -----------------------------------------
# Colour: the magnitude; white arrows: the field at 500 well-spread vertices; red: the stations; black crosses:
# the singularities (where the field vanishes and turns).

mesh = r.to_pyvista()
some = far_points(V, 500, seed=0)
tails = pv.PolyData(V[some] * 1.004)
tails.point_data["wind"] = r.values[some]
tails.point_data["speed"] = r.magnitude[some]
arrows = tails.glyph(orient="wind", scale="speed", factor=0.06)
pl = pv.Plotter(window_size=(850, 750))
pl.add_mesh(mesh, scalars="value_magnitude", cmap="viridis", smooth_shading=True,
            scalar_bar_args=dict(title="speed", vertical=False, position_x=0.2, position_y=0.04, width=0.6,
                                 height=0.1, n_labels=5, fmt="%.1f", color="black"))
pl.add_mesh(arrows, color="white")
pl.add_points(V[stations] * 1.01, color="red", point_size=10, render_points_as_spheres=True)
sing = r.singularities[0]["positions"]
if len(sing):
    pl.add_points(sing * 1.01, color="black", point_size=14, render_points_as_spheres=True)
pl.add_text(f"a tangent field from 80 stations (error {error:.3f};\nper component, projected: {error_c:.3f})",
            font_size=11, color="black")
pl.view_vector((1.0, -0.6, 0.5), viewup=(0, 0, 1))
pl.camera.zoom(1.3)
pl.set_background("white")
pl.show()

# %%
# Lines without a sign
# --------------------
# Fibres and hatching have a direction but no sign. With ``symmetry=2`` an arrow and its opposite are one line:
# arrows of random sign give the same line field as the correctly signed ones.

signs = rng.choice([-1.0, 1.0], len(stations))
lines = manifill.reconstruct_vectors(V, F, stations, truth[stations] * signs[:, None], symmetry=2, normal="drop")
unit = lines.values / np.linalg.norm(lines.values, axis=1, keepdims=True)
tu = t / np.linalg.norm(t, axis=1, keepdims=True)
angle = np.degrees(np.arccos(np.clip(np.abs(np.sum(unit * tu, axis=1)), 0, 1)))
fig, ax = plt.subplots(figsize=(6, 3.2), layout="constrained")
ax.hist(angle, bins=40, color="C0")
ax.set_xlabel("angle between the line field and the true direction (degrees)")
ax.set_ylabel("vertices")
ax.set_title(f"line field from arrows of random sign: median {np.median(angle):.2f} degrees")
plt.show()
