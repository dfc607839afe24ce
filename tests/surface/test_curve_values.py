"""Step 4: values on the curve network, from the samples on it."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import edge_set, grid, icosphere, irregular, torus
from manifill.surface.curve_values import curve_values
from manifill.errors import OptionError
from manifill.mesh.graph import mesh_graph
from manifill.surface.gradual import check_gradual
from manifill.surface.partition import partition
from manifill.surface.surface import Surface
from manifill.mesh.shapes import grid as shapes_grid

hsettings = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                     suppress_health_check=[HealthCheck.too_slow])

MESHES = {
    "icosphere2": lambda: icosphere(2),
    "grid": lambda: grid(9),
    "grid_right": lambda: grid(9, diagonal="right"),
    "torus": torus,
    "irregular": irregular,
}
_CACHE = {}


def mesh(name):
    if name not in _CACHE:
        _CACHE[name] = MESHES[name]()
    return _CACHE[name]


def network(name, method, distance, seed, k):
    V, F = mesh(name)
    rng = np.random.default_rng(seed)
    idx = np.sort(rng.choice(len(V), size=min(k, len(V)), replace=False))
    part = partition(Surface.from_mesh(V, F), idx, graph=mesh_graph(V, F, distance=distance), method=method)
    return V, F, idx, part, rng


networks = dict(name=st.sampled_from(sorted(MESHES)), method=st.sampled_from(["delaunay", "cycle", "tree"]),
                distance=st.sampled_from(["hops", "length"]), seed=st.integers(0, 10**6), k=st.integers(1, 25))


# ---------------------------------------------------------------------------
# linear
# ---------------------------------------------------------------------------


@hsettings
@given(seed=st.integers(0, 10**6), m=st.integers(2, 40), k=st.integers(1, 8))
def test_linear_is_piecewise_linear_in_arc_length_along_one_path(seed, m, k):
    rng = np.random.default_rng(seed)
    P = np.cumsum(rng.uniform(-1.0, 1.0, size=(m, 3)) * rng.uniform(0.01, 3.0, size=(m, 1)), axis=0)
    label = rng.permutation(m)  # path position j is vertex label[j]
    V = np.empty_like(P)
    V[label] = P
    edges = np.column_stack([label[:-1], label[1:]])
    pos = np.sort(rng.choice(m, size=min(k, m), replace=False))
    vals = rng.uniform(-3.0, 3.0, size=pos.size)
    order = rng.permutation(pos.size)
    cv, x = curve_values(V, edges, label[pos][order], vals[order], method="linear")
    np.testing.assert_array_equal(cv, np.arange(m))
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))]
    # linear between consecutive samples, constant beyond the outermost ones
    np.testing.assert_allclose(x[label], np.interp(s, s[pos], vals), rtol=0, atol=1e-11)
    np.testing.assert_array_equal(x[label[pos]], vals)
    assert x.min() >= vals.min() - 1e-12 and x.max() <= vals.max() + 1e-12


@hsettings
@given(**networks)
def test_linear_on_a_network_is_harmonic_on_the_curve_graph(name, method, distance, seed, k):
    V, F, idx, part, rng = network(name, method, distance, seed, k)
    vals = rng.uniform(-2.0, 5.0, size=idx.size)
    E = part.curve_edges()
    cv, x = curve_values(V, E, idx, vals, method="linear")
    np.testing.assert_array_equal(cv, np.flatnonzero(part.on_curve))
    value = dict(zip(cv.tolist(), x.tolist()))
    for v, f in zip(idx.tolist(), vals.tolist()):
        assert value[v] == f, "exact at the samples"
    assert x.min() >= vals.min() - 1e-12 and x.max() <= vals.max() + 1e-12, "never leaves the sample range"
    # away from the samples: the 1/length-weighted mean of the curve neighbours
    total = {v: 0.0 for v in value}
    weight = {v: 0.0 for v in value}
    for i, j in E.tolist():
        w = 1.0 / np.linalg.norm(V[i] - V[j])
        total[i] += w * value[j]
        weight[i] += w
        total[j] += w * value[i]
        weight[j] += w
    samples = set(idx.tolist())
    for v in value:
        if v not in samples:
            assert value[v] == pytest.approx(total[v] / weight[v], abs=1e-10)


# ---------------------------------------------------------------------------
# linear functions on a flat grid
# ---------------------------------------------------------------------------

from conftest import GRID_N as N, GRID_SAMPLES as SAMPLES, linear_field  # noqa: E402


def straight(V, c):
    d, e = V[c] - V[c[0]], V[c[-1]] - V[c[0]]
    return np.abs(np.cross(d, e)).max() < 1e-12


def spread_neighbourhoods(V, idx, ends):
    """Every sample is joined (within two curve steps) to samples not all on one line through it."""
    pos = {int(v): i for i, v in enumerate(idx)}
    A = [set() for _ in idx]
    for a, b in ends.tolist():
        A[pos[a]].add(pos[b])
        A[pos[b]].add(pos[a])
    for i in range(len(idx)):
        nb = (A[i] | {j for m in A[i] for j in A[m]}) - {i}
        D = V[idx[sorted(nb)]] - V[idx[i]]
        if np.linalg.matrix_rank(D[:, :2], tol=1e-9) < 2:
            return False
    return True


# (diagonal, samples, partition) where every curve is a straight vertex path
STRAIGHT = [
    ("alternate", "corners", "delaunay"), ("alternate", "corners", "cycle"), ("alternate", "corners", "tree"),
    ("alternate", "corners_center", "delaunay"), ("alternate", "corners_center", "cycle"),
    ("alternate", "nine", "delaunay"), ("alternate", "nine", "cycle"), ("alternate", "nine", "tree"),
    ("right", "corners", "delaunay"), ("right", "corners", "cycle"), ("right", "corners", "tree"),
    ("right", "nine", "delaunay"), ("right", "nine", "cycle"), ("right", "nine", "tree"),
]


def grid_network(diagonal, samples, method):
    V, F = shapes_grid(N, diagonal=diagonal)
    idx = np.sort(SAMPLES[samples])
    part = partition(Surface.from_mesh(V, F), idx, graph=mesh_graph(V, F, distance="length"), method=method)
    return V, F, idx, part


@pytest.mark.parametrize("diagonal, samples, method", STRAIGHT)
def test_linear_reproduces_a_linear_field_on_straight_curves(diagonal, samples, method):
    V, F, idx, part = grid_network(diagonal, samples, method)
    assert all(straight(V, c) for c in part.curves), "precondition: straight paths"
    cv, x = curve_values(V, part.curve_edges(), idx, linear_field(V[idx]), method="linear")
    np.testing.assert_allclose(x, linear_field(V[cv]), rtol=0, atol=1e-10)


# the tree through nine samples joins a corner only to samples on one line: test_hermite_with_a_collinear_...
SPREAD = [case for case in STRAIGHT if case[1:] != ("nine", "tree")]


@pytest.mark.parametrize("diagonal, samples, method", SPREAD)
def test_hermite_reproduces_a_linear_field_on_straight_curves(diagonal, samples, method):
    V, F, idx, part = grid_network(diagonal, samples, method)
    assert all(straight(V, c) for c in part.curves), "precondition: straight paths"
    assert spread_neighbourhoods(V, idx, part.ends), "precondition: gradients determined by the samples"
    cv, x = curve_values(V, part.curve_edges(), idx, linear_field(V[idx]), method="hermite", F=F,
                         curves=part.curves, ends=part.ends)
    np.testing.assert_allclose(x, linear_field(V[cv]), rtol=0, atol=1e-10)


def test_hermite_with_a_collinear_sample_neighbourhood():
    V, F, idx, part = grid_network("alternate", "nine", "tree")
    assert all(straight(V, c) for c in part.curves)
    assert not spread_neighbourhoods(V, idx, part.ends)
    cv, x = curve_values(V, part.curve_edges(), idx, linear_field(V[idx]), method="hermite", F=F,
                         curves=part.curves, ends=part.ends)
    np.testing.assert_allclose(x, linear_field(V[cv]), rtol=0, atol=1e-10)


@hsettings
@given(**networks)
def test_hermite_is_exact_at_the_samples(name, method, distance, seed, k):
    V, F, idx, part, rng = network(name, method, distance, seed, k)
    vals = rng.uniform(-2.0, 5.0, size=idx.size)
    cv, x = curve_values(V, part.curve_edges(), idx, vals, method="hermite", F=F, curves=part.curves,
                         ends=part.ends)
    np.testing.assert_array_equal(cv, np.flatnonzero(part.on_curve))
    assert np.isfinite(x).all()
    np.testing.assert_array_equal(x[np.searchsorted(cv, idx)], vals)


# ---------------------------------------------------------------------------
# gvf
# ---------------------------------------------------------------------------


@hsettings
@given(**networks)
def test_gvf_values_are_levels_changing_by_one_per_curve_edge(name, method, distance, seed, k):
    V, F, idx, part, rng = network(name, method, distance, seed, k)
    vals = rng.uniform(-2.0, 5.0, size=idx.size)
    check = check_gradual(mesh_graph(V, F, distance="hops"), idx, vals)
    assert check.holds
    E = part.curve_edges()
    cv, x = curve_values(V, E, idx, None, method="gvf", levels=check.levels, level=check.level)
    np.testing.assert_array_equal(cv, np.flatnonzero(part.on_curve))
    where = np.searchsorted(check.levels, x)
    assert np.all(where < check.levels.size) and np.array_equal(check.levels[where], x), "values on the levels"
    level = np.full(len(V), -1)
    level[cv] = where
    np.testing.assert_array_equal(level[idx], check.level)
    if len(E):
        assert np.abs(level[E[:, 0]] - level[E[:, 1]]).max() <= 1


def test_gvf_curve_values_equal_the_samples_at_the_samples():
    V, F = icosphere(2)
    rng = np.random.default_rng(0)
    idx = np.sort(rng.choice(len(V), size=10, replace=False))
    vals = rng.standard_normal(10)
    check = check_gradual(mesh_graph(V, F, distance="hops"), idx, vals)
    assert check.level_error > 0.1
    part = partition(Surface.from_mesh(V, F), idx, graph=mesh_graph(V, F, distance="length"))
    cv, x = curve_values(V, part.curve_edges(), idx, vals, method="gvf", levels=check.levels, level=check.level)
    np.testing.assert_allclose(x[np.searchsorted(cv, idx)], vals)


# ---------------------------------------------------------------------------
# several fields, options
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("method", ["linear", "hermite", "monotone"])
@pytest.mark.parametrize("name", ["icosphere2", "irregular", "torus"])
def test_columns_are_independent(method, name):
    V, F, idx, part, rng = network(name, "delaunay", "length", seed=4, k=12)
    vals = rng.uniform(-1.0, 1.0, size=(idx.size, 3))
    kw = dict(method=method, F=F, curves=part.curves, ends=part.ends)
    cv, X = curve_values(V, part.curve_edges(), idx, vals, **kw)
    assert X.shape == (cv.size, 3)
    for j in range(3):
        cvj, xj = curve_values(V, part.curve_edges(), idx, vals[:, j], **kw)
        np.testing.assert_array_equal(cvj, cv)
        assert xj.shape == (cv.size,)
        np.testing.assert_allclose(X[:, j], xj, rtol=0, atol=1e-12)


def test_docstring_example_by_hand():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [3, 0, 0], [4, 0, 0]])
    cv, x = curve_values(V, np.array([[0, 1], [1, 2], [2, 3]]), np.array([0, 3]), np.array([0.0, 8.0]))
    assert cv.tolist() == [0, 1, 2, 3] and x.tolist() == [0.0, 2.0, 6.0, 8.0]


def test_unknown_method_raises():
    V, F = grid(3)
    with pytest.raises(OptionError):
        curve_values(V, np.array(sorted(edge_set(F))), np.array([0, 8]), np.array([0.0, 1.0]), method="spline")


# ---------------------------------------------------------------------------
# hermite: quadratic precision where the slopes are exact
# ---------------------------------------------------------------------------
#
# Along a straight path of length L, cubic Hermite interpolation in arc length with exact end slopes
# reproduces any cubic, so any quadratic field of the plane; linear interpolation misses a quadratic
# c2 s^2 by c2 s (L - s), c2 L^2 / 4 at the middle. The slopes come from least-squares gradients of
# the samples within two curve steps (normals agreeing: every one on a flat mesh), so they are exact
#   - with eight or more well-spread such samples (the quadratic fit, exact on a quadratic), and
#   - on a line of equally spaced samples, at a sample with two on either side (the linear fit: the
#     quadratic term is even in the offset and drops out of the weighted normal equations),
# and the paths are straight (chord = arc length), so the slopes are the gradients' alone.


def quadratic_field(c):
    """The quadratic c0 + c1 x + c2 y + c3 x^2 + c4 x y + c5 y^2 and its gradient."""
    def f(X):
        x, y = X[:, 0], X[:, 1]
        return c[0] + c[1] * x + c[2] * y + c[3] * x * x + c[4] * x * y + c[5] * y * y

    def grad(X):
        x, y = X[:, 0], X[:, 1]
        return np.column_stack([c[1] + 2 * c[3] * x + c[4] * y, c[2] + c[4] * x + 2 * c[5] * y, 0 * x])

    return f, grad


QUADRATICS = {
    "general": (0.3, 2.0, -1.5, 0.8, -0.6, 0.5),
    "saddle": (1.0, 1.0, 1.0, 1.0, 0.0, -1.0),
    "xy": (0.0, 1.5, -0.5, 0.0, 2.0, 0.0),
}


def two_step_samples(idx, ends):
    """For every sample, the set of other samples within two curve steps."""
    pos = {int(v): i for i, v in enumerate(idx)}
    A = [set() for _ in idx]
    for a, b in ends.tolist():
        A[pos[a]].add(pos[b])
        A[pos[b]].add(pos[a])
    return [(A[i] | {j for m in A[i] for j in A[m]}) - {i} for i in range(len(idx))]


def quadratic_rank(D):
    """Rank of the quadratic fit's design (dx, dy, dx^2, dx dy, dy^2) for planar offsets D."""
    x, y = D[:, 0], D[:, 1]
    return np.linalg.matrix_rank(np.column_stack([x, y, x * x, x * y, y * y]))


# (grid size, sample spacing in grid steps): lattices of samples whose Delaunay network gives every
# sample eight others within two steps
LATTICES = [(15, 7), (21, 5)]


@pytest.mark.parametrize("field", sorted(QUADRATICS))
@pytest.mark.parametrize("n, step", LATTICES)
def test_hermite_reproduces_a_quadratic_where_the_gradient_fits_are_quadratic(n, step, field):
    V, F = shapes_grid(n)
    idx = np.sort([j * n + i for i in range(0, n, step) for j in range(0, n, step)])
    part = partition(Surface.from_mesh(V, F), idx, graph=mesh_graph(V, F, distance="length"), method="delaunay")
    f, _ = quadratic_field(QUADRATICS[field])
    assert all(straight(V, c) for c in part.curves), "precondition: straight paths"
    near = two_step_samples(idx, part.ends)
    assert min(len(s) for s in near) >= 8, "precondition: quadratic gradient fits"
    assert all(quadratic_rank(V[idx[sorted(s)]] - V[idx[i]]) == 5 for i, s in enumerate(near)), \
        "precondition: the neighbours determine a quadratic"
    E = part.curve_edges()
    cv, x = curve_values(V, E, idx, f(V[idx]), method="hermite", F=F, curves=part.curves, ends=part.ends)
    _, lin = curve_values(V, E, idx, f(V[idx]), method="linear")
    exact = f(V[cv])
    np.testing.assert_allclose(x, exact, rtol=0, atol=1e-10)
    # linear interpolation misses the quadratic (by c2 s (L - s) along each path), so the two differ
    interior = ~np.isin(cv, idx)
    assert np.abs(lin - exact)[interior].max() > 0.01
    assert np.abs(x - lin)[interior].max() > 0.01


@hsettings
@given(seed=st.integers(0, 10**6), m=st.integers(6, 11), q=st.integers(2, 6), h=st.floats(0.05, 3.0),
       c2=st.floats(0.2, 2.0), sign=st.sampled_from([-1.0, 1.0]))
def test_hermite_reproduces_a_quadratic_between_equally_spaced_samples_on_a_line(seed, m, q, h, c2, sign):
    # m samples, q edges apart, on a straight line in space; the field is quadratic in arc length
    rng = np.random.default_rng(seed)
    d = rng.standard_normal(3)
    d /= np.linalg.norm(d)
    normal = np.cross(d, rng.standard_normal(3))
    normal /= np.linalg.norm(normal)
    nv = (m - 1) * q + 1
    s = h * np.arange(nv)
    label = rng.permutation(nv)  # line position j is vertex label[j]
    V = np.empty((nv, 3))
    V[label] = rng.uniform(-5, 5, 3) + s[:, None] * d
    c0, c1, c2 = rng.uniform(-2, 2), rng.uniform(-2, 2), sign * c2
    field = c0 + c1 * s + c2 * s**2
    at = np.arange(0, nv, q)  # line positions of the samples
    idx = label[at]
    order = np.argsort(idx)
    curves = [label[at[i]:at[i + 1] + 1] for i in range(m - 1)]
    ends = np.array([[c[0], c[-1]] for c in curves])
    edges = np.column_stack([label[:-1], label[1:]])
    normals = np.tile(normal, (nv, 1))
    cv, x = curve_values(V, edges, idx[order], field[at][order], method="hermite", curves=curves, ends=ends,
                         normals=normals)
    _, lin = curve_values(V, edges, idx[order], field[at][order], method="linear")
    np.testing.assert_array_equal(cv, np.arange(nv))
    tol = 1e-9 * np.abs(field).max()
    # exact on the paths between samples with two others on either side; linear is off by c2 s (L - s)
    inner = np.arange(2 * q, (m - 3) * q + 1)
    np.testing.assert_allclose(x[label[inner]], field[inner], rtol=0, atol=tol)
    L = q * h
    off = s[inner] - s[inner // q * q]  # arc length from the path's start
    np.testing.assert_allclose(lin[label[inner]] - x[label[inner]], c2 * off * (L - off), rtol=0, atol=tol)
    # a linear field: both exact on every path, so equal
    _, xl = curve_values(V, edges, idx[order], (c0 + c1 * s[at])[order], method="hermite", curves=curves,
                         ends=ends, normals=normals)
    np.testing.assert_allclose(xl[label], c0 + c1 * s, rtol=0, atol=1e-9 * (abs(c0) + abs(c1) * s.max()))


# ---------------------------------------------------------------------------
# Step 4 on a partition: values_on_curves and its CurveValues
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("method", ["linear", "hermite", "monotone", "gvf"])
@pytest.mark.parametrize("name", ["icosphere2", "irregular", "torus"])
def test_values_on_curves_is_curve_values_on_the_partition(name, method):
    from manifill.surface.curve_values import CurveValues, values_on_curves
    from manifill.surface.surface import Surface

    V, F, idx, part, rng = network(name, "delaunay", "length", seed=5, k=12)
    s = Surface.from_mesh(V, F)
    vals = np.round(4 * rng.uniform(-1.0, 1.0, size=(idx.size, 2))) / 4
    checks = [check_gradual(s.G_hops, idx, vals[:, j]) for j in range(2)]
    cv = values_on_curves(s, part, idx, vals, method=method, checks=checks)
    assert isinstance(cv, CurveValues) and cv.method == method
    b, bc = cv
    assert b is cv.idx and bc is cv.vals and bc.shape == (b.size, 2)
    np.testing.assert_array_equal(b, np.flatnonzero(part.on_curve))
    np.testing.assert_array_equal(bc[np.searchsorted(b, idx)], vals)
    for j in range(2):
        kw = (dict(levels=checks[j].levels, level=checks[j].level) if method == "gvf"
              else dict(F=F, curves=part.curves, ends=part.ends))
        bj, xj = curve_values(V, part.curve_edges(), idx, vals[:, j], method=method, **kw)
        np.testing.assert_array_equal(bj, b)
        np.testing.assert_allclose(bc[:, j], xj, rtol=0, atol=1e-12)


def test_values_on_curves_takes_normals_from_a_surface_without_triangles():
    from manifill.surface.curve_values import values_on_curves, vertex_normals
    from manifill.surface.surface import Surface

    V, F, idx, part, rng = network("icosphere2", "delaunay", "length", seed=6, k=14)
    mesh_surface = Surface.from_mesh(V, F)
    vals = rng.uniform(-1.0, 1.0, size=(idx.size, 1))
    bare = Surface(mesh_surface.V, mesh_surface.G_hops, mesh_surface.G, mesh_surface.laplacian,
                   normals=vertex_normals(V, F))
    a = values_on_curves(mesh_surface, part, idx, vals)
    b = values_on_curves(bare, part, idx, vals)
    np.testing.assert_allclose(a.vals, b.vals, rtol=0, atol=1e-12)
    with pytest.raises(OptionError, match="curve_values"):
        values_on_curves(mesh_surface, part, idx, vals, method="cubic")


# ---------------------------------------------------------------------------
# hermite is linear in the data; monotone is bounded (and is not)
# ---------------------------------------------------------------------------


def on_paths(V, F, part, idx, vals, method):
    return curve_values(V, part.curve_edges(), idx, vals, method=method, F=F, curves=part.curves, ends=part.ends)


@hsettings
@given(**networks, a=st.floats(-3.0, 3.0), b=st.floats(-3.0, 3.0))
def test_hermite_is_linear_in_the_values(name, method, distance, seed, k, a, b):
    V, F, idx, part, rng = network(name, method, distance, seed, k)
    u, v = rng.uniform(-2.0, 5.0, size=(2, idx.size)) * rng.uniform(0.1, 10.0, size=(2, 1))
    _, xu = on_paths(V, F, part, idx, u, "hermite")
    _, xv = on_paths(V, F, part, idx, v, "hermite")
    _, xw = on_paths(V, F, part, idx, a * u + b * v, "hermite")
    scale = abs(a) * np.abs(xu).max() + abs(b) * np.abs(xv).max() + np.abs(a * u + b * v).max()
    np.testing.assert_allclose(xw, a * xu + b * xv, rtol=0, atol=1e-12 * scale)


@pytest.mark.parametrize("partition_method", ["delaunay", "cycle", "tree"])
def test_reconstruct_with_hermite_curve_values_is_linear_in_the_values(partition_method):
    # the partition depends on the sample positions only: the whole pipeline is a linear map
    from manifill import reconstruct

    V, F = icosphere(3)
    rng = np.random.default_rng(7)
    idx = np.sort(rng.choice(len(V), size=40, replace=False))
    u, v = rng.standard_normal((2, idx.size))
    kw = dict(method="gvf-harmonic", partition=partition_method, curve_values="hermite", solver="direct")
    ru, rv = (reconstruct(V, F, idx, x, **kw).values for x in (u, v))
    rw = reconstruct(V, F, idx, 2.5 * u - 0.75 * v, **kw).values
    np.testing.assert_allclose(rw, 2.5 * ru - 0.75 * rv, rtol=0, atol=1e-12 * np.abs(rw).max())


def containing_ends(part, cv):
    """For every curve vertex, the sample pairs at the ends of the paths through it."""
    where = {int(v): i for i, v in enumerate(cv)}
    out = [[] for _ in cv]
    for c, (a, b) in zip(part.curves, part.ends.tolist()):
        for v in c.tolist():
            out[where[v]].append((a, b))
    return out


@hsettings
@given(**networks, rough=st.booleans())
def test_monotone_values_stay_between_the_ends_of_their_paths(name, method, distance, seed, k, rough):
    V, F, idx, part, rng = network(name, method, distance, seed, k)
    vals = rng.standard_normal(idx.size) * (100.0 if rough else 1.0) + (0.0 if rough else V[idx, 0] * 5)
    cv, x = on_paths(V, F, part, idx, vals, "monotone")
    np.testing.assert_array_equal(x[np.searchsorted(cv, idx)], vals)
    value = dict(zip(idx.tolist(), vals.tolist()))
    tol = 1e-12 * np.abs(vals).max()
    samples = set(idx.tolist())
    for v, xv, paths in zip(cv.tolist(), x.tolist(), containing_ends(part, cv)):
        if v in samples or not paths:
            continue
        # on one path: inside the interval of its two ends; shared by several paths (the mean of
        # their values): inside the hull of all their ends
        ends_vals = [value[e] for ab in paths for e in ab]
        assert min(ends_vals) - tol <= xv <= max(ends_vals) + tol


def test_monotone_is_bounded_where_hermite_overshoots_and_is_not_linear():
    V, F, idx, part, rng = network("icosphere2", "delaunay", "length", seed=3, k=12)
    u = np.where(V[idx, 0] > 0, 1.0, 0.0) + 0.1 * rng.standard_normal(idx.size)
    cv, herm = on_paths(V, F, part, idx, u, "hermite")
    _, mono = on_paths(V, F, part, idx, u, "monotone")
    assert herm.max() > u.max() + 1e-3 or herm.min() < u.min() - 1e-3, "precondition: hermite overshoots"
    assert u.min() <= mono.min() and mono.max() <= u.max()
    # the limiter looks at the values: R(u) + R(-u) = 0 holds (odd), but R(u + v) != R(u) + R(v)
    v = rng.standard_normal(idx.size)
    _, mv = on_paths(V, F, part, idx, v, "monotone")
    _, muv = on_paths(V, F, part, idx, u + v, "monotone")
    assert np.abs(muv - (mono + mv)).max() > 1e-3


@pytest.mark.parametrize("diagonal, samples, method", STRAIGHT)
def test_monotone_reproduces_a_linear_field_on_straight_curves(diagonal, samples, method):
    # exact slopes of a linear field equal the secant: the limiter does not bind
    V, F, idx, part = grid_network(diagonal, samples, method)
    assert all(straight(V, c) for c in part.curves), "precondition: straight paths"
    cv, x = on_paths(V, F, part, idx, linear_field(V[idx]), "monotone")
    np.testing.assert_allclose(x, linear_field(V[cv]), rtol=0, atol=1e-10)


# ---------------------------------------------------------------------------
# long wandering paths (the cycle partition): the end slopes give way to the secant
# ---------------------------------------------------------------------------


def test_straightness_weight():
    from manifill.surface.curve_values import STRAIGHT_FULL, STRAIGHT_NONE, straightness_weight

    r = np.linspace(0.0, 1.0, 101)
    w = straightness_weight(r, np.ones_like(r))
    assert np.all(np.diff(w) >= 0) and w[0] == 0.0 and w[-1] == 1.0
    assert np.all(w[r >= STRAIGHT_FULL] == 1.0) and np.all(w[r <= STRAIGHT_NONE] == 0.0)
    np.testing.assert_allclose(straightness_weight(3 * r, 3 * np.ones_like(r)), w, rtol=0, atol=1e-15)


def test_a_wandering_path_gets_linear_values_and_a_straight_one_keeps_its_slopes():
    # a U-shaped path from (0, 0) to (1, 0) by way of y = 2 (arc length 5, chord 1), and straight
    # spokes from both ends to four samples each, so both ends have exact gradients of the field x + y
    P = [np.array([0.0, 0.0]) + [0, t] for t in np.linspace(0, 2, 9)[:-1]]
    P += [np.array([0.0, 2.0]) + [t, 0] for t in np.linspace(0, 1, 5)[:-1]]
    P += [np.array([1.0, 2.0]) - [0, t] for t in np.linspace(0, 2, 9)]
    U = np.array(P)
    spokes = []
    for end in (U[0], U[-1]):
        for d in ([-1, 0], [0, -1], [-0.7, -0.7] if end[0] == 0 else [0.7, -0.7], [0.3, -1]):
            spokes.append(np.array([end, end + np.array(d) * 0.5, end + np.array(d)]))
    V2 = np.concatenate([U] + [s[1:] for s in spokes])
    V = np.column_stack([V2, np.zeros(len(V2))])
    nu = len(U)
    curves = [np.arange(nu)]
    for j, _ in enumerate(spokes):
        start = 0 if j < 4 else nu - 1
        curves.append(np.array([start, nu + 2 * j, nu + 2 * j + 1]))
    idx = np.sort(np.array([0, nu - 1] + [c[-1] for c in curves[1:]]))
    ends = np.array([[c[0], c[-1]] for c in curves])
    edges = np.unique(np.sort(np.concatenate([np.column_stack([c[:-1], c[1:]]) for c in curves]), axis=1), axis=0)
    normals = np.tile([0.0, 0.0, 1.0], (len(V), 1))
    field = V[:, 0] + V[:, 1]
    cv, x = curve_values(V, edges, idx, field[idx], method="hermite", curves=curves, ends=ends, normals=normals)
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(U, axis=0), axis=1))]
    on_u = np.searchsorted(cv, np.arange(nu))
    # chord / arc length = 0.2: the secant, linear in arc length (not the cubic the gradients would give)
    np.testing.assert_allclose(x[on_u], np.interp(s, [0, s[-1]], field[[0, nu - 1]]), rtol=0, atol=1e-12)
    # the straight spokes: the field itself
    rest = np.searchsorted(cv, np.arange(nu, len(V)))
    np.testing.assert_allclose(x[rest], field[nu:], rtol=0, atol=1e-12)


def test_hermite_on_the_cycle_partition_stays_near_the_samples_range():
    # the cycle partition's late paths detour round the curve drawn so far (arc length up to
    # 8x the distance between their ends); their end slopes times that length overshot by 40 %
    V, F = icosphere(4)
    f = np.sin(2 * V[:, 0]) + V[:, 1] * V[:, 2] + 0.5 * np.cos(3 * V[:, 1])
    worst = 0.0
    for seed in (0, 1):
        idx = np.sort(np.random.default_rng([seed, 100]).choice(len(V), size=100, replace=False))
        part = partition(Surface.from_mesh(V, F), idx, graph=mesh_graph(V, F, distance="length"), method="cycle")
        _, x = on_paths(V, F, part, idx, f[idx], "hermite")
        lo, hi = f[idx].min(), f[idx].max()
        worst = max(worst, max(x.max() - hi, lo - x.min()) / (hi - lo))
    assert worst < 0.05


def fritsch_carlson_cubic(y0, y1, m0, m1, L, off):
    """The textbook monotone cubic (Fritsch and Carlson, 1980) at arc lengths ``off`` of one path."""
    d = (y1 - y0) / L
    if d == 0:
        m0 = m1 = 0.0
    else:
        a, b = max(m0 / d, 0.0), max(m1 / d, 0.0)
        if a * a + b * b > 9:
            a, b = 3 * a / np.hypot(a, b), 3 * b / np.hypot(a, b)
        m0, m1 = a * d, b * d
    t = off / L
    return ((2 * t**3 - 3 * t**2 + 1) * y0 + (t**3 - 2 * t**2 + t) * L * m0 + (-2 * t**3 + 3 * t**2) * y1
            + (t**3 - t**2) * L * m1)


@hsettings
@given(seed=st.integers(0, 10**6), m=st.integers(6, 11), q=st.integers(2, 6), h=st.floats(0.05, 3.0),
       top=st.floats(0.0, 1.0))
def test_monotone_is_the_fritsch_carlson_cubic_on_the_hermite_slopes(seed, m, q, h, top):
    # a parabola on a line of equally spaced samples: the hermite slopes are exact on the paths with two
    # samples on either side; its peak sits anywhere, so some paths' slopes are limited and some not
    rng = np.random.default_rng(seed)
    nv = (m - 1) * q + 1
    s = h * np.arange(nv)
    V = np.column_stack([s, np.zeros(nv), np.zeros(nv)])
    peak = s[-1] * top
    tilt = 0.1 * rng.standard_normal()
    field = 1.0 - (s - peak) ** 2 + tilt * s
    slope = -2 * (s - peak) + tilt
    at = np.arange(0, nv, q)
    curves = [np.arange(at[i], at[i + 1] + 1) for i in range(m - 1)]
    ends = np.array([[c[0], c[-1]] for c in curves])
    edges = np.column_stack([np.arange(nv - 1), np.arange(1, nv)])
    normals = np.tile([0.0, 0.0, 1.0], (nv, 1))
    _, x = curve_values(V, edges, at, field[at], method="monotone", curves=curves, ends=ends, normals=normals)
    L = q * h
    for i in range(2, m - 3):
        c = curves[i]
        want = fritsch_carlson_cubic(field[c[0]], field[c[-1]], slope[c[0]], slope[c[-1]], L, s[c] - s[c[0]])
        np.testing.assert_allclose(x[c], want, rtol=0, atol=1e-9 * (1 + np.abs(field).max()))


def test_two_neighbours_nearly_in_line_give_no_huge_gradient():
    # neighbours 3 degrees apart as seen from the sample: across their line the gradient is barely
    # determined; the fit leaves that direction out instead of dividing by sin(3 degrees)
    from manifill.surface.slopes import sample_gradients

    a = np.radians(3.0)
    V = np.array([[0.0, 0, 0], [1, 0, 0], [np.cos(a), np.sin(a), 0]])
    normals = np.tile([0.0, 0, 1], (3, 1))
    ends = np.array([[0, 1], [0, 2]])
    g, known = sample_gradients(V, normals, ends, np.arange(3), np.array([[0.0], [0.0], [1.0]]))
    assert known[0]
    assert np.linalg.norm(g[0, :, 0]) <= 1.0  # the steepest secant; the exact fit would give 19
    # and a gradient the two can see (along their line) is kept
    g, _ = sample_gradients(V, normals, ends, np.arange(3), V[:, :1] * 2.0)
    np.testing.assert_allclose(g[0, 0, 0], 2.0, rtol=0.01)
