"""Step 4's gradient fits (manifill.surface.slopes) against a slow fit, one sample at a time.

The reference follows the documented rule sample by sample in plain numpy: the samples within two steps
in the curve network whose normals are within 45 degrees, offsets projected onto the tangent plane, weights
one over the offset's length; a quadratic fit (full least squares) with eight or more neighbours when its
condition is below 1 / TOL.gradient_rcond, else the minimum-norm linear fit with cut-off
TOL.gradient_line_rcond, with two or more.
"""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import grid, icosphere, torus
from manifill.mesh.graph import mesh_graph
from manifill.surface.curve_values import vertex_normals
from manifill.surface.partition import partition
from manifill.surface.slopes import sample_gradients
from manifill.surface.surface import Surface
from manifill.tolerances import TOL

hsettings = settings(max_examples=30, deadline=None, derandomize=True, database=None,
                     suppress_health_check=[HealthCheck.too_slow])


def slow_gradients(V, normals, ends, idx, vals):
    k, p = vals.shape
    where = {int(v): i for i, v in enumerate(idx)}
    nb = [set() for _ in range(k)]
    for a, b in ends.tolist():
        nb[where[a]].add(where[b])
        nb[where[b]].add(where[a])
    grads, known = np.zeros((k, 3, p)), np.zeros(k, dtype=bool)
    for i in range(k):
        n = normals[idx[i]]
        ring = sorted(j for j in nb[i] | {m for j in nb[i] for m in nb[j]}
                      if j != i and normals[idx[j]] @ n >= np.cos(np.pi / 4))
        if len(ring) < 2:
            continue
        ref = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
        e1 = np.cross(n, ref)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(n, e1)
        d = V[idx[ring]] - V[idx[i]]
        D = np.column_stack([d @ e1, d @ e2])
        w = 1.0 / np.hypot(D[:, 0], D[:, 1])
        Y = (vals[ring] - vals[i]) * w[:, None]
        coef = None
        if len(ring) >= 8:
            Q = np.column_stack([D, 0.5 * D[:, 0] ** 2, D[:, 0] * D[:, 1], 0.5 * D[:, 1] ** 2]) * w[:, None]
            S = np.linalg.svd(Q, compute_uv=False)
            if S[-1] / TOL.gradient_rcond > S[0]:
                coef = np.linalg.lstsq(Q, Y, rcond=None)[0][:2]
        if coef is None:
            coef = np.linalg.lstsq(D * w[:, None], Y, rcond=TOL.gradient_line_rcond)[0]
        grads[i] = np.outer(e1, coef[0]) + np.outer(e2, coef[1])
        known[i] = True
    return grads, known


def network(V, F, k, seed, method):
    idx = np.sort(np.random.default_rng(seed).choice(len(V), size=k, replace=False))
    part = partition(Surface.from_mesh(V, F), idx, graph=mesh_graph(V, F), method=method)
    return idx, part.ends


@hsettings
@given(mesh=st.sampled_from(["sphere", "grid", "torus"]), method=st.sampled_from(["delaunay", "tree", "cycle"]),
       seed=st.integers(0, 10**6), k=st.integers(2, 60), p=st.integers(1, 3))
def test_the_batched_fits_equal_the_fits_one_sample_at_a_time(mesh, method, seed, k, p):
    V, F = {"sphere": lambda: icosphere(3), "grid": lambda: grid(12), "torus": torus}[mesh]()
    idx, ends = network(V, F, min(k, len(V)), seed, method)
    vals = np.random.default_rng(seed + 1).normal(size=(len(idx), p))
    normals = vertex_normals(V, F, idx)
    g, known = sample_gradients(V, normals, ends, idx, vals)
    ref, ref_known = slow_gradients(V, normals, ends, idx, vals)
    np.testing.assert_array_equal(known, ref_known)
    scale = max(1.0, float(np.abs(ref).max()))
    assert np.abs(g - ref).max() <= 1e-12 * scale


def test_neighbours_on_a_line_give_the_minimum_norm_linear_fit():
    # eight or more neighbours, all on the x axis: the quadratic fit is rank deficient, the linear one
    # exact along the line and zero across it
    x = np.array([-4.0, -3, -2, -1, 0, 1, 2, 3, 4])
    V = np.column_stack([x, np.zeros(9), np.zeros(9)])
    normals = np.tile([0.0, 0, 1], (9, 1))
    idx = np.arange(9)
    ends = np.array([[4, j] for j in range(9) if j != 4])
    vals = np.column_stack([3.0 * x, x ** 2])
    g, known = sample_gradients(V, normals, ends, idx, vals)
    ref, _ = slow_gradients(V, normals, ends, idx, vals)
    assert known.all()
    np.testing.assert_allclose(g, ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(g[:, 0, 0], 3.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(g[:, 1:, :], 0.0, rtol=0, atol=1e-12)


@pytest.mark.parametrize("seed", [0, 1])
def test_quadratic_fields_have_exact_gradients_where_the_fit_is_quadratic(seed):
    # on a flat grid a quadratic field is fitted exactly by the quadratic fit: its gradient at the sample
    V, F = grid(15)
    idx, ends = network(V, F, 40, seed, "delaunay")
    X = V[idx]
    vals = np.column_stack([1 + 2 * X[:, 0] - X[:, 1] + 0.5 * X[:, 0] ** 2 - X[:, 0] * X[:, 1]])
    g, known = sample_gradients(V, np.tile([0.0, 0, 1], (len(V), 1)), ends, idx, vals)
    ref, _ = slow_gradients(V, np.tile([0.0, 0, 1], (len(V), 1)), ends, idx, vals)
    quad = np.abs(ref[:, 0, 0] - (2 + X[:, 0] - X[:, 1])) < 1e-9  # the samples the quadratic fit served
    assert quad.sum() >= 10
    np.testing.assert_allclose(g[quad, 0, 0], (2 + X[:, 0] - X[:, 1])[quad], rtol=0, atol=1e-9)
    np.testing.assert_allclose(g[quad, 1, 0], (-1 - X[:, 0])[quad], rtol=0, atol=1e-9)
    assert known.all()


def test_a_fit_just_inside_the_condition_limit_stays_quadratic():
    # neighbours on a flat ellipse, squashed until the quadratic fit's condition is just below
    # 1 / TOL.gradient_rcond while |R|_F |R^-1|_F is above it (so only the singular values decide):
    # the fit must stay quadratic, exact on a quadratic field (a linear fit is not: 11 points, no symmetry)
    t = np.linspace(0, 2 * np.pi, 11, endpoint=False) + 0.3
    idx, ends = np.arange(12), np.array([[0, j] for j in range(1, 12)])
    normals = np.tile([0.0, 0, 1], (12, 1))
    limit = 1 / TOL.gradient_rcond
    for s in np.geomspace(1e-3, 1e-5, 800):
        d = np.column_stack([np.cos(t), s * np.sin(t)])
        w = 1 / np.hypot(d[:, 0], d[:, 1])
        Q = np.column_stack([d, 0.5 * d[:, 0] ** 2, d[:, 0] * d[:, 1], 0.5 * d[:, 1] ** 2]) * w[:, None]
        S = np.linalg.svd(Q, compute_uv=False)
        R = np.linalg.qr(Q)[1]
        if S[0] / S[-1] < 0.99 * limit and np.linalg.norm(R) * np.linalg.norm(np.linalg.inv(R)) > 1.01 * limit:
            break
    else:
        raise AssertionError("no squash gives a condition near the limit")
    V = np.vstack([[0.0, 0, 0], np.column_stack([d, np.zeros(11)])])
    vals = np.column_stack([V[:, 0] + 2 * V[:, 1] + V[:, 0] ** 2 + V[:, 0] * V[:, 1]])
    g, known = sample_gradients(V, normals, ends, idx, vals)
    ref, _ = slow_gradients(V, normals, ends, idx, vals)
    assert known[0]
    np.testing.assert_allclose(g[0], ref[0], rtol=1e-6, atol=0)
    np.testing.assert_allclose(g[0, :2, 0], [1.0, 2.0], rtol=1e-6)  # the quadratic fit is exact
