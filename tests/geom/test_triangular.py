"""Triangular Bézier patches (trimsurf.geom.triangular)."""

from fractions import Fraction
from math import factorial

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from trimsurf.errors import GeometryError
from trimsurf.geom import (bezier_triangle_derivatives, bezier_triangle_points, elevate_bezier_triangle,
                           triangle_indices)
from trimsurf.model import BezierTriangle

EPS = np.finfo(float).eps


def n_points(n):
    return (n + 1) * (n + 2) // 2


def random_bary(rng, k):
    b = rng.dirichlet(np.ones(3), size=k)
    return b


def exact_point(net, n, bary):
    """sum_I b_I n!/(i!j!k!) u^i v^j w^k in exact arithmetic."""
    u, v, w = (Fraction(x) for x in bary)
    total = [Fraction(0)] * net.shape[1]
    for (i, j, k), b in zip(triangle_indices(n).tolist(), net):
        c = Fraction(factorial(n), factorial(i) * factorial(j) * factorial(k)) * u ** i * v ** j * w ** k
        for d in range(net.shape[1]):
            total[d] += c * Fraction(b[d])
    return [float(x) for x in total]


def test_triangle_indices_order():
    assert triangle_indices(2).tolist() == [[2, 0, 0], [1, 1, 0], [1, 0, 1], [0, 2, 0], [0, 1, 1], [0, 0, 2]]
    for n in (0, 1, 5, 20):
        idx = triangle_indices(n)
        assert idx.shape == (n_points(n), 3) and idx.dtype == np.int64
        assert np.all(idx.sum(axis=1) == n)
        assert len({tuple(r) for r in idx}) == idx.shape[0]
        # i descending, then j descending: lexicographic order of (-i, -j)
        keys = [(-i, -j) for i, j, _ in idx]
        assert keys == sorted(keys)
    with pytest.raises(GeometryError, match="n must be >= 0"):
        triangle_indices(-1)
    with pytest.raises(GeometryError, match="integer"):
        triangle_indices(2.0)


@pytest.mark.parametrize("n", [1, 3, 8, 20])
def test_partition_of_unity(n):
    rng = np.random.default_rng(n)
    bary = np.vstack([random_bary(rng, 50), np.eye(3), [[0.5, 0.5, 0.0]]])
    ones = np.ones((n_points(n), 1))
    # n levels of convex combinations of values <= 1: a few ulps per level
    assert_allclose(bezier_triangle_points(ones, n, bary)[:, 0], 1.0, rtol=0, atol=(n + 1) * 4 * EPS)


def test_degree_20_matches_exact_arithmetic():
    n = 20
    rng = np.random.default_rng(20)
    net = rng.uniform(-10, 10, size=(n_points(n), 3))
    bary = np.vstack([random_bary(rng, 3), [[1 / 3, 1 / 3, 1 / 3]]])
    bary[:, 2] = 1.0 - bary[:, 0] - bary[:, 1]
    got = bezier_triangle_points(net, n, bary)
    for q in range(bary.shape[0]):
        # 1e-12 relative to the net size 10: 20 levels of convex combinations cost ~60 ulps
        assert_allclose(got[q], exact_point(net, n, bary[q]), rtol=0, atol=1e-12 * 10)


def test_vertices_and_edges_interpolate():
    rng = np.random.default_rng(0)
    n = 4
    net = rng.normal(size=(n_points(n), 3))
    corners = bezier_triangle_points(net, n, np.eye(3))
    idx = triangle_indices(n)
    for c in range(3):
        corner = np.flatnonzero(idx[:, c] == n)[0]
        assert_allclose(corners[c], net[corner], rtol=0, atol=0)  # exact: only one basis function is 1


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), times=st.integers(1, 6))
def test_elevated_linear_net_reproduces_the_linear_function(seed, times):
    rng = np.random.default_rng(seed)
    corners = rng.uniform(-5, 5, size=(3, 2))  # degree-1 net: the values at the corners
    net = elevate_bezier_triangle(corners, 1, times)
    n = 1 + times
    assert net.shape == (n_points(n), 2)
    bary = random_bary(rng, 30)
    # linear precision: b_I = sum_c (I_c / n) corner_c, up to rounding of the elevation steps
    assert_allclose(net, (triangle_indices(n) / n) @ corners, rtol=0, atol=1e-14 * 5 * n)
    assert_allclose(bezier_triangle_points(net, n, bary), bary @ corners, rtol=0, atol=1e-14 * 5 * n)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 9), times=st.integers(0, 4))
def test_elevation_leaves_the_patch_unchanged(seed, n, times):
    rng = np.random.default_rng(seed)
    net = rng.uniform(-1, 1, size=(3, n_points(n), 3))  # a batch of three patches
    up = elevate_bezier_triangle(net, n, times)
    assert up.shape == (3, n_points(n + times), 3)
    bary = random_bary(rng, 20)
    # convex combinations in elevation and evaluation: tens of ulps for degree <= 13
    assert_allclose(bezier_triangle_points(up, n + times, bary), bezier_triangle_points(net, n, bary),
                    rtol=0, atol=1e-13)
    d_up = bezier_triangle_derivatives(up, n + times, bary, n_derivs=2)
    d = bezier_triangle_derivatives(net, n, bary, n_derivs=2)
    # derivatives scale with n(n-1) ~ 170 and the differences of the net: relative to that
    assert_allclose(d_up, d, rtol=0, atol=1e-13 * max(1, (n + times) ** 2) * 4)


def test_batched_evaluation_equals_one_by_one():
    rng = np.random.default_rng(4)
    n = 5
    nets = rng.normal(size=(7, n_points(n), 3))
    bary = random_bary(rng, 11)
    batch = bezier_triangle_points(nets, n, bary)
    dbatch = bezier_triangle_derivatives(nets, n, bary, n_derivs=2)
    assert batch.shape == (7, 11, 3) and dbatch.shape == (3, 3, 7, 11, 3)
    # the same sums, possibly in another BLAS order: a few ulps of the values (points ~3, derivatives ~100)
    for p in range(7):
        assert_allclose(batch[p], bezier_triangle_points(nets[p], n, bary), rtol=0, atol=1e-14)
        assert_allclose(dbatch[:, :, p], bezier_triangle_derivatives(nets[p], n, bary, n_derivs=2), rtol=0,
                        atol=1e-13)
    assert_allclose(BezierTriangle(n, nets[2]).evaluate(bary), batch[2], rtol=0, atol=1e-14)


def blossom_net(n, f):
    """Control points of a quadratic monomial in (s, t) = (v, w) via its blossom at the index points."""
    idx = triangle_indices(n)
    j, k = idx[:, 1].astype(float), idx[:, 2].astype(float)
    m = n * (n - 1)
    return {"ss": j * (j - 1) / m, "st": j * k / m, "tt": k * (k - 1) / m}[f]


@pytest.mark.parametrize("n", [2, 3, 6])
def test_derivatives_of_exact_quadratics(n):
    rng = np.random.default_rng(n)
    bary = random_bary(rng, 15)
    s, t = bary[:, 1], bary[:, 2]
    net = np.stack([blossom_net(n, "ss"), blossom_net(n, "st"), blossom_net(n, "tt")], axis=1)
    d = bezier_triangle_derivatives(net, n, bary, n_derivs=2)
    zero, one = np.zeros_like(s), np.ones_like(s)
    expected = {
        (0, 0): [s * s, s * t, t * t],
        (1, 0): [2 * s, t, zero],
        (0, 1): [zero, s, 2 * t],
        (2, 0): [2 * one, zero, zero],
        (1, 1): [zero, one, zero],
        (0, 2): [zero, zero, 2 * one],
    }
    for (a, b), cols in expected.items():
        # exact polynomials with O(1) coefficients: only rounding, scaled by n(n-1) for second derivatives
        assert_allclose(d[a, b], np.stack(cols, axis=1), rtol=0, atol=1e-14 * n * n * 4)
    assert np.all(d[1, 2] == 0) and np.all(d[2, 1] == 0) and np.all(d[2, 2] == 0)


def test_derivatives_match_finite_differences():
    rng = np.random.default_rng(12)
    n = 6
    net = rng.uniform(-1, 1, size=(n_points(n), 3))
    st_ = rng.uniform(0.1, 0.4, size=(10, 2))
    h = 1e-5

    def f(s, t):
        return bezier_triangle_points(net, n, np.column_stack([1 - s - t, s, t]))

    s, t = st_[:, 0], st_[:, 1]
    d = bezier_triangle_derivatives(net, n, np.column_stack([1 - s - t, s, t]), n_derivs=2)
    fd_s = (f(s + h, t) - f(s - h, t)) / (2 * h)
    fd_t = (f(s, t + h) - f(s, t - h)) / (2 * h)
    fd_ss = (f(s + h, t) - 2 * f(s, t) + f(s - h, t)) / h ** 2
    fd_st = (f(s + h, t + h) - f(s + h, t - h) - f(s - h, t + h) + f(s - h, t - h)) / (4 * h * h)
    # central differences: truncation h^2/6 |x'''| <~ 1e-10 * n^3 |net| ~ 1e-8, rounding eps/h ~ 1e-11 for first
    # derivatives; second differences lose eps/h^2 ~ 2e-6 to rounding
    assert_allclose(d[1, 0], fd_s, rtol=0, atol=1e-7)
    assert_allclose(d[0, 1], fd_t, rtol=0, atol=1e-7)
    assert_allclose(d[2, 0], fd_ss, rtol=0, atol=1e-4)
    assert_allclose(d[1, 1], fd_st, rtol=0, atol=1e-4)
    assert_allclose(d[0, 0], f(s, t), rtol=0, atol=1e-15 * 8)  # same sum, another BLAS order


def test_derivatives_above_the_degree_are_zero():
    net = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])
    d = bezier_triangle_derivatives(net, 1, [[0.2, 0.3, 0.5]], n_derivs=2)
    assert_allclose(d[1, 0], [[-1.0, 1.0]], rtol=0, atol=0)
    assert_allclose(d[0, 1], [[-1.0, 0.0]], rtol=0, atol=0)
    assert np.all(d[2, 0] == 0) and np.all(d[1, 1] == 0) and np.all(d[0, 2] == 0)


def test_inputs_are_not_modified():
    net = np.arange(30.0).reshape(10, 3)
    keep = net.copy()
    out = elevate_bezier_triangle(net, 3, 0)
    out[0] = -1.0
    bezier_triangle_derivatives(net, 3, [[0.2, 0.3, 0.5]], n_derivs=2)
    assert np.array_equal(net, keep)


def test_bad_input():
    net = np.zeros((6, 3))
    with pytest.raises(GeometryError, match="needs 10 control points; got 6"):
        bezier_triangle_points(net, 3, [[1.0, 0.0, 0.0]])
    with pytest.raises(GeometryError, match="degree must be >= 0"):
        bezier_triangle_points(net, -1, [[1.0, 0.0, 0.0]])
    with pytest.raises(GeometryError, match=r"\(N, dim\) or \(n_patches, N, dim\)"):
        bezier_triangle_points(np.zeros(6), 2, [[1.0, 0.0, 0.0]])
    with pytest.raises(GeometryError, match=r"bary must have shape \(k, 3\)"):
        bezier_triangle_points(net, 2, [[0.5, 0.5]])
    with pytest.raises(GeometryError, match="sum to 1"):
        bezier_triangle_points(net, 2, [[0.5, 0.5, 0.5]])
    with pytest.raises(GeometryError, match="NaN"):
        bezier_triangle_points(net, 2, [[np.nan, 0.5, 0.5]])
    with pytest.raises(GeometryError, match="NaN"):
        bezier_triangle_points(np.full((6, 3), np.inf), 2, [[1.0, 0.0, 0.0]])
    with pytest.raises(GeometryError, match="n_derivs must be 0, 1 or 2"):
        bezier_triangle_derivatives(net, 2, [[1.0, 0.0, 0.0]], n_derivs=3)
    with pytest.raises(GeometryError, match="needs 6 control points"):
        bezier_triangle_derivatives(np.zeros((5, 3)), 2, [[1.0, 0.0, 0.0]])
    with pytest.raises(GeometryError, match="times must be an integer >= 0"):
        elevate_bezier_triangle(net, 2, -1)
    with pytest.raises(GeometryError, match="needs 3 control points"):
        elevate_bezier_triangle(net, 1)
