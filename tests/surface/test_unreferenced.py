"""Meshes with vertices used by no face (as exporters leave them): left out, NaN there, the numbering kept.

The result on such a mesh equals the result on the mesh without them, vertex for vertex, for every method;
the extra vertices get NaN (value, std, gradient), the report counts them, samples on them are refused with
the reason, and the interpolation map, cross-validation and the command line agree.
"""

import meshio
import numpy as np
import pytest

import manifill
from conftest import icosphere, run
from manifill.errors import SampleError

V0, F0 = icosphere(3)
N0 = len(V0)
IDX0 = np.arange(0, N0, 17)
FIELD = V0[:, 0] + V0[:, 2] ** 2


def _with_strays(where=(0, 300, N0)):
    """The mesh with stray vertices inserted before positions ``where`` of the original numbering."""
    where = np.asarray(where)
    old_to_new = np.arange(N0) + np.searchsorted(where, np.arange(N0), side="right")
    n = N0 + where.size
    V = np.full((n, 3), 9.0)
    V[old_to_new] = V0
    stray = np.setdiff1d(np.arange(n), old_to_new)
    return V, old_to_new[F0], old_to_new, stray


@pytest.mark.parametrize("method", ["gvf-harmonic", "harmonic", "biharmonic", "triharmonic", "rbf", "gp"])
def test_every_method_gives_the_compact_result_and_nan_at_the_strays(method):
    V, F, o2n, stray = _with_strays()
    r = manifill.reconstruct(V, F, o2n[IDX0], FIELD[IDX0], method=method)
    r0 = manifill.reconstruct(V0, F0, IDX0, FIELD[IDX0], method=method)
    assert r.values.shape == (len(V),) and np.isnan(r.values[stray]).all()
    assert np.abs(r.values[o2n] - r0.values).max() <= 1e-12 * np.abs(r0.values).max()
    assert r.report["mesh"]["unreferenced_vertices"] == stray.size
    np.testing.assert_array_equal(r.idx, o2n[r0.idx])
    assert all(np.array_equal(c, o2n[c0]) for c, c0 in zip(r.curves, r0.curves))
    if r.std is not None:
        assert np.isnan(r.std[stray]).all() and np.abs(r.std[o2n] - r0.std).max() <= 1e-10 * r0.std.max()
    g = r.gradient()
    assert np.isnan(g[stray]).all() and np.abs(g[o2n] - r0.gradient()).max() < 1e-9
    assert f"{stray.size} NaN" in repr(r)


def test_positions_map_and_samples_on_strays_are_refused():
    V, F, o2n, stray = _with_strays()
    P = V0[[5, 200]] * 1.001
    r = manifill.reconstruct(V, F, P, [1.0, 2.0], method="biharmonic")
    np.testing.assert_array_equal(r.points.nearest_vertex, o2n[[5, 200]])
    np.testing.assert_allclose(r.at(P), [1.0, 2.0], atol=1e-9)
    with pytest.raises(SampleError, match=f"sit on vertices that no face uses \\(vertex {stray[1]}\\)"):
        manifill.reconstruct(V, F, [o2n[0], stray[1]], [1.0, 2.0])


def test_the_map_and_cross_validation_agree_with_the_compact_mesh():
    V, F, o2n, stray = _with_strays()
    rec = manifill.Reconstructor(V, F, o2n[IDX0], method="gvf-harmonic", curve_values="hermite")
    W = rec.matrix()
    assert W.shape == (len(V), IDX0.size)
    np.testing.assert_allclose((W @ FIELD[IDX0])[o2n], rec.apply(FIELD[IDX0]).values[o2n], atol=1e-12)
    assert W[stray].nnz == 0
    cv = manifill.cross_validate(V, F, o2n[IDX0], FIELD[IDX0], methods=["harmonic", "biharmonic"])
    cv0 = manifill.cross_validate(V0, F0, IDX0, FIELD[IDX0], methods=["harmonic", "biharmonic"])
    assert cv.errors == pytest.approx(cv0.errors, rel=1e-12)


def test_the_command_line_says_how_many_and_writes_nan(tmp_path, capsys):
    V, F, o2n, stray = _with_strays((300,))
    mesh = tmp_path / "m.vtu"
    meshio.write(mesh, meshio.Mesh(V, [("triangle", F)]))
    samples = tmp_path / "s.csv"
    samples.write_text("vertex,t\n" + "".join(f"{o2n[i]},{float(FIELD[i])!r}\n" for i in IDX0))
    code, out, err = run(capsys, "reconstruct", mesh, samples, "-o", tmp_path / "o.vtu")
    assert code == 0, err
    assert "1 vertex is used by no face: left out, NaN in the output" in out
    t = meshio.read(tmp_path / "o.vtu").point_data["t"]
    assert np.isnan(t[stray]).all() and np.isfinite(t[o2n]).all()


def test_the_gps_draws_and_gradient_std_skip_the_strays():
    V, F, o2n, stray = _with_strays()
    r = manifill.reconstruct(V, F, o2n[IDX0], FIELD[IDX0], method="gp", gp={"range": 1.0, "sigma": 1.0})
    r0 = manifill.reconstruct(V0, F0, IDX0, FIELD[IDX0], method="gp", gp={"range": 1.0, "sigma": 1.0})
    D, D0 = r.sample(4, seed=3), r0.sample(4, seed=3)
    assert D.shape == (len(V), 4) and np.isnan(D[stray]).all()
    assert np.abs(D[o2n] - D0).max() < 1e-9 * np.abs(D0).max()  # the same draws as on the clean mesh
    _, s = r.gradient(return_std=True, draws=8)
    assert np.isnan(s[stray]).all() and np.isfinite(s[o2n]).all()
