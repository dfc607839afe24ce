"""The pyvista drawing behind :mod:`manifill.viz.render`: surfaces side by side in one PNG (:func:`render_panels`)
and three slices through a voxel field (:func:`render_slices`), each with a colour bar of round ticks
(:func:`nice_range`). :func:`~manifill.viz.render.render`, :func:`~manifill.viz.render.render_fields` and the
paper's figures (:mod:`manifill.viz.figures`) draw through it.
"""

import ctypes.util
import os

import numpy as np

from ..errors import WriteError
from .arrows import add_arrows
from .layout import fill_frame, position_text, tick_labels
from .viewer import MASK_STYLES, field_kind, field_range

__all__ = ["render_panels", "render_slices", "nice_range", "STD_CMAP"]

#: the colour map of a standard deviation (light at 0, where the samples are)
STD_CMAP = "YlGnBu"


def nice_range(values):
    """``((lo, hi), labels)``: the values' range widened to 4-6 round steps (1, 2, 2.5 or 5 times a power of
    ten; the least widening wins), so that every tick of a colour bar is a round number; values within half a
    percent of the range past a round end are not worth a whole step more (they take the end's colour).

    Examples
    --------
    >>> nice_range([-0.937, 1.02])
    ((-1.0, 1.5), 6)
    >>> nice_range([-0.646, 0.752])  # 0.752 drawn at 0.75's colour
    ((-0.75, 0.75), 7)
    >>> nice_range([-1.503, 1.498])  # a field in +-1.5: not padded to +-2
    ((-1.5, 1.5), 7)
    >>> nice_range([0.0509, 0.0509])
    ((0.0509, 0.0509), 2)
    """
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return (0.0, 1.0), 2
    lo, hi = float(v.min()), float(v.max())
    if not hi > lo:
        return (lo, hi), 2
    tol = 0.005 * (hi - lo)  # a value within half a percent past a round end is drawn at the end's colour
    lo, hi = lo + tol, hi - tol
    best = None
    for steps in (4, 5, 6):
        raw = (hi - lo) / steps
        mag = 10.0 ** np.floor(np.log10(raw))
        for m in (1.0, 2.0, 2.5, 5.0, 10.0):
            step = m * mag
            if step < raw * (1 - 1e-12):
                continue
            a = np.floor(lo / step + 1e-9) * step
            if a + steps * step < hi - 1e-9 * step:
                continue
            wide = steps * step - (hi - lo)
            if best is None or wide < best[0] - 1e-12 * step:
                ends = (float(f"{round(a / step) * step:.12g}"), float(f"{round(a / step + steps) * step:.12g}"))
                best = (wide, *ends, steps + 1)
    return (best[1], best[2]), best[3]


def _style(kind, name, values, cmap, clim):
    """``(cmap, clim, extra add_mesh keywords, extra scalar bar keywords)`` of a field of ``kind``."""
    if kind == "mask":
        (l0, c0), (l1, c1) = MASK_STYLES.get(name, MASK_STYLES[None])
        bar = {"n_labels": 0, "position_y": 0.1}  # room below the bar for the two labels
        return [c0, c1], [0.0, 1.0], {"n_colors": 2, "annotations": {0.0: l0, 1.0: l1}}, bar
    if kind == "category":  # labels (patches): one flat colour each, a legend of names, no continuous ticks
        cats = np.unique(np.asarray(values)[np.isfinite(values)]).astype(np.int64)
        return "tab10", [float(cats.min()) - 0.5, float(cats.max()) + 0.5], {"n_colors": len(cats)}, {"n_labels": 0}
    if kind == "std":
        return STD_CMAP, clim if clim is not None else field_range("std", values), {}, {}
    return cmap, clim, {}, {}


def _pv():
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY") and ctypes.util.find_library("EGL"):
        # no display: an EGL off-screen window, without first failing to reach an X server
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    try:
        import pyvista as pv
    except ImportError:
        raise ImportError("rendering needs pyvista: pip install 'manifill[viz]'") from None
    pv.OFF_SCREEN = True
    return pv


def _bar_text(pl, actors, clim, labels, title, names=None):
    """The bar's ticks and name drawn by hand: VTK's title sat on the middle label and its end labels, centred on
    the bar's ends, stuck out past them; here the end labels end with the bar (left- and right-aligned), labels
    that would crowd are thinned (:func:`manifill.viz.layout.tick_labels`), and a category's ``names`` stand
    centred under their colours."""
    for actor in actors:
        actor.SetDrawTickLabels(False)
        actor.SetTitle("")
        actor.SetPosition(0.2, 0.065)
        actor.SetHeight(0.045)
        actor.SetWidth(0.6)
    vp = pl.renderer.GetViewport()
    bar_pixels = 0.6 * pl.window_size[0] * (vp[2] - vp[0])
    if names is not None:
        ticks, suffix = [((j + 0.5) / len(names), str(t)) for j, t in enumerate(names)], ""
    else:
        ticks, suffix = tick_labels(clim, labels, bar_pixels, 13)
    for at, label in ticks:
        text = pl.add_text(label, position=(0.2 + 0.6 * at, 0.02), viewport=True, font_size=10, color="black")
        prop = text.GetTextProperty()
        (prop.SetJustificationToLeft if at == 0.0 else prop.SetJustificationToRight if at == 1.0
         else prop.SetJustificationToCentered)()
    name = pl.add_text(title + suffix, position=(0.5, 0.12), viewport=True, font_size=12, color="black")
    name.GetTextProperty().SetJustificationToCentered()


def _polydata(pv, V, F):
    if F is None:  # a point cloud
        return pv.PolyData(np.asarray(V, dtype=np.float64))
    faces = np.column_stack([np.full(len(F), 3), np.asarray(F, dtype=np.int64)]).ravel()
    return pv.PolyData(np.asarray(V, dtype=np.float64), faces)


def _look_of(V, F):
    """How a panel's mesh is drawn: shaded triangles, or a point cloud's points as spheres sized to their density
    (14 px for 2,500 points, 4 px for 40,000)."""
    if F is None:
        return {"point_size": float(np.clip(800.0 / np.sqrt(len(V)), 2.0, 14.0)), "render_points_as_spheres": True}
    return {"smooth_shading": True}


def _add_surface(pl, pv, panel, clim, cmap):
    V, F = panel["V"], panel["F"]
    mesh = _polydata(pv, V, F)
    values = panel.get("values")
    name = panel.get("name", "value")
    if values is not None:
        mesh.point_data[name] = np.asarray(values, dtype=np.float64)
        kind = panel.get("kind", "value")
        cmap, clim, extra, bar = _style(kind, name, values, panel.get("cmap", cmap), panel.get("clim", clim))
        labels = 5
        if kind not in ("mask", "category"):  # round ticks: the colour range widened to a whole number of round steps
            clim, labels = nice_range(values if clim is None else np.asarray(clim, dtype=np.float64))
        before = set(pl.scalar_bars.keys())
        pl.add_mesh(mesh, scalars=name, cmap=cmap, clim=clim, nan_color="lightgrey", **_look_of(V, F),
                    scalar_bar_args={"title": name, "vertical": False, "n_labels": labels, "fmt": "%.4g",
                                     "position_x": 0.2, "position_y": 0.04, "width": 0.6, "height": 0.08, **bar},
                    **extra)
        new = [key for key in pl.scalar_bars.keys() if key not in before]  # a bar shared with a panel before: none
        if kind != "mask" and new:  # our own labels under the bar, the name above it
            names = None
            if kind == "category":  # each colour's name under it
                cats = np.unique(np.asarray(values)[np.isfinite(values)]).astype(np.int64)
                names = ["curves" if c < 0 else f"{name} {c}" for c in cats]
            _bar_text(pl, [pl.scalar_bars[key] for key in new], clim, labels, panel.get("bar_title", name), names)
    else:
        pl.add_mesh(mesh, color="lightgrey", **_look_of(V, F))
    curves = panel.get("curves")
    lift = None
    if F is not None and (curves or panel.get("samples") is not None):  # off the surface along its normals
        normals = np.asarray(mesh.compute_normals(point_normals=True, cell_normals=False).point_data["Normals"])
        lift = float(np.linalg.norm(np.ptp(np.asarray(V), axis=0))) * normals
    if curves:
        pts, lines = [], []
        start = 0
        for c in curves:
            c = np.asarray(c)
            if len(c) < 2:
                continue
            pts.append(np.asarray(V, dtype=np.float64)[c] + (0.0 if lift is None else 0.002 * lift[c]))
            lines.append(np.concatenate([[len(c)], start + np.arange(len(c))]))
            start += len(c)
        if pts:
            poly = pv.PolyData(np.concatenate(pts), lines=np.concatenate(lines))
            if panel.get("colour_curves") and values is not None:
                # the curves themselves carry the values (e.g. Step 4 before the fill): thick, coloured
                poly.point_data[name] = np.concatenate([np.asarray(values)[np.asarray(c)] for c in curves
                                                        if len(c) >= 2])
                pl.add_mesh(poly, scalars=name, cmap=cmap, clim=clim, line_width=6, render_lines_as_tubes=True,
                            show_scalar_bar=False)
            elif values is None:  # the curves are what the panel shows: black and clear
                pl.add_mesh(poly, color="black", line_width=2.5)
            else:  # over a field: thin, dark grey, half see-through, marking where they run without hiding it
                pl.add_mesh(poly, color="#333333", line_width=1.5, opacity=0.6)
    samples = panel.get("samples")
    if samples is not None and len(samples):
        size = max(9.0, 1.6 * _look_of(V, F).get("point_size", 0.0))  # above a point cloud's own points
        at = np.asarray(V, dtype=np.float64)[np.asarray(samples)]
        if lift is not None:  # lifted off the surface: whole spheres, also on a silhouette
            at = at + 0.006 * lift[np.asarray(samples)]
        pl.add_points(at, color="red", point_size=size, render_points_as_spheres=True)
    if panel.get("arrows"):  # a vector field's arrows over its magnitude
        add_arrows(pl, pv, panel["arrows"])
    if panel.get("title"):
        pl.add_text(panel["title"], font_size=11, position="upper_edge")


def render_panels(panels, path, *, size=(1200, 500), cmap="viridis", same_scale=True, view=None, viewup=None,
                  zoom=1.0):
    """Render surfaces side by side into one PNG.

    Parameters
    ----------
    panels : list of dict
        Each with ``V`` (n, 3), ``F`` (m, 3) and optionally ``values`` (n,),
        ``samples`` (k,) vertex indices, ``curves`` (list of vertex paths),
        ``colour_curves`` (draw the curves thick and coloured by ``values``),
        ``title``, ``name`` (of the field, for the colour bar), ``kind`` (``'value'``,
        ``'std'``, ``'mask'`` or ``'category'``, e.g. patch labels, in flat colours with a legend of
        names: the colour map, :func:`manifill.viz.viewer.field_kind`),
        ``cmap`` and ``clim`` (this panel's own map and range), ``bar_title`` (the colour bar's title, by default
        ``name``), ``arrows`` (groups of arrows, :func:`manifill.viz.arrows.add_arrows`).
    path : str or Path
        The PNG to write.
    size : (int, int), optional
        Width and height in pixels.
    cmap : str, optional
        A matplotlib colour map name.
    same_scale : bool, optional
        One colour range for all panels of kind ``'value'`` without a ``clim`` (to compare them).
    zoom : float, optional
        Magnify every panel's view by this much more than the fit that makes the objects fill it
        (:func:`manifill.viz.layout.fill_frame`).
    view : tuple of 3 floats, optional
        Direction the camera looks from (default: pyvista's isometric view).
    viewup : tuple of 3 floats, optional
        The direction that points up in the picture (with ``view``).

    Raises
    ------
    ImportError
        Without pyvista.
    WriteError
        If the image cannot be written.
    """
    pv = _pv()
    clim = None
    if same_scale:
        finite = [np.asarray(p["values"])[np.isfinite(p["values"])] for p in panels
                  if p.get("values") is not None and p.get("kind", "value") == "value" and "clim" not in p]
        finite = [f for f in finite if f.size]
        if finite:
            clim = [float(min(f.min() for f in finite)), float(max(f.max() for f in finite))]
        if len(finite) > 1:  # one bar, under the first panel, for all of them: say so
            panels = [dict(p, bar_title=f"{p.get('name', 'value')}: one scale for all panels")
                      if p.get("values") is not None and p.get("kind", "value") == "value" and "clim" not in p else p
                      for p in panels]
    pl = pv.Plotter(off_screen=True, shape=(1, len(panels)), window_size=list(size), border=False)
    for j, panel in enumerate(panels):
        pl.subplot(0, j)
        _add_surface(pl, pv, panel, clim, cmap)
        if view is not None:
            pl.view_vector(view, viewup=viewup)
        pl.set_background("white")
    if len(panels) > 1:
        pl.link_views()
    pl.render()
    fill_frame(pl.renderers, [np.asarray(p["V"])[:: max(1, len(p["V"]) // 5000)] for p in panels])
    for ren in pl.renderers:
        if zoom != 1.0:
            ren.GetActiveCamera().Zoom(zoom)
            if len(panels) > 1:
                break  # one camera, linked
    try:
        pl.screenshot(str(path))
    except (OSError, ValueError) as exc:
        raise WriteError(f"{path}: could not write the image ({exc}); check the path") from None
    finally:
        pl.close()


def render_slices(values, spacing, origin, path, *, name="value", size=(1200, 450), cmap="viridis"):
    """Three orthogonal slices through the middle of a voxel field, side by side.

    Parameters
    ----------
    values : (n0, n1, n2) numpy array
        NaN outside the solid.
    spacing, origin : (3,) array_like
    path : str or Path
    name : str, optional
        The field's name: a ``<field>_std`` is drawn on a sequential map from 0, a mask
        (``trusted``) in two colours (:func:`manifill.viz.viewer.field_kind`).
    """
    pv = _pv()
    grid = pv.ImageData(dimensions=values.shape, spacing=tuple(map(float, spacing)), origin=tuple(map(float, origin)))
    grid.point_data[name] = np.asarray(values, dtype=np.float64).ravel(order="F")
    finite = values[np.isfinite(values)]
    clim = [float(finite.min()), float(finite.max())] if finite.size else None
    kind = field_kind(name, values)  # a std from 0 on its own map, a mask in two colours
    cmap, shown, extra, bar = _style(kind, name, values, cmap, clim if kind == "value" else None)
    labels = 5
    if kind == "value" and clim:  # round ticks, as on the surfaces
        shown, labels = nice_range(np.asarray(clim))
    centre = grid.center
    extent = float(max(np.ptp(np.reshape(grid.bounds, (3, 2)), axis=1)))
    pl = pv.Plotter(off_screen=True, shape=(1, 3), window_size=list(size), border=False)
    shown_points = []
    for j, normal in enumerate("xyz"):
        pl.subplot(0, j)
        sl = grid.slice(normal=normal)
        sl = sl.threshold(value=clim, scalars=name) if clim else sl
        before = set(pl.scalar_bars.keys())
        title = f"{name}, all three slices"
        pl.add_mesh(sl, scalars=name, cmap=cmap, clim=shown, nan_opacity=0.0,
                    scalar_bar_args={"title": title, "vertical": False, "fmt": "%.4g", "n_labels": labels,
                                     "position_x": 0.2, "position_y": 0.04, "width": 0.6, "height": 0.08, **bar},
                    **extra)
        new = [key for key in pl.scalar_bars.keys() if key not in before]
        if kind == "value" and clim and new:
            _bar_text(pl, [pl.scalar_bars[key] for key in new], shown, labels, title)
        at = float(centre["xyz".index(normal)])
        pl.add_text(f"slice at {normal} = {position_text(at, extent)}", font_size=10, position="upper_edge",
                    color="black")
        pl.view_vector({"x": (1, 0, 0), "y": (0, -1, 0), "z": (0, 0, 1)}[normal],  # x and y increase rightwards
                       viewup=(0, 1, 0) if normal == "z" else (0, 0, 1))
        if sl.n_points:  # the two in-plane axes and their ranges, in the mesh's units (x, y across; z, y up)
            across, up = {"x": ("y", "z"), "y": ("x", "z"), "z": ("x", "y")}[normal]
            lo, hi = np.reshape(sl.bounds, (3, 2)).T
            ends = {c: f"{c} {position_text(lo['xyz'.index(c)], extent)} to {position_text(hi['xyz'.index(c)], extent)}"
                    for c in (across, up)}
            note = pl.add_text(f"across: {ends[across]}\nup: {ends[up]}", position=(0.5, 0.83), viewport=True,
                               font_size=10, color="dimgray")
            note.GetTextProperty().SetJustificationToCentered()
        pl.set_background("white")
        shown_points.append(np.asarray(sl.points)[:: max(1, sl.n_points // 5000)] if sl.n_points else None)
    pl.render()
    fill_frame(pl.renderers, shown_points, height=0.5, centre=(0.0, 0.06))  # room for the ranges above
    try:
        pl.screenshot(str(path))
    except (OSError, ValueError) as exc:
        raise WriteError(f"{path}: could not write the image ({exc}); check the path") from None
    finally:
        pl.close()
