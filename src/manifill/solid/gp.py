"""``method='gp'`` in a solid: the Matérn field over the whole tets or voxels, with a std everywhere.

The field of the SPDE ``(kappa^2 - Delta)^(alpha/2) u = W`` is built on the solid itself
(:class:`manifill.linalg.spde.MaternShape` in dimension 3) and conditioned on samples
anywhere in it (:func:`manifill.linalg.gp.gp_condition`), as :func:`manifill.surface.gp.reconstruct_gp`
does on a surface; there is no surface pass and no harmonic fill.

- :func:`gp_tets`: the P1 finite elements of a tetrahedral mesh: the cotan stiffness
  :func:`~manifill.mesh.tetmesh.tet_laplacian`, the lumped mass
  :func:`~manifill.mesh.tetmesh.tet_mass_matrix` and the gradient root
  :func:`~manifill.mesh.tetmesh.tet_gradient_root`.
- :func:`gp_voxels`: the voxel Laplacian (:func:`~manifill.solid.voxels.voxel_laplacian`,
  ``-Delta`` in units of ``1 / length^2``) times the voxel volume, i.e. the stiffness in
  physical units (``h`` per face on a cubic grid of side ``h``), the mass the voxel volume
  per voxel, the root one row per neighbour pair (:func:`~manifill.mesh.roots.edge_root`).
  Scaling the spacing and the range by ``s`` leaves the values and the std as they are.
- :func:`volume_gp`: ``reconstruct_volume(V, F, ..., method='gp')``: the solid voxelised or
  tetrahedralised, the surface samples put on its nodes.
- :func:`split_gp_options`: the gp options of the ``reconstruct_volume`` functions, refused with other methods.
"""

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ..errors import OptionError
from ..linalg.gp import GPOptions, as_gp_options, gp_condition
from ..linalg.gpdraws import posterior_draws
from ..linalg.spde import MaternShape
from ..mesh.roots import edge_root
from ..surface.gp import trust_mask
from ..surface.methods.registry import configure, method_of
from ..validate import as_mask, as_origin, as_samples, as_spacing, as_tets, as_voxels
from ..mesh.tetmesh import tet_gradient_root, tet_laplacian, tet_mass_matrix
from .boundary import boundary_voxels
from .tetrahedralize import tetrahedralize
from .volume_result import VolumeReconstruction
from .voxelize import voxelize
from .voxels import as_connectivity, stencil_weights, voxel_centres, voxel_laplacian

__all__ = ["GP_SOLVERS", "GP_KEYS", "GP_USES", "tet_shape", "voxel_shape", "gp_tets", "gp_voxels", "volume_gp",
           "split_gp_options", "finish"]

#: The linear solvers of the solid's gp (multigrid and the iteration have no conditional variance here).
GP_SOLVERS = ("auto", "direct", "amg")


def tet_shape(V, T, alpha=2):
    """The :class:`~manifill.linalg.spde.MaternShape` of a validated tetrahedral mesh ``(V, T)``."""
    return MaternShape(tet_laplacian(V, T), tet_mass_matrix(V, T).diagonal(), tet_gradient_root(V, T), alpha, 3)


def voxel_shape(mask, spacing=(1.0, 1.0, 1.0), connectivity=6, alpha=2):
    """The :class:`~manifill.linalg.spde.MaternShape` of the voxels of ``mask`` (C order, physical units).

    The voxel Laplacian approximates ``-c Delta`` with ``c = sum_d w_d p_d0^2`` over one of
    each pair of neighbour offsets (1 for 6 neighbours, larger for 18 and 26); divided by
    ``c`` and multiplied by the voxel volume it is the stiffness, the volume the mass.

    Examples
    --------
    >>> s = voxel_shape(np.ones((2, 2, 2), dtype=bool), spacing=(2.0, 2.0, 2.0))
    >>> float(s.G[0, 1]), float(s.c[0])  # h per face, h^3 per voxel
    (-2.0, 8.0)
    """
    h = as_spacing(spacing)
    D, w = stencil_weights(h, connectivity)
    c = float(np.sum(w * (D[:, 0] * h[0]) ** 2))
    vol = float(np.prod(h))
    G = sp.csr_array(voxel_laplacian(mask, h, connectivity) * (vol / c))
    return MaternShape(G, np.full(G.shape[0], vol), edge_root(G), alpha, 3)


def _check_solver(solver, name="solver"):
    if solver not in GP_SOLVERS:
        raise OptionError(f"method='gp' in a solid solves with {', '.join(GP_SOLVERS)}, not {name}={solver!r}; "
                          f"pass one of those")


def _posterior(shape, idx, Y, gp, trust, untrusted, solver, length, diameter):
    """``(X, std, trusted or None, report)`` of the gp conditioned on ``Y`` at the nodes ``idx``."""
    opts = as_gp_options(gp)
    configure(method="gp", uncertainty=True, trust=trust, untrusted=untrusted)  # the std's options checked
    _check_solver(solver)
    X, std, report = gp_condition(shape, idx, None, Y, opts, length=length, diameter=diameter, solver=solver)
    trusted = None
    if trust is not None:
        X, trusted, threshold = trust_mask(X, std, Y, trust, untrusted)
    out = {"gp": report, "samples": int(idx.size)}
    if trust is not None:  # as on surfaces: the threshold per field, the count untrusted, what was done there
        out["trust"] = {"threshold": threshold, "untrusted": int((~trusted).sum()), "marked": untrusted}
    return X, std, trusted, out


@dataclass
class _Draws:
    """Posterior draws of a solid's gp (picklable), placed as its ``values``: on the mask for voxels."""

    shape: object
    idx: np.ndarray
    X: np.ndarray
    summary: dict
    mask: object = None
    squeeze: bool = False

    def __call__(self, count, seed):
        D = posterior_draws(self.shape, self.idx, None, self.X, self.summary, count, seed)
        if self.mask is not None:
            G = np.full(self.mask.shape + D.shape[1:], np.nan)
            G[self.mask] = D
            D = G
        return D[..., 0, :] if self.squeeze else D


def gp_tets(V: ArrayLike, T: ArrayLike, idx: ArrayLike, vals: ArrayLike, *, gp: GPOptions | dict | None = None,
            trust: float | None = None, untrusted: str = "mask", solver: str = "auto",
            duplicates: str = "error") -> VolumeReconstruction:
    """``method='gp'`` on a tetrahedral mesh: the posterior mean and std at every vertex.

    Parameters
    ----------
    V : (n, 3) array_like
    T : (m, 4) array_like of int
        Tetrahedra of nonzero volume; every vertex used.
    idx : (k,) array_like of int
        Sample vertices, anywhere in the solid (boundary or inside).
    vals : (k,) or (k, p) array_like of float
    gp : None, dict or GPOptions, optional
        As ``reconstruct(..., method='gp', gp=...)``; ``alpha=2`` is Matérn ``nu = 1/2`` in a solid.
    trust : float, optional
        Mark (``trusted``) where the std exceeds ``trust`` times the samples' std.
    untrusted : {'mask', 'nan'}, optional
    solver : {'auto', 'direct', 'amg'}, optional
    duplicates : {'error', 'mean'}, optional
        A vertex sampled twice with different values: raise, or average.

    Returns
    -------
    VolumeReconstruction
        ``form='tets'``, ``std`` shaped like ``values``, ``trusted`` with ``trust``, ``report['gp']``;
        ``surface`` is None.

    Raises
    ------
    MeshError, SampleError, OptionError

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2], [0.4, 0.4, 0.4]])
    >>> T = [[0, 1, 2, 4], [0, 1, 4, 3], [0, 4, 2, 3], [4, 1, 2, 3]]  # vertex 4 inside
    >>> r = gp_tets(V, T, [0, 1, 4], [0.0, 1.0, 2.0], gp={"range": 1.0, "sigma": 1.0})
    >>> bool(np.allclose(r.values[[0, 1, 4]], [0, 1, 2])), bool(r.std[4] < 1e-6 < r.std[3])
    (True, True)
    """
    V, T = as_tets(V, T)
    sidx, Y, squeeze = as_samples(idx, vals, len(V), duplicates=duplicates)
    opts = as_gp_options(gp)
    E = T[:, [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]].reshape(-1, 2)
    length = float(np.median(np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)))
    diameter = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    shape = tet_shape(V, T, opts.alpha)
    X, std, trusted, report = _posterior(shape, sidx, Y, opts, trust, untrusted, solver, length, diameter)
    report.update({"vertices": len(V), "tets": len(T), "method": "gp"})
    drawer = _Draws(shape, sidx, X, report["gp"], squeeze=squeeze)
    if squeeze:
        X, std = X[:, 0], std[:, 0]
    return VolumeReconstruction(X, "tets", None, TV=V, TT=T, report=report, samples=sidx, std=std, trusted=trusted,
                                drawer=drawer)


def gp_voxels(mask: ArrayLike, voxels: ArrayLike, vals: ArrayLike, *, spacing: ArrayLike = (1.0, 1.0, 1.0),
              origin: ArrayLike = (0.0, 0.0, 0.0), connectivity: int = 6, gp: GPOptions | dict | None = None,
              trust: float | None = None, untrusted: str = "mask", solver: str = "auto",
              duplicates: str = "error") -> VolumeReconstruction:
    """``method='gp'`` on a voxel mask: the posterior mean and std at every voxel of the solid.

    Parameters
    ----------
    mask : (n0, n1, n2) bool array_like
    voxels : (k, 3) array_like of int
        The sampled voxels, anywhere in the mask.
    vals : (k,) or (k, p) array_like of float
    spacing, origin : (3,) array_like of float, optional
    connectivity : {6, 18, 26}, optional
        The stencil of the stiffness.
    gp, trust, untrusted, solver
        As :func:`gp_tets`.
    duplicates : {'error', 'mean'}, optional
        A voxel sampled twice with different values.

    Returns
    -------
    VolumeReconstruction
        ``form='voxels'``: ``values`` and ``std`` shaped like ``mask`` (plus a field axis),
        NaN outside; ``trusted`` False outside; ``fixed`` the boundary voxels.

    Examples
    --------
    >>> mask = np.ones((6, 6, 6), dtype=bool)
    >>> r = gp_voxels(mask, [[0, 0, 0], [5, 5, 5], [2, 3, 2]], [0.0, 1.0, 5.0], gp={"range": 3.0})
    >>> round(float(r.values[2, 3, 2]), 9), r.std.shape
    (5.0, (6, 6, 6))
    """
    mask = as_mask(mask)
    h = as_spacing(spacing)
    connectivity = as_connectivity(connectivity)
    vox = as_voxels(voxels, mask.shape, mask=mask, unique=False)
    ids = np.full(mask.shape, -1, dtype=np.int64)
    ids[mask] = np.arange(int(mask.sum()))
    sidx, Y, squeeze = as_samples(ids[tuple(vox.T)], vals, int(mask.sum()), duplicates=duplicates)
    opts = as_gp_options(gp)
    extent = (np.argwhere(mask).max(axis=0) - np.argwhere(mask).min(axis=0)) * h
    shape = voxel_shape(mask, h, connectivity, opts.alpha)
    X, std, trusted, report = _posterior(shape, sidx, Y, opts, trust, untrusted, solver, float(np.median(h)),
                                         float(np.linalg.norm(extent)))
    report.update({"shape": list(mask.shape), "method": "gp"})
    p = X.shape[1]
    values = np.full(mask.shape + (p,), np.nan)
    sd = np.full(mask.shape + (p,), np.nan)
    values[mask], sd[mask] = X, std
    if squeeze:
        values, sd = values[..., 0], sd[..., 0]
    ok = None
    if trusted is not None:
        ok = np.zeros(mask.shape, dtype=bool)
        ok[mask] = trusted
    return VolumeReconstruction(values, "voxels", None, mask=mask, spacing=h, origin=as_origin(origin),
                                fixed=boundary_voxels(mask, connectivity), report=report,
                                samples=np.argwhere(mask)[sidx], std=sd, trusted=ok,
                                drawer=_Draws(shape, sidx, X, report["gp"], mask=mask, squeeze=squeeze))


#: The options of the gp in a solid, taken out of the surface options of the ``reconstruct_volume`` functions.
GP_KEYS = ("gp", "uncertainty", "trust", "untrusted")
#: The other options of :func:`manifill.reconstruct` that the gp in a solid uses; it runs no surface step, so
#: the rest (``partition``, ``weights``, ``solver``, ...) would do nothing and are refused.
GP_USES = ("method", "duplicates", "progress")


def split_gp_options(method, options):
    """The gp options popped from ``options`` (checked), refused with a method other than ``'gp'``.

    With ``method='gp'`` the surface step's options left in ``options`` (any but
    :data:`GP_USES` that is not None) are refused too: the gp in a solid has no
    surface step, so they would do nothing.

    Examples
    --------
    >>> opts = {"method": "gp", "trust": 2.0, "duplicates": "mean"}
    >>> split_gp_options("gp", opts), opts
    ({'trust': 2.0}, {'method': 'gp', 'duplicates': 'mean'})
    >>> split_gp_options("gp", {"method": "gp", "solver": "direct"})
    Traceback (most recent call last):
    ...
    manifill.errors.OptionError: solver='direct' is an option of the surface step, which method='gp' in a solid ...
    >>> split_gp_options("harmonic", {"uncertainty": True})
    Traceback (most recent call last):
    ...
    manifill.errors.OptionError: uncertainty=True in a solid needs method='gp' (the harmonic fill of the inside \
has no probability model); pass method='gp' or leave it out
    """
    gpo = {k: options.pop(k) for k in GP_KEYS if k in options}
    if method_of(method).gp_mean:
        configure(method=method, uncertainty=gpo.get("uncertainty"), trust=gpo.get("trust"),
                  untrusted=gpo.get("untrusted", "mask"))
        for name, value in options.items():
            if name not in GP_USES and value is not None:
                raise OptionError(f"{name}={value!r} is an option of the surface step, which method='gp' in a solid "
                                  f"does not run; leave it out (fill_solver, CLI --fill-solver, is the gp's solver)")
        return gpo
    for name, value in gpo.items():
        if not (value is None or value is False or (name == "untrusted" and value == "mask")):
            raise OptionError(f"{name}={value!r} in a solid needs method='gp' (the harmonic fill of the inside has "
                              f"no probability model); pass method='gp' or leave it out")
    return gpo


def finish(r, gpo):
    """``r`` without its std when ``uncertainty=False`` was asked."""
    if gpo.get("uncertainty") is False:
        r.std = None
    return r


def volume_gp(V, F, idx, vals, gpo, *, form, resolution, connectivity, max_volume, allow_open, fill_solver,
              duplicates="error"):
    """``reconstruct_volume(V, F, ..., method='gp')``: the gp over the voxelised or tetrahedralised solid.

    Tets: TetGen keeps the surface's vertices first, so the sample vertices are nodes of
    the solid. Voxels: each sample goes to the nearest boundary voxel (samples that meet
    in one voxel are averaged; ``report['merged']`` counts them, ``report['snap_max']`` is
    the largest distance moved, in voxels). ``fill_solver`` is the gp's solver.
    """
    kw = {"gp": gpo.get("gp"), "trust": gpo.get("trust"), "untrusted": gpo.get("untrusted", "mask"),
          "solver": fill_solver}
    _check_solver(fill_solver, "fill_solver")
    sidx, Y, squeeze = as_samples(idx, vals, len(V), duplicates=duplicates)
    Y = Y[:, 0] if squeeze else Y
    if form == "tets":
        TV, TT = tetrahedralize(V, F, max_volume=max_volume)
        return finish(gp_tets(TV, TT, sidx, Y, **kw), gpo)
    mask, spacing, origin = voxelize(V, F, resolution=resolution, allow_open=allow_open)
    fixed = boundary_voxels(mask, connectivity)
    on = np.argwhere(fixed)
    dist, near = cKDTree(voxel_centres(mask.shape, spacing, origin, where=fixed)).query(V[sidx])
    r = gp_voxels(mask, on[near], Y, spacing=spacing, origin=origin, connectivity=connectivity,
                  duplicates="mean", **kw)
    r.report.update({"resolution": int(resolution), "merged": int(sidx.size - r.samples.shape[0]),
                     "snap_max": float(dist.max() / spacing.min()) if dist.size else 0.0})
    return finish(r, gpo)
