"""The result of a vector reconstruction: a tangent vector per vertex and per face, magnitudes, singularities."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..mesh.objects import to_meshio, to_pyvista
from ..results import SAMPLE_MASK, Result, field_names, sample_mask

if TYPE_CHECKING:  # the types of the optional objects a result converts to
    import meshio
    import pyvista

__all__ = ["VectorReconstruction"]


class VectorReconstruction(Result):
    """Tangent vector fields on a surface (what :func:`manifill.reconstruct_vectors` returns).

    Parameters
    ----------
    V, F, values, faces, idx, symmetry, singularities, std, report, names, normals
        The attributes below.
    draws : callable, optional
        ``draws(count, seed)``: whole fields from the posterior (``method='gp'``), for :meth:`sample`.

    Attributes
    ----------
    values : (n, 3) or (n, 3, p) numpy array
        The vector at every vertex (tangent to the surface: in the plane normal to the vertex normal); ``p``
        fields (e.g. times) on the last axis.
    faces : (m, 3) or (m, 3, p) numpy array
        The vector of every face (in its plane).
    magnitude : (n,) or (n, p) numpy array
        ``|values|`` per vertex.
    std : (n,) or (n, p) numpy array or None
        ``method='gp'``: the std of each tangent component (the posterior is isotropic in the tangent plane:
        the covariance of the vertex's vector is ``std**2`` times the tangent plane's projector).
    singularities : list of dict
        Per field: ``faces`` (the faces holding a singularity), ``index`` (their index: integers for arrows,
        multiples of 1/2 for lines, 1/4 for crosses) and ``positions`` (the faces' centroids). On a closed surface
        the indices sum to its Euler characteristic.
    V, F : numpy arrays
        The mesh.
    normals : (n, 3) numpy array
        The unit vertex normals (area-weighted) the vectors are tangent to.
    idx : numpy array
        The sample vertices (``-1`` for samples inside faces).
    symmetry : int
        1 (arrows), 2 (lines) or 4 (crosses): a line's vector is one of its two directions.
    report : dict
        What ran: ``method``, ``symmetry``, ``fit``, ``samples``, ``bounds`` (the largest magnitude allowed and how
        many vertices were brought down to it), ``smoothing``, ``gp``, ``seconds``.
    names : list of str or None
        The fields' names (files write ``<name>`` as 3-vectors, ``<name>_magnitude`` and, with a gp,
        ``<name>_std``).
    """

    #: What :meth:`save` writes (``manifill.io.vector_files``): 3-vectors per vertex and per face.
    form = "vectors"

    def __init__(self, V: ArrayLike, F: ArrayLike | None, values: np.ndarray, faces: np.ndarray, *, idx: ArrayLike,
                 symmetry: int = 1, singularities: list[dict] | None = None, std: np.ndarray | None = None,
                 report: dict | None = None, names: Sequence[str] | None = None,
                 draws: Callable[[int, int], np.ndarray] | None = None, normals: np.ndarray | None = None) -> None:
        self.V, self.F, self.normals = V, F, normals
        self.values, self.faces = values, faces
        self.magnitude = np.linalg.norm(values, axis=1)
        self.idx = np.asarray(idx, dtype=np.int64)
        self.symmetry = symmetry
        self.singularities = singularities or []
        self.std = std
        self.report = report or {}
        self.names = names
        self._draw = draws

    def fields(self) -> np.ndarray:
        """``values`` with a last axis per field: ``(n, 3, p)``."""
        return self.values if self.values.ndim == 3 else self.values[..., None]

    def __repr__(self):
        """The method, the mesh, each field's largest magnitude and its singularities."""
        X = self.fields()
        lines = [f"<VectorReconstruction: {self.report.get('method', 'vectors')} on {len(self.V):,} vertices, "
                 f"{len(self.idx)} samples, {X.shape[-1]} field{'s' * (X.shape[-1] > 1)}"]
        for j, name in enumerate(self.field_names[:5]):
            mag = np.linalg.norm(X[..., j], axis=1)
            sing = self.singularities[j]["faces"].size if j < len(self.singularities) else 0
            lines.append(f"  {name}  |v| [{np.nanmin(mag):.4g}, {np.nanmax(mag):.4g}], {sing} singularities")
        return "\n".join(lines) + ">"

    def _domain(self):
        return f"{len(self.V):,} vertices, {len(self.idx)} samples"

    def masks(self) -> dict[str, np.ndarray]:
        """The samples' mask (1 at sample vertices)."""
        return {SAMPLE_MASK: sample_mask(len(self.V), self.idx[self.idx >= 0])}  # type: ignore[arg-type]

    def point_data(self, names: Sequence[str] | None = None) -> dict[str, np.ndarray]:
        """Per field ``<name>`` (3-vectors), ``<name>_magnitude`` (and ``<name>_std``), then the masks."""
        X = self.fields()
        names = self.field_names if names is None else field_names(names, X.shape[-1])
        out = {}
        S = None if self.std is None else (self.std if self.std.ndim == 2 else self.std[:, None])
        for j, name in enumerate(names):
            out[name] = X[..., j]
            out[f"{name}_magnitude"] = np.linalg.norm(X[..., j], axis=1)
            if S is not None:
                out[f"{name}_std"] = S[:, j]
        return {**out, **self.masks()}

    def cell_data(self, names: Sequence[str] | None = None) -> dict[str, np.ndarray]:
        """Per field ``<name>``: the face vectors ``(m, 3)`` (none on a point cloud)."""
        if self.F is None:
            return {}
        Y = self.faces if self.faces.ndim == 3 else self.faces[..., None]
        names = self.field_names if names is None else field_names(names, Y.shape[-1])
        return {name: Y[..., j] for j, name in enumerate(names)}

    def save(self, path: str | os.PathLike[str], names: Sequence[str] | None = None) -> Path:
        """Write the field(s) to ``path``, as the format holds vectors (:mod:`manifill.io.vector_files`).

        ``.vtu``, ``.vtp``, ``.vtk``: each field ``<name>`` one 3-component point array (the first the active vectors,
        which ParaView's Glyph filter follows), ``<name>_magnitude`` (and ``<name>_std``), the sample mask, and the
        face vectors as a 3-component cell array ``<name>``; ``.ply``: ``<name>_x``, ``_y``, ``_z`` per vertex (no
        face vectors); ``.csv``: columns ``vertex, <name>_x, <name>_y, <name>_z, <name>_magnitude``; ``.npy``: the
        ``(n, 3)`` array of one field.

        Parameters
        ----------
        path : str or path-like
        names : list of str, optional
            One name per field (default :attr:`field_names`).

        Returns
        -------
        pathlib.Path
            The file written (atomically: nothing is left half-written).
        """
        return super().save(path, names)

    def to_pyvista(self, names: Sequence[str] | None = None) -> pyvista.PolyData:
        """The surface with the vectors as point data (the first field active, for glyphs) and the face vectors
        as cell data (needs the ``[viz]`` extra)."""
        mesh = to_pyvista(self.V, self.F, self.point_data(names))
        for name, Y in self.cell_data(names).items():
            mesh.cell_data[name] = Y
        first = (self.field_names if names is None else field_names(names, self.fields().shape[-1]))[0]
        mesh.set_active_vectors(first)
        return mesh

    def to_meshio(self, names: Sequence[str] | None = None) -> meshio.Mesh:
        """The surface with the vectors as point data and the face vectors as cell data, as a ``meshio.Mesh``."""
        mesh = to_meshio(self.V, self.F, self.point_data(names))
        mesh.cell_data.update({name: [Y] for name, Y in self.cell_data(names).items()})
        return mesh

    def _draws(self, count, seed):
        if self._draw is None:
            return super()._draws(count, seed)
        return self._draw(count, seed)
