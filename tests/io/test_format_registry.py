"""One registry of formats: every reader and writer is reached through it (no suffix compared anywhere else), the
tables are views of it, and every format with a reader and a writer gives back what it was given."""

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import manifill
import manifill.io as mio
from manifill.io import formats as registry
from manifill.mesh.shapes import icosphere

SRC = Path(manifill.__file__).parent
# a suffix compared with a literal ('ext == ".vtk"', 'suffix in (".h5", ...)'), an ending tested with a literal, or
# a table keyed by literal suffixes: the registry's work, done outside it
SUFFIX_TESTS = [
    re.compile(r"""\b(suffix|suffixes|ext|src|sfx)\b[^\n#]*?(==|!=|\bin\b)\s*[(\[]?\s*(["'])\.[A-Za-z0-9]"""),
    re.compile(r"""\.endswith\(\s*\(?\s*b?(["'])\.[A-Za-z0-9]"""),
    re.compile(r"""\{\s*(["'])\.[A-Za-z0-9]+\1\s*:"""),
]


def test_no_suffix_is_compared_outside_the_registry():
    found = []
    for path in sorted(SRC.rglob("*.py")):
        if path == Path(registry.__file__):
            continue
        for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
            code = line.split("#", 1)[0]
            if any(p.search(code) for p in SUFFIX_TESTS):
                found.append(f"{path.relative_to(SRC)}:{lineno}: {line.strip()}")
    assert not found, "\n".join(found)


@pytest.mark.parametrize("line", ['if ext == ".vtk":', "elif path.suffix.lower() in ('.h5', '.hdf5'):",
                                  'if not name.endswith(".mgh"):', 'TABLE = {".xdmf": 1}'])
def test_the_grep_sees_a_suffix_comparison(line):
    assert any(p.search(line) for p in SUFFIX_TESTS)


def test_the_tables_are_views_of_the_registry():
    import manifill.adapters.globe  # noqa: F401 (registers the stations' formats)
    import manifill.cluster.manifest  # noqa: F401 (and the manifests')

    assert dict(mio.MESH_FORMATS) == registry.formats_of("mesh")
    assert set(mio.SERIES_FORMATS) == {".xdmf", ".pvd", ".npy", ".h5", ".hdf5", ".gii"}
    assert set(mio.TET_FORMATS) == {".vtu", ".vtk", ".msh"} and set(mio.GRID_FORMATS) == {".vti", ".npy"}
    assert set(mio.VALUE_FORMATS) == {".csv", ".npy", ".gii"} and set(mio.BARRIER_FORMATS) == {".txt", ".csv", ".npy"}
    assert set(mio.POINT_FORMATS) == {".vtp", ".vtu", ".vtk", ".ply"}
    assert {".csv", ".npz", ".npy", ".gii", ".mgh", ".mgz", ".label", ".thickness"} <= set(mio.SAMPLE_FORMATS)
    assert {k for k, _ in registry._FORMATS} == set(registry.KINDS)
    # a format registered later shows in every view at once, and its reader is the one reading uses
    seen = []
    fmt = registry.Format("test", "barriers", (".bartest",), read=lambda path: seen.append(path) or [np.arange(3)])
    registry.register_format(fmt)
    try:
        assert ".bartest" in mio.BARRIER_FORMATS
        assert mio.read_barriers("b.bartest")[0].tolist() == [0, 1, 2] and seen
    finally:
        del registry._FORMATS[("barriers", ".bartest")]
    assert ".bartest" not in mio.BARRIER_FORMATS


def test_the_old_name_of_a_format_warns_for_one_release():
    with pytest.warns(DeprecationWarning, match="manifill.io.Format"):
        assert mio.MeshFormat is registry.Format


def _fields(n):
    x = np.linspace(-1.0, 1.0, n)
    return {"t": x, "v": np.column_stack([x, 2 * x, 3 * x])}


def _mesh(tmp_path, fmt, suffix):
    V, F = icosphere(1)
    data = _fields(len(V)) if fmt.fields else {}
    mio.write_mesh(tmp_path / f"m{suffix}", V, F, data)
    m = mio.read_mesh_file(tmp_path / f"m{suffix}")
    if not fmt.vertex_numbering:  # STL: the corners merged again, in another order (float32)
        np.testing.assert_allclose(np.unique(m.V.round(5), axis=0), np.unique(V.round(5), axis=0), atol=1e-5)
        assert len(m.F) == len(F)
        return
    np.testing.assert_array_equal(m.V, V)
    assert (np.sort(m.F, axis=1) == np.sort(F, axis=1)).all()
    for name, a in data.items():
        got = m.point_data[name] if name in m.point_data else np.column_stack(
            [m.point_data[f"{name}_{j}"] for j in range(a.shape[1])])
        np.testing.assert_array_equal(np.asarray(got).reshape(a.shape), a)


def _tets(tmp_path, fmt, suffix):
    from manifill.solid.tetrahedralize import tetrahedralize

    V, T = tetrahedralize(*icosphere(1), max_volume=0.05)
    data = {"t": V[:, 0]}
    mio.write_tets(tmp_path / f"s{suffix}", V, T, data)
    V2, T2 = mio.read_tets(tmp_path / f"s{suffix}")
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(T2, T)


def _grid(tmp_path, fmt, suffix):
    a = np.arange(24.0).reshape(2, 3, 4) % 2 == 0
    mio.write_vti(tmp_path / f"g{suffix}", {"mask": a}, spacing=(1.0, 2.0, 3.0))
    mask, spacing, origin = mio.read_mask(tmp_path / f"g{suffix}")
    np.testing.assert_array_equal(mask, a)
    if fmt.fields:
        assert spacing.tolist() == [1.0, 2.0, 3.0]


def _values(tmp_path, fmt, suffix):
    from manifill.io.neuro import read_vertex_data

    X = np.column_stack([np.linspace(0, 1, 12), np.linspace(2, 3, 12)])
    mio.write_values(tmp_path / f"v{suffix}", X, names=["a", "b"])
    got, names = read_vertex_data(tmp_path / f"v{suffix}", 12)
    np.testing.assert_allclose(got, X, rtol=0 if fmt.exact else 1e-6)
    assert names == ["a", "b"]


def _series(tmp_path, fmt, suffix):
    V, F = icosphere(1)
    X = np.outer(V[:, 2], [1.0, 2.0, 3.0])
    times = np.array([0.5, 1.5, 4.0])
    mio.write_series(tmp_path / f"s{suffix}", V, F if fmt.cells else None, X, times)
    t, got = mio.read_series_values(tmp_path / f"s{suffix}")
    np.testing.assert_allclose(got, X, rtol=0 if fmt.exact else 1e-6)
    np.testing.assert_array_equal(t, times if fmt.times else np.arange(3.0))


def _stations(tmp_path, fmt, suffix):
    pytest.importorskip("xarray")
    pytest.importorskip("netCDF4")
    from manifill.adapters.globe import reconstruct_globe
    import pandas

    rng = np.random.default_rng(0)
    table = pandas.DataFrame({"lon": rng.uniform(-180, 180, 40), "lat": rng.uniform(-80, 80, 40)})
    table["temp"] = np.cos(np.radians(table["lat"]))
    field = reconstruct_globe(table, var="temp", grid=20.0)
    fmt.write(field, tmp_path / f"f{suffix}")
    back = fmt.read(tmp_path / f"f{suffix}")
    np.testing.assert_array_equal(np.asarray(back["temp"]), np.asarray(field))


ROUND_TRIPS = {"mesh": _mesh, "tets": _tets, "grid": _grid, "values": _values, "series": _series,
               "stations": _stations}


def _both():
    import manifill.adapters.globe  # noqa: F401

    return sorted({(k, s) for (k, s), f in registry._FORMATS.items() if f.read is not None and f.write is not None})


@pytest.mark.parametrize("kind, suffix", _both())
def test_every_format_with_a_reader_and_a_writer_round_trips(tmp_path, kind, suffix):
    fmt = registry.find_format(kind, f"x{suffix}")
    if fmt.extra == "neuro":
        pytest.importorskip("nibabel")
    if fmt.extra == "series":
        pytest.importorskip("h5py")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # GIfTI: float32 said in a note
        ROUND_TRIPS[kind](tmp_path, fmt, suffix)
