"""manifill as a scikit-learn regressor: the estimator API, sklearn's own checks where they apply, the invariances
those data checks would test (on surface data), cross-validation and a grid search that agrees with GCV."""

import pickle

import numpy as np
import pytest

try:
    import sklearn  # noqa: F401
except ImportError:
    pytest.skip("the [sklearn] extra (scikit-learn) is not installed", allow_module_level=True)

from sklearn.base import clone
from sklearn.model_selection import GridSearchCV, KFold, cross_val_score
from sklearn.pipeline import make_pipeline
from sklearn.utils.estimator_checks import check_estimator

import manifill
from manifill.adapters.sklearn import SurfaceRegressor
from manifill.errors import SampleError
from manifill.mesh.shapes import icosphere

V, F = icosphere(3)
RNG = np.random.default_rng(0)
IDX = np.sort(RNG.choice(len(V), 120, replace=False))


def field(P):
    return np.sin(3 * P[:, 0]) + P[:, 1] * P[:, 2]


def test_sklearn_s_checks_pass_where_they_apply():
    """The API checks pass. The data checks feed random features (R^2 .. R^10, not positions on a surface) or
    sparse and complex matrices, which do not apply to an estimator whose X says where on a fixed surface each
    sample is: the invariances they test (pickling, idempotence, row order and subsets, read-only and list input,
    2-D y, parameters left alone) are tested below on surface data."""
    results = check_estimator(SurfaceRegressor(V, F, method="biharmonic"), on_fail=None)
    passed = {r["check_name"] for r in results if r["status"] == "passed"}
    for name in ("check_estimator_cloneable", "check_get_params_invariance", "check_set_params",
                 "check_no_attributes_set_in_init", "check_parameters_default_constructible",
                 "check_estimators_unfitted", "check_fit1d", "check_supervised_y_no_nan", "check_estimator_repr",
                 "check_do_not_raise_errors_in_init_or_set_params", "check_mixin_order"):
        assert name in passed, name


@pytest.mark.parametrize("kind", ["vertices", "positions"])
def test_fit_predict_equal_the_library_and_the_invariances_hold(kind):
    X = IDX[:, None] if kind == "vertices" else V[IDX] * 1.001
    y = field(V[IDX])
    est = SurfaceRegressor(V, F, method="biharmonic")
    assert est.fit(X, y) is est and est.n_features_in_ == X.shape[1]
    r = manifill.reconstruct(V, F, IDX if kind == "vertices" else X, y, method="biharmonic")
    Xt = np.arange(len(V))[:, None] if kind == "vertices" else V * 1.0005
    want = r.values if kind == "vertices" else r.at(V * 1.0005)
    assert np.allclose(est.predict(Xt), want, atol=1e-12)
    # pickling, fitting twice, the order and subsets of the rows predicted, read-only and list inputs
    assert np.array_equal(pickle.loads(pickle.dumps(est)).predict(Xt), est.predict(Xt))
    again = clone(est).fit(X, y).fit(X, y)
    assert np.allclose(again.predict(Xt), est.predict(Xt), atol=1e-12)
    perm = RNG.permutation(len(Xt))
    assert np.allclose(est.predict(Xt[perm]), est.predict(Xt)[perm], atol=1e-12)
    assert np.allclose(est.predict(Xt[:7]), est.predict(Xt)[:7], atol=1e-12)
    Xr, yr = X.copy(), y.copy()
    Xr.setflags(write=False)
    yr.setflags(write=False)
    assert np.allclose(clone(est).fit(Xr, yr).predict(Xt), est.predict(Xt), atol=1e-12)
    assert np.allclose(clone(est).fit(X.tolist(), y.tolist()).predict(Xt), est.predict(Xt), atol=1e-12)
    X0 = np.array(X, copy=True)
    clone(est).fit(X, y)
    assert est.get_params()["method"] == "biharmonic" and np.array_equal(X, X0)  # nothing overwritten
    Y2 = np.column_stack([y, 2 * y])
    assert est.fit(X, Y2).predict(Xt).shape == (len(Xt), 2)


def test_the_gp_gives_its_std_and_bad_inputs_are_one_line():
    est = SurfaceRegressor(V, F, method="gp").fit(IDX[:, None], field(V[IDX]))
    mean, std = est.predict(np.arange(len(V))[:, None], return_std=True)
    assert np.allclose(std[IDX], 0.0, atol=1e-6) and std.max() > 0.01 and mean.shape == (len(V),)
    with pytest.raises(SampleError, match="columns"):
        est.predict(V[:3])
    with pytest.raises(SampleError, match=r"\(k, 1\) vertex indices or \(k, 3\) positions"):
        SurfaceRegressor(V, F).fit(np.zeros((5, 2)), np.zeros(5))
    with pytest.raises(SampleError, match="outside"):
        est.predict(np.array([[10 ** 6]]))
    with pytest.raises(manifill.OptionError, match="no std"):
        SurfaceRegressor(V, F, method="harmonic").fit(IDX[:, None], field(V[IDX])).predict(IDX[:3, None],
                                                                                         return_std=True)


def test_cross_val_score_and_pipelines():
    X, y = IDX[:, None], field(V[IDX])
    scores = cross_val_score(SurfaceRegressor(V, F, method="biharmonic"), X, y, cv=KFold(5, shuffle=True,
                                                                                          random_state=0))
    assert scores.min() > 0.9
    pipe = make_pipeline(SurfaceRegressor(V, F, method="harmonic"))
    assert pipe.fit(X, y).score(X, y) == pytest.approx(1.0)


def test_a_grid_search_over_smoothing_agrees_with_gcv():
    """Noisy samples: GridSearchCV over lambda picks one within 2x of generalised cross-validation's."""
    idx = np.sort(RNG.choice(len(V), 300, replace=False))
    y = field(V[idx]) + RNG.normal(0, 0.15, idx.size)
    gcv = manifill.reconstruct(V, F, idx, y, method="biharmonic", smoothing="auto")
    lam = gcv.report["fill"]["smoothing"]["lambda"]
    grid = GridSearchCV(SurfaceRegressor(V, F, method="biharmonic"),
                        {"smoothing": list(np.logspace(-5, 0, 21))}, cv=KFold(5, shuffle=True, random_state=0))
    grid.fit(idx[:, None], y)
    picked = grid.best_params_["smoothing"]
    assert lam / 2 <= picked <= 2 * lam, (picked, lam)


def test_point_clouds_too():
    est = SurfaceRegressor(V, None, method="biharmonic").fit(IDX[:, None], field(V[IDX]))
    mesh = SurfaceRegressor(V, F, method="biharmonic").fit(IDX[:, None], field(V[IDX]))
    Xt = np.arange(len(V))[:, None]
    assert np.allclose(est.predict(Xt), mesh.predict(Xt), atol=1e-9)
