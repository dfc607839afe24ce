"""The Domain on its own (vertices no face uses, samples at positions, barriers), and the Method's decisions it and
the Reconstructor ask for (``linearity``, ``barrier_model``)."""

import numpy as np
import pytest

from manifill.errors import OptionError
from manifill.mesh.shapes import grid
from manifill.surface.domain import Domain
from manifill.surface.engine import reconstruct_surface
from manifill.surface.methods.base import Method
from manifill.surface.methods.registry import configure, method_of
from manifill.surface.surface import Surface

N = 11
V, F = grid(N)
WALL = np.flatnonzero(np.isclose(V[:, 0], 0.5))
PATH = [WALL[np.argsort(V[WALL, 1])]]
OFF = np.flatnonzero(~np.isclose(V[:, 0], 0.5))
IDX = OFF[::7]


def domain(V, F, idx, **options):
    o = configure(**options)
    return Domain(V, F, idx, o, method_of(o.method))


def test_a_vertex_no_face_uses_is_left_out_and_nan_in_the_expanded_result():
    V1, F1 = np.vstack([[[7.0, 7.0, 0.0]], V]), F + 1  # vertex 0 first: every other index shifts by one
    d = domain(V1, F1, IDX + 1, method="harmonic")
    assert d.n == len(V1) and len(d.V) == len(V) and d.compact.dropped == 1
    assert np.array_equal(d.raw, IDX) and d.mesh()[0] is d.compact.V_full
    vals = V[IDX, 1] + 2.0
    idx, v, points, squeeze, given = d.place(vals, "error")
    assert points is None and squeeze and given.shape == (IDX.size, 1)
    r = d.expand(reconstruct_surface(Surface.from_mesh(d.V, d.F), idx, v, method="harmonic"))
    plain = reconstruct_surface(Surface.from_mesh(V, F), IDX, vals[:, None], method="harmonic")
    assert r.values.shape == (len(V1), 1) and np.isnan(r.values[0, 0])
    np.testing.assert_allclose(r.values[1:], plain.values, atol=1e-12)
    assert r.report["mesh"]["unreferenced_vertices"] == 1 and r.V is V1


def test_samples_at_positions_are_located_once_on_their_faces():
    faces = np.array([3, 40, 117, 150])
    P = V[F[faces]].mean(axis=1)  # the faces' centroids: inside, at no vertex
    d = domain(V, F, P, method="harmonic")
    assert d.samples == 4 and np.array_equal(d.located.faces, faces) and np.all(d.located.vertex == -1)
    idx, v, points, squeeze, _ = d.place(np.arange(4.0), "error")
    assert points is not None and squeeze
    near = d.located.nearest_vertex
    assert np.all((F[faces] == near[:, None]).any(axis=1)) and np.array_equal(points.nearest, np.unique(near))
    with pytest.raises(OptionError, match="max_distance applies to samples given as positions"):
        domain(V, F, IDX, method="harmonic", max_distance=0.1)


def test_a_sample_on_a_barrier_gets_a_copy_on_each_side():
    v = WALL[N // 2]
    idx = np.r_[IDX, v]
    d = domain(V, F, idx, method="harmonic", barriers=PATH)
    assert d.cut is not None and d.barrier_faces is None and len(d.V) > len(V) and d.n == len(V)
    copies, rows = d.copies
    assert copies.size == idx.size + 1 and np.array_equal(np.sort(d.cut.orig[copies]), np.sort(np.r_[idx, v]))
    vals = np.r_[np.zeros(IDX.size), 5.0]
    at, v2, _, _, _ = d.place(vals, "error")
    on_wall = d.cut.orig[at] == v
    assert on_wall.sum() == 2 and np.all(v2[on_wall] == 5.0) and np.all(v2[~on_wall] == 0.0)
    w = d.sample_weights(np.arange(1.0, idx.size + 1))  # one per copy: the wall sample's weight on both sides
    assert w.size == idx.size + 1 and np.all(w[on_wall] == idx.size)


def test_sample_weights_of_rows_on_one_vertex_add_up():
    d = domain(V, F, [5, 3, 5], method="harmonic")
    np.testing.assert_array_equal(d.sample_weights(np.array([1.0, 2.0, 4.0])), [2.0, 5.0])
    assert d.sample_weights(None) is None


def test_bakka_keeps_the_mesh_whole_and_marks_the_faces_along_the_barrier():
    d = domain(V, F, IDX, method="gp", barriers=PATH, gp={"barrier": "bakka"})
    assert d.cut is None and len(d.V) == len(V) and d.barrier_faces.shape == (len(F),)
    assert np.array_equal(d.barrier_faces, np.isin(F, WALL).any(axis=1))


def test_barriers_on_a_point_cloud_are_refused():
    with pytest.raises(OptionError, match="point cloud has none"):
        domain(V, None, IDX, method="harmonic", barriers=PATH)


@pytest.mark.parametrize("name, options, linear, why", [
    ("harmonic", {}, True, None),
    ("harmonic", {"bounds": "samples", "bounds_mode": "exact"}, False, "bounds make an active set"),
    ("harmonic", {"bounds": "samples", "bounds_mode": "project"}, False, "bounds_mode='project' clips"),
    ("harmonic", {"trust": 2.0, "untrusted": "nan"}, False, "trust with untrusted='nan'"),
    ("harmonic", {"trust": 2.0}, True, None),  # the std marks, it does not blank
    ("rbf", {"smoothing": "auto"}, False, "smoothing='auto' picks lambda"),
    ("gp", {}, False, "hyperparameters are fitted"),
    ("gp", {"gp": {"range": 0.5, "sigma": 1.0, "noise": 0.0}}, True, None),
])
def test_linearity_puts_the_shared_options_before_the_method_s_own(name, options, linear, why):
    o = configure(method=name, **options)
    got, said = method_of(name).linearity(o)
    assert got is linear and (why is None or why in said)


def test_the_barrier_model_is_the_method_s_to_take():
    assert Method.barrier_models == ("cut",) and method_of("gp").barrier_models == ("cut", "bakka")
    bakka = configure(method="gp", barriers=PATH, gp={"barrier": "bakka"})
    assert method_of("gp").barrier_model(bakka) == "bakka"
    assert method_of("gp").barrier_model(configure(method="gp", barriers=PATH)) == "cut"
    assert method_of("harmonic").barrier_model(configure(method="harmonic")) == "cut"
    message = "gp barrier='bakka' is the gp's model of barriers=: give barriers= and method='gp', or leave it out"
    with pytest.raises(OptionError) as e:
        method_of("harmonic").barrier_model(bakka)  # a method without Bakka's model
    assert str(e.value) == message
    with pytest.raises(OptionError) as e:
        method_of("gp").barrier_model(configure(method="gp", gp={"barrier": "bakka"}))  # no barriers to model
    assert str(e.value) == message
    with pytest.raises(OptionError, match="give barriers="):
        domain(V, F, IDX, method="gp", gp={"barrier": "bakka"})
