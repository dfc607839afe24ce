"""The result of a reconstruction on a surface: :class:`Reconstruction` (values, masks, std, files)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, overload

import numpy as np
from numpy.typing import ArrayLike

from ..errors import OptionError
from ..results import CURVE_MASK, PATCH_LABEL, SAMPLE_MASK, TRUSTED, Result, with_std
from ..mesh.gradients import cell_gradients, gradient_operator, vertex_gradients
from ..mesh.objects import to_meshio
from ..mesh.objects import to_pyvista
from .curve_values import vertex_normals
from .locate import locate_points

if TYPE_CHECKING:  # the types of the optional objects a result converts to
    import meshio
    import pyvista

__all__ = ["Reconstruction"]


@dataclass(repr=False)
class Reconstruction(Result):
    """The result of :func:`reconstruct` and :func:`reconstruct_surface` (a :class:`manifill.results.Result`).

    Attributes
    ----------
    values : (n,) or (n, p) numpy array
        The field at every vertex, equal to the samples at the samples.
    curves : list of (l,) int64 numpy arrays
        The partition curves (``gvf-harmonic``; empty otherwise).
    components : (n,) int64 numpy array
        Patch of every vertex, ``-1`` on the curves (all ``0`` for methods
        without a partition).
    on_curve : (n,) bool numpy array
        The vertices whose values were fixed before the harmonic fill.
    levels : list of (m,) numpy arrays
        The value levels of each field (Step 1).
    report : dict
        Diagnostics: the gradual variation check per field (Lipschitz
        constant, level step, violations), the partition's report, the
        harmonic solver's report, and ``seconds`` per step.
    V : (n, 3) numpy array
        The surface's vertices (as validated).
    F : (m, 3) int64 numpy array or None
        Its triangles (None on a digital surface, which has none).
    idx : (k,) int64 numpy array
        The sample vertices (sorted, unique); for samples given as positions,
        their nearest vertices.
    points : SurfacePoints or None
        For samples given as positions: each located at its closest surface point
        (:class:`manifill.surface.locate.SurfacePoints`: face, barycentric
        coordinates, distance, nearest vertex); ``None`` for vertex indices.
    std : (n,) or (n, p) numpy array or None
        The posterior standard deviation (``method='gp'``, or ``uncertainty=True``);
        written to files as ``<field>_std``.
    trusted : (n,) bool numpy array or None
        With ``trust=``: False where the std of some field exceeds the threshold.
    names : list of str or None
        The fields' names (:attr:`field_names` makes ``value, value2, ...`` when None).
    source : object or None
        The mesh object the reconstruction was given (a pyvista, trimesh or meshio mesh), whose own
        per-vertex (and per-face) arrays :meth:`to_pyvista` and :meth:`to_meshio` carry over.
    made_by, compact, cloud, cut, on_cut, barrier_faces : object or None
        How it was made, for its own methods (not written to files): the method (its draws for
        :meth:`sample`); the renumbering of a mesh with vertices used by no face; a point cloud's neighbourhoods
        and operators; the mesh cut along ``barriers=`` and the result on it (for its gradient); the faces along
        the barriers of the gp's Bakka model.
    """

    values: np.ndarray
    curves: list
    components: np.ndarray
    on_curve: np.ndarray
    levels: list
    report: dict = field(default_factory=dict)
    V: np.ndarray | None = None
    F: np.ndarray | None = None
    idx: np.ndarray | None = None
    points: object = None
    std: np.ndarray | None = None
    trusted: np.ndarray | None = None
    names: list | None = None
    source: object = None
    #: the method that made it (its :meth:`draws` for :meth:`sample`); not a field of the result's files
    made_by: object = field(default=None, repr=False, compare=False)
    #: for a mesh with vertices used by no face, the renumbering it ran on (:mod:`manifill.surface.unreferenced`)
    compact: object = field(default=None, repr=False, compare=False)
    #: for a point cloud, its neighbourhoods and operators (:class:`manifill.mesh.pointcloud.Cloud`)
    cloud: object = field(default=None, repr=False, compare=False)
    #: with ``barriers``, the cut mesh (:class:`manifill.surface.barriers.Cut`) and the result on its copies
    cut: object = field(default=None, repr=False, compare=False)
    on_cut: object = field(default=None, repr=False, compare=False)
    #: with gp's barrier='bakka', the faces along the barriers (the draws' precision needs them)
    barrier_faces: object = field(default=None, repr=False, compare=False)

    def _gradient(self, X, at):
        if self.cut is not None:  # each face's own side of the barriers
            if X is not self.values:
                raise OptionError("the gradient's std is not available with barriers (the draws are averaged over "
                                  "a barrier's sides); take r.gradient() alone, or reconstruct without barriers")
            inner = self.on_cut
            g = inner._gradient(np.asarray(inner.values), at)
            if at == "cells":
                return g
            g = self.cut.values(g)  # a barrier vertex: the mean of its sides' gradients, tangent to neither side
            N = vertex_normals(self.cut.V_full, self.cut.F_full)  # the whole mesh's normal there
            N = N if g.ndim == 2 else N[:, None, :]
            g = g - np.sum(g * N, axis=-1, keepdims=True) * N
            return g if self.compact is None else self.compact.full(g)
        if self.cloud is not None:
            if at == "cells":
                raise OptionError("a point cloud has no cells; take its gradient at='vertices' (per point, a "
                                  "least-squares plane through its neighbours)")
            g = (self.cloud.gradient_operator() @ X.reshape(len(X), -1)).reshape(len(X), 3, -1).transpose(0, 2, 1)
            return g[:, 0, :] if np.ndim(X) == 1 else g
        if self.F is None:
            raise OptionError("a digital surface (voxels) has no triangles to take a gradient on; reconstruct on a "
                              "triangle mesh, or take the volume's gradient")
        G, area = gradient_operator(self.V, self.F)
        g = cell_gradients(G, X)
        if at == "cells":
            return g
        V, F = np.asarray(self.V, dtype=np.float64), np.asarray(self.F, dtype=np.int64)
        return vertex_gradients(F, area, g, len(V), normals=vertex_normals(V, F))

    def _domain(self):
        kind = "vertices" if self.F is not None else "points" if self.cloud is not None else "surface voxels"
        return f"{len(self.values):,} {kind}, {0 if self.idx is None else len(self.idx):,} samples"

    def _draws(self, count, seed):
        if self.made_by is None:
            raise OptionError("this result does not know the method that made it (built by hand?); reconstruct "
                              "with method='gp' to draw from its posterior")
        c = self.compact  # vertices used by no face: drawn on the mesh without them, NaN there
        if self.cut is not None:  # drawn on the mesh cut along the barriers, each split vertex's sides averaged
            out = self.cut.values(self.made_by.draws(self.on_cut, count, seed))
        else:
            out = self.made_by.draws(self if c is None else c.shrink(self), count, seed)
        out = out if c is None else c.full(out)
        return out[:, 0, :] if np.ndim(self.values) == 1 else out

    @overload
    def at(self, points: ArrayLike, *, return_std: Literal[False] = ...,
           max_distance: float | None = ...) -> np.ndarray: ...
    @overload
    def at(self, points: ArrayLike, *, return_std: Literal[True],
           max_distance: float | None = ...) -> tuple[np.ndarray, np.ndarray]: ...
    @overload
    def at(self, points: ArrayLike, *, return_std: bool,
           max_distance: float | None = ...) -> np.ndarray | tuple[np.ndarray, np.ndarray]: ...

    def at(self, points: ArrayLike, *, return_std: bool = False,
           max_distance: float | None = None) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """The fields at points on (or near) the surface, linear on each triangle.

        Parameters
        ----------
        points : (m, 3) array_like of float
            Positions; each is located at its closest point of the surface
            (:func:`manifill.surface.locate.locate_points`); points farther than the
            samples' limit are refused, as samples would be.
        return_std : bool, optional
            Also return the std there (results with a std: ``method='gp'`` or
            ``uncertainty=True``): the same barycentric weights applied to the vertices'
            std, an upper bound of the std of the interpolated value.
        max_distance : float, optional
            As for samples at positions.

        Returns
        -------
        values : (m,) or (m, p) numpy array
        std : (m,) or (m, p) numpy array
            With ``return_std=True``.

        Examples
        --------
        >>> from manifill.mesh.shapes import icosphere
        >>> from manifill.surface.reconstruct import reconstruct
        >>> V, F = icosphere(2)
        >>> r = reconstruct(V, F, [0, 10, 50, 90, 120], [1.0, 2.0, 3.0, 4.0, 5.0])
        >>> bool(abs(r.at(V[[10]] * 1.001)[0] - 2.0) < 1e-9)
        True
        """
        if self.F is None and self.cloud is None:
            raise OptionError("at() interpolates on triangles; a digital surface has none: index r.values by vertex")
        if return_std and self.std is None:
            raise OptionError("this result has no std; reconstruct with method='gp' or uncertainty=True")
        where: Any = self if self.cut is None else self.on_cut  # with barriers: each face's own side
        loc = locate_points(where.V, where.F, points, max_distance=max_distance)
        out = [np.einsum("mc,mc...->m...", loc.bary, a[loc.corners])
               for a in ((where.values, where.std) if return_std else (where.values,))]
        return tuple(out) if return_std else out[0]

    def plot(self, field: str | None = None, **kwargs: Any) -> Any:
        """Draw the result with pyvista (the ``[viz]`` extra): ``self.to_pyvista().plot(scalars=field)``."""
        mesh = self.to_pyvista()
        return mesh.plot(scalars=self.field_names[0] if field is None else field, **kwargs)

    @property
    def sample_mask(self) -> np.ndarray:
        """(n,) bool numpy array: True at the sample vertices."""
        sample = np.zeros(len(self.values), dtype=bool)
        sample[self.idx] = True
        return sample

    def masks(self) -> dict[str, np.ndarray]:
        """``sample_mask``; with a partition (the pipeline's methods) ``curve_mask`` (:attr:`on_curve`) and
        ``patch_label`` (:attr:`components`); ``trusted`` with ``trust=``.

        Examples
        --------
        >>> from manifill.mesh.shapes import icosphere
        >>> V, F = icosphere(2)
        >>> from manifill.surface.reconstruct import reconstruct
        >>> r = reconstruct(V, F, [0, 10, 50, 90, 120], [1.0, 2.0, 3.0, 4.0, 5.0], method="gvf-harmonic")
        >>> list(r.masks()), int(r.masks()["sample_mask"].sum())
        (['sample_mask', 'curve_mask', 'patch_label'], 5)
        >>> list(reconstruct(V, F, [0, 10, 50, 90, 120], [1.0, 2.0, 3.0, 4.0, 5.0]).masks())  # the default
        ['sample_mask']
        """
        out = {SAMPLE_MASK: self.sample_mask}
        if len(self.curves):  # curves and patches mean something only where a partition ran
            out.update({CURVE_MASK: self.on_curve, PATCH_LABEL: self.components})
        if self.trusted is not None:
            out[TRUSTED] = self.trusted
        return out

    def point_data(self, names: Sequence[str] | None = None) -> dict[str, np.ndarray]:
        """The fields and manifill's masks, named as in every output file.

        Parameters
        ----------
        names : list of str, optional
            One name per field (``value``, ``value2``, ... by default).

        Returns
        -------
        dict of str to (n,) numpy array
            The fields, their standard deviations (``<name>_std``, when computed),
            ``sample_mask``, ``curve_mask``, ``patch_label`` (and ``trusted``).
        """
        return with_std(super().point_data(names), self.std, self.field_names if names is None else names)

    def to_pyvista(self, names: Sequence[str] | None = None) -> pyvista.PolyData:
        """The surface with every field and mask as a ``pyvista.PolyData`` (needs the ``[viz]`` extra).

        Examples
        --------
        >>> from manifill.mesh.shapes import icosphere
        >>> V, F = icosphere(2)
        >>> from manifill.surface.reconstruct import reconstruct
        >>> r = reconstruct(V, F, [0, 10, 50, 90, 120], [1.0, 2.0, 3.0, 4.0, 5.0], method="gvf-harmonic")
        >>> sorted(r.to_pyvista(["t"]).point_data.keys())
        ['curve_mask', 'patch_label', 'sample_mask', 't']
        """

        mesh = to_pyvista(self.V, self.F, self.point_data(names))
        cells = -1 if self.F is None else len(self.F)  # a point cloud: no cells of the source to carry
        for kind, ours, count in (("point_data", mesh.point_data, len(self.V)), ("cell_data", mesh.cell_data, cells)):  # type: ignore[arg-type]
            theirs = getattr(self.source, kind, None)
            pyvista = type(self.source).__module__.startswith("pyvista")  # meshio's cell data is per block
            if theirs is None or (kind == "cell_data" and (not pyvista or self.source.n_cells != count)):  # type: ignore[attr-defined]
                continue
            for key in list(theirs.keys()):
                if key not in ours.keys() and len(theirs[key]) == count:
                    ours[key] = theirs[key]
        return mesh

    def to_meshio(self, names: Sequence[str] | None = None) -> meshio.Mesh:
        """The surface with every field and mask as a ``meshio.Mesh``."""

        data = self.point_data(names)
        theirs = getattr(self.source, "point_data", None) or {}
        extra = {key: np.asarray(a) for key, a in dict(theirs).items()
                 if key not in data and len(np.asarray(a)) == len(self.V)}  # type: ignore[arg-type]
        return to_meshio(self.V, self.F, {**data, **extra})
