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
from numba import njit

from ..errors import TrimLoopError
from ..geom.predicates import PolygonIndex, _point_in_index
from .pslg import clean_pslg

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
                       extra=None, metric=None, tie_main: bool | None = None) -> DomainTriangulation:
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
