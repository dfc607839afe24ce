"""The Surface of Steps 1-6 (manifill.surface.surface): a mesh's pieces, built once, cached."""

import numpy as np
import pytest
import scipy.sparse as sp

from conftest import grid, icosphere, irregular, torus, two_components
from manifill import MeshError, OptionError
from manifill.mesh.graph import mesh_graph
from manifill.mesh.laplacian import WEIGHTS, assemble_laplacian
from manifill.surface.surface import Surface
from manifill.validate import as_mesh

MESHES = {"icosphere": lambda: icosphere(2), "irregular": irregular, "torus": torus,
          "two components": two_components}


def same_sparse(A, B):
    """Bit for bit: shape, pattern and stored values, after putting both in canonical CSR form."""
    A, B = sp.csr_array(A), sp.csr_array(B)
    A.sum_duplicates()
    B.sum_duplicates()
    return (A.shape == B.shape and A.dtype == B.dtype and np.array_equal(A.indptr, B.indptr)
            and np.array_equal(A.indices, B.indices) and A.data.tobytes() == B.data.tobytes())


@pytest.mark.parametrize("distance", ["length", "hops"])
@pytest.mark.parametrize("mesh", sorted(MESHES))
def test_from_mesh_equals_the_pieces_built_by_hand(mesh, distance):
    V0, F0 = MESHES[mesh]()
    s = Surface.from_mesh(V0.tolist(), F0.astype(np.int32), distance=distance)
    V, F = as_mesh(V0, F0)
    assert s.V.tobytes() == V.tobytes() and s.F.dtype == np.int64 and np.array_equal(s.F, F)
    assert s.n == len(V) and s.normals is None
    assert same_sparse(s.G_hops, mesh_graph(V, F, distance="hops"))
    assert same_sparse(s.G, mesh_graph(V, F, distance=distance))
    assert (s.G is s.G_hops) == (distance == "hops")
    for w in ("uniform", "cotan", "intrinsic"):
        assert same_sparse(s.laplacian(w), assemble_laplacian(V, F, w))


def test_the_graphs_measure_hops_and_lengths():
    V, F = irregular()
    s = Surface.from_mesh(V, F)
    G = sp.coo_array(s.G)
    np.testing.assert_array_equal(sp.coo_array(s.G_hops).data, 1.0)
    # length graph: proportional to the Euclidean edge lengths (in units of the mean edge length)
    ratio = G.data / np.linalg.norm(V[G.row] - V[G.col], axis=1)
    np.testing.assert_allclose(ratio, ratio[0], rtol=2e-9)  # rounded to 2**-30 of the mean (graph_length_quantum)
    # the Laplacian annihilates constants, and is symmetric
    L = s.laplacian("cotan")
    np.testing.assert_allclose(L @ np.ones(len(V)), 0, atol=1e-12)
    assert abs(L - L.T).max() < 1e-14


@pytest.mark.parametrize("weights", WEIGHTS)
def test_laplacian_cache_returns_the_same_object(weights):
    s = Surface.from_mesh(*icosphere(1))
    L = s.laplacian(weights)
    assert s.laplacian(weights) is L
    other = "uniform" if weights != "uniform" else "cotan"
    assert s.laplacian(other) is not L


def test_any_laplacian_callable_is_built_once_per_weight():
    # a digital surface passes its own graph Laplacian: the Surface caches it as well
    V, F = grid(3)
    G = mesh_graph(V, F, distance="hops")
    calls = []

    def build(w):
        calls.append(w)
        return sp.csr_array(sp.diags_array(np.asarray(G.sum(axis=1)).ravel()) - G)

    s = Surface(V, G, G, build, normals=np.tile([0.0, 0.0, 1.0], (len(V), 1)))
    assert s.F is None
    first = s.laplacian("uniform")
    assert s.laplacian("uniform") is first and calls == ["uniform"]
    s.laplacian("cotan")
    assert calls == ["uniform", "cotan"]
    # wrapping an already-wrapped Surface's cache keeps it
    assert Surface(V, G, G, s.laplacian).laplacian("uniform") is first


def test_check_false_gives_the_same_surface_for_validated_arrays():
    V, F = as_mesh(*torus())
    a, b = Surface.from_mesh(V, F), Surface.from_mesh(V, F, check=False)
    assert same_sparse(a.G, b.G) and same_sparse(a.laplacian("cotan"), b.laplacian("cotan"))


def test_from_mesh_refuses_bad_meshes_and_options():
    V, F = grid(3)
    with pytest.raises(OptionError, match="distance"):
        Surface.from_mesh(V, F, distance="geodesic")
    with pytest.raises(MeshError):
        Surface.from_mesh(V, F + len(V))
    degenerate = np.vstack([F, [[0, 1, 2]]])  # 0, 1, 2 lie on a line
    Vd = V.copy()
    Vd[1] = (Vd[0] + Vd[2]) / 2
    with pytest.raises(MeshError):
        Surface.from_mesh(Vd, degenerate)
    Surface.from_mesh(Vd, degenerate, allow_degenerate=True)
