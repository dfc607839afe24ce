"""Tangent vector fields from arrows at a few places: :class:`VectorReconstructor` (prepared once, applied to
any number of fields or times) and :func:`reconstruct_vectors` (one applied once).

The fill is :mod:`manifill.vectors.fill`'s (the connection's Dirichlet or biharmonic energy, exact at the samples
or smoothed), :mod:`manifill.vectors.hodge`'s (a potential's gradient or a stream function's rotated gradient:
curl-free or divergence-free flows) or :mod:`manifill.vectors.gp`'s (the connection-Laplacian Matérn field: a
mean and a std). Barriers cut the mesh as they do for scalar fields (:class:`manifill.surface.barriers.Cut`).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import OptionError, SampleError
from ..surface.barriers import Cut
from ..surface.curve_values import vertex_normals
from ..validate import as_mesh
from .fill import VectorFill
from .gp import VectorGP
from .hodge import HodgeFit
from .lines import LineFill
from .options import VectorOptions
from .result import VectorReconstruction

__all__ = ["VectorReconstructor", "reconstruct_vectors"]


class VectorReconstructor:
    """Tangent vector fields on one mesh from arrows at fixed places, prepared once.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles.
    idx : (k,) array_like of int, or (k, 3) array_like of float
        Sample vertices, or sample positions (each at its closest surface point).
    barriers : list of paths, or (m,) labels, optional
        Lines no field may cross (as :func:`manifill.reconstruct`'s ``barriers``).
    options : VectorOptions, optional
        All the options below as one checked object (:class:`manifill.VectorOptions`); keywords given beside it
        change it.
    **keywords
        The options one by one:
    method : {'biharmonic', 'harmonic', 'gp'}, optional
        ``biharmonic`` (the default): the smoothest field of the connection's biharmonic energy through the
        arrows; ``harmonic``: of its Dirichlet energy (a vector's direction turns along straight paths between
        samples, with kinks at them); ``gp``: the Matérn field of the connection Laplacian, a mean and a std.
    symmetry : {1, 2, 4}, optional
        1: arrows; 2: lines (a sample and its opposite are one: fibres, hatching); 4: crosses.
    fit : {None, 'curl-free', 'divergence-free'}, optional
        Fit a potential's gradient (a curl-free flow) or a stream function's rotated gradient (divergence-free:
        an incompressible flow) to the arrows.
    bounds : bool or float, optional
        True (the default): no vertex's magnitude above the samples' largest (larger ones are scaled down to
        it: the projection of the field onto the bound); a number: that magnitude; False: none.
    smoothing : float >= 0 or 'auto', optional
        For noisy arrows: the energy weighed against the squared misfit (``'auto'``: by generalised
        cross-validation); None (the default) meets the arrows exactly.
    normal : {'refuse', 'drop'}, optional
        A sample whose part normal to the surface is more than a tenth of its length is refused (the default: a
        sign of vectors in another frame or order) or has that part dropped.
    solver : {'auto', 'direct', 'amg', 'iterate'}, optional
        The solve's backend.
    max_distance : float, optional
        Positions farther than this from the surface are refused.
    gp : dict, optional
        ``method='gp'``: ``range``, ``sigma`` (fitted when not given) and ``noise`` (a variance).
    """

    def __init__(self, V: ArrayLike, F: ArrayLike | None, idx: ArrayLike, *, barriers: Any = None,
                 options: VectorOptions | None = None, **keywords: Any) -> None:
        t0 = time.perf_counter()
        o = self.options = VectorOptions.build(options, **keywords)
        if F is None and (o.fit is not None or barriers is not None):
            raise OptionError("a point cloud (F=None) takes the vector fill only: fit= and barriers= need "
                              "triangles; pass the mesh's faces")
        if F is not None:
            V, F = as_mesh(V, F, allow_unreferenced=True)
        self.V, self.F = V, F
        method, symmetry, fit = o.method, o.symmetry, o.fit
        self.method, self.symmetry, self.fit, self.bounds, self.normal = method, symmetry, fit, o.bounds, o.normal
        self.cut = Cut(V, F, barriers) if barriers is not None else None
        Vw, Fw = (self.cut.V, self.cut.F) if self.cut is not None else (V, F)
        self._work_V = Vw
        idx_w, self._rows = self._work_samples(idx)
        kw = {"solver": o.solver, "max_distance": o.max_distance, "validated": True}
        self.engine: Any
        if fit is not None:
            self.engine = HodgeFit(Vw, Fw, idx_w, kind=fit, method=method, **kw)
        elif o.kind.gives_std:
            self.engine = VectorGP(Vw, Fw, idx_w, symmetry=symmetry, **(o.gp or {}), **kw)
        else:
            fill = LineFill if symmetry == 2 and o.smoothing is None else VectorFill
            extra = {} if fill is LineFill else {"symmetry": symmetry, "smoothing": o.smoothing}
            self.engine = fill(Vw, Fw, idx_w, method=method, **extra, **kw)
        self.k = len(np.asarray(idx))
        self.idx = self._sample_vertices(idx)
        self.V = getattr(self.engine, "V", V) if F is None else V  # a cloud's points as it keeps them
        self.normals = vertex_normals(V, F) if F is not None else self.engine.connection.frames[:, 2]
        self.setup_seconds = time.perf_counter() - t0

    def _work_samples(self, idx):
        """The samples on the mesh the work is done on (a barrier's vertex held on each side), and the rows of
        the caller's samples they come from."""
        arr = np.asarray(idx)
        if self.cut is None or (arr.ndim == 2 and np.issubdtype(arr.dtype, np.floating)):
            return arr, None
        idx2, rows = self.cut.copies(arr.astype(np.int64))
        return idx2, rows

    def _sample_vertices(self, idx):
        arr = np.asarray(idx)
        if arr.ndim == 1:
            return arr.astype(np.int64)
        pts = getattr(self.engine, "points", None)
        return np.full(len(arr), -1, dtype=np.int64) if pts is None else np.where(pts.vertex >= 0, pts.vertex, -1)

    def apply(self, vectors: ArrayLike, names: Sequence[str] | None = None) -> VectorReconstruction:
        """The fields for arrows ``(k, 3)`` (one field) or ``(k, 3, p)`` (``p`` fields, e.g. times).

        Parameters
        ----------
        vectors : (k, 3) or (k, 3, p) array_like of float
            The arrows in space, in the order of ``idx``.
        names : list of str, optional
            The fields' names in files.

        Returns
        -------
        VectorReconstruction
        """
        t0 = time.perf_counter()
        X = np.asarray(vectors, dtype=np.float64)
        if X.ndim not in (2, 3) or X.shape[:2] != (self.k, 3):
            raise SampleError(f"the vectors have shape {X.shape}; pass one 3-vector per sample: ({self.k}, 3), "
                              f"or ({self.k}, 3, p) for p fields")
        Xw = X if self._rows is None else X[self._rows]
        out = self.engine.solve(Xw, normal=self.normal)
        vertex, face, Z, report = self._unpack(out)
        report["bounds"] = self._bound(vertex, face, Xw)
        sing = self._singularities(Z)
        std = report.pop("std", None)
        draws = getattr(self.engine, "draws_of", None)
        if self.cut is not None:
            vertex = self.cut.values(vertex)  # the mean of a split vertex's sides, put back in its tangent plane
            Nb = self.normals if vertex.ndim == 2 else self.normals[:, :, None]
            vertex = vertex - np.sum(vertex * Nb, axis=1, keepdims=True) * Nb
            std = None if std is None else self.cut.values(std, "max")
            report["barriers"] = self.cut.report()
        report.update({"method": self.method, "symmetry": self.symmetry, "fit": self.fit,
                       "seconds": {"setup": self.setup_seconds, "solve": time.perf_counter() - t0}})
        return VectorReconstruction(self.V, self.F, vertex, face, idx=self.idx, symmetry=self.symmetry,
                                    singularities=sing, std=std, report=report, names=names, draws=draws,
                                    normals=self.normals)

    def _unpack(self, out):
        """Every engine's answer as vertex vectors, face vectors, the complex vertex field and a report."""
        if hasattr(self.engine, "representative"):  # the fill: complex values in the power representation
            Z, report = out
            conn = self.engine.connection
            vertex = conn.to_space(self.engine.representative(Z))
            face = conn.to_space(self.engine.representative(conn.on_faces(Z, self.symmetry)), faces=True)
            return vertex, face, Z, report
        if hasattr(out, "vertex_vectors"):  # a Hodge fit: the vertex field's numbers for its singularities
            Z = self.engine.connection.to_complex(np.nan_to_num(out.vertex_vectors))
            return out.vertex_vectors, out.face_vectors, Z, dict(out.report)
        return out.vertex, out.faces, out.complex, {**out.report, "std": out.std}

    def _bound(self, vertex, face, X):
        """Scale magnitudes above the bound down to it (in place); what ``report['bounds']`` says."""
        if self.bounds is False:
            return None
        if self.bounds is True:  # each field's samples' tangent parts: what the field meets there
            e = getattr(self.engine, "lines", self.engine)  # a line fill keeps its samples in its power fill
            top = np.max(np.abs(e.places.coordinates(e.connection, X, "drop")), axis=0)  # () or (p,)
        else:
            top = np.full(X.shape[2:], float(self.bounds))
        counts = []
        for Y in (vertex, face):
            mag = np.linalg.norm(Y, axis=1, keepdims=True)  # (m, 1[, p])
            over = mag > top
            with np.errstate(invalid="ignore", divide="ignore"):
                scale = np.where(over, top / mag, 1.0)
            Y *= scale
            counts.append(int(over.sum()))
        return {"magnitude": float(top) if np.ndim(top) == 0 else top.tolist(), "vertices_scaled": counts[0],
                "faces_scaled": counts[1]}

    def _singularities(self, Z):
        conn = getattr(self.engine, "connection", None)
        if conn is None or Z is None:
            return []
        Zs = Z if Z.ndim == 2 else Z[:, None]
        F = conn.F
        out = []
        for j in range(Zs.shape[1]):
            ind = conn.singularities(Zs[:, j], self.symmetry)
            f = np.flatnonzero(ind)
            out.append({"faces": f, "index": ind[f], "positions": self._work_V[F[f]].mean(axis=1)})
        return out


def reconstruct_vectors(V: ArrayLike, F: ArrayLike | None, idx: ArrayLike, vectors: ArrayLike, *,
                        names: Sequence[str] | None = None, **options: Any) -> VectorReconstruction:
    """Reconstruct a tangent vector field on a surface from arrows at a few places.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles.
    idx : (k,) array_like of int, or (k, 3) array_like of float
        Sample vertices, or sample positions (each at its closest surface point).
    vectors : (k, 3) or (k, 3, p) array_like of float
        The arrows in space (their part tangent to the surface is used; see ``normal``), ``p`` fields on the
        last axis.
    names : list of str, optional
        The fields' names in files.
    **options
        As :class:`VectorReconstructor`: ``method``, ``symmetry``, ``fit``, ``bounds``, ``smoothing``,
        ``normal``, ``barriers``, ``solver``, ``max_distance``, ``gp``.

    Returns
    -------
    VectorReconstruction
        ``values`` (a tangent vector per vertex), ``faces``, ``magnitude``, ``singularities``, ``std`` (gp).

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(3)
    >>> idx = [0, 100, 300, 500]
    >>> arrows = np.cross(V[idx], [0.0, 0.0, 1.0])  # a rotation about the z axis, tangent to the sphere
    >>> r = reconstruct_vectors(V, F, idx, arrows)
    >>> normals = r.normals  # the mesh's unit vertex normals: the field is tangent to them, exactly
    >>> float(abs(np.sum(r.values * normals, axis=1)).max()) < 1e-12
    True
    >>> tangent = arrows - np.sum(arrows * normals[idx], axis=1)[:, None] * normals[idx]
    >>> float(abs(r.values[idx] - tangent).max()) < 1e-10  # the arrows' tangent parts, exactly
    True
    """
    return VectorReconstructor(V, F, idx, **options).apply(vectors, names=names)
