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


def fill_frame(renderers, points, *, width=0.8, height=0.58, rounds=2, centre=(0.0, 0.12)):
    """Zoom each renderer's camera so that the ``points`` it shows span ``width`` x ``height`` of it, centred.

    The camera's own fit is to the objects' bounding sphere, which leaves a wide or flat group small, and
    centres the sphere, not what a perspective view shows of it; here the points' projection is measured, the
    camera zoomed to fit the box left between the title and the colour bar, and moved so that the projection's
    centre is the box's (``centre``, in normalised device coordinates: a little above the middle, clear of the
    bar and its name). Renderers sharing one camera (linked views) are fitted together.

    Parameters
    ----------
    renderers : list of vtkRenderer
    points : list of (n, 3) numpy arrays
        What each renderer shows (a subsample is enough).
    width, height : float, optional
        The fractions of the renderer the points may span.
    rounds : int, optional
        Measurements (a perspective camera's zoom is not quite linear).
    centre : (float, float), optional
        Where the projection's centre goes, in normalised device coordinates (-1 to 1).
    """
    by_camera = {}
    for ren, P in zip(renderers, points):
        if P is not None and len(P):
            by_camera.setdefault(id(ren.GetActiveCamera()), []).append((ren, np.asarray(P, dtype=np.float64)))
    for group in by_camera.values():
        camera = group[0][0].GetActiveCamera()
        for _ in range(rounds):
            box = _projected_box(camera, group)
            if box is None:
                break
            (x0, x1), (y0, y1) = box
            span_x, span_y = (x1 - x0) / 2.0, (y1 - y0) / 2.0
            if span_x <= 0 or span_y <= 0:
                break
            camera.Zoom(min(width / span_x, height / span_y))
            box = _projected_box(camera, group)
            if box is not None:
                _pan(camera, group[0][0], (sum(box[0]) / 2.0 - centre[0], sum(box[1]) / 2.0 - centre[1]))


def _projected_box(camera, group):
    """``((x0, x1), (y0, y1))``: the points' extent in normalised device coordinates over the group's renderers."""
    xs, ys = [], []
    for ren, P in group:
        w, h = ren.GetSize()
        aspect = w / h if h else 1.0
        M = np.array([[camera.GetCompositeProjectionTransformMatrix(aspect, -1, 1).GetElement(i, j)
                       for j in range(4)] for i in range(4)])
        X = np.column_stack([P, np.ones(len(P))]) @ M.T
        front = X[:, 3] > 0  # in front of the camera
        if front.any():
            ndc = X[front, :2] / X[front, 3:4]
            xs += [float(ndc[:, 0].min()), float(ndc[:, 0].max())]
            ys += [float(ndc[:, 1].min()), float(ndc[:, 1].max())]
    return ((min(xs), max(xs)), (min(ys), max(ys))) if xs else None


def _pan(camera, ren, shift):
    """Move the camera (position and focal point together) so that the view shifts by ``shift`` in normalised
    device coordinates (what was at ``shift`` is then at the centre)."""
    w, h = ren.GetSize()
    aspect = w / h if h else 1.0
    pos, focal = np.array(camera.GetPosition()), np.array(camera.GetFocalPoint())
    if camera.GetParallelProjection():
        half = camera.GetParallelScale()
    else:
        half = float(np.linalg.norm(focal - pos)) * np.tan(np.radians(camera.GetViewAngle()) / 2.0)
    up = np.array(camera.GetViewUp(), dtype=np.float64)
    forward = (focal - pos) / max(float(np.linalg.norm(focal - pos)), 1e-300)
    right = np.cross(forward, up)
    up = np.cross(right, forward)
    move = shift[0] * half * aspect * right / max(np.linalg.norm(right), 1e-300) + shift[1] * half * up / max(
        np.linalg.norm(up), 1e-300)
    camera.SetPosition(*(pos + move))
    camera.SetFocalPoint(*(focal + move))
