"""The one preconditioned CG loop: against spsolve, with and without a preconditioner; how it reports its end."""

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from manifill.linalg.pcg import Kernels, PCGResult, dot, nrm2, pcg


def spd(n=60, seed=0):
    """A random sparse symmetric positive definite matrix (a jittered 1-D Laplacian plus a shift)."""
    rng = np.random.default_rng(seed)
    w = rng.uniform(0.5, 2.0, n - 1)
    W = sp.diags([w, w], [-1, 1], shape=(n, n))
    return sp.csr_matrix(sp.diags(np.asarray(W.sum(axis=1)).ravel() + 0.01) - W), rng.standard_normal(n)


def jacobi(A):
    d = A.diagonal()
    return lambda r, _: r / d


@pytest.mark.parametrize("precondition", [None, "jacobi"])
@pytest.mark.parametrize("flexible", [False, True])
def test_agrees_with_spsolve(precondition, flexible):
    A, b = spd()
    x = np.zeros_like(b)
    r = b.copy()
    res = pcg(lambda p: A @ p, r, x, precondition=jacobi(A) if precondition else None, rtol=1e-12, maxiter=500,
              norm0=nrm2(b), flexible=flexible)
    assert isinstance(res, PCGResult) and res.converged and res.status == "converged"
    np.testing.assert_allclose(x, spsolve(sp.csc_matrix(A), b), rtol=0, atol=1e-9)
    # the residual it kept is the true one, and the one it reports
    np.testing.assert_allclose(r, b - A @ x, rtol=0, atol=1e-10)
    assert res.residual == pytest.approx(np.linalg.norm(b - A @ x) / np.linalg.norm(b), abs=1e-13)
    assert res.residual <= 1e-12 and len(res.history) == res.iterations


def test_from_a_nonzero_start():
    A, b = spd(seed=1)
    x0 = np.random.default_rng(2).standard_normal(b.size)
    x = x0.copy()
    res = pcg(lambda p: A @ p, b - A @ x0, x, precondition=jacobi(A), rtol=1e-12, maxiter=500, norm0=nrm2(b))
    assert res.converged
    np.testing.assert_allclose(x, spsolve(sp.csc_matrix(A), b), rtol=0, atol=1e-9)


def test_a_preconditioner_saves_iterations():
    # a badly scaled diagonal: Jacobi undoes it
    A, b = spd(200, seed=3)
    D = sp.diags(np.logspace(0, 2, 200))
    A = sp.csr_matrix(D @ A @ D)
    plain = pcg(lambda p: A @ p, b.copy(), np.zeros_like(b), rtol=1e-10, maxiter=5000, norm0=nrm2(b))
    pre = pcg(lambda p: A @ p, b.copy(), np.zeros_like(b), precondition=jacobi(A), rtol=1e-10, maxiter=5000,
              norm0=nrm2(b))
    assert plain.converged and pre.converged and pre.iterations < plain.iterations


def test_iteration_cap_is_reported():
    A, b = spd(seed=4)
    x = np.zeros_like(b)
    res = pcg(lambda p: A @ p, b.copy(), x, rtol=1e-14, maxiter=3, norm0=nrm2(b))
    assert res.status == "maxiter" and res.iterations == 3 and not res.converged and res.residual > 1e-14
    assert len(res.history) == 3


def test_breakdown_on_an_indefinite_operator():
    A = sp.diags([1.0, -1.0]).tocsr()
    b = np.array([1.0, 1.0])
    res = pcg(lambda p: A @ p, b.copy(), np.zeros(2), rtol=1e-12, maxiter=10, norm0=nrm2(b))
    assert res.status == "breakdown" and res.iterations == 0


def test_stall_test():
    # a preconditioner that undoes nothing useful: the residual cannot halve in 2 steps on a system where
    # every step gains only a little
    A, b = spd(400, seed=5)
    res = pcg(lambda p: A @ p, b.copy(), np.zeros_like(b), rtol=1e-14, maxiter=1000, norm0=nrm2(b), stall=2)
    assert res.status == "stalled" and res.history[-1] > 0.5 * res.history[-3]


def test_norm_survives_overflow_and_underflow():
    for s in (1e-200, 1.0, 1e200):
        x = np.array([3.0, 4.0]) * s
        assert nrm2(x) == pytest.approx(5.0 * s, rel=1e-15)
    assert dot(np.ones(3), np.arange(3.0)) == 3.0
    assert nrm2(np.zeros(4)) == 0.0


def test_cg_in_another_inner_product():
    # A = M^-1 K is not symmetric, but it is self-adjoint and positive in <u, v>_M = u' M v: CG in that inner
    # product solves A x = M^-1 b, i.e. K x = b (with the Euclidean one, CG breaks down on this A)
    K, b = spd(40, seed=6)
    m = np.random.default_rng(7).uniform(0.1, 10.0, 40)
    x = np.zeros_like(b)
    res = pcg(lambda p: (K @ p) / m, b / m, x, rtol=1e-12, maxiter=200, norm0=nrm2(b / m),
              kernels=Kernels(inner=lambda u, v: float(u @ (m * v))))
    assert res.converged
    np.testing.assert_allclose(x, spsolve(sp.csc_matrix(K), b), rtol=0, atol=1e-8)


def test_own_vector_updates_give_the_same_iterates():
    # the updates done in two halves (as the voxel multigrid does on threads) are the same arithmetic
    A, b = spd(80, seed=8)
    calls = {"update": 0, "direction": 0}
    x = np.zeros_like(b)
    r = b.copy()
    halves = (slice(0, 40), slice(40, 80))

    def update(alpha, p, Ap):
        calls["update"] += 1
        for h in halves:
            x[h] += alpha * p[h]
            r[h] -= alpha * Ap[h]
        return nrm2(r)

    def direction(beta, p, z):
        calls["direction"] += 1
        for h in halves:
            p[h] = z[h] + beta * p[h]

    mine = pcg(lambda p: A @ p, r, x, precondition=jacobi(A), rtol=1e-12, maxiter=500, norm0=nrm2(b),
               kernels=Kernels(update=update, direction=direction))
    y = np.zeros_like(b)
    plain = pcg(lambda p: A @ p, b.copy(), y, precondition=jacobi(A), rtol=1e-12, maxiter=500, norm0=nrm2(b))
    assert mine.converged and calls == {"update": mine.iterations, "direction": mine.iterations - 1}
    assert mine.iterations == plain.iterations
    np.testing.assert_allclose(mine.history, plain.history, rtol=1e-9)
    np.testing.assert_allclose(x, y, rtol=0, atol=1e-12)
