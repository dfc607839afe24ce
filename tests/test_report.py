"""The numbers of a run's summary (manifill.report): each field's range, NaN left out."""

import numpy as np
import pytest

from manifill.report import value_ranges


def test_ranges_per_field_skip_nan():
    X = np.array([[1.0, -2.0], [np.nan, np.nan], [3.0, 4.0], [-1.0, np.nan]])
    lo, hi = value_ranges(X)
    np.testing.assert_array_equal(lo, [-1.0, -2.0])
    np.testing.assert_array_equal(hi, [3.0, 4.0])


def test_one_field_and_voxels():
    lo, hi = value_ranges([2.0, 5.0, -1.0])
    assert lo.tolist() == [-1.0] and hi.tolist() == [5.0]
    V = np.full((3, 4, 5, 2), np.nan)
    V[1, 2, 3] = [7.0, -3.0]
    V[0, 0, 1] = [1.0, 9.0]
    lo, hi = value_ranges(V, point_ndim=3)
    assert lo.tolist() == [1.0, -3.0] and hi.tolist() == [7.0, 9.0]
    lo, hi = value_ranges(V[..., 0], point_ndim=3)
    assert lo.tolist() == [1.0] and hi.tolist() == [7.0]


def test_a_field_without_values_has_a_nan_range():
    lo, hi = value_ranges(np.array([[np.nan, 1.0], [np.nan, 2.0]]))
    assert np.isnan(lo[0]) and np.isnan(hi[0]) and lo[1] == 1.0 and hi[1] == 2.0


@pytest.mark.parametrize("side, says", [("upper", "smoother than the samples can tell"),
                                        ("lower", "look uncorrelated at their spacing")])
def test_a_fitted_range_at_the_searchs_bound_says_what_to_do(side, says):
    from manifill.report import uncertainty_lines

    bounds = [0.1, 5.0]
    gp = {"alpha": 2, "nu": 1.0, "range": [bounds[1] if side == "upper" else bounds[0]], "sigma": [1.0],
          "noise": [0.0], "fitted": ["range", "sigma"], "fit": {"range_bounds": bounds}}
    lines = uncertainty_lines({"gp": gp}, np.ones(4))
    assert f"at the search's {side} bound" in lines[0] and says in lines[1]
    gp["range"] = [1.0]  # inside the search: no advice
    assert not any("the likelihood wanted" in x for x in uncertainty_lines({"gp": gp}, np.ones(4)))
