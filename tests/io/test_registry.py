"""Meshes and values on disk: round trips through every format, typed errors, atomic writes."""

import os

import meshio
import numpy as np
import pytest
from scipy.spatial import cKDTree

from manifill.errors import ReadError, SampleError, WriteError
from manifill.io import MESH_FORMATS, read_mesh, read_mesh_file, read_samples, write_mesh, write_values
from manifill.mesh.shapes import grid, icosphere

MESHES = {
    "grid": lambda: grid(5, 4, size=(2.0, 1.5)),
    "icosphere": lambda: icosphere(1),
}
WRITTEN = sorted(ext for ext, fmt in MESH_FORMATS.items() if fmt.write)
FIELD_FORMATS = [ext for ext in WRITTEN if MESH_FORMATS[ext].fields]
PLAIN_FORMATS = [ext for ext in WRITTEN if not MESH_FORMATS[ext].fields]

# meshio's binary-STL size check overflows harmlessly on ASCII STL files
pytestmark = pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")


def canonical_faces(F):
    """Faces rotated to start at their smallest index (orientation kept), rows sorted."""
    F = np.asarray(F, dtype=np.int64)
    shift = np.argmin(F, axis=1)
    G = np.take_along_axis(F, (shift[:, None] + np.arange(3)) % 3, axis=1)
    return G[np.lexsort(G.T[::-1])]


def match_vertices(V, V2):
    """Index of the vertex of ``V`` at each position of ``V2``, checked to be a bijection."""
    diag = np.linalg.norm(V.max(axis=0) - V.min(axis=0))
    dist, nearest = cKDTree(V).query(V2)
    assert dist.max() <= 1e-6 * diag  # STL stores float32
    assert len(V2) == len(V) and np.unique(nearest).size == len(V)
    return nearest


def leftovers(folder, keep=()):
    """Files in ``folder`` other than ``keep`` (temporary files included)."""
    return sorted(set(os.listdir(folder)) - set(keep))


# ----------------------------------------------------------------------------- mesh round trips


@pytest.mark.parametrize("name", ["p.xyz", "p.csv"])
def test_point_files_are_not_meshes_unless_points_are_taken(tmp_path, name):
    path = tmp_path / name
    path.write_text(("x,y,z\n" if name.endswith(".csv") else "") + "".join(
        f"{i},{i * i},{i % 3}\n" for i in range(9)))
    with pytest.raises(ReadError, match="holds points, not a mesh.*point cloud"):
        read_mesh(path)
    m = read_mesh_file(path, points=True)
    assert m.F is None and m.V.shape == (9, 3) and m.V[4].tolist() == [4.0, 16.0, 1.0]


def test_registry_lists_the_documented_formats():
    assert set(MESH_FORMATS) == {".off", ".obj", ".ply", ".stl", ".vtk", ".vtu", ".vtp", ".gii", ".xyz", ".csv"}
    assert {e for e, f in MESH_FORMATS.items() if not f.cells} == {".xyz", ".csv"}  # points only
    assert set(FIELD_FORMATS) == {".ply", ".vtk", ".vtu", ".vtp"}
    assert [ext for ext, f in MESH_FORMATS.items() if not f.vertex_numbering] == [".stl"]


@pytest.mark.parametrize("mesh", sorted(MESHES))
@pytest.mark.parametrize("ext", WRITTEN)
def test_mesh_round_trip(tmp_path, ext, mesh):
    V, F = MESHES[mesh]()
    path = tmp_path / f"mesh{ext}"
    write_mesh(path, V, F)
    assert leftovers(tmp_path) == [path.name]
    V2, F2 = read_mesh(path)
    assert V2.dtype == np.float64 and V2.shape[1] == 3
    assert F2.dtype == np.int64 and F2.shape == F.shape
    # geometry up to a renumbering of the vertices (STL merges and reorders them)
    nearest = match_vertices(V, V2)
    np.testing.assert_array_equal(canonical_faces(nearest[F2]), canonical_faces(F))
    if ext != ".stl":
        # every other format keeps the numbering, which vertex-indexed samples rely on
        np.testing.assert_allclose(V2, V, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(F2, F)


def test_stl_round_trip_of_a_moved_mesh_keeps_orientation(tmp_path):
    """Up to reordering, STL keeps each face's cyclic order (its outward normal)."""
    V, F = icosphere(1)
    V = V * 3.0 + [10.0, -5.0, 2.0]
    write_mesh(tmp_path / "m.stl", V, F)
    V2, F2 = read_mesh(tmp_path / "m.stl")
    nearest = match_vertices(V, V2)
    n1 = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    G = nearest[F2]
    n2 = np.cross(V[G[:, 1]] - V[G[:, 0]], V[G[:, 2]] - V[G[:, 0]])
    assert np.allclose(np.sort(n1, axis=0), np.sort(n2, axis=0))
    centroid = V.mean(axis=0)
    assert (np.einsum("ij,ij->i", n2, V[G].mean(axis=1) - centroid) > 0).all()


# ----------------------------------------------------------------------------- point data


def sample_fields(n, p=3):
    rng = np.random.default_rng(0)
    return {
        "temperature": rng.normal(size=n) * 1e3,
        "flow": rng.normal(size=(n, p)),
        "label": rng.integers(-3, 7, size=n),
        "fixed": rng.random(n) < 0.3,
    }


def read_back_field(point_data, ext, name, p):
    if ext == ".ply":
        assert name not in point_data
        return np.column_stack([point_data[f"{name}_{j}"] for j in range(p)])
    return point_data[name]


@pytest.mark.parametrize("ext", FIELD_FORMATS)
def test_point_data_round_trip(tmp_path, ext):
    V, F = icosphere(1)
    n = len(V)
    fields = sample_fields(n)
    path = tmp_path / f"fields{ext}"
    write_mesh(path, V, F, fields)
    assert leftovers(tmp_path) == [path.name]
    pd = read_mesh_file(path).point_data
    expected = {"temperature", "label", "fixed"} | (
        {"flow_0", "flow_1", "flow_2"} if ext == ".ply" else {"flow"})
    assert set(pd) == expected

    t = pd["temperature"]
    assert t.dtype.kind == "f" and t.shape == (n,)
    np.testing.assert_array_equal(t, fields["temperature"])

    flow = read_back_field(pd, ext, "flow", 3)
    assert flow.dtype.kind == "f" and flow.shape == (n, 3)
    np.testing.assert_array_equal(flow, fields["flow"])

    label = pd["label"]
    assert label.dtype.kind == "i" and label.shape == (n,)  # signed: negative labels survive
    np.testing.assert_array_equal(label, fields["label"])

    fixed = pd["fixed"]
    assert fixed.dtype.kind in "iub" and fixed.shape == (n,)  # a mask stays an integer/bool type
    assert set(np.unique(fixed).tolist()) <= {0, 1}
    np.testing.assert_array_equal(fixed.astype(bool), fields["fixed"])

    # the mesh itself is unchanged by the fields
    V2, F2 = read_mesh(path)
    np.testing.assert_allclose(V2, V, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(F2, F)


@pytest.mark.parametrize("ext", [
    ".ply",
    ".vtu",
    ".vtk",
])
def test_two_component_field_keeps_its_width(tmp_path, ext):
    V, F = icosphere(1)
    uv = np.random.default_rng(1).normal(size=(len(V), 2))
    write_mesh(tmp_path / f"uv{ext}", V, F, {"uv": uv})
    pd = read_mesh_file(tmp_path / f"uv{ext}").point_data
    got = read_back_field(pd, ext, "uv", 2)
    assert got.shape == uv.shape
    np.testing.assert_array_equal(got, uv)


@pytest.mark.parametrize("ext, name, stored", [
    (".ply", "z", "field_z"),
    (".ply", "my temp", "my_temp"),
    (".ply", "temp-2", "temp_2"),
    (".ply", "2nd", "field_2nd"),
    (".vtk", "z", "z"),
    (".vtu", "z", "z"),
    (".vtu", "my temp", "my temp"),
])
def test_awkward_field_names_round_trip(tmp_path, ext, name, stored):
    V, F = icosphere(1)
    path = tmp_path / f"names{ext}"
    written = write_mesh(path, V, F, {name: 2 * V[:, 2]})
    assert written == {name: stored}
    V2, F2 = read_mesh(path)
    np.testing.assert_allclose(V2, V, atol=1e-12)
    np.testing.assert_array_equal(read_mesh_file(path).point_data[stored], 2 * V[:, 2])


def test_ply_names_that_collide_after_renaming_stay_distinct(tmp_path):
    V, F = icosphere(1)
    written = write_mesh(tmp_path / "c.ply", V, F, {"a b": V[:, 0], "a_b": V[:, 1]})
    assert written == {"a b": "a_b", "a_b": "field_a_b"}
    pd = meshio.read(tmp_path / "c.ply").point_data
    np.testing.assert_array_equal(pd["a_b"], V[:, 0])
    np.testing.assert_array_equal(pd["field_a_b"], V[:, 1])


@pytest.mark.parametrize("ext", PLAIN_FORMATS)
def test_fields_in_a_format_without_point_data_raise(tmp_path, ext):
    V, F = grid(3)
    with pytest.raises(WriteError, match="per-vertex fields"):
        write_mesh(tmp_path / f"m{ext}", V, F, {"value": np.zeros(len(V))})
    assert leftovers(tmp_path) == []
    # without fields the same format is fine
    write_mesh(tmp_path / f"m{ext}", V, F, {})
    assert leftovers(tmp_path) == [f"m{ext}"]


# ----------------------------------------------------------------------------- read errors


@pytest.mark.parametrize("name", ["mesh.abc", "mesh", "mesh.txt", "mesh.ply.gz"])
def test_unknown_extension(tmp_path, name):
    V, F = grid(3)
    path = tmp_path / name
    path.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    with pytest.raises(ReadError, match="cannot read"):
        read_mesh(path)
    with pytest.raises(WriteError, match="cannot write"):
        write_mesh(tmp_path / ("out_" + name), V, F)
    assert leftovers(tmp_path) == [name]


def test_extension_is_case_insensitive(tmp_path):
    V, F = grid(3)
    write_mesh(tmp_path / "m.PLY", V, F)
    V2, F2 = read_mesh(tmp_path / "m.PLY")
    np.testing.assert_array_equal(F2, F)


@pytest.mark.parametrize("ext", WRITTEN)
def test_missing_file(tmp_path, ext):
    with pytest.raises(ReadError, match="no such file"):
        read_mesh(tmp_path / f"missing{ext}")


def broken_file(tmp_path, ext, kind):
    path = tmp_path / f"broken{ext}"
    if kind == "garbage":
        path.write_bytes(b"this is not a mesh\n\x00\x01\x02 at all\n1 2\n")
    elif kind == "empty":
        path.write_bytes(b"")
    else:  # the first half of a valid file
        V, F = icosphere(1)
        write_mesh(tmp_path / f"whole{ext}", V, F)
        data = (tmp_path / f"whole{ext}").read_bytes()
        path.write_bytes(data[: len(data) // 2])
    return path


@pytest.mark.parametrize("kind", ["garbage", "empty", "truncated"])
@pytest.mark.parametrize("ext", WRITTEN)
def test_unreadable_file_gives_one_line_read_error(tmp_path, capfd, ext, kind):
    path = broken_file(tmp_path, ext, kind)
    with pytest.raises(ReadError) as info:
        read_mesh(path)
    msg = str(info.value)
    assert "\n" not in msg and path.name in msg
    out, err = capfd.readouterr()
    assert out == "" and err == ""  # meshio must not print its own messages


def test_tetrahedra_only_vtu(tmp_path):
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], dtype=float)
    tets = np.array([[0, 1, 2, 3], [1, 2, 3, 4]])
    meshio.write(tmp_path / "tets.vtu", meshio.Mesh(points, [("tetra", tets)]))
    with pytest.raises(ReadError, match="holds no triangles") as info:
        read_mesh(tmp_path / "tets.vtu")
    assert "tetra" in str(info.value) and "\n" not in str(info.value)


def quad_grid(n=4):
    """(n x n) vertices in the unit square, (n-1)^2 counter-clockwise quads."""
    xs = np.linspace(0, 1, n)
    X, Y = np.meshgrid(xs, xs, indexing="xy")
    V = np.column_stack([X.ravel(), Y.ravel(), np.zeros(n * n)])
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="xy")
    a = (j * n + i).ravel()
    Q = np.column_stack([a, a + 1, a + n + 1, a + n])
    return V, Q


@pytest.mark.parametrize("ext", [".ply", ".obj", ".vtk", ".vtu"])
def test_quads_are_split_into_triangles(tmp_path, ext):
    V, Q = quad_grid(4)
    T = np.array([[0, 15, 12]])  # one triangle beside the quads (overlapping them; only combinatorics matter)
    meshio.write(tmp_path / f"q{ext}", meshio.Mesh(V, [("quad", Q), ("triangle", T)]))
    V2, F = read_mesh(tmp_path / f"q{ext}")
    np.testing.assert_allclose(V2, V, atol=1e-12)
    assert F.shape == (2 * len(Q) + len(T), 3)
    expected = np.vstack([Q[:, [0, 1, 2]], Q[:, [0, 2, 3]], T])  # each quad split on its diagonal (a, c)
    np.testing.assert_array_equal(canonical_faces(F), canonical_faces(expected))
    # the quad triangles tile the unit square, all counter-clockwise like the quads
    is_quad_tri = ~np.all(canonical_faces(F)[:, None, :] == canonical_faces(T)[None], axis=2).any(axis=1)
    P = V[canonical_faces(F)[is_quad_tri]]
    z = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])[:, 2]
    assert z.size == 2 * len(Q) and (z > 0).all()
    assert np.isclose(z.sum() / 2, 1.0)


# ----------------------------------------------------------------------------- atomic writes


def failing_meshio_write(exc):
    def fake_write(filename, mesh, file_format=None, **kwargs):
        with open(filename, "w") as fh:
            fh.write("partial")
        raise exc
    return fake_write


@pytest.mark.parametrize("exc", [OSError("disk full"), ValueError("bad data"), RuntimeError("crash")])
def test_failed_write_leaves_nothing_behind(tmp_path, monkeypatch, exc):
    V, F = icosphere(1)
    monkeypatch.setattr(meshio, "write", failing_meshio_write(exc))
    with pytest.raises((WriteError, type(exc))):
        write_mesh(tmp_path / "out.ply", V, F, {"t": V[:, 0]})
    assert leftovers(tmp_path) == []


def test_meshio_failure_becomes_write_error(tmp_path, monkeypatch):
    V, F = icosphere(1)
    monkeypatch.setattr(meshio, "write", failing_meshio_write(OSError("disk full")))
    with pytest.raises(WriteError, match="disk full") as info:
        write_mesh(tmp_path / "out.ply", V, F)
    assert "\n" not in str(info.value)


def failing_replace(src, dst):
    raise OSError("disk full")


@pytest.mark.parametrize("ext", FIELD_FORMATS)
def test_existing_file_replaced_only_on_success(tmp_path, monkeypatch, ext):
    V, F = icosphere(1)
    path = tmp_path / f"out{ext}"
    write_mesh(path, V, F, {"t": V[:, 0]})
    before = path.read_bytes()

    # a failure inside meshio's writer, or when the finished file replaces the old one
    with monkeypatch.context() as m:
        m.setattr(meshio, "write", failing_meshio_write(OSError("disk full")))
        m.setattr("manifill.io.files.os.replace", failing_replace)
        with pytest.raises(WriteError, match="disk full"):
            write_mesh(path, 2 * V, F, {"t": V[:, 1]})
    assert path.read_bytes() == before
    # a field of the wrong length
    with pytest.raises(WriteError, match="'y' has 41 values for 42 vertices"):
        write_mesh(path, V, F, {"t": V[:, 1], "y": np.zeros(len(V) - 1)})
    assert path.read_bytes() == before
    assert leftovers(tmp_path) == [path.name]

    # success replaces it
    write_mesh(path, 2 * V, F, {"t": V[:, 1]})
    V2, _ = read_mesh(path)
    np.testing.assert_allclose(V2, 2 * V, atol=1e-12)
    np.testing.assert_array_equal(read_mesh_file(path).point_data["t"], V[:, 1])
    assert leftovers(tmp_path) == [path.name]


def test_wrong_length_field_creates_nothing(tmp_path):
    V, F = grid(4)
    with pytest.raises(WriteError, match="one per vertex"):
        write_mesh(tmp_path / "out.ply", V, F, {"t": np.zeros(len(V) + 1)})
    assert leftovers(tmp_path) == []


def test_write_into_missing_folder(tmp_path):
    V, F = grid(3)
    target = tmp_path / "nope" / "out.ply"
    with pytest.raises(WriteError, match="does not exist"):
        write_mesh(target, V, F)
    with pytest.raises(WriteError, match="does not exist"):
        write_values(tmp_path / "nope" / "out.csv", np.zeros(len(V)))
    assert leftovers(tmp_path) == []


def test_failed_value_write_leaves_nothing_behind(tmp_path, monkeypatch):
    path = tmp_path / "vals.csv"
    write_values(path, np.arange(4.0))
    before = path.read_bytes()

    def partial_savetxt(fname, *args, **kwargs):
        with open(fname, "w") as fh:
            fh.write("vertex,value\n0,")
        raise OSError("disk full")

    monkeypatch.setattr(np, "savetxt", partial_savetxt)
    with pytest.raises(WriteError, match="disk full"):
        write_values(path, np.arange(4.0) * 2)
    assert path.read_bytes() == before
    assert leftovers(tmp_path) == [path.name]


# ----------------------------------------------------------------------------- values


def test_write_values_csv_round_trip(tmp_path):
    V, _ = grid(4)
    n = len(V)
    rng = np.random.default_rng(2)
    X = rng.normal(size=(n, 2)) * np.array([1e-7, 1e9])
    path = tmp_path / "vals.csv"
    write_values(path, X, names=["temp", "pressure"])
    lines = path.read_text().splitlines()
    assert lines[0] == "vertex,temp,pressure" and len(lines) == n + 1
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(table[:, 0], np.arange(n))
    np.testing.assert_array_equal(table[:, 1:], X)  # %.17g is exact
    # and it reads back as samples on every vertex
    S = read_samples(path, V)
    np.testing.assert_array_equal(S.idx, np.arange(n))
    np.testing.assert_array_equal(S.vals, X)
    assert S.names == ["temp", "pressure"]
    assert leftovers(tmp_path) == [path.name]


def test_write_values_default_names(tmp_path):
    write_values(tmp_path / "one.csv", np.arange(3.0))
    write_values(tmp_path / "three.csv", np.zeros((2, 3)))
    assert (tmp_path / "one.csv").read_text().splitlines()[0] == "vertex,value"
    assert (tmp_path / "three.csv").read_text().splitlines()[0] == "vertex,value,value2,value3"
    with pytest.raises(SampleError, match="field names"):
        write_values(tmp_path / "bad.csv", np.zeros((2, 3)), names=["a", "b"])
    assert not (tmp_path / "bad.csv").exists()


@pytest.mark.parametrize("shape", [(7,), (7, 1), (7, 3)])
def test_write_values_npy_round_trip(tmp_path, shape):
    X = np.random.default_rng(3).normal(size=shape)
    path = tmp_path / "vals.npy"
    write_values(path, X, names=None)
    got = np.load(path)
    assert got.dtype == np.float64
    # one column is stored as a vector
    np.testing.assert_array_equal(got, X.reshape(7, -1)[:, 0] if X.ndim == 1 or X.shape[1] == 1 else X)
    assert leftovers(tmp_path) == [path.name]


@pytest.mark.parametrize("name", ["vals.txt", "vals.ply", "vals"])
def test_write_values_unknown_extension(tmp_path, name):
    with pytest.raises(WriteError, match="cannot write"):
        write_values(tmp_path / name, np.zeros(3))
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("text", ["OFF\n# comment only\n", "OFF\n3 1\n", "OFF\na b c\n0 0 0\n"])
def test_off_without_counts_is_a_read_error_not_a_hang(tmp_path, text):
    path = tmp_path / "m.off"
    path.write_text(text)
    with pytest.raises(ReadError, match="counts"):
        read_mesh(path)


def test_write_mesh_refuses_faces_beyond_the_vertices(tmp_path):
    V, F = grid(3)
    with pytest.raises(WriteError, match="malformed"):
        write_mesh(tmp_path / "bad.ply", V, F + 100)
    assert leftovers(tmp_path) == []


def test_positions_snap_only_to_the_vertices_given(tmp_path):
    # a point beside vertex 0 but nearest to vertex 1 of the whole mesh lands on vertex 0 when only 0 and 2 may take it
    V = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]])
    path = tmp_path / "pts.csv"
    path.write_text("x,y,z,t\n0.9,0,0,5.0\n2.1,0,0,7.0\n")
    S = read_samples(path, V)
    np.testing.assert_array_equal(S.idx, [1, 2])
    S = read_samples(path, V, snap_to=[2, 0])
    np.testing.assert_array_equal(S.idx, [0, 2])  # V's numbers, sorted
    np.testing.assert_array_equal(S.vals[:, 0], [5.0, 7.0])
    np.testing.assert_allclose(S.snap_distance, [0.9, 0.1])
    # samples by vertex index keep their vertices
    (tmp_path / "idx.csv").write_text("vertex,t\n1,3.0\n")
    np.testing.assert_array_equal(read_samples(tmp_path / "idx.csv", V, snap_to=[0, 2]).idx, [1])


def test_the_front_door_exports_the_api_and_shadows_no_module():
    import importlib
    import pkgutil
    import types

    import manifill.io as io

    modules = {m.name for m in pkgutil.iter_modules(io.__path__)}
    assert {"registry", "samples", "solids", "files", "field_names", "vtkxml_read", "vtklegacy_read"} <= modules
    for name in io.__all__:
        assert not isinstance(getattr(io, name), types.ModuleType), name
        assert name not in modules, f"manifill.io.{name} would hide the module of that name"
    for name in modules:
        assert isinstance(importlib.import_module(f"manifill.io.{name}"), types.ModuleType)
        assert not hasattr(io, name) or isinstance(getattr(io, name), types.ModuleType), name
    for name in ("read_mesh", "read_mesh_file", "write_mesh", "write_cells", "MESH_FORMATS", "read_samples",
                 "write_values", "read_tets", "write_tets", "read_vti", "write_vti", "read_mask", "SAMPLE_MASK",
                 "CURVE_MASK", "PATCH_LABEL", "BOUNDARY_MASK"):
        assert name in io.__all__
