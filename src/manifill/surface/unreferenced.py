"""Meshes as tools export them: vertices used by no face are left out of the work and given NaN.

Exporters often keep points no face uses (a scan's stray points, the vertices of deleted faces, a shared
vertex table). :class:`Compact` renumbers the referenced vertices for the reconstruction, takes the caller's
sample indices over, and puts the result back in the caller's numbering: NaN values (and std) at the
vertices used by no face, the curves, samples and located points in the original numbering, ``patch_label``
-2 there, and ``report['mesh']['unreferenced_vertices']`` saying how many.
"""

import copy

import numpy as np

from ..errors import SampleError
from ..validate.options import first_entries

__all__ = ["Compact", "compact"]


class Compact:
    """The referenced part of ``(V, F)`` (``V``, ``F`` renumbered) and the way back (``keep``, ``n``)."""

    def __init__(self, V, F, used):
        self.n = len(V)
        self.keep = np.flatnonzero(used)
        self.new = np.full(self.n, -1, dtype=np.int64)
        self.new[self.keep] = np.arange(self.keep.size)
        self.V_full, self.F_full = V, F
        self.V, self.F = V[self.keep], self.new[F]
        self.dropped = self.n - self.keep.size

    def indices(self, idx):
        """The caller's vertex indices in the renumbered mesh; samples on vertices used by no face are refused."""
        out = self.new[idx]
        bad = np.flatnonzero(out < 0)
        if bad.size:
            raise SampleError(f"{bad.size} samples sit on vertices that no face uses (vertex "
                              f"{first_entries(np.asarray(idx)[bad])}), where nothing can be reconstructed; drop "
                              f"them, or give their positions so that they are located on the surface")
        return out

    def _full(self, X, fill):
        if X is None:
            return None
        out = np.full((self.n,) + X.shape[1:], fill, dtype=np.result_type(X.dtype, np.asarray(fill).dtype))
        out[self.keep] = X
        return out

    def expand(self, r):
        """The :class:`~manifill.surface.reconstruction.Reconstruction` ``r`` in the caller's numbering."""
        r.values = self._full(np.asarray(r.values), np.nan)
        r.std = self._full(r.std, np.nan)
        r.trusted = self._full(r.trusted, False)
        r.components = self._full(r.components, -2)
        r.on_curve = self._full(r.on_curve, False)
        r.curves = [self.keep[c] for c in r.curves]
        r.idx = None if r.idx is None else self.keep[r.idx]
        p = r.points
        if p is not None:
            p.corners, p.nearest_vertex = self.keep[p.corners], self.keep[p.nearest_vertex]
            p.vertex = np.where(p.vertex >= 0, self.keep[np.maximum(p.vertex, 0)], -1)
        r.V, r.F = self.V_full, self.F_full
        r.report.setdefault("mesh", {})["unreferenced_vertices"] = int(self.dropped)
        r.compact = self
        return r

    def shrink(self, r):
        """A shallow copy of the expanded result ``r`` in the renumbered mesh (what its method drew from)."""
        out = copy.copy(r)
        out.values = np.asarray(r.values)[self.keep]
        out.std = None if r.std is None else r.std[self.keep]
        out.idx = None if r.idx is None else self.new[r.idx]
        out.V, out.F, out.compact = self.V, self.F, None
        if r.points is not None:
            p = out.points = copy.copy(r.points)
            p.corners, p.nearest_vertex = self.new[p.corners], self.new[p.nearest_vertex]
            p.vertex = np.where(p.vertex >= 0, self.new[np.maximum(p.vertex, 0)], -1)
        return out

    def full(self, X):
        """Rows of the renumbered mesh (e.g. draws) in the caller's numbering, NaN at the vertices no face uses."""
        return self._full(np.asarray(X, dtype=np.float64), np.nan)


def compact(V, F):
    """A :class:`Compact` of ``(V, F)``, or None when every vertex is in a face."""
    used = np.zeros(len(V), dtype=bool)
    used[np.asarray(F).ravel()] = True
    return None if used.all() else Compact(V, F, used)
