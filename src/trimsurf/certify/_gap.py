r"""How far apart the perturbed faces of a shared edge can be between the Whitney samples.

The two faces A, B of a shared edge carry Whitney data at the same edge
parameters s_0 < s_1 < ... (both pass through the same target T_i, the edge
curve b(s_i) or the vertex, at sample i). Face X pairs s with its trim curve
through tau_X(s): closest-point at the samples (`_boundary._eval_use`) and
linear in s between them, so P_X(s) = p_X(tau_X(s)) runs along the exact
p-curve. Between samples the two faces need not meet exactly: the Whitney data
C is the polyline through the samples in (u, v), not the p-curve. This module
bounds, rigorously, ``|G_A(P_A(s)) - G_B(P_B(s))|`` on every sample interval.

Derivation
----------
On an interval [s_i, s_i+1] let lambda be the linear interpolation weight,
Q_i the polyline vertices (P_X(s_i), moved by ``shift`` at merged loop corners),
q(s) the polyline point and sigma = |tau_X(s_i+1) - tau_X(s_i)|. The Whitney
average a_X equals the data on C (Theorem 1), so a_X(q(s)) = lerp(T_j - F(Q_j)),
and a_X is L-Lipschitz componentwise, so |a_X(P) - a_X(q)| <= |L_X| |P - q|
(|L_X| the Euclidean norm of (L_1, L_2, L_3)). Hence

    G_X(P_X(s)) - lerp(T) = [F(P(s)) - lerp F(P(s_j))] + lerp[F(P(s_j)) - F(Q_j)] + r,  |r| <= |L_X| |P(s) - q(s)|

and with the linear-interpolation remainder ``|f - lerp f| <= sigma^2 / 8 sup|f''|``
(Peano kernel, vector-valued f, in the variable tau):

    R_X = sigma^2/8 (M2 + |L_X| sup|p''|) + shift (|grad F| + |L_X|),
    M2  = sup|F_uu| p_u'^2 + 2 sup|F_uv| |p_u'| |p_v'| + sup|F_vv| p_v'^2 + |grad F| sup|p''|
         >= sup |d^2 F(p(tau)) / d tau^2|,

    |G_A(P_A(s)) - G_B(P_B(s))| <= max_j |T_A,j - T_B,j| + R_A + R_B.

The sups are the rigorous control-net bounds of `trimsurf.certify._bounds`:
|p'| per component and |p''| over the p-curve's Bézier spans meeting the
interval, the derivatives of F over the surface's Bézier pieces meeting a box
that contains p([tau_i, tau_i+1]) (the end points widened by sup|p'| sigma / 2).
Samples beyond the surface's domain (by more than 1e-9 of it: F is
extrapolated there) make the interval's bound unbounded. Where an edge is done
refining and an interval is still over the tolerance (or its interval is below
2^-20 of the edge), the surface's derivatives are bounded again over the
interval's own box (`tight_boxes`: the control nets of the sub-patch over the
box, by knot insertion): on U_Joint face 96 the polygon runs 0.56 along the
pole line v = -pi/2, where F_uu = 0 but the pieces meeting it have F_uu ~ 3, and
edges 308/310 went from 0.10 to 2.45e-5 (tolerance 2.54e-5). Samples a face
merges away (closer than its merge tolerance in (u, v)) are not on its polygon:
each face's remainder is taken between the samples it keeps
(`_boundary.use_polygon`). Not proven: that a
p-curve whose samples lie in the domain stays in it between them (p-curves
along the domain's boundary are common; the derivative bounds are looked up
over the box clipped to the domain). Rounding: the bound
adds 1e-13 times the largest coordinate (`interval_bounds`); the bounds
themselves are evaluated in floating point.
"""

from __future__ import annotations

import numpy as np

from ._bounds import box_bounds, curve_bounds, max_over_boxes, max_over_spans, surface_bounds

__all__ = ["interval_bounds", "measure_edge_gaps"]


class BoundsCache:
    """Control-net bounds of the surfaces and p-curves, computed once per object."""

    def __init__(self):
        self._s: dict = {}
        self._c: dict = {}
        self.n_boxes = 0          # boxes bounded over their own sub-patch (`tight_boxes`)

    def surface(self, surface):
        key = id(surface)
        if key not in self._s:
            self._s[key] = (surface, surface_bounds(surface))
        return self._s[key][1]

    def curve(self, curve):
        key = id(curve)
        if key not in self._c:
            self._c[key] = (curve, curve_bounds(curve))
        return self._c[key][1]


def tight_boxes(surface, fb: np.ndarray, lo: np.ndarray, hi: np.ndarray, sel: np.ndarray,
                cache: BoundsCache) -> np.ndarray:
    """fb with the rows `sel` replaced by the bounds over the boxes' own sub-patches where smaller
    (`trimsurf.certify._bounds.box_bounds`; both are rigorous, so is their minimum)."""
    idx = np.flatnonzero(sel)
    if len(idx) == 0:
        return fb
    fb = fb.copy()
    fb[idx] = np.minimum(fb[idx], box_bounds(surface, lo[idx], hi[idx]))
    cache.n_boxes += len(idx)
    return fb


def use_remainder(surface, curve, uv: np.ndarray, tau: np.ndarray, big_l: np.ndarray, shift: np.ndarray,
                  cache: BoundsCache, tighten=None) -> np.ndarray:
    """R_X per interval (see the module docstring); uv, tau at the samples (n,), shift at the samples (n,).

    Intervals whose R_X exceeds `tighten` (a number or one per interval) get the surface's derivatives bounded over their own box
    (`tight_boxes`) instead of over the pieces of the fixed subdivision that meet it."""
    t0, t1 = tau[:-1], tau[1:]
    sigma = np.abs(t1 - t0)
    d1c, d1n, d2n = max_over_spans(cache.curve(curve), t0, t1)
    sh = np.maximum(shift[:-1], shift[1:])
    r = (0.5 * d1n * sigma + sh)[:, None]
    lo = np.minimum(uv[:-1], uv[1:]) - r
    hi = np.maximum(uv[:-1], uv[1:]) + r
    fb = max_over_boxes(cache.surface(surface), lo, hi)
    pu, pv = d1c[:, 0], d1c[:, 1]
    lx = float(np.linalg.norm(big_l))

    def rx(fb):
        fu, fv, fuu, fuv, fvv = fb.T
        grad = np.hypot(fu, fv)
        m2 = fuu * pu * pu + 2.0 * fuv * pu * pv + fvv * pv * pv + grad * d2n
        return sigma * sigma / 8.0 * (m2 + lx * d2n) + sh * (grad + lx)

    out = rx(fb)
    if tighten is not None:
        loose = (out > tighten) & ~_outside(surface, lo, hi)
        if loose.any():
            out = np.minimum(out, rx(tight_boxes(surface, fb, lo, hi, loose, cache)))
    ends_lo, ends_hi = np.minimum(uv[:-1], uv[1:]), np.maximum(uv[:-1], uv[1:])
    return np.where(_outside(surface, ends_lo, ends_hi), np.inf, out)


def polygon_remainder(surface, uv: np.ndarray, cache: BoundsCache, tighten=None) -> np.ndarray:
    """Chord remainder along the Whitney polygon itself (pairing "surface"), per interval.

    On the polygon segment Q_i Q_i+1 (uv length h, unit direction d) a_X is exactly the linear interpolant
    of the data, so G_X - lerp(T) = F(q) - lerp F(Q_j), at most h^2/8 sup |D^2 F[d, d]| with
    |D^2 F[d, d]| <= |F_uu| d_u^2 + 2 |F_uv| |d_u d_v| + |F_vv| d_v^2 over the pieces meeting the segment's box,
    or, where that exceeds `tighten`, over the box's own sub-patch (`tight_boxes`): a segment along a pole
    line (U_Joint face 96, v = -pi/2, where F(u, v) is one point) has F_uu = 0 on it, not the size of the
    neighbouring pieces' F_uu.
    """
    vec = uv[1:] - uv[:-1]
    h = np.linalg.norm(vec, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.where(h[:, None] > 0, np.abs(vec) / np.where(h > 0, h, 1.0)[:, None], 0.0)
    lo, hi = np.minimum(uv[:-1], uv[1:]), np.maximum(uv[:-1], uv[1:])
    fb = max_over_boxes(cache.surface(surface), lo, hi)

    def chord(fb):
        return h * h / 8.0 * (fb[:, 2] * d[:, 0] ** 2 + 2.0 * fb[:, 3] * d[:, 0] * d[:, 1] + fb[:, 4] * d[:, 1] ** 2)

    out = chord(fb)
    outside = _outside(surface, lo, hi)
    if tighten is not None:
        loose = (out > tighten) & ~outside
        if loose.any():
            out = np.minimum(out, chord(tight_boxes(surface, fb, lo, hi, loose, cache)))
    return np.where(outside, np.inf, out)


def _outside(surface, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Boxes reaching beyond the surface's domain by more than 1e-9 of its size: there F is extrapolated
    and the control-net bounds do not hold (the interval's bound is then unbounded)."""
    (u0, u1), (v0, v1) = surface.domain
    dlo, dhi = np.array([u0, v0]), np.array([u1, v1])
    slack = 1e-9 * (dhi - dlo)
    return np.any((lo < dlo - slack) | (hi > dhi + slack), axis=1)


def interval_bounds(remainders: list[np.ndarray], targets: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Bound per interval from the uses' remainders and targets at the samples (see the module docstring).

    Returns (fixed, remainder): the part refinement cannot reduce (the targets' mismatch at the interval
    ends, e.g. at a corner whose faces have different targets, plus a floating-point allowance of
    1e-13 times the largest coordinate) and the sum of the two largest remainders R_X (shrinks as sigma^2).
    """
    rem = np.sort(np.stack(remainders), axis=0)
    two = rem[-1] + (rem[-2] if len(rem) > 1 else 0.0)
    tg = np.stack(targets)
    mis = np.linalg.norm(tg.max(axis=0) - tg.min(axis=0), axis=1) if len(tg) > 1 else np.zeros(tg.shape[1])
    rounding = 1e-13 * float(np.abs(tg).max(initial=0.0) + np.ptp(tg.reshape(-1, 3), axis=0).max(initial=0.0))
    return np.maximum(mis[:-1], mis[1:]) + rounding, two


def measure_edge_gaps(perturbed, edges, shell, *, n: int = 10000, seed: int = 0) -> list[dict]:
    """max |G_A(P_A(s)) - G_B(P_B(s))| at `n` uniformly random s per shared edge, on the faces' boundaries.

    Pairings "curve" and "parameter": P_X(s) = p_X(tau_X(s)) on the exact p-curve, tau_X the face's pairing
    (at the samples; linear in s between them). Pairing "surface": P_X(s) on the face's Whitney polygon
    (through the feet of b(s_i) on F_X, linear in s between them), the boundary of the well-defined face.
    The same correspondence the bound is about. Returns one dict per shared edge: edge (index into the
    certificate's edge list), shell_edge, gap_max, gap_bound, tolerance.
    """
    rng = np.random.default_rng(seed)
    out = []
    for k, e in enumerate(edges):
        uses = [u for u in e.uses if perturbed[u.face] is not None]
        if len(uses) < 2 or e.degenerate or e.tau is None:
            continue
        s = np.sort(rng.uniform(e.lo, e.hi, n))
        pts = []
        for u in uses:
            key = (u.face, u.loop, u.seg)
            if u.pairing == "surface":
                # the face's boundary is the Whitney polygon through the feet of b(s_i): linear in s between
                poly = e.poly[key]
                uv = np.column_stack([np.interp(s, e.t, poly[:, 0]), np.interp(s, e.t, poly[:, 1])])
            else:
                uv = u.pcurve.curve.evaluate(np.interp(s, e.t, e.tau[key]))
            pts.append(perturbed[u.face].evaluate(uv))
        gap = np.zeros(n)
        for i in range(len(pts)):
            for j in range(i + 1, len(pts)):
                gap = np.maximum(gap, np.linalg.norm(pts[i] - pts[j], axis=1))
        out.append({"edge": k, "shell_edge": e.shell_edge, "gap_max": float(gap.max()),
                    "gap_bound": float(e.gap_bound), "tolerance": float(e.gap_tolerance),
                    "n_samples": int(len(e.t))})
    return out
