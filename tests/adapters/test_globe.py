"""Stations by longitude and latitude to a field on the sphere and a CF lon/lat grid (real pandas and xarray)."""

import numpy as np
import pytest

xr = pytest.importorskip("xarray", reason="the [xarray] extra (xarray) is not installed")
pd = pytest.importorskip("pandas", reason="the [xarray] extra (pandas) is not installed")

import manifill  # noqa: E402
from manifill.adapters.globe import (globe_mesh, lonlat_to_xyz, reconstruct_globe, write_netcdf,  # noqa: E402
                                     xyz_to_lonlat)
from manifill.errors import OptionError, SampleError  # noqa: E402

RNG = np.random.default_rng(0)
K = 300
LON = RNG.uniform(-180, 180, K)
LAT = np.degrees(np.arcsin(RNG.uniform(-1, 1, K)))


def field(P, t=0.0):
    return np.sin(2 * P[:, 0] + 0.1 * t) + P[:, 1] * P[:, 2]


def test_lon_lat_round_trip_and_the_mesh_for_a_resolution():
    lon, lat = xyz_to_lonlat(lonlat_to_xyz(LON, LAT))
    assert np.allclose(lon, LON) and np.allclose(lat, LAT)
    V, F = globe_mesh(5.0)
    assert len(V) == 2562 and np.allclose(np.linalg.norm(V, axis=1), 1.0)
    assert len(globe_mesh(1.0)[0]) == 40962


def test_a_dataset_with_time_to_a_cf_grid_and_netcdf(tmp_path):
    T = 4
    P = lonlat_to_xyz(LON, LAT)
    vals = np.column_stack([field(P, t) for t in range(T)])
    ds = xr.Dataset({"temp": (("station", "time"), vals, {"units": "K"})},
                    coords={"lon": ("station", LON), "lat": ("station", LAT),
                            "time": pd.date_range("2026-01-01", periods=T)})
    da = reconstruct_globe(ds, var="temp", grid=5.0, mesh=globe_mesh(5.0), method="biharmonic")
    assert da.dims == ("time", "lat", "lon") and da.shape == (T, 37, 72)
    assert da.lat.attrs["units"] == "degrees_north" and da.lon.attrs["standard_name"] == "longitude"
    assert da.attrs["units"] == "K" and da.attrs["Conventions"] == "CF-1.8"
    # the same numbers as the library on the same sphere, read at the grid's points
    V, F = globe_mesh(5.0)
    r = manifill.reconstruct(V, F, P, vals, method="biharmonic", solver="direct")
    Lo, La = np.meshgrid(da.lon.values, da.lat.values)
    want = r.at(lonlat_to_xyz(Lo.ravel(), La.ravel()), max_distance=0.1)
    assert np.allclose(da.values.reshape(T, -1).T, want, atol=1e-10)
    pytest.importorskip("netCDF4", reason="the [xarray] extra (netCDF4) is not installed")
    write_netcdf(da, tmp_path / "t.nc")
    back = xr.open_dataset(tmp_path / "t.nc")
    assert back.attrs["Conventions"] == "CF-1.8" and "300 stations" in back.attrs["source"]
    assert back["temp"].dims == ("time", "lat", "lon") and back.lat.attrs["standard_name"] == "latitude"
    assert np.allclose(back["temp"].values, da.values) and str(back.time.values[0])[:10] == "2026-01-01"


def test_a_dataframe_to_the_vertices_with_the_gp_s_std():
    df = pd.DataFrame({"lon": LON, "lat": LAT, "ozone": field(lonlat_to_xyz(LON, LAT))})
    out = reconstruct_globe(df, grid=None, mesh=globe_mesh(8.0), method="gp", std=True)
    V = globe_mesh(8.0)[0]
    assert out["ozone"].dims == ("vertex",) and out["ozone_std"].shape == (len(V),)
    assert np.allclose(out.lon.values, xyz_to_lonlat(V)[0])
    r = manifill.reconstruct(V, globe_mesh(8.0)[1], lonlat_to_xyz(LON, LAT), df["ozone"].to_numpy(), method="gp",
                             solver="direct")
    assert np.allclose(out["ozone_std"].values, r.std, atol=1e-9) and np.allclose(out["ozone"].values, r.values)


def test_the_grid_is_as_accurate_as_the_vertices():
    """A smooth field from 300 stations: the 2-degree grid's error within 1.1x the sphere vertices' (the sphere the
    grid was made on: as fine as the grid, and finer until the stations are apart, to edges of a degree)."""
    P = lonlat_to_xyz(LON, LAT)
    df = pd.DataFrame({"lon": LON, "lat": LAT, "v": field(P)})
    grid = reconstruct_globe(df, grid=2.0)
    Lo, La = np.meshgrid(grid.lon.values, grid.lat.values)
    e_grid = np.sqrt(np.mean((grid.values.ravel() - field(lonlat_to_xyz(Lo.ravel(), La.ravel()))) ** 2))
    assert grid.attrs["history"].endswith(": reconstructed on a sphere of 40,962 vertices")  # refined from 10,242
    V = globe_mesh(1.0)[0]
    verts = reconstruct_globe(df, grid=None)
    e_vert = np.sqrt(np.mean((verts.values - field(V)) ** 2))
    assert e_grid <= 1.1 * e_vert, (e_grid, e_vert)


def test_bad_stations_are_one_line():
    with pytest.raises(SampleError, match="latitude"):
        reconstruct_globe(pd.DataFrame({"lon": [0.0, 10.0], "lat": [95.0, 0.0], "v": [1.0, 2.0]}))
    with pytest.raises(OptionError, match="no column 'lon'"):
        reconstruct_globe(pd.DataFrame({"x": [0.0], "lat": [0.0], "v": [1.0]}))
    with pytest.raises(OptionError, match="pass var="):
        reconstruct_globe(xr.Dataset({"a": ("station", [1.0]), "b": ("station", [2.0])},
                                     coords={"lon": ("station", [0.0]), "lat": ("station", [0.0])}))


def test_missing_observations_leave_a_station_out_of_those_steps():
    """Station data have gaps (NaN): each step is reconstructed from the stations that reported, the steps with the
    same stations sharing one factorisation; (time, station) order works as (station, time)."""
    P = lonlat_to_xyz(LON, LAT)
    vals = np.column_stack([field(P, t) for t in range(3)])
    vals[5, 1] = vals[17, 1] = np.nan
    ds = xr.Dataset({"v": (("time", "station"), vals.T)}, coords={"lon": ("station", LON), "lat": ("station", LAT),
                                                                  "time": np.arange(3)})
    da = reconstruct_globe(ds, var="v", grid=None, mesh=globe_mesh(8.0))
    V, F = globe_mesh(8.0)
    keep = np.isfinite(vals[:, 1])
    want = manifill.reconstruct(V, F, P[keep], vals[keep, 1], solver="direct").values  # the default, as the globe's
    assert np.allclose(da.isel(time=1).values, want, atol=1e-10)
    full = manifill.reconstruct(V, F, P, vals[:, 0], solver="direct").values
    assert np.allclose(da.isel(time=0).values, full, atol=1e-10)


def test_times_grids_radii_and_crowded_stations():
    """The time coordinate keeps its name and attributes; grid coordinates are exact multiples and a spacing that
    does not divide 180 is refused; a sphere of Earth's radius works; on the caller's sphere 50 stations crowded in a
    20 x 10 degree box (more in a triangle than its corners hold apart) fall back to their nearest vertices."""
    P = lonlat_to_xyz(LON, LAT)
    t = xr.DataArray(np.array([0.0, 6.0]), dims="valid_time", attrs={"units": "hours since 2020-01-01",
                                                                     "standard_name": "time"})
    ds = xr.Dataset({"v": (("station", "valid_time"), np.column_stack([field(P), field(P, 1)]))},
                    coords={"lon": ("station", LON), "lat": ("station", LAT), "valid_time": t})
    da = reconstruct_globe(ds, var="v", time="valid_time", grid=7.5)
    assert da.dims[0] == "valid_time" and da.valid_time.attrs["units"] == "hours since 2020-01-01"
    fine = reconstruct_globe(ds.isel(valid_time=[0]), var="v", time="valid_time", grid=0.25, mesh=globe_mesh(8.0))
    assert 10.25 in fine.lon.values and fine.lat.values[-1] == 90.0 and fine.sizes["lon"] == 1440
    with pytest.raises(OptionError, match="does not divide 180"):
        reconstruct_globe(ds, var="v", time="valid_time", grid=7.0)
    V, F = globe_mesh(8.0)
    earth = reconstruct_globe(ds.isel(valid_time=[0]), var="v", time="valid_time", grid=7.5, mesh=(V * 6371.0, F))
    unit = reconstruct_globe(ds.isel(valid_time=[0]), var="v", time="valid_time", grid=7.5, mesh=(V, F))
    assert np.allclose(earth.values, unit.values, atol=1e-9)
    rng = np.random.default_rng(1)
    lon = np.r_[LON, rng.uniform(0, 20, 50)]
    lat = np.r_[LAT, rng.uniform(45, 55, 50)]
    crowded = pd.DataFrame({"lon": lon, "lat": lat, "v": field(lonlat_to_xyz(lon, lat))})
    out = reconstruct_globe(crowded, grid=5.0, smoothing=1e-6, mesh=globe_mesh(5.0))  # the caller's sphere: kept
    assert np.isfinite(out.values).all()


def test_the_command_line_writes_a_cf_netcdf(tmp_path, capsys):
    from conftest import assert_usage_error, files, run

    pytest.importorskip("netCDF4", reason="the [xarray] extra (netCDF4) is not installed")
    df = pd.DataFrame({"lon": LON, "lat": LAT, "name": [f"s{i}" for i in range(K)],
                       "temp": field(lonlat_to_xyz(LON, LAT))})
    df.to_csv(tmp_path / "st.csv", index=False)
    code, out, err = run(capsys, "globe", tmp_path / "st.csv", "-o", tmp_path / "t.nc", "--grid", "5")
    assert code == 0, err
    back = xr.open_dataset(tmp_path / "t.nc")
    want = reconstruct_globe(df, var="temp", grid=5.0)
    assert back.attrs["Conventions"] == "CF-1.8" and np.allclose(back["temp"].values, want.values)
    before = files(tmp_path)
    code, out, err = run(capsys, "globe", tmp_path / "st.csv", "-o", tmp_path / "t.txt")
    assert "netCDF" in assert_usage_error(code, out, err) and files(tmp_path) == before
    code, out, err = run(capsys, "globe", tmp_path / "st.csv", "-o", tmp_path / "u.nc", "--grid", "7")
    assert "does not divide 180" in assert_usage_error(code, out, err) and files(tmp_path) == before


def test_damaged_station_tables_are_one_line():
    with pytest.raises(SampleError, match="not a number"):
        reconstruct_globe(pd.DataFrame({"lon": ["1", "abc", "3"], "lat": [0.0, 1.0, 2.0], "v": [1.0, 2.0, 3.0]}))
    with pytest.raises(SampleError, match="no step has three stations"):
        reconstruct_globe(pd.DataFrame({"lon": [0.0, 10.0], "lat": [0.0, 5.0], "v": [1.0, np.nan]}))
