"""Steps 1-8 on a solid: reconstruct on its boundary surface D, then fill the inside.

Three forms of solid, one result (:class:`~manifill.solid.volume_result.VolumeReconstruction`):

``reconstruct_volume(V, F, idx, vals, form=...)``
    A closed triangle mesh with samples at its vertices. Steps 1-6 run on the
    mesh itself; ``form='voxels'`` voxelises the solid (winding numbers,
    :mod:`manifill.solid.voxelize`) and gives every boundary voxel the surface
    field at its closest surface point (:mod:`manifill.solid.boundary`);
    ``form='tets'`` tetrahedralises it with the surface kept (TetGen,
    :mod:`manifill.solid.tetrahedralize`), so D is the mesh. Step 8 fills the
    inside (:mod:`manifill.solid.fill`).
``reconstruct_volume_tets(V, T, idx, vals)``
    A tetrahedral mesh (e.g. read from VTU or MSH); D is its boundary triangles
    and the samples are vertices on them.
``reconstruct_volume_mask(mask, voxels, vals, spacing=..., origin=...)``
    A voxel mask; D is its boundary voxels, a digital surface whose graph
    joins boundary voxels that touch (26 neighbours) and whose normals come
    from the smoothed mask. Steps 1-6 run on that graph with the paper's
    uniform averaging.

One vocabulary for the three: the geometry and the samples first; then the
options of the inside (Step 8), ``fill_solver`` and, for tets, ``fill_weights``,
with the same names, sets and defaults in each; then ``**options``, the surface
step (Steps 1-6) exactly as :func:`manifill.reconstruct` takes it (``method``,
``weights``, ``solver``, ``curve_values``, ``bounds``, ...), forwarded unchanged.
A digital surface has no triangles, so a mask's ``weights`` defaults to
``'uniform'`` and refuses the others; ``method='gp'`` runs no surface step, and
refuses its options. Each refuses, before Steps 1-6, a volume predicted not to
fit in memory (:mod:`manifill.solid.estimates`).
"""

import time
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import OptionError, SampleError
from ..memory import check_fits
from ..mesh.laplacian import WEIGHTS as SURFACE_WEIGHTS
from ..mesh.objects import mesh_arrays
from ..progress import tick
from ..surface.methods.registry import method_of
from ..surface.reconstruct import reconstruct, reconstruct_surface
from ..deprecation import renamed
from ..validate import as_mask, as_samples, as_tets, as_voxels, check_option
from .boundary import (boundary_voxels, digital_surface, digital_surface_graph, surface_to_points,
                       surface_vertex_of_voxels)
from .estimates import (TET_FILL_SOLVERS, check_fill_solver, check_volume_options, mask_fill_estimate, n_fields,
                        tet_mesh_fill_estimate, volume_estimate)
from .fill import FILL_SOLVERS, VoxelFill, tet_fill
from .gp import finish, gp_tets, gp_voxels, split_gp_options, volume_gp
from .tetrahedralize import tetrahedralize
from .tets import boundary_faces
from .volume_result import VolumeReconstruction
from .voxels import as_connectivity, as_origin, as_spacing, voxel_centres
from .voxelize import voxelize

__all__ = ["VolumeReconstruction", "reconstruct_volume", "reconstruct_volume_tets", "reconstruct_volume_mask",
           "MASK_WEIGHTS"]

#: The surface weights a digital surface can use (it has no triangles for cotangents); its default.
MASK_WEIGHTS = ("uniform",)
__getattr__ = renamed(__name__, {"FILL_WEIGHTS": "manifill.mesh.tetmesh:TET_WEIGHTS"})  # one release (deprecation)
#: Options of :func:`manifill.reconstruct` a voxel mask cannot take: its samples are voxels, not positions.
_POSITION_OPTIONS = ("max_distance",)
#: Keywords of ``reconstruct_surface`` that are the functions' own, not the caller's.
_OWN = ("seconds", "points", "fields", "prepared")



def _solid_gp(options):
    """Whether ``options`` ask for the Gaussian process, which in a solid covers the whole solid at once."""
    return method_of(options.get("method")).gp_mean

def _equals(value, default):
    try:
        return bool(value == default) if value is not None else default is None
    except (TypeError, ValueError):  # an array: not the default
        return False


def _check_form_options(form, **given):
    """Refuse an option of the other form set to anything but its default: it would do nothing.

    ``given`` maps each name to ``(value, default)``; ``form`` is the form run.
    """
    other = "voxels" if form == "tets" else "tets"
    for name, (value, default) in given.items():
        if not _equals(value, default):
            raise OptionError(f"{name}={value!r} is for form={other!r} and does nothing with form={form!r}; "
                              f"drop it or pass form={other!r}")


def _check_fill(form, fill_solver, fill_weights="cotan"):
    """The inside's options, the same names and sets for every entry point.

    ``fill_solver`` from :data:`~manifill.solid.fill.FILL_SOLVERS` (voxels) or
    :data:`~manifill.solid.estimates.TET_FILL_SOLVERS` (tets); ``fill_weights`` from
    :data:`manifill.mesh.tetmesh.TET_WEIGHTS`, and at its default for voxels (their weights come from the spacing).
    """
    solvers = FILL_SOLVERS if form == "voxels" else TET_FILL_SOLVERS
    check_fill_solver(fill_solver, solvers)
    check_option("fill_solver", fill_solver, solvers)
    if form == "voxels":
        _check_form_options("voxels", fill_weights=(fill_weights, "cotan"))
    check_volume_options(fill_weights=fill_weights)


def _refuse_own(options):
    """Refuse the keywords ``reconstruct_surface`` takes from these functions, not from their callers."""
    own = sorted(set(options) & set(_OWN))
    if own:
        raise OptionError(f"no option {own[0]!r} (it is the function's own); see help(manifill.reconstruct)")


def reconstruct_volume(V: ArrayLike, F: ArrayLike, idx: ArrayLike, vals: ArrayLike, *, form: str = "voxels",
                       resolution: int = 128, connectivity: int = 6, max_volume: float | None = None,
                       fill_solver: str = "auto", fill_weights: str = "cotan", allow_open: bool = False,
                       **options: Any) -> VolumeReconstruction:
    """Reconstruct a field inside a solid from samples on its closed boundary surface (Steps 1-8).

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions of the closed surface.
    F : (m, 3) array_like of int
        Its triangles.
    idx : (k,) array_like of int
        Sample vertices.
    vals : (k,) or (k, p) array_like of float
        Sample values.
    form : {'voxels', 'tets'}, optional
        Fill a voxelisation (cubes, ``resolution`` along the longest side) or a
        tetrahedralisation (TetGen, surface kept).
    resolution : int, optional
        Voxels along the longest side (``form='voxels'``).
    connectivity : {6, 18, 26}, optional
        Voxel neighbours (``form='voxels'``).
    max_volume : float, optional
        Largest tetrahedron volume in the units of ``V`` (``form='tets'``).
    fill_solver : {'auto', 'multigrid', 'amg', 'direct'}, optional
        Solver of the inside (Step 8). ``auto``: ``multigrid`` for voxels; for
        tets ``direct`` up to :data:`manifill.solid.fill.AUTO_DIRECT_MAX` free
        vertices, ``amg`` above. ``multigrid`` is for voxels only.
    fill_weights : {'cotan', 'uniform'}, optional
        Weights of the inside's tetrahedral Laplacian (``form='tets'``).
    allow_open : bool, optional
        Voxelise an open surface by winding numbers instead of refusing it.
    **options
        Steps 1-6, exactly as :func:`manifill.reconstruct` takes them (``method``,
        ``partition``, ``weights``, ``solver``, ``curve_values``, ``bounds``, ...),
        forwarded unchanged. ``method='gp'`` (with ``gp``, ``uncertainty``,
        ``trust``, ``untrusted``, ``duplicates``): the gp over the solid, no
        surface pass (:func:`manifill.solid.gp.volume_gp`; ``fill_solver`` its solver).

    Returns
    -------
    VolumeReconstruction

    Raises
    ------
    MeshError
        A malformed or open surface (see ``allow_open``).
    ResourceError
        The volume steps are predicted not to fit in the memory available
        (:func:`manifill.solid.estimates.reconstruct_volume_memory`); checked before Steps 1-6.
    OptionError
        An option outside its set, ``fill_solver='multigrid'`` with ``form='tets'``,
        an option of the other form (``resolution``, ``connectivity``,
        ``allow_open`` with tets; ``max_volume``, ``fill_weights`` with voxels)
        set to anything but its default (it would be ignored), or a surface
        option with ``method='gp'``.
    OptionError or TypeError
        A keyword :func:`manifill.reconstruct` does not take, refused as it refuses it.
    SampleError, SolveError
        As the steps they come from.
    ImportError
        Without libigl or tetgen (``pip install 'manifill[volume]'``).

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> V, F = icosphere(3)
    >>> idx = np.arange(0, len(V), 7)
    >>> r = reconstruct_volume(V, F, idx, V[idx, 2], resolution=24)
    >>> r.values.shape, bool(np.isnan(r.values[0, 0, 0]))
    ((26, 26, 26), True)
    """
    check_volume_options(form=form, connectivity=connectivity, max_volume=max_volume, allow_open=allow_open)
    _check_fill(form, fill_solver, fill_weights)
    if form == "tets":
        _check_form_options("tets", resolution=(resolution, 128), connectivity=(connectivity, 6),
                            allow_open=(allow_open, False))
    else:
        _check_form_options("voxels", max_volume=(max_volume, None))
    V, F = mesh_arrays(V, F)
    gpo = split_gp_options(options.get("method"), options)
    # refuse a volume that will not fit before Steps 1-6 on the surface
    check_fits(*volume_estimate(V, F, form, resolution, connectivity, max_volume, fill_solver, n_fields(vals)))
    if _solid_gp(options):  # the gp over the whole solid, no surface pass
        return volume_gp(V, F, idx, vals, gpo, form=form, resolution=resolution, connectivity=connectivity,
                         max_volume=max_volume, allow_open=allow_open, fill_solver=fill_solver,
                         duplicates=options.get("duplicates", "error"))
    t0 = time.perf_counter()
    surf = reconstruct(V, F, idx, vals, **options)
    seconds = {"surface": time.perf_counter() - t0}
    V, F = np.asarray(V, dtype=np.float64), np.asarray(F, dtype=np.int64)
    progress = options.get("progress")
    if form == "voxels":
        r = _fill_voxelised(V, F, surf, resolution, as_connectivity(connectivity), allow_open, fill_solver,
                            progress, seconds)
    else:
        r = _fill_tetrahedralised(V, F, surf, max_volume, fill_weights, fill_solver, progress, seconds)
    seconds["total"] = time.perf_counter() - t0
    return r


def _fill_voxelised(V, F, surf, resolution, connectivity, allow_open, fill_solver, progress, seconds):
    """Step 8 of :func:`reconstruct_volume` with ``form='voxels'``: voxelise, carry the surface field to D, fill."""
    tick(progress, "voxelize")
    t = time.perf_counter()
    mask, spacing, origin = voxelize(V, F, resolution=resolution, allow_open=allow_open)
    fixed = boundary_voxels(mask, connectivity)
    bc, dist = surface_to_points(V, F, surf.values, voxel_centres(mask.shape, spacing, origin, where=fixed))
    seconds["voxelize"] = time.perf_counter() - t
    tick(progress, "fill")
    # bc is in the order of np.argwhere(fixed), as voxel_centres(where=fixed) lists them
    fill = VoxelFill(mask, np.argwhere(fixed), spacing=spacing, connectivity=connectivity, solver=fill_solver)
    values = fill.solve(bc)
    seconds["fill"] = sum(fill.report["seconds"].values())
    report = {"fill": fill.report, "resolution": int(resolution), "shape": list(mask.shape),
              "boundary_distance_max": float(dist.max() / spacing[0]) if dist.size else 0.0, "seconds": seconds}
    return VolumeReconstruction(values, "voxels", surf, mask=mask, spacing=spacing, origin=origin, fixed=fixed,
                                report=report)


def _fill_tetrahedralised(V, F, surf, max_volume, fill_weights, fill_solver, progress, seconds):
    """Step 8 of :func:`reconstruct_volume` with ``form='tets'``: tetrahedralise (surface kept), fill."""
    tick(progress, "tetrahedralize")
    t = time.perf_counter()
    TV, TT = tetrahedralize(V, F, max_volume=max_volume)
    seconds["tetrahedralize"] = time.perf_counter() - t
    tick(progress, "fill")
    t = time.perf_counter()
    values = tet_fill(TV, TT, np.arange(len(V)), surf.values, weights=fill_weights, solver=fill_solver)
    seconds["fill"] = time.perf_counter() - t
    report = {"vertices": len(TV), "tets": len(TT), "seconds": seconds}
    # tetgen keeps the surface's vertices first, so the sample vertices are vertices of TV
    return VolumeReconstruction(values, "tets", surf, TV=TV, TT=TT, report=report, samples=surf.idx)


def reconstruct_volume_tets(V: ArrayLike, T: ArrayLike, idx: ArrayLike, vals: ArrayLike, *, fill_solver: str = "auto",
                            fill_weights: str = "cotan", **options: Any) -> VolumeReconstruction:
    """Steps 1-8 on a tetrahedral mesh: reconstruct on its boundary triangles, fill the tets.

    Parameters
    ----------
    V : (n, 3) array_like
    T : (m, 4) array_like of int
    idx : (k,) array_like of int
        Sample vertices of ``V``, all on the boundary.
    vals : (k,) or (k, p) array_like of float
    fill_weights : {'cotan', 'uniform'}, optional
        Weights of the inside's tetrahedral Laplacian, as :func:`reconstruct_volume`.
    fill_solver : {'auto', 'amg', 'direct'}, optional
        Solver of the inside, as :func:`reconstruct_volume` with ``form='tets'``:
        ``auto`` is ``direct`` up to :data:`manifill.solid.fill.AUTO_DIRECT_MAX` free
        vertices, ``amg`` above (``multigrid`` is for voxels: an OptionError here).
    **options
        Steps 1-6 on the boundary triangles, exactly as :func:`manifill.reconstruct`
        takes them, forwarded unchanged; ``method='gp'`` (with ``gp``, ``uncertainty``,
        ``trust``, ``untrusted``, ``duplicates``): the gp over the tets, samples anywhere
        (:func:`manifill.solid.gp.gp_tets`; ``fill_solver`` its solver).

    Returns
    -------
    VolumeReconstruction
        ``TV, TT`` are ``V, T``.

    Raises
    ------
    SampleError
        A sample inside the solid (not on its boundary).
    ResourceError
        The fill is predicted not to fit in the memory available
        (:func:`manifill.solid.fill.tet_fill_memory`); checked before Steps 1-6.
    OptionError
        An option outside its set, or a surface option with ``method='gp'``.
    OptionError or TypeError
        A keyword :func:`manifill.reconstruct` does not take, refused as it refuses it.

    Examples
    --------
    >>> from manifill.mesh.shapes import icosphere
    >>> from manifill.solid.tetrahedralize import tetrahedralize
    >>> TV, TT = tetrahedralize(*icosphere(2), max_volume=0.05)
    >>> idx = np.arange(0, 162, 4)
    >>> r = reconstruct_volume_tets(TV, TT, idx, TV[idx, 0])
    >>> r.values.shape == (len(TV),), int(r.point_data()["sample_mask"].sum())
    (True, 41)
    """
    _check_fill("tets", fill_solver, fill_weights)
    gpo = split_gp_options(options.get("method"), options)
    if _solid_gp(options):  # the gp over the tets, samples anywhere
        return finish(gp_tets(V, T, idx, vals, gp=gpo.get("gp"), trust=gpo.get("trust"), solver=fill_solver,
                              untrusted=gpo.get("untrusted", "mask"), duplicates=options.get("duplicates", "error")),
                      gpo)
    t0 = time.perf_counter()
    V, T = as_tets(V, T, allow_degenerate=fill_weights == "uniform")
    n = len(V)
    bf = boundary_faces(T, V=V)
    on_d = np.unique(bf)
    check_fits(*tet_mesh_fill_estimate(n, len(T), on_d.size, fill_solver))
    idx_arr, vals2, squeeze = as_samples(idx, vals, n, duplicates=options.get("duplicates", "error"))
    inside = np.setdiff1d(idx_arr, on_d)
    if inside.size:
        raise SampleError(f"{inside.size} samples are inside the solid, not on its boundary (e.g. vertex "
                          f"{int(inside[0])}); give samples on boundary vertices")
    local = np.full(n, -1, dtype=np.int64)
    local[on_d] = np.arange(on_d.size)
    surf = reconstruct(V[on_d], local[bf], local[idx_arr], vals2[:, 0] if squeeze else vals2, **options)
    seconds = {"surface": time.perf_counter() - t0}
    tick(options.get("progress"), "fill")
    t = time.perf_counter()
    values = tet_fill(V, T, on_d, surf.values, weights=fill_weights, solver=fill_solver)
    seconds["fill"] = time.perf_counter() - t
    seconds["total"] = time.perf_counter() - t0
    return VolumeReconstruction(values, "tets", surf, TV=V, TT=T,
                                report={"vertices": n, "tets": len(T), "boundary_vertices": int(on_d.size),
                                        "seconds": seconds}, samples=idx_arr)


def reconstruct_volume_mask(mask: ArrayLike, voxels: ArrayLike, vals: ArrayLike, *,
                            spacing: ArrayLike = (1.0, 1.0, 1.0), origin: ArrayLike = (0.0, 0.0, 0.0),
                            connectivity: int = 6, fill_solver: str = "auto", **options: Any) -> VolumeReconstruction:
    """Steps 1-8 on a voxel mask: reconstruct on its digital boundary surface, fill the inside.

    Parameters
    ----------
    mask : (n0, n1, n2) bool array_like
        The solid.
    voxels : (k, 3) array_like of int
        (k, 3) int grid indices of the sampled voxels, each a boundary voxel of
        the mask (:func:`manifill.solid.boundary.boundary_voxels`).
    vals : (k,) or (k, p) array_like of float
    spacing, origin : (3,) array_like of float, optional
    connectivity : {6, 18, 26}, optional
        Neighbours of the fill (and which voxels are boundary).
    fill_solver : {'auto', 'multigrid', 'amg', 'direct'}, optional
        Solver of the inside, as :func:`reconstruct_volume` with ``form='voxels'``: ``auto`` is ``multigrid``.
    **options
        Steps 1-6 on the digital surface, exactly as :func:`manifill.reconstruct`
        takes them (``method``, ``partition``, ``solver``, ``curve_values``,
        ``bounds``, ``progress``, ...), forwarded unchanged; ``distance`` shapes the
        digital surface's graph and ``duplicates`` merges the samples, as there.
        ``weights`` defaults to ``'uniform'`` (the paper's average), the one weight
        a digital surface can use: it has no triangles for cotangents, so any other
        is an OptionError. ``method='gp'`` (with ``gp``, ``uncertainty``, ``trust``,
        ``untrusted``): the gp over the voxels, samples anywhere in the mask
        (:func:`manifill.solid.gp.gp_voxels`, ``fill_solver`` its solver).

    Returns
    -------
    VolumeReconstruction
        ``surface_voxels`` lists the voxel of each surface vertex, ``samples`` the sampled voxels.

    Raises
    ------
    SampleError
        A sample off the boundary, out of the grid, or malformed.
    MeshError
        A malformed ``spacing`` or ``origin``.
    OptionError
        An option outside its set, ``weights`` other than ``uniform``, ``fill_weights``
        other than its default (a voxel fill's weights come from the spacing),
        ``max_distance`` (the samples are voxels, not positions), or a surface option
        with ``method='gp'``.
    OptionError or TypeError
        A keyword :func:`manifill.reconstruct` does not take, refused as it refuses it.
    ResourceError
        The fill is predicted not to fit in the memory available; checked before Steps 1-6.

    Examples
    --------
    >>> x, y, z = np.indices((20, 20, 20)) - 9.5
    >>> mask = x**2 + y**2 + z**2 < 81
    >>> on = np.argwhere(boundary_voxels(mask))[::9]
    >>> r = reconstruct_volume_mask(mask, on, on[:, 0] * 1.0)
    >>> bool(np.allclose(r.values[tuple(on.T)], on[:, 0]))
    True
    """
    t0 = time.perf_counter()
    check_volume_options(connectivity=connectivity)
    _check_fill("voxels", fill_solver)
    _check_mask_options(options)
    mask = as_mask(mask)
    connectivity = as_connectivity(connectivity)
    h = as_spacing(spacing)
    # before the digital surface and Steps 1-6
    check_fits(*mask_fill_estimate(mask, fill_solver, connectivity))
    gpo = split_gp_options(options.get("method"), options)
    duplicates = options.pop("duplicates", "error")
    if _solid_gp(options):  # the gp over the voxels, samples anywhere in the mask
        return finish(gp_voxels(mask, voxels, vals, spacing=h, origin=origin, connectivity=connectivity,
                                gp=gpo.get("gp"), trust=gpo.get("trust"), untrusted=gpo.get("untrusted", "mask"),
                                solver=fill_solver, duplicates=duplicates), gpo)
    on_d, P, E, normals = digital_surface(mask, spacing=h, origin=origin, connectivity=connectivity)
    voxels = as_voxels(voxels, mask.shape, unique=False)  # repeats are merged (or refused) by duplicates
    sidx, svals, squeeze = as_samples(surface_vertex_of_voxels(on_d, voxels, mask.shape), vals, len(on_d),
                                      duplicates=duplicates)
    seconds = {"validate": time.perf_counter() - t0}
    t = time.perf_counter()
    surface = digital_surface_graph(P, E, normals, distance=options.pop("distance", "length"))
    seconds["graph"] = time.perf_counter() - t
    surf = reconstruct_surface(surface, sidx, svals, seconds=seconds, **{"weights": "uniform", **options})
    if squeeze:
        surf.values = surf.values[:, 0]
    fixed = np.zeros(mask.shape, dtype=bool)
    fixed[tuple(on_d.T)] = True
    tick(options.get("progress"), "fill")
    t = time.perf_counter()
    fill = VoxelFill(mask, on_d, spacing=h, connectivity=connectivity, solver=fill_solver)
    values = fill.solve(surf.values)  # one row per vertex of the digital surface, i.e. per voxel of on_d
    seconds = dict(surf.report["seconds"])
    seconds["fill"] = time.perf_counter() - t
    seconds["total"] = time.perf_counter() - t0
    return VolumeReconstruction(values, "voxels", surf, mask=mask, spacing=h, origin=as_origin(origin), fixed=fixed,
                                surface_voxels=on_d, report={"fill": fill.report, "shape": list(mask.shape),
                                                             "seconds": seconds}, samples=on_d[sidx])


def _check_mask_options(options):
    """Refuse, before any work, what a voxel mask cannot use: tet weights, triangle weights, positions."""
    _refuse_own(options)
    fill_weights = options.pop("fill_weights", "cotan")
    if not _equals(fill_weights, "cotan"):
        raise OptionError(f"fill_weights={fill_weights!r} is for tetrahedra, and a voxel fill takes its weights from "
                          f"the spacing; leave it out")
    weights = options.get("weights", "uniform")
    if not _solid_gp(options) and weights not in MASK_WEIGHTS:
        check_option("weights", weights, SURFACE_WEIGHTS)
        raise OptionError(f"weights={weights!r} needs triangles, and a digital surface has none; pass "
                          f"weights='uniform' (the paper's average, the default here), or a triangle mesh of the "
                          f"solid")
    for name in _POSITION_OPTIONS:
        if options.get(name) is not None:
            raise OptionError(f"{name}={options[name]!r} is for samples given as positions, and a mask's samples "
                              f"are voxels (grid indices); leave it out")
