"""Stations on the globe, by longitude and latitude, to fields on a sphere or a regular lon/lat grid (xarray).

:func:`reconstruct_globe` takes stations as a pandas ``DataFrame`` (one row per station: ``lon``, ``lat`` and a
value column per field) or an xarray ``Dataset`` (a ``station`` dimension, ``lon``/``lat`` along it, and the
variable with or without a ``time`` dimension), places them on the unit sphere (:func:`globe_mesh`, an icosphere
as fine as the grid asked for, or your mesh), reconstructs with any manifill method -- distances along the sphere
by construction, never through it -- and gives an xarray ``DataArray`` on the mesh's vertices or resampled to a
regular grid (``grid=1.0``: every degree), with CF attributes (``latitude``/``longitude`` in degrees north/east,
``Conventions: CF-1.8``), ready for ``.to_netcdf``. One factorisation serves every time step. Needs the
``[xarray]`` extra (xarray; netCDF4 or h5netcdf for the files).
"""

from __future__ import annotations

import datetime
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial import cKDTree

from ..errors import OptionError, ReadError, SampleError, WriteError
from ..io.files import atomic_path
from ..io.formats import Format, find_format, register_format
from .globe_tables import COORDINATES, check_name, check_names, listed, table_stations
from ..mesh.shapes import icosphere
from ..version import __version__
from ..memory import check_fits
from ..surface.locate import locate_points
from ..surface.reconstructor import Reconstructor

if TYPE_CHECKING:  # the [xarray] extra: types here only
    import pandas
    import xarray


def _xarray():
    """xarray, or the extra named (imported when used: the command line loads this module)."""
    try:
        import xarray
    except ImportError:
        raise ImportError("the globe's fields need xarray: pip install 'manifill[xarray]'") from None
    return xarray

__all__ = ["globe_mesh", "lonlat_to_xyz", "xyz_to_lonlat", "reconstruct_globe", "write_netcdf", "globe_file",
           "EDGE_DEGREES"]

#: The icosphere of level k has edges of about this many degrees over 2^k.
EDGE_DEGREES = 63.43


def lonlat_to_xyz(lon: ArrayLike, lat: ArrayLike) -> np.ndarray:
    """Unit vectors of longitudes and latitudes in degrees: ``(k, 3)``.

    Parameters
    ----------
    lon, lat : (k,) array_like of float
        Degrees east and north.
    """
    lo, la = np.radians(np.asarray(lon, dtype=np.float64)), np.radians(np.asarray(lat, dtype=np.float64))
    return np.column_stack([np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)])


def xyz_to_lonlat(P: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Longitudes in ``[-180, 180)`` and latitudes of points, degrees.

    Parameters
    ----------
    P : (k, 3) array_like of float
        Points (any distance from the centre).
    """
    P = np.asarray(P, dtype=np.float64)
    lon = np.degrees(np.arctan2(P[:, 1], P[:, 0]))
    lat = np.degrees(np.arcsin(np.clip(P[:, 2] / np.linalg.norm(P, axis=1), -1.0, 1.0)))
    return np.where(lon >= 180.0, lon - 360.0, lon), lat


#: The globe's memory per vertex of its sphere (the default biharmonic measured 2,700 bytes at 2.6M vertices)
#: and per vertex or grid cell and step (the fields, their interpolation and the netCDF's array).
GLOBE_BYTES_PER_VERTEX = 3000
GLOBE_BYTES_PER_VALUE = 32


def _level(resolution):
    return max(0, math.ceil(math.log2(EDGE_DEGREES / resolution)))


def _check_globe_fits(grid, level, steps, std):
    """Refuse, before the sphere is built, a grid whose sphere and fields will not fit in memory."""
    spacing = 1.0 if grid is None else grid
    n = 10 * 4 ** level + 2
    cells = 0 if grid is None else int(round(180.0 / grid) + 1) * int(round(360.0 / grid))
    need = n * GLOBE_BYTES_PER_VERTEX + (n + cells) * GLOBE_BYTES_PER_VALUE * steps * (2 if std else 1)
    check_fits(need, f"the globe at {spacing:g} degrees (a sphere of {n:,} vertices and a grid of {cells:,} cells, "
               f"{steps} step(s))", "pass a coarser grid (CLI: --grid)")


#: The finest sphere the stations may ask for beyond the grid's (level 6: edges of about 1 degree, 40,962 vertices).
STATION_LEVEL = 6


def _globe_level(grid, lons, lats):
    """``(level, sphere or None)``: the sphere's level, as fine as the grid asks and finer (up to
    :data:`STATION_LEVEL`) until no two stations share a nearest vertex -- two stations in one triangle of a coarse
    sphere make the field between them as steep as their difference over their distance, far beyond their values
    (stations nearer than that are merged) -- and that sphere where the search built it (small: level 6 at most)."""
    level = _level(_resolution(1.0 if grid is None else grid))
    P = lonlat_to_xyz(lons, lats)
    distinct = np.unique(np.round(P, 12), axis=0).shape[0]
    while level <= STATION_LEVEL:
        sphere = icosphere(level)
        if level == STATION_LEVEL or np.unique(cKDTree(sphere[0]).query(P)[1]).size == distinct:
            return level, sphere
        level += 1
    return level, None


def globe_mesh(resolution: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """The unit icosphere whose edges are at most about ``resolution`` degrees (level 6 for 1 degree: 40,962 vertices).

    Parameters
    ----------
    resolution : float, optional
        The largest edge, in degrees of arc.

    Examples
    --------
    >>> V, F = globe_mesh(5.0)
    >>> len(V)
    2562
    """
    return icosphere(_level(_resolution(resolution)))


def _resolution(resolution):
    """A sphere's resolution in degrees, checked."""
    if not (isinstance(resolution, (int, float)) and 0.05 <= resolution <= 60):
        raise OptionError(f"resolution={resolution!r} degrees; pass a number in [0.05, 60]")
    return resolution


def _stations(data, var, lon, lat, station, time):
    """``(lon (k,), lat (k,), values (k, T), times or None, name, attrs)`` of a DataFrame or a Dataset."""
    if lon == lat:
        raise OptionError(f"lon and lat are both {lon!r}; name the longitude and the latitude apart "
                          f"(CLI: --lon, --lat)")
    if hasattr(data, "data_vars"):  # an xarray Dataset
        return _dataset_stations(data, var, lon, lat, station, time)
    if not hasattr(data, "columns"):
        raise OptionError(f"stations are a pandas DataFrame or an xarray Dataset, not {type(data).__name__}")
    return table_stations(data, var, lon, lat, station, time)


def _dataset_stations(data, var, lon, lat, station, time):
    check_names("variable", data.variables, data.data_vars, var, lon, lat)
    names = [v for v in data.data_vars if v not in (lon, lat)] if var is None else [var]
    if len(names) != 1:
        raise OptionError(f"the stations have {len(names)} variables ({listed(names)}); pass var= one of them "
                          f"(CLI: --var)")
    da = data[names[0]]
    if station not in da.dims:
        raise OptionError(f"{names[0]} has dimensions {da.dims}, no {station!r}; pass station= its station "
                          f"dimension")
    extra = [d for d in da.dims if d not in (station, time)]
    if extra:
        raise OptionError(f"{names[0]} has dimensions {extra} besides {station!r} and {time!r}; select them away")
    times = da[time] if time in da.dims else None  # the coordinate itself: its name, attrs and encoding
    lons, lats = data[lon].values, data[lat].values
    for what, a in ((names[0], da), (lon, lons), (lat, lats)):
        kind = np.asarray(a).dtype.kind
        if kind not in "iufb":
            raise SampleError(f"the stations' {what!r} holds {_KINDS.get(kind, 'non-numeric')} values, not numbers; "
                              f"pass a numeric variable (var=, CLI: --var)")
    if lons.shape != (da.sizes[station],) or lats.shape != lons.shape:
        raise SampleError(f"{lon!r} and {lat!r} have shapes {lons.shape} and {lats.shape}; each needs one value "
                          f"per station ({da.sizes[station]}), along {station!r}")
    check_name(str(names[0]), var)
    if times is not None and times.name in COORDINATES:
        raise OptionError(f"the time dimension {times.name!r} would share its name with the output's coordinate; "
                          f"rename it")
    values = da.transpose(station, *([time] if times is not None else [])).values.astype(np.float64)
    return lons, lats, values.reshape(len(lons), -1), times, str(names[0]), dict(da.attrs)


_KINDS = {"U": "text", "S": "text", "O": "text", "M": "date", "m": "time-interval", "c": "complex"}


def reconstruct_globe(data: pandas.DataFrame | xarray.Dataset, *, var: str | None = None, lon: str = "lon",
                      lat: str = "lat", station: str = "station", time: str = "time", grid: float | None = 1.0,
                      mesh: tuple[ArrayLike, ArrayLike] | None = None, method: str | None = None, std: bool = False,
                      **options: Any) -> xarray.DataArray | xarray.Dataset:
    """Stations by longitude and latitude -> a field on the sphere, as an xarray ``DataArray`` (see the module).

    Parameters
    ----------
    data : pandas.DataFrame or xarray.Dataset
    var : str, optional
        The variable (a Dataset's) or the value column (a DataFrame's; all the other columns when None).
    lon, lat, station, time : str
        The names of the longitude and latitude (degrees), station and time.
    grid : float or None
        The output grid's spacing in degrees (``lat`` -90..90, ``lon`` -180..180 exclusive); None: the mesh's
        vertices (a ``vertex`` dimension with ``lon``/``lat`` coordinates).
    mesh : (V, F), optional
        Your sphere (unit radius, centred); by default :func:`globe_mesh` at ``grid`` (or 1 degree), refined (to
        edges of about 1 degree at most) until no two stations share a nearest vertex.
    method : str, optional
        Any method of :func:`manifill.reconstruct`; by default manifill's default (the biharmonic fill kept within
        the stations' range).
    std : bool
        Also the std (``method='gp'``, or ``uncertainty=True``): a ``Dataset`` of the field and ``<var>_std``.
    **options
        Of :func:`manifill.reconstruct`.

    Returns
    -------
    xarray.DataArray (or Dataset with ``std``)
    """
    xr = _xarray()
    lons, lats, values, times, name, attrs = _stations(data, var, lon, lat, station, time)
    bad = np.flatnonzero(~(np.isfinite(lons) & np.isfinite(lats) & (np.abs(lats) <= 90)))
    if bad.size:
        raise SampleError(f"station {int(bad[0])} has longitude {float(lons[bad[0]]):g} and latitude "
                          f"{float(lats[bad[0]]):g}; pass finite degrees with latitudes in [-90, 90]")
    if grid is not None and not (isinstance(grid, (int, float)) and grid > 0
                                 and abs(180.0 / grid - round(180.0 / grid)) < 1e-9):
        raise OptionError(f"grid={grid!r} degrees does not divide 180; pass a spacing that does (1, 0.5, 0.25, "
                          f"2.5, ...)")
    own = mesh is None  # the globe's own sphere, or the caller's (positions kept as given)
    if own:
        level, mesh = _globe_level(grid, lons, lats)
        _check_globe_fits(grid, level, values.shape[1], std)  # before a sphere finer than the search's is built
        mesh = icosphere(level) if mesh is None else mesh
    V, F = mesh  # type: ignore[misc]  # made above when None
    V = np.asarray(V, dtype=np.float64)
    R = float(np.median(np.linalg.norm(V, axis=1)))
    P = lonlat_to_xyz(lons, lats) * R
    options.setdefault("solver", "direct")  # one factorisation for every time step (AMG would iterate per step)
    options.setdefault("duplicates", "mean")  # stations at one position (or on one vertex, the fallback): averaged
    X, S, notes = _fields(V, F, P, values, method, std, options, snap=own)
    fields = attrs.pop("fields", None)
    dims_t = [times.name] if times is not None else ([] if X.shape[1] == 1 else ["field"])
    coords_t = {times.name: times} if times is not None else ({} if X.shape[1] == 1 else {"field": fields or list(
        range(X.shape[1]))})
    if grid is None:
        vlon, vlat = xyz_to_lonlat(V)
        coords = {"lon": ("vertex", vlon, _LON), "lat": ("vertex", vlat, _LAT), **coords_t}
        out = {name: (dims_t + ["vertex"], X.T.reshape(*([X.shape[1]] if dims_t else []), len(V)))}
        if S is not None:
            out[name + "_std"] = (dims_t + ["vertex"], S.T.reshape(*([S.shape[1]] if dims_t else []), len(V)))
    else:
        steps = int(round(180.0 / grid))
        glat = np.round(-90.0 + grid * np.arange(steps + 1), 10)  # exact multiples: ERA5-style grids align
        glon = np.round(-180.0 + grid * np.arange(2 * steps), 10)
        Lo, La = np.meshgrid(glon, glat)
        Q = lonlat_to_xyz(Lo.ravel(), La.ravel()) * R
        loc = locate_points(V, F, Q, max_distance=0.1 * R)  # linear on the sphere's faces, located once for all steps
        G = np.einsum("qc,qct->qt", loc.bary, X[loc.corners])
        GS = None if S is None else np.einsum("qc,qct->qt", loc.bary, S[loc.corners])
        shape = (len(glat), len(glon))
        def cube(A):
            A = np.asarray(A).reshape(len(Q), -1)
            return A.T.reshape(-1, *shape) if dims_t else A[:, 0].reshape(shape)
        coords = {"lat": ("lat", glat, _LAT), "lon": ("lon", glon, _LON), **coords_t}
        out = {name: (dims_t + ["lat", "lon"], cube(G))}
        if GS is not None:
            out[name + "_std"] = (dims_t + ["lat", "lon"], cube(GS))
    ds = xr.Dataset({k: (d, a) for k, (d, a) in out.items()}, coords={k: (c[0], c[1], c[2]) if isinstance(c, tuple)
                                                                       else c for k, c in coords.items()})
    ds[name].attrs.update(attrs)
    ds[name].attrs.setdefault("long_name", name)
    made = f"manifill {method or 'default'} from {len(lons)} stations"
    ds.attrs.update({"Conventions": "CF-1.8", "source": f"{attrs['source']}; {made}" if "source" in attrs else made,
                     "history": f"{_now()}: manifill.reconstruct_globe (manifill {__version__}): reconstructed on a "
                                f"sphere of {len(V):,} vertices"})
    if notes:
        ds.attrs["comment"] = "; ".join(notes)
    return ds if std else ds[name].assign_attrs(**{k: ds.attrs[k] for k in ("Conventions", "source", "history",
                                                                              "comment") if k in ds.attrs})


def write_netcdf(field: xarray.DataArray | xarray.Dataset, path: str | os.PathLike[str]) -> str | os.PathLike[str]:
    """Write a :func:`reconstruct_globe` result as netCDF, its ``Conventions``, ``source`` and ``history`` global
    (as CF puts them), its coordinates without a fill value, through xarray's ``to_netcdf``, atomically.

    Parameters
    ----------
    field : xarray.DataArray or xarray.Dataset
        What :func:`reconstruct_globe` returned.
    path : str or Path
        The ``.nc`` file.
    """
    ds = field if hasattr(field, "data_vars") else field.to_dataset()
    glob = {k: v for k, v in (field.attrs if not hasattr(field, "data_vars") else ds.attrs).items()
            if k in ("Conventions", "source", "history", "comment")}
    ds = ds.assign_attrs(glob)
    for v in ds.data_vars:
        ds[v].attrs = {k: a for k, a in ds[v].attrs.items() if k not in glob}
    encoding = {c: {"_FillValue": None} for c in ds.coords}  # CF: coordinates have no fill value
    with atomic_path(path) as tmp:  # nothing half-written is left at path
        ds.to_netcdf(tmp, encoding=encoding)
    return path


def _now():
    """The time now, UTC, as CF's history starts a line (``2026-12-07T09:00:00Z``)."""
    return datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def _read_csv_stations(path):
    import pandas

    return pandas.read_csv(path)


def _read_netcdf_stations(path):
    return _xarray().open_dataset(path)


# stations: read(path) -> a DataFrame or Dataset of stations; write(field, path) the globe's field
_NETCDF = register_format(Format("netCDF (CF)", "stations", (".nc",), _read_netcdf_stations, write_netcdf,
                                 fields=True, times=True, extra="xarray", seen_by=("xarray", "netCDF4")))
register_format(Format("CSV of stations", "stations", (".csv",), _read_csv_stations, fields=True, text=True,
                       extra="xarray"))


def _fields(V, F, P, values, method, std, options, snap=True):
    """``(X, S, notes)``: the fields on the vertices, ``(n, T)``, and what the summary should say (steps left
    empty, stations averaged). One Reconstructor per set of stations reporting (a station's missing values, NaN,
    leave it out of those steps; the steps with the same stations share a factorisation)."""
    finite = np.isfinite(values)
    X = np.full((len(V), values.shape[1]), np.nan)
    S = np.full_like(X, np.nan) if std else None
    patterns, which = np.unique(finite.T, axis=0, return_inverse=True)
    if not any(rows.sum() >= 3 for rows in patterns):
        raise SampleError(f"no step has three stations reporting (at most {int(finite.sum(axis=0).max())} of "
                          f"{len(P)} have a value); a field needs at least three")
    empty, merged = [], 0
    tree = cKDTree(V)  # the stations' nearest vertices, for every set of stations reporting
    for g, rows in enumerate(patterns):
        cols = np.flatnonzero(np.ravel(which) == g)
        if rows.sum() < 3:
            empty.extend(cols.tolist())  # too few stations reporting: left NaN, and said
            continue
        options = {**options, "uncertainty": True if std else options.get("uncertainty")}
        r, shared = _reconstruct(V, F, tree, P[rows], values[np.ix_(rows, cols)], method, options, snap)
        merged = max(merged, shared)
        X[:, cols] = np.asarray(r.values).reshape(len(V), -1)
        if std:
            S[:, cols] = np.asarray(r.std).reshape(len(V), -1)
    notes = []
    if empty:
        shown = ", ".join(str(c) for c in sorted(empty)[:5]) + (", ..." if len(empty) > 5 else "")
        notes.append(f"{len(empty)} steps (step {shown}) had fewer than three stations reporting and are left empty "
                     f"(NaN)")
    if merged:
        notes.append(f"{merged} stations shared the nearest vertex of the sphere with another and were averaged "
                     f"with it (one station at their mean position); a finer grid keeps them apart")
    return X, S, notes


def _reconstruct(V, F, tree, P, vals, method, options, snap=True):
    """``(result, stations averaged)``: the stations at their positions, but on the globe's own sphere (``snap``)
    those that share a nearest vertex (stations nearer than the finest sphere holds apart) merged into one station
    at their mean position (on the sphere) with their mean values: two stations inside one triangle would make the
    field between them as steep as their difference over their distance. Where the positions still crowd a
    triangle (rows not independent), every station goes to its nearest vertex. On the caller's mesh the positions
    are kept as given."""
    nearest = tree.query(P)[1]
    groups, inv = np.unique(nearest, return_inverse=True)
    inv = np.ravel(inv)
    shared = int(len(P) - groups.size)
    if snap and shared:
        merged = np.zeros((groups.size, 3))
        np.add.at(merged, inv, P)
        merged *= (np.linalg.norm(P, axis=1).mean() / np.linalg.norm(merged, axis=1))[:, None]
        means = np.zeros((groups.size, vals.shape[1]))
        np.add.at(means, inv, vals)
        P, vals = merged, means / np.bincount(inv)[:, None]
    try:
        return Reconstructor(V, F, P, method=method, fields=vals.shape[1], **options).apply(vals), \
            (shared if snap else 0)
    except SampleError as exc:
        if "not independent" not in str(exc):
            raise
    nearest = tree.query(P)[1]
    return Reconstructor(V, F, nearest, method=method, fields=vals.shape[1],
                         **{"duplicates": "mean", **options}).apply(vals), shared


def globe_file(stations: str | os.PathLike[str], out: str | os.PathLike[str], *, var: str | None = None,
               grid: float | None = 1.0, method: str | None = None, lon: str = "lon", lat: str = "lat",
               command: str | None = None, **options: Any) -> str:
    """``manifill globe``: a CSV of stations (``lon``, ``lat``, value columns) or a netCDF of them (a ``station``
    dimension) to a netCDF on a regular grid; returns a one-line summary.

    Parameters
    ----------
    stations : str or Path
        The CSV (wide: one row per station; long: a ``time`` column) or netCDF of stations.
    out : str or Path
        The ``.nc`` file to write.
    var, grid, method, lon, lat
        As :func:`reconstruct_globe`.
    command : str, optional
        The command line that asked for it, for the file's ``history``.
    **options
        More options of :func:`manifill.reconstruct`.

    Raises
    ------
    ReadError, WriteError, OptionError, SampleError
        A file that cannot be read, an output that is not ``.nc``, stations or options refused.
    """
    _xarray()
    src, out = Path(stations), Path(out)
    if find_format("stations", out, writing=True) is None:
        raise WriteError(f"{out.name}: the globe's field is written as netCDF; name the output OUT.nc")
    if not src.is_file():
        raise ReadError(f"{src}: no such file; pass a CSV of stations (lon, lat, values) or a netCDF of them")
    fmt = find_format("stations", src) or _NETCDF  # netCDF by default: its reader says what is wrong with a file
    try:
        data = fmt.read(src)
    except (ValueError, OSError, UnicodeDecodeError) as exc:
        raise ReadError(f"{src.name}: could not be read as stations ({str(exc).splitlines()[0][:120]}); pass a CSV "
                        f"with lon and lat columns or a netCDF with a station dimension") from None
    field = reconstruct_globe(data, var=var, grid=grid, method=method, lon=lon, lat=lat, **options)
    if command:  # CF's history: when, and the command line that made the file
        field.attrs["history"] = field.attrs["history"].replace("manifill.reconstruct_globe", command, 1)
    _NETCDF.write(field, out)
    said = f" ({field.attrs['comment']})" if field.attrs.get("comment") else ""
    return f"wrote {out.name}: {field.name} on {' x '.join(f'{d} {n}' for d, n in field.sizes.items())}{said}"


_LAT = {"standard_name": "latitude", "long_name": "latitude", "units": "degrees_north", "axis": "Y"}
_LON = {"standard_name": "longitude", "long_name": "longitude", "units": "degrees_east", "axis": "X"}
