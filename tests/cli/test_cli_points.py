"""``manifill reconstruct`` with samples given as positions: exact points for the energy methods."""

import numpy as np
import pytest

from conftest import assert_usage_error, run
from manifill.io import write_mesh
from manifill.mesh.shapes import icosphere
from manifill.surface.locate import locate_points


@pytest.fixture
def case(tmp_path):
    """An icosphere PLY and a CSV of 25 positions just off it, most nearest one vertex each."""
    V, F = icosphere(3)
    mesh = tmp_path / "sphere.ply"
    write_mesh(mesh, V, F)
    P = np.random.default_rng(4).normal(size=(25, 3))
    P *= 1.003 / np.linalg.norm(P, axis=1)[:, None]
    vals = P[:, 0] ** 2 - P[:, 2]
    samples = tmp_path / "points.csv"
    rows = "".join(f"{x:.17g},{y:.17g},{z:.17g},{v:.17g}\n" for (x, y, z), v in zip(P, vals))
    samples.write_text("x,y,z,temp\n" + rows)
    return dict(V=V, F=F, P=P, vals=vals, mesh=mesh, samples=samples, tmp=tmp_path)


@pytest.mark.parametrize("method", ["harmonic", "biharmonic", "triharmonic"])
def test_energy_methods_constrain_the_positions_exactly(case, capsys, method):
    out = case["tmp"] / "out.npy"
    code, text, err = run(capsys, "reconstruct", case["mesh"], case["samples"], "-o", out, "--method", method)
    assert code == 0 and err == ""
    assert "located 25 positions on the surface: 25 inside faces, 0 at vertices" in text
    X = np.load(out)
    X = X["temp"] if X.dtype.names else X.reshape(len(case["V"]), -1)[:, 0]
    s = locate_points(case["V"], case["F"], case["P"])
    assert np.abs(s.interpolate(X) - case["vals"]).max() <= 1e-10 * np.ptp(case["vals"])


def test_partition_methods_still_snap(case, capsys):
    out = case["tmp"] / "out.ply"
    code, text, err = run(capsys, "reconstruct", case["mesh"], case["samples"], "-o", out, "--duplicates", "mean",
                          "--method", "gvf-harmonic")
    assert code == 0 and err == ""
    assert "snapped positions to vertices: largest distance" in text and "located" not in text


def test_bounds_with_positions(case, capsys):
    out = case["tmp"] / "out.npy"
    code, text, err = run(capsys, "reconstruct", case["mesh"], case["samples"], "-o", out,
                          "--method", "biharmonic", "--bounds", "samples")
    assert code == 0 and err == "" and "bounded" in text


def test_amg_with_positions_inside_faces(case, capsys):
    out = case["tmp"] / "o.npy"
    code, text, err = run(capsys, "reconstruct", case["mesh"], case["samples"], "-o", out,
                          "--method", "biharmonic", "--solver", "amg")
    assert code == 0 and err == "" and "solver=amg" in text
    code, text, err = run(capsys, "reconstruct", case["mesh"], case["samples"], "-o", out,
                          "--method", "biharmonic", "--solver", "amg", "--bounds", "samples")
    assert code != 0 and "Traceback" not in text + err
    assert "pass solver='direct'" in err


def test_far_positions_refused_then_accepted_with_max_snap(case, capsys):
    far = case["tmp"] / "far.csv"
    far.write_text(case["samples"].read_text() + "0.0,0.0,40.0,1.0\n")
    o = case["tmp"] / "o.npy"
    code, out, err = run(capsys, "reconstruct", case["mesh"], far, "-o", o, "--method", "harmonic")
    assert code != 0 and "wrong units?" in err and "from the surface" in err
    code, out, err = run(capsys, "reconstruct", case["mesh"], far, "-o", o, "--method", "harmonic",
                         "--max-distance", "100")
    assert code == 0 and err == ""


def test_bad_max_snap_is_a_usage_error(case, capsys):
    code, out, err = run(capsys, "reconstruct", case["mesh"], case["samples"], "-o", case["tmp"] / "o.ply",
                         "--max-distance", "far")
    assert_usage_error(code, out, err)


def test_auto_on_the_command_line_uses_positions_as_the_library_does(tmp_path, capsys):
    # `--method auto` snapped positions to vertices (and said so) where manifill.reconstruct(method="auto") kept them
    import meshio

    import manifill
    from manifill.io import write_mesh
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(3)
    write_mesh(tmp_path / "m.vtu", V, F)
    P = V[F[::41]].mean(axis=1) * 1.003  # inside faces, a little off the surface
    vals = np.sin(3 * P[:, 0]) + P[:, 2]
    np.savetxt(tmp_path / "s.csv", np.column_stack([P, vals]), delimiter=",", header="x,y,z,t", comments="")
    code, out, err = run(capsys, "reconstruct", tmp_path / "m.vtu", tmp_path / "s.csv", "-o", tmp_path / "o.vtu",
                         "--method", "auto")
    assert code == 0, err
    assert "located" in out and "snapped" not in out
    want = manifill.reconstruct(V, F, P, vals, method="auto").values
    np.testing.assert_allclose(meshio.read(tmp_path / "o.vtu").point_data["t"], want, rtol=0, atol=1e-10)


def test_the_old_max_snap_spelling_works_for_one_release_with_a_note(case, capsys):
    """``--max-snap`` is now ``--max-distance`` (the library's ``max_distance``): the old flag still works, says so."""
    far = case["tmp"] / "far.csv"
    far.write_text(case["samples"].read_text() + "0.0,0.0,40.0,1.0\n")
    code, out, err = run(capsys, "reconstruct", case["mesh"], far, "-o", case["tmp"] / "o.npy", "--method",
                         "harmonic", "--max-snap", "100")
    assert code == 0, err
    assert err.strip() == ("manifill: note: --max-snap is now --max-distance (the library's max_distance); the old "
                           "name goes in the next release")
