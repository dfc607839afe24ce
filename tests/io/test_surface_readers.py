"""manifill's own readers of VTU surfaces, and the checks before meshio's STL and PLY readers.

A valid file reads as meshio (or pyvista) reads it; a damaged one ends in one line that says what is wrong
in the file (where: a line number, an offset, a count), never only a Python exception's name or words.
"""

import meshio
import numpy as np
import pytest

from manifill.errors import ReadError
from manifill.io import read_mesh_file
from manifill.io.vtkxml_read import read_unstructured
from manifill.mesh.shapes import icosphere

V0, F0 = icosphere(1)


def mixed_cells():
    """A square of four points split in ways meshio writes, with cells a surface reader must skip."""
    P = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1], [2, 0, 0]], dtype=float)
    cells = [("triangle", [[0, 1, 2]]), ("quad", [[0, 1, 2, 3]]), ("polygon", [[0, 1, 5, 2, 3]]),
             ("tetra", [[0, 1, 2, 4]]), ("line", [[0, 4]]), ("vertex", [[5]])]
    want = np.array([[0, 1, 2], [0, 1, 2], [0, 2, 3], [0, 1, 5], [0, 5, 2], [0, 2, 3]])
    return P, cells, want


@pytest.mark.parametrize("binary", [False, True])
def test_vtu_surface_cells_read_as_meshio_writes_them(tmp_path, binary):
    P, cells, want = mixed_cells()
    f = tmp_path / "m.vtu"
    meshio.write(f, meshio.Mesh(P, cells, point_data={"u": np.arange(6.0), "g": np.ones((6, 3))}), binary=binary)
    V, F, data = read_unstructured(f)
    assert np.array_equal(V, P) and np.array_equal(F, want)
    assert np.array_equal(data["u"], np.arange(6.0)) and data["g"].shape == (6, 3)
    m = read_mesh_file(f)  # the registry's reader is this one
    assert np.array_equal(m.F, want) and set(m.point_data) == {"u", "g"}


def test_vtu_pixels_and_strips_keep_their_orientation(tmp_path):
    pv = pytest.importorskip("pyvista", reason="pyvista writes pixels and strips (pip install 'manifill[viz]')")
    P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [2, 0, 0], [2, 1, 0]], dtype=float)
    # a pixel's points go in rows (0, 1, 2, 3); the strip 1, 4, 3, 5 covers the square beside it
    grid = pv.UnstructuredGrid(np.array([4, 0, 1, 2, 3, 4, 1, 4, 3, 5]),
                               np.array([pv.CellType.PIXEL, pv.CellType.TRIANGLE_STRIP]), P)
    grid.save(tmp_path / "p.vtu")
    V, F, _ = read_unstructured(tmp_path / "p.vtu")
    e1, e2 = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    normal_z = np.cross(e1, e2)[:, 2]
    assert len(F) == 4 and np.all(normal_z > 0)  # all facing +z, as VTK orients them
    assert 0.5 * normal_z.sum() == pytest.approx(2.0)  # the two unit squares, no overlap


def test_a_vtu_of_solid_cells_only_names_what_it_holds(tmp_path):
    P, cells, _ = mixed_cells()
    f = tmp_path / "t.vtu"
    meshio.write(f, meshio.Mesh(P, cells[3:]))
    with pytest.raises(ReadError, match=r"^t\.vtu: holds no triangles \(cells found: line, tetra, vertex\); "
                                        r"for a solid of tetrahedra use 'manifill volume'; pass a surface mesh$"):
        read_mesh_file(f)


@pytest.mark.parametrize("damage, says", [
    (lambda b: b[:len(b) // 2], r"no element found: line \d+"),  # truncated XML
    (lambda b: b.replace(b'type="UnstructuredGrid"', b'type="PolyData"', 1), r"holds PolyData"),
    (lambda b: b.replace(b'NumberOfCells="80"', b'NumberOfCells="81"', 1), r"'offsets' of Cells has 80 values for "
                                                                          r"81 cells"),
])
def test_a_damaged_vtu_says_what_is_wrong_in_it(tmp_path, damage, says):
    f = tmp_path / "d.vtu"
    meshio.write(f, meshio.Mesh(V0, [("triangle", F0)]), binary=False)
    f.write_bytes(damage(f.read_bytes()))
    with pytest.raises(ReadError, match=rf"^d\.vtu: .*{says}") as exc:
        read_mesh_file(f)
    assert "ReadError" not in str(exc.value) and "\n" not in str(exc.value)


def ascii_stl(tmp_path, name="a.stl"):
    f = tmp_path / name
    meshio.write(f, meshio.Mesh(V0, [("triangle", F0)]), binary=False)
    return f


def test_ascii_stls_as_editors_and_exporters_write_them_read(tmp_path):
    ref = read_mesh_file(ascii_stl(tmp_path))
    text = ascii_stl(tmp_path).read_bytes()
    variants = {
        "bom.stl": b"\xef\xbb\xbf" + text,  # a Windows editor's byte-order mark
        "name.stl": text.replace(b"solid", "solid Bauteil-\u00fc".encode(), 1),  # a name that is not ASCII
        "two.stl": text + text,  # two solids, one after the other
    }
    for name, data in variants.items():
        (tmp_path / name).write_bytes(data)
        m = read_mesh_file(tmp_path / name)
        assert np.allclose(m.V, ref.V) and np.array_equal(m.F, ref.F) or name == "two.stl" and len(m.F) == 2 * len(
            ref.F), name


@pytest.mark.parametrize("damage, says", [
    (lambda t: t.replace(b"vertex", b"vertex abc", 1), r"whose line 4 holds 4 numbers where 3 belong"),
    (lambda t: t.replace(b"vertex ", b"vertex x", 1), r"whose line 4 holds 'x\S*', not a number"),
    (lambda t: t.replace(b"endloop", b"endlop", 1), r"whose line 7 holds 'endlop', not an STL keyword"),
    (lambda t: b"\n".join(t.split(b"\n")[:3] + t.split(b"\n")[4:]),  # the first facet's first vertex deleted
     r"whose line 8 holds 'facet' after 2 vertices of the facet of line 2; 3 belong"),
    (lambda t: t[:t.index(b"endloop", 2000)], r"ends inside the facet of line \d+, after 3 of its vertices\); the "
                                              r"file is truncated"),
    (lambda t: t[:40] + b"\xff\xfe" + t[40:], r"whose line 2 holds bytes that are not text"),
])
def test_a_damaged_ascii_stl_names_the_line(tmp_path, damage, says):
    f = ascii_stl(tmp_path)
    f.write_bytes(damage(f.read_bytes()))
    with pytest.raises(ReadError, match=rf"^a\.stl: not a readable STL mesh \(an ASCII STL.*{says}"):
        read_mesh_file(f)


def test_a_truncated_binary_stl_gives_its_count_and_size(tmp_path):
    f = tmp_path / "b.stl"
    meshio.write(f, meshio.Mesh(V0, [("triangle", F0)]), binary=True)
    f.write_bytes(f.read_bytes()[:-7])
    with pytest.raises(ReadError, match=r"nor binary: its header gives 80 triangles, 4084 bytes, and the file has "
                                        r"4077\); the file is truncated or damaged"):
        read_mesh_file(f)


def test_a_ply_without_its_format_line_says_so(tmp_path):
    f = tmp_path / "p.ply"
    meshio.write(f, meshio.Mesh(V0, [("triangle", F0)]), binary=False)
    f.write_bytes(f.read_bytes().replace(b"format ascii 1.0", b"format ascii 9.9", 1))
    with pytest.raises(ReadError, match=r"^p\.ply: not a readable PLY mesh \(the line 'format ascii 9\.9' after "
                                        r"'ply', where 'format ascii 1\.0'"):
        read_mesh_file(f)


@pytest.mark.parametrize("exc, says", [
    (ValueError("could not convert string to float: 'x1'"), "'x1' is not a number"),
    (ValueError("invalid literal for int() with base 10: 'Infinity'"), "'Infinity' is not an integer"),
    (ValueError("cannot reshape array of size 1276 into shape (320,4)"), "1276 numbers where its counts ask for 320 "
                                                                          "rows of 4"),
    (EOFError(), "it ends early, truncated"),
    (KeyError("dOuble"), "the unknown name 'dOuble'"),
    (ValueError("malformed node or string on line 1: <ast.Name>"), "a header that is not the dictionary an NPY "
                                                                 "array starts with"),
    (OSError(22, "Invalid argument"), "a size or position in it that is impossible"),
])
def test_parser_complaints_are_said_in_the_files_terms(tmp_path, exc, says):
    from manifill.io.files import reading

    with pytest.raises(ReadError, match=rf"^x\.off: not a readable OFF mesh \({says}\); check or re-export"):
        with reading(tmp_path / "x.off", "OFF mesh"):
            raise exc
