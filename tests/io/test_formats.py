"""Every mesh format x {manifill, meshio, pyvista}: which readers see which fields, by name and value.

The registry (manifill.io.registry.MESH_FORMATS) says, per format, which common readers show the
named fields; these tests check each claim both ways (a reader listed sees every field,
a reader not listed really does not), so the README's table is measured, not hoped.
"""

import meshio
import numpy as np
import pytest

from manifill.io.formats import find_format
from manifill.errors import MeshError, SampleError, WriteError
from manifill.io import (
    MESH_FORMATS,
    RESERVED_NAMES,
    check_field_names,
    format_note,
    read_mesh_file,
    read_samples,
    stored_names,
    write_mesh,
)
from manifill.mesh.shapes import icosphere

pv = pytest.importorskip("pyvista")

FIELD_FORMATS = sorted(ext for ext, f in MESH_FORMATS.items() if f.write and f.fields)
ODD = "a&b<c>\"d'e"


def fields(n):
    rng = np.random.default_rng(3)
    return {
        "temp": rng.normal(size=n),
        ODD: rng.normal(size=n),
        "velocity": rng.normal(size=(n, 3)),
        "sample_mask": rng.random(n) < 0.2,
        "patch_label": rng.integers(-1, 7, size=n),
    }


def expected_arrays(data, names, ext):
    """What a reader should see: name -> array (PLY splits (n, p) fields into name_0...)."""
    out = {}
    for name, arr in data.items():
        key = names[name]
        arr = np.asarray(arr)
        if arr.ndim == 2 and ext == ".ply":
            out.update({f"{key}_{j}": arr[:, j] for j in range(arr.shape[1])})
        else:
            out[key] = arr
    return out


def assert_same(seen, want):
    assert set(want) <= set(seen), f"missing {set(want) - set(seen)}"
    for key, arr in want.items():
        got = np.asarray(seen[key])
        got = got.reshape(arr.shape)
        if arr.dtype == bool:
            np.testing.assert_array_equal(got.astype(bool), arr)
            assert np.issubdtype(got.dtype, np.integer)
        elif np.issubdtype(arr.dtype, np.integer):
            np.testing.assert_array_equal(got, arr)
            assert np.issubdtype(got.dtype, np.integer), key  # labels are never floats to average
        else:
            np.testing.assert_array_equal(got, arr)  # float64 stored: exact


@pytest.mark.parametrize("ext", FIELD_FORMATS)
def test_every_reader_the_registry_names_sees_every_field(tmp_path, ext):
    V, F = icosphere(2)
    data = fields(len(V))
    path = tmp_path / f"out{ext}"
    names = write_mesh(path, V, F, data)
    want = expected_arrays(data, names, ext)
    fmt = MESH_FORMATS[ext]

    ours = read_mesh_file(path)
    np.testing.assert_array_equal(ours.V, V)
    np.testing.assert_array_equal(ours.F, F)
    assert_same(ours.point_data, want)

    pvmesh = pv.read(path)
    np.testing.assert_allclose(np.asarray(pvmesh.points), V, atol=1e-6)
    if "pyvista" in fmt.seen_by:
        assert_same({k: pvmesh.point_data[k] for k in pvmesh.point_data.keys()}, want)
    else:
        assert not set(want) & set(pvmesh.point_data.keys())  # the claim "pyvista does not see them" holds
        assert "pyvista" in format_note(path)

    if ext == ".vtp":
        assert "meshio" not in fmt.seen_by and "meshio" in format_note(path)
        return
    m = meshio.read(path)
    np.testing.assert_allclose(m.points[:, :3], V, atol=1e-12)
    assert "meshio" in fmt.seen_by
    assert_same(m.point_data, want)


@pytest.mark.parametrize("ext", [".vtu", ".vtp"])
def test_xml_formats_keep_any_printable_name(tmp_path, ext):
    V, F = icosphere(1)
    name = "température (°C) <&> \"q\" 'q'"
    write_mesh(tmp_path / f"o{ext}", V, F, {name: V[:, 0]})
    assert name in pv.read(tmp_path / f"o{ext}").point_data.keys()
    assert name in read_mesh_file(tmp_path / f"o{ext}").point_data


@pytest.mark.parametrize("ext", [".ply", ".vtk"])
def test_word_formats_rename_and_say_so(ext):
    names = stored_names(["temp (K)", "a b", "a_b"], find_format("mesh", "o" + ext))
    assert names["temp (K)"] == "temp__K_"
    assert len(set(names.values())) == 3  # renamed names never collide
    assert all(set(v) <= set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_") for v in names.values())


@pytest.mark.parametrize("bad", ["", "   ", "a\nb", "tab\there", "nul\x00"])
@pytest.mark.parametrize("ext", FIELD_FORMATS)
def test_names_no_format_can_store_are_refused_and_nothing_written(tmp_path, ext, bad):
    V, F = icosphere(1)
    with pytest.raises(WriteError) as info:
        write_mesh(tmp_path / f"o{ext}", V, F, {bad: V[:, 0]})
    assert "\n" not in str(info.value)
    assert list(tmp_path.iterdir()) == []


def test_reserved_mask_names_are_refused_only_when_asked():
    for name in RESERVED_NAMES:
        with pytest.raises(WriteError, match="mask"):
            check_field_names([name], "out.vtu")
        check_field_names([name], masks=False)
    check_field_names(["fixed", "curve", "boundary"])  # the old names are ordinary fields now


def test_vtk_output_is_no_longer_lost_in_vtk_readers(tmp_path):
    # meshio's legacy writer used types VTK 9 rejects (every array lost); this is the regression
    V, F = icosphere(2)
    write_mesh(tmp_path / "o.vtk", V, F, {"m": V[:, 0] > 0, "l": np.arange(len(V)), "t": V[:, 1]})
    assert sorted(pv.read(tmp_path / "o.vtk").point_data.keys()) == ["l", "m", "t"]


# ----------------------------------------------------------------------------- inputs people have


def test_pyvista_globe_legacy_polydata_reads():
    import os

    path = os.path.join(os.path.dirname(pv.__file__), "examples", "globe.vtk")
    m = read_mesh_file(path)
    ref = pv.read(path).triangulate()
    np.testing.assert_allclose(m.V, np.asarray(ref.points), rtol=1e-6)
    assert len(m.F) == ref.n_cells
    np.testing.assert_allclose(pv.PolyData.from_regular_faces(m.V, m.F).area, ref.area, rtol=1e-9)


def test_vtp_written_by_pyvista_reads_with_its_fields(tmp_path):
    V, F = icosphere(2)
    mesh = pv.PolyData.from_regular_faces(V, F)
    mesh.point_data["t"] = V[:, 2]
    mesh.point_data["lab"] = np.arange(len(V), dtype=np.int32)
    mesh.save(tmp_path / "p.vtp")
    m = read_mesh_file(tmp_path / "p.vtp")
    np.testing.assert_array_equal(m.F, F)
    np.testing.assert_array_equal(m.point_data["t"], V[:, 2])
    np.testing.assert_array_equal(m.point_data["lab"], np.arange(len(V)))


def test_stl_refuses_vertex_index_samples_and_takes_positions(tmp_path):
    V, F = icosphere(2)
    write_mesh(tmp_path / "m.stl", V, F)
    mesh = read_mesh_file(tmp_path / "m.stl")
    assert "STL" in mesh.vertex_numbering
    (tmp_path / "s.csv").write_text("vertex,t\n0,1.0\n5,2.0\n")
    with pytest.raises(SampleError, match="STL does not keep vertex numbers.*positions") as info:
        read_samples(tmp_path / "s.csv", mesh.V, vertex_numbering=mesh.vertex_numbering)
    assert "\n" not in str(info.value)
    (tmp_path / "p.csv").write_text("x,y,z,t\n" + "".join(f"{a!r},{b!r},{c!r},{k}.0\n" for k, (a, b, c) in
                                                          enumerate(V[[0, 5]].tolist())))
    S = read_samples(tmp_path / "p.csv", mesh.V, vertex_numbering=mesh.vertex_numbering)
    np.testing.assert_allclose(mesh.V[S.idx], V[[0, 5]], atol=1e-6)  # STL stores float32


@pytest.mark.parametrize("ext", [".ply", ".obj", ".off", ".vtu", ".vtp", ".vtk"])
def test_formats_that_keep_numbering_take_vertex_samples(tmp_path, ext):
    V, F = icosphere(1)
    write_mesh(tmp_path / f"m{ext}", V, F)
    assert read_mesh_file(tmp_path / f"m{ext}").vertex_numbering is None


# ----------------------------------------------------------------------------- mesh objects


def objects(V, F):
    import trimesh

    return {
        "pyvista": pv.PolyData.from_regular_faces(V, F),
        "trimesh": trimesh.Trimesh(V, F, process=False),
        "meshio": meshio.Mesh(V, [("triangle", F)]),
    }


@pytest.mark.parametrize("kind", ["pyvista", "trimesh", "meshio"])
def test_mesh_objects_give_the_array_results(kind):
    import manifill

    V, F = icosphere(3)
    idx = np.arange(0, len(V), 29)
    vals = np.sin(3 * V[idx, 0]) + V[idx, 2]
    obj = objects(V, F)[kind]
    ref = manifill.reconstruct(V, F, idx, vals)
    np.testing.assert_array_equal(manifill.reconstruct(obj, None, idx, vals).values, ref.values)
    np.testing.assert_array_equal(manifill.harmonic(obj, None, idx, vals), manifill.harmonic(V, F, idx, vals))
    np.testing.assert_array_equal(manifill.HarmonicSolver(obj, None, idx).solve(vals),
                                  manifill.harmonic(V, F, idx, vals))
    assert (manifill.laplacian(obj, None) != manifill.laplacian(V, F)).nnz == 0
    assert manifill.mesh_info(obj, None) == manifill.mesh_info(V, F)


def test_results_convert_back_with_fields_and_masks():
    import manifill

    V, F = icosphere(2)
    idx = np.array([0, 7, 40, 90, 130])
    r = manifill.reconstruct(V, F, idx, np.column_stack([V[idx, 0], V[idx, 1]]), method="gvf-harmonic")
    m = r.to_pyvista(["a", "b"])
    np.testing.assert_array_equal(m.regular_faces, F)
    np.testing.assert_array_equal(m.point_data["a"], r.values[:, 0])
    np.testing.assert_array_equal(np.flatnonzero(m.point_data["sample_mask"]), idx)
    np.testing.assert_array_equal(m.point_data["patch_label"], r.components)
    mm = r.to_meshio(["a", "b"])
    np.testing.assert_array_equal(mm.point_data["b"], r.values[:, 1])
    np.testing.assert_array_equal(mm.point_data["curve_mask"].astype(bool), r.on_curve)
    # and what came out goes back in
    np.testing.assert_allclose(manifill.reconstruct(m, None, idx, r.values[idx], method="gvf-harmonic").values,
                               r.values, atol=1e-12)


def test_wrong_objects_name_what_to_pass():
    import manifill

    V, F = icosphere(1)
    quads = pv.Plane(i_resolution=3, j_resolution=3)
    with pytest.raises(MeshError, match=r"triangulate\(\)"):
        manifill.harmonic(quads, None, [0], [1.0])
    padded = pv.PolyData.from_regular_faces(V, F).faces
    with pytest.raises(MeshError, match="regular_faces"):
        manifill.harmonic(V, padded, [0], [1.0])
    with pytest.raises(MeshError, match="F=None"):
        manifill.harmonic(pv.PolyData.from_regular_faces(V, F), F, [0], [1.0])
    with pytest.raises(MeshError, match="F is None"):
        manifill.harmonic(V, None, [0], [1.0])
    with pytest.raises(MeshError, match="no faces"):
        manifill.harmonic(pv.PolyData(V), None, [0], [1.0])
    with pytest.raises(MeshError, match="no triangle cells"):
        manifill.harmonic(meshio.Mesh(V, [("line", [[0, 1]])]), None, [0], [1.0])


# ----------------------------------------------------------------------------- solids


def tet_cube():
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
    T = np.array([[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]])
    return V, T


@pytest.mark.parametrize("ext", [".vtu", ".vtk", ".msh"])
def test_tet_outputs_open_with_their_fields_in_meshio_and_pyvista(tmp_path, ext):
    from manifill.io import read_tets, write_tets

    V, T = tet_cube()
    data = {"temp": V[:, 0] + 2 * V[:, 2], "boundary_mask": np.ones(len(V), bool), "grad": np.tile([1.0, 0, 2], (8, 1))}
    names = write_tets(tmp_path / f"t{ext}", V, T, data)
    V2, T2 = read_tets(tmp_path / f"t{ext}")
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(T2, T)
    for reader in (meshio.read, pv.read):
        m = reader(tmp_path / f"t{ext}")
        pd = m.point_data if reader is meshio.read else {k: m.point_data[k] for k in m.point_data.keys()}
        for name, arr in data.items():
            got = np.asarray(pd[names[name]]).reshape(arr.shape)
            np.testing.assert_array_equal(got.astype(arr.dtype), arr)


def test_vti_output_opens_in_pyvista_with_names_and_voxel_positions(tmp_path):
    from manifill.io import read_vti, write_vti

    field = np.arange(60.0).reshape(3, 4, 5)
    write_vti(tmp_path / "g.vti", {ODD: field, "boundary_mask": field > 30}, spacing=(1, 2, 0.5), origin=(5, 6, 7))
    img = pv.read(tmp_path / "g.vti")
    np.testing.assert_array_equal(np.asarray(img.point_data[ODD]).reshape(5, 4, 3).transpose(2, 1, 0), field)
    np.testing.assert_allclose(np.asarray(img.points[1]) - np.asarray(img.points[0]), [1, 0, 0])
    np.testing.assert_allclose(img.origin, [5, 6, 7])
    fields, h, o = read_vti(tmp_path / "g.vti")
    np.testing.assert_array_equal(fields[ODD], field)
    np.testing.assert_array_equal(fields["boundary_mask"], field > 30)


def test_volume_results_convert_to_pyvista_and_meshio_and_take_objects():
    import manifill

    V, F = icosphere(2)
    idx = np.arange(0, len(V), 9)
    vals = V[idx, 2]
    obj = objects(V, F)["pyvista"]
    r = manifill.reconstruct_volume(obj, None, idx, vals, resolution=16)
    np.testing.assert_array_equal(r.values, manifill.reconstruct_volume(V, F, idx, vals, resolution=16).values)
    img = r.to_pyvista(["z"])
    ijk = np.array([8, 7, 10])
    pid = img.find_closest_point(r.origin + ijk * r.spacing)
    np.testing.assert_allclose(img.points[pid], r.origin + ijk * r.spacing)
    assert img.point_data["z"][pid] == r.values[tuple(ijk)]
    np.testing.assert_array_equal(np.asarray(img.point_data["boundary_mask"]).reshape(r.mask.shape, order="F"),
                                  r.fixed)
    t = manifill.reconstruct_volume(V, F, idx, vals, form="tets")
    ug, m = t.to_pyvista(["z"]), t.to_meshio(["z"])
    np.testing.assert_array_equal(ug.point_data["z"], t.values)
    np.testing.assert_array_equal(m.cells_dict["tetra"], t.TT)
    # a tetrahedral object goes back in, as pyvista's and as meshio's
    for solid in (ug, m):
        np.testing.assert_allclose(manifill.tet_fill(solid, None, np.arange(len(V)), t.values[:len(V)]), t.values,
                                   atol=1e-10)
    with pytest.raises(MeshError, match="no tetrahedra"):
        manifill.tet_fill(obj, None, [0], [1.0])


def test_gmsh_output_prints_nothing(tmp_path, capfd):
    from manifill.io import write_tets

    V, T = tet_cube()
    write_tets(tmp_path / "t.msh", V, T, {"t": V[:, 0]})
    assert capfd.readouterr() == ("", "")
