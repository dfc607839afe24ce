"""Step 1: Lipschitz constants, levels, the gradual variation condition, GVF and Lipschitz extensions.

Everything is compared with slow, obviously correct references built on the
all-pairs distance matrix ``scipy.sparse.csgraph.shortest_path(G)``: the
Lipschitz constant as the maximum ratio over all pairs of samples, the
violating samples as the pairs with ``d(p, q) < |i_p - i_q|``, the envelopes as
explicit minima over the sources.
"""

import re

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy.sparse import csgraph

from conftest import annulus, grid, icosphere, irregular, lattice, torus, two_components
from manifill.errors import OptionError, SampleError
from manifill.mesh.graph import mesh_graph, offset_distances, trace
from manifill.surface.gradual import check_gradual, gvf, lipschitz_constant, lipschitz_extension, violation_message

hsettings = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                     suppress_health_check=[HealthCheck.too_slow])

# ---------------------------------------------------------------------------
# graphs and references
# ---------------------------------------------------------------------------

MESHES = {
    "grid": lambda: grid(5),
    "grid_right": lambda: grid(6, diagonal="right"),
    "icosphere1": lambda: icosphere(1),
    "icosphere2": lambda: icosphere(2),
    "torus": torus,
    "irregular": lambda: irregular(7),
    "lattice": lambda: lattice(5),
    "annulus": annulus,
    "two_components": two_components,
}
CONNECTED_MESHES = [m for m in MESHES if m != "two_components"]
_MESH_CACHE = {}


def mesh(name):
    if name not in _MESH_CACHE:
        _MESH_CACHE[name] = MESHES[name]()
    return _MESH_CACHE[name]


def random_graph(seed, distance, *, connected=True):
    """A random symmetric graph: a random spanning tree plus extra edges (two halves if not connected)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 41))
    order = rng.permutation(n)
    cut = n if connected or n < 4 else int(rng.integers(2, n - 1))
    rows, cols = [], []
    for part in (order[:cut], order[cut:]):
        for j in range(1, part.size):  # a random tree on the part
            rows.append(part[j])
            cols.append(part[rng.integers(0, j)])
        extra = int(rng.integers(0, 2 * part.size + 1))
        if part.size > 1:
            a, b = rng.choice(part, size=(2, extra))
            keep = a != b
            rows.extend(a[keep])
            cols.extend(b[keep])
    E = np.unique(np.sort(np.column_stack([rows, cols]).astype(np.int64), axis=1), axis=0).reshape(-1, 2)
    w = np.ones(len(E)) if distance == "hops" else rng.uniform(0.1, 3.0, size=len(E))
    G = sp.csr_array((np.r_[w, w], (np.r_[E[:, 0], E[:, 1]], np.r_[E[:, 1], E[:, 0]])), shape=(n, n))
    G.sort_indices()
    return G


def graph_for(kind, seed, distance):
    """('mesh', name) or ('random', connected) -> graph with the given distance."""
    if kind[0] == "mesh":
        V, F = mesh(kind[1])
        return mesh_graph(V, F, distance=distance)
    return random_graph(seed, distance, connected=kind[1])


def all_pairs(G):
    return csgraph.shortest_path(G, method="D", directed=False)


def random_samples(rng, n, k):
    return rng.choice(n, size=min(k, n), replace=False)


def random_values(rng, k):
    """Values of several kinds: uniform floats, integers with ties, a few distinct ones, constants."""
    kind = int(rng.integers(0, 5))
    if kind == 0:
        return rng.uniform(-5.0, 5.0, size=k)
    if kind == 1:
        return rng.integers(-4, 5, size=k).astype(float)
    if kind == 2:
        return rng.choice([0.0, 0.3, 7.0], size=k)
    if kind == 3:
        return np.full(k, 2.5)
    return 1e3 * rng.standard_normal(k)


def brute_lipschitz(D, idx, vals):
    Dp = D[np.ix_(idx, idx)]
    diff = np.abs(vals[:, None] - vals[None, :])
    ok = np.isfinite(Dp) & (Dp > 0)
    return float((diff[ok] / Dp[ok]).max()) if ok.any() else 0.0


def brute_violators(D, idx, level, distance):
    """Samples p (vertex ids) with a partner q at i_p - i_q > d(p, q).

    Returns the clear violators and the possible ones: equal for hops (integers,
    exact); for lengths, pairs within 1e-7 of a tie may go either way.
    """
    excess = level[:, None] - level[None, :] - D[np.ix_(idx, idx)]
    np.fill_diagonal(excess, -np.inf)
    hi, lo = (0.5, 0.5) if distance == "hops" else (1e-7, -1e-7)
    clear = {int(idx[i]) for i in np.flatnonzero((excess > hi).any(axis=1))}
    possible = {int(idx[i]) for i in np.flatnonzero((excess > lo).any(axis=1))}
    return clear, possible


def samples_connected(G, idx):
    _, lab = csgraph.connected_components(G, directed=False)
    return np.unique(lab[idx]).size == 1


graph_kinds = st.one_of(
    st.sampled_from(CONNECTED_MESHES).map(lambda m: ("mesh", m)),
    st.just(("random", True)),
)
all_graph_kinds = st.one_of(graph_kinds, st.just(("mesh", "two_components")), st.just(("random", False)))
distances = st.sampled_from(["hops", "length"])


# ---------------------------------------------------------------------------
# the Lipschitz constant
# ---------------------------------------------------------------------------


@hsettings
@given(kind=graph_kinds, distance=distances, seed=st.integers(0, 10**6), k=st.integers(2, 30))
def test_lipschitz_constant_is_the_all_pairs_maximum(kind, distance, seed, k):
    G = graph_for(kind, seed, distance)
    rng = np.random.default_rng(seed)
    idx = random_samples(rng, G.shape[0], k)
    vals = random_values(rng, idx.size)
    D = all_pairs(G)
    K, pair, passes = lipschitz_constant(G, idx, vals)
    ref = brute_lipschitz(D, idx, vals)
    assert K == pytest.approx(ref, rel=1e-9, abs=1e-300)
    if ref == 0:
        assert pair == (-1, -1)
    else:
        p, q = pair
        assert p != q
        assert abs(vals[p] - vals[q]) / D[idx[p], idx[q]] == pytest.approx(ref, rel=1e-9)
        assert passes >= 1


def test_lipschitz_constant_trivial_cases():
    V, F = grid(4)
    G = mesh_graph(V, F, distance="hops")
    assert lipschitz_constant(G, np.array([3]), np.array([1.0]))[:2] == (0.0, (-1, -1))
    assert lipschitz_constant(G, np.array([3, 9, 12]), np.full(3, -2.0))[:2] == (0.0, (-1, -1))
    K, pair, _ = lipschitz_constant(G, np.array([0, 15]), np.array([1.0, 7.0]))
    assert (K, sorted(pair)) == (2.0, [0, 1])  # 3 hops apart, 6 apart in value


@pytest.mark.parametrize("idx, vals, expected", [
    ([0, 20], [0.0, 5.0], 0.0),                     # one sample per component: no pair at finite distance
    ([0, 15, 20], [0.0, 0.001, 5.0], 0.001 / 3),    # 0 and 15 are 3 hops apart in the 4x4 grid
])
def test_lipschitz_constant_samples_in_two_components(idx, vals, expected):
    V, F = two_components()
    G = mesh_graph(V, F, distance="hops")
    assert brute_lipschitz(all_pairs(G), np.array(idx), np.array(vals)) == pytest.approx(expected)
    K, _, _ = lipschitz_constant(G, np.array(idx), np.array(vals))
    assert K == pytest.approx(expected, abs=1e-15)


# ---------------------------------------------------------------------------
# levels and the gradual variation condition
# ---------------------------------------------------------------------------


def assert_nearest_level(vals, check):
    gap = np.abs(vals[:, None] - check.levels[None, :])
    chosen = np.abs(vals - check.levels[check.level])
    assert np.all(chosen <= gap.min(axis=1) + 1e-12 * max(1.0, float(np.abs(vals).max())))
    assert check.level_error == pytest.approx(float(chosen.max()), abs=1e-12)
    assert check.level.dtype.kind == "i"
    assert check.level.min() >= 0 and check.level.max() < check.levels.size


def assert_violations_match(D, idx, check):
    level = check.level
    clear, possible = brute_violators(D, idx, level, check.distance)
    rows = check.violations
    assert rows.shape == (len(rows), 4)
    reported = {int(p) for p in rows[:, 0]}
    assert len(reported) == len(rows), "one row per violating sample"
    assert clear <= reported <= possible
    pos = {int(v): i for i, v in enumerate(idx)}
    for p, q, d, gap in rows:
        i, j = pos[int(p)], pos[int(q)]
        assert d == pytest.approx(D[int(p), int(q)], rel=1e-9, abs=1e-9), "the true distance"
        assert gap == abs(level[i] - level[j])
        assert d < gap and level[i] > level[j], "a real violation, p above q"
        # q is the worst partner: it maximises i_p - i_q - d(p, q)
        worst = (level[i] - level - D[int(p), idx]).max()
        assert level[i] - level[j] - d == pytest.approx(worst, abs=1e-9)
    assert check.holds == (len(rows) == 0)


@hsettings
@given(kind=all_graph_kinds, distance=distances, seed=st.integers(0, 10**6), k=st.integers(2, 30),
       how=st.sampled_from(["count", "array", "auto"]))
def test_check_gradual_against_all_pairs(kind, distance, seed, k, how):
    G = graph_for(kind, seed, distance)
    rng = np.random.default_rng(seed)
    idx = random_samples(rng, G.shape[0], k)
    vals = random_values(rng, idx.size)
    D = all_pairs(G)
    if how == "count":
        m = int(rng.integers(1, 41))
        check = check_gradual(G, idx, vals, levels=m, distance=distance)
        expected = np.linspace(vals.min(), vals.max(), m) if np.ptp(vals) > 0 and m > 1 else [vals.min()]
        np.testing.assert_allclose(check.levels, expected, rtol=0, atol=1e-12 * max(1.0, np.abs(vals).max()))
    elif how == "array":
        m = int(rng.integers(1, 12))
        A = np.unique(rng.uniform(vals.min() - 1, vals.max() + 1, size=m))
        check = check_gradual(G, idx, vals, levels=list(A), distance=distance)
        np.testing.assert_array_equal(check.levels, A)
    else:
        check = check_gradual(G, idx, vals, distance=distance)
        assert check.holds, "auto levels always satisfy the condition"
        assert len(check.violations) == 0
    assert check.distance == distance
    assert_nearest_level(vals, check)
    assert_violations_match(D, idx, check)
    if samples_connected(G, idx):
        assert check.lipschitz == pytest.approx(brute_lipschitz(D, idx, vals), rel=1e-9, abs=1e-300)
        if check.lipschitz > 0:
            p, q = check.lipschitz_pair
            i, j = np.flatnonzero(idx == p)[0], np.flatnonzero(idx == q)[0]
            assert abs(vals[i] - vals[j]) / D[p, q] == pytest.approx(check.lipschitz, rel=1e-9)


def uniform_levels(vals, step):
    """The documented uniform levels: from the smallest value in steps of ``step``, each value rounded."""
    return np.floor((vals - vals.min()) / step + 0.5).astype(np.int64)


@hsettings
@given(kind=graph_kinds, distance=distances, seed=st.integers(0, 10**6), k=st.integers(2, 30))
def test_auto_step_is_the_lipschitz_constant_unless_rounding_breaks_it(kind, distance, seed, k):
    G = graph_for(kind, seed, distance)
    rng = np.random.default_rng(seed)
    idx = random_samples(rng, G.shape[0], k)
    vals = random_values(rng, idx.size)
    D = all_pairs(G)
    check = check_gradual(G, idx, vals, distance=distance)
    K = brute_lipschitz(D, idx, vals)
    if K == 0:
        assert check.step is None and check.levels.size == 1 and check.holds
        return

    def holds(step):
        lev = uniform_levels(vals, step)
        return not (lev[:, None] - lev[None, :] > D[np.ix_(idx, idx)] + 1e-9).any()

    if holds(K):
        assert check.step == pytest.approx(K, rel=1e-9)
    else:  # coarsened by factors of 1.5, the first that works
        j = round(np.log(check.step / K) / np.log(1.5))
        assert j >= 1
        assert check.step == pytest.approx(K * 1.5**j, rel=1e-9)
        assert holds(check.step) and not holds(check.step / 1.5)
    np.testing.assert_array_equal(check.level, uniform_levels(vals, check.step))
    # uniform steps, the top level capped at the largest sample (within half a step below or at it)
    np.testing.assert_allclose(np.diff(check.levels)[:-1], check.step, rtol=1e-9)
    if check.levels.size > 1:
        assert 0 < np.diff(check.levels)[-1] <= check.step * (1 + 1e-9)
        top = vals.min() + check.step * (check.levels.size - 1)
        want = min(top, vals.max())
        assert check.levels[-1] == want or abs(check.levels[-1] - want) <= 1e-9 * abs(top)


@pytest.mark.parametrize("name", CONNECTED_MESHES)
@pytest.mark.parametrize("seed", [0, 1])
def test_auto_step_equals_hop_lipschitz_when_samples_lie_on_levels(name, seed):
    # values c + s * (hop distance to one sample): integer multiples of s, 1-Lipschitz in hops -> K = s exactly
    V, F = mesh(name)
    G = mesh_graph(V, F, distance="hops")
    rng = np.random.default_rng(seed)
    idx = random_samples(rng, len(V), 12)
    s, c = 0.37, -1.25
    hops = csgraph.shortest_path(G, unweighted=True, indices=idx[0])[idx]
    vals = c + s * hops
    check = check_gradual(G, idx, vals)
    assert check.holds
    assert check.lipschitz == pytest.approx(s, rel=1e-12)
    assert check.step == pytest.approx(s, rel=1e-12)
    np.testing.assert_array_equal(check.level, hops.astype(np.int64))
    assert check.level_error < 1e-12


@pytest.mark.parametrize("levels", [[0.0, 1.0, 1.0], [2.0, 1.0], [0.0, 2.0, 1.0], [], [0.0, np.nan, 2.0],
                                    [0.0, np.inf], 0, -3])
def test_bad_levels_raise_sample_error(levels):
    V, F = grid(4)
    with pytest.raises(SampleError):
        check_gradual(mesh_graph(V, F, distance="hops"), np.array([0, 5, 15]), np.array([0.0, 1.0, 2.0]), levels=levels)


def test_docstring_violation_example_by_hand():
    # 0 and 1 are adjacent; with 4 levels their values 0 and 3 are 3 levels apart
    V, F = grid(5)
    check = check_gradual(mesh_graph(V, F, distance="hops"), np.array([0, 1]), np.array([0.0, 3.0]), levels=4)
    assert not check.holds
    np.testing.assert_array_equal(check.violations, [[1.0, 0.0, 1.0, 3.0]])


# ---------------------------------------------------------------------------
# offset_distances and trace
# ---------------------------------------------------------------------------


@hsettings
@given(kind=all_graph_kinds, distance=distances, seed=st.integers(0, 10**6), k=st.integers(1, 30))
def test_offset_distances_is_the_minimum_over_sources(kind, distance, seed, k):
    G = graph_for(kind, seed, distance)
    rng = np.random.default_rng(seed)
    n = G.shape[0]
    src = random_samples(rng, n, k)
    off = rng.uniform(-3.0, 3.0, size=src.size) if rng.random() < 0.7 else rng.integers(-2, 3, src.size) * 1.0
    D = all_pairs(G)
    dist, root, pred = offset_distances(G, src, off)
    ref = (off[None, :] + D[:, src]).min(axis=1)
    reach = np.isfinite(ref)
    np.testing.assert_array_equal(np.isfinite(dist), reach)
    np.testing.assert_allclose(dist[reach], ref[reach], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(root[~reach], -1)
    np.testing.assert_array_equal(pred[~reach], -9999)
    E = {(int(a), int(b)): float(w) for a, b, w in zip(*sp.find(G))}
    for x in np.flatnonzero(reach):
        r = root[x]
        assert 0 <= r < src.size
        assert off[r] + D[x, src[r]] == pytest.approx(ref[x], abs=1e-9), "root attains the minimum"
        path = trace(pred, x)
        assert path[0] == x and path[-1] == src[r], "pred leads to the root's source"
        length = sum(E[(int(a), int(b))] for a, b in zip(path[:-1], path[1:]))
        assert length == pytest.approx(D[x, src[r]], abs=1e-9), "along a shortest path"
        if pred[x] == -9999:
            assert x == src[r]


def test_offset_distances_docstring_example_by_hand():
    V, F = grid(4)
    d, root, pred = offset_distances(mesh_graph(V, F, distance="hops"), np.array([0, 15]), np.array([0.0, 10.0]))
    assert (d[15], root[15]) == (3.0, 0)
    assert len(trace(pred, 15)) == 4 and trace(pred, 15)[-1] == 0


# ---------------------------------------------------------------------------
# gradually varied fitting
# ---------------------------------------------------------------------------


def consistent_levels(D, idx, rng, spread):
    """Random integer levels repaired into ones satisfying the condition (their own upper envelope)."""
    raw = rng.integers(0, spread + 1, size=idx.size).astype(float)
    Dp = D[np.ix_(idx, idx)]
    env = (raw[None, :] + Dp).min(axis=1)  # min_q (i_q + d(p, q)): 1-Lipschitz, integer, <= raw
    return env.astype(np.int64)


GVF_MESHES = ["grid", "grid_right", "icosphere1", "icosphere2", "torus", "irregular", "annulus", "two_components"]


@hsettings
@given(kind=st.one_of(st.sampled_from(GVF_MESHES).map(lambda m: ("mesh", m)),
                      st.sampled_from([("random", True), ("random", False)])),
       seed=st.integers(0, 10**6), k=st.integers(1, 30), method=st.sampled_from(["envelope", "chen"]))
def test_gvf_is_a_gradually_varied_fit(kind, seed, k, method):
    G = graph_for(kind, seed, "hops")
    rng = np.random.default_rng(seed)
    D = all_pairs(G)
    idx = random_samples(rng, G.shape[0], k)
    level = consistent_levels(D, idx, rng, spread=int(rng.integers(0, 12)))
    assert not (level[:, None] - level[None, :] > D[np.ix_(idx, idx)]).any()
    fit = gvf(G, idx, level, method=method)
    assert fit.dtype.kind == "i" and fit.shape == (G.shape[0],)
    np.testing.assert_array_equal(fit[idx], level)
    reach = np.isfinite(D[:, idx]).any(axis=1)
    np.testing.assert_array_equal(fit[~reach], -1)
    assert fit[reach].min() >= level.min() and fit[reach].max() <= level.max()
    a, b = G.nonzero()
    both = reach[a] & reach[b]
    assert np.abs(fit[a[both]] - fit[b[both]]).max(initial=0) <= 1


def test_gvf_docstring_example_by_hand():
    V, F = grid(4, diagonal="right")
    fit = gvf(mesh_graph(V, F, distance="hops"), np.array([0, 15]), np.array([0, 2]))
    assert fit.reshape(4, 4).tolist() == [[0, 0, 0, 1], [0, 0, 1, 1], [0, 1, 1, 2], [1, 1, 2, 2]]


@pytest.mark.parametrize("method", ["envelope", "chen"])
@pytest.mark.parametrize("seed", range(4))
def test_gvf_raises_naming_real_violations(method, seed):
    V, F = icosphere(2)
    G = mesh_graph(V, F, distance="hops")
    D = all_pairs(G)
    rng = np.random.default_rng(seed)
    idx = random_samples(rng, len(V), 10)
    level = rng.integers(0, 12, size=idx.size)
    level[1] = level[0] + int(D[idx[0], idx[1]]) + 1  # at least this pair breaks the condition
    with pytest.raises(SampleError) as err:
        gvf(G, idx, level, method=method)
    named = re.findall(r"vertices (\d+) and (\d+) are (\S+) apart but (\d+) levels apart", str(err.value))
    assert named, str(err.value)
    pos = {int(v): i for i, v in enumerate(idx)}
    for p, q, d, gap in named:
        i, j = pos[int(p)], pos[int(q)]
        assert float(d) == D[int(p), int(q)] and int(gap) == abs(level[i] - level[j]) > float(d)


def test_gvf_rejects_a_length_graph_and_unknown_methods():
    V, F = grid(4)
    idx, level = np.array([0, 15]), np.array([0, 2])
    with pytest.raises(OptionError):
        gvf(mesh_graph(V, F, distance="length"), idx, level)
    with pytest.raises(OptionError):
        gvf(mesh_graph(V, F, distance="hops"), idx, level, method="fastest")


# ---------------------------------------------------------------------------
# Lipschitz extensions
# ---------------------------------------------------------------------------


@hsettings
@given(kind=all_graph_kinds, distance=distances, seed=st.integers(0, 10**6), k=st.integers(1, 30),
       factor=st.sampled_from([None, 1.0, 1.7]))
def test_lipschitz_extensions(kind, distance, seed, k, factor):
    G = graph_for(kind, seed, distance)
    rng = np.random.default_rng(seed)
    D = all_pairs(G)
    idx = random_samples(rng, G.shape[0], k)
    vals = random_values(rng, idx.size)
    Kmin = brute_lipschitz(D, idx, vals)
    if factor is None:
        if not samples_connected(G, idx):
            return  # the default K is wrong there: test_lipschitz_constant_samples_in_two_components
        K = Kmin
    else:
        K = factor * Kmin + (0.5 if Kmin == 0 and factor > 1 else 0.0)
        # K = 0 with unequal values (samples in different components): test_lipschitz_extension_k_zero
        assume(K > 0 or np.ptp(vals) == 0)
    ext = {kind_: lipschitz_extension(G, idx, vals, kind=kind_, K=None if factor is None else K)
           for kind_ in ("mcshane", "midpoint", "whitney")}
    reach = np.isfinite(D[:, idx]).any(axis=1)
    scale = max(1.0, float(np.abs(vals).max()))
    eps = 1e-9 * scale
    a, b, w = sp.find(G)
    both = reach[a] & reach[b]
    for name, x in ext.items():
        assert np.isnan(x[~reach]).all() and np.isfinite(x[reach]).all(), name
        np.testing.assert_array_equal(x[idx], vals)
        assert np.all(np.abs(x[a[both]] - x[b[both]]) <= K * w[both] + eps), f"{name} is not K-Lipschitz"
    lo, mid, hi = ext["mcshane"][reach], ext["midpoint"][reach], ext["whitney"][reach]
    assert np.all(lo <= mid + eps) and np.all(mid <= hi + eps)
    np.testing.assert_allclose(mid, (lo + hi) / 2, rtol=0, atol=eps)
    KD = np.where(np.isfinite(D), K * np.where(np.isfinite(D), D, 0.0), np.inf)  # K d(x, y), 0 * inf = inf
    W = (vals[None, :] + KD[:, idx]).min(axis=1)  # inf where unreachable
    M = (vals[None, :] - KD[:, idx]).max(axis=1)  # -inf where unreachable
    np.testing.assert_allclose(hi, W[reach], rtol=0, atol=eps)
    np.testing.assert_allclose(lo, M[reach], rtol=0, atol=eps)
    # every K-Lipschitz extension lies between McShane's and Whitney's: a few built from cones
    for _trial in range(4):
        tips = rng.choice(G.shape[0], size=3)
        tips = tips[reach[tips]]
        dip = rng.uniform(0.0, 2.0, size=tips.size) * scale
        KDt = KD[:, tips]
        # max of downward cones under Whitney at their tips, and min of upward cones over McShane
        up = np.maximum(M, (W[tips] - dip - KDt).max(axis=1, initial=-np.inf))
        down = np.minimum(W, (M[tips] + dip + KDt).min(axis=1, initial=np.inf))
        for h in (up, down, np.fmin(up, down), np.fmax(up, down)):
            hr = h[reach]
            np.testing.assert_allclose(h[idx], vals, rtol=0, atol=eps)  # the references are extensions
            assert np.all(np.abs(h[a[both]] - h[b[both]]) <= K * w[both] + eps)
            assert np.all(lo <= hr + eps) and np.all(hr <= hi + eps)


def test_lipschitz_extension_docstring_example_and_constant_values():
    V, F = grid(5, diagonal="right")
    G = mesh_graph(V, F, distance="hops")
    x = lipschitz_extension(G, np.array([0, 24]), np.array([0.0, 4.0]))
    assert x.reshape(5, 5)[0].tolist() == [0.0, 0.5, 1.0, 1.5, 2.0]
    V, F = two_components()
    y = lipschitz_extension(mesh_graph(V, F, distance="hops"), np.array([1, 3]), np.array([2.0, 2.0]))
    np.testing.assert_array_equal(y[:16], 2.0)
    assert np.isnan(y[16:]).all()
    with pytest.raises(OptionError):
        lipschitz_extension(G, np.array([0, 24]), np.array([0.0, 4.0]), kind="kirszbraun")


def test_lipschitz_extension_k_zero_with_samples_in_two_components():
    V, F = two_components()
    G = mesh_graph(V, F, distance="hops")
    x = lipschitz_extension(G, np.array([0, 20]), np.array([0.0, 5.0]), K=0.0)
    np.testing.assert_array_equal(x[:16], 0.0)
    np.testing.assert_array_equal(x[16:], 5.0)


# ---------------------------------------------------------------------------
# the check's own views: worst violations first, the report summary
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(8))
def test_worst_orders_violations_by_slack(seed):
    V, F = mesh("torus")
    G = mesh_graph(V, F, distance="hops")
    rng = np.random.default_rng(seed)
    idx = random_samples(rng, G.shape[0], 25)
    check = check_gradual(G, idx, rng.uniform(0, 10, idx.size), levels=40)
    assert len(check.violations) > 3, "precondition: several violations"
    rows = check.worst()
    slack = rows[:, 2] - rows[:, 3]
    assert (np.diff(slack) >= 0).all() and slack[0] < 0, "most negative slack first"
    # a permutation of the violations, exactly the rows numpy's argsort of the slack gives
    assert sorted(map(tuple, rows)) == sorted(map(tuple, check.violations))
    order = np.argsort(check.violations[:, 2] - check.violations[:, 3])
    assert rows.tobytes() == check.violations[order].tobytes()
    assert check.worst(2).tobytes() == rows[:2].tobytes()
    assert check.worst(0).shape == (0, 4) and check.worst(10**6).shape == rows.shape


def test_worst_of_a_check_that_holds_is_empty_and_summary_matches():
    V, F = mesh("grid")
    G = mesh_graph(V, F, distance="hops")
    check = check_gradual(G, np.array([0, 4, 24]), np.array([0.0, 2.0, 3.0]))
    assert check.holds and check.worst().shape == (0, 4)
    assert check.summary() == {"holds": True, "lipschitz_hops": 0.75, "step": 0.75, "levels": 5,
                               "violations": 0, "level_error": 0.25}  # 2.0 sits on 2.25
    bad = check_gradual(G, np.array([0, 1]), np.array([0.0, 3.0]), levels=4)
    assert bad.summary()["violations"] == 1 and bad.summary()["holds"] is False
    assert "vertices 1 and 0 are 1 apart but 3 levels apart" in violation_message(bad)


def test_check_gradual_reads_the_distance_from_the_graph_by_default():
    V, F = mesh("irregular")
    idx, vals = np.array([0, 10, 30]), np.array([0.0, 1.3, 2.0])
    hops, length = mesh_graph(V, F, distance="hops"), mesh_graph(V, F, distance="length")
    assert check_gradual(hops, idx, vals).distance == "hops"
    assert check_gradual(length, idx, vals).distance == "length"
    assert check_gradual(length, idx, vals, distance="hops").distance == "hops"
    a, b = check_gradual(hops, idx, vals), check_gradual(hops, idx, vals, distance="hops")
    assert a.levels.tobytes() == b.levels.tobytes() and a.level.tobytes() == b.level.tobytes()
    with pytest.raises(OptionError, match="distance"):
        check_gradual(hops, idx, vals, distance="geodesic")
