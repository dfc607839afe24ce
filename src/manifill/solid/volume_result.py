"""The result of Steps 1-8 on a solid (voxels or tets): :class:`VolumeReconstruction`.

Made by the ``reconstruct_volume`` functions (:mod:`manifill.solid.reconstruct_volume`)
and by the solid's gp (:mod:`manifill.solid.gp`); its own module, so that neither of
those imports the other.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..errors import OptionError
from ..mesh.gradients import cell_gradients, grid_gradients, tet_gradient_operator, vertex_gradients
from ..mesh.objects import to_meshio, to_pyvista
from ..results import BOUNDARY_MASK, SAMPLE_MASK, TRUSTED, Result, with_std
from .tets import boundary_vertices

if TYPE_CHECKING:  # the types of the optional objects a result converts to
    import meshio
    import pyvista

__all__ = ["VolumeReconstruction"]


@dataclass(repr=False)
class VolumeReconstruction(Result):
    """The result of the ``reconstruct_volume`` functions (a :class:`manifill.results.Result`).

    Attributes
    ----------
    values : numpy array
        ``form='voxels'``: shaped like ``mask`` (plus a field axis for several
        fields), NaN outside the solid. ``form='tets'``: one row per vertex of
        ``TV``.
    form : {'voxels', 'tets'}
    surface : Reconstruction
        Steps 1-6 on the boundary surface (on the digital surface for a mask:
        its vertices are ``surface_voxels``); None with ``method='gp'`` (no surface pass).
    mask : (n0, n1, n2) bool numpy array or None
    spacing, origin : (3,) numpy arrays or None
        The grid: voxel ``(i, j, k)`` is at ``origin + (i, j, k) * spacing``.
    fixed : (n0, n1, n2) bool numpy array or None
        The voxels whose values came from the surface (D).
    TV : (N, 3) numpy array or None
    TT : (M, 4) int64 numpy array or None
    surface_voxels : (d, 3) int64 numpy array or None
        For a mask: the voxel of each vertex of the digital surface.
    report : dict
        Counts, the fill's solver report and ``seconds`` per step.
    samples : numpy array or None
        Where the samples are in the solid: tets, the ``(k,)`` vertices of
        ``TV``; a mask, the ``(k, 3)`` sampled voxels; a voxelised surface,
        None (its samples are surface vertices, not voxels).
    std, trusted : numpy arrays or None
        ``method='gp'`` (:mod:`manifill.solid.gp`): the posterior std, shaped like ``values``
        (written as ``<field>_std``), and with ``trust=`` the ``trusted`` mask.
    names : list of str or None
        The fields' names (``value, value2, ...`` when None).
    drawer : callable or None
        ``(count, seed) ->`` posterior draws shaped like ``values`` plus a draws axis (the solid's gp), for
        :meth:`sample`; None otherwise.

    Examples
    --------
    >>> mask = np.ones((3, 3, 3), dtype=bool)
    >>> fixed = mask.copy()
    >>> fixed[1, 1, 1] = False  # the one voxel inside
    >>> r = VolumeReconstruction(np.zeros((3, 3, 3)), "voxels", None, mask=mask, fixed=fixed)
    >>> sorted(r.point_data(["t"])), int(r.masks()["boundary_mask"].sum())
    (['boundary_mask', 't'], 26)
    """

    values: np.ndarray
    form: str
    surface: object  # a manifill.surface.reconstruction.Reconstruction, or None
    mask: np.ndarray | None = None
    spacing: np.ndarray | None = None
    origin: np.ndarray | None = None
    fixed: np.ndarray | None = None
    TV: np.ndarray | None = None
    TT: np.ndarray | None = None
    surface_voxels: np.ndarray | None = None
    report: dict = field(default_factory=dict)
    samples: np.ndarray | None = None
    std: np.ndarray | None = None
    trusted: np.ndarray | None = None
    names: list | None = None
    #: ``(count, seed) ->`` posterior draws shaped like ``values`` plus a draws axis (the solid's gp), or None
    drawer: object = field(default=None, repr=False, compare=False)

    def _draws(self, count, seed):
        if self.drawer is None:
            raise OptionError("this solid has no fitted probability model to draw from; use method='gp' "
                              "(manifill.gp_tets, gp_voxels or reconstruct_volume(..., method='gp'))")
        return self.drawer(count, seed)

    def _gradient(self, X, at):
        if self.form == "voxels":  # differences on the grid: one gradient per voxel either way
            return grid_gradients(X, self.mask, self.spacing)
        G, vol = tet_gradient_operator(self.TV, self.TT)
        g = cell_gradients(G, X)
        return g if at == "cells" else vertex_gradients(self.TT, vol, g, len(self.TV))

    def _domain(self):
        if self.form == "voxels":
            return f"{int(np.count_nonzero(self.mask)):,} voxels of a {'x'.join(map(str, self.mask.shape))} grid"
        return f"{len(self.TV):,} vertices, {len(self.TT):,} tetrahedra"

    @property
    def point_ndim(self) -> int:  # type: ignore[override]  # the base's class attribute, by form here
        """Leading axes of ``values`` that index points: 3 for voxels, 1 for tet vertices."""
        return 3 if self.form == "voxels" else 1

    def masks(self) -> dict[str, np.ndarray]:
        """The boundary mask D, and for tets the sample mask, by name.

        Returns
        -------
        dict of str to numpy array
            Voxels: ``{BOUNDARY_MASK: fixed}``, (n0, n1, n2) bool. Tets:
            ``BOUNDARY_MASK`` (the vertices of :func:`manifill.solid.tets.boundary_faces`)
            and ``SAMPLE_MASK`` (the sample vertices), (N,) bool.
        """
        extra = {} if self.trusted is None else {TRUSTED: self.trusted}
        if self.form == "voxels":
            return {BOUNDARY_MASK: self.fixed, **extra}  # type: ignore[dict-item]  # voxels: fixed is set
        n = len(self.TV)  # type: ignore[arg-type]  # tets: TV is set
        boundary = np.zeros(n, dtype=bool)
        boundary[boundary_vertices(self.TT)] = True
        sample = np.zeros(n, dtype=bool)
        if self.samples is not None:
            sample[self.samples] = True
        return {BOUNDARY_MASK: boundary, SAMPLE_MASK: sample, **extra}

    def point_data(self, names: Sequence[str] | None = None) -> dict[str, np.ndarray]:
        """The fields, their std (``<field>_std``, with ``method='gp'``), then :meth:`masks`."""
        names = self.field_names if names is None else names
        return with_std(super().point_data(names), self.std, names, self.point_ndim)

    def to_pyvista(self, names: Sequence[str] | None = None) -> pyvista.ImageData | pyvista.UnstructuredGrid:
        """The solid as a ``pyvista.ImageData`` (voxels; NaN outside) or ``UnstructuredGrid`` (tets).

        Needs the ``[viz]`` extra. Voxel ``(i, j, k)`` is the point at ``origin + (i, j, k) * spacing``.
        """
        data = self.point_data(names)
        if self.form == "tets":
            return to_pyvista(self.TV, self.TT, data)
        try:
            import pyvista as pv
        except ImportError:
            raise ImportError("converting to pyvista needs pyvista: pip install 'manifill[viz]'") from None
        img = pv.ImageData(dimensions=self.mask.shape, spacing=tuple(self.spacing), origin=tuple(self.origin))  # type: ignore[union-attr, arg-type]
        for name, arr in data.items():
            arr = np.asarray(arr)
            arr = arr.astype(np.uint8) if arr.dtype == bool else arr
            img.point_data[name] = arr.reshape(-1, order="F")  # x fastest, as VTK orders points
        return img

    def to_meshio(self, names: Sequence[str] | None = None) -> meshio.Mesh:
        """The tetrahedral solid as a ``meshio.Mesh`` (voxels: use :meth:`to_pyvista` or ``write_vti``)."""
        if self.form != "tets":
            raise OptionError("a voxel result has no meshio form; use to_pyvista() or manifill.io.solids.write_vti")
        return to_meshio(self.TV, self.TT, self.point_data(names))
