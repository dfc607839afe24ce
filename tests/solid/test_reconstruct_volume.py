"""Steps 1-8 on a solid: a closed surface's samples carried into voxels and tetrahedra, and samples in a voxel solid."""

import functools

import numpy as np
import pytest

from manifill import ManifillError, MeshError, OptionError, SampleError
from manifill.mesh.shapes import icosphere
from manifill.solid.boundary import boundary_voxels, digital_surface
from manifill.solid.reconstruct_volume import reconstruct_volume, reconstruct_volume_mask, reconstruct_volume_tets
from manifill.solid.tets import boundary_faces, tet_laplacian
from manifill.solid.voxels import voxel_centres, voxel_laplacian
from solids import CONNECTIVITIES, SPACINGS, ball, needs_tetgen, one_line, tet_ball


# ---------------------------------------------------------------------------
# Steps 1-8 on a closed surface: voxels and tets
# ---------------------------------------------------------------------------


def field(X):
    """Harmonic: x y + x + 2 z."""
    return X[:, 0] * X[:, 1] + X[:, 0] + 2 * X[:, 2]


SPHERE = icosphere(3)
ALL_V = np.arange(len(SPHERE[0]))
SOME_V = np.arange(0, len(SPHERE[0]), 5)


@functools.lru_cache(maxsize=None)
def _solid(form, sampled, resolution=24):
    V, F = SPHERE
    idx = ALL_V if sampled == "all" else SOME_V
    method = "harmonic" if sampled == "all" else "gvf-harmonic"  # all vertices sampled: the surface is exact
    grid = dict(resolution=resolution) if form == "voxels" else {}  # tets have no resolution
    return reconstruct_volume(V, F, idx, field(V[idx]), form=form, method=method, **grid)


def barycentric_closest(V, F, P):
    """The linear interpolant of field(V) at the closest surface point of each P (igl for the point, numpy after)."""
    igl = pytest.importorskip("igl")

    _, face, C = igl.point_mesh_squared_distance(P, V, F)
    out = np.empty(len(P))
    f = field(V)
    for q in range(len(P)):
        tri = F[face[q]]
        A = np.vstack([V[tri].T, np.ones(3)])
        w = np.linalg.lstsq(A, np.append(C[q], 1.0), rcond=None)[0]
        out[q] = w @ f[tri]
    return out


@needs_tetgen
def test_tets_equal_the_surface_on_d():
    V, F = SPHERE
    for sampled in ("all", "some"):
        r = _solid("tets", sampled)
        n = len(V)
        assert r.form == "tets" and r.values.shape == (len(r.TV),)
        np.testing.assert_array_equal(r.TV[:n], V)
        np.testing.assert_array_equal(r.values[:n], r.surface.values)
        idx = ALL_V if sampled == "all" else SOME_V
        np.testing.assert_allclose(r.values[idx], field(V[idx]), rtol=0, atol=1e-12)
        L = tet_laplacian(r.TV, r.TT)
        assert np.abs((L @ r.values)[n:]).max() <= 1e-9 * abs(L).max()


def test_voxels_equal_the_closest_point_interpolation_on_d():
    V, F = SPHERE
    r = _solid("voxels", "all")
    assert r.form == "voxels" and r.values.shape == r.mask.shape
    np.testing.assert_array_equal(r.fixed, boundary_voxels(r.mask, 6))
    P = voxel_centres(r.mask.shape, r.spacing, r.origin, where=r.fixed)
    np.testing.assert_allclose(r.values[r.fixed], barycentric_closest(V, F, P), rtol=0, atol=1e-12)
    assert np.isnan(r.values[~r.mask]).all() and np.isfinite(r.values[r.mask]).all()
    assert r.report["boundary_distance_max"] < 1.0  # D lies within a voxel of the surface


@needs_tetgen
@pytest.mark.parametrize("sampled", ["all", "some"])
def test_tets_and_voxels_agree(sampled):
    V, _ = SPHERE
    rt, rv = _solid("tets", sampled), _solid("voxels", sampled)
    span = float(np.ptp(rt.values))
    inner = np.arange(len(rt.TV)) >= len(V)
    ijk = np.rint((rt.TV[inner] - rv.origin) / rv.spacing).astype(int)  # nearest voxel
    vox = rv.values[tuple(ijk.T)]
    assert np.isfinite(vox).all()  # every inner tet vertex lies in the voxelised solid
    # measured at resolution 24 (63 inner tet vertices): max 4.3 % of the range, mean 1.5 % (all vertices
    # sampled); max 4.2 %, mean 1.5 % (every fifth). The voxel D lies up to 0.88 voxel inside the surface.
    assert np.abs(vox - rt.values[inner]).max() <= 0.06 * span
    assert np.abs(vox - rt.values[inner]).mean() <= 0.02 * span


@needs_tetgen
def test_tets_and_voxels_close_to_the_exact_harmonic_function():
    rt, rv = _solid("tets", "all"), _solid("voxels", "all")
    span = float(np.ptp(rt.values))
    # measured: 0.5 % (tets, the surface is exact there), 3.6 % (voxels: D sits up to a voxel inside)
    assert np.abs(rt.values - field(rt.TV)).max() <= 0.01 * span
    X = voxel_centres(rv.mask.shape, rv.spacing, rv.origin, where=rv.mask)
    assert np.abs(rv.values[rv.mask] - field(X)).max() <= 0.05 * span


def test_voxel_result_converges_with_resolution():
    V, F = SPHERE
    errs = []
    for res in (12, 24):
        r = reconstruct_volume(V, F, ALL_V, field(V), resolution=res, method="harmonic")
        X = voxel_centres(r.mask.shape, r.spacing, r.origin, where=r.mask)
        errs.append(np.abs(r.values[r.mask] - field(X)).max())
    assert errs[1] < 0.75 * errs[0]  # measured: 0.31, 0.17 (and 0.087 at 48): first order, as D is a voxel off


def test_voxels_several_fields_and_connectivity():
    V, F = SPHERE
    vals = np.column_stack([field(V[SOME_V]), V[SOME_V, 2]])
    r = reconstruct_volume(V, F, SOME_V, vals, resolution=16, connectivity=26)
    assert r.values.shape == r.mask.shape + (2,)
    np.testing.assert_array_equal(r.fixed, boundary_voxels(r.mask, 26))
    assert r.report["fill"]["connectivity"] == 26
    # the second field is z sampled exactly on the surface: the fill stays within its range
    assert np.nanmax(r.values[..., 1]) <= 1.0 and np.nanmin(r.values[..., 1]) >= -1.0


def test_reconstruct_volume_bad_input():
    V, F = SPHERE
    with pytest.raises(OptionError) as info:
        reconstruct_volume(V, F, SOME_V, field(V[SOME_V]), form="hexes")
    assert "form" in one_line(info)
    with pytest.raises((TypeError, OptionError), match="'colour'"):  # refused as manifill.reconstruct refuses it
        reconstruct_volume(V, F, SOME_V, field(V[SOME_V]), colour="red")
    with pytest.raises(ManifillError) as info:
        reconstruct_volume(V, F[1:], SOME_V, field(V[SOME_V]), resolution=8)
    assert "open" in one_line(info)
    with pytest.raises(OptionError):
        reconstruct_volume(V, F, SOME_V, field(V[SOME_V]), connectivity=7, resolution=8)
    with pytest.raises(SampleError):
        reconstruct_volume(V, F, [len(V)], [1.0], resolution=8)


# ---------------------------------------------------------------------------
# Steps 1-8 on a tetrahedral mesh
# ---------------------------------------------------------------------------


@needs_tetgen
def test_reconstruct_volume_tets():
    TV, TT = tet_ball(2)
    b = np.unique(boundary_faces(TT))
    idx = b[::4]
    r = reconstruct_volume_tets(TV, TT, idx, field(TV[idx]))
    assert r.form == "tets" and r.values.shape == (len(TV),)
    assert r.TV is not None and r.report["boundary_vertices"] == b.size
    np.testing.assert_allclose(r.values[idx], field(TV[idx]), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(r.values[b], r.surface.values)  # D is the boundary, in vertex order
    inner = np.setdiff1d(np.arange(len(TV)), b)
    L = tet_laplacian(TV, TT)
    assert np.abs((L @ r.values)[inner]).max() <= 1e-9 * abs(L).max()
    lo, hi = r.values[b].min(), r.values[b].max()
    assert r.values.min() >= lo - 0.2 * (hi - lo) and r.values.max() <= hi + 0.2 * (hi - lo)


@needs_tetgen
def test_reconstruct_volume_tets_sample_inside():
    TV, TT = tet_ball(2)
    inner = np.setdiff1d(np.arange(len(TV)), boundary_faces(TT))
    assert inner.size
    with pytest.raises(SampleError) as info:
        reconstruct_volume_tets(TV, TT, [0, int(inner[0])], [1.0, 2.0])
    msg = one_line(info)
    assert "1 samples are inside the solid" in msg and f"vertex {int(inner[0])}" in msg


# ---------------------------------------------------------------------------
# Steps 1-8 on a voxel mask
# ---------------------------------------------------------------------------


def mask_ball(spacing=(1.0, 1.0, 1.0)):
    return ball(spacing, size=16.0, radius=6.6)


@pytest.mark.parametrize("spacing", SPACINGS)
@pytest.mark.parametrize("c", CONNECTIVITIES)
def test_reconstruct_volume_mask(spacing, c):
    mask = mask_ball(spacing)
    on = np.argwhere(boundary_voxels(mask, c))[::7]
    h = np.asarray(spacing)
    vals = np.sin(0.3 * on[:, 0] * h[0]) + 0.1 * on[:, 2] * h[2]
    r = reconstruct_volume_mask(mask, on, vals, spacing=spacing, origin=(1.0, 2.0, 3.0), connectivity=c)
    assert r.form == "voxels" and r.values.shape == mask.shape
    np.testing.assert_array_equal(r.values[tuple(on.T)], vals)
    np.testing.assert_array_equal(r.fixed, boundary_voxels(mask, c))
    np.testing.assert_array_equal(r.surface_voxels, np.argwhere(r.fixed))
    np.testing.assert_array_equal(r.values[tuple(r.surface_voxels.T)], r.surface.values)
    assert np.isnan(r.values[~mask]).all() and np.isfinite(r.values[mask]).all()
    np.testing.assert_array_equal(r.origin, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(r.spacing, h)
    # the inside is the harmonic fill of D
    L = voxel_laplacian(mask, h, c)
    free = ~r.fixed[mask]
    assert np.abs((L @ r.values[mask])[free]).max() <= 1e-8 * abs(L).max() * np.abs(vals).max()


def test_reconstruct_volume_mask_several_fields_and_duplicates():
    mask = mask_ball()
    on = np.argwhere(boundary_voxels(mask))[::9]
    vals = np.column_stack([on[:, 0] * 1.0, on[:, 1] * 2.0])
    r = reconstruct_volume_mask(mask, np.vstack([on, on[:1]]), np.vstack([vals, vals[:1]]))
    assert r.values.shape == mask.shape + (2,)
    np.testing.assert_array_equal(r.values[tuple(on.T)], vals)
    with pytest.raises(SampleError):
        reconstruct_volume_mask(mask, np.vstack([on, on[:1]]), np.vstack([vals, vals[:1] + 1]))


@pytest.mark.parametrize(
    "idx, words",
    [
        (np.array([[8, 8, 8]]), "not on boundary voxels"),  # the centre of the ball
        (np.array([[0, 0, 0]]), "not on boundary voxels"),  # outside the mask
        (np.array([[99, 0, 0]]), "outside the grid"),
        (np.array([[-1, 0, 0]]), "outside the grid"),
        (np.array([[1.0, 2.0, 3.0]]), "integer"),
        (np.array([1, 2, 3]), "(k, 3)"),
        (np.zeros((2, 2), dtype=int), "(k, 3)"),
    ],
)
def test_reconstruct_volume_mask_bad_samples(idx, words):
    mask = mask_ball()
    with pytest.raises(SampleError) as info:
        reconstruct_volume_mask(mask, idx, np.ones(len(idx)))
    assert words in one_line(info)


@pytest.mark.parametrize("origin", [(1.0, 2.0), (np.nan, 0.0, 0.0), "abc", None])
def test_reconstruct_volume_mask_bad_origin(origin):
    mask = mask_ball()
    on = np.argwhere(boundary_voxels(mask))[::9]
    with pytest.raises(MeshError) as info:  # the grid is the solid's geometry, not the samples'
        reconstruct_volume_mask(mask, on, on[:, 0] * 1.0, origin=origin)
    assert "origin" in one_line(info) and not isinstance(info.value, SampleError)
    with pytest.raises(MeshError):
        digital_surface(mask, origin=origin)
    with pytest.raises(MeshError) as info:
        reconstruct_volume_mask(mask, on, on[:, 0] * 1.0, spacing=origin)
    assert "spacing" in one_line(info)


def test_reconstruct_volume_mask_bad_mask():
    with pytest.raises(MeshError) as info:
        reconstruct_volume_mask(np.zeros((5, 5, 5), dtype=bool), np.zeros((1, 3), dtype=int), [1.0])
    assert "no voxel" in one_line(info)
    with pytest.raises(OptionError):
        reconstruct_volume_mask(mask_ball(), np.zeros((1, 3), dtype=int), [1.0], connectivity=5)


# ---------------------------------------------------------------------------
# options are used or refused, never dropped or renamed
# ---------------------------------------------------------------------------


@needs_tetgen
def test_multigrid_is_refused_for_tets():
    from manifill.solid.estimates import reconstruct_volume_memory

    V, F = SPHERE
    for call in (lambda: reconstruct_volume(V, F, SOME_V, field(V[SOME_V]), form="tets", fill_solver="multigrid"),
                 lambda: reconstruct_volume_memory(V, F, form="tets", fill_solver="multigrid"),
                 lambda: reconstruct_volume_tets(*tet_ball(2), [0], [1.0], fill_solver="multigrid")):
        with pytest.raises(OptionError) as info:
            call()
        msg = one_line(info)
        assert "multigrid is for voxels" in msg.replace("'", "") and "'amg'" in msg and "'direct'" in msg
    # voxels take it, and auto is multigrid there
    r = reconstruct_volume(V, F, SOME_V, field(V[SOME_V]), resolution=12, fill_solver="multigrid")
    assert r.report["fill"]["solver"] == "multigrid"
    assert _solid("voxels", "some").report["fill"]["solver"] == "multigrid"


@needs_tetgen
def test_tet_fill_solver_is_the_one_asked_for():
    # direct and amg solve the same system: the same fill to round-off, and auto is one of them
    V, F = SPHERE
    runs = {s: reconstruct_volume(V, F, SOME_V, field(V[SOME_V]), form="tets", fill_solver=s)
            for s in ("auto", "direct", "amg")}
    np.testing.assert_allclose(runs["amg"].values, runs["direct"].values, rtol=0, atol=1e-7)
    np.testing.assert_array_equal(runs["auto"].values, runs["direct"].values)  # few unknowns: auto factorises


def test_mask_refuses_weights_it_cannot_use():
    mask = mask_ball()
    on = np.argwhere(boundary_voxels(mask))[::9]
    for w in ("cotan", "intrinsic", "robust"):
        with pytest.raises(OptionError) as info:
            reconstruct_volume_mask(mask, on, on[:, 0] * 1.0, weights=w)
        assert "uniform" in one_line(info) and "digital surface" in one_line(info)
    with pytest.raises(OptionError):
        reconstruct_volume_mask(mask, on, on[:, 0] * 1.0, weights="heavy")
    with pytest.raises(OptionError):
        reconstruct_volume_mask(mask, on, on[:, 0] * 1.0, solver="fast")


def test_mask_uses_the_surface_solver():
    mask = mask_ball()
    on = np.argwhere(boundary_voxels(mask))[::9]
    vals = np.sin(0.4 * on[:, 0]) + 0.1 * on[:, 2]
    base = reconstruct_volume_mask(mask, on, vals, weights="uniform")
    direct = reconstruct_volume_mask(mask, on, vals, solver="direct")
    it = reconstruct_volume_mask(mask, on, vals, solver="iterate")
    assert direct.surface.report["fill"]["solver"] == "direct"
    assert it.surface.report["fill"]["solver"] == "iterate"
    np.testing.assert_allclose(it.surface.values, direct.surface.values, rtol=0, atol=1e-6)
    np.testing.assert_allclose(base.values[mask], direct.values[mask], rtol=0, atol=1e-9)


def test_point_data_carries_the_boundary_and_sample_masks():
    from manifill.results import BOUNDARY_MASK, SAMPLE_MASK

    mask = mask_ball()
    on = np.argwhere(boundary_voxels(mask))[::9]
    r = reconstruct_volume_mask(mask, on, np.column_stack([on[:, 0] * 1.0, on[:, 1] * 1.0]))
    data = r.point_data(["a", "b"])
    assert list(data) == ["a", "b", BOUNDARY_MASK] and SAMPLE_MASK not in data  # the voxel files as they were
    np.testing.assert_array_equal(data[BOUNDARY_MASK], boundary_voxels(mask))
    np.testing.assert_array_equal(data["b"], r.values[..., 1], strict=True)
    assert {tuple(v) for v in r.samples.tolist()} == {tuple(v) for v in on.tolist()}


@pytest.mark.parametrize("form, option", [("tets", dict(resolution=64)), ("tets", dict(connectivity=26)),
                                          ("tets", dict(allow_open=True)), ("voxels", dict(max_volume=0.01)),
                                          ("voxels", dict(fill_weights="uniform"))])
def test_options_of_the_other_form_are_refused(form, option):
    V, F = SPHERE
    with pytest.raises(OptionError) as info:
        reconstruct_volume(V, F, SOME_V, field(V[SOME_V]), form=form, **option)
    name = next(iter(option))
    assert one_line(info).startswith(f"{name}=") and "does nothing with form" in one_line(info)


# ---------------------------------------------------------------------------
# one vocabulary: fill_solver / fill_weights for the inside, **options for the surface step
# ---------------------------------------------------------------------------


def test_the_three_entry_points_speak_one_way():
    import inspect

    sigs = {f.__name__: inspect.signature(f).parameters
            for f in (reconstruct_volume, reconstruct_volume_tets, reconstruct_volume_mask)}
    for name, params in sigs.items():
        assert params["fill_solver"].default == "auto", name
        assert list(params.values())[-1].kind is inspect.Parameter.VAR_KEYWORD, name  # the surface step's options
        assert not {"solver", "weights", "method", "partition"} & set(params), name  # those are the surface's
        assert len(params) <= 12, name
    assert sigs["reconstruct_volume"]["fill_weights"].default == sigs["reconstruct_volume_tets"]["fill_weights"].default
    assert sigs["reconstruct_volume"]["fill_weights"].default == "cotan"


class _Stop(Exception):
    """Raised by a spy once it has seen its call: the rest of the run does not matter."""


def _spy(monkeypatch, name):
    import manifill.solid.reconstruct_volume as rv

    seen = {}

    def spy(*args, **kwargs):
        seen.update(kwargs)
        raise _Stop

    monkeypatch.setattr(rv, name, spy)
    return seen


OPTIONS = dict(method="harmonic", partition="tree", solver="direct", bounds="samples", tol=1e-9, check=False)


def test_surface_options_reach_reconstruct_unchanged(monkeypatch):
    # every keyword manifill.reconstruct takes (bounds and check too, once refused here) is passed on as given
    seen = _spy(monkeypatch, "reconstruct")
    V, F = SPHERE
    with pytest.raises(_Stop):
        reconstruct_volume(V, F, SOME_V, field(V[SOME_V]), resolution=8, fill_solver="direct", **OPTIONS)
    assert seen == OPTIONS


@needs_tetgen
def test_surface_options_reach_the_tet_mesh_surface_unchanged(monkeypatch):
    seen = _spy(monkeypatch, "reconstruct")
    V, T = tet_ball(2)
    b = np.unique(boundary_faces(T))[::5]
    with pytest.raises(_Stop):
        reconstruct_volume_tets(V, T, b, V[b, 0], fill_weights="uniform", duplicates="mean", **OPTIONS)
    assert seen == {**OPTIONS, "duplicates": "mean"}


def test_surface_options_reach_the_digital_surface_with_its_default_weights(monkeypatch):
    seen = _spy(monkeypatch, "reconstruct_surface")
    mask = mask_ball()
    on = np.argwhere(boundary_voxels(mask))[::9]
    with pytest.raises(_Stop):
        reconstruct_volume_mask(mask, on, on[:, 0] * 1.0, distance="hops", **OPTIONS)
    seconds = seen.pop("seconds")
    assert {"validate", "graph"} <= set(seconds)
    # weights: the one a digital surface can use, unless given; distance shaped the graph, not the fill
    assert seen == {**OPTIONS, "weights": "uniform"}
    seen.clear()
    with pytest.raises(_Stop):
        reconstruct_volume_mask(mask, on, on[:, 0] * 1.0, weights="uniform", **OPTIONS)
    assert seen["weights"] == "uniform"


def test_mask_refuses_what_a_digital_surface_or_voxels_cannot_use():
    mask = mask_ball()
    on = np.argwhere(boundary_voxels(mask))[::9]
    for kw, words in [({"max_distance": 0.5}, "positions"), ({"fill_weights": "uniform"}, "for tetrahedra"),
                      ({"fill_solver": "iterate"}, "fill_solver")]:
        with pytest.raises(OptionError) as info:
            reconstruct_volume_mask(mask, on, on[:, 0] * 1.0, **kw)
        assert words in one_line(info)
    with pytest.raises(OptionError, match="no option 'seconds'"):
        reconstruct_volume_mask(mask, on, on[:, 0] * 1.0, seconds={})
    with pytest.raises((TypeError, OptionError), match="'colour'"):  # as manifill.reconstruct refuses it
        reconstruct_volume_mask(mask, on, on[:, 0] * 1.0, colour="red")
    # the default fill weights are accepted, as reconstruct_volume(form='voxels') accepts them
    r = reconstruct_volume_mask(mask, on, on[:, 0] * 1.0, fill_weights="cotan", method="harmonic")
    np.testing.assert_allclose(r.values[tuple(on.T)], on[:, 0], rtol=0, atol=1e-9)


@needs_tetgen
def test_tets_take_the_same_fill_options_either_way():
    V, T = tet_ball(2)
    b = np.unique(boundary_faces(T))[::5]
    for bad, words in [({"fill_solver": "iterate"}, "fill_solver='iterate'"),
                       ({"fill_weights": "intrinsic"}, "fill_weights='intrinsic'")]:
        with pytest.raises(OptionError) as info:
            reconstruct_volume_tets(V, T, b, V[b, 0], **bad)
        assert one_line(info).startswith(words)


@needs_tetgen
@pytest.mark.parametrize("option", [dict(solver="direct"), dict(partition="tree"), dict(weights="uniform"),
                                    dict(curve_values="linear"), dict(bounds="samples")])
def test_gp_in_a_solid_refuses_the_surface_steps_options(option):
    # method='gp' in a solid runs no surface step: its options would do nothing, so they are refused
    mask = np.ones((6, 6, 6), dtype=bool)
    vox = np.array([[0, 0, 0], [5, 5, 5], [0, 5, 0], [5, 0, 5]])
    V, T = tet_ball(2)
    b = np.unique(boundary_faces(T))[::5]
    name = next(iter(option))
    for call in (lambda: reconstruct_volume_mask(mask, vox, np.arange(4.0), method="gp", **option),
                 lambda: reconstruct_volume_tets(V, T, b, V[b, 0], method="gp", **option)):
        with pytest.raises(OptionError) as info:
            call()
        assert one_line(info).startswith(f"{name}=") and "fill_solver" in one_line(info)
