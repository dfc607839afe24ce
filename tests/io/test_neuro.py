"""GIfTI and FreeSurfer surfaces and per-vertex data, through nibabel (the [neuro] extra)."""

import numpy as np
import pytest
from conftest import run

from manifill.errors import ReadError, SampleError
from manifill.io import read_mesh_file, read_samples
from manifill.surface.reconstruct import reconstruct
from manifill.mesh.shapes import icosphere

nib = pytest.importorskip("nibabel")
from nibabel.freesurfer import write_geometry, write_morph_data  # noqa: E402
from nibabel.gifti import GiftiDataArray, GiftiImage  # noqa: E402


@pytest.fixture
def brain(tmp_path):
    V, F = icosphere(3)
    V = 60.0 * V  # millimetres, as a cortex
    rng = np.random.default_rng(5)
    idx = np.sort(rng.choice(len(V), 40, replace=False))
    sparse = np.full(len(V), np.nan, dtype=np.float32)
    sparse[idx] = (np.sin(V[idx, 0] / 20) + 2).astype(np.float32)
    return dict(V=V, F=F, idx=idx, sparse=sparse, dir=tmp_path)


def gifti_surface(path, V, F, extra=None):
    arrays = [GiftiDataArray(V.astype(np.float32), intent="NIFTI_INTENT_POINTSET"),
              GiftiDataArray(F.astype(np.int32), intent="NIFTI_INTENT_TRIANGLE")]
    for name, a in (extra or {}).items():
        arrays.append(GiftiDataArray(a.astype(np.float32), intent="NIFTI_INTENT_SHAPE", meta={"Name": name}))
    nib.save(GiftiImage(darrays=arrays), str(path))


def test_gifti_surface_and_its_data_arrays(brain):
    path = brain["dir"] / "lh.surf.gii"
    thickness = np.linspace(1, 4, len(brain["V"]))
    gifti_surface(path, brain["V"], brain["F"], {"thickness": thickness})
    m = read_mesh_file(path)
    np.testing.assert_allclose(m.V, brain["V"].astype(np.float32))
    np.testing.assert_array_equal(m.F, brain["F"])
    np.testing.assert_allclose(m.point_data["thickness"], thickness.astype(np.float32))
    assert m.vertex_numbering is None


def test_func_gifti_with_nan_gives_the_measured_vertices_as_samples(brain):
    gii = brain["dir"] / "lh.func.gii"
    nib.save(GiftiImage(darrays=[GiftiDataArray(brain["sparse"], intent="NIFTI_INTENT_NONE",
                                                meta={"Name": "potential"})]), str(gii))
    S = read_samples(gii, brain["V"])
    np.testing.assert_array_equal(S.idx, brain["idx"])
    np.testing.assert_array_equal(S.vals[:, 0], brain["sparse"][brain["idx"]])
    assert S.names == ["potential"]
    r = reconstruct(brain["V"], brain["F"], S.idx, S.vals[:, 0])
    np.testing.assert_allclose(r.values[S.idx], S.vals[:, 0])


def test_freesurfer_surface_morph_and_label(brain):
    d = brain["dir"]
    write_geometry(str(d / "lh.pial"), brain["V"], brain["F"].astype(np.int32))
    m = read_mesh_file(d / "lh.pial")  # no extension: recognised by its magic number
    np.testing.assert_allclose(m.V, brain["V"], rtol=1e-6)
    np.testing.assert_array_equal(m.F, brain["F"])
    write_morph_data(str(d / "lh.thickness"), brain["sparse"])
    S = read_samples(d / "lh.thickness", m.V)
    np.testing.assert_array_equal(S.idx, brain["idx"])
    assert S.names == ["thickness"]
    lines = ["#!ascii label, from subject x vox2ras=TkReg", str(brain["idx"].size)]
    lines += [f"{i} {x:.3f} {y:.3f} {z:.3f} {v:.6f}" for i, (x, y, z), v in
              zip(brain["idx"], brain["V"][brain["idx"]], brain["sparse"][brain["idx"]])]
    (d / "lh.V1.label").write_text("\n".join(lines) + "\n")
    S2 = read_samples(d / "lh.V1.label", m.V)
    np.testing.assert_array_equal(S2.idx, brain["idx"])
    np.testing.assert_allclose(S2.vals[:, 0], brain["sparse"][brain["idx"]], atol=1e-6)


def test_mgh_per_vertex_data(brain):
    img = nib.MGHImage(brain["sparse"].reshape(-1, 1, 1), np.eye(4))
    nib.save(img, str(brain["dir"] / "lh.data.mgh"))
    S = read_samples(brain["dir"] / "lh.data.mgh", brain["V"])
    np.testing.assert_array_equal(S.idx, brain["idx"])


def test_data_of_another_surface_and_mixed_nan_are_refused(brain):
    d = brain["dir"]
    write_morph_data(str(d / "lh.curv"), np.zeros(10, dtype=np.float32))
    with pytest.raises(ReadError, match="10 values but the mesh has 642 vertices") as info:
        read_samples(d / "lh.curv", brain["V"])
    assert "\n" not in str(info.value)
    a, b = brain["sparse"].copy(), brain["sparse"].copy()
    b[brain["idx"][0]] = np.nan
    nib.save(GiftiImage(darrays=[GiftiDataArray(a), GiftiDataArray(b)]), str(d / "two.func.gii"))
    with pytest.raises(SampleError, match="same vertices"):
        read_samples(d / "two.func.gii", brain["V"])
    (d / "lh.white").write_bytes(b"\xff\xff\xfe" + b"created\n\n" + b"\x7f\xff\xff\xff" * 2)
    with pytest.raises(ReadError, match="lh.white.*claims"):
        read_mesh_file(d / "lh.white")


def test_cli_reconstructs_a_freesurfer_surface_from_a_morph_file(brain, capsys):
    d = brain["dir"]
    write_geometry(str(d / "lh.white"), brain["V"], brain["F"].astype(np.int32))
    write_morph_data(str(d / "lh.thickness"), brain["sparse"])
    code, out, err = run(capsys, "reconstruct", d / "lh.white", d / "lh.thickness", "-o", d / "out.vtu")
    assert code == 0, err
    assert "40 samples (1 field(s): thickness)" in out
