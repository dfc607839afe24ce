"""Fields in time: samples read in three layouts, (n, T) values streamed to four formats and read back.

Every format round-trips values and times exactly; the XDMF and PVD outputs are opened by
meshio and pyvista; writing in chunks gives the same files as writing at once; a failure
mid-series leaves the final path as it was and no temporary behind.
"""

import sys

import meshio
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from manifill.errors import ReadError, SampleError, WriteError
from manifill.io import (SERIES_FORMATS, SeriesWriter, read_samples, read_series, read_series_values,
                         write_series)
from manifill.mesh.shapes import icosphere

pv = pytest.importorskip("pyvista")
pytest.importorskip("h5py")

FORMATS = sorted(SERIES_FORMATS)
V, F = icosphere(2)
N = len(V)


def series(T=9, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(N, T))
    times = np.cumsum(rng.random(T) + 0.1) - 0.7  # not short decimals: exact only if stored exactly
    static = {"sample_mask": rng.random(N) < 0.2, "patch_label": rng.integers(-1, 5, N)}
    return X, times, static


def static_for(ext, static):
    return static if SERIES_FORMATS[ext].static else None


def listing(folder):
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*"))


def contents(folder):
    """Every file under ``folder``: relative name -> bytes."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


# --- writing and reading back -------------------------------------------------------------------------------------


@pytest.mark.parametrize("ext", FORMATS)
def test_every_format_round_trips_values_and_times_exactly(tmp_path, ext):
    X, times, static = series()
    path = tmp_path / f"temp{ext}"
    write_series(path, V, F, X, times, names="temp", static=static_for(ext, static))
    t, got = read_series_values(path)
    assert got.shape == X.shape
    if SERIES_FORMATS[ext].exact:
        np.testing.assert_array_equal(got, X)
    else:  # GIfTI keeps float32 (what Workbench reads)
        np.testing.assert_allclose(got, X, rtol=2e-7 * 4, atol=0)
    want = times if SERIES_FORMATS[ext].times else np.arange(X.shape[1])
    np.testing.assert_array_equal(t, want)
    names = {".xdmf": ["temp.h5", "temp.xdmf"], ".pvd": ["temp", *(f"temp/temp_{j:06d}.vtu" for j in range(9)),
                                                        "temp.pvd"]}
    assert listing(tmp_path) == sorted(names.get(ext, [path.name]))


def test_npy_is_numpys_own_file_of_the_array(tmp_path):
    X, times, _ = series()
    write_series(tmp_path / "a.npy", V, None, X, times)
    np.save(tmp_path / "b.npy", np.asfortranarray(X))
    assert (tmp_path / "a.npy").read_bytes() == (tmp_path / "b.npy").read_bytes()


def test_h5_holds_the_field_times_and_static_fields(tmp_path):
    import h5py

    X, times, static = series()
    write_series(tmp_path / "out.h5", V, None, X, times, names="temp", static=static)
    with h5py.File(tmp_path / "out.h5", "r") as f:
        assert f.attrs["field"] == "temp"
        np.testing.assert_array_equal(f["temp"][()], X)
        np.testing.assert_array_equal(f["times"][()], times)
        np.testing.assert_array_equal(f["sample_mask"][()], static["sample_mask"])
        np.testing.assert_array_equal(f["patch_label"][()], static["patch_label"])


def test_xdmf_is_read_by_meshio_with_the_mesh_the_steps_and_the_static_fields(tmp_path):
    X, times, static = series()
    path = tmp_path / "temp.xdmf"
    write_series(path, V, F, X, times, names="temp", static=static)
    with meshio.xdmf.TimeSeriesReader(path) as r:
        points, cells = r.read_points_cells()
        np.testing.assert_array_equal(points, V)
        assert [c.type for c in cells] == ["triangle"]
        np.testing.assert_array_equal(cells[0].data, F)
        assert r.num_steps == X.shape[1]
        for k in range(r.num_steps):
            t, pd, _ = r.read_data(k)
            assert t == times[k]
            assert list(pd) == ["temp", "sample_mask", "patch_label"]
            np.testing.assert_array_equal(pd["temp"], X[:, k])
            np.testing.assert_array_equal(pd["sample_mask"], static["sample_mask"])
            np.testing.assert_array_equal(pd["patch_label"], static["patch_label"])


def test_xdmf_is_read_by_pyvista_one_mesh_per_time_step(tmp_path):
    X, times, static = series()
    path = tmp_path / "temp.xdmf"
    write_series(path, V, F, X, times, names="temp", static=static)
    reader = pv.get_reader(str(path))
    assert reader.time_values == times.tolist()
    for k, t in enumerate(reader.time_values):
        reader.set_active_time_value(t)
        mesh = reader.read()
        assert mesh.n_points == N and mesh.n_cells == len(F)
        np.testing.assert_array_equal(mesh.points, V)
        np.testing.assert_array_equal(mesh.point_data["temp"], X[:, k])
        np.testing.assert_array_equal(mesh.point_data["sample_mask"], static["sample_mask"])
        assert mesh.point_data["sample_mask"].dtype == np.uint8  # masks as bytes (UChar), not VTK's uint32 (UInt)
    first = pv.read(str(path))
    np.testing.assert_array_equal(first.point_data["temp"], X[:, 0])


def test_pvd_is_read_by_pyvista_and_each_step_by_meshio(tmp_path):
    X, times, static = series()
    path = tmp_path / "temp.pvd"
    write_series(path, V, F, X, times, names="temp", static=static)
    reader = pv.PVDReader(str(path))
    assert reader.time_values == times.tolist()
    for k, t in enumerate(reader.time_values):
        reader.set_active_time_value(t)
        mesh = reader.read()[0]
        np.testing.assert_array_equal(mesh.points, V)
        np.testing.assert_array_equal(mesh.point_data["temp"], X[:, k])
        np.testing.assert_array_equal(mesh.point_data["patch_label"], static["patch_label"])
        step = meshio.read(tmp_path / "temp" / f"temp_{k:06d}.vtu")
        np.testing.assert_array_equal(step.point_data["temp"], X[:, k])
        np.testing.assert_array_equal(step.cells_dict["triangle"], F)


@pytest.mark.parametrize("ext", FORMATS)
@pytest.mark.parametrize("chunk", [1, 3, 7])
def test_chunks_of_columns_give_the_same_files_as_one_write(tmp_path, ext, chunk):
    X, times, static = series(T=10)
    (tmp_path / "one").mkdir()
    (tmp_path / "chunks").mkdir()
    write_series(tmp_path / "one" / f"s{ext}", V, F, X, times, names="u", static=static_for(ext, static))
    with SeriesWriter(tmp_path / "chunks" / f"s{ext}", V, F, names="u", static=static_for(ext, static),
                      steps=X.shape[1]) as w:
        for j in range(0, X.shape[1], chunk):
            w.write(X[:, j:j + chunk], times[j:j + chunk])
    one, chunks = contents(tmp_path / "one"), contents(tmp_path / "chunks")
    assert sorted(one) == sorted(chunks)
    assert one == chunks  # byte for byte


@pytest.mark.parametrize("ext", [".xdmf", ".pvd"])
def test_the_number_of_steps_need_not_be_known_for_xdmf_and_pvd(tmp_path, ext):
    X, _, _ = series(T=5)
    with SeriesWriter(tmp_path / f"s{ext}", V, F) as w:
        for j in range(5):
            w.write(X[:, j])  # one step at a time, times 0, 1, ...
    t, got = read_series_values(tmp_path / f"s{ext}")
    np.testing.assert_array_equal(t, np.arange(5.0))
    np.testing.assert_array_equal(got, X)


@pytest.mark.parametrize("ext", FORMATS)
@pytest.mark.parametrize("error", [RuntimeError, KeyboardInterrupt])
def test_a_failure_mid_series_leaves_the_old_output_and_no_temporary(tmp_path, ext, error):
    X, times, static = series(T=6)
    path = tmp_path / f"s{ext}"
    write_series(path, V, F, X[:, :2], times[:2], static=static_for(ext, static))  # an earlier run's output
    before = contents(tmp_path)
    with pytest.raises(error):
        with SeriesWriter(path, V, F, static=static_for(ext, static), steps=6) as w:
            w.write(X[:, :3], times[:3])
            raise error()
    assert contents(tmp_path) == before


@pytest.mark.parametrize("ext", FORMATS)
def test_writing_over_an_earlier_output_replaces_all_of_it(tmp_path, ext):
    X, times, _ = series(T=6)
    write_series(tmp_path / f"s{ext}", V, F, X, times)
    write_series(tmp_path / f"s{ext}", V, F, -X[:, :2], times[:2])
    t, got = read_series_values(tmp_path / f"s{ext}")
    np.testing.assert_allclose(got, -X[:, :2], rtol=0 if SERIES_FORMATS[ext].exact else 1e-6, atol=0)
    names = {".xdmf": ["s.h5", "s.xdmf"], ".pvd": ["s", "s/s_000000.vtu", "s/s_000001.vtu", "s.pvd"]}
    assert listing(tmp_path) == sorted(names.get(ext, [f"s{ext}"]))


@pytest.mark.parametrize("ext", FORMATS)
def test_a_failure_before_any_output_leaves_nothing(tmp_path, ext):
    X, times, _ = series(T=6)
    with pytest.raises(RuntimeError):
        with SeriesWriter(tmp_path / f"s{ext}", V, F, steps=6) as w:
            w.write(X[:, :1], times[:1])
            raise RuntimeError
    assert listing(tmp_path) == []


@pytest.mark.parametrize("ext", FORMATS)
def test_closing_with_too_few_steps_writes_nothing(tmp_path, ext):
    X, times, _ = series(T=6)
    with pytest.raises(WriteError, match="4 time steps written of steps=6"):
        with SeriesWriter(tmp_path / f"s{ext}", V, F, steps=6) as w:
            w.write(X[:, :4], times[:4])
    assert listing(tmp_path) == []


def test_writer_refusals(tmp_path):
    X, times, static = series(T=4)
    for ext in (".npy", ".h5"):
        with pytest.raises(WriteError, match="pass steps=T"):
            SeriesWriter(tmp_path / f"s{ext}", V, F)
    with pytest.raises(WriteError, match="holds the values alone"):
        SeriesWriter(tmp_path / "s.npy", V, F, static=static, steps=4)
    with pytest.raises(WriteError, match="cannot write '.vtu'"):
        SeriesWriter(tmp_path / "s.vtu", V, F)
    with pytest.raises(WriteError, match="mask"):
        SeriesWriter(tmp_path / "s.pvd", V, F, names="sample_mask")
    with pytest.raises(WriteError, match="'times' is taken"):
        SeriesWriter(tmp_path / "s.h5", V, F, names="times", steps=4)
    with SeriesWriter(tmp_path / "s.pvd", V, F) as w:
        w.write(X[:, :2], [0.0, 1.0])
        with pytest.raises(WriteError, match="time 1 comes after 1"):
            w.write(X[:, 2:], [1.0, 2.0])
        with pytest.raises(WriteError, match="shape"):
            w.write(X[:10], [5.0, 6.0])
        w.write(X[:, 2:], [2.0, 3.0])
    with pytest.raises(WriteError, match="5 time steps written for steps=4"):
        with SeriesWriter(tmp_path / "t.npy", V, F, steps=4) as w:
            w.write(np.column_stack([X, X[:, :1]]))
    (tmp_path / "u").mkdir()
    (tmp_path / "u" / "notes.txt").write_text("mine")
    with pytest.raises(WriteError, match="holds other files"):
        SeriesWriter(tmp_path / "u.pvd", V, F)
    assert listing(tmp_path) == sorted(["s", *(f"s/s_{j:06d}.vtu" for j in range(4)), "s.pvd", "u", "u/notes.txt"])


@pytest.mark.parametrize("ext", [".xdmf", ".h5"])
def test_without_h5py_the_error_names_the_extra_and_pvd(tmp_path, monkeypatch, ext):
    monkeypatch.setitem(sys.modules, "h5py", None)
    with pytest.raises(WriteError, match=r"\[series\] extra.*\.pvd"):
        SeriesWriter(tmp_path / f"s{ext}", V, F, steps=3)
    assert listing(tmp_path) == []


# --- reading samples in time --------------------------------------------------------------------------------------


def write_csv(path, header, rows):
    cell = lambda c: repr(c.item() if hasattr(c, "item") else c)  # noqa: E731
    path.write_text(header + "\n" + "".join(",".join(cell(c) for c in r) + "\n" for r in rows))
    return path


def test_wide_csv_reads_every_value_column_as_a_time_step(tmp_path):
    rows = [(7, 1.0, 2.0, 3.0), (2, 4.0, 5.0, 6.0)]
    s = read_series(write_csv(tmp_path / "w.csv", "vertex,a,b,c", rows), V)
    assert s.samples.idx.tolist() == [2, 7]
    np.testing.assert_array_equal(s.vals, [[4, 5, 6], [1, 2, 3]])
    np.testing.assert_array_equal(s.times, [0, 1, 2])
    assert s.samples.names == ["a", "b", "c"]
    S = read_samples(tmp_path / "w.csv", V)  # the same samples as read_samples gives
    np.testing.assert_array_equal(S.vals, s.vals)


def test_wide_csv_with_numbers_for_names_takes_them_as_times(tmp_path):
    s = read_series(write_csv(tmp_path / "w.csv", "vertex,2.5,0.5,1", [(3, 1.0, 2.0, 3.0)]), V)
    np.testing.assert_array_equal(s.times, [0.5, 1.0, 2.5])
    np.testing.assert_array_equal(s.vals, [[2.0, 3.0, 1.0]])


def test_npz_with_times_sorts_the_columns_by_time(tmp_path):
    np.savez(tmp_path / "s.npz", idx=[5, 1], vals=[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]], times=[3.0, 1.0, 2.0])
    s = read_series(tmp_path / "s.npz", V)
    np.testing.assert_array_equal(s.times, [1, 2, 3])
    np.testing.assert_array_equal(s.vals, [[5, 6, 4], [2, 3, 1]])
    np.savez(tmp_path / "bad.npz", idx=[5, 1], vals=np.zeros((2, 3)), times=[1.0, 2.0])
    with pytest.raises(SampleError, match="bad.npz: 'times' has 2 entries for 3 value columns"):
        read_series(tmp_path / "bad.npz", V)


def long_rows(X, times, idx):
    return [(int(v), float(t), float(X[i, j])) for i, v in enumerate(idx) for j, t in enumerate(times)]


@settings(max_examples=25, deadline=None)
@given(st.randoms(use_true_random=False))
def test_long_csv_in_any_row_order_pivots_to_the_same_series(tmp_path_factory, rnd):
    rng = np.random.default_rng(1)
    idx = rng.choice(N, 6, replace=False)
    times = np.array([0.25, 1.5, 3.0, 10.0])
    X = rng.normal(size=(6, 4))
    rows = long_rows(X, times, idx)
    rnd.shuffle(rows)
    path = write_csv(tmp_path_factory.mktemp("long") / "l.csv", "vertex,time,temp", rows)
    s = read_series(path, V)
    order = np.argsort(idx)
    assert s.samples.idx.tolist() == sorted(idx.tolist())
    np.testing.assert_array_equal(s.times, times)
    np.testing.assert_array_equal(s.vals, X[order])
    assert s.names == ["temp"]


def test_long_csv_of_positions(tmp_path):
    idx = np.array([4, 40, 100])
    rows = [(*V[v], t, 10.0 * i + t) for i, v in enumerate(idx) for t in (2.0, 1.0)]
    s = read_series(write_csv(tmp_path / "p.csv", "x,y,z,time,height", rows), V)
    assert s.samples.idx.tolist() == [4, 40, 100]
    np.testing.assert_array_equal(s.vals, [[1, 2], [11, 12], [21, 22]])
    np.testing.assert_array_equal(s.samples.snap_distance, 0)


def test_long_csv_missing_or_repeated_pair_is_refused_with_its_line(tmp_path):
    rows = long_rows(np.ones((2, 3)), [0.0, 1.0, 2.0], [3, 8])
    with pytest.raises(SampleError, match=r"l.csv: vertex 8 has no row at time 1 \(the file has 3 times\)"):
        read_series(write_csv(tmp_path / "l.csv", "vertex,time,temp", rows[:4] + rows[5:]), V)
    with pytest.raises(SampleError, match="d.csv: line 3 and line 8 both give vertex 3 at time 1; remove one"):
        read_series(write_csv(tmp_path / "d.csv", "vertex,time,temp", rows + [rows[1]]), V)
    with pytest.raises(ReadError, match="2 value columns"):
        read_series(write_csv(tmp_path / "two.csv", "vertex,time,a,b", [(1, 0.0, 1.0, 2.0)]), V)


def per_time(folder, names, rows_of, header="vertex,temp"):
    folder.mkdir(exist_ok=True)
    for name, rows in zip(names, rows_of):
        write_csv(folder / name, header, rows)
    return folder


def test_per_time_files_by_pattern_take_times_from_their_names(tmp_path):
    rng = np.random.default_rng(2)
    idx = [9, 1, 30]
    X = rng.normal(size=(3, 3))
    names = ["day_10.csv", "day_2.csv", "day_0.5.csv"]
    rows = [[(v, X[i, j]) for i, v in enumerate(idx)][::(1 if j % 2 else -1)] for j in range(3)]  # rows reordered
    per_time(tmp_path / "d", names, rows)
    (tmp_path / "d" / "notes.txt").write_text("not a sample file")
    for where in (tmp_path / "d" / "day_*.csv", tmp_path / "d"):
        s = read_series(where, V)
        np.testing.assert_array_equal(s.times, [0.5, 2.0, 10.0])
        assert [p.name for p in s.files] == ["day_0.5.csv", "day_2.csv", "day_10.csv"]
        assert s.samples.idx.tolist() == [1, 9, 30]
        np.testing.assert_array_equal(s.vals, X[[1, 0, 2]][:, [2, 1, 0]])
        assert s.names == ["temp"]


def test_per_time_files_without_numbers_are_taken_in_name_order(tmp_path):
    per_time(tmp_path / "d", ["b.csv", "a.csv", "c.csv"], [[(1, 2.0)], [(1, 1.0)], [(1, 3.0)]])
    s = read_series(tmp_path / "d", V)
    np.testing.assert_array_equal(s.times, [0, 1, 2])
    np.testing.assert_array_equal(s.vals, [[1, 2, 3]])


def test_per_time_files_that_differ_are_refused_naming_the_file(tmp_path):
    per_time(tmp_path / "a", ["s_1.csv", "s_2.csv"], [[(1, 1.0), (2, 1.0)], [(1, 1.0), (3, 1.0)]])
    with pytest.raises(SampleError, match="s_2.csv: vertex 2 of s_1.csv is not in it; every per-time file"):
        read_series(tmp_path / "a", V)
    per_time(tmp_path / "b", ["s_1.csv", "s_2.csv"], [[(1, 1.0)], [(1, 1.0), (3, 1.0)]])
    with pytest.raises(SampleError, match="s_2.csv: vertex 3 is not in s_1.csv"):
        read_series(tmp_path / "b" / "s_*.csv", V)
    per_time(tmp_path / "c", ["s_1.csv"], [[(1, 1.0)]])
    write_csv(tmp_path / "c" / "s_2.csv", "vertex,humidity", [(1, 1.0)])
    with pytest.raises(ReadError, match="s_2.csv: columns 'vertex,humidity' differ from s_1.csv's 'vertex,temp'"):
        read_series(tmp_path / "c", V)
    per_time(tmp_path / "e", ["s_1.csv"], [[(1, 1.0, 2.0)]], header="vertex,a,b")
    with pytest.raises(ReadError, match="s_1.csv: 2 value columns"):
        read_series(tmp_path / "e", V)
    with pytest.raises(ReadError, match="no file matches"):
        read_series(tmp_path / "nothing_*.csv", V)


def test_mismatched_columns_in_a_wide_csv_name_the_line(tmp_path):
    (tmp_path / "w.csv").write_text("vertex,a,b\n1,2,3\n2,3\n")
    with pytest.raises(ReadError, match="w.csv: line 3 has 2 fields, the header 3"):
        read_series(tmp_path / "w.csv", V)


def test_read_series_values_refuses_a_damaged_file(tmp_path):
    X, times, _ = series(T=3)
    write_series(tmp_path / "s.pvd", V, F, X, times)
    (tmp_path / "s" / "s_000001.vtu").write_text("<VTKFile")
    with pytest.raises(ReadError, match="s_000001.vtu"):
        read_series_values(tmp_path / "s.pvd")
    (tmp_path / "x.xdmf").write_text("<Xdmf>")
    with pytest.raises(ReadError, match="x.xdmf: not a readable XDMF time series"):
        read_series_values(tmp_path / "x.xdmf")
