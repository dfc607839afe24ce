"""Bounds lo <= x <= hi: the minimiser under the bounds, checked by its KKT conditions and a reference QP."""

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog, lsq_linear

from manifill import SampleError, SolveError
from manifill.linalg.active_set import bounds_per_field
from manifill.linalg.quadratic import QuadraticSolver
from manifill.mesh.laplacian import laplacian, mass_matrix
from manifill.mesh.shapes import grid, icosphere

hsettings = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                     suppress_health_check=[HealthCheck.too_slow])


def mesh(kind):
    return icosphere(1) if kind == "sphere" else grid(6)


def biharmonic(V, F):
    """``L M^-1 L`` with the cotangent stiffness and the lumped mass."""
    L, M = laplacian(V, F), mass_matrix(V, F, mass="barycentric")
    return sp.csr_array(L @ sp.diags(1.0 / M.diagonal()) @ L)


def reference_qp(A, idx, vals, c, lo, hi):
    """The box-constrained QP on the free indices by scipy's BVLS: with A_FF = L L^T, C = L^T,
    1/2 y'A_FF y + y'r = 1/2 ||C y - d||^2 + const for d = -L^-1 r."""
    A = A.toarray()
    n = A.shape[0]
    free = np.setdiff1d(np.arange(n), idx)
    r = A[np.ix_(free, idx)] @ vals + c[free]
    Lc = np.linalg.cholesky(A[np.ix_(free, free)])
    d = -np.linalg.solve(Lc, r)
    if lo == hi:  # one feasible point
        return np.where(np.isin(np.arange(n), idx), 0.0, lo) + np.bincount(idx, vals, n)
    res = lsq_linear(Lc.T, d, bounds=(np.full(free.size, lo), np.full(free.size, hi)), method="bvls", tol=1e-15)
    x = np.empty(n)
    x[idx], x[free] = vals, res.x
    return x


def assert_kkt(A, idx, vals, c, lo, hi, x, rtol=1e-9):
    """Primal feasibility, stationarity on inactive free indices, sign of the multipliers, complementarity."""
    n = A.shape[0]
    scale = max(np.abs(vals).max(), *(abs(b) for b in (lo, hi) if np.isfinite(b)), 1e-300)
    tx = rtol * scale
    tg = rtol * (abs(A).max() * scale + np.abs(c).max())
    free = np.setdiff1d(np.arange(n), idx)
    np.testing.assert_array_equal(x[idx], vals)
    xf = x[free]
    assert xf.min() >= lo and xf.max() <= hi  # exactly inside: zero overshoot by construction
    g = (A @ x + c)[free]
    at_lo, at_hi = xf <= lo + tx, xf >= hi - tx
    inside = ~at_lo & ~at_hi
    assert np.abs(g[inside]).max(initial=0.0) <= tg  # stationarity
    assert g[at_lo].min(initial=0.0) >= -tg  # multiplier >= 0 at lo
    assert g[at_hi].max(initial=0.0) <= tg  # multiplier <= 0 at hi
    # complementarity: the multiplier vanishes unless the value sits at its bound
    gap = np.minimum(xf - lo, hi - xf)
    assert (np.abs(g) * gap).max() <= tg * scale


def overshooting(kind, seed, energy):
    """A problem whose unbounded minimiser leaves the samples' range by more than 1% of it (the first
    such draw of a seeded generator)."""
    V, F = mesh(kind)
    n = V.shape[0]
    rng = np.random.default_rng(seed)
    A = biharmonic(V, F) if energy == "biharmonic" else laplacian(V, F, weights="uniform")
    while True:
        idx = rng.choice(n, 6, replace=False)
        vals = rng.uniform(-1.0, 1.0, 6)
        # a harmonic energy needs a load to bulge past the samples; a biharmonic one overshoots by itself
        c = np.zeros(n) if energy == "biharmonic" else rng.normal(0.0, 1.0, n)
        x = QuadraticSolver(A, idx).solve(vals, linear=c)
        if x.min() < vals.min() - 0.01 * np.ptp(vals) or x.max() > vals.max() + 0.01 * np.ptp(vals):
            return A, idx, vals, c


@pytest.mark.parametrize("kind", ["sphere", "grid"])
@pytest.mark.parametrize("energy", ["biharmonic", "loaded"])
@pytest.mark.parametrize("seed", range(3))
def test_kkt_and_agreement_with_a_reference_qp(kind, energy, seed):
    A, idx, vals, c = overshooting(kind, seed, energy)
    lo, hi = vals.min(), vals.max()
    q = QuadraticSolver(A, idx)
    free = q.unknown
    x0 = q.solve(vals, linear=c)
    assert x0[free].min() < lo - 1e-3 or x0[free].max() > hi + 1e-3  # the unbounded one overshoots
    x = q.solve(vals, linear=c, lo=lo, hi=hi)
    assert_kkt(A, idx, vals, c, lo, hi, x)
    ref = reference_qp(A, idx, vals, c, lo, hi)
    np.testing.assert_allclose(x, ref, rtol=0, atol=1e-8 * (hi - lo))
    rep = q.report["bounds"]
    assert rep["lo"] == [lo] and rep["hi"] == [hi] and rep["iterations"][0] >= 1
    assert rep["active_lo"][0] + rep["active_hi"][0] >= 1
    assert rep["active_lo"][0] == np.count_nonzero(x[free] == lo) - np.count_nonzero(x0[free] == lo)
    assert rep["kkt_residual"] <= 1e-9 * abs(A).max() * max(abs(lo), abs(hi))


def test_the_bounded_minimiser_beats_the_clip():
    A, idx, vals, c = overshooting("grid", 0, "biharmonic")
    q = QuadraticSolver(A, idx)
    lo, hi = vals.min(), vals.max()
    energy = lambda x: 0.5 * x @ (A @ x) + c @ x  # noqa: E731
    free = q.unknown
    x0 = q.solve(vals)
    clipped = x0.copy()
    clipped[free] = np.clip(x0[free], lo, hi)
    x = q.solve(vals, lo=lo, hi=hi)
    assert energy(x0) < energy(x) < energy(clipped) - 1e-6 * abs(energy(clipped))
    assert not np.allclose(x, clipped, atol=1e-6)


def test_bounds_that_are_not_active_give_the_unbounded_solution_exactly():
    A, idx, vals, c = overshooting("sphere", 1, "biharmonic")
    q = QuadraticSolver(A, idx)
    x0 = q.solve(vals, linear=c)
    x = q.solve(vals, linear=c, lo=x0.min() - 1.0, hi=x0.max() + 1.0)
    np.testing.assert_array_equal(x, x0)
    assert q.report["bounds"]["iterations"] == [0] and q.report["bounds"]["active_hi"] == [0]
    np.testing.assert_array_equal(q.solve(vals, linear=c, lo=None, hi=np.inf), x0)
    q.solve(vals)
    assert "bounds" not in q.report


@pytest.mark.parametrize("kind", ["sphere", "grid"])
@pytest.mark.parametrize("weights", ["uniform", "cotan"])
def test_harmonic_needs_no_bounds_at_the_samples_range(kind, weights):
    # the maximum principle (a Laplacian with positive weights): no overshoot, so the bounds change nothing
    V, F = mesh(kind)
    rng = np.random.default_rng(4)
    idx = rng.choice(V.shape[0], 5, replace=False)
    vals = rng.normal(size=5)
    q = QuadraticSolver(laplacian(V, F, weights=weights), idx)
    x0 = q.solve(vals)
    x = q.solve(vals, lo=vals.min(), hi=vals.max())
    np.testing.assert_allclose(x, x0, rtol=0, atol=1e-14)
    rep = q.report["bounds"]
    assert rep["iterations"] == [0] and rep["active_lo"] == [0] and rep["active_hi"] == [0]


def test_biharmonic_overshoots_and_the_bounded_one_does_not():
    # a step, 0 on the columns x = 0 and 1/4 and 1 on x = 3/4 and 1: the minimal-curvature fit (like a
    # natural cubic spline through (0, 0), (1/4, 0), (3/4, 1), (1, 1)) dips below 0 and rises above 1
    V, F = grid(9)
    x = V[:, 0]
    idx = np.flatnonzero(np.isclose(x[:, None], [0.0, 0.25, 0.75, 1.0]).any(axis=1))
    vals = (x[idx] > 0.5).astype(float)
    q = QuadraticSolver(biharmonic(V, F), idx)
    free = q.unknown
    x0 = q.solve(vals)
    assert x0[free].max() > 1.01 or x0[free].min() < -0.01
    xb = q.solve(vals, lo=0.0, hi=1.0)
    assert xb.min() >= 0.0 and xb.max() <= 1.0
    assert_kkt(q.A, idx, vals, np.zeros(V.shape[0]), 0.0, 1.0, xb)


def test_each_field_has_its_own_bounds_and_active_set():
    A, idx, vals, c = overshooting("sphere", 2, "biharmonic")
    q = QuadraticSolver(A, idx)
    V = np.column_stack([vals, -2 * vals, vals])
    lo = [vals.min(), -2 * vals.max(), -np.inf]
    hi = [vals.max(), -2 * vals.min(), np.inf]
    X = q.solve(V, lo=lo, hi=hi)
    rep = q.report["bounds"]
    assert rep["lo"][2] is None and rep["hi"][2] is None and rep["iterations"][2] == 0
    for j in range(3):
        np.testing.assert_allclose(X[:, j], q.solve(V[:, j], lo=lo[j], hi=hi[j]), rtol=0, atol=1e-12)
    np.testing.assert_allclose(X[:, 1], -2 * X[:, 0], rtol=0, atol=1e-12)  # scaling carries the active set
    np.testing.assert_allclose(X[:, 2], q.solve(vals), rtol=0, atol=1e-14)  # one LU solve of 3 columns vs 1


def test_amg_agrees_with_direct():
    A, idx, vals, c = overshooting("grid", 1, "loaded")
    lo, hi = vals.min(), vals.max()
    xd = QuadraticSolver(A, idx, solver="direct").solve(vals, linear=c, lo=lo, hi=hi)
    xa = QuadraticSolver(A, idx, solver="amg", tol=1e-13).solve(vals, linear=c, lo=lo, hi=hi)
    np.testing.assert_allclose(xa, xd, rtol=0, atol=1e-8)


def test_empty_components_stay_nan():
    V, F = grid(5)
    A = sp.csr_array(sp.block_diag([biharmonic(V, F), biharmonic(V, F)]))
    q = QuadraticSolver(A, [0, 24, 12], on_empty="nan")
    x = q.solve([0.0, 0.0, 1.0], lo=0.0, hi=1.0)
    assert np.isnan(x[25:]).all() and np.isfinite(x[:25]).all()
    assert 0.0 <= x[:25].min() and x[:25].max() <= 1.0


@pytest.mark.parametrize("seed", range(12))
def test_bounds_with_equality_rows(seed):
    # also Aeq x = beq (points inside faces); KKT with the equality multipliers fitted at the inside indices;
    # when no point meets the rows within the bounds (a linear program says so), a SolveError
    A, idx, vals, c = overshooting("grid", seed, "biharmonic")
    n = A.shape[0]
    rng = np.random.default_rng(seed)
    free = np.setdiff1d(np.arange(n), idx)
    rows = [sp.coo_array((rng.dirichlet(np.ones(3)), (np.zeros(3, int), rng.choice(free, 3, replace=False))),
                         shape=(1, n)) for _ in range(4)]
    Aeq = sp.csr_array(sp.vstack(rows))
    lo, hi = vals.min(), vals.max()
    beq = rng.uniform(lo, hi, 4)
    q = QuadraticSolver(A, idx, Aeq=Aeq)
    feasible = linprog(np.zeros(free.size), A_eq=Aeq[:, free].toarray(), b_eq=beq, bounds=(lo, hi)).status == 0
    if not feasible:
        with pytest.raises(SolveError, match="cannot be met within the bounds"):
            q.solve(vals, beq=beq, lo=lo, hi=hi)
        return
    x = q.solve(vals, beq=beq, lo=lo, hi=hi)
    np.testing.assert_allclose(Aeq @ x, beq, rtol=0, atol=1e-12)
    assert x.min() >= lo and x.max() <= hi
    g = A @ x
    xf = x[free]
    inside = free[(xf > lo + 1e-9) & (xf < hi - 1e-9)]
    mu = np.linalg.lstsq(Aeq[:, inside].toarray().T, -g[inside], rcond=None)[0]
    g = g + Aeq.T @ mu
    tg = 1e-8 * abs(A).max()
    assert np.abs(g[inside]).max() <= tg
    assert g[free[xf <= lo + 1e-9]].min(initial=0) >= -tg and g[free[xf >= hi - 1e-9]].max(initial=0) <= tg


def test_impossible_bounds_are_refused_in_one_line():
    A, idx, vals, c = overshooting("sphere", 0, "loaded")
    q = QuadraticSolver(A, idx)
    cases = [
        (dict(lo=vals.min() + 0.01), "sample values outside the bounds"),
        (dict(hi=vals.max() - 0.01), "bounds='samples'"),
        (dict(lo=1.0, hi=0.0), "exceeds the upper bound"),
        (dict(lo=np.nan), "NaN"),
        (dict(lo=[0.0, 1.0]), "shape"),
        (dict(hi="abc"), "numbers"),
    ]
    for kwargs, words in cases:
        with pytest.raises(SampleError, match=words.replace("(", r"\(")) as info:
            q.solve(vals, **kwargs)
        assert "\n" not in str(info.value)
    with pytest.raises(SolveError, match="bound_iterations") as info:
        q.solve(vals, linear=c, lo=vals.min(), hi=vals.max(), bound_iterations=0)
    assert "\n" not in str(info.value)


def test_as_bounds_broadcasts():
    lo, hi = bounds_per_field(None, [1.0, 2.0], 2)
    assert lo.tolist() == [-np.inf, -np.inf] and hi.tolist() == [1.0, 2.0]


def graph_laplacian(n, seed, extra):
    rng = np.random.default_rng(seed)
    rows = np.r_[np.arange(n - 1), rng.integers(0, n, extra)]
    cols = np.r_[np.arange(1, n), rng.integers(0, n, extra)]
    W = sp.coo_matrix((rng.uniform(0.1, 2.0, rows.size), (rows, cols)), shape=(n, n)).tocsr()
    W = W + W.T
    W.setdiag(0)
    W.eliminate_zeros()
    return sp.csr_array(sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W)


@st.composite
def bounded_problems(draw):
    n = draw(st.integers(3, 30))
    seed = draw(st.integers(0, 2**32 - 1))
    k = draw(st.integers(1, n - 1))
    rng = np.random.default_rng(seed)
    L = graph_laplacian(n, seed, draw(st.integers(0, 2 * n)))
    A = sp.csr_array(L @ L) if draw(st.booleans()) else L  # biharmonic-like or harmonic
    idx = rng.choice(n, k, replace=False)
    vals = rng.uniform(-1.0, 1.0, k)
    c = rng.normal(0.0, draw(st.sampled_from([0.0, 0.3, 3.0])), n)
    lo = vals.min() - draw(st.sampled_from([0.0, 0.1, np.inf]))
    hi = vals.max() + draw(st.sampled_from([0.0, 0.2]))
    return A, idx, vals, c, lo, hi


@hsettings
@given(problem=bounded_problems())
def test_property_kkt_and_the_reference_qp(problem):
    A, idx, vals, c, lo, hi = problem
    q = QuadraticSolver(A, idx, symmetric_pattern=True)
    x = q.solve(vals, linear=c, lo=lo, hi=hi)
    assert_kkt(A, idx, vals, c, lo, hi, x)
    ref = reference_qp(A, idx, vals, c, lo, hi)
    np.testing.assert_allclose(x, ref, rtol=0, atol=1e-8 * max(1.0, np.abs(ref).max()))


# --- the active set always settles (issue 12): primal-dual steps, then a monotone loop; reuse across faces ---


def sphere_step(level, k, seed):
    """The accuracy benchmark's sharp step on an icosphere and its bilaplacian (Voronoi mass), k samples."""
    from manifill.linalg.energies import polyharmonic_energy

    V, F = icosphere(level)
    V = V / np.abs(V).max()
    A = polyharmonic_energy(laplacian(V, F), mass_matrix(V, F, mass="voronoi"), 2)
    f = ((V[:, 0] + 2 * V[:, 1] + 2 * V[:, 2]) / 3 > 0.2).astype(float)
    idx = np.sort(np.random.default_rng([seed, k]).choice(V.shape[0], k, replace=False))
    return sp.csr_array(A), idx, f[idx]


def old_loop_iterations(A, idx, vals, lo, hi, cap):
    """The loop before issue 12's fix, in brief: fix every violator, else release every wrong-signed index."""
    q = QuadraticSolver(A, idx)
    x = q.solve(vals)
    free = q.unknown
    side = np.zeros(A.shape[0], dtype=np.int8)
    tol = 1e-10
    for it in range(cap):
        out = (side[free] == 0) & ((x[free] < lo - tol) | (x[free] > hi + tol))
        if out.any():
            side[free[out]] = np.where(x[free[out]] < lo, -1, 1)
        else:
            g = A @ x
            wrong = ((side < 0) & (g < -tol)) | ((side > 0) & (g > tol))
            if not wrong.any():
                return it
            side[wrong] = 0
        W = np.flatnonzero(side)
        x = q.fixing(W).solve(np.concatenate([vals, np.where(side[W] > 0, hi, lo)]))
    return cap


def test_a_step_that_chased_its_tail_settles_at_the_kkt_point():
    # 5 samples of a step on 642 vertices: the old loop took 22 re-solves (fix all violators, release all
    # wrong-signed: the moves undo each other); the primal-dual steps on the peaks of the violation take 8
    A, idx, vals = sphere_step(3, 5, 21)
    lo, hi = vals.min(), vals.max()
    assert old_loop_iterations(A, idx, vals, lo, hi, 100) >= 20
    q = QuadraticSolver(A, idx)
    x = q.solve(vals, lo=lo, hi=hi)
    rep = q.report["bounds"]
    assert rep["iterations"][0] <= 12
    assert_kkt(A, idx, vals, np.zeros(A.shape[0]), lo, hi, x)  # KKT: the minimiser of this convex QP


@pytest.mark.parametrize("seed", [1, 18, 21])
def test_the_monotone_loop_alone_settles_with_falling_energy(seed):
    # the finite rule by itself (the fallback when a primal-dual face repeats): every feasible face minimiser
    # has a lower energy than the one before, and the end is the KKT point
    from manifill.linalg import active_set

    A, idx, vals = sphere_step(3, 5, seed)
    lo, hi = vals.min(), vals.max()
    q = QuadraticSolver(A, idx)
    faces = active_set.Faces(q, vals, lo, hi, np.zeros(A.shape[0]))
    energies = []
    solve = faces.solve

    def recording(side, x0, beq=None):
        x, mu = solve(side, x0, beq)
        free = q.unknown[side == 0]
        if x[free].min() >= lo - 1e-10 and x[free].max() <= hi + 1e-10:  # a feasible face minimiser
            energies.append(faces.energy(x))
        return x, mu

    faces.solve = recording
    y = q.solve(vals)
    x, solves, active, at_hi = active_set._monotone(faces, y, np.zeros(q.unknown.size, np.int8), 0, 1e-10, 1e-10,
                                                    200, 0)
    x[q.unknown] = np.clip(x[q.unknown], lo, hi)
    assert solves >= 3 and len(energies) >= 2
    assert all(b < a for a, b in zip(energies, energies[1:]))
    assert_kkt(A, idx, vals, np.zeros(A.shape[0]), lo, hi, x)  # KKT: the minimiser of this convex QP
    np.testing.assert_allclose(x, q.solve(vals, lo=lo, hi=hi), rtol=0, atol=1e-9)  # the two phases' answer


def test_reusing_the_hierarchy_gives_the_fresh_setups_answer():
    # AMG: CG on every face's system preconditioned by the unbounded hierarchy restricted to the free set
    # (no set-up) reaches the same minimiser as a new hierarchy per face
    from manifill.linalg.active_set import solve_bounded

    A, idx, vals = sphere_step(3, 8, 2)
    lo, hi = np.array([vals.min()]), np.array([vals.max()])
    q = QuadraticSolver(A, idx, solver="amg", tol=1e-13, maxiter=5000)
    Xr, rr = solve_bounded(q, vals[:, None], lo, hi, reuse=True)
    Xf, rf = solve_bounded(q, vals[:, None], lo, hi, reuse=False)
    assert rr["setups"] == [0] and rr["cg_iterations"][0] > 0 and rf["setups"] == rf["iterations"]
    np.testing.assert_allclose(Xr, Xf, rtol=0, atol=1e-8)
    assert_kkt(A, idx, vals, np.zeros(A.shape[0]), lo[0], hi[0], Xr[:, 0], rtol=1e-8)
    xd = QuadraticSolver(A, idx, solver="direct").solve(vals, lo=lo, hi=hi)
    np.testing.assert_allclose(Xr[:, 0], xd, rtol=0, atol=1e-8)


@pytest.mark.parametrize("seed", range(4))
def test_a_face_on_the_base_factor_is_the_face_factorised(seed):
    # the faces solved from one factor (and its Schur block) are each face's own minimiser: a walk of random faces
    # (indices joining, leaving, changing sides) against a factorisation per face, and the same walk with cheap
    # columns (every face on one factor) and with dear ones (every face factorised, then bases change)
    from manifill.linalg.faces import Faces

    rng = np.random.default_rng(seed)
    A = biharmonic(*icosphere(2)) if seed % 2 else laplacian(*grid(12, 12)) + 1e-3 * sp.eye(144)
    idx = rng.choice(A.shape[0], 6, replace=False)
    vals, c = rng.normal(size=6), rng.normal(size=A.shape[0])
    q = QuadraticSolver(A, idx, solver="direct")
    c[idx] = 0.0
    walks = {name: Faces(q, vals, -0.5, 0.5, c) for name in ("cheap", "dear", "unkept")}
    walks["unkept"].keep_bytes = 0  # the Schur block alone, one solve per face
    fresh = Faces(q, vals, -0.5, 0.5, c)
    fresh.schur = False
    side = np.zeros(q.unknown.size, np.int8)
    for name, faces in walks.items():  # the empty face: the unbounded minimiser, and the base
        np.testing.assert_allclose(faces.solve(side, None)[0], q.solve(vals, linear=c), atol=1e-12)
        faces._column_seconds = np.inf if name == "dear" else 0.0
    for step in range(12):
        if step % 3 == 2:  # only indices at a bound move to the other bound
            flip = rng.choice(np.flatnonzero(side), 2, replace=False)
            side[flip] *= -1
        else:
            flip = rng.choice(side.size, 4, replace=False)
            side[flip] = rng.choice([-1, 0, 1], size=4)
        want, _ = fresh.solve(side, None)
        for faces in walks.values():
            got, _ = faces.solve(side, None)
            np.testing.assert_allclose(got, want, atol=1e-9 * (1 + np.abs(want).max()))
            W = q.unknown[side != 0]
            assert np.array_equal(got[W], np.where(side[side != 0] > 0, 0.5, -0.5))
    assert walks["cheap"].setups < walks["dear"].setups <= 12 == fresh.setups and walks["cheap"].columns > 0
    assert walks["cheap"]._base["Z"] is not None and walks["unkept"]._base["Z"] is None
