"""
Weather stations on the globe, to a netCDF grid
===============================================

Station measurements come as a table: a longitude, a latitude and a value per station.
:func:`manifill.adapters.globe.reconstruct_globe` places them on a unit sphere, reconstructs the field *along the
sphere* (never through it, and with no seam at the date line or singularity at the poles) and resamples it to a
regular longitude/latitude grid as an ``xarray.DataArray`` with CF attributes;
:func:`~manifill.adapters.globe.write_netcdf` writes it. The stations here are synthetic: 300 of them, measuring a
made-up temperature field that is known everywhere, so the map can be checked. The far south has only eight
stations, and the map is least accurate there.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import xarray as xr

from manifill.adapters.globe import reconstruct_globe, write_netcdf

# %%
# A table of stations
# -------------------


def temperature(lon, lat):
    """A made-up temperature (deg C): warm tropics, cold poles, and a few weather systems."""
    lon, lat = np.radians(lon), np.radians(lat)
    return (32 * np.cos(lat) ** 2 - 12 + 4 * np.sin(lat)
            + 6 * np.cos(lat) * np.sin(3 * lon + 1.0) * np.sin(2 * lat + 0.3)
            + 5 * np.exp(-((lon - 1.2) ** 2 + (lat - 0.7) ** 2) / 0.05))


rng = np.random.default_rng(4)
lon = rng.uniform(-180, 180, 300)
lat = np.degrees(np.arcsin(rng.uniform(-0.8, 0.98, 300)))  # uniform on the sphere north of 53 deg S ...
lat[:8] = rng.uniform(-88, -62, 8)  # ... and only eight stations farther south
stations = pd.DataFrame({"station": [f"ST{i:03d}" for i in range(300)], "lon": lon, "lat": lat})
stations["temp"] = temperature(stations.lon, stations.lat) + rng.normal(0, 0.3, len(stations))
print(stations.head())

# %%
# Reconstruct to a 2.5-degree grid and write a netCDF file
# --------------------------------------------------------
# ``var`` names the value column; the text column ``station`` is left out. The default method is the biharmonic
# fill kept within the stations' range.

out = Path(tempfile.mkdtemp()) / "temp.nc"
grid = reconstruct_globe(stations, var="temp", grid=2.5)
grid.attrs["units"] = "degC"
write_netcdf(grid, out)

ds = xr.open_dataset(out)  # read back, as any netCDF tool would
print(ds)
field = ds["temp"].load()
ds.close()

truth = temperature(*np.meshgrid(field.lon, field.lat))
err = field.values - truth
print(f"grid {field.shape}: RMS error {np.sqrt(np.mean(err ** 2)):.2f} deg C, largest {np.abs(err).max():.1f}")

# %%
# The map
# -------
# The reconstructed grid as a plain longitude/latitude plot, the stations on top in the same colours (a station
# whose dot stands out from its background would mark a misfit; at the stations the fit is exact).

vmin, vmax = np.floor(stations.temp.min()), np.ceil(stations.temp.max())
fig, axes = plt.subplots(2, 1, figsize=(9, 8.5), layout="constrained")
ax = axes[0]
mesh = ax.pcolormesh(field.lon, field.lat, field, cmap="RdYlBu_r", vmin=vmin, vmax=vmax, shading="nearest")
ax.scatter(stations.lon, stations.lat, c=stations.temp, cmap="RdYlBu_r", vmin=vmin, vmax=vmax, s=22,
           edgecolors="black", linewidths=0.6, label="stations")
fig.colorbar(mesh, ax=ax, label="temperature (°C)")
ax.set_title(f"reconstructed from {len(stations)} stations (netCDF grid, 2.5°)")
ax.legend(loc="lower left")

ax = axes[1]
lim = np.ceil(np.abs(err).max())
mesh = ax.pcolormesh(field.lon, field.lat, err, cmap="PuOr_r", vmin=-lim, vmax=lim, shading="nearest")
ax.plot(stations.lon, stations.lat, "k.", ms=3)
fig.colorbar(mesh, ax=ax, label="reconstructed - true (°C)")
ax.set_title("error: largest far from the stations (8 stations south of 53°S)")
for ax in axes:
    ax.set_xlabel("longitude (°E)")
    ax.set_ylabel("latitude (°N)")
    ax.set_xlim(-180, 180)
    ax.set_ylim(-90, 90)
    ax.set_aspect("equal")
plt.show()
