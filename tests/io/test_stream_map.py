"""A long linear series goes through its dense (n, k) map: the same file as solving every step, the same
refusals (NaN, conflicting duplicates) at the chunk that holds them, and never for a nonlinear configuration."""

import numpy as np
import pytest

import manifill
from manifill.errors import SampleError
from manifill.io import read_series_values
from manifill.io import stream
from manifill.mesh.shapes import icosphere

V, F = icosphere(3)
N = len(V)
K = 20
IDX = np.random.default_rng(3).choice(N, K, replace=False)
T = 2 * K + 7  # enough steps for the map


def values(T=T, rows=IDX):
    t = np.linspace(0, 3, T)
    P = V[rows]
    return np.sin(2 * P[:, :1] + t) + P[:, 1:2] * np.cos(t) + 0.2 * P[:, 2:3] ** 2


def solve_every_step(monkeypatch, *args, **kw):
    with monkeypatch.context() as m:
        m.setattr(stream, "MAP_STEPS_PER_SAMPLE", 10**9)
        return stream.reconstruct_series(*args, **kw)


LINEAR = [dict(method="harmonic"), dict(method="biharmonic"), dict(method="triharmonic"),
          dict(method="gvf-harmonic", curve_values="hermite"), dict(method="biharmonic", smoothing=1e-3)]


@pytest.mark.parametrize("options", LINEAR)
def test_the_map_gives_the_file_solving_every_step_gives(tmp_path, monkeypatch, options):
    vals = values()
    a = stream.reconstruct_series(V, F, IDX, vals, tmp_path / "map.h5", chunk=10, **options)
    b = solve_every_step(monkeypatch, V, F, IDX, vals, tmp_path / "solve.h5", chunk=10, **options)
    assert a.linear_map and not b.linear_map and "map" in a.seconds and "map" not in b.seconds
    assert a.chunks == b.chunks == 5
    ta, xa = read_series_values(tmp_path / "map.h5")
    tb, xb = read_series_values(tmp_path / "solve.h5")
    np.testing.assert_array_equal(ta, tb)
    assert np.abs(xa - xb).max() <= 1e-11 * np.abs(vals).max()
    one = manifill.reconstruct(V, F, IDX, vals[:, 17], **options).values
    assert np.abs(xa[:, 17] - one).max() <= 1e-11 * np.abs(vals).max()
    if options.get("smoothing") is None:
        np.testing.assert_array_equal(xa[IDX], vals)  # exact at the samples: W's sample rows are unit rows


@pytest.mark.parametrize("options", [dict(), dict(method="harmonic", bounds=(-2, 2)), dict(method="gvf")])
def test_a_nonlinear_series_solves_every_step(tmp_path, options):
    s = stream.reconstruct_series(V, F, IDX, values(), tmp_path / "x.npy", **options)
    assert "map" not in s.seconds


def test_few_steps_step_one_for_all_or_a_map_too_large_solve_every_step(tmp_path, monkeypatch):
    rec = manifill.Reconstructor(V, F, IDX, method="harmonic")
    assert stream.dense_map(rec, 2 * K) is not None and stream.dense_map(rec, 2 * K - 1) is None
    assert stream.dense_map(rec, 10 * K, check=True) is None
    monkeypatch.setattr(stream, "MAP_BYTES", 8 * N * K - 1)
    assert stream.dense_map(rec, 10 * K) is None


def test_a_nan_in_a_later_chunk_is_refused_there_and_leaves_no_file(tmp_path):
    vals = values()
    vals[4, 33] = np.nan
    seen = []
    with pytest.raises(SampleError, match="NaN"):
        stream.reconstruct_series(V, F, IDX, vals, tmp_path / "x.xdmf", chunk=10, method="harmonic",
                                  progress=seen.append)
    assert seen[-1] == "steps 30-39" and list(tmp_path.iterdir()) == []


def test_duplicate_samples_through_the_map_are_averaged_or_refused_as_apply_does(tmp_path, monkeypatch):
    rows = np.concatenate([IDX, IDX[:1]])  # the first vertex twice
    vals = values(rows=rows)
    vals[-1] = vals[0] + 0.5  # and two different values there
    a = stream.reconstruct_series(V, F, rows, vals, tmp_path / "a.npy", method="harmonic", duplicates="mean")
    solve_every_step(monkeypatch, V, F, rows, vals, tmp_path / "b.npy", method="harmonic", duplicates="mean")
    assert "map" in a.seconds
    xa, xb = np.load(tmp_path / "a.npy"), np.load(tmp_path / "b.npy")
    assert np.abs(xa - xb).max() <= 1e-11 * np.abs(vals).max()
    np.testing.assert_allclose(xa[IDX[0]], vals[0] + 0.25, rtol=1e-13)
    same = vals.copy()
    same[-1] = same[0]
    same[-1, 44] += 1.0  # agree everywhere but at one step: refused there, as apply refuses it
    with pytest.raises(SampleError):
        stream.reconstruct_series(V, F, rows, same, tmp_path / "c.npy", method="harmonic", chunk=10)
    assert not (tmp_path / "c.npy").exists()


def test_the_result_says_what_was_written(tmp_path):
    # 7 steps in chunks of 3: ceil(7 / 3) = 3 chunks; too few steps per sample for the map (20 samples)
    r = manifill.reconstruct_series(V, F, IDX, values(T=7), tmp_path / "x.npy", chunk=3, method="harmonic")
    assert isinstance(r, stream.SeriesResult) and r.path == tmp_path / "x.npy"
    assert (r.steps, r.chunk, r.chunks) == (7, 3, 3) and np.load(r.path).shape == (N, 7)
    assert not r.linear_map and r.report["method"] == "harmonic"
    assert {"prepare", "reconstruct", "write", "total"} <= set(r.seconds)
    assert r.seconds["total"] >= r.seconds["prepare"] + r.seconds["write"]
    # the dict it was: the same keys for one release, with a warning that names the attribute
    for key in ("steps", "chunk", "chunks", "seconds", "report"):
        with pytest.warns(DeprecationWarning, match=rf"\.{key}$"):
            assert r[key] is getattr(r, key)
    with pytest.raises(KeyError):
        r["path"]
