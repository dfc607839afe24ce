"""``manifill reconstruct MESH SAMPLES -o OUT.xdmf|.pvd|.h5|.npy``: time series in, time series out, chunk by chunk."""

import meshio
import numpy as np
import pytest

import manifill
from conftest import assert_usage_error, files, run
from manifill.io import write_mesh
from manifill.io.series import read_series_values
from manifill.mesh.shapes import icosphere

V, F = icosphere(3)
IDX = np.random.default_rng(2).choice(len(V), 25, replace=False)
T = 13
TIMES = np.linspace(0.0, 3.0, T)
VALS = np.sin(3 * V[IDX, 0][:, None] + TIMES) + V[IDX, 2][:, None] * TIMES


@pytest.fixture
def case(tmp_path):
    mesh = tmp_path / "sphere.ply"
    write_mesh(mesh, V, F)
    npz = tmp_path / "series.npz"
    np.savez(npz, idx=IDX, vals=VALS, times=TIMES)
    return mesh, npz


def expected(**opts):
    return manifill.Reconstructor(V, F, IDX, **opts).apply(VALS).values


@pytest.mark.parametrize("suffix", [".xdmf", ".pvd", ".h5", ".npy"])
def test_a_series_is_written_step_by_step_and_reads_back(tmp_path, capsys, case, suffix):
    mesh, npz = case
    out = tmp_path / f"out{suffix}"
    code, text, err = run(capsys, "reconstruct", mesh, npz, "-o", out, "--method", "harmonic", "--chunk", "4")
    assert code == 0, err
    assert f"{T:,} time steps" in text and "in 4 chunk(s) of 4" in text
    times, X = read_series_values(out)
    assert X.shape == (len(V), T)
    if suffix != ".npy":
        assert np.array_equal(times, TIMES)
    want = expected(method="harmonic")
    assert np.abs(X - want).max() <= 1e-12 * np.abs(VALS).max()
    # every column is the single-field reconstruction of its time step
    one = manifill.reconstruct(V, F, IDX, VALS[:, 5], method="harmonic").values
    assert np.abs(X[:, 5] - one).max() <= 1e-12 * np.abs(VALS).max()


def test_xdmf_and_pvd_open_in_meshio_and_pyvista(tmp_path, capsys, case):
    pv = pytest.importorskip("pyvista")
    mesh, npz = case
    run(capsys, "reconstruct", mesh, npz, "-o", tmp_path / "a.xdmf", "--quiet")
    run(capsys, "reconstruct", mesh, npz, "-o", tmp_path / "a.pvd", "--quiet")
    want = expected()
    with meshio.xdmf.TimeSeriesReader(str(tmp_path / "a.xdmf")) as r:
        points, _ = r.read_points_cells()
        assert r.num_steps == T and np.allclose(points, V)
        t, pd, _ = r.read_data(7)
        assert t == pytest.approx(TIMES[7])
        assert np.abs(pd["value"].ravel() - want[:, 7]).max() <= 1e-12 * 3
        assert pd["sample_mask"].astype(bool).sum() == IDX.size
    reader = pv.get_reader(str(tmp_path / "a.pvd"))
    assert len(reader.time_values) == T
    reader.set_active_time_value(reader.time_values[7])
    block = reader.read()
    m = block[0] if hasattr(block, "n_blocks") else block
    assert np.abs(np.asarray(m.point_data["value"]) - want[:, 7]).max() <= 1e-12 * 3


def test_chunked_output_equals_one_shot(tmp_path, capsys, case):
    mesh, npz = case
    outs = []
    for chunk in ("1", "5", str(T)):
        out = tmp_path / f"c{chunk}.h5"
        assert run(capsys, "reconstruct", mesh, npz, "-o", out, "--chunk", chunk, "--quiet")[0] == 0
        outs.append(read_series_values(out)[1])
    assert np.array_equal(outs[0], outs[2]) or np.abs(outs[0] - outs[2]).max() <= 1e-13
    assert np.abs(outs[1] - outs[2]).max() <= 1e-13


def test_long_csv_and_per_time_files(tmp_path, capsys, case):
    mesh, _ = case
    rows = [f"{i},{float(t)!r},{float(v)!r}" for j, t in enumerate(TIMES) for i, v in zip(IDX, VALS[:, j])]
    rows = [rows[k] for k in np.random.default_rng(0).permutation(len(rows))]
    long = tmp_path / "long.csv"
    long.write_text("vertex,time,temp\n" + "\n".join(rows) + "\n")
    folder = tmp_path / "steps"
    folder.mkdir()
    for j in range(T):
        (folder / f"temp_{j:03d}.csv").write_text(
            "vertex,temp\n" + "".join(f"{i},{float(v)!r}\n" for i, v in zip(IDX, VALS[:, j])))
    want = expected(method="harmonic")
    for src, out in ((long, "long.xdmf"), (folder, "files.npy"), (str(folder / "temp_*.csv"), "glob.pvd")):
        code, text, err = run(capsys, "reconstruct", mesh, src, "-o", tmp_path / out, "--method", "harmonic",
                              "--quiet")
        assert code == 0, err
        X = read_series_values(tmp_path / out)[1]
        assert np.abs(X - want).max() <= 1e-12 * 3, out


def test_a_failure_mid_series_leaves_nothing(tmp_path, capsys, case):
    mesh, _ = case
    bad = VALS.copy()
    bad[3, 9] = np.inf  # found only when the third chunk is reconstructed
    npz = tmp_path / "bad.npz"
    np.savez(npz, idx=IDX, vals=bad, times=TIMES)
    before = files(tmp_path)
    for out in ("x.xdmf", "x.pvd", "x.h5"):
        code, text, err = run(capsys, "reconstruct", mesh, npz, "-o", tmp_path / out, "--chunk", "4", "--quiet")
        line = assert_usage_error(code, text, err)
        assert "finite" in line or "inf" in line.lower()
        assert files(tmp_path) == before


def test_series_errors_are_one_line(tmp_path, capsys, case):
    mesh, npz = case
    long = tmp_path / "long.csv"
    long.write_text("vertex,time,temp\n0,0,1\n0,1,2\n5,0,3\n")  # sample 5 has no value at time 1
    for argv in ((long, "-o", tmp_path / "o.xdmf"),
                 (long, "-o", tmp_path / "o.vtu"),  # a series into one mesh file
                 (npz, "-o", tmp_path / "o.xdmf", "--chunk", "0"),
                 (npz, "-o", tmp_path / "o.xdmf", "--render", tmp_path / "o.png"),
                 (npz, "-o", tmp_path / "o.xdmf", "--uncertainty", "--method", "harmonic")):
        code, text, err = run(capsys, "reconstruct", mesh, *argv)
        assert_usage_error(code, text, err)
    assert not list(tmp_path.glob("o.*"))


def test_the_run_says_where_its_times_came_from_and_how_far_it_snapped(tmp_path, capsys, case):
    # numeric column names of a wide CSV became times silently; a series never reported its snapping distance
    mesh, npz = case
    code, text, err = run(capsys, "reconstruct", mesh, npz, "-o", tmp_path / "a.npy", "--method", "harmonic")
    assert code == 0, err
    assert "times from the file's 'times'" in text
    wide = tmp_path / "wide.csv"
    P = V[IDX] * 1.001  # positions just off the vertices
    header = "x,y,z," + ",".join(f"{t:g}" for t in TIMES)
    np.savetxt(wide, np.column_stack([P, VALS]), delimiter=",", header=header, comments="")
    code, text, err = run(capsys, "reconstruct", mesh, wide, "-o", tmp_path / "b.h5", "--method", "harmonic")
    assert code == 0, err
    assert "times from the value columns' names" in text
    assert "positions kept where they are (located on the surface); largest distance to a vertex" in text
    code, text, err = run(capsys, "reconstruct", mesh, wide, "-o", tmp_path / "b2.h5", "--method",
                          "gvf-harmonic")  # the pipeline snaps
    assert code == 0, err
    assert "snapped positions to vertices: largest distance" in text
    (tmp_path / "named.csv").write_text("vertex,a,b\n" + "".join(f"{i},{i},{2 * i}\n" for i in IDX))
    code, text, err = run(capsys, "reconstruct", mesh, tmp_path / "named.csv", "-o", tmp_path / "c.h5",
                          "--method", "harmonic")
    assert code == 0, err
    assert "times from the step numbers" in text
