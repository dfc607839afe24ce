"""The tangent vector fill (manifill.vectors.fill, manifill.vectors.reconstruct) against its mathematics.

The fill minimises the connection's Dirichlet energy ``E1(z) = sum over edges w_ij |z_j - r_ij z_i|^2`` (or the
biharmonic ``E2(z) = z^H L M^-1 L z``, ``L`` the Hessian of ``E1``, ``M`` the lumped mass) over the complex
numbers ``z`` of the vertices' tangent vectors, the samples fixed. Line and cross fields (``symmetry = s``) are
filled in the power representation ``|u| exp(1j s arg u)`` with the transport ``r_ij ** s``. From that:

- the samples' tangent parts are met exactly (vertices: the vector itself; a point inside a face: the three
  corners carried into the face and weighted by the barycentric coordinates), the field is tangent everywhere;
- the result commutes with rotations of space, does not see the numbering of the mesh or its scale, is linear in
  the arrows (symmetry 1), sees only the line of a symmetry-2 arrow and the cross of a symmetry-4 one;
- it equals the dense minimiser written here from scratch with numpy;
- ``smoothing=0`` is the exact fit, and the energy of the smoothed fit falls as the smoothing grows;
- ``bounds=True`` only scales the vertices above the samples' largest magnitude down to it;
- a barrier along a closed loop makes its two sides independent, and a side without a sample is refused alike
  whatever the solve's path.
"""

import contextlib
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from conftest import relabel
from manifill.errors import ManifillError, OptionError, SampleError
from manifill.mesh.laplacian import mass_matrix
from manifill.mesh.shapes import grid, icosphere, torus
from manifill.vectors.connection import connection
from manifill.vectors.fill import VectorFill
from manifill.vectors.reconstruct import VectorReconstructor, reconstruct_vectors

try:
    from threadpoolctl import threadpool_limits
except ImportError:  # pragma: no cover - an optional dependency
    threadpool_limits = None

HYP = settings(max_examples=4, deadline=None, derandomize=True, database=None)
METHODS = ["harmonic", "biharmonic"]


@pytest.fixture(autouse=True)
def _one_blas_thread():
    """Dense complex solves are pathologically slow with threaded OpenBLAS on a loaded machine."""
    with threadpool_limits(1) if threadpool_limits is not None else contextlib.nullcontext():
        yield


def ellipsoid(k=2, axes=(1.0, 0.7, 1.3)):
    V, F = icosphere(k)
    return V * np.asarray(axes), F


def normals_of(V, F):
    return connection(V, F).frames[:, 2]


def tangent(X, N):
    """``X`` less its parts along the unit normals ``N``."""
    return X - np.sum(X * N, axis=1, keepdims=True) * N


def arrows(V, F, idx, seed):
    rng = np.random.default_rng(seed)
    return tangent(rng.standard_normal((len(idx), 3)), normals_of(V, F)[idx])


def turned(X, N, angle):
    """``X`` (tangent) turned by ``angle`` about the normals ``N`` (per row)."""
    angle = np.asarray(angle)[..., None]
    return np.cos(angle) * X + np.sin(angle) * np.cross(N, X)


def sym_distance(A, B, N, symmetry):
    """The largest distance between the ``symmetry``-direction fields of representatives ``A`` and ``B``."""
    d = np.full(len(A), np.inf)
    for k in range(symmetry):
        d = np.minimum(d, np.linalg.norm(A - turned(B, N, 2 * np.pi * k / symmetry), axis=1))
    return d.max()


def power(w, symmetry):
    return np.abs(w) * np.exp(1j * symmetry * np.angle(w))


SPHERE = icosphere(2)
ELLIPSOID = ellipsoid(2)
SMALL = ellipsoid(1)


# ---------------------------------------------------------------------------
# exact, tangent
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("symmetry", [1, 2, 4])
def test_exact_at_vertex_samples_and_tangent(method, symmetry):
    V, F = ELLIPSOID
    rng = np.random.default_rng(0)
    idx = rng.choice(len(V), 10, replace=False)
    N = normals_of(V, F)
    T = arrows(V, F, idx, 1)
    X = T + 0.05 * np.linalg.norm(T, axis=1, keepdims=True) * N[idx]  # 5% normal: under the limit
    r = reconstruct_vectors(V, F, idx, X, method=method, symmetry=symmetry, bounds=False)
    assert sym_distance(r.values[idx], T, N[idx], symmetry) <= 1e-10
    np.testing.assert_allclose(r.normals, N, atol=1e-14)
    mag = np.linalg.norm(r.values, axis=1)
    assert np.all(np.abs(np.sum(r.values * N, axis=1)) <= 1e-12 * np.maximum(mag, 1e-300))
    P = V[F]
    fn = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
    fmag = np.linalg.norm(r.faces, axis=1)
    assert np.all(np.abs(np.sum(r.faces * fn, axis=1)) <= 1e-12 * np.maximum(fmag, 1e-300))


def _face_points(V, F, faces, seed):
    rng = np.random.default_rng(seed)
    bary = 0.15 + 0.55 * rng.dirichlet(np.ones(3), len(faces))
    bary /= bary.sum(axis=1, keepdims=True)
    return bary, np.einsum("kj,kjc->kc", bary, V[F[faces]])


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("symmetry", [1, 2, 4])
def test_exact_at_points_inside_faces(method, symmetry):
    """A sample inside face ``f`` at barycentric ``b`` fixes ``sum_k b_k t_k z_{F[f, k]}`` (``t_k`` the corner's
    transport into the face) to the sample's tangent part in the face's plane, in the face's frame."""
    V, F = ELLIPSOID
    rng = np.random.default_rng(2)
    faces = rng.choice(len(F), 6, replace=False)
    bary, P = _face_points(V, F, faces, 3)
    verts = rng.choice(np.setdiff1d(np.arange(len(V)), F[faces].ravel()), 4, replace=False)
    pos = np.vstack([P, V[verts]])
    conn = connection(V, F)
    fn = conn.face_frames[faces, 2]
    X = rng.standard_normal((10, 3))
    X[:6] = tangent(X[:6], fn)
    X[6:] = tangent(X[6:], conn.frames[verts, 2])
    X[:6] += 0.03 * np.linalg.norm(X[:6], axis=1, keepdims=True) * fn  # a small normal part, dropped
    fill = VectorFill(V, F, pos, method=method, symmetry=symmetry)
    assert fill.k == 10 and len(fill.face_samples) == 6
    np.testing.assert_array_equal(fill.faces, faces)
    np.testing.assert_allclose(fill.bary, bary, atol=1e-12)
    Z, report = fill.solve(X)
    assert report["inside_faces"] == 6
    # at the points inside faces: in the face frames, in the power representation
    got = conn.face_rows(faces, bary, symmetry) @ Z
    T = tangent(X[:6], fn)
    e1, e2 = conn.face_frames[faces, 0], conn.face_frames[faces, 1]
    want = power(np.sum(T * e1, axis=1) + 1j * np.sum(T * e2, axis=1), symmetry)
    np.testing.assert_allclose(got, want, atol=1e-10)
    # at the vertices
    np.testing.assert_allclose(Z[verts], power(conn.to_complex(X[6:], at=verts), symmetry), atol=1e-10)


@pytest.mark.parametrize("method", METHODS)
def test_points_inside_faces_on_a_flat_grid(method):
    """On a flat mesh the connection is trivial (the boundary's angles are not rescaled), so the vector at a point
    inside a face is the barycentric mean of its corners' vectors in space: it equals the arrow there."""
    V, F = grid(9)
    rng = np.random.default_rng(4)
    faces = rng.choice(len(F), 5, replace=False)
    bary, P = _face_points(V, F, faces, 5)
    X = np.column_stack([rng.standard_normal((5, 2)), np.zeros(5)])
    r = reconstruct_vectors(V, F, P, X, method=method, bounds=False)
    at_point = np.einsum("kj,kjc->kc", bary, r.values[F[faces]])
    np.testing.assert_allclose(at_point, X, atol=1e-10)
    np.testing.assert_array_equal(r.idx, -1)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("positions", [False, True])
def test_constant_arrows_on_a_flat_grid_give_the_constant(method, positions):
    """A constant field in space is parallel on a flat mesh (zero energy): arrows all equal to it, at vertices or
    inside faces, give it everywhere, exactly."""
    V, F = grid(9, 7, size=(1.0, 0.7))
    rng = np.random.default_rng(6)
    c = np.array([0.4, -1.1, 0.0])
    if positions:
        idx = _face_points(V, F, rng.choice(len(F), 4, replace=False), 7)[1]
    else:
        idx = rng.choice(len(V), 4, replace=False)
    r = reconstruct_vectors(V, F, idx, np.tile(c, (4, 1)), method=method)
    np.testing.assert_allclose(r.values, np.tile(c, (len(V), 1)), atol=1e-10)
    np.testing.assert_allclose(r.faces, np.tile(c, (len(F), 1)), atol=1e-10)
    assert not r.singularities[0]["faces"].size


# ---------------------------------------------------------------------------
# the dense reference
# ---------------------------------------------------------------------------


def dense_energy(V, F, method, symmetry):
    """The energy's Hermitian matrix from scratch: ``D`` the edge differences ``(D z)_e = z_j - r_e^s z_i``,
    ``E1 = (Dz)^H diag(w) (Dz) = z^H H1 z``; ``E2 = z^H H1 M^-1 H1 z``."""
    conn = connection(V, F)
    n = len(V)
    i, j = conn.edges.T
    r = np.exp(1j * symmetry * conn.transport)
    D = np.zeros((len(i), n), dtype=complex)
    D[np.arange(len(i)), j] = 1.0
    D[np.arange(len(i)), i] = -r
    H = D.conj().T @ (conn.weights[:, None] * D)
    rng = np.random.default_rng(0)
    z = rng.standard_normal(n) + 1j * rng.standard_normal(n)  # the matrix is the edge sum's
    assert np.vdot(z, H @ z).real == pytest.approx(np.sum(conn.weights * np.abs(z[j] - r * z[i]) ** 2), rel=1e-12)
    if method == "biharmonic":
        H = H @ np.diag(1.0 / mass_matrix(V, F).diagonal()) @ H
    return H


def dense_reference(V, F, idx, W, method, symmetry, smoothing=None):
    """The minimiser of :func:`dense_energy` with ``z_idx = W`` fixed (or the misfit ``|z_idx - W|^2`` beside
    ``smoothing`` times the energy: ``(S^H S + lambda H) z = S^H W``)."""
    n = len(V)
    H = dense_energy(V, F, method, symmetry)
    if smoothing is not None:
        S = np.zeros((len(idx), n))
        S[np.arange(len(idx)), idx] = 1.0
        return np.linalg.solve(S.T @ S + smoothing * H, S.T @ W)
    free = np.setdiff1d(np.arange(n), idx)
    out = np.zeros(n, dtype=complex)
    out[idx] = W
    out[free] = np.linalg.solve(H[np.ix_(free, free)], -H[np.ix_(free, idx)] @ W)
    return out


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("symmetry", [1, 2, 4])
def test_equals_dense_reference(method, symmetry):
    V, F = SPHERE
    rng = np.random.default_rng(5)
    idx = rng.choice(len(V), 9, replace=False)
    X = arrows(V, F, idx, 6)
    conn = connection(V, F)
    ref = dense_reference(V, F, idx, power(conn.to_complex(X, at=idx), symmetry), method, symmetry)
    Z, _ = VectorFill(V, F, idx, method=method, symmetry=symmetry).solve(X)
    assert np.abs(Z - ref).max() <= 1e-9 * np.abs(ref).max()
    if symmetry == 2:  # reconstruct_vectors may orient line samples instead: the next test
        return
    # and in space: one of the s roots of the reference
    r = reconstruct_vectors(V, F, idx, X, method=method, symmetry=symmetry, bounds=False)
    root = np.abs(ref) * np.exp(1j * np.angle(ref) / symmetry)
    assert sym_distance(r.values, conn.to_space(root), conn.frames[:, 2], symmetry) <= 1e-9 * np.abs(ref).max()


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("field", ["random", "rotation"])
def test_line_fields_power_fill_or_least_energy_signs(method, field):
    """``reconstruct_vectors(symmetry=2)`` fills either the power representation (the dense reference) or, when it
    says it oriented the samples, the arrows with the signs of least fill energy: the best of all ``2^(k-1)`` sign
    choices by brute force, the energy of a choice being ``(s w)^H K (s w)`` with ``K`` the dense energy's Schur
    complement on the samples; its line field is compared. Either way the samples' lines are met exactly."""
    V, F = SPHERE
    rng = np.random.default_rng(34)
    idx = rng.choice(len(V), 9, replace=False)
    N = normals_of(V, F)
    X = arrows(V, F, idx, 35) if field == "random" else np.cross(N[idx], [0.0, 0.0, 1.0])
    X = X * rng.choice([-1.0, 1.0], (len(idx), 1))  # the signs are unknown
    conn = connection(V, F)
    r = reconstruct_vectors(V, F, idx, X, method=method, symmetry=2, bounds=False)
    assert sym_distance(r.values[idx], X, N[idx], 2) <= 1e-10
    lines = r.report.get("lines", {"oriented": False})
    if not lines["oriented"]:
        ref = dense_reference(V, F, idx, power(conn.to_complex(X, at=idx), 2), method, 2)
        want = conn.to_space(np.abs(ref) * np.exp(1j * np.angle(ref) / 2))
        assert sym_distance(r.values, want, N, 2) <= 1e-9 * np.abs(ref).max()
        return
    H = dense_energy(V, F, method, 1)
    free = np.setdiff1d(np.arange(len(V)), idx)
    K = H[np.ix_(idx, idx)] - H[np.ix_(idx, free)] @ np.linalg.solve(H[np.ix_(free, free)], H[np.ix_(free, idx)])
    w = conn.to_complex(X, at=idx)

    def energy(s):
        return np.vdot(s * w, K @ (s * w)).real

    every = np.array([[1.0] + [1.0 - 2.0 * ((m >> b) & 1) for b in range(len(idx) - 1)]
                      for m in range(2 ** (len(idx) - 1))])
    best = every[np.argmin([energy(s) for s in every])]
    ref = dense_reference(V, F, idx, best * w, method, 1)
    assert sym_distance(r.values, conn.to_space(ref), N, 2) <= 1e-9 * np.abs(ref).max()


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("symmetry", [1, 2])
def test_equals_dense_reference_with_points_inside_faces(method, symmetry):
    """Points inside faces are linear rows ``R z = w`` (``R`` from :meth:`Connection.face_rows`): the minimiser of
    the energy built from scratch under them and the fixed vertices, by the dense complex KKT system
    ``[[H, C^H], [C, 0]] [z, mu] = [0, b]``."""
    V, F = SPHERE
    rng = np.random.default_rng(31)
    conn = connection(V, F)
    faces = rng.choice(len(F), 4, replace=False)
    bary, P = _face_points(V, F, faces, 32)
    verts = rng.choice(np.setdiff1d(np.arange(len(V)), F[faces].ravel()), 5, replace=False)
    fn, fr = conn.face_frames[faces, 2], conn.face_frames[faces]
    T = tangent(rng.standard_normal((4, 3)), fn)
    X = np.vstack([T, arrows(V, F, verts, 33)])
    wf = power(np.sum(T * fr[:, 0], axis=1) + 1j * np.sum(T * fr[:, 1], axis=1), symmetry)
    wv = power(conn.to_complex(X[4:], at=verts), symmetry)
    n = len(V)
    H = dense_energy(V, F, method, symmetry)
    C = np.zeros((9, n), dtype=complex)
    C[:4] = conn.face_rows(faces, bary, symmetry).toarray()
    C[np.arange(4, 9), verts] = 1.0
    K = np.block([[H, C.conj().T], [C, np.zeros((9, 9))]])
    ref = np.linalg.solve(K, np.concatenate([np.zeros(n), wf, wv]))[:n]
    Z, report = VectorFill(V, F, np.vstack([P, V[verts]]), method=method, symmetry=symmetry).solve(X)
    assert report["inside_faces"] == 4
    assert np.abs(Z - ref).max() <= 1e-9 * np.abs(ref).max()


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("smoothing", [1e-3, 0.3])
def test_smoothing_equals_dense_reference(method, smoothing):
    """``min |z_idx - w|^2 + lambda E(z)``: ``(S^H S + lambda H) z = S^H w``."""
    V, F = SPHERE
    rng = np.random.default_rng(8)
    idx = rng.choice(len(V), 12, replace=False)
    X = arrows(V, F, idx, 9)
    conn = connection(V, F)
    ref = dense_reference(V, F, idx, conn.to_complex(X, at=idx), method, 1, smoothing)
    Z, report = VectorFill(V, F, idx, method=method, smoothing=smoothing).solve(X)
    assert np.abs(Z - ref).max() <= 1e-9 * np.abs(ref).max()
    assert report["smoothing"]["lambda"] == smoothing


# ---------------------------------------------------------------------------
# invariances (hypothesis)
# ---------------------------------------------------------------------------


@HYP
@given(seed=st.integers(0, 2**31 - 1), method=st.sampled_from(METHODS), symmetry=st.sampled_from([1, 2, 4]))
def test_rotation_equivariance(seed, method, symmetry):
    V, F = SMALL
    rng = np.random.default_rng(seed)
    Q = Rotation.random(random_state=seed).as_matrix()
    idx = rng.choice(len(V), 6, replace=False)
    X = arrows(V, F, idx, seed)
    r1 = reconstruct_vectors(V, F, idx, X, method=method, symmetry=symmetry)
    r2 = reconstruct_vectors(V @ Q.T, F, idx, X @ Q.T, method=method, symmetry=symmetry)
    scale = np.abs(r1.values).max()
    assert sym_distance(r2.values, r1.values @ Q.T, r2.normals, symmetry) <= 1e-9 * scale
    np.testing.assert_allclose(r2.normals, r1.normals @ Q.T, atol=1e-12)
    s1, s2 = r1.singularities[0], r2.singularities[0]
    np.testing.assert_array_equal(s2["faces"], s1["faces"])
    np.testing.assert_array_equal(s2["index"], s1["index"])


@HYP
@given(seed=st.integers(0, 2**31 - 1), method=st.sampled_from(METHODS), symmetry=st.sampled_from([1, 2, 4]),
       positions=st.booleans())
def test_relabelling_invariance(seed, method, symmetry, positions):
    """Renumbered vertices, shuffled faces, corners rotated: the same field in space at every vertex and face,
    with vertex samples or with positions (inside faces and at vertices)."""
    V, F = SMALL
    rng = np.random.default_rng(seed)
    perm = rng.permutation(len(V))
    V2, F2, inv = relabel(V, F, perm, rng)
    if positions:
        faces = rng.choice(len(F), 4, replace=False)
        verts = rng.choice(np.setdiff1d(np.arange(len(V)), F[faces].ravel()), 2, replace=False)
        bary, P = _face_points(V, F, faces, seed)
        fn = connection(V, F).face_frames[faces, 2]
        X = np.vstack([tangent(rng.standard_normal((4, 3)), fn), arrows(V, F, verts, seed)])
        idx1 = idx2 = np.vstack([P, V[verts]])
    else:
        idx1 = rng.choice(len(V), 6, replace=False)
        idx2 = inv[idx1]
        X = arrows(V, F, idx1, seed)
    r1 = reconstruct_vectors(V, F, idx1, X, method=method, symmetry=symmetry)
    r2 = reconstruct_vectors(V2, F2, idx2, X, method=method, symmetry=symmetry)
    scale = np.abs(r1.values).max()
    assert sym_distance(r2.values, r1.values[perm], r2.normals, symmetry) <= 1e-10 * scale
    key = {tuple(sorted(inv[f])): k for k, f in enumerate(F)}
    match = np.array([key[tuple(sorted(f))] for f in F2])
    P = V2[F2]
    fn = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
    assert sym_distance(r2.faces, r1.faces[match], fn, symmetry) <= 1e-10 * scale
    ind1 = np.zeros(len(F))
    ind1[r1.singularities[0]["faces"]] = r1.singularities[0]["index"]
    ind2 = np.zeros(len(F))
    ind2[r2.singularities[0]["faces"]] = r2.singularities[0]["index"]
    np.testing.assert_array_equal(ind2, ind1[match])


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("s", [1e-3, 250.0])
def test_uniform_scaling_and_translation_invariance(method, s):
    V, F = ELLIPSOID
    rng = np.random.default_rng(10)
    idx = rng.choice(len(V), 8, replace=False)
    X = arrows(V, F, idx, 11)
    r1 = reconstruct_vectors(V, F, idx, X, method=method)
    r2 = reconstruct_vectors(s * V + [3.0, -1.0, 2.0], F, idx, X, method=method)
    np.testing.assert_allclose(r2.values, r1.values, atol=1e-9 * np.abs(r1.values).max())
    np.testing.assert_allclose(r2.faces, r1.faces, atol=1e-9 * np.abs(r1.values).max())


@pytest.mark.parametrize("method", METHODS)
def test_linear_in_the_arrows(method):
    V, F = ELLIPSOID
    rng = np.random.default_rng(12)
    idx = rng.choice(len(V), 8, replace=False)
    X, Y = arrows(V, F, idx, 13), arrows(V, F, idx, 14)
    R = VectorReconstructor(V, F, idx, method=method, bounds=False)
    a, b = R.apply(X).values, R.apply(Y).values
    scale = np.abs(a).max()
    np.testing.assert_allclose(R.apply(-2.5 * X).values, -2.5 * a, atol=1e-12 * scale)
    np.testing.assert_allclose(R.apply(X + 3.0 * Y).values, a + 3.0 * b, atol=1e-12 * scale)
    both = R.apply(np.stack([X, Y], axis=2))
    assert both.values.shape == (len(V), 3, 2)
    np.testing.assert_allclose(both.values[..., 0], a, atol=1e-12 * scale)
    np.testing.assert_allclose(both.values[..., 1], b, atol=1e-12 * scale)
    np.testing.assert_allclose(both.faces[..., 1], R.apply(Y).faces, atol=1e-12 * scale)
    assert len(both.singularities) == 2
    # one reconstructor, or reconstruct_vectors each time: the same
    np.testing.assert_allclose(reconstruct_vectors(V, F, idx, Y, method=method, bounds=False).values, b,
                               atol=1e-12 * scale)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("symmetry", [2, 4])
def test_line_and_cross_fields_ignore_the_representative(method, symmetry):
    """A symmetry-2 sample is a line: flipping the sign of some arrows gives the same line field (symmetry 4: any
    quarter turns give the same cross field); compared modulo ``2 pi / symmetry``."""
    V, F = ELLIPSOID
    rng = np.random.default_rng(15)
    idx = rng.choice(len(V), 10, replace=False)
    X = arrows(V, F, idx, 16)
    N = normals_of(V, F)
    Y = turned(X, N[idx], 2 * np.pi / symmetry * rng.integers(0, symmetry, len(idx)))
    assert np.abs(Y - X).max() > 0.1
    r1 = reconstruct_vectors(V, F, idx, X, method=method, symmetry=symmetry)
    r2 = reconstruct_vectors(V, F, idx, Y, method=method, symmetry=symmetry)
    assert sym_distance(r2.values, r1.values, N, symmetry) <= 1e-9 * np.abs(r1.values).max()
    np.testing.assert_allclose(r2.magnitude, r1.magnitude, atol=1e-9 * np.abs(r1.values).max())
    # while an arrow field does see the flips
    a1 = reconstruct_vectors(V, F, idx, X, method=method)
    a2 = reconstruct_vectors(V, F, idx, Y, method=method)
    assert sym_distance(a2.values, a1.values, N, symmetry) > 0.1


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("seed", [0, 1])
def test_lines_of_a_smooth_field_with_lost_signs_give_its_fill_back(method, seed):
    """The lines of a smooth arrow field on a sphere (a rotation about z plus a gradient), signs lost: the line fill
    orients them back, and its lines are those of the arrow fill of the correctly signed arrows."""
    V, F = SPHERE
    rng = np.random.default_rng(seed)
    idx = rng.choice(len(V), 12, replace=False)
    N = normals_of(V, F)[idx]
    X = np.cross(N, [0.0, 0.0, 1.0]) + 0.3 * np.cross(N, np.cross(N, [1.0, 0.0, 0.0]))
    lines = reconstruct_vectors(V, F, idx, X * rng.choice([-1.0, 1.0], (12, 1)), method=method, symmetry=2)
    signed = reconstruct_vectors(V, F, idx, X, method=method)
    assert lines.report["lines"]["oriented"]
    assert sym_distance(lines.values, signed.values, normals_of(V, F), 2) <= 1e-10 * np.abs(signed.values).max()


# ---------------------------------------------------------------------------
# singularities of reconstructed fields
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("mesh, chi", [
    pytest.param(lambda: icosphere(2), 2, id="sphere"),
    pytest.param(lambda: ellipsoid(2), 2, id="ellipsoid"),
    pytest.param(lambda: torus(10, 20), 0, id="torus"),
])
@pytest.mark.parametrize("symmetry", [1, 2, 4])
def test_reconstructed_indices_sum_to_euler_characteristic(mesh, chi, symmetry):
    V, F = mesh()
    rng = np.random.default_rng(17)
    idx = rng.choice(len(V), 15, replace=False)
    X = np.stack([arrows(V, F, idx, 18), arrows(V, F, idx, 19)], axis=2)
    r = reconstruct_vectors(V, F, idx, X, symmetry=symmetry, method="harmonic")
    for s in r.singularities:
        np.testing.assert_array_equal(s["index"] * symmetry, np.rint(s["index"] * symmetry))
        assert np.all(s["index"] != 0)
        assert s["index"].sum() == pytest.approx(chi, abs=1e-9)
        np.testing.assert_allclose(s["positions"], V[F[s["faces"]]].mean(axis=1))
    if chi:
        assert all(s["faces"].size > 0 for s in r.singularities)


def test_rotation_arrows_fill_to_a_rotation_like_field():
    """Arrows of the rotation about z at a dozen vertices: the fill has the rotation's two +1 singularities, one
    near each pole."""
    V, F = icosphere(3)
    rng = np.random.default_rng(20)
    idx = rng.choice(len(V), 12, replace=False)
    N = normals_of(V, F)
    for method in METHODS:
        r = reconstruct_vectors(V, F, idx, np.cross(N[idx], [0.0, 0.0, 1.0]), method=method)
        s = r.singularities[0]
        np.testing.assert_array_equal(s["index"], [1.0, 1.0])
        z = np.sort(s["positions"][:, 2])
        assert z[0] < -0.9 and z[1] > 0.9


# ---------------------------------------------------------------------------
# bounds, smoothing, barriers
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("symmetry", [1, 2])
def test_bounds_scale_down_only_what_exceeds(symmetry):
    V, F = SPHERE
    rng = np.random.default_rng(5)  # a draw whose biharmonic fill overshoots the samples' largest magnitude
    idx = rng.choice(len(V), 12, replace=False)
    X = tangent(rng.standard_normal((12, 3)), normals_of(V, F)[idx])
    top = np.linalg.norm(X, axis=1).max()
    free = reconstruct_vectors(V, F, idx, X, symmetry=symmetry, bounds=False)
    bound = reconstruct_vectors(V, F, idx, X, symmetry=symmetry)
    m0 = np.linalg.norm(free.values, axis=1)
    over = m0 > top
    assert over.sum() >= 1
    assert bound.magnitude.max() <= top * (1 + 1e-12)
    assert np.linalg.norm(bound.faces, axis=1).max() <= top * (1 + 1e-12)
    np.testing.assert_array_equal(bound.values[~over], free.values[~over])  # untouched
    # those above: the same direction, the bound's length
    np.testing.assert_allclose(bound.values[over], free.values[over] * (top / m0[over])[:, None], rtol=1e-12)
    assert bound.report["bounds"]["vertices_scaled"] == over.sum()
    assert bound.report["bounds"]["magnitude"] == pytest.approx(top, rel=1e-15)
    # a number: that magnitude
    low = reconstruct_vectors(V, F, idx, X, symmetry=symmetry, bounds=0.5)
    assert low.magnitude.max() <= 0.5 * (1 + 1e-12)
    np.testing.assert_array_equal(low.values[m0 <= 0.5], free.values[m0 <= 0.5])


def test_bounds_use_the_tangent_parts_of_the_arrows():
    """With ``normal='drop'`` the fill meets the arrows' tangent parts; the bound is theirs too (the dropped
    normal parts are no magnitude of the field)."""
    V, F = SPHERE
    rng = np.random.default_rng(5)
    idx = rng.choice(len(V), 12, replace=False)
    N = normals_of(V, F)
    T = tangent(rng.standard_normal((12, 3)), N[idx])
    top = np.linalg.norm(T, axis=1).max()
    r = reconstruct_vectors(V, F, idx, T + 2.0 * N[idx], normal="drop")
    np.testing.assert_allclose(r.values[idx], T, atol=1e-10)
    assert r.magnitude.max() <= top * (1 + 1e-12)


@pytest.mark.parametrize("method", METHODS)
def test_smoothing(method):
    V, F = SPHERE
    rng = np.random.default_rng(21)
    idx = rng.choice(len(V), 12, replace=False)
    X = arrows(V, F, idx, 22)
    conn = connection(V, F)
    L = conn.laplacian().toarray()
    A = L if method == "harmonic" else L @ np.diag(1.0 / mass_matrix(V, F).diagonal()) @ L
    exact = reconstruct_vectors(V, F, idx, X, method=method, bounds=False)
    zero = reconstruct_vectors(V, F, idx, X, method=method, bounds=False, smoothing=0.0)
    np.testing.assert_allclose(zero.values, exact.values, atol=1e-9 * np.abs(exact.values).max())
    energy, misfit = [], []
    for lam in (0.0, 1e-4, 1e-2, 1.0, 100.0):
        r = reconstruct_vectors(V, F, idx, X, method=method, bounds=False, smoothing=lam)
        Z = conn.to_complex(r.values)
        energy.append(np.vdot(Z, A @ Z).real)
        misfit.append(np.sum((r.values[idx] - X) ** 2))
    assert np.all(np.diff(energy) < 0)
    assert np.all(np.diff(misfit) > 0)
    assert energy[-1] < 1e-3 * energy[0]


def test_barrier_loop_makes_the_sides_independent():
    """A barrier around the equator: changing the southern arrows leaves the northern field as it was, exactly
    (and the other way round); the field stays tangent, split vertices included."""
    V, F = icosphere(3)
    t = np.linspace(0.0, 2 * np.pi, 25)
    loop = np.column_stack([np.cos(t), np.sin(t), np.zeros_like(t)])  # snapped to the nearest vertices
    rng = np.random.default_rng(23)
    north = rng.choice(np.flatnonzero(V[:, 2] > 0.3), 5, replace=False)
    south = rng.choice(np.flatnonzero(V[:, 2] < -0.3), 5, replace=False)
    idx = np.concatenate([north, south])
    X = arrows(V, F, idx, 24)
    R = VectorReconstructor(V, F, idx, barriers=[loop], bounds=False)
    assert R.apply(X).report["barriers"]["pieces"] == 2
    base = R.apply(X).values
    Y = X.copy()
    Y[5:] = arrows(V, F, south, 25)
    changed = R.apply(Y).values
    d = np.linalg.norm(changed - base, axis=1)
    assert d[V[:, 2] > 0.1].max() == 0.0
    assert d[V[:, 2] < -0.1].min() > 0.0
    Y = X.copy()
    Y[:5] = arrows(V, F, north, 26)
    d = np.linalg.norm(R.apply(Y).values - base, axis=1)
    assert d[V[:, 2] < -0.1].max() == 0.0
    N = normals_of(V, F)
    assert np.abs(np.sum(base * N, axis=1)).max() <= 1e-12 * np.abs(base).max()
    # without the barrier the south sees the north
    free = VectorReconstructor(V, F, idx, bounds=False)
    d = np.linalg.norm(free.apply(Y).values - free.apply(X).values, axis=1)
    assert d[V[:, 2] < -0.1].max() > 1e-3


@pytest.mark.parametrize("options, positions", [
    pytest.param({}, False, id="exact"),
    pytest.param({"method": "harmonic", "symmetry": 2}, False, id="harmonic-lines"),
    pytest.param({}, True, id="inside-faces"),
    pytest.param({"smoothing": 0.1}, False, id="smoothing"),
    pytest.param({"solver": "iterate"}, False, id="iterate"),
])
def test_barrier_piece_without_samples_is_named(options, positions):
    """Samples on one side only: the other side has no arrow to fill from. Whatever the path of the solve, the
    refusal is a SampleError that says a piece has no sample, counts its vertices (the mesh's, not the real
    form's two unknowns per vertex) and advises nothing the vector methods do not take."""
    V, F = icosphere(3)
    t = np.linspace(0.0, 2 * np.pi, 25)
    loop = np.column_stack([np.cos(t), np.sin(t), np.zeros_like(t)])
    rng = np.random.default_rng(27)
    if positions:
        faces = rng.choice(np.flatnonzero(V[F].mean(axis=1)[:, 2] > 0.3), 5, replace=False)
        idx = V[F[faces]].mean(axis=1)
        X = tangent(rng.standard_normal((5, 3)), connection(V, F).face_frames[faces, 2])
    else:
        idx = rng.choice(np.flatnonzero(V[:, 2] > 0.3), 5, replace=False)
        X = arrows(V, F, idx, 28)
    with pytest.raises(SampleError, match="piece") as err:
        reconstruct_vectors(V, F, idx, X, barriers=[loop], **options)
    msg = str(err.value)
    assert "on_empty" not in msg
    south = int(np.sum(V[:, 2] < 0))
    counts = [int(c.replace(",", "")) for c in re.findall(r"(\d[\d,]*) vertices", msg)]
    assert counts and all(c < len(V) for c in counts) and any(abs(c - south) < 0.2 * south for c in counts)


# ---------------------------------------------------------------------------
# errors
# ---------------------------------------------------------------------------


def test_normal_part_refused_naming_the_sample_and_dropped_on_request():
    V, F = SPHERE
    idx = np.array([3, 50, 77, 120, 140])
    N = normals_of(V, F)
    T = arrows(V, F, idx, 29)
    X = T + 0.09 * np.linalg.norm(T, axis=1, keepdims=True) * N[idx]  # under 10%: taken
    reconstruct_vectors(V, F, idx, X)
    X[3] = T[3] + 0.2 * np.linalg.norm(T[3]) * N[idx[3]]
    with pytest.raises(SampleError, match=r"sample 3\b") as err:
        reconstruct_vectors(V, F, idx, X)
    msg = str(err.value)
    assert "\n" not in msg and "normal" in msg and "normal='drop'" in msg
    r = reconstruct_vectors(V, F, idx, X, normal="drop", bounds=False)
    np.testing.assert_allclose(r.values[idx], T, atol=1e-10)
    np.testing.assert_allclose(r.values, reconstruct_vectors(V, F, idx, T, bounds=False).values, atol=1e-12)


def test_bad_input_refused():
    V, F = SPHERE
    idx = np.array([3, 50, 77])
    X = arrows(V, F, idx, 30)
    for bad in (X[:, :2], X[:2], X[None], np.zeros((3, 3, 2, 1))):
        with pytest.raises(SampleError, match="shape"):
            reconstruct_vectors(V, F, idx, bad)
    with pytest.raises(SampleError, match="NaN"):
        reconstruct_vectors(V, F, idx, np.where(np.arange(3)[:, None] == 1, np.nan, X))
    with pytest.raises(OptionError, match="symmetry"):
        reconstruct_vectors(V, F, idx, X, symmetry=3)
    with pytest.raises(OptionError, match="rbf"):
        reconstruct_vectors(V, F, idx, X, method="rbf")
    # F=None is a point cloud: the fill only (no barriers, no fits)
    with pytest.raises(OptionError, match="point cloud"):
        reconstruct_vectors(V, None, idx, X, barriers=[[0, 1]])
    with pytest.raises(OptionError, match="point cloud"):
        reconstruct_vectors(V, None, idx, X, fit="curl-free")
    with pytest.raises(OptionError, match="normal"):
        reconstruct_vectors(V, F, idx, X, normal="keep")
    with pytest.raises(SampleError, match="vertex 3 more than once"):
        reconstruct_vectors(V, F, [3, 50, 3], X)
    with pytest.raises(SampleError, match="one vertex"):  # two positions at one vertex
        reconstruct_vectors(V, F, V[[3, 50, 3]] * (1 + 1e-9), X)
    with pytest.raises(ManifillError):
        reconstruct_vectors(V, F, [3, 50, len(V)], X)
    for bad in ({"method": "harmonic", "symmetry": 0}, {"bounds": -1.0}, {"smoothing": -1.0}):
        with pytest.raises(OptionError):
            reconstruct_vectors(V, F, idx, X, **bad)


def test_bounds_hold_per_field():
    # each field is kept within its own samples' largest magnitude: two fields at once equal two runs
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(3)
    idx = np.random.default_rng(0).choice(len(V), 40, replace=False)
    U = np.cross(V[idx], [0.0, 0.0, 1.0])
    both = reconstruct_vectors(V, F, idx, np.stack([U, 10 * U], axis=2), normal="drop")
    for j, scale in enumerate((1, 10)):
        alone = reconstruct_vectors(V, F, idx, scale * U, normal="drop")
        assert np.allclose(both.values[..., j], alone.values, atol=1e-12 * scale)
        assert both.magnitude[:, j].max() <= scale * (1 + 1e-12)
