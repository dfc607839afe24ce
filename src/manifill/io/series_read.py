"""The readers of time-series files (``.npy``, ``.gii``, ``.xdmf``, ``.pvd``, ``.h5``): ``(times, values)`` of one
field, registered with their writers by :mod:`manifill.io.series_write`; :func:`manifill.io.series.read_series_values`
reads through them.
"""

import xml.etree.ElementTree as ET

import numpy as np

from ..errors import ReadError
from .files import check_input_file, reading
from .gifti_write import read_gifti_times
from .meshio_files import meshio_read
from .neuro import read_gifti_data
from .sample_formats import load_npy
from .series import need_h5py

__all__ = ["read_npy_series", "read_gifti_series", "read_xdmf_series", "read_pvd_series", "read_h5_series"]


def read_npy_series(path, name=None):
    """``(times, values)`` of an ``(n, T)`` array (times ``0 .. T-1``)."""
    X = load_npy(path)
    if X.ndim not in (1, 2) or X.dtype.names is not None:
        raise ReadError(f"{path.name}: an array of shape {X.shape}; a series is (n, T)")
    X = X.astype(np.float64).reshape(len(X), -1)
    return np.arange(X.shape[1], dtype=np.float64), X


def read_gifti_series(path, name=None):
    """``(times, values)`` of a GIfTI series: one data array per step (float32), each with its time (or the step
    numbers)."""
    X, _ = read_gifti_data(path, None)
    times = read_gifti_times(path)
    return (np.arange(X.shape[1], dtype=np.float64) if times is None else times), X


def read_xdmf_series(path, name=None):
    """``(times, values)`` of an XDMF file (its arrays in HDF5)."""
    return _steps(path, _read_xdmf(path, name))


def read_pvd_series(path, name=None):
    """``(times, values)`` of a ParaView collection of VTU files."""
    return _steps(path, _read_pvd(path, name))


def read_h5_series(path, name=None):
    """``(times, values)`` of manifill's HDF5 datasets."""
    return _read_h5(path, name)


def _steps(path, steps):
    if not steps:
        raise ReadError(f"{path.name}: no time steps; check the file")
    times = np.array([t for t, _ in steps], dtype=np.float64)
    cols = [np.asarray(c, dtype=np.float64).ravel() for _, c in steps]
    if len({c.size for c in cols}) != 1:
        raise ReadError(f"{path.name}: its steps hold different numbers of values; check the file")
    return times, np.column_stack(cols)


def _read_h5(path, name):
    h5py = need_h5py(path, ReadError)
    with reading(path, "HDF5 series"):
        with h5py.File(path, "r") as f:
            key = name if name is not None else f.attrs.get("field")
            if key is None:
                two = [k for k, d in f.items() if isinstance(d, h5py.Dataset) and d.ndim == 2]
                key = two[0] if len(two) == 1 else None
            if isinstance(key, bytes):
                key = key.decode()
            if key not in f:
                raise ReadError(f"{path.name}: no field {key!r} (datasets: {', '.join(f)}); pass name=")
            X = np.asarray(f[key][()], dtype=np.float64)
            X = X.reshape(len(X), -1)
            times = np.asarray(f["times"][()]) if "times" in f else np.arange(X.shape[1])
    return times.astype(np.float64), X


def _pick(path, point_data, name, t):
    if not point_data:
        raise ReadError(f"{path.name}: the step at time {t:.17g} has no point data; check the file")
    key = name if name is not None else next(iter(point_data))
    if key not in point_data:
        raise ReadError(f"{path.name}: no field {key!r} at time {t:.17g} (fields: {', '.join(point_data)}); pass "
                        f"name=")
    return point_data[key]


def _read_xdmf(path, name):
    need_h5py(path, ReadError)
    import meshio

    with reading(path, "XDMF time series"):
        with meshio.xdmf.TimeSeriesReader(str(path)) as r:
            r.read_points_cells()
            steps = []
            for k in range(r.num_steps):
                t, pd, _ = r.read_data(k)
                steps.append((t, np.asarray(_pick(path, pd, name, t))))
    return steps


def _read_pvd(path, name):
    with reading(path, "PVD collection"):
        root = ET.parse(path).getroot()
        sets = [(float(d.get("timestep", "0")), d.get("file")) for d in root.iter("DataSet")]
    steps = []
    for t, rel in sets:
        if not rel:
            raise ReadError(f"{path.name}: a DataSet without a file; check the file")
        step = path.parent / rel
        check_input_file(step)
        mesh = meshio_read(step, step.suffix.lower() or ".vtu", "vtu")
        steps.append((t, np.asarray(_pick(path, mesh.point_data, name, t))))
    order = np.argsort([t for t, _ in steps], kind="stable")
    return [steps[j] for j in order]
