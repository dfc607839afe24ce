"""Seeing the result: Loop subdivision, off-screen renders, the HTML viewer (in headless Chromium), CLI flags."""

import re
import shutil
import subprocess

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import grid, icosphere
from manifill import MeshError, OptionError, WriteError, reconstruct
from manifill.cli import main
from manifill.mesh.subdivide import loop_matrix, subdivide
from manifill.viz.viewer import embedded_arrays, write_html

pv = pytest.importorskip("pyvista")


def png(path):
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGB"), dtype=np.float64)


# ---------------------------------------------------------------------------
# Loop subdivision
# ---------------------------------------------------------------------------


def test_subdivision_equals_libigl_on_a_regular_mesh_with_boundary():
    # a flat grid: every inner vertex has valence 6, where every Loop variant agrees; the boundary rules too
    V, F = grid(7)
    V2, F2 = subdivide(V, F, levels=2)
    igl = pytest.importorskip("igl")
    W, G = igl.loop(V, F.astype(np.int64), 2)
    assert len(F2) == len(G) == 16 * len(F)
    from scipy.spatial import cKDTree

    d, _ = cKDTree(W).query(V2)
    assert d.max() < 1e-12


@pytest.mark.parametrize("k", [1, 2, 3])
def test_subdivision_counts_and_rows(k):
    V, F = icosphere(1)
    V2, F2 = subdivide(V, F, levels=k)
    assert len(F2) == 4**k * len(F)
    assert len(V2) - len(F2) // 2 == 2  # still a sphere: Euler characteristic 2
    S, _ = loop_matrix(F, len(V))
    np.testing.assert_allclose(S.sum(axis=1), 1.0, atol=1e-14)  # averages: constants stay constant
    assert S.data.min() > 0  # positive weights: the maximum principle


@settings(max_examples=25, deadline=None)
@given(a=st.lists(st.floats(-5, 5), min_size=4, max_size=4))
def test_linear_fields_follow_the_surface(a):
    # the field is subdivided with the positions' own stencil: a linear function of position stays one
    V, F = icosphere(2)
    f = V @ np.array(a[:3]) + a[3]
    V2, F2, f2 = subdivide(V, F, f, levels=2)
    np.testing.assert_allclose(f2, V2 @ np.array(a[:3]) + a[3], atol=1e-10)


def test_subdivided_values_stay_within_range_and_keep_columns():
    V, F = icosphere(2)
    X = np.random.default_rng(0).random((len(V), 2))
    _, _, X2 = subdivide(V, F, X, levels=2)
    assert X2.shape[1] == 2
    assert X2.min() >= X.min() - 1e-12 and X2.max() <= X.max() + 1e-12
    _, _, x2 = subdivide(V, F, X[:, 1], levels=2)
    np.testing.assert_allclose(x2, X2[:, 1])


def test_subdivision_commutes_with_relabelling():
    V, F = icosphere(2)
    perm = np.random.default_rng(1).permutation(len(V))
    inv = np.argsort(perm)
    A, _ = subdivide(V, F, levels=1)
    B, _ = subdivide(V[perm], inv[F], levels=1)
    key = lambda P: np.lexsort(np.round(P, 9).T)  # noqa: E731
    np.testing.assert_allclose(A[key(A)], B[key(B)], atol=1e-12)


@pytest.mark.parametrize("levels", [-1, 1.5, True, "2"])
def test_subdivision_bad_levels(levels):
    V, F = icosphere(1)
    with pytest.raises(OptionError):
        subdivide(V, F, levels=levels)


def test_subdivision_bad_mesh():
    with pytest.raises(MeshError):
        subdivide(np.zeros((3, 3)), [[0, 1, 5]])


# ---------------------------------------------------------------------------
# renders
# ---------------------------------------------------------------------------


def test_render_has_the_size_and_is_not_blank(tmp_path):
    from manifill.viz.render import render

    V, F = icosphere(3)
    path = tmp_path / "a.png"
    render(V, F, V[:, 2], path, samples=[0, 1, 2], size=(320, 240))
    img = png(path)
    assert img.shape == (240, 320, 3)
    assert img.std() > 10  # not one colour


def test_render_colours_follow_the_field(tmp_path):
    # a field rising left to right, seen from the front: the picture's colour (viridis: dark to bright)
    # brightens across the image
    from manifill.viz.render import render

    V, F = grid(30)
    V = np.column_stack([V[:, 0], V[:, 1], np.zeros(len(V))])
    path = tmp_path / "lin.png"
    render(V, F, V[:, 0], path, size=(400, 400), view=(0, 0, 1), viewup=(0, 1, 0))
    img = png(path)[150:250] / 255  # the middle band, above the colour bar
    # each pixel's place on the colour map: the nearest of 256 viridis colours (lighting scales brightness,
    # so compare directions in colour space)
    from matplotlib import colormaps

    lut = colormaps["viridis"](np.linspace(0, 1, 256))[:, :3]
    px = img.reshape(-1, 3)
    sim = (px / np.linalg.norm(px, axis=1, keepdims=True)) @ (lut / np.linalg.norm(lut, axis=1, keepdims=True)).T
    where = sim.argmax(axis=1).reshape(img.shape[:2]).astype(float)
    coloured = np.abs(img - 1).sum(axis=2) > 0.1  # not the white background
    cols = [where[:, a:b][coloured[:, a:b]].mean() for a, b in ((80, 140), (170, 230), (260, 320))]
    assert cols[0] + 20 < cols[1] < cols[2] - 20


def test_slices_and_panels(tmp_path):
    from manifill.viz.render import render_panels, render_slices

    x, y, z = np.indices((20, 20, 20)) - 9.5
    vals = np.where(x**2 + y**2 + z**2 < 81, x / 10.0, np.nan)
    render_slices(vals, (1, 1, 1), (0, 0, 0), tmp_path / "s.png", size=(600, 200))
    assert png(tmp_path / "s.png").shape == (200, 600, 3) and png(tmp_path / "s.png").std() > 10
    V, F = icosphere(2)
    render_panels([dict(V=V, F=F, values=V[:, 0]), dict(V=V, F=F, values=None, curves=[np.arange(5)])],
                  tmp_path / "p.png", size=(500, 250))
    assert png(tmp_path / "p.png").shape == (250, 500, 3)


# ---------------------------------------------------------------------------
# the HTML viewer
# ---------------------------------------------------------------------------


def test_viewer_holds_the_mesh_and_the_values(tmp_path):
    V, F = icosphere(3)
    idx = np.arange(0, len(V), 17)
    r = reconstruct(V, F, idx, V[idx, 0])
    path = tmp_path / "v.html"
    write_html(path, V, F, r.values, samples=idx, curves=r.curves, title="t <&> t", name="temp")
    a = embedded_arrays(path)
    np.testing.assert_allclose(a["positions"], V, atol=1e-6)
    assert (a["faces"] == F).all()
    np.testing.assert_allclose(a["values"], r.values, rtol=1e-6)
    assert a["samples"].tolist() == idx.tolist()
    assert len(a["segments"]) == sum(len(c) - 1 for c in r.curves)
    text = path.read_text()
    assert "t &lt;&amp;&gt; t" in text and "<script src" not in text and "http" not in text.split("<script>")[1]


def chromium():
    return shutil.which("chromium") or shutil.which("chromium-browser")


NEEDS_CHROMIUM = "needs Debian's chromium (.ci/run installs it: apt-get install chromium)"


@pytest.mark.skipif(chromium() is None, reason=NEEDS_CHROMIUM)
def test_viewer_draws_in_headless_chromium(tmp_path):
    V, F = icosphere(4)
    idx = np.arange(0, len(V), 97)
    r = reconstruct(V, F, idx, V[idx, 0] + V[idx, 2])
    page = tmp_path / "v.html"
    write_html(page, V, F, r.values, samples=idx, curves=r.curves)
    shot = tmp_path / "shot.png"
    cmd = [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
           "--enable-unsafe-swiftshader", "--no-first-run", "--disable-background-networking",
           "--disable-component-update", "--disable-sync", f"--user-data-dir={tmp_path / 'profile'}",
           "--window-size=640,480", f"--screenshot={shot}", page.as_uri()]
    subprocess.run(cmd, capture_output=True, timeout=120, check=False)
    img = png(shot)
    assert img.shape == (480, 640, 3)
    centre = img[140:340, 220:420]  # the sphere fills the middle: coloured, varied, not the white page
    assert centre.std() > 15 and (np.abs(centre - 255).sum(axis=2) > 60).mean() > 0.9


# ---------------------------------------------------------------------------
# the command line
# ---------------------------------------------------------------------------


def test_cli_render_html_subdivide_quiet(tmp_path, capsys):
    from manifill.io import write_mesh

    V, F = icosphere(2)
    write_mesh(tmp_path / "m.ply", V, F)
    idx = np.arange(0, len(V), 6)
    (tmp_path / "s.csv").write_text("vertex,t\n" + "".join(f"{i},{V[i, 0]}\n" for i in idx))
    code = main(["reconstruct", str(tmp_path / "m.ply"), str(tmp_path / "s.csv"), "-o", str(tmp_path / "o.ply"),
                 "--render", str(tmp_path / "o.png"), "--html", str(tmp_path / "o.html"), "--subdivide", "1",
                 "--quiet"])
    out, err = capsys.readouterr()
    assert code == 0 and out == ""
    assert png(tmp_path / "o.png").std() > 10
    assert len(embedded_arrays(tmp_path / "o.html")["positions"]) == len(V)
    import meshio

    assert len(meshio.read(tmp_path / "o.ply").cells[0].data) == 4 * len(F)
    code = main(["reconstruct", str(tmp_path / "m.ply"), str(tmp_path / "s.csv"), "-o", str(tmp_path / "p.ply"),
                 "--verbose", "--method", "gvf-harmonic"])
    out, _ = capsys.readouterr()
    assert code == 0 and "partition" in out.split("time:")[1]


@pytest.mark.parametrize("flag, name", [("--render", "x.jpg"), ("--html", "x.htm"), ("--render", "no/x.png")])
def test_cli_bad_picture_names_exit_2_before_work(tmp_path, capsys, flag, name):
    from manifill.io import write_mesh

    V, F = icosphere(1)
    write_mesh(tmp_path / "m.ply", V, F)
    (tmp_path / "s.csv").write_text("vertex,t\n0,1\n5,2\n")
    code = main(["reconstruct", str(tmp_path / "m.ply"), str(tmp_path / "s.csv"), "-o", str(tmp_path / "o.ply"),
                 flag, str(tmp_path / name)])
    out, err = capsys.readouterr()
    assert code == 2 and err.startswith("manifill: error:") and err.count("\n") == 1
    assert not (tmp_path / "o.ply").exists()


def test_progress_is_told_every_step():
    from manifill import reconstruct_volume

    V, F = icosphere(2)
    idx = np.arange(0, len(V), 9)
    steps = []
    reconstruct(V, F, idx, V[idx, 0], progress=steps.append)
    assert steps == ["graph", "check", "biharmonic fill"]
    steps.clear()
    reconstruct(V, F, idx, V[idx, 0], progress=steps.append, method="gvf-harmonic")
    assert steps == ["graph", "partition", "check", "curve values", "harmonic fill"]
    steps.clear()
    reconstruct_volume(V, F, idx, V[idx, 0], resolution=12, progress=steps.append)
    assert steps[-2:] == ["voxelize", "fill"] and steps[0] == "graph"


@pytest.mark.skipif(chromium() is None, reason=NEEDS_CHROMIUM)
def test_viewer_hover_reads_the_value_under_the_pointer(tmp_path):
    # the page's own picking, run in Chromium: the page opens with the PNGs' camera (pyvista's isometric view,
    # from (1, 1, 1)), so at the centre of the canvas the unit sphere shows (1, 1, 1) / sqrt(3), where z = 1/sqrt(3)
    V, F = icosphere(5)
    page = tmp_path / "v.html"
    write_html(page, V, F, V[:, 2])
    cmd = [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
           "--enable-unsafe-swiftshader", "--no-first-run", "--disable-background-networking",
           "--disable-component-update", "--disable-sync", f"--user-data-dir={tmp_path / 'profile'}",
           "--window-size=640,480", "--dump-dom", page.as_uri() + "#pick=0.5,0.5"]
    dom = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False).stdout
    value, vertex = dom.split('<div id="pick-result">')[1].split("</div>")[0].split()
    assert abs(float(value) - 1 / np.sqrt(3)) < 0.01
    assert abs(V[int(vertex), 2] - float(value)) < 0.02  # the nearest corner of the triangle hit


# ---------------------------------------------------------------------------
# several fields: the viewer's field list and the render's field choice
# ---------------------------------------------------------------------------

EVIL = "</script><b>\"x'&"  # a field name that would end the script and inject markup if written unescaped


def test_viewer_embeds_every_field_in_order_and_opens_on_the_chosen_one(tmp_path):
    V, F = icosphere(2)
    rng = np.random.default_rng(3)
    a, b = rng.random(len(V)), rng.random(len(V))
    c = np.where(V[:, 0] > 0, np.nan, V[:, 1])
    path = tmp_path / "v.html"
    write_html(path, V, F, {"b": b, "a": a, "c": c})  # a dict keeps its order (not sorted)
    got = embedded_arrays(path)
    assert list(got["fields"]) == ["b", "a", "c"] and got["field"] == "b"
    for key, want in zip("bac", (b, a, c)):
        np.testing.assert_allclose(got["fields"][key], want, rtol=1e-6)  # NaN stays NaN (grey) where it was
    np.testing.assert_allclose(got["values"], b, rtol=1e-6)
    write_html(path, V, F, np.column_stack([a, b]), names=["first", "second"], field="second")
    got = embedded_arrays(path)
    assert list(got["fields"]) == ["first", "second"] and got["field"] == "second"
    np.testing.assert_allclose(got["values"], b, rtol=1e-6)
    write_html(path, V, F, np.column_stack([a, b, c]), name="t")  # unnamed columns: name_0, name_1, ...
    assert list(embedded_arrays(path)["fields"]) == ["t_0", "t_1", "t_2"]
    # each field has its own colour range, from its finite values
    import json

    text = path.read_text()
    data = json.loads(text[text.index("const DATA = ") + 13:text.index(";\n", text.index("const DATA = "))])
    ranges = [f["range"] for f in data["fields"]]
    for r, x in zip(ranges, (a, b, c)):
        np.testing.assert_allclose(r, [np.nanmin(x), np.nanmax(x)])


def test_viewer_field_names_cannot_break_the_page(tmp_path):
    V, F = icosphere(1)
    names = [EVIL, "a\nb \u2028 <!-- \u00e9", "__DATA__", "__TITLE__"]
    path = tmp_path / "v.html"
    write_html(path, V, F, np.column_stack([V[:, 0], V[:, 1], V[:, 2], -V[:, 2]]), names=names,
               title="__DATA__ </script> __TITLE__")
    text = path.read_text(encoding="utf-8")
    # one script element, ended once; no markup from the names; the placeholders filled in once each
    assert text.count("<script>") == 1 and text.count("</script>") == 1 and text.index("</script>") > text.index("DATA")
    assert "<b>\"x" not in text and "<!--" not in text and "\u2028" not in text
    assert "<title>__DATA__ &lt;/script&gt; __TITLE__</title>" in text and text.count("const DATA = ") == 1
    got = embedded_arrays(path)
    assert list(got["fields"]) == names  # the names come back exactly
    np.testing.assert_allclose(got["fields"]["__TITLE__"], -V[:, 2], rtol=1e-6)


def test_viewer_unknown_field_lists_the_names(tmp_path):
    V, F = icosphere(1)
    path = tmp_path / "v.html"
    with pytest.raises(OptionError) as err:
        write_html(path, V, F, {"temp": V[:, 0], EVIL: V[:, 1]}, field="pressure")
    msg = str(err.value)
    assert "'pressure'" in msg and "'temp'" in msg and repr(EVIL) in msg and "\n" not in msg
    assert not path.exists()


@pytest.mark.parametrize("values, names, error", [
    ("short", None, WriteError),  # one value too few
    ("wide", ["a"], OptionError),  # two columns, one name
    ("wide", ["a", "a"], OptionError),  # the same name twice
    ("wide", "ab", OptionError),  # a string is not a list of names
    ("dict-short", None, WriteError),
    ("text", None, WriteError),
    ("empty-dict", None, WriteError),
])
def test_viewer_and_render_reject_fields_that_do_not_fit(tmp_path, values, names, error):
    from manifill.viz.render import render

    V, F = icosphere(1)
    n = len(V)
    values = {"short": np.zeros(n - 1), "wide": np.zeros((n, 2)), "dict-short": {"a": np.zeros(n), "b": [1.0]},
              "text": np.array(["x"] * n), "empty-dict": {}}[values]
    with pytest.raises(error) as err:
        write_html(tmp_path / "v.html", V, F, values, names=names)
    assert "\n" not in str(err.value)
    with pytest.raises(error):
        render(V, F, values, tmp_path / "r.png", names=names)
    assert not (tmp_path / "v.html").exists() and not (tmp_path / "r.png").exists()


def test_render_draws_the_chosen_field_as_if_alone(tmp_path):
    # choosing field "b" of several gives the very picture of "b" rendered alone (same name on the colour bar)
    from manifill.viz.render import render

    V, F = icosphere(3)
    a, b = V[:, 0], 3 * V[:, 2] ** 2 - 1
    kw = dict(size=(240, 200), view=(0, -1, 0.3), viewup=(0, 0, 1))
    render(V, F, b, tmp_path / "alone.png", name="b", **kw)
    render(V, F, {"a": a, "b": b}, tmp_path / "dict.png", field="b", **kw)
    render(V, F, np.column_stack([a, b]), tmp_path / "cols.png", names=["a", "b"], field="b", **kw)
    render(V, F, {"a": a, "b": b}, tmp_path / "first.png", **kw)  # default: the first field
    alone = png(tmp_path / "alone.png")
    assert np.array_equal(png(tmp_path / "dict.png"), alone) and np.array_equal(png(tmp_path / "cols.png"), alone)
    assert np.abs(png(tmp_path / "first.png") - alone).mean() > 5  # the other field looks different
    with pytest.raises(OptionError, match="'a', 'b'"):
        render(V, F, {"a": a, "b": b}, tmp_path / "x.png", field="c", **kw)
    assert not (tmp_path / "x.png").exists()


needs_chromium = pytest.mark.skipif(chromium() is None,
                                    reason="needs Debian's chromium (.ci/run installs it: apt-get install chromium)")


def run_chromium(tmp_path, url, *args):
    cmd = [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
           "--enable-unsafe-swiftshader", "--no-first-run", "--disable-background-networking",
           "--disable-component-update", "--disable-sync", f"--user-data-dir={tmp_path / 'profile'}",
           "--window-size=640,480", *args, url]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False).stdout


def between(text, start, end="</"):
    return text.split(start, 1)[1].split(end, 1)[0]


@needs_chromium
@pytest.mark.parametrize("field, scale, shift", [("2z+1", 2.0, 1.0), (EVIL, -1.0, 0.0)])
def test_viewer_switches_field_and_picks_it_in_headless_chromium(tmp_path, field, scale, shift):
    # fields z, 2z+1 and -z on the unit sphere; the page switches to one (window.manifillSelectField, from the
    # URL) and its own picking reads that field at the canvas centre, where z = 1/sqrt(3) (see above)
    from urllib.parse import quote

    V, F = icosphere(5)
    z = V[:, 2]
    page = tmp_path / "v.html"
    write_html(page, V, F, {"z": z, "2z+1": 2 * z + 1, EVIL: -z})
    dom = run_chromium(tmp_path, page.as_uri() + "#field=" + quote(field, safe="") + "&pick=0.5,0.5", "--dump-dom")
    value, vertex = between(dom, '<div id="pick-result">').split()
    assert abs(float(value) - (scale / np.sqrt(3) + shift)) < 0.01 * abs(scale)
    assert abs(scale * z[int(vertex)] + shift - float(value)) < 0.02 * abs(scale)
    import html

    shown = html.escape(field, quote=False)
    assert between(dom, '<div id="pick-field">') == shown
    # the hover read-out names the field; the colour bar shows its name and its own range
    assert between(dom, '<div id="hover"').split(">", 1)[1].startswith(f"{shown} = ")
    assert between(dom, '<b id="name">') == shown
    lo = float(between(dom, 'id="lo" style="text-align:left">'))
    hi = float(between(dom, 'id="hi" style="text-align:right">'))
    np.testing.assert_allclose([lo, hi], sorted([scale * z.min() + shift, scale * z.max() + shift]), atol=1e-3)
    # the list holds every name as text; the evil name injected no element
    options = [between(o, ">") for o in between(dom, '<select id="field">', "</select>").split("<option")[1:]]
    assert options == ["z", "2z+1", html.escape(EVIL, quote=False)]
    assert '<b>"x' not in dom


@needs_chromium
def test_viewer_recolours_with_the_field_range_in_headless_chromium(tmp_path):
    # a page switched to its second field draws the sphere exactly as a page holding only that field: the
    # colours follow the new field (x, not z) and its own range (3x - 2 spans [-5, 1], z spans [-1, 1])
    V, F = icosphere(4)
    both, alone = tmp_path / "both.html", tmp_path / "alone.html"
    write_html(both, V, F, {"z": V[:, 2], "w": 3 * V[:, 0] - 2}, samples=[0, 7])
    write_html(alone, V, F, {"w": 3 * V[:, 0] - 2}, samples=[0, 7])
    run_chromium(tmp_path, both.as_uri() + "#field=w", f"--screenshot={tmp_path / 'both.png'}")
    run_chromium(tmp_path, alone.as_uri(), f"--screenshot={tmp_path / 'alone.png'}")
    a, b = png(tmp_path / "both.png")[100:], png(tmp_path / "alone.png")[100:]  # below the panel (its list differs)
    assert a.shape == (380, 640, 3) and a[40:240, 220:420].std() > 15  # the sphere is drawn and coloured
    assert np.abs(a - b).max() <= 2


@pytest.mark.skipif(chromium() is None, reason=NEEDS_CHROMIUM)
def test_viewer_shows_controls_only_for_what_the_result_has(tmp_path):
    # a "curves" box showed for methods that draw no curves
    V, F = icosphere(3)
    idx = np.arange(0, len(V), 37)
    shown = {}
    for method in ("gvf-harmonic", "default"):
        r = reconstruct(V, F, idx, V[idx, 0], method=method)
        page = tmp_path / f"{method}.html"
        write_html(page, V, F, r.values, samples=idx, curves=r.curves)
        cmd = [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
               "--enable-unsafe-swiftshader", "--no-first-run", f"--user-data-dir={tmp_path / 'profile'}",
               "--dump-dom", page.as_uri()]
        dom = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False).stdout
        box = re.search(r'<label id="curvesBox"[^>]*>', dom).group()
        shown[method] = "display: none" not in box
        assert "display: none" not in re.search(r'<label id="samplesBox"[^>]*>', dom).group()
    assert shown == {"gvf-harmonic": True, "default": False}  # the default (the biharmonic) draws no curves
