"""``manifill reconstruct|volume --method gp``, ``--uncertainty`` and ``--trust``: the std in every output file.

The command line maps its flags to ``manifill.reconstruct(..., method='gp', gp=..., uncertainty=..., trust=...)``;
these tests check what the written files hold against the mathematics of a Gaussian posterior (the std is 0
at noise-free samples and never negative; it scales with the data and ignores a shift, since the constant
mean is estimated and the scale fitted) and against the library itself, and that every bad combination ends
in one line and exit status 2 with nothing written.
"""

import meshio
import numpy as np
import pytest

import manifill
from conftest import assert_usage_error, run
from manifill.io import read_mesh_file, write_mesh
from manifill.mesh.shapes import icosphere


@pytest.fixture(scope="module")
def mesh(tmp_path_factory):
    """icosphere(3) (642 vertices) as PLY, 22 vertex samples of t = x + z^2 and u = 3 t + 1 as CSV."""
    folder = tmp_path_factory.mktemp("gp")
    V, F = icosphere(3)
    path = folder / "sphere.ply"
    write_mesh(path, V, F)
    idx = np.arange(0, len(V), 30)
    t = V[idx, 0] + V[idx, 2] ** 2
    one = folder / "t.csv"
    one.write_text("vertex,t\n" + "".join(f"{i},{float(v)!r}\n" for i, v in zip(idx, t)))
    two = folder / "tu.csv"
    two.write_text("vertex,t,u\n" + "".join(f"{i},{float(v)!r},{float(3 * v + 1)!r}\n" for i, v in zip(idx, t)))
    return dict(path=path, V=V, F=F, idx=idx, t=t, one=one, two=two)


def test_gp_file_holds_the_std_zero_at_the_samples_and_the_trust_mask(tmp_path, capsys, mesh):
    out = tmp_path / "gp.vtu"
    code, text, err = run(capsys, "reconstruct", mesh["path"], mesh["one"], "-o", out, "--method", "gp",
                          "--trust", "0.4")
    assert code == 0, err
    data = meshio.read(out).point_data
    std, trusted = data["t_std"], data["trusted"].astype(bool)
    assert std.min() >= 0 and std.max() > 0
    assert np.abs(std[mesh["idx"]]).max() <= 1e-6 * std.max()  # noise-free samples: no uncertainty there
    threshold = 0.4 * np.std(mesh["t"])  # T times the samples' (population) standard deviation
    np.testing.assert_array_equal(trusted, std <= threshold)
    assert 0 < (~trusted).sum() < len(std)  # the threshold cuts: the test sees both sides
    assert f"trust: {(~trusted).sum():,} of {len(std):,} vertices untrusted" in text
    # the file is the library's result, not a look-alike
    r = manifill.reconstruct(mesh["V"], mesh["F"], mesh["idx"], mesh["t"], method="gp", trust=0.4)
    np.testing.assert_allclose(data["t"], r.values, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(std, r.std, rtol=1e-10, atol=1e-12)
    gp = r.report["gp"]
    assert f"range {gp['range'][0]:.4g} (fitted" in text and f"sigma {gp['sigma'][0]:.4g} (fitted)" in text
    assert f"restricted log-likelihood {gp['loglik']:.5g}" in text and "variance exact" in text
    assert f"std in [0, {std.max():.4g}]" in text


def test_gp_std_scales_with_the_data_and_ignores_a_shift(tmp_path, capsys, mesh):
    """u = 3 t + 1 in one run: the same range, the mean absorbs the 1, the fitted scale the 3 (std_u = 3 std_t)."""
    out = tmp_path / "two.vtu"
    code, text, err = run(capsys, "reconstruct", mesh["path"], mesh["two"], "-o", out, "--method", "gp",
                          "--gp-range", "1.5", "--trust", "0.4", "--untrusted", "nan")
    assert code == 0, err
    data = meshio.read(out).point_data
    np.testing.assert_allclose(data["u_std"], 3 * data["t_std"], rtol=1e-8, atol=1e-12)
    # --untrusted nan: NaN exactly where the vertex is not trusted, in both fields (thresholds scale alike)
    untrusted = ~data["trusted"].astype(bool)
    assert untrusted.any()
    np.testing.assert_array_equal(np.isnan(data["t"]), untrusted)
    np.testing.assert_array_equal(np.isnan(data["u"]), untrusted)
    ok = ~untrusted
    np.testing.assert_allclose(data["u"][ok], 3 * data["t"][ok] + 1, rtol=1e-8, atol=1e-10)
    assert "range 1.5 (given)" in text and "values set NaN there" in text


def test_gp_options_reach_the_library(tmp_path, capsys, mesh):
    """--gp-range/--gp-sigma/--noise/--variance sampled: the same numbers as gp={...} in the library."""
    out = tmp_path / "o.vtu"
    code, text, err = run(capsys, "reconstruct", mesh["path"], mesh["one"], "-o", out, "--method", "gp",
                          "--gp-range", "0.8", "--gp-sigma", "0.5", "--noise", "0.01", "--variance", "sampled",
                          "--variance-samples", "30", "--gp-alpha", "2")
    assert code == 0, err
    gp = {"range": 0.8, "sigma": 0.5, "noise": 0.01, "variance": "sampled", "samples": 30, "alpha": 2}
    r = manifill.reconstruct(mesh["V"], mesh["F"], mesh["idx"], mesh["t"], method="gp", gp=gp)
    data = meshio.read(out).point_data
    np.testing.assert_allclose(data["t"], r.values, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(data["t_std"], r.std, rtol=1e-10, atol=1e-12)
    assert data["t_std"][mesh["idx"]].min() > 0  # with noise the samples are uncertain too
    v = r.report["gp"]["variance"]
    median = f"{v['rel_se_median']:.1%}"
    assert f"variance sampled (30 Monte Carlo samples; its relative standard error: median {median}" in text
    assert "noise 0.01 (given)" in text and "log-likelihood" not in text  # nothing fitted but the closed-form scale


@pytest.mark.parametrize("method", ["harmonic", "biharmonic"])
def test_uncertainty_of_an_energy_method(tmp_path, capsys, mesh, method):
    out = tmp_path / "e.vtp"
    code, text, err = run(capsys, "reconstruct", mesh["path"], mesh["one"], "-o", out, "--method", method,
                          "--uncertainty")
    assert code == 0, err
    got = read_mesh_file(out).point_data
    r = manifill.reconstruct(mesh["V"], mesh["F"], mesh["idx"], mesh["t"], method=method, uncertainty=True)
    np.testing.assert_allclose(got["t_std"], r.std, rtol=1e-10, atol=1e-12)
    assert got["t_std"][mesh["idx"]].max() <= 1e-6 * got["t_std"].max() and got["t_std"].min() >= 0
    assert "trusted" not in got and f"the {method} energy read as an intrinsic Gaussian field" in text


@pytest.mark.parametrize("ext", [".vtu", ".vtp", ".vtk", ".ply"])
def test_every_mesh_format_keeps_the_std_and_the_mask(tmp_path, capsys, mesh, ext):
    out = tmp_path / f"o{ext}"
    code, _, err = run(capsys, "reconstruct", mesh["path"], mesh["one"], "-o", out, "--method", "gp",
                       "--gp-range", "1", "--trust", "0.4")
    assert code == 0, err
    got = read_mesh_file(out).point_data
    r = manifill.reconstruct(mesh["V"], mesh["F"], mesh["idx"], mesh["t"], method="gp", gp={"range": 1.0},
                             trust=0.4)
    np.testing.assert_allclose(got["t_std"], r.std, rtol=1e-6, atol=1e-9)  # PLY may store float32
    np.testing.assert_array_equal(got["trusted"].astype(bool), r.trusted)


def test_value_files_csv_holds_the_std_npy_says_it_does_not(tmp_path, capsys, mesh):
    out = tmp_path / "o.csv"
    code, _, err = run(capsys, "reconstruct", mesh["path"], mesh["one"], "-o", out, "--method", "gp",
                       "--gp-range", "1", "--trust", "0.4")
    assert code == 0, err
    header = out.read_text().splitlines()[0]
    assert header == "vertex,t,t_std,trusted"
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    r = manifill.reconstruct(mesh["V"], mesh["F"], mesh["idx"], mesh["t"], method="gp", gp={"range": 1.0},
                             trust=0.4)
    np.testing.assert_allclose(table[:, 2], r.std, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(table[:, 3], r.trusted.astype(float))
    code, text, err = run(capsys, "reconstruct", mesh["path"], mesh["one"], "-o", tmp_path / "o.npy", "--method",
                          "gp", "--gp-range", "1")
    assert code == 0, err
    assert "note: o.npy holds the values alone; t_std are not written" in text
    np.testing.assert_allclose(np.load(tmp_path / "o.npy"), r.values, rtol=1e-10, atol=1e-12)


BAD = {
    "uncertainty without a model": ["--method", "gvf-harmonic", "--uncertainty"],
    "uncertainty with the paper's pipeline": ["--method", "gvf-harmonic", "--uncertainty"],
    "trust with rbf": ["--method", "rbf", "--trust", "1"],
    "noise with harmonic": ["--method", "harmonic", "--noise", "0.1"],
    "gp-range with biharmonic": ["--method", "biharmonic", "--gp-range", "1"],
    "variance without uncertainty": ["--method", "harmonic", "--variance", "exact"],
    "negative range": ["--method", "gp", "--gp-range", "-1"],
    "range not a number": ["--method", "gp", "--gp-range", "far"],
    "negative noise": ["--method", "gp", "--noise", "-0.1"],
    "zero sigma": ["--method", "gp", "--gp-sigma", "0"],
    "sigma with alpha 1": ["--method", "gp", "--gp-alpha", "1", "--gp-sigma", "1"],
    "alpha 3": ["--method", "gp", "--gp-alpha", "3"],
    "untrusted without trust": ["--method", "gp", "--untrusted", "nan"],
    "trust zero": ["--method", "gp", "--trust", "0"],
    "trust nan": ["--method", "gp", "--trust", "nan"],
    "samples with exact": ["--method", "gp", "--variance", "exact", "--variance-samples", "10"],
    "one sample": ["--method", "gp", "--variance-samples", "1"],
    "gp with bounds": ["--method", "gp", "--bounds", "samples"],
    "gp with smoothing": ["--method", "gp", "--smoothing", "auto"],
    "gp with uniform weights": ["--method", "gp", "--weights", "uniform"],
    "gp with iterate": ["--method", "gp", "--solver", "iterate"],
    "uncertainty with bounds": ["--method", "harmonic", "--uncertainty", "--bounds", "samples"],
    "field not written": ["--method", "harmonic", "--field", "t_std"],
}


@pytest.mark.parametrize("case", BAD)
def test_bad_combinations_are_one_line_exit_2_and_write_nothing(tmp_path, capsys, mesh, case):
    out = tmp_path / "bad.vtu"
    code, text, err = run(capsys, "reconstruct", mesh["path"], mesh["one"], "-o", out, "--render",
                          tmp_path / "bad.png", *BAD[case])
    line = assert_usage_error(code, text, err)
    assert not out.exists() and not (tmp_path / "bad.png").exists()
    flags = [a for a in BAD[case] if a.startswith("--") and a != "--method"] or ["--uncertainty"]
    assert any(flag in line for flag in flags), line  # the message names the flag at fault


def test_a_value_column_named_like_a_std_is_refused_before_the_work(tmp_path, capsys, mesh):
    samples = tmp_path / "s.csv"
    samples.write_text("vertex,t,t_std\n" + "".join(f"{i},{float(v)!r},0\n" for i, v in zip(mesh["idx"], mesh["t"])))
    code, text, err = run(capsys, "reconstruct", mesh["path"], samples, "-o", tmp_path / "o.vtu", "--method", "gp")
    assert "t_std" in assert_usage_error(code, text, err)


def test_progress_counts_the_uncertainty_step(tmp_path, capsys, mesh, bars):
    code, _, err = run(capsys, "reconstruct", mesh["path"], mesh["one"], "-o", tmp_path / "o.vtu", "--method",
                       "harmonic", "--uncertainty")
    assert code == 0, err
    (bar,) = bars
    assert bar.steps[-1] == "uncertainty" and bar.total == len(bar.steps)


# ----------------------------------------------------------------------------- volume


def _volume_gp_available():
    from manifill import reconstruct_volume

    V, F = icosphere(1)
    try:
        r = reconstruct_volume(V, F, [0, 3, 7, 9], [0.0, 1.0, 2.0, 1.0], method="gp", form="voxels", resolution=6,
                               gp={"range": 1.0, "sigma": 1.0})
    except (manifill.OptionError, TypeError):
        return False
    return getattr(r, "std", None) is not None


needs_volume_gp = pytest.mark.skipif(not _volume_gp_available(),
                                     reason="reconstruct_volume(method='gp') is not in this manifill yet")


@needs_volume_gp
def test_volume_gp_writes_the_std_and_the_trust_mask(tmp_path, capsys):
    from manifill.io import read_vti

    V, F = icosphere(2)
    write_mesh(tmp_path / "s.ply", V, F)
    idx = np.arange(0, len(V), 9)
    (tmp_path / "s.csv").write_text("vertex,t\n" + "".join(f"{i},{float(V[i, 0])!r}\n" for i in idx))
    out = tmp_path / "v.vti"
    code, text, err = run(capsys, "volume", tmp_path / "s.ply", tmp_path / "s.csv", "-o", out, "--method", "gp",
                          "--resolution", "14", "--gp-range", "1.5", "--gp-sigma", "0.5", "--trust", "1.0")
    assert code == 0, err
    fields, _, _ = read_vti(out)
    std, inside = fields["t_std"], np.isfinite(fields["t"])
    assert np.nanmin(std[inside]) >= 0 and np.nanmax(std) > 0
    trusted = fields["trusted"].astype(bool)
    # at this resolution no two samples share a voxel, so the threshold is T x the samples' own sd
    np.testing.assert_array_equal(trusted[inside], std[inside] <= 1.0 * np.std(V[idx, 0]))
    assert 0 < trusted[inside].sum() < inside.sum()
    assert "gp: Matern alpha=2 (nu=0.5), range 1.5 (given), sigma 0.5 (given)" in text
    assert f"trust: {(~trusted[inside]).sum():,} of {inside.sum():,} voxels untrusted" in text


@pytest.mark.parametrize("extra", [["--uncertainty"], ["--trust", "1"], ["--noise", "0.1"]])
def test_volume_std_needs_gp(tmp_path, capsys, extra):
    V, F = icosphere(1)
    write_mesh(tmp_path / "s.ply", V, F)
    (tmp_path / "s.csv").write_text("vertex,t\n0,1\n5,2\n9,0\n")
    code, text, err = run(capsys, "volume", tmp_path / "s.ply", tmp_path / "s.csv", "-o", tmp_path / "v.vti",
                          "--method", "harmonic", "--resolution", "8", *extra)
    assert extra[0] in assert_usage_error(code, text, err)
    assert not (tmp_path / "v.vti").exists()


def test_variance_options_reach_an_energy_method(tmp_path, capsys, mesh):
    """--uncertainty --variance sampled --variance-samples with harmonic: the library's gp={'variance', 'samples'}."""
    out = tmp_path / "h.vtu"
    code, text, err = run(capsys, "reconstruct", mesh["path"], mesh["one"], "-o", out, "--method", "harmonic",
                          "--uncertainty", "--variance", "sampled", "--variance-samples", "20")
    assert code == 0, err
    r = manifill.reconstruct(mesh["V"], mesh["F"], mesh["idx"], mesh["t"], method="harmonic", uncertainty=True,
                             gp={"variance": "sampled", "samples": 20})
    assert r.report["uncertainty"]["variance"]["samples"] == 20
    np.testing.assert_allclose(meshio.read(out).point_data["t_std"], r.std, rtol=1e-10, atol=1e-12)
    assert "variance sampled (20 Monte Carlo samples" in text


def test_draws_are_written_beside_the_std_and_go_through_the_samples(tmp_path, capsys, mesh):
    out = tmp_path / "draws.vtu"
    code, text, err = run(capsys, "reconstruct", mesh["path"], mesh["two"], "-o", out, "--method", "gp",
                          "--draws", "3")
    assert code == 0, err
    data = meshio.read(out).point_data
    names = [f"{f}_draw{i}" for f in "tu" for i in (1, 2, 3)]
    assert set(names) <= set(data) and "t_draw4" not in data
    r = manifill.reconstruct(mesh["V"], mesh["F"], mesh["idx"], np.column_stack([mesh["t"], 3 * mesh["t"] + 1]),
                             method="gp")
    D = r.sample(3, seed=0)  # the library's draws, seed 0
    for j, f in enumerate("tu"):
        for i in range(3):
            np.testing.assert_allclose(data[f"{f}_draw{i + 1}"], D[:, j, i], rtol=1e-10, atol=1e-12)
            np.testing.assert_allclose(data[f"{f}_draw{i + 1}"][mesh["idx"]], data[f][mesh["idx"]], atol=1e-10)
    assert not np.allclose(data["t_draw1"], data["t_draw2"])


@pytest.mark.parametrize("extra, says", [((), "--draws takes whole fields from a fitted posterior, which --method "
                                              "harmonic has not; add --method gp"),
                                         (("--subdivide", "1"), "--draws and --subdivide")])
def test_draws_are_refused_where_there_is_no_posterior(tmp_path, capsys, mesh, extra, says):
    method = ("--method", "gp") if extra else ("--method", "harmonic")
    line = assert_usage_error(*run(capsys, "reconstruct", mesh["path"], mesh["one"], "-o", tmp_path / "x.vtu",
                                   *method, "--draws", "2", *extra))
    assert says in line and not (tmp_path / "x.vtu").exists()
