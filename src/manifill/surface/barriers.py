"""Barriers the field must not cross: the mesh cut along them for the work, the result in the caller's numbering.

A crack in a part, a sulcus on a cortex, a coastline on a globe: ``barriers=`` names lines of the mesh's edges
that no reconstruction may see across, as

- a list of polylines, each a path of vertex indices ``(k,)`` or of positions ``(k, 3)`` (each snapped to its
  nearest vertex); consecutive vertices that are not neighbours are joined by the shortest path along edges;
- or per-face labels ``(m,)`` (integers): every edge between faces of different labels is a barrier.

:class:`Cut` cuts the mesh along those edges (:func:`manifill.mesh.cut.cut_mesh`): a vertex on a barrier splits
into one copy per side, so every method -- the pipeline's graph and partition, the energies, the gp's precision,
the folds of cross-validation -- works on a surface with no path across. A sample on a barrier vertex holds on
every side. The result comes back in the caller's numbering: a split vertex's value is the mean of its sides'
(its std the largest), ``Reconstruction.at`` and ``gradient(at='cells')`` read each face's own side, and
``report['barriers']`` says how many edges, split vertices and pieces there are.
"""

import copy

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree

from ..errors import OptionError, SampleError
from ..mesh.cut import cut_mesh
from ..mesh.edges import EdgeIndex
from ..mesh.graph import mesh_graph
from ..validate import bbox_diagonal, unit_scale
from ..validate.options import first_entries
from .samples import distance_limit, refuse_far

__all__ = ["Cut", "barrier_edges", "barrier_faces", "renumber"]


def barrier_edges(V, F, barriers, index=None):
    """The edge ids (of ``EdgeIndex(F, n)``) the barriers run along (see the module docstring).

    Raises
    ------
    OptionError
        Labels of the wrong length or type, a path with a vertex outside the mesh, points that are not ``(k, 3)``,
        a path whose ends no edge path joins, or no barrier edge at all.
    """
    n, m = len(V), len(F)
    index = EdgeIndex(F, n) if index is None else index
    if isinstance(barriers, np.ndarray) and barriers.ndim == 1:
        if len(barriers) != m or barriers.dtype.kind not in "iub":
            raise OptionError(f"barriers as an array are per-face labels: {m:,} integers, one per face (this one has "
                              f"{len(barriers):,} {barriers.dtype}); give polylines as a list: barriers=[path, ...]")
        edges = _label_edges(index, barriers.astype(np.int64))
    elif isinstance(barriers, (list, tuple)) and len(barriers):
        G = mesh_graph(V, F, index=index)
        lookup = sp.csr_array((np.arange(1, len(index.E) + 1), (index.E[:, 0], index.E[:, 1])), shape=(n, n))
        snap = _Snapper(V)
        edges = np.unique(np.concatenate([_path_edges(V, G, lookup, p, j, snap) for j, p in enumerate(barriers)]))
    else:
        raise OptionError("barriers is a list of polylines (each vertex indices (k,) or positions (k, 3)) or an array "
                          "of per-face labels; pass one of those")
    if edges.size == 0:
        raise OptionError("the barriers run along no edge of the mesh (labels all equal, or paths of one vertex); "
                          "give paths of at least two vertices or faces of two labels")
    return edges


def renumber(barriers, new, faces_kept=True):
    """``barriers`` with its vertex paths renumbered by ``new`` (old vertex -> new, -1 where it went), for a mesh
    whose vertices were left out or merged; positions as they are; per-face labels only if the faces are kept.

    Raises
    ------
    OptionError
        A path through a vertex that went (or outside the mesh), labels of a mesh whose faces changed.
    """
    new = np.asarray(new, dtype=np.int64)
    if isinstance(barriers, np.ndarray) and barriers.ndim == 1:
        if not faces_kept:
            raise OptionError("barriers as per-face labels, and cleaning the mesh changed its faces; give the "
                              "barriers as paths (vertex indices or positions) instead")
        return barriers
    if not isinstance(barriers, (list, tuple)):
        return barriers
    out = []
    for j, path in enumerate(barriers):
        P = np.asarray(path)
        if P.ndim == 1 and P.dtype.kind in "iu":
            bad = P[(P < 0) | (P >= len(new))]
            if bad.size:
                raise OptionError(f"barrier {j} holds vertex {int(bad[0])}, outside 0..{len(new) - 1}; give vertex "
                                  f"indices of this mesh")
            gone = P[new[P] < 0]
            if gone.size:
                raise OptionError(f"barrier {j} passes vertex {int(gone[0])}, which no face uses (it was left out); "
                                  f"give paths along the surface's edges")
            P = new[P]
        out.append(P)
    return out


def barrier_faces(V, F, barriers):
    """``(m,)`` bool: the faces with a vertex on a barrier (Bakka's barrier area, ``gp={'barrier': 'bakka'}``):
    a strip along each barrier that no face of ordinary range crosses."""
    index = EdgeIndex(F, len(V))
    on = np.zeros(len(V), dtype=bool)
    on[index.E[barrier_edges(V, F, barriers, index)].ravel()] = True
    return on[F].any(axis=1)


def _label_edges(index, labels):
    fe = np.asarray(index.face_edges, dtype=np.int64)
    f = np.repeat(np.arange(len(fe)), 3)
    e = fe.ravel()
    ok = e >= 0
    e, lab = e[ok], labels[f[ok]]
    lo = np.full(len(index.E), np.iinfo(np.int64).max)
    hi = np.full(len(index.E), np.iinfo(np.int64).min)
    np.minimum.at(lo, e, lab)
    np.maximum.at(hi, e, lab)
    return np.flatnonzero((lo != hi) & (hi > np.iinfo(np.int64).min))


def _path_edges(V, G, lookup, path, j, snap):
    P = np.asarray(path)
    if P.ndim == 2 and P.shape[1] == 3 and P.dtype.kind == "f":
        if not np.isfinite(P).all():
            raise OptionError(f"barrier {j} has a NaN or infinite position; give finite (k, 3) positions")
        verts = snap(P, j)
    elif P.ndim == 1 and P.dtype.kind in "iu":
        verts = P.astype(np.int64)
        bad = np.flatnonzero((verts < 0) | (verts >= len(V)))
        if bad.size:
            raise OptionError(f"barrier {j} holds vertex {int(verts[bad[0]])}, outside 0..{len(V) - 1}; give vertex "
                              f"indices of this mesh")
    else:
        raise OptionError(f"barrier {j} has shape {P.shape} and type {P.dtype}; give vertex indices (k,) or "
                          f"positions (k, 3)")
    verts = verts[np.r_[True, verts[1:] != verts[:-1]]]
    out = []
    for a, b in zip(verts[:-1], verts[1:]):
        e = int(lookup[a, b] if a < b else lookup[b, a]) - 1
        if e >= 0:
            out.append(e)
            continue
        _, pred = dijkstra(G, indices=int(a), return_predecessors=True, min_only=False)
        if pred[b] < 0:
            raise OptionError(f"barrier {j}: no path of edges joins vertices {a} and {b} (different pieces of the "
                              f"mesh); give each piece its own barrier")
        walk = [int(b)]
        while walk[-1] != a:
            walk.append(int(pred[walk[-1]]))
        for x, y in zip(walk[:-1], walk[1:]):
            out.append(int(lookup[min(x, y), max(x, y)]) - 1)
    return np.asarray(out, dtype=np.int64)


class _Snapper:
    """Barrier positions to their nearest vertices: the vertices' tree and the accepted distance built at the first
    barrier given by positions, once for all of them; a position farther from the mesh than a sample may be is
    refused as samples are ("wrong units?")."""

    def __init__(self, V):
        self.V, self.tree = V, None

    def __call__(self, P, j):
        if self.tree is None:
            self.sc, self.diag = unit_scale(self.V), bbox_diagonal(self.V)
            self.tree = cKDTree(self.V / self.sc)
            self.limit = distance_limit(self.tree, self.sc, self.diag)
        dist, verts = self.tree.query(P / self.sc)
        refuse_far(dist * self.sc, self.limit, self.diag, "the nearest vertex", lead=f"barrier {j} has {{n}} points "
                   f"far from the mesh", row="point", fix="Give the barrier's positions in the mesh's units",
                   error=OptionError)
        return verts


class Cut:
    """A mesh cut along its barriers (``V``, ``F`` the copies) and the way back to the caller's numbering.

    Parameters
    ----------
    V, F
        The validated mesh.
    barriers
        As the module docstring says.
    """

    def __init__(self, V, F, barriers):
        self.n = len(V)
        self.V_full, self.F_full = V, F
        index = EdgeIndex(F, self.n)
        self.edges = barrier_edges(V, F, barriers, index)
        self.F, self.orig = cut_mesh(F, self.n, self.edges, index)
        self.V = V[self.orig]
        n2 = len(self.orig)
        self.split = np.unique(self.orig[self.n:])
        # copies of each vertex: a sparse (n, n2) map, and its row means
        self.C = sp.csr_array((np.ones(n2), (self.orig, np.arange(n2))), shape=(self.n, n2))
        self.count = np.asarray(self.C.sum(axis=1)).ravel()
        ix = EdgeIndex(self.F, n2)
        G = sp.coo_array((np.ones(len(ix.E)), (ix.E[:, 0], ix.E[:, 1])), shape=(n2, n2))
        self.pieces, self.piece = connected_components(G, directed=False)
        ix0 = index.E
        G0 = sp.coo_array((np.ones(len(ix0)), (ix0[:, 0], ix0[:, 1])), shape=(self.n, self.n))
        self.parted = self.pieces > connected_components(G0, directed=False)[0]  # a piece more than before

    def report(self):
        """What ``report['barriers']`` holds."""
        return {"edges": int(self.edges.size), "split_vertices": int(self.split.size), "pieces": int(self.pieces)}

    def copies(self, idx):
        """``(idx2, rows)``: every copy of the caller's vertices ``idx`` and the row of ``idx`` each came from."""
        idx = np.asarray(idx, dtype=np.int64)
        C = self.C[idx]
        rows = np.repeat(np.arange(len(idx)), np.diff(C.indptr))
        return C.indices.astype(np.int64), rows

    def check_pieces(self, idx2, on_empty):
        """Refuse pieces the barriers leave without a sample (unless ``on_empty='nan'``), naming them."""
        has = np.zeros(self.pieces, dtype=bool)
        has[self.piece[idx2]] = True
        empty = np.flatnonzero(~has)
        if empty.size and on_empty == "error":
            sizes = np.bincount(self.piece, minlength=self.pieces)[empty]
            raise SampleError(f"the barriers leave {empty.size} piece(s) of the surface with no sample "
                              f"({first_entries(sizes)} vertices); add samples there, or pass on_empty='nan' to "
                              f"leave them NaN")

    def both_sides(self, points):
        """Samples given as positions that sit at a split vertex: held on every side, as index samples are (a
        point inside a face, or on a barrier's edge between vertices, stays on its face's side)."""
        out = copy.copy(points)
        a = points.idx.size
        idx, vals = self._spread(points.idx, points.vals)
        pos = np.searchsorted(idx, points.idx)
        c = points.constraint
        out.idx, out.vals = idx, vals
        out.constraint = np.where(c < a, pos[np.minimum(c, max(a - 1, 0))] if a else c, c - a + idx.size)
        out.nearest, out.nearest_vals = self._spread(points.nearest, points.nearest_vals)
        return out

    def _spread(self, idx, vals):
        """Vertex samples ``idx`` (sorted copies) with the other copies of their vertices added (sorted)."""
        if idx.size == 0:
            return idx, vals
        extra, rows = self.copies(self.orig[idx])
        keep = ~np.isin(extra, idx)
        extra, first = np.unique(extra[keep], return_index=True)
        all_idx = np.concatenate([idx, extra])
        all_vals = np.vstack([vals, vals[rows[keep][first]]])
        order = np.argsort(all_idx, kind="stable")
        return all_idx[order], all_vals[order]

    def values(self, X, reduce="mean"):
        """Rows on the copies -> rows on the caller's vertices (the mean of a split vertex's sides, or their max)."""
        X = np.asarray(X)
        flat = X.reshape(len(X), -1)
        if reduce == "max":
            out = np.full((self.n, flat.shape[1]), np.nan)
            np.fmax.at(out, self.orig, flat)
        else:  # the sides that have a value (a side in a piece left NaN does not blank the other)
            have = (self.C @ (~np.isnan(flat)).astype(float))
            with np.errstate(invalid="ignore", divide="ignore"):
                out = (self.C @ np.where(np.isnan(flat), 0.0, flat)) / have
            out[have == 0] = np.nan
        return out.reshape((self.n,) + X.shape[1:])

    def expand(self, r):
        """The :class:`~manifill.surface.reconstruction.Reconstruction` on the copies, in the caller's numbering
        (kept as it was in ``r.on_cut``, for draws, gradients and ``at``)."""
        inner = copy.copy(r)
        r.values = self.values(r.values)
        r.std = None if r.std is None else self.values(r.std, "max")
        if r.trusted is not None:
            r.trusted = self.values(r.trusted.astype(float)) == 1.0
        r.components = self.values(r.components.astype(float), "max").astype(np.int64)
        r.on_curve = self.values(r.on_curve.astype(float), "max") > 0
        r.curves = [self.orig[c] for c in r.curves]
        r.idx = None if r.idx is None else np.unique(self.orig[r.idx])
        if r.points is not None:
            p = r.points = copy.copy(r.points)
            p.corners, p.nearest_vertex = self.orig[p.corners], self.orig[p.nearest_vertex]
            p.vertex = np.where(p.vertex >= 0, self.orig[np.maximum(p.vertex, 0)], -1)
        r.V, r.F = self.V_full, self.F_full
        r.report["barriers"] = self.report()
        r.cut, r.on_cut = self, inner
        return r
