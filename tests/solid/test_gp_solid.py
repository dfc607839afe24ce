"""method='gp' in a solid (tets and voxels): dense Gaussian conditioning, the root, units, files, refusals."""

import itertools
import math

import numpy as np
import pytest

from manifill.errors import OptionError
from manifill.mesh.shapes import icosphere
from manifill.solid.boundary import boundary_voxels
from manifill.solid.gp import gp_tets, gp_voxels, voxel_shape
from manifill.solid.reconstruct_volume import reconstruct_volume, reconstruct_volume_mask, reconstruct_volume_tets
from manifill.solid.tets import tet_gradient_root, tet_laplacian, tet_mass_matrix
from manifill.solid.voxels import voxel_laplacian

from solids import ball, coords, needs_tetgen, one_line

RANGE, SIGMA = 0.8, 1.3


def kuhn_cube(n, size=1.0):
    """The cube ``[0, size]^3`` cut into ``n^3`` cubes, each into the six tets around its main diagonal."""
    P = np.moveaxis(np.indices((n + 1,) * 3), 0, -1).reshape(-1, 3)
    V = P * (size / n)
    vid = lambda c: (c[..., 0] * (n + 1) + c[..., 1]) * (n + 1) + c[..., 2]  # noqa: E731
    C = np.moveaxis(np.indices((n,) * 3), 0, -1).reshape(-1, 3)
    T = []
    for perm in itertools.permutations(range(3)):
        corners = [C.copy()]
        for a in perm:
            nxt = corners[-1].copy()
            nxt[:, a] += 1
            corners.append(nxt)
        T.append(np.column_stack([vid(c) for c in corners]))
    return V, np.concatenate(T)


def dense_kriging(G, c, idx, y, kappa, sigma=None):
    """Mean and std of ``u ~ N(beta, tau^-2 Q^-1)``, ``Q = K C^-1 K``, ``K = kappa^2 C + G``, given ``u[idx] = y``.

    ``beta`` by generalised least squares; its variance is added to the std (universal
    kriging). ``sigma`` given: ``tau^2 = Gamma(1/2) / (Gamma(2) (4 pi)^(3/2) kappa sigma^2)`` (Matérn
    ``nu = 1/2`` in 3D); None: ``1 / tau^2`` by restricted likelihood, ``q / (m - 1)``.
    """
    G = G.toarray() if hasattr(G, "toarray") else G
    K = kappa**2 * np.diag(c) + G
    S0 = np.linalg.inv(K @ np.diag(1.0 / c) @ K)
    S = S0[np.ix_(idx, idx)]
    k = S0[:, idx]
    Si = np.linalg.inv(S)
    one = np.ones(len(idx))
    a = one @ Si @ one
    beta = (one @ Si @ y) / a
    mean = beta + k @ Si @ (y - beta)
    var0 = np.diag(S0) - np.einsum("ij,jk,ik->i", k, Si, k) + (1.0 - k @ Si @ one) ** 2 / a
    if sigma is None:
        s2 = (y - beta) @ Si @ (y - beta) / (len(idx) - 1)
    else:
        s2 = 1.0 / (math.gamma(0.5) / (math.gamma(2) * (4 * math.pi) ** 1.5 * kappa * sigma**2))
    return mean, np.sqrt(np.maximum(s2 * var0, 0.0))


@pytest.fixture(scope="module")
def cube():
    V, T = kuhn_cube(4)
    rng = np.random.default_rng(1)
    V = V + rng.uniform(-0.03, 0.03, V.shape)  # not a symmetric grid
    return V, T


@pytest.mark.parametrize("scale", [1.0, 1e3])
def test_tet_root_squares_to_the_cotan_stiffness(cube, scale):
    V, T = cube
    T = T.copy()
    T[::2] = T[::2][:, [1, 0, 2, 3]]  # both orientations
    B = tet_gradient_root(V * scale, T)
    L = tet_laplacian(V * scale, T)
    assert B.shape == (3 * len(T), len(V))
    assert abs(B.T @ B - L).max() < 1e-12 * abs(L).max()
    x = np.sin(3 * V[:, 0]) + V[:, 1] * V[:, 2]
    assert np.isclose(np.sum((B @ x) ** 2), x @ L @ x, rtol=1e-12)


@pytest.mark.parametrize("sigma", [SIGMA, "auto"])
def test_tets_equal_dense_conditioning(cube, sigma):
    V, T = cube
    rng = np.random.default_rng(2)
    idx = np.sort(rng.choice(len(V), 14, replace=False))  # boundary and inside
    y = np.cos(2 * V[idx, 0]) + V[idx, 2]
    r = gp_tets(V, T, idx, y, gp={"range": RANGE, "sigma": sigma, "variance": "exact"})
    kappa = math.sqrt(8 * 0.5) / RANGE
    mean, std = dense_kriging(tet_laplacian(V, T), tet_mass_matrix(V, T).diagonal(), idx, y, kappa,
                              None if sigma == "auto" else sigma)
    assert np.abs(r.values - mean).max() < 1e-8 * np.abs(mean).max()
    assert np.abs(r.std - std).max() < 1e-6 * std.max()
    assert np.abs(r.values[idx] - y).max() < 1e-9
    assert r.std[idx].max() < 1e-6 * std.max()
    assert r.report["gp"]["range"] == [pytest.approx(RANGE)] and r.form == "tets" and r.surface is None


@pytest.mark.parametrize("alpha", [1, 2])
def test_sampled_std_agrees_with_exact_through_the_roots(cube, alpha):
    # variance='sampled' draws fields through the root (alpha=1: the tet gradient root): same std, within its error
    V, T = cube
    idx = np.array([0, 10, 31, 62, 100, 124])
    y = V[idx, 0] + V[idx, 1]
    e, s = (gp_tets(V, T, idx, y, gp={"alpha": alpha, "range": 0.5, "variance": how, "samples": 400})
            for how in ("exact", "sampled"))
    free = np.setdiff1d(np.arange(len(V)), idx)
    rel = np.abs(s.std[free] / e.std[free] - 1.0)
    assert rel.max() < 0.15 and np.median(rel) < 0.05


def voxel_oracle_g(mask, h):
    """The 6-neighbour finite-difference stiffness in physical units: ``prod(h) / h_a^2`` per face on axis ``a``."""
    n = int(mask.sum())
    ids = np.full(mask.shape, -1)
    ids[mask] = np.arange(n)
    G = np.zeros((n, n))
    for a in range(3):
        sl0 = [slice(None)] * 3
        sl1 = [slice(None)] * 3
        sl0[a], sl1[a] = slice(0, -1), slice(1, None)
        i, j = ids[tuple(sl0)].ravel(), ids[tuple(sl1)].ravel()
        ok = (i >= 0) & (j >= 0)
        w = np.prod(h) / h[a] ** 2
        for p, q in zip(i[ok], j[ok]):
            G[p, q] -= w
            G[q, p] -= w
            G[p, p] += w
            G[q, q] += w
    return G


@pytest.mark.parametrize("spacing", [(1.0, 1.0, 1.0), (0.5, 1.0, 2.0)])
def test_voxels_equal_dense_conditioning(spacing):
    h = np.asarray(spacing)
    mask = ball(spacing, size=5.0, radius=2.6)
    rng = np.random.default_rng(3)
    where = np.argwhere(mask)
    pick = np.sort(rng.choice(len(where), 12, replace=False))
    X = coords(mask.shape, h)[mask]
    y = X[pick, 0] - np.sin(X[pick, 2])
    rng_ = 2.0 * h.max()
    r = gp_voxels(mask, where[pick], y, spacing=h, gp={"range": rng_, "sigma": SIGMA, "variance": "exact"})
    mean, std = dense_kriging(voxel_oracle_g(mask, h), np.full(len(where), np.prod(h)), pick, y,
                              math.sqrt(4.0) / rng_, SIGMA)
    assert np.abs(r.values[mask] - mean).max() < 1e-8 * np.abs(mean).max()
    assert np.abs(r.std[mask] - std).max() < 1e-6 * std.max()
    assert np.isnan(r.values[~mask]).all() and np.isnan(r.std[~mask]).all()


@pytest.mark.parametrize("connectivity", [6, 18, 26])
@pytest.mark.parametrize("spacing", [(1.0, 1.0, 1.0), (0.5, 1.0, 2.0)])
def test_voxel_stiffness_is_minus_volume_times_laplacian(connectivity, spacing):
    # every symmetric stencil is exact on quadratics: G u = -h^3 Delta u at inner voxels, u = |x|^2 / 2
    h = np.asarray(spacing)
    mask = np.ones((6, 6, 6), dtype=bool)
    s = voxel_shape(mask, h, connectivity)
    X = coords(mask.shape, h).reshape(-1, 3)
    Gu = s.G @ (0.5 * (X**2).sum(axis=1))
    inner = np.zeros(mask.shape, dtype=bool)
    inner[1:-1, 1:-1, 1:-1] = True
    assert np.allclose(Gu[inner.ravel()], -3.0 * np.prod(h), rtol=1e-10)
    assert np.allclose(s.c, np.prod(h))
    assert abs(s.root_G.T @ s.root_G - s.G).max() < 1e-12 * abs(s.G).max()
    if connectivity == 6:
        assert abs(s.G - voxel_laplacian(mask, h) * np.prod(h)).max() < 1e-12


@pytest.mark.parametrize("connectivity", [6, 26])
@pytest.mark.parametrize("sigma", [SIGMA, "auto"])
def test_voxel_spacing_and_range_scale_together(connectivity, sigma):
    base = np.array([1.0, 1.0, 2.0])
    mask = ball(base, size=9.0, radius=4.6)
    on = np.argwhere(boundary_voxels(mask))[::5]
    y = np.sin(on[:, 0] * 0.7) + on[:, 2]
    out = []
    for s in (1.0, 3.7):
        r = gp_voxels(mask, on, y, spacing=s * base, connectivity=connectivity,
                      gp={"range": 3.0 * s, "sigma": sigma, "variance": "exact"})
        out.append((r.values[mask], r.std[mask]))
    assert np.allclose(out[0][0], out[1][0], rtol=1e-8, atol=1e-10)
    assert np.allclose(out[0][1], out[1][1], rtol=1e-7, atol=1e-10)


def test_std_is_zero_at_samples_and_grows_inside():
    from scipy import ndimage

    mask = ball((1.0, 1.0, 1.0), size=11.0, radius=5.6)
    on = np.argwhere(boundary_voxels(mask))  # all of D sampled: the std grows with the depth
    r = gp_voxels(mask, on, on[:, 0] * 0.3, gp={"range": 4.0, "sigma": 1.0})
    assert r.std[tuple(on.T)].max() < 1e-6
    depth = np.round(ndimage.distance_transform_edt(mask)).astype(int)
    levels = [np.median(r.std[mask & (depth == k)]) for k in range(2, depth.max() + 1)]
    assert np.all(np.diff(levels) > 0) and levels[0] > 0.1
    assert r.std[mask].max() < 1.0  # below the prior's sigma: every voxel is within a range of D


def test_samples_inside_the_solid():
    V, T = kuhn_cube(3)
    idx = np.array([21, 22, 42])  # inner vertices of the 4x4x4 grid
    idx = np.r_[0, idx, len(V) - 1]
    y = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    opts = {"range": 0.6, "sigma": 1.0}
    r = reconstruct_volume_tets(V, T, idx, y, method="gp", gp=opts)
    assert np.allclose(r.values[idx], y) and r.std[idx].max() < 1e-6
    assert np.allclose(r.values, gp_tets(V, T, idx, y, gp=opts).values)
    mask = np.ones((8, 8, 8), dtype=bool)
    vox = np.array([[3, 3, 3], [4, 4, 4], [0, 0, 0]])
    m = reconstruct_volume_mask(mask, vox, [1.0, -1.0, 0.0], method="gp", gp=opts)
    assert np.allclose(m.values[tuple(vox.T)], [1.0, -1.0, 0.0]) and m.std[3, 3, 3] < 1e-6


def test_trust_marks_and_nans():
    mask = ball((1.0, 1.0, 1.0), size=9.0, radius=4.6)
    on = np.argwhere(boundary_voxels(mask))[::4]
    y = on[:, 1] * 1.0
    r = reconstruct_volume_mask(mask, on, y, method="gp", gp={"range": 3.0}, trust=0.3, untrusted="nan")
    th = r.report["trust"]["threshold"][0]
    assert th == pytest.approx(0.3 * y.std())
    assert np.array_equal(r.trusted, mask & (np.nan_to_num(r.std, nan=np.inf) <= th))
    assert np.isnan(r.values[mask & ~r.trusted]).all() and not np.isnan(r.values[r.trusted]).any()
    assert 0 < r.trusted.sum() < mask.sum()


def test_files_carry_std(tmp_path):
    meshio = pytest.importorskip("meshio")
    from manifill.io import read_vti, write_tets, write_vti

    V, T = kuhn_cube(3)
    idx = np.array([0, 5, 21, 40, 63])
    r = gp_tets(V, T, idx, np.column_stack([V[idx, 0], V[idx, 1] ** 2]), gp={"range": 0.5}, trust=1.0)
    data = r.point_data(["a", "b"])
    assert list(data)[:4] == ["a", "b", "a_std", "b_std"] and "trusted" in data
    write_tets(tmp_path / "g.vtu", r.TV, r.TT, data)
    back = meshio.read(tmp_path / "g.vtu")
    assert np.allclose(back.point_data["b_std"], r.std[:, 1])
    assert np.array_equal(back.point_data["trusted"].astype(bool), r.trusted)
    assert np.allclose(r.to_meshio(["a", "b"]).point_data["a_std"], r.std[:, 0])
    mask = np.ones((5, 6, 7), dtype=bool)
    m = gp_voxels(mask, [[0, 0, 0], [4, 5, 6], [2, 2, 2]], [1.0, 2.0, 0.5], spacing=(1, 2, 3), gp={"range": 4.0})
    write_vti(tmp_path / "g.vti", m.point_data(["t"]), spacing=m.spacing, origin=m.origin)
    fields, h, _ = read_vti(tmp_path / "g.vti")
    assert np.allclose(fields["t_std"], m.std) and h.tolist() == [1.0, 2.0, 3.0]
    pv = pytest.importorskip("pyvista")
    img = pv.read(tmp_path / "g.vti")
    assert np.allclose(img.point_data["t_std"], m.std.reshape(-1, order="F"))


def test_refusals():
    V, T = kuhn_cube(2)
    on = np.array([0, 2, 8, 26])
    y = np.arange(4.0)
    mask = np.ones((6, 6, 6), dtype=bool)
    vox = np.array([[0, 0, 0], [5, 5, 5], [0, 5, 0], [5, 0, 5]])
    for kw in ({"uncertainty": True}, {"trust": 2.0}, {"gp": {"range": 1.0}}, {"untrusted": "nan"}):
        with pytest.raises(OptionError) as info:
            reconstruct_volume_tets(V, T, on, y, method="harmonic", **kw)
        assert "method='gp'" in one_line(info)
        with pytest.raises(OptionError) as info:
            reconstruct_volume_mask(mask, vox, y, **kw)
        assert "method='gp'" in one_line(info)
    with pytest.raises(OptionError) as info:
        reconstruct_volume(*icosphere(1), [0, 1, 2], [0.0, 1.0, 2.0], method="biharmonic", trust=1.0)
    assert "method='gp'" in one_line(info)
    with pytest.raises(OptionError) as info:
        reconstruct_volume_mask(mask, vox, y, method="gp", fill_solver="multigrid")
    assert "fill_solver" not in one_line(info) or "multigrid" in one_line(info)
    with pytest.raises(OptionError):
        gp_tets(V, T, on, y, solver="iterate")
    with pytest.raises(OptionError) as info:
        reconstruct_volume_tets(V, T, on, y, method="gp", uncertainty=False, trust=1.0)
    one_line(info)
    r = reconstruct_volume_tets(V, T, on, y, method="gp", uncertainty=False, gp={"range": 1.0})
    assert r.std is None and "value_std" not in r.point_data()


def test_reconstruct_volume_voxels_conditions_on_the_surface_samples():
    V, F = icosphere(2)
    idx = np.arange(0, len(V), 9)
    r = reconstruct_volume(V, F, idx, V[idx, 2], resolution=12, method="gp", gp={"range": 0.8})
    assert r.form == "voxels" and r.surface is None and r.std.shape == r.mask.shape
    s = r.samples
    assert r.report["merged"] == len(idx) - len(s)
    assert r.std[tuple(s.T)].max() < 1e-6
    if r.report["merged"] == 0:
        assert np.allclose(np.sort(r.values[tuple(s.T)]), np.sort(V[idx, 2]))


@needs_tetgen
def test_reconstruct_volume_tets_conditions_on_the_surface_samples():
    V, F = icosphere(2)
    idx = np.arange(0, len(V), 5)
    r = reconstruct_volume(V, F, idx, V[idx, 0], form="tets", method="gp", gp={"range": 0.8})
    assert np.allclose(r.values[idx], V[idx, 0]) and r.std[idx].max() < 1e-6
    inner = np.setdiff1d(np.arange(len(r.TV)), np.arange(len(V)))
    assert inner.size and r.std[inner].min() > 0


def test_a_voxel_solids_draws_spread_as_its_std_and_go_through_the_samples():
    g = np.indices((9, 9, 9)).reshape(3, -1).T
    mask = (np.linalg.norm(g - 4, axis=1) <= 4.2).reshape(9, 9, 9)
    vox = np.argwhere(mask)[::23]
    vals = np.sin(vox[:, 0] / 3.0) + vox[:, 2] / 9.0
    r = gp_voxels(mask, vox, vals, gp=dict(range=4.0, sigma=1.0))
    D = r.sample(2000, seed=3)
    assert D.shape == mask.shape + (2000,) and np.isnan(D[~mask]).all()
    np.testing.assert_allclose(D[tuple(vox.T)], np.repeat(vals[:, None], 2000, axis=1), atol=1e-10)
    free = mask & (r.std > 1e-6 * np.nanmax(r.std))
    ratio = D[free].std(axis=1) / r.std[free]
    assert abs(np.median(ratio) - 1.0) < 0.03
    np.testing.assert_array_equal(r.sample(5, seed=4), r.sample(5, seed=4))  # the seed repeats them
    assert not np.allclose(r.sample(5, seed=4)[mask], r.sample(5, seed=5)[mask])


def test_a_tet_solids_draws_and_the_refusal_without_a_model():
    from manifill.solid.volume_result import VolumeReconstruction

    V = np.array([[0., 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2], [0.4, 0.4, 0.4]])
    T = [[0, 1, 2, 4], [0, 1, 4, 3], [0, 4, 2, 3], [4, 1, 2, 3]]
    r = gp_tets(V, T, [0, 1, 4], [0.0, 1.0, 2.0], gp={"range": 1.0, "sigma": 1.0})
    D = r.sample(4000, seed=0)
    assert D.shape == (5, 4000)
    np.testing.assert_allclose(D[[0, 1, 4]], np.repeat([[0.0], [1.0], [2.0]], 4000, axis=1), atol=1e-10)
    assert D[[2, 3]].std(axis=1) == pytest.approx(r.std[[2, 3]], rel=0.06)
    with pytest.raises(OptionError, match="no fitted probability model"):
        VolumeReconstruction(np.zeros(3), "tets", None).sample(2)
