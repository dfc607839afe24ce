"""
A barrier the field must not cross
==================================

Some fields jump across a line: temperature across a crack in a plate, salinity across a coastline, activity
across a sulcus. ``barriers=`` names such lines, as paths of vertices (joined along edges) or as per-face labels;
the mesh is cut along them for the work, so no method sees across, and the result keeps the mesh's numbering.

Here a square plate has a crack from its bottom edge up to its middle. The true field is the angle around the
crack's tip: it jumps by 2 across the crack and is smooth everywhere else, including round the tip, where a
barrier that ends inside the surface lets the field go round its end.
"""

import matplotlib.pyplot as plt
import matplotlib.tri as mtri
import numpy as np

import manifill
from manifill.mesh.shapes import grid

# %%
# A plate, a crack and 120 samples
# --------------------------------

V, F = grid(41)  # 41 x 41 vertices on the unit square
x, y = V[:, 0], V[:, 1]
tip = (0.5, 0.6)


def field(x, y):
    """The angle round the crack's tip (a jump of 2 across the crack), plus a gentle slope."""
    return np.arctan2(x - tip[0], y - tip[1]) / np.pi + 0.5 * x


truth = field(x, y)

crack = np.flatnonzero(np.isclose(x, tip[0]) & (y <= tip[1] + 1e-9))
crack = crack[np.argsort(y[crack])]  # a path: from the bottom edge up to the tip, vertex after vertex
rng = np.random.default_rng(1)
idx = rng.choice(np.setdiff1d(np.arange(len(V)), crack), 120, replace=False)

# %%
# With and without the barrier
# ----------------------------

plain = manifill.reconstruct(V, F, idx, truth[idx])
cut = manifill.reconstruct(V, F, idx, truth[idx], barriers=[crack])
print(cut.report["barriers"])

off = np.setdiff1d(np.arange(len(V)), np.concatenate([idx, crack]))  # the crack's own vertices have two values
for name, r in [("without the barrier", plain), ("with barriers=[crack]", cut)]:
    print(f"{name}: RMS error {np.sqrt(np.mean((r.values - truth)[off] ** 2)):.3f}")

# %%
# The pictures
# ------------
# The field is drawn per face, at the faces' centres: ``r.at(points)`` (like ``r.gradient(at="cells")``) reads
# each face's own side of a barrier.

tri = mtri.Triangulation(x, y, F)
centroids = V[F].mean(axis=1)
panels = [("true field", field(centroids[:, 0], centroids[:, 1])),
          ("default, no barrier: smeared across", plain.at(centroids)), ("barriers=[crack]", cut.at(centroids))]
fig, axes = plt.subplots(1, 3, figsize=(13, 4.6), layout="constrained", sharey=True)
for ax, (title, c) in zip(axes, panels):
    im = ax.tripcolor(tri, facecolors=c, cmap="viridis", vmin=-1.0, vmax=1.5, antialiased=False)
    ax.plot(x[crack], y[crack], color="black", lw=3, label="crack (barrier)")
    ax.scatter(x[idx], y[idx], s=18, c="white", edgecolors="black", linewidths=0.7, label="samples")
    ax.set_title(title)
    ax.set_aspect("equal")
    ax.set_xlabel("x")
axes[0].set_ylabel("y")
axes[0].legend(loc="upper left", fontsize=8, framealpha=0.9)
fig.colorbar(im, ax=axes, shrink=0.85, label="field value")
plt.show()

# %%
# Along the line y = 0.3, across the crack: without the barrier the fill bridges the jump with a smooth ramp;
# with it, the jump stays where the crack is.

pts = np.column_stack([np.linspace(0.01, 0.99, 300), np.full(300, 0.3), np.zeros(300)])
fig, ax = plt.subplots(figsize=(7, 3.5), layout="constrained")
ax.plot(pts[:, 0], field(pts[:, 0], pts[:, 1]), "k--", label="true")
ax.plot(pts[:, 0], plain.at(pts), label="no barrier")
ax.plot(pts[:, 0], cut.at(pts), label="barriers=[crack]")
ax.axvline(tip[0], color="0.5", lw=4, alpha=0.4, label="crack")
ax.set_xlabel("x (at y = 0.3)")
ax.set_ylabel("field value")
ax.legend()
plt.show()
