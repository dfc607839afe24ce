"""Steps 1-8 on a solid: reconstruct on its boundary surface D, then fill the inside.

Three forms of solid, one result (:class:`VolumeReconstruction`):

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

Each refuses, before Steps 1-6, a volume predicted not to fit in memory
(:mod:`manifill.solid.estimates`).
"""

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import OptionError, SampleError
from ..linalg.backends import SOLVERS
from ..memory import check_fits
from ..mesh.objects import mesh_arrays
from ..progress import tick
from ..results import BOUNDARY_MASK, SAMPLE_MASK, TRUSTED, Result, with_std
from ..surface.reconstruct import Reconstruction, check_options, reconstruct, reconstruct_surface
from ..validate import as_mask, as_samples, as_tets, as_voxels, check_option
from .boundary import (boundary_voxels, digital_surface, digital_surface_graph, surface_to_points,
                       surface_vertex_of_voxels)
from .estimates import (FORMS, TET_FILL_SOLVERS, check_fill_solver, mask_fill_estimate, n_fields,
                        tet_mesh_fill_estimate, volume_estimate)
from .fill import FILL_SOLVERS, VoxelFill, tet_fill
from .gp import finish, gp_tets, gp_voxels, split_gp_options, volume_gp
from .tetrahedralize import tetrahedralize
from .tets import boundary_faces, boundary_vertices
from .voxels import as_connectivity, as_origin, as_spacing, voxel_centres
from .voxelize import voxelize

__all__ = ["VolumeReconstruction", "reconstruct_volume", "reconstruct_volume_tets", "reconstruct_volume_mask"]


@dataclass
class VolumeReconstruction(Result):
    """The result of the ``reconstruct_volume`` functions (a :class:`manifill.results.Result`).

    Attributes
    ----------
    values : numpy array
        ``form='voxels'``: shaped like ``mask`` (plus a field axis for several
        fields), NaN outside the solid. ``form='tets'``: one row per vertex of
        ``TV``.
    form : {'voxels', 'tets'}
    surface : Reconstruction
        Steps 1-6 on the boundary surface (on the digital surface for a mask:
        its vertices are ``surface_voxels``); None with ``method='gp'`` (no surface pass).
    mask : (n0, n1, n2) bool numpy array or None
    spacing, origin : (3,) numpy arrays or None
        The grid: voxel ``(i, j, k)`` is at ``origin + (i, j, k) * spacing``.
    fixed : (n0, n1, n2) bool numpy array or None
        The voxels whose values came from the surface (D).
    TV : (N, 3) numpy array or None
    TT : (M, 4) int64 numpy array or None
    surface_voxels : (d, 3) int64 numpy array or None
        For a mask: the voxel of each vertex of the digital surface.
    report : dict
        Counts, the fill's solver report and ``seconds`` per step.
    samples : numpy array or None
        Where the samples are in the solid: tets, the ``(k,)`` vertices of
        ``TV``; a mask, the ``(k, 3)`` sampled voxels; a voxelised surface,
        None (its samples are surface vertices, not voxels).
    std, trusted : numpy arrays or None
        ``method='gp'`` (:mod:`manifill.solid.gp`): the posterior std, shaped like ``values``
        (written as ``<field>_std``), and with ``trust=`` the ``trusted`` mask.

    Examples
    --------
    >>> x, y, z = np.indices((12, 12, 12)) - 5.5
    >>> mask = x**2 + y**2 + z**2 < 25
    >>> on = np.argwhere(boundary_voxels(mask))[::7]
    >>> r = reconstruct_volume_mask(mask, on, on[:, 2] * 1.0)
    >>> sorted(r.point_data(["t"]))
    ['boundary_mask', 't']
    """

    values: np.ndarray
    form: str
    surface: Reconstruction
    mask: np.ndarray = None
    spacing: np.ndarray = None
    origin: np.ndarray = None
    fixed: np.ndarray = None
    TV: np.ndarray = None
    TT: np.ndarray = None
    surface_voxels: np.ndarray = None
    report: dict = field(default_factory=dict)
    samples: np.ndarray = None
    std: np.ndarray = None
    trusted: np.ndarray = None

    @property
    def point_ndim(self):
        """Leading axes of ``values`` that index points: 3 for voxels, 1 for tet vertices."""
        return 3 if self.form == "voxels" else 1

    def masks(self):
        """The boundary mask D, and for tets the sample mask, by name.

        Returns
        -------
        dict of str to numpy array
            Voxels: ``{BOUNDARY_MASK: fixed}``, (n0, n1, n2) bool. Tets:
            ``BOUNDARY_MASK`` (the vertices of :func:`manifill.solid.tets.boundary_faces`)
            and ``SAMPLE_MASK`` (the sample vertices), (N,) bool.
        """
        extra = {} if self.trusted is None else {TRUSTED: self.trusted}
        if self.form == "voxels":
            return {BOUNDARY_MASK: self.fixed, **extra}
        boundary = np.zeros(len(self.TV), dtype=bool)
        boundary[boundary_vertices(self.TT)] = True
        sample = np.zeros(len(self.TV), dtype=bool)
        if self.samples is not None:
            sample[self.samples] = True
        return {BOUNDARY_MASK: boundary, SAMPLE_MASK: sample, **extra}

    def point_data(self, names=None):
        """The fields, their std (``<field>_std``, with ``method='gp'``), then :meth:`masks`."""
        return with_std(super().point_data(names), self.std, names, self.point_ndim)

    def to_pyvista(self, names=None):
        """The solid as a ``pyvista.ImageData`` (voxels; NaN outside) or ``UnstructuredGrid`` (tets).

        Needs the ``[viz]`` extra. Voxel ``(i, j, k)`` is the point at ``origin + (i, j, k) * spacing``.
        """
        from ..mesh.objects import to_pyvista

        data = self.point_data(names)
        if self.form == "tets":
            return to_pyvista(self.TV, self.TT, data)
        try:
            import pyvista as pv
        except ImportError:
            raise ImportError("converting to pyvista needs pyvista: pip install 'manifill[viz]'") from None
        img = pv.ImageData(dimensions=self.mask.shape, spacing=tuple(self.spacing), origin=tuple(self.origin))
        for name, arr in data.items():
            arr = np.asarray(arr)
            arr = arr.astype(np.uint8) if arr.dtype == bool else arr
            img.point_data[name] = arr.reshape(-1, order="F")  # x fastest, as VTK orders points
        return img

    def to_meshio(self, names=None):
        """The tetrahedral solid as a ``meshio.Mesh`` (voxels: use :meth:`to_pyvista` or ``write_vti``)."""
        from ..mesh.objects import to_meshio

        if self.form != "tets":
            raise OptionError("a voxel result has no meshio form; use to_pyvista() or manifill.io.solids.write_vti")
        return to_meshio(self.TV, self.TT, self.point_data(names))


def _surface_options(options):
    allowed = {"method", "partition", "weights", "distance", "levels", "curve_values", "solver", "on_empty",
               "duplicates", "iteration", "init", "seed", "tol", "maxiter", "progress"}
    bad = sorted(set(options) - allowed)
    if bad:
        raise TypeError(f"unexpected keyword argument {bad[0]!r}; the surface options are those of "
                        f"manifill.reconstruct: {', '.join(sorted(allowed))}")
    return options


def _equals(value, default):
    try:
        return bool(value == default) if value is not None else default is None
    except (TypeError, ValueError):  # an array: not the default
        return False


def _check_form_options(form, resolution, connectivity, max_volume, fill_weights, allow_open):
    """Refuse an option of the other form set to anything but its default: it would do nothing."""
    if form == "tets":
        other, given = "voxels", {"resolution": (resolution, 128), "connectivity": (connectivity, 6),
                                  "allow_open": (allow_open, False)}
    else:
        other, given = "tets", {"max_volume": (max_volume, None), "fill_weights": (fill_weights, "cotan")}
    for name, (value, default) in given.items():
        if not _equals(value, default):
            raise OptionError(f"{name}={value!r} is for form={other!r} and does nothing with form={form!r}; "
                              f"drop it or pass form={other!r}")


def reconstruct_volume(V, F, idx, vals, *, form="voxels", resolution=128, connectivity=6, max_volume=None,
                       fill_solver="auto", fill_weights="cotan", allow_open=False, **options):
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
        Solver of the fill. ``auto``: ``multigrid`` for voxels; for tets
        ``direct`` up to :data:`manifill.solid.fill.AUTO_DIRECT_MAX` free vertices,
        ``amg`` above. ``multigrid`` is for voxels only: with ``form='tets'`` it
        is an :class:`~manifill.errors.OptionError`.
    fill_weights : {'cotan', 'uniform'}, optional
        Tetrahedral weights (``form='tets'``).
    allow_open : bool, optional
        Voxelise an open surface by winding numbers instead of refusing it.
    **options
        Passed to :func:`manifill.reconstruct` for Steps 1-6 (``method``,
        ``partition``, ``weights``, ``curve_values``, ...). ``method='gp'`` (with ``gp``, ``uncertainty``,
        ``trust``, ``untrusted``): the gp over the solid, no surface pass (:func:`manifill.solid.gp.volume_gp`).

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
        or an option of the other form (``resolution``, ``connectivity``,
        ``allow_open`` with tets; ``max_volume``, ``fill_weights`` with voxels)
        set to anything but its default: it would be ignored.
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
    check_option("form", form, FORMS)
    check_fill_solver(fill_solver, FILL_SOLVERS if form == "voxels" else TET_FILL_SOLVERS)
    _check_form_options(form, resolution, connectivity, max_volume, fill_weights, allow_open)
    V, F = mesh_arrays(V, F)
    gpo = split_gp_options(options.get("method"), options)
    _surface_options(options)
    # refuse a volume that will not fit before Steps 1-6 on the surface
    check_fits(*volume_estimate(V, F, form, resolution, connectivity, max_volume, fill_solver, n_fields(vals)))
    if options.get("method") == "gp":  # the gp over the whole solid, no surface pass
        return volume_gp(V, F, idx, vals, gpo, form=form, resolution=resolution, connectivity=connectivity,
                            max_volume=max_volume, allow_open=allow_open, fill_solver=fill_solver,
                            duplicates=options.get("duplicates", "error"))
    t0 = time.perf_counter()
    surf = reconstruct(V, F, idx, vals, **options)
    seconds = {"surface": time.perf_counter() - t0}
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    progress = options.get("progress")
    if form == "voxels":
        connectivity = as_connectivity(connectivity)
        tick(progress, "voxelize")
        t = time.perf_counter()
        mask, spacing, origin = voxelize(V, F, resolution, allow_open=allow_open)
        fixed = boundary_voxels(mask, connectivity)
        bc, dist = surface_to_points(V, F, surf.values, voxel_centres(mask.shape, spacing, origin, where=fixed))
        seconds["voxelize"] = time.perf_counter() - t
        tick(progress, "fill")
        # bc is in the order of np.argwhere(fixed), as voxel_centres(where=fixed) lists them
        fill = VoxelFill(mask, np.argwhere(fixed), spacing=spacing, connectivity=connectivity, solver=fill_solver)
        values = fill.solve(bc)
        seconds["fill"] = sum(fill.report["seconds"].values())
        report = {"fill": fill.report, "resolution": int(resolution), "shape": list(mask.shape),
                  "boundary_distance_max": float(dist.max() / spacing[0]) if dist.size else 0.0,
                  "seconds": seconds}
        seconds["total"] = time.perf_counter() - t0
        return VolumeReconstruction(values, "voxels", surf, mask=mask, spacing=spacing, origin=origin, fixed=fixed,
                                    report=report)
    tick(progress, "tetrahedralize")
    t = time.perf_counter()
    TV, TT = tetrahedralize(V, F, max_volume=max_volume)
    seconds["tetrahedralize"] = time.perf_counter() - t
    tick(progress, "fill")
    t = time.perf_counter()
    values = tet_fill(TV, TT, np.arange(len(V)), surf.values, weights=fill_weights, solver=fill_solver)
    seconds["fill"] = time.perf_counter() - t
    seconds["total"] = time.perf_counter() - t0
    report = {"vertices": len(TV), "tets": len(TT), "seconds": seconds}
    # tetgen keeps the surface's vertices first, so the sample vertices are vertices of TV
    return VolumeReconstruction(values, "tets", surf, TV=TV, TT=TT, report=report, samples=surf.idx)


def reconstruct_volume_tets(V, T, idx, vals, *, fill_weights="cotan", fill_solver="auto", **options):
    """Steps 1-8 on a tetrahedral mesh: reconstruct on its boundary triangles, fill the tets.

    Parameters
    ----------
    V : (n, 3) array_like
    T : (m, 4) array_like of int
    idx : (k,) array_like of int
        Sample vertices of ``V``, all on the boundary.
    vals : (k,) or (k, p) array_like of float
    fill_weights : {'cotan', 'uniform'}, optional
    fill_solver : {'auto', 'direct', 'amg', 'iterate'}, optional
        ``auto``: ``direct`` up to :data:`manifill.solid.fill.AUTO_DIRECT_MAX` free
        vertices, ``amg`` above (``multigrid`` is for voxels: an OptionError here).
    **options
        Passed to :func:`manifill.reconstruct` for Steps 1-6; ``method='gp'`` (with ``gp``, ``uncertainty``,
        ``trust``, ``untrusted``): the gp over the tets, samples anywhere (:func:`manifill.solid.gp.gp_tets`).

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
        An option outside its set.

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
    gpo = split_gp_options(options.get("method"), options)
    _surface_options(options)
    if options.get("method") == "gp":  # the gp over the tets, samples anywhere
        return finish(gp_tets(V, T, idx, vals, gp=gpo.get("gp"), trust=gpo.get("trust"), solver=fill_solver,
                                    untrusted=gpo.get("untrusted", "mask")), gpo)
    t0 = time.perf_counter()
    V, T = as_tets(V, T, allow_degenerate=fill_weights == "uniform")
    n = len(V)
    bf = boundary_faces(T, V=V)
    on_d = np.unique(bf)
    check_fill_solver(fill_solver, SOLVERS)
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


def reconstruct_volume_mask(mask, voxels, vals, *, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0), connectivity=6,
                            fill_solver="auto", method=None, partition="delaunay", weights="uniform",
                            distance="length", levels=None, curve_values=None, solver="auto",
                            duplicates="error", progress=None, gp=None, uncertainty=None, trust=None,
                            untrusted="mask"):
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
        ``auto`` is ``multigrid``.
    weights : {'uniform'}, optional
        Weights of the patches' harmonic fill (Steps 5-6): only ``uniform`` (the
        paper's average), since a digital surface has no triangles for
        cotangents; any other weight name is an OptionError.
    solver : {'auto', 'direct', 'amg', 'iterate'}, optional
        Linear solver of the patches' harmonic fill, as :func:`manifill.reconstruct`.
    progress : callable, optional
        Told the name of each step as it starts.
    method, partition, distance, levels, curve_values, duplicates
        Steps 1-6, as :func:`manifill.reconstruct`.
    gp, uncertainty, trust, untrusted
        ``method='gp'`` only: the gp over the voxels, samples anywhere in the mask
        (:func:`manifill.solid.gp.gp_voxels`, ``fill_solver`` its solver).

    Returns
    -------
    VolumeReconstruction
        ``surface_voxels`` lists the voxel of each surface vertex, ``samples``
        the sampled voxels.

    Raises
    ------
    SampleError
        A sample off the boundary, out of the grid, or malformed.
    MeshError
        A malformed ``spacing`` or ``origin``.
    OptionError
        An option outside its set, or ``weights`` other than ``uniform``.
    ResourceError
        The fill is predicted not to fit in the memory available; checked
        before Steps 1-6.

    Examples
    --------
    >>> x, y, z = np.indices((20, 20, 20)) - 9.5
    >>> mask = x**2 + y**2 + z**2 < 81
    >>> from manifill.solid.boundary import boundary_voxels
    >>> on = np.argwhere(boundary_voxels(mask))[::9]
    >>> r = reconstruct_volume_mask(mask, on, on[:, 0] * 1.0)
    >>> bool(np.allclose(r.values[tuple(on.T)], on[:, 0]))
    True
    """
    t0 = time.perf_counter()
    check_options(method, partition, weights, distance, curve_values, solver, "error", "gauss-seidel", "gvf")
    if weights != "uniform":
        raise OptionError(f"weights={weights!r} needs triangles, and a digital surface has none; pass "
                          f"weights='uniform' (the paper's average), or a triangle mesh of the solid")
    mask = as_mask(mask)
    connectivity = as_connectivity(connectivity)
    h = as_spacing(spacing)
    check_fill_solver(fill_solver, FILL_SOLVERS)
    # before the digital surface and Steps 1-6
    check_fits(*mask_fill_estimate(mask, fill_solver, connectivity))
    gpo = split_gp_options(method, {"gp": gp, "uncertainty": uncertainty, "trust": trust, "untrusted": untrusted})
    if method == "gp":  # the gp over the voxels, samples anywhere in the mask
        return finish(gp_voxels(mask, voxels, vals, spacing=h, origin=origin, connectivity=connectivity, gp=gp,
                                    trust=trust, untrusted=untrusted, solver=fill_solver, duplicates=duplicates), gpo)
    on_d, P, E, normals = digital_surface(mask, h, origin, connectivity)
    voxels = as_voxels(voxels, mask.shape, unique=False)  # repeats are merged (or refused) by duplicates
    where = surface_vertex_of_voxels(on_d, voxels, mask.shape)
    sidx, svals, squeeze = as_samples(where, vals, len(on_d), duplicates=duplicates)
    seconds = {"validate": time.perf_counter() - t0}
    t = time.perf_counter()
    surface = digital_surface_graph(P, E, normals, distance=distance)
    seconds["graph"] = time.perf_counter() - t
    surf = reconstruct_surface(surface, sidx, svals, method=method, partition=partition, weights="uniform",
                               levels=levels, curve_values=curve_values, solver=solver, on_empty="error",
                               iteration="gauss-seidel", init="gvf", seed=0, tol=None, maxiter=None,
                               progress=progress, seconds=seconds)
    if squeeze:
        surf.values = surf.values[:, 0]
    fixed = np.zeros(mask.shape, dtype=bool)
    fixed[tuple(on_d.T)] = True
    tick(progress, "fill")
    t = time.perf_counter()
    fill = VoxelFill(mask, on_d, spacing=h, connectivity=connectivity, solver=fill_solver)
    values = fill.solve(surf.values)  # one row per vertex of the digital surface, i.e. per voxel of on_d
    seconds = dict(surf.report["seconds"])
    seconds["fill"] = time.perf_counter() - t
    seconds["total"] = time.perf_counter() - t0
    return VolumeReconstruction(values, "voxels", surf, mask=mask, spacing=h,
                                origin=as_origin(origin), fixed=fixed, surface_voxels=on_d,
                                report={"fill": fill.report, "shape": list(mask.shape), "seconds": seconds},
                                samples=on_d[sidx])
