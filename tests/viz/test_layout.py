"""Tick labels that never collide, and objects that fill their panel (manifill.viz.layout)."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from manifill.viz.layout import CHAR_WIDTH, position_text, tick_labels
from manifill.viz.render import nice_range


@given(lo=st.floats(-1e9, 1e9), width=st.floats(1e-9, 1e9), bar=st.integers(80, 900))
@settings(max_examples=300, deadline=None, derandomize=True, database=None)
def test_tick_labels_are_short_alike_and_apart(lo, width, bar):
    assume(abs(lo) <= 1e3 * width)  # a range tiny next to its values needs an offset the labels do not take yet
    (a, b), count = nice_range([lo, lo + width])
    ticks, suffix = tick_labels((a, b), count, bar, 13)
    texts = [t for _, t in ticks]
    assert ticks[0][0] == 0.0 and ticks[-1][0] == 1.0  # the ends stay
    assert all(len(t) <= 6 for t in texts) and not any("e" in t for t in texts), texts  # no exponent per label
    scale = 10.0 ** int(suffix.split("1e")[1].rstrip(")")) if suffix else 1.0
    values = np.linspace(a, b, count)[[round(at * (count - 1)) for at, _ in ticks]]
    assert np.allclose([float(t) * scale for t in texts], values, rtol=1e-3, atol=1e-3 * scale)
    gap = bar * (ticks[1][0] - ticks[0][0])
    widest = max(len(t) for t in texts) * CHAR_WIDTH * 13
    assert gap >= 2.0 * widest or len(ticks) <= 3 or (len(ticks) - 1) % 2  # apart, or as thin as the ends allow


def test_labels_that_collided_are_thinned_and_small_values_share_a_power_of_ten():
    # seen in the demo and a gp render: "-1.5 -1" touching, "-0.0001-5e-05" overlapping
    assert [t for _, t in tick_labels((-1.5, 1.5), 7, 300, 13)[0]] == ["-1.5", "-0.5", "0.5", "1.5"]
    ticks, suffix = tick_labels((-1e-4, 1e-4), 5, 400, 13)
    assert [t for _, t in ticks] == ["-1", "-0.5", "0", "0.5", "1"] and suffix == " (× 1e-4)"
    assert tick_labels((0.0, 2e5), 5, 400, 13)[1] == " (× 1e5)" and tick_labels((0.0, 2e4), 5, 600, 13)[1] == ""


@pytest.mark.parametrize("at, extent, text", [(0.000268, 2.0, "0"), (-0.0007, 0.9, "0"), (12.3456, 100.0, "12"),
                                              (0.1234, 1.0, "0.12"), (-3.3e-7, 1e-5, "-0.0000003")])
def test_slice_positions_are_rounded_to_the_objects_size(at, extent, text):
    assert position_text(at, extent) == text


def test_a_wide_group_of_objects_fills_its_panel(tmp_path):
    pytest.importorskip("pyvista", reason="rendering needs pyvista (pip install 'manifill[viz]')")
    from PIL import Image

    from manifill.mesh.shapes import icosphere
    from manifill.viz.render import render_panels

    V, F = icosphere(2)
    # three spheres in a row: the camera's fit to their bounding sphere left them a third of the panel's height
    VV = np.vstack([V + [4.0 * i, 0, 0] for i in range(3)])
    FF = np.vstack([F + len(V) * i for i in range(3)])
    render_panels([dict(V=VV, F=FF, values=VV[:, 0])], tmp_path / "w.png", size=(800, 400), view=(0, -1, 0),
                  viewup=(0, 0, 1))
    img = np.asarray(Image.open(tmp_path / "w.png").convert("L"))[: int(0.8 * 400)]  # above the colour bar
    cols = np.flatnonzero((img < 200).any(axis=0))
    assert (cols.max() - cols.min()) / 800 >= 0.7  # the row spans most of the width (0.8 asked)
