"""``method='gp'`` and ``uncertainty=True`` on a surface: a posterior mean with a standard deviation everywhere.

- :func:`reconstruct_gp`: the Matérn field of the SPDE ``(kappa^2 - Delta)^(alpha/2) u = W``
  on the mesh (the cotangent stiffness and the lumped barycentric mass,
  :mod:`manifill.linalg.spde`), hyperparameters fitted or given (:class:`manifill.GPOptions`),
  conditioned on the samples (vertices or points inside faces), with or without noise
  (:func:`manifill.linalg.gp.gp_condition`).
- :func:`energy_uncertainty`: the probabilistic reading of the energy methods. Harmonic
  interpolation is the conditional mean of the Gaussian free field (precision ``s^-2 L``),
  biharmonic of the field with precision ``s^-2 L M^-1 L``, triharmonic likewise; with
  ``smoothing`` the samples carry noise of variance ``s^2 lambda / w_i``. The scale ``s``
  is fitted to the samples (restricted likelihood), so the std is that of a field as rough
  as the samples say, with *no* range: far from every sample it keeps growing (the
  field has no mean to return to), unlike ``method='gp'``'s, which levels off at the prior
  standard deviation. The paper's pipeline has no such reading (its curve values are
  estimates, not a model), and ``uncertainty=True`` refuses it.
- :func:`trust_mask`: where the std exceeds ``trust`` times the samples' standard deviation,
  the value is not to be trusted: marked (``trusted`` is False) and, if asked, set NaN.
"""

import numpy as np
import scipy.sparse as sp

from ..errors import OptionError, SampleError
from ..linalg.energies import polyharmonic_energy
from ..linalg.gp import as_gp_options, gp_condition, intrinsic_std
from ..linalg.gpdraws import posterior_draws
from ..linalg.spde import MaternShape
from ..mesh.roots import edge_root, gradient_root, laplacian_root
from ..mesh.topology import pattern_components
from ..validate.scale import LOW_DECADES, check_size

__all__ = ["VARIANCE_OPTIONS", "gp_draws", "reconstruct_gp", "energy_uncertainty", "trust_mask"]

#: The ``gp=`` options an energy method's ``uncertainty=True`` takes (how its variance is computed).
VARIANCE_OPTIONS = ("variance", "samples", "seed")


def trust_mask(values, std, sample_vals, trust, untrusted="mask"):
    """``(values, trusted, threshold)``: ``trusted`` where ``std <= trust * sd(samples)`` for every field.

    Examples
    --------
    >>> v, ok, th = trust_mask(np.ones((3, 1)), np.array([[0.0], [0.5], [2.0]]), np.array([[0.0], [2.0]]), 1.0, "nan")
    >>> ok.tolist(), v[:, 0].tolist(), th
    ([True, True, False], [1.0, 1.0, nan], [1.0])
    """
    sd = np.std(sample_vals, axis=0)
    threshold = float(trust) * sd
    ok = np.all(std <= threshold[None, :], axis=1)
    if untrusted == "nan":
        values = values.copy()
        values[std > threshold[None, :]] = np.nan
    return values, ok, threshold.tolist()


def gp_draws(result, draws, seed=0):
    """``(n, p, draws)`` posterior draws of a ``method='gp'`` result on a triangle surface (its fitted model).

    The model is rebuilt from the result's mesh, samples' locations and reported hyperparameters
    (:func:`manifill.linalg.gp.posterior_draws`); the draws equal the samples where they were observed exactly.
    """
    from .points import point_samples
    from .surface import Surface

    rep = result.report["gp"]
    V, F = result.V, result.F
    surface = Surface.from_mesh(V, F, check=False) if result.cloud is None else Surface.from_points(
        V, neighbours=result.cloud.k, check=False)
    surface.barrier_faces = result.barrier_faces
    shape = _matern(surface, rep["alpha"], rep.get("barrier_range"))
    points = None
    if result.points is not None:
        located = result.points
        points = point_samples(V, F, located.points, np.zeros(len(located.points)), duplicates="mean",
                               located=located)
    oidx, rows, _ = _observations(points, result.idx, np.zeros((len(result.idx), 1)))
    X = np.asarray(result.values, dtype=np.float64).reshape(len(V), -1)
    return posterior_draws(shape, oidx, rows, X, rep, draws, seed)


def _matern(surface, alpha, fraction=None):
    """The Matérn shape on a mesh (the finite-element gradient as its root) or a point cloud (the edges'); with
    ``surface.barrier_faces``, Bakka's barrier model (those faces' range ``fraction`` times the field's)."""
    L = surface.laplacian("cotan")
    c = surface.mass("barycentric").diagonal()
    if surface.F is None:
        return MaternShape(L, c, edge_root(L), alpha, 2)
    V, F, bf = surface.V, surface.F, surface.barrier_faces
    root = gradient_root(V, F)
    if bf is None or fraction is None:
        return MaternShape(L, c, root, alpha, 2)
    # the SPDE u - div(r^2/8 grad u) = r W with r = fraction * range on the barrier faces: their stiffness and
    # their share of the noise's mass scaled by fraction^2 (the outer mass stays the whole lumped mass)
    w = np.where(bf, fraction ** 2, 1.0)
    root = sp.csr_array(sp.diags_array(np.repeat(np.sqrt(w), 3)) @ root)
    G = sp.csr_array(root.T @ root)
    area = np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1) / 2.0
    c_mid = np.bincount(F.ravel(), weights=np.repeat(w * area / 3.0, 3), minlength=len(V))
    return MaternShape(G, c, root, alpha, 2, c_mid=c_mid)


def _lengths(surface):
    V, F = surface.V, surface.F
    E = surface.cloud.E if F is None else np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    length = float(np.median(np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)))
    diameter = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    return length, diameter


def _observations(points, idx, vals):
    """``(vertex idx, barycentric rows or None, data in that order)``."""
    if points is None:
        return idx, None, vals
    if points.inside:
        return points.idx, points.Aeq, np.vstack([points.vals, points.beq])
    return points.idx, None, points.vals


def reconstruct_gp(surface, idx, vals, *, gp=None, weights="cotan", solver="auto", points=None, seconds=None,
                   with_std=True):
    """``(values, std, report)`` of ``method='gp'`` on a triangle Surface.

    Parameters
    ----------
    surface : Surface
    idx, vals
        Validated samples (the nearest vertices when ``points`` is given).
    gp : None, dict or GPOptions
    weights : {'cotan'}
        The finite-element stiffness; other weights are refused.
    solver : {'auto', 'direct', 'amg'}
    points : PointSamples, optional
    with_std : bool, optional
        False (``uncertainty=False``): the mean only, ``std`` None.

    Raises
    ------
    OptionError
        A digital surface, weights other than cotan, ``solver='iterate'``, bad ``gp`` options.
    """
    opts = as_gp_options(gp)
    if surface.mass is None:
        raise OptionError("method='gp' needs triangles (a mass matrix), and a digital surface has none; use the "
                          "voxel mask's own gp (manifill.solid.gp.gp_voxels) or a triangle mesh")
    if weights != "cotan":
        raise OptionError(f"method='gp' uses the finite-element (cotangent) stiffness, not weights={weights!r}; "
                          f"leave weights out")
    if solver == "iterate":
        raise OptionError("method='gp' solves with 'direct' or 'amg' (or 'auto'), not solver='iterate'")
    # the Matern operator's precision holds kappa^4, the inverse of a squared area
    check_size(surface.V, 4, "the surface", "squared areas (the gp's precision divides by them)",
               "give the positions in other units", decades=LOW_DECADES)
    V = surface.V
    bakka = surface.barrier_faces is not None
    shape = _matern(surface, opts.alpha, opts.barrier_range if bakka else None)
    length, diameter = _lengths(surface)
    oidx, rows, Y = _observations(points, idx, vals)
    where = V[oidx] if rows is None else np.vstack([V[oidx], sp.csr_array(rows) @ V])
    X, std, report = gp_condition(shape, oidx, rows, Y, opts, length=length, diameter=diameter, solver=solver,
                                  positions=where, with_std=with_std)
    if bakka:
        report["barrier"], report["barrier_range"] = "bakka", opts.barrier_range
        report["barrier_faces"] = int(np.count_nonzero(surface.barrier_faces))
    return X, std, report


def energy_uncertainty(surface, k, X, observed, *, weights="cotan", fill_report=None, sample_weights=None, gp=None,
                       solver="auto"):
    """``(std, report)`` of an energy method's result ``X`` read as an intrinsic Gaussian field.

    Parameters
    ----------
    surface : Surface
    k : {1, 2, 3}
        The energy's order.
    X : (n, p) numpy array
        The method's result (the conditional mean).
    observed : (idx, vals, points)
        The samples as the method got them (``points`` a PointSamples or None).
    weights : str, optional
        The Laplacian weights the method used.
    fill_report : dict, optional
        The fill's report (``smoothing`` gives lambda per field).
    sample_weights : (k,) array_like, optional
        The smoothing's weights.
    gp : GPOptions, optional
        How the variance is computed: ``variance``, ``samples``, ``seed`` (:class:`manifill.GPOptions`).
    solver : {'auto', 'direct', 'amg'}, optional
    """
    idx, vals, points = observed
    gp = as_gp_options(gp)
    fill_report = {} if fill_report is None else fill_report
    L = surface.laplacian(weights)
    root = laplacian_root(L, surface.V, surface.F if weights == "cotan" else None)
    if k == 1:
        Q, B = L, root
    else:
        M = surface.mass("voronoi", weights).diagonal()
        Q = polyharmonic_energy(L, sp.diags_array(M), k)
        ML = sp.csr_array(sp.diags_array(1.0 / M) @ L)
        B = sp.csr_array(sp.diags_array(1.0 / np.sqrt(M)) @ L) if k == 2 else (
            None if root is None else sp.csr_array(root @ ML))
    oidx, rows, Y = _observations(points, idx, vals)
    eta = None
    sm = fill_report.get("smoothing")
    if sm is not None:
        lam = np.atleast_1d(np.asarray(sm["lambda"], dtype=np.float64))
        if np.any(lam == 0):
            raise SampleError("uncertainty with smoothing=0 is interpolation; pass smoothing=None (or a "
                              "lambda > 0)")
        w = np.ones(Y.shape[0]) if sample_weights is None else np.asarray(sample_weights, dtype=np.float64)
        if lam.size > 1 and not np.all(lam == lam[0]):
            raise OptionError("uncertainty with smoothing='auto' and several fields needs one lambda for all "
                              "(their lambdas differ); reconstruct the fields one at a time")
        eta = lam[0] / w
    ncomp, labels = pattern_components(Q, symmetric=True)
    touched = labels[oidx] if rows is None else np.concatenate([labels[oidx], labels[rows.indices[rows.data != 0]]])
    anchored = np.bincount(touched, minlength=ncomp) > 0
    keep = np.flatnonzero(anchored[labels])
    std = np.full(X.shape, np.nan)  # a component without samples (on_empty='nan'): no value, no std
    if keep.size < Q.shape[0]:
        pos = np.full(Q.shape[0], -1, dtype=np.int64)
        pos[keep] = np.arange(keep.size)
        Q = sp.csr_array(Q)[keep][:, keep]
        if B is not None:  # the root's rows of the dropped components touch only them
            B = sp.csr_array(B)[:, keep]
            B = B[np.flatnonzero(np.diff(B.indptr))]
        oidx = pos[oidx]
        rows = None if rows is None else sp.csr_array(rows)[:, keep]
    sub, rep = intrinsic_std(Q, B, oidx, rows, Y, X[keep], eta=eta, how=gp.variance, samples=gp.samples,
                             seed=gp.seed, solver=solver, components=int(anchored.sum()))
    std[keep] = sub
    rep["energy"] = k
    return std, rep
