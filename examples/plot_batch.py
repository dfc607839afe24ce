"""
A batch of jobs on a local Dask cluster
=======================================

A study of many subjects, a collection of shapes, years of fields on one globe: each is one ``manifill
reconstruct`` (or ``manifill volume``) command, and :func:`manifill.batch` runs a list of them on a Dask cluster
(the ``[batch]`` extra) -- a local one of worker processes, as here, or an existing cluster by its address. Each
job runs exactly as its command line would, writes its outputs whole or not at all, and gets a row in a summary
CSV (status, seconds, peak memory, the worker, the one-line error of a job that failed). A re-run skips the jobs
already done with the same inputs and options.

Here, three tiny "subjects" (spheres of slightly different shapes with their own samples) and a manifest in TOML,
all in a temporary folder, run on a local Dask cluster. A fourth job points to a samples file that does not exist:
it fails alone, with its reason in the summary, and the others go on.
"""

import tempfile
from pathlib import Path

import distributed
import matplotlib.pyplot as plt
import numpy as np
import pyvista as pv

import manifill
from manifill.mesh.shapes import icosphere

pv.OFF_SCREEN = True

# %%
# Three subjects' meshes and samples, and a manifest
# --------------------------------------------------

folder = Path(tempfile.mkdtemp())
rng = np.random.default_rng(7)
V0, F = icosphere(3)  # 642 vertices each
for s in range(1, 4):
    V = V0 * np.array([1.0, 1.0 + 0.15 * s, 1.0 - 0.1 * s])  # each subject its own ellipsoid
    manifill.write_mesh(folder / f"sub{s}.vtp", V, F)
    idx = np.sort(rng.choice(len(V), 40, replace=False))
    vals = np.sin(2 * V[idx, 0] + s) + V[idx, 2]
    np.savetxt(folder / f"sub{s}.csv", np.column_stack([idx, vals]), fmt=["%d", "%.6f"], delimiter=",",
               header="vertex,value", comments="")

manifest = folder / "jobs.toml"
manifest.write_text("""
[defaults]
bounds = "samples"

[[job]]
mesh = "sub1.vtp"
samples = "sub1.csv"
output = "out/sub1.vtu"
method = "harmonic"

[[job]]
mesh = "sub2.vtp"
samples = "sub2.csv"
output = "out/sub2.vtu"

[[job]]
mesh = "sub3.vtp"
samples = "sub3.csv"
output = "out/sub3.vtu"
method = "biharmonic"

[[job]]
id = "broken"
mesh = "sub3.vtp"
samples = "missing.csv"
output = "out/broken.vtu"
""")

# %%
# Run the batch
# -------------
# ``manifill.batch(manifest, workers=2)`` starts a local cluster of two worker *processes* and closes it at the end;
# ``scheduler="tcp://host:8786"`` sends the jobs to an existing cluster instead. Dask starts its worker processes
# as fresh interpreters that import the main script again, so a script that does so must keep the call under
# ``if __name__ == "__main__":`` -- which a gallery page, cut into cells, cannot. Here the cluster's worker is a
# thread of this process instead (``processes=False``), given to ``batch`` as its ``scheduler``; the jobs run
# exactly as they would on a worker process.

client = distributed.Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0")
result = manifill.batch(manifest, scheduler=client)
print(result.counts(), f"in {result.seconds:.1f} s on {result.workers} worker(s); summary: {result.summary.name}")
for row in result.rows:
    print(f"{row['id']:>7}  {row['status']:<7} {row['seconds'] or '-':>6}  {row['error'][:90]}")

# %%
# A second run skips what is done (same inputs, options and manifill version, outputs still there):

again = manifill.batch(manifest, scheduler=client)
print(again.counts())
client.close()

# %%
# The outputs
# -----------
# Each ``.vtu`` holds the field and the sample mask, as pyvista and ParaView read them.

done = [row for row in result.rows if row["status"] == "done"]
pl = pv.Plotter(shape=(1, len(done)), window_size=(1500, 520), border=False)
for j, row in enumerate(done):
    mesh = pv.read(folder / row["output"])
    pl.subplot(0, j)
    pl.add_mesh(mesh, scalars="value", cmap="viridis", clim=(-2, 2), smooth_shading=True, show_scalar_bar=j == 1,
                scalar_bar_args=dict(title="value (all three jobs)", vertical=False, position_x=0.1, position_y=0.03,
                                     width=0.8, height=0.12, n_labels=5, fmt="%.0f", color="black"))
    pl.add_points(mesh.points[mesh.point_data["sample_mask"] == 1] * 1.01, color="red", point_size=9,
                  render_points_as_spheres=True)
    method = {"sub1": "harmonic", "sub3": "biharmonic"}.get(row["id"], "default")
    pl.add_text(f"{row['id']} ({method}), {float(row['seconds']):.2f} s", font_size=11, color="black",
                position="upper_edge")
    pl.view_vector((1.0, -1.0, 0.6), viewup=(0, 0, 1))
    pl.set_background("white")
pl.link_views()
pl.camera.zoom(1.2)
pl.show()

# %%
# The summary as a chart: each job's time and the worker's peak memory (here the worker is this process, so its
# peak includes this script's own memory).

fig, ax = plt.subplots(figsize=(7, 3), layout="constrained")
ids = [row["id"] for row in result.rows]
secs = [float(row["seconds"] or 0) for row in result.rows]
colours = ["C2" if row["status"] == "done" else "C3" for row in result.rows]
ax.barh(ids, secs, color=colours)
for j, row in enumerate(result.rows):
    reason = row["error"].split(": ")[-1]  # the one-line error, without the job's name and the file's path
    note = f" {row['peak_mb']} MB peak" if row["status"] == "done" else f" {row['status']}: {reason}"
    ax.text(secs[j], j, note, va="center", fontsize=8)
ax.set_xlabel("seconds on the worker")
ax.set_title("jobs.summary.csv")
ax.set_xlim(0, max(secs) * 2.5)
ax.invert_yaxis()  # the manifest's order, top down
plt.show()
