"""The command line, run in-process through ``manifill.cli.main(argv)`` (and once as the installed script)."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import meshio
import numpy as np
import pytest
from scipy.spatial import cKDTree

import manifill
from manifill import harmonic, mesh_info
from conftest import assert_usage_error, files, run
from manifill.io import read_mesh, write_mesh
from manifill.mesh.shapes import grid, icosphere

pytestmark = pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")


@pytest.fixture
def sphere(tmp_path):
    """An icosphere (162 vertices) as PLY, its arrays, and vertex samples as CSV."""
    V, F = icosphere(2)
    path = tmp_path / "sphere.ply"
    write_mesh(path, V, F)
    idx = np.array([0, 7, 40, 100, 150])
    vals = np.array([[1.0, -3.0], [2.0, 0.5], [-1.0, 4.0], [0.25, 0.0], [3.0, 1.0]])
    samples = tmp_path / "samples.csv"
    rows = list(zip(idx.tolist(), vals.tolist()))
    samples.write_text("vertex,temp\n" + "".join(f"{i},{v[0]!r}\n" for i, v in rows))
    samples2 = tmp_path / "samples2.csv"
    samples2.write_text("vertex,temp,pressure\n" + "".join(f"{i},{v[0]!r},{v[1]!r}\n" for i, v in rows))
    return dict(path=path, V=V, F=F, idx=idx, vals=vals, samples=samples, samples2=samples2)


def two_spheres(tmp_path):
    V, F = icosphere(1)
    V2 = np.vstack([V, V + [5.0, 0.0, 0.0]])
    F2 = np.vstack([F, F + len(V)])
    path = tmp_path / "two.ply"
    write_mesh(path, V2, F2)
    return path, len(V)


# ----------------------------------------------------------------------------- info


def test_info_on_an_icosphere(tmp_path, capsys, sphere):
    code, out, err = run(capsys, "info", sphere["path"])
    assert code == 0 and err == ""
    assert "162 vertices, 320 faces, 480 edges" in out
    assert "components    1" in out
    assert "Euler characteristic 2, closed, genus 0" in out
    assert "boundary loops       0" in out


def test_info_on_an_open_grid_and_two_components(tmp_path, capsys):
    V, F = grid(6)
    write_mesh(tmp_path / "grid.obj", V, F)
    code, out, _ = run(capsys, "info", tmp_path / "grid.obj")
    assert code == 0
    assert "36 vertices, 50 faces, 85 edges" in out
    assert "Euler characteristic 1, open, 1 boundary loop(s)" in out and "genus" not in out
    path, _ = two_spheres(tmp_path)
    code, out, _ = run(capsys, "info", path)
    assert code == 0 and "components    2" in out and out.count("genus 0") == 2


@pytest.mark.parametrize("ext", [".ply", ".off", ".vtu"])
def test_info_json_agrees_with_mesh_info(tmp_path, capsys, ext):
    V, F = icosphere(2)
    path = tmp_path / f"m{ext}"
    write_mesh(path, V, F)
    code, out, err = run(capsys, "info", "--json", path)
    assert code == 0 and err == ""
    info = json.loads(out)
    assert info == json.loads(json.dumps(mesh_info(*read_mesh(path))))
    assert info["vertices"] == 162 and info["faces"] == 320
    assert [c["genus"] for c in info["components"]] == [0]
    assert info["components"][0]["euler"] == 2


# ----------------------------------------------------------------------------- harmonic


def test_harmonic_writes_the_library_result(tmp_path, capsys, sphere):
    out_path = tmp_path / "out.ply"
    code, out, err = run(capsys, "harmonic", sphere["path"], sphere["samples"], "-o", out_path)
    assert code == 0 and err == ""
    assert f"wrote {out_path}" in out and "weights=cotan" in out
    expected = harmonic(sphere["V"], sphere["F"], sphere["idx"], sphere["vals"][:, 0])
    m = meshio.read(out_path)
    np.testing.assert_allclose(m.points, sphere["V"], atol=1e-12)
    np.testing.assert_allclose(m.point_data["temp"], expected, rtol=1e-10, atol=1e-12)
    fixed = np.zeros(len(sphere["V"]), dtype=bool)
    fixed[sphere["idx"]] = True
    np.testing.assert_array_equal(m.point_data["sample_mask"].astype(bool), fixed)
    assert set(m.point_data) == {"temp", "sample_mask"}
    assert files(tmp_path) == ["out.ply", "samples.csv", "samples2.csv", "sphere.ply"]


@pytest.mark.parametrize("ext", [".vtu", ".vtk"])
def test_harmonic_to_other_mesh_formats(tmp_path, capsys, sphere, ext):
    code, _, _ = run(capsys, "harmonic", sphere["path"], sphere["samples2"], "-o", tmp_path / f"out{ext}")
    assert code == 0
    expected = harmonic(sphere["V"], sphere["F"], sphere["idx"], sphere["vals"])
    pd = meshio.read(tmp_path / f"out{ext}").point_data
    np.testing.assert_allclose(pd["temp"], expected[:, 0], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(pd["pressure"], expected[:, 1], rtol=1e-10, atol=1e-12)


def test_harmonic_values_as_csv_and_npy(tmp_path, capsys, sphere):
    expected = harmonic(sphere["V"], sphere["F"], sphere["idx"], sphere["vals"][:, 0])
    code, _, _ = run(capsys, "harmonic", sphere["path"], sphere["samples"], "-o", tmp_path / "out.csv")
    assert code == 0
    lines = (tmp_path / "out.csv").read_text().splitlines()
    assert lines[0] == "vertex,temp"
    table = np.loadtxt(tmp_path / "out.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(table[:, 0], np.arange(len(sphere["V"])))
    np.testing.assert_allclose(table[:, 1], expected, rtol=1e-10, atol=1e-12)

    code, _, _ = run(capsys, "harmonic", sphere["path"], sphere["samples"], "-o", tmp_path / "out.npy")
    assert code == 0
    np.testing.assert_allclose(np.load(tmp_path / "out.npy"), expected, rtol=1e-10, atol=1e-12)


def test_weights_and_solver_are_honoured(tmp_path, capsys, sphere):
    code, out, _ = run(capsys, "harmonic", sphere["path"], sphere["samples"], "-o", tmp_path / "u.npy",
                       "--weights", "uniform", "--solver", "direct")
    assert code == 0
    assert "weights=uniform" in out and "solver=direct" in out
    x = np.load(tmp_path / "u.npy")
    uniform = harmonic(sphere["V"], sphere["F"], sphere["idx"], sphere["vals"][:, 0], weights="uniform",
                       solver="direct")
    cotan = harmonic(sphere["V"], sphere["F"], sphere["idx"], sphere["vals"][:, 0])
    np.testing.assert_allclose(x, uniform, rtol=1e-12, atol=1e-12)
    assert np.abs(x - cotan).max() > 1e-4  # the option made a difference


def test_two_value_columns_give_two_fields(tmp_path, capsys, sphere):
    code, out, _ = run(capsys, "harmonic", sphere["path"], sphere["samples2"], "-o", tmp_path / "out.ply")
    assert code == 0 and "2 field(s): temp, pressure" in out
    expected = harmonic(sphere["V"], sphere["F"], sphere["idx"], sphere["vals"])
    pd = meshio.read(tmp_path / "out.ply").point_data
    assert set(pd) == {"temp", "pressure", "sample_mask"}
    np.testing.assert_allclose(np.column_stack([pd["temp"], pd["pressure"]]), expected, rtol=1e-10, atol=1e-12)
    code, _, _ = run(capsys, "harmonic", sphere["path"], sphere["samples2"], "-o", tmp_path / "out.csv")
    assert code == 0
    assert (tmp_path / "out.csv").read_text().splitlines()[0] == "vertex,temp,pressure"


def test_a_field_named_fixed_is_kept_and_a_mask_name_refused_before_the_work(tmp_path, capsys, sphere):
    path = tmp_path / "fixed.csv"
    path.write_text(sphere["samples"].read_text().replace("vertex,temp", "vertex,fixed"))
    code, _, _ = run(capsys, "harmonic", sphere["path"], path, "-o", tmp_path / "out.vtu")
    pd = meshio.read(tmp_path / "out.vtu").point_data
    expected = harmonic(sphere["V"], sphere["F"], sphere["idx"], sphere["vals"][:, 0])
    assert code == 0
    np.testing.assert_allclose(pd["fixed"], expected, rtol=1e-10, atol=1e-12)
    path.write_text(sphere["samples"].read_text().replace("vertex,temp", "vertex,sample_mask"))
    code, out, err = run(capsys, "harmonic", sphere["path"], path, "-o", tmp_path / "out2.vtu")
    assert code == 2 and "'sample_mask' is the name of manifill's mask" in err and err.count("\n") == 1
    assert not (tmp_path / "out2.vtu").exists()


def test_position_samples_are_snapped(tmp_path, capsys, sphere):
    V = sphere["V"]
    P = V[sphere["idx"]] * 1.01  # just outside the sphere
    path = tmp_path / "points.csv"
    path.write_text("x,y,z,temp\n" + "".join(f"{p[0]!r},{p[1]!r},{p[2]!r},{v!r}\n"
                                             for p, v in zip(P.tolist(), sphere["vals"][:, 0].tolist())))
    code, out, _ = run(capsys, "harmonic", sphere["path"], path, "-o", tmp_path / "out.npy")
    assert code == 0 and "snapped positions to vertices: largest distance 0.01" in out
    expected = harmonic(V, sphere["F"], sphere["idx"], sphere["vals"][:, 0])
    np.testing.assert_allclose(np.load(tmp_path / "out.npy"), expected, rtol=1e-10, atol=1e-12)


# ----------------------------------------------------------------------------- bad input


def bad_case(tmp_path, case):
    """Arguments of a ``harmonic`` call that must fail, and a word its message must contain."""
    V, F = icosphere(1)
    write_mesh(tmp_path / "m.ply", V, F)
    good = tmp_path / "s.csv"
    good.write_text("vertex,v\n0,1\n5,2\n")
    mesh, samples, output, word = tmp_path / "m.ply", good, tmp_path / "out.ply", None
    if case == "missing mesh":
        mesh, word = tmp_path / "nope.ply", "no such file"
    elif case == "bad mesh extension":
        mesh, word = tmp_path / "m.abc", "cannot read"
        mesh.write_text("1 2 3\n")
    elif case == "garbage mesh":
        mesh, word = tmp_path / "g.ply", "not a readable PLY mesh"
        mesh.write_bytes(b"garbage\x00\x01\n")
    elif case == "missing samples":
        samples, word = tmp_path / "nope.csv", "no such file"
    elif case == "bad samples header":
        samples, word = tmp_path / "h.csv", "header"
        samples.write_text("node,v\n0,1\n")
    elif case == "non-numeric sample":
        samples, word = tmp_path / "n.csv", "line 3, column 'v'"
        samples.write_text("vertex,v\n0,1\n5,high\n")
    elif case == "far samples":
        samples, word = tmp_path / "far.csv", "wrong units?"
        samples.write_text("x,y,z,v\n0,0,1000,1\n1000,0,0,2\n")
    elif case == "conflicting duplicates":
        samples, word = tmp_path / "dup.csv", "vertex 5"
        samples.write_text("vertex,v\n0,1\n5,2\n5,3\n")
    elif case == "vertex out of range":
        samples, word = tmp_path / "range.csv", "outside 0..41"
        samples.write_text("vertex,v\n0,1\n42,2\n")
    elif case == "negative vertex":
        samples, word = tmp_path / "neg.csv", "-1"
        samples.write_text("vertex,v\n-1,1\n")
    elif case == "missing output folder":
        output, word = tmp_path / "nope" / "out.ply", "does not exist"
    elif case.startswith("output ."):
        output, word = tmp_path / f"out{case[7:]}", "-o writes"
    elif case == "component without samples":
        mesh, _ = two_spheres(tmp_path)
        word = "component of 42 vertices"
    else:
        raise AssertionError(case)
    return [mesh, samples, "-o", output], word


BAD_CASES = [
    "missing mesh", "bad mesh extension", "garbage mesh", "missing samples", "bad samples header",
    "non-numeric sample", "far samples", "conflicting duplicates", "vertex out of range", "negative vertex",
    "missing output folder", "output .stl", "output .off", "output .obj", "output .txt", "output .",
    "component without samples",
]


@pytest.mark.parametrize("case", BAD_CASES)
def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, case):
    args, word = bad_case(tmp_path, case)
    before = files(tmp_path)
    code, out, err = run(capsys, "harmonic", *args)
    line = assert_usage_error(code, out, err)
    assert word in line
    assert files(tmp_path) == before  # nothing written, no temporary files


def test_duplicates_mean_succeeds(tmp_path, capsys):
    args, _ = bad_case(tmp_path, "conflicting duplicates")
    code, out, err = run(capsys, "harmonic", *args, "--duplicates", "mean")
    assert code == 0 and err == "" and "1 merged" in out
    V, F = read_mesh(args[0])
    x = meshio.read(args[3]).point_data["v"]
    np.testing.assert_allclose(x, harmonic(V, F, [0, 5], [1.0, 2.5]), rtol=1e-10, atol=1e-12)


def test_far_samples_accepted_with_max_snap(tmp_path, capsys):
    args, _ = bad_case(tmp_path, "far samples")
    code, _, err = run(capsys, "harmonic", *args, "--max-distance", "2000")
    assert code == 0 and err == ""


def test_on_empty_nan_writes_nan(tmp_path, capsys):
    args, _ = bad_case(tmp_path, "component without samples")
    code, out, err = run(capsys, "harmonic", *args, "--on-empty", "nan")
    assert code == 0 and err == ""
    assert "1 component(s) without samples left NaN" in out
    x = meshio.read(args[3]).point_data["v"]
    assert x.shape == (84,)
    assert np.isfinite(x[:42]).all() and np.isnan(x[42:]).all()
    code, _, _ = run(capsys, "harmonic", *args[:2], "-o", tmp_path / "out.csv", "--on-empty", "nan")
    assert code == 0
    table = np.loadtxt(tmp_path / "out.csv", delimiter=",", skiprows=1)
    assert np.isfinite(table[:42, 1]).all() and np.isnan(table[42:, 1]).all()


@pytest.mark.parametrize("argv", [
    [],
    ["frobnicate"],
    ["info"],
    ["harmonic", "m.ply", "s.csv"],  # no -o
    ["harmonic", "m.ply", "s.csv", "-o", "o.ply", "--weights", "magic"],
    ["harmonic", "m.ply", "s.csv", "-o", "o.ply", "--max-distance", "far"],
])
def test_argparse_errors_exit_2_without_traceback(capsys, argv):
    code, out, err = run(capsys, *argv)
    assert code == 2
    assert "Traceback" not in out + err
    assert "error:" in err.splitlines()[-1]


# ----------------------------------------------------------------------------- --clean


def soup(V, F):
    """Every face with its own three vertices: looks like the mesh, but falls apart."""
    return V[F].reshape(-1, 3), np.arange(3 * len(F)).reshape(-1, 3)


def same_field_by_position(Va, xa, Vb, xb):
    dist, j = cKDTree(Vb).query(Va)
    assert dist.max() < 1e-12 and len(Va) == len(Vb)
    np.testing.assert_allclose(xa, xb[j], rtol=1e-10, atol=1e-12)


def test_clean_welds_a_triangle_soup(tmp_path, capsys):
    V, F = grid(6)
    write_mesh(tmp_path / "grid.ply", V, F)
    write_mesh(tmp_path / "soup.ply", *soup(V, F))
    samples = tmp_path / "s.csv"
    samples.write_text("x,y,z,v\n0,0,0,1\n1,1,0,2\n0.4,0.6,0,-1\n1,0,0,0.5\n")

    code, out, err = run(capsys, "harmonic", tmp_path / "soup.ply", samples, "-o", tmp_path / "soup_out.ply")
    line = assert_usage_error(code, out, err)
    assert "--clean" in line
    assert not (tmp_path / "soup_out.ply").exists()

    code, out, err = run(capsys, "harmonic", tmp_path / "soup.ply", samples, "-o", tmp_path / "soup_out.ply",
                         "--clean")
    assert code == 0 and err == ""
    assert f"cleaned mesh: {3 * len(F)} -> {len(V)} vertices" in out
    code, _, _ = run(capsys, "harmonic", tmp_path / "grid.ply", samples, "-o", tmp_path / "grid_out.ply")
    assert code == 0
    a, b = meshio.read(tmp_path / "soup_out.ply"), meshio.read(tmp_path / "grid_out.ply")
    assert len(a.cells_dict["triangle"]) == len(F)
    same_field_by_position(a.points, a.point_data["v"], b.points, b.point_data["v"])
    same_field_by_position(a.points, a.point_data["sample_mask"], b.points, b.point_data["sample_mask"])


def vertex_samples_on_a_soup(tmp_path, soup_idx):
    V, F = grid(6)
    write_mesh(tmp_path / "grid.ply", V, F)
    write_mesh(tmp_path / "soup.ply", *soup(V, F))
    vals = np.arange(1.0, len(soup_idx) + 1)
    (tmp_path / "soup.csv").write_text("vertex,v\n" + "".join(f"{i},{v}\n" for i, v in zip(soup_idx, vals)))
    grid_idx = F.ravel()[soup_idx]  # the same vertices in the grid's numbering
    (tmp_path / "grid.csv").write_text("vertex,v\n" + "".join(f"{i},{v}\n" for i, v in zip(grid_idx, vals)))
    return [tmp_path / "soup.ply", tmp_path / "soup.csv", "-o", tmp_path / "soup_out.ply", "--clean"], \
           [tmp_path / "grid.ply", tmp_path / "grid.csv", "-o", tmp_path / "grid_out.ply"]


def check_clean_vertex_samples(tmp_path, capsys, soup_idx):
    soup_args, grid_args = vertex_samples_on_a_soup(tmp_path, soup_idx)
    assert run(capsys, "harmonic", *grid_args)[0] == 0
    code, out, err = run(capsys, "harmonic", *soup_args)
    assert code == 0, err
    a, b = meshio.read(soup_args[3]), meshio.read(grid_args[3])
    same_field_by_position(a.points, a.point_data["v"], b.points, b.point_data["v"])


def test_clean_renumbers_vertex_samples(tmp_path, capsys):
    # soup vertices 0..35 fall on 0..35 welded ones; these four land on distinct grid vertices
    V, F = grid(6)
    soup_idx = np.array([0, 4, 17, 31])
    assert np.unique(F.ravel()[soup_idx]).size == soup_idx.size
    check_clean_vertex_samples(tmp_path, capsys, soup_idx)


def test_clean_accepts_vertex_indices_beyond_the_welded_count(tmp_path, capsys):
    V, F = grid(6)
    soup_idx = np.array([0, 100, 149])  # the soup has 150 vertices, the welded grid 36
    assert np.unique(F.ravel()[soup_idx]).size == soup_idx.size
    check_clean_vertex_samples(tmp_path, capsys, soup_idx)


# ----------------------------------------------------------------------------- --version, --help, demo


def test_version(capsys):
    code, out, _ = run(capsys, "--version")
    assert code == 0 and out.strip() == f"manifill {manifill.__version__}"


@pytest.mark.parametrize("sub", [None, "info", "harmonic", "demo"])
def test_help(capsys, sub):
    code, out, err = run(capsys, *([sub] if sub else []), "--help")
    assert code == 0 and err == ""
    assert out.startswith("usage: manifill" + (f" {sub}" if sub else ""))


def test_demo(tmp_path, capsys):
    outdir = tmp_path / "d"
    code, out, err = run(capsys, "demo", "-o", outdir)
    assert code == 0 and err == ""
    rmse = {line.split("(")[1].split(")")[0].strip(): float(line.split("relative RMSE ")[1].split(",")[0])
            for line in out.splitlines() if "vertices (" in line and "relative RMSE" in line}
    assert len(rmse) == 5 and all(0 < r < 0.5 for r in rmse.values())
    # the paper's pipeline beats point constraints on the same samples, and the default beats the pipeline
    assert rmse["100 points, default"] < rmse["100 points, pipeline"] < rmse["100 points, harmonic"]
    base = ["report.txt", "samples.csv", "sphere.ply", "sphere.vtu"]
    pictures = ["fig4_1_cycle.png", "fig4_3_gvf_vs_harmonic.png", "fig4_4_three_components.png",
                "fig4_5_7_guiding_points.png", "solid_slices.png", "viewer.html"]
    assert files(outdir) == sorted(base + pictures)  # pyvista is a test dependency: the pictures are made
    assert (outdir / "report.txt").read_text().strip() == out.strip()
    m = meshio.read(outdir / "sphere.vtu")
    assert len(m.points) == 40962
    assert {"truth", "harmonic_curves", "harmonic_points", "circle_mask", "sample_mask",
            "default", "pipeline", "curve_mask", "patch_label", "gp", "gp_std"} <= set(m.point_data)
    scale = np.ptp(m.point_data["truth"])
    sample = m.point_data["sample_mask"].astype(bool)
    assert np.all(m.point_data["gp_std"][sample] == 0) and np.all(m.point_data["gp_std"][~sample] > 0)
    np.testing.assert_allclose(m.point_data["gp"][sample], m.point_data["truth"][sample], atol=1e-9 * scale)
    # the command the demo suggests runs, and gives the demo's own default result
    code, out, err = run(capsys, "reconstruct", outdir / "sphere.ply", outdir / "samples.csv",
                         "-o", outdir / "mine.npy")
    assert code == 0 and err == ""
    np.testing.assert_allclose(np.load(outdir / "mine.npy"), m.point_data["default"], atol=1e-6 * scale)
    code, out, err = run(capsys, "harmonic", outdir / "sphere.ply", outdir / "samples.csv",
                         "-o", outdir / "mine.npy")
    assert code == 0 and err == ""
    np.testing.assert_allclose(np.load(outdir / "mine.npy"), m.point_data["harmonic_points"], atol=1e-6 * scale)


# ----------------------------------------------------------------------------- the installed script


def installed_command():
    script = Path(sys.executable).parent / "manifill"
    if script.is_file() and os.access(script, os.X_OK):
        return [str(script)]
    found = shutil.which("manifill")
    return [found] if found else [sys.executable, "-m", "manifill"]


@pytest.mark.parametrize("how", ["script", "module"])
def test_installed_command_bad_input(tmp_path, how):
    (tmp_path / "bad.ply").write_bytes(b"not a mesh\n")
    (tmp_path / "s.csv").write_text("vertex,v\n0,1\n")
    cmd = installed_command() if how == "script" else [sys.executable, "-m", "manifill"]
    proc = subprocess.run(cmd + ["harmonic", "bad.ply", "s.csv", "-o", "out.ply"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stdout + proc.stderr
    assert proc.stderr.splitlines() == [proc.stderr.strip()]
    assert proc.stderr.startswith("manifill: error: bad.ply: not a readable PLY mesh")
    assert proc.stdout == ""
    assert files(tmp_path) == ["bad.ply", "s.csv"]


@pytest.mark.parametrize("argv", [["harmonic", "m.ply", "s.csv", "-o", "o.ply", "--weights", "foo"],
                                  ["harmonic", "m.ply"], [], ["nosuch"]])
def test_usage_errors_are_one_line(capsys, argv):
    code, out, err = run(capsys, *argv)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("manifill: error: ") and "--help" in err


# ----------------------------------------------------------------------------- check and reconstruct


def test_check_holds_with_auto_levels_and_prints_the_lipschitz_constant(tmp_path, capsys, sphere):
    s = sphere
    code, out, err = run(capsys, "check", s["path"], s["samples2"])
    assert code == 0 and err == ""
    from manifill.mesh.graph import mesh_graph
    from manifill.surface.gradual import lipschitz_constant
    G = mesh_graph(s["V"], s["F"], distance="hops")
    for j, name in enumerate(["temp", "pressure"]):
        K = lipschitz_constant(G, s["idx"], s["vals"][:, j])[0]
        assert f"{name}:" in out and f"Lipschitz constant {K:.6g} per hop" in out
    assert out.count("condition: holds") == 2


def test_check_fails_with_too_many_levels_and_lists_pairs(tmp_path, capsys, sphere):
    s = sphere
    code, out, err = run(capsys, "check", s["path"], s["samples"], "--levels", "1000")
    assert code == 1 and err == ""
    assert "FAILS for" in out
    from manifill.mesh.graph import mesh_graph
    from manifill.surface.gradual import check_gradual
    c = check_gradual(mesh_graph(s["V"], s["F"], distance="hops"), s["idx"], s["vals"][:, 0], levels=1000)
    assert f"FAILS for {len(c.violations)} samples" in out


def test_check_explicit_levels_and_bad_levels(tmp_path, capsys, sphere):
    s = sphere
    code, out, _ = run(capsys, "check", s["path"], s["samples"], "--levels=-1,0,1,2,3")
    assert code == 0 and "5 levels from -1 to 3" in out
    code, out, err = run(capsys, "check", s["path"], s["samples"], "--levels", "3,1,2")
    assert_usage_error(code, out, err)
    code, out, err = run(capsys, "check", s["path"], s["samples"], "--levels", "many")
    assert_usage_error(code, out, err)


def test_reconstruct_writes_field_curves_and_components(tmp_path, capsys, sphere):
    from manifill.surface.reconstruct import reconstruct
    s = sphere
    out_path = tmp_path / "rec.vtu"
    code, out, err = run(capsys, "reconstruct", s["path"], s["samples"], "-o", out_path, "--curve-values", "linear",
                         "--method", "gvf-harmonic")
    assert code == 0 and err == ""
    r = reconstruct(s["V"], s["F"], s["idx"], s["vals"][:, 0], curve_values="linear", method="gvf-harmonic")
    pd = meshio.read(out_path).point_data
    np.testing.assert_allclose(pd["temp"], r.values, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(pd["curve_mask"].astype(bool), r.on_curve)
    np.testing.assert_array_equal(pd["patch_label"], r.components)
    assert "delaunay partition" in out and "steps 5-6" in out


@pytest.mark.parametrize("extra", [["--method", "nope"], ["--partition", "x"], ["--curve-values", "y"]])
def test_reconstruct_bad_options_exit_2(tmp_path, capsys, extra, sphere):
    s = sphere
    code, out, err = run(capsys, "reconstruct", s["path"], s["samples"], "-o", tmp_path / "r.ply", *extra)
    assert_usage_error(code, out, err)
    assert not (tmp_path / "r.ply").exists()


def test_reconstruct_component_without_samples_exit_2_and_nan_option(tmp_path, capsys):
    path, n = two_spheres(tmp_path)
    samples = tmp_path / "s.csv"
    samples.write_text("vertex,v\n0,1\n5,2\n9,0\n")
    code, out, err = run(capsys, "reconstruct", path, samples, "-o", tmp_path / "r.npy")
    assert_usage_error(code, out, err)
    assert "no fixed vertex" in err and not (tmp_path / "r.npy").exists()
    code, out, err = run(capsys, "reconstruct", path, samples, "-o", tmp_path / "r.npy", "--on-empty", "nan")
    assert code == 0
    x = np.load(tmp_path / "r.npy")
    assert np.isnan(x[n:]).all() and np.isfinite(x[:n]).all()


def test_demo_into_an_existing_file_exits_2(tmp_path, capsys):
    target = tmp_path / "taken.ply"
    target.write_text("x")
    code, out, err = run(capsys, "demo", "-o", target)
    assert_usage_error(code, out, err)


def test_the_command_line_holds_no_numerics():
    """No module of manifill.cli imports numpy or scipy: the numbers come from the library."""
    import ast

    import manifill.cli

    for path in sorted(Path(manifill.cli.__file__).parent.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level else [])
            for name in names:
                assert name.split(".")[0] not in ("numpy", "scipy"), f"{path.name} imports {name}"


@pytest.mark.parametrize("method", ["gvf-harmonic", "harmonic", "gvf"])
def test_progress_total_is_the_steps_run(tmp_path, capsys, sphere, bars, method):
    code, out, err = run(capsys, "reconstruct", sphere["path"], sphere["samples"], "-o", tmp_path / "o.vtu",
                         "--method", method)
    assert code == 0, err
    (bar,) = bars
    assert bar.total == len(bar.steps) and bar.steps[-1] in ("harmonic fill", "gvf")



def test_energy_methods_with_bounds_and_smoothing(tmp_path, capsys, sphere):
    """--method biharmonic --bounds samples: the library's bounded result, in the samples' range; bad input exits 2."""
    s = sphere
    out_path = tmp_path / "bi.vtu"
    code, out, err = run(capsys, "reconstruct", s["path"], s["samples"], "-o", out_path, "--method", "biharmonic",
                         "--bounds", "samples")
    assert code == 0 and "biharmonic fill" in out and "bounded" in out
    vals = s["vals"][:, 0]
    r = manifill.reconstruct(s["V"], s["F"], s["idx"], vals, method="biharmonic", bounds="samples")
    got = meshio.read(out_path).point_data["temp"]
    np.testing.assert_allclose(got, r.values, rtol=1e-12, atol=1e-12)
    assert vals.min() <= got.min() and got.max() <= vals.max()
    code, out, err = run(capsys, "reconstruct", s["path"], s["samples"], "-o", out_path, "--method", "harmonic",
                         "--smoothing", "0.5")
    assert code == 0 and "smoothing lambda 0.5" in out
    for extra, words in [(["--method", "biharmonic", "--bounds", "0"], "--bounds"),
                         (["--method", "harmonic", "--smoothing", "lots"], "--smoothing"),
                         (["--method", "gvf-harmonic", "--smoothing", "0.5"], "energy methods"),
                         (["--method", "biharmonic", "--bounds", "0,1"], "outside the bounds")]:
        line = assert_usage_error(*run(capsys, "reconstruct", s["path"], s["samples"], "-o", tmp_path / "x.vtu",
                                       *extra))
        assert words in line
        assert not (tmp_path / "x.vtu").exists()
