"""One implementation per energy: the public functions and the methods give the same numbers.

``biharmonic``/``PolyharmonicSolver`` (arrays in) and ``method='harmonic'``, ``'biharmonic'``,
``'triharmonic'`` (a Surface, through the engine) compose their energy in one place
(:func:`manifill.surface.polyharmonic.energy_matrix`) and choose their solver by one policy
(``PolyharmonicSolver.settings``); ``harmonic(V, T)`` and ``tet_fill`` are one solver. The two
routes differ only by an exact power-of-two scaling of the positions, so they agree to round-off
(1e-12 of the values' range) when they factorise, and to the iteration's tolerance with AMG.
"""

import importlib.util

import numpy as np
import pytest

from conftest import icosphere, irregular
import manifill
from manifill.mesh.shapes import grid
from manifill.surface.harmonic import HarmonicSolver, harmonic
from manifill.surface.polyharmonic import PolyharmonicSolver, biharmonic

HAVE_TETGEN = importlib.util.find_spec("tetgen") is not None


def _close(a, b, scale, tol=1e-12):
    return float(np.nanmax(np.abs(np.asarray(a) - np.asarray(b)))) <= tol * scale


def _meshes():
    V, F = icosphere(3)
    yield "sphere", V, F
    yield "curved", V * (1.0 + 0.15 * np.random.default_rng(4).uniform(-1, 1, len(V)))[:, None], F
    yield "open grid", *grid(20)
    yield "irregular", *irregular()


@pytest.mark.parametrize("k,method", [(1, "harmonic"), (2, "biharmonic"), (3, "triharmonic")])
@pytest.mark.parametrize("solver", ["direct", "auto", "amg"])
def test_public_functions_equal_the_methods(k, method, solver):
    for name, V, F in _meshes():
        rng = np.random.default_rng(len(V))
        idx = np.sort(rng.choice(len(V), 25, replace=False))
        vals = np.column_stack([np.sin(3 * V[idx, 0]) + V[idx, 2], rng.normal(size=idx.size)])
        x = biharmonic(V, F, idx, vals, k=k, solver=solver)
        r = manifill.reconstruct(V, F, idx, vals, method=method, solver=solver, check=False)
        tol = 1e-8 if solver == "amg" else 1e-12  # CG stops at a relative residual of 1e-10 (1e-12 for k >= 2)
        assert _close(x, r.values, np.ptp(vals), tol), (name, k, solver)
        if k == 1:  # the harmonic fill itself, a third route
            assert _close(harmonic(V, F, idx, vals, solver=solver), r.values, np.ptp(vals), tol), name


def test_one_solver_policy():
    """The methods and PolyharmonicSolver choose the same backend, and k = 1 is the harmonic fill's choice."""
    V, F = icosphere(3)
    idx = np.arange(0, len(V), 9)
    for k in (1, 2, 3):
        s = PolyharmonicSolver(V, F, idx, k=k)
        r = manifill.reconstruct(V, F, idx, V[idx, 0], method=["harmonic", "biharmonic", "triharmonic"][k - 1],
                                 check=False)
        assert s.report["solver"] == r.report["fill"]["solver"]
    assert PolyharmonicSolver(V, F, idx, k=1).report["solver"] == HarmonicSolver(V, F, idx).report["solver"]


def test_scale_does_not_change_the_energy_route():
    """At any unit, the two routes give the same field (the scaling is exact)."""
    V, F = icosphere(2)
    idx = np.arange(0, len(V), 7)
    vals = V[idx, 1] ** 2
    for s in (1e-6, 1.0, 3e5):
        x = biharmonic(V * s, F, idx, vals)
        r = manifill.reconstruct(V * s, F, idx, vals, method="biharmonic", check=False)
        assert _close(x, r.values, np.ptp(vals)), s


@pytest.mark.skipif(not HAVE_TETGEN, reason="tetgen is not installed")
@pytest.mark.parametrize("solver", ["direct", "amg"])
def test_tetrahedra_one_harmonic_fill(solver):
    """``harmonic(V, T)`` and the solid's ``tet_fill`` are the same solve."""
    from manifill.solid.tetrahedralize import tetrahedralize

    TV, TT = tetrahedralize(*icosphere(2))
    idx = np.arange(0, len(TV), 5)
    vals = np.cos(2 * TV[idx, 0]) * TV[idx, 1]
    for s in (1.0, 1e-4):
        a = harmonic(TV * s, TT, idx, vals, solver=solver)
        b = manifill.tet_fill(TV * s, TT, idx, vals, solver=solver)
        assert _close(a, b, np.ptp(vals))
