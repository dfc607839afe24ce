"""Tangent vector fields on disk: a :class:`~manifill.vectors.result.VectorReconstruction` written
(:func:`save_vectors`, what its ``save`` runs) and arrows read (:func:`read_vector_samples`).

Written, by the output's format (:mod:`manifill.io.formats`' ``vectors``, ``cell_fields`` and ``fields``):

VTU, VTP, legacy VTK
    Each field ``<name>`` one 3-component point array (the first one the active vectors of a VTK XML file, so
    ParaView's Glyph filter and pyvista's ``glyph()`` point along it), ``<name>_magnitude`` (and ``<name>_std``)
    beside it, the masks, and the face vectors as a 3-component cell array ``<name>``.
PLY
    ``<name>_x``, ``<name>_y``, ``<name>_z`` per vertex (the columns of ``--gradient``), the magnitude, the masks;
    PLY has no per-face fields, so the face vectors are not written.
CSV (and GIfTI values)
    Columns ``vertex, <name>_x, <name>_y, <name>_z, <name>_magnitude[, <name>_std]``.
NPY
    The ``(n, 3)`` array of the one field.

Read: a sample table whose value columns are ``vx, vy, vz`` (CSV with ``vertex`` or ``x, y, z`` first, a
structured NPY with those fields, an NPZ with ``vectors`` of shape ``(k, 3)`` beside ``idx`` or ``points``).
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ReadError, SampleError, WriteError
from ..report import value_columns
from ..results import RESERVED_NAMES
from ..surface.samples import Samples
from .formats import find_format, formats_of
from .registry import write_mesh
from .sample_formats import VECTOR_COLUMNS, write_values
from .samples import read_sample_table, read_samples

__all__ = ["VECTOR_COLUMNS", "VECTOR_NAME", "VectorSamples", "vector_columns", "holds_vectors",
           "read_vector_samples", "split_vectors", "save_vectors", "vector_suffixes"]

#: The name of the field read from the columns ``vx, vy, vz`` (in files: ``v``, ``v_magnitude``).
VECTOR_NAME = "v"


def vector_suffixes():
    """The suffixes a vector field is written as (mesh formats with fields, then value files)."""
    meshes = [s for s, f in formats_of("mesh", writing=True).items() if f.fields]
    return meshes + [s for s in formats_of("values", writing=True) if s not in meshes]


def split_vectors(data):
    """``data`` with each ``(n, 3)`` array as three columns ``<name>_x``, ``<name>_y``, ``<name>_z``.

    Examples
    --------
    >>> list(split_vectors({"v": np.zeros((2, 3)), "v_magnitude": np.zeros(2)}))
    ['v_x', 'v_y', 'v_z', 'v_magnitude']
    """
    out = {}
    for key, a in data.items():
        a = np.asarray(a)
        if a.ndim == 2 and a.shape[1] == 3:
            out.update({f"{key}_{c}": a[:, i] for i, c in enumerate("xyz")})
        else:
            out[key] = a
    return out


def save_vectors(result, path, names):
    """Write a vector result to ``path`` as its format holds vectors (see the module docstring); returns the path.

    Raises
    ------
    WriteError
        A format that holds no fields (``.obj``, ``.stl``, a series), or several fields for ``.npy``.
    """
    path = Path(path)
    data = result.point_data(names)
    values = find_format("values", path, writing=True)
    if values is not None and values.fields:  # named columns: the components apart
        cols = {k: a for k, a in split_vectors(data).items() if k not in RESERVED_NAMES}
        write_values(path, value_columns(cols, list(cols)), names=list(cols))
        return path
    if values is not None:
        X = result.fields()
        if X.shape[-1] > 1:
            raise WriteError(f"{path.name}: an .npy holds one vector field's (n, 3) array, and the result has "
                             f"{X.shape[-1]} fields; write .vtu or .csv for all of them")
        write_values(path, X[..., 0])
        return path
    fmt = find_format("mesh", path, writing=True)
    if fmt is None or not fmt.fields:
        raise WriteError(f"{path.name}: a vector field is written as {', '.join(vector_suffixes())}; change the "
                         f"name")
    cells = result.cell_data(names) if fmt.cell_fields else None
    write_mesh(path, np.asarray(result.V), result.F, data if fmt.vectors else split_vectors(data), cell_data=cells)
    return path


def vector_columns(names, path="samples"):
    """The positions of ``vx, vy, vz`` among a sample table's value columns, or None when it has none of them.

    Raises
    ------
    SampleError
        Some of the three without the others (the message names the missing column), or other value columns
        beside them.

    Examples
    --------
    >>> vector_columns(["vz", "vx", "vy"]), vector_columns(["temperature"])
    ([1, 2, 0], None)
    """
    names = list(names or [])  # a table may leave its value columns unnamed (an NPZ without 'names')
    low = [str(n).strip().lower() for n in names]
    have = [c for c in VECTOR_COLUMNS if c in low]
    if not have:
        return None
    name = Path(str(path)).name
    missing = [c for c in VECTOR_COLUMNS if c not in low]
    if missing:
        raise SampleError(f"{name}: columns {', '.join(have)} but no {missing[0]}; add the {missing[0]} column (the "
                          f"arrows' third component: 0 on a flat mesh in the x, y plane)")
    others = [str(n) for n, lo in zip(names, low) if lo not in VECTOR_COLUMNS]
    if others:
        raise SampleError(f"{name}: columns {', '.join(others)} beside the arrows' vx, vy, vz; reconstruct one at a "
                          f"time (put them in another file)")
    return [low.index(c) for c in VECTOR_COLUMNS]


def holds_vectors(path):
    """Whether the sample file ``path`` holds arrows (value columns ``vx, vy, vz``); False for a file that is not
    there, not a table or a damaged one (the samples' reader then says what is wrong, when its turn comes).

    Raises
    ------
    SampleError
        ``vx, vy`` without ``vz``, or other value columns beside them (:func:`vector_columns`).
    """
    fmt = find_format("samples", path)
    if fmt is None or fmt.extra is not None or not Path(path).is_file():
        return False  # per-vertex data (one value per vertex) or no file: not arrows
    try:
        names = read_sample_table(path, 0).names
    except (ReadError, SampleError):
        return False
    return vector_columns(names, path) is not None


@dataclass
class VectorSamples:
    """Arrows read from a file, ready for :func:`manifill.vectors.reconstruct.reconstruct_vectors`.

    Attributes
    ----------
    where : (k,) int64 or (k, 3) float64 numpy array
        Sample vertices, or positions (kept as given: the vector fill locates them on the surface).
    vectors : (k, 3) float64 numpy array
        One arrow per sample (``vx, vy, vz``).
    name : str
        The field's name in files (:data:`VECTOR_NAME`).
    samples : manifill.surface.samples.Samples
        The samples as read (snap distances, merged rows).
    """

    where: np.ndarray
    vectors: np.ndarray
    name: str
    samples: Samples

    @property
    def magnitudes(self):
        """``|vectors|``, one per arrow."""
        return np.linalg.norm(self.vectors, axis=1)


def read_vector_samples(path, V, *, duplicates="error", max_distance=None, vertex_numbering=None):
    """Read arrows: a sample table whose value columns are ``vx, vy, vz``.

    Parameters
    ----------
    path : str or Path
        ``.csv`` (``vertex,vx,vy,vz`` or ``x,y,z,vx,vy,vz``), ``.npz`` (``idx`` or ``points`` and ``vectors``
        ``(k, 3)``) or a structured ``.npy`` with those fields.
    V : (n, 3) numpy array
        The mesh's vertices.
    duplicates, max_distance, vertex_numbering
        As :func:`manifill.io.samples.read_samples` (several arrows on one vertex: refused, or averaged).

    Returns
    -------
    VectorSamples

    Raises
    ------
    ReadError, SampleError
        As :func:`~manifill.io.samples.read_samples`; a table without ``vx, vy, vz`` or with only some of them.
    """
    path = Path(path)
    S = read_samples(path, V, duplicates=duplicates, max_distance=max_distance, vertex_numbering=vertex_numbering,
                     keep_points=True)
    cols = vector_columns(S.names, path)
    if cols is None:
        raise SampleError(f"{path.name}: no arrows (columns {', '.join(S.names)}); name the components vx, vy, vz")
    if S.points is not None:
        return VectorSamples(S.points, S.point_vals[:, cols], VECTOR_NAME, S)
    return VectorSamples(S.idx, S.vals[:, cols], VECTOR_NAME, S)
