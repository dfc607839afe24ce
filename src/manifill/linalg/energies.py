"""Energy matrices built from a stiffness and a lumped mass, for any domain (surface, tetrahedra, graph).

The k-harmonic (polyharmonic) energy of a field ``x`` is ``x^T A x`` with

    A = L (M^-1 L)^(k-1),

``L`` a symmetric positive semi-definite stiffness (a Laplacian, ``L = D - W``)
and ``M`` a lumped (diagonal, positive) mass matrix: ``M^-1 L`` is the pointwise
Laplace-Beltrami operator, so for ``k = 2`` this is ``|| M^-1 L x ||_M^2``, the
discrete integral of the squared Laplacian (the biharmonic energy), and for
``k = 3`` the Dirichlet energy of the Laplacian. ``k = 1`` is ``L`` itself. This
is the matrix libigl's ``igl::harmonic(L, M, b, bc, k)`` minimises (libigl's
``L`` is negative semi-definite: its ``Q`` is ``(-L) (M^-1 (-L))^(k-1)``, this ``A``).
"""

import numpy as np
import scipy.sparse as sp

from ..errors import MeshError, OptionError
from ..validate import as_laplacian

__all__ = ["polyharmonic_energy", "polyharmonic"]


def polyharmonic_energy(L, M, k=2):
    """The k-harmonic energy matrix ``A = L (M^-1 L)^(k-1)``, symmetric positive semi-definite.

    Parameters
    ----------
    L : (n, n) scipy sparse matrix
        Symmetric positive semi-definite stiffness (e.g.
        :func:`manifill.mesh.laplacian.laplacian` or
        :func:`manifill.mesh.tetmesh.tet_laplacian`).
    M : (n, n) scipy sparse matrix or (n,) array_like
        The lumped mass (e.g. :func:`manifill.mesh.laplacian.mass_matrix`, whose
        ``mass`` keyword picks it): a diagonal matrix or its diagonal, non-negative. A
        vertex of zero mass (used by no face) must have an empty row of ``L``;
        its ``M^-1`` is taken as 0.
    k : int, optional
        The order: 1 (``L``), 2 (biharmonic), 3 (triharmonic), ...

    Returns
    -------
    (n, n) scipy.sparse.csr_array
        ``A``, exactly symmetric (the mean of the product and its transpose),
        with sorted indices. Constants are in its null space, as in ``L``'s.
        Its pattern is the ``k``-ring of ``L``'s graph, so it is symmetric.

    Raises
    ------
    MeshError
        ``L`` not a square sparse matrix of finite numbers, ``M`` not of size
        ``n`` or negative or not finite, or a vertex of zero mass with a
        non-zero stiffness row.
    OptionError
        ``k`` not a positive integer.

    See Also
    --------
    manifill.surface.polyharmonic.biharmonic : this energy on a mesh, solved with fixed values.
    manifill.linalg.quadratic.QuadraticSolver : its minimiser with fixed values.

    Examples
    --------
    A path of 4 vertices, unit masses: ``A = L^2``.

    >>> L = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(4, 4)).tolil()
    >>> L[0, 0] = L[3, 3] = 1.0
    >>> polyharmonic_energy(L, np.ones(4)).toarray().tolist()
    [[2.0, -3.0, 1.0, 0.0], [-3.0, 6.0, -4.0, 1.0], [1.0, -4.0, 6.0, -3.0], [0.0, 1.0, -3.0, 2.0]]
    """
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise OptionError(f"k must be a positive integer (1 harmonic, 2 biharmonic, 3 triharmonic), not {k!r}")
    L = as_laplacian(L, what="L")
    n = L.shape[0]
    m = M.diagonal() if sp.issparse(M) else np.asarray(M, dtype=np.float64).ravel()
    if m.shape != (n,) or not np.isfinite(m).all() or (m < 0).any():
        raise MeshError(f"the mass M has {m.size} entries, or negative or infinite ones; pass {n} non-negative "
                        f"finite vertex masses (e.g. manifill.mesh.laplacian.mass_matrix)")
    inv = np.divide(1.0, m, out=np.zeros(n), where=m > 0)
    if k == 1:
        A = L.copy()
    else:
        massless = m <= 0
        if massless.any():
            rows = np.abs(L).sum(axis=1)
            bad = np.flatnonzero(massless & (np.asarray(rows).ravel() > 0))
            if bad.size:
                raise MeshError(f"vertex {int(bad[0])} has zero mass but non-zero stiffness ({bad.size} such); "
                                f"remove degenerate faces or pass positive masses")
        Mi = sp.diags_array(inv, format="csr")
        A = L
        for _ in range(k - 1):
            A = A @ (Mi @ L)
        A = sp.csr_array(A)
    A = sp.csr_array((A + A.T) * 0.5)
    A.sum_duplicates()
    A.sort_indices()
    return A


#: Short name of :func:`polyharmonic_energy` (``polyharmonic(L, M, k)``).
polyharmonic = polyharmonic_energy
