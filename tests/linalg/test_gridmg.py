"""The voxel geometric multigrid as a solver backend: the V-cycle, CG on it, the coarse matrix, the stall report."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy import ndimage

import manifill.linalg.gridmg
from manifill.linalg.gridlevels import free_matrix
from manifill.linalg.gridmg import GridMultigrid
from manifill.solid.boundary import boundary_voxels
from manifill.solid.voxels import stencil_weights, voxel_laplacian

hsettings = settings(max_examples=25, deadline=None, derandomize=True, database=None,
                     suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
CONNECTIVITIES = (6, 18, 26)
SPACINGS = [(1.0, 1.0, 1.0), (1.0, 1.0, 2.5), (0.5, 1.0, 3.0), (2.0, 0.7, 1.0)]


@pytest.fixture
def few_levels(monkeypatch):
    """Coarsen small grids too, so that the V-cycle (not only the coarse LU) runs on them."""
    monkeypatch.setattr(manifill.linalg.gridmg, "COARSE_MAX", 40)


def grid_problem(seed, c, shape=(13, 11, 12)):
    """A random blobby solid and its free voxels: all but the boundary D and 3 % of random voxels."""
    rng = np.random.default_rng(seed)
    noise = ndimage.gaussian_filter(rng.standard_normal(shape), 1.5)
    mask = noise > np.quantile(noise, 0.05)
    fixed = boundary_voxels(mask, c) | (mask & (rng.random(shape) < 0.03))
    return mask, mask & ~fixed


def reference(mask, free, g, spacing, c):
    """``x`` on the free voxels by spsolve on the voxel Laplacian: ``L_II x = -L_Ib g``."""
    L = voxel_laplacian(mask, spacing, c).tocsr()
    fr = free[mask]
    out = np.zeros(mask.shape)
    out[free] = sla.spsolve(sp.csc_matrix(L[fr][:, fr]), -(L[fr][:, ~fr] @ g[mask][~fr]))
    return out


def multigrid(mask, free, spacing=(1.0, 1.0, 1.0), c=6, **kw):
    return GridMultigrid(mask, free, spacing, c, stencil=stencil_weights, **kw)


@hsettings
@given(seed=st.integers(0, 2**32 - 1), c=st.sampled_from(CONNECTIVITIES), spacing=st.sampled_from(SPACINGS))
def test_v_cycle_is_symmetric_and_positive(few_levels, seed, c, spacing):
    mask, free = grid_problem(seed, c)
    mg = multigrid(mask, free, spacing, c)
    assert mg.report["levels"] >= 2
    rng = np.random.default_rng(seed)
    on = mg.pad(free) > 0
    x, y = rng.normal(size=on.size) * on, rng.normal(size=on.size) * on
    Mx, My = mg.precondition(x), mg.precondition(y)
    assert np.array_equal(Mx[~on], np.zeros(int((~on).sum())))  # nothing leaks off the free voxels
    scale = np.linalg.norm(Mx) * np.linalg.norm(y) + np.linalg.norm(My) * np.linalg.norm(x)
    assert abs(Mx @ y - x @ My) <= 1e-5 * scale  # single precision
    assert Mx @ x > 0 and My @ y > 0


@hsettings
@given(seed=st.integers(0, 2**32 - 1), c=st.sampled_from(CONNECTIVITIES), spacing=st.sampled_from(SPACINGS))
def test_solve_matches_spsolve(few_levels, seed, c, spacing):
    mask, free = grid_problem(seed, c)
    fixed = mask & ~free
    g = np.where(fixed, np.random.default_rng(seed).normal(size=mask.shape), 0.0)
    mg = multigrid(mask, free, spacing, c, rtol=1e-12)
    X, info = mg.solve(mg.rhs(mg.pad(g)))
    assert X.shape == (mg.pad(g).size, 1)
    assert info["status"] == ["converged"] and info["residuals"][0] <= 1e-12 and info["iterations"][0] < 60
    x = mg.unpad(X[:, 0])
    np.testing.assert_allclose(x[free], reference(mask, free, g, spacing, c)[free], rtol=0, atol=1e-9)
    assert (x[~free] == 0).all()


def test_is_a_backend_and_columns_are_independent(few_levels):
    mask, free = grid_problem(3, 18)
    mg = multigrid(mask, free, (1.0, 2.0, 1.0), 18, rtol=1e-12)
    assert mg.name == "multigrid" and mg.setup_seconds > 0
    rng = np.random.default_rng(4)
    G = np.stack([mg.rhs(mg.pad(np.where(mask & ~free, rng.normal(size=mask.shape), 0.0))) for _ in range(3)], 1)
    X, info = mg.solve(G)
    assert X.shape == G.shape and len(info["iterations"]) == 3
    for j in range(3):
        np.testing.assert_array_equal(X[:, j], mg.solve(G[:, j])[0][:, 0])


@pytest.mark.parametrize("c", CONNECTIVITIES)
@pytest.mark.parametrize("spacing", SPACINGS)
def test_coarse_matrix_is_the_free_laplacian_with_the_given_diagonal(c, spacing):
    mask, free = grid_problem(5, c, shape=(7, 8, 6))
    d = np.random.default_rng(0).uniform(1, 2, int(free.sum()))
    L = voxel_laplacian(free, spacing, c)
    ref = sp.csr_array(L - sp.diags_array(L.diagonal()) + sp.diags_array(d))
    A = free_matrix(free, np.asarray(spacing, float), c, stencil_weights, d)
    # the same entries in the same order: the same LU as before the stencil was passed in
    for a, b in [(A.indptr, ref.indptr), (A.indices, ref.indices), (A.data, ref.data)]:
        np.testing.assert_array_equal(a, b)


def test_pad_unpad_and_zero_rhs():
    mask = np.ones((4, 5, 6), dtype=bool)
    mg = multigrid(mask, boundary_voxels(mask) ^ mask)
    a = np.arange(120.0).reshape(4, 5, 6)
    assert mg.pad(a).shape == (6 * 7 * 8,)
    np.testing.assert_array_equal(mg.unpad(mg.pad(a)), a)
    X, info = mg.solve(np.zeros(6 * 7 * 8))
    assert info["iterations"] == [0] and info["residuals"] == [0.0] and not X.any()


def test_a_singular_coarse_problem_is_reported_as_stalled():
    # one fixed voxel at odd indices along every coarsened axis is on no coarse grid (see tests/solid/test_fill.py)
    mask = np.ones((20, 20, 20), dtype=bool)
    free = mask.copy()
    free[9, 9, 9] = False
    mg = multigrid(mask, free, maxiter=100)
    g = np.where(~free, 2.0, 0.0)
    _, info = mg.solve(mg.rhs(mg.pad(g)))
    assert info["status"] == ["stalled"] and info["residuals"][0] > 0.5
    assert manifill.linalg.gridmg.STALL < info["iterations"][0] < 100


def test_iteration_cap_is_reported():
    mask = np.ones((24, 24, 24), dtype=bool)
    free = mask & ~boundary_voxels(mask)
    mg = multigrid(mask, free, maxiter=1)
    _, info = mg.solve(mg.rhs(mg.pad(np.where(free, 0.0, 1.0))))
    assert info["status"] == ["maxiter"] and info["iterations"] == [1] and info["residuals"][0] > 1e-10


def test_layer_takes_its_stencil_from_the_caller():
    # a plain 6-neighbour stencil of the test's own: the backend needs nothing of manifill.solid
    def plain(spacing, connectivity):
        return np.eye(3, dtype=np.int64), 1.0 / np.asarray(spacing, float) ** 2

    mask = np.ones((9, 8, 7), dtype=bool)
    free = mask & ~boundary_voxels(mask)
    g = np.where(free, 0.0, np.random.default_rng(1).normal(size=mask.shape))
    mg = GridMultigrid(mask, free, (1.0, 1.0, 1.0), 6, stencil=plain, rtol=1e-12)
    x = mg.unpad(mg.solve(mg.rhs(mg.pad(g)))[0][:, 0])
    np.testing.assert_allclose(x[free], reference(mask, free, g, (1.0, 1.0, 1.0), 6)[free], rtol=0, atol=1e-9)
