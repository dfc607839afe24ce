"""An interactive viewer in one self-contained HTML file: rotate, zoom, hover a value, switch fields, toggle overlays.

The mesh, every field, the samples and the curves are embedded in the page
(base64 little-endian arrays) with a small WebGL program of our own, so the file
opens offline in any current browser with nothing else to load. Drag to rotate,
wheel to zoom, hover to read the value under the pointer (interpolated on the
triangle it hits), pick a field from the list when there are several (each keeps
its own colour range), and tick the boxes to show or hide the curves and the samples.
"""

import base64
import binascii
import html
import json
import re
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from ..errors import OptionError, ReadError, WriteError
from ..io.files import atomic_path
from ..results import BOUNDARY_MASK, CURVE_MASK, SAMPLE_MASK, TRUSTED
from ..validate import as_mesh, as_vertices
from .arrows import LENGTH, MAX_ARROWS, arrow_segments, thin_points, vector_field

__all__ = ["write_html", "write_vectors_html", "embedded_arrays", "named_fields", "choose_field", "field_kind",
           "field_range", "MASK_STYLES", "STD_SUFFIX"]

_TEMPLATE = Path(__file__).with_name("viewer.html")

#: the suffix of a field's standard deviation (``value`` -> ``value_std``), as results write it
STD_SUFFIX = "_std"
#: two-colour masks: name -> ((label of 0, colour of 0), (label of 1, colour of 1)); other 0/1 masks get ``None``'s
MASK_STYLES = {
    TRUSTED: (("untrusted", "#d95f02"), ("trusted", "#c6dbef")),
    None: (("0", "#d9d9d9"), ("1", "#d95f02")),
}
_MASKS = (SAMPLE_MASK, CURVE_MASK, BOUNDARY_MASK, TRUSTED)


def field_kind(name, values):
    """How a field is coloured: ``'mask'`` (two colours), ``'std'`` (sequential from 0) or ``'value'``.

    A mask is one of manifill's mask names (``trusted``, ``sample_mask``, ...) holding only 0 and 1;
    a std is a ``<field>_std`` without negative values.

    Examples
    --------
    >>> field_kind("trusted", [0, 1, 1]), field_kind("value_std", [0.0, 0.2]), field_kind("t_std", [-1.0])
    ('mask', 'std', 'value')
    """
    x = np.asarray(values, dtype=np.float64)
    x = x[np.isfinite(x)]
    if str(name) in _MASKS and np.isin(x, (0.0, 1.0)).all():
        return "mask"
    if str(name).endswith(STD_SUFFIX) and (x >= 0).all():
        return "std"
    return "value"


def field_range(kind, values):
    """The colour range of a field: its finite values' (``[0, max]`` for a std, ``[0, 1]`` for a mask)."""
    x = np.asarray(values, dtype=np.float64)
    finite = x[np.isfinite(x)]
    if kind == "mask":
        return [0.0, 1.0]
    if not finite.size:
        return [0.0, 1.0]
    lo, hi = float(finite.min()), float(finite.max())
    if kind == "std":
        lo = 0.0
        hi = hi if hi > 0 else 1.0
    return [lo, hi]


def _b64(a, dtype):
    return base64.b64encode(np.ascontiguousarray(a, dtype=np.dtype(dtype).newbyteorder("<")).tobytes()).decode()


def _column(a, n, what):
    try:
        a = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError):
        raise WriteError(f"{what} is not numeric; pass per-vertex numbers") from None
    if a.ndim != 1 or a.shape[0] != n:
        raise WriteError(f"{what} has shape {a.shape} for {n} vertices; pass one value per vertex")
    return a


def named_fields(values, n, *, names=None, name="value"):
    """The named per-vertex fields in ``values``, in order.

    Parameters
    ----------
    values : None, (n,) or (n, p) array_like, or dict of str to (n,) array_like
        None gives no fields.
    n : int
        The number of vertices.
    names : list of p str, optional
        The names of the columns of an array (default: ``name`` for a (n,) array,
        ``name_0 ... name_{p-1}`` for a (n, p) one).
    name : str, optional

    Returns
    -------
    dict of str to (n,) float64 numpy array

    Raises
    ------
    WriteError
        If a field does not hold one number per vertex.
    OptionError
        If ``names`` does not fit the columns, or two fields share a name.
    """
    if values is None:
        return {}
    if isinstance(values, dict):
        if names is not None:
            raise OptionError("names is for array values; a dict names its fields by its keys, drop names")
        if not values:
            raise WriteError("values is an empty dict; give at least one field or None")
        out = {}
        for key, col in values.items():
            if str(key) in out:
                raise OptionError(f"two fields are named {str(key)!r}; give every field its own name")
            out[str(key)] = _column(col, n, f"field {str(key)!r}")
        return out
    try:
        a = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise WriteError("values are not numeric; pass an (n,) or (n, p) array of numbers or a dict") from None
    if a.ndim not in (1, 2) or a.shape[0] != n or a.size == 0:
        raise WriteError(f"values have shape {a.shape} for {n} vertices; pass (n,) or (n, p) per-vertex values")
    cols = [a] if a.ndim == 1 else list(a.T)
    if names is None:
        names = [str(name)] if a.ndim == 1 else [f"{name}_{j}" for j in range(len(cols))]
    elif isinstance(names, (str, bytes)) or not hasattr(names, "__len__"):
        raise OptionError(f"names must be a list of {len(cols)} str, not {type(names).__name__}; pass a list")
    if len(names) != len(cols):
        raise OptionError(f"{len(names)} field names for {len(cols)} value columns; give one name per column")
    names = [str(s) for s in names]
    dup = next((s for j, s in enumerate(names) if s in names[:j]), None)
    if dup is not None:
        raise OptionError(f"two fields are named {dup!r}; give every field its own name")
    return dict(zip(names, cols))


def choose_field(fields, field):
    """The name of the field ``field`` picks (default: the first); OptionError listing the names if unknown."""
    if field is None:
        return next(iter(fields), None)
    if isinstance(field, str) and field in fields:
        return field
    if not fields:
        raise OptionError(f"no field {field!r}: no values were given; pass values or drop field")
    shown = ", ".join(repr(s) for s in list(fields)[:20]) + (f" ... ({len(fields)} in all)" if len(fields) > 20 else "")
    raise OptionError(f"no field {field!r}; choose one of {shown}")


def _script_json(obj):
    # safe inside <script>: no "</script>", "<!--" or "&" survives, and no raw non-ASCII (U+2028...)
    text = json.dumps(obj, ensure_ascii=True, allow_nan=False)
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def write_html(path, V, F, values=None, *, samples=None, curves=None, title="manifill", name="value", names=None,
               field=None, arrows=None):
    """Write the interactive viewer for a surface and its fields.

    Parameters
    ----------
    path : str or Path
        The ``.html`` file to write (atomically).
    V : (n, 3) array_like
    F : (m, 3) array_like of int
    values : (n,) or (n, p) array_like, or dict of str to (n,) array_like, optional
        The field(s); NaN shows grey. A dict keeps its order. With several fields the
        page lists them by name to switch between, each with its own colour range and
        map (:func:`field_kind`): a standard deviation ``<field>_std`` on a sequential map
        from 0, a mask such as ``trusted`` in two colours, any other field on viridis.
    samples : (k,) array_like of int, optional
        Sample vertices, drawn as points.
    curves : list of (l,) int arrays, optional
        Partition curves, drawn as lines.
    title : str, optional
        Page title.
    name : str, optional
        The name of a (n,) field (for the colour bar and the hover text); the prefix
        ``name_0 ... name_{p-1}`` of the columns of a (n, p) one without ``names``.
    names : list of p str, optional
        The names of the columns of a (n, p) ``values``.
    field : str, optional
        The name of the field shown first (default: the first).
    arrows : (s, 2, 3) array_like of float, optional
        Line segments drawn over the surface, black, with a box to hide them: a vector field's arrows
        (:func:`manifill.viz.arrows.arrow_segments`).

    Raises
    ------
    MeshError
        If ``(V, F)`` is malformed.
    WriteError
        If a field does not hold one number per vertex, or the file cannot be written.
    OptionError
        If ``field`` names no field (the message lists them), or ``names`` does not fit.

    Notes
    -----
    Opening the page at ``page.html#field=NAME`` (NAME percent-encoded) shows that
    field first; ``#field=NAME&pick=fx,fy`` also writes the value under the point
    ``(fx, fy)`` of the canvas (fractions of its size) into the page, for tests.
    ``window.manifillSelectField(name)`` switches the field from a script.

    Examples
    --------
    >>> import tempfile, os
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(2)
    >>> path = os.path.join(tempfile.mkdtemp(), "v.html")
    >>> write_html(path, V, F, V[:, 2], samples=[0, 5])
    >>> arrays = embedded_arrays(path)
    >>> bool(np.allclose(arrays["values"], V[:, 2])), arrays["samples"].tolist()
    (True, [0, 5])
    >>> write_html(path, V, F, {"z": V[:, 2], "x": V[:, 0]}, field="x")
    >>> arrays = embedded_arrays(path)
    >>> list(arrays["fields"]), arrays["field"], bool(np.allclose(arrays["values"], V[:, 0]))
    (['z', 'x'], 'x', True)
    """
    spacing = 0.0
    if F is None:  # a point cloud: drawn as points as wide as their median spacing
        V, F = as_vertices(V), np.zeros((0, 3), dtype=np.int64)
        spacing = float(np.median(cKDTree(V).query(V, k=2)[0][:, 1])) if len(V) > 1 else 0.0
    else:
        V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    n = len(V)
    fields = named_fields(values, n, names=names, name=name) or {str(name): np.full(n, np.nan)}
    chosen = list(fields).index(choose_field(fields, field))
    seg = np.empty((0, 2), dtype=np.int64)
    if curves:
        seg = np.concatenate([np.column_stack([c[:-1], c[1:]]) for c in map(np.asarray, curves) if len(c) > 1]
                             or [seg])
    samples = np.asarray([] if samples is None else samples, dtype=np.int64)
    arrows = np.zeros((0, 2, 3)) if arrows is None else np.asarray(arrows, dtype=np.float64)
    if arrows.ndim != 3 or arrows.shape[1:] != (2, 3) or not np.isfinite(arrows).all():
        raise WriteError(f"arrows have shape {arrows.shape}; pass (s, 2, 3) finite segment ends")
    table = []
    for key, x in fields.items():
        kind = field_kind(key, x)
        entry = {"name": key, "values": _b64(x, np.float32), "kind": kind, "range": field_range(kind, x)}
        if kind == "mask":
            entry["classes"] = [list(c) for c in MASK_STYLES.get(key, MASK_STYLES[None])]
        table.append(entry)
    data = {
        "positions": _b64(V, np.float32), "faces": _b64(F, np.uint32), "samples": _b64(samples, np.uint32),
        "segments": _b64(seg, np.uint32), "fields": table, "field": chosen, "title": str(title),
        "counts": [n, len(F), int(samples.size), len(seg)], "spacing": spacing, "arrows": _b64(arrows, np.float32),
    }
    subs = {"__TITLE__": html.escape(str(title)), "__DATA__": _script_json(data)}
    page = re.sub("__TITLE__|__DATA__", lambda mo: subs[mo.group()], _TEMPLATE.read_text(encoding="utf-8"))
    with atomic_path(path) as tmp:
        Path(tmp).write_text(page, encoding="utf-8")


def write_vectors_html(path, result, *, field=None, count=MAX_ARROWS, title="manifill"):
    """Write the interactive viewer of a tangent vector field: its magnitude (and std) coloured, its arrows drawn
    as lines at up to ``count`` places spread evenly (:func:`manifill.viz.arrows.thin_points`), the samples.

    Parameters
    ----------
    path : str or Path
        The ``.html`` file.
    result : manifill.vectors.result.VectorReconstruction
    field : str, optional
        The field whose arrows are drawn and whose magnitude (``<name>_std``: std) shows first (default the first).
    count : int, optional
        The most arrows drawn.
    title : str, optional

    Raises
    ------
    OptionError, WriteError
        As :func:`write_html`; ``field`` names no vector field.
    """
    names = result.field_names
    name, shown = vector_field(names, field, result.std is not None)
    vec = result.fields()[..., names.index(name)]
    data = result.point_data()
    fields = {k: a for k, a in data.items() if k.endswith(("_magnitude", STD_SUFFIX))}
    V, N = np.asarray(result.V, dtype=np.float64), np.asarray(result.normals, dtype=np.float64)
    at, spacing = thin_points(V, count)
    length = LENGTH * spacing
    seg = arrow_segments(V[at] + 0.02 * length * N[at], vec[at], N[at], length, result.symmetry)
    write_html(path, V, result.F, fields, field=shown, samples=result.idx[result.idx >= 0], arrows=seg, title=title)


def embedded_arrays(path):
    """The data embedded in a viewer page (for checks).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    dict
        ``positions`` (n, 3) float32, ``faces`` (m, 3) uint32, ``samples`` (k,) uint32,
        ``segments`` (s, 2) uint32, ``arrows`` (a, 2, 3) float32 (segment ends), ``fields`` (dict of str to (n,)
        float32 arrays, in the page's order), ``kinds`` (dict of str to the colouring, :func:`field_kind`),
        ``field`` (the name of the field shown first) and ``values`` (that field's (n,) array).

    Raises
    ------
    ReadError
        If the file cannot be read or is not a viewer page.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
        start = text.index("const DATA = ", text.index("<script>")) + len("const DATA = ")
        data = json.loads(text[start:text.index(";\n", start)])
        kinds = {"positions": ("<f4", 3), "faces": ("<u4", 3), "samples": ("<u4", 1), "segments": ("<u4", 2),
                 "arrows": ("<f4", 6)}
        out = {}
        for key, (dt, width) in kinds.items():
            a = np.frombuffer(base64.b64decode(data.get(key, ""), validate=True), dtype=dt)
            out[key] = a.reshape(-1, width) if width > 1 else a
        out["arrows"] = out["arrows"].reshape(-1, 2, 3)
        if "fields" in data:
            table = [(f["name"], f["values"]) for f in data["fields"]]
            first = table[data["field"]][0]
            kinds = {str(f["name"]): f.get("kind", "value") for f in data["fields"]}
        else:  # a page with one field, as written before several fields
            table = [(data["name"], data["values"])]
            first = data["name"]
            kinds = {str(first): "value"}
        out["fields"] = {str(k): np.frombuffer(base64.b64decode(v, validate=True), dtype="<f4") for k, v in table}
        out["kinds"] = kinds
    except OSError as exc:
        raise ReadError(f"{path.name}: cannot be read ({exc.strerror or exc}); check the path") from None
    except (ValueError, KeyError, IndexError, TypeError, binascii.Error, UnicodeDecodeError) as exc:
        raise ReadError(f"{path.name}: not a manifill viewer page ({type(exc).__name__}); write it with "
                        "manifill.viz.viewer.write_html") from None
    out["field"], out["values"] = first, out["fields"][first]
    return out
