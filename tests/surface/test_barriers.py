"""Barriers: the mesh cut along lines no method may see across, the result in the caller's numbering."""

import pickle

import numpy as np
import pytest

import manifill
from manifill import Reconstructor, cross_validate, reconstruct
from manifill.errors import OptionError, SampleError
from manifill.mesh.cut import cut_mesh
from manifill.mesh.edges import EdgeIndex
from manifill.mesh.shapes import grid, uv_sphere
from manifill.surface.barriers import barrier_edges
from manifill.surface.engine import reconstruct_surface
from manifill.surface.surface import Surface

N = 21
V, F = grid(N)
WALL = np.flatnonzero(np.isclose(V[:, 0], 0.5))
OFF = ~np.isclose(V[:, 0], 0.5)
IDX = np.sort(np.random.default_rng(0).choice(np.flatnonzero(OFF), 50, replace=False))
ENERGY = ["harmonic", "biharmonic", "triharmonic"]


def step(P):
    return P[:, 1] + (P[:, 0] > 0.5)


def slit_by_hand(n=N):
    """The grid with a slit along x = 1/2 from y = 0 up to (not through) y = 1/2, cut by hand: faces right of it
    take new copies of its vertices."""
    slit = np.flatnonzero(np.isclose(V[:, 0], 0.5) & (V[:, 1] < 0.5 - 1e-9))
    slit = slit[np.argsort(V[slit, 1])]
    new = {int(v): len(V) + j for j, v in enumerate(slit)}
    F2 = F.copy()
    for f in np.flatnonzero(V[F].mean(axis=1)[:, 0] > 0.5):
        F2[f] = [new.get(int(v), v) for v in F[f]]
    tip = np.flatnonzero(np.isclose(V[:, 0], 0.5) & np.isclose(V[:, 1], 0.5))
    return np.vstack([V, V[slit]]), F2, np.concatenate([slit, tip]), slit


def test_cut_mesh_splits_the_vertices_on_the_cut_and_keeps_the_tip_whole():
    _, _, path, slit = slit_by_hand()
    index = EdgeIndex(F, len(V))
    F2, orig = cut_mesh(F, len(V), barrier_edges(V, F, [path], index), index)
    assert len(orig) == len(V) + len(slit)  # the tip stays one vertex
    assert sorted(orig[len(V):].tolist()) == sorted(slit.tolist())
    assert np.array_equal(orig[F2], F)  # every face keeps its corners' positions
    # a cut from edge to edge parts the square in two
    cut = barrier_edges(V, F, [WALL[np.argsort(V[WALL, 1])]], index)
    _, orig = cut_mesh(F, len(V), cut, index)
    assert len(orig) == len(V) + len(WALL)


@pytest.mark.parametrize("method", ["default", "gvf-harmonic", "gvf", "harmonic", "biharmonic", "triharmonic", "gp"])
def test_a_barrier_along_a_slit_is_the_mesh_cut_by_hand(method):
    """The slit given as a barrier on the whole mesh gives the values of the mesh cut along it by hand."""
    V2, F2, path, slit = slit_by_hand()
    f = V[:, 0] + ((V[:, 0] > 0.5) & (V[:, 1] < 0.5))
    kw = dict(method=None if method == "default" else method)
    if method == "gp":
        kw["gp"] = {"range": 0.4, "sigma": 1.0}
    a = reconstruct(V, F, IDX, f[IDX], barriers=[path], **kw)
    b = reconstruct_surface(Surface.from_mesh(V2, F2, check=False), IDX, f[IDX][:, None], **kw)
    off = ~np.isin(np.arange(len(V)), slit)
    assert np.abs(a.values[off] - b.values[:len(V), 0][off]).max() < 1e-10
    # each split vertex: the mean of its sides; each face reads its own side
    assert np.allclose(a.values[slit], (b.values[slit, 0] + b.values[len(V):, 0]) / 2)
    faces = np.flatnonzero(np.isin(F, slit).any(axis=1))
    centres = V[F[faces]].mean(axis=1)
    assert np.allclose(a.at(centres), b.values[F2[faces], 0].mean(axis=1))


@pytest.mark.parametrize("method", ["default", "gvf-harmonic", "harmonic", "biharmonic", "triharmonic", "gp", "rbf"])
def test_a_wall_across_the_square_halves_the_error(method):
    kw = dict(method=None if method == "default" else method)
    path = WALL[np.argsort(V[WALL, 1])]
    errs = [np.sqrt(np.mean((reconstruct(V, F, IDX, step(V[IDX]), barriers=b, **kw).values - step(V))[OFF] ** 2))
            for b in (None, [path])]
    assert errs[1] <= 0.5 * errs[0]


def test_the_three_ways_of_giving_a_barrier_agree():
    path = WALL[np.argsort(V[WALL, 1])]
    labels = (V[F].mean(axis=1)[:, 0] > 0.5).astype(np.int64)
    points = V[path[::4]] + 1e-4  # every fourth vertex, as positions: joined along edges
    runs = [reconstruct(V, F, IDX, step(V[IDX]), method="biharmonic", barriers=b)
            for b in ([path], labels, [points], (path[:8], path[7:]))]
    for r in runs[1:]:
        assert np.array_equal(r.values, runs[0].values)
    assert runs[0].report["barriers"] == {"edges": N - 1, "split_vertices": N, "pieces": 2}


def test_the_field_is_exact_at_samples_on_the_barrier_on_both_sides():
    idx = np.concatenate([IDX, WALL[[3, 10]]])
    vals = step(V[idx])
    r = reconstruct(V, F, idx, vals, method="biharmonic", barriers=[WALL[np.argsort(V[WALL, 1])]])
    assert np.allclose(r.values[idx], vals)
    assert np.allclose(r.on_cut.values[r.cut.copies(WALL[[3, 10]])[0]], np.repeat(vals[-2:], 2))


def test_pieces_without_samples_are_refused_or_left_nan():
    path = [WALL[np.argsort(V[WALL, 1])]]
    left = IDX[V[IDX, 0] < 0.5]
    with pytest.raises(SampleError, match="leave 1 piece.*no sample.*on_empty='nan'"):
        reconstruct(V, F, left, step(V[left]), barriers=path)
    r = reconstruct(V, F, left, step(V[left]), barriers=path, on_empty="nan", method="harmonic")
    assert np.isnan(r.values[V[:, 0] > 0.5]).all() and np.isfinite(r.values[V[:, 0] < 0.5]).all()


def test_reconstructor_matrix_pickle_cv_draws_gradient():
    path = [WALL[np.argsort(V[WALL, 1])]]
    vals = step(V[IDX])
    rec = Reconstructor(V, F, IDX, method="harmonic", barriers=path)
    assert np.allclose(rec.matrix() @ vals, rec.apply(vals).values)
    assert np.array_equal(pickle.loads(pickle.dumps(rec)).apply(vals).values, rec.apply(vals).values)
    cv = cross_validate(V, F, IDX, vals, methods=["harmonic", "biharmonic"], folds=5, barriers=path)
    plain = cross_validate(V, F, IDX, vals, methods=["harmonic", "biharmonic"], folds=5)
    assert all(cv.errors[m] < plain.errors[m] for m in cv.errors)
    g = reconstruct(V, F, IDX, vals, method="gp", barriers=path)
    D = g.sample(3)
    assert D.shape == (len(V), 3) and np.allclose(D[IDX], vals[:, None])
    lin = reconstruct(V, F, IDX, 2 * V[IDX, 0] - V[IDX, 1], method="rbf", barriers=path)  # one spline per side
    assert np.abs(lin.gradient(at="cells")[:, :2] - [2, -1]).max() < 1e-9
    assert np.abs(lin.gradient()[:, :2] - [2, -1]).max() < 1e-9
    with pytest.raises(OptionError, match="std is not available with barriers"):
        g.gradient(return_std=True, draws=4)


def test_a_meridian_arc_on_the_sphere():
    """A line that does not part the sphere: the field goes round its ends; rbf (in space) refuses it."""
    Vs, Fs = uv_sphere(24, 48)  # a globe's grid: the meridian is a path of edges
    arc = np.flatnonzero(np.isclose(Vs[:, 1], 0.0, atol=1e-9) & (Vs[:, 0] <= 1e-9))
    arc = arc[np.argsort(Vs[arc, 2])]
    f = np.arctan2(Vs[:, 1], Vs[:, 0]) * (1 - Vs[:, 2] ** 2)
    off = ~np.isin(np.arange(len(Vs)), arc)
    idx = np.sort(np.random.default_rng(3).choice(np.flatnonzero(off), 150, replace=False))
    for method in ("harmonic", "biharmonic", "gvf-harmonic"):
        errs = [np.sqrt(np.mean((reconstruct(Vs, Fs, idx, f[idx], method=method, barriers=b).values - f)[off] ** 2))
                for b in (None, [arc])]
        assert errs[1] <= 0.5 * errs[0], method
    r = reconstruct(Vs, Fs, idx, f[idx], method="biharmonic", barriers=[arc])
    assert r.report["barriers"]["pieces"] == 1
    with pytest.raises(OptionError, match="rbf.*one piece"):
        reconstruct(Vs, Fs, idx, f[idx], method="rbf", barriers=[arc])


@pytest.mark.parametrize("barriers, word", [
    (np.zeros(5, dtype=np.int64), "per-face labels"),
    (np.zeros(2 * (N - 1) ** 2, dtype=np.int64), "no edge"),
    ([np.array([0, 10 ** 6])], "outside"),
    ([np.array([[0.0, 1.0]])], "shape"),
    ("wall", "list of polylines"),
])
def test_bad_barriers_are_one_line(barriers, word):
    with pytest.raises(OptionError, match=word):
        reconstruct(V, F, IDX, step(V[IDX]), barriers=barriers)


def test_a_point_cloud_refuses_barriers():
    with pytest.raises(OptionError, match="point cloud"):
        reconstruct(V, None, IDX, step(V[IDX]), barriers=[WALL])


def test_bakka_s_barrier_model():
    """gp={'barrier': 'bakka'}: the mesh whole, the faces along the barrier of a tenth of the range. At a range
    fraction of 1 it is the stationary model; at 0.1 the wall cuts the error as the cut does; its precision is
    K diag(c_mid)^-1 K with a root and covariances that agree with it."""
    path = [WALL[np.argsort(V[WALL, 1])]]
    given = {"range": 0.5, "sigma": 1.0}
    plain = reconstruct(V, F, IDX, step(V[IDX]), method="gp", gp=given)
    same = reconstruct(V, F, IDX, step(V[IDX]), method="gp", barriers=path,
                       gp={**given, "barrier": "bakka", "barrier_range": 1.0})
    assert np.abs(plain.values - same.values).max() < 1e-10 and np.abs(plain.std - same.std).max() < 1e-10
    r = reconstruct(V, F, IDX, step(V[IDX]), method="gp", barriers=path, gp={**given, "barrier": "bakka"})
    cut = reconstruct(V, F, IDX, step(V[IDX]), method="gp", barriers=path, gp=given)
    errs = [np.sqrt(np.mean((x.values - step(V))[OFF] ** 2)) for x in (plain, r, cut)]
    assert errs[1] <= 0.5 * errs[0] and errs[1] <= 1.5 * errs[2]
    assert r.report["gp"]["barrier"] == "bakka" and "barriers" not in r.report  # the mesh was not cut
    assert np.allclose(r.values[IDX], step(V[IDX])) and r.sample(2).shape == (len(V), 2)
    from manifill.surface.gp import _matern
    s = Surface.from_mesh(V, F)
    s.barrier_faces = manifill.surface.barriers.barrier_faces(V, F, path)
    shape = _matern(s, 2, 0.1)
    Q = shape.precision(3.0).toarray()
    K = shape.K(3.0).toarray()
    assert np.allclose(Q, K @ np.diag(1.0 / shape.c_mid) @ K)
    B = shape.root(3.0)
    assert np.allclose((B.T @ B).toarray(), Q)
    h = 1e-6
    dQ = (shape.precision(3.0 + h) - shape.precision(3.0 - h)).toarray() / (2 * h)
    assert np.allclose(shape.dprecision(3.0).toarray(), dQ, rtol=1e-6, atol=1e-6 * np.abs(dQ).max())
    # independently: the barrier faces are those with a vertex on the wall, their share of the noise's mass
    # scaled by the fraction squared
    bf = np.isclose(V[F][:, :, 0], 0.5).any(axis=1)
    assert np.array_equal(s.barrier_faces, bf)
    area = np.abs(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])[:, 2]) / 2
    want = np.zeros(len(V))
    np.add.at(want, F.ravel(), np.repeat(np.where(bf, 0.01, 1.0) * area / 3, 3))
    assert np.allclose(shape.c_mid, want, rtol=1e-12)


def test_barrier_paths_are_in_the_caller_s_numbering_with_stray_vertices():
    """A vertex no face uses first: the wall's indices shift by one, and the result is the same."""
    path = WALL[np.argsort(V[WALL, 1])]
    V1, F1 = np.vstack([[5.0, 5.0, 0.0], V]), F + 1
    a = reconstruct(V, F, IDX, step(V[IDX]), method="harmonic", barriers=[path])
    b = reconstruct(V1, F1, IDX + 1, step(V[IDX]), method="harmonic", barriers=[path + 1])
    assert np.abs(a.values - b.values[1:]).max() < 1e-12 and np.isnan(b.values[0])
    g = [reconstruct(M, T, i, step(V[IDX]), method="gp", barriers=[p], gp={"range": 0.5, "sigma": 1.0,
                                                                          "barrier": "bakka"}).values
         for M, T, i, p in ((V, F, IDX, path), (V1, F1, IDX + 1, path + 1))]
    assert np.abs(g[0] - g[1][1:]).max() < 1e-10
    cv = [cross_validate(M, T, i, step(V[IDX]), methods=["harmonic"], folds=4, barriers=[p]).errors["harmonic"]
          for M, T, i, p in ((V, F, IDX, path), (V1, F1, IDX + 1, path + 1))]
    assert cv[0] == pytest.approx(cv[1], rel=1e-12)
    with pytest.raises(OptionError, match="no face uses"):
        reconstruct(V1, F1, IDX + 1, step(V[IDX]), barriers=[np.r_[0, path + 1]])


def test_a_time_series_with_barriers(tmp_path):
    from manifill.io.stream import reconstruct_series

    path = [WALL[np.argsort(V[WALL, 1])]]
    vals = np.column_stack([step(V[IDX]) * k for k in (1.0, 2.0, 3.0)])
    s = reconstruct_series(V, F, IDX, vals, tmp_path / "s.npy", method="harmonic", barriers=path)
    X = np.load(tmp_path / "s.npy")
    r = reconstruct(V, F, IDX, vals[:, 2], method="harmonic", barriers=path)
    assert X.shape == (len(V), 3) and np.allclose(X[:, 2], r.values) and s is not None


def test_a_position_sample_at_a_barrier_vertex_holds_on_both_sides():
    path = [WALL[np.argsort(V[WALL, 1])]]
    v = WALL[10]
    idx = np.r_[IDX, v]
    vals = np.r_[step(V[IDX]), 5.0]
    for method in ("harmonic", "biharmonic"):
        by_index = reconstruct(V, F, idx, vals, method=method, barriers=path)
        by_position = reconstruct(V, F, np.vstack([V[IDX], V[[v]]]), vals, method=method, barriers=path)
        sides = by_position.on_cut.values[by_position.cut.copies([v])[0]]
        assert np.allclose(sides, 5.0) and by_position.values[v] == pytest.approx(5.0)
        assert np.abs(by_index.values - by_position.values).max() < 1e-9


def test_errors_name_the_caller_s_rows_and_vertices():
    path = [WALL[np.argsort(V[WALL, 1])]]
    idx = np.r_[IDX[:4], WALL[5], IDX[4:6], WALL[5]]
    vals = np.r_[step(V[IDX[:4]]), 1.0, step(V[IDX[4:6]]), 2.0]
    with pytest.raises(SampleError, match=r"1 vertices get two different values \(vertex \d+: rows 4, 7"):
        reconstruct(V, F, idx, vals, barriers=path)
    with pytest.raises(SampleError, match="outside 0..440"):
        cross_validate(V, F, np.r_[IDX, 450], np.r_[step(V[IDX]), 1.0], methods=["harmonic"], barriers=path)
    with pytest.raises(OptionError, match="barrier='bakka'.*give barriers="):
        reconstruct(V, F, IDX, step(V[IDX]), method="gp", gp={"barrier": "bakka"})


def test_a_split_vertex_beside_a_piece_left_nan_keeps_its_other_side():
    path = [WALL[np.argsort(V[WALL, 1])]]
    left = IDX[V[IDX, 0] < 0.5]
    r = reconstruct(V, F, left, step(V[left]), barriers=path, on_empty="nan", method="harmonic")
    assert np.isfinite(r.values[WALL]).all()
    assert np.allclose(r.values[WALL], r.on_cut.values[r.cut.copies(WALL)[0]][np.isfinite(
        r.on_cut.values[r.cut.copies(WALL)[0]])])
