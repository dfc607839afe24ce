"""Pictures of the standard deviation: the PNG's std and trust panels, the viewer's std and mask fields.

A std is drawn on a sequential map that starts at 0 (light, where the samples are), a mask
such as ``trusted`` in two flat colours, a value on viridis; each panel and each field of the
viewer has its own colour range (a std's from 0). The checks read the colours back from the
images: the colour bars are drawn flat (no shading), so their ends are the maps' end colours.
"""

import json
import shutil
import subprocess

import numpy as np
import pytest

import manifill
from conftest import run
from manifill.io import write_mesh
from manifill.mesh.shapes import icosphere
from manifill.viz.viewer import MASK_STYLES, embedded_arrays, field_kind, write_html

pv = pytest.importorskip("pyvista")

VIRIDIS_ENDS = [(68, 1, 84), (253, 231, 37)]
STD_ENDS = [(255, 255, 217), (8, 29, 88)]  # YlGnBu, light at 0
TRUST_COLOURS = [tuple(int(c[1][k:k + 2], 16) for k in (1, 3, 5)) for c in MASK_STYLES["trusted"]]


def png(path):
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGB"), dtype=np.float64)


def has_colour(img, rgb, tol=14):
    return bool((np.abs(img - np.asarray(rgb, dtype=np.float64)).max(axis=2) <= tol).any())


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    folder = tmp_path_factory.mktemp("std")
    V, F = icosphere(3)
    write_mesh(folder / "m.ply", V, F)
    idx = np.arange(0, len(V), 30)
    (folder / "s.csv").write_text("vertex,t\n" + "".join(f"{i},{float(V[i, 0] + V[i, 2] ** 2)!r}\n" for i in idx))
    return dict(folder=folder, V=V, F=F, idx=idx)


def test_render_shows_value_std_and_trust_side_by_side_each_on_its_own_map(tmp_path, capsys, case):
    f = case["folder"]
    code, out, err = run(capsys, "reconstruct", f / "m.ply", f / "s.csv", "-o", tmp_path / "o.vtu", "--method", "gp",
                         "--gp-range", "1", "--trust", "0.4", "--render", tmp_path / "o.png")
    assert code == 0, err
    assert f"rendered {tmp_path / 'o.png'} (t, t_std, trusted)" in out
    img = png(tmp_path / "o.png")
    assert img.shape == (550, 1800, 3)
    value, std, trust = img[:, :600], img[:, 600:1200], img[:, 1200:]
    for ends, panel in ((VIRIDIS_ENDS, value), (STD_ENDS, std), (TRUST_COLOURS, trust)):
        for rgb in ends:
            assert has_colour(panel, rgb), (rgb, ends)
    assert not has_colour(std, VIRIDIS_ENDS[0]) and not has_colour(value, STD_ENDS[1])


def test_render_of_the_std_alone_and_the_library_default(tmp_path, capsys, case):
    f = case["folder"]
    code, out, err = run(capsys, "reconstruct", f / "m.ply", f / "s.csv", "-o", tmp_path / "o.vtu", "--method",
                         "harmonic", "--uncertainty", "--field", "t_std", "--render", tmp_path / "std.png")
    assert code == 0, err
    img = png(tmp_path / "std.png")
    assert img.shape == (700, 900, 3) and img.std() > 10  # one panel, the size of a plain render
    assert has_colour(img, STD_ENDS[0]) and has_colour(img, STD_ENDS[1]) and not has_colour(img, VIRIDIS_ENDS[0])
    from manifill.viz.render import render_fields

    V, F, idx = case["V"], case["F"], case["idx"]
    r = manifill.reconstruct(V, F, idx, V[idx, 0], method="gp", gp={"range": 1.0}, trust=0.4)
    render_fields(V, F, r.point_data(), tmp_path / "lib.png", samples=idx)  # value, value_std, trusted
    assert png(tmp_path / "lib.png").shape == (550, 1800, 3)


def test_field_kinds_and_ranges_in_the_viewer(tmp_path, capsys, case):
    f = case["folder"]
    code, out, err = run(capsys, "reconstruct", f / "m.ply", f / "s.csv", "-o", tmp_path / "o.vtu", "--method", "gp",
                         "--gp-range", "1", "--trust", "0.4", "--html", tmp_path / "v.html")
    assert code == 0, err
    page = embedded_arrays(tmp_path / "v.html")
    assert page["kinds"] == {"t": "value", "t_std": "std", "trusted": "mask"} and page["field"] == "t"
    import meshio

    data = meshio.read(tmp_path / "o.vtu").point_data
    np.testing.assert_allclose(page["fields"]["t_std"], data["t_std"], rtol=1e-6, atol=1e-7)
    np.testing.assert_array_equal(page["fields"]["trusted"], data["trusted"])
    text = (tmp_path / "v.html").read_text()
    table = json.loads(text[text.index("const DATA = ") + 13:text.index(";\n", text.index("const DATA = "))])["fields"]
    ranges = {e["name"]: e["range"] for e in table}
    assert ranges["t_std"] == [0.0, pytest.approx(float(data["t_std"].max()))]  # a std's colours start at 0
    assert ranges["trusted"] == [0.0, 1.0] and table[2]["classes"][0][0] == "untrusted"
    # only what looks the part: a negative "_std" or a 0/1 field not named as a mask stays a value
    assert field_kind("x_std", [-1.0, 2.0]) == "value" and field_kind("flag", [0.0, 1.0]) == "value"


def chromium():
    return shutil.which("chromium") or shutil.which("chromium-browser")


needs_chromium = pytest.mark.skipif(chromium() is None,
                                    reason="needs Debian's chromium (.ci/run installs it: apt-get install chromium)")


def run_chromium(tmp_path, url, *args):
    cmd = [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
           "--enable-unsafe-swiftshader", "--disable-quic", "--no-first-run", "--disable-background-networking",
           "--disable-component-update", "--disable-sync", f"--user-data-dir={tmp_path / 'profile'}",
           "--window-size=640,480", *args, url]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False).stdout


@needs_chromium
def test_viewer_draws_the_std_and_the_mask_with_their_own_colours(tmp_path):
    V, F = icosphere(4)
    idx = np.arange(0, len(V), 97)
    r = manifill.reconstruct(V, F, idx, V[idx, 0], method="gp", gp={"range": 1.0}, trust=0.4)
    assert 0 < r.trusted.sum() < r.trusted.size
    page = tmp_path / "v.html"
    write_html(page, V, F, r.point_data(["t"]), samples=idx)
    shots = {}
    for name in ("t_std", "trusted"):  # (viridis for a value: tests/viz/test_pictures.py)
        shot = tmp_path / f"{name}.png"
        run_chromium(tmp_path, page.as_uri() + f"#field={name}", f"--screenshot={shot}")
        shots[name] = png(shot)[380:]  # the colour bar's strip, below the sphere
    assert all(has_colour(shots["t_std"], c) for c in STD_ENDS) and not has_colour(shots["t_std"], VIRIDIS_ENDS[0])
    assert all(has_colour(shots["trusted"], c, tol=4) for c in TRUST_COLOURS)
    # the bar's labels: the std's range from 0; the pointer reads the std
    dom = run_chromium(tmp_path, page.as_uri() + "#field=t_std&pick=0.5,0.5", "--dump-dom")
    lo = dom.split('id="lo" style="text-align:left">')[1].split("<")[0]
    assert float(lo) == 0.0
    value, vertex = dom.split('<div id="pick-result">')[1].split("</div>")[0].split()
    ring = np.unique(F[(F == int(vertex)).any(axis=1)])  # the triangle hit has the nearest corner in its ring
    assert r.std[ring].min() - 1e-6 <= float(value) <= r.std[ring].max() + 1e-6
