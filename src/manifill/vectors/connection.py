"""The discrete Levi-Civita connection of a triangle mesh: tangent frames, transport along edges, its Laplacian.

A tangent vector at vertex ``i`` is a complex number ``z`` in the vertex's frame. The frame is intrinsic
(Knöppel, Crane, Pinkall and Schröder 2013; Sharp, Soliman and Crane 2019): going around the vertex, the
corner angles are scaled to sum to ``2 pi`` (on the boundary they stay as they are: a constant field on a flat
mesh is then parallel, so reproduced exactly), so that the edge ``i -> j`` has an angle
``phi_ij`` there. Carrying a vector along the edge keeps its angle to the edge, so the transport from ``i`` to
``j`` multiplies by ``r_ij = exp(1j (phi_ji - phi_ij + pi))``. The vector Dirichlet energy is

    E(z) = 1/2 sum over edges of w_ij |z_j - r_ij z_i|^2  =  1/2 z^H L z

with ``w_ij`` the cotangent weights and ``L`` the connection Laplacian (Hermitian, positive semi-definite). An
``n``-direction field (a line field: ``n = 2``, a cross field: ``n = 4``) is stored as ``z = |u| exp(1j n arg u)``
and transported by ``r_ij ** n``.

The frames in space: ``e1, e2`` span the plane normal to the area-weighted vertex normal, turned so that the
projected edges' angles agree with the intrinsic ones on average (a circular mean). A vector in space and its
complex number are then one rotation apart, the same whatever edge the angles were measured from: the
result does not depend on the vertices' numbering. Faces have frames of their own (their plane, the first
edge); a vertex's vector is carried into a face along its corner's bisector.

The real form of the Laplacian (``[x_0, y_0, x_1, y_1, ...]`` with ``z = x + 1j y``) has the block
``[[a, -b], [b, a]]`` for an entry ``a + 1j b``: the solvers of :mod:`manifill.linalg` take it as they are.
"""

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import MeshError
from ..mesh.laplacian import assemble_laplacian
from ..surface.curve_values import vertex_normals
from ..validate import as_mesh

__all__ = ["Connection", "connection", "real_form", "wrap"]

TWO_PI = 2.0 * np.pi


def wrap(a):
    """Angles wrapped into ``(-pi, pi]``."""
    return np.pi - np.mod(np.pi - a, TWO_PI)


def real_form(A):
    """The real ``(2n, 2n)`` matrix of a complex ``(n, n)`` one, unknowns interleaved ``[x_0, y_0, x_1, ...]``."""
    A = sp.coo_array(A)
    r, c, a, b = A.row, A.col, A.data.real, A.data.imag
    rows = np.concatenate([2 * r, 2 * r, 2 * r + 1, 2 * r + 1])
    cols = np.concatenate([2 * c, 2 * c + 1, 2 * c, 2 * c + 1])
    data = np.concatenate([a, -b, b, a])
    n = A.shape[0]
    return sp.csr_array((data, (rows, cols)), shape=(2 * n, 2 * n))


def _unit(X):
    norm = np.linalg.norm(X, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(norm > 0, X / norm, 0.0)


@dataclass(frozen=True)
class Connection:
    """The connection of a mesh (:func:`connection`).

    Attributes
    ----------
    frames : (n, 3, 3) numpy array
        Per vertex ``e1``, ``e2`` and the unit normal, as rows.
    edges : (e, 2) int64 numpy array
        The edges ``i < j``.
    weights : (e,) numpy array
        Their cotangent weights.
    transport : (e,) numpy array
        The angle ``rho_ij`` of the transport from ``edges[:, 0]`` to ``edges[:, 1]``.
    face_frames : (m, 3, 3) numpy array
        Per face ``e1``, ``e2`` and its unit normal.
    face_transport : (m, 3) numpy array
        The angle carrying a vector from the face's corner ``k`` (vertex ``F[f, k]``) into the face's frame.
    face_curvature : (m,) numpy array
        ``Omega_f``: the face's scaled corner angles less ``pi`` (the connection's holonomy around it); they
        sum to ``2 pi`` times the Euler characteristic on a closed surface (on an open one, less the
        boundary's turning).
    F : (m, 3) int64 numpy array
        The faces.
    """

    frames: np.ndarray
    edges: np.ndarray
    weights: np.ndarray
    transport: np.ndarray
    face_frames: np.ndarray
    face_transport: np.ndarray
    face_curvature: np.ndarray
    F: np.ndarray

    @property
    def n(self):
        """The number of vertices."""
        return len(self.frames)

    def laplacian(self, symmetry=1):
        """The complex ``(n, n)`` connection Laplacian of ``symmetry``-direction fields (1: vectors)."""
        i, j = self.edges[:, 0], self.edges[:, 1]
        w = self.weights
        r = np.exp(1j * symmetry * self.transport)
        n = self.n
        diag = np.bincount(i, w, n) + np.bincount(j, w, n)
        rows = np.concatenate([np.arange(n), j, i])
        cols = np.concatenate([np.arange(n), i, j])
        data = np.concatenate([diag.astype(complex), -w * r, -w * np.conj(r)])
        return sp.csr_array((data, (rows, cols)), shape=(n, n))

    def to_complex(self, X, at=None):
        """Vectors in space ``(k, 3)`` (or ``(k, 3, p)``) at vertices ``at`` (all by default) as complex numbers.

        Only the tangent part counts (the normal part is dropped).
        """
        fr = self.frames if at is None else self.frames[at]
        X = np.asarray(X, dtype=np.float64)
        if X.ndim == 2:
            return np.einsum("kc,kc->k", X, fr[:, 0]) + 1j * np.einsum("kc,kc->k", X, fr[:, 1])
        return np.einsum("kcp,kc->kp", X, fr[:, 0]) + 1j * np.einsum("kcp,kc->kp", X, fr[:, 1])

    def to_space(self, Z, at=None, faces=False):
        """Complex numbers ``(k,)`` or ``(k, p)`` at vertices (or faces) as vectors in space, ``(k, 3[, p])``."""
        base = self.face_frames if faces else self.frames
        fr = base if at is None else base[at]
        Z = np.asarray(Z)
        if Z.ndim == 1:
            return Z.real[:, None] * fr[:, 0] + Z.imag[:, None] * fr[:, 1]
        return np.einsum("kp,kc->kcp", Z.real, fr[:, 0]) + np.einsum("kp,kc->kcp", Z.imag, fr[:, 1])

    def face_rows(self, faces, bary, symmetry=1):
        """The complex rows ``(k, n)``: a vertex field carried into ``faces`` and weighted by ``bary``."""
        faces = np.asarray(faces, dtype=np.int64)
        coef = np.asarray(bary, dtype=np.float64) * np.exp(1j * symmetry * self.face_transport[faces])
        r = np.repeat(np.arange(len(faces)), 3)
        return sp.csr_array((coef.ravel(), (r, self.F[faces].ravel())), shape=(len(faces), self.n))

    def on_faces(self, Z, symmetry=1):
        """A vertex field's complex numbers carried into every face and averaged: ``(m,)`` or ``(m, p)``."""
        m = len(self.F)
        R = self.face_rows(np.arange(m), np.full((m, 3), 1.0 / 3.0), symmetry)
        return R @ Z

    def singularities(self, Z, symmetry=1):
        """The index of each face of a vertex field ``Z`` (complex, ``(n,)``): integers over ``symmetry``.

        The turning of the field around the face, against the connection's transport, plus its holonomy; zero
        where the field has no singularity. On a closed surface they sum to the Euler characteristic.
        """
        F = self.F
        key = self.edges[:, 0] * self.n + self.edges[:, 1]
        order = np.argsort(key)
        total = symmetry * self.face_curvature.copy()
        ang = np.angle(Z)
        for a, b in ((0, 1), (1, 2), (2, 0)):
            i, j = F[:, a], F[:, b]
            lo, hi = np.minimum(i, j), np.maximum(i, j)
            e = order[np.searchsorted(key, lo * self.n + hi, sorter=order)]
            rho = np.where(i < j, self.transport[e], -self.transport[e])
            total += wrap(ang[j] - ang[i] - symmetry * rho)
        return np.rint(total / TWO_PI) / symmetry


def _corners(V, F):
    """Per corner ``c = 3 f + k``: its vertex, the next two vertices of the face, and its angle."""
    i = F.ravel()
    a = np.roll(F, -1, axis=1).ravel()
    b = np.roll(F, -2, axis=1).ravel()
    u, w = _unit(V[a] - V[i]), _unit(V[b] - V[i])
    theta = np.arctan2(np.linalg.norm(np.cross(u, w), axis=1), np.einsum("kc,kc->k", u, w))
    return i, a, b, theta


def _fan_angles(n, i, a, b, theta):
    """Per corner, the angle of its first edge ``i -> a`` going around ``i`` from a start edge; per vertex the
    start corner, whether it is on the boundary, and whether the corners make one fan (a manifold vertex)."""
    key_start = i * n + a
    order = np.argsort(key_start, kind="stable")
    sorted_keys = key_start[order]

    def find(keys):
        pos = np.searchsorted(sorted_keys, keys)
        pos = np.minimum(pos, len(sorted_keys) - 1)
        hit = sorted_keys[pos] == keys
        return np.where(hit, order[pos], -1)

    nxt = find(i * n + b)  # the corner whose first edge is this corner's second edge
    has_prev = np.zeros(len(i), dtype=bool)
    has_prev[nxt[nxt >= 0]] = True
    boundary = np.zeros(n, dtype=bool)
    boundary[i[~has_prev]] = True
    # the start: a corner without a predecessor on the boundary, the lowest corner of an interior vertex
    cand = np.where(~has_prev | ~boundary[i])[0]
    first = np.full(n, len(i), dtype=np.int64)
    np.minimum.at(first, i[cand], cand)
    start = np.where(first < len(i), first, -1)
    phi = np.full(len(i), np.nan)
    seen = np.zeros(len(i), dtype=bool)
    front = start[start >= 0]
    phi[front], seen[front] = 0.0, True
    while len(front):
        nx = nxt[front]
        ok = nx >= 0
        ok[ok] = ~seen[nx[ok]]
        phi[nx[ok]] = phi[front[ok]] + theta[front[ok]]
        seen[nx[ok]] = True
        front = nx[ok]
    starts = np.bincount(i[~has_prev], minlength=n)
    manifold = (starts <= 1) & (np.bincount(i, ~seen, n) == 0)
    return phi, start, boundary, manifold, nxt


def connection(V, F, *, validated=False):
    """The discrete Levi-Civita connection of a triangle mesh (see the module's description).

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles.
    validated : bool, optional
        ``V``, ``F`` are arrays already checked (a mesh cut along barriers, whose copies coincide).

    Returns
    -------
    Connection

    Raises
    ------
    MeshError
        If the mesh is malformed, or has no triangle.
    """
    if not validated:
        V, F = as_mesh(V, F, allow_unreferenced=True)
    if len(F) == 0:
        raise MeshError("vector fields need triangles: the mesh has none; pass its faces (F)")
    n = len(V)
    i, a, b, theta = _corners(V, F)
    phi, start, boundary, manifold, _ = _fan_angles(n, i, a, b, theta)
    total = np.bincount(i, theta, n)
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(total > 0, np.where(boundary, total, TWO_PI) / total, 1.0)
    N = vertex_normals(V, F)
    bad = np.linalg.norm(N, axis=1) == 0
    if bad.any():
        N[bad] = np.array([0.0, 0.0, 1.0])
    # projected angles of every corner's first edge, from the start corner's first edge
    ref = np.zeros((n, 3))
    s_ok = start >= 0
    ref[s_ok] = V[a[start[s_ok]]] - V[s_ok.nonzero()[0]]
    ref = _unit(ref - np.einsum("kc,kc->k", ref, N)[:, None] * N)
    ref2 = np.cross(N, ref)
    d = V[a] - V[i]
    proj = np.arctan2(np.einsum("kc,kc->k", d, ref2[i]), np.einsum("kc,kc->k", d, ref[i]))
    # a vertex whose corners make no single fan: its projected angles are its intrinsic ones
    plain = ~manifold[i] | np.isnan(phi)
    scaled = np.where(plain, proj, scale[i] * np.nan_to_num(phi))
    corner_scale = np.where(plain, 1.0, scale[i])
    dev = np.bincount(i, np.cos(scaled - proj), n) + 1j * np.bincount(i, np.sin(scaled - proj), n)
    beta = np.angle(dev)
    e1 = np.cos(beta)[:, None] * ref - np.sin(beta)[:, None] * ref2
    frames = np.stack([e1, np.cross(N, e1), N], axis=1)
    # every half-edge's intrinsic angle: first edges of corners, and a boundary fan's last edge
    h_from = np.concatenate([i, i])
    h_to = np.concatenate([a, b])
    h_ang = np.concatenate([scaled, scaled + corner_scale * theta])
    hkey = h_from * n + h_to
    order = np.argsort(hkey, kind="stable")
    hkey_sorted = hkey[order]
    W = assemble_laplacian(V, F, "cotan")
    Wc = sp.triu(W, k=1).tocoo()
    ei, ej = Wc.row.astype(np.int64), Wc.col.astype(np.int64)

    def angle_of(u, v):
        pos = np.searchsorted(hkey_sorted, u * n + v)
        return h_ang[order[np.minimum(pos, len(order) - 1)]]

    rho = angle_of(ej, ei) - angle_of(ei, ej) + np.pi
    # faces: frames, the corners' transport into them, their holonomy
    p0, p1, p2 = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    fn = _unit(np.cross(p1 - p0, p2 - p0))
    f1 = _unit(p1 - p0)
    f2 = np.cross(fn, f1)
    face_frames = np.stack([f1, f2, fn], axis=1)
    f = np.repeat(np.arange(len(F)), 3)
    psi = np.arctan2(np.einsum("kc,kc->k", d, f2[f]), np.einsum("kc,kc->k", d, f1[f]))
    tau = psi + 0.5 * theta - scaled - 0.5 * corner_scale * theta
    curvature = np.bincount(f, corner_scale * theta, len(F)) - np.pi
    return Connection(frames=frames, edges=np.column_stack([ei, ej]), weights=-Wc.data, transport=wrap(rho),
                      face_frames=face_frames, face_transport=tau.reshape(-1, 3), face_curvature=curvature,
                      F=F.astype(np.int64))
