"""One mesh, many fields over Dask workers: a pickled Reconstructor gives the same values, a series whose
chunks run on a real two-process ``LocalCluster`` is the same file as one run here, in time order, and a chunk
that fails stops the series with its own error and leaves no file."""

import operator
import pickle

import meshio
import numpy as np
import pytest

import manifill
from conftest import run
from manifill.errors import ManifillError, SampleError
from manifill.io import read_series_values, write_mesh
from manifill.io.distributed import ordered_map
from manifill.io.stream import reconstruct_series
from manifill.mesh.shapes import icosphere

distributed = pytest.importorskip("distributed")
pytest.importorskip("h5py")

V, F = icosphere(3)
N = len(V)
IDX = np.random.default_rng(1).choice(N, 25, replace=False)


def values(T, seed=0):
    """(k, T) values: a smooth field moving in time plus noise, so that every step differs."""
    rng = np.random.default_rng(seed)
    t = np.arange(T)
    return np.sin(3 * V[IDX, :1] + 0.1 * t) + 0.3 * V[IDX, 2:3] * np.cos(0.05 * t) + 0.01 * rng.normal(size=(25, T))


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                       memory_limit="2GB")
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.mark.parametrize("options", [dict(method="harmonic"), dict(method="gvf-harmonic"),
                                     dict(method="biharmonic", bounds=(-1.5, 1.5)),
                                     dict(method="gp", gp={"range": 1.0}), dict(method="biharmonic", smoothing=1e-3)])
def test_a_pickled_reconstructor_gives_the_same_values(options):
    vals = values(6)
    rec = manifill.Reconstructor(V, F, IDX, fields=6, **options)
    want = rec.apply(vals).values
    copy = pickle.loads(pickle.dumps(rec))
    assert copy.method == rec.method and copy.surface.n == N
    np.testing.assert_allclose(copy.apply(vals).values, want, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(copy.apply(vals[:, 2]).values, want[:, 2], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("ext", [".npy", ".xdmf", ".pvd"])
def test_a_series_over_two_workers_is_the_serial_series(tmp_path, client, ext):
    vals = values(23)
    here, there = tmp_path / f"here{ext}", tmp_path / f"there{ext}"
    times = 0.5 + 0.25 * np.arange(23)
    a = reconstruct_series(V, F, IDX, vals, here, times=times, chunk=4, method="biharmonic")
    seen = []
    b = reconstruct_series(V, F, IDX, vals, there, times=times, chunk=4, method="biharmonic", client=client,
                           progress=seen.append)
    assert a.chunks == b.chunks == 6 and b.seconds["send"] > 0
    assert seen == [f"steps {s}-{min(s + 4, 23) - 1}" for s in range(0, 23, 4)]  # written in time order
    t1, x1 = read_series_values(here)
    t2, x2 = read_series_values(there)
    assert x2.shape == (N, 23)
    np.testing.assert_array_equal(t2, t1)
    np.testing.assert_allclose(x2, x1, rtol=1e-12, atol=1e-13)  # a worker's BLAS: one thread
    one_shot = manifill.reconstruct(V, F, IDX, vals, method="biharmonic").values
    np.testing.assert_allclose(x2, one_shot, rtol=1e-10, atol=1e-12)
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


def test_the_results_come_back_in_order_however_the_tasks_finish(client):
    got = list(ordered_map(client, operator.add, 100, ((k,) for k in range(40)), in_flight=1))
    assert got == [100 + k for k in range(40)]


def test_a_failing_chunk_raises_its_own_error_and_cancels_the_rest(client):
    args = [(1.0,), (2.0,), (0.0,), (4.0,), (5.0,)]
    out = []
    with pytest.raises(ZeroDivisionError):
        for x in ordered_map(client, operator.truediv, 8.0, args):
            out.append(x)
    assert out == [8.0, 4.0]


@pytest.mark.parametrize("ext", [".xdmf", ".pvd"])
def test_a_chunk_refused_on_a_worker_stops_the_series_and_leaves_no_file(tmp_path, client, ext):
    vals = values(20)
    vals[3, 13] = np.nan  # the fourth chunk's: refused by the worker's apply, after three chunks were written
    path = tmp_path / f"s{ext}"
    with pytest.raises(SampleError, match="NaN"):
        reconstruct_series(V, F, IDX, vals, path, chunk=4, method="harmonic", client=client)
    assert list(tmp_path.iterdir()) == []
    client.run(lambda: None)  # the workers are alive and take work


def test_the_command_line_applies_the_chunks_on_workers(tmp_path, capsys):
    mesh = tmp_path / "m.ply"
    write_mesh(mesh, V, F)
    vals = values(12)
    samples = tmp_path / "s.csv"
    samples.write_text("vertex," + ",".join(f"v{k}" for k in range(12)) + "\n" +
                       "".join(f"{i}," + ",".join(repr(float(v)) for v in row) + "\n" for i, row in zip(IDX, vals)))
    code, _, err = run(capsys, "reconstruct", mesh, samples, "-o", tmp_path / "a.xdmf", "--chunk", "5", "-q")
    assert code == 0, err
    code, _, err = run(capsys, "reconstruct", mesh, samples, "-o", tmp_path / "b.xdmf", "--chunk", "5", "-q",
                       "--workers", "2")
    assert code == 0, err
    a, b = meshio.xdmf.TimeSeriesReader(tmp_path / "a.xdmf"), meshio.xdmf.TimeSeriesReader(tmp_path / "b.xdmf")
    a.read_points_cells()
    b.read_points_cells()
    assert a.num_steps == b.num_steps == 12
    for k in range(12):
        ta, pa, _ = a.read_data(k)
        tb, pb, _ = b.read_data(k)
        assert ta == tb
        np.testing.assert_allclose(pb["value"], pa["value"], rtol=1e-12, atol=1e-13)


def test_bad_worker_options_are_one_line_errors(tmp_path, capsys):
    mesh = tmp_path / "m.ply"
    write_mesh(mesh, V, F)
    samples = tmp_path / "s.csv"
    samples.write_text("vertex,a,b\n" + "".join(f"{i},1.0,2.0\n" for i in IDX))
    code, _, err = run(capsys, "reconstruct", mesh, samples, "-o", tmp_path / "a.xdmf", "--workers", "0")
    assert code == 2 and err.count("\n") == 1 and "--workers 0" in err and "Traceback" not in err
    code, _, err = run(capsys, "reconstruct", mesh, samples, "-o", tmp_path / "a.xdmf", "--workers", "2",
                       "--scheduler", "tcp://127.0.0.1:1")
    assert code == 2 and "not allowed with" in err
    assert not (tmp_path / "a.xdmf").exists()
    one = tmp_path / "one.csv"
    one.write_text("vertex,value\n" + "".join(f"{i},1.0\n" for i in IDX))
    for flag, value in (("--workers", "2"), ("--scheduler", "tcp://127.0.0.1:1")):
        code, _, err = run(capsys, "reconstruct", mesh, one, "-o", tmp_path / "one.vtu", flag, value)
        assert code == 2 and err.count("\n") == 1 and f"leave {flag} out" in err
    assert not (tmp_path / "one.vtu").exists()
    assert isinstance(ManifillError("x"), ValueError)


def test_without_the_batch_extra_the_error_names_it(tmp_path, capsys, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed now raises ImportError
    mesh = tmp_path / "m.ply"
    write_mesh(mesh, V, F)
    samples = tmp_path / "s.csv"
    samples.write_text("vertex,a,b\n" + "".join(f"{i},1.0,2.0\n" for i in IDX))
    code, _, err = run(capsys, "reconstruct", mesh, samples, "-o", tmp_path / "a.xdmf", "--workers", "2")
    assert code == 2 and "manifill[batch]" in err and err.count("\n") == 1
    with pytest.raises(ManifillError, match=r"manifill\[batch\]"):
        manifill.batch([dict(mesh=mesh, samples=samples, output=tmp_path / "o.vtu")], summary=tmp_path / "b.csv")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.ply", "s.csv"]
