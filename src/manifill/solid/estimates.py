"""Memory of whole solid reconstructions, estimated before anything large is made.

The estimates of the single steps live with them (:func:`manifill.solid.voxelize.voxelize_memory`,
:func:`manifill.solid.tetrahedralize.tetrahedralize_memory`, :func:`manifill.solid.fill.fill_memory`,
:func:`manifill.solid.fill.tet_fill_memory`); here they are combined for the three entry points of
:mod:`manifill.solid.reconstruct_volume`, each as ``(bytes, what, fix)`` for
:func:`manifill.memory.check_fits`, and the fill solvers each form of solid takes are checked.

Which fill solver ``auto`` is
-----------------------------
Voxels: ``multigrid`` (geometric multigrid on the grid, the least memory).
Tets: ``direct`` up to :data:`manifill.solid.fill.AUTO_DIRECT_MAX` free vertices, ``amg``
above (as :func:`manifill.solid.fill.tet_fill`). ``multigrid`` is for voxels only and is
refused for tets.
"""

import math

import numpy as np

from ..errors import OptionError
from ..mesh.tetmesh import TET_WEIGHTS
from ..validate import as_mesh, check_option
from ..validate.constraints import Flag, Number, OneOf, check
from .fill import AUTO_DIRECT_MAX, FILL_SOLVERS, fill_memory, tet_fill_memory
from .tetrahedralize import check_max_volume, tet_count_on_mesh, tet_words, tetrahedralize_memory
from .voxels import CONNECTIVITY, as_connectivity
from .voxelize import grid_words, solid_voxels, voxel_grid, voxelize_memory_on_grid

__all__ = ["FORMS", "TET_FILL_SOLVERS", "VOLUME_CONSTRAINTS", "check_volume_options", "check_fill_solver",
           "reconstruct_volume_memory", "volume_estimate",
           "mask_fill_estimate", "tet_mesh_fill_estimate", "n_fields"]

FORMS = ("voxels", "tets")
#: The fill solvers of a solid made of tets (by :func:`manifill.solid.tetrahedralize.tetrahedralize`).
TET_FILL_SOLVERS = ("auto", "amg", "direct")

#: What the solid's own options take (:mod:`manifill.validate.constraints`): checked on entry by
#: :func:`manifill.reconstruct_volume` and its siblings (:func:`check_volume_options`), read by the command line,
#: tried with a wrong value by a test. (A whole ``resolution``, and which fill solvers each form takes, are checked
#: where they are used, with messages of their own.)
VOLUME_CONSTRAINTS = {
    "form": [OneOf(*FORMS)], "resolution": [Number(lo=2)], "connectivity": [OneOf(*CONNECTIVITY)],
    "max_volume": [None, Number(lo=0, lo_open=True)], "fill_solver": [OneOf(*FILL_SOLVERS)],
    "fill_weights": [OneOf(*TET_WEIGHTS)], "allow_open": [Flag()],
}


def check_volume_options(**given):
    """Check the solid's options given (names of :data:`VOLUME_CONSTRAINTS`) against their table."""
    for name, value in given.items():
        check(name, value, VOLUME_CONSTRAINTS[name])


def check_fill_solver(fill_solver, choices=FILL_SOLVERS):
    """Refuse a fill solver outside ``choices``, naming why ``multigrid`` is not one of them.

    Parameters
    ----------
    fill_solver : str
    choices : tuple of str, optional
        The solvers of this form of solid: :data:`manifill.solid.fill.FILL_SOLVERS`
        for voxels, :data:`TET_FILL_SOLVERS` for tets.

    Raises
    ------
    OptionError
        ``fill_solver`` not in ``choices``.

    Examples
    --------
    >>> check_fill_solver("multigrid")
    >>> check_fill_solver("multigrid", TET_FILL_SOLVERS)
    Traceback (most recent call last):
    ...
    manifill.errors.OptionError: fill_solver='multigrid' is for voxels; for tets use 'auto', 'amg' or 'direct' ...
    """
    if fill_solver == "multigrid" and "multigrid" not in choices:
        names = ", ".join(repr(c) for c in choices[:-1]) + f" or {choices[-1]!r}"
        raise OptionError(f"fill_solver='multigrid' is for voxels; for tets use {names} (CLI --fill-solver)")
    check_option("fill_solver", fill_solver, choices)


def n_fields(vals):
    """Columns of ``vals`` for an estimate (1 when it is not a table; validation comes later).

    Examples
    --------
    >>> n_fields([[1.0, 2.0]]), n_fields([1.0, 2.0]), n_fields(None)
    (2, 1, 1)
    """
    try:
        shape = np.shape(vals)
    except (TypeError, ValueError):
        return 1
    return int(shape[1]) if len(shape) == 2 else 1


def volume_estimate(V, F, form, resolution, connectivity, max_volume, fill_solver, fields=1):
    """Peak bytes of the volume steps of :func:`manifill.solid.reconstruct_volume.reconstruct_volume`.

    Parameters
    ----------
    V : (n, 3) array_like
    F : (m, 3) array_like of int
    form, resolution, connectivity, max_volume, fill_solver
        As :func:`manifill.solid.reconstruct_volume.reconstruct_volume`, ``form``
        and ``fill_solver`` checked already.
    fields : int, optional
        Fields reconstructed.

    Returns
    -------
    bytes : float
    what : str
        What needs them, for the message.
    fix : str
        How to need less.
    """
    V, F = as_mesh(V, F, allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    p = max(int(fields), 1)
    if form == "voxels":
        connectivity = as_connectivity(connectivity)
        shape, h, _ = voxel_grid(V, resolution)
        voxels, _ = voxelize_memory_on_grid(V, F, shape, h)
        N = math.prod(float(c) for c in shape)
        unknowns = min(N, solid_voxels(V, F, h))
        solver = "multigrid" if fill_solver == "auto" else fill_solver
        # the mask and D are held through the fill; each further field adds its grid of values
        fill = 2.0 * N + fill_memory(shape, unknowns, solver, connectivity) + 8.0 * N * (p - 1)
        fix = "lower the resolution (CLI --resolution)"
        if solver != "multigrid":
            fix += " or use fill_solver='multigrid' (CLI --fill-solver multigrid)"
        return max(voxels, fill), f"the voxel form at {grid_words(int(resolution), shape)} ({solver} fill)", fix
    check_max_volume(max_volume)
    tets = tet_count_on_mesh(V, F, max_volume)
    vertices = len(V) + tets / 6.0  # tetgen's meshes have about 6 tets per vertex
    fill = tet_fill_memory(vertices, tets, len(V), fill_solver) + 32.0 * (vertices + tets) + 8.0 * vertices * p
    fix = "raise max_volume (CLI --max-volume)"
    if fill_solver == "direct" or (fill_solver == "auto" and vertices - len(V) <= AUTO_DIRECT_MAX):
        fix += " or use fill_solver='amg' (CLI --fill-solver amg)"
    what = f"{tet_words(max_volume, tets)} and its fill"
    return max(tetrahedralize_memory(V, F, max_volume=max_volume), fill), what, fix


def mask_fill_estimate(mask, fill_solver, connectivity):
    """Peak bytes of :func:`manifill.solid.reconstruct_volume.reconstruct_volume_mask` past Steps 1-6.

    The digital surface (about 40 bytes per voxel of the grid) or the fill, with
    at most every voxel of the mask unknown, and the mask and D.

    Parameters
    ----------
    mask : (n0, n1, n2) bool numpy array
        Validated.
    fill_solver : {'auto', 'multigrid', 'amg', 'direct'}
    connectivity : {6, 18, 26}

    Returns
    -------
    bytes : float
    what, fix : str
        For :func:`manifill.memory.check_fits`.
    """
    solver = "multigrid" if fill_solver == "auto" else fill_solver
    voxels = int(np.count_nonzero(mask))
    need = max(fill_memory(mask.shape, voxels, solver, connectivity), 40.0 * mask.size) + 2.0 * mask.size
    what = f"the fill of a {' x '.join(str(c) for c in mask.shape)} mask of {voxels:,} voxels ({solver})"
    fix = "crop or downsample the mask" + ("" if solver == "multigrid" else
                                           " or use fill_solver='multigrid' (CLI --fill-solver multigrid)")
    return need, what, fix


def tet_mesh_fill_estimate(n_vertices, n_tets, n_fixed, fill_solver):
    """Peak bytes of :func:`manifill.solid.reconstruct_volume.reconstruct_volume_tets`'s fill.

    Parameters
    ----------
    n_vertices, n_tets, n_fixed : int
        The mesh and its boundary vertices.
    fill_solver : {'auto', 'direct', 'amg', 'iterate'}

    Returns
    -------
    bytes : float
    what, fix : str
        For :func:`manifill.memory.check_fits`.
    """
    free = n_vertices - n_fixed
    factorised = fill_solver == "direct" or (fill_solver == "auto" and free <= AUTO_DIRECT_MAX)
    return (tet_fill_memory(n_vertices, n_tets, n_fixed, fill_solver),
            f"the harmonic fill of {free:,} tet vertices ({fill_solver})",
            ("use fill_solver='amg' (CLI --fill-solver amg) or " if factorised else "use ")
            + "a coarser tetrahedral mesh")


def reconstruct_volume_memory(V, F, *, form="voxels", resolution=128, connectivity=6, max_volume=None,
                              fill_solver="auto", n_fields=1):
    """Estimated peak memory of the volume steps of :func:`manifill.solid.reconstruct_volume.reconstruct_volume`.

    ``form='voxels'``: the larger of the voxelisation
    (:func:`manifill.solid.voxelize.voxelize_memory`) and the fill
    (:func:`manifill.solid.fill.fill_memory`, with the unknowns from the volume
    the surface encloses, :func:`manifill.solid.tets.surface_volume`), on the grid
    that ``resolution`` makes of the bounding box. ``form='tets'``: the larger
    of TetGen's mesh (:func:`manifill.solid.tetrahedralize.tetrahedralize_memory`) and its
    fill (:func:`manifill.solid.fill.tet_fill_memory`). Steps 1-6 on the surface
    are not counted.

    Parameters
    ----------
    V : (n, 3) array_like
    F : (m, 3) array_like of int
    form, resolution, connectivity, max_volume, fill_solver
        As :func:`manifill.solid.reconstruct_volume.reconstruct_volume`.
    n_fields : int, optional
        Fields reconstructed (columns of ``vals``).

    Returns
    -------
    float
        Bytes.

    Raises
    ------
    MeshError, OptionError
        A malformed mesh or option (``fill_solver='multigrid'`` with ``form='tets'``).

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
    check_fill_solver(fill_solver, FILL_SOLVERS if form == "voxels" else TET_FILL_SOLVERS)
    return volume_estimate(V, F, form, resolution, connectivity, max_volume, fill_solver, n_fields)[0]
