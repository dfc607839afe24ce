"""Solids on disk: VTI and NPY voxel grids, VTU/VTK/MSH tetrahedral meshes, atomic writes."""

import base64
import doctest
import os
from pathlib import Path

import meshio
import numpy as np
import pytest

import manifill.io.solids
from manifill import ReadError, WriteError
from manifill.mesh.shapes import icosphere
from manifill.io.solids import read_mask, read_tets, read_vti, write_tets, write_vti


def one_line(info):
    msg = str(info.value)
    assert msg and "\n" not in msg
    return msg


def listing(folder):
    return sorted(p.name for p in Path(folder).iterdir())


SHAPE = (3, 4, 5)
RNG = np.random.default_rng(0)
FIELDS = {
    "temperature": RNG.normal(size=SHAPE),
    "label": RNG.integers(-5, 5, SHAPE),
    "inside": RNG.random(SHAPE) > 0.5,
    "velocity": RNG.normal(size=SHAPE + (3,)),
    "with nan": np.where(RNG.random(SHAPE) > 0.5, np.nan, 1.5),
}
SPACING, ORIGIN = (0.5, 1.0, 2.5), (1.0, -2.0, 3.25)


def tet_cube():
    """Unit cube split into the 6 Kuhn tets (8 vertices, all on the boundary)."""
    V = np.array([[x, y, z] for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0)])
    T = np.array([[0, 4, 6, 7], [0, 4, 5, 7], [0, 2, 6, 7], [0, 2, 3, 7], [0, 1, 5, 7], [0, 1, 3, 7]])
    return V, T


# ---------------------------------------------------------------------------
# VTI
# ---------------------------------------------------------------------------


def test_vti_round_trip(tmp_path):
    path = tmp_path / "grid.vti"
    write_vti(path, FIELDS, spacing=SPACING, origin=ORIGIN)
    fields, h, o = read_vti(path)
    assert list(fields) == list(FIELDS)
    np.testing.assert_array_equal(h, SPACING)
    np.testing.assert_array_equal(o, ORIGIN)
    for name, arr in FIELDS.items():
        assert fields[name].shape == arr.shape
        np.testing.assert_array_equal(fields[name], arr)  # bit for bit, NaN included
    assert fields["temperature"].dtype == np.float64
    assert np.issubdtype(fields["label"].dtype, np.integer)
    assert fields["inside"].dtype == np.uint8 and set(np.unique(fields["inside"])) <= {0, 1}
    assert listing(tmp_path) == ["grid.vti"]


@pytest.mark.parametrize("shape", [(1, 1, 1), (1, 3, 1), (7, 2, 3)])
def test_vti_round_trip_shapes_and_axis_order(tmp_path, shape):
    # a different value at every voxel, so a transposed or flipped read cannot pass
    arr = np.arange(np.prod(shape), dtype=np.float64).reshape(shape) * 1.5 - 3
    write_vti(tmp_path / "a.vti", {"a": arr})
    fields, h, o = read_vti(tmp_path / "a.vti")
    np.testing.assert_array_equal(fields["a"], arr)
    np.testing.assert_array_equal(h, [1.0, 1.0, 1.0])
    np.testing.assert_array_equal(o, [0.0, 0.0, 0.0])


def test_vti_exact_floats_and_big_integers(tmp_path):
    # repr round-trips every double of the header; integers beyond int32 are kept, not wrapped
    h, o = (0.1, 1 / 3, 2.0**-30), (1e300, -np.pi, 5e-324)
    big = np.full((2, 2, 2), 2**40, dtype=np.int64)
    big[0, 0, 0] = -(2**50)
    write_vti(tmp_path / "b.vti", {"big": big, "small": np.ones((2, 2, 2), dtype=np.int16)}, spacing=h, origin=o)
    fields, h2, o2 = read_vti(tmp_path / "b.vti")
    assert h2.tolist() == list(h) and o2.tolist() == list(o)
    np.testing.assert_array_equal(fields["big"], big)
    np.testing.assert_array_equal(fields["small"], 1)


def test_vti_field_names_are_any_text(tmp_path):
    names = ['température', 'a "quoted" <b> & c', "Δu (m/s)"]
    write_vti(tmp_path / "n.vti", {n: np.full((2, 2, 2), float(k)) for k, n in enumerate(names)})
    fields, _, _ = read_vti(tmp_path / "n.vti")
    assert list(fields) == names
    assert [float(fields[n][0, 0, 0]) for n in names] == [0.0, 1.0, 2.0]


def test_vti_read_by_pyvista(tmp_path):
    pv = pytest.importorskip("pyvista")
    path = tmp_path / "grid.vti"
    write_vti(path, FIELDS, spacing=SPACING, origin=ORIGIN)
    grid = pv.read(path)
    assert tuple(grid.dimensions) == SHAPE
    np.testing.assert_allclose(grid.spacing, SPACING, rtol=0, atol=0)
    np.testing.assert_allclose(grid.origin, ORIGIN, rtol=0, atol=0)
    assert sorted(grid.point_data.keys()) == sorted(FIELDS)
    for name, arr in FIELDS.items():
        got = np.asarray(grid.point_data[name])
        if arr.ndim == 4:  # x fastest, the components of a point together
            want = np.stack([arr[..., j].ravel(order="F") for j in range(arr.shape[3])], axis=1)
        else:
            want = arr.ravel(order="F")
        np.testing.assert_array_equal(got, want)
    # the point positions are the voxel centres origin + (i, j, k) * spacing
    i, j, k = 2, 1, 3
    np.testing.assert_allclose(grid.points[i + SHAPE[0] * (j + SHAPE[1] * k)],
                               np.asarray(ORIGIN) + np.array([i, j, k]) * SPACING, rtol=1e-12)


@pytest.mark.parametrize("binary", [False, True])
def test_vti_written_by_pyvista(tmp_path, binary):
    pv = pytest.importorskip("pyvista")
    arr = np.arange(60.0).reshape(SHAPE) / 7
    img = pv.ImageData(dimensions=SHAPE, spacing=SPACING, origin=ORIGIN)
    img.point_data["a"] = arr.ravel(order="F")
    img.point_data["v"] = np.column_stack([arr.ravel(order="F"), -arr.ravel(order="F")])
    img.cell_data["per_cell"] = np.arange(img.n_cells, dtype=float)  # not a voxel field: left out
    path = tmp_path / "pv.vti"
    try:
        img.save(path, binary=binary, compression=None)
    except TypeError:  # older pyvista: no compression argument
        img.save(path, binary=binary)
    if b'compressor="' in path.read_bytes():
        pytest.skip("this pyvista compresses its VTI files")
    if b'format="appended"' in path.read_bytes():
        with pytest.raises(ReadError) as info:
            read_vti(path)
        assert "appended" in one_line(info)
        return
    fields, h, o = read_vti(path)
    assert sorted(fields) == ["a", "v"]
    np.testing.assert_array_equal(fields["a"], arr)
    np.testing.assert_array_equal(fields["v"], np.stack([arr, -arr], axis=-1))
    np.testing.assert_allclose(h, SPACING)
    np.testing.assert_allclose(o, ORIGIN)


def vti_text(body, header='header_type="UInt64"', extent="0 1 0 0 0 0"):
    return (f'<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" {header}>\n'
            f'<ImageData WholeExtent="{extent}" Origin="0 0 0" Spacing="1 1 1"><Piece Extent="{extent}">'
            f'<PointData>{body}</PointData></Piece></ImageData></VTKFile>\n')


def test_vti_ascii_and_uint32_header(tmp_path):
    (tmp_path / "a.vti").write_text(vti_text('<DataArray type="Int16" Name="s" format="ascii">-3 7</DataArray>'))
    fields, _, _ = read_vti(tmp_path / "a.vti")
    assert fields["s"].dtype == np.int16 and fields["s"].ravel().tolist() == [-3, 7]
    raw = np.array([1.5, -2.5], dtype="<f4").tobytes()
    blob = base64.b64encode(np.uint32(len(raw)).tobytes() + raw).decode()
    (tmp_path / "b.vti").write_text(vti_text(f'<DataArray type="Float32" Name="f" format="binary">{blob}</DataArray>',
                                             header=""))
    fields, _, _ = read_vti(tmp_path / "b.vti")
    assert fields["f"].ravel().tolist() == [1.5, -2.5]


@pytest.mark.parametrize(
    "text, words",
    [
        ("not xml at all", "not a readable VTI"),
        ('<?xml version="1.0"?><VTKFile type="PolyData"><PolyData/></VTKFile>', "not VTK ImageData"),
        (vti_text("").replace('header_type="UInt64"', 'compressor="vtkBloscCompressor"'), "compressor"),
        (vti_text("", extent="0 1 0 0"), "WholeExtent"),
        (vti_text("", extent="0 a 0 0 0 0"), "malformed"),
        (vti_text('<DataArray type="Float64" Name="x" format="appended" offset="0"/>'), "appended"),
        (vti_text('<DataArray type="Float64" Name="x" format="ascii">1 2 3</DataArray>'), "3 values for 2 points"),
        (vti_text('<DataArray type="Bit" Name="x" format="ascii">1 0</DataArray>'), "Bit"),
    ],
)
def test_read_vti_errors(tmp_path, text, words):
    path = tmp_path / "bad.vti"
    path.write_text(text)
    with pytest.raises(ReadError) as info:
        read_vti(path)
    assert words in one_line(info)


def test_read_vti_missing_and_wrong_extension(tmp_path):
    with pytest.raises(ReadError) as info:
        read_vti(tmp_path / "nothing.vti")
    assert "no such file" in one_line(info)
    with pytest.raises(ReadError) as info:
        read_vti(tmp_path / "grid.vtk")
    assert ".vti" in one_line(info)


@pytest.mark.parametrize(
    "path, fields, words",
    [
        ("a.vtr", {"a": np.zeros(SHAPE)}, "cannot write '.vtr'"),
        ("a.vti", {}, "no fields"),
        ("a.vti", {"a": np.zeros((3, 4))}, "shape (3, 4)"),
        ("a.vti", {"a": np.zeros(SHAPE), "b": np.zeros((3, 4, 6))}, "on one grid"),
        ("a.npy", {"a": np.zeros(SHAPE), "b": np.zeros(SHAPE)}, "holds one array"),
        ("missing/a.vti", {"a": np.zeros(SHAPE)}, "does not exist"),
        ("a.vti", {"a": np.zeros(SHAPE), "spacing": (1.0, 2.0)}, "not three numbers"),
        ("a.vti", {"a": np.zeros(SHAPE), "origin": "abc"}, "not three numbers"),
    ],
)
def test_write_vti_errors_write_nothing(tmp_path, path, fields, words):
    fields = dict(fields)
    grid = {k: fields.pop(k) for k in ("spacing", "origin") if k in fields}
    with pytest.raises(WriteError) as info:
        write_vti(tmp_path / path, fields, **grid)
    assert words in one_line(info)
    assert listing(tmp_path) == []


def test_failed_write_leaves_the_old_file(tmp_path, monkeypatch):
    path = tmp_path / "grid.vti"
    write_vti(path, {"a": np.zeros(SHAPE)})
    before = path.read_bytes()

    def broken(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(manifill.io.solids.base64, "b64encode", broken)
    with pytest.raises(WriteError) as info:
        write_vti(path, {"a": np.ones(SHAPE)})
    assert "No space left" in one_line(info)
    assert path.read_bytes() == before and listing(tmp_path) == ["grid.vti"]  # no temporary file left


# ---------------------------------------------------------------------------
# masks
# ---------------------------------------------------------------------------


def test_npy_mask_round_trip(tmp_path):
    mask = RNG.random(SHAPE) > 0.4
    write_vti(tmp_path / "m.npy", {"mask": mask})
    got, h, o = read_mask(tmp_path / "m.npy")
    assert got.dtype == bool and h is None and o is None
    np.testing.assert_array_equal(got, mask)
    values = RNG.normal(size=SHAPE)
    write_vti(tmp_path / "v.npy", {"v": values})
    np.testing.assert_array_equal(np.load(tmp_path / "v.npy"), values)


@pytest.mark.parametrize("dtype", [bool, np.uint8, np.int64, np.float32])
def test_read_mask_npy_of_zeros_and_ones(tmp_path, dtype):
    mask = RNG.random(SHAPE) > 0.5
    np.save(tmp_path / "m.npy", mask.astype(dtype))
    np.testing.assert_array_equal(read_mask(tmp_path / "m.npy")[0], mask)


def test_read_mask_from_vti(tmp_path):
    mask = RNG.random(SHAPE) > 0.5
    write_vti(tmp_path / "one.vti", {"seg": mask}, spacing=SPACING, origin=ORIGIN)
    got, h, o = read_mask(tmp_path / "one.vti")  # the only field
    np.testing.assert_array_equal(got, mask)
    np.testing.assert_array_equal(h, SPACING)
    np.testing.assert_array_equal(o, ORIGIN)
    write_vti(tmp_path / "two.vti", {"t": np.zeros(SHAPE), "mask": mask, "other": ~mask})
    np.testing.assert_array_equal(read_mask(tmp_path / "two.vti")[0], mask)  # the one called mask
    np.testing.assert_array_equal(read_mask(tmp_path / "two.vti", field="other")[0], ~mask)
    write_vti(tmp_path / "three.vti", {"a": mask, "b": mask})
    with pytest.raises(ReadError) as info:
        read_mask(tmp_path / "three.vti")
    assert "--mask-field" in one_line(info) and "a, b" in str(info.value)
    with pytest.raises(ReadError):
        read_mask(tmp_path / "three.vti", field="c")


@pytest.mark.parametrize(
    "arr, words",
    [
        (np.ones((3, 4), dtype=bool), "3-D"),
        (np.ones((2, 3, 4, 1), dtype=bool), "3-D"),
        (np.full(SHAPE, 2), "0 and 1"),
        (np.full(SHAPE, 0.5), "0 and 1"),
        (np.where(np.ones(SHAPE, dtype=bool), np.nan, 1.0), "0 and 1"),
    ],
)
def test_read_mask_errors(tmp_path, arr, words):
    np.save(tmp_path / "m.npy", arr)
    with pytest.raises(ReadError) as info:
        read_mask(tmp_path / "m.npy")
    assert words in one_line(info)


def test_read_mask_unreadable(tmp_path):
    (tmp_path / "m.npy").write_bytes(b"not numpy")
    with pytest.raises(ReadError) as info:
        read_mask(tmp_path / "m.npy")
    assert "not a readable .npy" in one_line(info)
    np.save(tmp_path / "o.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(ReadError):
        read_mask(tmp_path / "o.npy")  # no pickles
    with pytest.raises(ReadError) as info:
        read_mask(tmp_path / "absent.npy")
    assert "no such file" in one_line(info)
    with pytest.raises(ReadError):
        read_mask(tmp_path / "m.txt")


# ---------------------------------------------------------------------------
# tetrahedral meshes
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("ext", [".vtu", ".vtk", ".msh"])
def test_tets_round_trip(tmp_path, ext):
    V, T = tet_cube()
    V = V * [1.0, 2.0, 0.5] + [0.1, 0.2, 0.3]
    data = {"u": np.linspace(0, 1, len(V)), "boundary": np.arange(len(V)) % 2 == 0}
    path = tmp_path / f"cube{ext}"
    write_tets(path, V, T, data)
    V2, T2 = read_tets(path)
    assert V2.dtype == np.float64 and T2.dtype == np.int64 and T2.shape == (6, 4)
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(T2, T)
    mesh = meshio.read(path)
    np.testing.assert_allclose(np.asarray(mesh.point_data["u"]).ravel(), data["u"], rtol=1e-15)
    np.testing.assert_array_equal(np.asarray(mesh.point_data["boundary"]).ravel(), data["boundary"])
    assert listing(tmp_path) == [path.name]


def test_tets_read_by_pyvista(tmp_path):
    pv = pytest.importorskip("pyvista")
    V, T = tet_cube()
    write_tets(tmp_path / "cube.vtu", V, T, {"u": V[:, 0]})
    grid = pv.read(tmp_path / "cube.vtu")
    assert grid.n_points == 8 and grid.n_cells == 6
    np.testing.assert_array_equal(grid.points, V)
    np.testing.assert_array_equal(grid.point_data["u"], V[:, 0])


def test_read_tets_of_a_triangle_mesh(tmp_path):
    V, F = icosphere(1)
    meshio.write(tmp_path / "tri.vtu", meshio.Mesh(V, [("triangle", F)]))
    with pytest.raises(ReadError) as info:
        read_tets(tmp_path / "tri.vtu")
    msg = one_line(info)
    assert "holds no tetrahedra" in msg and "triangle" in msg
    assert not manifill.io.solids.has_tets(tmp_path / "tri.vtu")


def test_read_tets_keeps_only_tets(tmp_path):
    V, T = tet_cube()
    meshio.write(tmp_path / "mixed.vtu", meshio.Mesh(V, [("triangle", T[:, :3]), ("tetra", T)]))
    V2, T2 = read_tets(tmp_path / "mixed.vtu")
    np.testing.assert_array_equal(T2, T)


@pytest.mark.parametrize("name, content", [("bad.vtu", "hello"), ("bad.vtk", "hello"), ("bad.msh", "hello"),
                                           ("empty.vtu", "")])
def test_read_tets_unreadable(tmp_path, name, content):
    (tmp_path / name).write_text(content)
    with pytest.raises(ReadError) as info:
        read_tets(tmp_path / name)
    assert "not a readable" in one_line(info) or "not a legacy VTK file" in one_line(info)
    assert name in one_line(info)


def test_read_tets_missing_and_wrong_extension(tmp_path):
    with pytest.raises(ReadError) as info:
        read_tets(tmp_path / "nothing.vtu")
    assert "no such file" in one_line(info)
    with pytest.raises(ReadError) as info:
        read_tets(tmp_path / "mesh.ply")
    assert "cannot read '.ply'" in one_line(info)


@pytest.mark.parametrize(
    "path, data, words",
    [
        ("a.ply", None, "cannot write '.ply'"),
        ("a.vtu", {"u": np.zeros(3)}, "3 values for 8 vertices"),
        ("a.vtu", {"u": np.zeros((8, 2, 2))}, "shape (8, 2, 2)"),
        ("missing/a.vtu", None, "does not exist"),
    ],
)
def test_write_tets_errors_write_nothing(tmp_path, path, data, words):
    V, T = tet_cube()
    with pytest.raises(WriteError) as info:
        write_tets(tmp_path / path, V, T, data)
    assert words in one_line(info)
    assert listing(tmp_path) == []


def test_failed_tet_write_leaves_nothing(tmp_path, monkeypatch):
    V, T = tet_cube()

    def broken(path, *args, **kwargs):
        Path(path).write_text("half")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(meshio, "write", broken)
    with pytest.raises(WriteError) as info:
        write_tets(tmp_path / "cube.msh", V, T)
    assert "No space left" in one_line(info)
    assert listing(tmp_path) == []


def test_doctests():
    cwd = os.getcwd()
    result = doctest.testmod(manifill.io.solids, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert os.getcwd() == cwd
    assert result.attempted > 0 and result.failed == 0
