"""The grid of iso-parametric lines with the trim polygons inserted (paper Sec. 4.3, 5.1, Fig. 10).

Trim segments are clipped against the grid cells with the Cohen-Sutherland
outcodes; only the cells they cross are triangulated by a constrained Delaunay
triangulation (Shewchuk's Triangle) of the cell boundaries and the clipped
segments; every untouched cell inside the trim is split along the diagonal
that best fits the surface (or kept as a quad). Exterior triangles are removed.

All crossed cells go to Triangle in one call: their four sides are constraint
segments, so each crossed cell is triangulated on its own, exactly as one
call per cell would, at a fraction of the cost.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import triangle as tr
from triangle.core import triang as _triang
from numba import njit

from .._numba_load import install as _install_lazy_bitcode
from ..errors import TrimLoopError
from ..geom.predicates import _CCW_BOUND, PolygonIndex, _point_in_index, _slab_index
from .pslg import _is_clean_kernel, clean_pslg

_install_lazy_bitcode()     # before this module's kernels load (trimsurf._numba_load)

__all__ = ["outcodes", "cohen_sutherland_cells", "DomainTriangulation", "triangulate_domain"]

_INSIDE, _LEFT, _RIGHT, _BOTTOM, _TOP = 0, 1, 2, 4, 8

#: distance in Triangle's coordinates (the crossed cells' box scaled to about the unit square, so about
#: a fraction of the face's size) below which two points are one and a point lies on a segment
SNAP = 1e-10


def outcodes(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Cohen-Sutherland outcodes of points (n, 2) against boxes lo, hi (n, 2) (closed boxes)."""
    code = np.zeros(len(p), dtype=np.int8)
    code |= np.where(p[:, 0] < lo[:, 0], _LEFT, 0).astype(np.int8)
    code |= np.where(p[:, 0] > hi[:, 0], _RIGHT, 0).astype(np.int8)
    code |= np.where(p[:, 1] < lo[:, 1], _BOTTOM, 0).astype(np.int8)
    code |= np.where(p[:, 1] > hi[:, 1], _TOP, 0).astype(np.int8)
    return code


def _clip_hits(p0, p1, lo, hi) -> np.ndarray:
    """Whether each segment p0 p1 meets its closed box [lo, hi] (Cohen-Sutherland, vectorized)."""
    a, b = p0.astype(np.float64).copy(), p1.astype(np.float64).copy()
    ca, cb = outcodes(a, lo, hi), outcodes(b, lo, hi)
    hit = np.zeros(len(a), dtype=bool)
    active = np.ones(len(a), dtype=bool)
    for _ in range(6):                            # each round clips one end to one box side
        acc = active & ((ca | cb) == 0)
        hit |= acc
        active &= ~acc & ((ca & cb) == 0)         # trivially accepted or rejected: done
        if not active.any():
            break
        use_a = ca != 0
        out = np.where(use_a, ca, cb)
        d = b - a
        with np.errstate(divide="ignore", invalid="ignore"):
            ty = np.where(out & _TOP, hi[:, 1], lo[:, 1])
            tx = np.where(out & _RIGHT, hi[:, 0], lo[:, 0])
            vert = (out & (_TOP | _BOTTOM)) != 0
            x = np.where(vert, a[:, 0] + d[:, 0] * (ty - a[:, 1]) / d[:, 1], tx)
            y = np.where(vert, ty, a[:, 1] + d[:, 1] * (tx - a[:, 0]) / d[:, 0])
        new = np.column_stack([x, y])
        ma = active & use_a
        mb = active & ~use_a
        a = np.where(ma[:, None], new, a)
        b = np.where(mb[:, None], new, b)
        ca = np.where(ma, outcodes(a, lo, hi), ca)
        cb = np.where(mb, outcodes(b, lo, hi), cb)
    return hit


def _candidate_cells(p0: np.ndarray, p1: np.ndarray, us: np.ndarray, vs: np.ndarray):
    """Per segment p0 p1, the candidate cells i0..i1 x j0..j1 (closed ranges, within the grid) around
    the segment's box: what `cohen_sutherland_cells` and `_crossed_cells` clip against."""
    lo = np.minimum(p0, p1)
    hi = np.maximum(p0, p1)
    i0 = np.clip(np.searchsorted(us, lo[:, 0], side="right") - 2, 0, len(us) - 2)
    i1 = np.clip(np.searchsorted(us, hi[:, 0], side="left"), 0, len(us) - 2)
    j0 = np.clip(np.searchsorted(vs, lo[:, 1], side="right") - 2, 0, len(vs) - 2)
    j1 = np.clip(np.searchsorted(vs, hi[:, 1], side="left"), 0, len(vs) - 2)
    return i0, i1, j0, j1


def cohen_sutherland_cells(p0: np.ndarray, p1: np.ndarray, us: np.ndarray, vs: np.ndarray) -> np.ndarray:
    """Cells (i, j) of the grid us x vs that each segment p0 p1 meets (closed cells).

    Parameters
    ----------
    p0, p1 : (n, 2) float64
    us, vs : increasing grid values.

    Returns
    -------
    (k, 3) int64 : rows (segment, i, j), cell i in [0, len(us) - 1), j in [0, len(vs) - 1).

    Examples
    --------
    >>> import numpy as np
    >>> g = np.array([0.0, 1.0, 2.0])
    >>> cohen_sutherland_cells(np.array([[0.5, 0.5]]), np.array([[1.5, 0.5]]), g, g).tolist()
    [[0, 0, 0], [0, 1, 0]]
    """
    i0, i1, j0, j1 = _candidate_cells(p0, p1, us, vs)
    ni, nj = i1 - i0 + 1, j1 - j0 + 1
    cnt = ni * nj
    seg = np.repeat(np.arange(len(p0)), cnt)
    k = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    ci = i0[seg] + k // nj[seg]
    cj = j0[seg] + k % nj[seg]
    blo = np.column_stack([us[ci], vs[cj]])
    bhi = np.column_stack([us[ci + 1], vs[cj + 1]])
    hit = _clip_hits(p0[seg], p1[seg], blo, bhi)
    return np.column_stack([seg[hit], ci[hit], cj[hit]]).astype(np.int64)


def _side_segments_numpy(uv, us, vs, crossed):
    """`_side_segments` in numpy (the reference of the compiled kernel, for the tests)."""
    nu, nv = len(us), len(vs)
    segs = [np.zeros((0, 2), dtype=np.int64)]
    for axis in (0, 1):
        line_vals, other_vals = (vs, us) if axis == 0 else (us, vs)
        # horizontal sides (axis 0): v = vs[j], u in [us[i], us[i+1]]
        on = _is_in(uv[:, 1 - axis], line_vals)
        cand = np.flatnonzero(on)
        if not len(cand):
            continue
        line_idx = np.searchsorted(line_vals, uv[cand, 1 - axis])
        order = np.lexsort((uv[cand, axis], line_idx))
        cand, line_idx = cand[order], line_idx[order]
        a, b = cand[:-1], cand[1:]
        same = line_idx[:-1] == line_idx[1:]
        a, b, li = a[same], b[same], line_idx[:-1][same]
        mid = 0.5 * (uv[a, axis] + uv[b, axis])
        col = np.clip(np.searchsorted(other_vals, mid) - 1, 0, len(other_vals) - 2)
        within = (uv[a, axis] >= other_vals[col]) & (uv[b, axis] <= other_vals[col + 1])
        if axis == 0:   # side between cells (col, li-1) and (col, li)
            c1 = np.where(li > 0, crossed[col, np.maximum(li - 1, 0)], False)
            c2 = np.where(li < nv - 1, crossed[col, np.minimum(li, nv - 2)], False)
        else:
            c1 = np.where(li > 0, crossed[np.maximum(li - 1, 0), col], False)
            c2 = np.where(li < nu - 1, crossed[np.minimum(li, nu - 2), col], False)
        sel = within & (c1 | c2) & (uv[a, axis] < uv[b, axis])
        segs.append(np.column_stack([a[sel], b[sel]]))

    return np.concatenate(segs)


def _side_segments(uv: np.ndarray, us: np.ndarray, vs: np.ndarray, crossed: np.ndarray) -> np.ndarray:
    """The sides of the crossed cells as segments between consecutive vertices of `uv` lying exactly on a
    grid line (k, 2) int64 (the order differs from `_side_segments_numpy`, the set is the same): the
    vertices on each line sorted by numpy, the pairs tested by a compiled loop."""
    parts = []
    for axis in (0, 1):
        line_vals = vs if axis == 0 else us
        cand = np.flatnonzero(_is_in(uv[:, 1 - axis], line_vals))
        if len(cand) < 2:
            continue
        line_idx = np.searchsorted(line_vals, uv[cand, 1 - axis])
        order = np.lexsort((uv[cand, axis], line_idx))
        parts.append(_side_pairs_kernel(np.ascontiguousarray(uv, dtype=np.float64), np.ascontiguousarray(us),
                                        np.ascontiguousarray(vs), np.ascontiguousarray(crossed), axis,
                                        np.ascontiguousarray(cand[order]), np.ascontiguousarray(line_idx[order])))
    return np.concatenate(parts) if parts else np.zeros((0, 2), dtype=np.int64)


@njit(cache=True, nogil=True)
def _side_pairs_kernel(uv, us, vs, crossed, axis, cand, line):
    """Of the vertices `cand` sorted along their grid lines `line`, the consecutive pairs that are a side
    (or a piece of one) of a crossed cell."""
    nu, nv = us.shape[0], vs.shape[0]
    other_vals = us if axis == 0 else vs
    out = np.empty((max(cand.shape[0] - 1, 0), 2), dtype=np.int64)
    cnt = 0
    for t in range(cand.shape[0] - 1):
        if line[t] != line[t + 1]:
            continue
        a, b = cand[t], cand[t + 1]
        li = line[t]
        ua, ub = uv[a, axis], uv[b, axis]
        mid = 0.5 * (ua + ub)
        col = min(max(np.searchsorted(other_vals, mid) - 1, 0), other_vals.shape[0] - 2)
        if not (ua >= other_vals[col] and ub <= other_vals[col + 1] and ua < ub):
            continue
        if axis == 0:   # side between cells (col, li-1) and (col, li)
            c1 = crossed[col, max(li - 1, 0)] if li > 0 else False
            c2 = crossed[col, min(li, nv - 2)] if li < nv - 1 else False
        else:
            c1 = crossed[max(li - 1, 0), col] if li > 0 else False
            c2 = crossed[min(li, nu - 2), col] if li < nu - 1 else False
        if c1 or c2:
            out[cnt, 0] = a
            out[cnt, 1] = b
            cnt += 1
    return out[:cnt]


def _is_in(x: np.ndarray, values: np.ndarray) -> np.ndarray:
    """np.isin(x, values) for increasing `values` (a binary search each)."""
    if not len(values):
        return np.zeros(len(x), dtype=bool)
    pos = np.minimum(np.searchsorted(values, x), len(values) - 1)
    return values[pos] == x


def _first_equal(p: np.ndarray) -> np.ndarray:
    """Per row of p (n, 2), the lowest index of a row equal to it (value-wise, as np.unique(axis=0))."""
    n = len(p)
    if not n:
        return np.zeros(0, dtype=np.int64)
    order = np.lexsort((p[:, 1], p[:, 0]))      # stable: equal rows in index order, the first is the lowest
    q = p[order]
    new = np.empty(n, dtype=bool)
    new[0] = True
    np.not_equal(q[1:, 0], q[:-1, 0], out=new[1:])
    new[1:] |= q[1:, 1] != q[:-1, 1]
    head = order[np.flatnonzero(new)]
    out = np.empty(n, dtype=np.int64)
    out[order] = head[np.cumsum(new) - 1]
    return out


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _bisect(a, x, right):
    """np.searchsorted(a, x, side="right" if right else "left") for increasing a (NaN sorts last)."""
    lo, hi = 0, a.shape[0]
    if x != x:
        return hi
    while lo < hi:
        mid = (lo + hi) >> 1
        if a[mid] < x or (right and a[mid] == x):
            lo = mid + 1
        else:
            hi = mid
    return lo


def _crossed_cells(p0: np.ndarray, p1: np.ndarray, us: np.ndarray, vs: np.ndarray) -> np.ndarray:
    """(len(us) - 1, len(vs) - 1) bool: the cells `cohen_sutherland_cells` finds, compiled (the same
    candidate cells and the same clipping arithmetic, per segment and cell)."""
    crossed = np.zeros((len(us) - 1, len(vs) - 1), dtype=np.bool_)
    _crossed_cells_kernel(np.ascontiguousarray(p0, dtype=np.float64), np.ascontiguousarray(p1, dtype=np.float64),
                          np.ascontiguousarray(us, dtype=np.float64), np.ascontiguousarray(vs, dtype=np.float64),
                          crossed)
    return crossed


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _outcode(x, y, lx, ly, hx, hy):
    c = 0
    if x < lx:
        c |= _LEFT
    if x > hx:
        c |= _RIGHT
    if y < ly:
        c |= _BOTTOM
    if y > hy:
        c |= _TOP
    return c


@njit(cache=True, nogil=True, error_model="numpy")
def _crossed_cells_kernel(p0, p1, us, vs, crossed):
    nu, nv = us.shape[0], vs.shape[0]
    for s in range(p0.shape[0]):
        # `_candidate_cells`
        i0 = min(max(_bisect(us, min(p0[s, 0], p1[s, 0]), np.bool_(True)) - 2, 0), nu - 2)
        i1 = min(max(_bisect(us, max(p0[s, 0], p1[s, 0]), np.bool_(False)), 0), nu - 2)
        j0 = min(max(_bisect(vs, min(p0[s, 1], p1[s, 1]), np.bool_(True)) - 2, 0), nv - 2)
        j1 = min(max(_bisect(vs, max(p0[s, 1], p1[s, 1]), np.bool_(False)), 0), nv - 2)
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                if crossed[i, j]:
                    continue
                lx, ly, hx, hy = us[i], vs[j], us[i + 1], vs[j + 1]
                ax, ay, bx, by = p0[s, 0], p0[s, 1], p1[s, 0], p1[s, 1]
                ca = _outcode(ax, ay, lx, ly, hx, hy)
                cb = _outcode(bx, by, lx, ly, hx, hy)
                for _ in range(6):      # as `_clip_hits`: each round clips one end to one box side
                    if (ca | cb) == 0:
                        crossed[i, j] = True
                        break
                    if (ca & cb) != 0:
                        break
                    use_a = ca != 0
                    out = ca if use_a else cb
                    dx, dy = bx - ax, by - ay
                    if out & (_TOP | _BOTTOM):
                        ty = hy if out & _TOP else ly
                        x = ax + dx * (ty - ay) / dy
                        y = ty
                    else:
                        tx = hx if out & _RIGHT else lx
                        x = tx
                        y = ay + dy * (tx - ax) / dx
                    if use_a:
                        ax, ay = x, y
                        ca = _outcode(ax, ay, lx, ly, hx, hy)
                    else:
                        bx, by = x, y
                        cb = _outcode(bx, by, lx, ly, hx, hy)


@njit(cache=True, nogil=True)
def _keep_cells_kernel(us, vs, crossed, a, b, y0, h, n_slab, start, edges, keep):
    """keep[i, j]: cell (i, j) is not crossed and its centre lies inside the polygons (a `PolygonIndex`)."""
    for i in range(us.shape[0] - 1):
        cx = 0.5 * (us[i] + us[i + 1])
        for j in range(vs.shape[0] - 1):
            if not crossed[i, j]:
                keep[i, j] = _point_in_index(cx, 0.5 * (vs[j] + vs[j + 1]), a, b, y0, h, n_slab, start, edges)


@njit(cache=True, nogil=True)
def _grid_nodes_kernel(pts, us, vs, crossed, keep, ki, kj, main):
    """The grid nodes at crossed or kept cells (strictly increasing us, vs): (uv, grid node) of those not
    equal to a trim point, in flat order, the grid node of each trim point (-1 or the node it equals, for
    the first of equal trim points), and the kept cells' two triangles (first triangles, then second)."""
    nu, nv = us.shape[0], vs.shape[0]
    n_trim = pts.shape[0]
    node_trim = np.empty(nu * nv, dtype=np.int64)
    node_vertex = np.empty(nu * nv, dtype=np.int64)
    for f in range(nu * nv):
        node_trim[f] = -1
        node_vertex[f] = -1
    for t in range(n_trim):
        iu = _bisect(us, pts[t, 0], np.bool_(False))
        jv = _bisect(vs, pts[t, 1], np.bool_(False))
        if iu < nu and jv < nv and us[iu] == pts[t, 0] and vs[jv] == pts[t, 1]:
            f = iu * nv + jv
            if node_trim[f] < 0:
                node_trim[f] = t
    trim_gn = np.empty(n_trim, dtype=np.int64)
    for t in range(n_trim):
        trim_gn[t] = -1
    n_used = 0
    for i in range(nu):
        for j in range(nv):
            used = False
            for ci in range(max(i - 1, 0), min(i, nu - 2) + 1):
                for cj in range(max(j - 1, 0), min(j, nv - 2) + 1):
                    if crossed[ci, cj] or keep[ci, cj]:
                        used = True
            if used:
                node_vertex[i * nv + j] = -2
                n_used += 1
    node_uv = np.empty((n_used, 2))
    node_gn = np.empty(n_used, dtype=np.int64)
    k = 0
    for f in range(nu * nv):
        if node_vertex[f] != -2:
            continue
        t = node_trim[f]
        if t >= 0:
            node_vertex[f] = t
            trim_gn[t] = f
        else:
            node_vertex[f] = n_trim + k
            node_uv[k, 0] = us[f // nv]
            node_uv[k, 1] = vs[f % nv]
            node_gn[k] = f
            k += 1
    nq = ki.shape[0]
    tris = np.empty((2 * nq, 3), dtype=np.int64)
    for q in range(nq):
        i, j = ki[q], kj[q]
        v00 = node_vertex[i * nv + j]
        v10 = node_vertex[(i + 1) * nv + j]
        v11 = node_vertex[(i + 1) * nv + j + 1]
        v01 = node_vertex[i * nv + j + 1]
        if main[q]:
            tris[q, 0], tris[q, 1], tris[q, 2] = v00, v10, v11
            tris[nq + q, 0], tris[nq + q, 1], tris[nq + q, 2] = v00, v11, v01
        else:
            tris[q, 0], tris[q, 1], tris[q, 2] = v00, v10, v01
            tris[nq + q, 0], tris[nq + q, 1], tris[nq + q, 2] = v10, v11, v01
    return node_uv[:k], node_gn[:k], trim_gn, tris


def _grid_nodes_numpy(pts, us, vs, crossed, keep_cell, ki, kj, main):
    """`_grid_nodes_kernel` for any grid values (equal ones too), the reference of the kernel:
    (uv, grid_node, grid triangles)."""
    nu, nv = len(us), len(vs)
    n_trim = len(pts)
    node_used = np.zeros((nu, nv), dtype=bool)
    for di in (0, 1):
        for dj in (0, 1):
            node_used[di:nu - 1 + di, dj:nv - 1 + dj] |= crossed | keep_cell
    node_flat = np.flatnonzero(node_used.ravel())
    gi, gj = node_flat // nv, node_flat % nv
    node_uv = np.column_stack([us[gi], vs[gj]])
    # merge grid nodes that coincide exactly with trim points
    all_uv = np.concatenate([pts, node_uv])
    # representative index: trim points keep their index; a node equal to a trim point maps to it
    idx_of = _first_equal(all_uv)                         # index into all_uv of each point's representative
    # compact vertex list: trim points first (all kept), then nodes not merged
    is_node = np.arange(len(all_uv)) >= n_trim
    node_kept = is_node & (idx_of == np.arange(len(all_uv)))
    new_index = np.full(len(all_uv), -1, dtype=np.int64)
    new_index[:n_trim] = np.arange(n_trim)
    new_index[node_kept] = n_trim + np.arange(int(node_kept.sum()))
    vmap = new_index[idx_of]                              # all_uv index -> vertex index
    uv = np.concatenate([pts, node_uv[node_kept[n_trim:]]])
    grid_node = np.full(len(uv), -1, dtype=np.int64)
    grid_node[vmap[n_trim:]] = node_flat
    node_vertex = np.full(nu * nv, -1, dtype=np.int64)
    node_vertex[node_flat] = vmap[n_trim:]
    v00 = node_vertex[ki * nv + kj]
    v10 = node_vertex[(ki + 1) * nv + kj]
    v11 = node_vertex[(ki + 1) * nv + kj + 1]
    v01 = node_vertex[ki * nv + kj + 1]
    t1 = np.where(main[:, None], np.column_stack([v00, v10, v11]), np.column_stack([v00, v10, v01]))
    t2 = np.where(main[:, None], np.column_stack([v00, v11, v01]), np.column_stack([v10, v11, v01]))
    return uv, grid_node, np.concatenate([t1, t2]).reshape(-1, 3).astype(np.int64)


@njit(cache=True, nogil=True)
def _cdt_keep_kernel(uv, tri, us, vs, crossed, a, b, y0, h, n_slab, start, edges, ok):
    """ok[k]: triangle k's centroid (the mean of its corners) lies in a crossed cell and inside the polygons."""
    nu, nv = us.shape[0], vs.shape[0]
    for k in range(tri.shape[0]):
        p, q, r = tri[k, 0], tri[k, 1], tri[k, 2]
        cx = (uv[p, 0] + uv[q, 0] + uv[r, 0]) / 3.0
        cy = (uv[p, 1] + uv[q, 1] + uv[r, 1]) / 3.0
        ti = min(max(_bisect(us, cx, np.bool_(False)) - 1, 0), nu - 2)
        tj = min(max(_bisect(vs, cy, np.bool_(False)) - 1, 0), nv - 2)
        ok[k] = crossed[ti, tj] and _point_in_index(cx, cy, a, b, y0, h, n_slab, start, edges)


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _less2(a, b, i, j):
    """(a[i], b[i], i) < (a[j], b[j], j): np.lexsort((b, a))'s order (stable)."""
    if a[i] != a[j]:
        return a[i] < a[j]
    if b[i] != b[j]:
        return b[i] < b[j]
    return i < j


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _argsort2(a, b):
    """np.lexsort((b, a)) of finite a, b (a merge sort; -0.0 equal to 0.0, equal keys in index order)."""
    n = a.shape[0]
    idx = np.arange(n)
    tmp = np.empty(n, dtype=np.int64)
    width = 1
    while width < n:
        for lo in range(0, n, 2 * width):
            mid = min(lo + width, n)
            hi = min(lo + 2 * width, n)
            i, j, k = lo, mid, lo
            while i < mid and j < hi:
                if _less2(a, b, idx[j], idx[i]):
                    tmp[k] = idx[j]
                    j += 1
                else:
                    tmp[k] = idx[i]
                    i += 1
                k += 1
            while i < mid:
                tmp[k] = idx[i]
                i += 1
                k += 1
            while j < hi:
                tmp[k] = idx[j]
                j += 1
                k += 1
        idx, tmp = tmp, idx
        width *= 2
    return idx


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _in_sorted(values, x):
    """`_is_in` of one value."""
    if values.shape[0] == 0:
        return False
    pos = min(_bisect(values, x, np.bool_(False)), values.shape[0] - 1)
    return values[pos] == x


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _domain_cells(pts, lens, us, vs, extra):
    """Steps 1-2 of `triangulate_domain`: each trim point's next (p1), the crossed cells (the extra points'
    cells too, `extra` unique rows: which of them count), the `PolygonIndex` of the polygons and the kept
    cells."""
    n_trim = pts.shape[0]
    nu, nv = us.shape[0], vs.shape[0]
    seg_b = np.empty(n_trim, dtype=np.int64)
    s0 = 0
    for L in lens:
        for k in range(L):
            seg_b[s0 + k] = s0 + k + 1
        seg_b[s0 + L - 1] = s0
        s0 += L
    p1 = np.empty((n_trim, 2))
    for t in range(n_trim):
        p1[t, 0] = pts[seg_b[t], 0]
        p1[t, 1] = pts[seg_b[t], 1]
    crossed = np.zeros((nu - 1, nv - 1), dtype=np.bool_)
    _crossed_cells_kernel(pts, p1, us, vs, crossed)
    ne = extra.shape[0]
    e_ok = np.zeros(ne, dtype=np.bool_)
    for k in range(ne):
        ex, ey = extra[k, 0], extra[k, 1]
        ei = _bisect(us, ex, np.bool_(False)) - 1
        ej = _bisect(vs, ey, np.bool_(False)) - 1
        if 0 <= ei < nu - 1 and 0 <= ej < nv - 1 and not _in_sorted(us, ex) and not _in_sorted(vs, ey):
            crossed[ei, ej] = True
            e_ok[k] = True
    y0, h, n_slab, start, edges = _slab_index(pts, p1)
    keep = np.zeros((nu - 1, nv - 1), dtype=np.bool_)
    _keep_cells_kernel(us, vs, crossed, pts, p1, y0, h, n_slab, start, edges, keep)
    return seg_b, p1, crossed, e_ok, y0, h, n_slab, start, edges, keep


@njit(cache=True, nogil=True)
def _domain_keep_kernel(pts, lens, us, vs, extra):
    """The kept cells of `triangulate_domain` (untouched, centre inside)."""
    return _domain_cells(pts, lens, us, vs, extra)[9]


@njit(cache=True, nogil=True)
def _domain_prepare_kernel(pts, lens, us, vs, extra, cell_main, has_main, shear, snap, bound):
    """`_triangulate_domain_numpy` up to Triangle, for strictly increasing us, vs and finite points.

    Returns (status, uv, grid_node, grid_tris, quads, crossed, p1, PolygonIndex arrays (y0, h, n_slab,
    start, edges), Triangle's vertices q and segments, the vertices used (rows of uv), scale_lo, scale):
    status 0 no crossed cell (no Triangle), 1 Triangle's input is ready (what `clean_pslg` returns at
    once), 2 the graph needs `clean_pslg`'s rounds (not done here), 3 grid values not strictly increasing
    or points not finite (nothing done)."""
    n_trim = pts.shape[0]
    nu, nv = us.shape[0], vs.shape[0]
    ok = True
    for i in range(nu - 1):
        ok &= us[i + 1] > us[i]
    for j in range(nv - 1):
        ok &= vs[j + 1] > vs[j]
    for t in range(n_trim):
        ok &= np.isfinite(pts[t, 0]) and np.isfinite(pts[t, 1])
    for k in range(extra.shape[0]):
        ok &= np.isfinite(extra[k, 0]) and np.isfinite(extra[k, 1])
    if not ok:      # the numpy path's case
        z2, zi = np.empty((0, 2)), np.empty(0, dtype=np.int64)
        return (3, z2, zi, np.empty((0, 3), dtype=np.int64), np.empty((0, 2), dtype=np.int64),
                np.zeros((0, 0), dtype=np.bool_), z2, 0.0, 1.0, 0, zi, zi, z2, np.empty((0, 2), dtype=np.int32), zi,
                np.zeros(2), np.ones(2))
    seg_b, p1, crossed, e_ok, y0, h, n_slab, start, edges, keep = _domain_cells(pts, lens, us, vs, extra)
    nq = 0
    for i in range(nu - 1):
        for j in range(nv - 1):
            if keep[i, j]:
                nq += 1
    ki = np.empty(nq, dtype=np.int64)
    kj = np.empty(nq, dtype=np.int64)
    main = np.ones(nq, dtype=np.bool_)
    k = 0
    for i in range(nu - 1):
        for j in range(nv - 1):
            if keep[i, j]:
                ki[k], kj[k] = i, j
                if has_main:
                    main[k] = cell_main[i * (nv - 1) + j]
                k += 1
    # the first trim point equal to each (`_first_equal`)
    px = np.empty(n_trim)
    py = np.empty(n_trim)
    for t in range(n_trim):
        px[t], py[t] = pts[t, 0], pts[t, 1]
    order = _argsort2(px, py)
    vmap = np.empty(n_trim, dtype=np.int64)
    head = -1
    for r in range(n_trim):
        t = order[r]
        if r == 0 or pts[t, 0] != pts[order[r - 1], 0] or pts[t, 1] != pts[order[r - 1], 1]:
            head = t
        vmap[t] = head
    node_uv, node_gn, trim_gn, grid_tris = _grid_nodes_kernel(pts, us, vs, crossed, keep, ki, kj, main)
    n_node = node_uv.shape[0]
    n_e = 0
    for k in range(e_ok.shape[0]):
        if e_ok[k]:
            n_e += 1
    any_crossed = False
    for i in range(nu - 1):
        for j in range(nv - 1):
            if crossed[i, j]:
                any_crossed = True
    n_uv = n_trim + n_node + (n_e if any_crossed else 0)
    uv = np.empty((n_uv, 2))
    grid_node = np.empty(n_uv, dtype=np.int64)
    for t in range(n_trim):
        uv[t, 0], uv[t, 1] = pts[t, 0], pts[t, 1]
        grid_node[t] = trim_gn[t]
    for k in range(n_node):
        uv[n_trim + k, 0], uv[n_trim + k, 1] = node_uv[k, 0], node_uv[k, 1]
        grid_node[n_trim + k] = node_gn[k]
    quads = np.empty((nq, 2), dtype=np.int64)
    for k in range(nq):
        quads[k, 0] = k
        quads[k, 1] = nq + k
    q = np.empty((0, 2))
    no_seg = np.empty((0, 2), dtype=np.int32)     # Triangle's segments (its C int) where it is not called
    used = np.empty(0, dtype=np.int64)
    lo = np.zeros(2)
    scale = np.ones(2)
    if not any_crossed:
        return (0, uv, grid_node, grid_tris, quads, crossed, p1, y0, h, n_slab, start, edges, q, no_seg, used,
                lo, scale)
    n_base = n_trim + n_node
    # constraint segments: the trim segments, then the crossed cells' sides (`_side_segments`)
    side0 = np.empty((0, 2), dtype=np.int64)
    side1 = np.empty((0, 2), dtype=np.int64)
    for axis in range(2):
        line_vals = vs if axis == 0 else us
        n_c = 0
        for t in range(n_base):
            if _in_sorted(line_vals, uv[t, 1 - axis]):
                n_c += 1
        if n_c < 2:
            continue
        cand = np.empty(n_c, dtype=np.int64)
        line = np.empty(n_c, dtype=np.int64)
        key = np.empty(n_c)
        line_f = np.empty(n_c)
        c = 0
        for t in range(n_base):
            if _in_sorted(line_vals, uv[t, 1 - axis]):
                cand[c] = t
                line[c] = _bisect(line_vals, uv[t, 1 - axis], np.bool_(False))
                line_f[c] = line[c]
                key[c] = uv[t, axis]
                c += 1
        o = _argsort2(line_f, key)
        cand_o = np.empty(n_c, dtype=np.int64)
        line_o = np.empty(n_c, dtype=np.int64)
        for c in range(n_c):
            cand_o[c], line_o[c] = cand[o[c]], line[o[c]]
        sp = _side_pairs_kernel(uv, us, vs, crossed, axis, cand_o, line_o)
        if axis == 0:
            side0 = sp
        else:
            side1 = sp
    n_side = side0.shape[0] + side1.shape[0]
    seg = np.empty((n_trim + n_side, 2), dtype=np.int64)
    m = 0
    for t in range(n_trim):
        a, b = vmap[t], vmap[seg_b[t]]
        if a != b:
            seg[m, 0], seg[m, 1] = a, b
            m += 1
    for r in range(n_side):
        a = side0[r, 0] if r < side0.shape[0] else side1[r - side0.shape[0], 0]
        b = side0[r, 1] if r < side0.shape[0] else side1[r - side0.shape[0], 1]
        if a != b:
            seg[m, 0], seg[m, 1] = a, b
            m += 1
    seg = seg[:m]
    mark = np.zeros(n_uv, dtype=np.bool_)
    for r in range(m):
        mark[seg[r, 0]] = True
        mark[seg[r, 1]] = True
    n_used = 0
    for t in range(n_base):
        if mark[t]:
            n_used += 1
    used = np.empty(n_used + n_e, dtype=np.int64)
    c = 0
    for t in range(n_base):
        if mark[t]:
            used[c] = t
            c += 1
    r = n_base
    for k in range(e_ok.shape[0]):
        if e_ok[k]:
            uv[r, 0], uv[r, 1] = extra[k, 0], extra[k, 1]
            grid_node[r] = -1
            used[c] = r
            c += 1
            r += 1
    local = np.full(n_uv, -1, dtype=np.int64)
    for c in range(used.shape[0]):
        local[used[c]] = c
    n_q = used.shape[0]
    if n_q == 0:
        return (2, uv, grid_node, grid_tris, quads, crossed, p1, y0, h, n_slab, start, edges, q, no_seg, used,
                lo, scale)
    hi = np.empty(2)
    for d in range(2):
        lo[d] = uv[used[0], d]
        hi[d] = uv[used[0], d]
    for c in range(n_q):
        for d in range(2):
            lo[d] = min(lo[d], uv[used[c], d])
            hi[d] = max(hi[d], uv[used[c], d])
    for d in range(2):
        scale[d] = max(hi[d] - lo[d], 1e-300)
    q = np.empty((n_q, 2))
    finite = True
    for c in range(n_q):
        for d in range(2):
            q[c, d] = (uv[used[c], d] - lo[d]) / scale[d]
        if shear != 0.0:
            q[c, 0] += shear * q[c, 1]
        finite &= np.isfinite(q[c, 0]) and np.isfinite(q[c, 1])
    lseg = np.empty((m, 2), dtype=np.int64)
    for r in range(m):
        lseg[r, 0], lseg[r, 1] = local[seg[r, 0]], local[seg[r, 1]]
    if not finite or not _is_clean_kernel(q, lseg, snap, bound):
        return (2, uv, grid_node, grid_tris, quads, crossed, p1, y0, h, n_slab, start, edges, q, no_seg, used,
                lo, scale)
    # `_unique_segments`: sorted by (lower end, higher end), repeated ones once
    lo_s = np.empty(m)
    hi_s = np.empty(m)
    for r in range(m):
        lo_s[r] = min(lseg[r, 0], lseg[r, 1])
        hi_s[r] = max(lseg[r, 0], lseg[r, 1])
    o = _argsort2(lo_s, hi_s)
    n_k = 1
    for r in range(m):
        n_k = max(n_k, max(lseg[r, 0], lseg[r, 1]) + 1)
    keys = np.empty(m, dtype=np.int64)
    u = 0
    for r in range(m):
        k = min(lseg[o[r], 0], lseg[o[r], 1]) * n_k + max(lseg[o[r], 0], lseg[o[r], 1])
        if u == 0 or k != keys[u - 1]:
            keys[u] = k
            u += 1
    out = np.empty((u, 2), dtype=np.int32)      # Triangle's C int: its wrapper takes it as it is
    for r in range(u):
        out[r, 0] = keys[r] // n_k
        out[r, 1] = keys[r] % n_k
    return (1, uv, grid_node, grid_tris, quads, crossed, p1, y0, h, n_slab, start, edges, q, out, used, lo,
            scale)


@njit(cache=True, nogil=True)
def _domain_finish_kernel(uv, grid_node, grid_tris, quads, out_v, out_t, used, lo, scale, shear, us, vs, crossed,
                          a, b, y0, h, n_slab, start, edges):
    """`_triangulate_domain_numpy` after Triangle (whose input `_domain_prepare_kernel` made): Triangle's
    new points back in (u, v), its triangles in crossed cells and inside the trim kept, grid triangles
    that lost a corner dropped with their quads, every triangle counter-clockwise in (u, v).

    Returns (uv, triangles, grid_node, quads, number of crossed cells)."""
    n_q = used.shape[0]
    n_uv = uv.shape[0]
    n_out = out_v.shape[0]
    n_new = max(n_out - n_q, 0)
    glob = np.empty(n_out, dtype=np.int64)
    for r in range(min(n_out, n_q)):
        glob[r] = used[r]
    if n_new:
        uv2 = np.empty((n_uv + n_new, 2))
        gn2 = np.full(n_uv + n_new, -1, dtype=np.int64)
        for k in range(n_uv):
            uv2[k, 0], uv2[k, 1] = uv[k, 0], uv[k, 1]
            gn2[k] = grid_node[k]
        for k in range(n_new):
            x, y = out_v[n_q + k, 0], out_v[n_q + k, 1]
            if shear != 0.0:
                x -= shear * y
            uv2[n_uv + k, 0] = x * scale[0] + lo[0]
            uv2[n_uv + k, 1] = y * scale[1] + lo[1]
            glob[n_q + k] = n_uv + k
        uv, grid_node = uv2, gn2
    tri = np.empty((out_t.shape[0], 3), dtype=np.int64)
    for k in range(out_t.shape[0]):
        for c in range(3):
            tri[k, c] = glob[out_t[k, c]]
    ok = np.zeros(tri.shape[0], dtype=np.bool_)
    _cdt_keep_kernel(uv, tri, us, vs, crossed, a, b, y0, h, n_slab, start, edges, ok)
    n_g = grid_tris.shape[0]
    new_row = np.empty(n_g, dtype=np.int64)
    n_keep = 0
    for k in range(n_g):
        p, q, r = grid_tris[k, 0], grid_tris[k, 1], grid_tris[k, 2]
        if p == q or q == r or p == r:
            new_row[k] = -1
        else:
            new_row[k] = n_keep
            n_keep += 1
    if n_keep < n_g:        # a cell narrower than SNAP lost a corner: its triangles go, and the quad
        nq = 0
        for k in range(quads.shape[0]):
            if new_row[quads[k, 0]] >= 0 and new_row[quads[k, 1]] >= 0:
                nq += 1
        qd = np.empty((nq, 2), dtype=np.int64)
        nq = 0
        for k in range(quads.shape[0]):
            if new_row[quads[k, 0]] >= 0 and new_row[quads[k, 1]] >= 0:
                qd[nq, 0], qd[nq, 1] = new_row[quads[k, 0]], new_row[quads[k, 1]]
                nq += 1
        quads = qd
    n_cdt = 0
    for k in range(ok.shape[0]):
        if ok[k]:
            n_cdt += 1
    tris = np.empty((n_keep + n_cdt, 3), dtype=np.int64)
    m = 0
    for k in range(n_g):
        if new_row[k] >= 0:
            tris[m] = grid_tris[k]
            m += 1
    for k in range(tri.shape[0]):
        if ok[k]:
            tris[m] = tri[k]
            m += 1
    for k in range(m):          # counter-clockwise in (u, v)
        p, q, r = tris[k, 0], tris[k, 1], tris[k, 2]
        area = ((uv[q, 0] - uv[p, 0]) * (uv[r, 1] - uv[p, 1])
                - (uv[r, 0] - uv[p, 0]) * (uv[q, 1] - uv[p, 1]))
        if area < 0:
            tris[k, 0], tris[k, 2] = r, p
    n_crossed = 0
    for i in range(crossed.shape[0]):
        for j in range(crossed.shape[1]):
            if crossed[i, j]:
                n_crossed += 1
    return uv, tris, grid_node, quads, n_crossed


@dataclass(eq=False)
class DomainTriangulation:
    """A triangulation of the trimmed region in (u, v).

    Attributes
    ----------
    uv : (n, 2) float64
        Vertices: first the trim-polygon points (in the order given), then grid
        nodes and points Triangle inserted.
    triangles : (m, 3) int64
        Counter-clockwise in (u, v).
    n_trim : int
        Number of trim-polygon points at the start of `uv`.
    grid_node : (n,) int64
        Flat grid index i * len(vs) + j of grid nodes, -1 for other vertices.
    quads : (q, 2) int64
        Pairs of triangles that form an untouched grid cell (the quads of ``--quads``).
    n_crossed_cells, n_cells : int
    """

    uv: np.ndarray
    triangles: np.ndarray
    n_trim: int
    grid_node: np.ndarray
    quads: np.ndarray
    n_crossed_cells: int
    n_cells: int


def triangulate_domain(us: np.ndarray, vs: np.ndarray, polygons: list, *, split=None,
                       extra=None, metric=None, tie_main: bool | None = None,
                       cell_main: np.ndarray | None = None, packed: tuple | None = None) -> DomainTriangulation:
    """Triangulate the region bounded by `polygons` on the grid us x vs (paper Sec. 4.3, 5.1).

    Parameters
    ----------
    us, vs : increasing float64
        Iso-values (domain values); the polygons lie in [us[0], us[-1]] x [vs[0], vs[-1]].
    polygons : list of (k, 2) float64
        Closed trim polygons (the first point not repeated), iso-values already
        inserted (a segment never crosses a grid line, it may run along one).
        Even-odd rule: outer loop and holes.
    split : callable or None
        split(i, j) -> bool array: True to cut untouched cell (i, j) along the
        diagonal from (i, j) to (i+1, j+1), False along the other one; None: the former.
    extra : (k, 2) float64 or None
        Interior points added to the constrained Delaunay triangulation (e.g. where a
        triangle left the tolerance); a cell holding one is triangulated like a crossed
        cell (its sides stay edges); points on a grid line are ignored. They follow the
        grid nodes in `uv` (``grid_node`` -1).
    tie_main : bool or None
        How the Delaunay triangulation of the crossed cells breaks ties (four
        cocircular points, as every rectangular cell's corners are): True toward the
        diagonal (i,j)-(i+1,j+1), False toward the other, None: Triangle's choice.
        A consistent direction keeps reflection lines from wandering where the
        trims run along grid lines (a strip of crossed cells).
    cell_main : ((len(us) - 1) * (len(vs) - 1),) bool or None
        Per cell (flat index i * (len(vs) - 1) + j) what `split` would answer for it; takes the place of
        `split` (one compiled pass over the grid, no call back).
    packed : (pts (n, 2) float64, lens (k,) int64) or None
        The polygons concatenated and their lengths, when the caller has them (`polygons` being
        views of pts, each of 3 points or more: no copies then).
    metric : (2,) float64 or None
        3D length per unit of u and of v (e.g. mean |S_u|, |S_v|): the crossed cells'
        Delaunay triangulation is computed in (u * metric[0], v * metric[1]), so that
        it maximises the smallest angles nearly as in 3D; None: each axis scaled to the
        box of the vertices.

    Returns
    -------
    DomainTriangulation

    Raises
    ------
    TrimLoopError
        Polygons with fewer than 3 points or outside the grid.
    """

    us = _as_float(us)
    vs = _as_float(vs)
    if packed is None:
        polys = [np.asarray(p, dtype=np.float64) for p in polygons]
        if any(len(p) < 3 for p in polys) or not polys:
            raise TrimLoopError("a trim polygon has fewer than 3 points")
    else:
        polys = polygons
    nu, nv = len(us), len(vs)
    if cell_main is not None and len(cell_main) != max(nu - 1, 0) * max(nv - 1, 0):
        raise ValueError(f"cell_main has {len(cell_main)} values for {max(nu - 1, 0) * max(nv - 1, 0)} cells")
    if metric is None and nu >= 2 and nv >= 2:
        # the compiled path checks the rest of its conditions (strictly increasing grid values, finite
        # points) and answers None where they fail
        pts = packed[0] if packed is not None else np.concatenate(polys) if len(polys) > 1 else polys[0]
        e = _EMPTY2 if extra is None or not len(extra) else np.unique(
            np.asarray(extra, dtype=np.float64).reshape(-1, 2), axis=0)
        if cell_main is None and split is not None:
            cell_main = _split_all(us, vs, polys, pts, e, split)
        out = _triangulate_compiled(us, vs, pts, polys if packed is None else packed[1], e, cell_main, tie_main)
        if out is not None:
            return out
    if cell_main is not None and split is None:
        n_v = nv - 1
        cm = np.asarray(cell_main, dtype=bool)

        def split(ki, kj):
            return cm[np.asarray(ki) * n_v + np.asarray(kj)]
    return _triangulate_domain_numpy(us, vs, polys, split=split, extra=extra, metric=metric, tie_main=tie_main)


_EMPTY2 = np.zeros((0, 2))


def _as_float(a) -> np.ndarray:
    """np.asarray(a, dtype=np.float64) without its copy of an array the compiled kernels returned (whose
    dtype is another instance, equal to float64)."""
    return a if isinstance(a, np.ndarray) and a.dtype == np.float64 else np.asarray(a, dtype=np.float64)


def _split_all(us, vs, polys, pts, e, split) -> np.ndarray:
    """`split` asked for the cells `_domain_prepare_kernel` keeps, as a flat per-cell array (True elsewhere)."""
    if not (np.all(us[1:] > us[:-1]) and np.all(vs[1:] > vs[:-1]) and np.isfinite(pts).all()
            and np.isfinite(e).all()):
        return np.ones((len(us) - 1) * (len(vs) - 1), dtype=np.bool_)     # not asked: the numpy path calls split
    lens = np.array([len(p) for p in polys], dtype=np.int64)
    keep = _domain_keep_kernel(np.ascontiguousarray(pts), lens, us, vs, np.ascontiguousarray(e))
    ki, kj = np.nonzero(keep)
    out = np.ones(keep.size, dtype=np.bool_)
    if len(ki):
        out[ki * keep.shape[1] + kj] = np.asarray(split(ki, kj), dtype=bool)
    return out


def _triangulate_compiled(us, vs, pts, polys, e, cell_main, tie_main):
    """`_triangulate_domain_numpy` in two compiled passes around Triangle (strictly increasing us, vs,
    finite points, no metric); None when the graph for Triangle needs `clean_pslg`'s rounds (the caller
    takes the numpy path then)."""
    lens = polys if isinstance(polys, np.ndarray) else np.array([len(p) for p in polys], dtype=np.int64)
    shear = 0.0 if tie_main is None else (-1e-3 if tie_main else 1e-3)
    has_main = cell_main is not None
    cm = (cell_main if isinstance(cell_main, np.ndarray) and cell_main.dtype == np.bool_
          and cell_main.flags.c_contiguous else np.ascontiguousarray(cell_main, dtype=np.bool_)) if has_main \
        else _EMPTY_BOOL
    (status, uv, grid_node, grid_tris, quads, crossed, p1, y0, h, n_slab, start, edges, q, lseg, used, lo,
     scale) = _domain_prepare_kernel(np.ascontiguousarray(pts), lens, us, vs, np.ascontiguousarray(e), cm,
                                     np.bool_(has_main), shear, SNAP, _CCW_BOUND)
    if status >= 2:
        return None
    if status == 1:
        # `tr.triangulate({"vertices": q, "segments": lseg}, "pQ")` without its renaming of the dicts' keys:
        # the same triangulation (`TRIANGLE_OPTS`), the arrays in the wrapper's types (float64, C int: no
        # conversion) and back as it gives them (the points float64, the triangles C int)
        # (the wrapper, not Triangle's C function from compiled code: Triangle ends an internal error by a
        # longjmp to the buffer the wrapper sets, so only the wrapper turns one into an exception)
        res, _ = _triang({"pointlist": q, "segmentlist": lseg}, TRIANGLE_OPTS)
        out_v, out_t = res["pointlist"], res["trianglelist"]
    else:
        out_v, out_t = _EMPTY2, _EMPTY_TRI
    uv, tris, grid_node, quads, n_crossed = _domain_finish_kernel(
        uv, grid_node, grid_tris, quads, out_v, out_t, used, lo, scale, shear, us, vs, crossed, pts, p1, y0, h,
        n_slab, start, edges)
    return DomainTriangulation(uv, tris, len(pts), grid_node, quads, int(n_crossed), int(crossed.size))


_EMPTY_BOOL = np.zeros(0, dtype=np.bool_)
_EMPTY_TRI = np.zeros((0, 3), dtype=np.intc)

#: Triangle's switches of the compiled path: tr.triangulate(..., "pQ") passes "Qz{pQ}" (Q quiet, z indices from
#: 0, p the segments; its parser skips the braces); P and B only leave out the output segments and the
#: boundary markers (not read), the points and triangles are the same (tests/tessellate/test_mesh_compiled.py)
TRIANGLE_OPTS = "QzpPB"


def _triangulate_domain_numpy(us, vs, polygons, *, split=None, extra=None, metric=None,
                              tie_main=None) -> DomainTriangulation:
    """`triangulate_domain` in numpy (any grid values, any graph: the reference of the compiled path, and
    its fallback)."""
    us = np.asarray(us, dtype=np.float64)
    vs = np.asarray(vs, dtype=np.float64)
    nu, nv = len(us), len(vs)
    polys = [np.asarray(p, dtype=np.float64) for p in polygons]
    if any(len(p) < 3 for p in polys) or not polys:
        raise TrimLoopError("a trim polygon has fewer than 3 points")
    pts = np.concatenate(polys)
    n_trim = len(pts)
    index = PolygonIndex(polys)
    lens = np.array([len(p) for p in polys], dtype=np.int64)
    seg_a = np.arange(n_trim)
    seg_b = seg_a + 1
    seg_b[np.cumsum(lens) - 1] = np.cumsum(lens) - lens          # each polygon closes on its first point
    # 1. Cohen-Sutherland: which cells each trim segment meets
    crossed = _crossed_cells(pts[seg_a], pts[seg_b], us, vs)
    if extra is not None and len(extra):
        # a cell with an extra point is triangulated like a crossed one (its sides stay edges)
        e = np.asarray(extra, dtype=np.float64).reshape(-1, 2)
        ei = np.searchsorted(us, e[:, 0]) - 1
        ej = np.searchsorted(vs, e[:, 1]) - 1
        ok = (ei >= 0) & (ei < nu - 1) & (ej >= 0) & (ej < nv - 1) & ~_is_in(e[:, 0], us) & ~_is_in(e[:, 1], vs)
        crossed[ei[ok], ej[ok]] = True
    # 2. untouched cells inside the trim: centre inside
    keep_cell = np.zeros_like(crossed)
    _keep_cells_kernel(us, vs, crossed, index.a, index.b, index.y0, index.h, index.n_slab, index.start,
                       index.edges, keep_cell)
    ki, kj = np.nonzero(keep_cell)
    main = np.ones(len(ki), dtype=bool) if split is None or not len(ki) else np.asarray(split(ki, kj), dtype=bool)
    # grid nodes used (corners of crossed or kept cells), a node equal to a trim point merged into the first
    # such point; 3. untouched cells: two triangles along the best diagonal (or a quad)
    vmap = _first_equal(pts)                              # trim point -> the first trim point equal to it
    if np.all(us[1:] > us[:-1]) and np.all(vs[1:] > vs[:-1]):
        node_uv, node_gn, trim_gn, grid_tris = _grid_nodes_kernel(
            np.ascontiguousarray(pts), us, vs, crossed, keep_cell, ki.astype(np.int64), kj.astype(np.int64),
            np.ascontiguousarray(main))
        uv = np.concatenate([pts, node_uv])
        grid_node = np.concatenate([trim_gn, node_gn])
    else:
        uv, grid_node, grid_tris = _grid_nodes_numpy(pts, us, vs, crossed, keep_cell, ki, kj, main)
    nq = len(ki)
    quads = np.arange(nq)[:, None] + np.array([0, nq])
    # 4. crossed cells: one constrained Delaunay triangulation of their sides and the trim segments
    cdt_tris = np.zeros((0, 3), dtype=np.int64)
    if crossed.any():
        segs = [np.stack([vmap[seg_a], vmap[seg_b]], axis=1)]        # trim points: vmap their own
        # cell sides of crossed cells, split at every vertex lying exactly on them
        segs.append(_side_segments(uv, us, vs, crossed))
        seg = np.concatenate(segs)
        seg = seg[seg[:, 0] != seg[:, 1]]
        # Triangle on the vertices these segments use (plus the extra interior points)
        mark = np.zeros(len(uv), dtype=bool)
        mark[seg.ravel()] = True
        used = np.flatnonzero(mark)                 # np.unique(seg)
        if extra is not None and len(extra):
            e = np.unique(np.asarray(extra, dtype=np.float64).reshape(-1, 2), axis=0)
            ei = np.searchsorted(us, e[:, 0]) - 1
            ej = np.searchsorted(vs, e[:, 1]) - 1
            ok = (ei >= 0) & (ei < nu - 1) & (ej >= 0) & (ej < nv - 1)
            ok[ok] &= crossed[ei[ok], ej[ok]]
            ok[ok] &= ~_is_in(e[ok, 0], us) & ~_is_in(e[ok, 1], vs)
            e = e[ok]
            if len(e):
                used = np.r_[used, len(uv) + np.arange(len(e))]
                uv = np.concatenate([uv, e])
                grid_node = np.r_[grid_node, np.full(len(e), -1, dtype=np.int64)]
        local = np.full(len(uv), -1, dtype=np.int64)
        local[used] = np.arange(len(used))
        scale_lo = uv[used].min(axis=0)
        scale = np.maximum(uv[used].max(axis=0) - scale_lo, 1e-300)
        if metric is not None:
            m = np.asarray(metric, dtype=np.float64)
            if np.all(np.isfinite(m)) and np.all(m > 0):
                ext = scale * m
                scale = scale * ext.max() / np.maximum(ext, 1e-300 * ext.max())
        n_q = len(used)
        q = (uv[used] - scale_lo) / scale
        shear = 0.0 if tie_main is None else (-1e-3 if tie_main else 1e-3)
        if shear:       # u += shear * v: every rectangle turns into a parallelogram, its shorter diagonal wins
            q[:, 0] += shear * q[:, 1]          # q is a new array
        # a graph without crossings, near-duplicate points or points on segments: Triangle never
        # computes a crossing point then, so it always finishes (see `clean_pslg`)
        q, lseg, rep = clean_pslg(q, local[seg], eps=SNAP)
        keep = np.flatnonzero(rep == np.arange(len(q)))
        compact = np.full(len(q), -1, dtype=np.int64)
        compact[keep] = np.arange(len(keep))
        res = tr.triangulate({"vertices": q[keep], "segments": compact[lseg]}, "pQ")
        gone = np.flatnonzero(rep[:n_q] != np.arange(n_q))
        if len(gone):       # a merged grid node: the untouched cells at it use the point it merged into
            alias = np.arange(len(uv))
            alias[used[gone]] = used[rep[gone]]
            grid_tris = alias[grid_tris]
        out_v = res["vertices"]
        out_t = res["triangles"].astype(np.int64)
        # Triangle's vertices: the input points exactly as given, the others (crossing points) new, mapped
        # back from Triangle's coordinates
        given = np.flatnonzero(keep < n_q)
        glob = np.empty(len(out_v), dtype=np.int64)
        glob[given] = used[keep[given]]
        is_new = np.ones(len(out_v), dtype=bool)
        is_new[given] = False
        new_rows = np.flatnonzero(is_new)
        n_new = len(new_rows)
        if n_new:
            glob[new_rows] = len(uv) + np.arange(n_new)
            v = out_v[new_rows]
            if shear:
                v[:, 0] -= shear * v[:, 1]
            uv = np.concatenate([uv, v * scale + scale_lo])
            grid_node = np.concatenate([grid_node, np.full(n_new, -1, dtype=np.int64)])
        tri = glob[out_t]
        # the triangles whose centroid lies in a crossed cell and inside the trim
        ok = np.zeros(len(tri), dtype=np.bool_)
        _cdt_keep_kernel(uv, tri, us, vs, crossed, index.a, index.b, index.y0, index.h, index.n_slab,
                         index.start, index.edges, ok)
        cdt_tris = tri[ok]
    flat = (grid_tris[:, 0] == grid_tris[:, 1]) | (grid_tris[:, 1] == grid_tris[:, 2]) | (grid_tris[:, 0] == grid_tris[:, 2])
    if flat.any():          # a cell narrower than SNAP lost a corner: its triangles go, and the quad
        new_row = np.cumsum(~flat) - 1
        quads = quads[~(flat[quads[:, 0]] | flat[quads[:, 1]])]
        quads = new_row[quads]
        grid_tris = grid_tris[~flat]
    tris = np.concatenate([grid_tris, cdt_tris]).astype(np.int64)
    # counter-clockwise in (u, v)
    p = uv[tris]
    area = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1])
    tris = np.where((area < 0)[:, None], tris[:, ::-1], tris)
    return DomainTriangulation(uv, tris, n_trim, grid_node, quads, int(crossed.sum()), int((nu - 1) * (nv - 1)))
