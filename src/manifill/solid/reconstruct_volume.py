"""Steps 1-8 on a solid: reconstruct on its boundary surface D, then fill the inside.

Three forms of solid, one result (:class:`VolumeReconstruction`):

``reconstruct_volume(V, F, idx, vals, form=...)``
    A closed triangle mesh with samples at its vertices. Steps 1-6 run on the
    mesh itself; ``form='voxels'`` voxelises the solid (winding numbers) and
    gives every boundary voxel the surface field at its closest surface point;
    ``form='tets'`` tetrahedralises it with the surface kept (TetGen), so D is
    the mesh. Step 8 fills the inside.
``reconstruct_volume_tets(V, T, idx, vals)``
    A tetrahedral mesh (e.g. read from VTU or MSH); D is its boundary triangles
    and the samples are vertices on them.
``reconstruct_volume_mask(mask, idx, vals, spacing=..., origin=...)``
    A voxel mask; D is its boundary voxels, a digital surface whose graph
    joins boundary voxels that touch (26 neighbours) and whose normals come
    from the smoothed mask. Steps 1-6 run on that graph with the paper's
    uniform averaging.
"""

import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..errors import SampleError
from ..mesh.objects import mesh_arrays
from ..memory import check_fits
from ..progress import tick
from ..linalg.backends import SOLVERS
from ..surface.reconstruct import Reconstruction, _check_options, _pipeline, _Surface, reconstruct
from .tets import _check_max_volume, _tet_count, _tet_words, boundary_faces, tetrahedralize
from .tets import tetrahedralize_memory
from ..validate import as_mask, as_mesh, as_samples, as_tets, check_option
from .fill import _AUTO_DIRECT_MAX, FILL_SOLVERS, VoxelFill, fill_memory, tet_fill, tet_fill_memory
from .voxels import (_grid_words, _solid_voxels, _voxelize_memory, as_connectivity, as_origin, as_spacing,
                     boundary_voxels, neighbour_offsets, voxel_centres, voxel_grid, voxelize)

__all__ = ["FORMS", "VolumeReconstruction", "digital_surface", "reconstruct_volume", "reconstruct_volume_tets",
           "reconstruct_volume_mask", "surface_to_points", "reconstruct_volume_memory"]

FORMS = ("voxels", "tets")


@dataclass
class VolumeReconstruction:
    """The result of the ``reconstruct_volume`` functions.

    Attributes
    ----------
    values : numpy array
        ``form='voxels'``: shaped like ``mask`` (plus a field axis for several
        fields), NaN outside the solid. ``form='tets'``: one row per vertex of
        ``TV``.
    form : {'voxels', 'tets'}
    surface : Reconstruction
        Steps 1-6 on the boundary surface (on the digital surface for a mask:
        its vertices are ``surface_voxels``).
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

    def point_data(self, names=None):
        """The fields and the boundary mask, named as in every output file.

        Parameters
        ----------
        names : list of str, optional
            One name per field (``value``, ``value2``, ... by default).

        Returns
        -------
        dict of str to numpy array
            Voxels: ``(n0, n1, n2)`` arrays; tets: ``(N,)`` arrays.
        """
        from ..io.registry import BOUNDARY_MASK
        from ..surface.samples import field_names

        X = self.values if self.values.ndim == (4 if self.form == "voxels" else 2) else self.values[..., None]
        data = dict(zip(field_names(names, X.shape[-1]), np.moveaxis(X, -1, 0)))
        if self.form == "voxels":
            data[BOUNDARY_MASK] = self.fixed
        else:
            boundary = np.zeros(len(self.TV), dtype=bool)
            boundary[np.unique(boundary_faces(self.TT))] = True
            data[BOUNDARY_MASK] = boundary
        return data

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
        from ..errors import OptionError
        from ..mesh.objects import to_meshio

        if self.form != "tets":
            raise OptionError("a voxel result has no meshio form; use to_pyvista() or manifill.io.solids.write_vti")
        return to_meshio(self.TV, self.TT, self.point_data(names))


def surface_to_points(V, F, values, P):
    """Values of a surface field at the closest surface point of each query point.

    Parameters
    ----------
    V : (n, 3) numpy array
    F : (m, 3) numpy array of int
    values : (n,) or (n, p) numpy array
        The field at the vertices (linear on each triangle).
    P : (q, 3) numpy array
        Query points.

    Returns
    -------
    values : (q,) or (q, p) numpy array
    distance : (q,) numpy array
        From each point to the surface.

    Notes
    -----
    The closest points and their barycentric coordinates are computed on
    ``V / s`` and ``P / s``, ``s`` the power of two of
    :func:`manifill.validate.unit_scale` (1 for meshes of the usual sizes), and
    the distances multiplied back by ``s``: squared lengths of a mesh of size
    ``1e-150`` underflow and of ``1e150`` overflow, their ratios do not.
    """
    import igl

    from ..validate import unit_scale

    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    s = unit_scale(V)
    V = V / s  # exact
    P = np.asarray(P, dtype=np.float64) / s
    d2, face, C = igl.point_mesh_squared_distance(np.ascontiguousarray(P), np.ascontiguousarray(V),
                                                  np.ascontiguousarray(F))
    tri = F[face]
    a, b, c = V[tri[:, 0]], V[tri[:, 1]], V[tri[:, 2]]
    # barycentric coordinates of the closest point (which lies on the triangle)
    v0, v1, v2 = b - a, c - a, C - a
    d00 = np.einsum("ij,ij->i", v0, v0)
    d01 = np.einsum("ij,ij->i", v0, v1)
    d11 = np.einsum("ij,ij->i", v1, v1)
    d20 = np.einsum("ij,ij->i", v2, v0)
    d21 = np.einsum("ij,ij->i", v2, v1)
    den = d00 * d11 - d01 * d01
    den = np.where(den > 0, den, 1.0)
    wb = np.clip((d11 * d20 - d01 * d21) / den, 0, 1)
    wc = np.clip((d00 * d21 - d01 * d20) / den, 0, 1)
    wa = np.clip(1.0 - wb - wc, 0, 1)
    total = wa + wb + wc
    w = np.column_stack([wa, wb, wc]) / total[:, None]
    vals = np.asarray(values, dtype=np.float64)
    X = vals[:, None] if vals.ndim == 1 else vals
    out = np.einsum("qk,qkp->qp", w, X[tri])
    return (out[:, 0] if vals.ndim == 1 else out), np.sqrt(d2) * s


def _surface_options(options):
    allowed = {"method", "partition", "weights", "distance", "levels", "curve_values", "solver", "on_empty",
               "duplicates", "iteration", "init", "seed", "tol", "maxiter", "progress"}
    bad = sorted(set(options) - allowed)
    if bad:
        raise TypeError(f"unexpected keyword argument {bad[0]!r}; the surface options are those of "
                        f"manifill.reconstruct: {', '.join(sorted(allowed))}")
    return options


def _n_fields(vals):
    """Columns of ``vals`` for the estimate (1 when it is not a table; validation comes later)."""
    try:
        shape = np.shape(vals)
    except (TypeError, ValueError):
        return 1
    return int(shape[1]) if len(shape) == 2 else 1


def _volume_estimate(V, F, form, resolution, connectivity, max_volume, fill_solver, n_fields):
    """Peak bytes of the volume steps of :func:`reconstruct_volume`, what needs them and how to need less."""
    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    p = max(int(n_fields), 1)
    if form == "voxels":
        connectivity = as_connectivity(connectivity)
        shape, h, _ = voxel_grid(V, resolution)
        voxels, _ = _voxelize_memory(V, F, shape, h)
        N = math.prod(float(c) for c in shape)
        unknowns = min(N, _solid_voxels(V, F, h))
        solver = "multigrid" if fill_solver == "auto" else fill_solver
        # the mask and D are held through the fill; each further field adds its grid of values
        fill = 2.0 * N + fill_memory(shape, unknowns, solver, connectivity) + 8.0 * N * (p - 1)
        fix = "lower the resolution (CLI --resolution)"
        if solver != "multigrid":
            fix += " or use fill_solver='multigrid' (CLI --fill-solver multigrid)"
        return max(voxels, fill), f"the voxel form at {_grid_words(int(resolution), shape)} ({solver} fill)", fix
    _check_max_volume(max_volume)
    tets = _tet_count(V, F, max_volume)
    vertices = len(V) + tets / 6.0  # tetgen's meshes have about 6 tets per vertex
    solver = "auto" if fill_solver in ("auto", "multigrid") else fill_solver
    fill = tet_fill_memory(vertices, tets, len(V), solver) + 32.0 * (vertices + tets) + 8.0 * vertices * p
    fix = "raise max_volume (CLI --max-volume)"
    if solver == "direct" or (solver == "auto" and vertices - len(V) <= _AUTO_DIRECT_MAX):
        fix += " or use fill_solver='amg' (CLI --fill-solver amg)"
    what = f"{_tet_words(max_volume, tets)} and its fill"
    return max(tetrahedralize_memory(V, F, max_volume=max_volume), fill), what, fix


def reconstruct_volume_memory(V, F, *, form="voxels", resolution=128, connectivity=6, max_volume=None,
                              fill_solver="auto", n_fields=1):
    """Estimated peak memory of the volume steps of :func:`reconstruct_volume`, in bytes.

    ``form='voxels'``: the larger of the voxelisation
    (:func:`manifill.solid.voxels.voxelize_memory`) and the fill
    (:func:`manifill.solid.fill.fill_memory`, with the unknowns from the volume
    the surface encloses, :func:`manifill.solid.tets.surface_volume`), on the grid
    that ``resolution`` makes of the bounding box. ``form='tets'``: the larger
    of TetGen's mesh (:func:`manifill.solid.tets.tetrahedralize_memory`) and its
    fill (:func:`manifill.solid.fill.tet_fill_memory`). Steps 1-6 on the surface
    are not counted.

    Parameters
    ----------
    V : (n, 3) array_like
    F : (m, 3) array_like of int
    form, resolution, connectivity, max_volume, fill_solver
        As :func:`reconstruct_volume`.
    n_fields : int, optional
        Fields reconstructed (columns of ``vals``).

    Returns
    -------
    float

    Raises
    ------
    MeshError, OptionError
        A malformed mesh or option.

    Examples
    --------
    >>> from manifill.memory import human
    >>> from manifill.mesh.shapes import icosphere
    >>> human(reconstruct_volume_memory(*icosphere(3), resolution=96))  # 175 MB measured
    '172 MB'
    >>> human(reconstruct_volume_memory(*icosphere(3), resolution=3000))
    '4.7 TB'
    """
    check_option("form", form, FORMS)
    check_option("fill_solver", fill_solver, FILL_SOLVERS)
    return _volume_estimate(V, F, form, resolution, connectivity, max_volume, fill_solver, n_fields)[0]


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
        Solver of the fill (``multigrid`` is for voxels only).
    fill_weights : {'cotan', 'uniform'}, optional
        Tetrahedral weights (``form='tets'``).
    allow_open : bool, optional
        Voxelise an open surface by winding numbers instead of refusing it.
    **options
        Passed to :func:`manifill.reconstruct` for Steps 1-6 (``method``,
        ``partition``, ``weights``, ``curve_values``, ...).

    Returns
    -------
    VolumeReconstruction

    Raises
    ------
    MeshError
        A malformed or open surface (see ``allow_open``).
    ResourceError
        The volume steps are predicted not to fit in the memory available
        (:func:`reconstruct_volume_memory`); checked before Steps 1-6.
    SampleError, OptionError, SolveError
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
    check_option("fill_solver", fill_solver, FILL_SOLVERS)
    V, F = mesh_arrays(V, F)
    _surface_options(options)
    # refuse a volume that will not fit before Steps 1-6 on the surface
    check_fits(*_volume_estimate(V, F, form, resolution, connectivity, max_volume, fill_solver, _n_fields(vals)))
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
        fill = VoxelFill(mask, fixed, spacing=spacing, connectivity=connectivity, solver=fill_solver)
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
    values = tet_fill(TV, TT, np.arange(len(V)), surf.values, weights=fill_weights,
                      solver="auto" if fill_solver in ("auto", "multigrid") else fill_solver)
    seconds["fill"] = time.perf_counter() - t
    seconds["total"] = time.perf_counter() - t0
    report = {"vertices": len(TV), "tets": len(TT), "seconds": seconds}
    return VolumeReconstruction(values, "tets", surf, TV=TV, TT=TT, report=report)


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
    fill_solver : {'auto', 'direct', 'amg'}, optional
    **options
        Passed to :func:`manifill.reconstruct` for Steps 1-6.

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
    """
    _surface_options(options)
    t0 = time.perf_counter()
    V, T = as_tets(V, T, allow_degenerate=fill_weights == "uniform")
    n = len(V)
    bf = boundary_faces(T, V=V)
    on_d = np.unique(bf)
    check_option("fill_solver", fill_solver, SOLVERS)
    free = n - on_d.size
    factorised = fill_solver == "direct" or (fill_solver == "auto" and free <= _AUTO_DIRECT_MAX)
    check_fits(tet_fill_memory(n, len(T), on_d.size, fill_solver),
               f"the harmonic fill of {free:,} tet vertices ({fill_solver})",
               ("use fill_solver='amg' (CLI --fill-solver amg) or " if factorised else "use ")
               + "a coarser tetrahedral mesh")
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
                                        "seconds": seconds})


def digital_surface(mask, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0), connectivity=6):
    """The boundary voxels of a mask as a surface graph with positions and normals.

    Parameters
    ----------
    mask : (n0, n1, n2) bool array_like
    spacing, origin : (3,) array_like of float, optional
    connectivity : {6, 18, 26}, optional
        Which neighbours outside the mask make a voxel a boundary voxel.

    Returns
    -------
    voxels : (d, 3) int64 numpy array
        The boundary voxels, C order.
    P : (d, 3) numpy array
        Their centres.
    E : (e, 2) int64 numpy array
        Pairs of boundary voxels that touch (26 neighbours), ``i < j``.
    normals : (d, 3) numpy array
        Outward unit normals from the gradient of the smoothed mask.
    """
    from scipy import ndimage

    mask = as_mask(mask)
    h = as_spacing(spacing)
    origin = as_origin(origin)
    D = boundary_voxels(mask, connectivity)
    voxels = np.argwhere(D)
    P = voxel_centres(mask.shape, h, origin, where=D)
    ids = np.full(mask.shape, -1, dtype=np.int64)
    ids[D] = np.arange(len(voxels))
    pad = np.pad(ids, 1, constant_values=-1)
    E = []
    for d in neighbour_offsets(26):
        there = pad[tuple(slice(1 + s, 1 + s + n) for s, n in zip(d, mask.shape))]
        both = D & (there >= 0)
        E.append(np.column_stack([ids[both], there[both]]))
    E = np.sort(np.concatenate(E), axis=1)
    smooth = ndimage.gaussian_filter(mask.astype(np.float64), sigma=1.0 / h * h.min(), mode="constant")
    # an axis one voxel thick has no difference along it (np.gradient needs two)
    grad = np.stack([np.gradient(smooth, h[a], axis=a)[D] if mask.shape[a] > 1 else np.zeros(len(voxels))
                     for a in range(3)], axis=1)
    norm = np.linalg.norm(grad, axis=1, keepdims=True)
    normals = np.divide(-grad, norm, out=np.zeros_like(grad), where=norm > 0)
    return voxels, P, E, normals


def _graph(n, E, w):
    A = sp.csr_array((np.concatenate([w, w]), (np.concatenate([E[:, 0], E[:, 1]]),
                                              np.concatenate([E[:, 1], E[:, 0]]))), shape=(n, n))
    A.sum_duplicates()
    A.sort_indices()
    return A


def reconstruct_volume_mask(mask, idx, vals, *, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0), connectivity=6,
                            fill_solver="auto", method="gvf-harmonic", partition="delaunay", distance="length",
                            levels=None, curve_values="hermite", duplicates="error", progress=None):
    """Steps 1-8 on a voxel mask: reconstruct on its digital boundary surface, fill the inside.

    Parameters
    ----------
    mask : (n0, n1, n2) bool array_like
        The solid.
    idx : (k, 3) array_like of int
        Voxel indices of the samples, each a boundary voxel of the mask
        (:func:`manifill.solid.voxels.boundary_voxels`).
    vals : (k,) or (k, p) array_like of float
    spacing, origin : (3,) array_like of float, optional
    connectivity : {6, 18, 26}, optional
        Neighbours of the fill (and which voxels are boundary).
    fill_solver : {'auto', 'multigrid', 'amg', 'direct'}, optional
    progress : callable, optional
        Told the name of each step as it starts.
    method, partition, distance, levels, curve_values, duplicates
        Steps 1-6, as :func:`manifill.reconstruct`; the patches are filled with
        uniform weights (the paper's average), since a digital surface has no
        triangles for cotangents.

    Returns
    -------
    VolumeReconstruction
        ``surface_voxels`` lists the voxel of each surface vertex.

    Raises
    ------
    SampleError
        A sample off the boundary, out of the grid, or malformed.
    ResourceError
        The fill is predicted not to fit in the memory available; checked
        before Steps 1-6.

    Examples
    --------
    >>> x, y, z = np.indices((20, 20, 20)) - 9.5
    >>> mask = x**2 + y**2 + z**2 < 81
    >>> from manifill.solid.voxels import boundary_voxels
    >>> on = np.argwhere(boundary_voxels(mask))[::9]
    >>> r = reconstruct_volume_mask(mask, on, on[:, 0] * 1.0)
    >>> bool(np.allclose(r.values[tuple(on.T)], on[:, 0]))
    True
    """
    t0 = time.perf_counter()
    _check_options(method, partition, "uniform", distance, curve_values, "auto", "error", "gauss-seidel", "gvf")
    mask = as_mask(mask)
    connectivity = as_connectivity(connectivity)
    h = as_spacing(spacing)
    check_option("fill_solver", fill_solver, FILL_SOLVERS)
    # before the digital surface (about 40 bytes per voxel) and Steps 1-6: the fill, with at most every
    # voxel of the mask unknown
    solver = "multigrid" if fill_solver == "auto" else fill_solver
    voxels = int(np.count_nonzero(mask))
    check_fits(max(fill_memory(mask.shape, voxels, solver, connectivity), 40.0 * mask.size) + 2.0 * mask.size,
               f"the fill of a {' x '.join(str(c) for c in mask.shape)} mask of {voxels:,} voxels ({solver})",
               "crop or downsample the mask" + ("" if solver == "multigrid" else
                                                 " or use fill_solver='multigrid' (CLI --fill-solver multigrid)"))
    voxels, P, E, normals = digital_surface(mask, h, origin, connectivity)
    try:
        ijk = np.asarray(idx)
    except (TypeError, ValueError):
        ijk = np.empty((0,))
    if ijk.ndim != 2 or ijk.shape[1] != 3 or not np.issubdtype(ijk.dtype, np.integer):
        raise SampleError(f"idx has shape {np.shape(idx)}; pass (k, 3) integer voxel indices of boundary voxels")
    if ((ijk < 0) | (ijk >= np.array(mask.shape))).any():
        raise SampleError(f"a sample voxel lies outside the grid {mask.shape}; pass voxel indices inside it")
    pos = np.full(mask.shape, -1, dtype=np.int64)
    pos[tuple(voxels.T)] = np.arange(len(voxels))
    where = pos[tuple(ijk.T)]
    if (where < 0).any():
        v = tuple(int(c) for c in ijk[np.flatnonzero(where < 0)[0]])
        raise SampleError(f"{int((where < 0).sum())} samples are not on boundary voxels of the mask (e.g. voxel {v}); "
                          f"place them on manifill.solid.voxels.boundary_voxels(mask)")
    sidx, svals, squeeze = as_samples(where, vals, len(voxels), duplicates=duplicates)
    seconds = {"validate": time.perf_counter() - t0}
    t = time.perf_counter()
    n = len(voxels)
    length = np.linalg.norm(P[E[:, 0]] - P[E[:, 1]], axis=1)
    G_hops = _graph(n, E, np.ones(len(E)))
    G = G_hops if distance == "hops" else _graph(n, E, length / length.mean() if len(E) else length)

    def laplacian(weights):
        deg = np.asarray(G_hops.sum(axis=1)).ravel()
        L = sp.csr_array(sp.diags_array(deg) - G_hops)
        L.sort_indices()
        return L

    seconds["graph"] = time.perf_counter() - t
    surface = _Surface(P, G_hops, G, laplacian, normals=normals)
    surf = _pipeline(surface, sidx, svals, squeeze, seconds, t0, method=method, partition=partition,
                     weights="uniform", levels=levels, curve_values=curve_values, solver="auto", on_empty="error",
                     iteration="gauss-seidel", init="gvf", seed=0, tol=None, maxiter=None, progress=progress)
    fixed = np.zeros(mask.shape, dtype=bool)
    fixed[tuple(voxels.T)] = True
    tick(progress, "fill")
    t = time.perf_counter()
    fill = VoxelFill(mask, fixed, spacing=h, connectivity=connectivity, solver=fill_solver)
    values = fill.solve(surf.values)
    seconds = dict(surf.report["seconds"])
    seconds["fill"] = time.perf_counter() - t
    seconds["total"] = time.perf_counter() - t0
    return VolumeReconstruction(values, "voxels", surf, mask=mask, spacing=h,
                                origin=as_origin(origin), fixed=fixed, surface_voxels=voxels,
                                report={"fill": fill.report, "shape": list(mask.shape), "seconds": seconds})
