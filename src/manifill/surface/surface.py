"""The surface the paper's Steps 1-6 run on: positions, two graphs, a Laplacian, normals.

A :class:`Surface` is what :func:`manifill.surface.reconstruct.reconstruct_surface` and
the steps it composes (:mod:`manifill.surface.gradual`, :mod:`manifill.surface.partition`,
:mod:`manifill.surface.curve_values`, :mod:`manifill.surface.fill`) need of a surface.
A triangle mesh gives all of it from ``(V, F)`` (:meth:`Surface.from_mesh`); a digital
surface (the boundary voxels of a solid, :func:`manifill.solid.boundary.digital_surface_graph`) gives
graphs from voxel adjacency, normals from the solid, and has no triangles (``F`` is None). A point cloud
(:meth:`Surface.from_points`) has no triangles either, but a Laplacian and a mass from each point's local
Delaunay fan (:class:`manifill.mesh.pointcloud.Cloud`), so that every method runs on it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..mesh.graph import DISTANCES, mesh_graph
from ..mesh.laplacian import assemble_laplacian, mass_matrix
from ..mesh.edges import EdgeIndex
from ..mesh.pointcloud import NEIGHBOURS, Cloud
from ..validate import as_mesh, as_points, check_option
from .barriers import Cut

__all__ = ["Surface"]


class _CachedLaplacian:
    """``weights -> L``, each Laplacian built once by ``build(weights)``."""

    def __init__(self, build):
        self.build = build
        self.cache = {}

    def __call__(self, weights):
        if weights not in self.cache:
            self.cache[weights] = self.build(weights)
        return self.cache[weights]


@dataclass
class Surface:
    """A validated surface: what Steps 1-6 need of it.

    Attributes
    ----------
    V : (n, 3) numpy array
        Vertex positions (a digital surface: voxel centres).
    G_hops : (n, n) scipy sparse matrix
        The graph with unit edge lengths (Step 1 measures hops).
    G : (n, n) scipy sparse matrix
        The graph whose shortest paths the partition follows (Steps 2-3):
        ``G_hops`` itself, or edge lengths.
    laplacian : callable
        ``laplacian(weights)`` gives the (n, n) sparse Laplacian of the harmonic
        fill (Steps 5-6) for a weight name of :mod:`manifill.mesh.laplacian`;
        built on the first call for each name and cached (the same object is
        returned after; do not modify it). Any callable passed is wrapped so.
    F : (m, 3) int64 numpy array or None
        Triangles (None on a digital surface).
    normals : (n, 3) numpy array or None
        Unit normals, where the surface has no triangles to compute them from
        (Step 4's Hermite slopes).
    index : EdgeIndex or None
        The edge index of ``F`` (:class:`manifill.mesh.edges.EdgeIndex`),
        shared by both graphs and the Laplacians.
    mass : callable or None
        ``mass(kind, weights)`` gives the (n, n) diagonal lumped mass (``kind`` one of
        :func:`manifill.mesh.laplacian.mass_matrix`'s on a mesh; a point cloud has one mass, or the
        robust Laplacian's own for ``weights='robust'``); None on a digital surface (the methods that
        need a mass refuse it).
    cloud : Cloud or None
        A point cloud's neighbourhoods and operators (:class:`manifill.mesh.pointcloud.Cloud`).
    cut : Cut or None
        For a mesh cut along barriers, the cut (:class:`manifill.surface.barriers.Cut`): ``piece`` labels the
        pieces it parts the surface into (what a method working in space needs).
    barrier_faces : (m,) bool numpy array or None
        The faces along barriers, for ``method='gp'`` with ``gp={'barrier': 'bakka'}`` (the mesh is not cut).

    See Also
    --------
    manifill.surface.reconstruct.reconstruct_surface : Steps 1-6 on a Surface.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(1)
    >>> s = Surface.from_mesh(V, F)
    >>> s.G.shape, s.laplacian("uniform") is s.laplacian("uniform")
    ((42, 42), True)
    """

    V: np.ndarray
    G_hops: object
    G: object
    laplacian: object
    F: np.ndarray | None = None
    normals: np.ndarray | None = None
    index: object = None
    mass: object = None
    cloud: Any = None
    cut: Any = None
    barrier_faces: Any = None

    def __post_init__(self):
        if not isinstance(self.laplacian, _CachedLaplacian):
            self.laplacian = _CachedLaplacian(self.laplacian)

    @property
    def n(self) -> int:
        """Number of vertices."""
        return len(self.V)

    @classmethod
    def from_mesh(cls, V: ArrayLike, F: ArrayLike, *, distance: str = "length", allow_degenerate: bool = False,
                  check: bool = True, cut: Cut | None = None) -> Surface:
        """A triangle mesh as a Surface: validated, with its edge index, both graphs and Laplacians.

        Parameters
        ----------
        V : (n, 3) array_like
            Vertex positions.
        F : (m, 3) array_like of int
            Triangles, any integer dtype.
        distance : {'length', 'hops'}, optional
            The edge lengths of ``G`` (see :func:`manifill.mesh.graph.mesh_graph`).
        allow_degenerate : bool, optional
            Accept zero-area triangles (fine for ``uniform`` and ``robust``
            weights; see :func:`manifill.validate.as_mesh`).
        check : bool, optional
            Validate ``(V, F)`` with :func:`manifill.validate.as_mesh`; pass
            False only for arrays it has already returned.
        cut : Cut, optional
            The mesh cut along barriers (:class:`manifill.surface.barriers.Cut`): the surface is its copies.

        Returns
        -------
        Surface

        Raises
        ------
        MeshError
            On a malformed mesh.
        OptionError
            On an unknown ``distance``.

        Examples
        --------
        >>> from manifill.mesh.shapes import grid
        >>> s = Surface.from_mesh(*grid(3), distance="hops")
        >>> s.G is s.G_hops, s.laplacian("uniform").shape
        (True, (9, 9))
        """
        check_option("distance", distance, DISTANCES)
        if cut is not None:
            V, F = cut.V, cut.F
        elif check:
            V, F = as_mesh(V, F, allow_degenerate=allow_degenerate)
        n = len(V)  # type: ignore[arg-type]  # check=False: arrays that as_mesh returned
        index = EdgeIndex(F, n)
        G_hops = mesh_graph(V, F, distance="hops", index=index)
        G = G_hops if distance == "hops" else mesh_graph(V, F, distance="length", index=index)
        return cls(V, G_hops, G, lambda w: assemble_laplacian(V, F, w, index), F=F, index=index,  # type: ignore[arg-type]
                   mass=lambda kind, weights=None: mass_matrix(V, F, mass=kind), cut=cut)

    @classmethod
    def from_points(cls, P: ArrayLike, *, neighbours: int | None = None, distance: str = "length",
                    check: bool = True) -> Surface:
        """A point cloud as a Surface: graphs, Laplacians, mass and normals from its points alone.

        Parameters
        ----------
        P : (n, 3) array_like
            The points.
        neighbours : int, optional
            Nearest neighbours per point (:data:`manifill.mesh.pointcloud.NEIGHBOURS` by default).
        distance : {'length', 'hops'}, optional
            The edge lengths of ``G``.
        check : bool, optional
            Validate ``P`` with :func:`manifill.validate.as_points`.

        Returns
        -------
        Surface
            ``F`` None, ``cloud`` the :class:`~manifill.mesh.pointcloud.Cloud`; the graphs join each point
            to its local Delaunay neighbours; ``laplacian('uniform')`` is that graph's, every other weight
            name the fans' cotangent Laplacian (``'robust'``: Sharp & Crane's, from robust-laplacian).

        Examples
        --------
        >>> from manifill.mesh.shapes import icosphere
        >>> s = Surface.from_points(icosphere(2)[0])
        >>> s.n, s.F is None, s.cloud.components, s.mass("voronoi").shape
        (162, True, 1, (162, 162))
        """
        check_option("distance", distance, DISTANCES)
        if check:
            P = as_points(P)
        cloud = Cloud(P, NEIGHBOURS if neighbours is None else int(neighbours))
        G_hops = cloud.graph("hops")
        G = G_hops if distance == "hops" else cloud.graph("length")
        return cls(P, G_hops, G, cloud.laplacian, normals=cloud.normals,  # type: ignore[arg-type]
                   mass=lambda kind, weights=None: cloud.mass(weights), cloud=cloud)
