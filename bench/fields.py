"""Meshes and known fields for the accuracy benchmark, and the samples drawn from them.

Every case is a mesh, a true field at its vertices and a rule for drawing ``k``
sample vertices with a fixed seed:

``sphere-smooth``
    ``sin(2x) + yz + 0.5 cos(3y)`` on an icosphere scaled so that its
    coordinates fill ``[-1, 1]``.
``sphere-step``
    1 on one side of a plane, 0 on the other, on the same icosphere.
``u-strip``
    A flat U-shaped strip whose two arms are close together; the field is a
    cosine of the exact planar geodesic distance from the tip of one arm,
    computed in closed form (straight where visible, tangent-arc-tangent
    around the inner bend otherwise). Two points facing each other across the
    gap are close in space and far apart on the surface.
``airplane``
    pyvista's airplane (cleaned, two Loop subdivisions, largest component:
    the open fuselage); the same kind of field of the exact geodesic distance
    (``igl.exact_geodesic``) from the nose.
``ant``
    pyvista's ant (cleaned, two Loop subdivisions), all fifteen components
    (legs, antennae, body parts that touch but are not connected); the field
    is the cosine of the exact geodesic distance from the tip of each
    component, within the component. Samples: one random vertex in each of the
    ``min(k, 15)`` largest components first, the rest uniformly at random, so
    every component has a sample when ``k >= 15`` (and the methods that need
    one per component fail below that, as they should).

The cases of issue 12 (``sphere-noisy``, ``globe-image``, ``head-eeg``) are in
:mod:`bench.fields_more`.
"""

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["Case", "cases", "draw_samples", "sample_values", "u_strip", "u_geodesic"]


@dataclass
class Case:
    """A mesh, a known field on it and how samples are drawn."""

    key: str
    title: str
    mesh: str
    field: str
    V: np.ndarray
    F: np.ndarray
    truth: np.ndarray
    stratify: np.ndarray = None  # component label of every vertex, when samples must cover them
    notes: list = field(default_factory=list)
    noise: float = 0.0  # standard deviation of Gaussian noise on the sample values (the truth stays clean)
    layouts: dict = None  # fixed sample sets {k: (name, idx)} instead of random ones (the EEG montages)

    @property
    def n(self):
        return len(self.V)


def sample_values(case, idx, seed):
    """The values every method gets at ``idx``: the truth, plus the case's noise (seed ``(seed, k, 12)``)."""
    vals = case.truth[idx]
    if case.noise:
        vals = vals + np.random.default_rng([int(seed), len(idx), 12]).normal(0.0, case.noise, len(idx))
    return vals


def draw_samples(case, k, seed):
    """``k`` distinct sample vertices, sorted; the same for every method (seed ``(seed, k)``).

    A case with fixed ``layouts`` returns the layout with ``k`` samples (the seed is not used).
    """
    if case.layouts is not None:
        return case.layouts[k][1]
    rng = np.random.default_rng([int(seed), int(k)])
    n = case.n
    if case.stratify is None:
        return np.sort(rng.choice(n, size=k, replace=False))
    labels = case.stratify
    count = int(labels.max()) + 1
    sizes = np.bincount(labels, minlength=count)
    order = np.argsort(-sizes, kind="stable")
    first = [int(rng.choice(np.flatnonzero(labels == c))) for c in order[:min(k, count)]]
    rest = np.setdiff1d(np.arange(n), first)
    more = rng.choice(rest, size=k - len(first), replace=False) if k > len(first) else np.empty(0, np.int64)
    return np.sort(np.concatenate([np.array(first, dtype=np.int64), more.astype(np.int64)]))


# ---------------------------------------------------------------------------
# the fields
# ---------------------------------------------------------------------------


def smooth_field(V):
    """``sin(2x) + yz + 0.5 cos(3y)`` (coordinates expected in [-1, 1])."""
    return np.sin(2 * V[:, 0]) + V[:, 1] * V[:, 2] + 0.5 * np.cos(3 * V[:, 1])


STEP_NORMAL = np.array([1.0, 2.0, 2.0]) / 3.0
STEP_OFFSET = 0.2


def step_field(V):
    """1 where ``n . x > 0.2`` with ``n = (1, 2, 2) / 3``, else 0."""
    return (V @ STEP_NORMAL > STEP_OFFSET).astype(np.float64)


def distance_field(d, scale):
    """``cos(3 pi d / scale)``: one and a half periods over the distance ``scale``."""
    return np.cos(3 * np.pi * d / scale)


# ---------------------------------------------------------------------------
# the U-shaped strip and its exact geodesic distance
# ---------------------------------------------------------------------------


def _in_u(P, gap, width, length):
    x, y = P[:, 0], P[:, 1]
    r = np.hypot(x, y)
    r0, r1 = gap / 2, gap / 2 + width
    arms = (y >= 0) & (y <= length) & (np.abs(x) >= r0) & (np.abs(x) <= r1)
    bend = (y < 0) & (r >= r0) & (r <= r1)
    return arms | bend


def u_strip(h=0.02, *, gap=0.15, width=1.0, length=3.0):
    """A flat U in the plane z = 0: two arms ``width`` wide, ``length`` long, ``gap`` apart.

    The arms run along +y from a half-annulus around the origin (inner radius
    ``gap / 2``). Vertices are a triangular lattice of spacing ``h`` inside the
    U; triangles are the lattice's Delaunay triangles whose centroids lie in
    the U (a jagged but well-shaped boundary).
    """
    from scipy.spatial import Delaunay

    from manifill.mesh.clean import clean_mesh

    r1 = gap / 2 + width
    dy = h * np.sqrt(3) / 2
    xs = np.arange(-r1 - h, r1 + h, h)
    ys = np.arange(-r1 - h, length + h, dy)
    X, Y = np.meshgrid(xs, ys)
    X = X + (np.arange(len(ys))[:, None] % 2) * (h / 2)
    P = np.column_stack([X.ravel(), Y.ravel()])
    P = P[_in_u(P, gap, width, length)]
    T = Delaunay(P).simplices
    longest = np.max(np.linalg.norm(P[T] - P[np.roll(T, 1, axis=1)], axis=2), axis=1)
    T = T[_in_u(P[T].mean(axis=1), gap, width, length) & (longest < 1.5 * h)]
    V, F, _ = clean_mesh(np.column_stack([P, np.zeros(len(P))]), T)
    return V, F


def u_geodesic(V, source, gap):
    """Exact geodesic distance in the U from ``source`` (a point in it) to every vertex.

    The obstacle between the arms (the slot and the disc of radius ``gap / 2``
    at the origin) is convex and the rest of the boundary is convex, so a
    shortest path is the straight segment when the two points see each other,
    and otherwise tangent - arc of the disc - tangent, around the bottom.
    Angles are measured from the downward direction, so going round the bottom
    never crosses the slot.
    """
    r = gap / 2
    s = np.asarray(source, dtype=np.float64)[:2]
    P = V[:, :2]
    rs, rp = np.hypot(*s), np.hypot(P[:, 0], P[:, 1])
    a_s = np.arctan2(s[0], -s[1])
    a_p = np.arctan2(P[:, 0], -P[:, 1])
    turn = np.abs(a_p - a_s)
    horizon = np.arccos(np.clip(r / rs, -1, 1)) + np.arccos(np.clip(r / np.maximum(rp, r), -1, 1))
    straight = np.hypot(P[:, 0] - s[0], P[:, 1] - s[1])
    around = np.sqrt(rs**2 - r**2) + np.sqrt(np.maximum(rp**2 - r**2, 0)) + r * (turn - horizon)
    return np.where(turn <= horizon, straight, around)


# ---------------------------------------------------------------------------
# the cases
# ---------------------------------------------------------------------------


def _pyvista_mesh(name, levels):
    """One of the meshes shipped inside pyvista's examples folder: welded, subdivided, unit diagonal."""
    import pyvista.examples as ex

    from manifill.io.registry import read_mesh
    from manifill.mesh.subdivide import subdivide
    from manifill.mesh.clean import clean_mesh
    from manifill.validate import bbox_diagonal

    V, F = read_mesh(Path(ex.__file__).with_name(name))
    V, F, _ = clean_mesh(V, F)
    if levels:
        V, F = subdivide(V, F, levels=levels)
    return (V - V.mean(axis=0)) / bbox_diagonal(V), F


def _keep(V, F, mask):
    new = np.cumsum(mask) - 1
    return V[mask], new[F[mask[F].all(axis=1)]]


def _tips(V, labels):
    """For every component, its vertex farthest from the component's centroid."""
    out = []
    for c in range(int(labels.max()) + 1):
        m = np.flatnonzero(labels == c)
        P = V[m]
        out.append(m[int(np.argmax(np.linalg.norm(P - P.mean(axis=0), axis=1)))])
    return np.array(out, dtype=np.int64)


def _exact_geodesic(V, F, sources):
    import igl

    none = np.empty(0, dtype=np.int64)
    return igl.exact_geodesic(V, F.astype(np.int64), sources.astype(np.int64), none,
                              np.arange(len(V), dtype=np.int64), none)


def sphere_cases(level):
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(level)
    V = V / np.abs(V).max()
    mesh = f"icosphere level {level} ({len(V):,} vertices)"
    smooth = Case("sphere-smooth", "Smooth analytic field on a sphere", mesh,
                  "sin(2x) + yz + 0.5 cos(3y), coordinates in [-1, 1]", V, F, smooth_field(V))
    step = Case("sphere-step", "Sharp step on a sphere", mesh,
                "1 where (x + 2y + 2z) / 3 > 0.2, else 0", V, F, step_field(V))
    return [smooth, step]


def u_case(h):
    gap, width, length = 0.15, 1.0, 3.0
    V, F = u_strip(h, gap=gap, width=width, length=length)
    src = np.array([-(gap / 2 + width / 2), length])
    d = u_geodesic(V, src, gap)
    return Case("u-strip", "Geodesic field on a flat U-shaped strip",
                f"flat U, arms {width:g} wide and {length:g} long, {gap:g} apart, lattice spacing {h:g} "
                f"({len(V):,} vertices)",
                "cos(3 pi d / max d), d = exact planar geodesic distance from the tip of the left arm "
                "(closed form)", V, F, distance_field(d, d.max()))


def airplane_case(levels):
    from manifill.mesh.topology import connected_components

    V, F = _pyvista_mesh("airplane.ply", levels)
    count, labels = connected_components(F, len(V))
    V, F = _keep(V, F, labels == 0)
    nose = np.array([int(np.argmin(V[:, 1]))])  # the fuselage runs along y
    d = _exact_geodesic(V, F, nose)
    return Case("airplane", "Geodesic field on pyvista's airplane (fuselage)",
                f"airplane.ply, cleaned, {levels} Loop subdivision(s), largest of {count} components "
                f"(the open fuselage; {len(V):,} vertices)",
                "cos(3 pi d / max d), d = igl.exact_geodesic from the nose", V, F, distance_field(d, d.max()))


def ant_case(levels):
    from manifill.mesh.topology import connected_components

    V, F = _pyvista_mesh("ant.ply", levels)
    count, labels = connected_components(F, len(V))
    tips = _tips(V, labels)
    d = _exact_geodesic(V, F, tips)  # each vertex's distance to the tip of its own component
    return Case("ant", "Geodesic field on pyvista's ant (all components)",
                f"ant.ply, cleaned, {levels} Loop subdivision(s), all {count} components ({len(V):,} vertices)",
                "cos(3 pi d / max d), d = igl.exact_geodesic from the tip of each vertex's own component",
                V, F, distance_field(d, d.max()), stratify=labels,
                notes=[f"samples: one in each of the min(k, {count}) largest components first, the rest uniformly at "
                       f"random; for k < {count} some components have none, and the methods that need one there "
                       f"fail"])


def cases(smoke=False, log=print):
    """The accuracy cases: full size, or tiny ones for ``--smoke``.

    The cases of :mod:`bench.fields_more` come after the first five; ``head-eeg``
    is skipped, with a line to ``log`` and a returned note, when mne is missing.
    Returns ``(cases, notes)``.
    """
    from . import fields_more as more

    lv, head = (3, 3) if smoke else (6, 6)
    out = [*sphere_cases(lv), u_case(0.1 if smoke else 0.02), airplane_case(0 if smoke else 2),
           ant_case(0 if smoke else 2), more.noisy_case(lv), more.globe_case(lv)]
    notes = []
    out.append(more.cap_case(lv))
    try:
        out.append(more.head_case(head))
        out.append(more.scalp_case(head))
    except ImportError as exc:
        notes.append(f"case head-eeg skipped: mne is not installed ({exc.name or exc}); pip install mne")
        log("  " + notes[-1])
    return out, notes
