"""The tangent vector fill: the smoothest field of the connection's energy that meets the arrows.

With ``L`` the connection Laplacian (:mod:`manifill.vectors.connection`) and ``M`` the lumped mass, the energy is
the vector Dirichlet energy ``z^H L z`` (``method='harmonic'``) or the vector biharmonic energy ``z^H L M^-1 L z``
(``method='biharmonic'``, the default: smooth across the samples). Samples at vertices fix the vertex's two
coordinates; samples inside faces are linear rows (the three corners carried into the face, weighted by the
barycentric coordinates). The real form of the problem is one of :class:`~manifill.linalg.quadratic.QuadraticSolver`
(exact samples) or of :func:`~manifill.linalg.smoothing.smooth` (``smoothing=``, noisy arrows): prepared once,
solved for any number of fields.

Line and cross fields (``symmetry=2`` or ``4``: directions without a sign) are filled in the power
representation: a sample ``u`` becomes ``|u| exp(1j n arg u)``, which ``u`` and ``-u`` (or its quarter turns) share;
the result's direction is the ``n``-th root's, one of the ``n`` equal ones.
"""

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..errors import OptionError, SampleError
from ..linalg.hermitian import factorise_hermitian
from ..linalg.quadratic import QuadraticSolver
from ..mesh.pointcloud import Cloud
from ..linalg.smoothing import smooth
from ..mesh.laplacian import mass_matrix
from ..surface.locate import locate_points
from ..validate import as_indices, as_mesh
from .cloud import cloud_connection
from .connection import connection, real_form
from .options import NORMAL, SYMMETRIES, VECTOR_METHODS

__all__ = ["ORDERS", "SYMMETRIES", "NORMAL", "VectorFill", "tangent_parts"]

#: The energies by name: the power of the connection Laplacian.
ORDERS = {name: m.order for name, m in VECTOR_METHODS.items() if m.energy}
NORMAL_LIMIT = 0.1


def _interleave(i):
    i = np.asarray(i, dtype=np.int64)
    return np.column_stack([2 * i, 2 * i + 1]).ravel()


def _real_rows(R):
    """The real rows ``(2k, 2n)`` of complex rows ``(k, n)`` (unknowns and rows interleaved)."""
    R = sp.coo_array(R)
    r, c, a, b = R.row, R.col, R.data.real, R.data.imag
    rows = np.concatenate([2 * r, 2 * r, 2 * r + 1, 2 * r + 1])
    cols = np.concatenate([2 * c, 2 * c + 1, 2 * c, 2 * c + 1])
    return sp.csr_array((np.concatenate([a, -b, b, a]), (rows, cols)), shape=(2 * R.shape[0], 2 * R.shape[1]))


def _to_real(Z):
    """Complex ``(k,)`` or ``(k, p)`` as real ``(2k,)`` or ``(2k, p)``, interleaved."""
    Z = np.asarray(Z)
    out = np.empty((2 * Z.shape[0],) + Z.shape[1:])
    out[0::2], out[1::2] = Z.real, Z.imag
    return out


def _to_complex(X):
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


class VectorFill:
    """The vector fill of one mesh and one set of sample places, prepared once; :meth:`solve` for any arrows.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles.
    idx : (k,) array_like of int, or (k, 3) array_like of float
        Sample vertices, or positions (each at its closest surface point: a vertex or a face's inside).
    method : {'biharmonic', 'harmonic'}, optional
        The energy (:data:`ORDERS`).
    symmetry : {1, 2, 4}, optional
        1 for arrows, 2 for lines (no sign), 4 for crosses.
    smoothing : float >= 0 or 'auto', optional
        None (the default) meets the samples exactly; a number weighs the energy against the squared misfit (as
        the scalar methods' ``smoothing``), ``'auto'`` chooses it by generalised cross-validation.
    solver : {'auto', 'direct', 'amg', 'iterate'}, optional
        The backend of the solve (:class:`~manifill.linalg.quadratic.QuadraticSolver`); samples inside faces need
        ``'direct'`` or ``'auto'``.
    max_distance : float, optional
        Positions farther than this from the surface are refused (the scalar methods' ``max_distance``).
    validated : bool, optional
        ``V``, ``F`` are arrays already checked (a mesh cut along barriers, whose copies coincide).
    """

    def __init__(self, V, F, idx, *, method="biharmonic", symmetry=1, smoothing=None, solver="auto",
                 max_distance=None, validated=False):
        if method not in ORDERS:
            raise OptionError(f"method={method!r} is not a vector method; pass one of {', '.join(ORDERS)}")
        if symmetry not in SYMMETRIES:
            raise OptionError(f"symmetry={symmetry!r}: pass 1 (arrows), 2 (lines) or 4 (crosses)")
        if F is None:  # a point cloud: its own frames and fans
            self.cloud = Cloud(np.asarray(V, dtype=np.float64))
            V, conn, self.mass = self.cloud.P, cloud_connection(self.cloud), self.cloud.M
        else:
            if not validated:
                V, F = as_mesh(V, F, allow_unreferenced=True)
            self.cloud, conn, self.mass = None, connection(V, F, validated=True), mass_matrix(V, F).diagonal()
        self.V, self.F, self.method, self.symmetry, self.smoothing = V, F, method, symmetry, smoothing
        self.connection = conn
        n = conn.n
        self._place(np.asarray(idx), max_distance)
        if len(np.unique(self.vertices)) < len(self.vertices):
            raise SampleError("two samples sit at one vertex: merge them (their mean vector) or move one")
        self.k = len(self.vertex_samples) + len(self.face_samples)
        Ac = conn.laplacian(symmetry)
        if ORDERS[method] == 2:
            inv = 1.0 / np.maximum(self.mass, np.finfo(float).tiny)
            Ac = (Ac @ sp.diags_array(inv) @ Ac).tocsr()
        self.energy = Ac
        self.rows = _real_rows(conn.face_rows(self.faces, self.bary, symmetry)) if len(self.faces) else None
        self.complex = None
        if smoothing is None and self.rows is None and solver in ("auto", "direct"):
            self.complex = _HermitianDirichlet(Ac, self.vertices, conn.edges, self._used())
            self.A = self.solver = None
            self.solver_name = solver
            return
        self.A = A = real_form(Ac)
        if smoothing is None:
            self.solver = QuadraticSolver(A, _interleave(self.vertices), Aeq=self.rows,
                                          solver="direct" if solver == "auto" else solver,
                                          what="the connection's energy")
        else:
            unit = sp.csr_array((np.ones(len(self.vertices)), (np.arange(len(self.vertices)), self.vertices)),
                                shape=(len(self.vertices), n))
            S = sp.vstack([unit, conn.face_rows(self.faces, self.bary, symmetry)]) if len(self.faces) else unit
            self.S = _real_rows(S)
            self.solver = None
        self.solver_name = solver

    def _place(self, idx_arr, max_distance):
        """The samples: vertices (or a cloud's nearest points) fixed, positions inside faces as rows."""
        n = self.connection.n
        self.face_samples = np.zeros(0, dtype=np.int64)
        self.faces, self.bary, self.points = np.zeros(0, dtype=np.int64), np.zeros((0, 3)), None
        if idx_arr.ndim == 2 and np.issubdtype(idx_arr.dtype, np.floating) and self.F is None:
            dist, self.vertices = cKDTree(self.V).query(idx_arr)
            if max_distance is not None and np.max(dist) > max_distance:
                raise SampleError(f"sample {int(np.argmax(dist))} is {np.max(dist):.3g} from the nearest point of "
                                  f"the cloud, beyond max_distance={max_distance}; check the positions' units")
        elif idx_arr.ndim == 2 and np.issubdtype(idx_arr.dtype, np.floating):
            where = locate_points(self.V, self.F, idx_arr, max_distance=max_distance)
            at_vertex = where.vertex >= 0
            self.vertices = where.vertex[at_vertex]
            self.face_samples = np.where(~at_vertex)[0]
            self.faces, self.bary = where.faces[~at_vertex], where.bary[~at_vertex]
            self.points = where
        else:
            self.vertices = as_indices(idx_arr, n, what="idx")
        self.vertex_samples = np.setdiff1d(np.arange(len(idx_arr)), self.face_samples)

    def _used(self):
        """The vertices in a face (a cloud: every point)."""
        used = np.zeros(self.connection.n, dtype=bool)
        if self.F is None:
            used[:] = True
        else:
            used[np.asarray(self.F).ravel()] = True
        return used

    def sample_coordinates(self, vectors, normal="refuse"):
        """The arrows ``(k, 3[, p])`` as complex numbers in their vertex's or face's frame, in the power
        representation of :attr:`symmetry`: ``(k[, p])``."""
        X = np.asarray(vectors, dtype=np.float64)
        if X.ndim not in (2, 3) or X.shape[0] != self.k or X.shape[1] != 3:
            raise SampleError(f"the vectors have shape {X.shape}; pass one 3-vector per sample, ({self.k}, 3)")
        if not np.all(np.isfinite(X)):
            raise SampleError("the vectors have NaN or infinite entries; drop those samples")
        conn = self.connection
        W = np.zeros((self.k,) + X.shape[2:], dtype=complex)
        if len(self.vertex_samples):
            fr = conn.frames[self.vertices]
            T = tangent_parts(X[self.vertex_samples], fr[:, 2], normal)
            W[self.vertex_samples] = conn.to_complex(T, at=self.vertices)
        if len(self.face_samples):
            fr = conn.face_frames[self.faces]
            T = tangent_parts(X[self.face_samples], fr[:, 2], normal)
            W[self.face_samples] = _coords(T, fr)
        if self.symmetry > 1:
            W = np.abs(W) * np.exp(1j * self.symmetry * np.angle(W))
        return W

    def solve(self, vectors, *, normal="refuse"):
        """The vertex field ``Z`` (complex, ``(n,)`` or ``(n, p)``) and a report, for arrows ``(k, 3[, p])``."""
        W = self.sample_coordinates(vectors, normal)
        report = {"method": self.method, "symmetry": self.symmetry, "samples": self.k,
                  "inside_faces": int(len(self.face_samples))}
        if self.complex is not None:
            Z = self.complex.solve(W[self.vertex_samples])
            report["solver"] = self.complex.name
            return Z, report
        if self.solver is not None:
            vals = _to_real(W[self.vertex_samples])
            beq = _to_real(W[self.face_samples]) if self.rows is not None else None
            X = self.solver.solve(vals, beq=beq)
        else:
            y = _to_real(np.concatenate([W[self.vertex_samples], W[self.face_samples]]))
            lam = self.smoothing
            X, info = smooth(self.A, self.S, y, lam, solver=self.solver_name)
            report["smoothing"] = {key: info[key] for key in ("lambda", "edf", "rms_residual") if key in info}
        return _to_complex(X), report

    def representative(self, Z):
        """One vector per power-representation number: ``|Z| exp(1j arg Z / n)``."""
        if self.symmetry == 1:
            return Z
        return np.abs(Z) * np.exp(1j * np.angle(Z) / self.symmetry)


class _HermitianDirichlet:
    """The complex energy's Dirichlet problem: the sample vertices fixed, the rest solved with one Hermitian
    factorisation (:func:`manifill.linalg.hermitian.factorise_hermitian`); vertices in no face are NaN."""

    def __init__(self, A, fixed, edges, used):
        n = A.shape[0]
        free_mask = used.copy()
        free_mask[fixed] = False
        self.n, self.fixed, self.free = n, fixed, np.flatnonzero(free_mask)
        _check_pieces(edges, used, fixed)
        A = sp.csr_array(A)
        rows = A[self.free]
        self.A_fb = sp.csr_array(rows[:, fixed])
        self.factor = factorise_hermitian(rows[:, self.free])
        self.name = self.factor.name
        self.unused = ~used

    def solve(self, W):
        W = np.asarray(W, dtype=np.complex128)
        Z = np.empty((self.n,) + W.shape[1:], dtype=np.complex128)
        Z[self.fixed] = W
        Z[self.free] = self.factor.solve(-(self.A_fb @ W))
        Z[self.unused] = np.nan
        return Z


def _check_pieces(edges, used, fixed):
    """Refuse a piece of the surface without a sample: nothing fixes its field."""
    n = len(used)
    G = sp.coo_array((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    count, label = connected_components(G, directed=False)
    has = np.zeros(count, dtype=bool)
    has[label[fixed]] = True
    empty = np.unique(label[used & ~has[label]])
    if empty.size:
        raise SampleError(f"{empty.size} piece(s) of the surface have no sample (the first has "
                          f"{int(np.sum(label == empty[0])):,} vertices); add samples there or leave the piece out")


def _coords(T, frames):
    """Tangent vectors ``(k, 3[, p])`` in the frames ``(k, 3, 3)`` as complex numbers."""
    if T.ndim == 2:
        return np.einsum("kc,kc->k", T, frames[:, 0]) + 1j * np.einsum("kc,kc->k", T, frames[:, 1])
    return np.einsum("kcp,kc->kp", T, frames[:, 0]) + 1j * np.einsum("kcp,kc->kp", T, frames[:, 1])
