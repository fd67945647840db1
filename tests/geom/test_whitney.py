"""Whitney extension of piecewise-linear polyline data: exactness, bounds and brute-force agreement."""

import tracemalloc

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from numpy.testing import assert_allclose, assert_array_equal
from scipy.optimize import minimize

from trimsurf.errors import GeometryError, InputError, TrimLoopError
from trimsurf.geom import WhitneyExtension, lipschitz_constant, whitney_extension

# Values are O(1) and L is at most O(100) on these polylines of unit size, so rounding in
# eps(q) - L |p - q| stays near 1e-14; 1e-12 leaves a margin of ~100.
TOL = 1e-12


def star_polygon(rng, k, *, convex):
    """Simple polygon with k vertices around the origin (star-shaped; convex on a circle)."""
    ang = (np.arange(k) + rng.uniform(0.1, 0.9, k)) * (2 * np.pi / k)  # jittered, never coincident
    rad = np.ones(k) if convex else rng.uniform(0.3, 1.0, k)
    return np.c_[rad * np.cos(ang), rad * np.sin(ang)]


def segment_list(k, closed):
    return [(i, (i + 1) % k) for i in range(k if closed else k - 1)]


def sample_boundary(bnd, val, closed, n):
    """n points per segment (both ends included) with their linearly interpolated values."""
    s = np.linspace(0, 1, n)
    pts, vals = [], []
    for i, j in segment_list(len(bnd), closed):
        pts.append(bnd[i] + s[:, None] * (bnd[j] - bnd[i]))
        vals.append(val[i] + s[:, None] * (val[j] - val[i]) if val.ndim == 2 else val[i] + s * (val[j] - val[i]))
    return np.concatenate(pts), np.concatenate(vals)


CASES = [(k, closed, convex) for k in (3, 5, 8) for closed in (True, False) for convex in (True, False)]


@pytest.fixture(params=CASES, ids=lambda c: f"k{c[0]}-{'closed' if c[1] else 'open'}-{'convex' if c[2] else 'star'}")
def case(request):
    k, closed, convex = request.param
    rng = np.random.default_rng(1000 * k + 10 * closed + convex)
    bnd = star_polygon(rng, k, convex=convex)
    val = rng.standard_normal(k)
    return bnd, val, closed, rng


def test_extension_equals_data_on_the_boundary(case):
    bnd, val, closed, rng = case
    pts, vals = sample_boundary(bnd, val, closed, 23)  # vertices and interior points of every segment
    ext = whitney_extension(bnd, val, pts, closed=closed)
    for f in (ext.lower, ext.upper, ext.average):
        assert_allclose(f, vals, rtol=0, atol=TOL)


def test_bracketing_bound_and_lipschitz(case):
    bnd, val, closed, rng = case
    q = rng.uniform(-1.5, 1.5, (400, 2))
    ext = whitney_extension(bnd, val, q, closed=closed)
    assert isinstance(ext, WhitneyExtension)
    assert np.all(ext.lower <= ext.average + TOL) and np.all(ext.average <= ext.upper + TOL)
    assert np.all(np.abs(ext.average) <= np.max(np.abs(val)) + TOL)  # Theorem 1: |a| <= sup |eps|
    i, j = rng.integers(0, len(q), (2, 2000))
    dist = np.linalg.norm(q[i] - q[j], axis=1)
    for f in (ext.lower, ext.upper, ext.average):
        assert np.all(np.abs(f[i] - f[j]) <= ext.lipschitz * dist + TOL)


def reference_lipschitz(bnd, val, closed):
    """Sup of the difference quotient by dense sampling of (s, t) on every pair of segments, refined
    by bounded optimisation; independent of the endpoint argument the implementation relies on."""
    segs = segment_list(len(bnd), closed)
    g = np.linspace(0, 1, 41)
    best = 0.0
    for a, b in segs:
        for c, d in segs:
            def ratio(st, a=a, b=b, c=c, d=d):
                s, t = st
                p1, p2 = bnd[a] + s * (bnd[b] - bnd[a]), bnd[c] + t * (bnd[d] - bnd[c])
                e1, e2 = val[a] + s * (val[b] - val[a]), val[c] + t * (val[d] - val[c])
                dist = np.hypot(*(p1 - p2))
                return abs(e1 - e2) / dist if dist > 1e-9 else 0.0
            grid = np.array([[ratio((s, t)) for t in g] for s in g])
            i, j = np.unravel_index(np.argmax(grid), grid.shape)
            res = minimize(lambda x: -ratio(x), [g[i], g[j]], method="L-BFGS-B", bounds=[(0, 1), (0, 1)],
                           options={"ftol": 1e-15, "gtol": 1e-13})
            best = max(best, grid[i, j], -res.fun)
    return best


@pytest.mark.parametrize("seed", range(4))
def test_lipschitz_matches_refined_brute_force(seed):
    rng = np.random.default_rng(seed)
    closed = seed % 2 == 0
    bnd = star_polygon(rng, 5, convex=seed >= 2)
    val = rng.standard_normal(5)
    big_l = lipschitz_constant(bnd, val, closed=closed)
    ref = reference_lipschitz(bnd, val, closed)
    assert big_l >= ref * (1 - 1e-12)  # never below a value the data attains
    assert big_l - ref <= 1e-9 * big_l  # the optimiser refines the sup to ~1e-12 relative


def test_lipschitz_attained_inside_a_segment():
    # the sup 1 is at vertex (1, 1) versus the middle of the bottom edge; vertex pairs only give 1/sqrt(2)
    bnd = np.array([[0.0, 0.0], [2.0, 0.0], [1.0, 1.0]])
    assert_allclose(lipschitz_constant(bnd, [0.0, 0.0, 1.0]), 1.0, rtol=0, atol=1e-15)
    assert_allclose(lipschitz_constant([[0.0, 0.0], [3.0, 4.0]], [1.0, 3.0], closed=False), 0.4, rtol=0, atol=1e-15)


@settings(max_examples=25, deadline=None)
@given(st.integers(3, 7), st.booleans(), st.integers(0, 2**31))
def test_dense_sampling_never_exceeds_lipschitz(k, closed, seed):
    rng = np.random.default_rng(seed)
    bnd = star_polygon(rng, k, convex=False)
    val = rng.normal(0, 1, k)
    big_l = lipschitz_constant(bnd, val, closed=closed)
    pts, vals = sample_boundary(bnd, val, closed, 30)
    d = np.linalg.norm(pts[:, None] - pts[None], axis=-1)
    off = d > 1e-9
    quot = np.abs(vals[:, None] - vals[None])[off] / d[off]
    assert quot.max() <= big_l * (1 + 1e-12)


def test_lower_upper_match_brute_force(case):
    bnd, val, closed, rng = case
    q = rng.uniform(-1.5, 1.5, (200, 2))
    ext = whitney_extension(bnd, val, q, closed=closed)
    big_l = ext.lipschitz
    gaps = []
    for n in (11, 101):
        pts, vals = sample_boundary(bnd, val, closed, n)
        d = np.linalg.norm(q[:, None] - pts[None], axis=-1)
        lo = np.max(vals[None] - big_l * d, axis=1)
        up = np.min(vals[None] + big_l * d, axis=1)
        assert np.all(lo <= ext.lower + TOL) and np.all(up >= ext.upper - TOL)  # samples are a subset
        # q -> eps(q) - L|p - q| is 2L-Lipschitz along the boundary; samples lie within h/2 of any point
        h = max(np.linalg.norm(bnd[j] - bnd[i]) for i, j in segment_list(len(bnd), closed)) / (n - 1)
        gap = max(np.max(ext.lower - lo), np.max(up - ext.upper))
        assert gap <= big_l * h + TOL
        gaps.append(gap)
    assert gaps[1] <= gaps[0]


def test_vector_values_are_componentwise(case):
    bnd, val, closed, rng = case
    vec = np.c_[val, rng.standard_normal(len(bnd)), 5.0 * rng.standard_normal(len(bnd))]
    q = rng.uniform(-1.5, 1.5, (100, 2))
    ext = whitney_extension(bnd, vec, q, closed=closed)
    assert ext.lower.shape == (100, 3) and ext.lipschitz.shape == (3,)
    for c in range(3):
        one = whitney_extension(bnd, vec[:, c], q, closed=closed)
        assert_allclose(ext.lower[:, c], one.lower, rtol=0, atol=1e-14)  # same operations per component
        assert_allclose(ext.upper[:, c], one.upper, rtol=0, atol=1e-14)
        assert_allclose(ext.lipschitz[c], one.lipschitz, rtol=1e-15, atol=0)
    assert_allclose(lipschitz_constant(bnd, vec, closed=closed), ext.lipschitz, rtol=0, atol=0)


def test_constant_data_and_larger_user_lipschitz():
    bnd = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    q = np.array([[0.5, 0.5], [3.0, -2.0]])
    ext = whitney_extension(bnd, np.full(4, 2.5), q)
    assert ext.lipschitz == 0.0
    assert_array_equal(ext.average, [2.5, 2.5])
    val = np.array([0.0, 1.0, 1.0, 0.0])
    wide = whitney_extension(bnd, val, np.r_[q, [[0.5, 0.0]]], lipschitz=3.0)
    assert wide.lipschitz == 3.0
    assert_allclose(wide.average[2], 0.5, rtol=0, atol=TOL)  # still interpolates
    assert wide.lower[0] < wide.upper[0]  # a looser L widens the bracket


def test_user_lipschitz_below_data_raises():
    bnd = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    with pytest.raises(GeometryError, match="below the Lipschitz constant"):
        whitney_extension(bnd, [0.0, 1.0, 1.0, 0.0], [[0.5, 0.5]], lipschitz=0.5)
    with pytest.raises(GeometryError, match="lipschitz must be"):
        whitney_extension(bnd, [0.0, 1.0, 1.0, 0.0], [[0.5, 0.5]], lipschitz=[1.0, 2.0])


def test_chunking_bounds_memory_and_keeps_results():
    rng = np.random.default_rng(7)
    bnd = star_polygon(rng, 100, convex=False)
    val = rng.standard_normal((100, 2))
    q = rng.uniform(-1, 1, (10_000, 2))  # 1e6 query-segment pairs
    ref = whitney_extension(bnd, val, q[:500])
    tracemalloc.start()
    try:
        ext = whitney_extension(bnd, val, q, chunk_size=2000)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    # outputs 3 x (1e4, 2) float64 = 0.5 MB; the chunk temporaries a few x 16 kB. Unchunked needs > 100 MB.
    assert peak < 4e6
    assert_array_equal(ext.lower[:500], ref.lower)  # max/min over chunks is order independent
    assert_array_equal(ext.upper[:500], ref.upper)


def test_empty_queries_and_inputs_unchanged():
    bnd = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    val = np.array([1.0, 2.0, 3.0])
    b0, v0 = bnd.copy(), val.copy()
    ext = whitney_extension(bnd, val, np.zeros((0, 2)))
    assert ext.average.shape == (0,)
    assert_array_equal(bnd, b0)
    assert_array_equal(val, v0)


@pytest.mark.parametrize("boundary, values, queries, kwargs, error, match", [
    (np.zeros((4, 3)), np.zeros(4), np.zeros((1, 2)), {}, TrimLoopError, r"shape \(k, 2\)"),
    ([[0.0, 0.0]], [1.0], np.zeros((1, 2)), {}, TrimLoopError, "at least 2 vertices"),
    ([[0.0, 0.0], [1.0, np.nan], [0, 1]], [1.0, 2, 3], np.zeros((1, 2)), {}, TrimLoopError, "vertex 1 is not finite"),
    ([[0.0, 0.0], [1.0, 0], [1, 0], [0, 1]], [1.0, 2, 2, 3], np.zeros((1, 2)), {}, TrimLoopError, "zero length"),
    ([[0.0, 0.0], [1.0, 0], [0, 1], [0, 0]], [1.0, 2, 3, 1], np.zeros((1, 2)), {}, TrimLoopError, "zero length"),
    ([[0.0, 0.0], [2.0, 0], [1, 0], [1, 1]], [0.0, 0, 1, 0], np.zeros((1, 2)), {}, TrimLoopError, "not Lipschitz"),
    ([[0.0, 0.0], [1.0, 0], [0, 1]], [1.0, 2], np.zeros((1, 2)), {}, GeometryError, "values must have shape"),
    ([[0.0, 0.0], [1.0, 0], [0, 1]], [1.0, np.inf, 2], np.zeros((1, 2)), {}, GeometryError, "not finite"),
    ([[0.0, 0.0], [1.0, 0], [0, 1]], [1.0, 2, 3], np.zeros((2, 3)), {}, GeometryError, r"shape \(q, 2\)"),
    ([[0.0, 0.0], [1.0, 0], [0, 1]], [1.0, 2, 3], [[np.nan, 0]], {}, GeometryError, "query point 0"),
    ([[0.0, 0.0], [1.0, 0], [0, 1]], [1.0, 2, 3], [[0, 0]], {"chunk_size": 0}, GeometryError, "chunk_size"),
    ([[0.0, 0.0], [1.0, 0], [0, 1]], [1.0, 2, 3], [[0, 0]], {"lipschitz": -1.0}, GeometryError, "finite and >= 0"),
])
def test_bad_input(boundary, values, queries, kwargs, error, match):
    with pytest.raises(error, match=match):
        whitney_extension(boundary, values, queries, **kwargs)
    assert issubclass(error, InputError)


def test_lipschitz_constant_bad_input():
    with pytest.raises(TrimLoopError, match="at least 2 vertices"):
        lipschitz_constant(np.zeros((1, 2)), [0.0])
    with pytest.raises(GeometryError, match="values must have shape"):
        lipschitz_constant(np.eye(2), np.zeros((3, 2)))
