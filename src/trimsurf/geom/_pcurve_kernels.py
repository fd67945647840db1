"""Compiled sampling of trim loops (numba, nogil): the p-curve segments of loops, all in one call.

`loop_polylines_kernel` samples every segment of a list of loops as `model.Loop.polylines` does segment by
segment (`PCurve.parameters`' arithmetic, the parameter clamped into the curve's domain as
`geom.nurbs.curve_derivatives` clamps it, each point as `_nurbs_kernels.curve_points_kernel` computes it),
so the same points bit for bit. Its callers: the meshing's trim fronts (`tessellate.face._sample_loops`)
and the measurement's loop polygons (`model.trim.loops_polylines`), with the same argument types (one
compiled version). The segments are packed by `model.trim._pcurve_rows`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["loop_polylines_kernel"]


@njit(cache=True, nogil=True)
def loop_polylines_kernel(si, sf, ck, cpw, n_a, n_b, out_a, out_b):
    """`model.Loop.polylines(n_a, n_b)` of the segments (p-curves) of a face's loops at once: segment j
    (si[j] = (degree, knots offset, knots count, pw offset, control points, dimw, rational), sf[j] = (t0, t1),
    flat read-only knots ck and homogeneous points cpw) at `PCurve.parameters(n)` (np.linspace's
    arithmetic), clamped into the curve's domain, evaluated as `curve_points_kernel` does (its operations,
    written out here: helper calls and array views cost reference counting per point); rows
    j (n - 1) to (j + 1) (n - 1) of out_a / out_b (the segment's last point left out)."""
    mp = 0
    for j in range(si.shape[0]):
        mp = max(mp, si[j, 0])
    ndu = np.empty((mp + 1, mp + 1))
    left = np.empty(mp + 1)
    right = np.empty(mp + 1)
    for j in range(si.shape[0]):
        p, ko, nk, po, n_ctrl, dimw = si[j, 0], si[j, 1], si[j, 2], si[j, 3], si[j, 4], si[j, 5]
        rational = si[j, 6] != 0
        dim = dimw - 1 if rational else dimw
        lo, hi = ck[ko + p], ck[ko + nk - p - 1]
        t0, t1 = sf[j, 0], sf[j, 1]
        for which in range(2):
            n = n_a if which == 0 else n_b
            out = out_a if which == 0 else out_b
            step = (t1 - t0) / (n - 1)
            for k in range(n - 1):
                if step == 0.0:
                    t = (k / (n - 1)) * (t1 - t0) + t0
                else:
                    t = k * step + t0
                t = min(max(t, lo), hi)
                # `_nurbs_kernels._curve_point` written out (its `_span`, `_ders_basis` with nd = 0, and sums:
                # the same operations in the same order), with no helper call and no array view per point
                if t >= ck[ko + n_ctrl]:
                    s = n_ctrl - 1
                    while s > p and ck[ko + s] >= ck[ko + n_ctrl]:
                        s -= 1
                else:
                    s, hi_ = p, n_ctrl
                    while hi_ - s > 1:
                        mid = (s + hi_) // 2
                        if t < ck[ko + mid]:
                            hi_ = mid
                        else:
                            s = mid
                ndu[0, 0] = 1.0
                for jj in range(1, p + 1):
                    left[jj] = t - ck[ko + s + 1 - jj]
                    right[jj] = ck[ko + s + jj] - t
                    saved = 0.0
                    for r in range(jj):
                        ndu[jj, r] = right[r + 1] + left[jj - r]
                        temp = ndu[r, jj - 1] / ndu[jj, r]
                        ndu[r, jj] = saved + right[r + 1] * temp
                        saved = left[jj - r] * temp
                    ndu[jj, jj] = saved
                base = po + (s - p) * dimw
                w = 1.0
                if rational:
                    w = 0.0
                    for r in range(p + 1):
                        w += ndu[r, p] * cpw[base + r * dimw + dim]
                for d in range(dim):
                    acc = 0.0
                    for r in range(p + 1):
                        acc += ndu[r, p] * cpw[base + r * dimw + d]
                    out[j * (n - 1) + k, d] = acc / w if rational else acc
