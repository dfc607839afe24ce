"""Where things go in a picture: tick labels that never collide, objects that fill their panel.

Plain functions of numbers (and of a VTK camera for :func:`fill_frame`), used by
:mod:`manifill.viz.render`; no pyvista import here.
"""

import math

import numpy as np

__all__ = ["tick_labels", "fill_frame", "position_text"]

#: the width of one character of a tick label, in units of its font size (sans-serif digits)
CHAR_WIDTH = 0.62


def tick_labels(clim, count, bar_pixels, font_pixels):
    """``([(fraction along the bar, text)], title suffix)``: the colour bar's tick labels.

    Values far from 1 (below 1e-3 or from 1e5 on) share one power of ten, said once in the bar's
    title (``× 1e-4``) so that every label is short and alike; when labels would stand closer than
    twice their width (the end labels are aligned with the bar's ends, half a label inwards), every
    second one is left out (the ends stay).

    Examples
    --------
    >>> tick_labels((-1e-4, 1e-4), 5, 400, 10)
    ([(0.0, '-1'), (0.25, '-0.5'), (0.5, '0'), (0.75, '0.5'), (1.0, '1')], ' (× 1e-4)')
    >>> [t for _, t in tick_labels((-1.5, 1.5), 7, 300, 13)[0]]
    ['-1.5', '-0.5', '0.5', '1.5']
    """
    values = np.linspace(clim[0], clim[1], count)
    top = float(np.abs(values).max())
    power = int(math.floor(math.log10(top))) if top > 0 else 0
    scale, suffix = (10.0 ** power, f" (× 1e{power})") if top > 0 and not -3 <= power < 5 else (1.0, "")
    texts = [_plain(v / scale) for v in values]
    keep = list(range(count))
    while len(keep) > 2:
        width = max(len(texts[j]) for j in keep) * CHAR_WIDTH * font_pixels
        gap = bar_pixels * (keep[1] - keep[0]) / max(count - 1, 1)
        if gap >= 2.0 * width or (len(keep) - 1) % 2:
            break
        keep = keep[::2]
    return [(j / max(count - 1, 1), texts[j]) for j in keep], suffix


def _plain(v):
    """A tick value in at most 4 significant digits, no exponent, no '-0'."""
    text = f"{float(f'{v:.4g}'):.10f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def position_text(at, extent):
    """A slice's position rounded to a step of 1/50 to 1/500 of the object's size (``0.000268`` in 2 is 0).

    Examples
    --------
    >>> position_text(0.000268, 2.0), position_text(12.3456, 100.0), position_text(-0.0004, 0.9)
    ('0', '12', '0')
    """
    digits = max(0, -int(math.floor(math.log10(extent / 50.0)))) if extent > 0 else 3
    text = f"{round(at, digits):.{digits}f}".rstrip("0").rstrip(".") if digits else f"{round(at):.0f}"
    return "0" if text in ("-0", "") else text


def fill_frame(renderers, points, *, width=0.8, height=0.58, rounds=2):
    """Zoom each renderer's camera so that the ``points`` it shows span ``width`` x ``height`` of it.

    The camera's own fit is to the objects' bounding sphere, which leaves a wide or flat group small;
    here the points' projection is measured and the camera zoomed to fit the box left between the
    title and the colour bar. Renderers sharing one camera (linked views) are fitted together.

    Parameters
    ----------
    renderers : list of vtkRenderer
    points : list of (n, 3) numpy arrays
        What each renderer shows (a subsample is enough).
    width, height : float, optional
        The fractions of the renderer the points may span.
    """
    by_camera = {}
    for ren, P in zip(renderers, points):
        if P is not None and len(P):
            by_camera.setdefault(id(ren.GetActiveCamera()), []).append((ren, np.asarray(P, dtype=np.float64)))
    for group in by_camera.values():
        camera = group[0][0].GetActiveCamera()
        for _ in range(rounds):  # a perspective camera's zoom is not quite linear: measure twice
            span_x = span_y = 0.0
            for ren, P in group:
                w, h = ren.GetSize()
                aspect = w / h if h else 1.0
                M = np.array([[camera.GetCompositeProjectionTransformMatrix(aspect, -1, 1).GetElement(i, j)
                               for j in range(4)] for i in range(4)])
                X = np.column_stack([P, np.ones(len(P))]) @ M.T
                front = X[:, 3] > 0  # in front of the camera
                if not front.any():
                    continue
                ndc = X[front, :2] / X[front, 3:4]
                span_x = max(span_x, float(np.ptp(ndc[:, 0])) / 2.0)
                span_y = max(span_y, float(np.ptp(ndc[:, 1])) / 2.0)
            if span_x <= 0 or span_y <= 0:
                break
            camera.Zoom(min(width / span_x, height / span_y))
