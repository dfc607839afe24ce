"""Samples and per-vertex values on disk.

Sample files
------------
CSV
    A header, then one row per sample. Either ``vertex,value[,value2...]``
    (0-based vertex indices) or ``x,y,z,value[,...]`` (positions, snapped to the
    nearest vertex, or kept as given with ``keep_points`` for the energy methods,
    which locate them on the surface). The value columns keep their header names.
NPZ
    Arrays ``idx`` (or ``points``) and ``vals`` (``(k,)`` or ``(k, p)``), and
    optionally ``names``.
NPY
    A structured array whose field names follow the CSV header rules.
Per-vertex data (the ``[neuro]`` extra)
    GIfTI ``.func.gii`` / ``.shape.gii`` arrays, FreeSurfer morphometry files
    (``lh.thickness``, ``lh.curv``, ...), MGH/MGZ: one value per vertex, NaN
    where nothing was measured; the finite entries are the samples. FreeSurfer
    ``.label`` files: vertex numbers with one value each.

Values are written as CSV (``vertex,name...``) or NPY. Damaged files end in one
:class:`~manifill.errors.ReadError` naming the file: a lying NPY header or a
damaged ZIP member is caught before anything is allocated.
"""

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from ..errors import MeshError, ReadError, SampleError
from ..surface.options import PointOptions
from ..surface.samples import Samples
from .files import check_input_file, check_not_foreign
from .formats import find_format, lookup
from .neuro import sniff
from .sample_formats import (MORPH, SAMPLE_FORMATS, VALUE_FORMATS, load_npy, load_npz,  # noqa: F401 (shown here)
                             write_values)

__all__ = ["SAMPLE_FORMATS", "VALUE_FORMATS", "SampleTable", "read_samples", "read_sample_table",
           "samples_from_table", "load_npz", "write_values"]

def _sample_format(path):
    """The format of a sample file: by suffix, else a FreeSurfer morphometry file by its first bytes."""
    fmt = find_format("samples", path)
    if fmt is None and Path(path).is_file() and sniff(path) == "freesurfer-morph":
        return MORPH
    return fmt or lookup("samples", path, also=" (or a FreeSurfer file such as lh.thickness)")


def read_samples(path: str | os.PathLike[str], V: np.ndarray, *, duplicates: str = "error",
                 max_distance: float | None = None, vertex_numbering: str | None = None,
                 snap_to: ArrayLike | None = None, keep_points: bool = False) -> Samples:
    """Read samples, snapping positions to vertices.

    Parameters
    ----------
    path : str or Path
        The file (see the module docstring for the layouts).
    V : (n, 3) numpy array
        Vertex positions of the mesh the samples belong to.
    duplicates : {'error', 'mean'}, optional
        Several samples on one vertex with different values: raise, or average.
    max_distance : float, optional
        Largest accepted snap distance for positions (see
        :func:`manifill.surface.samples.snap_to_vertices`).
    vertex_numbering : str, optional
        Why the mesh's vertex numbers are not the file's (e.g. an STL, whose
        reader renumbers): samples by vertex index are then refused with this
        reason (:attr:`manifill.io.registry.MeshFile.vertex_numbering`).
    snap_to : (d,) array_like of int, optional
        The only vertices positions snap to (e.g. the boundary vertices of a tetrahedral
        solid, :func:`manifill.solid.tets.boundary_vertices`); every vertex by
        default. The samples keep ``V``'s vertex numbers. Samples given by
        vertex index are not affected.
    keep_points : bool, optional
        For positions: keep them as given (``Samples.points``, ``point_vals``)
        for a reconstruction that locates them on the surface (see
        :meth:`manifill.surface.samples.Samples.from_points`); not with ``snap_to``.

    Returns
    -------
    Samples
        Unique vertex indices, values, field names and snap distances.

    Raises
    ------
    ReadError
        Missing file, unknown extension, bad header, non-numeric cells (the
        line and column are named), a damaged file.
    SampleError
        Out-of-range indices, NaN values, far-away positions ("wrong units?"),
        conflicting duplicates, vertex indices on a mesh that was renumbered.
    MeshError
        Positions given for a mesh whose points are not all finite.
    """
    PointOptions(duplicates=duplicates, max_distance=max_distance).validate()  # before the file is read
    path = Path(path)
    table = read_sample_table(path, len(V))
    return samples_from_table(path, V, table, duplicates=duplicates, max_distance=max_distance,
                              vertex_numbering=vertex_numbering, snap_to=snap_to, keep_points=keep_points)


@dataclass
class SampleTable:
    """A sample file's rows as numbers, before they meet the mesh.

    Attributes
    ----------
    kind : {'vertex', 'points'}
        Whether the rows start with a vertex index or with ``x, y, z``.
    table : (r, c) float64 numpy array
        One row per sample: the index (or three coordinates), then the values.
    names : list of str or None
        The value columns' names.
    lines : (r,) int numpy array or None
        The line of each row in a CSV file (``None`` for other files).
    """

    kind: str
    table: np.ndarray
    names: list
    lines: np.ndarray | None = None


def read_sample_table(path, n):
    """Read a sample file's rows (any layout :func:`read_samples` reads) without snapping them to a mesh.

    Parameters
    ----------
    path : str or Path
    n : int
        Number of vertices of the mesh (per-vertex data files hold one value per vertex).

    Returns
    -------
    SampleTable

    Raises
    ------
    ReadError, SampleError
        As :func:`read_samples`.
    """
    path = Path(path)
    fmt = _sample_format(path)
    check_input_file(path)
    check_not_foreign(path, f"a {fmt.name} file of samples", "samples", archive=fmt.container == "zip",
                      gzip=fmt.container == "gzip")
    return SampleTable(*fmt.read(path, n))


def samples_from_table(path, V, table, *, duplicates="error", max_distance=None, vertex_numbering=None,
                       snap_to=None, keep_points=False):
    """The :class:`Samples` of a :class:`SampleTable` read from ``path`` (options as :func:`read_samples`).

    Raises
    ------
    ReadError, SampleError, MeshError
        As :func:`read_samples`; the messages name ``path``.
    """
    path = Path(path)
    n = len(V)
    kind, names, table = table.kind, table.names, table.table
    if kind == "vertex":
        if vertex_numbering:
            raise SampleError(f"{vertex_numbering}; give the samples as positions (x,y,z,value) instead")
        col = table[:, 0]
        if np.any(np.abs(col) >= 2.0**62):
            row = int(np.flatnonzero(np.abs(col) >= 2.0**62)[0])
            raise ReadError(f"{path.name}: vertex index {col[row]:g} in data row {row + 1} is far too large")
        if not np.all(col == np.round(col)):
            row = int(np.flatnonzero(col != np.round(col))[0])
            raise ReadError(f"{path.name}: vertex index {col[row]:g} in data row {row + 1} is not an integer")
    if kind != "vertex" and not np.isfinite(np.asarray(V, dtype=np.float64)).all():
        bad = int(np.flatnonzero(~np.isfinite(np.asarray(V, dtype=np.float64)).all(axis=1))[0])
        raise MeshError(f"{path.name}: its positions cannot be snapped to a mesh with NaN or infinite coordinates "
                        f"(vertex {bad}); fix the mesh's points")
    try:
        if kind == "vertex":
            return Samples.from_indices(col.astype(np.int64), table[:, 1:], n, names=names, duplicates=duplicates)
        if snap_to is None:
            return Samples.from_points(V, table[:, :3], table[:, 3:], names=names, duplicates=duplicates,
                                       max_distance=max_distance, keep_points=keep_points)
        snap_to = np.unique(np.asarray(snap_to, dtype=np.int64))
        S = Samples.from_points(np.asarray(V, dtype=np.float64)[snap_to], table[:, :3], table[:, 3:], names=names,
                                duplicates=duplicates, max_distance=max_distance)
        S.idx = snap_to[S.idx]
        return S
    except SampleError as exc:  # the file's samples are wrong: the message names the file
        msg = str(exc)
        raise SampleError(msg if msg.startswith(f"{path.name}:") else f"{path.name}: {msg}") from None
