"""``--gradient``: each field's gradient and its magnitude beside it, the library's numbers, in every output kind.

VTK files hold ``grad_<field>`` as one 3-vector per point; value files and PLY hold ``grad_<field>_x``, ``_y``,
``_z``; all hold ``grad_<field>_norm``. A linear field's gradient is its slope where the mesh is flat; what cannot
be done (a time series, a subdivided output, a field already named like a gradient) ends in one line, exit 2.
"""

import csv

import meshio
import numpy as np
import pytest

import manifill
from conftest import assert_usage_error, files, grid, run
from manifill.io import write_mesh
from manifill.io.solids import read_vti
from manifill.mesh.shapes import icosphere
from solid.solids import needs_tetgen


@pytest.fixture(scope="module")
def flat(tmp_path_factory):
    """A flat 9 x 9 grid (PLY) with 12 samples of the linear t = 2 x - 3 y + 1 and of u = t^2 (CSV)."""
    folder = tmp_path_factory.mktemp("grad")
    V, F = grid(9)
    path = folder / "flat.ply"
    write_mesh(path, V, F)
    idx = np.arange(0, len(V), 7)
    t = 2 * V[idx, 0] - 3 * V[idx, 1] + 1
    two = folder / "tu.csv"
    two.write_text("vertex,t,u\n" + "".join(f"{i},{float(a)!r},{float(a * a)!r}\n" for i, a in zip(idx, t)))
    return dict(path=path, V=V, F=F, idx=idx, t=t, two=two, folder=folder)


def test_vtk_output_holds_the_gradient_vector_and_its_magnitude(tmp_path, capsys, flat):
    out = tmp_path / "g.vtu"
    code, text, err = run(capsys, "reconstruct", flat["path"], flat["two"], "-o", out, "--method", "rbf",
                          "--gradient")
    assert code == 0, err
    data = meshio.read(out).point_data
    r = manifill.reconstruct(flat["V"], flat["F"], flat["idx"], np.column_stack([flat["t"], flat["t"] ** 2]),
                             method="rbf")
    G = r.gradient()
    for j, name in enumerate(("t", "u")):
        assert data[f"grad_{name}"].shape == (len(flat["V"]), 3)
        np.testing.assert_allclose(data[f"grad_{name}"], G[:, j], rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(data[f"grad_{name}_norm"], np.linalg.norm(G[:, j], axis=1), rtol=1e-10)
    # the thin-plate spline reproduces a linear field: its gradient is the slope everywhere
    assert np.abs(data["grad_t"] - [2.0, -3.0, 0.0]).max() < 1e-8


@pytest.mark.parametrize("suffix", [".csv", ".ply"])
def test_other_outputs_hold_one_column_per_component(tmp_path, capsys, flat, suffix):
    out = tmp_path / f"g{suffix}"
    code, _, err = run(capsys, "reconstruct", flat["path"], flat["two"], "-o", out, "--method", "harmonic",
                       "--gradient")
    assert code == 0, err
    if suffix == ".csv":
        with open(out) as fh:
            rows = list(csv.DictReader(fh))
        cols = {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}
    else:
        cols = meshio.read(out).point_data
    g = np.column_stack([cols[f"grad_u_{c}"] for c in "xyz"])
    want = manifill.reconstruct(flat["V"], flat["F"], flat["idx"], flat["t"] ** 2, method="harmonic").gradient()
    np.testing.assert_allclose(g, want, rtol=1e-9, atol=1e-9)  # each column its own component
    np.testing.assert_allclose(cols["grad_u_norm"], np.linalg.norm(want, axis=1), rtol=1e-9)
    assert "grad_u" not in cols and np.abs(g[:, 2]).max() < 1e-12  # flat: no z component


@needs_tetgen
def test_a_volume_writes_the_gradient_per_voxel_and_per_tet_vertex(tmp_path, capsys):
    V, F = icosphere(3)
    mesh = tmp_path / "ball.ply"
    write_mesh(mesh, V, F)
    idx = np.arange(0, len(V), 5)
    samples = tmp_path / "s.csv"
    samples.write_text("vertex,t\n" + "".join(f"{i},{float(V[i] @ [1.0, 2.0, -1.0])!r}\n" for i in idx))
    for form, out, more in (("voxels", tmp_path / "v.vti", ["--resolution", "16"]), ("tets", tmp_path / "t.vtu", [])):
        code, _, err = run(capsys, "volume", mesh, samples, "-o", out, "--form", form, *more, "--gradient")
        assert code == 0, err
        data = read_vti(out)[0] if form == "voxels" else meshio.read(out).point_data
        g = np.asarray(data["grad_t"]).reshape(-1, 3)
        ok = np.isfinite(g).all(axis=1)
        inside = np.isfinite(np.asarray(data["t"]).ravel())
        assert not ok[~inside].any() and ok.sum() > 0.95 * inside.sum()  # NaN outside, a gradient inside
        # a linear field filled harmonically stays near linear inside: the slope (1, 2, -1), median over points
        assert np.abs(np.median(g[ok], axis=0) - [1.0, 2.0, -1.0]).max() < 0.15


def test_what_cannot_take_a_gradient_ends_in_one_line(tmp_path, capsys, flat):
    before = files(tmp_path)
    code, out, err = run(capsys, "reconstruct", flat["path"], flat["two"], "-o", tmp_path / "s.vtu", "--gradient",
                         "--subdivide", "1")
    assert "--gradient and --subdivide" in assert_usage_error(code, out, err)
    named = tmp_path / "named.csv"
    named.write_text("vertex,t,grad_t_norm\n0,1.0,2.0\n7,2.0,3.0\n14,0.5,1.0\n")
    code, out, err = run(capsys, "reconstruct", flat["path"], named, "-o", tmp_path / "n.vtu", "--gradient")
    assert "'grad_t_norm' is also the name of a field this run adds" in assert_usage_error(code, out, err)
    assert files(tmp_path) == sorted(before + ["named.csv"])


def test_a_time_series_output_takes_no_gradient(tmp_path, capsys, flat):
    code, out, err = run(capsys, "reconstruct", flat["path"], flat["two"], "-o", tmp_path / "s.xdmf", "--gradient")
    line = assert_usage_error(code, out, err)
    assert "-o s.xdmf writes a time series" in line and not (tmp_path / "s.xdmf").exists()


def test_a_method_whose_gradient_jumps_says_so(tmp_path, capsys, flat):
    code, out, err = run(capsys, "reconstruct", flat["path"], flat["two"], "-o", tmp_path / "d.vtu", "--gradient",
                         "--method", "gvf-harmonic")
    assert code == 0, err
    assert "gives a field with kinks at its samples and curves, so its gradient jumps there" in out
    code, out, err = run(capsys, "reconstruct", flat["path"], flat["two"], "-o", tmp_path / "b.vtu", "--gradient",
                         "--method", "biharmonic")
    assert code == 0 and "kinks" not in out
