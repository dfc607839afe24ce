"""``method="rbf"``: the thin-plate spline on the positions (manifill.surface.rbf).

Exact at the samples, affine precision (also on flat and tilted flat meshes, and with
samples on one line), invariance under translation and scaling, agreement with a dense
closed-form thin-plate solve written here, the meaning of ``smoothing``, and the mesh's
connectivity ignored (components, digital surfaces).
"""

import math

import numpy as np
import pytest

from manifill import OptionError, SolveError, reconstruct
from manifill.mesh.shapes import grid, icosphere
from manifill.surface.rbf import affine_frame, thin_plate_rbf


def tps_reference(X, Y, Q, lam=0.0, w=None):
    """Dense closed form: [[K + lam W^-1, P], [P', 0]] [c; d] = [Y; 0], evaluated at Q (phi = r^2 log r)."""
    def phi(A, B):
        r = np.sqrt(((A[:, None, :] - B[None, :, :]) ** 2).sum(-1))
        with np.errstate(divide="ignore", invalid="ignore"):
            out = r ** 2 * np.log(r)
        return np.where(r > 0, out, 0.0)

    k, d = X.shape
    w = np.ones(k) if w is None else w
    P = np.hstack([np.ones((k, 1)), X])
    M = np.zeros((k + d + 1, k + d + 1))
    M[:k, :k] = phi(X, X) + np.diag(lam / w)
    M[:k, k:] = P
    M[k:, :k] = P.T
    rhs = np.vstack([Y, np.zeros((d + 1, Y.shape[1]))])
    sol = np.linalg.solve(M, rhs)
    return phi(Q, X) @ sol[:k] + np.hstack([np.ones((len(Q), 1)), Q]) @ sol[k:]


def normalised(V):
    """The frame the module promises: bounding-box centre, power of two just above the largest half-extent."""
    c = (V.min(0) + V.max(0)) / 2
    h = float(((V.max(0) - V.min(0)) / 2).max())
    return c, 2.0 ** (math.floor(math.log2(h)) + 1)


@pytest.fixture
def sphere():
    V, F = icosphere(3)
    idx = np.random.default_rng(0).choice(len(V), 40, replace=False)
    return V, F, np.sort(idx)


def rel(a, b):
    return float(np.abs(a - b).max() / max(np.ptp(b), 1.0))


def test_exact_at_the_samples(sphere):
    V, F, idx = sphere
    f = np.column_stack([np.sin(3 * V[:, 0]) * V[:, 1], np.exp(V[:, 2])])
    r = reconstruct(V, F, idx, f[idx], method="rbf")
    assert r.values.shape == (len(V), 2)
    assert rel(r.values[idx], f[idx]) < 1e-10
    assert r.report["method"] == "rbf" and r.report["rbf"]["dims"] == 3


def test_reproduces_affine_functions(sphere):
    V, F, idx = sphere
    f = 2.0 - V[:, 0] + 3.0 * V[:, 1] + 0.5 * V[:, 2]
    r = reconstruct(V, F, idx, f[idx], method="rbf")
    assert r.values.shape == (len(V),)  # one field given as (k,): squeezed as every method does
    assert rel(r.values, f) < 1e-10


@pytest.mark.parametrize("tilt", [False, True])
def test_affine_precision_on_a_flat_mesh(tilt):
    # a constant coordinate (or a tilted plane) would make the affine part singular in 3-D
    V, F = grid(9)
    if tilt:
        R = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))[0]
        V = V @ R.T + [3.0, -1.0, 2.0]
    idx = np.arange(0, len(V), 7)
    f = 1.0 + 2.0 * V[:, 0] - 3.0 * V[:, 1] + V[:, 2]
    r = reconstruct(V, F, idx, f[idx], method="rbf")
    assert r.report["rbf"]["dims"] == 2
    assert rel(r.values, f) < 1e-10


def test_samples_on_one_line_give_a_field_constant_across_it():
    V, F = grid(6)
    idx = np.arange(6)  # the row y = 0
    r = reconstruct(V, F, idx, 2.0 * V[idx, 0] + 1.0, method="rbf")
    assert r.report["rbf"]["dims"] == 1
    assert rel(r.values, 2.0 * V[:, 0] + 1.0) < 1e-10


def test_translation_and_scale_invariance(sphere):
    V, F, idx = sphere
    f = np.cos(2 * V[:, 0]) + V[:, 1] * V[:, 2]
    base = reconstruct(V, F, idx, f[idx], method="rbf").values
    # a power of two: the normalised positions are the same bits
    assert np.array_equal(reconstruct(V * 2.0**40, F, idx, f[idx], method="rbf").values, base)
    moved = reconstruct(V * 3.7 + [1e3, -20.0, 5.0], F, idx, f[idx], method="rbf").values
    assert rel(moved, base) < 1e-8


def test_agrees_with_a_dense_thin_plate_solve(sphere):
    V, F, idx = sphere
    f = np.column_stack([np.sin(2 * V[:, 0] + V[:, 2]), V[:, 1] ** 3])
    X, _ = thin_plate_rbf(V, V[idx], f[idx])
    # interpolation does not depend on the frame: raw coordinates
    assert rel(X, tps_reference(V[idx], f[idx], V)) < 1e-8


def test_smoothing_is_the_weighted_penalised_fit(sphere):
    V, F, idx = sphere
    f = (np.sin(2 * V[:, 0]) + V[:, 2])[:, None]
    w = np.linspace(0.5, 2.0, idx.size)
    lam = 0.01
    X, rep = thin_plate_rbf(V, V[idx], f[idx], smoothing=lam, sample_weights=w)
    c, s = normalised(V)
    ref = tps_reference((V[idx] - c) / s, f[idx], (V - c) / s, lam=lam, w=w)
    assert rep["smoothing"] == lam and rep["scale"] == s
    assert rel(X, ref) < 1e-8
    assert np.abs(X[idx] - f[idx]).max() > 1e-4  # soft: not through the samples


def test_large_smoothing_gives_the_weighted_affine_least_squares_fit(sphere):
    V, F, idx = sphere
    y = np.sin(3 * V[idx, 0]) + V[idx, 1] ** 2
    w = np.linspace(1.0, 3.0, idx.size)
    X, _ = thin_plate_rbf(V, V[idx], y[:, None], smoothing=1e12, sample_weights=w)
    A = np.hstack([np.ones((idx.size, 1)), V[idx]])
    coef = np.linalg.lstsq(A * np.sqrt(w)[:, None], y * np.sqrt(w), rcond=None)[0]
    assert rel(X[:, 0], np.hstack([np.ones((len(V), 1)), V]) @ coef) < 1e-6


def test_ignores_connectivity_across_components():
    V1, F1 = icosphere(2)
    V = np.vstack([V1, V1 + [3.0, 0.0, 0.0]])
    F = np.vstack([F1, F1 + len(V1)])
    idx = np.arange(0, len(V1), 9)  # samples on the first sphere only
    f = 1.0 + V[:, 0] - V[:, 2]
    r = reconstruct(V, F, idx, f[idx], method="rbf")  # on_empty='error' does not apply: no mesh energy
    assert rel(r.values, f) < 1e-9


def test_on_a_digital_surface():
    from manifill.solid.boundary import digital_surface, digital_surface_graph
    from manifill.surface.reconstruct import reconstruct_surface

    g = np.indices((8, 8, 8)).reshape(3, -1).T
    mask = (((g - 3.5) ** 2).sum(1) < 9).reshape(8, 8, 8)
    _, P, E, normals = digital_surface(mask)
    surface = digital_surface_graph(P, E, normals)
    idx = np.arange(0, len(P), 5)
    f = (P[:, 0] - 2 * P[:, 1] + 0.5 * P[:, 2])[:, None]
    r = reconstruct_surface(surface, idx, f[idx], method="rbf")
    assert r.F is None and rel(r.values, f) < 1e-9


def test_bounds_and_auto_smoothing_are_refused(sphere):
    V, F, idx = sphere
    y = V[idx, 0]
    with pytest.raises(OptionError, match="no mesh energy") as e:
        reconstruct(V, F, idx, y, method="rbf", bounds="samples")
    assert "\n" not in str(e.value)
    with pytest.raises(OptionError, match="number"):
        reconstruct(V, F, idx, y, method="rbf", smoothing="auto")
    with pytest.raises(OptionError, match="smoothing"):
        reconstruct(V, F, idx, y, method="rbf", sample_weights=np.ones(idx.size))
    with pytest.raises(OptionError):
        thin_plate_rbf(V, V[idx], y[:, None], smoothing=-1.0)


def test_coinciding_sample_positions_are_a_solve_error():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.0, 0, 0]])
    with pytest.raises(SolveError, match="singular"):
        thin_plate_rbf(V, V[[0, 1, 2, 4]], np.array([[0.0], [1.0], [2.0], [3.0]]))


def test_the_frame():
    V, _ = grid(4)
    c, s, axes = affine_frame(V * 6.0 + 1.0)
    assert np.allclose(c, [4.0, 4.0, 1.0]) and s == 4.0 and axes.shape == (2, 3)
    assert affine_frame(icosphere(1)[0])[2] is None
