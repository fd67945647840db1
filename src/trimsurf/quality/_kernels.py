"""Compiled (numba) kernels of the measurement: exact closest points on a mesh, distances to trim polygons.

`_tri_closest` is `closest_point.point_triangle_closest` (Ericson's
Voronoi-region test, zero-area triangles as their three edges) for one pair;
`grid_closest_kernel` searches a face mesh's triangles binned in a uniform grid
(`grid_build_kernel`) with it; `segments_distance_kernel` is the (u, v)
distance to trim polygons.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._numba_load import install as _install_lazy_bitcode

_install_lazy_bitcode()     # before this module's kernels load (trimsurf._numba_load)


@njit(cache=True, nogil=True, inline="always")
def _seg(p0, p1, p2, a0, a1, a2, b0, b1, b2):
    """Closest point parameter t on [a, b] to p (`point_segment_closest`)."""
    ab0, ab1, ab2 = b0 - a0, b1 - a1, b2 - a2
    den = ab0 * ab0 + ab1 * ab1 + ab2 * ab2
    t = 0.0
    if den > 0:
        t = ((p0 - a0) * ab0 + (p1 - a1) * ab1 + (p2 - a2) * ab2) / den
        t = min(max(t, 0.0), 1.0)
    return t


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _tri_closest(p0, p1, p2, a, b, c, out):
    """out[0:3] closest point on triangle (a, b, c) to p, out[3:6] its barycentric weights, returns the distance."""
    ab0, ab1, ab2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    ac0, ac1, ac2 = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    ap0, ap1, ap2 = p0 - a[0], p1 - a[1], p2 - a[2]
    bp0, bp1, bp2 = p0 - b[0], p1 - b[1], p2 - b[2]
    cp0, cp1, cp2 = p0 - c[0], p1 - c[1], p2 - c[2]
    d1 = ab0 * ap0 + ab1 * ap1 + ab2 * ap2
    d2 = ac0 * ap0 + ac1 * ap1 + ac2 * ap2
    d3 = ab0 * bp0 + ab1 * bp1 + ab2 * bp2
    d4 = ac0 * bp0 + ac1 * bp1 + ac2 * bp2
    d5 = ab0 * cp0 + ab1 * cp1 + ab2 * cp2
    d6 = ac0 * cp0 + ac1 * cp1 + ac2 * cp2
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    # the regions in the order `point_triangle_closest` lets them override each other (last wins)
    den = va + vb + vc
    v = vb / den if den != 0 else np.nan
    w = vc / den if den != 0 else np.nan
    if (va <= 0) and (d4 - d3 >= 0) and (d5 - d6 >= 0):
        s = (d4 - d3) + (d5 - d6)
        t = (d4 - d3) / s if s != 0 else np.nan
        v, w = 1.0 - t, t
    if (vb <= 0) and (d2 >= 0) and (d6 <= 0):
        s = d2 - d6
        t = d2 / s if s != 0 else np.nan
        v, w = 0.0, t
    if (d6 >= 0) and (d5 <= d6):
        v, w = 0.0, 1.0
    if (vc <= 0) and (d1 >= 0) and (d3 <= 0):
        s = d1 - d3
        t = d1 / s if s != 0 else np.nan
        v, w = t, 0.0
    if (d3 >= 0) and (d4 <= d3):
        v, w = 1.0, 0.0
    if (d1 <= 0) and (d2 <= 0):
        v, w = 0.0, 0.0
    n0 = ab1 * ac2 - ab2 * ac1
    n1 = ab2 * ac0 - ab0 * ac2
    n2 = ab0 * ac1 - ab1 * ac0
    flat = (n0 * n0 + n1 * n1 + n2 * n2) <= 1e-12 * (ab0 * ab0 + ab1 * ab1 + ab2 * ab2) * (ac0 * ac0 + ac1 * ac1
                                                                                           + ac2 * ac2)
    bad = not (np.isfinite(v) and np.isfinite(w)) or v < 0 or w < 0 or v + w > 1
    if bad or flat:
        # zero-area triangle: closest point on its three edges (first of equal distances kept); a nearly flat
        # one (sin of the angle at a below 1e-6) keeps the nearer of that and its regions' point, since
        # rounding decides its regions
        best = np.inf
        if not bad:
            x0 = (1.0 - v - w) * a[0] + v * b[0] + w * c[0]
            x1 = (1.0 - v - w) * a[1] + v * b[1] + w * c[1]
            x2 = (1.0 - v - w) * a[2] + v * b[2] + w * c[2]
            best = (p0 - x0) * (p0 - x0) + (p1 - x1) * (p1 - x1) + (p2 - x2) * (p2 - x2)
        for e in range(3):
            if e == 0:
                t = _seg(p0, p1, p2, a[0], a[1], a[2], b[0], b[1], b[2])
                vv, ww = t, 0.0 * t
                q0, q1, q2 = a[0] + t * ab0, a[1] + t * ab1, a[2] + t * ab2
            elif e == 1:
                t = _seg(p0, p1, p2, a[0], a[1], a[2], c[0], c[1], c[2])
                vv, ww = 0.0 * t, t
                q0, q1, q2 = a[0] + t * ac0, a[1] + t * ac1, a[2] + t * ac2
            else:
                t = _seg(p0, p1, p2, b[0], b[1], b[2], c[0], c[1], c[2])
                vv, ww = 1.0 - t, t
                q0 = b[0] + t * (c[0] - b[0])
                q1 = b[1] + t * (c[1] - b[1])
                q2 = b[2] + t * (c[2] - b[2])
            dd = (p0 - q0) * (p0 - q0) + (p1 - q1) * (p1 - q1) + (p2 - q2) * (p2 - q2)
            if dd < best:
                best, v, w = dd, vv, ww
    u = 1.0 - v - w
    x0 = u * a[0] + v * b[0] + w * c[0]
    x1 = u * a[1] + v * b[1] + w * c[1]
    x2 = u * a[2] + v * b[2] + w * c[2]
    out[0], out[1], out[2] = x0, x1, x2
    out[3], out[4], out[5] = u, v, w
    r0, r1, r2 = p0 - x0, p1 - x1, p2 - x2
    return np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)


@njit(cache=True, nogil=True)
def grid_build_kernel(lo_box, hi_box, origin, h, dims, counts_only, start, items):
    """Cells (a dense grid of side h from `origin`, dims (3,)) overlapped by each triangle's box: with
    `counts_only` fill start[c + 1] with the number of triangles of cell c; otherwise write the triangle
    indices into items[start[c]:start[c + 1]] (start as running offsets, advanced in place)."""
    nx, ny, nz = dims[0], dims[1], dims[2]
    for t in range(lo_box.shape[0]):
        i0 = min(max(int(np.floor((lo_box[t, 0] - origin[0]) / h)), 0), nx - 1)
        j0 = min(max(int(np.floor((lo_box[t, 1] - origin[1]) / h)), 0), ny - 1)
        k0 = min(max(int(np.floor((lo_box[t, 2] - origin[2]) / h)), 0), nz - 1)
        i1 = min(max(int(np.floor((hi_box[t, 0] - origin[0]) / h)), 0), nx - 1)
        j1 = min(max(int(np.floor((hi_box[t, 1] - origin[1]) / h)), 0), ny - 1)
        k1 = min(max(int(np.floor((hi_box[t, 2] - origin[2]) / h)), 0), nz - 1)
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                for k in range(k0, k1 + 1):
                    c = (i * ny + j) * nz + k
                    if counts_only:
                        start[c + 1] += 1
                    else:
                        items[start[c]] = t
                        start[c] += 1


@njit(cache=True, nogil=True)
def grid_closest_kernel(q, a, b, c, lo_box, hi_box, origin, h, dims, start, items, best_d, best_t, best_p, best_w):
    """Exact closest triangle for every query (`best_*` may hold an upper bound already: a pair replaces
    it only when strictly nearer). Searches cube shells of cells around the query's cell, r = 0, 1, ...:
    after shell r every triangle with a point within r h of the query has been tried, so the search stops
    once the best distance is at most r h (or the shells cover the grid)."""
    nx, ny, nz = dims[0], dims[1], dims[2]
    m = a.shape[0]
    stamp = np.full(m, -1, dtype=np.int64)
    out = np.empty(6)
    for n in range(q.shape[0]):
        fx = (q[n, 0] - origin[0]) / h
        fy = (q[n, 1] - origin[1]) / h
        fz = (q[n, 2] - origin[2]) / h
        ci, cj, ck = int(np.floor(fx)), int(np.floor(fy)), int(np.floor(fz))
        # shells before r0 lie wholly outside the grid
        r0 = max(0, -ci, ci - (nx - 1), -cj, cj - (ny - 1), -ck, ck - (nz - 1))
        r_all = max(ci, nx - 1 - ci, cj, ny - 1 - cj, ck, nz - 1 - ck)
        # the cube of shells 0..r-1 ends at these planes: every triangle not yet tried lies beyond one of
        # them (less a rounding allowance of the plane coordinates)
        slack = 1e-12 * (abs(q[n, 0]) + abs(q[n, 1]) + abs(q[n, 2]) + abs(origin[0]) + abs(origin[1])
                         + abs(origin[2]) + (abs(ci) + abs(cj) + abs(ck) + 3 * r_all + 3) * h)
        r = r0
        while True:
            if r > 0:
                if best_d[n] <= (r - 1) * h:
                    break
                # the exact distance to the cube's faces: often larger than (r - 1) h (the query's own
                # offset in its cell), so the search stops a shell earlier; a triangle beyond is at least
                # that far, and only a strictly nearer one would replace the best
                wall = min(q[n, 0] - (origin[0] + (ci - r + 1) * h), origin[0] + (ci + r) * h - q[n, 0],
                           q[n, 1] - (origin[1] + (cj - r + 1) * h), origin[1] + (cj + r) * h - q[n, 1],
                           q[n, 2] - (origin[2] + (ck - r + 1) * h), origin[2] + (ck + r) * h - q[n, 2])
                if best_d[n] <= wall - slack:
                    break
            i0, i1 = max(ci - r, 0), min(ci + r, nx - 1)
            j0, j1 = max(cj - r, 0), min(cj + r, ny - 1)
            k0, k1 = max(ck - r, 0), min(ck + r, nz - 1)
            for i in range(i0, i1 + 1):
                edge_i = i == ci - r or i == ci + r
                for j in range(j0, j1 + 1):
                    edge_j = edge_i or j == cj - r or j == cj + r
                    if edge_j:
                        kk0, kk1, kstep = k0, k1, 1
                    else:                       # only the two faces k = ck -+ r of the shell
                        kk0, kk1, kstep = ck - r, ck + r, 2 * r
                    k = kk0
                    while k <= kk1:
                        if 0 <= k < nz:
                            # the cell's box: skip it when wholly farther than the best so far
                            gx = max(origin[0] + i * h - q[n, 0], q[n, 0] - origin[0] - (i + 1) * h, 0.0)
                            gy = max(origin[1] + j * h - q[n, 1], q[n, 1] - origin[1] - (j + 1) * h, 0.0)
                            gz = max(origin[2] + k * h - q[n, 2], q[n, 2] - origin[2] - (k + 1) * h, 0.0)
                            if gx * gx + gy * gy + gz * gz >= best_d[n] * best_d[n]:
                                k += kstep
                                if kstep == 0:
                                    break
                                continue
                            cell = (i * ny + j) * nz + k
                            for s in range(start[cell], start[cell + 1]):
                                t = items[s]
                                if stamp[t] == n:
                                    continue
                                stamp[t] = n
                                # the triangle's box farther than the best so far: so is the triangle
                                bx = max(lo_box[t, 0] - q[n, 0], q[n, 0] - hi_box[t, 0], 0.0)
                                by = max(lo_box[t, 1] - q[n, 1], q[n, 1] - hi_box[t, 1], 0.0)
                                bz = max(lo_box[t, 2] - q[n, 2], q[n, 2] - hi_box[t, 2], 0.0)
                                if bx * bx + by * by + bz * bz >= best_d[n] * best_d[n]:
                                    continue
                                d = _tri_closest(q[n, 0], q[n, 1], q[n, 2], a[t], b[t], c[t], out)
                                if d < best_d[n]:
                                    best_d[n] = d
                                    best_t[n] = t
                                    for x in range(3):
                                        best_p[n, x] = out[x]
                                        best_w[n, x] = out[3 + x]
                        if kstep == 0:
                            break
                        k += kstep
            if r >= r_all:
                break
            r += 1


@njit(cache=True, nogil=True)
def hint_closest_kernel(q, a, b, c, tri, best_d, best_t, best_p, best_w):
    """best_* of every query q[n] on its hinted triangle tri[n] (`_tri_closest`, the numbers
    `grid_closest_kernel` computes for that pair): an upper bound it starts from."""
    out = np.empty(6)
    for n in range(q.shape[0]):
        t = tri[n]
        best_d[n] = _tri_closest(q[n, 0], q[n, 1], q[n, 2], a[t], b[t], c[t], out)
        best_t[n] = t
        for x in range(3):
            best_p[n, x] = out[x]
            best_w[n, x] = out[3 + x]


@njit(cache=True, nogil=True)
def segments_distance_kernel(p, a, b, out):
    """out[i] = distance from p[i] (2D) to the nearest segment a[j]-b[j] (`sampling.distance_outside_face`'s
    numpy expression per pair: t clipped to [0, 1], den floored at the smallest normal double)."""
    tiny = np.finfo(np.float64).tiny
    for i in range(p.shape[0]):
        best = np.inf
        for j in range(a.shape[0]):
            ab0, ab1 = b[j, 0] - a[j, 0], b[j, 1] - a[j, 1]
            den = max(ab0 * ab0 + ab1 * ab1, tiny)
            t = ((p[i, 0] - a[j, 0]) * ab0 + (p[i, 1] - a[j, 1]) * ab1) / den
            t = min(max(t, 0.0), 1.0)
            r0 = p[i, 0] - (a[j, 0] + t * ab0)
            r1 = p[i, 1] - (a[j, 1] + t * ab1)
            d = np.sqrt(r0 * r0 + r1 * r1)
            if d < best:
                best = d
        out[i] = best


@njit(cache=True, nogil=True)
def uv_locate_kernel(uv, order, start, lo, h, dims, tri, skip, hint, in_skipped):
    """For (u, v) points `uv` (n, 2) binned in a uniform grid (cell side h (2,), dims (2,), from `lo`;
    `order` the points sorted by cell, `start` (cells + 1) the offsets): hint[p] = a triangle of `tri`
    (m, 3, 2) holding uv[p] (closed; -1 none; a triangle with a NaN corner or zero area holds none), and
    in_skipped[p] whether one with skip[t] holds it. Each triangle tests the points of the cells its box
    overlaps (barycentric coordinates, the same expressions as `deviation._in_triangles`)."""
    nu, nv = dims[0], dims[1]
    for t in range(tri.shape[0]):
        x0, y0 = tri[t, 0, 0], tri[t, 0, 1]
        x1, y1 = tri[t, 1, 0], tri[t, 1, 1]
        x2, y2 = tri[t, 2, 0], tri[t, 2, 1]
        if not (np.isfinite(x0) and np.isfinite(y0) and np.isfinite(x1) and np.isfinite(y1)
                and np.isfinite(x2) and np.isfinite(y2)):
            continue
        e10, e11 = x1 - x0, y1 - y0
        e20, e21 = x2 - x0, y2 - y0
        det = e10 * e21 - e11 * e20
        if det == 0.0:
            continue
        i0 = min(max(int(np.floor((min(x0, x1, x2) - lo[0]) / h[0])), 0), nu - 1)
        i1 = min(max(int(np.floor((max(x0, x1, x2) - lo[0]) / h[0])), 0), nu - 1)
        j0 = min(max(int(np.floor((min(y0, y1, y2) - lo[1]) / h[1])), 0), nv - 1)
        j1 = min(max(int(np.floor((max(y0, y1, y2) - lo[1]) / h[1])), 0), nv - 1)
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                c = i * nv + j
                for s in range(start[c], start[c + 1]):
                    p = order[s]
                    if in_skipped[p] or (hint[p] >= 0 and not skip[t]):
                        continue
                    r0, r1 = uv[p, 0] - x0, uv[p, 1] - y0
                    l1 = (r0 * e21 - r1 * e20) / det
                    l2 = (e10 * r1 - e11 * r0) / det
                    if l1 >= 0.0 and l2 >= 0.0 and l1 + l2 <= 1.0:
                        hint[p] = t
                        if skip[t]:
                            in_skipped[p] = True
