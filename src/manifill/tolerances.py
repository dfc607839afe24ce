"""The one place where manifill's numerical tolerances live."""

from dataclasses import dataclass

__all__ = ["TOL"]


@dataclass(frozen=True)
class Tolerances:
    """Numerical tolerances, all relative to a scale stated per field.

    Attributes
    ----------
    weld : float
        Two vertices closer than ``weld * diag`` are duplicates (``diag`` is the
        bounding-box diagonal).
    degenerate_area : float
        A face with area below ``degenerate_area * diag**2`` has zero area.
    snap : float
        A sample position farther than ``snap * diag`` from its nearest vertex
        is rejected ("wrong units?").
    amg_rtol : float
        Relative residual at which the AMG-preconditioned conjugate gradient stops.
    polyharmonic_rtol : float
        The same for the biharmonic and k-harmonic energies
        (:mod:`manifill.surface.polyharmonic`), worse conditioned (4th order), so
        tighter: the answer then matches a factorisation to about 1e-9 of the range.
    iterate_tol : float
        The paper's averaging iteration stops when the largest change in one sweep
        falls below ``iterate_tol`` times the range of the fixed values.
    grid_rtol : float
        Relative residual at which the voxel fill (:class:`manifill.solid.fill.VoxelFill`,
        multigrid or sparse) stops, and the default of :class:`manifill.linalg.gridmg.GridMultigrid`.
    norm_tiny, norm_huge : float
        A sum of squares outside ``(norm_tiny, norm_huge)`` may have under- or
        overflowed: the conjugate gradients' norm then rescales the vector first.
    sample_conflict : float
        Two samples at one vertex conflict when their values differ by more than
        ``sample_conflict`` times the largest absolute sample value.
    graph_length_quantum : float
        Edge lengths of the ``length`` mesh graph, in units of the mean edge
        length, are rounded to multiples of ``graph_length_quantum``, a power of
        two, and are at least one (no edge has length 0). Lengths equal in exact
        arithmetic (a regular mesh has many) are then equal in floating point
        whatever the mesh's units, and their sums along paths are exact: equal
        shortest paths are tied, and the ties broken the same way at every scale.
    robust_mollify : float
        Mollification factor of ``weights='robust'`` (robust-laplacian's
        ``mollify_factor``, relative to the mean edge length).
    vti_direction : float
        A VTI file's ``Direction`` matrix counts as the identity (an axis-aligned
        grid) when no entry differs from it by more than ``vti_direction``.
    lipschitz_rtol : float
        Step 1's Lipschitz search (:func:`manifill.surface.gradual.lipschitz_constant`)
        ignores envelope shortfalls and ratio gains below ``lipschitz_rtol`` relative
        to the values (round-off).
    level_slack : float
        Level indices carried in floats (envelopes, distances in hops) are compared,
        floored and ceiled with this absolute slack (:mod:`manifill.surface.gradual`).
    level_tie : float
        A sample within ``level_tie`` level steps of a rounding midpoint is a tie,
        and Step 1 verifies the rounded levels with a shortest-path pass.
    tiny : float
        Floor of lengths and distances that are divided by (Steps 1 and 4), so a
        zero length gives a huge ratio, not a division by zero.
    gradient_rcond : float
        Step 4's gradient fits (:mod:`manifill.surface.curve_values`): singular
        values below ``gradient_rcond`` times the largest count as zero; a quadratic
        fit with one is dropped for the linear one.
    gradient_line_rcond : float
        Step 4's linear gradient fits (two to seven neighbours, :mod:`manifill.surface.slopes`):
        a direction whose singular value is below ``gradient_line_rcond`` times the
        largest (neighbours within about 11 degrees of one line) is left out, so the
        gradient is exact along that line and zero across it rather than huge.
    grid_count : float
        :func:`manifill.solid.voxelize.voxel_grid` counts ``ceil(side / h - grid_count)``
        voxels per side: a side within ``grid_count`` voxels of a whole number of
        them (round-off in ``side / h``) gets no extra voxel.
    energy_symmetry : float
        :class:`manifill.linalg.smoothing.SmoothingFit` refuses an energy ``A`` with
        ``max |A - A^T| > energy_symmetry * max |A|``; :func:`manifill.linalg.factorise.factorise`
        factorises such an ``A`` as general, not symmetric.
    smoothing_leverage : float
        A GCV denominator ``k - tr H`` below ``smoothing_leverage * k``, or a leverage
        ``H_ii`` within ``smoothing_leverage`` of 1, makes the score infinite
        (:mod:`manifill.linalg.smoothing`).
    smoothing_null : float
        :class:`manifill.linalg.smoothing.SmoothingFit`: a generalised eigenvalue
        ``theta`` (in ``[0, 1]``) below ``smoothing_null`` is the energy's null space
        (the constants) seen through rounding, and set to 0, so that no lambda damps it.
    bound_rtol : float
        The bounds' active set (:mod:`manifill.linalg.active_set`): a free value
        violates a bound by more than ``bound_rtol`` times the field's scale (the
        largest absolute sample value or finite bound), a multiplier has the wrong
        sign by more than ``bound_rtol`` times ``sum_j |A_ij| * scale + max|c|`` (its own row).
    affine_span : float
        The thin-plate RBF (:mod:`manifill.surface.rbf`) works in the affine span of the
        positions: directions whose singular value (of the centred, unit-scaled
        positions) is below ``affine_span`` times the largest are dropped (a flat mesh
        is two-dimensional; samples on one line are one-dimensional).
    bary_vertex : float
        A closest surface point (:func:`manifill.surface.locate.locate_points`) with a
        barycentric coordinate within ``bary_vertex`` of 1 sits at that vertex; coordinates
        below it are 0 (the point is on the opposite edge).
    tie_rtol : float
        Relative margin of Step 4's "a third of the curve's length" (the vertex whose direction gives a curve
        end's tangent): a vertex within it of the third is short of it, whatever rounding says
        (:mod:`manifill.surface.curve_values`; regular meshes put vertices exactly there).
    point_rank : float
        The rows of points inside faces (barycentric constraints) are independent when
        the smallest singular value of each coupled block is above ``point_rank`` times
        its largest (:mod:`manifill.surface.samples`).
    cloud_cluster : float
        A point of a point cloud nearer than ``cloud_cluster`` times the cloud's median spacing to another is refused
        (:class:`manifill.mesh.pointcloud.Cloud`): its fan's cotangent weights and tiny area make the bi- and
        triharmonic systems singular or wrong (measured: the triharmonic fill of a sphere's cloud left the samples'
        range 10-fold with 20 points at 8e-5 of the spacing from one point; fine at 8e-4).
    """

    weld: float = 1e-12
    degenerate_area: float = 1e-14
    snap: float = 0.05
    amg_rtol: float = 1e-10
    polyharmonic_rtol: float = 1e-12
    iterate_tol: float = 1e-10
    grid_rtol: float = 1e-10
    norm_tiny: float = 1e-280
    norm_huge: float = 1e280
    sample_conflict: float = 1e-12
    graph_length_quantum: float = 2.0 ** -30
    robust_mollify: float = 1e-5
    vti_direction: float = 1e-12
    lipschitz_rtol: float = 1e-12
    level_slack: float = 1e-9
    level_tie: float = 1e-6
    tiny: float = 1e-300
    gradient_rcond: float = 1e-8
    gradient_line_rcond: float = 0.1
    grid_count: float = 1e-9
    energy_symmetry: float = 1e-10
    smoothing_leverage: float = 1e-10
    smoothing_null: float = 1e-13
    bound_rtol: float = 1e-10
    bary_vertex: float = 1e-12
    point_rank: float = 1e-10
    affine_span: float = 1e-9
    tie_rtol: float = 1e-9
    cloud_cluster: float = 1e-3


TOL = Tolerances()
