"""Curl-free and divergence-free fits: a tangent field from arrows, as the gradient of a potential or the rotated
gradient of a stream function (the Hodge decomposition's exact and co-exact parts).

A scalar ``x`` at the vertices, linear on each face, gives the field ``u_f = grad x`` (curl-free, ``x = phi`` the
potential) or ``u_f = n_f x grad x`` (divergence-free, ``x = psi`` the stream function). Either is exact by
construction: the weak divergence ``div_i(u) = - sum_f area_f grad(hat_i)_f . u_f`` of ``n x grad psi`` is zero at
every interior vertex (``area_f n_f x grad(hat_i)_f`` is half the edge opposite ``i``: the differences of ``psi``
around the ring telescope), as is the weak curl ``curl_i(u) = div_i(u x n)`` of ``grad phi`` (:func:`weak_divergence`,
:func:`weak_curl`). A vertex's vector is the area-weighted mean of its faces' in its tangent plane (the vertex frame
of :mod:`manifill.vectors.connection`), as :func:`manifill.mesh.gradients.vertex_gradients` has it.

The fit meets the arrows' tangent parts exactly (two rows per sample, in its vertex's or face's frame) and minimises:

- ``'harmonic'``: the faces' vector Dirichlet energy ``sum_e w_e |u_f - R_e u_g|^2`` over interior edges, ``R_e``
  unfolding face ``g`` onto ``f`` about their edge, ``w_e = 3 |e|^2 / (2 (area_f + area_g))``;
- ``'biharmonic'`` (the default): the vertex vectors' biharmonic energy ``z^H L M^-1 L z``, ``L`` the connection
  Laplacian of the transport turning one vertex normal onto the other (Levi-Civita's on a sphere, none on a flat
  mesh), plus :data:`FACE_WEIGHT` over the surface's area times the harmonic one (for face patterns whose vertex
  means vanish).

Both vanish on a constant field of a flat mesh: a linear potential is fitted exactly there, boundary or not.
Measured on the unit icosphere (``f = x y + z^2 + sin(2 x)``, ``grad f`` or ``n x grad f`` at ``k`` random vertices),
the relative RMS error of the vertex vectors, both kinds alike (last column: 10,242 vertices):

=================================  ======  =====  ======  =======
2,562 vertices                     k = 30  100    300     300 (5)
=================================  ======  =====  ======  =======
VectorFill, biharmonic             0.395   0.034  0.0055  0.0040
this, biharmonic                   0.057   0.010  0.0034  0.0015
``phi' L M^-1 L M^-1 L phi``       0.055   0.010  0.0056  0.0023
this, harmonic                     0.212   0.087  0.015
``phi' L M^-1 L phi``              0.236   0.099  0.019
=================================  ======  =====  ======  =======

The potential's polyharmonic energies miss linear potentials of an open mesh (their Neumann boundary); the Hessian
energy errs 1.5-2 times the harmonic one, the face graph's squared Laplacian 2.5 times VectorFill at ``k >= 100``.
The harmonic part of a surface with handles or holes (circling one) is not fitted; a component without samples gets
the zero field; a position on an edge, the vector of the face ``locate_points`` chose.
"""

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import OptionError, SampleError, SolveError
from ..linalg.quadratic import QuadraticSolver
from ..mesh.gradients import gradient_operator
from ..mesh.laplacian import mass_matrix
from ..mesh.topology import connected_components
from ..validate import as_mesh
from .connection import connection, real_form
from .options import NORMAL
from .places import SamplePlaces, to_real

__all__ = ["KINDS", "METHODS", "FACE_WEIGHT", "HodgeFit", "HodgeResult", "hodge_fit", "field_operator",
           "weak_divergence", "weak_curl"]

#: The fits: the gradient of a potential, or its quarter turn (the rotated gradient of a stream function).
KINDS = ("curl-free", "divergence-free")
#: The smoothness energies of the field, by their order (1: its Dirichlet energy, 2: its biharmonic energy).
METHODS = {"biharmonic": 2, "harmonic": 1}
#: The faces' Dirichlet energy under the biharmonic one, over the surface's area (1e-3 to 1 measured alike; the
#: weight per squared edge length biased the fit on fine meshes).
FACE_WEIGHT = 0.1


def _face_normals(V, F):
    N = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    norm = np.linalg.norm(N, axis=1, keepdims=True)
    return np.divide(N, norm, out=np.zeros_like(N), where=norm > 0)


def field_operator(V, F, kind="curl-free"):
    """The face field of a vertex scalar: ``(B, area)``, ``B`` ``(3m, n)`` (row ``3 f + c``: coordinate ``c`` on face
    ``f``), the gradient (``'curl-free'``) or the rotated gradient ``n_f x grad`` (``'divergence-free'``).

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles.
    kind : {'curl-free', 'divergence-free'}, optional
        The field (:data:`KINDS`).

    Returns
    -------
    B : (3m, n) scipy.sparse.csr_array
    area : (m,) numpy array
        The faces' areas.

    Examples
    --------
    >>> V = np.array([[0.0, 0, 0], [2, 0, 0], [0, 1, 0]])
    >>> B, area = field_operator(V, [[0, 1, 2]], kind="divergence-free")
    >>> (B @ np.array([1.0, 3.0, 4.0])).tolist()  # z x (1, 3, 0)
    [-3.0, 1.0, 0.0]
    """
    if kind not in KINDS:
        raise OptionError(f"kind={kind!r} is not a Hodge fit; pass one of {', '.join(KINDS)}")
    V, F = np.asarray(V, dtype=np.float64), np.asarray(F, dtype=np.int64)
    G, area = gradient_operator(V, F)
    if kind == "curl-free":
        return G.tocsr(), area
    m = len(F)
    x, y, z = _face_normals(V, F).T  # the blocks of u -> n x u
    base = 3 * np.repeat(np.arange(m), 6)
    J = sp.csr_array((np.column_stack([-z, y, z, -x, -y, x]).ravel(),
                      (base + np.tile([0, 0, 1, 1, 2, 2], m), base + np.tile([1, 2, 0, 2, 0, 1], m))),
                     shape=(3 * m, 3 * m))
    return (J @ G).tocsr(), area


def weak_divergence(V, F, U):
    """The weak divergence ``div_i = - sum_f area_f grad(hat_i)_f . u_f`` of a face field at every vertex: ``-L phi``
    for ``u = grad phi`` (``L`` the cotangent Laplacian), zero at interior vertices for ``u = n x grad psi``.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles.
    U : (m, 3) or (m, 3, p) array_like
        One vector per face (per field).

    Returns
    -------
    (n,) or (n, p) numpy array
        At a boundary vertex, it holds the flux through the boundary.
    """
    G, area = gradient_operator(np.asarray(V, dtype=np.float64), np.asarray(F, dtype=np.int64))
    U = np.asarray(U, dtype=np.float64)
    if U.ndim not in (2, 3) or U.shape[:2] != (len(area), 3):
        raise SampleError(f"the face vectors have shape {U.shape}; pass one 3-vector per face, ({len(area)}, 3)")
    out = -(G.T @ (U.reshape(3 * len(area), -1) * np.repeat(area, 3)[:, None]))
    return out[:, 0] if U.ndim == 2 else out


def weak_curl(V, F, U):
    """The weak curl ``curl_i(u) = div_i(u x n)`` of a face field (:func:`weak_divergence`) at every vertex: zero at
    interior vertices for ``u = grad phi``, ``-L psi`` for ``u = n x grad psi``.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles.
    U : (m, 3) or (m, 3, p) array_like
        One vector per face (per field).

    Returns
    -------
    (n,) or (n, p) numpy array
    """
    V, F, U = np.asarray(V, dtype=np.float64), np.asarray(F, dtype=np.int64), np.asarray(U, dtype=np.float64)
    N = _face_normals(V, F)
    return weak_divergence(V, F, np.cross(U, N[:, :, None], axis=1) if U.ndim == 3 else np.cross(U, N))


@dataclass(frozen=True)
class HodgeResult:
    """A Hodge fit (:meth:`HodgeFit.solve`).

    Attributes
    ----------
    potential : (n,) or (n, p) numpy array
        The potential ``phi`` (curl-free: the field is ``grad phi``) or the stream function ``psi``
        (divergence-free: ``n x grad psi``), linear on each face, of zero mean (lumped mass) on every component.
    face_vectors : (m, 3) or (m, 3, p) numpy array
        The field on every face: exactly ``grad phi`` or ``n_f x grad psi`` there.
    vertex_vectors : (n, 3) or (n, 3, p) numpy array
        The area-weighted mean of each vertex's faces' vectors in its tangent plane (NaN at a vertex in no face).
    report : dict
        ``method``, ``kind``, ``samples``, ``inside_faces``; ``divergence``, ``curl``: their largest weak value at an
        interior vertex over the largest ``sum_f area_f |grad(hat_i)_f| |u_f|``; ``zero`` names the kind's (round-off).
    """

    potential: np.ndarray
    face_vectors: np.ndarray
    vertex_vectors: np.ndarray
    report: dict


def _frame_rows(frames, at, n3):
    """The ``(2k, n3)`` rows ``e1 . v, e2 . v`` of the 3-vectors ``v`` at ``at`` (rows ``3 at + c``), interleaved."""
    at = np.asarray(at, dtype=np.int64)
    cols = np.repeat(3 * at, 6) + np.tile([0, 1, 2], 2 * len(at))
    return sp.csr_array((frames[at][:, :2].ravel(), (np.repeat(np.arange(2 * len(at)), 3), cols)),
                        shape=(2 * len(at), n3))


def _vertex_means(F, area, n):
    """``(3n, 3m)``: every vertex's faces' vectors weighted by their areas; and the vertices in no face."""
    W = sp.csr_array((np.repeat(area, 3), (F.ravel(), np.repeat(np.arange(len(F)), 3))), shape=(n, len(F)))
    total = W.sum(axis=1)
    W = sp.diags_array(np.divide(1.0, total, out=np.zeros_like(total), where=total > 0)) @ W
    return sp.kron(W, sp.eye_array(3), format="csr"), total <= 0


def _face_jumps(V, F, N, area):
    """``(D, w)``: per interior edge ``e`` of faces ``f, g`` the jump ``u_f - R_e u_g`` ((3E, 3m), ``R_e`` the rotation
    about the edge that turns ``N_g`` onto ``N_f``), and its weight ``3 |e|^2 / (2 (area_f + area_g))``, thrice."""
    half = np.sort(np.stack([F[:, [1, 2]], F[:, [2, 0]], F[:, [0, 1]]], axis=1).reshape(-1, 2), axis=1)
    key = half[:, 0] * len(V) + half[:, 1]
    order = np.argsort(key, kind="stable")
    pair = key[order][1:] == key[order][:-1]
    pair[1:] &= ~pair[:-1]  # a non-manifold edge: its first two faces only
    a, b = order[:-1][pair], order[1:][pair]
    f, g, E = a // 3, b // 3, int(pair.sum())
    e = V[half[a, 1]] - V[half[a, 0]]
    length2 = np.einsum("kc,kc->k", e, e)
    ax = e / np.sqrt(np.maximum(length2, np.finfo(float).tiny))[:, None]
    sin, cos = np.einsum("kc,kc->k", np.cross(N[g], N[f]), ax), np.einsum("kc,kc->k", N[g], N[f])
    K = np.zeros((E, 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -ax[:, 2], ax[:, 1], -ax[:, 0]
    K -= np.transpose(K, (0, 2, 1))
    R = np.eye(3) + sin[:, None, None] * K + (1.0 - cos)[:, None, None] * (K @ K)  # Rodrigues
    r3 = (3 * np.arange(E)[:, None] + np.arange(3)).ravel()
    cols = np.concatenate([(3 * f[:, None] + np.arange(3)).ravel(),
                           np.broadcast_to((3 * g)[:, None, None] + np.arange(3), (E, 3, 3)).ravel()])
    D = sp.csr_array((np.concatenate([np.ones(3 * E), -R.ravel()]), (np.concatenate([r3, np.repeat(r3, 3)]), cols)),
                     shape=(3 * E, 3 * len(F)))
    denom = area[f] + area[g]
    return D, np.repeat(np.divide(1.5 * length2, denom, out=np.zeros_like(denom), where=denom > 0), 3)


def _normal_transport(conn):
    """The complex connection Laplacian of the transport turning one vertex normal onto the other (or none)."""
    fr, i, j, w = conn.frames, conn.edges[:, 0], conn.edges[:, 1], conn.weights
    c = np.einsum("kc,kc->k", fr[i, 2], fr[j, 2])
    k = np.cross(fr[i, 2], fr[j, 2])
    kv = np.cross(k, fr[i, 0])
    ok = 1.0 + c > 1e-12  # opposite normals: no shortest turn, the frame kept
    turned = fr[i, 0] + kv + np.cross(k, kv) / np.where(ok, 1.0 + c, 1.0)[:, None]
    r = np.einsum("kc,kc->k", turned, fr[j, 0]) + 1j * np.einsum("kc,kc->k", turned, fr[j, 1])
    r = np.where(ok, r / np.maximum(np.abs(r), np.finfo(float).tiny), 1.0)
    n = conn.n
    data = np.concatenate([(np.bincount(i, w, n) + np.bincount(j, w, n)).astype(complex), -w * r, -w * np.conj(r)])
    return sp.csr_array((data, (np.concatenate([np.arange(n), j, i]), np.concatenate([np.arange(n), i, j]))),
                        shape=(n, n))


def _energy(V, F, conn, B, T, area, method):
    """The energy matrix ``(n, n)`` of the scalar: its field's Dirichlet or biharmonic energy."""
    D, w = _face_jumps(V, F, conn.face_frames[:, 2], area)
    DB = D @ B
    A = DB.T @ sp.diags_array(w) @ DB
    if METHODS[method] == 2:
        mass = mass_matrix(V, F).diagonal()
        inv = np.repeat(np.divide(1.0, mass, out=np.zeros_like(mass), where=mass > 0), 2)
        K = real_form(_normal_transport(conn)) @ T
        A = K.T @ sp.diags_array(inv) @ K + (FACE_WEIGHT / max(float(area.sum()), np.finfo(float).tiny)) * A
    return sp.csr_array((A + A.T) * 0.5)


def _interior(F, n):
    """The vertices in a face and on no boundary (or non-manifold) edge."""
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    keys, counts = np.unique(e[:, 0] * n + e[:, 1], return_counts=True)
    inside, rim = np.isin(np.arange(n), F), keys[counts != 2]
    inside[rim // n], inside[rim % n] = False, False
    return inside


class HodgeFit:
    """The curl-free or divergence-free fit of one mesh and one set of sample places, prepared once (the
    factorisation); :meth:`solve` for any arrows. See the module's description for the field and its energies.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles.
    idx : (k,) array_like of int, or (k, 3) array_like of float
        Sample vertices, or positions (at their closest surface point: a vertex's vector, or inside a face its own).
    kind : {'curl-free', 'divergence-free'}, optional
        The gradient of a potential, or the rotated gradient of a stream function (:data:`KINDS`).
    method : {'biharmonic', 'harmonic'}, optional
        The field's smoothness energy (:data:`METHODS`).
    solver : {'auto', 'direct'}, optional
        The samples are equality rows: their KKT system is factorised (``'auto'`` is ``'direct'``).
    max_distance : float, optional
        Positions farther than this from the surface are refused (the scalar methods' ``max_distance``).
    validated : bool, optional
        ``V``, ``F`` are arrays already checked (a mesh cut along barriers, whose copies coincide).

    Raises
    ------
    OptionError
        ``kind``, ``method`` or ``solver`` not one of its values.
    SampleError
        Bad places, two samples at one vertex, none, or rows the scalar cannot meet for every arrow (two samples in
        one face or in faces sharing an edge: both fix the gradient along it).

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> V, F = grid(5)
    >>> fit = HodgeFit(V, F, [6, 18], kind="curl-free")
    >>> out = fit.solve([[1.0, 2.0, 0.0], [1.0, 2.0, 0.0]])
    >>> np.allclose(out.face_vectors, [1.0, 2.0, 0.0])  # the gradient of x + 2 y
    True
    """

    def __init__(self, V, F, idx, *, kind="curl-free", method="biharmonic", solver="auto", max_distance=None,
                 validated=False):
        if kind not in KINDS:
            raise OptionError(f"kind={kind!r} is not a Hodge fit; pass one of {', '.join(KINDS)}")
        if method not in METHODS:
            raise OptionError(f"method={method!r} is not a Hodge fit's energy; pass one of {', '.join(METHODS)}")
        if solver not in ("auto", "direct"):
            raise OptionError(f"solver={solver!r}: the samples' rows are factorised; pass 'auto' or 'direct'")
        if not validated:
            V, F = as_mesh(V, F, allow_unreferenced=True)
        ext = float(np.ptp(V, axis=0).max()) if len(V) else 0.0
        self.scale = 2.0 ** np.round(np.log2(ext)) if ext > 0 else 1.0  # a power of two: V / scale exact, about unit
        V = V / self.scale  # the solve's conditioning then does not depend on the units (the potential scales back)
        self.V, self.F, self.kind, self.method = V, F, kind, method
        self.connection = conn = connection(V, F, validated=True)
        n, m = len(V), len(F)
        self._place(idx, max_distance)
        self.B, self.area = field_operator(V, F, kind)
        means, self.lonely = _vertex_means(F, self.area, n)
        if self.lonely[self.vertices].any():
            raise SampleError("a sample sits at a vertex in no face, which has no vector; drop it")
        self.T = (_frame_rows(conn.frames, np.arange(n), 3 * n) @ means @ self.B).tocsr()  # (2n, n) frame coords
        C = sp.csr_array(sp.vstack([_frame_rows(conn.frames, self.vertices, 3 * n) @ means @ self.B,
                                    _frame_rows(conn.face_frames, self.faces, 3 * m) @ self.B]))
        self.count, self.labels = connected_components(F, n)
        anchors = np.unique(self.labels, return_index=True)[1]
        if C.shape[0] > n - len(anchors):
            raise SampleError(f"{self.k} samples give {C.shape[0]} rows for {n - len(anchors)} free values of the "
                              f"scalar; pass fewer samples, or refine the mesh")
        A = _energy(V, F, conn, self.B, self.T, self.area, method)
        probe = np.random.default_rng(0).standard_normal(C.shape[0])  # met only if the rows are independent
        try:
            self.solver = QuadraticSolver(A, anchors, Aeq=C, solver="direct", symmetric_pattern=True)
            self.probe = float(np.abs(C @ self.solver.solve(np.zeros(len(anchors)), beq=probe) - probe).max())
            bad = self.probe > 1e-5  # dependent rows miss by O(1); round-off of a factorisation by far less
        except SolveError:  # the factoriser saw the KKT system singular
            bad = True
        if bad:
            raise SampleError("the samples' rows are dependent (samples in one face, in faces that share an edge, or "
                              "whose edges close a ring, fix one gradient twice): drop or merge such samples")
        self.mass = mass_matrix(V, F).diagonal()
        self.interior = _interior(F, n)
        half = 0.5 * np.linalg.norm(V[F[:, [2, 0, 1]]] - V[F[:, [1, 2, 0]]], axis=2)  # area_f |grad hat_i|_f
        self._size = sp.csr_array((half.ravel(), (F.ravel(), np.repeat(np.arange(m), 3))), shape=(n, m))

    def _place(self, idx, max_distance):
        """The samples at vertices and inside faces (:class:`~manifill.vectors.places.SamplePlaces`, in the
        positions' scaled units)."""
        idx = np.asarray(idx)
        if idx.ndim == 2 and np.issubdtype(idx.dtype, np.floating):
            idx = idx / self.scale
            max_distance = None if max_distance is None else max_distance / self.scale
        self.places = p = SamplePlaces(self.V, self.F, idx, max_distance)
        self.vertices, self.faces, self.k = p.vertices, p.faces, p.k
        self.vertex_samples, self.face_samples = p.vertex_samples, p.face_samples

    def _coordinates(self, vectors, normal):
        """The arrows' tangent parts in their frames, ``(2k[, p])`` interleaved: vertex samples, then faces'."""
        if normal not in NORMAL:
            raise OptionError(f"normal={normal!r}: pass 'refuse' or 'drop'")
        W = self.places.coordinates(self.connection, vectors, normal)
        return to_real(np.concatenate([W[self.vertex_samples], W[self.face_samples]]))

    def solve(self, vectors, *, normal="refuse"):
        """The fitted field for arrows ``(k, 3)`` or ``(k, 3, p)``.

        Parameters
        ----------
        vectors : (k, 3) or (k, 3, p) array_like
            One arrow per sample (per field), in space; only the tangent part is met.
        normal : {'refuse', 'drop'}, optional
            An arrow more than a tenth normal to the surface is refused, or its normal part dropped.

        Returns
        -------
        HodgeResult
            The potential (or stream function), the face and vertex vectors, the report.
        """
        beq = self._coordinates(vectors, normal)
        p = beq.shape[1:]
        X = self._zero_mean(np.asarray(self.solver.solve(np.zeros((self.count,) + p), beq=beq)).reshape((-1,) + p))
        faces = (self.B @ X.reshape(len(X), -1)).reshape((len(self.F), 3) + p)
        XY = self.T @ X
        verts = self.connection.to_space(XY[0::2] + 1j * XY[1::2])
        verts[self.lonely] = np.nan
        report = {"method": self.method, "kind": self.kind, "samples": self.k, "inside_faces": len(self.face_samples),
                  "divergence": self._relative(faces, "divergence"), "curl": self._relative(faces, "curl"),
                  "zero": "divergence" if self.kind == "divergence-free" else "curl"}
        return HodgeResult(potential=X * self.scale, face_vectors=faces, vertex_vectors=verts, report=report)

    def _zero_mean(self, X):
        """The scalar less its mass-weighted mean on every component."""
        S = sp.csr_array((self.mass, (self.labels, np.arange(len(X)))), shape=(self.count, len(X)))
        total = S.sum(axis=1)[:, None]
        means = np.divide(S @ X.reshape(len(X), -1), total, out=np.zeros((self.count, X[0].size)), where=total > 0)
        return X - means[self.labels].reshape(X.shape)

    def _relative(self, U, measure):
        """The largest weak divergence (or curl) at the interior vertices over the largest size of its terms."""
        if not self.interior.any():
            return 0.0
        fn = weak_divergence if measure == "divergence" else weak_curl
        d = np.abs(fn(self.V, self.F, U)).reshape(len(self.V), -1)[self.interior]
        size = (self._size @ np.linalg.norm(U, axis=1).reshape(len(self.F), -1))[self.interior]
        top = size.max(axis=0)
        return float(np.max(np.divide(d.max(axis=0), top, out=np.zeros_like(top), where=top > 0)))


def hodge_fit(V, F, idx, vectors, *, kind="curl-free", method="biharmonic", solver="auto", max_distance=None,
              normal="refuse"):
    """The curl-free or divergence-free fit of arrows at once: :class:`HodgeFit` prepared and solved.

    Parameters
    ----------
    V, F, idx, kind, method, solver, max_distance
        As :class:`HodgeFit`.
    vectors, normal
        As :meth:`HodgeFit.solve`.

    Returns
    -------
    HodgeResult

    See Also
    --------
    manifill.vectors.fill.VectorFill : the fit of any tangent field (no Hodge constraint).
    """
    fit = HodgeFit(V, F, idx, kind=kind, method=method, solver=solver, max_distance=max_distance)
    return fit.solve(vectors, normal=normal)
