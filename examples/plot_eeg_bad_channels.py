"""
EEG: repair two bad channels through the MNE adapter
====================================================

Two electrodes of a recording went bad: one is flat, the other picked up line noise. MNE-Python marks them in
``info["bads"]``; :func:`manifill.adapters.mne.interpolate_bads` returns a copy whose bad EEG channels are filled
from the good ones *along the scalp* (fsaverage's head, which ships inside MNE: nothing is downloaded), with
manifill's biharmonic fill by default. The map from the good channels to the bad ones is built once and applied to
every time sample.

The data here are synthetic, so the true values of the bad channels are known and the repair can be checked.
"""

import matplotlib.pyplot as plt
import mne
import numpy as np
import pyvista as pv

from manifill.adapters.mne import electrodes, head_surface, interpolate_bads, to_surface

pv.OFF_SCREEN = True

# %%
# A synthetic evoked response on the 10-20 montage
# ------------------------------------------------
# MNE ships the 10-20 positions of the Colin27 template (``"colin27_1020"``, the name ``"standard_1020"`` had
# before MNE 1.13). The old names T3/T4/T5/T6 repeat the positions of T7/T8/P7/P8 (a scalp map cannot draw two
# electrodes at one place) and the ear and mastoid references A1/A2/M1/M2 are not scalp channels, so they are left
# out: 86 electrodes remain.
#
# The potentials are those of two current dipoles inside the head (the potential of a dipole in an unbounded
# conductor), each with its own time course.

name = "colin27_1020" if "colin27_1020" in mne.channels.get_builtin_montages() else "standard_1020"
montage = mne.channels.make_standard_montage(name)
drop = {"T3", "T4", "T5", "T6", "M1", "M2", "A1", "A2"}
ch_names = [c for c in montage.ch_names if c not in drop]
info = mne.create_info(ch_names, sfreq=250.0, ch_types="eeg")
info.set_montage(montage)  # the montage's extra channels are ignored
_, pos = electrodes(info)  # (86, 3) electrode positions, head coordinates, metres


def dipole_potential(r, r0, p):
    """Potential (arbitrary units) at positions r of a current dipole p at r0."""
    d = r - r0
    return d @ p / np.linalg.norm(d, axis=1) ** 3


times = np.arange(-0.05, 0.4, 1 / info["sfreq"])
wave1 = np.exp(-0.5 * ((times - 0.10) / 0.025) ** 2)  # an early, lateral component
wave2 = np.exp(-0.5 * ((times - 0.25) / 0.05) ** 2)  # a later, central one
topo1 = dipole_potential(pos, np.array([-0.035, 0.0, 0.055]), np.array([0.4, 0.2, 1.0]))
topo2 = dipole_potential(pos, np.array([0.0, -0.02, 0.06]), np.array([0.0, -0.6, 1.0]))
scale = 1e-6 / np.abs(topo1).max() * 8  # about 8 microvolts at the peak
truth = scale * (np.outer(topo1, wave1) + np.outer(topo2, wave2))
evoked_true = mne.EvokedArray(truth, info, tmin=times[0], verbose=False)

# %%
# Two channels go bad
# -------------------
# C3 lies over the first dipole and goes flat; CP4 picks up 50 Hz noise.

bads = ["C3", "CP4"]
data = truth.copy()
rng = np.random.default_rng(0)
data[ch_names.index("C3")] = 0.0
data[ch_names.index("CP4")] += 15e-6 * np.sin(2 * np.pi * 50 * times) + 2e-6 * rng.standard_normal(times.size)
evoked = mne.EvokedArray(data, info.copy(), tmin=times[0], verbose=False)
evoked.info["bads"] = bads

fixed = interpolate_bads(evoked)  # a copy: the bad channels filled, info["bads"] emptied
print("bads after the repair:", fixed.info["bads"])
for ch in bads:
    i = ch_names.index(ch)
    err = np.sqrt(np.mean((fixed.data[i] - truth[i]) ** 2)) / np.ptp(truth[i])
    print(f"{ch}: RMS error of the repaired channel {100 * err:.1f}% of its range")

# %%
# Scalp maps before and after
# ---------------------------
# The maps at the first peak (100 ms): the true potentials, the recording with its two bad channels (drawn as
# white circles), and the repaired recording.

t_peak = np.argmin(np.abs(times - 0.10))
mask = np.isin(ch_names, bads)[:, None]
vlim = np.ceil(np.abs(truth[:, t_peak]).max() * 1e6)  # a round colour range, the same in every map
fig, axes = plt.subplots(1, 3, figsize=(11, 4), layout="constrained")
panels = [("true potentials", truth), ("recorded: C3 flat, CP4 noisy", data), ("after interpolate_bads", fixed.data)]
for ax, (title, d) in zip(axes, panels):
    im, _ = mne.viz.plot_topomap(d[:, t_peak] * 1e6, evoked.info, axes=ax, show=False, vlim=(-vlim, vlim),
                                 cmap="RdBu_r", mask=mask, contours=6,
                                 mask_params=dict(marker="o", markerfacecolor="w", markeredgecolor="k", markersize=9))
    ax.set_title(title)
fig.colorbar(im, ax=axes, shrink=0.8, label="potential at 100 ms (µV)")
fig.suptitle("86 electrodes; the two bad ones circled")

# %%
# The bad channels' time courses: the flat line and the noise are replaced by values close to the truth.

fig, axes = plt.subplots(1, 2, figsize=(11, 3.5), layout="constrained", sharey=True)
for ax, ch in zip(axes, bads):
    i = ch_names.index(ch)
    ax.plot(times * 1e3, data[i] * 1e6, color="0.6", label="recorded (bad)")
    ax.plot(times * 1e3, truth[i] * 1e6, "k--", lw=2, label="true")
    ax.plot(times * 1e3, fixed.data[i] * 1e6, color="C3", label="manifill")
    ax.set_title(ch)
    ax.set_xlabel("time (ms)")
axes[0].set_ylabel("potential (µV)")
axes[0].legend(loc="upper right")

# %%
# The field over the whole scalp
# ------------------------------
# :func:`~manifill.adapters.mne.to_surface` gives the field at every vertex of the scalp (one column per time
# sample) as a :class:`manifill.Reconstruction`; here it is drawn at 100 ms, with the electrodes it came from as
# black dots and the two repaired channels in red.

scalp = to_surface(fixed)
V, F = head_surface()
mesh = pv.PolyData(V, np.column_stack([np.full(len(F), 3), F]).ravel())
mesh.point_data["potential at 100 ms (µV)"] = scalp.values[:, t_peak] * 1e6

pl = pv.Plotter(window_size=(800, 650))
pl.add_mesh(mesh, cmap="RdBu_r", clim=(-vlim, vlim), smooth_shading=True,
            scalar_bar_args=dict(title="potential at 100 ms (µV)", vertical=False, position_x=0.2, position_y=0.04,
                                 width=0.6, height=0.1, n_labels=5, fmt="%.0f", color="black"))
good = ~np.isin(ch_names, bads)
pl.add_points(pos[good], color="black", point_size=8, render_points_as_spheres=True)
pl.add_points(pos[~good], color="red", point_size=14, render_points_as_spheres=True)
pl.add_text("fsaverage scalp, field from the 84 good electrodes (black);\nthe repaired C3 and CP4 in red",
            font_size=11, color="black")
pl.set_background("white")
pl.view_vector((0.0, -0.3, 1.0), viewup=(0, 1, 0))  # from above, the nose at the top, as in the maps
pl.camera.zoom(1.2)
pl.show()

plt.show()
