"""Steps 2-3: curves through every sample, and the patches they cut out.

The invariants are checked against the mesh itself (its edge set, a plain
breadth-first search for the patches), never against manifill's own graphs.
"""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import edge_set, grid, icosphere, irregular, torus, two_components
from manifill.errors import OptionError
from manifill.mesh.graph import mesh_graph
from manifill.surface.partition import partition
from manifill.surface.surface import Surface

hsettings = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                     suppress_health_check=[HealthCheck.too_slow])
METHODS = ("delaunay", "cycle", "tree")

MESHES = {
    "icosphere2": lambda: icosphere(2),
    "icosphere3": lambda: icosphere(3),
    "grid": lambda: grid(10),
    "grid_right": lambda: grid(10, diagonal="right"),
    "torus": torus,
    "irregular": irregular,
}
_CACHE = {}


def mesh(name):
    if name not in _CACHE:
        V, F = MESHES[name]() if name in MESHES else {"two_components": two_components}[name]()
        _CACHE[name] = (V, F, edge_set(F))
    return _CACHE[name]


def neighbours(E, n):
    nb = [[] for _ in range(n)]
    for i, j in E:
        nb[i].append(j)
        nb[j].append(i)
    return nb


def flood(nb, free):
    """Connected components of the free vertices by breadth-first search: a label per vertex, -1 elsewhere."""
    lab = np.full(len(nb), -1)
    count = 0
    for s in np.flatnonzero(free):
        if lab[s] >= 0:
            continue
        lab[s] = count
        stack = [s]
        while stack:
            x = stack.pop()
            for y in nb[x]:
                if free[y] and lab[y] < 0:
                    lab[y] = count
                    stack.append(y)
        count += 1
    return lab, count


def assert_partition(V, F, E, idx, G, part):
    """Every invariant of a Partition, checked on the mesh's own edge set."""
    n = len(V)
    samples = set(idx.tolist())
    assert part.on_curve.shape == part.labels.shape == (n,)
    assert part.on_curve[idx].all(), "every sample is on a curve"
    # curves: vertex paths along mesh edges, from the sample in ends[:, 0] to the one in ends[:, 1]
    assert part.ends.shape == (len(part.curves), 2)
    covered = np.zeros(n, dtype=bool)
    covered[idx] = True
    uses = np.zeros(n, dtype=int)
    for c, (a, b) in zip(part.curves, part.ends):
        c = np.asarray(c)
        assert c.ndim == 1 and c.size >= 2
        assert c[0] == a and c[-1] == b, "a curve runs between the samples its ends row names"
        assert a in samples and b in samples and a != b
        assert all((min(u, v), max(u, v)) in E for u, v in zip(c[:-1].tolist(), c[1:].tolist()))
        covered[c] = True
        uses[np.unique(c[1:-1])] += 1
    np.testing.assert_array_equal(part.on_curve, covered, err_msg="on_curve is the curves and the samples")
    # labels: -1 exactly on curves; elsewhere the connected components of the rest, largest first
    np.testing.assert_array_equal(part.labels < 0, part.on_curve)
    assert (part.labels >= -1).all()
    nb = neighbours(E, n)
    ref, count = flood(nb, ~part.on_curve)
    assert part.labels.max() + 1 == count == len(part.boundaries)
    free = np.flatnonzero(~part.on_curve)
    pairs = set(zip(part.labels[free].tolist(), ref[free].tolist()))
    assert len(pairs) == count, "patches are exactly the components off the curves"
    for i, j in E:  # no mesh edge joins two different patches
        if part.labels[i] >= 0 and part.labels[j] >= 0:
            assert part.labels[i] == part.labels[j]
    sizes = np.bincount(part.labels[free], minlength=count)
    assert np.all(np.diff(sizes) <= 0), "numbered by decreasing size"
    # boundaries: exactly the curve vertices adjacent to the patch
    for p, bnd in enumerate(part.boundaries):
        expected = {y for x in np.flatnonzero(part.labels == p) for y in nb[x] if part.on_curve[y]}
        assert set(np.asarray(bnd).tolist()) == expected
        assert len(bnd) == len(expected)
    # curve_edges: the unique consecutive pairs
    ce = {(min(u, v), max(u, v)) for c in part.curves for u, v in zip(c[:-1].tolist(), c[1:].tolist())}
    got = part.curve_edges()
    assert got.shape == (len(ce), 2) and set(map(tuple, got.tolist())) == ce
    # the report
    r = part.report
    assert r["curves"] == len(part.curves)
    assert r["curve_vertices"] == int(part.on_curve.sum())
    assert r["patches"] == count
    assert r["patch_sizes"] == sizes.tolist()
    assert sum(r["patch_sizes"]) == r["inner_points"] == n - int(part.on_curve.sum())
    length = sum(float(G[i, j]) for i, j in ce)
    assert r["curve_length"] == pytest.approx(length, rel=1e-12)
    if ce:
        assert r["curve_length"] > 0
    if count:
        assert r["balance"] >= 1.0
        assert r["balance"] == pytest.approx(sizes.max() / sizes.mean())
    assert r["merged_vertices"] == int((uses > 1).sum())


@hsettings
@given(name=st.sampled_from(sorted(MESHES)), method=st.sampled_from(METHODS),
       distance=st.sampled_from(["hops", "length"]), seed=st.integers(0, 10**6), k=st.integers(1, 30))
def test_partition_invariants(name, method, distance, seed, k):
    V, F, E = mesh(name)
    rng = np.random.default_rng(seed)
    idx = np.sort(rng.choice(len(V), size=k, replace=False))
    G = mesh_graph(V, F, distance=distance)
    part = partition(Surface.from_mesh(V, F), idx, graph=G, method=method)
    assert part.report["method"] == method
    assert_partition(V, F, E, idx, G, part)
    if method == "tree":
        assert len(part.curves) == k - 1, "a spanning tree of the samples"
    if method == "cycle":
        assert len(part.curves) == (0 if k == 1 else 1 if k == 2 else k)
        if k > 2:  # a chain through every sample, closed back to the first
            assert all(part.curves[j][-1] == part.curves[j + 1][0] for j in range(k - 1))
            assert part.curves[-1][-1] == part.curves[0][0]
            assert sorted(part.ends[:, 0].tolist()) == idx.tolist()


# ---------------------------------------------------------------------------
# the paper's examples
# ---------------------------------------------------------------------------

WELL_SPREAD_5 = [
    [[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [0, 0, 1]],
    [[1, 0, 0], [-0.5, 0.8, 0.1], [-0.5, -0.8, 0.2], [0, 0.3, 1], [0.1, -0.2, -1]],
]


@pytest.mark.parametrize("k", [2, 3, 4])
@pytest.mark.parametrize("dirs", range(len(WELL_SPREAD_5)))
@pytest.mark.parametrize("distance", ["hops", "length"])
def test_five_samples_on_a_sphere_give_one_cycle_and_two_patches(k, dirs, distance):
    # Fig. 4.1: five samples linked into one closed curve cut the sphere into two regions
    V, F = icosphere(k)
    idx = np.array([int(np.argmax(V @ np.asarray(d, float))) for d in WELL_SPREAD_5[dirs]])
    G = mesh_graph(V, F, distance=distance)
    part = partition(Surface.from_mesh(V, F), idx, graph=G, method="cycle")
    assert_partition(V, F, edge_set(F), np.sort(idx), G, part)
    assert len(part.curves) == 5
    # one closed simple cycle: every curve vertex has exactly two curve neighbours, and it is connected
    E = part.curve_edges()
    deg = np.bincount(E.ravel(), minlength=len(V))
    assert set(deg[part.on_curve].tolist()) == {2}
    assert len(E) == int(part.on_curve.sum())
    nb = neighbours([tuple(e) for e in E.tolist()], len(V))
    lab, count = flood(nb, part.on_curve)
    assert count == 1
    assert part.report["patches"] == 2


def test_twelve_icosahedron_vertices_give_the_icosahedron():
    # 12 well-spread guiding points on a sphere: the Delaunay graph is the icosahedron,
    # 3 * 12 - 6 = 30 curves and 2 * 12 - 4 = 20 patches
    V, F = icosphere(4)
    idx = np.arange(12)
    for distance in ("hops", "length"):
        G = mesh_graph(V, F, distance=distance)
        part = partition(Surface.from_mesh(V, F), idx, graph=G, method="delaunay")
        assert_partition(V, F, edge_set(F), idx, G, part)
        assert part.report["curves"] == 30
        assert part.report["patches"] == 20
        _, F0 = icosphere(0)
        ends = {tuple(sorted(e)) for e in part.ends.tolist()}
        assert ends == edge_set(F0)
        assert len(set(part.report["patch_sizes"])) == 1, "twenty equal triangles"
        # Euler on the sphere for the curve network: V - E + F = 2
        assert part.report["curve_vertices"] - len(part.curve_edges()) + part.report["patches"] == 2


@pytest.mark.parametrize("distance", ["hops", "length"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_twelve_guiding_points_on_the_torus(distance, seed):
    V, F = torus(16, 10)
    rng = np.random.default_rng(seed)
    idx = np.sort(rng.choice(len(V), size=12, replace=False))
    G = mesh_graph(V, F, distance=distance)
    part = partition(Surface.from_mesh(V, F), idx, graph=G, method="delaunay")
    assert_partition(V, F, edge_set(F), idx, G, part)
    assert part.on_curve[idx].all()
    assert part.report["patches"] >= 2


@pytest.mark.parametrize("distance", ["hops", "length"])
@pytest.mark.parametrize("seed", range(6))
def test_tree_leaves_one_patch_on_a_sphere(distance, seed):
    # sparse samples: with dense ones two branches can enclose a vertex (see the report)
    V, F, E = mesh("icosphere3")
    rng = np.random.default_rng(seed)
    k = int(rng.integers(2, 16))
    idx = np.sort(rng.choice(len(V), size=k, replace=False))
    G = mesh_graph(V, F, distance=distance)
    part = partition(Surface.from_mesh(V, F), idx, graph=G, method="tree")
    assert_partition(V, F, E, idx, G, part)
    assert len(part.curves) == k - 1
    assert part.report["patches"] == 1
    # the curve edges form a tree: connected, one edge fewer than vertices
    ce = part.curve_edges()
    assert len(ce) == int(part.on_curve.sum()) - 1
    assert flood(neighbours([tuple(e) for e in ce.tolist()], len(V)), part.on_curve)[1] == 1


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("distance", ["hops", "length"])
def test_one_and_two_samples(method, distance):
    V, F, E = mesh("icosphere2")
    G = mesh_graph(V, F, distance=distance)
    one = partition(Surface.from_mesh(V, F), np.array([7]), graph=G, method=method)
    assert_partition(V, F, E, np.array([7]), G, one)
    assert one.curves == [] and one.report["patches"] == 1 and one.report["curve_length"] == 0.0
    assert one.report["inner_points"] == len(V) - 1
    two = partition(Surface.from_mesh(V, F), np.array([3, 40]), graph=G, method=method)
    assert_partition(V, F, E, np.array([3, 40]), G, two)
    assert len(two.curves) == 1 and two.report["patches"] == 1
    assert sorted([two.curves[0][0], two.curves[0][-1]]) == [3, 40]


@pytest.mark.parametrize("method", ["delaunay", "tree"])
@pytest.mark.parametrize("distance", ["hops", "length"])
def test_two_components_with_samples_in_both(method, distance):
    V, F, E = mesh("two_components")
    idx = np.array([0, 5, 15, 17, 23])
    G = mesh_graph(V, F, distance=distance)
    part = partition(Surface.from_mesh(V, F), idx, graph=G, method=method)
    assert_partition(V, F, E, idx, G, part)
    comp = (np.arange(len(V)) >= 16).astype(int)
    for c in part.curves:
        assert np.unique(comp[c]).size == 1, "no curve between components"
    if method == "tree":
        assert len(part.curves) == len(idx) - 2  # a spanning forest


@pytest.mark.parametrize("distance", ["hops", "length"])
def test_cycle_on_two_components_with_samples_in_both(distance):
    V, F, E = mesh("two_components")
    idx = np.array([0, 5, 15, 17, 23])
    G = mesh_graph(V, F, distance=distance)
    assert_partition(V, F, E, idx, G, partition(Surface.from_mesh(V, F), idx, graph=G, method="cycle"))


def test_partition_invariants_on_dense_samples():
    # every vertex a sample, and half of them: merged paths, patches of single vertices
    V, F, E = mesh("irregular")
    for idx in (np.arange(len(V)), np.arange(0, len(V), 2)):
        for method in METHODS:
            G = mesh_graph(V, F, distance="length")
            part = partition(Surface.from_mesh(V, F), idx, graph=G, method=method)
            assert_partition(V, F, E, idx, G, part)


def test_unknown_method_raises():
    V, F, _ = mesh("icosphere2")
    with pytest.raises(OptionError):
        partition(Surface.from_mesh(V, F), np.array([0, 1]), graph=mesh_graph(V, F, distance="hops"), method="voronoi")


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", sorted(MESHES))
def test_steepest_curve_bounds_the_hop_lipschitz_constant_from_below(name, method):
    from scipy.sparse import csgraph

    V, F, _ = mesh(name)
    rng = np.random.default_rng(len(name))
    idx = np.sort(rng.choice(len(V), 12, replace=False))
    X = np.column_stack([V[idx, 0], rng.uniform(-1, 1, 12), np.full(12, 2.0)])
    part = partition(Surface.from_mesh(V, F), idx, graph=mesh_graph(V, F, distance="length"), method=method)
    starts = part.steepest(idx, X)
    D = csgraph.shortest_path(mesh_graph(V, F, distance="hops"), unweighted=True, indices=idx)[:, idx]
    for j, (K0, (a, b)) in enumerate(starts):
        # the ratio of a pair of samples over the hop length of a curve joining them ...
        c = [i for i, e in enumerate(part.ends) if {int(e[0]), int(e[1])} == {int(idx[a]), int(idx[b])}]
        assert c and K0 == pytest.approx(abs(X[a, j] - X[b, j]) / max(len(part.curves[c[0]]) - 1, 1), rel=1e-12)
        # ... at most the true Lipschitz constant in hops, and the steepest such ratio
        off = ~np.eye(12, dtype=bool)
        K = (np.abs(X[:, None, j] - X[None, :, j])[off] / D[off]).max()
        assert K0 <= K * (1 + 1e-12)
        hops = np.array([len(cv) - 1 for cv in part.curves])
        pos = np.searchsorted(idx, part.ends)
        ratios = np.abs(X[pos[:, 0], j] - X[pos[:, 1], j])[hops > 0] / hops[hops > 0]
        assert K0 == ratios.max()
    assert starts[2][0] == 0.0  # a constant field


def test_steepest_without_curves():
    V, F, _ = mesh("grid")
    part = partition(Surface.from_mesh(V, F), np.array([3]), graph=mesh_graph(V, F, distance="hops"), method="delaunay")
    assert part.curves == [] and part.steepest(np.array([3]), np.ones((1, 2))) == [None, None]


# ---------------------------------------------------------------------------
# the paths of all curves traced at once equal the paths traced one at a time
# ---------------------------------------------------------------------------


def slow_partition(V, F, idx, G, method):
    """Curves, ends and patch labels one path at a time, in plain Python, from the same Voronoi pairs."""
    from scipy.sparse import csgraph, csr_array

    from manifill.mesh.graph import voronoi_pairs

    vor = voronoi_pairs(G, idx)

    def walk(x):
        path = [int(x)]
        while vor.pred[path[-1]] >= 0:
            path.append(int(vor.pred[path[-1]]))
        return path

    rows = list(range(len(vor.p)))
    if method == "tree" and rows:
        k = len(idx)
        T = csgraph.minimum_spanning_tree(csr_array((vor.length, (vor.p, vor.q)), shape=(k, k))).tocoo()
        tree = {(min(a, b), max(a, b)) for a, b in zip(T.row.tolist(), T.col.tolist())}
        rows = [j for j in rows if (int(vor.p[j]), int(vor.q[j])) in tree]
    curves = [walk(vor.edge[j][0])[::-1] + ([int(vor.via[j])] if vor.via[j] >= 0 else []) + walk(vor.edge[j][1])
              for j in rows]
    ends = [(int(idx[vor.p[j]]), int(idx[vor.q[j]])) for j in rows]
    on = np.zeros(len(V), dtype=bool)
    on[idx] = True
    for c in curves:
        on[c] = True
    lab, count = flood(neighbours(edge_set(F), len(V)), ~on)  # numbered by first vertex
    sizes = np.bincount(lab[lab >= 0], minlength=count)
    rank = np.empty(count, dtype=np.int64)
    rank[np.argsort(-sizes, kind="stable")] = np.arange(count)
    labels = np.where(lab >= 0, rank[np.maximum(lab, 0)], -1) if count else np.full(len(V), -1)  # all on curves
    return curves, ends, on, labels


@hsettings
@given(name=st.sampled_from(sorted(MESHES) + ["two_components"]), method=st.sampled_from(["delaunay", "tree"]),
       distance=st.sampled_from(["hops", "length"]), seed=st.integers(0, 10**6), k=st.integers(1, 40))
def test_all_paths_at_once_equal_one_path_at_a_time(name, method, distance, seed, k):
    V, F, _ = mesh(name)
    idx = np.sort(np.random.default_rng(seed).choice(len(V), size=min(k, len(V)), replace=False))
    G = mesh_graph(V, F, distance=distance)
    part = partition(Surface.from_mesh(V, F), idx, graph=G, method=method)
    curves, ends, on, labels = slow_partition(V, F, idx, G, method)
    assert [c.tolist() for c in part.curves] == curves
    assert part.ends.tolist() == [list(e) for e in ends]
    np.testing.assert_array_equal(part.on_curve, on)
    np.testing.assert_array_equal(part.labels, labels)
