"""Legacy VTK: the reader against VTK (pyvista) and meshio, the writer read back by both, and mutated files."""

import collections
import os
import re
import warnings
from pathlib import Path

import meshio
import numpy as np
import pytest

from manifill import ReadError, WriteError
from manifill.mesh.shapes import icosphere
from manifill.io.vtklegacy_read import read_legacy
from manifill.io.vtklegacy_write import write_legacy


def one_line(info, path):
    """The message of a caught error, checked to be one line that starts with the file's name."""
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(f"{Path(path).name}: "), msg
    return msg


def tet_cube():
    """Unit cube split into the 6 Kuhn tets (8 vertices)."""
    V = np.array([[x, y, z] for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0)])
    T = np.array([[0, 4, 6, 7], [0, 4, 5, 7], [0, 2, 6, 7], [0, 2, 3, 7], [0, 1, 5, 7], [0, 1, 3, 7]])
    return V, T


# ---------------------------------------------------------------------------
# references: the cells VTK read, turned into triangles by the textbook rules
# ---------------------------------------------------------------------------


def split_cells(flat):
    """VTK's flat cell list ``k i1 .. ik k ...`` as a list of lists."""
    flat, out, p = list(np.asarray(flat)), [], 0
    while p < len(flat):
        out.append([int(i) for i in flat[p + 1:p + 1 + flat[p]]])
        p += flat[p] + 1
    return out


def fan(c):
    return [(c[0], c[i], c[i + 1]) for i in range(1, len(c) - 1)]


def strip(c):
    return [(c[i], c[i + 1], c[i + 2]) if i % 2 == 0 else (c[i + 1], c[i], c[i + 2]) for i in range(len(c) - 2)]


def expected_cells(mesh):
    """Triangles (polygons fanned, strips alternated) and tets of a mesh as VTK read it, in file order."""
    import pyvista as pv

    tris, tets = [], []
    if isinstance(mesh, pv.PolyData):
        for c in split_cells(mesh.faces):
            tris += fan(c)
        for c in split_cells(mesh.strips):
            tris += strip(c)
    else:
        for c, t in zip(split_cells(mesh.cells), mesh.celltypes):
            tris += fan(c) if t in (5, 7, 9) else strip(c) if t == 6 else []
            tets += [c] if t == 10 else []
    return np.array(tris, dtype=np.int64).reshape(-1, 3), np.array(tets, dtype=np.int64).reshape(-1, 4)


def assert_same_as_vtk(path):
    """Points, cells and every point array of ours equal VTK's reading of ``path``, dtype included."""
    import pyvista as pv

    ref = pv.read(path)
    V, cells, pd = read_legacy(path)
    assert V.dtype == np.float64 and V.shape == (ref.n_points, 3)
    np.testing.assert_array_equal(V, np.asarray(ref.points, dtype=np.float64))
    tris, tets = expected_cells(ref)
    assert set(cells) == {k for k, c in (("triangle", tris), ("tetra", tets)) if len(c)}
    np.testing.assert_array_equal(cells.get("triangle", tris), tris)
    np.testing.assert_array_equal(cells.get("tetra", tets), tets)
    assert all(c.dtype == np.int64 for c in cells.values())
    assert sorted(pd) == sorted(ref.point_data.keys())
    for name, arr in pd.items():
        want = ref.point_data[name]
        assert arr.dtype == want.dtype, name
        np.testing.assert_array_equal(arr, want, err_msg=name)
    return V, cells, pd


# ---------------------------------------------------------------------------
# files written by VTK
# ---------------------------------------------------------------------------


def vtk_polydata():
    """PolyData with verts, lines, a triangle, a quad, a pentagon and a strip, and every kind of point attribute."""
    pv = pytest.importorskip("pyvista")
    from vtkmodules.vtkCommonCore import vtkIdTypeArray, vtkLookupTable

    rng = np.random.default_rng(3)
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0], [3, 0, 0], [3, 1, 0],
                    [2.5, 2, 0], [0, 0, 1], [4, 0, 0], [4, 1, 0], [5, 0, 0], [5, 1, 0]], dtype=float)
    mesh = pv.PolyData(pts, faces=[3, 0, 1, 2, 4, 1, 4, 5, 2, 5, 4, 6, 7, 8, 5],
                       strips=[6, 6, 7, 10, 11, 12, 13], verts=[1, 9], lines=[2, 0, 9])
    n = mesh.n_points
    mesh.point_data["scal int"] = np.arange(n, dtype=np.int32) * 3 - 5
    lut = vtkLookupTable()
    lut.SetNumberOfTableValues(3)
    lut.Build()
    mesh.GetPointData().GetArray("scal int").SetLookupTable(lut)
    mesh.point_data["vec"] = rng.normal(size=(n, 3))
    mesh.point_data["nrm"] = rng.normal(size=(n, 3)).astype(np.float32)
    mesh.point_data["uv"] = rng.random((n, 2))
    mesh.point_data["T"] = rng.normal(size=(n, 9))
    mesh.point_data["flags"] = (np.arange(n) % 3).astype(np.uint8)
    mesh.point_data["five"] = rng.normal(size=(n, 5)).astype(np.float32)
    mesh.point_data["big"] = np.arange(n, dtype=np.int64) * 2**40 - 7
    mesh.point_data["short"] = np.arange(n, dtype=np.int16) - 4
    mesh.point_data["50% two"] = rng.normal(size=(n, 2))
    mesh.GetPointData().GetArray("50% two").SetComponentName(0, "first x")  # a METADATA block
    ids = vtkIdTypeArray()
    ids.SetName("gid")
    for i in range(n):
        ids.InsertNextValue(100 + i)
    pd = mesh.GetPointData()
    pd.SetGlobalIds(ids)
    pd.SetActiveScalars("scal int")
    pd.SetActiveVectors("vec")
    pd.SetActiveNormals("nrm")
    pd.SetActiveTCoords("uv")
    pd.SetActiveTensors("T")
    mesh.cell_data["cid"] = np.arange(mesh.n_cells, dtype=float)
    mesh.field_data["note"] = ["two words", "x"]  # string arrays in the dataset's field data
    mesh.user_dict["k"] = "v"
    return mesh


def vtk_grid():
    """UnstructuredGrid with a triangle, quad, hexagon, strip, tet, and cells that are skipped, and colours."""
    pv = pytest.importorskip("pyvista")
    rng = np.random.default_rng(4)
    pts = rng.random((12, 3))
    cells = [3, 0, 1, 2, 4, 2, 3, 4, 5, 6, 5, 6, 7, 8, 9, 10, 5, 0, 2, 4, 6, 8, 4, 1, 3, 5, 7,
             8, 0, 1, 2, 3, 4, 5, 6, 7, 1, 11, 2, 10, 11]
    types = [5, 9, 7, 6, 10, 12, 1, 3]
    mesh = pv.UnstructuredGrid(np.array(cells), np.array(types, dtype=np.uint8), pts)
    n = mesh.n_points
    mesh.point_data["rgb"] = rng.integers(0, 256, (n, 3)).astype(np.uint8)
    mesh.GetPointData().SetActiveScalars("rgb")  # written as COLOR_SCALARS
    mesh.point_data["i8"] = (np.arange(n) - 6).astype(np.int8)
    mesh.point_data["u32"] = np.arange(n, dtype=np.uint32) * 3_000_000
    mesh.point_data["f"] = rng.normal(size=n).astype(np.float32)
    mesh.cell_data["c"] = np.arange(mesh.n_cells, dtype=np.int32)
    return mesh


def write_vtk(mesh, path, version, binary):
    from vtkmodules.vtkIOLegacy import vtkPolyDataWriter, vtkUnstructuredGridWriter

    import pyvista as pv

    w = vtkPolyDataWriter() if isinstance(mesh, pv.PolyData) else vtkUnstructuredGridWriter()
    w.SetInputData(mesh)
    w.SetFileName(str(path))
    if version is not None:
        w.SetFileVersion(version)
    if binary:
        w.SetFileTypeToBinary()
    assert w.Write() == 1
    return path


@pytest.mark.parametrize("binary", [False, True], ids=["ascii", "binary"])
@pytest.mark.parametrize("version", [42, 51, None], ids=["v4.2", "v5.1", "default"])
@pytest.mark.parametrize("build", [vtk_polydata, vtk_grid])
def test_files_written_by_vtk_read_as_vtk_reads_them(tmp_path, build, version, binary):
    path = write_vtk(build(), tmp_path / "vtk.vtk", version, binary)
    head = path.read_bytes()[:80]
    assert head.startswith(b"# vtk DataFile Version " + (b"4.2" if version == 42 else b"5.1" if version else b""))
    assert (b"\nBINARY\n" in head) == binary
    V, cells, pd = assert_same_as_vtk(path)
    if build is vtk_polydata:
        # 1 + 2 + 3 fan triangles and 4 strip triangles; the METADATA block and %XX name survived
        assert len(cells["triangle"]) == 10 and "tetra" not in cells
        assert {"scal int", "50% two", "gid"} <= set(pd)
        assert pd["scal int"].dtype == np.int32 and pd["big"].dtype == np.int64 and pd["big"][-1] == 13 * 2**40 - 7
    else:
        assert len(cells["triangle"]) == 1 + 2 + 4 + 3 and len(cells["tetra"]) == 1  # tri, quad, hexagon, strip
        assert pd["rgb"].dtype == np.uint8 and pd["rgb"].shape == (len(V), 3)


def test_default_vtk_writer_writes_version_5_1():
    pytest.importorskip("pyvista")
    from vtkmodules.vtkIOLegacy import vtkPolyDataWriter

    assert vtkPolyDataWriter().GetFileVersion() == 51  # so the 'default' files above are 5.1


def test_pyvista_globe_matches_its_triangulation():
    pv = pytest.importorskip("pyvista")
    path = os.path.join(os.path.dirname(pv.__file__), "examples", "globe.vtk")
    assert open(path, "rb").read(80).startswith(b"# vtk DataFile Version 4.2\nvtk output\nBINARY\nDATASET POLYDATA")
    V, cells, pd = read_legacy(path)
    ref = pv.read(path).triangulate()
    np.testing.assert_array_equal(V, ref.points)
    np.testing.assert_array_equal(cells["triangle"], ref.regular_faces)
    assert list(pd) == ["Texture Coordinates"] == list(ref.point_data.keys())  # '%20' decoded
    np.testing.assert_array_equal(pd["Texture Coordinates"], ref.point_data["Texture Coordinates"])


def test_polygons_and_strips_cover_what_vtk_triangulate_covers(tmp_path):
    """VTK's triangle filter may cut a quad along the other diagonal: the same triangles count and vector area."""
    pv = pytest.importorskip("pyvista")
    path = write_vtk(vtk_polydata(), tmp_path / "p.vtk", 42, True)
    V, cells, _ = read_legacy(path)
    ref = pv.read(path).triangulate()
    F, G = cells["triangle"], ref.regular_faces

    def vector_area(V, F):
        return np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]).sum(axis=0) / 2

    assert len(F) == len(G)
    np.testing.assert_allclose(vector_area(V, F), vector_area(np.asarray(ref.points, float), G), atol=1e-12)
    strip_tris = {tuple(np.roll(t, -np.argmin(t))) for t in F[6:]}  # the strip's triangles: exactly VTK's
    assert strip_tris <= {tuple(np.roll(t, -np.argmin(t))) for t in G}


# ---------------------------------------------------------------------------
# files written by meshio
# ---------------------------------------------------------------------------


def meshio_mesh():
    rng = np.random.default_rng(5)
    V = rng.random((9, 3))
    cells = [("triangle", np.array([[0, 1, 2], [2, 3, 4]])), ("quad", np.array([[4, 5, 6, 7]])),
             ("tetra", np.array([[0, 2, 4, 8], [1, 3, 5, 8]]))]
    data = {"a": rng.normal(size=9), "b": rng.integers(-2**40, 2**40, (9, 3)), "c": np.arange(9, dtype=np.uint8),
            "d": np.arange(9, dtype=np.int32) - 4, "e": rng.normal(size=(9, 5)).astype(np.float32),
            "s": np.arange(9, dtype=np.int16) * -300}
    return meshio.Mesh(V, cells, point_data=data)


@pytest.mark.parametrize("binary", [False, True], ids=["ascii", "binary"])
@pytest.mark.parametrize("version", ["4.2", "5.1"])
def test_files_written_by_meshio_read_as_meshio_reads_them(tmp_path, version, binary):
    path = tmp_path / "m.vtk"
    meshio.vtk.write(path, meshio_mesh(), fmt_version=version, binary=binary)
    ref = meshio.read(path)
    V, cells, pd = read_legacy(path)
    np.testing.assert_array_equal(V, ref.points)
    blocks = {b.type: b.data for b in ref.cells}
    q = blocks["quad"]
    np.testing.assert_array_equal(cells["triangle"], np.concatenate([blocks["triangle"], q[:, [0, 1, 2]],
                                                                     q[:, [0, 2, 3]]]))
    np.testing.assert_array_equal(cells["tetra"], blocks["tetra"])
    assert sorted(pd) == sorted(ref.point_data)
    for name, arr in pd.items():
        want = ref.point_data[name]
        assert (arr.dtype.kind, arr.dtype.itemsize) == (want.dtype.kind, want.dtype.itemsize), name
        np.testing.assert_array_equal(arr, want, err_msg=name)


# ---------------------------------------------------------------------------
# the writer, read back by meshio, VTK and the reader here
# ---------------------------------------------------------------------------


def fields_for(n, rng):
    f1 = rng.normal(size=n) * 10.0 ** rng.integers(-300, 300, n)  # exact round trips of any double
    f1[:3] = [np.nan, -0.0, np.inf]
    return {"f1": f1, "f3": rng.normal(size=(n, 3)),
            "i5": np.concatenate([[[-2**31, 2**31 - 1, 0, 1, -1]], rng.integers(-2**31, 2**31, (n - 1, 5))]),
            "inside": rng.random(n) > 0.5, "label": rng.integers(0, 60000, n).astype(np.uint16),
            "count": rng.integers(-5, 5, n), "matrix_3x3[0]": rng.normal(size=(n, 5)).astype(np.float32)}


#: what each field is read back as: bool -> uint8, integers -> int32, floats -> float64
READ_BACK = {"f1": "f8", "f3": "f8", "i5": "i4", "inside": "u1", "label": "i4", "count": "i4", "matrix_3x3[0]": "f8"}


@pytest.mark.parametrize("kind", ["triangle", "tetra"])
def test_written_file_reads_back_in_meshio_pyvista_and_here(tmp_path, kind):
    pv = pytest.importorskip("pyvista")
    V, C = icosphere(1) if kind == "triangle" else tet_cube()
    rng = np.random.default_rng(6)
    V = V * 10.0 ** rng.integers(-200, 200, V.shape)
    fields = fields_for(len(V), rng)
    path = tmp_path / "out.vtk"
    write_legacy(path, V, kind, C, fields)
    assert path.read_bytes().startswith(b"# vtk DataFile Version 4.2\n")
    assert b"\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS " in path.read_bytes()[:100]
    vtk_type = 5 if kind == "triangle" else 10

    m = meshio.read(path)
    p = pv.read(path)
    ours = read_legacy(path)
    np.testing.assert_array_equal(m.points, V)
    np.testing.assert_array_equal(p.points, V)
    np.testing.assert_array_equal(ours[0], V)
    assert [b.type for b in m.cells] == [kind]
    np.testing.assert_array_equal(m.cells[0].data, C)
    np.testing.assert_array_equal(p.cells_dict[vtk_type], C)
    np.testing.assert_array_equal(ours[1][kind], C)
    for got in (m.point_data, p.point_data, ours[2]):
        assert sorted(got) == sorted(fields)
        for name, arr in fields.items():
            assert (got[name].dtype.kind + str(got[name].dtype.itemsize)) == READ_BACK[name], name
            np.testing.assert_array_equal(got[name], arr, err_msg=name)


def test_written_file_without_fields(tmp_path):
    V, F = icosphere(0)
    write_legacy(tmp_path / "bare.vtk", V, "triangle", F)
    assert b"POINT_DATA" not in (tmp_path / "bare.vtk").read_bytes()
    assert meshio.read(tmp_path / "bare.vtk").point_data == {}
    V2, cells, pd = read_legacy(tmp_path / "bare.vtk")
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(cells["triangle"], F)
    assert pd == {}


@pytest.mark.parametrize("name, chars", [("two words", "' '"), ("tab\there", "'\\t'"), ("line\nbreak", "'\\n'"),
                                         ("50%", "'%'"), ("température", "'é'"), ("del\x7f", "'\\x7f'")])
def test_writer_refuses_names_legacy_vtk_cannot_hold(tmp_path, name, chars):
    V, F = icosphere(0)
    with pytest.raises(WriteError) as info:
        write_legacy(tmp_path / "x.vtk", V, "triangle", F, {"ok": np.zeros(len(V)), name: np.zeros(len(V))})
    msg = one_line(info, "x.vtk")
    assert repr(name) in msg and chars in msg and "rename it or write .vtu/.vtp" in msg
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", ["", "NULL_ARRAY", "METADATA", "metadata_x", "MetaData"])
def test_writer_refuses_names_that_read_as_keywords(tmp_path, name):
    V, F = icosphere(0)
    with pytest.raises(WriteError) as info:
        write_legacy(tmp_path / "x.vtk", V, "triangle", F, {name: np.zeros(len(V))})
    assert repr(name) in one_line(info, "x.vtk") and "rename it" in str(info.value)


def test_vtk_misreads_a_field_named_metadata_so_the_writer_refuses_it(tmp_path):
    """Why 'metadata...' names are refused: VTK takes such a line after an array for a METADATA block."""
    pv = pytest.importorskip("pyvista")
    path = tmp_path / "md.vtk"
    path.write_bytes(b"# vtk DataFile Version 4.2\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 double\n0 0 0 1 0 0 0 1 0\n"
                     b"POLYGONS 1 4\n3 0 1 2\nPOINT_DATA 3\nFIELD FieldData 2\na 1 3 double\n1 2 3\n"
                     b"metadata_x 1 3 double\n4 5 6\n")
    assert "metadata_x" not in pv.read(path).point_data.keys()
    assert read_legacy(path)[2]["metadata_x"].tolist() == [4, 5, 6]  # the reader here gets it right


def test_int64_fields_are_refused_because_meshio_cannot_read_them_in_version_4_2(tmp_path):
    """Why integers are written as int32: meshio's 4.2 reader knows no vtktypeint64 (VTK does)."""
    pv = pytest.importorskip("pyvista")
    V, F = icosphere(0)
    write_legacy(tmp_path / "i.vtk", V, "triangle", F, {"k": np.arange(12)})
    data = (tmp_path / "i.vtk").read_bytes().replace(b"k 1 12 int\n", b"k 1 12 vtktypeint64\n")
    data = data[:data.index(b"vtktypeint64\n") + 13] + np.arange(12, dtype=">i8").tobytes() + b"\n"
    path = write(tmp_path, data, "i64.vtk")
    assert pv.read(path).point_data["k"].tolist() == list(range(12))
    assert read_legacy(path)[2]["k"].dtype == np.int64
    with pytest.raises(KeyError, match="vtktypeint64"):
        meshio.read(path)
    with pytest.raises(WriteError, match="beyond int32"):
        write_legacy(tmp_path / "i.vtk", V, "triangle", F, {"k": np.arange(12) + 2**31})


@pytest.mark.parametrize("field, what", [
    (np.zeros(11), "shape (11,)"), (np.zeros((12, 2, 2)), "shape (12, 2, 2)"), (np.zeros((12, 0)), "shape (12, 0)"),
    (np.full(12, 2**31), "beyond int32"), (np.zeros(12, complex), "complex128"), (np.array(["a"] * 12), "<U1"),
])
def test_writer_refuses_fields_of_the_wrong_shape_or_type(tmp_path, field, what):
    V, F = icosphere(0)
    (tmp_path / "x.vtk").write_text("old")
    with pytest.raises(WriteError) as info:
        write_legacy(tmp_path / "x.vtk", V, "triangle", F, {"f": field})
    assert what in one_line(info, "x.vtk")
    assert (tmp_path / "x.vtk").read_text() == "old" and len(list(tmp_path.iterdir())) == 1


@pytest.mark.parametrize("args, what", [
    ((np.zeros((4, 2)), "triangle", [[0, 1, 2]]), "not (n, 3)"),
    ((np.zeros((4, 3)), "quad", [[0, 1, 2, 3]]), "'quad'"),
    ((np.zeros((4, 3)), "tetra", [[0, 1, 2]]), "not an (m, 4) integer array"),
    ((np.zeros((4, 3)), "triangle", [[0, 1, 4]]), "point 4 but there are 4 points"),
    ((np.zeros((4, 3)), "triangle", [[0, -1, 2]]), "point -1"),
    ((np.zeros((4, 3)), "triangle", [[0.0, 1.0, 2.0]]), "not an (m, 3) integer array"),
    ((np.zeros((4, 3)), "triangle", [[0, 1, 2], [0, 1]]), "not an (m, 3) integer array"),
    ((np.zeros((4, 3)), "triangle", [[0, 1, 2]], {"f": [[1, 2], [3], [4], [5]]}), "'f' is not an array of numbers"),
])
def test_writer_refuses_malformed_meshes(tmp_path, args, what):
    with pytest.raises(WriteError) as info:
        write_legacy(tmp_path / "x.vtk", *args)
    assert what in one_line(info, "x.vtk")
    assert list(tmp_path.iterdir()) == []


def test_writer_needs_an_existing_folder(tmp_path):
    V, F = icosphere(0)
    with pytest.raises(WriteError, match="does not exist"):
        write_legacy(tmp_path / "missing" / "x.vtk", V, "triangle", F)


# ---------------------------------------------------------------------------
# the reader on hand-written files and on every kind of damage
# ---------------------------------------------------------------------------

BASE = """# vtk DataFile Version 4.2
hand written
ASCII
DATASET UNSTRUCTURED_GRID
POINTS 4 double
0 0 0 1 0 0 0 1 0 0 0 1
CELLS 2 9
3 0 1 2
4 0 1 2 3
CELL_TYPES 2
5
10
POINT_DATA 4
SCALARS s float
LOOKUP_TABLE default
1 2 3 4
FIELD FieldData 1
v 3 4 double
0 0 0 1 1 1 2 2 2 3 3 3
"""


def write(tmp_path, text, name="bad.vtk"):
    path = tmp_path / name
    path.write_bytes(text.encode("latin-1") if isinstance(text, str) else text)
    return path


def test_hand_written_file(tmp_path):
    V, cells, pd = read_legacy(write(tmp_path, BASE))
    np.testing.assert_array_equal(V, [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    assert cells["triangle"].tolist() == [[0, 1, 2]] and cells["tetra"].tolist() == [[0, 1, 2, 3]]
    assert pd["s"].dtype == np.float32 and pd["s"].tolist() == [1, 2, 3, 4]
    assert pd["v"].shape == (4, 3) and pd["v"][:, 0].tolist() == [0, 1, 2, 3]


def test_hand_written_polydata_with_every_optional_part(tmp_path):
    text = ("# vtk DataFile Version 2.0\n\nascii\nDATASET POLYDATA\nFIELD FieldData 1\nt 1 1 double\n7\n"
            "POINTS 6 float\n0 0 0 1 0 0 1 1 0 0 1 0 2 0 0 2 1 0\nMETADATA\nINFORMATION 0\n\n"
            "VERTICES 2 4\n1 0\n1 5\nPOLYGONS 2 9\n4 0 1 2 3\n3 1 4 5\nCELL_DATA 2\nSCALARS c int\n"
            "LOOKUP_TABLE default\n7 8\nPOINT_DATA 6\nSCALARS two%zz%41 double 2\n" + "1 " * 12 + "\n"
            "LOOKUP_TABLE mine 2\n0 0 0 1 1 1 1 1\nCOLOR_SCALARS rgba 4\n" + "0.5 0 1 0.25 " * 6 + "\n"
            "TENSORS6 t6 float\n" + "1 " * 36 + "\nNULL\n")
    with pytest.raises(ReadError, match="unknown POINT_DATA entry 'NULL'"):
        read_legacy(write(tmp_path, text))
    V, cells, pd = read_legacy(write(tmp_path, text.replace("NULL\n", "")))
    assert cells["triangle"].tolist() == [[0, 1, 2], [0, 2, 3], [1, 4, 5]]  # the quad fanned, vertices skipped
    assert sorted(pd) == ["rgba", "t6", "two%zzA"]  # no LOOKUP_TABLE line needed; '%zz' is no escape
    assert pd["two%zzA"].shape == (6, 2) and pd["t6"].shape == (6, 6)
    assert pd["rgba"].dtype == np.uint8 and pd["rgba"][0].tolist() == [128, 0, 255, 64]  # as VTK: 255 v + 0.5


def test_counts_in_a_binary_file_are_checked_before_reading(tmp_path):
    V, F = icosphere(1)
    write_legacy(tmp_path / "ok.vtk", V, "triangle", F, {"f": np.zeros(len(V))})
    data = (tmp_path / "ok.vtk").read_bytes()
    size = len(data) - data.index(b"POINTS 42 double\n") - len(b"POINTS 42 double\n")
    with pytest.raises(ReadError) as info:
        read_legacy(write(tmp_path, data.replace(b"POINTS 42 ", b"POINTS 2000000000 ")))
    assert f"header claims 2,000,000,000 points (48,000,000,000 bytes) but only {size:,} bytes follow" in one_line(
        info, "bad.vtk")
    with pytest.raises(ReadError, match=r"claims 42 points \(1,008 bytes\) but only 1,000 bytes follow"):
        read_legacy(write(tmp_path, data[:data.index(b"POINTS") + 17 + 1000]))
    with pytest.raises(ReadError, match=r"CELLS 80 cells in 320 values \(1,280 bytes\) but only"):
        read_legacy(write(tmp_path, data[:data.index(b"CELL_TYPES") - 7]))


FIELD_TAIL = "POINT_DATA 4\nSCALARS s float\nLOOKUP_TABLE default\n1 2 3 4\nFIELD FieldData 1\nv 3 4 double\n"


@pytest.mark.parametrize("old, new, message", [
    ("POINTS 4 double", "POINTS 1.5 double", "gives point count '1.5', which is not a whole number"),
    ("POINTS 4 double", "POINTS abc double", "gives point count 'abc', which is not a whole number"),
    ("POINTS 4 double", "POINTS", "lacks its point count"),
    ("POINTS 4 double", "POINTS 4", "lacks its data type"),
    ("POINTS 4 double", "POINTS -4 double", r"point count '-4', outside 0\.\.2147483647"),
    ("POINTS 4 double", "POINTS 2147483648 double", "outside 0..2147483647"),
    ("POINTS 4 double", "POINTS 99999999999999999999999 double", "outside 0..2147483647"),
    ("POINTS 4 double", "POINTS 1000000 double", r"header claims 1,000,000 points \(3,000,000 numbers\) but only"),
    ("POINTS 4 double", "POINTS 4 bit", "type bit, which is not supported; re-export"),
    ("POINTS 4 double", "POINTS 4 quadruple", "unknown data type 'quadruple'"),
    ("0 0 0 1 0 0 0 1 0 0 0 1", "0 0 0 1 0 0 0 1 0 0 0 x", "4 points holds 'x', which is not a number"),
    ("0 0 0 1 0 0 0 1 0 0 0 1", "0 0 0 1 0 0 0 1 0 0 0 1e999", None),  # inf: read; the validator judges it
    ("3 0 1 2\n", "3 0 1 7\n", r"CELLS uses point 7 but there are 4 points \(0\.\.3\)"),
    ("3 0 1 2\n", "3 0 1 -1\n", "CELLS uses point -1"),
    ("3 0 1 2\n", "3 0 1 99999999999999999999999\n", "holds '99999999999999999999999', which is not an integer"),
    ("3 0 1 2\n", "3 0 1 2.5\n", "holds '2.5', which is not an integer"),
    ("3 0 1 2\n", "3 0 1 2147483648\n", "holds 2147483648, which does not fit its type int32"),
    ("3 0 1 2\n", "-3 0 1 2\n", "cell 0 claims -3 points"),
    ("CELLS 2 9", "CELLS 2 8", "the 2 cells take 9 values, not the 8 the header claims"),
    ("CELLS 2 9", "CELLS 3 9", "its values end after 2 of the 3 cells"),
    ("CELLS 2 9", "CELLS 10 9", "claims 10 cells in 9 values"),
    ("CELLS 2 9", "CELLS 2 x9", "gives size 'x9', which is not a whole number"),
    ("CELL_TYPES 2\n5\n10\n", "", "the file has CELLS but no CELL_TYPES"),
    ("CELL_TYPES 2\n5\n10\n", "CELL_TYPES 3\n5\n10\n10\n", "CELL_TYPES gives 3 types for 2 cells"),
    ("5\n10\n", "9\n10\n", r"cell 0 is a quad \(type 9\) with 3 points instead of 4"),
    ("5\n10\n", "5\n5\n", r"cell 1 is a triangle \(type 5\) with 4 points instead of 3"),
    ("5\n10\n", "3\n42\n", None),  # a line and an unknown type: skipped
    (FIELD_TAIL + "0 0 0 1 1 1 2 2 2 3 3 3\n", "POINT_DATA 3\nSCALARS s float\n1 2 3\n",
     "POINT_DATA has 3 values per array for 4 points"),
    ("v 3 4 double", "v 3 3 double", "FIELD array 'v' has 3 tuples for 4 points"),
    ("v 3 4 double", "v 0 4 double", "component count '0', outside 1.."),
    ("FieldData 1", "FieldData 2", "FIELD claims 2 arrays but the file ends after 1"),
    ("SCALARS s float", "SCALARS s", "lacks its name or type"),
    ("SCALARS s float", "BLOB s float", "unknown POINT_DATA entry 'BLOB s float'"),
    ("SCALARS s float", "SCALARS s float 2", "SCALARS 's' holds 'FIELD', which is not a number"),
    ("POINT_DATA 4", "POINT_DATA 4\nPOINTS 4 double", "unknown POINT_DATA entry 'POINTS 4 double'"),
    ("CELLS 2 9", "POINTS 1 float\n0 0 0\nCELLS 2 9", "the file has two POINTS sections"),
    ("DATASET UNSTRUCTURED_GRID", "DATASET STRUCTURED_POINTS", "DATASET STRUCTURED_POINTS is not a mesh"),
    ("DATASET UNSTRUCTURED_GRID", "DATASET POLYDATA", "unknown POLYDATA section 'CELLS 2 9'"),
    ("DATASET UNSTRUCTURED_GRID", "DATASET", "not 'DATASET type'"),
    ("DATASET UNSTRUCTURED_GRID", "DATASET HYPERCUBE", "'HYPERCUBE' is not a legacy VTK dataset type"),
    ("# vtk DataFile Version 4.2", "# vtk DataFile Version 6.0", "version 6.0 is not one this reader knows"),
    ("# vtk DataFile Version 4.2", "# vtk DataFile Version x", "gives no file version"),
    ("# vtk DataFile Version 4.2", "# vtk DataFile Versoin 4.2", r"not a legacy VTK file \(.*\); pass a .vtk file"),
    ("ASCII", "TEXT", "line 3 is 'TEXT', not ASCII or BINARY"),
    ("POINTS 4 double\n0 0 0 1 0 0 0 1 0 0 0 1\n", "", "no POINTS section"),
    ("0 0 0 1 1 1 2 2 2 3 3 3\n", "0 0 0 1 1 1 2 2\n", r"'v' \(12 numbers\) but only 16 bytes follow"),
    ("0 0 0 1 1 1 2 2 2 3 3 3\n", "0 0 0 1 1 1 2 2 2 3 3333\n", r"\(12 numbers\) but the file ends after 11"),
])
def test_malformed_ascii_files(tmp_path, old, new, message):
    assert BASE.count(old) == 1
    path = write(tmp_path, BASE.replace(old, new))
    if message is None:
        V, cells, _ = read_legacy(path)
        assert len(V) == 4
        return
    with pytest.raises(ReadError) as info:
        read_legacy(path)
    msg = one_line(info, path)
    assert re.search(message, msg), msg
    assert re.search(r"; (check|re-export|pass|extract) ", msg), msg  # the problem, then the fix


@pytest.mark.parametrize("data, message", [
    (b"", "the file is empty"), (b"# vtk DataFile Version 4.2\n", "ends after its first line"),
    (b"# vtk DataFile Version 4.2\ntitle\n", "line 3 is ''"), (b"\xff\xfe\x00garbage\n", "not a legacy VTK file"),
])
def test_empty_and_foreign_files(tmp_path, data, message):
    with pytest.raises(ReadError, match=message) as info:
        read_legacy(write(tmp_path, data))
    one_line(info, "bad.vtk")


def test_missing_file(tmp_path):
    with pytest.raises(ReadError, match="no such file"):
        read_legacy(tmp_path / "none.vtk")


# ---------------------------------------------------------------------------
# mutations: every damaged file is read consistently or refused in one line
# ---------------------------------------------------------------------------

LIES = [b"0", b"1", b"-1", b"2", b"7", b"2147483647", b"2147483648", b"9223372036854775808",
        b"99999999999999999999999", b"1.5", b"abc", b"", b"1e3", b"+3"]
HEADER = re.compile(rb"(?m)^[A-Z_]{4,}[ A-Za-z0-9_%.+-]*$")


def mutants(data, rng):
    """(operator, mutated bytes) pairs: truncations, byte flips, lying counts, deleted/duplicated/swapped lines."""
    heads = [m for m in HEADER.finditer(data)]
    for cut in sorted(set(rng.integers(0, len(data), 30).tolist()) | {m.start() for m in heads} |
                      {m.end() + 1 for m in heads}):
        yield "truncate", data[:cut]
    for at, byte in zip(rng.integers(0, len(data), 30), rng.integers(0, 256, 30)):
        yield "flip", data[:at] + bytes([byte]) + data[at + 1:]
    for m in heads:
        for num in re.finditer(rb"[0-9]+", m.group()):
            a, b = m.start() + num.start(), m.start() + num.end()
            value = int(num.group())
            for lie in [str(value + 1).encode(), str(max(value - 1, 0)).encode(), str(10 * value + 3).encode()] + [
                    LIES[i] for i in rng.choice(len(LIES), 5, replace=False)]:
                yield "lie", data[:a] + lie + data[b:]
        yield "delete line", data[:m.start()] + data[m.end() + 1:]
        yield "duplicate line", data[:m.end() + 1] + m.group() + b"\n" + data[m.end() + 1:]
    for m1, m2 in zip(heads, heads[1:]):
        yield "swap lines", data[:m1.start()] + m2.group() + data[m1.end():m2.start()] + m1.group() + data[m2.end():]


def assert_consistent(V, cells, pd):
    n = len(V)
    assert V.dtype == np.float64 and V.shape == (n, 3)
    assert set(cells) <= {"triangle", "tetra"}
    for kind, c in cells.items():
        assert c.dtype == np.int64 and c.ndim == 2 and c.shape[1] == (3 if kind == "triangle" else 4) and len(c)
        assert c.min() >= 0 and c.max() < n
    for arr in pd.values():
        assert isinstance(arr, np.ndarray) and arr.ndim in (1, 2) and len(arr) == n


def mutation_sources(tmp_path):
    pv = pytest.importorskip("pyvista")
    V, F = icosphere(0)
    write_legacy(tmp_path / "ours.vtk", V, "triangle", F, fields_for(len(V), np.random.default_rng(7)))
    meshio.vtk.write(tmp_path / "meshio51a.vtk", meshio_mesh(), fmt_version="5.1", binary=False)
    meshio.vtk.write(tmp_path / "meshio42b.vtk", meshio_mesh(), fmt_version="4.2", binary=True)
    write_vtk(vtk_polydata(), tmp_path / "poly51b.vtk", 51, True)
    write_vtk(vtk_polydata(), tmp_path / "poly42a.vtk", 42, False)
    write_vtk(vtk_grid(), tmp_path / "grid51a.vtk", 51, False)
    write_vtk(vtk_grid(), tmp_path / "grid42b.vtk", 42, True)
    globe = Path(pv.__file__).parent / "examples" / "globe.vtk"
    sources = {p.name: p.read_bytes() for p in sorted(tmp_path.glob("*.vtk"))}
    sources["globe.vtk"] = globe.read_bytes()  # binary POLYDATA 4.2 with a %20 name
    return sources


def test_mutated_files_read_consistently_or_fail_in_one_line(tmp_path):
    sources = mutation_sources(tmp_path)
    for name, data in sources.items():  # every source is valid before it is mutated
        assert_consistent(*read_legacy(write(tmp_path, data, name)))
    rng = np.random.default_rng(2024)
    outcomes = collections.Counter()
    for name, data in sources.items():
        for i, (op, mutant) in enumerate(mutants(data, rng)):
            path = tmp_path / f"mutant{i}.vtk"  # a new file each time: rewriting one is slow on some disks
            path.write_bytes(mutant)
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("error")  # no numpy warning either
                    result = read_legacy(path)
            except ReadError as exc:
                msg = str(exc)
                assert "\n" not in msg and msg.startswith(f"{path.name}: "), (name, op, msg)
                outcomes[op, "ReadError"] += 1
            else:
                assert_consistent(*result)
                outcomes[op, "read"] += 1
            path.unlink()
    total = sum(outcomes.values())
    counts = ", ".join(f"{op} {outcomes[op, 'read']} read / {outcomes[op, 'ReadError']} refused"
                       for op in dict.fromkeys(op for op, _ in outcomes))
    assert total > 1000, f"{total} mutants of {len(sources)} files: {counts}"
    assert all(outcomes[op, "ReadError"] for op in ("truncate", "flip", "lie", "delete line"))
    assert outcomes["flip", "read"] and outcomes["truncate", "read"]
