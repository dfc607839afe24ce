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
    part = partition(V, F, idx, mesh_graph(V, F, distance=distance), method=method)
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
    part = partition(V, F, idx, mesh_graph(V, F, distance="length"), method=method)
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
    part = partition(V, F, idx, mesh_graph(V, F, distance="length"))
    cv, x = curve_values(V, part.curve_edges(), idx, vals, method="gvf", levels=check.levels, level=check.level)
    np.testing.assert_allclose(x[np.searchsorted(cv, idx)], vals)


# ---------------------------------------------------------------------------
# several fields, options
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("method", ["linear", "hermite"])
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
# provided no end slope is cut by the cap (twice the steepest secant at that sample).


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


def slopes_within_cap(V, idx, curves, ends, f, grad):
    """No exact end slope exceeds twice the steepest secant of the curves at that sample."""
    pos = {int(v): i for i, v in enumerate(idx)}
    steep = np.zeros(len(idx))
    for c, (a, b) in zip(curves, ends.tolist()):
        secant = abs(f(V[[b]])[0] - f(V[[a]])[0]) / np.linalg.norm(V[c[-1]] - V[c[0]])
        steep[pos[a]] = max(steep[pos[a]], secant)
        steep[pos[b]] = max(steep[pos[b]], secant)
    for c, (a, b) in zip(curves, ends.tolist()):
        t = (V[c[-1]] - V[c[0]]) / np.linalg.norm(V[c[-1]] - V[c[0]])
        for v in (a, b):
            if abs(grad(V[[v]])[0] @ t) > 2 * steep[pos[v]] * (1 - 1e-9):
                return False
    return True


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
    part = partition(V, F, idx, mesh_graph(V, F, distance="length"), method="delaunay")
    f, grad = quadratic_field(QUADRATICS[field])
    assert all(straight(V, c) for c in part.curves), "precondition: straight paths"
    near = two_step_samples(idx, part.ends)
    assert min(len(s) for s in near) >= 8, "precondition: quadratic gradient fits"
    assert all(quadratic_rank(V[idx[sorted(s)]] - V[idx[i]]) == 5 for i, s in enumerate(near)), \
        "precondition: the neighbours determine a quadratic"
    assert slopes_within_cap(V, idx, part.curves, part.ends, f, grad), "precondition: no slope capped"
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


@pytest.mark.parametrize("method", ["linear", "hermite", "gvf"])
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
