"""The sparse factorisation behind ``solver='direct'``: SciPy's SuperLU, or Intel MKL's Pardiso when installed.

:func:`factorise` returns an object with ``solve(B)`` (SuperLU's interface) and the
name of what factorised; :class:`manifill.linalg.backends.DirectSolver` uses it.
Pardiso comes from the optional ``pypardiso`` (the ``[fast]`` extra, pip only, x86-64).
"""

import contextlib
import importlib.metadata
import os

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..errors import OptionError
from ..tolerances import TOL
from .cholesky import cholesky

__all__ = ["DIRECT_ENV", "PARDISO_MIN", "direct_factoriser", "PardisoFactor", "factorise", "pardiso_module",
           "pardiso_solver"]

#: Smallest system Pardiso factorises: below it SuperLU is faster (measured on sphere Laplacians,
#: factorisation and one solve: 3.3 / 77 ms at 642 unknowns, 16 / 27 ms at 2,562, 110 / 66 ms at 10,242).
PARDISO_MIN = 5_000

#: Environment variable naming the factorisation of ``solver='direct'``: ``superlu`` or ``pardiso``
#: (default: ``pardiso`` when the optional ``pypardiso`` is installed, the ``[fast]`` extra).
DIRECT_ENV = "MANIFILL_DIRECT"


def direct_factoriser():
    """The sparse factorisation ``solver='direct'`` uses: ``'pardiso'`` if pypardiso imports, else ``'superlu'``.

    Measured (docs/NOTES.md, 2026-12-01): Intel MKL's Pardiso through pypardiso factorises the
    reduced bilaplacian of a 41k-vertex sphere about 4x faster than SuperLU, with the same values to
    1e-11. ``MANIFILL_DIRECT=superlu`` forces SciPy's SuperLU.

    Examples
    --------
    >>> direct_factoriser() in ("pardiso", "superlu")
    True
    """
    want = os.environ.get(DIRECT_ENV, "").strip().lower()
    if want == "superlu":
        return "superlu"
    try:
        pardiso_module()
    except ImportError:
        return "superlu"
    return "pardiso"


class PardisoFactor:
    """``solve(B)`` with a Pardiso factorisation kept by its solver object (the SuperLU interface).

    Pardiso keeps its factors in MKL's memory, outside Python's: they are freed when this
    object goes (an active set builds one factorisation per face; without this, every one
    of them stayed: 21 GB after 30 faces at 41k vertices).
    """

    def __init__(self, solver, A):
        self._solver, self._A = solver, A

    def __del__(self):
        try:
            self._solver.free_memory(everything=True)
        except Exception:  # interpreter shutdown: nothing left to free into
            pass

    def solve(self, B):
        X = self._solver.solve(self._A, np.asarray(B, dtype=np.float64))  # Fortran order passes as is
        return np.asarray(X, dtype=np.float64).reshape(np.shape(B))


_MKL_RT: list = []  # MKL's library, as the installed ``mkl`` package lists it (None: pypardiso searches for it)


def _mkl_rt():
    """The path of MKL's ``mkl_rt`` from the installed ``mkl`` package's file list, or None (then pypardiso
    searches its install tree: 0.35-0.6 s, measured, the first time in every process)."""
    try:
        files = importlib.metadata.files("mkl") or []
    except importlib.metadata.PackageNotFoundError:
        return None
    found = sorted((str(f.locate()) for f in files if "mkl_rt" in f.name), key=len)
    return next((path for path in found if os.path.exists(path)), None)


@contextlib.contextmanager
def _mkl_named():
    """``PYPARDISO_MKL_RT`` set to MKL's library while pypardiso looks for it (unless the user set it): its import
    and every new solver search the install tree when ``find_library`` fails (0.24 s each, measured)."""
    if not _MKL_RT:
        _MKL_RT.append(_mkl_rt())
    given = os.environ.get("PYPARDISO_MKL_RT") is not None
    if _MKL_RT[0] and not given:
        os.environ["PYPARDISO_MKL_RT"] = _MKL_RT[0]
    try:
        yield
    finally:
        if not given:
            os.environ.pop("PYPARDISO_MKL_RT", None)


def pardiso_module():
    """``import pypardiso``, with MKL's library named for it (its import builds a solver)."""
    with _mkl_named():
        import pypardiso
    return pypardiso


def pardiso_solver(pypardiso):
    """A new ``PyPardisoSolver``, with MKL's library named."""
    with _mkl_named():
        return pypardiso.PyPardisoSolver()


def factorise(A, factoriser=None, spd=False):
    """``(name, factor)``: the factorisation of the square sparse ``A``, with ``factor.solve(B)``.

    ``factoriser='cholesky'`` (``A`` symmetric positive definite) gives the sparse Cholesky factor
    (:class:`manifill.linalg.cholesky.Factor`: CHOLMOD's where the ``[cholmod]`` extra is installed, else
    SuperLU's in symmetric mode) that a selected inversion reads: the gp's mean and exact variance share it.

    ``factoriser='superlu'`` always takes SuperLU (the many-fields fill does: on the pipeline's small
    patches at 163k vertices it factorised in 0.9 s against Pardiso's 3.1 s and solved in 10-20 ms per
    right-hand side against 100-250 ms, measured side by side). Otherwise
    Pardiso when :func:`direct_factoriser` says so (or ``factoriser='pardiso'``) and ``A`` has at least
    :data:`PARDISO_MIN` rows, unless it had to perturb pivots (a
    singular or nearly singular ``A``): then SuperLU, which raises ``RuntimeError``
    ("exactly singular") where ``A`` is singular, as it always did.

    ``spd=True`` (the caller knows ``A`` symmetric positive definite: an energy's reduced
    matrix) lets Pardiso factorise its upper triangle as such (a Cholesky factor), when ``A``
    is symmetric to rounding; at 163k unknowns it solved 200 right-hand sides in 0.58x the
    time of the general factorisation (1.25 s + 30.6 ms per column against 1.43 s + 52.4 ms,
    measured side by side). Where Pardiso finds ``A`` is not positive definite after all,
    the general factorisation runs instead (name ``pardiso``, then as above).

    Examples
    --------
    >>> name, f = factorise(sp.csr_matrix(np.diag([2.0, 4.0])))
    >>> f.solve(np.array([2.0, 4.0])).tolist()
    [1.0, 1.0]
    """
    if factoriser not in (None, "superlu", "pardiso", "cholesky"):
        raise OptionError(f"factoriser={factoriser!r} is not 'superlu', 'pardiso' or 'cholesky'; pass one, or None")
    if factoriser == "cholesky":
        f = cholesky(A)
        return f"{f.name} (Cholesky)", f
    want = direct_factoriser() if factoriser is None else factoriser
    if want == "pardiso" and direct_factoriser() == "pardiso" and A.shape[0] >= PARDISO_MIN:
        pypardiso = pardiso_module()
        A = sp.csr_matrix(A)
        A.sort_indices()
        if spd and _symmetric(A):
            got = _cholesky(pypardiso, A)
            if got is not None:
                return "pardiso (symmetric positive definite)", got
        solver = pardiso_solver(pypardiso)  # real non-symmetric: also the KKT systems
        solver.factorize(A)
        perturbed = int(solver.get_iparms().get(14, 0))  # iparm(14): pivots Pardiso had to perturb
        if not perturbed:
            return "pardiso", PardisoFactor(solver, A)
        solver.free_memory(everything=True)
        return f"superlu (Pardiso perturbed {perturbed} pivots)", splu(sp.csc_matrix(A))
    return "superlu", splu(sp.csc_matrix(A))


def _symmetric(A):
    """Whether the CSR ``A`` equals its transpose to rounding (``TOL.energy_symmetry`` of its largest entry)."""
    D = (A - A.T).tocsr()
    big = float(np.abs(A.data).max()) if A.nnz else 0.0
    return D.nnz == 0 or float(np.abs(D.data).max()) <= TOL.energy_symmetry * big


def _cholesky(pypardiso, A):
    """A :class:`PardisoFactor` of the upper triangle of ``A`` as real symmetric positive definite, or ``None``
    when Pardiso finds it is not (a zero or negative pivot)."""
    U = sp.triu(A, format="csr")
    U.sort_indices()
    solver = pardiso_solver(pypardiso)
    solver.set_matrix_type(2)  # real symmetric positive definite
    try:
        solver.factorize(U)
    except (pypardiso.pardiso_wrapper.PyPardisoError, ValueError):  # ValueError: an empty row (a zero block)
        solver.free_memory(everything=True)
        return None
    return PardisoFactor(solver, U)
