"""Per-vertex fields and time series as GIfTI data (``.func.gii``, ``.shape.gii``): nibabel, nilearn, Workbench.

:func:`write_gifti_data` writes one data array per column (float32, named in its ``Name`` metadata): a result's
fields (``NIFTI_INTENT_NONE``), or the steps of a time series (``NIFTI_INTENT_TIME_SERIES``, the image's
``TimeStep`` metadata the steps' spacing in milliseconds when they are evenly spaced), as nilearn's surface
images and Connectome Workbench read them. :class:`GiftiSeries` is the ``.gii`` back end of
:class:`manifill.io.series_write.SeriesWriter` (the steps kept in memory, written at the end: a cortical series
of 164k vertices x 1,000 steps is 0.66 GB in float32). Needs the ``[neuro]`` extra (nibabel).
"""

from pathlib import Path

import numpy as np

from ..errors import WriteError
from .files import atomic_path

__all__ = ["write_gifti_data", "read_gifti_times", "GiftiSeries"]


def _nibabel():
    try:
        import nibabel
        import nibabel.gifti  # noqa: F401
    except ImportError:
        raise ImportError("writing GIfTI files needs nibabel: pip install 'manifill[neuro]'") from None
    return nibabel


def write_gifti_data(path, values, *, names=None, times=None):
    """Write ``(n,)`` or ``(n, p)`` per-vertex values as a GIfTI data file, one data array per column.

    Parameters
    ----------
    path : str or Path
        ``.func.gii`` (or any ``.gii``).
    values : (n,) or (n, p) array_like of float
    names : list of str, optional
        A name per column (``Name`` metadata).
    times : (p,) array_like of float, optional
        The columns are time steps at these times (seconds): time-series intent.

    Raises
    ------
    WriteError
        Values of the wrong shape, names or times of the wrong length, a missing folder, a failed write (nothing
        is left behind).
    """
    nib = _nibabel()
    path = Path(path)
    X = np.asarray(values, dtype=np.float64)
    X = X[:, None] if X.ndim == 1 else X
    if X.ndim != 2 or X.shape[0] == 0:
        raise WriteError(f"{path.name}: values of shape {np.shape(values)}; pass (n,) or (n, p) per-vertex values")
    p = X.shape[1]
    names = [f"value{j}" if p > 1 else "value" for j in range(p)] if names is None else [str(n) for n in names]
    if len(names) != p:
        raise WriteError(f"{path.name}: {len(names)} names for {p} columns; pass one name per column")
    meta, t = {}, None
    intent = "NIFTI_INTENT_NONE"
    if times is not None:
        t = np.asarray(times, dtype=np.float64).ravel()
        if t.size != p:
            raise WriteError(f"{path.name}: {t.size} times for {p} time steps; pass one time per column")
        intent = "NIFTI_INTENT_TIME_SERIES"
        steps = np.diff(t)
        if steps.size and np.allclose(steps, steps[0], rtol=1e-9):
            meta["TimeStep"] = f"{steps[0] * 1000.0:.9g}"  # milliseconds, as Workbench writes it
    # each step's own time in its array's metadata (``Time``, as given: seconds for ``TimeStep``'s milliseconds)
    arrays = [nib.gifti.GiftiDataArray(np.ascontiguousarray(X[:, j], dtype=np.float32), intent=intent,
                                       datatype="NIFTI_TYPE_FLOAT32",
                                       meta=nib.gifti.GiftiMetaData({"Name": names[j]} if t is None else
                                                                    {"Name": names[j], "Time": repr(float(t[j]))}))
              for j in range(p)]
    image = nib.gifti.GiftiImage(darrays=arrays, meta=nib.gifti.GiftiMetaData(meta))
    if not path.parent.is_dir():
        raise WriteError(f"folder {path.parent} does not exist; create it first or choose another path")
    with atomic_path(path) as tmp:
        try:
            nib.save(image, str(tmp))
        except OSError as exc:
            raise WriteError(f"{path.name}: could not write ({exc.strerror or exc}); check the path and free space") \
                from None


def read_gifti_times(path):
    """The steps' times of a GIfTI series :func:`write_gifti_data` wrote (``Time`` metadata), or None."""
    nib = _nibabel()
    try:
        times = [d.meta.get("Time") for d in nib.load(str(path)).darrays]
        return None if not times or None in times else np.array([float(x) for x in times])
    except (ValueError, TypeError, OSError):
        return None


class GiftiSeries:
    """The ``.gii`` back end of :class:`~manifill.io.series_write.SeriesWriter`: steps kept, written at the end."""

    def __init__(self, w):
        _nibabel()  # the extra named before any work
        self.w, self.columns, self.times = w, [], []

    def add(self, X, times, j0):
        self.columns.append(np.asarray(X, dtype=np.float32))
        self.times.extend(np.asarray(times, dtype=np.float64).ravel().tolist())

    def finish(self):
        X = np.concatenate(self.columns, axis=1) if self.columns else np.zeros((self.w.n, 0), np.float32)
        write_gifti_data(self.w.path, X, names=[f"{self.w.name}_{j}" for j in range(X.shape[1])], times=self.times)

    def abort(self):
        self.columns = []
