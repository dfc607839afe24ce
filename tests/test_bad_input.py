"""Named regressions for bad input that used to slip through: each ends in one manifill error, or is handled."""

import warnings

import numpy as np
import pytest
from conftest import assert_usage_error, files, run

import manifill
from manifill.errors import ReadError, SampleError
from manifill.io import read_mesh_file, read_samples, write_mesh
from manifill.mesh.shapes import icosphere


def test_regression_complex_sample_values_are_refused_not_truncated(tmp_path):
    V, F = icosphere(1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's ComplexWarning used to be all that was said
        with pytest.raises(SampleError, match="complex"):
            manifill.harmonic(V, F, [0, 5], np.array([1 + 2j, 3 + 0j]))
        np.savez(tmp_path / "c.npz", idx=np.array([0, 5]), vals=np.array([1 + 2j, 3 + 0j]))
        with pytest.raises(SampleError, match="complex") as info:
            read_samples(tmp_path / "c.npz", V)
        assert "c.npz" in str(info.value)
        arr = np.zeros(2, dtype=[("vertex", "i8"), ("value", "c16")])
        np.save(tmp_path / "c.npy", arr)
        with pytest.raises(SampleError, match="complex"):
            read_samples(tmp_path / "c.npy", V)


def test_regression_non_numeric_sample_arrays(tmp_path):
    V, F = icosphere(1)
    np.savez(tmp_path / "s.npz", idx=np.array([0, 5]), vals=np.array(["a", "b"]))
    with pytest.raises(ReadError, match="not numbers") as info:
        read_samples(tmp_path / "s.npz", V)
    assert "s.npz" in str(info.value)
    with pytest.raises(SampleError, match="could not be read as numbers"):
        manifill.harmonic(V, F, [0, 5], ["a", "b"])


def test_regression_ascii_stl_reads_without_warnings(tmp_path, capfd):
    V, F = icosphere(1)
    lines = ["solid s"]
    for f in F:
        a, b, c = V[f]
        n = np.cross(b - a, c - a)
        lines += [f"facet normal {n[0]} {n[1]} {n[2]}", "outer loop",
                  *(f"vertex {p[0]} {p[1]} {p[2]}" for p in (a, b, c)), "endloop", "endfacet"]
    (tmp_path / "a.stl").write_text("\n".join(lines + ["endsolid s"]) + "\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = read_mesh_file(tmp_path / "a.stl")
    assert caught == [] and capfd.readouterr() == ("", "")
    assert len(m.F) == len(F) and len(m.V) == len(V)  # the corners merged back into the 42 vertices


@pytest.mark.parametrize("shape", [(1, 6, 6), (6, 1, 6), (6, 6, 1), (1, 1, 1)])
def test_regression_flat_voxel_mask_is_filled_from_its_boundary(shape):
    # a mask one voxel thick is all boundary: its values come from the digital surface, nothing to fill
    from manifill.solid.boundary import digital_surface

    mask = np.ones(shape, dtype=bool)
    voxels, _, _, _ = digital_surface(mask)
    assert len(voxels) == mask.sum()
    k = min(3, len(voxels))
    r = manifill.reconstruct_volume_mask(mask, voxels[:k], np.arange(1.0, k + 1), method="harmonic")
    assert np.isfinite(r.values[mask]).all()
    assert r.values[mask].min() >= 1 - 1e-12 and r.values[mask].max() <= k + 1e-12


def test_regression_tiny_coordinates_are_not_called_zero_area(tmp_path, capsys):
    V, F = icosphere(2)
    idx = np.arange(0, len(V), 13)
    for scale in (1e-150, 1e150):
        write_mesh(tmp_path / "m.ply", scale * V, F)
        (tmp_path / "s.csv").write_text("vertex,t\n" + "".join(f"{i},{float(V[i, 0])!r}\n" for i in idx))
        code, out, err = run(capsys, "reconstruct", tmp_path / "m.ply", tmp_path / "s.csv", "-o",
                             tmp_path / "o.npy", "-q")
        assert code == 0, err
        np.testing.assert_allclose(np.load(tmp_path / "o.npy"), manifill.reconstruct(V, F, idx, V[idx, 0]).values,
                                   rtol=0, atol=1e-10)


def test_regression_cli_bad_values_file_is_one_line(tmp_path, capsys):
    V, F = icosphere(1)
    write_mesh(tmp_path / "m.ply", V, F)
    np.savez(tmp_path / "c.npz", idx=np.array([0, 5]), vals=np.array([1 + 2j, 3 + 0j]))
    code, out, err = run(capsys, "harmonic", tmp_path / "m.ply", tmp_path / "c.npz", "-o", tmp_path / "o.vtu")
    assert "complex" in assert_usage_error(code, out, err)
    assert files(tmp_path) == ["c.npz", "m.ply"]


def test_regression_structured_npy_with_a_sub_array_field_is_one_line(tmp_path, capsys):
    # a field holding (2,) per row ended in "internal error: ValueError: all the input array dimensions ..."
    V, F = icosphere(1)
    arr = np.zeros(3, dtype=[("vertex", "i8"), ("value", "f8", (2,))])
    arr["vertex"] = [0, 5, 9]
    np.save(tmp_path / "s.npy", arr)
    with pytest.raises(ReadError, match="field 'value' holds .* per row, not one number"):
        read_samples(tmp_path / "s.npy", V)
    np.save(tmp_path / "t.npy", np.zeros((3, 2), dtype=[("vertex", "i8"), ("value", "f8")]))
    with pytest.raises(ReadError, match=r"shape \(3, 2\); save one row per sample"):
        read_samples(tmp_path / "t.npy", V)
    write_mesh(tmp_path / "m.vtu", V, F)
    line = assert_usage_error(*run(capsys, "reconstruct", tmp_path / "m.vtu", tmp_path / "s.npy", "-o",
                                   tmp_path / "o.vtu"))
    assert "per row, not one number" in line and not (tmp_path / "o.vtu").exists()


@pytest.mark.parametrize("method", ["default", "biharmonic", "gp", "rbf", "harmonic"])
def test_regression_huge_sample_values_are_refused_before_any_overflow(method):
    # 1e308 printed four RuntimeWarnings, then "NaN or infinite values in rows 2, 6, 14" of an internal array
    V, F = icosphere(2)
    idx = np.arange(0, 162, 7)
    vals = np.sin(V[idx, 0])
    vals[3] = 1e308
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(SampleError, match=r"vals reaches 1e\+308 \(rows 3\), beyond 1e\+150"):
            manifill.reconstruct(V, F, idx, vals, method=method)
        vals[3], vals[4] = 1e149, -1e149  # the largest taken: a result, with no warning
        r = manifill.reconstruct(V, F, idx, vals, method=method)
    assert np.isfinite(r.values).all() and np.allclose(r.values[idx], vals, rtol=1e-9, atol=1e135)


def test_regression_huge_values_in_a_csv_are_said_with_the_files_lines(tmp_path, capsys):
    # the CLI said "vals reaches 1e+308 (rows 0, 1, ...)": an internal name, rows counted from 0 without the header
    V, F = icosphere(1)
    write_mesh(tmp_path / "m.vtu", V, F)
    (tmp_path / "s.csv").write_text("vertex,value\n0,1.0\n5,-1e200\n7,2.0\n9,1e308\n")
    line = assert_usage_error(*run(capsys, "reconstruct", tmp_path / "m.vtu", tmp_path / "s.csv", "-o",
                                   tmp_path / "o.vtu"))
    assert "s.csv: values beyond 1e+150 on lines 3, 5 (up to 1e+308)" in line and "vals" not in line


def test_regression_mesh_and_samples_swapped_get_a_hint(tmp_path, capsys):
    # was "s.csv: cannot read '.csv' files; use one of ..."
    V, F = icosphere(1)
    write_mesh(tmp_path / "m.vtu", V, F)
    (tmp_path / "s.csv").write_text("vertex,value\n0,1.0\n5,2.0\n")
    for command in (["reconstruct"], ["harmonic"]):
        line = assert_usage_error(*run(capsys, *command, tmp_path / "s.csv", tmp_path / "m.vtu", "-o",
                                       tmp_path / "o.vtu"))
        assert "did you swap them? the order is MESH SAMPLES" in line
    assert not (tmp_path / "o.vtu").exists()


def test_regression_a_killed_runs_temporary_is_removed_by_the_next_write(tmp_path):
    # a SIGKILLed run left `.out.vtu.<pid>.tmp.vtu` for ever; a live writer's temporary stays
    import subprocess
    import sys

    V, F = icosphere(1)
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    stale = tmp_path / f".out.vtu.{int(dead.stdout)}.tmp.vtu"
    stale.write_bytes(b"half")
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        busy = tmp_path / f".out.vtu.{live.pid}.tmp.vtu"
        busy.write_bytes(b"being written")
        write_mesh(tmp_path / "out.vtu", V, F)
        assert not stale.exists() and busy.exists() and (tmp_path / "out.vtu").exists()
    finally:
        live.kill()
        live.wait()


def test_regression_extreme_levels_and_spacing_end_in_one_line_without_warnings(tmp_path, capsys):
    # --levels=-1e308,1e308 succeeded with overflow warnings; --spacing 1e-300 printed numpy's overflow warning first
    V, F = icosphere(2)
    write_mesh(tmp_path / "m.vtu", V, F)
    idx = np.arange(0, 162, 9)
    np.savetxt(tmp_path / "s.csv", np.column_stack([idx, np.sin(V[idx, 0])]), delimiter=",", header="vertex,value",
               comments="")
    np.save(tmp_path / "mask.npy", np.ones((5, 5, 5), bool))
    (tmp_path / "v.csv").write_text("x,y,z,value\n0,0,0,1.0\n4e-300,4e-300,4e-300,2.0\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        line = assert_usage_error(*run(capsys, "reconstruct", tmp_path / "m.vtu", tmp_path / "s.csv", "-o",
                                       tmp_path / "o.vtu", "--levels=-1e308,1e308"))
        assert "levels reaches 1e+308 (rows 0, 1), beyond 1e+150" in line and not (tmp_path / "o.vtu").exists()
        code, out, err = run(capsys, "volume", tmp_path / "mask.npy", tmp_path / "v.csv", "-o", tmp_path / "o.vti",
                             "--spacing", "1e-300")
        assert code == 0 and err == "" and (tmp_path / "o.vti").exists(), err


def test_regression_a_full_disk_names_the_file_and_the_cause(tmp_path, monkeypatch, capsys):
    # was "238328 requested and 130544 written", with no file name or cause; nothing may be left behind
    def short_write(*args, **kwargs):
        raise OSError("238328 requested and 130544 written")  # what numpy says when the disk fills up

    np.save(tmp_path / "mask.npy", np.ones((6, 6, 6), bool))
    (tmp_path / "v.csv").write_text("x,y,z,value\n0,0,0,1.0\n5,5,5,2.0\n")
    monkeypatch.setattr(np.lib.format, "write_array", short_write)
    line = assert_usage_error(*run(capsys, "volume", tmp_path / "mask.npy", tmp_path / "v.csv", "-o",
                                   tmp_path / "out.npy"))
    assert "out.npy: could not be written (238328 requested and 130544 written: the disk is probably full)" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mask.npy", "v.csv"]


def test_regression_a_damaged_header_gives_the_same_message_every_run(tmp_path, capsys):
    # an NPY header with `'shape': (inf**40,)` said "<ast.BinOp object at 0x7f...>": a new address every run
    V, F = icosphere(1)
    write_mesh(tmp_path / "m.vtu", V, F)
    arr = np.zeros(3, dtype=[("vertex", "i8"), ("value", "f8")])
    np.save(tmp_path / "s.npy", arr)
    data = (tmp_path / "s.npy").read_bytes()
    start = data.index(b"'shape': (") + len(b"'shape': (")
    end = data.index(b")", start)
    damaged = data[:start] + b"inf**40," + data[end:]
    (tmp_path / "s.npy").write_bytes(damaged[:len(data)] if len(damaged) >= len(data) else
                                     damaged[:start + 8] + b" " * (len(data) - len(damaged)) + damaged[start + 8:])
    line = assert_usage_error(*run(capsys, "reconstruct", tmp_path / "m.vtu", tmp_path / "s.npy", "-o",
                                   tmp_path / "o.vtu"))
    assert "s.npy" in line and " at 0x" not in line


def test_regression_only_a_full_disk_becomes_could_not_be_written(tmp_path):
    # every OSError inside a write turned into "could not be written (...); free some space"
    from manifill.io.files import atomic_path

    with pytest.raises(PermissionError):
        with atomic_path(tmp_path / "o.vtu"):
            raise PermissionError(13, "Permission denied")
    assert list(tmp_path.iterdir()) == []
