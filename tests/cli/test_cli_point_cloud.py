"""``manifill reconstruct`` and ``manifill cv`` on point clouds: .xyz, .csv, and mesh files with no faces.

The values written equal the library's on the same points; the outputs hold the points (vertex cells) with
the fields; what a cloud cannot give (--subdivide, --clean, a format without points) ends in one line, exit 2,
before the work.
"""

import meshio
import numpy as np
import pytest

import manifill
from conftest import assert_usage_error, files, run
from manifill.io import read_mesh_file, write_mesh
from manifill.mesh.shapes import icosphere

V, _ = icosphere(3)
IDX = np.arange(0, len(V), 9)


def temp(P):
    return np.sin(3 * P[:, 0]) + P[:, 1]


@pytest.fixture(scope="module")
def cloud(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cloud")
    (folder / "c.xyz").write_text("# a scan\n" + "".join(f"{a!r} {b!r} {c!r} 0 0 1\n" for a, b, c in V.tolist()))
    (folder / "c.csv").write_text("z,x,y\n" + "".join(f"{c!r},{a!r},{b!r}\n" for a, b, c in V.tolist()))
    meshio.write(folder / "c.ply", meshio.Mesh(V, []), binary=True)
    write_mesh(folder / "c.vtp", V, None)
    t = temp(V[IDX]).tolist()
    (folder / "s.csv").write_text("vertex,temp\n" + "".join(f"{i},{v!r}\n" for i, v in zip(IDX, t)))
    (folder / "p.csv").write_text("x,y,z,temp\n" + "".join(
        f"{a * 1.01!r},{b!r},{c!r},{v!r}\n" for (a, b, c), v in zip(V[IDX].tolist(), t)))
    return folder


@pytest.mark.parametrize("name", ["c.xyz", "c.csv", "c.ply", "c.vtp"])
def test_every_point_file_reconstructs_as_the_library_does(tmp_path, capsys, cloud, name):
    out = tmp_path / "o.vtu"
    code, text, err = run(capsys, "reconstruct", cloud / name, cloud / "s.csv", "-o", out, "--method",
                          "biharmonic", "--gradient")
    assert code == 0, err
    assert "point cloud: 642 points" in text and "local Delaunay neighbours among the 16 nearest" in text
    m = meshio.read(out)
    assert [c.type for c in m.cells] == ["vertex"] and len(m.points) == len(V)
    r = manifill.reconstruct(V, None, IDX, temp(V[IDX]), method="biharmonic")
    assert np.allclose(m.point_data["temp"], r.values, atol=1e-12)
    assert np.allclose(m.point_data["grad_temp"], r.gradient(), atol=1e-10)


@pytest.mark.parametrize("suffix", [".vtp", ".vtk", ".ply", ".csv"])
def test_every_point_output_reads_back(tmp_path, capsys, cloud, suffix):
    out = tmp_path / f"o{suffix}"
    code, _, err = run(capsys, "reconstruct", cloud / "c.xyz", cloud / "p.csv", "-o", out, "--method", "gp")
    assert code == 0, err
    if suffix == ".csv":
        head = out.read_text().splitlines()[0]
        assert head.split(",")[-2:] == ["temp", "temp_std"]
        return
    back = read_mesh_file(out, points=True)
    assert back.F is None and back.V.shape == V.shape
    assert "temp" in back.point_data and "temp_std" in back.point_data


def test_a_time_series_on_a_cloud(tmp_path, capsys, cloud):
    steps = np.array([temp(V[IDX]) * k for k in (1.0, 2.0, 3.0)]).T
    src = tmp_path / "ts.csv"
    rows = zip(IDX, steps.tolist())
    src.write_text("vertex,t0,t1,t2\n" + "".join(f"{i},{a!r},{b!r},{c!r}\n" for i, (a, b, c) in rows))
    out = tmp_path / "ts.xdmf"
    code, _, err = run(capsys, "reconstruct", cloud / "c.xyz", src, "-o", out, "--method", "harmonic")
    assert code == 0, err
    with meshio.xdmf.TimeSeriesReader(out) as reader:
        points, cells = reader.read_points_cells()
        assert [c.type for c in cells] == ["vertex"] and len(points) == len(V)
        _, data, _ = reader.read_data(2)
    r = manifill.reconstruct(V, None, IDX, steps[:, 2], method="harmonic")
    assert np.allclose(data["value"], r.values, atol=1e-10)


def test_cv_on_a_cloud(capsys, cloud):
    code, text, err = run(capsys, "cv", cloud / "c.ply", cloud / "s.csv", "--methods", "harmonic,biharmonic",
                          "--folds", "4", "--neighbours", "20")
    assert code == 0, err
    assert "point cloud" in text and "biharmonic" in text


@pytest.mark.parametrize("extra, word", [
    (["-o", "{tmp}/o.off"], "-o writes .vtu, .vtp, .vtk, .ply, .csv"),
    (["-o", "{tmp}/o.vtu", "--subdivide", "1"], "--subdivide"),
    (["-o", "{tmp}/o.vtu", "--clean"], "--clean"),
    (["-o", "{tmp}/o.vtu", "--neighbours", "3"], "neighbours=3"),
])
def test_what_a_cloud_cannot_do_is_one_line_before_the_work(tmp_path, capsys, cloud, extra, word):
    args = [a.replace("{tmp}", str(tmp_path)) for a in extra]
    before = files(tmp_path)
    code, out, err = run(capsys, "reconstruct", cloud / "c.xyz", cloud / "s.csv", *args)
    line = assert_usage_error(code, out, err)
    assert word in line
    assert files(tmp_path) == before


@pytest.mark.parametrize("text, word", [
    ("0 0\n1 0 0\n", "line 1 holds 2 value(s)"),
    ("0 0 0\n1 zero 0\n", "line 2: 'zero' is not a number"),
    ("# nothing\n", "no points"),
    ("0 0 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n2 0 0\n0 2 0\n2 2 0\n", "coincide"),
])
def test_damaged_point_files_name_the_line(tmp_path, capsys, cloud, text, word):
    bad = tmp_path / "bad.xyz"
    bad.write_text(text)
    (tmp_path / "one.csv").write_text("vertex,temp\n0,1.0\n")
    code, out, err = run(capsys, "reconstruct", bad, tmp_path / "one.csv", "-o", tmp_path / "o.vtu")
    assert word in assert_usage_error(code, out, err)


def test_a_mesh_command_names_the_point_cloud(tmp_path, capsys, cloud):
    code, out, err = run(capsys, "harmonic", cloud / "c.ply", cloud / "s.csv", "-o", tmp_path / "o.vtu")
    assert "takes its 642 points as a point cloud" in assert_usage_error(code, out, err)
