"""The result family (manifill.results): one set of mask names, point data built the same way for every result."""

import numpy as np
import pytest

import manifill.io.field_names as io_names
from conftest import icosphere
from manifill import SampleError
from manifill.results import (BOUNDARY_MASK, CURVE_MASK, PATCH_LABEL, RESERVED_NAMES, SAMPLE_MASK, TRUSTED, Result,
                              field_names)
from manifill.surface.reconstruct import Reconstruction, reconstruct


def test_mask_names_are_one_set_shared_with_the_file_formats():
    assert (SAMPLE_MASK, CURVE_MASK, PATCH_LABEL, BOUNDARY_MASK) == ("sample_mask", "curve_mask", "patch_label",
                                                                     "boundary_mask")
    assert RESERVED_NAMES == (SAMPLE_MASK, CURVE_MASK, PATCH_LABEL, BOUNDARY_MASK, TRUSTED)
    assert io_names.RESERVED_NAMES is RESERVED_NAMES and io_names.SAMPLE_MASK is SAMPLE_MASK


def test_field_names():
    assert field_names(None, 1) == ["value"] and field_names(None, 3) == ["value", "value2", "value3"]
    assert field_names(("a", 2), 2) == ["a", "2"]
    with pytest.raises(SampleError, match="2 field names for 3"):
        field_names(["a", "b"], 3)
    with pytest.raises(SampleError, match="repeats"):
        field_names(["a", "a"], 2)


class Grid(Result):
    """A minimal result on a 2 x 3 x 4 voxel grid: values with three point axes."""

    point_ndim = 3

    def __init__(self, values):
        self.values, self.report = values, {}

    def masks(self):
        return {BOUNDARY_MASK: np.ones((2, 3, 4), dtype=bool)}

    def to_pyvista(self, names=None):
        return self.point_data(names)

    def to_meshio(self, names=None):
        return self.point_data(names)


def test_point_data_splits_the_field_axis_and_appends_the_masks():
    X = np.arange(48.0).reshape(2, 3, 4, 2)
    data = Grid(X).point_data(["u", "v"])
    assert list(data) == ["u", "v", BOUNDARY_MASK]
    assert data["u"].tobytes() == X[..., 0].tobytes() and data["v"].tobytes() == X[..., 1].tobytes()
    one = Grid(X[..., 0])
    assert one.fields().shape == (2, 3, 4, 1) and list(one.point_data()) == ["value", BOUNDARY_MASK]
    # the base only states the interface: a result without masks or conversions cannot be made
    with pytest.raises(TypeError):
        Result()

    class NoConversions(Result):
        def masks(self):
            return {}

    with pytest.raises(TypeError, match="to_meshio|to_pyvista"):
        NoConversions()


@pytest.mark.parametrize("columns", [1, 2])
def test_a_reconstruction_is_a_result_with_its_masks(columns):
    V, F = icosphere(2)
    idx = np.array([0, 10, 50, 90, 120])
    vals = np.column_stack([V[idx, 0], V[idx, 1]])[:, :columns]
    r = reconstruct(V, F, idx, vals[:, 0] if columns == 1 else vals, method="gvf-harmonic")
    assert isinstance(r, Result) and isinstance(r, Reconstruction)
    data = r.point_data()
    assert list(data) == field_names(None, columns) + [SAMPLE_MASK, CURVE_MASK, PATCH_LABEL]
    assert np.flatnonzero(data[SAMPLE_MASK]).tolist() == idx.tolist()
    assert data[CURVE_MASK] is r.on_curve and data[PATCH_LABEL] is r.components
    X = r.values.reshape(len(V), -1)
    for j, name in enumerate(field_names(None, columns)):
        assert data[name].tobytes() == X[:, j].tobytes()
    # every patch label is -1 exactly on the curves
    assert ((r.components == -1) == r.on_curve).all()


def test_the_repr_is_short_and_names_what_ran():
    V, F = icosphere(3)
    idx = np.arange(0, 600, 40)
    X = np.random.default_rng(0).normal(size=(idx.size, 200))
    r = reconstruct(V, F, idx, X, method="biharmonic")
    text = repr(r)
    assert len(text) < 800 and text.count("\n") <= 10  # not every array (57 KB before)
    assert "biharmonic" in text and f"{len(V):,} vertices" in text and "200 fields" in text
    assert "... and 194 more" in text
    lo, hi = X[:, 0].min(), r.values[:, 0].max()
    assert f"{r.values[:, 0].min():.4g}" in text and f"{hi:.4g}" in text and lo >= r.values[:, 0].min()
    one = repr(reconstruct(V, F, idx, X[:, 0]))
    assert "default (biharmonic)" in one and "1 field\n" in one


def test_names_are_an_attribute_and_name_every_output(tmp_path):
    import meshio

    V, F = icosphere(2)
    idx = np.arange(0, 162, 20)
    r = reconstruct(V, F, idx, np.column_stack([V[idx, 0], V[idx, 1]]), method="harmonic")
    assert r.field_names == ["value", "value2"]
    r.names = ["t", "p"]
    assert list(r.point_data())[:2] == ["t", "p"] and r.field_names == ["t", "p"]
    m = meshio.read(r.save(tmp_path / "o.vtu"))
    np.testing.assert_array_equal(m.point_data["p"], r.values[:, 1])
    assert m.point_data["sample_mask"].dtype == np.uint8  # masks as 0/1 bytes, as documented
    assert "curve_mask" not in m.point_data  # no partition ran: no curves, no patches
    table = np.genfromtxt(r.save(tmp_path / "o.csv"), delimiter=",", names=True)
    assert table.dtype.names == ("vertex", "t", "p")  # as the CLI writes values
    np.testing.assert_allclose(table["t"], r.values[:, 0])


def test_at_interpolates_linearly_on_the_triangles_and_refuses_far_points():
    V, F = icosphere(3)
    idx = np.arange(0, 642, 7)
    r = reconstruct(V, F, idx, np.column_stack([V[idx, 0], 2 * V[idx, 2]]), method="gp")
    np.testing.assert_allclose(r.at(V[:20]), r.values[:20], atol=1e-12)  # at the vertices: their values
    f = F[5]
    w = np.array([0.2, 0.3, 0.5])
    p = w @ V[f]
    vals, std = r.at(p[None], return_std=True)
    np.testing.assert_allclose(vals[0], w @ r.values[f], atol=1e-10)
    np.testing.assert_allclose(std[0], w @ r.std[f], atol=1e-10)
    with pytest.raises(SampleError):
        r.at([[10.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match="no std"):
        reconstruct(V, F, idx, V[idx, 0]).at(V[:1], return_std=True)


def test_to_pyvista_and_to_meshio_keep_the_input_meshs_own_arrays():
    # the normals (and every array) of a PolyData given as the mesh were lost on the way out
    pv = pytest.importorskip("pyvista")
    import meshio

    m = pv.Sphere(theta_resolution=20, phi_resolution=20).compute_normals()
    m.point_data["thickness"] = np.arange(m.n_points, dtype=float)
    m.cell_data["region"] = np.arange(m.n_cells)
    r = reconstruct(m, None, [0, 50, 150, 300], [1.0, 2.0, 0.5, 3.0], method="harmonic")
    out = r.to_pyvista(["t"])
    np.testing.assert_array_equal(out.point_data["thickness"], m.point_data["thickness"])
    np.testing.assert_array_equal(out.point_data["Normals"], m.point_data["Normals"])
    np.testing.assert_array_equal(out.cell_data["region"], m.cell_data["region"])
    assert list(out.point_data.keys())[:2] == ["t", "sample_mask"]  # ours first; a clash keeps ours
    mm = meshio.Mesh(np.asarray(m.points), [("triangle", m.regular_faces)], point_data={"t": np.zeros(m.n_points),
                                                                                         "own": np.ones(m.n_points)})
    got = reconstruct(mm, None, [0, 50, 150, 300], [1.0, 2.0, 0.5, 3.0], method="harmonic").to_meshio(["t"])
    assert np.array_equal(got.point_data["own"], np.ones(m.n_points)) and got.point_data["t"][50] == 2.0
