"""Shortest paths on the mesh graph: all-at-once path tracing and the Voronoi pairs, against slow references.

The references are written here one path, one edge at a time in plain Python.
"""

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import grid, icosphere, torus, two_components
from manifill.mesh.graph import mesh_graph, offset_distances, trace, trace_paths, voronoi_pairs

hsettings = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                     suppress_health_check=[HealthCheck.too_slow])


def walk(pred, x):
    """The predecessor chain from x to its source, one step at a time."""
    path = [int(x)]
    while pred[path[-1]] >= 0:
        path.append(int(pred[path[-1]]))
    return path


def random_forest(rng, n):
    """Predecessors of a random forest: every vertex points to an earlier one, or starts a path (-9999)."""
    order = rng.permutation(n)
    pred = np.full(n, -9999, dtype=np.int64)
    for i in range(1, n):
        if rng.random() < 0.8:
            pred[order[i]] = order[rng.integers(0, i)]
    return pred


@hsettings
@given(seed=st.integers(0, 10**6), n=st.integers(1, 60), e=st.integers(0, 40))
def test_trace_paths_is_every_trace_one_after_another(seed, n, e):
    rng = np.random.default_rng(seed)
    pred = random_forest(rng, n)
    x = rng.integers(0, n, size=e)
    flat, lens = trace_paths(pred, x)
    ref = [walk(pred, v) for v in x]
    assert lens.dtype == flat.dtype == np.int64
    assert lens.tolist() == [len(p) for p in ref]
    assert flat.tolist() == [v for p in ref for v in p]


def test_trace_paths_on_a_dijkstra_forest_agrees_with_trace():
    V, F = icosphere(3)
    G = mesh_graph(V, F)
    rng = np.random.default_rng(3)
    _, _, pred = offset_distances(G, rng.choice(len(V), 7, replace=False), rng.random(7))
    x = rng.integers(0, len(V), 200)
    flat, lens = trace_paths(pred, x)
    pieces = np.split(flat, np.cumsum(lens)[:-1])
    assert all(np.array_equal(p, trace(pred, v)) for p, v in zip(pieces, x))


def slow_voronoi(G, sources):
    """Per pair of touching cells, the crossing edge of least length (the first in the graph's order among equals)."""
    dist, root, _ = offset_distances(G, sources, np.zeros(len(sources)))
    best = {}
    for u in range(G.shape[0]):
        for at in range(G.indptr[u], G.indptr[u + 1]):
            v = int(G.indices[at])
            a, b = int(root[u]), int(root[v])
            if a < 0 or b < 0 or a >= b:
                continue
            length = dist[u] + G.data[at] + dist[v]
            if (a, b) not in best or length < best[(a, b)][0]:
                best[(a, b)] = (length, u, v, -1)
    # then through a vertex x of a third cell as near to two others (its first neighbour in each): p .. a, x, b .. q
    for x in range(G.shape[0]):
        near = {}
        for at in range(G.indptr[x], G.indptr[x + 1]):
            a = int(G.indices[at])
            if root[a] >= 0 and root[a] != root[x] and dist[a] + G[a, x] == dist[x]:
                near[int(root[a])] = min(near.get(int(root[a]), a), a)
        for p in sorted(near):
            for q in sorted(near):
                if p < q and ((p, q) not in best or 2 * dist[x] < best[(p, q)][0]):
                    best[(p, q)] = (2 * dist[x], near[p], near[q], x)
    keys = sorted(best)
    return keys, [best[k] for k in keys]


MESHES = {"sphere": lambda: icosphere(2), "grid": lambda: grid(9), "torus": torus, "two": two_components}


@hsettings
@given(name=st.sampled_from(sorted(MESHES)), distance=st.sampled_from(["hops", "length"]),
       seed=st.integers(0, 10**6), k=st.integers(1, 25))
def test_voronoi_pairs_match_the_pairs_edge_by_edge(name, distance, seed, k):
    V, F = MESHES[name]()
    G = mesh_graph(V, F, distance=distance)
    sources = np.sort(np.random.default_rng(seed).choice(len(V), size=min(k, len(V)), replace=False))
    vor = voronoi_pairs(G, sources)
    keys, rows = slow_voronoi(G, sources)
    assert list(zip(vor.p.tolist(), vor.q.tolist())) == keys
    assert vor.length.tolist() == [r[0] for r in rows]
    assert vor.edge.tolist() == [[r[1], r[2]] for r in rows]
    assert vor.via.tolist() == [r[3] for r in rows]
