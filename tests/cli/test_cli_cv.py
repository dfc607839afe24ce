"""``manifill cv MESH SAMPLES``: the cross-validation table and a recommendation; ``--method auto|rbf``."""

import numpy as np
import pytest

from conftest import assert_usage_error, files, run
from manifill import cross_validate
from manifill.io import write_mesh
from manifill.mesh.shapes import icosphere
from manifill.surface.crossval import CANDIDATES


@pytest.fixture
def case(tmp_path):
    V, F = icosphere(3)
    path = tmp_path / "sphere.ply"
    write_mesh(path, V, F)
    idx = np.arange(0, len(V), 13)
    t, u = np.sin(2 * V[idx, 0]), 1.0 + V[idx, 2] - V[idx, 1]  # u is affine in space
    samples = tmp_path / "samples.csv"
    samples.write_text("vertex,t,u\n" + "".join(f"{i},{float(a)!r},{float(b)!r}\n" for i, a, b in zip(idx, t, u)))
    return dict(path=path, samples=samples, V=V, F=F, idx=idx, t=t, u=u, folder=tmp_path)


def test_cv_prints_every_candidate_and_a_recommendation(capsys, case):
    before = files(case["folder"])
    code, out, err = run(capsys, "cv", case["path"], case["samples"], "--folds", "5")
    assert code == 0 and err == ""
    lines = out.splitlines()
    assert lines[0] == f"642 vertices, {case['idx'].size} samples (2 field(s): t, u)"
    assert "5-fold cross-validation" in out
    ranked = [ln for ln in lines if ln[:4].strip() in {str(i) for i in range(1, 10)}]
    assert len(ranked) == len(CANDIDATES)
    rec = [ln for ln in lines if ln.startswith("recommendation: Use method=")]
    assert len(rec) == 1
    # the library's table (but for the seconds) and recommendation
    cv = cross_validate(case["V"], case["F"], case["idx"], np.column_stack([case["t"], case["u"]]), folds=5)
    assert cv.table().splitlines()[0] in lines and rec[0] == f"recommendation: {cv.recommendation}"
    assert [ln[:60] for ln in ranked] == [ln[:60] for ln in cv.table().splitlines()[2:]]
    assert files(case["folder"]) == before  # writes nothing


def test_cv_one_field_chosen_methods_and_leave_one_out(capsys, case):
    code, out, err = run(capsys, "cv", case["path"], case["samples"], "--field", "u", "--folds", "loo",
                         "--methods", "harmonic,biharmonic:bounds=samples,rbf", "--seed", "3")
    assert code == 0, err
    assert "(1 field(s): u)" in out and "leave-one-out" in out
    ranked = [ln.split()[1] for ln in out.splitlines() if ln[:4].strip() in ("1", "2", "3")]
    assert ranked[0] == "rbf" and set(ranked) == {"harmonic", "biharmonic", "rbf"}
    assert "lives in space" in out


def test_cv_seed_changes_the_split(capsys, case):
    outs = []
    for seed in ("0", "0", "1"):
        code, out, _ = run(capsys, "cv", case["path"], case["samples"], "--methods", "harmonic", "--seed", seed,
                           "--folds", "4")
        assert code == 0
        outs.append([ln for ln in out.splitlines() if "harmonic" in ln and ln.lstrip().startswith("1")][0][:40])
    assert outs[0] == outs[1] != outs[2]


@pytest.mark.parametrize("argv,expect", [
    (["--folds", "1"], "--folds '1'"),
    (["--folds", "many"], "--folds 'many'"),
    (["--folds", "100"], "needs at least 100 samples"),
    (["--methods", "fast"], "method='fast'"),
    (["--methods", "harmonic:bounds"], "OPTION=VALUE"),
    (["--methods", "harmonic:colour=red"], "option 'colour'"),
    (["--field", "nope"], "--field 'nope'"),
])
def test_cv_bad_input_is_one_line_and_exit_2(capsys, case, argv, expect):
    line = assert_usage_error(*run(capsys, "cv", case["path"], case["samples"], *argv))
    assert expect in line


def test_cv_missing_file_is_exit_2(capsys, case):
    assert_usage_error(*run(capsys, "cv", case["folder"] / "none.ply", case["samples"]))


@pytest.mark.parametrize("method", ["auto", "rbf"])
def test_reconstruct_takes_auto_and_rbf(capsys, case, method):
    out_path = case["folder"] / "out.csv"
    code, out, err = run(capsys, "reconstruct", case["path"], case["samples"], "--method", method, "-o", out_path, "-q")
    assert code == 0, err
    assert out_path.exists()
    code, out, err = run(capsys, "reconstruct", case["path"], case["samples"], "--method", method, "-o",
                         case["folder"] / "out2.csv")
    assert code == 0, err
    assert ("auto: chose " in out) == (method == "auto")
    assert "thin-plate spline" in out or method == "auto"  # auto says it only when it chose rbf


def test_cv_with_samples_at_positions(capsys, case):
    P = np.random.default_rng(0).normal(size=(30, 3))
    P /= np.linalg.norm(P, axis=1)[:, None]
    path = case["folder"] / "points.csv"
    path.write_text("x,y,z,value\n" + "".join(f"{a!r},{b!r},{c!r},{float(1 + a - c)!r}\n" for a, b, c in P.tolist()))
    code, out, err = run(capsys, "cv", case["path"], path, "--folds", "5", "--methods", "rbf,biharmonic")
    assert code == 0, err
    assert "30 samples" in out and "samples at positions" in out


def test_auto_prints_the_table_before_the_fill_it_chose(capsys, case):
    code, out, err = run(capsys, "reconstruct", case["path"], case["samples"], "--method", "auto", "-o",
                         case["folder"] / "out3.csv")
    assert code == 0, err
    lines = out.splitlines()
    table = next(i for i, line in enumerate(lines) if "cross-validation of" in line)
    chose = next(i for i, line in enumerate(lines) if line.startswith("auto: chose"))
    fill = [i for i, line in enumerate(lines) if line.startswith(("steps 5-6", "rbf:")) or " fill (" in line]
    assert fill and table < chose < min(fill)


def test_auto_says_when_its_choice_leaves_the_samples_range(capsys, case, monkeypatch):
    # the choice overshot by 7.56% of the range and the command line said nothing (cv did)
    from manifill.surface import crossval_result

    monkeypatch.setattr(crossval_result.CrossValidation, "_bounded_advice",
                        lambda self, best, rest: " It overshoots the samples' range by up to 7.56% of it.")
    code, out, err = run(capsys, "reconstruct", case["path"], case["samples"], "--method", "auto", "-o",
                         case["folder"] / "out4.csv")
    assert code == 0, err
    lines = out.splitlines()
    chose = next(i for i, line in enumerate(lines) if line.startswith("auto: chose"))
    assert "overshoots the samples' range by up to 7.56%" in lines[chose + 1]


def test_many_fields_are_summed_up_not_listed(capsys):
    # a wide CSV of 200 time columns written to .npy printed 200 range lines and a line of 200 names
    from types import SimpleNamespace

    from manifill.cli.common import MANY_FIELDS, field_list, print_ranges

    names = [f"t{j}" for j in range(200)]
    X = np.arange(5 * 200, dtype=float).reshape(5, 200)
    print_ranges(X, SimpleNamespace(names=names, vals=X[:3]), "o.npy")
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 3 + 1 + 1 and out[3].startswith("  ... 197 more fields; all 200: range [0, 999]")
    assert field_list(names) == "t0, t1, t2, ..., t199" and field_list(names[:MANY_FIELDS]).count(",") == 7
