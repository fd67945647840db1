"""Robust planar predicates: exact signs, point in polygon, self-intersections of polylines."""

import numpy as np
from numpy.testing import assert_array_equal

from trimsurf.geom.predicates import (orient2d, points_in_polygons, polygon_signed_area,
                                      polyline_self_intersections, segment_intersections)


def test_orient2d_is_exact_on_nearly_collinear_points():
    # points on the line y = x perturbed by one ulp: naive evaluation gets some signs wrong
    rng = np.random.default_rng(0)
    base = rng.uniform(0.5, 1.0, 200)
    a = np.column_stack([np.full(200, 0.5), np.full(200, 0.5)])
    b = np.column_stack([np.full(200, 12.0), np.full(200, 12.0)])
    c = np.column_stack([base, np.nextafter(base, 2.0)])  # just above the line: counter-clockwise
    assert_array_equal(orient2d(a, b, c), 1)
    c_on = np.column_stack([base, base])
    assert_array_equal(orient2d(a, b, c_on), 0)


def test_points_in_polygon_with_hole():
    outer = np.array([[0, 0], [4, 0], [4, 4], [0, 4]], dtype=float)
    hole = np.array([[1, 1], [1, 3], [3, 3], [3, 1]], dtype=float)
    pts = np.array([[0.5, 0.5], [2, 2], [3.5, 2], [5, 5], [-1, 2]])
    assert_array_equal(points_in_polygons(pts, [outer, hole]), [True, False, True, False, False])
    assert polygon_signed_area(outer) == 16.0 and polygon_signed_area(hole) == -4.0


def test_segment_intersections_touching_and_crossing():
    p0 = np.array([[0, 0], [0, 0], [0, 0], [0, 0]], dtype=float)
    p1 = np.array([[2, 2], [1, 0], [1, 0], [1, 1]], dtype=float)
    q0 = np.array([[0, 2], [1, 0], [2, 0], [2, 2]], dtype=float)
    q1 = np.array([[2, 0], [1, 1], [3, 0], [3, 3]], dtype=float)
    assert_array_equal(segment_intersections(p0, p1, q0, q1), [True, True, False, False])


def test_self_intersections_of_a_figure_eight_and_a_circle():
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    circle = np.column_stack([np.cos(t), np.sin(t)])
    assert len(polyline_self_intersections(circle)) == 0
    eight = np.column_stack([np.sin(t), np.sin(2 * t)])
    hits = polyline_self_intersections(eight)
    # it crosses itself once, at the origin, where segments 399, 0 (around vertex 0) meet 199, 200
    assert 1 <= len(hits) <= 4
    assert set(hits.ravel()) <= {399, 0, 199, 200}
    assert {int(hits[0, 0]), int(hits[0, 1])} & {0, 399} and {int(hits[0, 0]), int(hits[0, 1])} & {199, 200}


def _points_in_polygons_brute(pts, polys):
    # the even-odd count over every edge (the definition the bucketed kernel must reproduce exactly)
    a = np.concatenate(polys)
    b = np.concatenate([np.roll(p, -1, axis=0) for p in polys])
    x, y = pts[:, :1], pts[:, 1:]
    straddle = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return np.count_nonzero(straddle & (x < xc), axis=1) % 2 == 1


def test_points_in_polygons_bucketed_equals_brute_force():
    # random star polygons with a hole; rounded coordinates make horizontal edges, points exactly on
    # vertices and edges, and rows through vertices (the slab boundaries' worst cases)
    rng = np.random.default_rng(1)
    for trial in range(120):
        k = int(rng.integers(3, 300))
        ang = np.sort(rng.uniform(0, 2 * np.pi, k))
        r = rng.uniform(0.2, 1, k)
        poly = np.column_stack([r * np.cos(ang), r * np.sin(ang)])
        if trial % 3 == 0:
            poly = np.round(poly, 1)
        hole = 0.1 * poly[::-1]
        pts = np.r_[rng.uniform(-1.1, 1.1, (1500, 2)), poly, hole, poly + [0.0, 1e-17]]
        if trial % 2:
            pts = np.round(pts, 1)
        assert_array_equal(points_in_polygons(pts, [poly, hole]), _points_in_polygons_brute(pts, [poly, hole]))
    # tall edges (a comb): fewer slabs, same answer
    comb = np.array([[0, 0]] + [[i, 10.0 * (i % 2)] for i in range(1, 400)] + [[400, -1]], dtype=float)
    pts = rng.uniform([-1, -2], [401, 11], (3000, 2))
    assert_array_equal(points_in_polygons(pts, [comb]), _points_in_polygons_brute(pts, [comb]))


def _self_intersections_brute(v, closed=True):
    """Every non-adjacent pair by the exact `segment_intersections` (no filter)."""
    a = v if closed else v[:-1]
    b = np.roll(v, -1, axis=0) if closed else v[1:]
    n = len(a)
    i, j = np.triu_indices(n, 1)
    keep = ~((j - i == 1) | (closed & (i == 0) & (j == n - 1)))
    i, j = i[keep], j[keep]
    hit = segment_intersections(a[i], b[i], a[j], b[j])
    return np.column_stack([i[hit], j[hit]])


def test_self_intersections_fast_path_equals_brute_force():
    """The compiled pre-check (a polyline certainly simple: no exact test) changes no answer: random
    wobbly loops, loops with a pinch (touching), collinear overlaps along a grid line and tiny crossings."""
    rng = np.random.default_rng(7)
    cases = []
    for k in range(40):
        n = int(rng.integers(5, 80))
        a = np.sort(rng.uniform(0, 2 * np.pi, n))
        r = 1.0 + (0.05 + 0.5 * (k % 4 == 0)) * rng.standard_normal(n)
        cases.append(np.column_stack([r * np.cos(a), r * np.sin(a)]))
    sq = np.array([[0, 0], [2, 0], [2, 2], [1, 2], [1, 0], [0.5, 0], [0, 1]], float)   # overlap along v = 0
    pinch = np.array([[0, 0], [1, 0], [1, 1], [0.5, 0], [0, 1]], float)                 # touches a side
    tiny = np.array([[0, 0], [1, 1e-17], [1, 1], [0, 1], [0.5, 1e-16], [0.5, -1]], float)
    cases += [sq, pinch, tiny, sq[::-1], pinch * 1e-9 + 3.0]
    n_hit = 0
    for v in cases:
        for closed in (True, False):
            got = polyline_self_intersections(v, closed=closed)
            want = _self_intersections_brute(v, closed)
            assert_array_equal(got, want[np.lexsort((want[:, 1], want[:, 0]))] if len(want) else got)
            assert len(got) == len(want)
            n_hit += len(got) > 0
    assert n_hit >= 10          # the cases do cross and touch
