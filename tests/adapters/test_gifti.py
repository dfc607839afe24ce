"""Fields and time series as GIfTI data (.func.gii), read back by nibabel and nilearn (real objects)."""

import numpy as np
import pytest

try:
    import nibabel as nib
except ImportError:
    pytest.skip("the [neuro] extra (nibabel) is not installed", allow_module_level=True)

import manifill
from conftest import run
from manifill.io import write_values
from manifill.io.stream import reconstruct_series
from manifill.mesh.shapes import icosphere

V, F = icosphere(3)
IDX = np.arange(0, len(V), 11)


def test_a_result_s_fields_are_named_data_arrays(tmp_path):
    vals = np.column_stack([V[IDX, 0], V[IDX, 2] ** 2])
    r = manifill.reconstruct(V, F, IDX, vals, method="biharmonic")
    r.save(tmp_path / "r.func.gii", names=["x", "z2"])
    g = nib.load(tmp_path / "r.func.gii")
    assert [d.meta["Name"] for d in g.darrays] == ["x", "z2"]
    assert all(d.intent == nib.nifti1.intent_codes["NIFTI_INTENT_NONE"] for d in g.darrays)
    assert np.allclose(np.column_stack([d.data for d in g.darrays]), r.values, rtol=1e-6, atol=1e-6)


def test_a_time_series_has_time_series_intent_and_every_step(tmp_path):
    T = 7
    vals = np.column_stack([np.sin(V[IDX, 0] + 0.3 * t) for t in range(T)])
    out = tmp_path / "s.func.gii"
    reconstruct_series(V, F, IDX, vals, out, times=np.arange(T) * 0.004, method="harmonic", chunk=3)
    g = nib.load(out)
    assert len(g.darrays) == T and g.meta["TimeStep"] == "4"
    assert all(d.intent == nib.nifti1.intent_codes["NIFTI_INTENT_TIME_SERIES"] for d in g.darrays)
    want = manifill.reconstruct(V, F, IDX, vals, method="harmonic").values
    assert np.allclose(np.column_stack([d.data for d in g.darrays]), want, atol=1e-6)
    nilearn_surface = pytest.importorskip("nilearn.surface")
    data = nilearn_surface.load_surf_data(str(out))
    assert data.shape == (len(V), T) and np.allclose(data, want, atol=1e-6)
    mesh = nilearn_surface.InMemoryMesh(coordinates=V, faces=F)
    image = nilearn_surface.SurfaceImage(mesh={"left": mesh}, data={"left": str(out)})
    assert image.shape == (len(V), T)


def test_the_command_line_writes_gifti(tmp_path, capsys):
    write = manifill.write_mesh
    write(tmp_path / "m.ply", V, F)
    (tmp_path / "s.csv").write_text("vertex,u\n" + "".join(f"{i},{float(V[i, 0])!r}\n" for i in IDX))
    code, out, err = run(capsys, "reconstruct", tmp_path / "m.ply", tmp_path / "s.csv", "-o", tmp_path / "o.func.gii",
                         "--method", "biharmonic")
    assert code == 0, err
    g = nib.load(tmp_path / "o.func.gii")
    r = manifill.reconstruct(V, F, IDX, V[IDX, 0], method="biharmonic")
    assert g.darrays[0].meta["Name"] == "u" and np.allclose(g.darrays[0].data, r.values, atol=1e-6)
    code, out, err = run(capsys, "reconstruct", tmp_path / "m.ply", tmp_path / "s.csv", "-o", tmp_path / "gp.func.gii",
                         "--method", "gp")
    assert code == 0, err
    assert [d.meta["Name"] for d in nib.load(tmp_path / "gp.func.gii").darrays] == ["u", "u_std"]
    (tmp_path / "two.csv").write_text("vertex,a,b\n" + "".join(f"{i},1.0,2.0\n" for i in IDX))  # two fields
    code, out, err = run(capsys, "reconstruct", tmp_path / "m.ply", tmp_path / "two.csv", "-o", tmp_path / "t.gii")
    assert code == 0, err
    assert [d.meta["Name"] for d in nib.load(tmp_path / "t.gii").darrays] == ["a", "b"]


def test_bad_gifti_writes_are_one_line(tmp_path):
    with pytest.raises(manifill.WriteError, match="names for"):
        write_values(tmp_path / "a.func.gii", np.zeros((5, 2)), names=["one"])
    with pytest.raises(manifill.WriteError, match="does not exist"):
        write_values(tmp_path / "nope" / "a.func.gii", np.zeros(5))


def test_uneven_times_are_kept_step_by_step(tmp_path):
    from manifill.io import read_series_values

    times = np.array([0.0, 0.5, 1.5, 2.0, 4.0])
    vals = np.column_stack([np.cos(V[IDX, 2] * t) for t in times])
    reconstruct_series(V, F, IDX, vals, tmp_path / "u.func.gii", times=times, method="harmonic")
    g = nib.load(tmp_path / "u.func.gii")
    assert "TimeStep" not in g.meta and [float(d.meta["Time"]) for d in g.darrays] == times.tolist()
    t, X = read_series_values(tmp_path / "u.func.gii")
    assert np.array_equal(t, times) and X.shape == (len(V), 5)
