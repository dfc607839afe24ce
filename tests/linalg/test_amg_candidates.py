"""AMG with near-null-space candidates for the k-harmonic energies (:mod:`manifill.linalg.amg_candidates`)."""

import numpy as np
import pytest

from conftest import icosphere
from manifill.linalg.amg_candidates import CandidateAMG
from manifill.linalg.quadratic import QuadraticSolver
from manifill.surface.polyharmonic import PolyharmonicSolver, polyharmonic_matrix, positions


def _system(level=5, k=100):
    V, F = icosphere(level)
    idx = np.sort(np.random.default_rng(1).choice(len(V), k, replace=False))
    return V, F, idx, np.sin(3 * V[idx, 0]) + V[idx, 1] * V[idx, 2]


def test_same_minimiser_as_the_factorisation():
    V, F, idx, vals = _system()
    amg = PolyharmonicSolver(V, F, idx, solver="amg")
    assert isinstance(amg.backend, CandidateAMG)
    x = amg.solve(vals)
    y = PolyharmonicSolver(V, F, idx, solver="direct").solve(vals)
    assert np.abs(x - y).max() <= 1e-9 * np.ptp(vals)
    assert np.array_equal(x[idx], vals)


def test_linear_candidates_cut_the_steps():
    """The positions as candidates: the aggregation interpolates linear functions, which the biharmonic energy
    nearly annihilates; CG then needs several times fewer steps than with constants alone."""
    V, F, idx, vals = _system()
    A = polyharmonic_matrix(V, F)
    plain = QuadraticSolver(A, idx, solver="amg", tol=1e-12, maxiter=5000, symmetric_pattern=True)
    plain.solve(vals)
    cand = QuadraticSolver(A, idx, solver="amg", tol=1e-12, maxiter=5000, symmetric_pattern=True,
                           candidates=positions(V, 2))
    cand.solve(vals)
    assert cand.report["iterations"][0] * 3 < plain.report["iterations"][0]


def test_many_columns_equal_one_by_one():
    V, F, idx, vals = _system(level=4, k=40)
    s = PolyharmonicSolver(V, F, idx, solver="amg")
    X = s.solve(np.column_stack([vals, -2 * vals + 1]))
    np.testing.assert_allclose(X[:, 1], s.solve(-2 * vals + 1), atol=1e-12 * np.ptp(vals))


@pytest.mark.parametrize("scale", [1e-6, 1e6])
def test_units_do_not_change_the_field(scale):
    V, F, idx, vals = _system(level=4, k=40)
    a = PolyharmonicSolver(V, F, idx, solver="amg").solve(vals)
    b = PolyharmonicSolver(V * scale, F, idx, solver="amg").solve(vals)
    assert np.abs(a - b).max() <= 1e-9 * np.ptp(vals)
