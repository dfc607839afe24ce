"""``method='hessian'`` and ``'hessian-curved'``: libigl's energies, linear precision with a boundary, invariances."""

import numpy as np
import pytest
import scipy.sparse as sp

import manifill
from conftest import icosphere
from manifill import OptionError
from manifill.linalg.quadratic import QuadraticSolver
from manifill.mesh.hessian import hessian_energy
from manifill.mesh.shapes import grid

igl = pytest.importorskip("igl")


def cap(level=3, z=-0.2):
    """A sphere cut at ``z``: an open surface with one boundary loop."""
    V, F = icosphere(level)
    F = F[(V[F][:, :, 2] > z).all(axis=1)]
    used = np.unique(F)
    new = np.full(len(V), -1)
    new[used] = np.arange(used.size)
    return V[used], new[F]


def jittered(n=20, seed=0):
    V, F = grid(n)
    V = V.copy()
    inner = (V[:, 0] > 0) & (V[:, 0] < 1) & (V[:, 1] > 0) & (V[:, 1] < 1)
    V[inner, :2] += np.random.default_rng(seed).uniform(-0.3, 0.3, (inner.sum(), 2)) / n
    return V, F


def _igl(f, V, F):
    return sp.csr_array(f(np.ascontiguousarray(V, dtype=np.float64), np.ascontiguousarray(F, dtype=np.int64)))


@pytest.mark.parametrize("mesh", [cap, lambda: icosphere(2), lambda: grid(8)])
def test_energy_is_libigls(mesh):
    """Equal to libigl's, but for a rank-one anchor per vertex that has no Hessian (a grid's corner)."""
    V, F = mesh()
    Q, R = hessian_energy(V, F), _igl(igl.hessian_energy, V, F)
    loose = int((R.diagonal() <= 1e-12 * R.diagonal().max()).sum())
    D = (Q - R).toarray()
    s = np.linalg.svd(D, compute_uv=False)
    assert (s[loose:] <= 1e-12 * abs(R).max()).all()
    assert np.abs(D @ np.column_stack([np.ones(len(V)), V])).max() <= 1e-9 * abs(R).max() or V[:, 2].any()
    assert loose == (2 if len(V) == 64 else 0)


@pytest.mark.parametrize("method,ref", [("hessian", "hessian_energy"), ("hessian-curved", "curved_hessian_energy")])
def test_minimiser_equals_libigls(method, ref):
    V, F = cap()
    idx = np.sort(np.random.default_rng(0).choice(len(V), 40, replace=False))
    vals = np.sin(3 * V[idx, 0]) + V[idx, 1] * V[idx, 2]
    x = QuadraticSolver(_igl(getattr(igl, ref), V, F), idx, solver="direct").solve(vals)
    for solver in ("direct", "amg"):
        r = manifill.reconstruct(V, F, idx, vals, method=method, solver=solver, check=False)
        assert np.abs(r.values - x).max() <= 1e-8 * np.ptp(vals), solver


@pytest.mark.parametrize("method", ["hessian", "hessian-curved"])
@pytest.mark.parametrize("solver", ["direct", "amg", "auto"])
def test_linear_fields_on_a_jittered_grid(method, solver):
    """Exact on linear fields, boundary or not, from scattered samples (the biharmonic is not: checked too)."""
    V, F = jittered()
    rng = np.random.default_rng(1)
    idx = np.sort(rng.choice(len(V), 30, replace=False))
    lin = 2 * V[:, 0] - 3 * V[:, 1] + 1
    r = manifill.reconstruct(V, F, idx, lin[idx], method=method, solver=solver, check=False)
    assert np.abs(r.values - lin).max() <= 1e-8
    b = manifill.reconstruct(V, F, idx, lin[idx], method="biharmonic", check=False)
    assert np.abs(b.values - lin).max() > 1e-3


def test_linear_fields_from_points_inside_faces():
    V, F = jittered()
    P = np.column_stack([np.random.default_rng(2).uniform(0.05, 0.95, (25, 2)), np.zeros(25)])
    r = manifill.reconstruct(V, F, P, 1 - P[:, 0] + 4 * P[:, 1], method="hessian", check=False)
    assert np.abs(r.values - (1 - V[:, 0] + 4 * V[:, 1])).max() <= 1e-8


def test_corner_vertices_are_determined():
    """The alternating grid's corners have no Hessian: the anchor extrapolates them, and the system is definite."""
    V, F = grid(6)
    Q = hessian_energy(V, F)
    assert np.linalg.eigvalsh(Q.toarray())[3] > 1e-8  # null space: the three linear functions only
    R = _igl(igl.hessian_energy, V, F)
    assert np.linalg.eigvalsh(R.toarray())[3] < 1e-12  # libigl's leaves a corner free


@pytest.mark.parametrize("method", ["hessian", "hessian-curved"])
def test_invariances(method):
    V, F = cap(level=2)
    rng = np.random.default_rng(3)
    idx = np.sort(rng.choice(len(V), 25, replace=False))
    vals = np.cos(2 * V[idx, 0]) + V[idx, 2]
    base = manifill.reconstruct(V, F, idx, vals, method=method, check=False).values
    Rot, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    for W in (V * 1e-5, V * 3e6, V @ Rot.T + 7.0):
        got = manifill.reconstruct(W, F, idx, vals, method=method, check=False).values
        assert np.abs(got - base).max() <= 1e-8 * np.ptp(vals)
    perm = rng.permutation(len(V))
    inv = np.argsort(perm)
    got = manifill.reconstruct(V[perm], inv[F], inv[idx], vals, method=method, check=False).values
    assert np.abs(got[inv] - base).max() <= 1e-8 * np.ptp(vals)


def test_bounds_and_smoothing():
    V, F = cap()
    idx = np.sort(np.random.default_rng(4).choice(len(V), 40, replace=False))
    vals = np.sign(V[idx, 0])
    for mode in ("exact", "project"):
        r = manifill.reconstruct(V, F, idx, vals, method="hessian", bounds="samples", bounds_mode=mode)
        assert r.values.min() >= -1 - 1e-12 and r.values.max() <= 1 + 1e-12
    s = manifill.reconstruct(V, F, idx, vals, method="hessian", smoothing=1e-3)
    assert 0 < np.abs(s.values[idx] - vals).max() < 1


def test_a_point_cloud_is_refused_in_one_line():
    V, _ = icosphere(2)
    with pytest.raises(OptionError) as e:
        manifill.reconstruct(V, None, np.arange(0, len(V), 8), V[::8, 0], method="hessian")
    assert "needs triangles" in str(e.value) and "\n" not in str(e.value)


def test_closed_sphere_close_to_the_biharmonic():
    """Without a boundary the two energies differ by curvature terms only: their fills agree closely."""
    V, F = icosphere(3)
    idx = np.sort(np.random.default_rng(5).choice(len(V), 60, replace=False))
    f = np.sin(2 * V[:, 0]) + V[:, 1] * V[:, 2]
    h = manifill.reconstruct(V, F, idx, f[idx], method="hessian-curved").values
    b = manifill.reconstruct(V, F, idx, f[idx], method="biharmonic").values
    assert np.sqrt(np.mean((h - b) ** 2)) < 0.05 * np.ptp(f)
