"""Compiled helpers of the per-face triangulation (`trimsurf.tessellate.face`, mesh side)."""

from __future__ import annotations

import numpy as np
from numba import njit

from ..geom.predicates import _segments_apart_kernel
from ._line_kernels import _points0

__all__ = ["cell_main_kernel", "curved_kernel", "deviation_samples", "deviation_start_bound", "face_loops_kernel",
           "lift_kernel", "trim_loop_kernel"]


@njit(cache=True, nogil=True)
def deviation_samples(bary, uv, xyz, tris):
    """The sample points of `trimsurf.tessellate.face.triangle_deviation`: per triangle the points
    sum_k bary[b, k] * corner_k (in (u, v) and in 3D, summed in k order as numpy's einsum does) for the rows b
    of `bary`, rows 1-3 being the edge midpoints 01, 12, 20; a midpoint shared by two triangles (the same
    numbers either way round) is listed once.

    Returns (suv (n, 2), sx (n, 3), rows (m, nb)): the points and, per triangle, its samples' indices.
    """
    m, nb = tris.shape[0], bary.shape[0]
    n_own = nb - 3
    # edges by their lower corner (buckets of a CSR); an edge's point belongs to its first occurrence
    n_v = 0
    for i in range(m):
        for c in range(3):
            n_v = max(n_v, tris[i, c] + 1)
    start = np.zeros(n_v + 1, dtype=np.int64)
    for i in range(m):
        for c in range(3):
            start[min(tris[i, c], tris[i, (c + 1) % 3]) + 1] += 1
    for v in range(n_v):
        start[v + 1] += start[v]
    fill = start[:-1].copy()
    other = np.empty(3 * m, dtype=np.int64)          # the higher corner of the bucket's edges
    slot = np.empty(3 * m, dtype=np.int64)           # the triangle edge there
    edge_id = np.empty(3 * m, dtype=np.int64)
    n_edge = 0
    for i in range(m):
        for c in range(3):
            a, b = tris[i, c], tris[i, (c + 1) % 3]
            lo, hi = min(a, b), max(a, b)
            e = -1
            for r in range(start[lo], fill[lo]):
                if other[r] == hi:
                    e = edge_id[slot[r]]
                    break
            if e < 0:
                e = n_edge
                n_edge += 1
                other[fill[lo]] = hi
                slot[fill[lo]] = 3 * i + c
                fill[lo] += 1
            edge_id[3 * i + c] = e
    n = m * n_own + n_edge
    suv = np.empty((n, 2))
    sx = np.empty((n, 3))
    rows = np.empty((m, nb), dtype=np.int64)
    done = np.zeros(n_edge, dtype=np.bool_)
    for i in range(m):
        p, q, r = tris[i, 0], tris[i, 1], tris[i, 2]
        for b in range(nb):
            if 1 <= b <= 3:
                e = edge_id[3 * i + b - 1]
                k = m * n_own + e
                rows[i, b] = k
                if done[e]:
                    continue
                done[e] = True
            else:
                k = i * n_own + (0 if b == 0 else b - 3)
                rows[i, b] = k
            for d in range(2):
                suv[k, d] = bary[b, 0] * uv[p, d] + bary[b, 1] * uv[q, d] + bary[b, 2] * uv[r, d]
            for d in range(3):
                sx[k, d] = bary[b, 0] * xyz[p, d] + bary[b, 1] * xyz[q, d] + bary[b, 2] * xyz[r, d]
    return suv, sx, rows


@njit(cache=True, nogil=True)
def trim_loop_kernel(poly, xyz, vid, has_vid, bound):
    """One trim loop of `trimsurf.tessellate.face.mesh_face_from_chunks` as its polygon: consecutive
    duplicates in (u, v) dropped (and a last point equal to the first), then whether the polygon is
    certainly simple (`repair.remove_polygon_loops` keeps every point then: fewer than 4 points, or
    every pair of segments apart by `predicates._segments_apart_kernel`).

    Returns (poly, xyz, vid of the kept points (vid -1 without has_vid), keep mask, status): status 0
    fewer than 3 points left, 1 simple, 2 `remove_polygon_loops` must decide."""
    n = poly.shape[0]
    keep = np.empty(n, dtype=np.bool_)
    m = 0
    for i in range(n):
        k = i == 0 or poly[i, 0] != poly[i - 1, 0] or poly[i, 1] != poly[i - 1, 1]
        if i == n - 1 and n > 1 and poly[i, 0] == poly[0, 0] and poly[i, 1] == poly[0, 1]:
            k = False
        keep[i] = k
        if k:
            m += 1
    p2 = np.empty((m, 2))
    x2 = np.empty((m, 3))
    v2 = np.empty(m, dtype=np.int64)
    j = 0
    finite = True
    for i in range(n):
        if keep[i]:
            p2[j, 0], p2[j, 1] = poly[i, 0], poly[i, 1]
            x2[j, 0], x2[j, 1], x2[j, 2] = xyz[i, 0], xyz[i, 1], xyz[i, 2]
            v2[j] = vid[i] if has_vid else -1
            finite &= np.isfinite(poly[i, 0]) and np.isfinite(poly[i, 1])
            j += 1
    if m < 3:
        return p2, x2, v2, keep, 0
    if m < 4:
        return p2, x2, v2, keep, 1
    if finite:
        b = np.empty((m, 2))
        for i in range(m):
            b[i, 0], b[i, 1] = p2[(i + 1) % m, 0], p2[(i + 1) % m, 1]
        if _segments_apart_kernel(p2, b, np.bool_(True), bound):
            return p2, x2, v2, keep, 1
    return p2, x2, v2, keep, 2


@njit(cache=True, nogil=True)
def deviation_start_bound(bary, uv, xyz, tris, pu, pv, ku, kv, pw, rational):
    """Per triangle, the largest first distance |S(uv_b) - x_b| over the samples of `deviation_samples`
    (uv_b clipped to the domain): the distance `_nurbs_kernels._surface_distance1` starts from and never
    exceeds, so an upper bound of `trimsurf.tessellate.face.triangle_deviation` (NaN where a sample's is),
    at one surface point per sample instead of the Gauss-Newton steps' three evaluations."""
    suv, sx, rows = deviation_samples(bary, uv, xyz, tris)
    # S at every sample (clipped to the domain) by `_line_kernels._points0`: `_surface_point01`'s numbers, each
    # parameter value's span and basis computed once (samples on a grid line or cell column share them)
    sp = np.empty((suv.shape[0], 3))
    _points0(pu, pv, ku, kv, pw, rational, suv, sp)
    d = np.empty(suv.shape[0])
    for i in range(suv.shape[0]):
        r0, r1, r2 = sx[i, 0] - sp[i, 0], sx[i, 1] - sp[i, 1], sx[i, 2] - sp[i, 2]
        d[i] = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
    out = np.empty(rows.shape[0])
    for t in range(rows.shape[0]):
        m = d[rows[t, 0]]
        for b in range(1, rows.shape[1]):
            x = d[rows[t, b]]
            if x > m or x != x:
                m = x
            if m != m:
                break
        out[t] = m
    return out


@njit(cache=True, nogil=True)
def lift_kernel(bary, uv, trim_xyz, tris, pu, pv, ku, kv, pw, rational, all_points, tol):
    """The points of a face's triangulation (`trimsurf.tessellate.face.mesh_face_from_chunks`) in one pass:
    S(uv) (uv clipped to the domain, as `NurbsSurface.evaluate`) for the points after the trim points
    (all_points: for the trim points too), the trim points' rows then set to `trim_xyz`.

    With all_points: also each trim point's distance |S(uv) - trim_xyz| (`trim_off`) and, for tris of
    length > 0, the triangles whose `deviation_start_bound` is not at most `tol` (`maybe`, in order).

    Returns (status, xyz, trim_off, maybe): status 1 where a (u, v) is not finite (nothing computed: the
    caller's numpy path raises as `evaluate` does), else 0."""
    n, nt = uv.shape[0], trim_xyz.shape[0]
    xyz = np.empty((n, 3))
    off = np.zeros(nt if all_points else 0)
    maybe = np.zeros(0, dtype=np.int64)
    for i in range(n):
        if not (np.isfinite(uv[i, 0]) and np.isfinite(uv[i, 1])):
            return 1, xyz, off, maybe
    # S(uv) clipped to the domain by `_line_kernels._points0` (`_surface_point01`'s numbers; a grid's nodes share
    # their u and v values: each one's span and basis computed once)
    s0 = 0 if all_points else nt
    if s0 == 0:
        _points0(pu, pv, ku, kv, pw, rational, uv, xyz)
    elif n > s0:
        q = np.empty((n - s0, 2))
        for i in range(n - s0):
            q[i, 0], q[i, 1] = uv[s0 + i, 0], uv[s0 + i, 1]
        x = np.empty((n - s0, 3))
        _points0(pu, pv, ku, kv, pw, rational, q, x)
        for i in range(n - s0):
            xyz[s0 + i, 0], xyz[s0 + i, 1], xyz[s0 + i, 2] = x[i, 0], x[i, 1], x[i, 2]
    for i in range(nt):
        if all_points:
            r0, r1, r2 = xyz[i, 0] - trim_xyz[i, 0], xyz[i, 1] - trim_xyz[i, 1], xyz[i, 2] - trim_xyz[i, 2]
            off[i] = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
        xyz[i, 0], xyz[i, 1], xyz[i, 2] = trim_xyz[i, 0], trim_xyz[i, 1], trim_xyz[i, 2]
    if all_points and tris.shape[0]:
        sb = deviation_start_bound(bary, uv, xyz, tris, pu, pv, ku, kv, pw, rational)
        k = 0
        for t in range(sb.shape[0]):
            if not sb[t] <= tol:
                k += 1
        maybe = np.empty(k, dtype=np.int64)
        k = 0
        for t in range(sb.shape[0]):
            if not sb[t] <= tol:
                maybe[k] = t
                k += 1
    return 0, xyz, off, maybe


@njit(cache=True, nogil=True)
def face_loops_kernel(uv, xyz, ids, meta, n_chunks, bound):
    """Every trim loop of a face (`trimsurf.tessellate.face.mesh_face_from_chunks`) from its chunks in one
    pass: chunk c (rows of uv, xyz, ids after those of the chunks before it; meta[c] // 2 points) adds its
    points but the last in its direction (forward where meta[c] is odd; else reversed, without its first
    point), loop l being chunks meta[n_chunks + l]:meta[n_chunks + l + 1]; then `trim_loop_kernel` of each
    loop (ids -1: no id).

    Returns (status, pts, x, vid, lens): the loops that kept 3 points or more concatenated, lens their
    lengths (a loop that did not keep 3 left out); status 2 where some loop is not certainly simple (then
    nothing else is meaningful: `remove_polygon_loops` must decide, loop by loop), else 0."""
    n_loops = meta.shape[0] - n_chunks - 1
    total = 0
    for c in range(n_chunks):
        total += max((meta[c] >> 1) - 1, 0)
    pts = np.empty((total, 2))
    x = np.empty((total, 3))
    vid = np.empty(total, dtype=np.int64)
    lens = np.zeros(n_loops, dtype=np.int64)
    first = np.zeros(n_chunks + 1, dtype=np.int64)
    for c in range(n_chunks):
        first[c + 1] = first[c] + (meta[c] >> 1)
    out = 0
    n_kept = 0
    for lp in range(n_loops):
        c0, c1 = meta[n_chunks + lp], meta[n_chunks + lp + 1]
        m = 0
        for c in range(c0, c1):
            m += max((meta[c] >> 1) - 1, 0)
        p = np.empty((m, 2))
        q = np.empty((m, 3))
        v = np.empty(m, dtype=np.int64)
        j = 0
        for c in range(c0, c1):
            k = (meta[c] >> 1) - 1
            fw = (meta[c] & 1) == 1
            for r in range(k):
                src = first[c] + r if fw else first[c] + k - r
                p[j, 0], p[j, 1] = uv[src, 0], uv[src, 1]
                q[j, 0], q[j, 1], q[j, 2] = xyz[src, 0], xyz[src, 1], xyz[src, 2]
                v[j] = ids[src]
                j += 1
        p2, x2, v2, keep, status = trim_loop_kernel(p, q, v, np.bool_(True), bound)
        if status == 2:
            return 2, pts, x, vid, lens
        if status == 0:
            continue
        lens[n_kept] = p2.shape[0]
        n_kept += 1
        for i in range(p2.shape[0]):
            pts[out, 0], pts[out, 1] = p2[i, 0], p2[i, 1]
            x[out, 0], x[out, 1], x[out, 2] = x2[i, 0], x2[i, 1], x2[i, 2]
            vid[out] = v2[i]
            out += 1
    return 0, pts[:out], x[:out], vid[:out], lens[:n_kept]


@njit(cache=True, nogil=True)
def cell_main_kernel(d, has_tol, tolerance, pref):
    """`trimsurf.tessellate.face._split_from_fits(d, tolerance, pref)` with the preference given (the same
    comparisons per cell): with a tolerance, the preferred diagonal unless the other one fits clearly
    better where the preferred one costs more than half the tolerance; without, the better fitting one."""
    k = d.shape[0]
    out = np.empty(k, dtype=np.bool_)
    half, most = 0.5 * tolerance, 0.9 * tolerance
    for c in range(k):
        if not has_tol:
            out[c] = d[c, 0] <= d[c, 1]
            continue
        dp, do = (d[c, 0], d[c, 1]) if pref else (d[c, 1], d[c, 0])
        switch = ((dp > half) and (do < 0.8 * dp)) or ((dp > most) and (do < 0.98 * dp))
        out[c] = (not pref) if switch else pref
    return out


@njit(cache=True, nogil=True)
def curved_kernel(cp, w, rational, has_tol, tolerance):
    """True where `trimsurf.tessellate.face._plane_offset` certainly answers None (a weight not positive,
    or the control points' spread along the control net's normal above its limit with a margin), False
    where it must decide (a degenerate net, a near-planar one, or numbers not finite).

    The spread: the points' products with the unit normal, each within gamma_3 * sum_k |p_k n_k| of the
    exact one whatever the order of the sums (numpy's matmul, BLAS; gamma_3 < 3.4e-16); the margin
    1e-14 (sum + spread) lies far above those roundings and the ones of the limit and the normal."""
    if rational:
        for i in range(w.shape[0]):
            for j in range(w.shape[1]):
                if not w[i, j] > 0:
                    return True
    nu, nv = cp.shape[0], cp.shape[1]
    a0 = cp[nu - 1, nv - 1, 0] - cp[0, 0, 0]
    a1 = cp[nu - 1, nv - 1, 1] - cp[0, 0, 1]
    a2 = cp[nu - 1, nv - 1, 2] - cp[0, 0, 2]
    b0 = cp[nu - 1, 0, 0] - cp[0, nv - 1, 0]
    b1 = cp[nu - 1, 0, 1] - cp[0, nv - 1, 1]
    b2 = cp[nu - 1, 0, 2] - cp[0, nv - 1, 2]
    n0, n1, n2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
    ln2 = n0 * n0 + n1 * n1 + n2 * n2
    s2 = max(a0 * a0 + a1 * a1 + a2 * a2, b0 * b0 + b1 * b1 + b2 * b2)
    if not ln2 > 1e-12 * s2 * s2:
        return False
    size = np.sqrt(s2)
    ln = np.sqrt(ln2)
    n0, n1, n2 = n0 / ln, n1 / ln, n2 / ln
    lo, hi, big = np.inf, -np.inf, 0.0
    for i in range(nu):
        for j in range(nv):
            x, y, z = cp[i, j, 0], cp[i, j, 1], cp[i, j, 2]
            dist = x * n0 + y * n1 + z * n2
            lo = min(lo, dist)
            hi = max(hi, dist)
            big = max(big, abs(x * n0) + abs(y * n1) + abs(z * n2))
    delta = 0.5 * (hi - lo)
    limit = 1e-9 * size if not has_tol else min(1e-9 * size, 1e-3 * tolerance)
    return delta - 1e-14 * (big + delta) > limit
