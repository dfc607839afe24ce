"""VTK XML PolyData and ImageData: every encoding VTK writes, checked against VTK's own reading (pyvista)."""

import base64
import ctypes
import ctypes.util
import re
import sys
import tracemalloc
import types
import zlib
from pathlib import Path

import numpy as np
import pytest

from manifill import ReadError, WriteError
from manifill.mesh.shapes import icosphere
from manifill.io.vtkxml_read import read_imagedata, read_polydata
from manifill.io.vtkxml_write import write_imagedata, write_polydata

pv = pytest.importorskip("pyvista")
vtk = pytest.importorskip("vtk")

ODD = "a&b<c>\"d'e"
UNICODE = "température Δu (m/s)"
INT_TYPES = [np.int8, np.uint8, np.int16, np.uint16, np.int32, np.uint32, np.int64, np.uint64]
ALL_TYPES = INT_TYPES + [np.float32, np.float64]


def one_line(info, path):
    msg = str(info.value)
    assert msg and "\n" not in msg and Path(path).name in msg
    return msg


def listing(folder):
    return sorted(p.name for p in Path(folder).iterdir())


def typed_fields(n, seed=0):
    """A field of every VTK numeric type spanning its whole range, a 3-component one and odd names."""
    rng = np.random.default_rng(seed)
    out = {}
    for t in INT_TYPES:
        info = np.iinfo(t)
        a = rng.integers(info.min, info.max, n, dtype=t, endpoint=True)
        a[:2] = info.min, info.max
        out[np.dtype(t).name] = a
    out["float32"] = rng.normal(size=n).astype(np.float32)
    out["float64"] = rng.normal(size=n) * 1e300
    out["vector"] = rng.normal(size=(n, 3))
    out[ODD] = np.arange(n, dtype=np.float64)
    out[UNICODE] = -np.arange(n, dtype=np.int32)
    return out


# ---------------------------------------------------------------------------
# our writer -> our reader and pyvista
# ---------------------------------------------------------------------------


def written_dtype(arr):
    if arr.dtype in (bool, np.uint8):  # masks stay bytes
        return np.uint8
    if np.issubdtype(arr.dtype, np.integer):
        lo, hi = int(arr.min()), int(arr.max())
        return next(t for t in (np.int32, np.int64, np.uint64) if np.iinfo(t).min <= lo and hi <= np.iinfo(t).max)
    return np.float64


def test_polydata_round_trip_and_pyvista_reads_it(tmp_path):
    V, F = icosphere(2)
    data = typed_fields(len(V)) | {"mask": np.arange(len(V)) % 3 == 0, "f16": np.linspace(0, 1, len(V), dtype="f2")}
    path = tmp_path / "m.vtp"
    write_polydata(path, V, F, data)
    assert listing(tmp_path) == ["m.vtp"]
    head = path.read_text(encoding="utf-8")[:400]
    assert 'header_type="UInt64"' in head and 'compressor="vtkZLibDataCompressor"' in head
    V2, F2, d2 = read_polydata(path)
    assert V2.dtype == np.float64 and F2.dtype == np.int64
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(F2, F)
    assert list(d2) == list(data)
    mesh = pv.read(path)
    np.testing.assert_array_equal(mesh.points, V)
    np.testing.assert_array_equal(mesh.regular_faces, F)
    assert sorted(mesh.point_data.keys()) == sorted(data)
    for name, arr in data.items():
        want = arr.astype(written_dtype(arr))
        assert d2[name].dtype == want.dtype and d2[name].shape == arr.shape, name
        np.testing.assert_array_equal(d2[name], want)
        got = np.asarray(mesh.point_data[name])
        assert got.dtype == want.dtype, name
        np.testing.assert_array_equal(got, want)
    # int8 ... int32 and uint8/uint16 fit Int32; int64/uint32 extremes need Int64; uint64 extremes UInt64
    assert d2["uint32"].dtype == np.int64 and d2["uint64"].dtype == np.uint64 and d2["int16"].dtype == np.int32


def test_polydata_several_blocks(tmp_path):
    # a field over 1 MiB is split into several zlib blocks, which VTK and our reader join
    V, F = icosphere(5)  # 10242 vertices
    big = np.random.default_rng(1).normal(size=(len(V), 16))
    write_polydata(tmp_path / "b.vtp", V, F, {"big": big})
    _, _, d = read_polydata(tmp_path / "b.vtp")
    np.testing.assert_array_equal(d["big"], big)
    np.testing.assert_array_equal(pv.read(tmp_path / "b.vtp").point_data["big"], big)


def test_imagedata_round_trip_and_pyvista_reads_it(tmp_path):
    shape = (4, 3, 5)
    n = int(np.prod(shape))
    fields = {k: (v.reshape(shape + v.shape[1:], order="F")) for k, v in typed_fields(n, seed=2).items()}
    path = tmp_path / "g.vti"
    write_imagedata(path, fields, spacing=(0.5, 1.0, 2.5), origin=(1.0, -2.0, 3.0))
    got, h, o = read_imagedata(path)
    assert h.tolist() == [0.5, 1.0, 2.5] and o.tolist() == [1.0, -2.0, 3.0]
    grid = pv.read(path)
    assert tuple(grid.dimensions) == shape
    for name, arr in fields.items():
        want = arr.astype(written_dtype(arr))
        assert got[name].dtype == want.dtype and got[name].shape == arr.shape
        np.testing.assert_array_equal(got[name], want)
        p = arr.shape[3] if arr.ndim == 4 else 1
        np.testing.assert_array_equal(np.asarray(grid.point_data[name]).reshape(n, p),
                                      want.reshape(n, p, order="F"))


def test_imagedata_several_blocks(tmp_path):
    arr = np.random.default_rng(3).normal(size=(60, 50, 45))  # 1.08 MB: two zlib blocks
    write_imagedata(tmp_path / "g.vti", {"a": arr})
    np.testing.assert_array_equal(read_imagedata(tmp_path / "g.vti")[0]["a"], arr)
    np.testing.assert_array_equal(pv.read(tmp_path / "g.vti").point_data["a"], arr.ravel(order="F"))


@pytest.mark.parametrize("name", ["", "a\nb", "tab\there", "nul\x00", "bell\x07", "del\x7f", "\ud800"])
def test_write_rejects_names_xml_cannot_keep(tmp_path, name):
    V, F = icosphere(0)
    with pytest.raises(WriteError) as info:
        write_polydata(tmp_path / "m.vtp", V, F, {name: np.zeros(len(V))})
    assert "\n" not in str(info.value) and "name" in str(info.value)
    with pytest.raises(WriteError):
        write_imagedata(tmp_path / "g.vti", {name: np.zeros((2, 2, 2))})
    assert listing(tmp_path) == []


@pytest.mark.parametrize(
    "V, F, data, words",
    [
        (np.zeros((3, 3)), [[0, 1, 3]], None, "malformed"),
        (np.zeros((3, 4)), [[0, 1, 2]], None, "malformed"),
        (np.eye(3), [[0, 1, 2]], {"u": np.zeros(4)}, "shape (4,)"),
        (np.eye(3), [[0, 1, 2]], {"u": np.zeros((3, 2, 2))}, "shape (3, 2, 2)"),
        (np.eye(3), [[0, 1, 2]], {"u": np.zeros((3, 0))}, "shape (3, 0)"),
        (np.eye(3), [[0, 1, 2]], {"u": np.zeros(3, complex)}, "complex"),
        (np.eye(3), [[0, 1, 2]], {"u": np.array(["a", "b", "c"])}, "<U1"),
        (np.eye(3), [[0, 1, 2]], {1: np.zeros(3), "1": np.ones(3)}, "two fields"),
    ],
)
def test_write_polydata_errors_write_nothing(tmp_path, V, F, data, words):
    with pytest.raises(WriteError) as info:
        write_polydata(tmp_path / "m.vtp", V, F, data)
    assert words in str(info.value) and "\n" not in str(info.value)
    assert listing(tmp_path) == []


def test_failed_write_keeps_the_old_file(tmp_path, monkeypatch):
    V, F = icosphere(0)
    write_polydata(tmp_path / "m.vtp", V, F)
    before = (tmp_path / "m.vtp").read_bytes()

    def full(*args):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(zlib, "compress", full)
    with pytest.raises(WriteError) as info:
        write_polydata(tmp_path / "m.vtp", V * 2, F)
    assert "No space left" in one_line(info, "m.vtp")
    assert (tmp_path / "m.vtp").read_bytes() == before and listing(tmp_path) == ["m.vtp"]
    with pytest.raises(WriteError):
        write_polydata(tmp_path / "missing" / "m.vtp", V, F)


# ---------------------------------------------------------------------------
# files written by VTK -> our reader, compared with VTK's own reading
# ---------------------------------------------------------------------------

MODES = [("ascii", None, "UInt32", "LittleEndian")] + [
    (mode, comp, header, order)
    for mode in ("binary", "appended-raw", "appended-base64")
    for comp in (None, "zlib", "lzma")
    for header in ("UInt32", "UInt64")
    for order in ("LittleEndian", "BigEndian")
]


def vtk_write(obj, path, mode, comp=None, header="UInt32", order="LittleEndian", pieces=None):
    """Write with VTK's own XML writer in the given mode; check that the file says so."""
    writer = vtk.vtkXMLPolyDataWriter() if str(path).endswith(".vtp") else vtk.vtkXMLImageDataWriter()
    if pieces:
        writer.SetInputConnection(obj.GetOutputPort())
        writer.SetNumberOfPieces(pieces)
    else:
        writer.SetInputData(obj)
    writer.SetFileName(str(path))
    {"ascii": writer.SetDataModeToAscii, "binary": writer.SetDataModeToBinary}.get(
        mode, writer.SetDataModeToAppended)()
    writer.SetEncodeAppendedData(mode == "appended-base64")
    {None: writer.SetCompressorTypeToNone, "zlib": writer.SetCompressorTypeToZLib,
     "lzma": writer.SetCompressorTypeToLZMA, "lz4": writer.SetCompressorTypeToLZ4}[comp]()
    (writer.SetHeaderTypeToUInt32 if header == "UInt32" else writer.SetHeaderTypeToUInt64)()
    (writer.SetByteOrderToLittleEndian if order == "LittleEndian" else writer.SetByteOrderToBigEndian)()
    assert writer.Write() == 1
    head = Path(path).read_bytes()[:300].decode("ascii", "replace")
    assert f'header_type="{header}"' in head and f'byte_order="{order}"' in head
    if mode != "ascii":
        assert ('compressor="' in head) == (comp is not None)
    return path


def sphere_with_fields():
    mesh = pv.Sphere(theta_resolution=40, phi_resolution=40)  # 1522 points: "vector" fills two 32 KiB blocks
    for name, arr in typed_fields(mesh.n_points).items():
        if name != ODD:  # VTK's writer puts names in the XML unescaped
            mesh.point_data[name] = arr
    mesh.cell_data["per_cell"] = np.arange(mesh.n_cells)  # not a point field: left out
    return mesh


def assert_same_as_pyvista(path, V, F, data):
    ref = pv.read(path)
    np.testing.assert_array_equal(V, ref.points)
    np.testing.assert_array_equal(F, ref.triangulate().regular_faces)
    assert sorted(data) == sorted(ref.point_data.keys())
    for name in data:
        want = np.asarray(ref.point_data[name])
        assert data[name].dtype == want.dtype and data[name].shape == want.shape, name
        np.testing.assert_array_equal(data[name], want)


@pytest.fixture(scope="module")
def sphere():
    return sphere_with_fields()


@pytest.mark.parametrize("mode, comp, header, order", MODES)
def test_polydata_written_by_vtk(tmp_path, sphere, mode, comp, header, order):
    path = vtk_write(sphere, tmp_path / "s.vtp", mode, comp, header, order)
    V, F, data = read_polydata(path)
    assert F.shape == (sphere.n_cells, 3)
    assert_same_as_pyvista(path, V, F, data)


@pytest.mark.parametrize("binary", [True, False])
def test_polydata_saved_by_pyvista(tmp_path, sphere, binary):
    sphere.save(tmp_path / "s.vtp", binary=binary)
    assert_same_as_pyvista(tmp_path / "s.vtp", *read_polydata(tmp_path / "s.vtp"))


def image_with_fields(dims=(7, 5, 4)):
    img = pv.ImageData(dimensions=dims, spacing=(0.5, 1.0, 2.5), origin=(1.0, -2.0, 3.25))
    for name, arr in typed_fields(img.n_points, seed=4).items():
        if name != ODD:
            img.point_data[name] = arr
    img.cell_data["per_cell"] = np.arange(img.n_cells, dtype=float)
    return img


def assert_image_same_as_pyvista(path, fields, spacing, origin):
    ref = pv.read(path)
    dims = tuple(ref.dimensions)
    np.testing.assert_array_equal(spacing, ref.spacing)
    np.testing.assert_array_equal(origin, ref.points[0])  # the position of voxel (0, 0, 0)
    assert sorted(fields) == sorted(ref.point_data.keys())
    for name, arr in fields.items():
        want = np.asarray(ref.point_data[name])
        assert arr.shape[:3] == dims and arr.dtype == want.dtype, name
        # (i, j, k) indexing of x-fastest points: Fortran order over the first three axes
        np.testing.assert_array_equal(arr.reshape((-1,) + want.shape[1:], order="F"), want)


@pytest.mark.parametrize("mode, comp, header, order", MODES)
def test_imagedata_written_by_vtk(tmp_path, mode, comp, header, order):
    path = vtk_write(image_with_fields(), tmp_path / "g.vti", mode, comp, header, order)
    fields, h, o = read_imagedata(path)
    assert fields["vector"].shape == (7, 5, 4, 3)
    assert_image_same_as_pyvista(path, fields, h, o)


@pytest.mark.parametrize("binary", [True, False])
def test_imagedata_saved_by_pyvista(tmp_path, binary):
    image_with_fields().save(tmp_path / "g.vti", binary=binary)
    assert_image_same_as_pyvista(tmp_path / "g.vti", *read_imagedata(tmp_path / "g.vti"))


def test_imagedata_extent_not_starting_at_zero(tmp_path):
    src = vtk.vtkRTAnalyticSource()
    src.SetWholeExtent(-2, 3, 1, 4, 5, 7)
    src.Update()
    path = vtk_write(src.GetOutput(), tmp_path / "e.vti", "appended-raw", "zlib")
    fields, h, o = read_imagedata(path)
    assert fields["RTData"].shape == (6, 4, 3)
    np.testing.assert_array_equal(o, [-2.0, 1.0, 5.0])
    assert_image_same_as_pyvista(path, fields, h, o)


@pytest.mark.parametrize("mode", ["ascii", "binary", "appended-raw"])
def test_several_pieces(tmp_path, mode):
    src = vtk.vtkSphereSource()
    src.SetThetaResolution(12)
    src.SetPhiResolution(8)
    path = vtk_write(src, tmp_path / "p.vtp", mode, "zlib", pieces=3)
    assert path.read_bytes().count(b"<Piece") == 3
    V, F, data = read_polydata(path)
    assert F.max() >= len(V) - 3  # the indices of later pieces are offset by the earlier pieces' points
    assert_same_as_pyvista(path, V, F, data)
    img = vtk.vtkRTAnalyticSource()
    img.SetWholeExtent(0, 6, 0, 4, 0, 3)
    path = vtk_write(img, tmp_path / "p.vti", mode, "zlib", pieces=3)
    assert path.read_bytes().count(b"<Piece") == 3
    assert_image_same_as_pyvista(path, *read_imagedata(path))


def test_polygons_and_strips_are_triangulated(tmp_path):
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [3, 0.5, 0], [2.5, 1.5, 0], [2, 1, 0],
                    [0, 2, 0], [1, 2, 0.2], [0, 3, 0], [1, 3, 0.5], [0, 4, 0], [1, 4.2, 0.3]], dtype=float)
    polys = [4, 0, 1, 2, 3, 5, 4, 5, 6, 7, 1, 2, 0, 1, 3, 8, 9, 10]  # a quad, a pentagon, a 2-gon, a triangle
    strips = [6, 8, 9, 10, 11, 12, 13, 3, 0, 2, 1]
    mesh = pv.PolyData(pts, faces=polys, strips=strips, lines=[2, 0, 5], verts=[1, 3])
    mesh.save(tmp_path / "t.vtp")
    V, F, _ = read_polydata(tmp_path / "t.vtp")
    ref = mesh.triangulate()  # VTK: ear-cut polygons, strips split keeping orientation
    assert len(F) == ref.n_cells == 2 + 3 + 1 + 4 + 1
    cross = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    rf = ref.regular_faces
    ref_cross = np.cross(V[rf[:, 1]] - V[rf[:, 0]], V[rf[:, 2]] - V[rf[:, 0]])
    # per polygon the vector area (area and orientation) does not depend on how it is triangulated
    np.testing.assert_allclose([cross[:2].sum(0), cross[2:5].sum(0), cross[5]], [ref_cross[:2].sum(0),
                               ref_cross[2:5].sum(0), ref_cross[5]], atol=1e-12)
    np.testing.assert_array_equal(F[6:], rf[6:])  # strips: the same triangles, in the same order
    assert np.all(np.isin(F[6:10].ravel(), [8, 9, 10, 11, 12, 13]))


def test_two_component_points(tmp_path):
    text = ('<VTKFile type="PolyData" version="1.0"><PolyData><Piece NumberOfPoints="3" NumberOfPolys="1">'
            '<Points><DataArray type="Float32" NumberOfComponents="2" format="ascii">0 0 1 0 0 1</DataArray>'
            '</Points><Polys><DataArray type="Int32" Name="connectivity" format="ascii">0 1 2</DataArray>'
            '<DataArray type="Int32" Name="offsets" format="ascii">0 3</DataArray></Polys></Piece></PolyData>'
            '</VTKFile>')
    (tmp_path / "f.vtp").write_text(text)
    V, F, data = read_polydata(tmp_path / "f.vtp")  # offsets with the leading 0 read too
    np.testing.assert_array_equal(V, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    assert F.tolist() == [[0, 1, 2]] and data == {}


def liblz4():
    lib = ctypes.util.find_library("lz4")
    return ctypes.CDLL(lib) if lib else None


def test_lz4(tmp_path, sphere, monkeypatch):
    path = vtk_write(sphere, tmp_path / "s.vtp", "appended-raw", "lz4")
    monkeypatch.setitem(sys.modules, "lz4", None)  # not installed
    with pytest.raises(ReadError) as info:
        read_polydata(path)
    msg = one_line(info, path)
    assert "LZ4" in msg and "pip install lz4" in msg and "zlib" in msg
    lib = liblz4()
    if lib is None:
        pytest.skip("no liblz4 to stand in for the lz4 module")

    class LZ4BlockError(Exception):
        pass

    def decompress(data, uncompressed_size):  # lz4.block.decompress, through the C library
        out = ctypes.create_string_buffer(uncompressed_size)
        got = lib.LZ4_decompress_safe(bytes(data), out, len(data), uncompressed_size)
        if got < 0:
            raise LZ4BlockError("corrupt input")
        return out.raw[:got]

    block = types.SimpleNamespace(decompress=decompress, LZ4BlockError=LZ4BlockError)
    monkeypatch.setitem(sys.modules, "lz4", types.SimpleNamespace(block=block))
    monkeypatch.setitem(sys.modules, "lz4.block", block)
    assert_same_as_pyvista(path, *read_polydata(path))


# ---------------------------------------------------------------------------
# damaged files: one-line ReadErrors naming the file
# ---------------------------------------------------------------------------


def vtp(points='0 0 0 1 0 0 0 1 0', conn="0 1 2", offsets="3", n="3", m="1", header="", fmt="ascii", extra=""):
    return (f'<?xml version="1.0"?>\n<VTKFile type="PolyData" version="1.0" {header}><PolyData>'
            f'<Piece NumberOfPoints="{n}" NumberOfPolys="{m}"><PointData>{extra}</PointData>'
            f'<Points><DataArray type="Float64" NumberOfComponents="3" format="{fmt}">{points}</DataArray></Points>'
            f'<Polys><DataArray type="Int64" Name="connectivity" format="ascii">{conn}</DataArray>'
            f'<DataArray type="Int64" Name="offsets" format="ascii">{offsets}</DataArray></Polys>'
            f'</Piece></PolyData></VTKFile>\n')


def b64(*parts):
    return "".join(base64.b64encode(p).decode() for p in parts)


PTS = np.array([0, 0, 0, 1, 0, 0, 0, 1, 0], dtype="<f8").tobytes()
ZPTS = zlib.compress(PTS)


@pytest.mark.parametrize(
    "text, words",
    [
        ("not xml", "not a readable VTP"),
        (vtp()[:150], "not a readable VTP"),
        ('<VTKFile type="ImageData"><ImageData/></VTKFile>', "not VTK PolyData (the file holds ImageData)"),
        (vtp(n="1e99"), "'1e99' is not an integer"),
        (vtp(n="abc"), "is not an integer"),
        (vtp(n="-3"), "negative"),
        (vtp(n="99999999999999999999999"), "not an integer"),
        (vtp(n="1000000000000"), "has 9 values for 1000000000000 points of 3 components"),
        (vtp(n="4"), "has 9 values for 4 points"),
        (vtp(points="0 0 x"), "not of type Float64"),
        (vtp(conn="0 1 3"), "refers to point 3"),
        (vtp(conn="0 1 -1"), "outside 0.."),
        (vtp(conn="0 1 2 0 2 1", offsets="3 2", m="2"), "not increasing"),
        (vtp(conn="0 1 2", offsets="4"), "not increasing"),
        (vtp(conn="0 1 2", offsets="3 6", m="1"), "has 2 values for 1 cells"),
        (vtp(conn="0 1 2.5"), "not of type Int64"),
        (vtp(conn="0 1", offsets="2"), "holds no triangles"),
        (vtp(fmt="binary", points=b64(np.uint32(72).tobytes() + PTS)[:-8]), "header claims 72 bytes"),
        (vtp(fmt="binary", points=b64(np.uint32(720).tobytes() + PTS)), "header claims 720 bytes"),
        (vtp(fmt="binary", points="AAAA!AAA"), "not valid base64"),
        (vtp(fmt="binary", header='compressor="vtkZLibDataCompressor"',
             points=b64(np.array([1, 72, 72, len(ZPTS)], "<u4").tobytes(), b"\x00\x00" + ZPTS[2:])),
         "not a valid zlib stream"),
        (vtp(fmt="binary", header='compressor="vtkZLibDataCompressor"',
             points=b64(np.array([1, 72, 72, len(ZPTS) + 100], "<u4").tobytes(), ZPTS)), "compressed bytes"),
        (vtp(fmt="binary", header='compressor="vtkZLibDataCompressor"',
             points=b64(np.array([2**31, 72, 72], "<u4").tobytes(), ZPTS)), "2147483648 compressed blocks"),
        (vtp(fmt="binary", header='compressor="vtkZLibDataCompressor"',
             points=b64(np.array([1, 2**31, 0, len(ZPTS)], "<u4").tobytes(), ZPTS)),
         f"from {len(ZPTS)} compressed bytes"),
        (vtp(fmt="binary", header='compressor="vtkZLibDataCompressor"',
             points=b64(np.array([1, 80, 80, len(ZPTS)], "<u4").tobytes(), ZPTS)), "does not decompress to the 80"),
        (vtp(fmt="binary", header='compressor="vtkLZ4DataCompressor"',
             points=b64(np.array([1, 72, 72, 8], "<u4").tobytes(), b"12345678")), "lz4"),
        (vtp(header='compressor="vtkBloscCompressor"'), "compressor 'vtkBloscCompressor' is unknown"),
        (vtp(header='header_type="UInt16"'), "header_type"),
        (vtp(header='byte_order="Middle"'), "byte_order"),
        (vtp(fmt="appended", points=""), "no AppendedData section"),
        (vtp(fmt='appended" offset="99', points="").replace("</VTKFile>", '<AppendedData encoding="raw">_'
                                                             '\x00\x00\x00\x00</AppendedData></VTKFile>'),
         "offset 99 outside the appended data"),
        (vtp(fmt="appended", points="").replace("</VTKFile>", '<AppendedData encoding="raw">_\x48\x00'),
         "not closed"),
        (vtp(extra='<DataArray type="String" Name="s" format="ascii">1 2 3</DataArray>'), "type String"),
        (vtp(extra='<DataArray type="Float32" Name="s" NumberOfComponents="0" format="ascii"></DataArray>'),
         "NumberOfComponents=0"),
    ],
)
def test_read_polydata_errors(tmp_path, monkeypatch, text, words):
    path = tmp_path / "bad.vtp"
    path.write_text(text, encoding="utf-8")
    monkeypatch.setitem(sys.modules, "lz4", None)  # as if not installed
    with pytest.raises(ReadError) as info:
        read_polydata(path)
    assert words in one_line(info, path)


def vti(body, extent="0 1 0 0 0 0", extra=""):
    return (f'<VTKFile type="ImageData" version="1.0" header_type="UInt64"><ImageData WholeExtent="{extent}" '
            f'Origin="0 0 0" Spacing="1 1 1" {extra}><Piece Extent="{extent}"><PointData>{body}</PointData>'
            f'</Piece></ImageData></VTKFile>')


@pytest.mark.parametrize(
    "text, words",
    [
        (vti("", extra='Direction="0 1 0 -1 0 0 0 0 1"'), "Direction that is not the identity"),
        (vti("", extra='Direction="1 0 0"'), "Direction"),
        (vti("", extent="0 -1 0 0 0 0"), "is empty"),
        (vti("").replace('Spacing="1 1 1"', 'Spacing="1 nan 1"'), "finite"),
        (vti('<DataArray type="Float64" Name="x" format="binary">'
             + b64(np.uint64(8 * 10**15).tobytes()) + "</DataArray>", extent="0 99999 0 99999 0 99999"),
         "header claims 8000000000000000 bytes"),
        (vti('<DataArray type="UInt8" Name="x" format="ascii">1 2</DataArray>', extent="0 99999 0 99999 0 99999"),
         "has 2 values for 1000000000000000 points"),
        (vti('<DataArray type="UInt8" Name="x" format="ascii">1 300</DataArray>'), "not of type UInt8"),
    ],
)
def test_read_imagedata_errors(tmp_path, text, words):
    path = tmp_path / "bad.vti"
    path.write_text(text)
    with pytest.raises(ReadError) as info:
        read_imagedata(path)
    assert words in one_line(info, path)


def test_lying_counts_allocate_nothing(tmp_path):
    # a tiny file that claims a trillion points, 2**40 blocks or an exabyte: read without a big allocation
    cases = [
        vtp(n="1000000000000"),
        vtp(fmt="binary", header='compressor="vtkZLibDataCompressor" header_type="UInt64"',
            points=b64(np.array([2**40, 2**40, 0], "<u8").tobytes(), ZPTS)),
        vti('<DataArray type="Float64" Name="x" format="binary">' + b64(np.uint64(2**60).tobytes())
            + "</DataArray>", extent="0 999999 0 999999 0 999999"),
    ]
    tracemalloc.start()
    try:
        for k, text in enumerate(cases):
            path = tmp_path / f"c{k}.{'vti' if 'ImageData' in text else 'vtp'}"
            path.write_text(text)
            with pytest.raises(ReadError):
                (read_imagedata if path.suffix == ".vti" else read_polydata)(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 5e6


def test_imagedata_pieces_must_cover(tmp_path):
    text = vti('<DataArray type="UInt8" Name="x" format="ascii">1 2</DataArray>', extent="0 1 0 0 0 0")
    text = text.replace('WholeExtent="0 1 0 0 0 0"', 'WholeExtent="0 2 0 0 0 0"')
    (tmp_path / "p.vti").write_text(text)
    with pytest.raises(ReadError) as info:
        read_imagedata(tmp_path / "p.vti")
    assert "do not cover" in one_line(info, "p.vti")


def test_missing_file(tmp_path):
    for reader in (read_polydata, read_imagedata):
        with pytest.raises(ReadError) as info:
            reader(tmp_path / "none.vtp")
        assert "no such file" in one_line(info, "none.vtp")


# ---------------------------------------------------------------------------
# seeded mutations of valid files: a consistent read or a one-line ReadError, nothing else
# ---------------------------------------------------------------------------

_B64_RUN = re.compile(rb"[A-Za-z0-9+/=]{12,}")
_NUM_ATTR = re.compile(rb'(\w+)="([^"]*[0-9][^"]*)"')
BAD_NUMBERS = [b"1e99", b"-3", b"abc", b"99999999999999", b"18446744073709551616", b"", b"0", b"2147483648",
               b"nan", b"1 2", b"4611686018427387904", b"7"]


def base_files(folder):
    """Small valid files of each mode."""
    V, F = icosphere(0)
    data = {"u": np.arange(12.0), "k": np.arange(12) - 5, "v": V * 2, "m": np.arange(12) % 2 == 0}
    write_polydata(folder / "ours.vtp", V, F, data)
    files = [folder / "ours.vtp"]
    mesh = pv.PolyData(V, faces=np.column_stack([np.full(len(F), 3), F]))
    for k, v in data.items():
        mesh.point_data[k] = v
    for i, mode in enumerate([("ascii",), ("binary", None), ("appended-raw", "zlib", "UInt64"),
                              ("appended-base64", "lzma", "UInt64", "BigEndian"),
                              ("appended-raw", None, "UInt32", "BigEndian"), ("binary", "zlib", "UInt64")]):
        files.append(vtk_write(mesh, folder / f"vtk{i}.vtp", *mode))
    grid = {"a": np.arange(24.0).reshape(2, 3, 4), "b": np.ones((2, 3, 4, 2), dtype=np.int32)}
    write_imagedata(folder / "ours.vti", grid, spacing=(1, 2, 3))
    files.append(folder / "ours.vti")
    img = pv.ImageData(dimensions=(2, 3, 4))
    img.point_data["a"] = np.arange(24.0)
    img.point_data["b"] = np.ones((24, 2), dtype=np.int32)
    for i, mode in enumerate([("ascii",), ("appended-raw", None, "UInt64"), ("binary", "zlib"),
                              ("appended-base64", "lzma", "UInt32", "BigEndian")]):
        files.append(vtk_write(img, folder / f"vtk{i}.vti", *mode))
    return files


def mutants(data, rng, k=14):
    """(kind, bytes) pairs: truncations, byte flips, bad numbers in attributes, broken base64, broken payloads."""
    out = [("truncate", data[:int(c)]) for c in np.linspace(0, len(data) - 1, k)]
    out += [("truncate", data[:int(rng.integers(len(data)))]) for _ in range(k)]
    for _ in range(2 * k):
        b = bytearray(data)
        for pos in rng.integers(0, len(b), rng.integers(1, 4)):
            b[pos] ^= int(rng.integers(1, 256))
        out.append(("flip", bytes(b)))
    attrs = list(_NUM_ATTR.finditer(data.split(b"<AppendedData")[0]))
    for _ in range(2 * k):
        a = attrs[rng.integers(len(attrs))]
        bad = BAD_NUMBERS[rng.integers(len(BAD_NUMBERS))]
        out.append(("attribute", data[:a.start(2)] + bad + data[a.end(2):]))
    runs = list(_B64_RUN.finditer(data)) if b'encoding="raw"' not in data else []
    for _ in range(k if runs else 0):
        r = runs[rng.integers(len(runs))]
        pos = int(rng.integers(r.start(), r.end()))
        new = [b"", b"!", b"=", b"A", b"/", bytes([data[pos]]) * 2][rng.integers(6)]
        out.append(("base64", data[:pos] + new + data[pos + 1:]))
    if b"<AppendedData" in data:  # flips in the appended payload only (raw bytes or base64 text)
        start = data.index(b"_", data.index(b"<AppendedData")) + 1
        for _ in range(k):
            b = bytearray(data)
            pos = int(rng.integers(start, len(b) - 20))
            b[pos] = (b[pos] + int(rng.integers(1, 255))) % 256 if b'encoding="raw"' in data else \
                b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdef"[int(rng.integers(32))]
            out.append(("payload", bytes(b)))
    return out


def check_consistent(path, result):
    if path.suffix == ".vtp":
        V, F, data = result
        n = len(V)
        assert V.shape == (n, 3) and V.dtype == np.float64 and F.dtype == np.int64 and F.ndim == 2
        assert F.shape[1] == 3 and len(F) > 0 and F.min() >= 0 and F.max() < n
        assert all(a.shape[0] == n and a.ndim in (1, 2) for a in data.values())
    else:
        fields, h, o = result
        shapes = {a.shape[:3] for a in fields.values()}
        assert len(shapes) <= 1 and all(a.ndim in (3, 4) for a in fields.values())
        assert h.shape == (3,) and o.shape == (3,) and np.isfinite(h).all() and np.isfinite(o).all()


def test_mutated_files_fail_cleanly(tmp_path):
    rng = np.random.default_rng(20240601)
    (tmp_path / "src").mkdir()
    counts, escaped = {}, []
    for base in base_files(tmp_path / "src"):
        reader = read_polydata if base.suffix == ".vtp" else read_imagedata
        for i, (kind, data) in enumerate(mutants(base.read_bytes(), rng)):
            path = tmp_path / f"{base.stem}-{kind}-{i}{base.suffix}"
            path.write_bytes(data)
            try:
                result = reader(path)
            except ReadError as exc:
                msg = str(exc)
                if "\n" in msg or not msg.startswith(path.name + ": "):
                    escaped.append((path.name, msg))
                outcome = "ReadError"
            except Exception as exc:  # anything else is the failure this test looks for
                escaped.append((path.name, f"{type(exc).__name__}: {exc}"))
                continue
            else:
                check_consistent(path, result)
                outcome = "read"
            counts[(kind, outcome)] = counts.get((kind, outcome), 0) + 1
            path.unlink()
    print("\nmutants:", {f"{k}/{o}": c for (k, o), c in sorted(counts.items())},
          "total", sum(counts.values()))
    assert not escaped, escaped[:5]
    assert sum(counts.values()) > 500
    assert counts.get(("truncate", "ReadError"), 0) > 100 and counts.get(("flip", "read"), 0) > 10


def test_a_series_cache_writes_the_same_bytes_and_encodes_the_mesh_once(tmp_path, monkeypatch):
    from manifill.io import vtkxml_write
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(2)
    x = np.linspace(0.0, 1.0, len(V))
    mask = x > 0.5
    for i in range(3):
        vtkxml_write.write_unstructured(tmp_path / f"plain{i}.vtu", V, F, {"value": x + i, "Points": mask})
    calls = []
    real = vtkxml_write.zlib.compress
    monkeypatch.setattr(vtkxml_write.zlib, "compress", lambda b, lv: calls.append(len(b)) or real(b, lv))
    cache = {}
    for i in range(3):
        vtkxml_write.write_unstructured(tmp_path / f"cached{i}.vtu", V, F, {"value": x + i, "Points": mask},
                                        cache=cache, constant={"Points"})
    for i in range(3):
        assert (tmp_path / f"cached{i}.vtu").read_bytes() == (tmp_path / f"plain{i}.vtu").read_bytes()
    # first file: value, the field named Points, points, connectivity, offsets, types; then the value alone
    assert len(calls) == 6 + 1 + 1
