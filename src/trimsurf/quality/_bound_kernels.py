"""Compiled (numba) kernel of `interpolation_bound.span_bounds`: a NURBS surface's per-cell bounds on its
second derivatives in one call (session 28, issue 17 item 2: the numpy version spent ~0.14 ms of glue per
small surface).

`span_bounds_kernel` does the arithmetic of `interpolation_bound._span_bounds_numpy` in the same order, so
the numbers are the same bit for bit (tests/quality/test_span_bounds_kernel.py): the derivative nets
``(X_{i+1} - X_i) * (p / den)`` (0 factor where ``den <= 0``); a cell's 3-vector lengths squared as numpy's
``einsum("...d,...d->...")`` sums them on this machine, ``(x0^2 + x2^2) + x1^2`` (its two-lane SIMD tail),
and as ``np.linalg.norm`` does, ``(x0^2 + x1^2) + x2^2`` (a sequential reduction); the cell centroid
summed in C order from the first point, then divided by the count (``mean`` over two axes); maxima and
minima propagate NaN as numpy's do. The helpers are compiled functions of their own, not inlined: cold
compile 3.4 s CPU instead of 5.1 s inlined, the same speed; one `_diff` for both axes and one `_cell_max_k`
for both nets, each compiled once (session 29; tests/quality/test_span_bounds_kernel.py checks it).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._numba_load import install as _install_lazy_bitcode

_install_lazy_bitcode()     # before this module's kernels load (trimsurf._numba_load)


@njit(cache=True, nogil=True)
def _breaks_k(knots, p, n):
    """`interpolation_bound._breaks`: distinct knots of [knots[p], knots[n]], span index of each cell, creases."""
    lo, hi = knots[p], knots[n]
    m = len(knots)
    b = np.empty(m)
    s = np.empty(m, np.int64)
    crease = np.zeros(m, np.bool_)
    nb = 0
    i = 0
    cmin = max(p, 1)
    while i < m:
        j = i
        while j + 1 < m and knots[j + 1] == knots[i]:
            j += 1
        v = knots[i]
        if v >= lo and v <= hi:
            b[nb] = v
            s[nb] = min(j, n - 1)
            crease[nb] = (j - i + 1) >= cmin
            nb += 1
        i = j + 1
    if nb > 0:
        crease[0] = False
        crease[nb - 1] = False
    return b[:nb].copy(), s[:max(nb - 1, 0)].copy(), crease[:nb].copy()


@njit(cache=True, nogil=True)
def _diff(x, knots, koff, p, axis):
    """`interpolation_bound._diff` along axis 0 or 1 (a run-time value: one compiled function for both) with
    knots ``knots[koff:]`` (koff 0, or 1 for ``knots[1:-1]``)."""
    n0, n1, d = x.shape
    n = n0 if axis == 0 else n1
    if p < 1 or n < 2:
        return np.zeros((max(n0 - 1, 0), n1, d)) if axis == 0 else np.zeros((n0, max(n1 - 1, 0), d))
    out = np.empty((n0 - 1, n1, d)) if axis == 0 else np.empty((n0, n1 - 1, d))
    for i in range(n - 1):
        den = knots[koff + p + 1 + i] - knots[koff + 1 + i]
        f = p / den if den > 0 else 0.0
        if axis == 0:
            for j in range(n1):
                for k in range(d):
                    out[i, j, k] = (x[i + 1, j, k] - x[i, j, k]) * f
        else:
            for j in range(n0):
                for k in range(d):
                    out[j, i, k] = (x[j, i + 1, k] - x[j, i, k]) * f
    return out


@njit(cache=True, nogil=True, inline="always")
def _upd_max(mx, v):
    """numpy's max: NaN wins."""
    if v > mx or v != v:
        return v
    return mx


@njit(cache=True, nogil=True)
def _cell_max_k(h, su, sv, lo_u, n_u, lo_v, n_v, rat, centre, out_a, out_w, q):
    """Not `rat`: out_a[q] = `interpolation_bound._cell_max` (no centre) of h (.., .., 3); `rat`: out_a[q],
    out_w[q] = `interpolation_bound._cell_max2` of h = [x w, w] (.., .., 4) about the cell centres (one
    compiled function for both)."""
    cu, cv = len(su), len(sv)
    for i in range(cu):
        for j in range(cv):
            if n_u <= 0 or n_v <= 0:
                out_a[q, i, j] = 0.0
                if rat:
                    out_w[q, i, j] = 0.0
                continue
            ma = 0.0
            mw = 0.0
            c0 = c1 = c2 = 0.0
            if rat:
                c0, c1, c2 = centre[i, j, 0], centre[i, j, 1], centre[i, j, 2]
            for a in range(n_u):
                r = su[i] - lo_u + a
                for b in range(n_v):
                    c = sv[j] - lo_v + b
                    if rat:
                        wv = h[r, c, 3]
                        x0 = h[r, c, 0] - c0 * wv
                        x1 = h[r, c, 1] - c1 * wv
                        x2 = h[r, c, 2] - c2 * wv
                        vw = np.sqrt(wv * wv)
                    else:
                        x0, x1, x2 = h[r, c, 0], h[r, c, 1], h[r, c, 2]
                        vw = 0.0
                    va = np.sqrt((x0 * x0 + x2 * x2) + x1 * x1)
                    if a == 0 and b == 0:
                        ma, mw = va, vw
                    else:
                        ma = _upd_max(ma, va)
                        mw = _upd_max(mw, vw)
            out_a[q, i, j] = ma
            if rat:
                out_w[q, i, j] = mw


@njit(cache=True, nogil=True)
def span_bounds_kernel(pu, pv, ku, kv, cp, w, rational):
    """`interpolation_bound.span_bounds` of the surface (degrees pu, pv; knots ku, kv; control points cp
    (nu, nv, 3); weights w (nu, nv) if `rational`, else unused): bu, bv, crease_u, crease_v, m (3, cu, cv)."""
    nu, nv = cp.shape[0], cp.shape[1]
    # offsets, axes and rows as int64 values, not literals: one specialization per helper (a literal 0, 1 or 2
    # compiled _diff/_cell_max_k once per value)
    i0 = np.int64(0)
    i1, i2 = i0 + 1, i0 + 2
    i3, i4 = i0 + 3, i0 + 4
    no, yes = i0 > i1, i0 < i1
    bu, su, cru = _breaks_k(ku, pu, nu)
    bv, sv, crv = _breaks_k(kv, pv, nv)
    cu, cv = len(su), len(sv)
    m = np.empty((3, cu, cv))
    if not rational:
        cw = cp.copy()      # a writable array like the others (a read-only one compiled _diff a second time)
        xu = _diff(cw, ku, i0, pu, i0)
        xuu = _diff(xu, ku, i1, pu - 1, i0)
        xv = _diff(cw, kv, i0, pv, i1)
        xvv = _diff(xv, kv, i1, pv - 1, i1)
        xuv = _diff(xu, kv, i0, pv, i1)
        no_c = np.empty((0, 0, 3))
        _cell_max_k(xuu, su, sv, pu, pu - 1, pv, pv + 1, no, no_c, m, m, i0)
        _cell_max_k(xvv, su, sv, pu, pu + 1, pv, pv - 1, no, no_c, m, m, i2)
        _cell_max_k(xuv, su, sv, pu, pu, pv, pv, no, no_c, m, m, i1)
        return bu, bv, cru, crv, m
    hw = np.empty((nu, nv, 4))
    for i in range(nu):
        for j in range(nv):
            wt = w[i, j]
            hw[i, j, 0] = cp[i, j, 0] * wt
            hw[i, j, 1] = cp[i, j, 1] * wt
            hw[i, j, 2] = cp[i, j, 2] * wt
            hw[i, j, 3] = wt
    hu = _diff(hw, ku, i0, pu, i0)
    huu = _diff(hu, ku, i1, pu - 1, i0)
    hv = _diff(hw, kv, i0, pv, i1)
    hvv = _diff(hv, kv, i1, pv - 1, i1)
    huv = _diff(hu, kv, i0, pv, i1)
    centre = np.empty((cu, cv, 3))
    rmax = np.empty((cu, cv))
    wmin = np.empty((cu, cv))
    cnt = float((pu + 1) * (pv + 1))
    for i in range(cu):
        for j in range(cv):
            r0, c0 = su[i] - pu, sv[j] - pv
            s0, s1, s2 = cp[r0, c0, 0], cp[r0, c0, 1], cp[r0, c0, 2]
            for a in range(pu + 1):
                for b in range(pv + 1):
                    if a or b:
                        s0 += cp[r0 + a, c0 + b, 0]
                        s1 += cp[r0 + a, c0 + b, 1]
                        s2 += cp[r0 + a, c0 + b, 2]
            s0, s1, s2 = s0 / cnt, s1 / cnt, s2 / cnt
            centre[i, j, 0], centre[i, j, 1], centre[i, j, 2] = s0, s1, s2
            rm = 0.0
            wm = 0.0
            for a in range(pu + 1):
                for b in range(pv + 1):
                    d0 = cp[r0 + a, c0 + b, 0] - s0
                    d1 = cp[r0 + a, c0 + b, 1] - s1
                    d2 = cp[r0 + a, c0 + b, 2] - s2
                    v = np.sqrt((d0 * d0 + d1 * d1) + d2 * d2)
                    wt = w[r0 + a, c0 + b]
                    if a == 0 and b == 0:
                        rm, wm = v, wt
                    else:
                        rm = _upd_max(rm, v)
                        if wt < wm or wt != wt:
                            wm = wt
            rmax[i, j] = rm
            wmin[i, j] = wm
    # rows of A, W: u, v, uu, vv, uv
    A = np.empty((5, cu, cv))
    W = np.empty((5, cu, cv))
    _cell_max_k(hu, su, sv, pu, pu, pv, pv + 1, yes, centre, A, W, i0)
    _cell_max_k(hv, su, sv, pu, pu + 1, pv, pv, yes, centre, A, W, i1)
    _cell_max_k(huu, su, sv, pu, pu - 1, pv, pv + 1, yes, centre, A, W, i2)
    _cell_max_k(hvv, su, sv, pu, pu + 1, pv, pv - 1, yes, centre, A, W, i3)
    _cell_max_k(huv, su, sv, pu, pu, pv, pv, yes, centre, A, W, i4)
    for i in range(cu):
        for j in range(cv):
            rm, wm = rmax[i, j], wmin[i, j]
            s_u = (A[0, i, j] + W[0, i, j] * rm) / wm
            s_v = (A[1, i, j] + W[1, i, j] * rm) / wm
            m[0, i, j] = (A[2, i, j] + 2.0 * W[0, i, j] * s_u + W[2, i, j] * rm) / wm
            m[2, i, j] = (A[3, i, j] + 2.0 * W[1, i, j] * s_v + W[3, i, j] * rm) / wm
            m[1, i, j] = (A[4, i, j] + W[0, i, j] * s_v + W[1, i, j] * s_u + W[4, i, j] * rm) / wm
    return bu, bv, cru, crv, m
