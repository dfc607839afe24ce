"""``manifill volume``: Steps 1-8 inside a solid from the command line, run in-process through ``main(argv)``."""

import functools
import importlib.util

import numpy as np
import pytest

import manifill.memory
from conftest import assert_usage_error, files, run
from manifill.mesh.shapes import icosphere
from manifill.solid.tetrahedralize import tetrahedralize
from manifill.solid.tets import boundary_faces
from manifill.io import read_tets, read_vti, write_mesh, write_tets
from manifill.solid.boundary import boundary_voxels
from manifill.solid.voxels import voxel_centres

needs_tetgen = pytest.mark.skipif(importlib.util.find_spec("tetgen") is None, reason="tetgen is not installed")


def field(X):
    return X[:, 0] + 2.0 * X[:, 2]


def vertex_csv(path, idx, vals, names=("temp",)):
    vals = np.asarray(vals, dtype=float).reshape(len(idx), -1)
    path.write_text("vertex," + ",".join(names) + "\n"
                    + "".join(f"{i}," + ",".join(repr(float(v)) for v in row) + "\n" for i, row in zip(idx, vals)))
    return path


def points_csv(path, P, vals):
    path.write_text("x,y,z,temp\n" + "".join(f"{p[0]!r},{p[1]!r},{p[2]!r},{v!r}\n"
                                             for p, v in zip(P.tolist(), np.asarray(vals, float).tolist())))
    return path


@pytest.fixture
def sphere(tmp_path):
    """icosphere(2) as OFF with samples of a linear field at every 4th vertex."""
    V, F = icosphere(2)
    path = tmp_path / "sphere.off"
    write_mesh(path, V, F)
    idx = np.arange(0, len(V), 4)
    samples = vertex_csv(tmp_path / "samples.csv", idx, field(V[idx]))
    return dict(path=path, V=V, F=F, idx=idx, samples=samples)


@functools.lru_cache(maxsize=None)
def _ball():
    return tetrahedralize(*icosphere(2))


@pytest.fixture
def tet_ball(tmp_path):
    TV, TT = _ball()
    path = tmp_path / "ball.vtu"
    write_tets(path, TV, TT)
    b = np.unique(boundary_faces(TT))
    inner = np.setdiff1d(np.arange(len(TV)), b)
    idx = b[::4]
    samples = vertex_csv(tmp_path / "samples.csv", idx, field(TV[idx]))
    return dict(path=path, TV=TV, TT=TT, b=b, inner=inner, idx=idx, samples=samples)


def voxel_ball(shape=(14, 15, 13), radius=5.5):
    X = np.indices(shape).reshape(3, -1).T - (np.array(shape) - 1) / 2
    return (np.linalg.norm(X, axis=1) < radius).reshape(shape)


# ---------------------------------------------------------------------------
# closed surfaces
# ---------------------------------------------------------------------------


def test_surface_to_voxels(tmp_path, capsys, sphere):
    out_path = tmp_path / "out.vti"
    code, out, err = run(capsys, "volume", sphere["path"], sphere["samples"], "-o", out_path, "--resolution", "16")
    assert code == 0 and err == ""
    assert "wrote" in out and "voxels: grid (18, 18, 18)" in out
    fields, h, o = read_vti(out_path)
    assert set(fields) == {"temp", "boundary_mask"}
    t, fixed = fields["temp"], fields["boundary_mask"].astype(bool)
    assert t.shape == (18, 18, 18)
    inside = np.isfinite(t)
    assert 0 < inside.sum() < t.size and np.isnan(t[~inside]).all()
    np.testing.assert_array_equal(fixed, boundary_voxels(inside))
    np.testing.assert_allclose(h, 2.0 / 16, rtol=1e-6)
    # the field is linear and sampled on the surface: inside it stays close to x + 2z
    X = voxel_centres(t.shape, h, o, where=inside)
    assert np.abs(t[inside] - field(X)).max() < 0.25 * np.ptp(field(sphere["V"]))
    assert files(tmp_path) == ["out.vti", "samples.csv", "sphere.off"]


def test_surface_to_voxels_npy_and_connectivity(tmp_path, capsys, sphere):
    code, out, err = run(capsys, "volume", sphere["path"], sphere["samples"], "-o", tmp_path / "out.npy",
                         "--resolution", "12", "--connectivity", "26", "--fill-solver", "direct")
    assert code == 0 and err == ""
    t = np.load(tmp_path / "out.npy")
    assert t.shape == (14, 14, 14) and t.dtype == np.float64
    assert np.isnan(t).any() and np.isfinite(t).any()
    assert "connectivity 26" in out and "(direct" in out


@needs_tetgen
def test_surface_to_tets(tmp_path, capsys, sphere):
    out_path = tmp_path / "out.vtu"
    code, out, err = run(capsys, "volume", sphere["path"], sphere["samples"], "-o", out_path, "--form", "tets")
    assert code == 0 and err == ""
    TV, TT = read_tets(out_path)
    V = sphere["V"]
    np.testing.assert_array_equal(TV[:len(V)], V)
    assert len(TV) > len(V)
    import meshio

    data = meshio.read(out_path).point_data
    assert set(data) == {"temp", "boundary_mask", "sample_mask"}
    t = np.asarray(data["temp"]).ravel()
    assert t.shape == (len(TV),) and np.isfinite(t).all()
    np.testing.assert_allclose(t[sphere["idx"]], field(V[sphere["idx"]]), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(np.asarray(data["boundary_mask"]).ravel().astype(bool), np.arange(len(TV)) < len(V))


# ---------------------------------------------------------------------------
# tetrahedral meshes
# ---------------------------------------------------------------------------


@needs_tetgen
def test_tets_to_tets(tmp_path, capsys, tet_ball):
    out_path = tmp_path / "out.vtu"
    code, out, err = run(capsys, "volume", tet_ball["path"], tet_ball["samples"], "-o", out_path)
    assert code == 0 and err == ""
    assert "tetrahedral mesh" in out
    import meshio

    mesh = meshio.read(out_path)
    np.testing.assert_allclose(mesh.points, tet_ball["TV"], rtol=0, atol=0)
    t = np.asarray(mesh.point_data["temp"]).ravel()
    np.testing.assert_allclose(t[tet_ball["idx"]], field(tet_ball["TV"][tet_ball["idx"]]), rtol=0, atol=1e-12)
    assert np.isfinite(t).all()
    boundary = np.asarray(mesh.point_data["boundary_mask"]).ravel().astype(bool)
    np.testing.assert_array_equal(np.flatnonzero(boundary), tet_ball["b"])


@needs_tetgen
def test_tets_with_position_samples_snap_to_the_boundary(tmp_path, capsys, tet_ball):
    TV, b = tet_ball["TV"], tet_ball["b"]
    idx = b[::5]
    P = TV[idx] * 0.97  # just inside: the nearest vertex overall might be an inner one, the boundary is meant
    points_csv(tmp_path / "pts.csv", P, field(TV[idx]))
    code, out, err = run(capsys, "volume", tet_ball["path"], tmp_path / "pts.csv", "-o", tmp_path / "out.vtk")
    assert code == 0 and err == ""
    import meshio

    t = np.asarray(meshio.read(tmp_path / "out.vtk").point_data["temp"]).ravel()
    np.testing.assert_allclose(t[idx], field(TV[idx]), rtol=0, atol=1e-12)


# ---------------------------------------------------------------------------
# voxel masks
# ---------------------------------------------------------------------------


def test_npy_mask_with_position_samples(tmp_path, capsys):
    mask = voxel_ball()
    np.save(tmp_path / "mask.npy", mask)
    h, o = np.array([1.0, 1.0, 2.5]), np.array([10.0, -5.0, 0.5])
    D = boundary_voxels(mask)
    on = np.argwhere(D)[::6]
    P = o + on * h
    vals = 0.3 * P[:, 0] - P[:, 2]
    points_csv(tmp_path / "pts.csv", P, vals)
    out_path = tmp_path / "out.vti"
    code, out, err = run(capsys, "volume", tmp_path / "mask.npy", tmp_path / "pts.csv", "-o", out_path,
                         "--spacing", "1,1,2.5", "--origin", "10,-5,0.5")
    assert code == 0 and err == ""
    assert f"digital surface {int(D.sum()):,} voxels" in out
    fields, h2, o2 = read_vti(out_path)
    np.testing.assert_array_equal(h2, h)
    np.testing.assert_array_equal(o2, o)
    t = fields["temp"]
    assert t.shape == mask.shape
    assert np.isnan(t[~mask]).all() and np.isfinite(t[mask]).all()
    np.testing.assert_allclose(t[tuple(on.T)], vals, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(fields["boundary_mask"].astype(bool), D)


def test_vti_mask_takes_its_spacing(tmp_path, capsys):
    from manifill.io import write_vti

    mask = voxel_ball((10, 11, 12), 4.2)
    write_vti(tmp_path / "seg.vti", {"mask": mask, "noise": np.zeros(mask.shape)}, spacing=(0.5, 0.5, 1.0),
              origin=(1.0, 2.0, 3.0))
    on = np.argwhere(boundary_voxels(mask))
    vertex_csv(tmp_path / "s.csv", np.arange(0, len(on), 5), on[::5, 2] * 1.0)  # vertices: boundary voxels, C order
    code, out, err = run(capsys, "volume", tmp_path / "seg.vti", tmp_path / "s.csv", "-o", tmp_path / "out.vti")
    assert code == 0 and err == ""
    fields, h, o = read_vti(tmp_path / "out.vti")
    np.testing.assert_array_equal(h, [0.5, 0.5, 1.0])
    np.testing.assert_array_equal(o, [1.0, 2.0, 3.0])
    np.testing.assert_allclose(fields["temp"][tuple(on[::5].T)], on[::5, 2], rtol=0, atol=1e-12)


# ---------------------------------------------------------------------------
# bad input: exit 2, one line, no output
# ---------------------------------------------------------------------------


def test_open_surface(tmp_path, capsys, sphere):
    write_mesh(tmp_path / "open.off", sphere["V"], sphere["F"][1:])
    code, out, err = run(capsys, "volume", tmp_path / "open.off", sphere["samples"], "-o", tmp_path / "out.vti",
                         "--resolution", "12")
    msg = assert_usage_error(code, out, err)
    assert "open" in msg and "--allow-open" in msg
    assert not (tmp_path / "out.vti").exists()
    code, out, err = run(capsys, "volume", tmp_path / "open.off", sphere["samples"], "-o", tmp_path / "out.vti",
                         "--resolution", "12", "--allow-open")
    assert code == 0 and (tmp_path / "out.vti").exists()


def test_empty_mask(tmp_path, capsys):
    np.save(tmp_path / "mask.npy", np.zeros((5, 5, 5), dtype=bool))
    points_csv(tmp_path / "pts.csv", np.zeros((1, 3)), [1.0])
    code, out, err = run(capsys, "volume", tmp_path / "mask.npy", tmp_path / "pts.csv", "-o", tmp_path / "out.vti")
    assert "no voxel" in assert_usage_error(code, out, err)
    assert files(tmp_path) == ["mask.npy", "pts.csv"]


@pytest.mark.parametrize("mask", [np.ones((4, 4), dtype=bool), np.full((3, 3, 3), 2)])
def test_bad_mask_file(tmp_path, capsys, mask):
    np.save(tmp_path / "mask.npy", mask)
    points_csv(tmp_path / "pts.csv", np.zeros((1, 3)), [1.0])
    code, out, err = run(capsys, "volume", tmp_path / "mask.npy", tmp_path / "pts.csv", "-o", tmp_path / "out.vti")
    assert "3-D mask of 0 and 1" in assert_usage_error(code, out, err)
    assert not (tmp_path / "out.vti").exists()


@pytest.mark.parametrize("form, output", [("voxels", "out.vtu"), ("voxels", "out.ply"), ("tets", "out.vti"),
                                          ("tets", "out.npy")])
def test_wrong_output_extension_for_the_form(tmp_path, capsys, sphere, form, output):
    code, out, err = run(capsys, "volume", sphere["path"], sphere["samples"], "-o", tmp_path / output,
                         "--form", form, "--resolution", "8")
    msg = assert_usage_error(code, out, err)
    assert f"a {form} result is written as" in msg and out == ""  # refused before any work
    assert not (tmp_path / output).exists()


@needs_tetgen
def test_tet_mesh_to_a_voxel_output(tmp_path, capsys, tet_ball):
    code, out, err = run(capsys, "volume", tet_ball["path"], tet_ball["samples"], "-o", tmp_path / "out.vti")
    assert "a tets result is written as" in assert_usage_error(code, out, err)


def test_mask_to_a_tet_output(tmp_path, capsys):
    np.save(tmp_path / "mask.npy", voxel_ball())
    points_csv(tmp_path / "pts.csv", np.zeros((1, 3)), [1.0])
    code, out, err = run(capsys, "volume", tmp_path / "mask.npy", tmp_path / "pts.csv", "-o", tmp_path / "out.vtu")
    assert "a voxels result is written as" in assert_usage_error(code, out, err)


@pytest.mark.parametrize("output", ["out.vti", "out.vtu"])
@pytest.mark.parametrize("name", ["missing.off", "missing.vtu", "missing.msh", "missing.npy", "missing.vti"])
def test_missing_mesh_file(tmp_path, capsys, sphere, name, output):
    # the missing file is the error, whatever the output (not a guess at its kind from the name)
    code, out, err = run(capsys, "volume", tmp_path / name, sphere["samples"], "-o", tmp_path / output)
    msg = assert_usage_error(code, out, err)
    if name != "missing.off" or output == "out.vti":
        assert msg == f"manifill: error: {tmp_path / name}: no such file"
    assert files(tmp_path) == ["samples.csv", "sphere.off"]


def test_missing_output_folder(tmp_path, capsys, sphere):
    code, out, err = run(capsys, "volume", sphere["path"], sphere["samples"], "-o", tmp_path / "no" / "out.vti")
    assert "does not exist" in assert_usage_error(code, out, err)


@needs_tetgen
def test_sample_inside_a_tet_mesh(tmp_path, capsys, tet_ball):
    inner = int(tet_ball["inner"][0])
    vertex_csv(tmp_path / "bad.csv", [int(tet_ball["b"][0]), inner], [1.0, 2.0])
    code, out, err = run(capsys, "volume", tet_ball["path"], tmp_path / "bad.csv", "-o", tmp_path / "out.vtu")
    msg = assert_usage_error(code, out, err)
    assert "inside the solid" in msg and f"vertex {inner}" in msg
    assert not (tmp_path / "out.vtu").exists()


def test_several_fields_to_npy(tmp_path, capsys, sphere):
    V, idx = sphere["V"], sphere["idx"]
    vertex_csv(tmp_path / "two.csv", idx, np.column_stack([field(V[idx]), V[idx, 1]]), names=("a", "b"))
    code, out, err = run(capsys, "volume", sphere["path"], tmp_path / "two.csv", "-o", tmp_path / "out.npy",
                         "--resolution", "8")
    assert "holds one field" in assert_usage_error(code, out, err)
    assert not (tmp_path / "out.npy").exists()
    code, out, err = run(capsys, "volume", sphere["path"], tmp_path / "two.csv", "-o", tmp_path / "out.vti",
                         "--resolution", "8")
    assert code == 0
    fields, _, _ = read_vti(tmp_path / "out.vti")
    assert set(fields) == {"a", "b", "boundary_mask"}


def test_not_enough_memory(tmp_path, capsys, sphere, monkeypatch):
    monkeypatch.setattr(manifill.memory, "available_bytes", lambda: 10_000)
    code, out, err = run(capsys, "volume", sphere["path"], sphere["samples"], "-o", tmp_path / "out.vti",
                         "--resolution", "12")
    msg = assert_usage_error(code, out, err)
    assert "of memory is available" in msg and "lower the resolution" in msg
    assert not (tmp_path / "out.vti").exists()


@pytest.mark.parametrize("args, words", [
    (["--spacing", "1,2"], "--spacing '1,2' is not three"),
    (["--origin", "a,b,c"], "--origin 'a,b,c' is not three"),
    (["--spacing", "1,0,1"], "spacing"),
    (["--connectivity", "8"], "invalid choice"),
    (["--resolution", "x"], "invalid int"),
])
def test_bad_options(tmp_path, capsys, args, words):
    np.save(tmp_path / "mask.npy", voxel_ball())
    vertex_csv(tmp_path / "s.csv", [0], [1.0])
    code, out, err = run(capsys, "volume", tmp_path / "mask.npy", tmp_path / "s.csv", "-o", tmp_path / "out.vti",
                         *args)
    assert words in assert_usage_error(code, out, err)
    assert not (tmp_path / "out.vti").exists()


# ---------------------------------------------------------------------------
# options reach the library as given (never renamed or dropped)
# ---------------------------------------------------------------------------


@needs_tetgen
def test_multigrid_is_refused_for_a_tet_mesh_not_renamed(tmp_path, capsys, tet_ball):
    code, out, err = run(capsys, "volume", tet_ball["path"], tet_ball["samples"], "-o", tmp_path / "out.vtu",
                         "--fill-solver", "multigrid")
    msg = assert_usage_error(code, out, err)
    assert "fill_solver='multigrid' is for voxels" in msg and "--fill-solver" in msg
    assert not (tmp_path / "out.vtu").exists()


def test_multigrid_is_refused_for_a_surface_filled_as_tets(tmp_path, capsys, sphere):
    code, out, err = run(capsys, "volume", sphere["path"], sphere["samples"], "-o", tmp_path / "out.vtu",
                         "--form", "tets", "--fill-solver", "multigrid")
    assert "fill_solver='multigrid' is for voxels" in assert_usage_error(code, out, err)
    assert not (tmp_path / "out.vtu").exists()


def test_weights_and_solver_reach_the_mask_reconstruction(tmp_path, capsys, monkeypatch):
    import manifill.solid.reconstruct_volume as rv

    mask = voxel_ball()
    np.save(tmp_path / "mask.npy", mask)
    on = np.argwhere(boundary_voxels(mask))
    vertex_csv(tmp_path / "s.csv", np.arange(0, len(on), 7), on[::7, 0] * 1.0)
    seen = []
    real = rv.reconstruct_volume_mask

    def spy(*args, **kwargs):
        seen.append(kwargs)
        return real(*args, **kwargs)

    monkeypatch.setattr(rv, "reconstruct_volume_mask", spy)
    argv = ["volume", tmp_path / "mask.npy", tmp_path / "s.csv", "-o", tmp_path / "out.vti"]
    # a digital surface has no triangles: cotangent weights are the library's one-line refusal
    msg = assert_usage_error(*run(capsys, *argv, "--weights", "cotan"))
    assert "weights='cotan' needs triangles" in msg and seen[-1]["weights"] == "cotan"
    assert not (tmp_path / "out.vti").exists()
    code, out, err = run(capsys, *argv, "--weights", "uniform", "--solver", "direct", "--fill-solver", "amg")
    assert code == 0 and err == ""
    assert (seen[-1]["weights"], seen[-1]["solver"], seen[-1]["fill_solver"]) == ("uniform", "direct", "amg")
    code, out, err = run(capsys, *argv)  # no --weights: the library's default for a mask
    assert code == 0 and "weights" not in seen[-1] and seen[-1]["solver"] == "auto"


@pytest.mark.parametrize("method", ["gvf-harmonic", "harmonic"])
@pytest.mark.parametrize("kind", ["voxels", "tets", "tet mesh", "mask"])
def test_progress_total_is_the_steps_run(tmp_path, capsys, sphere, bars, method, kind):
    if kind in ("tets", "tet mesh") and importlib.util.find_spec("tetgen") is None:
        pytest.skip("tetgen is not installed")
    if kind in ("voxels", "tets"):
        argv = [sphere["path"], sphere["samples"], "-o", tmp_path / ("o.vti" if kind == "voxels" else "o.vtu"),
                "--form", kind] + (["--resolution", "10"] if kind == "voxels" else [])
    elif kind == "tet mesh":
        TV, TT = _ball()
        write_tets(tmp_path / "ball.vtu", TV, TT)
        b = np.unique(boundary_faces(TT))[::4]
        argv = [tmp_path / "ball.vtu", vertex_csv(tmp_path / "b.csv", b, field(TV[b])), "-o", tmp_path / "o.vtu"]
    else:
        mask = voxel_ball()
        np.save(tmp_path / "mask.npy", mask)
        on = np.argwhere(boundary_voxels(mask))
        argv = [tmp_path / "mask.npy", vertex_csv(tmp_path / "m.csv", np.arange(0, len(on), 7), on[::7, 0] * 1.0),
                "-o", tmp_path / "o.vti"]
    code, out, err = run(capsys, "volume", *argv, "--method", method)
    assert code == 0, err
    (bar,) = bars
    assert bar.total == len(bar.steps) and bar.steps[-1] == "fill"


def test_volume_draws_of_the_solids_gp_are_written_beside_its_std(tmp_path, capsys):
    # --draws N on a voxel solid: <field>_draw1..N in the .vti, through the samples; refused without --method gp
    import pyvista as pv

    from conftest import assert_usage_error, run
    from manifill.io import write_mesh
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(2)
    write_mesh(tmp_path / "m.vtu", V, F)
    idx = np.arange(0, len(V), 11)
    (tmp_path / "s.csv").write_text("vertex,t\n" + "".join(f"{i},{float(V[i, 0])!r}\n" for i in idx))
    code, out, err = run(capsys, "volume", tmp_path / "m.vtu", tmp_path / "s.csv", "-o", tmp_path / "v.vti",
                         "--method", "gp", "--draws", "2", "--resolution", "12")
    assert code == 0, err
    g = pv.read(tmp_path / "v.vti")
    assert {"t", "t_std", "t_draw1", "t_draw2"} <= set(g.point_data.keys())
    d1, d2, t = (np.asarray(g.point_data[k]) for k in ("t_draw1", "t_draw2", "t"))
    inside = np.isfinite(t)
    assert np.isfinite(d1[inside]).all() and not np.allclose(d1[inside], d2[inside])
    line = assert_usage_error(*run(capsys, "volume", tmp_path / "m.vtu", tmp_path / "s.csv", "-o",
                                   tmp_path / "w.vti", "--draws", "2", "--resolution", "12"))
    assert "which the default method has not; add --method gp" in line and not (tmp_path / "w.vti").exists()
