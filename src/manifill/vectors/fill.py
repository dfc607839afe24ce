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

from ..errors import OptionError, SampleError
from ..linalg.hermitian import factorise_hermitian
from ..linalg.quadratic import QuadraticSolver
from ..mesh.pointcloud import Cloud
from ..linalg.smoothing import smooth
from ..mesh.laplacian import mass_matrix
from ..validate import as_mesh
from .cloud import cloud_connection
from .connection import connection, real_form
from .options import NORMAL, SYMMETRIES, VECTOR_METHODS
from .places import SamplePlaces, interleave, real_rows, tangent_parts, to_complex, to_real

__all__ = ["ORDERS", "SYMMETRIES", "NORMAL", "VectorFill", "tangent_parts"]

#: The energies by name: the power of the connection Laplacian.
ORDERS = {name: m.order for name, m in VECTOR_METHODS.items() if m.energy}
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
    like : VectorFill, optional
        A fill of the same mesh and samples (another symmetry or energy): its connection, mass and sample places
        are taken as they are instead of built again.
    """

    def __init__(self, V, F, idx, *, method="biharmonic", symmetry=1, smoothing=None, solver="auto",
                 max_distance=None, validated=False, like=None):
        if method not in ORDERS:
            raise OptionError(f"method={method!r} is not a vector method; pass one of {', '.join(ORDERS)}")
        if symmetry not in SYMMETRIES:
            raise OptionError(f"symmetry={symmetry!r}: pass 1 (arrows), 2 (lines) or 4 (crosses)")
        if like is not None:
            V, F, self.cloud, conn, self.mass = like.V, like.F, like.cloud, like.connection, like.mass
        elif F is None:  # a point cloud: its own frames and fans
            self.cloud = Cloud(np.asarray(V, dtype=np.float64))
            V, conn, self.mass = self.cloud.P, cloud_connection(self.cloud), self.cloud.M
        else:
            if not validated:
                V, F = as_mesh(V, F, allow_unreferenced=True)
            self.cloud, conn, self.mass = None, connection(V, F, validated=True), mass_matrix(V, F).diagonal()
        self.V, self.F, self.method, self.symmetry, self.smoothing = V, F, method, symmetry, smoothing
        self.connection = conn
        n = conn.n
        self.places = p = like.places if like is not None else SamplePlaces(V, F, idx, max_distance)
        self.vertices, self.vertex_samples, self.face_samples = p.vertices, p.vertex_samples, p.face_samples
        self.faces, self.bary, self.points, self.k = p.faces, p.bary, p.points, p.k
        # every path of the solve (complex, real with rows, smoothed, iterative) refuses an unsampled piece alike
        corners = np.asarray(F)[self.faces].ravel() if F is not None else np.zeros(0, dtype=np.int64)
        _check_pieces(conn.edges, self._used(), np.concatenate([self.vertices, corners]).astype(np.int64))
        Ac = conn.laplacian(symmetry)
        if ORDERS[method] == 2:
            inv = 1.0 / np.maximum(self.mass, np.finfo(float).tiny)
            Ac = (Ac @ sp.diags_array(inv) @ Ac).tocsr()
        self.energy = Ac
        self.rows = real_rows(conn.face_rows(self.faces, self.bary, symmetry)) if len(self.faces) else None
        self.complex = None
        if smoothing is None and self.rows is None and solver in ("auto", "direct"):
            self.complex = _HermitianDirichlet(Ac, self.vertices, self._used())
            self.A = self.solver = None
            self.solver_name = solver
            return
        self.A = A = real_form(Ac)
        if smoothing is None:
            self.solver = QuadraticSolver(A, interleave(self.vertices), Aeq=self.rows,
                                          solver="direct" if solver == "auto" else solver,
                                          what="the connection's energy")
        else:
            unit = sp.csr_array((np.ones(len(self.vertices)), (np.arange(len(self.vertices)), self.vertices)),
                                shape=(len(self.vertices), n))
            S = sp.vstack([unit, conn.face_rows(self.faces, self.bary, symmetry)]) if len(self.faces) else unit
            self.S = real_rows(S)
            self.solver = None
        self.solver_name = solver

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
        return self.places.coordinates(self.connection, vectors, normal, self.symmetry)

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
            vals = to_real(W[self.vertex_samples])
            beq = to_real(W[self.face_samples]) if self.rows is not None else None
            X = self.solver.solve(vals, beq=beq)
        else:
            y = to_real(np.concatenate([W[self.vertex_samples], W[self.face_samples]]))
            lam = self.smoothing
            X, info = smooth(self.A, self.S, y, lam, solver=self.solver_name)
            report["smoothing"] = {key: info[key] for key in ("lambda", "edf", "rms_residual") if key in info}
        return to_complex(X), report

    def representative(self, Z):
        """One vector per power-representation number: ``|Z| exp(1j arg Z / n)``."""
        if self.symmetry == 1:
            return Z
        return np.abs(Z) * np.exp(1j * np.angle(Z) / self.symmetry)


class _HermitianDirichlet:
    """The complex energy's Dirichlet problem: the sample vertices fixed, the rest solved with one Hermitian
    factorisation (:func:`manifill.linalg.hermitian.factorise_hermitian`); vertices in no face are NaN."""

    def __init__(self, A, fixed, used):  # every piece has a sample: VectorFill checked
        n = A.shape[0]
        free_mask = used.copy()
        free_mask[fixed] = False
        self.n, self.fixed, self.free = n, fixed, np.flatnonzero(free_mask)
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
