"""Where the arrows sit, and their numbers in the frames there: one home for every vector method.

A sample is a vertex (its two frame coordinates are fixed) or a position inside a face (the face's field there,
the corners carried into the face and weighted by the barycentric coordinates, is a row). On a point cloud a
position is its nearest point. The real forms interleave ``[x_0, y_0, x_1, y_1, ...]`` for ``z = x + 1j y``.
"""

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ..errors import SampleError
from ..surface.locate import locate_points
from ..validate import as_indices

__all__ = ["SamplePlaces", "tangent_parts", "interleave", "real_rows", "to_real", "to_complex", "NORMAL_LIMIT"]

#: A sample's normal part beyond this fraction of its length is refused (``normal='refuse'``) or dropped.
NORMAL_LIMIT = 0.1


def interleave(i):
    """The real unknowns ``[2 i, 2 i + 1]`` of the complex ones ``i``."""
    i = np.asarray(i, dtype=np.int64)
    return np.column_stack([2 * i, 2 * i + 1]).ravel()


def real_rows(R):
    """The real rows ``(2k, 2n)`` of complex rows ``(k, n)`` (unknowns and rows interleaved)."""
    R = sp.coo_array(R)
    r, c, a, b = R.row, R.col, R.data.real, R.data.imag
    rows = np.concatenate([2 * r, 2 * r, 2 * r + 1, 2 * r + 1])
    cols = np.concatenate([2 * c, 2 * c + 1, 2 * c, 2 * c + 1])
    return sp.csr_array((np.concatenate([a, -b, b, a]), (rows, cols)), shape=(2 * R.shape[0], 2 * R.shape[1]))


def to_real(Z):
    """Complex ``(k,)`` or ``(k, p)`` as real ``(2k,)`` or ``(2k, p)``, interleaved."""
    Z = np.asarray(Z)
    out = np.empty((2 * Z.shape[0],) + Z.shape[1:])
    out[0::2], out[1::2] = Z.real, Z.imag
    return out


def to_complex(X):
    """Real interleaved ``(2k[, p])`` as complex ``(k[, p])``."""
    return X[0::2] + 1j * X[1::2]


def tangent_parts(vectors, normals, normal="refuse", what="sample"):
    """The vectors ``(k, 3[, p])`` less their parts along the unit ``normals`` ``(k, 3)``, checked.

    Raises
    ------
    SampleError
        With ``normal='refuse'``, a vector whose normal part is more than a tenth of its length (naming the first).
    """
    X = np.asarray(vectors, dtype=np.float64)
    Nb = normals if X.ndim == 2 else normals[:, :, None]
    along = np.sum(X * Nb, axis=1, keepdims=True)
    length = np.linalg.norm(X, axis=1)
    if normal == "refuse":
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = np.where(length > 0, np.abs(along[:, 0]) / length, 0.0)
        bad = np.argwhere(frac > NORMAL_LIMIT)
        if len(bad):
            k = tuple(bad[0])
            raise SampleError(f"{what} {k[0]}'s vector is {frac[k]:.0%} normal to the surface ({len(bad)} such, "
                              f"more than {NORMAL_LIMIT:.0%} of their length): pass tangent vectors, or drop the "
                              f"normal parts (normal='drop'); check the vectors' order and frame")
    return X - along * Nb


class SamplePlaces:
    """The samples of a mesh (or a point cloud, ``F=None``): vertices, and positions inside faces.

    Parameters
    ----------
    V, F
        The mesh (checked), or a cloud's points and None.
    idx : (k,) array_like of int, or (k, 3) array_like of float
        Sample vertices, or positions (located at their closest surface point; a cloud's nearest point).
    max_distance : float, optional
        Positions farther than this from the surface are refused.

    Attributes
    ----------
    vertices : (a,) int64 numpy array
        The vertices of the samples at vertices, in their order.
    vertex_samples, face_samples : int64 numpy arrays
        Which samples sit at a vertex, which inside a face.
    faces, bary : numpy arrays
        The faces and barycentric coordinates of the latter.
    points : SurfacePoints or None
        The located positions (None for vertices or a cloud).
    k : int
        The number of samples.
    """

    def __init__(self, V, F, idx, max_distance=None):
        idx = np.asarray(idx)
        self.face_samples = np.zeros(0, dtype=np.int64)
        self.faces, self.bary, self.points = np.zeros(0, dtype=np.int64), np.zeros((0, 3)), None
        if idx.ndim == 2 and np.issubdtype(idx.dtype, np.floating) and F is None:
            dist, self.vertices = cKDTree(V).query(idx)
            if max_distance is not None and np.max(dist) > max_distance:
                raise SampleError(f"sample {int(np.argmax(dist))} is {np.max(dist):.3g} from the nearest point of "
                                  f"the cloud, beyond max_distance={max_distance}; check the positions' units")
        elif idx.ndim == 2 and np.issubdtype(idx.dtype, np.floating):
            where = locate_points(V, F, idx, max_distance=max_distance)
            at_vertex = where.vertex >= 0
            self.vertices = where.vertex[at_vertex]
            self.face_samples = np.flatnonzero(~at_vertex)
            self.faces, self.bary = where.faces[~at_vertex], where.bary[~at_vertex]
            self.points = where
        else:
            self.vertices = as_indices(idx, len(V), what="idx")
        self.vertices = np.asarray(self.vertices, dtype=np.int64)
        self.vertex_samples = np.setdiff1d(np.arange(len(idx)), self.face_samples)
        self.k = len(idx)
        if self.k == 0:
            raise SampleError("there are no samples; pass at least one vertex or position with its vector")
        if len(np.unique(self.vertices)) < len(self.vertices):
            raise SampleError("two samples sit at one vertex: merge them (their mean vector) or move one")

    def coordinates(self, conn, vectors, normal="refuse", symmetry=1):
        """The arrows ``(k, 3[, p])`` as complex numbers in their vertex's or face's frame of ``conn``, ``(k[, p])``,
        in the power representation of ``symmetry`` (``|u| exp(1j n arg u)``)."""
        X = np.asarray(vectors, dtype=np.float64)
        if X.ndim not in (2, 3) or X.shape[0] != self.k or X.shape[1] != 3:
            raise SampleError(f"the vectors have shape {X.shape}; pass one 3-vector per sample, ({self.k}, 3)")
        if not np.all(np.isfinite(X)):
            raise SampleError("the vectors have NaN or infinite entries; drop those samples")
        W = np.zeros((self.k,) + X.shape[2:], dtype=complex)
        for which, frames in ((self.vertex_samples, conn.frames[self.vertices]),
                              (self.face_samples, conn.face_frames[self.faces])):
            if len(which):
                T = tangent_parts(X[which], frames[:, 2], normal)
                e1, e2 = (frames[:, 0], frames[:, 1]) if T.ndim == 2 else (frames[:, 0, :, None], frames[:, 1, :, None])
                W[which] = np.sum(T * e1, axis=1) + 1j * np.sum(T * e2, axis=1)
        if symmetry > 1:
            W = np.abs(W) * np.exp(1j * symmetry * np.angle(W))
        return W
