"""
A time series for ParaView: .pvd and .xdmf
==========================================

A recording is many fields on one mesh: the same sensors, a value per time step.
:func:`manifill.reconstruct_series` prepares the reconstruction once (partition, Laplacian, factorisation) and
applies it to chunks of time steps, streaming each chunk to the file so that memory does not grow with the number
of steps. The file's format is its extension: ``.xdmf`` (with its ``.h5``, the ``[series]`` extra) or ``.pvd`` (a
ParaView collection of ``.vtu`` files), both of which ParaView plays as an animation; ``.h5`` and ``.npy`` hold the
values alone.

Here a wave travels round a sphere, measured at 60 vertices for 40 steps; the series is written both ways into a
temporary folder and read back, the ``.pvd`` with pyvista and the ``.xdmf`` with meshio.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import meshio
import numpy as np
import pyvista as pv

import manifill
from manifill.mesh.shapes import icosphere

pv.OFF_SCREEN = True

# %%
# A travelling wave, sampled at 60 vertices
# -----------------------------------------

V, F = icosphere(4)
lon = np.arctan2(V[:, 1], V[:, 0])
times = np.linspace(0.0, 2.0, 40)  # seconds
truth = np.cos(2 * lon[:, None] - np.pi * times[None, :]) * (1 - V[:, 2:3] ** 2) + 0.3 * V[:, 2:3]  # (n, 40)
rng = np.random.default_rng(6)
idx = rng.choice(len(V), 60, replace=False)
vals = truth[idx]  # (60, 40): one row per sample, one column per time step

# %%
# Write the series: XDMF + HDF5, and ParaView's PVD
# -------------------------------------------------

folder = Path(tempfile.mkdtemp())
for name in ["wave.xdmf", "wave.pvd"]:
    s = manifill.reconstruct_series(V, F, idx, vals, folder / name, times=times, name="wave", chunk=16)
    print(f"{name}: {s.steps} steps in {s.chunks} chunks of {s.chunk}, {s.seconds['total']:.2f} s")
print(sorted(p.name for p in folder.iterdir()))

# %%
# Read the ``.pvd`` back with pyvista, and draw four steps
# --------------------------------------------------------

reader = pv.get_reader(folder / "wave.pvd")
print(len(reader.time_values), "time values, from", reader.time_values[0], "to", reader.time_values[-1])
shown = [0, 10, 20, 30]
from_pvd = {}
pl = pv.Plotter(shape=(1, 4), window_size=(1600, 480), border=False)
for j, k in enumerate(shown):
    reader.set_active_time_value(reader.time_values[k])
    step = reader.read()[0]  # the step's .vtu: the field "wave" and "sample_mask"
    from_pvd[k] = np.asarray(step["wave"])
    pl.subplot(0, j)
    pl.add_mesh(step, scalars="wave", cmap="RdBu_r", clim=(-1, 1), smooth_shading=True, show_scalar_bar=j == 1,
                scalar_bar_args=dict(title="wave (all four steps)", vertical=False, position_x=0.1, position_y=0.03,
                                     width=0.8, height=0.12, n_labels=5, fmt="%.1f", color="black"))
    pl.add_points(step.points[step.point_data["sample_mask"] == 1] * 1.01, color="red", point_size=8,
                  render_points_as_spheres=True)
    pl.add_text(f"t = {reader.time_values[k]:.2f} s", font_size=12, color="black", position="upper_edge")
    pl.view_vector((0.3, -1.0, 0.35), viewup=(0, 0, 1))
    pl.camera.zoom(1.25)
    pl.set_background("white")
pl.link_views()
pl.show()

# %%
# Read the ``.xdmf`` back with meshio
# -----------------------------------
# ``meshio.xdmf.TimeSeriesReader`` (not ``meshio.read``, which cannot read a time series): the mesh once, then
# one step at a time. Here, the time course at three unsampled vertices against the truth.

with meshio.xdmf.TimeSeriesReader(folder / "wave.xdmf") as ts:
    points, cells = ts.read_points_cells()
    steps = [ts.read_data(k) for k in range(ts.num_steps)]
t_read = np.array([t for t, _, _ in steps])
X = np.column_stack([pd["wave"] for _, pd, _ in steps])  # (n, 40)
print("the .xdmf holds the same values as the .pvd:", all(np.allclose(X[:, k], from_pvd[k]) for k in shown))
free = np.setdiff1d(np.arange(len(V)), idx)
print(f"RMS error over the unsampled vertices and all steps: {np.sqrt(np.mean((X - truth)[free] ** 2)):.3f}")

watch = free[[100, 900, 1700]]
fig, ax = plt.subplots(figsize=(8, 3.6), layout="constrained")
for j, v in enumerate(watch):
    ax.plot(times, truth[v], "--", color=f"C{j}", lw=1)
    ax.plot(t_read, X[v], "o", color=f"C{j}", ms=3, label=f"vertex {v}")
ax.set_xlabel("time (s)")
ax.set_ylabel("wave")
ax.set_title("read from the .xdmf (dots) against the truth (dashed), at three unsampled vertices")
ax.legend(loc="upper right", fontsize=8)
plt.show()
