"""The pictures' findings: objects framed clear of the colour bar and its name, a colour range not padded past the
field's round ends."""

import numpy as np
import pytest

from manifill.viz.layout import _projected_box, fill_frame  # noqa: F401 (the measure the frame is fitted by)
from manifill.viz.panels import nice_range


@pytest.mark.parametrize("values, want", [([-1.5, 1.5], (-1.5, 1.5)), ([-1.503, 1.498], (-1.5, 1.5)),
                                          ([0.0, 0.96], (0.0, 1.0))])
def test_a_field_in_round_ends_is_not_padded_by_a_step(values, want):
    assert nice_range(values)[0] == want


def test_the_objects_fill_the_box_between_title_and_bar_centred():
    pv = pytest.importorskip("pyvista")
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(2)
    V = V * np.array([2.0, 1.0, 0.5]) + np.array([3.0, -1.0, 2.0])  # off-centre and flat: the camera's fit is off
    pl = pv.Plotter(off_screen=True, window_size=[400, 300])
    pl.add_mesh(pv.PolyData(V, np.column_stack([np.full(len(F), 3), F]).ravel()))
    pl.view_vector((0.4, -1.0, 0.7))
    pl.render()
    fill_frame([pl.renderer], [V], width=0.8, height=0.58, centre=(0.0, 0.12))
    (x0, x1), (y0, y1) = _projected_box(pl.renderer.GetActiveCamera(), [(pl.renderer, V)])
    pl.close()
    assert abs((x0 + x1) / 2) < 0.02 and abs((y0 + y1) / 2 - 0.12) < 0.02  # centred where asked
    assert max((x1 - x0) / 2 / 0.8, (y1 - y0) / 2 / 0.58) == pytest.approx(1.0, abs=0.03)  # fills the box
    assert y0 > -0.64  # clear of the bar and its name (the lowest 18% of the panel)


def test_fig4_4_takes_its_samples_on_the_side_the_camera_sees():
    # the nut's paths were edge-on or behind it: half its samples were on the far side
    from manifill.mesh.shapes import icosphere
    from manifill.viz import figures

    V, _ = icosphere(3)
    view = np.array([0.3, -1.0, 0.45])
    got = figures._facing(V, view, 4, 0) if hasattr(figures, "_facing") else None
    assert got is not None and len(np.unique(got)) == 4
    assert np.all((V[got] - V.mean(axis=0)) @ (view / np.linalg.norm(view)) > 0.2)
