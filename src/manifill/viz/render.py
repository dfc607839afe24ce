"""Pictures of a reconstruction: PNG renders made off-screen with pyvista (the ``[viz]`` extra).

The surface coloured by the field with a colour bar, the samples as points, the
partition curves as lines; several panels side by side like the paper's figures;
three orthogonal slices through a solid. Everything renders off-screen, so it works
on a machine with no display. :func:`render` takes several named fields and draws
the one chosen by name; :func:`render_fields` draws several side by side, each on its own
colour bar and map (:func:`manifill.viz.viewer.field_kind`): a field on viridis, its standard
deviation ``<field>_std`` on a sequential map from 0, a mask such as ``trusted`` in two colours.
:func:`render_vectors` draws a tangent vector field: its magnitude as colour, arrows on top.
"""

import dataclasses
from dataclasses import dataclass, replace

import numpy as np

from ..errors import OptionError
from ..mesh.objects import mesh_arrays
from ..validate import as_vertices, is_mesh_object
from ..results import TRUSTED
from .arrows import LENGTH, MAX_ARROWS, thin_points, vector_field
from .panels import STD_CMAP, render_panels, render_slices
from .panels import nice_range  # noqa: F401 (re-exported from its old home)
from .viewer import choose_field, field_kind, named_fields

__all__ = ["Look", "render", "render_fields", "render_vectors", "render_panels", "render_slices", "STD_CMAP"]


@dataclass(frozen=True, kw_only=True)
class Look:
    """How a picture of :func:`render` or :func:`render_fields` looks (what it shows is given apart).

    Its fields may also be passed to those functions one by one, as keywords
    (``render(..., size=(320, 240))`` is ``render(..., look=Look(size=(320, 240)))``).

    Attributes
    ----------
    title : str, optional
        Above the picture (:func:`render_fields`: ``title: field`` above each panel).
    size : (int, int), optional
        Width and height in pixels; None: the function's default.
    cmap : str
        A matplotlib colour map name, for the fields of kind ``'value'``.
    view : tuple of 3 floats, optional
        Direction the camera looks from (default: pyvista's isometric view).
    viewup : tuple of 3 floats, optional
        The direction that points up in the picture (with ``view``).

    Examples
    --------
    >>> Look(size=(320, 240)).cmap
    'viridis'
    """

    title: object = None
    size: object = None
    cmap: str = "viridis"
    view: object = None
    viewup: object = None


def _look(look, options, function):
    """``look`` (None or a :class:`Look`) with the fields given one by one in ``options`` replaced."""
    names = [f.name for f in dataclasses.fields(Look)]
    if look is None:
        look = Look()
    elif not isinstance(look, Look):
        raise OptionError(f"{function} look={look!r} is not a manifill.viz.render.Look; pass Look(...) or None")
    for key in options:
        if key not in names:
            raise OptionError(f"{function} has no option {key!r}; pass one of its own or of Look's "
                              f"({', '.join(names)})")
    return replace(look, **options)


def _arrays(V, F):
    """``(V, F)`` of a mesh (arrays or an object), or ``(V, None)`` of a point cloud's array."""
    return (as_vertices(V), None) if F is None and not is_mesh_object(V) else mesh_arrays(V, F)


def render(V, F, values, path, *, samples=None, curves=None, name="value", names=None, field=None, look=None,
           **look_options):
    """Render one surface coloured by a field into a PNG.

    Parameters
    ----------
    V : (n, 3) numpy array
    F : (m, 3) numpy array of int
    values : (n,) or (n, p) numpy array, dict of str to (n,) array, or None
        The field(s); None draws the surface grey. Only the field ``field`` is drawn.
    path : str or Path
    samples : (k,) array of int, optional
        Drawn as red points.
    curves : list of (l,) int arrays, optional
        Drawn as black lines.
    name : str, optional
        The name of a (n,) field, for the colour bar; the prefix ``name_0 ... name_{p-1}``
        of the columns of a (n, p) one without ``names``.
    names : list of p str, optional
        The names of the columns of a (n, p) ``values``.
    field : str, optional
        The name of the field to draw (default: the first).
    look : Look, optional
        Title, size (default 900 by 700 pixels), colour map and camera.
    **look_options
        :class:`Look`'s fields one by one (``title``, ``size``, ``cmap``, ``view``, ``viewup``),
        replacing those of ``look``.

    Raises
    ------
    OptionError
        If ``field`` names no field (the message lists them), ``names`` does not fit, or an
        option is none of these.
    WriteError
        If a field does not hold one number per vertex, or the image cannot be written.
    ImportError
        Without pyvista.
    """
    look = _look(look, look_options, "render()")
    V, F = _arrays(V, F)
    fields = named_fields(values, len(V), names=names, name=name)
    chosen = choose_field(fields, field)
    x = None if chosen is None else fields[chosen]
    render_panels([dict(V=V, F=F, values=x, samples=samples, curves=curves, title=look.title,
                        name=name if chosen is None else chosen,
                        kind="value" if chosen is None else field_kind(chosen, x))],
                  path, size=look.size or (900, 700), cmap=look.cmap, view=look.view, viewup=look.viewup)


def render_fields(V, F, fields, path, *, show=None, samples=None, curves=None, look=None, **look_options):
    """Render several fields of one surface side by side, each with its own colour bar and map.

    Parameters
    ----------
    V : (n, 3) numpy array
    F : (m, 3) numpy array of int
    fields : dict of str to (n,) array_like
        The fields by name (e.g. :meth:`manifill.Reconstruction.point_data`).
    path : str or Path
    show : list of str, optional
        The fields to draw, one panel each, in order. Default: the first field, then
        its standard deviation ``<first>_std`` and ``trusted`` where ``fields`` holds them.
    samples, curves
        As :func:`render`.
    look : Look, optional
        As :func:`render`: the panels are titled ``title: name`` (or ``name``); the size is by
        default 600 by 550 pixels a panel (one panel: 900 by 700, as :func:`render`); ``cmap``
        colours the fields of kind ``'value'``.
    **look_options
        :class:`Look`'s fields one by one, replacing those of ``look``.

    Raises
    ------
    OptionError
        If ``show`` names a field ``fields`` does not hold (the message lists them).
    WriteError, ImportError
        As :func:`render`.

    Examples
    --------
    >>> import tempfile, os
    >>> from manifill.mesh.shapes import icosphere
    >>> from manifill import reconstruct
    >>> V, F = icosphere(2)
    >>> r = reconstruct(V, F, [0, 10, 50, 90, 120], [1.0, 2.0, 3.0, 4.0, 5.0], method="gp", trust=1.0)
    >>> render_fields(V, F, r.point_data(), os.path.join(tempfile.mkdtemp(), "std.png"))  # doctest: +SKIP
    """
    look = _look(look, look_options, "render_fields()")
    V, F = _arrays(V, F)
    fields = named_fields(fields, len(V))
    if show is None:
        first = choose_field(fields, None)
        show = [first] + [k for k in (f"{first}_std", TRUSTED) if k in fields]
    title = look.title
    panels = []
    for key in show:
        key = choose_field(fields, key)
        panels.append(dict(V=V, F=F, values=fields[key], samples=samples, curves=curves, name=key,
                           kind=field_kind(key, fields[key]), title=f"{title}: {key}" if title else key))
    size = look.size or ((900, 700) if len(panels) == 1 else (600 * len(panels), 550))  # one panel: as render's
    render_panels(panels, path, size=size, cmap=look.cmap, same_scale=False, view=look.view, viewup=look.viewup)


#: The spacing of the arrows of :func:`render_vectors` on the picture, in pixels (when no ``count`` is given).
ARROW_PIXELS = 26


def render_vectors(result, path, *, field=None, count=None, samples=True, look=None, **look_options):
    """Render a tangent vector field into a PNG: its magnitude as colour, arrows on top.

    The arrows stand at most ``count`` places spread evenly over the side of the surface the camera sees
    (:func:`manifill.viz.arrows.thin_points`), each as long as its magnitude over the largest times their spacing;
    lines (``symmetry=2``) are drawn without heads, crosses (4) as two crossing lines. The samples' arrows are red.

    Parameters
    ----------
    result : manifill.vectors.result.VectorReconstruction
    path : str or Path
        The PNG to write.
    field : str, optional
        The field drawn (its name; default the first); ``<name>_std`` (``method='gp'``) colours its std instead
        of its magnitude.
    count : int, optional
        The most arrows shown; by default about one per :data:`ARROW_PIXELS` pixels of the picture, at most
        :data:`manifill.viz.arrows.MAX_ARROWS`.
    samples : bool, optional
        Draw the samples' arrows (red), where they are at vertices.
    look : Look, optional
        Title, size (default 900 by 700 pixels), colour map and camera, as :func:`render`.
    **look_options
        :class:`Look`'s fields one by one.

    Raises
    ------
    OptionError
        ``field`` names no field, or an option is none of these.
    WriteError, ImportError
        As :func:`render`.
    """
    look = _look(look, look_options, "render_vectors()")
    names = result.field_names
    name, shown = vector_field(names, field, result.std is not None)
    vec = result.fields()[..., names.index(name)]
    values = result.point_data()[shown]
    V, N = np.asarray(result.V, dtype=np.float64), np.asarray(result.normals, dtype=np.float64)
    top = float(np.nanmax(np.linalg.norm(vec, axis=1), initial=0.0))
    size = look.size or (900, 700)
    count = min(MAX_ARROWS, int((min(size) / ARROW_PIXELS) ** 2 / 2)) if count is None else int(count)
    toward = np.asarray(look.view if look.view is not None else (1.0, 1.0, 1.0), dtype=np.float64)
    facing = N @ (toward / np.linalg.norm(toward)) > 0.3  # the side the camera sees, not edge-on
    seen = np.flatnonzero(facing)
    at, spacing = thin_points(V[seen], count)
    at = seen[at]
    given = np.unique(result.idx[result.idx >= 0]) if samples else np.zeros(0, dtype=np.int64)
    at, given = np.setdiff1d(at, given), given[facing[given]]
    groups = [dict(points=V[i], vectors=vec[i], normals=N[i], length=LENGTH * spacing, scale=top,
                   symmetry=result.symmetry, color=c) for i, c in ((at, "black"), (given, "red")) if len(i)]
    bar = f"{name} std (per component)" if shown.endswith("_std") else f"{name} magnitude"
    render_panels([dict(V=V, F=result.F, values=values, name=shown, kind=field_kind(shown, values), title=look.title,
                        bar_title=bar, arrows=groups)],
                  path, size=size, cmap=look.cmap, view=look.view, viewup=look.viewup)
