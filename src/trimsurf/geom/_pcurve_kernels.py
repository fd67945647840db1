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

from ._nurbs_kernels import _curve_point

__all__ = ["loop_polylines_kernel"]


@njit(cache=True, nogil=True)
def loop_polylines_kernel(si, sf, ck, cpw, n_a, n_b, out_a, out_b):
    """`model.Loop.polylines(n_a, n_b)` of the segments (p-curves) of a face's loops at once: segment j
    (si[j] = (degree, knots offset, knots count, pw offset, control points, dimw, rational), sf[j] = (t0, t1),
    flat read-only knots ck and homogeneous points cpw) at `PCurve.parameters(n)` (np.linspace's
    arithmetic), clamped into the curve's domain, evaluated as `curve_points_kernel` does; rows
    j (n - 1) to (j + 1) (n - 1) of out_a / out_b (the segment's last point left out)."""
    mp = 0
    for j in range(si.shape[0]):
        mp = max(mp, si[j, 0])
    ndu = np.empty((mp + 1, mp + 1))
    aa = np.empty((2, mp + 1))
    left = np.empty(mp + 1)
    right = np.empty(mp + 1)
    ders = np.empty((1, mp + 1))
    row = np.empty(2)
    for j in range(si.shape[0]):
        p = si[j, 0]
        kc = ck[si[j, 1]:si[j, 1] + si[j, 2]]
        pw = cpw[si[j, 3]:si[j, 3] + si[j, 4] * si[j, 5]].reshape((si[j, 4], si[j, 5]))
        rational = si[j, 6] != 0
        lo, hi = kc[p], kc[kc.shape[0] - p - 1]
        t0, t1 = sf[j, 0], sf[j, 1]
        for which in range(2):
            n = n_a if which == 0 else n_b
            step = (t1 - t0) / (n - 1)
            for k in range(n - 1):
                if step == 0.0:
                    t = (k / (n - 1)) * (t1 - t0) + t0
                else:
                    t = k * step + t0
                t = min(max(t, lo), hi)
                _curve_point(p, kc, pw, rational, t, ndu, aa, left, right, ders, row)
                if which == 0:
                    out_a[j * (n - 1) + k, 0] = row[0]
                    out_a[j * (n - 1) + k, 1] = row[1]
                else:
                    out_b[j * (n - 1) + k, 0] = row[0]
                    out_b[j * (n - 1) + k, 1] = row[1]
