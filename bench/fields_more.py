"""The accuracy cases of issue 12: noisy samples, a rough real field, EEG sensors on a head.

``sphere-noisy``
    The ``sphere-smooth`` field; the sample values get Gaussian noise of
    standard deviation 5 % of the field's range (seed ``(seed, k, 12)``, the
    same for every method); the truth stays the noise-free field.
``globe-image``
    The luminance (Rec. 709: ``0.2126 R + 0.7152 G + 0.0722 B`` of the 8-bit
    channels divided by 255) of pyvista's shipped ``2k_earth_daymap.jpg``
    (2048 x 1024, equirectangular) at each vertex's longitude and latitude,
    bilinear between pixel centres (periodic in longitude): a rough real field.
``cap-dipoles`` (open)
    The unit icosphere cut at ``z > -0.2`` (one boundary loop); the field is the potential of two
    current dipoles at depth 0.5 (:data:`CAP_DIPOLES`, the head's formula on the unit sphere).
``scalp-eeg`` (open)
    ``head-eeg``'s head cut 3 mm below its lowest electrode (the base gone): a scalp with a rim, the same montages
    and dipoles; errors over every vertex of the scalp.
``head-eeg``
    A closed head-like surface: the unit icosphere's directions ``u`` mapped to
    an ellipsoid of semi-axes 7.5 cm (left-right, x), 9.5 cm (back-front, y)
    and 8.5 cm (down-up, z), the base flattened below ``u_z = -0.45`` (the
    height is compressed to 30 % there through a smooth softplus blend of
    width 0.08, so the surface stays smooth) and a nose: a Gaussian bump of
    1.5 cm along ``u`` around the direction ``(0, 1, -0.15)`` (angular width
    0.18 rad). The electrodes are MNE's shipped montages ``biosemi32``,
    ``biosemi64`` and ``GSN-HydroCel-128`` (k = 32, 64, 128): each montage's
    positions are centred on their least-squares sphere, normalised to
    directions, sent through the same map onto the head and snapped to the
    nearest vertex, so every method gets the same sample vertices. The field
    is the potential of three current dipoles in an infinite homogeneous
    medium, ``phi(r) = sum_j p_j . (r - r_j) / (4 pi sigma |r - r_j|^3)`` with
    ``sigma = 0.33 S/m`` (closed form; the units cancel in the relative
    errors). Errors are measured over every vertex, the face and the base
    included (extrapolation below the electrodes counts).
"""

from pathlib import Path

import numpy as np

from .fields import Case, smooth_field

__all__ = ["noisy_case", "globe_case", "head_case", "head_surface", "dipole_potential", "MONTAGES", "cap_case",
           "scalp_case"]

NOISE = 0.05  # standard deviation of the sample noise, as a fraction of the field's range
MONTAGES = ("biosemi32", "biosemi64", "GSN-HydroCel-128")
AXES = np.array([0.075, 0.095, 0.085])  # the head's semi-axes in metres: x right, y front, z up
BASE, BASE_SQUASH, BASE_WIDTH = -0.45, 0.3, 0.08
NOSE_DIR = np.array([0.0, 1.0, -0.15]) / np.linalg.norm([0.0, 1.0, -0.15])
NOSE_HEIGHT, NOSE_WIDTH = 0.015, 0.18
SIGMA = 0.33  # S/m
DIPOLES = (  # (position in m, moment in A m)
    (np.array([0.030, 0.020, 0.045]), np.array([0.0, 1.0, 0.5]) * 1e-8),
    (np.array([-0.035, -0.030, 0.035]), np.array([0.6, 0.0, 1.0]) * 1e-8),
    (np.array([0.000, 0.045, 0.010]), np.array([-1.0, 0.3, 0.0]) * 0.6e-8),
)


def noisy_case(level):
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(level)
    V = V / np.abs(V).max()
    truth = smooth_field(V)
    sd = NOISE * float(np.ptp(truth))
    return Case("sphere-noisy", "Smooth field on a sphere, noisy samples (sigma = 5 % of the range)",
                f"icosphere level {level} ({len(V):,} vertices)",
                "sin(2x) + yz + 0.5 cos(3y); sample values + Gaussian noise, sigma = 5 % of the range "
                "(truth: noise-free)", V, F, truth, noise=sd,
                notes=[f"noise: sigma = {sd:.4f} (5 % of the range), seed (seed, k, 12), added to the sample "
                       "values only; the errors are against the noise-free field"])


def _image_luminance():
    import matplotlib.image as mpimg
    import pyvista.examples as ex

    img = np.asarray(mpimg.imread(Path(ex.__file__).with_name("2k_earth_daymap.jpg")), dtype=np.float64)
    if img.max() > 1.5:
        img = img / 255.0
    return img[..., 0] * 0.2126 + img[..., 1] * 0.7152 + img[..., 2] * 0.0722


def lonlat_bilinear(img, V):
    """Bilinear sample of an equirectangular image (row 0 = north) at the directions of ``V``."""
    h, w = img.shape
    U = V / np.linalg.norm(V, axis=1, keepdims=True)
    lon = np.arctan2(U[:, 1], U[:, 0])  # -pi..pi, column 0 at -180 degrees
    lat = np.arcsin(np.clip(U[:, 2], -1, 1))
    x = (lon + np.pi) / (2 * np.pi) * w - 0.5
    y = (np.pi / 2 - lat) / np.pi * h - 0.5
    y = np.clip(y, 0, h - 1)
    x0, y0 = np.floor(x).astype(np.int64), np.minimum(np.floor(y).astype(np.int64), h - 2)
    fx, fy = x - x0, y - y0
    x0, x1 = x0 % w, (x0 + 1) % w
    top = img[y0, x0] * (1 - fx) + img[y0, x1] * fx
    bottom = img[y0 + 1, x0] * (1 - fx) + img[y0 + 1, x1] * fx
    return top * (1 - fy) + bottom * fy


def globe_case(level):
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(level)
    return Case("globe-image", "Rough real field: Earth image luminance on a sphere",
                f"icosphere level {level} ({len(V):,} vertices)",
                "luminance of pyvista's 2k_earth_daymap.jpg (Rec. 709 weights), bilinear in longitude/latitude",
                V, F, lonlat_bilinear(_image_luminance(), V))


def head_surface(U):
    """The head map: unit directions ``(n, 3)`` to points on the head (metres)."""
    U = np.asarray(U, dtype=np.float64)
    z = U[:, 2]
    t = (z - BASE) / BASE_WIDTH
    soft = BASE_WIDTH * np.logaddexp(0.0, t)  # smooth max(z - BASE, 0)
    z = BASE + BASE_SQUASH * (z - BASE) + (1 - BASE_SQUASH) * soft
    P = np.column_stack([U[:, 0], U[:, 1], z]) * AXES
    ang = np.arccos(np.clip(U @ NOSE_DIR, -1, 1))
    return P + (NOSE_HEIGHT * np.exp(-0.5 * (ang / NOSE_WIDTH) ** 2))[:, None] * U


def dipole_potential(P):
    """Potential of :data:`DIPOLES` in an infinite medium of conductivity :data:`SIGMA`, at ``P`` (n, 3)."""
    out = np.zeros(len(P))
    for r0, p in DIPOLES:
        d = P - r0
        out += (d @ p) / (4 * np.pi * SIGMA * np.linalg.norm(d, axis=1) ** 3)
    return out


def fit_sphere(P):
    """Least-squares sphere through points: (centre, radius)."""
    A = np.column_stack([2 * P, np.ones(len(P))])
    sol, *_ = np.linalg.lstsq(A, (P**2).sum(axis=1), rcond=None)
    c = sol[:3]
    return c, float(np.sqrt(sol[3] + c @ c))


def montage_vertices(name, V):
    """Sample vertices of one MNE montage on the head mesh ``V`` (sorted, distinct) and the dropped count."""
    import mne

    pos = mne.channels.make_standard_montage(name).get_positions()["ch_pos"]
    P = np.array(list(pos.values()), dtype=np.float64)
    c, _ = fit_sphere(P)
    D = P - c
    D /= np.linalg.norm(D, axis=1, keepdims=True)
    from scipy.spatial import cKDTree

    _, idx = cKDTree(V).query(head_surface(D))
    uniq = np.unique(idx)
    return uniq.astype(np.int64), len(idx) - len(uniq)


def head_case(level):
    """The head with the montages' electrodes as fixed sample sets (needs mne: ImportError otherwise)."""
    import mne  # noqa: F401  (the montages ship inside mne)

    from manifill.mesh.shapes import icosphere

    U, F = icosphere(level)
    V = head_surface(U)
    layouts, dropped = {}, []
    for name in MONTAGES:
        idx, lost = montage_vertices(name, V)
        layouts[len(idx)] = (name, idx)
        if lost:
            dropped.append(f"{name}: {lost} electrode(s) on an already used vertex")
    notes = ["samples: the electrodes of MNE's " + ", ".join(f"{n} (k = {k})" for k, (n, _) in layouts.items())
             + ", snapped to the nearest vertex; one fixed layout per k, so no seeds",
             "errors over every vertex (face and base included: below the electrodes every method extrapolates)"]
    if dropped:
        notes.append("; ".join(dropped))
    return Case("head-eeg", "EEG: three dipoles' potential on a head, electrodes of MNE montages",
                f"head-like closed surface (ellipsoid 15 x 19 x 17 cm, flattened base, nose) from icosphere level "
                f"{level} ({len(V):,} vertices)",
                "potential of three current dipoles inside the head, infinite homogeneous medium (closed form)",
                V, F, dipole_potential(V), layouts=layouts, notes=notes)


CAP_Z = -0.2
CAP_DIPOLES = (  # (position, moment) inside the unit sphere
    (np.array([0.25, 0.10, 0.40]), np.array([0.0, 1.0, 0.5])),
    (np.array([-0.30, -0.20, 0.25]), np.array([0.6, 0.0, 1.0])),
)


def _cut(V, F, keep_vertex):
    """The faces whose corners all pass ``keep_vertex``, renumbered: ``(V, F, old index of each vertex)``."""
    F = F[keep_vertex[F].all(axis=1)]
    used = np.unique(F)
    new = np.full(len(V), -1)
    new[used] = np.arange(used.size)
    return V[used], new[F], used


def cap_case(level):
    """An open cap of the unit sphere with a two-dipole potential (see the module docstring)."""
    from manifill.mesh.shapes import icosphere

    U, F = icosphere(level)
    V, F, _ = _cut(U, F, U[:, 2] > CAP_Z)
    truth = np.zeros(len(V))
    for r0, p in CAP_DIPOLES:
        d = V - r0
        truth += (d @ p) / np.linalg.norm(d, axis=1) ** 3
    return Case("cap-dipoles", "Open cap: two dipoles' potential on a sphere cut at z > -0.2",
                f"icosphere level {level} cut at z > {CAP_Z} ({len(V):,} vertices, one boundary loop)",
                "potential of two current dipoles at depth 0.5 (closed form)", V, F, truth)


def scalp_case(level):
    """``head-eeg``'s head cut 3 mm below its lowest electrode: an open scalp (needs mne)."""
    head = head_case(level)
    lowest = min(head.V[idx, 2].min() for _, idx in head.layouts.values())
    V, F, old = _cut(head.V, head.F, head.V[:, 2] > lowest - 0.003)
    new = np.full(len(head.V), -1)
    new[old] = np.arange(old.size)
    layouts = {k: (name, np.sort(new[idx])) for k, (name, idx) in head.layouts.items()}
    return Case("scalp-eeg", "EEG on an open scalp: the head cut 3 mm below the lowest electrode",
                f"head-eeg's surface cut at z > {lowest - 0.003:.3f} m ({len(V):,} vertices, one rim)",
                head.field, V, F, head.truth[old], layouts=layouts, notes=head.notes[:1])
