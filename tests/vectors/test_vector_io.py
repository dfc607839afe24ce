"""Vector fields in and out: files that hold 3-vectors (and read back equal), arrows read from sample tables, the
globe's wind on a lon/lat grid, and the pictures' arrows (thinned, tangent, drawn).

Every file is read back by another reader than manifill's (meshio, pyvista, numpy, xarray) and compared with the
result's own arrays; every refusal is one line naming what to change.
"""

import csv

import numpy as np
import pytest

from conftest import icosphere
from manifill import reconstruct_vectors
from manifill.errors import ReadError, SampleError, WriteError
from manifill.io import read_mesh_file
from manifill.io.vector_files import holds_vectors, read_vector_samples, split_vectors, vector_columns
from manifill.vectors.result import VectorReconstruction

V, F = icosphere(2)
N = len(V)
IDX = np.arange(0, N, 9)
ARROWS = np.cross(V[IDX], [0.0, 0.0, 1.0]) + 0.3 * np.cross(V[IDX], [1.0, 0.0, 0.0])  # tangent to the sphere


@pytest.fixture(scope="module")
def result():
    return reconstruct_vectors(V, F, IDX, ARROWS)


def _with_std(r):
    """The result with a std and a second field, built directly (the writers' concern, not a method's)."""
    X = np.stack([r.values, 2 * r.values], axis=2)
    Y = np.stack([r.faces, 2 * r.faces], axis=2)
    std = np.column_stack([np.linspace(0, 1, N), np.linspace(1, 2, N)])
    return VectorReconstruction(V, F, X, Y, idx=IDX, std=std, names=["wind", "current"], normals=r.normals)


# ---------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("ext", [".vtu", ".vtp", ".vtk"])
def test_vtk_files_hold_the_vectors_as_3_component_point_and_cell_arrays(tmp_path, result, ext):
    pv = pytest.importorskip("pyvista")
    path = result.save(tmp_path / f"w{ext}")
    mesh = pv.read(path)
    assert mesh.point_data["value"].shape == (N, 3) and np.allclose(mesh.point_data["value"], result.values)
    assert np.allclose(mesh.point_data["value_magnitude"], np.linalg.norm(result.values, axis=1))
    assert mesh.cell_data["value"].shape == (len(F), 3) and np.allclose(mesh.cell_data["value"], result.faces)
    assert mesh.point_data["sample_mask"].sum() == len(IDX)
    if ext != ".vtk":  # VTK XML marks the active vectors: what ParaView's Glyph and pyvista's glyph() follow
        assert mesh.active_vectors_name == "value"
    if ext != ".vtp":  # meshio reads VTU and legacy VTK (not VTP)
        import meshio

        m = meshio.read(path)
        assert np.allclose(m.point_data["value"], result.values)
        assert np.allclose(m.cell_data["value"][0], result.faces)
    back = read_mesh_file(path)  # manifill's own readers pass the cell arrays by
    assert np.allclose(back.point_data["value"], result.values) and np.array_equal(back.F, F)


def test_ply_csv_and_npy_hold_the_components(tmp_path, result):
    import meshio

    m = meshio.read(result.save(tmp_path / "w.ply"))
    got = np.column_stack([m.point_data[f"value_{c}"] for c in "xyz"])
    assert np.allclose(got, result.values)
    with open(result.save(tmp_path / "w.csv"), newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["vertex", "value_x", "value_y", "value_z", "value_magnitude"]
    table = np.array(rows[1:], dtype=float)
    assert np.array_equal(table[:, 0], np.arange(N)) and np.allclose(table[:, 1:4], result.values)
    assert np.allclose(table[:, 4], result.magnitude)
    arr = np.load(result.save(tmp_path / "w.npy"))
    assert arr.shape == (N, 3) and np.allclose(arr, result.values)


def test_several_fields_and_their_std_keep_their_names(tmp_path, result):
    pv = pytest.importorskip("pyvista")
    r = _with_std(result)
    mesh = pv.read(r.save(tmp_path / "two.vtu"))
    assert np.allclose(mesh.point_data["current"], 2 * result.values)
    assert np.allclose(mesh.point_data["wind_std"], np.linspace(0, 1, N))
    assert np.allclose(mesh.cell_data["current"], 2 * result.faces)
    with open(r.save(tmp_path / "two.csv"), newline="") as fh:
        head = next(csv.reader(fh))
    assert head == ["vertex", "wind_x", "wind_y", "wind_z", "wind_magnitude", "wind_std", "current_x", "current_y",
                    "current_z", "current_magnitude", "current_std"]


@pytest.mark.parametrize("name, what", [("two.npy", "one vector field"), ("w.obj", "vector field is written as"),
                                        ("w.xdmf", "vector field is written as")])
def test_outputs_that_cannot_hold_the_vectors_are_refused_in_one_line(tmp_path, result, name, what):
    r = _with_std(result) if name.endswith(".npy") else result
    with pytest.raises(WriteError, match=what) as e:
        r.save(tmp_path / name)
    assert "\n" not in str(e.value) and list(tmp_path.iterdir()) == []


def test_split_vectors_names_the_components():
    out = split_vectors({"g": np.arange(6.0).reshape(2, 3), "g_magnitude": np.ones(2)})
    assert list(out) == ["g_x", "g_y", "g_z", "g_magnitude"] and out["g_z"].tolist() == [2.0, 5.0]


# ---------------------------------------------------------------------------
# reading arrows
# ---------------------------------------------------------------------------


def _csv(path, header, rows):
    fmt = ["%d" if header[0] == "vertex" else "%.17g"] + ["%.17g"] * (len(header) - 1)
    np.savetxt(path, rows, fmt=fmt, delimiter=",", header=",".join(header), comments="")
    return path


def png(path):
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGB"), dtype=np.float64)


def test_arrows_by_vertex_and_by_position_from_csv(tmp_path):
    by_vertex = _csv(tmp_path / "a.csv", ["vertex", "vx", "vy", "vz"], np.column_stack([IDX, ARROWS]))
    assert holds_vectors(by_vertex)
    a = read_vector_samples(by_vertex, V)
    assert np.array_equal(a.where, IDX) and np.allclose(a.vectors, ARROWS) and a.name == "v"
    P = V[IDX] * 1.01  # a little off the surface: kept as given, for the vector fill to locate
    by_position = _csv(tmp_path / "p.csv", ["x", "y", "z", "VX", "VY", "VZ"], np.column_stack([P, ARROWS]))
    b = read_vector_samples(by_position, V)
    assert np.allclose(b.where, P) and np.allclose(b.vectors, ARROWS)
    shuffled = _csv(tmp_path / "s.csv", ["vertex", "vz", "vx", "vy"], np.column_stack([IDX, ARROWS[:, [2, 0, 1]]]))
    assert np.allclose(read_vector_samples(shuffled, V).vectors, ARROWS)  # by name, not by place


def test_arrows_from_npz_and_structured_npy(tmp_path):
    np.savez(tmp_path / "a.npz", idx=IDX, vectors=ARROWS)
    a = read_vector_samples(tmp_path / "a.npz", V)
    assert np.array_equal(a.where, IDX) and np.allclose(a.vectors, ARROWS)
    rec = np.zeros(len(IDX), dtype=[("vertex", "i8"), ("vx", "f8"), ("vy", "f8"), ("vz", "f8")])
    rec["vertex"], rec["vx"], rec["vy"], rec["vz"] = IDX, *ARROWS.T
    np.save(tmp_path / "s.npy", rec)
    assert np.allclose(read_vector_samples(tmp_path / "s.npy", V).vectors, ARROWS)
    np.savez(tmp_path / "flat.npz", idx=IDX, vectors=ARROWS[:, :2])
    with pytest.raises(ReadError, match=r"'vectors' has shape \(\d+, 2\); pass one 3-vector"):
        read_vector_samples(tmp_path / "flat.npz", V)


def test_a_table_missing_vz_or_mixing_values_is_refused_naming_the_column(tmp_path):
    two = _csv(tmp_path / "two.csv", ["vertex", "vx", "vy"], np.column_stack([IDX, ARROWS[:, :2]]))
    with pytest.raises(SampleError, match=r"^two.csv: columns vx, vy but no vz; add the vz column") as e:
        holds_vectors(two)
    assert "\n" not in str(e.value)
    with pytest.raises(SampleError, match="temp beside the arrows"):
        vector_columns(["vx", "vy", "vz", "temp"], "m.csv")
    scalar = _csv(tmp_path / "t.csv", ["vertex", "t"], np.column_stack([IDX, IDX * 1.0]))
    assert not holds_vectors(scalar) and vector_columns(["t"]) is None
    with pytest.raises(SampleError, match="no arrows"):
        read_vector_samples(scalar, V)


# ---------------------------------------------------------------------------
# the globe's wind
# ---------------------------------------------------------------------------


def _stations(k=200, seed=1):
    rng = np.random.default_rng(seed)
    lon = rng.uniform(-180, 180, k)
    lat = np.degrees(np.arcsin(rng.uniform(-1, 1, k)))  # uniform on the sphere
    return lon, lat


def test_east_and_north_are_an_orthonormal_tangent_frame():
    from manifill.adapters.globe import lonlat_to_xyz
    from manifill.adapters.globe_vectors import east_north

    lon, lat = _stations(50)
    e, n = east_north(lon, lat)
    P = lonlat_to_xyz(lon, lat)
    assert np.allclose(np.sum(e * P, axis=1), 0) and np.allclose(np.sum(n * P, axis=1), 0)
    assert np.allclose(np.sum(e * n, axis=1), 0) and np.allclose(np.linalg.norm(e, axis=1), 1)
    assert np.allclose(np.cross(e, n), P)  # east, north, up: right-handed


def test_a_solid_body_rotation_is_recovered_on_the_grid(tmp_path):
    pd = pytest.importorskip("pandas")
    xr = pytest.importorskip("xarray")
    from manifill.adapters.globe_vectors import reconstruct_globe_vectors

    lon, lat = _stations()
    df = pd.DataFrame({"lon": lon, "lat": lat, "u": np.cos(np.radians(lat)), "v": 0.0})
    ds = reconstruct_globe_vectors(df, grid=10.0)
    assert set(ds.data_vars) == {"eastward_wind", "northward_wind"} and ds["eastward_wind"].dims == ("lat", "lon")
    u, v = ds["eastward_wind"].values, ds["northward_wind"].values
    want = np.cos(np.radians(ds.lat.values))[:, None]
    assert np.abs(u - want).max() < 0.02 and np.abs(v).max() < 0.02  # measured: 0.006 and 0.003
    assert ds["eastward_wind"].attrs["standard_name"] == "eastward_wind"
    assert ds["northward_wind"].attrs["standard_name"] == "northward_wind"
    # the poles are no special place: the rotation's speed goes to 0 there, in every direction
    assert np.abs(u[[0, -1]]).max() < 0.02
    pytest.importorskip("netCDF4")
    from manifill.adapters.globe import write_netcdf

    back = xr.open_dataset(write_netcdf(ds, tmp_path / "w.nc"))
    assert np.allclose(back["eastward_wind"].values, u) and back.attrs["Conventions"] == "CF-1.8"


def test_other_components_time_steps_and_a_dataset():
    xr = pytest.importorskip("xarray")
    from manifill.adapters.globe_vectors import reconstruct_globe_vectors

    lon, lat = _stations(120, seed=2)
    speed = np.cos(np.radians(lat))[:, None] * np.array([[1.0, -2.0]])  # two steps: the rotation, reversed twice
    ds = xr.Dataset({"ucur": (("station", "time"), speed, {"units": "m s-1"}),
                     "vcur": (("station", "time"), np.zeros_like(speed), {"units": "m s-1"})},
                    coords={"lon": ("station", lon), "lat": ("station", lat), "time": [0.0, 6.0]})
    out = reconstruct_globe_vectors(ds, east="ucur", north="vcur", grid=15.0, bounds=False)  # options passed on
    east = out["eastward_ucur_vcur"]
    assert east.dims == ("time", "lat", "lon") and east.attrs["units"] == "m s-1"
    assert "standard_name" not in east.attrs and east.attrs["long_name"] == "eastward component of ucur_vcur"
    assert np.allclose(east.values[1], -2 * east.values[0], atol=1e-9)  # linear in the arrows (without bounds)


# ---------------------------------------------------------------------------
# pictures
# ---------------------------------------------------------------------------


def test_thinned_arrows_are_few_and_cover_the_surface():
    from scipy.spatial import cKDTree

    from manifill.viz.arrows import MAX_ARROWS, thin_points

    P = icosphere(5)[0]  # 10,242 vertices
    at, h = thin_points(P, MAX_ARROWS)
    assert 0.6 * MAX_ARROWS <= len(at) <= MAX_ARROWS and len(np.unique(at)) == len(at)
    far = cKDTree(P[at]).query(P)[0].max()  # every vertex near an arrow: none left bare
    assert far < 1.8 * h
    assert np.array_equal(thin_points(P[:100], 500)[0], np.arange(100))  # few points: all of them


def test_the_viewer_holds_tangent_arrows(tmp_path, result):
    from manifill.viz.viewer import embedded_arrays, write_vectors_html

    write_vectors_html(tmp_path / "v.html", result, count=50)
    a = embedded_arrays(tmp_path / "v.html")
    seg = a["arrows"]
    assert seg.shape[1:] == (2, 3) and 50 <= len(seg) <= 3 * 50  # a shaft and two barbs an arrow
    d = seg[:, 1] - seg[:, 0]
    mid = seg.mean(axis=1)
    radial = np.abs(np.sum(d * mid, axis=1)) / np.linalg.norm(d, axis=1) / np.linalg.norm(mid, axis=1)
    assert np.median(radial) < 0.1  # in the tangent plane (up to the sphere's curvature over an arrow)
    assert list(a["fields"]) == ["value_magnitude"]


def test_a_vector_picture_has_arrows_over_the_magnitude(tmp_path, result):
    pytest.importorskip("pyvista")
    from manifill.viz.render import render_vectors

    render_vectors(result, tmp_path / "with.png", size=(320, 260))
    render_vectors(result, tmp_path / "without.png", size=(320, 260), count=0, samples=False)
    a, b = png(tmp_path / "with.png"), png(tmp_path / "without.png")
    dark = (a.sum(axis=2) < 120) & (b.sum(axis=2) > 200)  # black arrows where the surface was coloured
    assert dark.sum() > 200
    with pytest.raises(Exception, match="not one of the vector fields"):
        render_vectors(result, tmp_path / "x.png", field="nope")
