"""The Hessian energy of a triangle mesh: the squared Hessian, with natural boundary conditions that keep linear
functions.

The biharmonic energy ``|Delta u|^2`` has natural boundary conditions that bend a field at a
surface's boundary (a scalp's rim, a helmet's edge, a scan's hole): its minimiser from scattered
samples is not exact on linear functions there. The Hessian energy ``|Hess u|^2_F`` (Stein,
Grinspun, Wardetzky, Jacobson, *Natural boundary conditions for smoothing in geometry
processing*, 2018) equals it on closed surfaces up to curvature terms and vanishes on every
linear function of a flat mesh, boundary or not, so its fill reproduces linear fields exactly.

Discretisation (mixed finite elements, as libigl's ``hessian_energy``): ``G`` the per-triangle
gradient of piecewise-linear fields (:func:`manifill.mesh.gradients.gradient_operator`), ``A``
the triangles' areas; for each pair of ambient axes ``(i, j)`` the weak second derivative
``D_ij = G_i^T A G_j`` (``n x n``); the energy ``Q = sum_ij D_ij^T M_int^+ D_ij`` with ``M_int``
the Voronoi mass of the interior vertices (boundary vertices carry no Hessian: 0 in ``M_int^+``).

:func:`curved_hessian_energy` is the energy of Stein, Jacobson, Wardetzky, Grinspun (*A smoothness
energy without boundary distortion for curved surfaces*, 2020), which measures the covariant
Hessian of a curved surface; it is libigl's ``curved_hessian_energy`` (the ``[hessian]`` extra).
"""

import numpy as np
import scipy.sparse as sp

from ..errors import MeshError
from .gradients import gradient_operator
from .laplacian import mass_matrix
from .topology import boundary_loops

__all__ = ["hessian_energy", "curved_hessian_energy"]


def hessian_energy(V, F):
    """The Hessian energy matrix ``Q`` (n x n, symmetric positive semi-definite) of a triangle mesh.

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions (validated; any unit: ``Q`` scales as ``1 / length^2``).
    F : (m, 3) numpy array of int
        Triangles.

    Returns
    -------
    (n, n) scipy.sparse.csr_array
        ``x^T Q x`` is the discrete integral of the squared Frobenius norm of the Hessian of ``x``; it
        vanishes on the linear functions of a flat mesh (and on constants on any mesh). Equal to libigl's
        ``hessian_energy`` where every vertex has a Hessian; a vertex without one (a grid's corner) gets a
        term that extrapolates it linearly from its neighbours (see ``_anchored``), so the minimiser is unique.

    Raises
    ------
    MeshError
        An interior vertex with zero area around it.

    Examples
    --------
    >>> from manifill.mesh.shapes import grid
    >>> V, F = grid(6)
    >>> Q = hessian_energy(V, F)
    >>> bool(abs(Q @ (2 * V[:, 0] - V[:, 1] + 3)).max() < 1e-12)
    True
    """
    V = np.asarray(V, dtype=np.float64)
    n = len(V)
    G, area = gradient_operator(V, F)
    G = sp.csr_array(G)
    rows = [sp.csr_array(G[i::3]) for i in range(3)]  # (m, n) per ambient axis
    Aw = sp.diags_array(area)
    m = mass_matrix(V, F).diagonal().copy()
    interior = np.zeros(n, dtype=bool)
    interior[np.asarray(F).ravel()] = True
    for loop in boundary_loops(np.asarray(F)):
        interior[loop] = False
    m[~interior] = 0.0
    inner = m > 0
    if (interior & ~inner).any():
        v = int(np.flatnonzero(interior & ~inner)[0])
        raise MeshError(f"interior vertex {v} has zero area around it, so the Hessian energy is undefined there; "
                        f"remove degenerate faces")
    Minv = sp.diags_array(np.divide(1.0, m, out=np.zeros(n), where=inner))
    Q = sp.csr_array((n, n))
    for i in range(3):
        AGi = Aw @ rows[i]
        for j in range(3):
            D = sp.csr_array(AGi.T @ rows[j])  # the weak second derivative d_i d_j (D_ji is its transpose)
            Q = Q + D.T @ Minv @ D
    return _anchored(Q, V, F)


def _anchored(Q, V, F):
    """``Q`` made definite at the vertices it leaves free, without losing the linear functions.

    A vertex none of whose triangles touches an interior vertex (the corner of a grid, a boundary ear) has no
    Hessian at all: its value would be undetermined. Each such vertex ``v`` gets the term
    ``s (x_v - l(x))^2``, ``l`` the linear extrapolation to ``v`` from a neighbouring triangle that does not
    contain it (its barycentric coordinates, negative outside), ``s`` the mean diagonal of ``Q``: zero on every
    linear field, so the fill stays exact on them, and the system has a unique minimiser.
    """
    Q = sp.csr_array((Q + Q.T) * 0.5)
    Q.sum_duplicates()
    d = Q.diagonal()
    F = np.asarray(F, dtype=np.int64)
    used = np.zeros(len(V), dtype=bool)
    used[F.ravel()] = True
    loose = np.flatnonzero(used & (d <= 1e-12 * max(d.max(initial=0.0), 1e-300)))
    if loose.size:
        rows, cols, vals = [], [], []
        faces_of = [[] for _ in range(len(V))]
        for t, f in enumerate(F.tolist()):
            for v in f:
                faces_of[v].append(t)
        for r, v in enumerate(loose.tolist()):
            near = {u for t in faces_of[v] for u in F[t].tolist() if u != v}
            cand = [t for u in near for t in faces_of[u] if v not in F[t]]
            if not cand:
                continue  # a lone triangle: nothing to extrapolate from (the component has no Hessian at all)
            tri = F[cand[0]]
            a, b, c = V[tri]
            e1, e2, p = b - a, c - a, V[v] - a
            G = np.array([[e1 @ e1, e1 @ e2], [e1 @ e2, e2 @ e2]])
            w1, w2 = np.linalg.solve(G, [p @ e1, p @ e2])
            rows += [r] * 4
            cols += [v, *tri.tolist()]
            vals += [1.0, -(1.0 - w1 - w2), -w1, -w2]
        R = sp.csr_array((vals, (rows, cols)), shape=(loose.size, len(V)))
        Q = sp.csr_array(Q + d.mean() * (R.T @ R))
    Q.sum_duplicates()
    Q.sort_indices()
    return Q


def curved_hessian_energy(V, F):
    """The Hessian energy of a curved surface (libigl's ``curved_hessian_energy``; the ``[hessian]`` extra).

    Parameters
    ----------
    V : (n, 3) numpy array
        Vertex positions.
    F : (m, 3) numpy array of int
        Triangles.

    Returns
    -------
    (n, n) scipy.sparse.csr_array
        Symmetric positive semi-definite; constants in its null space.

    Raises
    ------
    ImportError
        libigl is not installed (the message names the extra).
    """
    try:
        import igl
    except ImportError:
        raise ImportError("hessian='curved' needs libigl: pip install 'manifill[hessian]'") from None
    V = np.ascontiguousarray(V, dtype=np.float64)
    return _anchored(sp.csr_array(igl.curved_hessian_energy(V, np.ascontiguousarray(F, dtype=np.int64))), V, F)
