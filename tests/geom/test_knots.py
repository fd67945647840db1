"""Knot insertion, refinement, degree elevation, Bézier extraction and assembly (trimsurf.geom.knots)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from trimsurf.errors import GeometryError
from trimsurf.geom import (bezier_curve_points, bezier_curve_to_nurbs, bezier_extract, bezier_extract_surface,
                           bezier_grid_to_nurbs, bezier_patch_points, curve_points, elevate_bezier,
                           elevate_degree, insert_knot, refine_knots, surface_points)
from trimsurf.tolerance import Tolerance

# Every algorithm here is exact in exact arithmetic and built from convex combinations (insertion,
# extraction) or from short affine combinations with bounded factors (degree elevation's knot removal on
# knots spaced >= 1/16 apart): 1e-12 relative to the control-net size (1) leaves a margin of 40 over the
# largest error measured on 2000 random curves of this generator (6e-16 refinement and extraction,
# 2.4e-14 elevation).
REL = 1e-12

KNOT_POOL = np.arange(1, 16) / 16.0  # exactly representable interior knots
OUTER_POOL = np.array([-0.5, -0.25, -0.125, 0.0])


def random_knots(rng, p, n, clamped):
    n_inner = n - p - 1
    while True:
        inner = np.sort(rng.choice(KNOT_POOL, n_inner, replace=True))
        if n_inner == 0 or np.unique(inner, return_counts=True)[1].max() <= p:
            break
    if clamped:
        left, right = np.zeros(p + 1), np.ones(p + 1)
    else:
        left = np.append(np.sort(rng.choice(OUTER_POOL, p)), 0.0)
        right = np.insert(np.sort(1.0 - rng.choice(OUTER_POOL, p)), 0, 1.0)
    return np.concatenate([left, inner, right])


def random_curve(seed, p, extra, clamped, rational, dim=3):
    rng = np.random.default_rng(seed)
    n = p + 1 + extra
    knots = random_knots(rng, p, n, clamped)
    cp = rng.uniform(-1, 1, size=(n, dim))
    w = rng.uniform(0.5, 2.0, n) if rational else None
    return knots, cp, w


def random_surface(seed, pu, pv, eu, ev, clamped, rational):
    rng = np.random.default_rng(seed)
    nu, nv = pu + 1 + eu, pv + 1 + ev
    ku = random_knots(rng, pu, nu, clamped)
    kv = random_knots(rng, pv, nv, clamped)
    cp = rng.uniform(-1, 1, size=(nu, nv, 3))
    w = rng.uniform(0.5, 2.0, (nu, nv)) if rational else None
    return ku, kv, cp, w


curve_args = dict(seed=st.integers(0, 2**32 - 1), p=st.integers(1, 5), extra=st.integers(0, 6),
                  clamped=st.booleans(), rational=st.booleans())
T = np.linspace(0.0, 1.0, 41)  # every random knot vector has the domain [0, 1]
UV = np.stack(np.meshgrid(np.linspace(0, 1, 9), np.linspace(0, 1, 7)), axis=-1).reshape(-1, 2)


# --------------------------------------------------------------------------- insertion


@settings(max_examples=40, deadline=None)
@given(**curve_args, data=st.data())
def test_insert_knot_keeps_the_curve(seed, p, extra, clamped, rational, data):
    knots, cp, w = random_curve(seed, p, extra, clamped, rational)
    candidates = [t for t in np.unique(knots[p:-p]) if np.count_nonzero(knots == t) < p] + [0.3, 0.71875]
    t = data.draw(st.sampled_from(candidates))
    s = np.count_nonzero(knots == t)
    times = data.draw(st.integers(1, p - s))
    res = insert_knot(p, knots, cp, w, t, times)
    assert res.control_points.shape == (cp.shape[0] + times, 3)
    assert np.count_nonzero(res.knots == t) == s + times
    assert np.all(np.diff(res.knots) >= 0)
    assert (res.weights is None) == (w is None)
    assert_allclose(curve_points(p, *res, T), curve_points(p, knots, cp, w, T), rtol=0, atol=REL)


@settings(max_examples=40, deadline=None)
@given(**curve_args, n_new=st.integers(1, 8))
def test_refine_knots_keeps_the_curve(seed, p, extra, clamped, rational, n_new):
    knots, cp, w = random_curve(seed, p, extra, clamped, rational)
    rng = np.random.default_rng(seed + 1)
    new = rng.choice(np.concatenate([KNOT_POOL, [0.0, 1.0, 0.1, 0.9]]), n_new)
    if np.unique(np.concatenate([knots, new]), return_counts=True)[1].max() > p + 1:
        with pytest.raises(GeometryError, match="multiplicity"):
            refine_knots(p, knots, cp, w, new)
        return
    res = refine_knots(p, knots, cp, w, new)
    assert res.control_points.shape[0] == cp.shape[0] + n_new
    assert np.array_equal(res.knots, np.sort(np.concatenate([knots, new])))
    assert_allclose(curve_points(p, *res, T), curve_points(p, knots, cp, w, T), rtol=0, atol=REL)


def test_insert_and_refine_agree():
    knots, cp, w = random_curve(4, 3, 4, False, True)
    a = insert_knot(3, knots, cp, w, 0.40625, 2)
    b = refine_knots(3, knots, cp, w, [0.40625, 0.40625])
    assert np.array_equal(a.knots, b.knots)
    assert_allclose(a.control_points, b.control_points, rtol=0, atol=1e-14)  # same convex combinations
    assert_allclose(a.weights, b.weights, rtol=0, atol=1e-14)


def test_insert_knot_at_the_domain_ends_of_an_unclamped_curve():
    knots = np.array([-0.5, -0.25, 0.0, 0.5, 1.0, 1.25, 1.5])  # p = 2, domain [0, 1]
    cp = np.array([[0.0, 0.0], [1.0, 2.0], [2.0, -1.0], [3.0, 1.0]])
    for t in (0.0, 1.0):
        res = insert_knot(2, knots, cp, None, t, 1)
        assert_allclose(curve_points(2, *res, T), curve_points(2, knots, cp, None, T), rtol=0, atol=REL * 3)
        # multiplicity p at an end makes a control point the end point of the curve
        end = res.control_points[1 if t == 0.0 else -2]
        assert_allclose(end, curve_points(2, knots, cp, None, [t])[0], rtol=0, atol=1e-15 * 3)


def test_insertion_along_v_of_a_surface():
    ku, kv, cp, w = random_surface(8, 3, 2, 2, 3, False, True)
    res = insert_knot(2, kv, cp, w, 0.5625, 2, axis=1)
    assert res.control_points.shape == (cp.shape[0], cp.shape[1] + 2, 3)
    assert res.weights.shape == res.control_points.shape[:2]
    assert_allclose(surface_points(3, 2, ku, res.knots, res.control_points, res.weights, UV),
                    surface_points(3, 2, ku, kv, cp, w, UV), rtol=0, atol=REL)


def test_insertion_bad_input():
    knots, cp, w = random_curve(1, 2, 2, True, True)
    with pytest.raises(GeometryError, match="outside the domain"):
        insert_knot(2, knots, cp, w, 1.5)
    with pytest.raises(GeometryError, match="outside the domain"):
        refine_knots(2, knots, cp, w, [-0.1, 0.5])
    with pytest.raises(GeometryError, match="degree must be >= 1"):
        insert_knot(-1, knots, cp, w, 0.5)
    with pytest.raises(GeometryError, match="non-decreasing"):
        insert_knot(2, knots[::-1], cp, w, 0.5)
    with pytest.raises(GeometryError, match=r"knots must have shape \(8,\)"):
        insert_knot(2, knots[:-1], cp, w, 0.5)
    with pytest.raises(GeometryError, match="weights must have shape"):
        insert_knot(2, knots, cp, w[:-1], 0.5)
    with pytest.raises(GeometryError, match="weights must be positive"):
        insert_knot(2, knots, cp, -w, 0.5)
    with pytest.raises(GeometryError, match=r"multiplicity \d > degree 2"):
        insert_knot(2, knots, cp, w, 0.5, 3)
    with pytest.raises(GeometryError, match="multiplicity"):
        insert_knot(2, knots, cp, w, 0.0)  # clamped end knot already has multiplicity p + 1
    with pytest.raises(GeometryError, match="times must be >= 1"):
        insert_knot(2, knots, cp, w, 0.5, 0)
    with pytest.raises(GeometryError, match="axis"):
        insert_knot(2, knots, cp, w, 0.5, axis=1)
    with pytest.raises(GeometryError, match=r"shape \(n, dim\)"):
        insert_knot(2, knots, cp[:, 0], None, 0.5)
    with pytest.raises(GeometryError, match="NaN"):
        insert_knot(2, knots, cp, w, np.nan)
    with pytest.raises(GeometryError, match=r"new_knots must have shape \(r,\)"):
        refine_knots(2, knots, cp, w, [[0.5]])
    with pytest.raises(GeometryError, match="multiplicity"):
        refine_knots(2, knots, cp, w, [0.25, 0.25, 0.25, 0.25])


# --------------------------------------------------------------------------- degree elevation


@settings(max_examples=40, deadline=None)
@given(**curve_args, times=st.integers(0, 3))
def test_elevate_degree_keeps_the_curve(seed, p, extra, clamped, rational, times):
    knots, cp, w = random_curve(seed, p, extra, clamped, rational, dim=2)
    res = elevate_degree(p, knots, cp, w, times)
    assert res.degree == p + times
    q = res.degree
    # end knots clamped to multiplicity q + 1, every interior knot keeps multiplicity + times
    assert np.count_nonzero(res.knots == 0.0) == q + 1 and np.count_nonzero(res.knots == 1.0) == q + 1 \
        or times == 0
    inner, counts = np.unique(knots[(knots > 0) & (knots < 1)], return_counts=True)
    for value, count in zip(inner, counts):
        assert np.count_nonzero(res.knots == value) == count + times
    assert res.control_points.shape[0] == res.knots.shape[0] - q - 1
    assert_allclose(curve_points(q, *res[1:], T), curve_points(p, knots, cp, w, T), rtol=0, atol=REL)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), rational=st.booleans(), clamped=st.booleans(), times=st.integers(1, 2))
def test_elevate_degree_of_a_surface_in_u_and_v(seed, rational, clamped, times):
    ku, kv, cp, w = random_surface(seed, 2, 3, 3, 2, clamped, rational)
    ref = surface_points(2, 3, ku, kv, cp, w, UV)
    eu = elevate_degree(2, ku, cp, w, times, axis=0)
    assert eu.control_points.shape[1] == cp.shape[1]
    assert_allclose(surface_points(eu.degree, 3, eu.knots, kv, eu.control_points, eu.weights, UV), ref,
                    rtol=0, atol=REL)
    ev = elevate_degree(3, kv, eu.control_points, eu.weights, times, axis=1)
    assert_allclose(surface_points(eu.degree, ev.degree, eu.knots, ev.knots, ev.control_points, ev.weights, UV),
                    ref, rtol=0, atol=REL)


def test_elevate_degree_bad_input():
    knots, cp, w = random_curve(2, 2, 3, True, False)
    with pytest.raises(GeometryError, match="times must be >= 0"):
        elevate_degree(2, knots, cp, w, -1)
    with pytest.raises(GeometryError, match="degree must be >= 1"):
        elevate_degree(0, knots, cp, w)
    with pytest.raises(GeometryError, match="discontinuous"):
        elevate_degree(1, [0, 0, 0.5, 0.5, 1, 1], np.zeros((4, 2)), None)
    with pytest.raises(GeometryError, match="non-decreasing"):
        elevate_degree(2, np.roll(knots, 1), cp, w)
    with pytest.raises(GeometryError, match="at least 3 control points"):
        elevate_degree(2, [0, 0, 0, 1, 1], cp[:2], None)


# --------------------------------------------------------------------------- Bézier extraction


@settings(max_examples=40, deadline=None)
@given(**curve_args)
def test_bezier_extract_reproduces_the_curve_segment_by_segment(seed, p, extra, clamped, rational):
    knots, cp, w = random_curve(seed, p, extra, clamped, rational)
    seg = bezier_extract(p, knots, cp, w)
    distinct = np.unique(knots[p:-p])
    assert np.array_equal(seg.breaks, distinct)
    assert seg.control_points.shape == (distinct.size - 1, p + 1, 3)
    r = np.linspace(0, 1, 9)
    for i in range(distinct.size - 1):
        t = seg.breaks[i] + r * (seg.breaks[i + 1] - seg.breaks[i])
        wi = None if seg.weights is None else seg.weights[i]
        assert_allclose(bezier_curve_points(seg.control_points[i], r, weights=wi),
                        curve_points(p, knots, cp, w, t), rtol=0, atol=REL)
    joined = bezier_curve_to_nurbs(seg.control_points, seg.breaks, seg.weights)
    assert joined.degree == p
    assert_allclose(curve_points(*joined, T), curve_points(p, knots, cp, w, T), rtol=0, atol=REL)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), pu=st.integers(1, 4), pv=st.integers(1, 4), clamped=st.booleans(),
       rational=st.booleans())
def test_bezier_extract_surface_and_grid_round_trip(seed, pu, pv, clamped, rational):
    ku, kv, cp, w = random_surface(seed, pu, pv, 2, 3, clamped, rational)
    patches = bezier_extract_surface(pu, pv, ku, kv, cp, w)
    m, n = patches.u_breaks.size - 1, patches.v_breaks.size - 1
    assert patches.control_points.shape == (m, n, pu + 1, pv + 1, 3)
    local = np.random.default_rng(seed).uniform(0, 1, size=(10, 2))
    for i in range(m):
        for j in range(n):
            uv = np.column_stack([patches.u_breaks[i] + local[:, 0] * np.diff(patches.u_breaks)[i],
                                  patches.v_breaks[j] + local[:, 1] * np.diff(patches.v_breaks)[j]])
            wij = None if w is None else patches.weights[i, j]
            assert_allclose(bezier_patch_points(patches.control_points[i, j], local, weights=wij),
                            surface_points(pu, pv, ku, kv, cp, w, uv), rtol=0, atol=REL)
    s = bezier_grid_to_nurbs(patches.control_points, patches.u_breaks, patches.v_breaks, patches.weights)
    assert (s.degree_u, s.degree_v) == (pu, pv)
    assert (s.weights is None) == (w is None)
    assert_allclose(surface_points(*s, UV), surface_points(pu, pv, ku, kv, cp, w, UV), rtol=0, atol=REL)


def test_bezier_extract_along_v_keeps_the_axis_in_place():
    ku, kv, cp, w = random_surface(3, 2, 3, 1, 2, True, True)
    seg = bezier_extract(3, kv, cp, w, axis=1)
    assert seg.control_points.shape == (seg.breaks.size - 1, cp.shape[0], 4, 3)
    assert seg.weights.shape == seg.control_points.shape[:-1]
    grid = bezier_extract_surface(2, 3, ku, kv, cp, w)
    assert np.array_equal(grid.v_breaks, seg.breaks)


def test_bezier_extract_bad_input():
    knots, cp, w = random_curve(5, 3, 2, True, True)
    with pytest.raises(GeometryError, match="non-decreasing"):
        bezier_extract(3, np.sort(knots)[::-1], cp, w)
    with pytest.raises(GeometryError, match="weights must have shape"):
        bezier_extract(3, knots, cp, np.ones((2, 2)))
    with pytest.raises(GeometryError, match="empty domain"):
        bezier_extract(1, [0, 1, 1, 1], cp[:2], None)
    with pytest.raises(GeometryError, match="multiplicity 4 > degree"):
        bezier_extract(2, [0, 0, 0, 0.5, 0.5, 0.5, 0.5, 1, 1, 1], np.zeros((7, 3)), None)
    with pytest.raises(GeometryError, match=r"\(nu, nv, dim\)"):
        bezier_extract_surface(3, 3, knots, knots, cp, None)
    ku, kv, scp, sw = random_surface(5, 2, 2, 1, 1, True, False)
    with pytest.raises(GeometryError, match="v direction: knots must have shape"):
        bezier_extract_surface(2, 2, ku, kv[:-1], scp, None)
    with pytest.raises(GeometryError, match="v direction: degree must be >= 1"):
        bezier_extract_surface(2, -2, ku, kv, scp, None)
    with pytest.raises(GeometryError, match="u direction: weights must have shape"):
        bezier_extract_surface(2, 2, ku, kv, scp, np.ones(3))


# --------------------------------------------------------------------------- assembly of Bézier grids


def mixed_grid(seed, rational):
    """A 2 x 3 grid of patches of a C0 surface, each elevated by its own amount in u and v."""
    ku = np.array([0, 0, 0, 0.5, 0.5, 1, 1, 1.0])
    kv = np.array([0, 0, 0, 0, 0.25, 0.25, 0.25, 0.75, 0.75, 0.75, 1, 1, 1, 1.0])
    rng = np.random.default_rng(seed)
    cp = rng.uniform(-1, 1, size=(5, 10, 3))
    w = rng.uniform(0.5, 2.0, (5, 10)) if rational else None
    grid = bezier_extract_surface(2, 3, ku, kv, cp, w)
    patches, weights = [], []
    for i in range(2):
        row_p, row_w = [], []
        for j in range(3):
            wt = np.ones((3, 4)) if w is None else grid.weights[i, j]
            hom = np.concatenate([grid.control_points[i, j] * wt[..., None], wt[..., None]], axis=-1)
            hom = elevate_bezier(elevate_bezier(hom, (i + j) % 3, axis=0), (2 * i + j) % 2, axis=1)
            if rational:
                hom = hom * (1.0 + i + 2 * j)  # a patch's weights may be scaled by any constant
            row_p.append(hom[..., :3] / hom[..., 3:])
            row_w.append(hom[..., 3] if rational else None)
        patches.append(row_p)
        weights.append(row_w)
    return (ku, kv, cp, w), grid, patches, (weights if rational else None)


@pytest.mark.parametrize("rational", [False, True])
def test_mixed_degree_grid_equals_each_patch(rational):
    (ku, kv, cp, w), grid, patches, weights = mixed_grid(21, rational)
    s = bezier_grid_to_nurbs(patches, grid.u_breaks, grid.v_breaks, weights)
    assert (s.degree_u, s.degree_v) == (4, 4)
    assert s.control_points.shape == (2 * 4 + 1, 3 * 4 + 1, 3)
    assert np.array_equal(s.knots_u, [0] * 5 + [0.5] * 4 + [1] * 5)
    local = np.random.default_rng(1).uniform(0, 1, size=(12, 2))
    for i in range(2):
        for j in range(3):
            uv = np.column_stack([grid.u_breaks[i] + local[:, 0] * np.diff(grid.u_breaks)[i],
                                  grid.v_breaks[j] + local[:, 1] * np.diff(grid.v_breaks)[j]])
            wij = None if weights is None else weights[i][j]
            assert_allclose(surface_points(*s, uv), bezier_patch_points(patches[i][j], local, weights=wij),
                            rtol=0, atol=REL)
    assert_allclose(surface_points(*s, UV), surface_points(2, 3, ku, kv, cp, w, UV), rtol=0, atol=REL)


def test_mismatched_shared_boundary_raises():
    _, grid, patches, _ = mixed_grid(5, False)
    bad = [[p.copy() for p in row] for row in patches]
    bad[1][1][0, 2] += [0.0, 0.0, 1e-3]  # a control point on the boundary shared with patch (0, 1)
    with pytest.raises(GeometryError, match=r"patches \(0, 1\) and \(1, 1\) .* differ by up to 0\.001"):
        bezier_grid_to_nurbs(bad, grid.u_breaks, grid.v_breaks)
    # within tol it joins (tol is absolute, model units), and the shared point is the average
    s = bezier_grid_to_nurbs(bad, grid.u_breaks, grid.v_breaks, tol=2e-3)
    assert s.control_points.shape == (9, 13, 3)
    s = bezier_grid_to_nurbs(bad, grid.u_breaks, grid.v_breaks, tol=Tolerance(point=2e-3))
    bad[1][2][1, 0] += 1.0  # on the boundary shared with patch (1, 1), not on the one with (0, 2)
    with pytest.raises(GeometryError, match=r"patches \(1, 1\) and \(1, 2\)"):
        bezier_grid_to_nurbs(bad, grid.u_breaks, grid.v_breaks, tol=2e-3)


def test_inconsistent_boundary_weights_raise():
    _, grid, patches, weights = mixed_grid(6, True)
    weights = [[w.copy() for w in row] for row in weights]
    # one weight on the boundary with patch (1, 0) (patch (1, 1) is not elevated further along u, so only
    # this point changes): same Cartesian points, different weights, a different boundary curve
    weights[1][1][1, 0] *= 1.5
    with pytest.raises(GeometryError, match=r"patches \(1, 0\) and \(1, 1\) have inconsistent boundary weights"):
        bezier_grid_to_nurbs(patches, grid.u_breaks, grid.v_breaks, weights)


def test_bezier_curve_to_nurbs_mixed_degrees_and_gap():
    line = np.array([[0.0, 0.0], [1.0, 0.0]])
    quad = np.array([[1.0, 0.0], [2.0, 1.0], [3.0, 0.0]])
    cubic = np.array([[3.0, 0.0], [3.0, -1.0], [4.0, -1.0], [4.0, 0.0]])
    c = bezier_curve_to_nurbs([line, quad, cubic], [0.0, 1.0, 3.0, 4.0])
    assert c.degree == 3 and c.weights is None
    assert np.array_equal(c.knots, [0, 0, 0, 0, 1, 1, 1, 3, 3, 3, 4, 4, 4, 4])
    r = np.linspace(0, 1, 11)
    for seg, (a, b) in zip([line, quad, cubic], [(0, 1), (1, 3), (3, 4)]):
        assert_allclose(curve_points(*c, a + r * (b - a)), bezier_curve_points(seg, r), rtol=0, atol=1e-14 * 4)
    gap = quad + [0.0, 0.01]
    with pytest.raises(GeometryError, match=r"segments 0 and 1 do not meet: gap 0\.01"):
        bezier_curve_to_nurbs([line, gap, cubic], [0.0, 1.0, 3.0, 4.0])
    rational = bezier_curve_to_nurbs([line, quad], [0.0, 1.0, 2.0], [None, np.array([1.0, 3.0, 1.0])])
    assert rational.weights is not None
    assert_allclose(curve_points(*rational, [1.5])[0], bezier_curve_points(quad, [0.5], weights=[1, 3, 1])[0],
                    rtol=0, atol=1e-15 * 4)


def test_assembly_bad_input():
    line = np.array([[0.0, 0.0], [1.0, 0.0]])
    with pytest.raises(GeometryError, match="strictly increasing"):
        bezier_curve_to_nurbs([line, line + [1.0, 0.0]], [0.0, 1.0, 1.0])
    with pytest.raises(GeometryError, match=r"breaks must have shape \(3,\)"):
        bezier_curve_to_nurbs([line, line + [1.0, 0.0]], [0.0, 1.0])
    with pytest.raises(GeometryError, match="no segments"):
        bezier_curve_to_nurbs([], [0.0])
    with pytest.raises(GeometryError, match="degree >= 1"):
        bezier_curve_to_nurbs([line[:1]], [0.0, 1.0])
    with pytest.raises(GeometryError, match="different dimensions"):
        bezier_curve_to_nurbs([line, np.zeros((2, 3))], [0.0, 1.0, 2.0])
    with pytest.raises(GeometryError, match="tol must be"):
        bezier_curve_to_nurbs([line], [0.0, 1.0], tol=-1.0)
    with pytest.raises(GeometryError, match="weights must be positive"):
        bezier_curve_to_nurbs([line], [0.0, 1.0], [np.array([1.0, 0.0])])
    net = np.zeros((2, 2, 3, 3, 3))
    with pytest.raises(GeometryError, match=r"u_breaks must have shape \(3,\)"):
        bezier_grid_to_nurbs(net, [0.0, 1.0], [0.0, 1.0, 2.0])
    with pytest.raises(GeometryError, match="5 dimensions"):
        bezier_grid_to_nurbs(net[0], [0.0, 1.0, 2.0], [0.0, 1.0, 2.0])
    with pytest.raises(GeometryError, match="same number of patches"):
        bezier_grid_to_nurbs([[net[0, 0], net[0, 1]], [net[1, 0]]], [0.0, 1.0, 2.0], [0.0, 1.0, 2.0])
    with pytest.raises(GeometryError, match=r"weights must have shape \(2, 2, 3, 3\)"):
        bezier_grid_to_nurbs(net, [0.0, 1.0, 2.0], [0.0, 1.0, 2.0], np.ones((2, 2, 3)))
    with pytest.raises(GeometryError, match="NaN"):
        bezier_grid_to_nurbs(np.full((1, 1, 2, 2, 3), np.nan), [0.0, 1.0], [0.0, 1.0])


def test_inputs_are_not_modified():
    knots, cp, w = random_curve(9, 3, 3, False, True)
    keep = (knots.copy(), cp.copy(), w.copy())
    insert_knot(3, knots, cp, w, 0.5)
    refine_knots(3, knots, cp, w, [0.0, 0.5, 1.0])
    elevate_degree(3, knots, cp, w, 2)
    bezier_extract(3, knots, cp, w)
    for a, b in zip(keep, (knots, cp, w)):
        assert np.array_equal(a, b)
    _, grid, patches, weights = mixed_grid(2, True)
    keep = [[p.copy() for p in row] for row in patches]
    bezier_grid_to_nurbs(patches, grid.u_breaks, grid.v_breaks, weights)
    assert all(np.array_equal(a, b) for ra, rb in zip(keep, patches) for a, b in zip(ra, rb))
