"""The prepared reconstruction: apply equals reconstruct, the matrix equals apply, linearity, errors."""

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings, strategies as st

import manifill
from manifill.errors import OptionError, SampleError
from manifill.linalg import backends
from manifill.mesh.shapes import icosphere
from manifill.surface.methods.base import CHECK_FIELDS

V, F = icosphere(3)
N = len(V)
IDX = np.random.default_rng(3).choice(N, 30, replace=False)


def field(P, j=0):
    return np.sin(2 * P[:, 0] + j) + P[:, 1] * P[:, 2] + 0.3 * j * P[:, 2]


A = np.column_stack([field(V[IDX], j) for j in range(3)])
B = np.column_stack([field(V[IDX], j + 5) ** 2 for j in range(2)])

CONFIGS = {
    "default": {},
    "gvf-harmonic hermite": {"method": "gvf-harmonic"},
    "gvf-harmonic linear cycle": {"method": "gvf-harmonic", "curve_values": "linear", "partition": "cycle"},
    "gvf-harmonic monotone bounded": {"method": "gvf-harmonic", "curve_values": "monotone", "bounds": "samples"},
    "gvf-harmonic gvf curves": {"method": "gvf-harmonic", "curve_values": "gvf", "levels": None},
    "gvf-harmonic tree uniform": {"method": "gvf-harmonic", "partition": "tree", "weights": "uniform"},
    "harmonic": {"method": "harmonic"},
    "harmonic amg": {"method": "harmonic", "solver": "amg", "tol": 1e-13},
    "harmonic bounded": {"method": "harmonic", "bounds": "samples"},
    "harmonic smoothing": {"method": "harmonic", "smoothing": 0.1},
    "harmonic smoothing auto": {"method": "harmonic", "smoothing": "auto"},
    "harmonic uncertainty": {"method": "harmonic", "uncertainty": True, "gp": {"variance": "exact"}},
    "biharmonic": {"method": "biharmonic"},
    "biharmonic bounded": {"method": "biharmonic", "bounds": "samples"},
    "triharmonic": {"method": "triharmonic"},
    "gvf": {"method": "gvf", "levels": None},
    "rbf": {"method": "rbf"},
    "gp given": {"method": "gp", "gp": {"range": 0.8, "sigma": 1.0, "noise": 0.0, "variance": "exact"}},
    "gp fitted": {"method": "gp", "gp": {"variance": "exact", "fit_samples": 30}},
}
LINEAR = ("gvf-harmonic hermite", "gvf-harmonic linear cycle", "gvf-harmonic tree uniform", "harmonic",
          "harmonic smoothing", "biharmonic", "triharmonic", "rbf", "gp given")


def close(a, b, scale=1.0):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape
    same_nan = np.isnan(a) == np.isnan(b)
    assert same_nan.all()
    ok = ~np.isnan(a)
    assert np.abs(a[ok] - b[ok]).max(initial=0.0) <= 1e-12 * scale


@pytest.mark.parametrize("name", list(CONFIGS))
def test_apply_equals_reconstruct_for_every_method(name):
    opts = CONFIGS[name]
    rec = manifill.Reconstructor(V, F, IDX, **opts)
    rec.apply(A)  # a first set of values must not change what the next gives
    for vals in (B, B[:, 0]):
        got = rec.apply(vals)
        want = manifill.reconstruct(V, F, IDX, vals, **opts)
        close(got.values, want.values, np.abs(vals).max())
        if want.std is not None:
            close(got.std, want.std, np.nanmax(want.std))
        assert got.report["method"] == want.report["method"]


def test_apply_equals_reconstruct_with_points_inside_faces():
    rng = np.random.default_rng(1)
    f = rng.choice(len(F), 25, replace=False)
    w = rng.dirichlet(np.ones(3), 25)
    P = np.einsum("ij,ijk->ik", w, V[F[f]])
    vals = field(P)
    for opts in ({"method": "harmonic"}, {"method": "biharmonic"}, {}):
        rec = manifill.Reconstructor(V, F, P, **opts)
        rec.apply(2 * vals + 1)
        close(rec.apply(vals).values, manifill.reconstruct(V, F, P, vals, **opts).values, 1.0)


@pytest.mark.parametrize("name", LINEAR)
def test_matrix_times_values_equals_apply(name):
    rec = manifill.Reconstructor(V, F, IDX, **CONFIGS[name])
    assert rec.linear
    X = rec.apply(A).values
    for form in ("auto", "sparse", "operator"):
        W = rec.matrix(form=form)
        assert W.shape == (N, IDX.size)
        close(W @ A, X, 10 * np.abs(A).max())
        close(W @ A[:, 1], X[:, 1], 10 * np.abs(A).max())
    W = rec.matrix(form="sparse")
    # the map's columns are the reconstructions of unit values
    j = 7
    e = np.zeros(IDX.size)
    e[j] = 1.0
    close(W[:, [j]].toarray()[:, 0], rec.apply(e).values, 10.0)


def test_the_pipelines_map_is_sparse_and_local():
    rec = manifill.Reconstructor(V, F, IDX, method="gvf-harmonic")
    W = rec.matrix()
    assert sp.issparse(W)
    # every vertex depends on a few samples around its patch, not on all of them
    per_row = np.diff(W.indptr)
    assert per_row.max() < IDX.size and per_row.mean() < 0.6 * IDX.size
    # a sample's own row is its unit vector
    close(W[IDX].toarray(), np.eye(IDX.size))


@pytest.mark.parametrize("name", ["gvf-harmonic hermite", "harmonic", "biharmonic", "rbf", "gp given"])
@settings(max_examples=8, deadline=None)
@given(a=st.floats(-3, 3), b=st.floats(-3, 3))
def test_linear_methods_are_linear(name, a, b):
    rec = _cached(name)
    x, y = A[:, 0], B[:, 1]
    lhs = rec.apply(a * x + b * y).values
    rhs = a * rec.apply(x).values + b * rec.apply(y).values
    assert np.abs(lhs - rhs).max() <= 1e-10 * (1 + abs(a) + abs(b)) * np.abs(B).max()


_RECS = {}


def _cached(name):
    if name not in _RECS:
        _RECS[name] = manifill.Reconstructor(V, F, IDX, **CONFIGS[name])
    return _RECS[name]


def test_the_default_is_not_linear_and_says_so():
    x = A[:, 0]
    rec = manifill.Reconstructor(V, F, IDX)
    assert not rec.linear
    # monotone curve values and bounds: scaling by -1 is fine, but adding fields is not (the cubic's slopes are
    # limited per field)
    with pytest.raises(OptionError, match="not linear.*curve_values='monotone'|not linear.*bounds"):
        rec.matrix()
    with pytest.raises(OptionError, match="not linear"):
        manifill.Reconstructor(V, F, IDX, method="gvf", levels=None).matrix()
    with pytest.raises(OptionError, match="hyperparameters"):
        manifill.Reconstructor(V, F, IDX, method="gp").matrix()
    assert np.isfinite(rec.apply(x).values).all()


def test_wrong_rows_and_bad_values_are_refused():
    rec = manifill.Reconstructor(V, F, IDX, method="harmonic")
    with pytest.raises(SampleError, match="prepared for 30 samples"):
        rec.apply(np.ones(29))
    with pytest.raises(SampleError, match="prepared for 30 samples"):
        rec.apply(np.ones((30, 2, 2)))
    bad = A[:, 0].copy()
    bad[3] = np.nan
    with pytest.raises(SampleError):
        rec.apply(bad)
    with pytest.raises(OptionError, match="fields"):
        manifill.Reconstructor(V, F, IDX, fields=0)
    with pytest.raises(OptionError, match="check"):
        manifill.reconstruct(V, F, IDX, A[:, 0], check="yes")


def test_duplicate_rows_follow_the_duplicates_rule():
    idx = np.r_[IDX, IDX[:2]]
    vals = np.r_[A[:, 0], A[:2, 0]]
    rec = manifill.Reconstructor(V, F, idx, method="gvf-harmonic")
    close(rec.apply(vals).values, manifill.reconstruct(V, F, IDX, A[:, 0], method="gvf-harmonic").values, 3.0)
    bad = vals.copy()
    bad[-1] += 1.0
    with pytest.raises(SampleError, match="two different values"):
        rec.apply(bad)
    # the map reads repeated rows by their mean: consistent values give the same field
    W = rec.matrix()
    close(W @ vals, rec.apply(vals).values, 10.0)


def test_step_1_runs_per_field_only_when_asked():
    many = np.column_stack([field(V[IDX], j) for j in range(CHECK_FIELDS + 1)])
    r = manifill.reconstruct(V, F, IDX, many, method="harmonic")
    assert r.report["check"] == [] and "check=True" in r.report["check_skipped"]
    r = manifill.reconstruct(V, F, IDX, many, method="harmonic", check=True)
    assert len(r.report["check"]) == CHECK_FIELDS + 1 and "check_skipped" not in r.report
    assert manifill.reconstruct(V, F, IDX, many[:, :2], method="harmonic", check=False).report["check"] == []
    # gvf needs the levels: it runs Step 1 whatever check says
    r = manifill.reconstruct(V, F, IDX, many[:, :2], method="gvf", levels=None, check=False)
    assert len(r.report["check"]) == 2
    # the fields are the same with and without Step 1
    close(manifill.reconstruct(V, F, IDX, many[:, :2], check=True).values,
          manifill.reconstruct(V, F, IDX, many[:, :2], check=False).values)


def test_many_fields_factorise_a_fourth_order_kkt_system_with_either_factoriser(monkeypatch):
    # AMG-CG on the rows eliminated is slow per field (measured 0.9-9 s at 41k-163k vertices): many fields factorise
    for name in ("pardiso", "superlu"):
        monkeypatch.setenv(backends.DIRECT_ENV, name)
        assert backends.auto_backend(100_000, 700_000, fields=backends.AUTO_DIRECT_FIELDS, rows=True) == "direct"
        assert backends.auto_backend(100_000, 700_000, fields=backends.AUTO_DIRECT_FIELDS - 1, rows=True) == "amg"
        # the factors do not fit
        assert backends.auto_backend(10**9, 7 * 10**9, fields=backends.AUTO_DIRECT_FIELDS, rows=True) == "amg"


def test_many_fields_inside_faces_of_a_large_mesh_are_factorised_and_meet_their_points():
    # 40,962 vertices (above the 20,000 of auto's plain rule), points inside faces: the biharmonic's KKT factorised
    from manifill.surface.locate import locate_points

    V, F = icosphere(6)
    rng = np.random.default_rng(0)
    P = locate_points(V, F, V[rng.choice(len(V), 12, replace=False)] + 0.004, max_distance=0.1).points
    vals = rng.normal(size=(12, 8))
    r = manifill.reconstruct(V, F, P, vals, method="biharmonic", max_distance=0.1)
    assert r.report["fill"]["solver"] == "direct"
    assert np.abs(r.at(P) - vals).max() < 1e-9  # each point's value at its point


def test_many_fields_factorise_and_block_the_solves(monkeypatch):
    assert backends.auto_backend(10**5, 7 * 10**5) == "amg"
    assert backends.auto_backend(10**5, 7 * 10**5, fields=backends.AUTO_DIRECT_FIELDS) == "amg"  # one block
    assert backends.auto_backend(10**5, 7 * 10**5, fields=backends.AUTO_DIRECT_FIELDS, largest=5000) == "direct"
    assert backends.auto_backend(10**5, 7 * 10**5, fields=backends.AUTO_DIRECT_FIELDS - 1, largest=5000) == "amg"
    L = manifill.laplacian(V, F)
    K = sp.csr_matrix(L[1:, 1:] + sp.eye(N - 1) * 1e-3)
    R = np.random.default_rng(0).standard_normal((N - 1, 37))
    whole = backends.DirectSolver(K).solve(R)[0]
    monkeypatch.setattr(backends, "SOLVE_BLOCK_BYTES", 8 * (N - 1) * 5)  # blocks of 5 columns
    assert backends.solve_block(N - 1) == 5
    blocked = backends.DirectSolver(K).solve(R)[0]
    assert np.abs(blocked - whole).max() <= 1e-12 * np.abs(whole).max()
    assert np.abs(K @ blocked - R).max() <= 1e-9 * np.abs(R).max()


def test_prepared_solver_is_built_once():
    rec = manifill.Reconstructor(V, F, IDX, method="gvf-harmonic")
    assert "prepare" in rec.seconds and {"partition", "fill", "curve map"} <= set(rec._prepared)
    fill = rec._prepared["fill"]
    rec.apply(A)
    rec.apply(B)
    assert rec._prepared["fill"] is fill
    lazy = manifill.Reconstructor(V, F, IDX, method="harmonic", prepare=False)
    assert not lazy._prepared
    lazy.apply(A)
    assert "fill" in lazy._prepared
