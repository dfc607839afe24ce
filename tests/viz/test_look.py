"""A picture's look (title, size, colour map, camera) as one Look or as keywords: the same picture."""

import numpy as np
import pytest

from conftest import icosphere
from manifill import OptionError
from manifill.viz.render import Look, render, render_fields

pytest.importorskip("pyvista")


def png(path):
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGB"), dtype=np.float64)


def test_a_look_is_its_keywords(tmp_path):
    V, F = icosphere(2)
    look = Look(title="z", size=(240, 200), cmap="plasma", view=(0, -1, 0.3), viewup=(0, 0, 1))
    render(V, F, V[:, 2], tmp_path / "look.png", look=look)
    render(V, F, V[:, 2], tmp_path / "kw.png", title="z", size=(240, 200), cmap="plasma", view=(0, -1, 0.3),
           viewup=(0, 0, 1))
    # a keyword replaces that field of the look; the others stay
    render(V, F, V[:, 2], tmp_path / "both.png", look=Look(title="z", size=(10, 10), cmap="plasma",
                                                           view=(0, -1, 0.3), viewup=(0, 0, 1)), size=(240, 200))
    a = png(tmp_path / "look.png")
    assert a.shape == (200, 240, 3)
    assert np.array_equal(a, png(tmp_path / "kw.png")) and np.array_equal(a, png(tmp_path / "both.png"))
    render(V, F, V[:, 2], tmp_path / "viridis.png", look=Look(title="z", size=(240, 200), view=(0, -1, 0.3),
                                                              viewup=(0, 0, 1)))
    assert np.abs(png(tmp_path / "viridis.png") - a).mean() > 1  # the colour map is not ignored


def test_render_fields_takes_a_look(tmp_path):
    V, F = icosphere(2)
    fields = {"t": V[:, 0], "t_std": np.abs(V[:, 1])}
    render_fields(V, F, fields, tmp_path / "a.png", look=Look(size=(400, 200)))
    render_fields(V, F, fields, tmp_path / "b.png", size=(400, 200))
    assert png(tmp_path / "a.png").shape == (200, 400, 3)
    assert np.array_equal(png(tmp_path / "a.png"), png(tmp_path / "b.png"))


@pytest.mark.parametrize("kw", [{"sise": (10, 10)}, {"look": {"size": (10, 10)}}])
def test_an_unknown_option_is_refused(tmp_path, kw):
    V, F = icosphere(1)
    with pytest.raises(OptionError) as err:
        render(V, F, V[:, 0], tmp_path / "x.png", **kw)
    assert "\n" not in str(err.value) and not (tmp_path / "x.png").exists()
