"""Small robust predicates in the plane, batched.

`orient2d` uses Shewchuk's static error bound and recomputes the uncertain
cases in exact rational arithmetic, so its sign is always right.

References
----------
J. R. Shewchuk, Adaptive precision floating-point arithmetic and fast robust
geometric predicates, Discrete Comput. Geom. 18 (1997) 305-363.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from .._numba_load import install as _install_lazy_bitcode

_install_lazy_bitcode()     # before this module's kernels load (trimsurf._numba_load)

__all__ = ["orient2d", "points_in_polygons", "PolygonIndex", "segment_intersections", "polyline_self_intersections",
           "polygon_signed_area"]

_EPS = np.finfo(np.float64).eps / 2
_CCW_BOUND = (3.0 + 16.0 * _EPS) * _EPS  # Shewchuk's ccwerrboundA


def orient2d(a, b, c) -> np.ndarray:
    """Sign of the orientation of triangles (a, b, c): +1 counter-clockwise, -1 clockwise, 0 collinear.

    Parameters
    ----------
    a, b, c : (n, 2) float64

    Returns
    -------
    (n,) int64

    Examples
    --------
    >>> orient2d([[0, 0]], [[1, 0]], [[0, 1]])
    array([1])
    """
    a, b, c = (np.atleast_2d(np.asarray(x, dtype=np.float64)) for x in (a, b, c))
    left = (a[:, 0] - c[:, 0]) * (b[:, 1] - c[:, 1])
    right = (a[:, 1] - c[:, 1]) * (b[:, 0] - c[:, 0])
    det = left - right
    bound = _CCW_BOUND * (np.abs(left) + np.abs(right))
    sign = np.sign(det).astype(np.int64)
    unsure = np.flatnonzero(np.abs(det) <= bound)
    for i in unsure:  # rare: exact arithmetic on the nearly degenerate cases only
        ax, ay, bx, by, cx, cy = (Fraction(float(x)) for x in (*a[i], *b[i], *c[i]))
        exact = (ax - cx) * (by - cy) - (ay - cy) * (bx - cx)
        sign[i] = (exact > 0) - (exact < 0)
    return sign


def polygon_signed_area(polygon) -> float:
    """Signed area of a closed polygon (k, 2), positive when counter-clockwise."""
    p = np.asarray(polygon, dtype=np.float64)
    q = np.roll(p, -1, axis=0)
    return 0.5 * float(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))


class PolygonIndex:
    """Closed polygons (an outer boundary and holes, even-odd rule) with their edges bucketed into
    horizontal slabs, for many `points_in_polygons` queries against the same polygons.

    Parameters
    ----------
    polygons : sequence of (k_i, 2) float64
        Closed polygons (last vertex not repeated).
    """

    def __init__(self, polygons):
        self.polygons = polygons
        a = np.concatenate([np.asarray(p, dtype=np.float64) for p in polygons])
        # each polygon's next vertices (np.roll(p, -1) per polygon), by index
        lens = np.array([len(p) for p in polygons], dtype=np.int64)
        nxt = np.arange(1, len(a) + 1)
        ends = np.cumsum(lens)
        nxt[ends[lens > 0] - 1] = (ends - lens)[lens > 0]
        b = a[nxt] if len(a) else a.copy()
        self.a, self.b = np.ascontiguousarray(a), np.ascontiguousarray(b)
        if not len(a):
            return
        # edges bucketed into horizontal slabs (about one edge per slab and row): each point tests only
        # the edges of its slab, with the same crossing test as the brute-force count
        self.y0, self.h, self.n_slab, self.start, self.edges = _slab_index(self.a, self.b)

    def contains(self, points) -> np.ndarray:
        """`points_in_polygons` of these polygons, (n,) bool."""
        pts = np.ascontiguousarray(np.atleast_2d(np.asarray(points, dtype=np.float64)))
        inside = np.zeros(len(pts), dtype=bool)
        if not len(pts) or not len(self.a):
            return inside
        _points_in_polygons_kernel(np.array(pts, order="C"), self.a, self.b, self.y0, self.h, self.n_slab,
                                   self.start, self.edges, inside)
        return inside


def points_in_polygons(points, polygons, *, chunk_size: int = 1 << 22) -> np.ndarray:
    """Whether each point lies inside the region bounded by closed polygons (even-odd rule).

    Parameters
    ----------
    points : (n, 2) float64
    polygons : sequence of (k_i, 2) float64, or PolygonIndex
        Closed polygons (last vertex not repeated): an outer boundary and holes; a `PolygonIndex`
        of them when the same polygons are asked many times.
    chunk_size : int
        Bounds memory: points x edges pairs processed at once.

    Returns
    -------
    (n,) bool
    """
    index = polygons if isinstance(polygons, PolygonIndex) else PolygonIndex(polygons)
    return index.contains(points)


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _point_in_index(x, y, a, b, y0, h, n_slab, start, edges):
    """Whether (x, y) lies inside the polygons of a `PolygonIndex` (its arrays), even-odd rule."""
    if not y >= y0:          # below every edge (or NaN): no crossing
        return False
    # the same monotone expression as the edges' slabs: an edge with ylo <= y < yhi is in slab k
    k = min(int((y - y0) / h), n_slab - 1)
    c = 0
    for j in range(start[k], start[k + 1]):
        e = edges[j]
        ay, by = a[e, 1], b[e, 1]
        if (ay > y) != (by > y):
            xc = a[e, 0] + (y - ay) * (b[e, 0] - a[e, 0]) / (by - ay)
            if x < xc:
                c += 1
    return c % 2 == 1


@njit(cache=True, nogil=True)
def _points_in_polygons_kernel(pts, a, b, y0, h, n_slab, start, edges, inside):
    for i in range(pts.shape[0]):
        inside[i] = _point_in_index(pts[i, 0], pts[i, 1], a, b, y0, h, n_slab, start, edges)


def segment_intersections(p0, p1, q0, q1) -> np.ndarray:
    """Whether closed segments [p0, p1] and [q0, q1] intersect (touching counts), per row.

    Parameters
    ----------
    p0, p1, q0, q1 : (n, 2) float64

    Returns
    -------
    (n,) bool
    """
    d1 = orient2d(q0, q1, p0)
    d2 = orient2d(q0, q1, p1)
    d3 = orient2d(p0, p1, q0)
    d4 = orient2d(p0, p1, q1)
    proper = (d1 * d2 < 0) & (d3 * d4 < 0)

    def on_segment(a, b, c):  # c collinear with a-b: inside the box of a-b?
        return np.all((np.minimum(a, b) <= c) & (c <= np.maximum(a, b)), axis=1)

    p0, p1, q0, q1 = (np.atleast_2d(np.asarray(x, dtype=np.float64)) for x in (p0, p1, q0, q1))
    touch = ((d1 == 0) & on_segment(q0, q1, p0)) | ((d2 == 0) & on_segment(q0, q1, p1)) \
        | ((d3 == 0) & on_segment(p0, p1, q0)) | ((d4 == 0) & on_segment(p0, p1, q1))
    return proper | touch


def polyline_self_intersections(vertices, *, closed: bool = True) -> np.ndarray:
    """Pairs of non-adjacent segments of a polyline that intersect, (k, 2) int64 segment indices.

    Candidate pairs come from a k-d tree over segment bounding circles, so the
    cost is about O(n log n) for well-spread polylines, not O(n^2).
    """
    v = np.asarray(vertices, dtype=np.float64)
    a = v if closed else v[:-1]
    b = np.roll(v, -1, axis=0) if closed else v[1:]
    n = len(a)
    if n < 3:
        return np.zeros((0, 2), dtype=np.int64)
    if np.all(np.isfinite(v)) and _segments_apart_kernel(np.ascontiguousarray(a), np.ascontiguousarray(b),
                                                         bool(closed), _CCW_BOUND):
        return np.zeros((0, 2), dtype=np.int64)     # certainly simple: what the exact test finds too
    mid = 0.5 * (a + b)
    rad = 0.5 * np.linalg.norm(b - a, axis=1)
    tree = cKDTree(mid)
    rmax = float(rad.max())
    pairs = tree.query_pairs(2.0 * rmax + 1e-300, output_type="ndarray")
    if len(pairs) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    i, j = np.sort(pairs, axis=1).T
    near = np.linalg.norm(mid[i] - mid[j], axis=1) <= rad[i] + rad[j]
    adjacent = (j - i == 1) | (closed & (i == 0) & (j == n - 1))
    keep = near & ~adjacent
    i, j = i[keep], j[keep]
    hit = segment_intersections(a[i], b[i], a[j], b[j])
    out = np.column_stack([i[hit], j[hit]]).astype(np.int64)
    return out[np.lexsort((out[:, 1], out[:, 0]))] if len(out) else out


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _sign_certain(ax, ay, bx, by, cx, cy, bound):
    left = (ax - cx) * (by - cy)
    right = (ay - cy) * (bx - cx)
    det = left - right
    if abs(det) <= bound * (abs(left) + abs(right)):
        return 0
    return 1 if det > 0 else -1


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _may_cross(ax, ay, bx, by, cx, cy, dx, dy, bound):
    """Whether segments ab and cd may meet: their boxes overlap and no sign certain in floating point
    (`_sign_certain`) puts c and d, or a and b, strictly on one side of the other's line."""
    if max(min(ax, bx), min(cx, dx)) > min(max(ax, bx), max(cx, dx)):
        return False
    if max(min(ay, by), min(cy, dy)) > min(max(ay, by), max(cy, dy)):
        return False
    if _sign_certain(cx, cy, dx, dy, ax, ay, bound) * _sign_certain(cx, cy, dx, dy, bx, by, bound) > 0:
        return False
    return _sign_certain(ax, ay, bx, by, cx, cy, bound) * _sign_certain(ax, ay, bx, by, dx, dy, bound) <= 0


@njit(cache=True, nogil=True)
def _segments_apart_kernel(a, b, closed, bound):
    """True when no two non-adjacent segments (a[i], b[i]) of a polyline can meet: every pair whose
    closed boxes overlap is apart by certain floating-point orientations (Shewchuk's bound). False
    means "maybe" (the exact test decides). Segments are bucketed on a uniform grid of their boxes."""
    n = a.shape[0]
    x0, y0 = min(a[0, 0], b[0, 0]), min(a[0, 1], b[0, 1])
    x1, y1 = max(a[0, 0], b[0, 0]), max(a[0, 1], b[0, 1])
    for i in range(n):
        x0 = min(x0, min(a[i, 0], b[i, 0]))
        y0 = min(y0, min(a[i, 1], b[i, 1]))
        x1 = max(x1, max(a[i, 0], b[i, 0]))
        y1 = max(y1, max(a[i, 1], b[i, 1]))
    g = max(1, int(np.sqrt(n)))
    hx = (x1 - x0) / g if x1 > x0 else 1.0
    hy = (y1 - y0) / g if y1 > y0 else 1.0
    while True:
        total = 0
        for i in range(n):
            ia = min(int((min(a[i, 0], b[i, 0]) - x0) / hx), g - 1)
            ib = min(int((max(a[i, 0], b[i, 0]) - x0) / hx), g - 1)
            ja = min(int((min(a[i, 1], b[i, 1]) - y0) / hy), g - 1)
            jb = min(int((max(a[i, 1], b[i, 1]) - y0) / hy), g - 1)
            total += (ib - ia + 1) * (jb - ja + 1)
        if g == 1 or total <= 16 * n:
            break
        g = max(1, g // 2)
        hx = (x1 - x0) / g if x1 > x0 else 1.0
        hy = (y1 - y0) / g if y1 > y0 else 1.0
    cnt = np.zeros(g * g + 1, dtype=np.int64)
    for i in range(n):
        ia = min(int((min(a[i, 0], b[i, 0]) - x0) / hx), g - 1)
        ib = min(int((max(a[i, 0], b[i, 0]) - x0) / hx), g - 1)
        ja = min(int((min(a[i, 1], b[i, 1]) - y0) / hy), g - 1)
        jb = min(int((max(a[i, 1], b[i, 1]) - y0) / hy), g - 1)
        for p in range(ia, ib + 1):
            for q in range(ja, jb + 1):
                cnt[p * g + q + 1] += 1
    for c in range(g * g):
        cnt[c + 1] += cnt[c]
    fill = cnt[:-1].copy()
    sb = np.empty(cnt[-1], dtype=np.int64)
    for i in range(n):
        ia = min(int((min(a[i, 0], b[i, 0]) - x0) / hx), g - 1)
        ib = min(int((max(a[i, 0], b[i, 0]) - x0) / hx), g - 1)
        ja = min(int((min(a[i, 1], b[i, 1]) - y0) / hy), g - 1)
        jb = min(int((max(a[i, 1], b[i, 1]) - y0) / hy), g - 1)
        for p in range(ia, ib + 1):
            for q in range(ja, jb + 1):
                sb[fill[p * g + q]] = i
                fill[p * g + q] += 1
    for c in range(g * g):
        for s in range(cnt[c], cnt[c + 1]):
            i = sb[s]
            ax, ay, bx, by = a[i, 0], a[i, 1], b[i, 0], b[i, 1]
            for t in range(s + 1, cnt[c + 1]):
                j = sb[t]
                lo, hi = min(i, j), max(i, j)
                if hi - lo == 1 or (closed and lo == 0 and hi == n - 1):
                    continue
                if _may_cross(ax, ay, bx, by, a[j, 0], a[j, 1], b[j, 0], b[j, 1], bound):
                    return False
    return True


@njit(cache=True, nogil=True)
def _slab_index(a, b):
    """`PolygonIndex`'s slabs: (y0, h, n_slab, start, edges), edges of slab k in edges[start[k]:start[k + 1]]
    (every edge whose y range meets the slab, in increasing order)."""
    m = a.shape[0]
    ylo = np.empty(m)
    yhi = np.empty(m)
    for e in range(m):
        ylo[e] = min(a[e, 1], b[e, 1])
        yhi[e] = max(a[e, 1], b[e, 1])
    y0, y1 = ylo.min(), yhi.max()
    n_slab = min(max(1, m), 1 << 16)
    first = np.empty(m, dtype=np.int64)
    last = np.empty(m, dtype=np.int64)
    while True:
        h = (y1 - y0) / n_slab if y1 > y0 else 1.0
        total = 0
        for e in range(m):
            first[e] = min(max(int((ylo[e] - y0) / h), 0), n_slab - 1)
            last[e] = min(max(int((yhi[e] - y0) / h), 0), n_slab - 1)
            total += last[e] - first[e] + 1
        if n_slab == 1 or total <= 8 * m + (1 << 16):     # tall edges: fewer slabs
            break
        n_slab //= 4
    start = np.zeros(n_slab + 1, dtype=np.int64)
    for e in range(m):
        for k in range(first[e], last[e] + 1):
            start[k + 1] += 1
    for k in range(n_slab):
        start[k + 1] += start[k]
    fill = start[:-1].copy()
    edges = np.empty(start[-1], dtype=np.int64)
    for e in range(m):
        for k in range(first[e], last[e] + 1):
            edges[fill[k]] = e
            fill[k] += 1
    return y0, h, n_slab, start, edges
