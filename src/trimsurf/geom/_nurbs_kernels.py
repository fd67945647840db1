"""Compiled per-point kernels for tensor-product NURBS evaluation (numba).

The numpy path in `nurbs.py` is batched but moves (n, p+1, q+1, dim) arrays
through memory several times; evaluating with derivatives in one pass per
point is 3-6x faster. Same algorithms: A2.1, A2.3, A3.6, A4.4 of The NURBS Book.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def _span(degree, knots, n_ctrl, t):
    if t >= knots[n_ctrl]:
        last = n_ctrl - 1
        while last > degree and knots[last] >= knots[n_ctrl]:
            last -= 1
        return last
    lo, hi = degree, n_ctrl
    while hi - lo > 1:  # knots[lo] <= t < knots[hi]
        mid = (lo + hi) // 2
        if t < knots[mid]:
            hi = mid
        else:
            lo = mid
    return lo


@njit(cache=True, nogil=True)
def _ders_basis(span, t, p, knots, nd, ndu, a, left, right, ders):
    ndu[0, 0] = 1.0
    for j in range(1, p + 1):
        left[j] = t - knots[span + 1 - j]
        right[j] = knots[span + j] - t
        saved = 0.0
        for r in range(j):
            ndu[j, r] = right[r + 1] + left[j - r]
            temp = ndu[r, j - 1] / ndu[j, r]
            ndu[r, j] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        ndu[j, j] = saved
    for j in range(p + 1):
        ders[0, j] = ndu[j, p]
    for k in range(1, nd + 1):
        for j in range(p + 1):
            ders[k, j] = 0.0
    top = min(nd, p)
    for r in range(p + 1):
        s1, s2 = 0, 1
        a[0, 0] = 1.0
        for k in range(1, top + 1):
            d = 0.0
            rk, pk = r - k, p - k
            if r >= k:
                a[s2, 0] = a[s1, 0] / ndu[pk + 1, rk]
                d = a[s2, 0] * ndu[rk, pk]
            j1 = 1 if rk >= -1 else -rk
            j2 = k - 1 if r - 1 <= pk else p - r
            for j in range(j1, j2 + 1):
                a[s2, j] = (a[s1, j] - a[s1, j - 1]) / ndu[pk + 1, rk + j]
                d += a[s2, j] * ndu[rk + j, pk]
            if r <= pk:
                a[s2, k] = -a[s1, k - 1] / ndu[pk + 1, r]
                d += a[s2, k] * ndu[r, pk]
            ders[k, r] = d
            s1, s2 = s2, s1
    factor = p
    for k in range(1, top + 1):
        for j in range(p + 1):
            ders[k, j] *= factor
        factor *= p - k


@njit(cache=True, nogil=True)
def surface_derivatives_kernel(pu, pv, ku, kv, pw, rational, u, v, nd, out):
    """out[k, l, i, :] = d^(k+l) S / du^k dv^l at (u[i], v[i]); pw homogeneous if rational."""
    nu_ctrl, nv_ctrl, dimw = pw.shape
    dim = dimw - 1 if rational else dimw
    ndu_u = np.empty((pu + 1, pu + 1))
    ndu_v = np.empty((pv + 1, pv + 1))
    a_u = np.empty((2, pu + 1))
    a_v = np.empty((2, pv + 1))
    l_u = np.empty(pu + 1)
    r_u = np.empty(pu + 1)
    l_v = np.empty(pv + 1)
    r_v = np.empty(pv + 1)
    bu = np.empty((nd + 1, pu + 1))
    bv = np.empty((nd + 1, pv + 1))
    tmp = np.empty((nd + 1, pu + 1, dimw))
    skl = np.empty((nd + 1, nd + 1, dimw))
    binom = np.zeros((nd + 1, nd + 1))
    for i in range(nd + 1):
        binom[i, 0] = 1.0
        for j in range(1, i + 1):
            binom[i, j] = binom[i - 1, j - 1] + (binom[i - 1, j] if j < i else 0.0)
    for i in range(u.shape[0]):
        su = _span(pu, ku, nu_ctrl, u[i])
        sv = _span(pv, kv, nv_ctrl, v[i])
        _ders_basis(su, u[i], pu, ku, nd, ndu_u, a_u, l_u, r_u, bu)
        _ders_basis(sv, v[i], pv, kv, nd, ndu_v, a_v, l_v, r_v, bv)
        # contract v: tmp[l, r] = sum_s bv[l, s] P[su - pu + r, sv - pv + s]
        for l in range(nd + 1):
            for r in range(pu + 1):
                for d in range(dimw):
                    tmp[l, r, d] = 0.0
                for s in range(pv + 1):
                    b = bv[l, s]
                    if b != 0.0:
                        row = su - pu + r
                        col = sv - pv + s
                        for d in range(dimw):
                            tmp[l, r, d] += b * pw[row, col, d]
        for k in range(nd + 1):
            for l in range(nd + 1 - k):
                for d in range(dimw):
                    acc = 0.0
                    for r in range(pu + 1):
                        acc += bu[k, r] * tmp[l, r, d]
                    skl[k, l, d] = acc
        if not rational:
            for k in range(nd + 1):
                for l in range(nd + 1 - k):
                    for d in range(dim):
                        out[k, l, i, d] = skl[k, l, d]
            continue
        w0 = skl[0, 0, dim]
        for k in range(nd + 1):
            for l in range(nd + 1 - k):
                for d in range(dim):
                    val = skl[k, l, d]
                    for j in range(1, l + 1):
                        val -= binom[l, j] * skl[0, j, dim] * out[k, l - j, i, d]
                    for q in range(1, k + 1):
                        val -= binom[k, q] * skl[q, 0, dim] * out[k - q, l, i, d]
                        v2 = 0.0
                        for j in range(1, l + 1):
                            v2 += binom[l, j] * skl[q, j, dim] * out[k - q, l - j, i, d]
                        val -= binom[k, q] * v2
                    out[k, l, i, d] = val / w0


@njit(cache=True, nogil=True)
def basis_functions_kernel(p, knots, spans, t, nd, out):
    """out[k, i, r] = k-th derivative of N_{spans[i]-p+r, p} at t[i] (A2.3 per point)."""
    ndu = np.empty((p + 1, p + 1))
    a = np.empty((2, p + 1))
    left = np.empty(p + 1)
    right = np.empty(p + 1)
    ders = np.empty((nd + 1, p + 1))
    for i in range(t.shape[0]):
        _ders_basis(spans[i], t[i], p, knots, nd, ndu, a, left, right, ders)
        for k in range(nd + 1):
            for r in range(p + 1):
                out[k, i, r] = ders[k, r]
