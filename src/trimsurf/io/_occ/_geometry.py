"""Open CASCADE curves and surfaces <-> `NurbsCurve` / `NurbsSurface` (arrays, knots, domains)."""

from __future__ import annotations

import math

import numpy as np

from ...model import NurbsCurve, NurbsSurface

# relative parametric slack below which a p-curve outside the surface domain is left to clamping
# (the 3D error is then < 1e-12 of the surface's extent)
_REL_PARAM_EPS = 1e-12
# relative margin added when the domain is extended, so points sampled between p-curve samples stay inside
_REL_EXTEND_MARGIN = 1e-6


# OCC arrays -> numpy
# --------------------------------------------------------------------------------------------------------------

def _reals(arr) -> np.ndarray:
    return np.fromiter(arr, dtype=np.float64, count=arr.Length())


# Points are read by index (``Value``): iterating an OCP point array costs ~80 us per point (its
# iterator), ``Value`` ~2 us; with iteration, copying the points was half of the conversion (measured
# on the shared files: 0.88 s of 1.45 s for U_Joint, bearing, featuretype and cornetta).

def _points2(arr) -> np.ndarray:
    """Array2_gp_Pnt (rows along u) -> (nu, nv, 3)."""
    value, r0, c0 = arr.Value, arr.LowerRow(), arr.LowerCol()
    cols = range(c0, c0 + arr.NbColumns())
    pts = np.array([value(i, j).Coord() for i in range(r0, r0 + arr.NbRows()) for j in cols], dtype=np.float64)
    return pts.reshape(arr.NbRows(), arr.NbColumns(), 3)


def _points1(arr, dim: int) -> np.ndarray:
    """Array1_gp_Pnt or Array1_gp_Pnt2d -> (n, dim)."""
    value, lo = arr.Value, arr.Lower()
    return np.array([value(i).Coord() for i in range(lo, lo + arr.Length())], dtype=np.float64).reshape(-1, dim)


def _homogeneous(points: np.ndarray, weights: np.ndarray | None) -> np.ndarray:
    w = np.ones(points.shape[:-1]) if weights is None else weights
    return np.concatenate([points * w[..., None], w[..., None]], axis=-1)


def _cartesian(pw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    w = pw[..., -1]
    return pw[..., :-1] / w[..., None], w


# --------------------------------------------------------------------------------------------------------------
# evaluation without the compiled kernels
# --------------------------------------------------------------------------------------------------------------

def curve_points(curve: NurbsCurve, t) -> np.ndarray:
    """Points C(t) of a `NurbsCurve`, shape (n, dim): bit for bit ``curve.evaluate(t)``, without numba.

    The reader evaluates p-curves (the (u, v) range a face uses, the seam repair). Through
    ``NurbsCurve.evaluate`` that is the compiled kernel ``geom._nurbs_kernels.curve_points_kernel``, and
    loading the first compiled kernel makes numba import scipy.linalg: ~0.2 s CPU in the reader server's
    start, which a ``trimsurf`` command reading one file waits for. `curves_points` is the kernel's
    arithmetic (A2.1 span, A2.2 basis functions, A4.1 rational point), every operation in the same order
    on the same float64 values, batched with numpy (numba compiles without fast-math: no contraction
    into FMA, so the results are the same floats; `benchmarks/read_identity.py` and
    ``tests/io/test_step.py`` compare them).
    """
    return curves_points([curve], [np.asarray(t, dtype=np.float64).ravel()])[0]


#: points evaluated together at most (plus one curve's): 2^16 points of degree 3 hold ~10 MB of work arrays
_BATCH_POINTS = 1 << 16


def curves_points(curves, ts) -> list[np.ndarray]:
    """`curve_points` of each curve at its own parameters (same dimension), batched over all of them.

    Curves of one degree are evaluated together on one concatenated knot vector and control net: the
    kernel's span search (a binary search, and at the domain end the last non-empty span) runs on all
    points at once, then the basis functions and the sums. A polynomial curve gets weight 1 in the shared
    sums (its homogeneous points are its points) but its result is the plain sum, as the kernel's; a
    rational curve's is the weighted sum divided by the weight sum.
    """
    out: list = [None] * len(curves)
    by_degree: dict[int, list[int]] = {}
    for i, c in enumerate(curves):
        by_degree.setdefault(int(c.degree), []).append(i)
    batches = []  # (degree, members) with at most _BATCH_POINTS points each (bounds the (p+1)^2 work arrays)
    for p, members in by_degree.items():
        start, points = 0, 0
        for k, i in enumerate(members):
            points += ts[i].shape[0]
            if points > _BATCH_POINTS and k > start:
                batches.append((p, members[start:k]))
                start, points = k, ts[i].shape[0]
        batches.append((p, members[start:]))
    for p, members in batches:
        group = [curves[i] for i in members]
        counts = np.array([ts[i].shape[0] for i in members])
        n_ctrl = np.array([c.control_points.shape[0] for c in group])
        k_off = np.concatenate([[0], np.cumsum(n_ctrl + p + 1)[:-1]])
        c_off = np.concatenate([[0], np.cumsum(n_ctrl)[:-1]])
        knots = np.concatenate([c.knots for c in group])
        cp = np.concatenate([c.control_points for c in group])
        w = np.concatenate([np.ones(c.control_points.shape[0]) if c.weights is None else c.weights for c in group])
        t = np.concatenate([ts[i] for i in members])
        ko = np.repeat(k_off, counts)
        lo_i = ko + p
        end_i = ko + np.repeat(n_ctrl, counts)
        t = np.minimum(np.maximum(t, knots[lo_i]), knots[end_i])
        # the kernel's _span: the largest i in [p, n_ctrl) with knots[i] <= t, or at the domain end
        # (t >= knots[n_ctrl]) with knots[i] < knots[n_ctrl], else p
        at_end = t >= knots[end_i]
        if len(group) == 1:  # one curve: numpy's search (few calls), then the domain end
            spans = np.searchsorted(knots, t, side="right") - 1
            np.clip(spans, p, n_ctrl[0] - 1, out=spans)
            if at_end.any():
                last = n_ctrl[0] - 1
                while last > p and knots[last] >= knots[n_ctrl[0]]:
                    last -= 1
                spans[at_end] = last
        else:  # the kernel's binary search, on all points at once
            lo, hi = lo_i.copy(), end_i.copy()
            while True:
                open_ = hi - lo > 1
                if not open_.any():
                    break
                mid = (lo + hi) // 2
                km = knots[mid]
                left_ = open_ & ((t < km) | (at_end & (t <= km)))
                hi = np.where(left_, mid, hi)
                lo = np.where(open_ & ~left_, mid, lo)
            spans = lo
        first = spans - ko - p + np.repeat(c_off, counts)
        n = t.shape[0]
        # ndu[j][r]: the triangle of A2.2 (basis values and knot differences), one value per point
        ndu = [[None] * (p + 1) for _ in range(p + 1)]
        ndu[0][0] = np.ones(n)
        left = [None] * (p + 1)
        right = [None] * (p + 1)
        for j in range(1, p + 1):
            left[j] = t - knots[spans + 1 - j]
            right[j] = knots[spans + j] - t
            saved = np.zeros(n)
            for r in range(j):
                ndu[j][r] = right[r + 1] + left[j - r]
                temp = ndu[r][j - 1] / ndu[j][r]
                ndu[r][j] = saved + right[r + 1] * temp
                saved = left[j - r] * temp
            ndu[j][j] = saved
        cw = cp * w[:, None]  # the kernel's homogeneous points (cp itself for a polynomial curve)
        acc = np.zeros((n, cp.shape[1]))
        wsum = np.zeros(n)
        for r in range(p + 1):
            b = ndu[r][p]
            acc = acc + b[:, None] * cw[first + r]
            wsum = wsum + b * w[first + r]
        rational = np.repeat([c.weights is not None for c in group], counts)
        if rational.any():
            acc[rational] = acc[rational] / wsum[rational, None]
        o = 0
        for i, k in zip(members, counts.tolist()):
            out[i] = acc[o:o + k]
            o += k
    return out


def linspaces(t0: np.ndarray, t1: np.ndarray, num: int) -> np.ndarray:
    """``np.linspace(t0[i], t1[i], num)`` for every i, shape (len(t0), num): the same floats (its arithmetic:
    ``arange(num) * step + start``, the end exact), in one pass. num >= 2; a zero step falls back to it."""
    step = (t1 - t0) / (num - 1)
    if not np.all(step != 0):
        return np.stack([np.linspace(a, b, num) for a, b in zip(t0.tolist(), t1.tolist())])
    y = np.arange(num, dtype=np.float64)[None, :] * step[:, None] + t0[:, None]
    y[:, -1] = t1
    return y


# --------------------------------------------------------------------------------------------------------------
# curves
# --------------------------------------------------------------------------------------------------------------

def _curve_to_bspline(curve, first: float, last: float, dim: int):
    """A B-spline copy of an Open CASCADE curve (a B-spline already after NurbsConvert)."""
    if curve.DynamicType().Name() in ("Geom_BSplineCurve", "Geom2d_BSplineCurve"):
        return curve.Copy()
    if dim == 3:
        from OCP.Geom import Geom_TrimmedCurve
        from OCP.GeomConvert import GeomConvert
        return GeomConvert.CurveToBSplineCurve_s(Geom_TrimmedCurve(curve, first, last))
    from OCP.Geom2d import Geom2d_TrimmedCurve
    from OCP.Geom2dConvert import Geom2dConvert
    return Geom2dConvert.CurveToBSplineCurve_s(Geom2d_TrimmedCurve(curve, first, last))


def _is_clamped(flat_knots: np.ndarray, degree: int) -> bool:
    """End knots of multiplicity degree + 1 (the sequence is non-decreasing: first == (degree+1)-th is enough)."""
    return bool(flat_knots[0] == flat_knots[degree] and flat_knots[-1] == flat_knots[-degree - 1])


def _insert_knot(bs, u: float, mult: int, tol: float) -> None:
    """Raise the multiplicity of knot `u` of a 2D or 3D B-spline curve to at least `mult` (inserting it if new).

    ``Geom_BSplineCurve::InsertKnot`` takes an ``Add`` flag (default: add to the
    multiplicity); ``Geom2d_BSplineCurve::InsertKnot`` has none and raises to `mult`.
    """
    if bs.DynamicType().Name() == "Geom2d_BSplineCurve":
        bs.InsertKnot(u, mult, tol)
    else:
        bs.InsertKnot(u, mult, tol, False)


def _knot_index(values: np.ndarray, x: float, tol: float) -> int | None:
    hit = np.flatnonzero(np.abs(values - x) <= tol)
    return int(hit[0]) + 1 if hit.size else None


def curve_from_occ(curve, first: float, last: float, dim: int) -> NurbsCurve:
    """Convert an Open CASCADE (2D or 3D) curve to a `NurbsCurve` whose domain holds [first, last].

    A periodic B-spline is made non-periodic; when [first, last] leaves its
    knot span the origin is moved (knot insertion + ``SetOrigin``) and the
    knots are translated by whole periods, so the parameterization is kept.
    When [first, last] leaves the knot range of a non-periodic curve, the
    end span is continued exactly (as for surfaces, see the module notes of
    `trimsurf.io._occ`), as Open CASCADE evaluates it.
    """
    bs = _curve_to_bspline(curve, first, last, dim)
    lo, hi = min(first, last), max(first, last)
    shift = 0.0
    if bs.IsPeriodic():
        c0, c1 = bs.FirstParameter(), bs.LastParameter()
        period = c1 - c0
        eps = _REL_PARAM_EPS * period
        if (lo < c0 - eps or hi > c1 + eps) and hi - lo <= period * (1 + 1e-9):
            k = math.floor((lo - c0) / period)
            start = lo - k * period
            shift = k * period
            _insert_knot(bs, start, 1, eps)
            index = _knot_index(_reals(bs.Knots()), start, eps)
            if index is not None:
                bs.SetOrigin(index)
            else:  # pragma: no cover - insertion always leaves the knot
                shift = 0.0
        bs.SetNotPeriodic()
    flat = _reals(bs.KnotSequence())
    if not _is_clamped(flat, bs.Degree()):
        bs.Segment(bs.FirstParameter(), bs.LastParameter())
        flat = None
    # [first, last] beyond the knot range: Open CASCADE continues the end polynomials; so do we, exactly
    p = bs.Degree()
    d0, d1 = bs.FirstParameter() + shift, bs.LastParameter() + shift
    eps = _REL_PARAM_EPS * (d1 - d0)
    need_lo, need_hi = lo < d0 - eps, hi > d1 + eps
    n_knots = bs.NbKnots()
    if need_hi and n_knots > 2:
        _insert_knot(bs, bs.Knot(n_knots - 1), p, 0.0)
        flat = None
    if need_lo and n_knots > 2:
        _insert_knot(bs, bs.Knot(2), p, 0.0)
        flat = None
    knots = (_reals(bs.KnotSequence()) if flat is None else flat) + shift
    poles = _points1(bs.Poles(), dim)
    weights = _reals(bs.WeightsArray()) if bs.IsRational() else None
    if need_lo or need_hi:
        nk, npw = _extend(knots, _homogeneous(poles, weights), p, min(lo, d0), max(hi, d1))
        if np.all(npw[:, -1] > 0):
            knots = nk
            poles, w = _cartesian(npw)
            weights = None if weights is None else w
    return NurbsCurve(p, knots, poles, weights)


def curve_to_occ(curve: NurbsCurve):
    """A ``Geom_BSplineCurve`` or ``Geom2d_BSplineCurve`` of a `NurbsCurve`."""
    from OCP.collections import Array1_gp_Pnt, Array1_gp_Pnt2d, Array1_int
    from OCP.gp import gp_Pnt, gp_Pnt2d

    values, mults = _compress_knots(curve.knots)
    knots_a = _array1_double(values)
    mults_a = Array1_int(1, len(mults))
    for i, m in enumerate(mults, start=1):
        mults_a.SetValue(i, int(m))
    n = curve.n_control_points
    if curve.dim == 3:
        from OCP.Geom import Geom_BSplineCurve
        poles = Array1_gp_Pnt(1, n)
        for i, (x, y, z) in enumerate(curve.control_points.tolist(), start=1):
            poles.SetValue(i, gp_Pnt(x, y, z))
        cls = Geom_BSplineCurve
    else:
        from OCP.Geom2d import Geom2d_BSplineCurve
        poles = Array1_gp_Pnt2d(1, n)
        for i, (x, y) in enumerate(curve.control_points.tolist(), start=1):
            poles.SetValue(i, gp_Pnt2d(x, y))
        cls = Geom2d_BSplineCurve
    if curve.weights is None:
        return cls(poles, knots_a, mults_a, curve.degree)
    return cls(poles, _array1_double(curve.weights), knots_a, mults_a, curve.degree)


def _array1_double(values) -> object:
    from OCP.collections import Array1_double
    values = np.asarray(values, dtype=np.float64).ravel()
    arr = Array1_double(1, len(values))
    for i, x in enumerate(values.tolist(), start=1):
        arr.SetValue(i, x)
    return arr


def _compress_knots(knots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    values, counts = np.unique(np.asarray(knots), return_counts=True)
    return values, counts


# --------------------------------------------------------------------------------------------------------------
# surfaces
# --------------------------------------------------------------------------------------------------------------

def _make_nonperiodic(bs, direction: str, lo: float, hi: float) -> float:
    """Make one direction of a periodic Geom_BSplineSurface non-periodic; return the knot translation."""
    first, last = bs.Bounds()[0:2] if direction == "u" else bs.Bounds()[2:4]
    period = last - first
    eps = _REL_PARAM_EPS * period
    shift = 0.0
    if (lo < first - eps or hi > last + eps) and hi - lo <= period * (1 + 1e-9):
        k = math.floor((lo - first) / period)
        start = lo - k * period
        shift = k * period
        if direction == "u":
            bs.InsertUKnot(start, 1, eps, False)
            index = _knot_index(_reals(bs.UKnots()), start, eps)
            if index is not None:
                bs.SetUOrigin(index)
        else:
            bs.InsertVKnot(start, 1, eps, False)
            index = _knot_index(_reals(bs.VKnots()), start, eps)
            if index is not None:
                bs.SetVOrigin(index)
        if index is None:  # pragma: no cover - insertion always leaves the knot
            shift = 0.0
    if direction == "u":
        bs.SetUNotPeriodic()
    else:
        bs.SetVNotPeriodic()
    return shift


def _bezier_end_multiplicity(bs, direction: str, at_end: bool) -> None:
    """Raise the knot next to one end to multiplicity `degree`, so the end span's poles are its Bézier points."""
    if direction == "u":
        n, deg = bs.NbUKnots(), bs.UDegree()
        if n > 2:
            i = n - 1 if at_end else 2
            bs.InsertUKnot(bs.UKnot(i), deg, 0.0, False)
    else:
        n, deg = bs.NbVKnots(), bs.VDegree()
        if n > 2:
            i = n - 1 if at_end else 2
            bs.InsertVKnot(bs.VKnot(i), deg, 0.0, False)


def _extend_end(knots: np.ndarray, pw: np.ndarray, degree: int, target: float) -> tuple[np.ndarray, np.ndarray]:
    """Continue the last span's polynomial to `target` > knots[-1] (exact, homogeneous, along axis 0).

    Requires the last p + 1 control points to be the end span's Bézier points
    (the knot before the end of multiplicity >= p). The span [a, b] becomes
    [a, target]: its Bézier points are the left half of the de Casteljau
    subdivision at s = (target - a) / (b - a) > 1.
    """
    p = degree
    b = knots[-1]
    a = knots[-p - 2]
    s = (target - a) / (b - a)
    q = pw[-p - 1:].copy()
    new = [q[0].copy()]
    for _ in range(p):
        q = (1.0 - s) * q[:-1] + s * q[1:]
        new.append(q[0].copy())
    out = pw.copy()
    out[-p - 1:] = np.stack(new)
    k = knots.copy()
    k[-p - 1:] = target
    return k, out


def _extend(knots: np.ndarray, pw: np.ndarray, degree: int, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Extend a clamped direction (axis 0 of `pw`) so its domain holds [lo, hi]."""
    d0, d1 = knots[degree], knots[-degree - 1]
    margin = _REL_EXTEND_MARGIN * (d1 - d0)
    if hi > d1:
        knots, pw = _extend_end(knots, pw, degree, hi + margin)
    if lo < d0:
        rk, rp = _extend_end(-knots[::-1], pw[::-1], degree, -(lo - margin))
        knots, pw = -rk[::-1], rp[::-1]
    return knots, pw


def surface_from_occ(surface, uv_lo: np.ndarray, uv_hi: np.ndarray) -> NurbsSurface:
    """Convert an Open CASCADE surface to a `NurbsSurface` whose domain holds the box [uv_lo, uv_hi].

    See the module notes for the periodic-seam and domain-extension conventions.
    """
    if surface.DynamicType().Name() == "Geom_BSplineSurface":
        bs = surface.Copy()
    else:
        from OCP.GeomConvert import GeomConvert
        bs = GeomConvert.SurfaceToBSplineSurface_s(surface)
    shifts = [0.0, 0.0]
    periodic = [bs.IsUPeriodic(), bs.IsVPeriodic()]
    for axis, direction in enumerate("uv"):
        if periodic[axis]:
            shifts[axis] = _make_nonperiodic(bs, direction, float(uv_lo[axis]), float(uv_hi[axis]))
    if not (_is_clamped(_reals(bs.UKnotSequence()), bs.UDegree())
            and _is_clamped(_reals(bs.VKnotSequence()), bs.VDegree())):
        bs.Segment(*bs.Bounds())  # clamp: end knots of multiplicity degree + 1, same surface
    # which ends need an extension (non-periodic directions only)
    u0, u1, v0, v1 = bs.Bounds()
    bounds = ((u0 + shifts[0], u1 + shifts[0]), (v0 + shifts[1], v1 + shifts[1]))
    ends = []
    for axis, direction in enumerate("uv"):
        d0, d1 = bounds[axis]
        eps = _REL_PARAM_EPS * (d1 - d0)
        need_lo = not periodic[axis] and uv_lo[axis] < d0 - eps
        need_hi = not periodic[axis] and uv_hi[axis] > d1 + eps
        ends.append((need_lo, need_hi))
        if need_lo:
            _bezier_end_multiplicity(bs, direction, at_end=False)
        if need_hi:
            _bezier_end_multiplicity(bs, direction, at_end=True)
    poles = _points2(bs.Poles())
    weights = None
    if bs.IsURational() or bs.IsVRational():
        w = bs.WeightsArray()
        weights = np.fromiter(w, dtype=np.float64, count=w.Size()).reshape(w.NbRows(), w.NbColumns())
    ku = _reals(bs.UKnotSequence()) + shifts[0]
    kv = _reals(bs.VKnotSequence()) + shifts[1]
    pu, pv = bs.UDegree(), bs.VDegree()
    if any(a or b for a, b in ends):
        pw = _homogeneous(poles, weights)
        lo_u = min(float(uv_lo[0]), ku[pu]) if ends[0][0] else ku[pu]
        hi_u = max(float(uv_hi[0]), ku[-pu - 1]) if ends[0][1] else ku[-pu - 1]
        nku, npw = _extend(ku, pw, pu, lo_u, hi_u)
        lo_v = min(float(uv_lo[1]), kv[pv]) if ends[1][0] else kv[pv]
        hi_v = max(float(uv_hi[1]), kv[-pv - 1]) if ends[1][1] else kv[-pv - 1]
        nkv, npw_t = _extend(kv, np.swapaxes(npw, 0, 1), pv, lo_v, hi_v)
        npw = np.swapaxes(npw_t, 0, 1)
        if np.all(npw[..., -1] > 0):
            ku, kv = nku, nkv
            poles, w = _cartesian(npw)
            weights = None if weights is None else w
    return NurbsSurface(pu, pv, ku, kv, poles, weights)


def surface_to_occ(surface: NurbsSurface):
    """A ``Geom_BSplineSurface`` of a `NurbsSurface`."""
    from OCP.collections import Array1_int, Array2_double, Array2_gp_Pnt
    from OCP.Geom import Geom_BSplineSurface
    from OCP.gp import gp_Pnt

    nu, nv = surface.shape
    poles = Array2_gp_Pnt(1, nu, 1, nv)
    cp = surface.control_points.tolist()
    for i in range(nu):
        row = cp[i]
        for j in range(nv):
            x, y, z = row[j]
            poles.SetValue(i + 1, j + 1, gp_Pnt(x, y, z))
    args = []
    for knots in (surface.knots_u, surface.knots_v):
        values, mults = _compress_knots(knots)
        m = Array1_int(1, len(mults))
        for i, k in enumerate(mults.tolist(), start=1):
            m.SetValue(i, int(k))
        args.append((_array1_double(values), m))
    (uk, um), (vk, vm) = args
    if surface.weights is None:
        return Geom_BSplineSurface(poles, uk, vk, um, vm, surface.degree_u, surface.degree_v)
    w = Array2_double(1, nu, 1, nv)
    wl = surface.weights.tolist()
    for i in range(nu):
        for j in range(nv):
            w.SetValue(i + 1, j + 1, wl[i][j])
    return Geom_BSplineSurface(poles, w, uk, vk, um, vm, surface.degree_u, surface.degree_v)
