r"""Rigorous bounds on the derivatives of NURBS curves and surfaces from their Bézier control nets.

Every knot span of a NURBS curve or surface is a rational Bézier piece with
positive weights. Write the piece as ``F = P / w`` (P the weighted points, a
polynomial, w > 0 the weight polynomial) and translate by a point c (the
centre of the piece's control points; derivatives do not change), so that
``F - c = (P - w c) / w``. By the convex-hull property of the Bernstein basis

* ``|F - c| <= R = max_k |P_k / w_k - c|``  (a convex combination with weights w_k B_k / w),
* ``w >= w_min = min_k w_k``,
* ``|D P~| <= max |control points of D P~|`` for every derivative D of the
  polynomial ``P~ = P - w c`` (and of w): the derivative of a Bézier
  polynomial is a Bézier polynomial whose coefficients are scaled forward
  differences of the control points.

Differentiating ``P~ = w (F - c)`` (the quotient rule, solved for the derivatives of F):

    F_u  = (P~_u - w_u (F - c)) / w
    F_uu = (P~_uu - 2 w_u F_u - w_uu (F - c)) / w
    F_uv = (P~_uv - w_u F_v - w_v F_u - w_uv (F - c)) / w

so each norm is bounded by the same expression with every term replaced by
its bound and w by w_min. For a polynomial piece (w = 1) these are the plain
control-net bounds. The bounds hold over the whole piece; they are the
building blocks of the gap bound between Whitney samples (`trimsurf.certify._gap`)
and of the rigorous normal bound over a face (`trimsurf.certify._face`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from .._numba_load import install as _install_lazy_bitcode
from ..geom import bezier_extract, bezier_extract_surface
from ..model import NurbsCurve, NurbsSurface

_install_lazy_bitcode()     # before this module's kernels load (trimsurf._numba_load)

__all__ = ["CurveBounds", "SurfaceBounds", "curve_bounds", "surface_bounds", "max_over_spans", "max_over_boxes",
           "box_bounds"]


class CurveBounds(NamedTuple):
    """Per Bézier span of a curve: sup of |C'| per component and of |C''| (norm)."""

    breaks: np.ndarray      # (m + 1,)
    d1: np.ndarray          # (m, dim) sup |C_i'| per component
    d1_norm: np.ndarray     # (m,) sup |C'|
    d2_norm: np.ndarray     # (m,) sup |C''|


class SurfaceBounds(NamedTuple):
    """Per Bézier piece (i, j) of a surface: sups of |F_u|, |F_v|, |F_uu|, |F_uv|, |F_vv|, stacked (m, n, 5)."""

    u_breaks: np.ndarray
    v_breaks: np.ndarray
    values: np.ndarray


def _diff(x: np.ndarray, axis: int, degree: int, h: float) -> np.ndarray:
    """Control points of the derivative of a Bézier polynomial along `axis` (empty for degree 0)."""
    if degree < 1:
        shape = list(x.shape)
        shape[axis] = 0
        return np.zeros(shape)
    return degree * np.diff(x, axis=axis) / h


def _maxnorm(x: np.ndarray) -> float:
    if x.size == 0:
        return 0.0
    return float(np.sqrt((x * x).sum(axis=-1)).max()) if x.ndim > 1 else float(np.abs(x).max())


def _maxabs(x: np.ndarray) -> float:
    return float(np.abs(x).max()) if x.size else 0.0


def _split_knots(knots: np.ndarray, degree: int, parts: int) -> np.ndarray:
    """Knots splitting every non-empty span of the domain into `parts` equal parts."""
    br = np.unique(np.asarray(knots, float)[degree:len(knots) - degree])
    if parts <= 1 or len(br) < 2:
        return np.zeros(0)
    f = np.arange(1, parts) / parts
    return (br[:-1, None] + (br[1:] - br[:-1])[:, None] * f[None, :]).ravel()


def curve_bounds(curve: NurbsCurve, *, parts: int = 8, max_spans: int = 4096) -> CurveBounds:
    """Rigorous per-span bounds of |C'| (per component and norm) and |C''| (see the module docstring).

    Every span is first split into `parts` (knot refinement, the curve unchanged): the quotient bounds of
    rational spans tighten as the spans shrink (at most `max_spans` spans in all)."""
    kn, cp, w = curve.knots, curve.control_points, curve.weights
    n_spans = max(len(np.unique(kn[curve.degree:len(kn) - curve.degree])) - 1, 1)
    parts = int(max(1, min(parts, max_spans // n_spans)))
    extra = _split_knots(kn, curve.degree, parts)
    if len(extra):
        from ..geom import refine_knots

        r = refine_knots(curve.degree, kn, cp, w, extra)
        kn, cp, w = r.knots, r.control_points, r.weights
    seg = bezier_extract(curve.degree, kn, cp, w)
    br = np.asarray(seg.breaks, float)
    cp = np.asarray(seg.control_points, float)            # (m, p+1, dim)
    m, n1, dim = cp.shape
    p = n1 - 1
    w = np.ones((m, n1)) if seg.weights is None else np.asarray(seg.weights, float)
    d1 = np.zeros((m, dim))
    d1n = np.zeros(m)
    d2n = np.zeros(m)
    for i in range(m):
        h = br[i + 1] - br[i]
        c = 0.5 * (cp[i].min(axis=0) + cp[i].max(axis=0))
        rel = cp[i] - c
        big_r = np.sqrt((rel * rel).sum(axis=1)).max()
        rc = np.abs(rel).max(axis=0)
        pw = rel * w[i][:, None]                            # P~ = P - w c, weighted
        wmin = w[i].min()
        p1, w1 = _diff(pw, 0, p, h), _diff(w[i], 0, p, h)
        p2, w2 = _diff(p1, 0, p - 1, h), _diff(w1, 0, p - 1, h)
        aw1, aw2 = _maxabs(w1), _maxabs(w2)
        comp = (np.abs(p1).max(axis=0) if p1.size else np.zeros(dim)) + aw1 * rc
        d1[i] = comp / wmin
        d1n[i] = (_maxnorm(p1) + aw1 * big_r) / wmin
        d2n[i] = (_maxnorm(p2) + 2 * aw1 * d1n[i] + aw2 * big_r) / wmin
    return CurveBounds(br, d1, d1n, d2n)


def surface_bounds(surface: NurbsSurface, *, parts: int = 4, max_pieces: int = 16384) -> SurfaceBounds:
    """Rigorous per-piece bounds of |F_u|, |F_v|, |F_uu|, |F_uv|, |F_vv| (see the module docstring).

    Every knot span is first split into `parts` in each direction (knot refinement, the surface unchanged;
    fewer where that would make more than `max_pieces` pieces): the bounds tighten as the pieces shrink."""
    from ..geom import refine_knots

    ku, kv, cp, w = surface.knots_u, surface.knots_v, surface.control_points, surface.weights
    pu_, pv_ = surface.degree_u, surface.degree_v
    m0 = max(len(np.unique(ku[pu_:len(ku) - pu_])) - 1, 1)
    n0 = max(len(np.unique(kv[pv_:len(kv) - pv_])) - 1, 1)
    parts = int(max(1, min(parts, int(np.sqrt(max_pieces / (m0 * n0))))))
    eu, ev = _split_knots(ku, pu_, parts), _split_knots(kv, pv_, parts)
    if len(eu):
        r = refine_knots(pu_, ku, cp, w, eu, axis=0)
        ku, cp, w = r.knots, r.control_points, r.weights
    if len(ev):
        r = refine_knots(pv_, kv, cp, w, ev, axis=1)
        kv, cp, w = r.knots, r.control_points, r.weights
    bez = bezier_extract_surface(pu_, pv_, ku, kv, cp, w)
    ub, vb = np.asarray(bez.u_breaks, float), np.asarray(bez.v_breaks, float)
    return SurfaceBounds(ub, vb, _net_bounds(ub, vb, np.asarray(bez.control_points, float), bez.weights))


def _net_bounds(ub: np.ndarray, vb: np.ndarray, cp: np.ndarray, weights) -> np.ndarray:
    """The bounds of `surface_bounds` from the Bézier nets (m, n, p+1, q+1, 3) on the breaks ub, vb: (m, n, 5)."""
    m, n, p1_, q1_, _ = cp.shape
    p, q = p1_ - 1, q1_ - 1
    w = np.ones(cp.shape[:-1]) if weights is None else np.asarray(weights, float)
    hu = np.diff(ub)[:, None, None, None]
    hv = np.diff(vb)[None, :, None, None]
    lo, hi = cp.min(axis=(2, 3)), cp.max(axis=(2, 3))
    c = 0.5 * (lo + hi)                                  # (m, n, 3)
    rel = cp - c[:, :, None, None, :]
    big_r = np.sqrt((rel * rel).sum(-1)).max(axis=(2, 3))
    pw = rel * w[..., None]
    wmin = w.min(axis=(2, 3))

    def dif(x, axis, deg, h):
        if deg < 1:
            shape = list(x.shape)
            shape[axis] = 0
            return np.zeros(shape)
        return deg * np.diff(x, axis=axis) / (h[..., None] if x.ndim == 5 else h)

    def mx(x, vec):
        if x.size == 0:
            return np.zeros((m, n))
        v = np.sqrt((x * x).sum(-1)) if vec else np.abs(x)
        return v.max(axis=(2, 3))

    pu, wu = dif(pw, 2, p, hu), dif(w, 2, p, hu)
    pv, wv = dif(pw, 3, q, hv), dif(w, 3, q, hv)
    puu, wuu = dif(pu, 2, p - 1, hu), dif(wu, 2, p - 1, hu)
    pvv, wvv = dif(pv, 3, q - 1, hv), dif(wv, 3, q - 1, hv)
    puv, wuv = dif(pu, 3, q, hv), dif(wu, 3, q, hv)
    awu, awv, awuu, awvv, awuv = mx(wu, False), mx(wv, False), mx(wuu, False), mx(wvv, False), mx(wuv, False)
    fu = (mx(pu, True) + awu * big_r) / wmin
    fv = (mx(pv, True) + awv * big_r) / wmin
    fuu = (mx(puu, True) + 2 * awu * fu + awuu * big_r) / wmin
    fvv = (mx(pvv, True) + 2 * awv * fv + awvv * big_r) / wmin
    fuv = (mx(puv, True) + awu * fv + awv * fu + awuv * big_r) / wmin
    return np.stack([fu, fv, fuu, fuv, fvv], axis=-1)


def _cuts(x0: float, x1: float, knots: np.ndarray, degree: int, d0: float, d1: float,
          min_width: float) -> tuple[float, float, list]:
    """A box side [x0, x1] widened to at least `min_width` inside [d0, d1] and moved outward onto existing
    knots closer than `min_width` (no sliver pieces), with the knots to insert to make both full breaks."""
    a, b = max(float(x0), d0), min(float(x1), d1)
    if b - a < min_width:
        mid = 0.5 * (a + b)
        a, b = max(mid - 0.5 * min_width, d0), min(mid + 0.5 * min_width, d1)
    near_a = knots[np.abs(knots - a) < min_width]
    if len(near_a):
        a = min(a, float(near_a.min())) if near_a.min() <= a else max(a - min_width, d0)
    near_b = knots[np.abs(knots - b) < min_width]
    if len(near_b):
        b = max(b, float(near_b.max())) if near_b.max() >= b else min(b + min_width, d1)
    ins = []
    for x in (a, b):
        if d0 < x < d1:
            ins += [x] * max(degree - int(np.sum(knots == x)), 0)
    return a, b, ins


def box_bounds(surface: NurbsSurface, lo: np.ndarray, hi: np.ndarray, *, min_width: float = 1e-6) -> np.ndarray:
    """Bounds of |F_u|, |F_v|, |F_uu|, |F_uv|, |F_vv| over each (u, v) box [lo, hi] itself, shape (n, 5).

    The box's sides are made full knots (knot insertion: the surface unchanged), so the control nets of
    the pieces inside the box are those of the sub-patch over the box, and the bounds of the module
    docstring are taken over them. Much tighter than `max_over_boxes` (the pieces of a fixed subdivision
    that meet the box) on thin boxes: along a pole line (F(u, v0) one point) they go to 0 with the box's
    width. A box narrower than `min_width` of the domain (e.g. a segment along an iso-line) is widened to
    that, inside the domain; sides closer than that to a knot move outward onto it (no sliver pieces whose
    nets lose their accuracy in rounding). Costs a knot refinement per box: for the few loose intervals.
    """
    from ..geom import refine_knots

    (u0, u1), (v0, v1) = surface.domain
    out = np.zeros((len(lo), 5))
    for k in range(len(lo)):
        ku, kv, cp, w = surface.knots_u, surface.knots_v, surface.control_points, surface.weights
        p, q = surface.degree_u, surface.degree_v
        a_u, b_u, ins_u = _cuts(lo[k, 0], hi[k, 0], np.asarray(ku, float), p, u0, u1, min_width * (u1 - u0))
        a_v, b_v, ins_v = _cuts(lo[k, 1], hi[k, 1], np.asarray(kv, float), q, v0, v1, min_width * (v1 - v0))
        if ins_u:
            r = refine_knots(p, ku, cp, w, ins_u, axis=0)
            ku, cp, w = r.knots, r.control_points, r.weights
        if ins_v:
            r = refine_knots(q, kv, cp, w, ins_v, axis=1)
            kv, cp, w = r.knots, r.control_points, r.weights
        bez = bezier_extract_surface(p, q, ku, kv, cp, w)
        ub, vb = np.asarray(bez.u_breaks, float), np.asarray(bez.v_breaks, float)
        i0, i1 = np.searchsorted(ub, a_u), np.searchsorted(ub, b_u)
        j0, j1 = np.searchsorted(vb, a_v), np.searchsorted(vb, b_v)
        i1, j1 = max(i1, i0 + 1), max(j1, j0 + 1)
        net = np.asarray(bez.control_points, float)[i0:i1, j0:j1]
        wts = None if bez.weights is None else np.asarray(bez.weights, float)[i0:i1, j0:j1]
        out[k] = _net_bounds(ub[i0:i1 + 1], vb[j0:j1 + 1], net, wts).max(axis=(0, 1))
    return out


def max_over_spans(cb: CurveBounds, t0: np.ndarray, t1: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Max of the span bounds over the spans meeting each [t0, t1] (clamped to the curve's breaks).

    Returns d1 (n, dim), d1_norm (n,), d2_norm (n,)."""
    a, b = np.minimum(t0, t1), np.maximum(t0, t1)
    m = len(cb.breaks) - 1
    i0 = np.clip(np.searchsorted(cb.breaks, a, side="right") - 1, 0, m - 1)
    i1 = np.clip(np.searchsorted(cb.breaks, b, side="left") - 1, 0, m - 1)
    i1 = np.maximum(i1, i0)
    stack = np.concatenate([cb.d1, cb.d1_norm[:, None], cb.d2_norm[:, None]], axis=1)
    out = _range_max_1d(np.ascontiguousarray(stack), i0.astype(np.int64), i1.astype(np.int64))
    dim = cb.d1.shape[1]
    return out[:, :dim], out[:, dim], out[:, dim + 1]


def max_over_boxes(sb: SurfaceBounds, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Max of the piece bounds over the pieces meeting each (u, v) box [lo, hi] (clamped), shape (n, 5)."""
    m, n = len(sb.u_breaks) - 1, len(sb.v_breaks) - 1
    iu0 = np.clip(np.searchsorted(sb.u_breaks, lo[:, 0], side="right") - 1, 0, m - 1)
    iu1 = np.maximum(np.clip(np.searchsorted(sb.u_breaks, hi[:, 0], side="left") - 1, 0, m - 1), iu0)
    jv0 = np.clip(np.searchsorted(sb.v_breaks, lo[:, 1], side="right") - 1, 0, n - 1)
    jv1 = np.maximum(np.clip(np.searchsorted(sb.v_breaks, hi[:, 1], side="left") - 1, 0, n - 1), jv0)
    return _range_max_2d(np.ascontiguousarray(sb.values), iu0.astype(np.int64), iu1.astype(np.int64),
                         jv0.astype(np.int64), jv1.astype(np.int64))


@njit(cache=True, nogil=True)
def _range_max_1d(vals, i0, i1):  # pragma: no cover - compiled
    out = np.zeros((i0.shape[0], vals.shape[1]))
    for k in range(i0.shape[0]):
        for i in range(i0[k], i1[k] + 1):
            for c in range(vals.shape[1]):
                if vals[i, c] > out[k, c]:
                    out[k, c] = vals[i, c]
    return out


@njit(cache=True, nogil=True)
def _range_max_2d(vals, i0, i1, j0, j1):  # pragma: no cover - compiled
    out = np.zeros((i0.shape[0], vals.shape[2]))
    for k in range(i0.shape[0]):
        for i in range(i0[k], i1[k] + 1):
            for j in range(j0[k], j1[k] + 1):
                for c in range(vals.shape[2]):
                    if vals[i, j, c] > out[k, c]:
                        out[k, c] = vals[i, j, c]
    return out
