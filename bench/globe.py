"""Stations on the globe to a 1-degree grid netCDF: time and accuracy (issue 29's xarray target).

``python -m bench.globe [--stations 500] [--days 365] [--grid 1.0]``: stations uniform on the sphere, a smooth field
drifting day by day, ``manifill.adapters.globe.reconstruct_globe`` (biharmonic) to a CF lon/lat grid, written with
``write_netcdf`` (xarray's ``to_netcdf``, CF's global attributes) and opened again by xarray; the error on the
grid beside the same method's on the mesh's vertices.
"""

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from manifill.adapters.globe import globe_mesh, lonlat_to_xyz, reconstruct_globe, write_netcdf


def field(P, t):
    return np.sin(2 * P[:, 0] + 0.01 * t) + P[:, 1] * P[:, 2]


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--stations", type=int, default=500)
    p.add_argument("--days", type=int, default=365)
    p.add_argument("--grid", type=float, default=1.0)
    a = p.parse_args(argv)
    rng = np.random.default_rng(0)
    lon = rng.uniform(-180, 180, a.stations)
    lat = np.degrees(np.arcsin(rng.uniform(-1, 1, a.stations)))
    P = lonlat_to_xyz(lon, lat)
    vals = np.column_stack([field(P, t) for t in range(a.days)])
    ds = xr.Dataset({"temp": (("station", "time"), vals, {"units": "K"})},
                    coords={"lon": ("station", lon), "lat": ("station", lat),
                            "time": pd.date_range("2026-01-01", periods=a.days)})
    t0 = time.perf_counter()
    da = reconstruct_globe(ds, var="temp", grid=a.grid)
    t1 = time.perf_counter()
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "temp.nc"
        write_netcdf(da, path)
        t2 = time.perf_counter()
        back = xr.open_dataset(path)
        cf = back.lat.attrs.get("standard_name"), back.lon.attrs.get("units"), back.attrs.get("Conventions")
        size = path.stat().st_size
        back.close()
    Lo, La = np.meshgrid(da.lon.values, da.lat.values)
    Q = lonlat_to_xyz(Lo.ravel(), La.ravel())
    days = [0, a.days // 2, a.days - 1]
    e_grid = np.sqrt(np.mean([(da.isel(time=t).values.ravel() - field(Q, t)) ** 2 for t in days]))
    V = globe_mesh(a.grid)[0]
    verts = reconstruct_globe(ds.isel(time=days), var="temp", grid=None)
    e_vert = np.sqrt(np.mean([(verts.isel(time=i).values - field(V, t)) ** 2 for i, t in enumerate(days)]))
    print(f"{a.stations} stations x {a.days} days -> {da.sizes['lat']} x {da.sizes['lon']} grid on a {len(V):,}-vertex "
          f"sphere: reconstruct and resample {t1 - t0:.1f} s, to_netcdf {t2 - t1:.1f} s ({size / 2**20:.0f} MiB); "
          f"xarray reads back CF {cf}")
    print(f"error on the grid {e_grid:.3g}, on the vertices {e_vert:.3g}: {e_grid / e_vert:.3f}x (days {days})")


if __name__ == "__main__":
    main()
