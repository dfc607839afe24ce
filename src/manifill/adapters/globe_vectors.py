"""Winds and currents on the globe: stations' eastward and northward components (``u``, ``v``) to a tangent vector
field on the sphere, and back to eastward and northward components on a regular lon/lat grid (CF: ``eastward_wind``,
``northward_wind``).

Each station's arrow is ``u e + v n`` with the unit east and north vectors at its longitude and latitude
(:func:`east_north`: ``e = (-sin lon, cos lon, 0)``, ``n = (-sin lat cos lon, -sin lat sin lon, cos lat)``), tangent
to the sphere there; :func:`manifill.vectors.reconstruct.reconstruct_vectors` fills the tangent field on the
globe's icosphere (no pole is special: the components of a field are never interpolated apart, which breaks at
the poles), and each grid point's vector, interpolated linearly on the face of the sphere it falls in, is read back
as its eastward and northward parts. The stations are a pandas ``DataFrame`` (``lon``, ``lat``, ``u``, ``v``
columns, and optionally ``time``: one row per station and time) or an xarray ``Dataset`` (a ``station``
dimension, ``u`` and ``v`` along it and optionally ``time``). Needs the ``[xarray]`` extra.
"""

import datetime
import math
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from ..errors import OptionError, ReadError, SampleError, WriteError
from ..io.formats import find_format
from ..memory import check_fits
from ..mesh.shapes import icosphere
from ..surface.locate import locate_points
from ..vectors.reconstruct import VectorReconstructor
from .globe import (EDGE_DEGREES, GLOBE_BYTES_PER_VALUE, GLOBE_BYTES_PER_VERTEX, lonlat_to_xyz, write_netcdf,
                    xyz_to_lonlat)
from .globe_tables import check_names, table_stations

__all__ = ["east_north", "reconstruct_globe_vectors", "holds_components", "globe_vectors_file"]

#: The CF standard names of the wind's components, for the columns ``u`` and ``v``.
WIND = ("u", "v")
LAT_ATTRS = {"standard_name": "latitude", "long_name": "latitude", "units": "degrees_north", "axis": "Y"}
LON_ATTRS = {"standard_name": "longitude", "long_name": "longitude", "units": "degrees_east", "axis": "X"}


def east_north(lon, lat):
    """The unit east and north vectors at longitudes and latitudes in degrees: two ``(k, 3)`` arrays.

    Examples
    --------
    >>> e, n = east_north([0.0], [0.0])
    >>> e.tolist(), n.tolist()
    ([[-0.0, 1.0, 0.0]], [[-0.0, -0.0, 1.0]])
    """
    lo, la = np.radians(np.asarray(lon, dtype=np.float64)), np.radians(np.asarray(lat, dtype=np.float64))
    east = np.column_stack([-np.sin(lo), np.cos(lo), np.zeros_like(lo)])
    north = np.column_stack([-np.sin(la) * np.cos(lo), -np.sin(la) * np.sin(lo), np.cos(la)])
    return east, north


def _components(data, east, north, lon, lat, station, time):
    """``(lon, lat, U (k, T), V (k, T), times or None, attrs of u, attrs of v)`` of a DataFrame or a Dataset."""
    if hasattr(data, "data_vars"):
        return _dataset_components(data, east, north, lon, lat, station, time)
    if not hasattr(data, "columns"):
        raise OptionError(f"stations are a pandas DataFrame or an xarray Dataset, not {type(data).__name__}")
    lo, la, U, times, _, _ = table_stations(data, east, lon, lat, station, time)
    _, _, Vn, _, _, _ = table_stations(data, north, lon, lat, station, time)  # the same stations, in order
    return lo, la, U, Vn, times, {}, {}


def _dataset_components(data, east, north, lon, lat, station, time):
    out, times = [], None
    for var in (east, north):
        check_names("variable", data.variables, data.data_vars, var, lon, lat)
        da = data[var]
        extra = [d for d in da.dims if d not in (station, time)]
        if station not in da.dims or extra:
            raise OptionError(f"{var} has dimensions {da.dims}; pass one along {station!r} (and {time!r})")
        times = da[time] if time in da.dims else None
        vals = da.transpose(station, *([time] if times is not None else [])).values.astype(np.float64)
        out.append((vals.reshape(da.sizes[station], -1), dict(da.attrs)))
    lons, lats = np.asarray(data[lon].values, dtype=np.float64), np.asarray(data[lat].values, dtype=np.float64)
    if lons.shape != (len(out[0][0]),) or lats.shape != lons.shape:
        raise SampleError(f"{lon!r} and {lat!r} have shapes {lons.shape} and {lats.shape}; each needs one value "
                          f"per station, along {station!r}")
    return lons, lats, out[0][0], out[1][0], times, out[0][1], out[1][1]


def _sphere(grid):
    """The icosphere whose edges are about the grid's spacing (stations sharing a nearest vertex are merged,
    :func:`_merge`, rather than the sphere refined: the vector fill's setup grows fast with its size)."""
    level = max(0, math.ceil(math.log2(EDGE_DEGREES / grid)))
    n = 10 * 4 ** level + 2
    cells = int(round(180.0 / grid) + 1) * int(round(360.0 / grid))
    check_fits(n * GLOBE_BYTES_PER_VERTEX * 2 + (n + cells) * GLOBE_BYTES_PER_VALUE * 6,
               f"the globe at {grid:g} degrees (a sphere of {n:,} vertices)", "pass a coarser grid (CLI: --grid)")
    return icosphere(level)


def _merge(V, P, X):
    """Stations sharing a nearest vertex merged into one at their mean position (on the sphere), with their mean
    arrow (their tangent planes differ by less than an edge's angle); ``(P, X, how many merged)``."""
    groups, inv = np.unique(cKDTree(V).query(P)[1], return_inverse=True)
    inv = np.ravel(inv)
    if groups.size == len(P):
        return P, X, 0
    count = np.bincount(inv)
    Pm = np.zeros((groups.size, 3))
    np.add.at(Pm, inv, P)
    Xm = np.zeros((groups.size,) + X.shape[1:])
    np.add.at(Xm, inv, X)
    return Pm / np.linalg.norm(Pm, axis=1, keepdims=True), Xm / count.reshape(-1, *([1] * (X.ndim - 1))), \
        len(P) - groups.size


def _vertex_fields(V, F, P, X, options):
    """The vertex vectors ``(n, 3, T)``, steps with fewer than three stations reporting left NaN; notes."""
    finite = np.isfinite(X).all(axis=1)  # (k, T): the station reports both components at that step
    out = np.full((len(V), 3, X.shape[2]), np.nan)
    patterns, which = np.unique(finite.T, axis=0, return_inverse=True)
    empty, merged = [], 0
    for g, rows in enumerate(patterns):
        cols = np.flatnonzero(np.ravel(which) == g)
        if rows.sum() < 3:
            empty.extend(cols.tolist())
            continue
        Pg, Xg, m = _merge(V, P[rows], X[rows][:, :, cols])
        merged = max(merged, m)
        out[:, :, cols] = VectorReconstructor(V, F, Pg, **options).apply(Xg).fields()
    if len(empty) == X.shape[2]:
        raise SampleError(f"no step has three stations reporting both components (at most "
                          f"{int(finite.sum(axis=0).max())} of {len(P)}); a field needs at least three")
    notes = [f"{len(empty)} steps had fewer than three stations reporting and are left empty (NaN)"] if empty else []
    if merged:
        notes.append(f"{merged} stations shared the nearest vertex of the sphere with another and were averaged with "
                     f"it; a finer grid keeps them apart")
    return out, notes


def reconstruct_globe_vectors(data, *, east="u", north="v", name=None, lon="lon", lat="lat", station="station",
                              time="time", grid=1.0, method="biharmonic", **options):
    """Stations' eastward and northward components -> the field's components on a lon/lat grid, as an xarray
    ``Dataset`` of ``eastward_<name>`` and ``northward_<name>`` (see the module).

    Parameters
    ----------
    data : pandas.DataFrame or xarray.Dataset
    east, north : str
        The eastward and northward components' columns or variables (``u``, ``v``).
    name : str, optional
        The field's name in the output: ``wind`` for ``u, v`` (CF's ``eastward_wind``, ``northward_wind``), else
        ``<east>_<north>``.
    lon, lat, station, time : str
        The names of the longitude and latitude (degrees), station and time.
    grid : float or None
        The grid's spacing in degrees (``lat`` -90..90, ``lon`` -180..180 exclusive); None: the sphere's vertices.
    method : {'biharmonic', 'harmonic', 'gp'}, optional
        The vector method.
    **options
        Of :func:`manifill.vectors.reconstruct.reconstruct_vectors` (``smoothing``, ``bounds``, ...).

    Returns
    -------
    xarray.Dataset
        ``eastward_<name>`` and ``northward_<name>`` on ``(time,) lat, lon`` (or ``vertex``), CF attributes.

    Examples
    --------
    >>> import pandas as pd
    >>> rng = np.random.default_rng(0)
    >>> lon, lat = rng.uniform(-180, 180, 60), np.degrees(np.arcsin(rng.uniform(-1, 1, 60)))
    >>> df = pd.DataFrame({"lon": lon, "lat": lat, "u": np.cos(np.radians(lat)), "v": 0.0})
    >>> ds = reconstruct_globe_vectors(df, grid=10.0)
    >>> sorted(ds.data_vars), ds["eastward_wind"].attrs["standard_name"]
    (['eastward_wind', 'northward_wind'], 'eastward_wind')
    """
    xr = _xarray()
    lons, lats, U, Vn, times, attrs_u, attrs_v = _components(data, east, north, lon, lat, station, time)
    bad = np.flatnonzero(~(np.isfinite(lons) & np.isfinite(lats) & (np.abs(lats) <= 90)))
    if bad.size:
        raise SampleError(f"station {int(bad[0])} has longitude {float(lons[bad[0]]):g} and latitude "
                          f"{float(lats[bad[0]]):g}; pass finite degrees with latitudes in [-90, 90]")
    if grid is not None and not (isinstance(grid, (int, float)) and 0 < grid <= 60
                                 and abs(180.0 / grid - round(180.0 / grid)) < 1e-9):
        raise OptionError(f"grid={grid!r} degrees does not divide 180 (or is above 60); pass a spacing that does "
                          f"(1, 0.5, 2.5, 5, ...)")
    e, n = east_north(lons, lats)
    X = e[:, :, None] * U[:, None, :] + n[:, :, None] * Vn[:, None, :]  # (k, 3, T): NaN where a component is
    P = lonlat_to_xyz(lons, lats)
    V, F = _sphere(1.0 if grid is None else grid)
    W, notes = _vertex_fields(V, F, P, X, {"method": method, "solver": "direct", **options})
    name = name or ("wind" if (east, north) == WIND else f"{east}_{north}")
    if grid is None:
        vlon, vlat = xyz_to_lonlat(V)
        Q, dims = V, ["vertex"]
        coords = {"lon": ("vertex", vlon, LON_ATTRS), "lat": ("vertex", vlat, LAT_ATTRS)}
        G = W
    else:
        steps = int(round(180.0 / grid))
        glat = np.round(-90.0 + grid * np.arange(steps + 1), 10)
        glon = np.round(-180.0 + grid * np.arange(2 * steps), 10)
        Lo, La = np.meshgrid(glon, glat)
        Q, dims = lonlat_to_xyz(Lo.ravel(), La.ravel()), ["lat", "lon"]
        coords = {"lat": ("lat", glat, LAT_ATTRS), "lon": ("lon", glon, LON_ATTRS)}
        loc = locate_points(V, F, Q, max_distance=0.1)  # the grid's points on the sphere's faces, once for all steps
        G = np.einsum("qc,qcdt->qdt", loc.bary, W[loc.corners])  # linear on the face, then east and north of Q
    qlon, qlat = xyz_to_lonlat(Q) if grid is None else (Lo.ravel(), La.ravel())
    eq, nq = east_north(qlon, qlat)
    parts = {"eastward": np.einsum("qd,qdt->qt", eq, G), "northward": np.einsum("qd,qdt->qt", nq, G)}
    shape = [len(V)] if grid is None else [len(coords["lat"][1]), len(coords["lon"][1])]
    if times is not None:
        coords[times.name] = times
    ds = xr.Dataset(coords=coords)
    lead = [] if times is None else [times.name]
    for (way, A), attrs in zip(parts.items(), (attrs_u, attrs_v)):
        arr = A.T.reshape([A.shape[1]] + shape)
        key = f"{way}_{name}"
        ds[key] = (lead + dims, arr if lead else arr[0])
        ds[key].attrs.update(attrs)
        if (east, north) == WIND and name == "wind":  # CF's names of the wind's components
            ds[key].attrs["standard_name"] = f"{way}_wind"
        ds[key].attrs.setdefault("long_name", f"{way} component of {name}")
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    ds.attrs.update({"Conventions": "CF-1.8", "source": f"manifill {method} tangent vector field from {len(lons)} "
                                                        f"stations",
                     "history": f"{now}: manifill.reconstruct_globe_vectors: reconstructed on a sphere of "
                                f"{len(V):,} vertices"})
    if notes:
        ds.attrs["comment"] = "; ".join(notes)
    return ds


def _xarray():
    try:
        import xarray
    except ImportError:
        raise ImportError("the globe's fields need xarray: pip install 'manifill[xarray]'") from None
    return xarray


def _read(src):
    fmt = find_format("stations", src) or find_format("stations", src.with_suffix(".nc"))  # netCDF by default
    try:
        return fmt.read(src)
    except (ValueError, OSError, UnicodeDecodeError) as exc:
        raise ReadError(f"{src.name}: could not be read as stations ({str(exc).splitlines()[0][:120]}); pass a CSV "
                        f"with lon and lat columns or a netCDF with a station dimension") from None


def holds_components(stations, east="u", north="v"):
    """Whether the station file ``stations`` (CSV or netCDF) has both components' columns or variables (False when
    it is not a file: the globe's reader then says so)."""
    src = Path(stations)
    if not src.is_file():
        return False
    data = _read(src)
    names = data.data_vars if hasattr(data, "data_vars") else data.columns
    return east in names and north in names


def globe_vectors_file(stations, out, *, east="u", north="v", name=None, grid=1.0, method=None, lon="lon", lat="lat",
                       command=None, **options):
    """``manifill globe`` for stations with eastward and northward components: a netCDF of ``eastward_<name>`` and
    ``northward_<name>`` on a regular grid; returns a one-line summary.

    Parameters
    ----------
    stations, out : str or Path
        The CSV or netCDF of stations, and the ``.nc`` to write.
    east, north, name, grid, lon, lat
        As :func:`reconstruct_globe_vectors`.
    method : str, optional
        A vector method (default ``biharmonic``).
    command : str, optional
        The command line, for the file's ``history``.
    **options
        Of :func:`manifill.vectors.reconstruct.reconstruct_vectors`.
    """
    _xarray()
    src, out = Path(stations), Path(out)
    if find_format("stations", out, writing=True) is None:
        raise WriteError(f"{out.name}: the globe's field is written as netCDF; name the output OUT.nc")
    ds = reconstruct_globe_vectors(_read(src), east=east, north=north, name=name, grid=grid,
                                   method=method or "biharmonic", lon=lon, lat=lat, **options)
    if command:
        ds.attrs["history"] = ds.attrs["history"].replace("manifill.reconstruct_globe_vectors", command, 1)
    write_netcdf(ds, out)
    said = f" ({ds.attrs['comment']})" if ds.attrs.get("comment") else ""
    first = next(iter(ds.data_vars))
    return (f"wrote {out.name}: {' and '.join(ds.data_vars)} (a tangent vector field) on "
            f"{' x '.join(f'{d} {k}' for d, k in ds[first].sizes.items())}{said}")
