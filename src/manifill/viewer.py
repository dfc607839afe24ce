"""An interactive viewer in one self-contained HTML file: rotate, zoom, hover a value, toggle curves and samples.

The mesh, the field, the samples and the curves are embedded in the page (base64
little-endian arrays) with a small WebGL program of our own, so the file opens
offline in any current browser with nothing else to load. Drag to rotate, wheel to
zoom, hover to read the value under the pointer (interpolated on the triangle it
hits), and tick the boxes to show or hide the curves and the samples.
"""

import base64
import html
import json
from pathlib import Path

import numpy as np

from .io import atomic_path
from .validate import as_mesh

__all__ = ["write_html", "embedded_arrays"]

_TEMPLATE = Path(__file__).with_name("viewer.html")


def _b64(a, dtype):
    return base64.b64encode(np.ascontiguousarray(a, dtype=np.dtype(dtype).newbyteorder("<")).tobytes()).decode()


def write_html(path, V, F, values=None, *, samples=None, curves=None, title="manifill", name="value"):
    """Write the interactive viewer for a surface and its field.

    Parameters
    ----------
    path : str or Path
        The ``.html`` file to write (atomically).
    V : (n, 3) array_like
    F : (m, 3) array_like of int
    values : (n,) array_like, optional
        The field (NaN shows grey).
    samples : (k,) array_like of int, optional
        Sample vertices, drawn as points.
    curves : list of (l,) int arrays, optional
        Partition curves, drawn as lines.
    title, name : str, optional
        Page title, and the field's name for the colour bar and the hover text.

    Examples
    --------
    >>> import tempfile, os
    >>> from manifill.shapes import icosphere
    >>> V, F = icosphere(2)
    >>> path = os.path.join(tempfile.mkdtemp(), "v.html")
    >>> write_html(path, V, F, V[:, 2], samples=[0, 5])
    >>> arrays = embedded_arrays(path)
    >>> bool(np.allclose(arrays["values"], V[:, 2])), arrays["samples"].tolist()
    (True, [0, 5])
    """
    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    n = len(V)
    x = np.full(n, np.nan) if values is None else np.asarray(values, dtype=np.float64).reshape(n)
    seg = np.empty((0, 2), dtype=np.int64)
    if curves:
        seg = np.concatenate([np.column_stack([c[:-1], c[1:]]) for c in map(np.asarray, curves) if len(c) > 1]
                             or [seg])
    samples = np.asarray([] if samples is None else samples, dtype=np.int64)
    finite = x[np.isfinite(x)]
    data = {
        "positions": _b64(V, np.float32), "faces": _b64(F, np.uint32), "values": _b64(x, np.float32),
        "samples": _b64(samples, np.uint32), "segments": _b64(seg, np.uint32),
        "range": [float(finite.min()), float(finite.max())] if finite.size else [0.0, 1.0],
        "name": str(name), "title": str(title), "counts": [n, len(F), int(samples.size), len(seg)],
    }
    page = _TEMPLATE.read_text(encoding="utf-8")
    page = page.replace("__TITLE__", html.escape(str(title))).replace("__DATA__", json.dumps(data))
    with atomic_path(path) as tmp:
        Path(tmp).write_text(page, encoding="utf-8")


def embedded_arrays(path):
    """The arrays embedded in a viewer page (for checks): positions, faces, values, samples, segments.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    dict of str to numpy array
    """
    text = Path(path).read_text(encoding="utf-8")
    start = text.index("const DATA = ") + len("const DATA = ")
    data = json.loads(text[start:text.index(";\n", start)])
    kinds = {"positions": ("<f4", 3), "faces": ("<u4", 3), "values": ("<f4", 1), "samples": ("<u4", 1),
             "segments": ("<u4", 2)}
    out = {}
    for key, (dt, width) in kinds.items():
        a = np.frombuffer(base64.b64decode(data[key]), dtype=dt)
        out[key] = a.reshape(-1, width) if width > 1 else a
    return out
