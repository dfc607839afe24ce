"""Sample files (CSV, NPZ, NPY), snapping positions to vertices, and every way a sample file can be wrong."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from manifill.errors import ReadError, SampleError
from manifill.io import read_samples
from manifill.surface.samples import Samples, snap_to_vertices
from manifill.mesh.shapes import grid


def mesh():
    """5 x 5 vertices on the unit square: spacing 0.25, diagonal sqrt(2)."""
    return grid(5)


def write(tmp_path, text, name="s.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def one_line(exc_info):
    msg = str(exc_info.value)
    assert "\n" not in msg
    return msg


# ----------------------------------------------------------------------------- good files


def test_csv_with_vertex_header(tmp_path):
    V, _ = mesh()
    S = read_samples(write(tmp_path, "vertex,temp\n3,1.5\n0,-2\n24,7e3\n"), V)
    assert isinstance(S, Samples)
    assert S.idx.dtype == np.int64 and S.idx.tolist() == [0, 3, 24]  # sorted
    assert S.vals.dtype == np.float64 and S.vals.shape == (3, 1)
    assert S.vals[:, 0].tolist() == [-2.0, 1.5, 7000.0]
    assert S.names == ["temp"]
    assert S.snap_distance is None and S.merged == 0


@pytest.mark.parametrize("column", ["vertex", "idx", "index", "vertex_id", "id", "Vertex", " VERTEX "])
def test_vertex_column_names(tmp_path, column):
    V, _ = mesh()
    S = read_samples(write(tmp_path, f"{column},value\n7,1\n"), V)
    assert S.idx.tolist() == [7] and S.names == ["value"]


def test_csv_with_xyz_header_snaps_positions(tmp_path):
    V, _ = mesh()
    idx = np.array([0, 6, 12, 24])
    offset = np.array([[0.01, 0.02, 0.0], [-0.05, 0.0, 0.03], [0.0, 0.0, -0.1], [0.0, -0.06, 0.08]])
    P = V[idx] + offset
    rows = "\n".join(f"{p[0]:.17g},{p[1]:.17g},{p[2]:.17g},{v}" for p, v in zip(P, [1.0, 2.0, 3.0, 4.0]))
    S = read_samples(write(tmp_path, "x,y,z,height\n" + rows + "\n"), V)
    assert S.idx.tolist() == idx.tolist()
    assert S.vals[:, 0].tolist() == [1.0, 2.0, 3.0, 4.0]
    assert S.names == ["height"]
    np.testing.assert_allclose(S.snap_distance, np.linalg.norm(offset, axis=1), rtol=1e-12)
    assert S.merged == 0


def test_extra_value_columns_keep_their_names(tmp_path):
    V, _ = mesh()
    S = read_samples(write(tmp_path, "x,y,z, temp ,pressure,Salinity\n0,0,0,1,2,3\n1,1,0,4,5,6\n"), V)
    assert S.names == ["temp", "pressure", "Salinity"]
    assert S.idx.tolist() == [0, 24]
    np.testing.assert_array_equal(S.vals, [[1, 2, 3], [4, 5, 6]])
    S = read_samples(write(tmp_path, "vertex,a,b\n2,1,-1\n1,0,5\n"), V)
    assert S.names == ["a", "b"] and S.idx.tolist() == [1, 2]
    np.testing.assert_array_equal(S.vals, [[0, 5], [1, -1]])


def test_csv_tolerates_bom_blank_lines_and_spaces(tmp_path):
    V, _ = mesh()
    path = tmp_path / "s.csv"
    path.write_bytes("\ufeffvertex, value\n\n 4 , 2.5\n\n".encode("utf-8"))
    S = read_samples(path, V)
    assert S.idx.tolist() == [4] and S.vals.tolist() == [[2.5]] and S.names == ["value"]


def test_npz_with_indices(tmp_path):
    V, _ = mesh()
    np.savez(tmp_path / "s.npz", idx=np.array([5, 1], dtype=np.int32), vals=np.array([1.0, 2.0]))
    S = read_samples(tmp_path / "s.npz", V)
    assert S.idx.tolist() == [1, 5] and S.vals[:, 0].tolist() == [2.0, 1.0]
    assert S.names == ["value"] and S.snap_distance is None


def test_npz_with_indices_and_names(tmp_path):
    V, _ = mesh()
    vals = np.array([[1.0, 10.0], [2.0, 20.0], [3.0, 30.0]])
    np.savez(tmp_path / "s.npz", idx=np.array([9, 3, 0]), vals=vals, names=np.array(["u", "w"]))
    S = read_samples(tmp_path / "s.npz", V)
    assert S.idx.tolist() == [0, 3, 9] and S.names == ["u", "w"]
    np.testing.assert_array_equal(S.vals, vals[[2, 1, 0]])


def test_npz_with_points(tmp_path):
    V, _ = mesh()
    P = V[[24, 2]] + [[0.0, 0.0, 0.05], [0.03, 0.04, 0.0]]
    np.savez(tmp_path / "s.npz", points=P, vals=np.array([[1.0, 2.0], [3.0, 4.0]]), names=np.array(["a", "b"]))
    S = read_samples(tmp_path / "s.npz", V)
    assert S.idx.tolist() == [2, 24] and S.names == ["a", "b"]
    np.testing.assert_array_equal(S.vals, [[3.0, 4.0], [1.0, 2.0]])
    np.testing.assert_allclose(S.snap_distance, [0.05, 0.05], rtol=1e-12)


def test_structured_npy(tmp_path):
    V, _ = mesh()
    a = np.array([(8, 1.0, -1.0), (2, 3.0, -3.0)], dtype=[("vertex", "i4"), ("t", "f8"), ("s", "f4")])
    np.save(tmp_path / "s.npy", a)
    S = read_samples(tmp_path / "s.npy", V)
    assert S.idx.tolist() == [2, 8] and S.names == ["t", "s"]
    np.testing.assert_array_equal(S.vals, [[3.0, -3.0], [1.0, -1.0]])

    b = np.array([(1.0, 0.0, 0.02, 5.0)], dtype=[("x", "f8"), ("y", "f8"), ("z", "f8"), ("h", "f8")])
    np.save(tmp_path / "p.npy", b)
    S = read_samples(tmp_path / "p.npy", V)
    assert S.idx.tolist() == [4] and S.names == ["h"] and S.vals.tolist() == [[5.0]]
    np.testing.assert_allclose(S.snap_distance, [0.02])


def test_plain_npy_names_the_fix(tmp_path):
    V, _ = mesh()
    np.save(tmp_path / "s.npy", np.array([[0.0, 1.0], [3.0, 2.0]]))
    with pytest.raises(ReadError) as info:
        read_samples(tmp_path / "s.npy", V)
    msg = one_line(info)
    assert "structured" in msg and ".npz" in msg and "vertex" in msg


@pytest.mark.parametrize("name", ["s.txt", "s.ply", "s"])
def test_unknown_sample_extension(tmp_path, name):
    V, _ = mesh()
    with pytest.raises(ReadError, match="cannot read"):
        read_samples(write(tmp_path, "vertex,value\n0,1\n", name), V)


def test_missing_sample_file(tmp_path):
    V, _ = mesh()
    with pytest.raises(ReadError, match="no such file"):
        read_samples(tmp_path / "missing.csv", V)


# ----------------------------------------------------------------------------- bad CSV


@pytest.mark.parametrize("text, error, words", [
    ("", ReadError, ["empty file"]),
    ("\n\n", ReadError, ["empty file"]),
    ("vertex,value\n", ReadError, ["no samples"]),
    ("a,b\n0,1\n", ReadError, ["'a,b'", "vertex,value", "x,y,z,value"]),
    ("vertex\n0\n", ReadError, ["'vertex'", "vertex,value"]),  # no value column
    ("x,y,value\n0,0,1\n", ReadError, ["x,y,z,value"]),
    ("vertex,temp\n0,1\n1,warm\n", ReadError, ["line 3", "'temp'", "'warm'"]),
    ("x,y,z,temp\n0,0,0,1\n0,abc,0,1\n", ReadError, ["line 3", "'y'", "'abc'"]),
    ("vertex,temp\n0,1\n1,2,3\n", ReadError, ["line 3", "3 fields", "header 2"]),
    ("vertex,temp\n0\n", ReadError, ["line 2", "1 fields"]),
    ("vertex,temp\n0,1\n1,2\n2,nan\n", SampleError, ["lines 4", "NaN"]),
    ("vertex,temp\n0,inf\n1,1\n2,-inf\n", SampleError, ["lines 2, 4"]),
    ("x,y,z,temp\n0,0,nan,1\n", SampleError, ["lines 2"]),
])
def test_bad_csv(tmp_path, text, error, words):
    V, _ = mesh()
    with pytest.raises(error) as info:
        read_samples(write(tmp_path, text), V)
    msg = one_line(info)
    assert msg.startswith("s.csv: ")
    for w in words:
        assert w in msg


def test_bad_cell_line_counts_blank_lines(tmp_path):
    V, _ = mesh()
    with pytest.raises(ReadError, match="line 5"):
        read_samples(write(tmp_path, "vertex,temp\n\n0,1\n\n1,warm\n"), V)


@pytest.mark.parametrize("bad", [-1, 25, 1000])
def test_vertex_index_out_of_range(tmp_path, bad):
    V, _ = mesh()
    with pytest.raises(SampleError) as info:
        read_samples(write(tmp_path, f"vertex,v\n0,1\n{bad},2\n"), V)
    msg = one_line(info)
    assert str(bad) in msg and "0..24" in msg


def test_last_vertex_is_in_range(tmp_path):
    V, _ = mesh()
    assert read_samples(write(tmp_path, "vertex,v\n24,1\n0,2\n"), V).idx.tolist() == [0, 24]


@pytest.mark.parametrize("bad", ["1.5", "0.999"])
def test_non_integer_vertex_index(tmp_path, bad):
    V, _ = mesh()
    with pytest.raises(ReadError) as info:
        read_samples(write(tmp_path, f"vertex,v\n0,1\n{bad},2\n"), V)
    msg = one_line(info)
    assert "not an integer" in msg and "row 2" in msg


def test_integral_float_index_is_accepted(tmp_path):
    V, _ = mesh()
    assert read_samples(write(tmp_path, "vertex,v\n3.0,1\n1e1,2\n"), V).idx.tolist() == [3, 10]


@pytest.mark.parametrize("arrays_, error", [
    (dict(vals=np.ones(2)), ReadError),  # no idx or points
    (dict(idx=np.arange(2)), ReadError),  # no vals
    (dict(points=np.zeros((2, 2, 2)), vals=np.ones(2)), ReadError),
    (dict(points=np.zeros((3, 3)), vals=np.ones(2)), ReadError),
    (dict(idx=np.array([0, 30]), vals=np.ones(2)), SampleError),
    (dict(idx=np.array([0, 1]), vals=np.array([1.0, np.nan])), SampleError),
    (dict(idx=np.arange(2), vals=np.ones(2), names=np.array(["a", "b"])), SampleError),  # 2 names, 1 column
])
def test_bad_npz(tmp_path, arrays_, error):
    V, _ = mesh()
    np.savez(tmp_path / "s.npz", **arrays_)
    with pytest.raises(error) as info:
        read_samples(tmp_path / "s.npz", V)
    one_line(info)


# ----------------------------------------------------------------------------- duplicates


def test_conflicting_duplicates_name_the_vertex(tmp_path):
    V, _ = mesh()
    path = write(tmp_path, "vertex,v\n3,1\n5,0\n3,2\n")
    with pytest.raises(SampleError) as info:
        read_samples(path, V)
    msg = one_line(info)
    assert "vertex 3" in msg and "1, 2" in msg and "mean" in msg


def test_duplicates_mean_averages(tmp_path):
    V, _ = mesh()
    S = read_samples(write(tmp_path, "vertex,a,b\n3,1,10\n5,0,0\n3,2,20\n3,6,60\n"), V, duplicates="mean")
    assert S.idx.tolist() == [3, 5]
    np.testing.assert_allclose(S.vals, [[3.0, 30.0], [0.0, 0.0]])
    assert S.merged == 2


def test_equal_duplicates_merge_silently(tmp_path):
    V, _ = mesh()
    S = read_samples(write(tmp_path, "vertex,v\n3,1.25\n5,0\n3,1.25\n5,0\n3,1.25\n"), V)
    assert S.idx.tolist() == [3, 5] and S.vals[:, 0].tolist() == [1.25, 0.0]
    assert S.merged == 3


def test_positions_snapping_to_one_vertex(tmp_path):
    V, _ = mesh()
    text = "x,y,z,v\n0.01,0,0,1\n0,0.02,0,2\n1,1,0,5\n"  # the first two both snap to vertex 0
    with pytest.raises(SampleError, match="vertex 0"):
        read_samples(write(tmp_path, text), V)
    S = read_samples(write(tmp_path, text), V, duplicates="mean")
    assert S.idx.tolist() == [0, 24] and S.vals[:, 0].tolist() == [1.5, 5.0] and S.merged == 1
    np.testing.assert_allclose(S.snap_distance, [0.02, 0.0])  # the larger of the two
    S = read_samples(write(tmp_path, "x,y,z,v\n0.01,0,0,1\n0,0.02,0,1\n"), V)
    assert S.idx.tolist() == [0] and S.merged == 1


# ----------------------------------------------------------------------------- far-away positions


def test_far_positions_suggest_wrong_units(tmp_path):
    V, _ = mesh()
    # positions in millimetres on a mesh in metres
    P = V[[0, 6, 18]] * 1000.0
    rows = "\n".join(f"{x:.17g},{y:.17g},{z:.17g},1" for x, y, z in P)
    with pytest.raises(SampleError) as info:
        read_samples(write(tmp_path, "x,y,z,v\n" + rows + "\n"), V)
    msg = one_line(info)
    assert "wrong units?" in msg
    dist = np.linalg.norm(P[:, None] - V[None], axis=2).min(axis=1)
    diag = np.sqrt(2.0)
    assert f"{dist.max() / diag:.3g} x" in msg  # the worst sample as a multiple of the mesh size
    assert "2 samples lie far" in msg  # row 0 is still at vertex 0
    assert "max_distance" in msg


def test_max_distance_raises_and_lowers_the_limit(tmp_path):
    V, _ = mesh()
    far = write(tmp_path, "x,y,z,v\n0,0,3,1\n1,1,0,2\n")  # 3 units above vertex 0
    with pytest.raises(SampleError, match="wrong units"):
        read_samples(far, V)
    S = read_samples(far, V, max_distance=3.5)
    assert S.idx.tolist() == [0, 24]
    np.testing.assert_allclose(S.snap_distance, [3.0, 0.0])
    near = write(tmp_path, "x,y,z,v\n0,0,0.1,1\n", "near.csv")
    assert read_samples(near, V).idx.tolist() == [0]
    with pytest.raises(SampleError, match="far from the mesh"):
        read_samples(near, V, max_distance=0.05)


# ----------------------------------------------------------------------------- snapping


@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(
    V=arrays(np.float64, st.tuples(st.integers(2, 40), st.just(3)),
             elements=st.floats(-10, 10, allow_nan=False, width=64)),
    seed=st.integers(0, 2**16),
    k=st.integers(1, 20),
)
def test_snap_agrees_with_brute_force(V, seed, k):
    rng = np.random.default_rng(seed)
    P = V[rng.integers(0, len(V), k)] + rng.normal(scale=rng.uniform(0.01, 5.0), size=(k, 3))
    idx, dist = snap_to_vertices(V, P, max_distance=np.inf)
    D = np.linalg.norm(P[:, None, :] - V[None, :, :], axis=2)
    assert idx.dtype == np.int64 and idx.shape == (k,) and dist.shape == (k,)
    np.testing.assert_allclose(dist, D.min(axis=1), rtol=1e-12, atol=1e-12)
    # the chosen vertex is a nearest one (ties may go either way)
    np.testing.assert_allclose(D[np.arange(k), idx], D.min(axis=1), rtol=1e-12, atol=1e-12)


def test_snap_accepts_flat_positions_and_rejects_bad_shapes():
    V, _ = mesh()
    idx, dist = snap_to_vertices(V, [[0.26, 0.49]])
    assert idx.tolist() == [11] and np.isclose(dist[0], np.hypot(0.01, 0.01))
    for bad in ([[0.0, 0.0, 0.0, 0.0]], np.zeros((0, 3)), [0.0, 0.0, 0.0], [[np.nan, 0, 0]]):
        with pytest.raises(SampleError):
            snap_to_vertices(V, bad)


@pytest.mark.parametrize("case", ["npz idx longer than vals", "npz 2-D idx", "npy text field"])
def test_malformed_arrays_give_read_error(tmp_path, case):
    V, _ = mesh()
    if case == "npz idx longer than vals":
        path = tmp_path / "s.npz"
        np.savez(path, idx=np.array([0, 1, 2]), vals=np.array([1.0, 2.0]))
    elif case == "npz 2-D idx":
        path = tmp_path / "s.npz"
        np.savez(path, idx=np.array([[0, 1], [2, 3]]), vals=np.array([1.0, 2.0]))
    else:
        path = tmp_path / "s.npy"
        np.save(path, np.array([(0, "warm")], dtype=[("vertex", "i8"), ("temp", "U8")]))
    with pytest.raises((ReadError, SampleError)):
        read_samples(path, V)


def test_repeated_value_column_names_are_refused(tmp_path):
    V, _ = mesh()
    with pytest.raises(SampleError, match="repeats"):
        read_samples(write(tmp_path, "vertex,a,a\n0,1,2\n"), V)


@pytest.mark.parametrize("bad", [float("nan"), -1.0])
def test_max_distance_must_be_a_distance(bad):
    V, _ = mesh()
    with pytest.raises(SampleError, match="max_distance"):
        snap_to_vertices(V, [[0.0, 0.0, 0.0]], max_distance=bad)


def test_small_conflicting_values_are_not_merged_silently():
    from manifill.validate import as_samples
    with pytest.raises(SampleError, match="two different values"):
        as_samples([0, 0], [1e-13, 9e-13], 3)


def test_huge_vertex_index_is_a_read_error(tmp_path):
    V, _ = mesh()
    with pytest.raises(ReadError, match="too large"):
        read_samples(write(tmp_path, "vertex,v\n1e23,1\n"), V)
