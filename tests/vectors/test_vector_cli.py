"""The command line with arrows: ``manifill reconstruct MESH ARROWS -o OUT`` runs the vector fill when the samples have
the columns vx, vy, vz (the library's numbers, written as vectors), ``manifill globe`` writes the wind's eastward and
northward components; what a vector field cannot take ends in one line, exit 2, nothing written."""

import numpy as np
import pytest

from conftest import assert_usage_error, files, icosphere, run
from manifill import reconstruct_vectors
from manifill.io import write_mesh


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    d = tmp_path_factory.mktemp("arrows")
    V, F = icosphere(3)
    write_mesh(d / "m.ply", V, F)
    idx = np.arange(0, len(V), 23)
    X = np.cross(V[idx], [0.0, 0.0, 1.0]) + 0.3 * np.cross(V[idx], [1.0, 0.0, 0.0])
    lines = "".join(f"{i},{a!r},{b!r},{c!r}\n" for i, (a, b, c) in zip(idx, X.tolist()))
    (d / "a.csv").write_text("vertex,vx,vy,vz\n" + lines)
    (d / "two.csv").write_text("vertex,vx,vy\n" + "".join(f"{i},{a!r},{b!r}\n" for i, (a, b, _) in
                                                            zip(idx, X.tolist())))
    (d / "s.csv").write_text("vertex,t\n" + "".join(f"{i},{float(V[i, 0])!r}\n" for i in idx))
    return dict(d=d, V=V, F=F, idx=idx, X=X)


def test_arrows_make_a_tangent_vector_field_in_a_vtk_file(case, tmp_path, capsys):
    pv = pytest.importorskip("pyvista")
    d = case["d"]
    code, out, err = run(capsys, "reconstruct", d / "m.ply", d / "a.csv", "-o", tmp_path / "o.vtp")
    assert code == 0, err
    assert "tangent vector field of arrows" in out and "biharmonic energy of the connection" in out
    assert f"{len(case['idx'])} arrows" in out and "singularities: 2 (indices sum to 2)" in out  # a sphere's: chi = 2
    want = reconstruct_vectors(case["V"], case["F"], case["idx"], case["X"])
    mesh = pv.read(tmp_path / "o.vtp")
    assert mesh.point_data["v"].shape == (len(case["V"]), 3) and np.allclose(mesh.point_data["v"], want.values)
    assert np.allclose(mesh.cell_data["v"], want.faces) and mesh.active_vectors_name == "v"


def test_symmetry_and_method_reach_the_library_and_csv_holds_the_components(case, tmp_path, capsys):
    d = case["d"]
    code, out, err = run(capsys, "reconstruct", d / "m.ply", d / "a.csv", "-o", tmp_path / "o.csv", "--symmetry",
                         "2", "--method", "harmonic", "--bounds", "none")
    assert code == 0, err
    assert "of lines (no sign)" in out and "harmonic energy" in out
    want = reconstruct_vectors(case["V"], case["F"], case["idx"], case["X"], symmetry=2, method="harmonic",
                               bounds=False)
    table = np.loadtxt(tmp_path / "o.csv", delimiter=",", skiprows=1)
    head = (tmp_path / "o.csv").read_text().splitlines()[0]
    assert head == "vertex,v_x,v_y,v_z,v_magnitude" and np.allclose(table[:, 1:4], want.values)


def test_render_and_viewer_of_arrows(case, tmp_path, capsys):
    pytest.importorskip("pyvista")
    from manifill.viz.viewer import embedded_arrays

    d = case["d"]
    code, out, err = run(capsys, "reconstruct", d / "m.ply", d / "a.csv", "-o", tmp_path / "o.vtu", "--render",
                         tmp_path / "o.png", "--html", tmp_path / "o.html")
    assert code == 0, err
    assert "rendered" in out and (tmp_path / "o.png").stat().st_size > 10_000
    a = embedded_arrays(tmp_path / "o.html")
    assert len(a["arrows"]) >= 3 * len(case["V"]) // 2 and list(a["fields"]) == ["v_magnitude"]


@pytest.mark.parametrize("extra, says", [
    (["--symmetry", "3"], "--symmetry: invalid choice: 3"),
    (["--fit", "curl"], "--fit: invalid choice"),
    (["--method", "rbf"], "--method rbf is a method of scalar fields; arrows take --method biharmonic"),
    (["--weights", "uniform"], "--weights is an option of scalar fields"),
    (["--gradient"], "--gradient is an option of scalar fields"),
    (["--bounds", "0,1"], "--bounds '0,1': arrows take 'samples'"),
    (["--gp-range", "0.3"], "--gp-range is an option of --method gp"),
    (["--method", "gp", "--noise", "auto"], "--noise auto is not fitted for arrows"),
    (["--field", "t"], "not one of the vector fields (v, v_magnitude)"),
])
def test_what_arrows_cannot_take_is_one_line(case, tmp_path, capsys, extra, says):
    d = case["d"]
    code, out, err = run(capsys, "reconstruct", d / "m.ply", d / "a.csv", "-o", tmp_path / "o.vtu", *extra)
    assert says in assert_usage_error(code, out, err)
    assert files(tmp_path) == []


@pytest.mark.parametrize("samples, out, extra, says", [
    ("two.csv", "o.vtu", [], "two.csv: columns vx, vy but no vz; add the vz column"),
    ("a.csv", "o.xdmf", [], "a vector field is written as .vtu, .vtp, .vtk, .ply, .csv, .npy"),
    ("s.csv", "o.vtu", ["--symmetry", "2"], "--symmetry is an option of arrows"),
])
def test_bad_arrows_outputs_and_flags_for_values_are_one_line(case, tmp_path, capsys, samples, out, extra, says):
    d = case["d"]
    code, text, err = run(capsys, "reconstruct", d / "m.ply", d / samples, "-o", tmp_path / out, *extra)
    assert says in assert_usage_error(code, text, err)
    assert files(tmp_path) == []


def test_fits_and_the_gp_from_the_command_line(case, tmp_path, capsys):
    pv = pytest.importorskip("pyvista")
    d = case["d"]
    code, out, err = run(capsys, "reconstruct", d / "m.ply", d / "a.csv", "-o", tmp_path / "f.vtu", "--fit",
                         "divergence-free")
    assert code == 0, err
    want = reconstruct_vectors(case["V"], case["F"], case["idx"], case["X"], fit="divergence-free")
    assert "fitted divergence-free" in out and np.allclose(pv.read(tmp_path / "f.vtu").point_data["v"], want.values)
    code, out, err = run(capsys, "reconstruct", d / "m.ply", d / "a.csv", "-o", tmp_path / "g.vtu", "--method", "gp",
                         "--gp-range", "0.8")
    assert code == 0, err
    want = reconstruct_vectors(case["V"], case["F"], case["idx"], case["X"], method="gp", gp={"range": 0.8})
    mesh = pv.read(tmp_path / "g.vtu")
    assert "Matérn field" in out and np.allclose(mesh.point_data["v_std"], want.std)


def test_the_globe_writes_the_wind_s_components(tmp_path, capsys):
    pd = pytest.importorskip("pandas")
    xr = pytest.importorskip("xarray")
    pytest.importorskip("netCDF4")
    from manifill.adapters.globe_vectors import reconstruct_globe_vectors

    rng = np.random.default_rng(1)
    lon, lat = rng.uniform(-180, 180, 200), np.degrees(np.arcsin(rng.uniform(-1, 1, 200)))
    df = pd.DataFrame({"lon": lon, "lat": lat, "name": [f"s{i}" for i in range(200)],
                       "u": np.cos(np.radians(lat)), "v": 0.0})
    df.to_csv(tmp_path / "st.csv", index=False)
    code, out, err = run(capsys, "globe", tmp_path / "st.csv", "-o", tmp_path / "w.nc", "--grid", "10")
    assert code == 0, err
    assert "eastward_wind and northward_wind (a tangent vector field)" in out
    back = xr.open_dataset(tmp_path / "w.nc")
    want = reconstruct_globe_vectors(df.drop(columns="name"), grid=10.0)
    assert back["eastward_wind"].attrs["standard_name"] == "eastward_wind"
    assert np.allclose(back["eastward_wind"].values, want["eastward_wind"].values)
    assert np.allclose(back["northward_wind"].values, want["northward_wind"].values)
    from manifill.adapters.globe import xyz_to_lonlat

    lon12, lat12 = xyz_to_lonlat(icosphere(0)[0])  # twelve stations far apart: a coarse sphere holds them
    pd.DataFrame({"lon": lon12, "lat": lat12, "u": np.cos(np.radians(lat12)), "v": 0.0}).to_csv(tmp_path / "12.csv",
                                                                                               index=False)
    code, out, err = run(capsys, "globe", tmp_path / "12.csv", "-o", tmp_path / "t.nc", "--grid", "60", "--var", "u")
    assert code == 0, err  # --var: the scalar globe, as before
    assert list(xr.open_dataset(tmp_path / "t.nc").data_vars) == ["u"]
