"""Station tables (pandas DataFrames) for the globe: a wide table (one row per station, one value column per field
or per time step) or a long one (one row per station and time, a ``time`` column), to positions, values and times;
and the checks of the names that tables and Datasets share (:mod:`manifill.adapters.globe` uses them).

A wide table's value columns are time steps when their names are: numbers (``1990``, ``1991``), dates
(``2024-01-01``) or one prefix with step numbers (``t0`` ... ``t9``); else fields.
"""

import re

import numpy as np

from ..errors import OptionError, SampleError

__all__ = ["COORDINATES", "check_name", "check_names", "listed", "numbers", "table_stations", "column_times"]


def table_stations(data, var, lon, lat, station, time):
    """``(lon (k,), lat (k,), values (k, T), times or None, name, attrs)`` of a DataFrame of stations."""
    check_names("column", data.columns, data.columns, var, lon, lat)
    if time in data.columns and time not in (lon, lat):
        return _long(data, var, lon, lat, station, time)
    rest = [c for c in data.columns if c not in (lon, lat, station)] if var is None else [var]
    columns = {c: numbers(data[c], c, strict=var is not None) for c in rest}
    cols = [c for c in rest if columns[c] is not None]
    if not cols:
        raise OptionError("the stations have no column of numbers besides lon and lat; add one, or pass var=")
    values = np.column_stack([columns[c] for c in cols])
    where = numbers(data[lon], lon, strict=True), numbers(data[lat], lat, strict=True)
    steps = column_times(cols) if len(cols) > 1 else None
    if steps is not None:  # the columns are time steps of one field
        return (*where, values, _time_coordinate(steps, time), "value", {"long_name": "value at each time step"})
    name = str(cols[0]) if len(cols) == 1 else "value"
    check_name(name, var)
    return (*where, values, None, name, {"fields": [str(c) for c in cols]})


def _long(data, var, lon, lat, station, time):
    """A long table: one row per station and time; the stations are the distinct (lon, lat) pairs."""
    rest = [c for c in data.columns if c not in (lon, lat, station, time)] if var is None else [var]
    columns = {c: numbers(data[c], c, strict=var is not None) for c in rest}
    cols = [c for c in rest if columns[c] is not None]
    if len(cols) != 1:
        raise OptionError(f"a table with a {time!r} column holds one value per row; it has "
                          f"{'none' if not cols else listed(cols)}: pass var= one of them (CLI: --var)")
    lo, la = numbers(data[lon], lon, strict=True), numbers(data[lat], lat, strict=True)
    t = data[time].to_numpy()
    if data[time].isna().any():
        i = int(np.flatnonzero(data[time].isna().to_numpy())[0])
        raise SampleError(f"column {time!r}, row {i + 1} has no time; give every row its time")
    key = np.column_stack([lo, la])
    uniq, first, which = np.unique(key, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)  # stations in the order they first appear
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    row = rank[which.ravel()]
    steps, col = np.unique(t, return_inverse=True)
    values = np.full((len(uniq), len(steps)), np.nan)
    cell = row * len(steps) + col.ravel()
    twice = np.flatnonzero(np.bincount(cell, minlength=values.size) > 1)
    if twice.size:
        r, c = divmod(int(twice[0]), len(steps))
        raise SampleError(f"station at lon {uniq[order[r], 0]:g}, lat {uniq[order[r], 1]:g} has two rows at "
                          f"{time} {steps[c]}; keep one row per station and time")
    values[row, col.ravel()] = columns[cols[0]]
    where = uniq[order, 0], uniq[order, 1]
    check_name(str(cols[0]), var)
    return (*where, values, _time_coordinate(steps, time), str(cols[0]), {})


def column_times(names):
    """The times that a wide table's column names are (numbers, dates, or a shared prefix and step numbers), or
    None when they are names of fields.

    Examples
    --------
    >>> column_times(["t0", "t1", "t2"]).tolist(), column_times(["1990", "1991"]).tolist()
    ([0, 1, 2], [1990.0, 1991.0])
    >>> column_times(["temp", "rain"]) is None
    True
    """
    import pandas

    texts = [str(n).strip() for n in names]
    try:
        nums = np.array([float(t) for t in texts])
        return nums if np.isfinite(nums).all() and len(np.unique(nums)) == len(nums) else None
    except ValueError:
        pass
    m = [re.fullmatch(r"(.*?)(\d+)", t) for t in texts]
    if all(m) and len({x.group(1) for x in m}) == 1 and m[0].group(1):
        steps = np.array([int(x.group(2)) for x in m])
        return steps if len(np.unique(steps)) == len(steps) else None
    if all(re.fullmatch(r"\d{4}-\d{2}-\d{2}([T ][\d:.]+)?", t) for t in texts):
        dates = pandas.to_datetime(texts, errors="coerce")
        return None if dates.isna().any() or dates.has_duplicates else dates.to_numpy()
    return None


def _time_coordinate(steps, time):
    import xarray

    return xarray.DataArray(np.asarray(steps), dims=[time], name=time)


#: Names a value may not take: the output's own coordinates.
COORDINATES = ("lon", "lat", "vertex", "field")


def check_name(name, var):
    if name in COORDINATES:
        raise OptionError(f"the value {name!r} would share its name with the output's {name!r} coordinate; rename "
                          f"the column or variable" + ("" if var else ", or pass var= another (CLI: --var)"))


def check_names(kind, names, values, var, lon, lat):
    """The longitude and latitude among ``names``, and ``var`` among the ``values`` (a table's columns, a
    Dataset's variables), each refused in one line naming what is there."""
    for c in (lon, lat):
        if c not in names:
            raise OptionError(f"the stations have no {kind} {c!r} (they have {listed(names)}); name their longitude "
                              f"and latitude {kind}s (lon=, lat=; CLI: --lon, --lat), in degrees")
    if var in (lon, lat):
        raise OptionError(f"var={var!r} is the stations' {'longitude' if var == lon else 'latitude'}; pass a value "
                          f"{kind} (CLI: --var)")
    if var is not None and var not in values:
        raise OptionError(f"the stations have no {kind} {var!r} (they have {listed(values)}); pass var= one of "
                          f"them (CLI: --var)")


def listed(names, most=8):
    names = [str(n) for n in names]
    return ", ".join(names[:most]) + (f" and {len(names) - most} more" if len(names) > most else "")


def numbers(column, name, strict):
    """A DataFrame column as floats (empty cells NaN: no value at that station); None for a column of text alone
    (station names) unless ``strict``; a cell that is neither a number nor empty is named with its row."""
    if getattr(column.dtype, "kind", "O") in "iufb":
        return column.to_numpy(dtype=np.float64)
    import pandas

    text = column.astype(str).str.strip()
    empty = column.isna().to_numpy() | (text == "").to_numpy()
    parsed = pandas.to_numeric(column.where(~empty), errors="coerce").to_numpy(dtype=np.float64)
    bad = np.flatnonzero(np.isnan(parsed) & ~empty & ~text.str.lower().isin(("nan", "na", "n/a")).to_numpy())
    if bad.size and not strict and bad.size == (~empty).sum():
        return None  # text alone: station names or notes, left out
    if bad.size:
        i = int(bad[0])
        raise SampleError(f"column {name!r}, row {i + 1} (line {i + 2} of a CSV with one header line) holds "
                          f"{str(column.iloc[i])[:40]!r}, not a number ({bad.size} such cell(s)); fix it, or leave the "
                          f"cell empty for a station without a value")
    return parsed
