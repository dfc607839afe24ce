"""Bad EEG channels: manifill's ``interpolate_bads`` beside MNE-Python's own (spherical splines), same data.

``python -m bench.mne_adapter [--trials 20] [--methods biharmonic,gp]``: MNE's shipped biosemi 32, 64 and 128
montages; the electrodes moved onto MNE's shipped fsaverage scalp (a cap on that head) or left at the montage's
positions (``--as-given``); the potential of three current dipoles 2.5 cm under the scalp (random places and
orientations, infinite homogeneous medium) at the electrodes, or (``--model sphere``) of three dipoles in the brain
(random places 0.5-0.85 of the head's radius from its centre, above the ears, random orientations) through MNE's
four-shell spherical head model fitted to the cap (``mne.make_sphere_model``, ``mne.make_forward_dipole``: brain,
CSF, skull, scalp conductivities); 10% of the channels marked bad; the RMS error on the bad channels over all trials
for manifill and for ``inst.interpolate_bads()``, and their ratio. Then the time to fill an ``Epochs`` of 100 epochs
x 1,000 samples x 64 channels (6 bad), both, alternated; ``--sizes 0,1,2``: the map's build on the head refined.
``interpolate_to``: the 32-channel cap's data moved onto the 64-channel cap, and 64 onto 128, beside MNE's own.
"""

import argparse
import time

import numpy as np

import igl
import mne
from manifill.adapters.mne import ScalpMap, electrodes, forget_maps, head_surface, interpolate_bads, interpolate_to
from manifill.surface.locate import locate_points

MONTAGES = ("biosemi32", "biosemi64", "biosemi128")


def cap(name, on):
    """The montage ``name`` with its electrodes at ``on`` (head coordinates)."""
    mon = mne.channels.make_standard_montage(name)
    fid = mon.get_positions()
    return mne.channels.make_dig_montage(ch_pos=dict(zip(mon.ch_names, on)), nasion=fid["nasion"], lpa=fid["lpa"],
                                         rpa=fid["rpa"], coord_frame="head")


def montage_info(name, V, F, on_scalp):
    mon = mne.channels.make_standard_montage(name)
    info = mne.create_info(mon.ch_names, 500.0, "eeg")
    info.set_montage(mon)
    _, P = electrodes(info)
    if not on_scalp:
        return info, P
    on = locate_points(V, F, P, max_distance=0.05).points
    info = mne.create_info(mon.ch_names, 500.0, "eeg")
    info.set_montage(cap(name, on))
    return info, on


def potential(P, V, rng, depth=0.025):
    centre, out = V.mean(axis=0), np.zeros(len(P))
    for _ in range(3):
        i = rng.integers(len(V))
        r0 = V[i] - depth * (V[i] - centre) / np.linalg.norm(V[i] - centre)
        d = P - r0
        out += (d @ rng.normal(size=3)) / np.linalg.norm(d, axis=1) ** 3
    return out


def sphere_potentials(info, sphere, rng, fields=4, dipoles=3):
    """``(channels, fields)``: each column the potential of ``dipoles`` random dipoles in the brain, MNE's forward."""
    r0, radius, pos = sphere["r0"], sphere.radius, []
    while len(pos) < fields * dipoles:
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        if u[2] >= 0.1:  # above the ears
            pos.append(r0 + u * radius * rng.uniform(0.5, 0.85))
    ori = rng.normal(size=(len(pos), 3))
    ori /= np.linalg.norm(ori, axis=1)[:, None]
    dip = mne.Dipole(np.arange(len(pos)) * 1e-3, np.array(pos), np.full(len(pos), 1e-8), ori, np.ones(len(pos)))
    G = mne.make_forward_dipole(dip, sphere, info)[0]["sol"]["data"]
    return np.column_stack([G[:, dipoles * t:dipoles * (t + 1)].sum(axis=1) for t in range(fields)])


def accuracy(name, methods, trials, on_scalp, model="infinite"):
    V, F = head_surface()
    info, P = montage_info(name, V, F, on_scalp)
    sphere = mne.make_sphere_model("auto", "auto", info) if model == "sphere" else None
    errs = {m: [] for m in methods + ["mne"]}
    for trial in range(trials):
        rng = np.random.default_rng(trial)
        if sphere is None:
            data = np.column_stack([potential(P, V, np.random.default_rng(1000 * trial + t)) for t in range(4)])
        else:
            data = sphere_potentials(info, sphere, np.random.default_rng(1000 + trial))
        ev = mne.EvokedArray(data, info.copy())
        bads = list(rng.choice(info["ch_names"], max(1, len(P) // 10), replace=False))
        ev.info["bads"] = bads
        bi = [info["ch_names"].index(b) for b in bads]
        for m in methods:
            kw = {"gp": {"range": 0.1, "sigma": 1.0}} if m == "gp" else {}
            errs[m].append(np.mean((interpolate_bads(ev, method=m, **kw).data[bi] - data[bi]) ** 2))
        errs["mne"].append(np.mean((ev.copy().interpolate_bads().data[bi] - data[bi]) ** 2))
    rms = {m: float(np.sqrt(np.mean(e))) for m, e in errs.items()}
    line = ", ".join(f"{m} {rms[m]:.4g} ({rms[m] / rms['mne']:.2f}x)" for m in methods)
    where = f"{'on the scalp' if on_scalp else 'as given'}, {model} model"
    print(f"{name} ({len(P)} channels, {trials} trials, {where}): mne "
          f"{rms['mne']:.4g}; {line}")


def moved(source, dest, trials, model):
    """``interpolate_to``: a cap's data moved onto a denser cap, ours beside MNE's (spherical splines)."""
    V, F = head_surface()
    info, P = montage_info(source, V, F, True)
    tinfo, T = montage_info(dest, V, F, True)
    both = mne.create_info(info["ch_names"] + [f"to {n}" for n in tinfo["ch_names"]], 500.0, "eeg")
    both.set_montage(mne.channels.make_dig_montage(ch_pos=dict(zip(both["ch_names"], np.vstack([P, T]))),
                                                   coord_frame="head"))
    sphere = mne.make_sphere_model("auto", "auto", info) if model == "sphere" else None
    ours, theirs = [], []
    for trial in range(trials):
        if sphere is None:
            d = np.column_stack([potential(np.vstack([P, T]), V, np.random.default_rng(1000 * trial + t))
                                 for t in range(4)])
        else:
            d = sphere_potentials(both, sphere, np.random.default_rng(1000 + trial))
        ev = mne.EvokedArray(d[:len(P)], info.copy())
        ours.append(np.mean((interpolate_to(ev, cap(dest, T)).data - d[len(P):]) ** 2))
        theirs.append(np.mean((ev.copy().interpolate_to(cap(dest, T), method="spline").data - d[len(P):]) ** 2))
    a, b = np.sqrt(np.mean(ours)), np.sqrt(np.mean(theirs))
    print(f"interpolate_to {source} -> {dest} ({trials} trials, {model} model): mne {b:.4g}; manifill biharmonic "
          f"{a:.4g} ({a / b:.2f}x)")


def timing(repeats):
    mon = mne.channels.make_standard_montage("biosemi64")
    info = mne.create_info(mon.ch_names, 1000.0, "eeg")
    info.set_montage(mon)
    rng = np.random.default_rng(0)
    ep = mne.EpochsArray(rng.normal(size=(100, 64, 1000)), info)
    ep.info["bads"] = list(rng.choice(mon.ch_names, 6, replace=False))
    cold, warm, theirs = [], [], []
    for _ in range(repeats):  # alternated: a first call (the map built), a later one (the map kept), MNE's
        forget_maps()
        t = time.perf_counter()
        interpolate_bads(ep)
        cold.append(time.perf_counter() - t)
        t = time.perf_counter()
        interpolate_bads(ep)
        warm.append(time.perf_counter() - t)
        t = time.perf_counter()
        ep.copy().interpolate_bads()
        theirs.append(time.perf_counter() - t)
    m = min(theirs)
    print(f"Epochs 100 x 1,000 x 64 (6 bad), minimum of {repeats}: mne {m:.3f} s; manifill first call (the map built) "
          f"{min(cold):.3f} s ({min(cold) / m:.2f}x), a later call with the same cap and bads (the map kept) "
          f"{min(warm):.3f} s ({min(warm) / m:.2f}x)")
    to = mne.channels.make_standard_montage("colin27_1020")
    cold, warm, theirs = [], [], []
    for _ in range(repeats):
        forget_maps()
        for into in (cold, warm):
            t = time.perf_counter()
            interpolate_to(ep, to)
            into.append(time.perf_counter() - t)
        t = time.perf_counter()
        ep.interpolate_to(to, method="spline")
        theirs.append(time.perf_counter() - t)
    m = min(theirs)
    print(f"interpolate_to the same Epochs onto colin27_1020 (94 channels): mne {m:.3f} s; manifill first call "
          f"{min(cold):.3f} s ({min(cold) / m:.2f}x), later {min(warm):.3f} s ({min(warm) / m:.2f}x)")


def map_sizes(levels):
    """The scalp map's build time on fsaverage's head refined by Loop subdivision (a subject's denser scalp)."""
    V0, F0 = head_surface()
    info, _ = montage_info("biosemi64", V0, F0, True)
    names = info["ch_names"]
    for level in levels:
        V, F = (V0, F0) if level == 0 else igl.loop(V0, F0, level)
        t = time.perf_counter()
        ScalpMap(info, names[6:], names[:6], surface=(np.asarray(V), np.asarray(F)))
        print(f"scalp map, 58 good and 6 bad channels, head with {len(V):,} vertices: {time.perf_counter() - t:.2f} s")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=20)
    p.add_argument("--methods", default="biharmonic,triharmonic,gp,rbf")
    p.add_argument("--as-given", action="store_true")
    p.add_argument("--model", default="infinite,sphere", help="infinite (homogeneous medium), sphere (MNE's shells)")
    p.add_argument("--repeats", type=int, default=7)
    p.add_argument("--sizes", default="", help="Loop subdivision levels of the head to time the map on, e.g. 0,1,2")
    a = p.parse_args(argv)
    mne.set_log_level("ERROR")
    for model in a.model.split(","):
        for name in MONTAGES:
            accuracy(name, a.methods.split(","), a.trials, not a.as_given, model)
        for source, dest in zip(MONTAGES, MONTAGES[1:]):
            moved(source, dest, a.trials, model)
    timing(a.repeats)
    if a.sizes:
        map_sizes([int(x) for x in a.sizes.split(",")])


if __name__ == "__main__":
    main()
