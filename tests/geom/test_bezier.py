"""Bernstein bases, Bézier evaluation, elevation and power-basis conversion (trimsurf.geom.bezier)."""

from fractions import Fraction
from math import comb

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from trimsurf.errors import GeometryError
from trimsurf.geom import (bernstein, bernstein_derivatives, bezier_curve_derivatives, bezier_curve_points,
                           bezier_patch_derivatives, bezier_patch_points, bezier_to_monomial, curve_points,
                           elevate_bezier, monomial_to_bezier, surface_derivatives, surface_points)

EPS = np.finfo(float).eps


def bezier_knots(p):
    return np.concatenate([np.zeros(p + 1), np.ones(p + 1)])


# --------------------------------------------------------------------------- exact references


def exact_bernstein(p, i, t):
    t = Fraction(t)
    return comb(p, i) * t ** i * (1 - t) ** (p - i)


def poly_bernstein(p, i):
    """Exact coefficients (ascending powers) of B_i^p."""
    coeffs = [Fraction(0)] * (p + 1)
    for k in range(p - i + 1):  # t^i (1-t)^(p-i) = sum_k C(p-i, k) (-1)^k t^(i+k)
        coeffs[i + k] += comb(p, i) * comb(p - i, k) * (-1) ** k
    return coeffs


def poly_derivative(c):
    return [k * c[k] for k in range(1, len(c))] or [Fraction(0)]


def poly_eval(c, t):
    t = Fraction(t)
    return sum(ck * t ** k for k, ck in enumerate(c))


def exact_de_casteljau(points, t):
    """de Casteljau in exact arithmetic; points is a list of lists of Fractions."""
    t = Fraction(t)
    pts = [list(p) for p in points]
    while len(pts) > 1:
        pts = [[(1 - t) * a + t * b for a, b in zip(p, q)] for p, q in zip(pts[:-1], pts[1:])]
    return pts[0]


# --------------------------------------------------------------------------- bernstein


def test_bernstein_degree_25_matches_exact_values():
    t = np.array([0.0, 1e-3, 0.1, 1 / 3, 0.5, 0.77, 0.999, 1.0])
    b = bernstein(25, t)
    expected = np.array([[float(exact_bernstein(25, i, x)) for i in range(26)] for x in t])
    # the recurrence makes 25 levels of convex combinations: <= ~25 rounding errors on values <= 1
    assert_allclose(b, expected, rtol=0, atol=30 * EPS)
    assert_allclose(b.sum(axis=1), 1.0, rtol=0, atol=30 * EPS)
    assert np.all(b >= 0)


def test_bernstein_derivatives_match_exact_polynomials():
    p = 7
    t = np.array([0.0, 0.2, 0.5, 0.9, 1.0])
    d = bernstein_derivatives(p, t, n_derivs=3)
    assert d.shape == (4, 5, 8)
    for i in range(p + 1):
        c = poly_bernstein(p, i)
        for k in range(4):
            expected = [float(poly_eval(c, x)) for x in t]
            # derivative values are up to p!/(p-3)! * 2^3 ~ 1700; a few hundred ulps of that
            assert_allclose(d[k, :, i], expected, rtol=0, atol=1e-11)
            c = poly_derivative(c)


def test_bernstein_derivatives_above_degree_are_zero():
    d = bernstein_derivatives(2, [0.3, 0.6], n_derivs=4)
    assert np.all(d[3:] == 0)
    assert_allclose(d[2], [[2, -4, 2], [2, -4, 2]], rtol=0, atol=1e-14)  # exact up to rounding


def test_bernstein_bad_input():
    with pytest.raises(GeometryError, match="degree must be >= 0"):
        bernstein(-1, [0.5])
    with pytest.raises(GeometryError, match="integer"):
        bernstein(2.5, [0.5])
    with pytest.raises(GeometryError, match=r"shape \(n,\)"):
        bernstein(2, [[0.5]])
    with pytest.raises(GeometryError, match="NaN"):
        bernstein(2, [np.nan])
    with pytest.raises(GeometryError, match="n_derivs must be >= 0"):
        bernstein_derivatives(2, [0.5], n_derivs=-1)


# --------------------------------------------------------------------------- evaluation


def test_degree_19_patch_matches_exact_de_casteljau():
    rng = np.random.default_rng(19)
    net = rng.uniform(-10, 10, size=(20, 20, 3))
    weights = rng.uniform(0.5, 2.0, size=(20, 20))
    uv = np.array([[0.3, 0.7], [1 / 3, 0.05], [0.91, 0.5]])
    got = bezier_patch_points(net, uv)
    got_w = bezier_patch_points(net, uv, weights=weights)
    for q, (u, v) in enumerate(uv):
        # homogeneous exact evaluation: rows first (v), then the column (u)
        rows = [exact_de_casteljau([[Fraction(x) for x in net[i, j]] + [Fraction(1)] for j in range(20)], v)
                for i in range(20)]
        rows_w = [exact_de_casteljau([[Fraction(x) * Fraction(weights[i, j]) for x in net[i, j]]
                                      + [Fraction(weights[i, j])] for j in range(20)], v) for i in range(20)]
        exact = exact_de_casteljau(rows, u)
        exact_w = exact_de_casteljau(rows_w, u)
        # 1e-12 relative to the control-net size (10): degree 19 + 19 convex steps cost ~40 ulps
        assert_allclose(got[q], [float(x) for x in exact[:3]], rtol=0, atol=1e-12 * 10)
        assert_allclose(got_w[q], [float(x / exact_w[3]) for x in exact_w[:3]], rtol=0, atol=1e-12 * 10)


def test_degree_19_patch_agrees_with_nurbs_evaluation():
    rng = np.random.default_rng(7)
    net = rng.uniform(-1, 1, size=(20, 18, 3))
    weights = rng.uniform(0.5, 2.0, size=(20, 18))
    uv = rng.uniform(0, 1, size=(50, 2))
    kn_u, kn_v = bezier_knots(19), bezier_knots(17)
    mine = bezier_patch_derivatives(net, uv, weights=weights, n_derivs=2)
    ref = surface_derivatives(19, 17, kn_u, kn_v, net, weights, uv, n_derivs=2)
    # second derivatives of a degree-19 rational patch reach ~1e3-1e4: compare relative to their size
    for k in range(3):
        for l in range(3 - k):
            scale = max(1.0, np.abs(ref[k, l]).max())
            assert_allclose(mine[k, l], ref[k, l], rtol=0, atol=1e-11 * scale)


def test_curve_derivatives_rational_agree_with_nurbs():
    rng = np.random.default_rng(3)
    cp = rng.normal(size=(6, 2))
    w = rng.uniform(0.5, 2, 6)
    t = np.linspace(0, 1, 23)
    mine = bezier_curve_derivatives(cp, t, weights=w, n_derivs=2)
    from trimsurf.geom import curve_derivatives
    ref = curve_derivatives(5, bezier_knots(5), cp, w, t, n_derivs=2)
    assert_allclose(mine, ref, rtol=0, atol=1e-11 * np.abs(ref).max())  # two stable algorithms, ~1e3 ulps
    assert_allclose(bezier_curve_points(cp, t, weights=w), ref[0], rtol=0, atol=1e-13 * 4)


def test_evaluation_clamps_parameters():
    cp = np.array([[0.0, 0.0], [1.0, 2.0], [3.0, 1.0]])
    assert_allclose(bezier_curve_points(cp, [-1.0, 2.0]), cp[[0, -1]], rtol=0, atol=0)
    net = np.arange(12.0).reshape(2, 2, 3)
    assert_allclose(bezier_patch_points(net, [[-5.0, 7.0]]), net[0, 1][None], rtol=0, atol=0)


def test_evaluation_bad_input():
    with pytest.raises(GeometryError, match=r"\(p \+ 1, dim\)"):
        bezier_curve_points(np.zeros((3,)), [0.5])
    with pytest.raises(GeometryError, match="weights must have shape"):
        bezier_curve_points(np.zeros((3, 2)), [0.5], weights=np.ones(2))
    with pytest.raises(GeometryError, match="positive"):
        bezier_curve_points(np.zeros((3, 2)), [0.5], weights=[1.0, 0.0, 1.0])
    with pytest.raises(GeometryError, match=r"\(p \+ 1, q \+ 1, dim\)"):
        bezier_patch_points(np.zeros((3, 3)), [[0.5, 0.5]])
    with pytest.raises(GeometryError, match=r"uv must have shape \(n, 2\)"):
        bezier_patch_points(np.zeros((3, 3, 3)), [[0.5, 0.5, 0.5]])
    with pytest.raises(GeometryError, match="n_derivs"):
        bezier_patch_derivatives(np.zeros((3, 3, 3)), [[0.5, 0.5]], n_derivs=-2)
    with pytest.raises(GeometryError, match="NaN"):
        bezier_curve_derivatives(np.full((3, 2), np.nan), [0.5])


# --------------------------------------------------------------------------- elevation


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), degree=st.integers(0, 12), times=st.integers(0, 4),
       rational=st.booleans())
def test_elevate_bezier_keeps_the_curve(seed, degree, times, rational):
    rng = np.random.default_rng(seed)
    cp = rng.uniform(-1, 1, size=(degree + 1, 3))
    w = rng.uniform(0.5, 2, degree + 1) if rational else np.ones(degree + 1)
    hom = np.concatenate([cp * w[:, None], w[:, None]], axis=1)
    up = elevate_bezier(hom, times)
    assert up.shape == (degree + times + 1, 4)
    t = np.linspace(0, 1, 31)
    before = bezier_curve_points(cp, t, weights=w)
    after = bezier_curve_points(up[:, :3] / up[:, 3:], t, weights=up[:, 3])
    # convex combinations only: a few ulps per elevation step and per evaluation level
    assert_allclose(after, before, rtol=0, atol=1e-13)


def test_elevate_bezier_along_second_axis_of_a_patch():
    rng = np.random.default_rng(11)
    net = rng.normal(size=(4, 3, 3))
    up = elevate_bezier(net, 2, axis=1)
    assert up.shape == (4, 5, 3)
    uv = rng.uniform(0, 1, size=(40, 2))
    assert_allclose(bezier_patch_points(up, uv), bezier_patch_points(net, uv), rtol=0, atol=1e-13)
    assert_allclose(up[:, 0], net[:, 0], rtol=0, atol=0)  # end points are kept exactly
    assert np.shares_memory(elevate_bezier(net, 0), net) is False


def test_elevate_bezier_bad_input():
    with pytest.raises(GeometryError, match="times must be >= 0"):
        elevate_bezier(np.zeros((3, 2)), -1)
    with pytest.raises(GeometryError, match="out of range"):
        elevate_bezier(np.zeros((3, 2)), 1, axis=3)
    with pytest.raises(GeometryError, match="last"):
        elevate_bezier(np.zeros((3, 2)), 1, axis=1)
    with pytest.raises(GeometryError, match="no control point"):
        elevate_bezier(np.zeros((0, 2)), 1)


# --------------------------------------------------------------------------- power basis


def horner(coeffs, x):
    out = np.zeros_like(coeffs[0] * x[:, None])
    for c in coeffs[::-1]:
        out = out * x[:, None] + c
    return out


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), degree=st.integers(0, 9), mode=st.sampled_from(["local", "shifted", "plain"]))
def test_monomial_bezier_round_trip_and_values(seed, degree, mode):
    rng = np.random.default_rng(seed)
    a = rng.uniform(-1, 1, size=(degree + 1, 3))
    s0 = float(rng.uniform(-2, 2))
    s1 = s0 + float(rng.uniform(0.5, 3))
    kwargs = {"local": {}, "shifted": {"interval": (s0, s1)}, "plain": {"interval": (s0, s1), "origin": 0.0}}[mode]
    bez = monomial_to_bezier(a, **kwargs)
    back = bezier_to_monomial(bez, **kwargs)
    r = np.linspace(0, 1, 17)
    s = s0 + r * (s1 - s0)
    x = {"local": r, "shifted": s - s0, "plain": s}[mode]
    values = horner(a, x)
    # both sides are sums of terms up to sum_k |a_k| |x|^k (the condition of the power form): relative to it
    scale = max(1.0, horner(np.abs(a), np.abs(x)).max())
    assert_allclose(bezier_curve_points(bez, r), values, rtol=0, atol=1e-12 * scale * (degree + 1))
    # the round trip is a linear solve with the conversion matrix M: it loses up to cond(M) (huge for plain
    # powers far from 0) times a size-dependent factor; measured <= 3.6 (p+1)^2 eps cond(M) on 3000 cases
    cond = np.linalg.cond(monomial_to_bezier(np.eye(degree + 1), **kwargs))
    assert_allclose(back, a, rtol=0, atol=10 * (degree + 1) ** 2 * EPS * cond)


def test_monomial_to_bezier_along_axis_1_of_a_patch():
    rng = np.random.default_rng(5)
    a = rng.normal(size=(3, 4, 3))  # x(u, v) = sum a_ij u^i v^j on [0,1]^2
    bez = monomial_to_bezier(monomial_to_bezier(a, axis=0), axis=1)
    uv = rng.uniform(0, 1, size=(20, 2))
    expected = np.einsum("ijd,ni,nj->nd", a, uv[:, :1] ** np.arange(3), uv[:, 1:] ** np.arange(4))
    assert_allclose(bezier_patch_points(bez, uv), expected, rtol=0, atol=1e-13 * 20)


def test_monomial_known_values():
    # x(s) = (s - 2)^2 on [2, 4]: in r, 4 r^2 -> Bézier (0, 0, 4)
    assert_allclose(monomial_to_bezier([[0.0], [0.0], [1.0]], interval=(2, 4))[:, 0], [0, 0, 4], rtol=0, atol=0)
    # x(s) = s on [2, 4] in plain powers -> Bézier (2, 4)
    assert_allclose(monomial_to_bezier([[0.0], [1.0]], interval=(2, 4), origin=0.0)[:, 0], [2, 4], rtol=0,
                    atol=0)


def test_monomial_bad_input():
    with pytest.raises(GeometryError, match="s0 < s1"):
        monomial_to_bezier([[1.0], [2.0]], interval=(1.0, 1.0))
    with pytest.raises(GeometryError, match="pair"):
        monomial_to_bezier([[1.0], [2.0]], interval=(1.0,))
    with pytest.raises(GeometryError, match="origin needs an interval"):
        bezier_to_monomial([[1.0], [2.0]], origin=0.0)
    with pytest.raises(GeometryError, match="out of range"):
        monomial_to_bezier([[1.0], [2.0]], axis=2)
    with pytest.raises(GeometryError, match="NaN"):
        bezier_to_monomial([[np.inf], [2.0]])
    with pytest.raises(GeometryError, match="no entry"):
        monomial_to_bezier(np.zeros((0, 3)))


def test_inputs_are_not_modified():
    cp = np.arange(9.0).reshape(3, 3)
    keep = cp.copy()
    elevate_bezier(cp, 2)
    monomial_to_bezier(cp, interval=(0.0, 2.0))
    bezier_to_monomial(cp)
    bezier_curve_derivatives(cp, [0.2], weights=np.ones(3), n_derivs=2)
    assert np.array_equal(cp, keep)


def test_patch_points_agree_with_surface_points():
    rng = np.random.default_rng(2)
    net = rng.normal(size=(4, 6, 3))
    uv = rng.uniform(0, 1, size=(30, 2))
    ref = surface_points(3, 5, bezier_knots(3), bezier_knots(5), net, None, uv)
    assert_allclose(bezier_patch_points(net, uv), ref, rtol=0, atol=1e-13 * 10)
    cp = net[:, 0]
    assert_allclose(bezier_curve_points(cp, uv[:, 0]), curve_points(3, bezier_knots(3), cp, None, uv[:, 0]),
                    rtol=0, atol=1e-13 * 10)
