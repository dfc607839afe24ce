"""Properties every method of ``reconstruct`` states, checked across the whole method table at once.

One table (:data:`CASES`) names every method of :data:`manifill.surface.reconstruct.METHOD_NAMES` with the option
sets that change what it computes (the paper's pipeline with each curve value and partition; harmonic,
biharmonic, triharmonic alone, bounded by the samples or by a pair, smoothed with a fixed lambda or GCV;
the gradually varied fit; ``rbf`` and ``auto`` when they exist), and each test states one property for the
cases it holds for:

- exact at the samples (every method but smoothing, whose residuals the report gives);
- linear in the data, ``R(a u + b v) = a R(u) + b R(v)``, for the methods documented as linear;
- affine equivariance in the values, ``R(c u + d) = c R(u) + d`` (``c > 0``), for every method;
- invariance under translating and uniformly scaling the mesh (1e-3 and 1e3), and under relabelling
  its vertices (faces shuffled, corners rotated);
- the maximum principle for the methods that claim it (and what the gradually varied fit keeps instead);
- samples at points inside faces: exact there, linear, invariant, and linear precision on a flat mesh.

Library bugs found by these properties are single ``xfail(strict=True)`` tests naming the inputs.

Linear precision, the limits of smoothing and the error messages: tests/surface/test_method_limits.py.
Tolerances are relative to the range of the sample values.
"""

import importlib
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import manifill
from conftest import icosphere, irregular, relabel
from manifill.surface.reconstruct import METHOD_NAMES as METHODS, reconstruct

hsettings = settings(max_examples=4, deadline=None, derandomize=True, database=None,
                     suppress_health_check=[HealthCheck.too_slow])
seeds = st.integers(0, 2**16)

HAS_RBF = "rbf" in METHODS
HAS_AUTO = "auto" in METHODS
needs_rbf = pytest.mark.skipif(not HAS_RBF, reason="method='rbf' is not in METHODS yet (helper B)")
needs_auto = pytest.mark.skipif(not HAS_AUTO, reason="method='auto' is not in METHODS yet (helper B)")


def jittered_sphere(k=2, seed=0):
    """An icosphere with radii jittered by 5 %: no two edges of equal length, so no ties in shortest paths."""
    V, F = icosphere(k)
    rng = np.random.default_rng(seed)
    return V * (1.0 + 0.05 * rng.standard_normal((len(V), 1))), F


V, F = jittered_sphere(2)
IDX = np.sort(np.random.default_rng(11).choice(len(V), 24, replace=False))


def smooth_field(X):
    return np.sin(2 * X[:, 0]) + X[:, 1] * X[:, 2] + 0.5 * np.cos(3 * X[:, 1])


def data(seed, rough=False):
    """Sample values: a smooth field plus a random part (or a step plus noise: where cubics overshoot)."""
    rng = np.random.default_rng(seed)
    if rough:
        return np.where(V[IDX, 0] > 0, 1.0, 0.0) + 0.3 * rng.standard_normal(IDX.size)
    return smooth_field(V[IDX]) * rng.uniform(0.5, 2.0) + rng.standard_normal(IDX.size)


# -- the method table ---------------------------------------------------------------------------------------
#: bounds (lo, hi) of the 'pair' cases, given for values in [-3, 3] (test data stay inside).
PAIR = (-12.0, 12.0)
#: method='gp' with its hyperparameters given (the fitted ones have their own tests, tests/surface/test_gp.py):
#: its mean is then linear in the data.
GP_GIVEN = {"range": 0.8, "sigma": 1.0, "variance": "exact"}


def case(name, *, linear=False, exact=True, bounded=False, kind=None, **kw):
    """A pytest param: the options of reconstruct and what the method documents about itself."""
    marks = [needs_rbf] if kw.get("method") == "rbf" else [needs_auto] if kw.get("method") == "auto" else []
    return pytest.param(dict(kw=kw, linear=linear, exact=exact, bounded=bounded, kind=kind), id=name, marks=marks)


PIPELINE = [case(f"gvf-harmonic-{cv}-{p}", linear=cv in ("hermite", "linear"), bounded=cv != "hermite",
                 method="gvf-harmonic", curve_values=cv, partition=p)
            for cv in ("hermite", "monotone", "linear", "gvf") for p in ("delaunay", "tree", "cycle")]
ENERGY = [case(m, linear=True, bounded=m == "harmonic", method=m)
          for m in ("harmonic", "biharmonic", "triharmonic", "hessian", "hessian-curved")]
BOUNDED = ([case(f"{m}-bounds-samples", bounded=True, method=m, bounds="samples")
            for m in ("harmonic", "biharmonic", "triharmonic")]
           + [case(f"{m}-bounds-pair", kind="pair", method=m, bounds=PAIR) for m in ("biharmonic", "triharmonic")]
           + [case(f"{m}-bounds-project", bounded=True, method=m, bounds="samples", bounds_mode="project")
              for m in ("biharmonic", "hessian", "rbf")])
SMOOTHED = ([case(f"{m}-smoothing-fixed", linear=True, exact=False, kind="fixed", method=m, smoothing=1e-2)
             for m in ("harmonic", "biharmonic", "triharmonic")]
            + [case(f"{m}-smoothing-auto", exact=False, kind="auto", method=m, smoothing="auto")
               for m in ("harmonic", "biharmonic", "triharmonic")])
OTHER = [case("gvf", bounded=True, method="gvf"), case("rbf", linear=True, method="rbf"),
         case("rbf-smoothing-fixed", linear=True, exact=False, kind="rbf-fixed", method="rbf", smoothing=1e-2),
         case("auto", method="auto"),
         case("gp", linear=True, kind="gp-given", method="gp", gp=GP_GIVEN)]
CASES = PIPELINE + ENERGY + BOUNDED + SMOOTHED + OTHER


def test_the_table_covers_every_method():
    named = {p.values[0]["kw"]["method"] for p in CASES}
    assert set(METHODS) <= named, f"methods without a row in CASES: {set(METHODS) - named}"


def run(c, vals, V_=V, F_=F, idx=IDX, **over):
    kw = dict(c["kw"], distance="length", solver="direct")
    if kw["method"] in ("rbf", "auto"):
        kw.pop("solver")
    kw.update(over)
    return reconstruct(V_, F_, idx, vals, **kw)


def where(key, value=True):
    return [p for p in CASES if p.values[0][key] == value]


# ---------------------------------------------------------------------------
# exactness at the samples
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("c", where("exact"))
@hsettings
@given(seed=seeds, rough=st.booleans())
def test_exact_at_the_samples(c, seed, rough):
    vals = data(seed, rough)
    r = run(c, vals)
    assert np.abs(r.values[IDX] - vals).max() <= 1e-10 * np.ptp(vals)
    assert np.isfinite(r.values).all()


@pytest.mark.parametrize("c", [p for p in where("exact", False) if p.values[0]["kind"] != "rbf-fixed"])
def test_smoothing_reports_its_residuals_at_the_samples(c):
    vals = data(3)
    r = run(c, vals)
    rep = r.report["fill"]["smoothing"]
    res = np.asarray(rep["residuals"]).ravel()
    np.testing.assert_allclose(res, r.values[IDX] - vals, rtol=0, atol=1e-10 * np.ptp(vals))
    assert float(np.ravel(rep["lambda"])[0]) > 0


# ---------------------------------------------------------------------------
# linearity in the data (the methods documented as linear)
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("c", where("linear"))
@hsettings
@given(seed=seeds, a=st.floats(-3.0, 3.0), b=st.floats(-3.0, 3.0))
def test_linear_in_the_data(c, seed, a, b):
    u, v = data(seed), data(seed + 1, rough=True)
    ru, rv, rw = (run(c, x).values for x in (u, v, a * u + b * v))
    scale = abs(a) * np.abs(ru).max() + abs(b) * np.abs(rv).max() + np.abs(a * u + b * v).max()
    np.testing.assert_allclose(rw, a * ru + b * rv, rtol=0, atol=1e-10 * scale)


NOT_LINEAR = {"monotone": "curve_values='monotone'", "bounds": "bounds=", "gvf": "'gvf'",
              "auto": "smoothing='auto' / method='auto'"}


def linearity_claims():
    """Every sentence of the README and the method modules' docstrings that says something is linear in the data."""
    import manifill.linalg.smoothing
    import manifill.surface.curve_values
    import manifill.surface.energy_fill
    import manifill.surface.reconstruct

    texts = [(Path(__file__).parents[2] / "README.md").read_text()]
    mods = [manifill.surface.reconstruct, manifill.surface.energy_fill, manifill.surface.curve_values,
            manifill.linalg.smoothing, manifill.reconstruct]
    for name in ("manifill.surface.rbf", "manifill.surface.crossval"):  # helper B's, when there
        try:
            mods.append(importlib.import_module(name))
        except ImportError:
            pass
    texts += [mod.__doc__ or "" for mod in mods]
    sentences = [s for t in texts for s in re.split(r"(?<=[.;:])\s+|\n\s*[-*]\s+|\n``", t)]
    claim = re.compile(r"linear in the (data|values|sample values)|linear map|interpolation matrix exists|additive",
                       re.I)
    return [" ".join(s.split()) for s in sentences if claim.search(s) and not re.search(r"\bnot\b", s)]


def test_no_method_that_is_not_linear_is_documented_as_linear():
    """Monotone curves, bounds, GVF and 'auto' look at the values: no sentence may call them linear."""
    claims = linearity_claims()
    assert claims, "the README documents hermite as linear: the scan must find that sentence"
    for s in claims:
        for word in ("monotone", "bounds", "bounded", "'gvf'", '"gvf"', "auto"):
            assert word not in s, f"a sentence calls a non-linear option linear: {s!r}"


# ---------------------------------------------------------------------------
# affine equivariance in the values: R(c u + d) = c R(u) + d, c > 0
# ---------------------------------------------------------------------------


def affine_options(c, scale, shift):
    """The options for values ``scale * u + shift``: a given (lo, hi) pair moves with the data."""
    if c["kind"] == "pair":
        return dict(bounds=(scale * PAIR[0] + shift, scale * PAIR[1] + shift))
    return {}


@pytest.mark.parametrize("c", CASES)
@hsettings
@given(seed=seeds, rough=st.booleans(), scale=st.floats(0.01, 100.0), shift=st.floats(-50.0, 50.0))
def test_affine_equivariance_in_the_values(c, seed, rough, scale, shift):
    u = data(seed, rough)
    ru = run(c, u).values
    rw = run(c, scale * u + shift, **affine_options(c, scale, shift)).values
    # smoothing='auto': the GCV score is invariant, but the search stops at a resolution of 0.01 decade, and a
    # flat minimum lets rounding pick a neighbouring evaluated lambda; the fit moves by that much
    tol = 1e-7 if c["kind"] == "auto" or c["kw"]["method"] == "auto" else 1e-10
    np.testing.assert_allclose(rw, scale * ru + shift, rtol=0, atol=tol * scale * np.ptp(u) + 1e-12 * abs(shift))


# ---------------------------------------------------------------------------
# invariance under moving and scaling the mesh, and under relabelling it
# ---------------------------------------------------------------------------


def mesh_scaled_options(c, s):
    """A fixed lambda weighs an energy in units of length^-2(k-1) (M scales as s^2): it scales with the mesh.

    A given gp range is a length: it scales with the mesh too.
    """
    if c["kind"] == "gp-given":
        return dict(gp=dict(GP_GIVEN, range=GP_GIVEN["range"] * s))
    if c["kind"] != "fixed":  # (rbf: lambda is in the normalised units of rbf.py, scale-free)
        return {}
    k = {"harmonic": 1, "biharmonic": 2, "triharmonic": 3}[c["kw"]["method"]]
    return dict(smoothing=c["kw"]["smoothing"] * s ** (2 * (k - 1)))


@pytest.mark.parametrize("c", CASES)
@hsettings
@given(seed=seeds, s=st.sampled_from([1e-3, 1e3]), move=st.booleans())
def test_invariant_under_translation_and_scaling_of_the_mesh(c, seed, s, move):
    if c["kind"] == "rbf-fixed":
        # rbf.py normalises positions by a power of two near the half-extent, and a fixed lambda weighs the
        # bending energy in those units: only power-of-two scalings leave a smoothed rbf fit unchanged
        s = 2.0 ** round(np.log2(s))
    vals = data(seed)
    shift = np.array([10.0, -3.0, 7.0]) * s if move else np.zeros(3)
    r1 = run(c, vals).values
    r2 = run(c, vals, V_=s * V + shift, **mesh_scaled_options(c, s)).values
    tol = 1e-7 if c["kind"] == "auto" else 1e-9  # auto: the search's resolution, as above
    np.testing.assert_allclose(r2, r1, rtol=0, atol=tol * np.ptp(vals))


def test_a_fixed_lambda_is_not_scale_free_for_the_higher_energies():
    """What the rescaling above stands for: the same lambda on a mesh 1000x larger smooths far less (k = 2)."""
    c = next(p.values[0] for p in SMOOTHED if p.values[0]["kw"]["method"] == "biharmonic" and
             p.values[0]["kind"] == "fixed")
    vals = data(0)
    r1, r2 = run(c, vals).values, run(c, vals, V_=1e3 * V).values
    assert np.abs(r2 - r1).max() > 1e-3 * np.ptp(vals)
    harm = next(p.values[0] for p in SMOOTHED if p.values[0]["kw"]["method"] == "harmonic" and
                p.values[0]["kind"] == "fixed")
    np.testing.assert_allclose(run(harm, vals, V_=1e3 * V).values, run(harm, vals).values, rtol=0,
                               atol=1e-9 * np.ptp(vals))  # the cotan Laplacian is scale-free on a surface


def order_keeping_permutation(rng, idx):
    """A random vertex permutation (old -> new) that keeps the samples in their order.

    The cycle partition starts at the sample with the smallest vertex number and visits the samples in an
    order that depends on their numbers, so only such relabellings may leave it unchanged.
    """
    inv = rng.permutation(len(V))
    inv[idx] = np.sort(inv[idx])
    return inv


# method='auto' is left out: its cross-validation folds are drawn over the samples in vertex order, so a
# relabelling changes the folds (and may change the choice) by design
@pytest.mark.parametrize("c", [p for p in CASES if p.values[0]["kw"]["method"] != "auto"])
@hsettings
@given(seed=seeds)
def test_invariant_under_relabelling(c, seed):
    rng = np.random.default_rng(seed)
    vals = data(seed)
    if c["kw"].get("partition") == "cycle":
        inv = order_keeping_permutation(rng, IDX)
        perm = np.argsort(inv)
    else:
        perm = rng.permutation(len(V))
    V2, F2, inv = relabel(V, F, perm, rng)
    order = rng.permutation(IDX.size)  # and the samples given in another order
    a = run(c, vals)
    b = run(c, vals[order], V_=V2, F_=F2, idx=inv[IDX][order])
    if c["kind"] == "auto":
        # the GCV curve can be flat to rounding (near interpolation), and rounding then picks another evaluated
        # lambda of the same score: the score is invariant (to 1e-6: near interpolation its denominator
        # (k - edf)^2 amplifies rounding), and so is the fit at the first run's lambda
        s1, s2 = (r.report["fill"]["smoothing"] for r in (a, b))
        np.testing.assert_allclose(s2["score"], s1["score"], rtol=1e-6)
        b = run(c, vals[order], V_=V2, F_=F2, idx=inv[IDX][order], smoothing=float(np.ravel(s1["lambda"])[0]))
    np.testing.assert_allclose(b.values[inv], a.values, rtol=0, atol=1e-9 * np.ptp(vals))


# method='auto' is left out: it picks one method for all fields, by their mean cross-validation error
@pytest.mark.parametrize("c", [p for p in CASES if p.values[0]["kw"]["method"] != "auto"])
def test_fields_are_reconstructed_independently(c):
    """(k, 2) values give the two columns each reconstructed alone (bounds and lambda per field)."""
    u, v = data(7), 3.0 * data(8, rough=True)
    both = run(c, np.column_stack([u, v])).values
    assert both.shape == (len(V), 2)
    for j, x in enumerate((u, v)):
        np.testing.assert_allclose(both[:, j], run(c, x).values, rtol=0, atol=1e-9 * np.ptp(x))


# ---------------------------------------------------------------------------
# the maximum principle
# ---------------------------------------------------------------------------

# the plain icosphere: every triangle acute, so every cotangent weight is positive (on the jittered one some
# are not, and the harmonic fill may leave the range by a hair)
VA, FA = icosphere(2)


GVF_CASES = [p for p in CASES if "gvf" in (p.values[0]["kw"]["method"], p.values[0]["kw"].get("curve_values"))]


@pytest.mark.parametrize("c", [p for p in where("bounded") + where("kind", "pair") if p not in GVF_CASES])
@hsettings
@given(seed=seeds, rough=st.booleans())
def test_maximum_principle(c, seed, rough):
    vals = data(seed, rough)
    r = run(c, vals, V_=VA, F_=FA)
    lo, hi = (vals.min(), vals.max()) if c["kind"] != "pair" else PAIR
    eps = 1e-12 * (hi - lo)
    assert lo - eps <= r.values.min() and r.values.max() <= hi + eps
    if c["kind"] != "pair":
        assert r.report["overshoot"] <= eps


def test_maximum_principle_has_teeth():
    """The same data make Hermite curves and the free biharmonic leave the range: the test above can fail."""
    vals = data(0, rough=True)
    for c in (next(p.values[0] for p in PIPELINE if p.id == "gvf-harmonic-hermite-delaunay"),
              next(p.values[0] for p in ENERGY if p.id == "biharmonic")):
        assert run(c, vals, V_=VA, F_=FA).report["overshoot"] > 1e-3 * np.ptp(vals)


def test_harmonic_with_uniform_weights_keeps_the_range_on_an_obtuse_flat_mesh():
    Vi, Fi = irregular(9, seed=2)
    rng = np.random.default_rng(4)
    idx = rng.choice(len(Vi), 12, replace=False)
    vals = rng.standard_normal(idx.size)
    r = reconstruct(Vi, Fi, idx, vals, method="harmonic", weights="uniform")
    assert vals.min() <= r.values.min() and r.values.max() <= vals.max()
    assert r.report["overshoot"] <= 0


@pytest.mark.parametrize("c", GVF_CASES)
@hsettings
@given(seed=seeds, rough=st.booleans())
def test_gvf_values_stay_within_their_levels(c, seed, rough):
    """What the gradually varied fit does keep: every value a level or a sample, the levels near the range.

    The uniform levels run from the smallest sample in steps of the Lipschitz constant, so the top level lies
    up to half a step below the largest sample (the top level is capped at the largest sample).
    """
    vals = data(seed, rough)
    r = run(c, vals, V_=VA, F_=FA)
    levels = r.levels[0]
    step = r.report["check"][0]["step"] or 0.0
    eps = 1e-12 * np.ptp(vals)
    lo, hi = min(levels[0], vals.min()), max(levels[-1], vals.max())  # the samples keep their own values
    assert lo - eps <= r.values.min() and r.values.max() <= hi + eps
    assert abs(levels[0] - vals.min()) <= eps and abs(levels[-1] - vals.max()) <= step / 2 + eps
    if c["kw"]["method"] == "gvf":
        off = np.setdiff1d(np.arange(len(VA)), IDX)
        assert np.abs(r.values[off][:, None] - levels[None, :]).min(axis=1).max() <= eps


@pytest.mark.parametrize("method, curve_values", [("gvf", "hermite"), ("gvf-harmonic", "gvf")])
def test_gvf_keeps_the_samples_range(method, curve_values):
    vals = data(0)
    r = reconstruct(VA, FA, IDX, vals, method=method, curve_values=curve_values)
    eps = 1e-12 * np.ptp(vals)
    assert vals.min() - eps <= r.values.min() and r.values.max() <= vals.max() + eps
    assert r.report["overshoot"] <= eps


# ---------------------------------------------------------------------------
# samples at points inside faces (the energy methods constrain the points themselves)
# ---------------------------------------------------------------------------

POINT_CASES = ["harmonic", "biharmonic", "triharmonic"]


def points_on_faces(V_, F_, k, seed, faces=None):
    """k points inside k distinct faces (barycentric coordinates >= 0.1): positions, faces, coordinates."""
    rng = np.random.default_rng(seed)
    faces = rng.choice(len(F_) if faces is None else faces, k, replace=False)
    B = 0.1 + 0.7 * rng.dirichlet([2.0, 2.0, 2.0], size=k)
    return np.einsum("kj,kjd->kd", B, V_[F_[faces]]), faces, B


def at_points(values, F_, faces, B):
    return np.einsum("kj,kj->k", B, values[F_[faces]])


def feasible_within_the_range(F_, n, faces, B, vals):
    """The reference: is there any x in [min, max]^n meeting every point's row? (a linear program)"""
    from scipy.optimize import linprog

    A = np.zeros((len(faces), n))
    A[np.arange(len(faces))[:, None], F_[faces]] = B
    return linprog(np.zeros(n), A_eq=A, b_eq=vals, bounds=(vals.min(), vals.max()), method="highs").status == 0


@pytest.mark.parametrize("bounds", [None, "samples"])
@pytest.mark.parametrize("method", POINT_CASES)
@hsettings
@given(seed=seeds)
def test_exact_at_points_inside_faces(method, bounds, seed):
    """Exact at every point; with bounds='samples' exactly when some field in the range meets the rows.

    (A point at the largest value pins its face's three vertices to it: neighbouring points may then be
    out of reach, and the bounded problem has no solution; the refusal must come exactly then.)
    """
    P, faces, B = points_on_faces(V, F, 16, seed)
    vals = smooth_field(P) + np.random.default_rng(seed).standard_normal(len(P))
    if bounds is not None and not feasible_within_the_range(F, len(V), faces, B, vals):
        with pytest.raises(manifill.SolveError, match="cannot be met within the bounds"):
            reconstruct(V, F, P, vals, method=method, bounds=bounds)
        return
    r = reconstruct(V, F, P, vals, method=method, bounds=bounds)
    assert r.report["points"]["inside_faces"] == len(P)
    np.testing.assert_allclose(at_points(r.values, F, faces, B), vals, rtol=0, atol=1e-10 * np.ptp(vals))
    if bounds is not None:
        eps = 1e-12 * np.ptp(vals)
        assert vals.min() - eps <= r.values.min() and r.values.max() <= vals.max() + eps


@pytest.mark.parametrize("method", POINT_CASES)
@hsettings
@given(seed=seeds, a=st.floats(-3.0, 3.0), b=st.floats(-3.0, 3.0))
def test_linear_in_the_data_at_points(method, seed, a, b):
    P, _, _ = points_on_faces(V, F, 16, seed)
    u, v = np.random.default_rng(seed).standard_normal((2, len(P)))
    ru, rv, rw = (reconstruct(V, F, P, x, method=method).values for x in (u, v, a * u + b * v))
    scale = abs(a) * np.abs(ru).max() + abs(b) * np.abs(rv).max() + np.abs(a * u + b * v).max()
    np.testing.assert_allclose(rw, a * ru + b * rv, rtol=0, atol=1e-10 * scale)


@pytest.mark.parametrize("method", POINT_CASES)
@hsettings
@given(seed=seeds, s=st.sampled_from([1e-3, 1e3]))
def test_points_invariant_under_relabelling_and_scaling(method, seed, s):
    rng = np.random.default_rng(seed)
    P, _, _ = points_on_faces(V, F, 16, seed)
    vals = smooth_field(P)
    r1 = reconstruct(V, F, P, vals, method=method).values
    V2, F2, inv = relabel(V, F, rng.permutation(len(V)), rng)
    order = rng.permutation(len(P))
    r2 = reconstruct(s * V2 + s, F2, s * P[order] + s, vals[order], method=method).values
    np.testing.assert_allclose(r2[inv], r1, rtol=0, atol=1e-9 * np.ptp(vals))


@hsettings
@given(seed=seeds, coef=st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-5, 5)))
def test_harmonic_with_points_inside_faces_reproduces_linear_fields(seed, coef):
    """The issue's statement: a flat mesh, its boundary vertices and points inside faces: linear fields exactly."""
    from manifill.mesh.topology import boundary_loops

    V_, F_ = irregular(8, seed=3)
    bnd = np.unique(np.concatenate(boundary_loops(F_)))
    inner_faces = np.flatnonzero(~np.isin(F_, bnd).any(axis=1))
    P, _, _ = points_on_faces(V_, F_, 6, seed, faces=inner_faces)
    X = np.vstack([V_[bnd], P])  # the boundary vertices given as positions too
    f = lambda Y: coef[0] + Y[:, :2] @ np.array(coef[1:])  # noqa: E731
    r = reconstruct(V_, F_, X, f(X), method="harmonic")
    np.testing.assert_allclose(r.values, f(V_), rtol=0, atol=1e-10 * (np.ptp(f(V_)) + abs(coef[0])))
