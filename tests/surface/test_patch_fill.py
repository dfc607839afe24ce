"""Steps 5-6 (manifill.surface.fill): the harmonic fill of the patches, its starts, the whole-surface GVF."""

import numpy as np
import pytest

from conftest import edge_set, grid, icosphere, irregular, obtuse, torus, two_components
from manifill import SampleError, SolveError
from manifill.surface.fill import INITS, fill_patches, gvf_fill, start_values
from manifill.surface.gradual import check_gradual
from manifill.surface.harmonic import HarmonicSolver
from manifill.surface.surface import Surface

MESHES = {"icosphere": lambda: icosphere(2), "irregular": irregular, "obtuse": obtuse, "torus": torus}


def fixed_set(n, k, seed, p=None):
    rng = np.random.default_rng(seed)
    b = np.sort(rng.choice(n, size=k, replace=False))
    bc = rng.uniform(-3, 5, size=(k,) if p is None else (k, p))
    return b, bc


@pytest.mark.parametrize("solver", ["direct", "amg", "iterate"])
@pytest.mark.parametrize("weights", ["cotan", "uniform", "intrinsic"])
@pytest.mark.parametrize("mesh", sorted(MESHES))
def test_exact_at_the_fixed_vertices(mesh, weights, solver):
    s = Surface.from_mesh(*MESHES[mesh]())
    b, bc = fixed_set(s.n, 9, seed=len(mesh), p=2)
    x, report = fill_patches(s, b, bc, weights=weights, solver=solver)
    assert x.shape == (s.n, 2)
    assert x[b].tobytes() == bc.tobytes()
    assert report["weights"] == weights and report["fixed"] == 9 and report["solver"] == solver


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("mesh", sorted(MESHES))
def test_harmonic_away_from_the_fixed_vertices(mesh, seed):
    s = Surface.from_mesh(*MESHES[mesh]())
    b, bc = fixed_set(s.n, 7, seed)
    for weights in ("cotan", "uniform"):
        x, _ = fill_patches(s, b, bc, weights=weights)
        free = np.setdiff1d(np.arange(s.n), b)
        r = s.laplacian(weights) @ x
        assert np.abs(r[free]).max() < 1e-9 * np.abs(bc).max()


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("mesh", sorted(MESHES))
def test_maximum_principle_with_uniform_weights(mesh, seed):
    # uniform weights are all positive: every free value is a convex combination of its neighbours
    s = Surface.from_mesh(*MESHES[mesh]())
    b, bc = fixed_set(s.n, 3 + seed, seed)
    x, _ = fill_patches(s, b, bc, weights="uniform")
    eps = 1e-12 * np.abs(bc).max()
    assert x.min() >= bc.min() - eps and x.max() <= bc.max() + eps
    # and strictly inside the range away from the fixed vertices, the range not being a point
    free = np.setdiff1d(np.arange(s.n), b)
    assert (x[free] > bc.min()).all() and (x[free] < bc.max()).all()


@pytest.mark.parametrize("weights", ["cotan", "uniform", "intrinsic", "robust"])
@pytest.mark.parametrize("solver", ["direct", "amg", "iterate"])
def test_equals_harmonic_solver_from_laplacian(solver, weights):
    s = Surface.from_mesh(*icosphere(2))
    b, bc = fixed_set(s.n, 11, seed=5, p=3)
    x, report = fill_patches(s, b, bc, weights=weights, solver=solver, tol=1e-8, maxiter=500)
    hs = HarmonicSolver.from_laplacian(s.laplacian(weights), b, solver=solver, tol=1e-8, maxiter=500,
                                       symmetric_pattern=weights in ("uniform", "cotan"))
    assert x.tobytes() == hs.solve(bc).tobytes()
    assert {k: v for k, v in report.items() if k not in ("seconds", "weights")} == \
        {k: v for k, v in hs.report.items() if k not in ("seconds", "weights")}


def test_x0_is_used_only_by_the_iteration_and_a_callable_only_called_then():
    s = Surface.from_mesh(*irregular())
    b, bc = fixed_set(s.n, 6, seed=2, p=1)
    calls = []

    def x0():
        calls.append(1)
        return np.zeros((s.n, 1))

    x, _ = fill_patches(s, b, bc, solver="direct", x0=x0)
    assert calls == []
    it, report = fill_patches(s, b, bc, solver="iterate", x0=x0, tol=1e-12, maxiter=100000)
    assert calls == [1]
    np.testing.assert_allclose(it, x, atol=1e-8)
    # an array start changes the iteration's path, not its limit
    it2, report2 = fill_patches(s, b, bc, solver="iterate", x0=np.zeros((s.n, 1)), tol=1e-12, maxiter=100000)
    assert it2.tobytes() == it.tobytes()
    with pytest.raises(SampleError, match="x0"):
        fill_patches(s, b, bc, solver="iterate", x0=np.zeros(s.n + 1))


def test_a_patch_without_fixed_vertices():
    s = Surface.from_mesh(*two_components())
    b, bc = np.array([0, 5, 15]), np.array([1.0, 2.0, 3.0])  # all in the 16-vertex component
    with pytest.raises(SolveError, match="no fixed vertex"):
        fill_patches(s, b, bc)
    x, report = fill_patches(s, b, bc, on_empty="nan")
    assert np.isnan(x[16:]).all() and np.isfinite(x[:16]).all()
    assert report["empty_components"] == [{"vertices": 9, "example_vertex": 16}]


def test_gvf_fill_is_gradually_varied_and_exact_at_the_samples():
    V, F = icosphere(3)
    s = Surface.from_mesh(V, F)
    idx = np.arange(0, s.n, 37)
    vals = np.column_stack([V[idx, 0], np.round(4 * V[idx, 2]) / 4])
    checks = [check_gradual(s.G_hops, idx, vals[:, j]) for j in range(2)]
    X = gvf_fill(s, idx, vals, checks)
    assert X[idx].tobytes() == vals.tobytes()
    free = np.setdiff1d(np.arange(s.n), idx)
    E = np.array(sorted(edge_set(F)))
    for j, c in enumerate(checks):
        # off the samples a level of the check; neighbours at most one level apart
        level = np.searchsorted(c.levels, X[free, j])
        assert c.levels[level].tobytes() == X[free, j].tobytes()
        full = np.empty(s.n, dtype=np.int64)
        full[free] = level
        full[idx] = c.level
        assert np.abs(full[E[:, 0]] - full[E[:, 1]]).max() <= 1


def test_gvf_fill_on_empty():
    s = Surface.from_mesh(*two_components())
    idx, vals = np.array([0, 15]), np.array([[0.0], [3.0]])
    checks = [check_gradual(s.G_hops, idx, vals[:, 0])]
    X = gvf_fill(s, idx, vals, checks)
    assert np.isnan(X[16:]).all() and np.isfinite(X[:16]).all()
    with pytest.raises(SolveError, match="components without samples"):
        gvf_fill(s, idx, vals, checks, on_empty="error")


def test_start_values():
    s = Surface.from_mesh(*grid(6))
    idx, vals = np.array([0, 20, 35]), np.array([[0.0, 10.0], [1.0, 10.0], [3.0, 12.0]])
    assert set(INITS) == {"gvf", "random", "mean"}
    assert start_values("mean", s, idx, vals) is None
    x = start_values("random", s, idx, vals, seed=4)
    assert x.shape == (s.n, 2) and x.tobytes() == start_values("random", s, idx, vals, seed=4).tobytes()
    assert (x >= vals.min(axis=0)).all() and (x <= vals.max(axis=0)).all()
    assert x.tobytes() != start_values("random", s, idx, vals, seed=5).tobytes()
    checks = [check_gradual(s.G_hops, idx, vals[:, j]) for j in range(2)]
    assert start_values("gvf", s, idx, vals, checks=checks).tobytes() == gvf_fill(s, idx, vals, checks).tobytes()
