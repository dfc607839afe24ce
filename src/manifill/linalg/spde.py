"""Matérn Gaussian fields on a mesh through the SPDE ``(kappa^2 - Delta)^(alpha/2) u = W / tau``.

With the finite-element stiffness ``G`` (a cotangent Laplacian, a tet stiffness, a voxel
Laplacian) and the lumped mass ``C`` (diagonal) of a domain of dimension ``d``, the
weak solution's precision is (Lindgren, Rue & Lindström 2011)

    alpha = 1:  Q = tau^2 K,             K = kappa^2 C + G
    alpha = 2:  Q = tau^2 K C^-1 K.

This module builds ``Q / tau^2`` (the *shape*: manifill fits the scale ``1 / tau^2`` in
closed form), a root ``B`` with ``B' B = Q / tau^2`` for sampling (``B = C^-1/2 K`` for
``alpha = 2``; ``[grad root of G; kappa C^1/2]`` for ``alpha = 1``), the covariance of the
field at observation rows, and the map between ``(kappa, tau)`` and the parameters users
give: the range ``rho = sqrt(8 nu) / kappa`` (correlation near 0.13 there) and the
marginal standard deviation

    sigma^2 = Gamma(nu) / (Gamma(alpha) (4 pi)^(d/2) kappa^(2 nu) tau^2),   nu = alpha - d/2.

For ``nu <= 0`` (``alpha = 1`` on surfaces and in solids) the continuum field has no
finite variance: the range is then ``1 / kappa`` and ``sigma`` is not defined (the
mesh's variance grows as it is refined); manifill fits the scale only.
"""

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import OptionError

__all__ = ["ALPHAS", "MaternShape", "nu", "kappa_from_range", "range_from_kappa", "sigma_from_tau",
           "tau_from_sigma"]

#: The SPDE orders built here.
ALPHAS = (1, 2)


def nu(alpha, d):
    """The Matérn smoothness ``nu = alpha - d / 2`` of the SPDE of order ``alpha`` in dimension ``d``."""
    return alpha - d / 2.0


def kappa_from_range(rho, alpha, d):
    """``kappa = sqrt(8 nu) / rho`` (``1 / rho`` where ``nu <= 0``).

    Examples
    --------
    >>> round(kappa_from_range(2.0, 2, 2), 6)
    1.414214
    """
    v = nu(alpha, d)
    return (math.sqrt(8.0 * v) if v > 0 else 1.0) / float(rho)


def range_from_kappa(kappa, alpha, d):
    """The inverse of :func:`kappa_from_range`."""
    v = nu(alpha, d)
    return (math.sqrt(8.0 * v) if v > 0 else 1.0) / float(kappa)


def _variance_factor(kappa, alpha, d):
    v = nu(alpha, d)
    return math.gamma(v) / (math.gamma(alpha) * (4.0 * math.pi) ** (d / 2.0) * kappa ** (2.0 * v))


def sigma_from_tau(tau, kappa, alpha, d):
    """The continuum marginal standard deviation, or None where ``nu <= 0``.

    Examples
    --------
    >>> round(sigma_from_tau(1.0, 1.0, 2, 2) ** 2 * 4 * math.pi, 12)
    1.0
    """
    if nu(alpha, d) <= 0:
        return None
    return math.sqrt(_variance_factor(kappa, alpha, d)) / float(tau)


def tau_from_sigma(sigma, kappa, alpha, d):
    """The inverse of :func:`sigma_from_tau` (``nu > 0`` only)."""
    if nu(alpha, d) <= 0:
        raise OptionError(f"sigma= needs a field with a finite variance, and alpha={alpha} in dimension {d} has "
                          f"none (it grows as the mesh is refined); pass alpha=2 or leave sigma='auto'")
    return math.sqrt(_variance_factor(kappa, alpha, d)) / float(sigma)


@dataclass
class MaternShape:
    """The precision shape ``Q / tau^2`` of the Matérn SPDE on one domain.

    Parameters
    ----------
    G : (n, n) scipy sparse matrix
        Stiffness (symmetric positive semi-definite).
    c : (n,) numpy array
        Lumped mass (the diagonal of ``C``), ``> 0``.
    root : (r, n) scipy sparse matrix
        ``B_G`` with ``B_G' B_G = G`` (:mod:`manifill.mesh.roots`).
    alpha : {1, 2}
    d : int
        The domain's dimension (2 for surfaces, 3 for solids).
    c_mid : (n,) numpy array, optional
        The white noise's lumped mass where it differs from ``c`` (Bakka's barrier model: the barrier
        faces' part scaled by the squared range fraction): ``Q / tau^2 = K diag(c_mid)^-1 K``.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> from manifill.mesh.laplacian import laplacian, mass_matrix
    >>> from manifill.mesh.roots import gradient_root
    >>> V, F = icosphere(2)
    >>> m = MaternShape(laplacian(V, F), mass_matrix(V, F, mass="barycentric").diagonal(), gradient_root(V, F), 2, 2)
    >>> B, Q = m.root(3.0), m.precision(3.0)
    >>> bool(abs(B.T @ B - Q).max() < 1e-9 * abs(Q).max())
    True
    """

    G: object
    c: np.ndarray
    root_G: object
    alpha: int
    d: int
    c_mid: np.ndarray | None = None

    def __post_init__(self):
        if self.alpha not in ALPHAS:
            raise OptionError(f"alpha={self.alpha!r} is not one of {ALPHAS}; pass alpha=1 or alpha=2")
        self.G = sp.csr_array(self.G)
        self.c = np.asarray(self.c, dtype=np.float64)
        self.mid = self.c if self.c_mid is None else np.asarray(self.c_mid, dtype=np.float64)

    @property
    def n(self):
        """Number of nodes."""
        return self.G.shape[0]

    def K(self, kappa):
        """``kappa^2 C + G`` (CSR)."""
        return sp.csr_array(self.G + sp.diags_array(kappa * kappa * self.c))

    def precision(self, kappa):
        """``Q / tau^2``: ``K`` for ``alpha = 1``, ``K C^-1 K`` for ``alpha = 2`` (CSR, sorted)."""
        K = self.K(kappa)
        Q = K if self.alpha == 1 else sp.csr_array(K @ sp.diags_array(1.0 / self.mid) @ K)
        Q = sp.csr_array((Q + Q.T) * 0.5)
        Q.sort_indices()
        return Q

    def dprecision(self, kappa):
        """``d(Q / tau^2) / d kappa``: ``2 kappa C`` for ``alpha = 1``, ``4 kappa K`` for ``alpha = 2`` (CSR)."""
        if self.alpha == 1:
            return sp.csr_array(sp.diags_array(2.0 * kappa * self.c))
        if self.c_mid is not None:  # d(K M^-1 K) = dK M^-1 K + K M^-1 dK, dK = 2 kappa C
            half = sp.csr_array(sp.diags_array(2.0 * kappa * self.c / self.mid) @ self.K(kappa))
            return sp.csr_array(half + half.T)
        return sp.csr_array(4.0 * kappa * self.K(kappa))

    def root(self, kappa):
        """``B`` with ``B' B = Q / tau^2``."""
        if self.alpha == 2:
            return sp.csr_array(sp.diags_array(1.0 / np.sqrt(self.mid)) @ self.K(kappa))
        return sp.csr_array(sp.vstack([sp.csr_array(self.root_G), sp.diags_array(kappa * np.sqrt(self.c))]))

    def covariance_at(self, kappa, H, factor):
        """``H (Q / tau^2)^-1 H'`` (dense ``m x m``) with ``factor.solve`` a factorisation of :meth:`K`.

        One solve with ``K`` per row of ``H``: ``alpha = 1``: ``H K^-1 H'``; ``alpha = 2``:
        ``W' C W`` with ``W = K^-1 H'``.
        """
        Ht = np.asarray(sp.csr_array(H).T.toarray())
        W = factor.solve(Ht)
        R = (Ht.T @ W) if self.alpha == 1 else (W.T @ (self.mid[:, None] * W))
        return (R + R.T) * 0.5
