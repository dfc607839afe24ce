"""What a new user met (issue 40's findings), each fixed: files that are not what their names say, headers with a
wrong column, positions in other units, the globe's long and wide tables and its netCDF, the demo without an extra,
tangent gradients at barriers, and no message hinting at a flag its command does not take."""

import re
import zipfile
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_usage_error, run

import manifill
from manifill.mesh.shapes import icosphere

SRC = Path(manifill.__file__).parent


@pytest.fixture
def sphere(tmp_path):
    V, F = icosphere(3)
    manifill.write_mesh(tmp_path / "s.ply", V, F)
    idx = np.arange(0, len(V), 40)
    return tmp_path, V, F, idx


@pytest.mark.parametrize("head, kind", [(b"\x89PNG\r\n\x1a\n", "a PNG image"), (b"\xff\xd8\xff\xe0", "a JPEG image"),
                                        (b"%PDF-1.7", "a PDF document"), (b"PK\x03\x04", "a ZIP archive")])
def test_an_image_pdf_or_archive_given_as_mesh_or_samples_is_named(sphere, capsys, head, kind):
    d, V, F, idx = sphere
    (d / "scan.ply").write_bytes(head + b"\0" * 64)
    (d / "s.csv").write_bytes(head + b"\0" * 64)
    code, out, err = run(capsys, "reconstruct", d / "scan.ply", d / "s.csv", "-o", d / "o.vtu")
    line = assert_usage_error(code, out, err)
    assert line == f"manifill: error: scan.ply is {kind}, not a PLY mesh; pass the mesh file itself"
    code, out, err = run(capsys, "reconstruct", d / "s.ply", d / "s.csv", "-o", d / "o.vtu")
    assert f"s.csv is {kind}, not a CSV file of samples" in assert_usage_error(code, out, err)
    assert not (d / "o.vtu").exists()


def test_an_npz_is_a_zip_and_is_read(sphere):
    d, V, F, idx = sphere
    np.savez(d / "s.npz", idx=idx, vals=V[idx, 0])
    assert zipfile.is_zipfile(d / "s.npz")
    S = manifill.read_samples(d / "s.npz", V)
    assert np.array_equal(S.idx, idx)


@pytest.mark.parametrize("header, words", [
    ("x,yy,z,value", "column 2 is 'yy', not 'y' (positions are x,y,z,value[,...]); rename it 'y'"),
    ("X,Y,Zed,value", "column 3 is 'Zed', not 'z'"),
    ("vertx,value", "the first column 'vertx' is neither 'vertex' (did you mean 'vertex'?) nor 'x'"),
    ("1,2", "the first line '1,2' is not a header"),
])
def test_a_header_names_the_wrong_column_and_the_expected_one(sphere, capsys, header, words):
    d, V, F, idx = sphere
    (d / "h.csv").write_text(header + "\n" + "0,1,2,3\n")
    code, out, err = run(capsys, "reconstruct", d / "s.ply", d / "h.csv", "-o", d / "o.vtu")
    assert words in assert_usage_error(code, out, err)


@pytest.mark.parametrize("factor, says", [(1000.0, "scale them by 0.001 (e.g. mm to m)"),
                                          (100.0, "scale them by 0.01 (e.g. cm to m)"),
                                          (0.001, "scale them by 1000 (e.g. m to mm)")])
def test_positions_in_other_units_name_the_factor(sphere, capsys, factor, says):
    d, V, F, idx = sphere
    np.savetxt(d / "p.csv", np.column_stack([V[idx] * factor, V[idx, 2]]), delimiter=",", header="x,y,z,t",
               comments="")
    code, out, err = run(capsys, "reconstruct", d / "s.ply", d / "p.csv", "-o", d / "o.vtu")
    assert says in assert_usage_error(code, out, err)


def test_far_positions_in_the_same_units_suggest_no_factor(sphere, capsys):
    d, V, F, idx = sphere
    P = V[idx].copy()
    P[0] += 3.0  # one position off the sphere, the rest on it: no units problem
    np.savetxt(d / "p.csv", np.column_stack([P, V[idx, 2]]), delimiter=",", header="x,y,z,t", comments="")
    code, out, err = run(capsys, "reconstruct", d / "s.ply", d / "p.csv", "-o", d / "o.vtu")
    line = assert_usage_error(code, out, err)
    assert "samples lie far" in line and "scale them" not in line


def test_vertex_gradients_are_tangent_at_barrier_vertices():
    from manifill.surface.curve_values import vertex_normals

    V, F = icosphere(3)
    ring = np.flatnonzero(np.abs(V[:, 2]) < 0.05)
    ring = ring[np.argsort(np.arctan2(V[ring, 1], V[ring, 0]))]
    path = ring[: len(ring) // 2]
    idx = np.arange(0, len(V), 17)
    r = manifill.reconstruct(V, F, idx, V[idx, 0] + V[idx, 2], method="biharmonic", barriers=[path])
    g, N = r.gradient(), vertex_normals(V, F)
    along = np.abs(np.sum(g * N, axis=1))
    assert along[path].max() <= 1e-12 * np.linalg.norm(g[path], axis=1).max()
    assert np.linalg.norm(g[path], axis=1).min() > 0  # the projection kept the gradient, not zeroed it


def test_the_demo_names_what_is_missing_and_lists_what_it_wrote(tmp_path, monkeypatch):
    import manifill.demo as demo

    def first_figure_then_missing(out, field, label, *, into):
        path = Path(out) / "fig4_1_cycle.png"
        path.write_bytes(b"png")
        into.setdefault("files", []).append(path)
        into.setdefault("lines", []).append("    Fig. 4.1")
        raise ImportError("No module named 'igl'", name="igl")

    monkeypatch.setattr(demo, "paper_figures", first_figure_then_missing)
    report = demo.run_demo(tmp_path, level=2, samples=30)
    assert "pictures: the rest need igl (pip install 'manifill[volume]')" in report["text"]
    assert str(tmp_path / "fig4_1_cycle.png") in report["files"]
    wrote = next(line for line in report["text"].splitlines() if line.startswith("  wrote "))
    assert "fig4_1_cycle.png" in wrote and "install pyvista" not in report["text"]


@pytest.fixture
def stations():
    pandas = pytest.importorskip("pandas")
    pytest.importorskip("xarray")
    rng = np.random.default_rng(3)
    lon, lat = rng.uniform(-180, 180, 120), rng.uniform(-75, 75, 120)
    wide = pandas.DataFrame({"lon": lon, "lat": lat})
    for t in range(3):
        wide[f"t{t}"] = np.cos(np.radians(lat)) + 0.1 * t * np.sin(np.radians(lon))
    long = pandas.DataFrame([(a, b, t, wide[f"t{t}"][i]) for t in range(3) for i, (a, b) in enumerate(zip(lon, lat))],
                            columns=["lon", "lat", "time", "temp"])
    return wide, long


def test_a_long_table_with_a_time_column_is_a_series_of_the_same_field(stations):
    from manifill.adapters.globe import reconstruct_globe

    wide, long = stations
    a = reconstruct_globe(long, grid=10.0)
    b = reconstruct_globe(wide, grid=10.0)
    assert a.dims == ("time", "lat", "lon") and a.sizes["time"] == 3 and a.name == "temp"
    assert b.dims == ("time", "lat", "lon") and b["time"].values.tolist() == [0, 1, 2]
    np.testing.assert_allclose(a.values, b.values, rtol=0, atol=1e-12)
    shuffled = long.sample(frac=1.0, random_state=0)  # the rows in any order: the same stations and steps
    np.testing.assert_allclose(reconstruct_globe(shuffled, grid=10.0).values, a.values, rtol=0, atol=1e-9)


def test_a_long_table_with_a_station_twice_at_one_time_is_refused(stations):
    from manifill.adapters.globe import reconstruct_globe
    from manifill.errors import SampleError

    _, long = stations
    import pandas

    twice = pandas.concat([long, long.iloc[[5]]], ignore_index=True)
    with pytest.raises(SampleError, match="two rows at time 0; keep one row per station and time"):
        reconstruct_globe(twice, grid=10.0)


def test_the_globe_command_takes_a_long_table_and_writes_clean_cf(stations, tmp_path, capsys):
    netCDF4 = pytest.importorskip("netCDF4")
    _, long = stations
    long.to_csv(tmp_path / "st.csv", index=False)
    code, out, err = run(capsys, "globe", tmp_path / "st.csv", "-o", tmp_path / "f.nc", "--grid", "10")
    assert code == 0, err
    assert "temp on time 3 x lat 19 x lon 36" in out
    with netCDF4.Dataset(tmp_path / "f.nc") as nc:
        for c in ("lat", "lon", "time"):
            assert "_FillValue" not in nc[c].ncattrs(), c
        history = nc.getncattr("history")
    assert re.match(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ: manifill globe .*st\.csv -o .*f\.nc --grid 10", history)


def test_no_message_hints_at_a_flag_its_command_does_not_take():
    """Every 'CLI: --x' in a message is a flag of the command that reaches that code (the globe's of globe, the
    batch's of batch, the solid's of volume, the rest of reconstruct's or volume's)."""
    from manifill.cli.main import build_parser
    import manifill.cluster  # noqa: F401 (registers the batch command)

    parser = build_parser()
    flags = {name: {s for a in sub._actions for s in a.option_strings}
             for name, sub in parser._subparsers._group_actions[0].choices.items()}
    owners = {"adapters/globe.py": ["globe"], "adapters/globe_tables.py": ["globe"], "cli/globe.py": ["globe"],
              "adapters/globe_vectors.py": ["globe"],
              "cluster": ["batch"], "io/distributed.py": ["batch", "reconstruct"], "solid": ["volume"]}
    found = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        commands = next((c for k, c in owners.items() if rel.startswith(k)), ["reconstruct", "volume"])
        for flag in re.findall(r"CLI:? (--[a-z][a-z-]*)", path.read_text(encoding="utf-8")):
            if not any(flag in flags[c] for c in commands):
                found.append(f"{rel}: {flag} (not a flag of {' or '.join(commands)})")
    assert not found, "\n".join(found)


def test_the_fill_report_counts_negative_weights_only_for_the_harmonic_energy():
    # a bilaplacian's positive off-diagonal entries are no obtuse triangles: an icosphere has none, and the harmonic
    # fill says 0; the bi- and triharmonic fills said 61,410 at level 6
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(3)
    idx, vals = [0, 5, 9, 40], [0.0, 1.0, 2.0, 3.0]
    assert manifill.reconstruct(V, F, idx, vals, method="harmonic").report["fill"]["negative_weights"] == 0
    for method in ("biharmonic", "triharmonic"):
        assert "negative_weights" not in manifill.reconstruct(V, F, idx, vals, method=method).report["fill"]
