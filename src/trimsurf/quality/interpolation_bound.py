"""A-priori bound on the distance between a flat triangle and the surface patch over its (u, v) triangle.

For a triangle with corners P_i (mesh vertices) and corner parameters x_i = (u_i, v_i) (their feet on
the surface), let x(w) = sum w_i x_i and p(w) = sum w_i P_i (w barycentric). Then for every w

    |p(w) - S(x(w))| <= max_i |P_i - S(x_i)| + E,      E = max_w |sum_i w_i S(x_i) - S(x(w))|,

and by Taylor's theorem with integral remainder from x(w) to each corner (the first-order terms
cancel: sum w_i (x_i - x) = 0), E <= max_w sum_i w_i |R_i|, |R_i| <= (1/2) max over the segment of
|S''[x_i - x, x_i - x]|. With |S_uu| <= M_uu, |S_uv| <= M_uv, |S_vv| <= M_vv over the triangle's (u, v)
box and 2 |du dv| <= du^2 + dv^2,

    |S''[d, d]| <= a du^2 + b dv^2,       a = M_uu + M_uv,  b = M_vv + M_uv,

and ``max_w sum_i w_i (a du_i^2 + b dv_i^2)`` is the squared radius of the smallest disc holding the
triangle in the coordinates (sqrt(a) u, sqrt(b) v) (the same identity as `deviation._enclosing_radius`),
so ``E <= R^2 / 2``. Both quantities the measurement samples are points of this kind: a mesh point p(w)
lies at most ``|p(w) - S(x(w))|`` from the surface, and a surface point S(x(w)) of the triangle's
footprint at most as far from the face's mesh (p(w) is a point of it). The bound is proven, not sampled,
given

- M: bounds on the second derivatives from the control net, per knot-span cell (`SpanBounds`): for a
  polynomial B-spline the largest second difference of the control points acting on the cell (convex
  hull property of the derivative's B-spline form); for a rational one from S = A / w, A = sum N w P,
  through ``S_u = (A^c_u - w_u (S - c)) / w`` and ``S_uu = (A^c_uu - 2 w_u S_u - w_uu (S - c)) / w``
  (``S_uv`` likewise), with A^c = A - c w for the cell's control-point centroid c, |S - c| at most the
  largest |P_ij - c| of the cell, w at least the smallest weight of the cell;
- S C^1 along every segment inside the box: a box that holds an interior knot of multiplicity >= the
  degree strictly inside (a parametric crease or a break of the first derivative) gets no bound (inf).

Floating-point rounding of these sums is covered by a relative margin (`MARGIN`).
"""

from __future__ import annotations

import numpy as np

from ._bound_kernels import span_bounds_kernel

__all__ = ["SpanBounds", "span_bounds", "triangle_bounds", "domain_bound", "MARGIN"]

#: relative margin added to every bound for the rounding of its own arithmetic (sums of a few dozen
#: products of doubles, each off by at most ~1e-15 relative)
MARGIN = 1e-9


def _diff(x: np.ndarray, knots: np.ndarray, p: int, axis: int) -> np.ndarray:
    """Control points of the derivative of a B-spline along `axis` (degree p, `knots`): ``p (X_{i+1} -
    X_i) / (k_{i+p+1} - k_{i+1})`` (0 where the knot difference is 0: that basis function is 0)."""
    n = x.shape[axis]
    if p < 1 or n < 2:
        shape = list(x.shape)
        shape[axis] = max(n - 1, 0)
        return np.zeros(shape)
    den = knots[p + 1:p + n] - knots[1:n]
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(den > 0, p / np.where(den > 0, den, 1.0), 0.0)
    shape = [1] * x.ndim
    shape[axis] = n - 1
    return np.diff(x, axis=axis) * f.reshape(shape)


class SpanBounds:
    """Per knot-span cell of a NURBS surface: bounds on |S_uu|, |S_uv|, |S_vv|.

    Attributes
    ----------
    bu, bv : (nu + 1,), (nv + 1,) float64
        The distinct knot values of the domain (cell i spans [bu[i], bu[i+1]]).
    crease_u, crease_v : (nu + 1,), (nv + 1,) bool
        Interior breakpoints of multiplicity >= the degree (S may not be C^1 across them).
    m : (3, nu, nv) float64
        M_uu, M_uv, M_vv per cell.
    """

    def __init__(self, bu, bv, crease_u, crease_v, m):
        self.bu, self.bv, self.crease_u, self.crease_v, self.m = bu, bv, crease_u, crease_v, m


def _breaks(knots: np.ndarray, p: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distinct knots of the domain, the span index s (knots[s] <= u < knots[s+1]) of each cell, and the
    crease flags of the breakpoints."""
    lo, hi = knots[p], knots[n]
    b = np.unique(knots[(knots >= lo) & (knots <= hi)])
    # span index of cell [b_i, b_i+1]: the last s with knots[s] == b_i (s <= n - 1)
    s = np.searchsorted(knots, b[:-1], side="right") - 1
    s = np.minimum(s, n - 1)
    # multiplicities: the knots are non-decreasing (`NurbsSurface` checks), so the run of each value
    mult = np.searchsorted(knots, b, side="right") - np.searchsorted(knots, b, side="left")
    crease = mult >= max(p, 1)
    crease[0] = crease[-1] = False
    return b, s, crease


def _breaks_by_count(knots: np.ndarray, p: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`_breaks` with a count per breakpoint (the reference of its tests)."""
    lo, hi = knots[p], knots[n]
    b = np.unique(knots[(knots >= lo) & (knots <= hi)])
    # span index of cell [b_i, b_i+1]: the last s with knots[s] == b_i (s <= n - 1)
    s = np.searchsorted(knots, b[:-1], side="right") - 1
    s = np.minimum(s, n - 1)
    mult = np.array([int(np.count_nonzero(knots == x)) for x in b])
    crease = mult >= max(p, 1)
    crease[0] = crease[-1] = False
    return b, s, crease


def _cell_max(arr: np.ndarray, su: np.ndarray, sv: np.ndarray, lo_u: int, n_u: int, lo_v: int, n_v: int,
              centre=None, warr=None) -> np.ndarray:
    """max over each cell (su[i], sv[j]) of |arr[s - lo_u + a, t - lo_v + b]| (a < n_u, b < n_v), arr (.., .., d);
    with `centre` (nu, nv, d) and `warr`: of |arr - centre * warr|."""
    if n_u <= 0 or n_v <= 0:
        return np.zeros((len(su), len(sv)))
    iu = (su[:, None] - lo_u + np.arange(n_u)[None, :])         # (cu, n_u)
    iv = (sv[:, None] - lo_v + np.arange(n_v)[None, :])         # (cv, n_v)
    blk = arr[iu[:, None, :, None], iv[None, :, None, :]]      # (cu, cv, n_u, n_v, d)
    if centre is not None:
        wb = warr[iu[:, None, :, None], iv[None, :, None, :]]   # (cu, cv, n_u, n_v, 1)
        blk = blk - centre[:, :, None, None, :] * wb
    return np.sqrt(np.einsum("...d,...d->...", blk, blk)).max(axis=(2, 3))


def span_bounds(surface) -> SpanBounds:
    """`SpanBounds` of a `NurbsSurface` (see the module's notes for what they bound).

    One compiled call (`_bound_kernels.span_bounds_kernel`, the arithmetic of `_span_bounds_numpy` in the
    same order: the same numbers bit for bit); control points of another dimension than 3 take
    `_span_bounds_numpy`."""
    cp = np.ascontiguousarray(surface.control_points, dtype=np.float64)
    if cp.ndim != 3 or cp.shape[2] != 3:
        return _span_bounds_numpy(surface)
    ku = np.ascontiguousarray(surface.knots_u, dtype=np.float64)
    kv = np.ascontiguousarray(surface.knots_v, dtype=np.float64)
    w = surface.weights
    wa = _NO_WEIGHTS if w is None else np.ascontiguousarray(w, dtype=np.float64)
    bu, bv, cu, cv, m = span_bounds_kernel(np.int64(surface.degree_u), np.int64(surface.degree_v), ku, kv, cp,
                                           wa, np.bool_(w is not None))
    return SpanBounds(bu, bv, cu, cv, m)


#: the weights argument of a polynomial surface: read-only like a `NurbsSurface`'s arrays (one specialization)
_NO_WEIGHTS = np.zeros((0, 0))
_NO_WEIGHTS.flags.writeable = False


def _span_bounds_numpy(surface) -> SpanBounds:
    """`span_bounds` in numpy (session 27; the reference of its tests).

    A rational surface's points and weights are differenced together (one (nu, nv, 4) array: the same
    elementwise differences and factors), and each cell's block of them gathered once; the numbers are
    those of `_span_bounds_by_part`, bit for bit."""
    pu, pv = int(surface.degree_u), int(surface.degree_v)
    ku, kv = np.asarray(surface.knots_u, float), np.asarray(surface.knots_v, float)
    cp = np.asarray(surface.control_points, float)
    nu, nv = cp.shape[:2]
    bu, su, cu = _breaks(ku, pu, nu)
    bv, sv, cv = _breaks(kv, pv, nv)
    w = surface.weights
    if w is None:
        xu = _diff(cp, ku, pu, 0)
        xuu = _diff(xu, ku[1:-1], pu - 1, 0)
        xv = _diff(cp, kv, pv, 1)
        xvv = _diff(xv, kv[1:-1], pv - 1, 1)
        xuv = _diff(xu, kv, pv, 1)
        muu = _cell_max(xuu, su, sv, pu, pu - 1, pv, pv + 1)
        mvv = _cell_max(xvv, su, sv, pu, pu + 1, pv, pv - 1)
        muv = _cell_max(xuv, su, sv, pu, pu, pv, pv)
        return SpanBounds(bu, bv, cu, cv, np.stack([muu, muv, mvv]))
    wt = np.asarray(w, float)[..., None]
    d = cp.shape[2]
    hw = np.concatenate([cp * wt, wt], axis=-1)                 # (nu, nv, d + 1): x w, then w
    hu = _diff(hw, ku, pu, 0)
    huu = _diff(hu, ku[1:-1], pu - 1, 0)
    hv = _diff(hw, kv, pv, 1)
    hvv = _diff(hv, kv[1:-1], pv - 1, 1)
    huv = _diff(hu, kv, pv, 1)
    iu = su[:, None] - pu + np.arange(pu + 1)[None, :]
    iv = sv[:, None] - pv + np.arange(pv + 1)[None, :]
    blk = cp[iu[:, None, :, None], iv[None, :, None, :]]        # (cu, cv, pu+1, pv+1, 3)
    centre = blk.mean(axis=(2, 3))                              # (cu, cv, 3)
    rmax = np.linalg.norm(blk - centre[:, :, None, None, :], axis=-1).max(axis=(2, 3))
    wmin = np.asarray(w, float)[iu[:, None, :, None], iv[None, :, None, :]].min(axis=(2, 3))
    a_u, w_u = _cell_max2(hu, d, su, sv, pu, pu, pv, pv + 1, centre)
    a_v, w_v = _cell_max2(hv, d, su, sv, pu, pu + 1, pv, pv, centre)
    a_uu, w_uu = _cell_max2(huu, d, su, sv, pu, pu - 1, pv, pv + 1, centre)
    a_vv, w_vv = _cell_max2(hvv, d, su, sv, pu, pu + 1, pv, pv - 1, centre)
    a_uv, w_uv = _cell_max2(huv, d, su, sv, pu, pu, pv, pv, centre)
    s_u = (a_u + w_u * rmax) / wmin
    s_v = (a_v + w_v * rmax) / wmin
    muu = (a_uu + 2.0 * w_u * s_u + w_uu * rmax) / wmin
    mvv = (a_vv + 2.0 * w_v * s_v + w_vv * rmax) / wmin
    muv = (a_uv + w_u * s_v + w_v * s_u + w_uv * rmax) / wmin
    return SpanBounds(bu, bv, cu, cv, np.stack([muu, muv, mvv]))


def _cell_max2(harr: np.ndarray, d: int, su: np.ndarray, sv: np.ndarray, lo_u: int, n_u: int, lo_v: int,
               n_v: int, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`_cell_max(x, .., centre, w)` and `_cell_max(w, ..)` of harr = [x, w] (.., .., d + 1), each cell's
    block gathered once (the same contiguous arrays reduced, so the same numbers)."""
    if n_u <= 0 or n_v <= 0:
        z = np.zeros((len(su), len(sv)))
        return z, z.copy()
    iu = (su[:, None] - lo_u + np.arange(n_u)[None, :])         # (cu, n_u)
    iv = (sv[:, None] - lo_v + np.arange(n_v)[None, :])         # (cv, n_v)
    hb = harr[iu[:, None, :, None], iv[None, :, None, :]]      # (cu, cv, n_u, n_v, d + 1)
    wb = np.ascontiguousarray(hb[..., d:])
    blk = hb[..., :d] - centre[:, :, None, None, :] * wb
    a = np.sqrt(np.einsum("...d,...d->...", blk, blk)).max(axis=(2, 3))
    w = np.sqrt(np.einsum("...d,...d->...", wb, wb)).max(axis=(2, 3))
    return a, w


def _span_bounds_by_part(surface) -> SpanBounds:
    """`span_bounds` as it was: one `_diff` / `_cell_max` per control-point array (the reference of its
    tests; the creases by a count per breakpoint)."""
    pu, pv = int(surface.degree_u), int(surface.degree_v)
    ku, kv = np.asarray(surface.knots_u, float), np.asarray(surface.knots_v, float)
    cp = np.asarray(surface.control_points, float)
    nu, nv = cp.shape[:2]
    bu, su, cu = _breaks_by_count(ku, pu, nu)
    bv, sv, cv = _breaks_by_count(kv, pv, nv)
    w = surface.weights
    hom = cp if w is None else cp * np.asarray(w, float)[..., None]
    xu = _diff(hom, ku, pu, 0)
    xuu = _diff(xu, ku[1:-1], pu - 1, 0)
    xv = _diff(hom, kv, pv, 1)
    xvv = _diff(xv, kv[1:-1], pv - 1, 1)
    xuv = _diff(xu, kv, pv, 1)
    # on span (s, t): derivative control points i in [s - p, s - 1] (first), [s - p, s - 2] (second)
    if w is None:
        muu = _cell_max(xuu, su, sv, pu, pu - 1, pv, pv + 1)
        mvv = _cell_max(xvv, su, sv, pu, pu + 1, pv, pv - 1)
        muv = _cell_max(xuv, su, sv, pu, pu, pv, pv)
        return SpanBounds(bu, bv, cu, cv, np.stack([muu, muv, mvv]))
    wt = np.asarray(w, float)[..., None]
    wu = _diff(wt, ku, pu, 0)
    wuu = _diff(wu, ku[1:-1], pu - 1, 0)
    wv = _diff(wt, kv, pv, 1)
    wvv = _diff(wv, kv[1:-1], pv - 1, 1)
    wuv = _diff(wu, kv, pv, 1)
    iu = su[:, None] - pu + np.arange(pu + 1)[None, :]
    iv = sv[:, None] - pv + np.arange(pv + 1)[None, :]
    blk = cp[iu[:, None, :, None], iv[None, :, None, :]]        # (cu, cv, pu+1, pv+1, 3)
    centre = blk.mean(axis=(2, 3))                              # (cu, cv, 3)
    rmax = np.linalg.norm(blk - centre[:, :, None, None, :], axis=-1).max(axis=(2, 3))
    wmin = np.asarray(w, float)[iu[:, None, :, None], iv[None, :, None, :]].min(axis=(2, 3))
    a_u = _cell_max(xu, su, sv, pu, pu, pv, pv + 1, centre, wu)
    a_v = _cell_max(xv, su, sv, pu, pu + 1, pv, pv, centre, wv)
    a_uu = _cell_max(xuu, su, sv, pu, pu - 1, pv, pv + 1, centre, wuu)
    a_vv = _cell_max(xvv, su, sv, pu, pu + 1, pv, pv - 1, centre, wvv)
    a_uv = _cell_max(xuv, su, sv, pu, pu, pv, pv, centre, wuv)
    w_u = _cell_max(wu, su, sv, pu, pu, pv, pv + 1)
    w_v = _cell_max(wv, su, sv, pu, pu + 1, pv, pv)
    w_uu = _cell_max(wuu, su, sv, pu, pu - 1, pv, pv + 1)
    w_vv = _cell_max(wvv, su, sv, pu, pu + 1, pv, pv - 1)
    w_uv = _cell_max(wuv, su, sv, pu, pu, pv, pv)
    s_u = (a_u + w_u * rmax) / wmin
    s_v = (a_v + w_v * rmax) / wmin
    muu = (a_uu + 2.0 * w_u * s_u + w_uu * rmax) / wmin
    mvv = (a_vv + 2.0 * w_v * s_v + w_vv * rmax) / wmin
    muv = (a_uv + w_u * s_v + w_v * s_u + w_uv * rmax) / wmin
    return SpanBounds(bu, bv, cu, cv, np.stack([muu, muv, mvv]))


#: most cells per direction whose bounds are gathered one by one; a triangle over more cells takes the
#: largest bound of the whole surface (still a bound)
MAX_CELLS = 8


def _cells(b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = len(b) - 1
    c0 = np.clip(np.searchsorted(b, lo, side="right") - 1, 0, n - 1)
    c1 = np.clip(np.searchsorted(b, hi, side="left") - 1, c0, n - 1)
    return c0, c1


def triangle_bounds(sb: SpanBounds, uv: np.ndarray, corner_dist: np.ndarray) -> np.ndarray:
    """Per triangle, the bound ``max_i |P_i - S(x_i)| + R^2 / 2`` (module notes) on the distance between
    its points p(w) and S(x(w)), w barycentric.

    Parameters
    ----------
    sb : SpanBounds
    uv : (m, 3, 2) float64
        Corner parameters x_i (inside the domain; NaN: no bound).
    corner_dist : (m, 3) float64
        |P_i - S(x_i)| at the corners.

    Returns
    -------
    (m,) float64
        The bound; inf where none holds (a crease inside the triangle's (u, v) box, NaN input).
    """
    m = len(uv)
    out = np.full(m, np.inf)
    if not m:
        return out
    fin = np.all(np.isfinite(uv.reshape(m, -1)), axis=1) & np.all(np.isfinite(corner_dist), axis=1)
    if not fin.any():
        return out
    x = uv[fin]
    lo, hi = x.min(axis=1), x.max(axis=1)
    cu0, cu1 = _cells(sb.bu, lo[:, 0], hi[:, 0])
    cv0, cv1 = _cells(sb.bv, lo[:, 1], hi[:, 1])
    # a crease strictly inside the box: no bound
    bad = np.zeros(len(x), dtype=bool)
    for b, crease, a0, a1, col in ((sb.bu, sb.crease_u, cu0, cu1, 0), (sb.bv, sb.crease_v, cv0, cv1, 1)):
        if crease.any():
            cb = b[crease]
            i0 = np.searchsorted(cb, lo[:, col], side="right")
            i1 = np.searchsorted(cb, hi[:, col], side="left")
            bad |= i1 > i0
    wu, wv = cu1 - cu0 + 1, cv1 - cv0 + 1
    big = (wu > MAX_CELLS) | (wv > MAX_CELLS)
    mcell = sb.m[:, cu0, cv0].copy()
    small = ~big
    if small.any():
        for a in range(int(wu[small].max())):
            for c in range(int(wv[small].max())):
                if a or c:
                    mcell = np.maximum(mcell, sb.m[:, np.minimum(cu0 + a, cu1), np.minimum(cv0 + c, cv1)])
    if big.any():
        mcell[:, big] = sb.m.reshape(3, -1).max(axis=1)[:, None]
    a = mcell[0] + mcell[1]
    b = mcell[2] + mcell[1]
    q = np.empty((len(x), 3, 3))
    q[:, :, 0] = x[:, :, 0] * np.sqrt(a)[:, None]
    q[:, :, 1] = x[:, :, 1] * np.sqrt(b)[:, None]
    q[:, :, 2] = 0.0
    r = _enclosing_radius2(q)
    e = 0.5 * r
    val = corner_dist[fin].max(axis=1) + e
    val = val * (1.0 + MARGIN)
    val[bad | ~np.isfinite(val)] = np.inf
    out[fin] = val
    return out


def _enclosing_radius2(p: np.ndarray) -> np.ndarray:
    """Squared radius of the smallest disc holding each triangle (m, 3, 3): the circumradius of an acute
    triangle, half the longest side of an obtuse one (``max_w sum_i w_i |p_i - p(w)|^2``); computed from
    the side lengths so that a degenerate (flat) triangle gets half its longest side."""
    a2 = np.einsum("ij,ij->i", p[:, 1] - p[:, 2], p[:, 1] - p[:, 2])
    b2 = np.einsum("ij,ij->i", p[:, 2] - p[:, 0], p[:, 2] - p[:, 0])
    c2 = np.einsum("ij,ij->i", p[:, 0] - p[:, 1], p[:, 0] - p[:, 1])
    s = np.sort(np.column_stack([a2, b2, c2]), axis=1)
    cr = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    area2sq = np.einsum("ij,ij->i", cr, cr)             # (2 area)^2
    with np.errstate(divide="ignore", invalid="ignore"):
        r2 = a2 * b2 * c2 / (4.0 * area2sq)
    obtuse = s[:, 2] >= s[:, 0] + s[:, 1]
    half = 0.25 * s[:, 2]
    return np.where(obtuse | ~np.isfinite(r2), half, np.maximum(r2, half))


def domain_bound(sb: SpanBounds) -> float:
    """A bound on E (module notes) for every triangle whose (u, v) lies in the domain: with the largest
    M of all cells, ``(a du^2 + b dv^2) / 8`` (du, dv the domain's extents: the smallest disc holding a
    triangle of the box has at most half the box's diagonal, in the scaled coordinates, as radius);
    inf where a crease lies inside the domain (then a triangle may straddle it)."""
    if sb.crease_u.any() or sb.crease_v.any():
        return float("inf")
    m = sb.m.reshape(3, -1).max(axis=1)
    a, b = m[0] + m[1], m[2] + m[1]
    du, dv = sb.bu[-1] - sb.bu[0], sb.bv[-1] - sb.bv[0]
    return float((a * du * du + b * dv * dv) / 8.0 * (1.0 + MARGIN))
