"""Arrows on a surface, for the pictures of a tangent vector field: a few places spread evenly over it
(:func:`thin_points`), their arrows (or lines, or crosses) as pyvista glyphs in a PNG (:func:`add_arrows`, which
:func:`manifill.viz.panels.render_panels` draws for a panel's ``arrows``) and as line segments for the HTML viewer
(:func:`arrow_segments`).

An arrow's length is its magnitude over the largest, times the spacing of the places shown (so the longest just
reaches its neighbour); a line field (symmetry 2) is drawn as segments without heads, a cross field (4) as two
crossing segments.
"""

import numpy as np
from scipy.spatial import cKDTree

from ..errors import OptionError

__all__ = ["MAX_ARROWS", "LENGTH", "vector_field", "thin_points", "arrow_segments", "add_arrows"]

#: The most arrows a picture shows (more crowd it).
MAX_ARROWS = 1500
#: An arrow's longest length, as a fraction of the spacing of the places shown.
LENGTH = 0.85


def vector_field(names, field, has_std):
    """``(name, coloured)``: the vector field ``field`` names (``<name>``, ``<name>_magnitude`` or, with a std,
    ``<name>_std``; the first by default) and the point field its picture colours.

    Raises
    ------
    OptionError
        ``field`` names none of them (the message lists them).
    """
    shown = {f"{n}{end}": (n, f"{n}{end or '_magnitude'}") for n in names
             for end in ("", "_magnitude") + (("_std",) if has_std else ())}
    if field is None:
        return names[0], f"{names[0]}_magnitude"
    if field not in shown:
        raise OptionError(f"field {field!r} is not one of the vector fields ({', '.join(shown)}); pick one of them")
    return shown[field]


def _cells(P, lo, h):
    """The voxel of side ``h`` of every point, as one integer per point."""
    key = np.floor((P - lo) / h).astype(np.int64)
    width = key.max(axis=0) + 1
    return (key[:, 0] * width[1] + key[:, 1]) * width[2] + key[:, 2]


def thin_points(P, count=MAX_ARROWS):
    """At most ``count`` of the points ``P``, spread evenly: one per cell of a voxel grid whose cells are the smallest
    (by bisection) that ``count`` of them hold every point; in each cell the point nearest the cell's points' mean.

    Parameters
    ----------
    P : (n, 3) array_like of float
    count : int, optional

    Returns
    -------
    idx : (c,) int64 numpy array
        The points kept, ``c <= count`` (all of them when ``n <= count``).
    spacing : float
        The cells' side: about the distance between neighbouring points kept (for the arrows' length).

    Examples
    --------
    >>> P = np.random.default_rng(0).random((5000, 3)) * [1.0, 1.0, 0.0]
    >>> idx, h = thin_points(P, 100)
    >>> 50 <= len(idx) <= 100, 0.05 < h < 0.2
    (True, True)
    """
    P = np.asarray(P, dtype=np.float64)
    n = len(P)
    if count < 1:
        return np.zeros(0, dtype=np.int64), 1.0
    span = float(np.ptp(P, axis=0).max()) if n else 0.0
    if n <= count or span == 0.0:  # every point: their spacing is the nearest neighbours' distance
        near = float(np.median(cKDTree(P).query(P, k=2)[0][:, 1])) if n > 1 else 0.0
        return np.arange(n, dtype=np.int64), near or 1.0
    lo = P.min(axis=0)
    small, large = span / (4.0 * n), 1.01 * span  # too many cells, and one cell of everything
    for _ in range(40):
        h = np.sqrt(small * large)
        if np.unique(_cells(P, lo, h)).size > count:
            small = h
        else:
            large = h
        if large / small < 1.01:
            break
    cell = np.unique(_cells(P, lo, large), return_inverse=True)[1].ravel()
    sizes = np.bincount(cell)
    mean = np.column_stack([np.bincount(cell, P[:, k]) for k in range(3)]) / sizes[:, None]
    dist = np.linalg.norm(P - mean[cell], axis=1)
    order = np.lexsort((dist, cell))
    first = order[np.r_[0, np.flatnonzero(np.diff(cell[order])) + 1]]
    return np.sort(first).astype(np.int64), float(large)


def _directions(vectors, normals, symmetry):
    """The segments' directions of each place: the vector, and for a cross also the vector turned a quarter
    about the normal."""
    if symmetry == 4:
        turned = np.cross(normals, vectors)
        return [vectors, turned]
    return [vectors]


def arrow_segments(points, vectors, normals, length, symmetry=1):
    """Line segments drawing arrows (with two barbs at the head), lines (symmetry 2) or crosses (4), centred on
    ``points``, the longest ``length`` long: ``(s, 2, 3)`` start and end points (for the HTML viewer).

    Examples
    --------
    >>> seg = arrow_segments(np.zeros((1, 3)), np.array([[2.0, 0, 0]]), np.array([[0, 0, 1.0]]), 1.0)
    >>> seg.shape, seg[0].tolist()
    ((3, 2, 3), [[-0.5, 0.0, 0.0], [0.5, 0.0, 0.0]])
    """
    points, vectors, normals = (np.asarray(a, dtype=np.float64).reshape(-1, 3) for a in (points, vectors, normals))
    top = float(np.max(np.linalg.norm(vectors, axis=1), initial=0.0))
    if top == 0.0 or not len(points):
        return np.zeros((0, 2, 3))
    segs = []
    for d in _directions(vectors * (length / top), normals, symmetry):
        segs.append(np.stack([points - d / 2, points + d / 2], axis=1))
        if symmetry == 1:  # the head: two barbs back from the tip, in the tangent plane
            tip, side = points + d / 2, np.cross(normals, d)
            for s in (1.0, -1.0):
                segs.append(np.stack([tip, tip - 0.3 * d + s * 0.18 * side], axis=1))
    return np.concatenate(segs)


def add_arrows(pl, pv, arrows):
    """Draw groups of arrows into the plotter's current panel (what a panel's ``arrows`` holds).

    Parameters
    ----------
    pl : pyvista.Plotter
    pv : module
        pyvista.
    arrows : list of dict
        Each with ``points``, ``vectors`` and ``normals`` ``(a, 3)``, ``length`` (of the largest vector),
        ``scale`` (the largest vector's magnitude; by default this group's), and optionally ``symmetry``
        (1, 2, 4) and ``color``.
    """
    for group in arrows:
        points = np.asarray(group["points"], dtype=np.float64)
        vectors, normals = np.asarray(group["vectors"], dtype=np.float64), np.asarray(group["normals"])
        mags = np.linalg.norm(vectors, axis=1)
        top = float(group.get("scale") or np.max(mags, initial=0.0))
        keep = mags > 1e-6 * top
        if top == 0.0 or not keep.any():
            continue
        length, symmetry = float(group["length"]), group.get("symmetry", 1)
        if symmetry == 1:
            geom = pv.Arrow(start=(-0.5, 0.0, 0.0), direction=(1.0, 0.0, 0.0), tip_length=0.35, tip_radius=0.13,
                            shaft_radius=0.045)
        else:  # a line has no head
            geom = pv.Cylinder(center=(0.0, 0.0, 0.0), direction=(1.0, 0.0, 0.0), radius=0.05, height=1.0,
                               resolution=12)
        lift = points[keep] + 0.08 * length * normals[keep]  # lying on the surface, not half inside it
        for d in _directions(vectors[keep], normals[keep], symmetry):
            cloud = pv.PolyData(lift)
            cloud["v"] = d
            glyphs = cloud.glyph(orient="v", scale="v", factor=length / top, geom=geom)
            pl.add_mesh(glyphs, color=group.get("color", "black"), smooth_shading=True, show_scalar_bar=False)
