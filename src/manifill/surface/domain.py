"""Where a prepared reconstruction works: the caller's mesh made ready, its samples placed on it, and the way back.

:class:`Domain` leaves out the vertices no face uses (:mod:`manifill.surface.unreferenced`), cuts the mesh along
``barriers=`` (:mod:`manifill.surface.barriers`) or marks the faces along them for the gp's Bakka model, locates
samples given as positions once, and holds a sample on a barrier on every side. It places each call's values
on that mesh and puts the result back in the caller's numbering (:class:`manifill.Reconstructor` holds one).
"""

import numpy as np

from ..errors import OptionError, SampleError
from ..validate import as_indices, as_mesh, as_points, as_samples
from ..validate.objects import is_mesh_object
from .barriers import Cut, barrier_faces, renumber
from .locate import locate_points
from .points import is_positions, point_samples
from .samples import weights_by_vertex
from .unreferenced import compact

__all__ = ["Domain"]


class Domain:
    """A mesh (or point cloud) and one sample set, ready for the work, and the way back to the caller's numbering.

    Parameters
    ----------
    V, F, idx
        As for :func:`manifill.reconstruct`: the caller's mesh (``F`` None for a point cloud, or a mesh object
        as ``V``) and its samples (vertex indices or positions).
    options : Options
        Configured (:func:`manifill.surface.methods.registry.configure`); its ``weights``, ``barriers``,
        ``max_distance`` and ``on_empty`` are read.
    method : Method
        The method that runs: its barrier model (:meth:`~manifill.surface.methods.base.Method.barrier_model`)
        and whether it constrains samples inside faces where they are (``at_points``).

    Attributes
    ----------
    V, F : numpy arrays
        The mesh the work runs on: the vertices no face uses left out, cut along the barriers (``F`` None for
        a point cloud).
    compact : Compact or None
        The vertices left out, and the way back (None when every vertex is in a face).
    cut : Cut or None
        The mesh cut along the barriers, and the way back.
    barrier_faces : (m,) bool numpy array or None
        The faces along the barriers, for the gp's Bakka model (the mesh whole).
    located : SurfacePoints or None
        The samples given as positions, located once.
    raw : numpy array
        The samples: positions ``(k, 3)``, or vertex indices ``(k,)`` in the left-out mesh's numbering.
    copies : tuple or None
        ``(vertices, rows)``: every copy of the sample vertices on a cut mesh, sorted, and the row of the
        sorted unique vertices each came from.
    samples : int
        Rows of the values :meth:`place` takes.
    vertices : int
        Vertices the vertex samples index (the left-out mesh's, before a cut).

    Raises
    ------
    MeshError, OptionError, SampleError
        A malformed mesh or sample set, barriers on a point cloud, a barrier model the method does not take
        (or without barriers), a piece the barriers leave without a sample.

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> from manifill.surface.methods.registry import configure, method_of
    >>> V, F = grid(3)
    >>> V = np.vstack([V, [[9.0, 9.0, 0.0]]])        # vertex 9: no face uses it
    >>> d = Domain(V, F, [0, 4, 8], configure(method="harmonic"), method_of("harmonic"))
    >>> d.n, len(d.V), d.samples, d.compact.dropped
    (10, 9, 3, 1)
    """

    def __init__(self, V, F, idx, options, method):
        o = options
        if F is None and not is_mesh_object(V):  # a point cloud
            V, self.compact = as_points(V), None
        else:
            V, F = as_mesh(V, F, allow_degenerate=o.fill.weights in ("uniform", "robust"), allow_unreferenced=True)
            self.compact = compact(V, F)  # vertices used by no face: left out, NaN in the result
        n_full = len(V)
        if self.compact is not None:
            V, F = self.compact.V, self.compact.F
        self.vertices = len(V)  # before a cut: what vertex samples index
        self.V, self.F, self.cut, self.barrier_faces = V, F, None, None
        self._barriers(o, method)
        self.nearest_only, self.max_distance = not method.at_points, o.points.max_distance
        self.located, self.raw, self.copies = None, idx, None
        if is_positions(idx):
            self.raw = np.asarray(idx, dtype=np.float64)  # the positions, kept for every call
            self.located = locate_points(self.V, self.F, self.raw, max_distance=o.points.max_distance)
            self.samples = len(self.raw)
            if self.cut is not None:
                self.cut.check_pieces(self.located.corners[:, 0], o.fill.on_empty)
        elif o.points.max_distance is not None:
            raise OptionError("max_distance applies to samples given as positions, not vertex indices; leave it out")
        else:
            self.raw = as_indices(idx, n_full, what="idx", unique=False)
            if self.compact is not None:
                self.raw = self.compact.indices(self.raw)
            self.samples = self.raw.size
            if self.cut is not None:  # a sample on a barrier holds on each side: a row per copy, sorted
                copies, rows = self.cut.copies(np.unique(self.raw))
                order = np.argsort(copies, kind="stable")
                self.copies = copies[order], rows[order]
                self.cut.check_pieces(copies, o.fill.on_empty)

    def _barriers(self, o, method):
        """Cut the mesh along ``barriers=`` (paths in the caller's numbering), or mark their faces (Bakka's model)."""
        barriers = o.fill.barriers
        if barriers is not None and self.compact is not None:
            barriers = renumber(barriers, self.compact.new)
        model = method.barrier_model(o)  # refuses a model the method does not take, or one without barriers
        if barriers is None:
            return
        if self.F is None:
            raise OptionError("barriers cut a mesh along its edges, and a point cloud has none; give the mesh's "
                              "faces, or leave barriers out")
        if model == "bakka":
            self.barrier_faces = barrier_faces(self.V, self.F, barriers)  # the mesh whole, those faces slow
        else:  # the mesh cut along them: no method sees across
            self.cut = Cut(self.V, self.F, barriers)
            self.V, self.F = self.cut.V, self.cut.F

    @property
    def n(self):
        """Rows of the results: the caller's vertices (before any left out, and before a barrier's cut)."""
        whole = self.compact or self.cut
        return len(self.V) if whole is None else whole.n

    def mesh(self):
        """``(V, F)`` in the caller's numbering (``F`` None for a point cloud): what the results are on."""
        whole = self.compact or self.cut
        return (self.V, self.F) if whole is None else (whole.V_full, whole.F_full)

    def sample_weights(self, weights):
        """The caller's ``sample_weights`` (one per row) as the methods take them.

        Parameters
        ----------
        weights : (k,) array_like of float or None

        Returns
        -------
        numpy array or None
            For vertex samples, one weight per sorted unique vertex (rows on one vertex add up), repeated for
            each copy on a barrier; positions' weights as given.
        """
        if weights is None or self.located is not None:
            return weights
        weights = weights_by_vertex(self.raw, weights, np.unique(self.raw))
        return weights if self.copies is None else weights[self.copies[1]]

    def place(self, vals, duplicates):
        """The values of one call placed on the mesh the work runs on.

        Parameters
        ----------
        vals : (k,) or (k, p) array_like of float
            One row per sample, in the order given.
        duplicates : {'error', 'mean'}
            Samples on one vertex (or at one position) with different values: refused, or averaged.

        Returns
        -------
        tuple
            ``(idx, vals, points, squeeze, given)``: the sample vertices (sorted; every copy on a barrier) and
            their ``(u, p)`` values, the :class:`~manifill.surface.points.PointSamples` of positions (or None),
            whether ``vals`` was one field ``(k,)``, and ``vals`` as ``(k, p)`` in the caller's rows.

        Raises
        ------
        SampleError
            Values with another number of rows, NaN, conflicting duplicates.
        """
        arr = np.asarray(vals, dtype=np.float64) if not isinstance(vals, np.ndarray) else vals
        if arr.ndim not in (1, 2) or arr.shape[0] != self.samples:
            raise SampleError(f"vals has shape {arr.shape}, but this Reconstructor was prepared for "
                              f"{self.samples} samples; pass ({self.samples},) or ({self.samples}, p) values, one "
                              f"row per sample in the order given")
        given = arr.reshape(self.samples, -1)
        if self.located is not None:
            points = point_samples(self.V, self.F, self.raw, arr, duplicates=duplicates,
                                   max_distance=self.max_distance, nearest_only=self.nearest_only,
                                   located=self.located)
            if self.cut is not None:
                points = self.cut.both_sides(points)
            return points.nearest, points.nearest_vals, points, points.squeeze, given
        idx, v, squeeze = as_samples(self.raw, arr, self.vertices, duplicates=duplicates)
        if self.copies is not None:  # checked in the caller's rows, then held on every side of a barrier
            copies, rows = self.copies
            return copies, v[rows], None, squeeze, given
        return idx, v, None, squeeze, given

    def at_samples(self, r):
        """``(k, p)``: the result ``r``'s values (still on the work's mesh) at the samples, in the caller's rows."""
        return r.points.interpolate(r.values) if self.located is not None else r.values[self.raw]

    def expand(self, r):
        """The :class:`~manifill.surface.reconstruction.Reconstruction` ``r`` in the caller's numbering: a cut's
        sides merged (:meth:`Cut.expand`), NaN at the vertices left out (:meth:`Compact.expand`)."""
        if self.cut is not None:
            r = self.cut.expand(r)
        return r if self.compact is None else self.compact.expand(r)
