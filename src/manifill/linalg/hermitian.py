"""Complex Hermitian positive definite systems: one factorisation, any number of right-hand sides.

The connection's energies (:mod:`manifill.vectors`) are complex Hermitian. Their real form (a ``2 x 2`` block
per entry) factorises too, but at twice the unknowns it costs more than twice the flops: at 163,842 vertices the
reduced vector biharmonic took 3.4x the scalar biharmonic's factorisation as a real symmetric matrix, 1.6x as a
complex Hermitian one (MKL's Pardiso, matrix type 4; measured side by side, docs/NOTES.md). :func:`factorise_hermitian`
takes, in order of measured speed: Pardiso's complex Hermitian Cholesky (the ``[fast]`` extra), CHOLMOD's complex
Cholesky (the ``[cholmod]`` extra), SciPy's SuperLU (complex LU, always there).
"""

import ctypes

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from .cholesky import cholmod_module
from .factorise import PARDISO_MIN, direct_factoriser, pardiso_module, pardiso_solver

__all__ = ["factorise_hermitian", "HermitianPardiso"]

#: Pardiso's matrix type of a complex Hermitian positive definite matrix.
HERMITIAN_PD = 4


class HermitianPardiso:
    """Pardiso's Cholesky factor of the upper triangle of a complex Hermitian positive definite ``A``.

    pypardiso passes real arrays only; its MKL entry point takes any data pointer, so the complex arrays go to it
    directly. The factor lives in MKL's memory and is freed with this object.
    """

    name = "pardiso (complex Hermitian)"

    def __init__(self, A):
        U = sp.triu(sp.csr_matrix(A), format="csr")
        U.sort_indices()
        self.n = U.shape[0]
        self._data = np.ascontiguousarray(U.data, dtype=np.complex128)
        self._ia = U.indptr.astype(np.int32) + 1
        self._ja = U.indices.astype(np.int32) + 1
        self._solver = pardiso_solver(pardiso_module())
        for i, v in ((1, 1), (2, 2), (10, 13), (11, 0), (13, 0)):  # own iparm; METIS order; no scaling
            self._solver.set_iparm(i, v)
        self._call(12, np.zeros((self.n, 1), dtype=np.complex128, order="F"))

    def _call(self, phase, B):
        s = self._solver
        X = np.zeros_like(B)
        err = ctypes.c_int32(0)
        i32 = ctypes.POINTER(ctypes.c_int32)

        def ref(v):
            return ctypes.byref(ctypes.c_int32(v))

        s._mkl_pardiso(s.pt.ctypes.data_as(ctypes.POINTER(s._pt_type[0])), ref(1), ref(1), ref(HERMITIAN_PD),
                       ref(phase), ref(self.n), self._data.ctypes.data_as(ctypes.c_void_p),
                       self._ia.ctypes.data_as(i32), self._ja.ctypes.data_as(i32), s.perm.ctypes.data_as(i32),
                       ref(B.shape[1]), s.iparm.ctypes.data_as(i32), ref(0), B.ctypes.data_as(ctypes.c_void_p),
                       X.ctypes.data_as(ctypes.c_void_p), ctypes.byref(err))
        if err.value != 0:
            raise np.linalg.LinAlgError(f"Pardiso's complex Hermitian factorisation failed (error {err.value})")
        return X

    def solve(self, B):
        B = np.asarray(B)
        flat = np.asfortranarray(B.reshape(self.n, -1), dtype=np.complex128)
        return self._call(33, flat).reshape(B.shape)

    def __del__(self):
        try:
            self._solver.free_memory(everything=True)
        except Exception:  # interpreter shutdown
            pass


class _Wrapped:
    def __init__(self, name, solve):
        self.name, self._solve = name, solve

    def solve(self, B):
        return self._solve(np.asarray(B, dtype=np.complex128))


def factorise_hermitian(A):
    """A factorisation of the complex Hermitian positive definite sparse ``A`` with ``name`` and ``solve(B)``.

    Examples
    --------
    >>> A = sp.csr_matrix(np.array([[2.0, 1j], [-1j, 2.0]]))
    >>> f = factorise_hermitian(A)
    >>> np.allclose(A @ f.solve(np.array([1.0, 1j])), [1.0, 1j])
    True
    """
    A = sp.csr_matrix(A, dtype=np.complex128)
    if A.shape[0] >= PARDISO_MIN and direct_factoriser() == "pardiso":
        try:
            return HermitianPardiso(A)
        except np.linalg.LinAlgError:  # not positive definite to Pardiso: the general factorisations below
            pass
    cholmod = cholmod_module()
    if cholmod is not None:
        try:
            f = cholmod.cholesky(sp.csc_matrix(A))
            return _Wrapped("cholmod (complex)", f.solve_A)
        except Exception:  # CHOLMOD's NotPositiveDefiniteError, or a build without complex support
            pass
    try:  # symmetric mode, pivots on the diagonal: 3x faster than the general LU on the connection's energies
        lu = splu(sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                  options={"SymmetricMode": True})
    except RuntimeError:  # a zero pivot: the general LU
        lu = splu(sp.csc_matrix(A))
    return _Wrapped("superlu (complex)", lu.solve)
