"""NURBS evaluation against scipy's independent B-spline evaluation (BSpline, NdBSpline)."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from numpy.testing import assert_allclose
from scipy.interpolate import BSpline, NdBSpline

from trimsurf import geom
from trimsurf.errors import GeometryError
from trimsurf.model import NurbsCurve, NurbsSurface


def random_knots(rng, degree, n_ctrl, *, repeated=True):
    """Clamped knot vector with random interior knots, some repeated up to the degree."""
    n_inner = n_ctrl - degree - 1
    inner = np.sort(rng.uniform(0.1, 3.9, n_inner))
    if repeated and n_inner >= 2:
        inner[1] = inner[0]  # a double knot
    return np.r_[np.zeros(degree + 1), inner, np.full(degree + 1, 4.0)]


def scipy_surface_derivs(ku, kv, pu, pv, cp, w, uv, nd):
    """SKL by scipy: evaluate numerator and denominator, apply the quotient rule (independent of A4.4)."""
    hom = cp * (w[..., None] if w is not None else 1.0)
    num = NdBSpline((ku, kv), hom, (pu, pv))
    den = NdBSpline((ku, kv), w if w is not None else np.ones(cp.shape[:2]), (pu, pv))
    A = {(k, l): num(uv, nu=(k, l)) for k in range(nd + 1) for l in range(nd + 1 - k)}
    W = {(k, l): den(uv, nu=(k, l))[:, None] for k in range(nd + 1) for l in range(nd + 1 - k)}
    S = {}
    S[0, 0] = A[0, 0] / W[0, 0]
    if nd >= 1:
        S[1, 0] = (A[1, 0] - W[1, 0] * S[0, 0]) / W[0, 0]
        S[0, 1] = (A[0, 1] - W[0, 1] * S[0, 0]) / W[0, 0]
    if nd >= 2:
        S[2, 0] = (A[2, 0] - 2 * W[1, 0] * S[1, 0] - W[2, 0] * S[0, 0]) / W[0, 0]
        S[0, 2] = (A[0, 2] - 2 * W[0, 1] * S[0, 1] - W[0, 2] * S[0, 0]) / W[0, 0]
        S[1, 1] = (A[1, 1] - W[1, 0] * S[0, 1] - W[0, 1] * S[1, 0] - W[1, 1] * S[0, 0]) / W[0, 0]
    return S


@settings(max_examples=25, deadline=None)
@given(pu=st.integers(1, 6), pv=st.integers(1, 6), rational=st.booleans(), seed=st.integers(0, 2**31))
def test_surface_derivatives_match_scipy(pu, pv, rational, seed):
    rng = np.random.default_rng(seed)
    nu, nv = pu + 1 + rng.integers(0, 5), pv + 1 + rng.integers(0, 5)
    ku, kv = random_knots(rng, pu, nu), random_knots(rng, pv, nv)
    cp = rng.normal(size=(nu, nv, 3))
    w = rng.uniform(0.3, 3.0, (nu, nv)) if rational else None
    uv = rng.uniform(0, 4, (50, 2))
    ours = geom.surface_derivatives(pu, pv, ku, kv, cp, w, uv, n_derivs=2)
    ref = scipy_surface_derivs(ku, kv, pu, pv, cp, w, uv, 2)
    scale = np.abs(cp).max()
    for (k, l), val in ref.items():
        # values grow with derivative order through 1/(knot spacing)^k; compare relative to the reference size
        atol = 1e-10 * scale * max(1.0, np.abs(val).max())
        assert_allclose(ours[k, l], val, rtol=0, atol=atol, err_msg=f"SKL[{k},{l}]")


@settings(max_examples=25, deadline=None)
@given(p=st.integers(1, 7), dim=st.sampled_from([2, 3]), rational=st.booleans(), seed=st.integers(0, 2**31))
def test_curve_derivatives_match_scipy(p, dim, rational, seed):
    rng = np.random.default_rng(seed)
    n = p + 1 + rng.integers(0, 6)
    k = random_knots(rng, p, n)
    cp = rng.normal(size=(n, dim))
    w = rng.uniform(0.3, 3.0, n) if rational else np.ones(n)
    t = rng.uniform(0, 4, 40)
    num = BSpline(k, cp * w[:, None], p)
    den = BSpline(k, w, p)
    a0, a1, a2 = num(t), num(t, 1), num(t, 2)
    w0, w1, w2 = den(t)[:, None], den(t, 1)[:, None], den(t, 2)[:, None]
    c0 = a0 / w0
    c1 = (a1 - w1 * c0) / w0
    c2 = (a2 - 2 * w1 * c1 - w2 * c0) / w0
    ours = geom.curve_derivatives(p, k, cp, w if rational else None, t, n_derivs=2)
    for i, ref in enumerate((c0, c1, c2)):
        assert_allclose(ours[i], ref, rtol=0, atol=1e-10 * max(1.0, np.abs(ref).max()))


def test_degree_19_bezier_patch_matches_exact_bernstein():
    """An order-20 tensor Bezier patch (real car data has them) against exact rational arithmetic."""
    from fractions import Fraction
    from math import comb

    rng = np.random.default_rng(7)
    p = 19
    knots = np.r_[np.zeros(p + 1), np.ones(p + 1)]
    cp = rng.normal(size=(p + 1, p + 1, 3))
    uv = np.array([[0.3, 0.7], [0.05, 0.95], [0.5, 0.5]])
    ours = geom.surface_points(p, p, knots, knots, cp, None, uv)
    for (u, v), got in zip(uv, ours):
        fu, fv = Fraction(u), Fraction(v)
        bu = [comb(p, i) * fu**i * (1 - fu) ** (p - i) for i in range(p + 1)]
        bv = [comb(p, j) * fv**j * (1 - fv) ** (p - j) for j in range(p + 1)]
        exact = [float(sum(bu[i] * bv[j] * Fraction(cp[i, j, d]) for i in range(p + 1) for j in range(p + 1)))
                 for d in range(3)]
        # Cox-de Boor is backward stable: error ~ p * machine eps * sum |B_i||P_i|
        assert_allclose(got, exact, rtol=0, atol=1e-13 * np.abs(cp).max() * p)


def test_domain_ends_and_clamping():
    p = 3
    k = np.r_[np.zeros(4), [0.5, 0.5, 0.5], np.ones(4)]  # a C0 joint of multiplicity 3
    cp = np.arange(7 * 2, dtype=float).reshape(7, 2)
    c = NurbsCurve(p, k, cp)
    assert_allclose(c.evaluate([0.0, 0.5, 1.0]), cp[[0, 3, 6]], rtol=0, atol=1e-14)
    # parameters outside the domain are clamped, not extrapolated
    assert_allclose(c.evaluate([-1.0, 2.0]), cp[[0, 6]], rtol=0, atol=1e-14)


def test_normals_and_fundamental_form_of_a_cylinder_patch():
    # exact quarter cylinder of radius 2 as a rational quadratic in u, linear in v
    r = 2.0
    cp = np.array([[[r, 0, 0], [r, 0, 1]], [[r, r, 0], [r, r, 1]], [[0, r, 0], [0, r, 1]]], dtype=float)
    w = np.array([[1, 1], [np.sqrt(0.5)] * 2, [1, 1]])
    s = NurbsSurface(2, 1, [0, 0, 0, 1, 1, 1], [0, 0, 1, 1], cp, w)
    uv = np.random.default_rng(1).uniform(0, 1, (100, 2))
    pts = s.evaluate(uv)
    assert_allclose(np.hypot(pts[:, 0], pts[:, 1]), r, rtol=0, atol=1e-14 * r)
    n = s.normals(uv)
    assert_allclose(n[:, :2] * r, pts[:, :2] * np.sign(np.sum(n[:, :2] * pts[:, :2], axis=1))[:, None],
                    rtol=0, atol=1e-12)
    E, F, G = s.fundamental_form(uv)
    assert_allclose(F, 0, atol=1e-13)
    assert_allclose(G, 1, rtol=0, atol=1e-13)
    assert np.all(E > 0)


def test_bad_input():
    with pytest.raises(GeometryError, match="knots"):
        NurbsCurve(2, [0, 0, 1, 1], np.zeros((3, 2)))
    with pytest.raises(GeometryError, match="non-decreasing"):
        NurbsCurve(1, [0, 1, 0.5, 1], np.zeros((2, 2)))
    with pytest.raises(GeometryError, match="weights must be positive"):
        NurbsCurve(1, [0, 0, 1, 1], np.zeros((2, 2)), weights=[1, -1])
    with pytest.raises(GeometryError, match="non-finite"):
        NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], np.full((2, 2, 3), np.nan))
    s = NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], np.zeros((2, 2, 3)))
    with pytest.raises(GeometryError, match=r"uv must have shape \(n, 2\)"):
        s.evaluate(np.zeros((3, 3)))
    with pytest.raises(GeometryError, match="NaN"):
        s.evaluate([[np.nan, 0.0]])


@settings(max_examples=25, deadline=None)
@given(p=st.integers(1, 7), dim=st.sampled_from([2, 3]), rational=st.booleans(), seed=st.integers(0, 2**31))
def test_curve_points_kernel_matches_scipy(p, dim, rational, seed):
    # points only (n_derivs=0) go through the compiled kernel; t beyond the domain is clamped
    rng = np.random.default_rng(seed)
    n = p + 1 + rng.integers(0, 6)
    k = random_knots(rng, p, n)
    cp = rng.normal(size=(n, dim))
    w = rng.uniform(0.3, 3.0, n) if rational else np.ones(n)
    t = np.r_[rng.uniform(0, 4, 40), k[p], k[-p - 1]]
    ref = BSpline(k, cp * w[:, None], p)(t) / BSpline(k, w, p)(t)[:, None]
    ours = geom.curve_points(p, k, cp, w if rational else None, t)
    assert_allclose(ours, ref, rtol=0, atol=1e-12 * max(1.0, np.abs(ref).max()))
    lo = geom.curve_points(p, k, cp, w if rational else None, [k[p] - 1.0])
    assert_allclose(lo[0], ref[-2], rtol=0, atol=1e-12 * max(1.0, np.abs(ref).max()))


def test_homogeneous_net_cached_only_for_read_only_arrays():
    from trimsurf.geom.nurbs import _homogeneous

    cp = np.arange(12.0).reshape(4, 3)
    w = np.array([1.0, 2.0, 1.0, 0.5])
    a = _homogeneous(cp, w)
    cp[0, 0] = 100.0                    # a writable array may change: never served from the cache
    assert _homogeneous(cp, w)[0, 0] == 100.0 and a[0, 0] == 0.0
    cp.setflags(write=False)
    w.setflags(write=False)
    assert _homogeneous(cp, w) is _homogeneous(cp, w)
