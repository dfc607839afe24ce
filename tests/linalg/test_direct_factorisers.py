"""solver='direct' factorises with SuperLU, or with Pardiso when pypardiso is installed: the same solutions."""

import numpy as np
import pytest
import scipy.sparse as sp

from manifill.linalg.backends import DIRECT_ENV, DirectSolver, direct_factoriser
from manifill.mesh.laplacian import laplacian
from manifill.mesh.shapes import icosphere

pypardiso = pytest.importorskip("pypardiso", reason="the [fast] extra (pypardiso) is not installed")


@pytest.fixture(autouse=True)
def any_size(monkeypatch):
    """These systems are small: let Pardiso take them all (its size floor is tested below)."""
    import manifill.linalg.factorise as fz

    monkeypatch.setattr(fz, "PARDISO_MIN", 0)


def test_small_systems_go_to_superlu(monkeypatch):
    import manifill.linalg.factorise as fz

    monkeypatch.setenv(DIRECT_ENV, "pardiso")
    monkeypatch.setattr(fz, "PARDISO_MIN", 1000)
    A = reduced_laplacian()
    assert A.shape[0] < 1000
    assert DirectSolver(A).factoriser == "superlu"
    monkeypatch.setattr(fz, "PARDISO_MIN", 100)
    assert DirectSolver(A).factoriser == "pardiso"


def reduced_laplacian():
    V, F = icosphere(3)
    L = sp.csr_matrix(laplacian(V, F))
    free = np.arange(5, len(V))
    return L[free][:, free]


def kkt():
    """A symmetric indefinite saddle-point system, as the equality rows of the solve core make."""
    A = reduced_laplacian()
    rng = np.random.default_rng(0)
    C = sp.random(4, A.shape[0], density=0.02, random_state=1, format="csr") + sp.eye(4, A.shape[0], k=3)
    return sp.bmat([[A, C.T], [C, None]], format="csr"), rng.standard_normal((A.shape[0] + 4, 3))


@pytest.mark.parametrize("system", ["spd", "kkt"])
def test_pardiso_and_superlu_give_the_same_solutions(system, monkeypatch):
    if system == "spd":
        A = reduced_laplacian()
        R = np.random.default_rng(2).standard_normal((A.shape[0], 2))
    else:
        A, R = kkt()
    out = {}
    for name in ("superlu", "pardiso"):
        monkeypatch.setenv(DIRECT_ENV, name)
        d = DirectSolver(A)
        assert d.factoriser == name
        X, _ = d.solve(R)
        assert np.linalg.norm(A @ X - R) <= 1e-10 * np.linalg.norm(R)  # a solution, not just an agreement
        out[name] = X
    np.testing.assert_allclose(out["pardiso"], out["superlu"], rtol=0, atol=1e-9 * np.abs(out["superlu"]).max())


def test_the_environment_forces_superlu(monkeypatch):
    monkeypatch.setenv(DIRECT_ENV, "superlu")
    assert direct_factoriser() == "superlu"
    monkeypatch.delenv(DIRECT_ENV)
    assert direct_factoriser() == "pardiso"


def test_a_singular_matrix_is_not_solved_by_perturbed_pivots(monkeypatch):
    """Pardiso perturbs zero pivots and returns a number; manifill hands such a matrix to SuperLU, which refuses it."""
    monkeypatch.setenv(DIRECT_ENV, "pardiso")
    A = sp.csr_matrix(np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 2.0]]))
    with pytest.raises(RuntimeError, match="singular"):
        DirectSolver(A)


def _resident_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096


@pytest.mark.skipif(not __import__("os").path.exists("/proc/self/statm"), reason="needs /proc (Linux)")
def test_pardiso_factors_are_freed_with_their_solver(monkeypatch):
    """Pardiso's factors live in MKL's memory: an active set making one factorisation per face must not keep them.

    Without the release, each factorisation of this system stayed resident (about 0.13 GB each at 41k vertices).
    """
    from manifill.linalg.energies import polyharmonic_energy
    from manifill.mesh.laplacian import mass_matrix

    monkeypatch.setenv(DIRECT_ENV, "pardiso")
    V, F = icosphere(5)
    Q = polyharmonic_energy(sp.csr_matrix(laplacian(V, F)), mass_matrix(V, F, mass="voronoi"), 2).tocsr()[5:, 5:]
    first = _resident_bytes()
    DirectSolver(Q).solve(np.ones(Q.shape[0]))
    one = max(_resident_bytes() - first, 1)
    start = _resident_bytes()
    for _ in range(6):
        DirectSolver(Q).solve(np.ones(Q.shape[0]))
    assert _resident_bytes() - start < 2 * one  # six more factorisations cost no more than about one


SPD_NAME = "pardiso (symmetric positive definite)"


@pytest.mark.parametrize("system", ["spd", "kkt", "nonsymmetric"])
def test_a_matrix_said_positive_definite_is_factorised_as_such_only_when_it_is(system, monkeypatch):
    """spd=True: Pardiso's Cholesky factor for an SPD matrix; a symmetric indefinite one (a KKT system) or one
    that is not symmetric goes to the general factorisation, and every one is solved."""
    monkeypatch.setenv(DIRECT_ENV, "pardiso")
    A = reduced_laplacian()
    R = np.random.default_rng(3).standard_normal((A.shape[0], 3))
    if system == "kkt":
        A, R = kkt()
    elif system == "nonsymmetric":
        A = (A + sp.eye(A.shape[0], k=1, format="csr") * 1e-3).tocsr()
    d = DirectSolver(A, spd=True)
    assert d.factoriser == (SPD_NAME if system == "spd" else "pardiso")
    X, _ = d.solve(R)
    assert np.linalg.norm(A @ X - R) <= 1e-10 * np.linalg.norm(R)


def test_the_cholesky_factor_gives_the_general_factors_solutions(monkeypatch):
    monkeypatch.setenv(DIRECT_ENV, "pardiso")
    A = reduced_laplacian()
    R = np.asfortranarray(np.random.default_rng(4).standard_normal((A.shape[0], 70)))
    X, _ = DirectSolver(A, spd=True).solve(R)
    Y, _ = DirectSolver(A).solve(R)
    np.testing.assert_allclose(X, Y, rtol=0, atol=1e-10 * np.abs(Y).max())


def test_many_fields_factorise_one_large_positive_definite_system_with_pardiso_only(monkeypatch):
    from manifill.linalg.backends import AUTO_DIRECT_FIELDS, auto_backend

    monkeypatch.setenv(DIRECT_ENV, "pardiso")
    many = AUTO_DIRECT_FIELDS
    assert auto_backend(100_000, 700_000, fields=many, spd=True) == "direct"
    assert auto_backend(100_000, 700_000, fields=many - 1, spd=True) == "amg"  # few fields: CG per field
    assert auto_backend(100_000, 700_000, fields=many) == "amg"  # not known SPD: SuperLU-sized fill-in rule
    monkeypatch.setenv(DIRECT_ENV, "superlu")
    assert auto_backend(100_000, 700_000, fields=many, spd=True) == "amg"
