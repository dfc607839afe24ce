"""The validation layer: every bad input gets its own error class and a one-line message naming it."""

import numpy as np
import pytest

from conftest import grid, single_triangle
from manifill import HarmonicSolver, ManifillError, MeshError, OptionError, SampleError, harmonic, laplacian
from manifill.validate import (
    as_cells,
    as_indices,
    as_laplacian,
    as_mask,
    as_mesh,
    as_origin,
    as_samples,
    as_spacing,
    as_tets,
    as_values,
    check_option,
)

V9, F8 = grid(3)  # 9 vertices, 8 faces, vertex i at ((i % 3) / 2, (i // 3) / 2)


def check_error(exc_info, cls, *fragments):
    """The error has the class, is a ManifillError and a ValueError, is one line and names the problem."""
    err = exc_info.value
    assert type(err) is cls
    assert isinstance(err, ManifillError) and isinstance(err, ValueError)
    msg = str(err)
    assert msg and "\n" not in msg
    for frag in fragments:
        assert frag in msg, f"{frag!r} not in {msg!r}"


def replaced(A, index, value, dtype=None):
    A = np.array(A, dtype=dtype)
    A[index] = value
    return A


# ---------------------------------------------------------------------------
# as_mesh
# ---------------------------------------------------------------------------

BAD_MESHES = {
    # name: (V, F, fragments of the message)
    "V_1d": (np.zeros(9), F8, ["V has shape (9,)"]),
    "V_4_columns": (np.zeros((9, 4)), F8, ["V has shape (9, 4)"]),
    "V_1_column": (np.zeros((9, 1)), F8, ["V has shape (9, 1)"]),
    "V_3d": (np.zeros((9, 3, 1)), F8, ["V has shape (9, 3, 1)"]),
    "V_empty": (np.zeros((0, 3)), F8, ["V is empty"]),
    "V_text": ([["a", "b", "c"]] * 9, F8, ["V could not be read as numbers"]),
    "V_ragged": ([[0, 0, 0], [1, 0]], F8, ["V could not be read as numbers"]),
    "V_nan": (replaced(replaced(V9, (2, 0), np.nan), (5, 2), np.nan), F8,
              ["2 vertices have NaN or infinite coordinates", "rows 2, 5"]),
    "V_inf": (replaced(V9, (7, 1), -np.inf), F8, ["1 vertices have NaN or infinite", "rows 7"]),
    "F_1d": (V9, F8.ravel(), ["F has shape (24,)"]),
    "F_4_columns": (V9, np.zeros((8, 4), int), ["F has shape (8, 4)"]),
    "F_transposed": (V9, F8.T, ["F has shape (3, 8)"]),
    "F_empty": (V9, np.zeros((0, 3), int), ["F is empty"]),
    "F_ragged": (V9, [[0, 1, 2], [1, 2]], ["F is ragged"]),
    "F_float_fraction": (V9, F8 + 0.5, ["F has dtype float64", "integers"]),
    "F_float_nan": (V9, replaced(F8, (0, 0), np.nan, float), ["F has dtype float64"]),
    "F_bool": (V9, F8 > 3, ["F has dtype bool"]),
    "F_text": (V9, F8.astype(str), ["F has dtype <U"]),
    "F_negative": (V9, replaced(F8, (3, 1), -1), ["F refers to vertex -1, outside 0..8", "rows 3"]),
    "F_too_big": (V9, replaced(F8, (5, 2), 9), ["F refers to vertex 9, outside 0..8", "rows 5"]),
    "F_far_too_big_uint": (V9, replaced(F8, (6, 0), 4_000_000_000, np.uint32), ["F refers to vertex 4000000000"]),
    "F_both_ends": (V9, replaced(replaced(F8, (1, 0), -3), (4, 1), 12), ["F refers to vertex -3", "rows 1, 4"]),
    "zero_area_collinear": (np.vstack([V9, [[2.0, 0, 0], [3.0, 0, 0]]]), np.vstack([F8, [[2, 9, 10]]]),
                            ["1 faces have zero area", "faces 8", "clean_mesh"]),
    "zero_area_repeated_index": (V9, replaced(F8, (2, 1), F8[2, 0]), ["1 faces have zero area", "faces 2"]),
    "unreferenced": (np.vstack([V9, [[5.0, 5, 5], [6.0, 6, 6]]]), F8,
                     ["2 vertices are used by no face", "vertices 9, 10", "clean_mesh"]),
    "unwelded": (np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0]]), [[0, 1, 2], [3, 4, 2]],
                 ["1 pairs of vertices coincide", "first: 1 and 3", "clean_mesh"]),
}


@pytest.mark.parametrize("name", list(BAD_MESHES))
def test_as_mesh_rejects(name):
    V, F, fragments = BAD_MESHES[name]
    with pytest.raises(MeshError) as exc:
        as_mesh(V, F)
    check_error(exc, MeshError, *fragments)


@pytest.mark.parametrize("name", list(BAD_MESHES))
def test_bad_mesh_surfaces_through_harmonic_and_laplacian(name):
    V, F, fragments = BAD_MESHES[name]
    with pytest.raises(MeshError) as exc:
        harmonic(V, F, [0], [1.0], weights="cotan")
    # harmonic takes tetrahedra (m, 4) too, as libigl's does: eight all-zero tets leave vertices unused
    check_error(exc, MeshError, *(["used by no tetrahedron"] if name == "F_4_columns" else fragments))
    if not name.startswith("unreferenced"):  # laplacian allows vertices used by no face
        with pytest.raises(MeshError) as exc:
            laplacian(V, F, weights="cotan")
        check_error(exc, MeshError, *fragments)


@pytest.mark.parametrize("dtype", [np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16, np.uint32, np.uint64])
def test_as_mesh_accepts_any_integer_dtype(dtype):
    V, F = as_mesh(V9, F8.astype(dtype))
    assert F.dtype == np.int64 and V.dtype == np.float64
    np.testing.assert_array_equal(F, F8)
    np.testing.assert_array_equal(V, V9)


def test_as_mesh_accepts_integral_floats_lists_and_flat_meshes():
    V, F = as_mesh(V9[:, :2].tolist(), F8.astype(float).tolist())
    assert V.shape == (9, 3) and F.dtype == np.int64
    np.testing.assert_array_equal(V, V9)
    np.testing.assert_array_equal(F, F8)


@pytest.mark.parametrize(
    "name, flag",
    [("zero_area_collinear", "allow_degenerate"), ("zero_area_repeated_index", "allow_degenerate"),
     ("unreferenced", "allow_unreferenced"), ("unwelded", "allow_unwelded")],
)
def test_as_mesh_allow_flags(name, flag):
    V, F, _ = BAD_MESHES[name]
    V2, F2 = as_mesh(V, F, **{flag: True})
    np.testing.assert_array_equal(F2, np.asarray(F))


def test_weld_tolerance_is_relative_to_the_mesh_size():
    for s in (1e-6, 1.0, 1e6):
        near = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1 + 1e-14, 0, 0], [1, 1, 0]]) * s
        with pytest.raises(MeshError, match="coincide"):
            as_mesh(near, [[0, 1, 2], [3, 4, 2]])
        apart = near.copy()
        apart[3, 0] = (1 + 1e-9) * s  # distinct vertices, however close
        as_mesh(apart, [[0, 1, 2], [3, 4, 2]])


def test_small_but_nondegenerate_faces_accepted():
    V, F = single_triangle()
    for s in (1e-8, 1e8):
        as_mesh(V * s, F)
    sliver = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, 1e-6, 0]])
    as_mesh(sliver, [[0, 1, 2]])


# ---------------------------------------------------------------------------
# as_indices
# ---------------------------------------------------------------------------

BAD_INDICES = {
    "2d": ([[1], [2]], ["idx has shape (2, 1)"]),
    "scalar": (3, ["idx has shape ()"]),
    "empty": ([], ["idx is empty"]),
    "ragged": ([[1], [2, 3]], ["idx is ragged"]),
    "fraction": ([1.5, 2.0], ["idx has dtype float64"]),
    "nan": ([np.nan, 2.0], ["idx has dtype float64"]),
    "bool_mask": (np.arange(9) > 4, ["idx has dtype bool"]),
    "huge_python_int": ([2**70], ["idx has dtype object"]),
    "negative": ([0, -1, 3], ["idx holds vertex -1, outside 0..8", "entries 1"]),
    "too_big": ([0, 9, 3], ["idx holds vertex 9, outside 0..8", "entries 1"]),
    "both_ends": ([-2, 4, 11], ["idx holds vertex -2", "entries 0, 2"]),
    "duplicate": ([3, 1, 3, 1, 5], ["idx lists vertex 1 more than once", "2 repeated vertices"]),
}


@pytest.mark.parametrize("name", list(BAD_INDICES))
def test_as_indices_rejects(name):
    b, fragments = BAD_INDICES[name]
    with pytest.raises(SampleError) as exc:
        as_indices(b, 9)
    check_error(exc, SampleError, *fragments)


@pytest.mark.parametrize("name", [n for n in BAD_INDICES if n != "scalar"])
def test_bad_indices_surface_through_harmonic(name):
    b, fragments = BAD_INDICES[name]
    with pytest.raises(SampleError) as exc:
        HarmonicSolver(V9, F8, b)
    check_error(exc, SampleError, *fragments)


def test_as_indices_names_the_argument():
    with pytest.raises(SampleError, match=r"^fixed holds vertex 9"):
        as_indices([9], 9, what="fixed")
    with pytest.raises(SampleError, match=r"^heights has NaN"):
        as_values([np.nan], 1, what="heights")


@pytest.mark.parametrize("dtype", [np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16, np.uint32, np.uint64,
                                   float])
def test_as_indices_accepts_any_integer_dtype_in_order(dtype):
    b = as_indices(np.array([8, 0, 3], dtype=dtype), 9)
    assert b.dtype == np.int64 and b.tolist() == [8, 0, 3]


def test_as_indices_duplicates_allowed_when_not_unique():
    assert as_indices([3, 3, 0], 9, unique=False).tolist() == [3, 3, 0]


@pytest.mark.filterwarnings("ignore:invalid value encountered in cast:RuntimeWarning")
def test_as_indices_integral_float_too_large_for_int64_is_rejected():
    with pytest.raises(SampleError):
        as_indices([1e20], 9)


# ---------------------------------------------------------------------------
# as_values
# ---------------------------------------------------------------------------

BAD_VALUES = {
    "too_few": ([1.0, 2.0, 3.0], 4, ["vals has shape (3,) for 4 vertices"]),
    "too_many_rows": (np.zeros((5, 2)), 4, ["vals has shape (5, 2) for 4 vertices"]),
    "3d": (np.zeros((4, 2, 2)), 4, ["vals has shape (4, 2, 2)"]),
    "scalar": (1.0, 4, ["vals has shape () for 4 vertices"]),
    "no_columns": (np.zeros((4, 0)), 4, ["vals has no columns"]),
    "text": (["a", "b", "c", "d"], 4, ["vals could not be read as numbers"]),
    "ragged": ([[1.0], [1.0, 2.0]], 2, ["vals could not be read as numbers"]),
    "nan": ([0.0, np.nan, 1.0, np.nan], 4, ["vals has NaN or infinite values in rows 1, 3"]),
    "inf_in_a_column": ([[0.0, 1.0], [0.0, np.inf], [1.0, 1.0]], 3, ["rows 1"]),
}


@pytest.mark.parametrize("name", list(BAD_VALUES))
def test_as_values_rejects(name):
    bc, k, fragments = BAD_VALUES[name]
    with pytest.raises(SampleError) as exc:
        as_values(bc, k)
    check_error(exc, SampleError, *fragments)


@pytest.mark.parametrize("name", [n for n in BAD_VALUES if n not in ("ragged", "inf_in_a_column")])
def test_bad_values_surface_through_harmonic(name):
    bc, _, fragments = BAD_VALUES[name]
    with pytest.raises(SampleError) as exc:
        harmonic(V9, F8, [0, 2, 6, 8], bc)
    check_error(exc, SampleError, *fragments)
    solver = HarmonicSolver(V9, F8, [0, 2, 6, 8])
    with pytest.raises(SampleError):
        solver.solve(bc)


def test_as_values_shapes():
    bc, squeeze = as_values([1, 2, 3], 3)
    assert bc.shape == (3, 1) and bc.dtype == np.float64 and squeeze
    bc, squeeze = as_values(np.ones((3, 2), dtype=np.int16), 3)
    assert bc.shape == (3, 2) and bc.dtype == np.float64 and not squeeze


# ---------------------------------------------------------------------------
# as_samples
# ---------------------------------------------------------------------------


def test_as_samples_conflicting_values_are_listed():
    with pytest.raises(SampleError) as exc:
        as_samples([2, 0, 2, 5, 5], [1.0, 3.0, 4.5, 7.0, 8.0], 9)
    check_error(exc, SampleError, "2 vertices get two different values", "vertex 2: rows 0, 2 = 1, 4.5",
                "duplicates='mean'")


def test_as_samples_mean_averages_conflicts():
    idx, vals, squeeze = as_samples([2, 0, 2, 5, 5, 5], [1.0, 3.0, 4.0, 7.0, 8.0, 12.0], 9, duplicates="mean")
    assert idx.tolist() == [0, 2, 5] and squeeze
    np.testing.assert_allclose(vals[:, 0], [3.0, 2.5, 9.0])


def test_as_samples_mean_per_column():
    idx, vals, squeeze = as_samples([4, 4, 1], [[1.0, 10.0], [3.0, 30.0], [0.0, 0.0]], 9, duplicates="mean")
    assert idx.tolist() == [1, 4] and not squeeze
    np.testing.assert_allclose(vals, [[0.0, 0.0], [2.0, 20.0]])


def test_as_samples_equal_repeats_merge_silently():
    idx, vals, _ = as_samples([7, 1, 7], [0.25, -1.0, 0.25], 9)
    assert idx.tolist() == [1, 7]
    assert vals[:, 0].tolist() == [-1.0, 0.25]


def test_as_samples_sorts_unique_samples():
    idx, vals, _ = as_samples(np.array([8, 0, 3], dtype=np.uint16), [8.0, 0.0, 3.0], 9)
    assert idx.tolist() == [0, 3, 8] and vals[:, 0].tolist() == [0.0, 3.0, 8.0]


@pytest.mark.parametrize(
    "idx, vals, cls, fragments",
    [
        ([0, -1], [1.0, 2.0], SampleError, ["idx holds vertex -1", "entries 1"]),
        ([0, 9], [1.0, 2.0], SampleError, ["idx holds vertex 9", "entries 1"]),
        ([], [], SampleError, ["idx is empty"]),
        ([0, 1, 2], [1.0, np.nan, np.inf], SampleError, ["vals has NaN or infinite values in rows 1, 2"]),
        ([0, 1, 2], [1.0, 2.0], SampleError, ["vals has shape (2,) for 3 vertices"]),
    ],
)
def test_as_samples_rejects(idx, vals, cls, fragments):
    with pytest.raises(cls) as exc:
        as_samples(idx, vals, 9)
    check_error(exc, cls, *fragments)


def test_as_samples_unknown_duplicates_option():
    with pytest.raises(OptionError) as exc:
        as_samples([0], [1.0], 9, duplicates="first")
    check_error(exc, OptionError, "duplicates='first'", "'error', 'mean'")


# ---------------------------------------------------------------------------
# check_option
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("value", ["fast", "Cotan", "", None, 1, ["cotan"], b"cotan"])
def test_check_option_rejects(value):
    with pytest.raises(OptionError) as exc:
        check_option("weights", value, ("uniform", "cotan"))
    check_error(exc, OptionError, f"weights={value!r}", "'uniform', 'cotan'")


def test_check_option_returns_the_value():
    assert check_option("weights", "cotan", ("uniform", "cotan")) == "cotan"


@pytest.mark.parametrize(
    "kw, fragment",
    [({"weights": "cot"}, "weights='cot'"), ({"solver": "fast"}, "solver='fast'"),
     ({"on_empty": "zero"}, "on_empty='zero'"), ({"solver": "iterate", "iteration": "sor"}, "iteration='sor'")],
)
def test_bad_options_surface_through_harmonic(kw, fragment):
    with pytest.raises(OptionError) as exc:
        harmonic(V9, F8, [0, 8], [0.0, 1.0], **kw)
    check_error(exc, OptionError, fragment)


def test_degenerate_faces_through_harmonic_depend_on_weights():
    V, F, _ = BAD_MESHES["zero_area_collinear"]
    with pytest.raises(MeshError, match="zero area"):
        harmonic(V, F, [0, 10], [0.0, 1.0], weights="cotan")
    x = harmonic(V, F, [0, 10], [0.0, 1.0], weights="uniform")
    assert np.isfinite(x).all()


# ---------------------------------------------------------------------------
# as_tets and as_cells
# ---------------------------------------------------------------------------

TV = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]])
TT = np.array([[0, 1, 2, 3], [1, 2, 3, 4]])

BAD_TETS = {
    "V_flat": (TV[:, :2], TT, ["V has shape (5, 2)", "(n, 3)"]),
    "V_4_columns": (np.zeros((5, 4)), TT, ["V has shape (5, 4)"]),
    "V_nan": (replaced(TV, (4, 2), np.nan), TT, ["1 vertices have NaN or infinite coordinates", "rows 4"]),
    "T_triangles": (TV, TT[:, :3], ["T has shape (2, 3)", "tetrahedra"]),
    "T_empty": (TV, np.zeros((0, 4), int), ["T is empty"]),
    "T_fraction": (TV, TT + 0.25, ["T has dtype float64"]),
    "T_negative": (TV, replaced(TT, (1, 3), -1), ["T refers to vertex -1, outside 0..4", "rows 1"]),
    "T_too_big": (TV, replaced(TT, (0, 0), 5), ["T refers to vertex 5, outside 0..4", "rows 0"]),
    "T_both_ends": (TV, replaced(replaced(TT, (0, 0), 7), (1, 0), -1), ["T refers to vertex -1", "rows 0, 1"]),
    "flat_tet": (np.vstack([TV, [[2.0, 0, 0]]]), np.vstack([TT, [[0, 1, 5, 2]]]), ["1 tetrahedra have zero volume"]),
    "unreferenced": (np.vstack([TV, [[5.0, 5, 5]]]), TT, ["1 vertices are used by no tetrahedron", "vertices 5"]),
}


@pytest.mark.parametrize("name", list(BAD_TETS))
def test_as_tets_rejects(name):
    V, T, fragments = BAD_TETS[name]
    with pytest.raises(MeshError) as exc:
        as_tets(V, T)
    check_error(exc, MeshError, *fragments)


def test_as_tets_accepts_either_orientation_and_integral_floats():
    V, T = as_tets(TV.tolist(), TT[:, ::-1].astype(float))
    assert V.dtype == np.float64 and T.dtype == np.int64
    np.testing.assert_array_equal(T, TT[:, ::-1])


@pytest.mark.parametrize("dtype", [np.uint8, np.int16, np.uint32, np.int64])
def test_as_cells_any_integer_dtype_and_the_upper_end(dtype):
    np.testing.assert_array_equal(as_cells(TT.astype(dtype), 5, width=4), TT)
    with pytest.raises(MeshError) as exc:
        as_cells(TT.astype(dtype), 4, width=4, what="T", kind="tetrahedra")
    check_error(exc, MeshError, "T refers to vertex 4, outside 0..3", "rows 1")


# ---------------------------------------------------------------------------
# voxel grids: the mask, its spacing and origin are the domain (MeshError)
# ---------------------------------------------------------------------------

MASK = np.zeros((3, 4, 5), dtype=bool)
MASK[1, 1:3, 1:4] = True

BAD_MASKS = {
    "2d": (np.ones((4, 4), dtype=bool), ["mask has shape (4, 4)", "3-D"]),
    "4d": (np.ones((2, 2, 2, 2), dtype=bool), ["mask has shape (2, 2, 2, 2)"]),
    "ragged": ([[[0, 1]], [[1]]], ["mask is ragged"]),
    "empty_grid": (np.zeros((0, 3, 3), dtype=bool), ["mask has no voxel set"]),
    "no_voxel": (np.zeros((3, 3, 3)), ["mask has no voxel set"]),
    "twos": (MASK * 2, ["mask holds values other than 0 and 1 (int64)"]),
    "halves": (MASK * 0.5, ["other than 0 and 1 (float64)"]),
    "nan": (np.where(MASK, np.nan, 0.0), ["other than 0 and 1"]),
    "text": (np.full((2, 2, 2), "x"), ["other than 0 and 1"]),
}


@pytest.mark.parametrize("name", list(BAD_MASKS))
def test_as_mask_rejects_with_a_mesh_error(name):
    mask, fragments = BAD_MASKS[name]
    with pytest.raises(MeshError) as exc:
        as_mask(mask)
    check_error(exc, MeshError, *fragments)


def test_as_mask_of_fixed_voxels_is_a_sample_error():
    with pytest.raises(SampleError) as exc:
        as_mask(MASK[:, :, :-1], what="fixed", shape=MASK.shape, error=SampleError)
    check_error(exc, SampleError, "fixed has shape (3, 4, 4) but the mask has (3, 4, 5)")
    with pytest.raises(SampleError) as exc:
        as_mask(np.zeros_like(MASK), what="fixed", error=SampleError)
    check_error(exc, SampleError, "fixed has no voxel set")


@pytest.mark.parametrize("dtype", [bool, np.uint8, np.int64, np.float32])
def test_as_mask_accepts_zeros_and_ones_of_any_dtype(dtype):
    m = as_mask(MASK.astype(dtype), shape=(3, 4, 5))
    assert m.dtype == bool and m.flags.c_contiguous
    np.testing.assert_array_equal(m, MASK)


@pytest.mark.parametrize("bad", [(1, 2), (1, 2, 3, 4), (0, 1, 1), (1, -1, 1), (np.inf, 1, 1), (np.nan, 1, 1), None,
                                 "abc", (1, "a", 2), 0.0, []])
def test_as_spacing_rejects_with_a_mesh_error(bad):
    with pytest.raises(MeshError) as exc:
        as_spacing(bad)
    check_error(exc, MeshError, "spacing", "spacing=(1.0, 1.0, 2.5)")


def test_as_spacing_one_number_means_cubes():
    assert as_spacing(2).tolist() == [2.0, 2.0, 2.0]
    assert as_spacing([1, 2, 3.5]).tolist() == [1.0, 2.0, 3.5] and as_spacing((1, 1, 1)).dtype == np.float64


@pytest.mark.parametrize("bad", [(0, 0), (0, 0, 0, 0), (np.nan, 0, 0), (0, -np.inf, 0), None, "abc", 1.0])
def test_as_origin_rejects_with_a_mesh_error(bad):
    with pytest.raises(MeshError) as exc:
        as_origin(bad)
    check_error(exc, MeshError, "origin", "three finite numbers")


def test_as_origin_accepts_negative_and_far_origins():
    assert as_origin((-1, 0, 1e300)).tolist() == [-1.0, 0.0, 1e300]


# ---------------------------------------------------------------------------
# a user's Laplacian (MeshError: it stands for the mesh)
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "L, fragments",
    [
        (np.ones((3, 4)), ["L has shape (3, 4)", "square"]),
        (np.ones(3), ["L has shape (3,)"]),
        (np.array([[1.0, np.nan], [np.nan, 1.0]]), ["L has NaN or infinite entries"]),
        (np.array([[np.inf, 0.0], [0.0, 1.0]]), ["L has NaN or infinite entries"]),
        (np.array([["a", "b"], ["c", "d"]]), ["L could not be read as a sparse matrix"]),
        ("L", ["L could not be read"]),
    ],
    ids=["rectangular", "vector", "nan", "inf", "text", "string"],
)
def test_as_laplacian_rejects_with_a_mesh_error(L, fragments):
    with pytest.raises(MeshError) as exc:
        as_laplacian(L)
    check_error(exc, MeshError, *fragments)


def test_as_laplacian_returns_float_csr():
    L = laplacian(V9, F8)
    A = as_laplacian(L.astype(np.float32).tocoo())
    assert A.format == "csr" and A.dtype == np.float64
    np.testing.assert_allclose(A.toarray(), L.toarray(), rtol=1e-7)
