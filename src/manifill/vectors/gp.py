"""The tangent vector field as a Gaussian field: the connection-Laplacian Matérn prior, its posterior mean and std.

A tangent field is the complex number ``z_i = x_i + 1j y_i`` per vertex in its frame
(:mod:`manifill.vectors.connection`). Its prior is the Whittle-Matérn SPDE ``(kappa^2 + nabla^* nabla) z = W / tau``
of order ``alpha = 2`` with the connection Laplacian ``L_c`` (Hermitian) in place of the scalar one: with ``M`` the
lumped (barycentric, as the scalar gp's) mass and ``K = kappa^2 M + L_c``, the precision is

    Q = s^-2 K M^-1 K,    s^2 = 1 / tau^2,

taken in its real form (``[x_0, y_0, x_1, ...]``, :func:`~manifill.vectors.connection.real_form`, ``M`` repeated
per component), so that :class:`~manifill.linalg.spde.MaternShape` and :class:`~manifill.linalg.gaussian.Conditional`
take it as they are (the likelihood's covariances use the complex ``K``: :func:`_covariance`). The mean is zero: a
tangent field has no constant to estimate.

The field is *circular*: a complex-linear prior and complex-linear observations (a vertex's two components; a point
inside a face, the corners carried into its frame; noise of equal variance on both components) keep the real
form's blocks ``[[a, -b], [b, a]]``, so the posterior covariance of ``(x_i, y_i)`` is ``v_i I`` (the diagonal block
of a Hermitian matrix is real). The tangent vector's uncertainty is the same in every tangent direction: ``std``
is the standard deviation of its component along any unit tangent direction, ``E|z_i - mean_i|^2 = 2 std^2``, and
its covariance in space is ``std^2 (I - n n')`` (:attr:`VectorPosterior.cov`).

``sigma`` is, likewise, the prior standard deviation of one tangent component, the scalar Matérn's ``sigma^2 =
s^2 / (4 pi kappa^2)`` (``nu = alpha - d / 2 = 1``; exact on a flat domain, where each component is a scalar
Matérn field), and the range is the scalar's ``sqrt(8 nu) / kappa``. Both are fitted by maximum likelihood of the
samples unless given (the mean known, zero): for a fixed ``kappa`` the scale is ``s^2 = y' R^-1 y / (2 m)``
(``R`` the samples' covariance shape, ``2 m`` real components); ``log kappa`` is searched
(:func:`~manifill.linalg.gpfit.fit_range`, :mod:`manifill.linalg.search`) between a range of twice the mesh's
diameter and the larger of two edges and a quarter of the samples' median spacing. Line and cross fields
(``symmetry=2, 4``) are the same model on the power representation (:class:`~manifill.vectors.fill.VectorFill`).
"""

import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ..errors import MeshError, OptionError, SampleError
from ..linalg.cholesky import cholmod_available
from ..linalg.factorise import factorise
from ..linalg.gaussian import VARIANCES, Conditional, factoriser_for, observation_matrix
from ..linalg.quadratic import QuadraticSolver
from ..linalg.gpfit import fit_range
from ..linalg.hermitian import factorise_hermitian
from ..linalg.spde import MaternShape, kappa_from_range, range_from_kappa, sigma_from_tau, tau_from_sigma
from ..mesh.laplacian import mass_matrix
from ..validate import as_mesh
from .connection import connection, real_form
from .options import SYMMETRIES
from .places import SamplePlaces, interleave, real_rows

__all__ = ["FIT_SAMPLES", "SOLVERS", "VectorGP", "VectorPosterior"]

#: Most arrows the likelihood sees (a random subset, fixed, in the samples' order). Not the scalar gp's sparse
#: likelihood of every sample: its factor of the real form's ``Q`` is too costly here (41k vertices, 1,000 arrows,
#: side by side on a loaded machine: 432 s for the fit against 68 s on 200 of them).
FIT_SAMPLES = 200
#: The linear solvers of the posterior.
SOLVERS = ("auto", "direct", "amg")
_ALPHA, _DIM = 2, 2


def _covariance(Lc, mass, Hc, kappa):
    """``R`` (dense ``2k x 2k``): the real form of ``Hc K^-1 M K^-1 Hc^H``, the covariance shape of the samples'
    components, from one complex Hermitian factorisation of ``K = kappa^2 M + L_c`` (at 41k vertices a third of
    the real form's time: half the unknowns, a quarter of the factor's entries)."""
    f = factorise_hermitian(Lc + sp.diags_array(kappa * kappa * mass))
    W = np.asarray(f.solve(Hc.conj().T.toarray())).reshape(Lc.shape[0], -1)
    C = W.conj().T @ (mass[:, None] * W)
    C = (C + C.conj().T) * 0.5
    R = np.empty((2 * C.shape[0], 2 * C.shape[0]))
    R[0::2, 0::2], R[0::2, 1::2], R[1::2, 0::2], R[1::2, 1::2] = C.real, -C.imag, C.imag, C.real
    return R


def _s2_of_sigma(sigma, kappa):
    return 1.0 / tau_from_sigma(sigma, kappa, _ALPHA, _DIM) ** 2


#: Without CHOLMOD, the exact variance is read from solves with unit columns (the real form's Cholesky factor from
#: SuperLU drops exact zeros of its pattern, which the selected inversion needs) up to this many unknowns.
EXACT_BY_SOLVES = 8_000


def _variance_by_solves(Q, idx, rows, eta, block=512):
    """The conditional variance of every unknown from solves of the conditioned system with unit columns: exact data
    (``x[idx]`` fixed, ``rows x = 0``) through :class:`~manifill.linalg.quadratic.QuadraticSolver` (``-x`` minimises
    ``x' Q x / 2 - e' x``: a column of the conditional covariance), noisy data through the factor of
    ``Q + H' E^-1 H``."""
    t0 = time.perf_counter()
    n = Q.shape[0]
    var = np.zeros(n)
    if eta is None:
        qs = QuadraticSolver(Q, idx, solver="direct", Aeq=rows, on_empty="solve", symmetric_pattern=True)
        free = np.setdiff1d(np.arange(n), idx)
        zeros = np.zeros(len(idx))
        beq = None if rows is None else np.zeros(rows.shape[0])
        for start in range(0, len(free), block):
            cols = free[start:start + block]
            E = np.zeros((n, len(cols)))
            E[cols, np.arange(len(cols))] = -1.0
            X = qs.solve(np.repeat(zeros[:, None], len(cols), axis=1), linear=E,
                         beq=None if beq is None else np.repeat(beq[:, None], len(cols), axis=1))
            var[cols] = X[cols, np.arange(len(cols))]
    else:
        H = observation_matrix(n, idx, rows)
        eta = np.broadcast_to(np.asarray(eta, dtype=np.float64), (H.shape[0],))
        _, f = factorise(sp.csr_array(Q + H.T @ sp.diags_array(1.0 / eta) @ H), spd=True)
        for start in range(0, n, block):
            cols = np.arange(start, min(n, start + block))
            E = np.zeros((n, len(cols)))
            E[cols, np.arange(len(cols))] = 1.0
            var[cols] = np.asarray(f.solve(E))[cols, np.arange(len(cols))]
    return np.maximum(var, 0.0), {"how": "exact", "seconds": time.perf_counter() - t0}


def _check(range_, sigma, noise, symmetry, solver, variance):
    real = (int, float, np.integer, np.floating)
    for name, v in (("range", range_), ("sigma", sigma)):
        if v is not None and not (isinstance(v, real) and math.isfinite(v) and v > 0):
            raise OptionError(f"{name}={v!r} is not a length > 0; pass a positive number, or None to fit it")
    if not (isinstance(noise, real) and math.isfinite(noise) and noise >= 0):
        raise OptionError(f"noise={noise!r} is not a variance >= 0; pass 0 for exact arrows or a positive variance")
    if symmetry not in SYMMETRIES:
        raise OptionError(f"symmetry={symmetry!r}: pass 1 (arrows), 2 (lines) or 4 (crosses)")
    if solver not in SOLVERS:
        raise OptionError(f"solver={solver!r} is not one of {', '.join(SOLVERS)}; pass one of those")
    if variance not in VARIANCES:
        raise OptionError(f"variance={variance!r} is not one of {', '.join(VARIANCES)}; pass one of those")


@dataclass
class VectorPosterior:
    """The posterior of a tangent field given arrows (:meth:`VectorGP.solve`).

    Attributes
    ----------
    Z : (n,) or (n, p) complex numpy array
        The posterior mean in the vertex frames (the power representation for ``symmetry > 1``).
    std : (n,) or (n, p) numpy array
        The posterior standard deviation of the vector's component along any unit tangent direction (the
        covariance is isotropic in the tangent plane); 0 at exact samples at vertices.
    kappa, range : float
        The SPDE's ``kappa`` and the range ``sqrt(8) / kappa`` (fitted or given; shared by the fields).
    sigma, scale : float or (p,) numpy array
        Per field: the prior standard deviation of one tangent component and ``s = 1 / tau``.
    noise : float
        The noise variance of each component of an arrow (0: exact).
    report : dict
        ``fitted``, ``loglik``, ``fit`` (samples, likelihood, evaluations, range bounds), ``variance`` (how,
        seconds, ``anisotropy``: the largest ``|var_x - var_y|`` over the largest variance), ``solver``,
        ``seconds``.
    connection : Connection
    symmetry : int
    """

    Z: np.ndarray
    std: np.ndarray
    kappa: float
    range: float
    sigma: object
    scale: object
    noise: float
    report: dict
    connection: object = field(repr=False)
    symmetry: int = 1
    _draw: object = field(default=None, repr=False)

    @property
    def complex(self):
        """:attr:`Z`, the mean's complex numbers."""
        return self.Z

    @property
    def vertex(self):
        """The mean as vectors in space, ``(n, 3[, p])`` (for ``symmetry > 1`` one of the equal directions)."""
        return self.connection.to_space(self._representative(self.Z))

    @property
    def faces(self):
        """The mean carried into every face and averaged, as vectors in space, ``(m, 3[, p])``."""
        return self.connection.to_space(self._representative(self.connection.on_faces(self.Z, self.symmetry)),
                                        faces=True)

    def _representative(self, Z):
        return Z if self.symmetry == 1 else np.abs(Z) * np.exp(1j * np.angle(Z) / self.symmetry)

    @property
    def cov(self):
        """The covariance of the vector in space per vertex, ``std^2 (I - n n')``: ``(n, 3, 3[, p])`` (in the
        vertex's frame it is ``std^2 I``)."""
        N = self.connection.frames[:, 2]
        P = np.eye(3)[None] - N[:, :, None] * N[:, None, :]
        v = self.std ** 2
        return P * v[:, None, None] if v.ndim == 1 else P[..., None] * v[:, None, None, :]

    def sample(self, count, seed=0, *, field=0):
        """``count`` draws of whole fields from the posterior of field ``field``: complex ``(n, count)``.

        Each is the mean plus ``s`` times a draw of the conditional law given zero data
        (:meth:`~manifill.linalg.gaussian.Conditional.draws`); ``connection.to_space`` makes them vectors.
        """
        count = int(count)
        if count < 1:
            raise OptionError(f"count={count} draws: pass 1 or more")
        p = 1 if self.Z.ndim == 1 else self.Z.shape[1]
        if not 0 <= field < p:
            raise OptionError(f"field={field} is not one of the {p} fields; pass 0 to {p - 1}")
        E = self._draw(field, count, np.random.default_rng(seed if field == 0 else (seed, field)))
        mean = self.Z if self.Z.ndim == 1 else self.Z[:, field]
        return mean[:, None] + E

    def draws_of(self, count, seed=0):
        """:meth:`sample` of every field as vectors in space: :attr:`vertex`'s shape and the draws last."""
        p = 1 if self.Z.ndim == 1 else self.Z.shape[1]
        D = [self.connection.to_space(self._representative(self.sample(count, seed, field=j))) for j in range(p)]
        return D[0] if self.Z.ndim == 1 else np.stack(D, axis=2)


class VectorGP:
    """The Gaussian tangent field of one mesh and one set of sample places, prepared once (see the module).

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles.
    idx : (k,) array_like of int, or (k, 3) array_like of float
        Sample vertices, or positions (each at its closest surface point: a vertex or a face's inside).
    range : float > 0, optional
        The prior's range ``sqrt(8) / kappa``; None (the default) fits it by maximum likelihood.
    sigma : float > 0, optional
        The prior standard deviation of one tangent component; None fits it (closed form for exact arrows).
    noise : float >= 0, optional
        The variance of the noise on each component of an arrow; 0 (the default): the arrows are met exactly.
    symmetry : {1, 2, 4}, optional
        1 for arrows, 2 for lines, 4 for crosses (the power representation).
    solver : {'auto', 'direct', 'amg'}, optional
        The posterior's linear solver (``auto``: a factorisation).
    max_distance : float, optional
        Positions farther than this from the surface are refused.
    variance : {'auto', 'exact', 'sampled'}, optional
        How the std is computed (:meth:`~manifill.linalg.gaussian.Conditional.variance`).
    validated : bool, optional
        ``V``, ``F`` are arrays already checked (a mesh cut along barriers, whose copies coincide).

    Raises
    ------
    OptionError
        An option out of its range.
    SampleError
        Malformed sample places, or two at one vertex.
    MeshError
        A malformed mesh, or a vertex of no face.

    Notes
    -----
    :meth:`solve` (or :meth:`fit`, the same) takes the arrows; ``draws_of`` is then the last posterior's
    :meth:`VectorPosterior.draws_of`. The factorisations of a posterior are kept for the next arrows with the same
    hyperparameters (given ones: every call).
    """

    def __init__(self, V, F, idx, *, range=None, sigma=None, noise=0.0, symmetry=1, solver="auto",
                 max_distance=None, variance="auto", validated=False):
        _check(range, sigma, noise, symmetry, solver, variance)
        if not validated:
            V, F = as_mesh(V, F, allow_unreferenced=True)
        self.V, self.F, self.symmetry, self.solver, self.variance = V, F, symmetry, solver, variance
        self.range, self.sigma, self.noise = range, sigma, float(noise)
        self.connection = conn = connection(V, F, validated=True)
        c = mass_matrix(V, F, mass="barycentric").diagonal()
        if np.any(c <= 0):
            raise MeshError(f"vertex {int(np.argmin(c))} belongs to no face (no mass); drop the unreferenced "
                            f"vertices (manifill.mesh.clean.clean_mesh)")
        self._places(V, F, idx, max_distance)
        self.Lc, self.mass = conn.laplacian(symmetry), c
        self.shape = MaternShape(real_form(self.Lc), np.repeat(c, 2), None, _ALPHA, _DIM)
        # the real data: vertex samples by vertex (Conditional wants them sorted), then the face samples
        order = np.argsort(self.vertices, kind="stable")
        self.order = np.concatenate([self.vertex_samples[order], self.face_samples])
        self.idx = interleave(self.vertices[order])
        rows = conn.face_rows(self.faces, self.bary, symmetry)
        self.rows = real_rows(rows) if len(self.faces) else None
        self.Hc = sp.csr_array(sp.vstack([observation_matrix(conn.n, self.vertices[order]), rows]))
        E = conn.edges
        self.length = float(np.median(np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)))
        self.diameter = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
        P = V[self.vertices] if self.points is None else self.points.points
        self.spacing = self.diameter if len(P) < 2 else float(np.median(cKDTree(P).query(P, k=2)[0][:, 1]))
        self._conds = {}

    def _places(self, V, F, idx, max_distance):
        """The samples' vertices, and the faces and barycentric coordinates of those inside faces."""
        self.places = p = SamplePlaces(V, F, idx, max_distance)
        self.vertices, self.vertex_samples, self.face_samples = p.vertices, p.vertex_samples, p.face_samples
        self.faces, self.bary, self.points, self.k = p.faces, p.bary, p.points, p.k

    def coordinates(self, vectors, normal="refuse"):
        """The arrows ``(k, 3[, p])`` as complex numbers in their vertex's or face's frame, ``(k[, p])`` (the
        power representation for ``symmetry > 1``); ``normal='drop'`` drops normal parts (else refused)."""
        return self.places.coordinates(self.connection, vectors, normal, self.symmetry)

    def solve(self, vectors, *, normal="refuse"):
        """The posterior of the field given the arrows ``(k, 3[, p])``: a :class:`VectorPosterior`.

        The hyperparameters not given are fitted first (one ``kappa`` for all the fields, a scale per field).
        """
        t0 = time.perf_counter()
        W = self.coordinates(vectors, normal)
        single = W.ndim == 1
        Wr = W.reshape(self.k, -1)[self.order]
        Y = np.stack([Wr.real, Wr.imag], axis=1).reshape(2 * self.k, -1)  # [x_0, y_0, x_1, ...]
        report = {"samples": self.k, "inside_faces": int(len(self.face_samples)), "symmetry": self.symmetry}
        kappa, s2 = self._hyper(Y, report)
        t = time.perf_counter()
        Z, var, conds, s2 = self._posterior(Y, kappa, s2, report)
        report["seconds"] = {"posterior": time.perf_counter() - t, "total": time.perf_counter() - t0}
        std = np.sqrt(np.maximum(var * s2[None, :], 0.0))
        sigma = np.array([sigma_from_tau(1.0 / math.sqrt(v), kappa, _ALPHA, _DIM) for v in s2])
        scale = np.sqrt(s2)
        report.update({"kappa": kappa, "range": range_from_kappa(kappa, _ALPHA, _DIM), "sigma": sigma.tolist(),
                       "scale": scale.tolist(), "noise": self.noise})

        def draw(j, count, rng):
            E = conds[j].draws(count, rng)
            return math.sqrt(s2[j]) * (E[0::2] + 1j * E[1::2])

        pick = (lambda a: a[:, 0]) if single else (lambda a: a)
        one = (lambda a: float(a[0])) if single else (lambda a: a)
        post = VectorPosterior(pick(Z), pick(std), kappa, report["range"], one(sigma), one(scale), self.noise,
                               report, self.connection, self.symmetry, draw)
        self.draws_of = post.draws_of  # the last posterior's draws in space (what VectorReconstructor reads)
        return post

    fit = solve

    # ---- the hyperparameters ------------------------------------------------------------------------------

    def kappa_bounds(self):
        """The search interval of ``kappa``: ranges from ``max(2 edges, spacing / 4)`` to twice the diameter."""
        lo = max(2.0 * self.length, self.spacing / 4.0)
        hi = max(2.0 * self.diameter, 2.0 * lo)
        return kappa_from_range(hi, _ALPHA, _DIM), kappa_from_range(lo, _ALPHA, _DIM)

    def _hyper(self, Y, report):
        """``(kappa, s2)``: given, or fitted; ``s2`` entries left NaN are profiled on all the samples later."""
        p = Y.shape[1]
        given_k = None if self.range is None else kappa_from_range(self.range, _ALPHA, _DIM)
        noisy = self.noise > 0
        report["fitted"] = [name for name, v in (("range", self.range), ("sigma", self.sigma)) if v is None]
        if given_k is not None and (self.sigma is not None or not noisy):
            s2 = np.full(p, np.nan if self.sigma is None else _s2_of_sigma(self.sigma, given_k))
            return given_k, s2
        if Y.shape[0] < 6 and given_k is None:
            raise SampleError(f"fitting the range needs at least 3 arrows, got {Y.shape[0] // 2}; pass range=")
        t = time.perf_counter()
        unit = np.sqrt(np.mean(Y * Y, axis=0))
        unit[~(unit > 0)] = 1.0
        sub = np.arange(self.k)
        if self.k > FIT_SAMPLES:  # a subset in the samples' own order: the same for any numbering
            pick = np.sort(np.random.default_rng(0).choice(self.k, FIT_SAMPLES, replace=False))
            sub = np.sort(np.argsort(self.order)[pick])
        rows = interleave(sub)
        Zd = Y[rows] / unit
        Hc = self.Hc[sub]

        def s2_given(kap):  # a given sigma: the scale follows kappa
            return np.full(p, _s2_of_sigma(self.sigma, kap)) / unit ** 2
        given = None if self.sigma is None else s2_given if given_k is None else s2_given(given_k)
        fit = fit_range(lambda kap: _covariance(self.Lc, self.mass, Hc, kap), Zd, self.kappa_bounds(), mean=0.0,
                        s2=given, noise2=np.full(p, self.noise) / unit ** 2 if noisy else None, kappa=given_k)
        s2 = np.asarray(fit["s2"]) * unit ** 2
        if self.sigma is None and not noisy:
            s2[:] = np.nan  # the closed form on every sample
        report["loglik"] = fit["loglik"] - len(rows) * float(np.log(unit).sum())
        report["fit"] = {"samples": int(len(sub)), "evaluations": fit["evaluations"],
                         "range_bounds": [range_from_kappa(b, _ALPHA, _DIM) for b in self.kappa_bounds()[::-1]],
                         "seconds": time.perf_counter() - t}
        return fit["kappa"], s2

    # ---- the posterior ------------------------------------------------------------------------------------

    def _conditional(self, kappa, eta):
        """The :class:`~manifill.linalg.gaussian.Conditional` of ``(kappa, eta)`` and its variance (per component,
        units of ``s^2``), kept for the next call with the same ones."""
        key = (float(kappa), None if eta is None else float(f"{eta:.12g}"))
        if key not in self._conds:
            if len(self._conds) >= 4:
                self._conds.clear()
            unknowns = self.shape.n - (len(self.idx) if eta is None else 0)
            Q = self.shape.precision(kappa)
            by_solves = not cholmod_available() and (self.variance == "exact" or (
                self.variance == "auto" and unknowns <= EXACT_BY_SOLVES))
            cond = Conditional(Q, self.shape.root(kappa), self.idx, rows=self.rows,
                               eta=eta, solver="direct" if self.solver == "auto" else self.solver, definite=True,
                               factoriser=None if by_solves else factoriser_for(True, self.variance, unknowns))
            if by_solves:
                var, info = _variance_by_solves(Q, self.idx, self.rows, eta)
            else:
                var, info = cond.variance(self.variance)
            vx, vy = var[0::2], var[1::2]
            info = {k: v for k, v in info.items() if k != "se"}
            info["anisotropy"] = float(np.abs(vx - vy).max() / max(float(var.max()), 1e-300))
            self._conds[key] = (cond, 0.5 * (vx + vy), info)
        return self._conds[key]

    def _posterior(self, Y, kappa, s2, report):
        """``(Z, var, conds, s2)``: the mean, the variance per component in units of ``s^2`` per field, the
        Conditional of every field, the scales (NaN ones profiled here: ``y' R^-1 y / (2 m)``)."""
        m2, p = Y.shape
        Z = np.empty((self.connection.n, p), dtype=complex)
        var = np.empty((self.connection.n, p))
        conds = [None] * p
        etas = [None if self.noise == 0 else self.noise / s2[j] for j in range(p)]
        groups = {}
        for j, eta in enumerate(etas):
            groups.setdefault(eta, []).append(j)
        for eta, cols in groups.items():
            cond, v, info = self._conditional(kappa, eta)
            X = cond.extend(Y[:, cols])
            G = cond.gram(Y[:, cols], X)
            for i, j in enumerate(cols):
                Z[:, j] = X[0::2, i] + 1j * X[1::2, i]
                var[:, j], conds[j] = v, cond
                if np.isnan(s2[j]):
                    s2[j] = max(G[i, i] / m2, 1e-300)
            report["variance"], report["solver"] = info, cond.report
        return Z, var, conds, s2
