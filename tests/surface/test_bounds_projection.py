"""``bounds_mode='project'``: the field without bounds, projected onto them (a clip), for every method.

The projection is the nearest field within the bounds in every norm that weighs vertices separately, so it
equals ``clip`` of the unbounded result to the bit; it changes only the values that left the bounds, and
the report counts them and says how far they went.
"""

import numpy as np
import pytest

import manifill
from conftest import icosphere
from manifill import OptionError, Reconstructor, SampleError

GP = {"range": 0.6, "sigma": 1.0, "noise": 0.0}


def _case(level=3, k=40, seed=0):
    V, F = icosphere(level)
    rng = np.random.default_rng(seed)
    idx = np.sort(rng.choice(len(V), k, replace=False))
    # a step (overshoots for every smooth method) and a smooth field with another range
    vals = np.column_stack([np.sign(V[idx, 0]) * 2.0, 10.0 + V[idx, 1] * V[idx, 2]])
    return V, F, idx, vals


def _extra(method):
    return {"gp": GP} if method == "gp" else {}


@pytest.mark.parametrize("method", ["biharmonic", "triharmonic", "harmonic", "rbf", "gp", "gvf-harmonic"])
def test_projection_is_the_clip_of_the_unbounded_field(method):
    V, F, idx, vals = _case()
    free = manifill.reconstruct(V, F, idx, vals, method=method, check=False, **_extra(method)).values
    r = manifill.reconstruct(V, F, idx, vals, method=method, bounds="samples", bounds_mode="project", check=False,
                             **_extra(method))
    lo, hi = vals.min(axis=0), vals.max(axis=0)
    np.testing.assert_array_equal(r.values, np.clip(free, lo, hi))
    assert (r.values >= lo).all() and (r.values <= hi).all()
    np.testing.assert_allclose(r.values[idx], vals, rtol=0, atol=1e-12 * np.ptp(vals))  # the samples stay exact
    b = r.report["bounds"]
    assert b["mode"] == "project" and b["lo"] == lo.tolist() and b["hi"] == hi.tolist()
    assert b["projected"] == ((free < lo) | (free > hi)).sum(axis=0).tolist()
    over = np.maximum((free - hi).max(axis=0), (lo - free).max(axis=0)).clip(0)
    np.testing.assert_allclose(b["overshoot"], over, rtol=0, atol=0)
    assert r.report["overshoot"] <= 0


def test_smooth_methods_do_overshoot_here():
    """The case above is not vacuous: the biharmonic leaves the range on the step field."""
    V, F, idx, vals = _case()
    r = manifill.reconstruct(V, F, idx, vals, method="biharmonic", bounds="samples", bounds_mode="project")
    assert r.report["bounds"]["projected"][0] > 0 and r.report["bounds"]["overshoot"][0] > 0.1


def test_given_bounds_one_side_open():
    V, F, idx, vals = _case()
    v = vals[:, 0]
    free = manifill.reconstruct(V, F, idx, v, method="biharmonic").values
    r = manifill.reconstruct(V, F, idx, v, method="biharmonic", bounds=(None, 2.0), bounds_mode="project")
    np.testing.assert_array_equal(r.values, np.minimum(free, 2.0))
    assert r.values.min() < -2.0  # the open side is left alone


def test_samples_outside_given_bounds_are_refused():
    V, F, idx, vals = _case()
    with pytest.raises(SampleError):
        manifill.reconstruct(V, F, idx, vals[:, 0], method="biharmonic", bounds=(0.0, 1.0), bounds_mode="project")


def test_points_inside_faces():
    """Samples at positions: the range is the points' values, and the points are still met exactly."""
    V, F = icosphere(3)
    rng = np.random.default_rng(3)
    P = rng.normal(size=(30, 3))
    P /= np.linalg.norm(P, axis=1)[:, None]
    v = np.sign(P[:, 2]) + 0.1 * P[:, 0]
    free = manifill.reconstruct(V, F, P, v, method="biharmonic").values
    r = manifill.reconstruct(V, F, P, v, method="biharmonic", bounds="samples", bounds_mode="project")
    np.testing.assert_array_equal(r.values, np.clip(free, v.min(), v.max()))
    # a point stays exact where its face's corners stayed inside the range; the others move with those corners
    moved = np.abs(r.points.interpolate(r.values) - v)
    b = r.report["bounds"]
    assert b["points_moved"] == int((moved > 1e-9).sum()) > 0
    assert abs(b["points_largest_move"] - moved.max()) < 1e-12 and moved.max() <= max(b["overshoot"])
    clipped = (free < v.min()) | (free > v.max())
    touched = np.array([clipped[F[f]].any() for f in r.points.faces])
    assert np.abs(moved[~touched]).max() < 1e-9 and (moved[touched] > 1e-9).all()


def test_reconstructor_applies_the_prepared_map_then_projects():
    V, F, idx, vals = _case()
    rec = Reconstructor(V, F, idx, method="biharmonic", bounds="samples", bounds_mode="project", check=False)
    plain = Reconstructor(V, F, idx, method="biharmonic", check=False)
    W = plain.matrix()
    for j in range(vals.shape[1]):
        got = rec.apply(vals[:, j]).values
        np.testing.assert_allclose(got, np.clip(W @ vals[:, j], vals[:, j].min(), vals[:, j].max()), atol=1e-12)
    both = rec.apply(vals).values  # many fields: each its own bounds
    np.testing.assert_array_equal(both, np.clip(plain.apply(vals).values, vals.min(axis=0), vals.max(axis=0)))
    assert any("energy" in str(key) for key in rec._prepared)  # the solver was prepared once, before any values


def test_exact_mode_is_the_default_and_differs():
    """``bounds`` alone is the exact minimiser, which moves values that never left the range (the projection
    does not)."""
    V, F, idx, vals = _case()
    v = vals[:, 0]
    exact = manifill.reconstruct(V, F, idx, v, method="biharmonic", bounds="samples").values
    same = manifill.reconstruct(V, F, idx, v, method="biharmonic", bounds="samples", bounds_mode="exact").values
    proj = manifill.reconstruct(V, F, idx, v, method="biharmonic", bounds="samples", bounds_mode="project").values
    np.testing.assert_array_equal(exact, same)
    inside = (proj > v.min()) & (proj < v.max())
    assert np.abs(exact - proj)[inside].max() > 1e-3


def test_uncertainty_with_projection_keeps_the_std():
    V, F, idx, vals = _case()
    r = manifill.reconstruct(V, F, idx, vals[:, 0], method="gp", gp=GP, bounds="samples", bounds_mode="project")
    u = manifill.reconstruct(V, F, idx, vals[:, 0], method="gp", gp=GP)
    np.testing.assert_array_equal(r.std, u.std)
    assert r.values.max() <= 2.0


def test_bad_mode_is_one_line():
    V, F, idx, vals = _case()
    with pytest.raises(OptionError) as e:
        manifill.reconstruct(V, F, idx, vals, method="biharmonic", bounds="samples", bounds_mode="clip")
    assert "bounds_mode" in str(e.value) and "\n" not in str(e.value)


def test_scale_invariance():
    V, F, idx, vals = _case(level=2, k=20)
    a = manifill.reconstruct(V, F, idx, vals, method="biharmonic", bounds="samples", bounds_mode="project").values
    for s in (1e-6, 1e7):
        b = manifill.reconstruct(V * s, F, idx, vals, method="biharmonic", bounds="samples",
                                 bounds_mode="project").values
        np.testing.assert_allclose(a, b, atol=1e-9 * np.ptp(vals))


def test_command_line(tmp_path, capsys):
    from conftest import assert_usage_error, run
    from manifill.io import write_mesh

    V, F, idx, vals = _case(level=2, k=15)
    write_mesh(tmp_path / "m.ply", V, F)
    rows = zip(idx.tolist(), vals[:, 0].tolist())
    (tmp_path / "s.csv").write_text("vertex,value\n" + "".join(f"{i},{v!r}\n" for i, v in rows))
    out = tmp_path / "out.csv"
    code, text, err = run(capsys, "reconstruct", tmp_path / "m.ply", tmp_path / "s.csv", "-o", out, "--method",
                          "biharmonic", "--bounds", "samples", "--bounds-mode", "project", "--verbose")
    assert code == 0, err
    x = np.loadtxt(out, delimiter=",", skiprows=1)[:, 1]
    free = manifill.reconstruct(V, F, idx, vals[:, 0], method="biharmonic").values
    np.testing.assert_allclose(x, np.clip(free, -2.0, 2.0), atol=1e-12)
    assert "bounds: projected" in text
    line = assert_usage_error(*run(capsys, "reconstruct", tmp_path / "m.ply", tmp_path / "s.csv", "-o", out,
                                   "--bounds", "samples", "--bounds-mode", "clip"))
    assert "--bounds-mode" in line
