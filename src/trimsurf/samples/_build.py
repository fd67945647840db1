"""Helpers shared by the samples: simple curves, edge curves fitted to F(p(t)), shell topology."""

from __future__ import annotations

from dataclasses import replace
import numpy as np
from scipy.interpolate import make_lsq_spline
from scipy.optimize import brentq

from ..model import Edge, Loop, NurbsCurve, NurbsSurface, PCurve, Shell, TrimmedFace

__all__ = ["line", "bezier", "bspline", "ellipse_loop", "rounded_rectangle_loop", "fit_edge_curve",
           "with_edge_curves", "assemble_shell", "triangulate_polygon",
           "resample_closed"]

# Quarter circle as a cubic Bézier: inner control points at this fraction of the radius
# (the usual 4/3 (sqrt(2) - 1); radial error 2.7e-4 of the radius).
_KAPPA = 4.0 / 3.0 * (np.sqrt(2.0) - 1.0)


def line(a, b) -> NurbsCurve:
    """The segment from `a` to `b` as a degree-1 curve on [0, 1]."""
    return NurbsCurve(1, [0.0, 0.0, 1.0, 1.0], np.array([a, b], dtype=np.float64))


def bezier(points) -> NurbsCurve:
    """The Bézier curve with control points `points` (k+1, dim) on [0, 1]."""
    pts = np.asarray(points, dtype=np.float64)
    k = len(pts) - 1
    return NurbsCurve(k, np.r_[np.zeros(k + 1), np.ones(k + 1)], pts)


def bspline(points, degree: int, interior=()) -> NurbsCurve:
    """A clamped B-spline on [0, 1] with the given interior knots."""
    pts = np.asarray(points, dtype=np.float64)
    knots = np.r_[np.zeros(degree + 1), np.asarray(interior, dtype=np.float64), np.ones(degree + 1)]
    return NurbsCurve(degree, knots, pts)


def _arc(center, radii, a0: float, a1: float) -> NurbsCurve:
    """A quarter (or shorter) elliptic arc from angle a0 to a1 as a cubic Bézier."""
    c, r = np.asarray(center, float), np.asarray(radii, float)
    k = 4.0 / 3.0 * np.tan((a1 - a0) / 4.0)
    p0 = c + r * [np.cos(a0), np.sin(a0)]
    p3 = c + r * [np.cos(a1), np.sin(a1)]
    d0 = r * [-np.sin(a0), np.cos(a0)]
    d1 = r * [-np.sin(a1), np.cos(a1)]
    return bezier([p0, p0 + k * d0, p3 - k * d1, p3])


def ellipse_loop(center, radii, *, clockwise: bool) -> Loop:
    """An ellipse in (u, v) as four cubic Bézier arcs (a hole when `clockwise`)."""
    angles = np.linspace(0.0, 2 * np.pi, 5)
    if clockwise:
        angles = angles[::-1]
    return Loop(tuple(PCurve(_arc(center, radii, angles[i], angles[i + 1]), 0.0, 1.0) for i in range(4)))


def rounded_rectangle_loop(lo, hi, radius) -> Loop:
    """Counter-clockwise rounded rectangle in (u, v): four lines and four quarter arcs."""
    (u0, v0), (u1, v1) = lo, hi
    ru, rv = radius if np.ndim(radius) else (radius, radius)
    h = np.pi / 2
    segs = [line((u0 + ru, v0), (u1 - ru, v0)), _arc((u1 - ru, v0 + rv), (ru, rv), -h, 0.0),
            line((u1, v0 + rv), (u1, v1 - rv)), _arc((u1 - ru, v1 - rv), (ru, rv), 0.0, h),
            line((u1 - ru, v1), (u0 + ru, v1)), _arc((u0 + ru, v1 - rv), (ru, rv), h, 2 * h),
            line((u0, v1 - rv), (u0, v0 + rv)), _arc((u0 + ru, v0 + rv), (ru, rv), 2 * h, 3 * h)]
    return Loop(tuple(PCurve(c, 0.0, 1.0) for c in segs))


def _knot_crossings(surface: NurbsSurface, curve: NurbsCurve, lo: float, hi: float) -> np.ndarray:
    """Parameters in (lo, hi) where the p-curve crosses an interior knot line of the surface."""
    t = np.linspace(lo, hi, 2001)
    uv = curve.evaluate(t)
    out = []
    for axis, knots, p in ((0, surface.knots_u, surface.degree_u), (1, surface.knots_v, surface.degree_v)):
        for k in np.unique(knots[p + 1:-p - 1]):
            g = uv[:, axis] - k
            out.extend(t[1:-1][g[1:-1] == 0.0])
            for i in np.flatnonzero(np.sign(g[:-1]) * np.sign(g[1:]) < 0):
                out.append(brentq(lambda s: curve.evaluate([s])[0, axis] - k, t[i], t[i + 1], xtol=1e-15))
    return np.unique(np.round(np.array(out, dtype=np.float64), 14))


def _lsq_edge_curve(surface, curve, lo, hi, breaks, degree, n_spans):
    uniform = np.linspace(lo, hi, n_spans + 1)[1:-1]
    if breaks.size:
        uniform = uniform[np.all(np.abs(uniform[:, None] - breaks[None, :]) > (hi - lo) / (4 * n_spans), axis=1)]
    interior = np.sort(np.r_[uniform, np.repeat(breaks, degree - 1)])
    knots = np.r_[np.full(degree + 1, lo), interior, np.full(degree + 1, hi)]
    spans = np.unique(knots)
    t = np.unique(np.concatenate([np.linspace(a, b, 4 * degree + 1) for a, b in zip(spans[:-1], spans[1:])]))
    spl = make_lsq_spline(t, surface.evaluate(curve.evaluate(t)), knots, k=degree)
    fitted = NurbsCurve(degree, spl.t, spl.c)
    check = np.linspace(lo, hi, 16 * (len(spans) - 1) * degree + 1)
    err = np.linalg.norm(fitted.evaluate(check) - surface.evaluate(curve.evaluate(check)), axis=1).max()
    return fitted, float(err)


def fit_edge_curve(surface: NurbsSurface, pcurve: PCurve, *, max_error: float, degree: int = 5,
                   max_spans: int = 256) -> NurbsCurve:
    """A 3D B-spline b(t) ~ F(p(t)) on the p-curve's parameter range (same parameter).

    Least squares on uniform spans plus a C1 break wherever p(t) crosses a
    knot line of the surface (where F(p(t)) loses smoothness); the number of
    spans doubles until the sampled error is at most `max_error`.
    """
    lo, hi = sorted((pcurve.t0, pcurve.t1))
    breaks = _knot_crossings(surface, pcurve.curve, lo, hi)
    n_spans = 4
    while True:
        fitted, err = _lsq_edge_curve(surface, pcurve.curve, lo, hi, breaks, degree, n_spans)
        if err <= max_error or n_spans >= max_spans:
            return fitted
        n_spans *= 2


def with_edge_curves(face: TrimmedFace, *, max_error: float, degree: int = 5) -> TrimmedFace:
    """The face with a fitted 3D edge curve (within `max_error`) on every segment that has none."""
    loops = []
    for loop in face.loops:
        segs = tuple(s if s.edge_curve is not None else
                     replace(s, edge_curve=fit_edge_curve(face.surface, s, max_error=max_error, degree=degree))
                     for s in loop.segments)
        loops.append(Loop(segs))
    return replace(face, loops=tuple(loops))


def _segment_ends(face: TrimmedFace, seg: PCurve) -> np.ndarray:
    """3D start and end point of a segment (its edge curve, else F(p(t))), shape (2, 3)."""
    if seg.edge_curve is not None:
        return seg.edge_curve.evaluate([seg.t0, seg.t1])
    return face.surface.evaluate(seg.curve.evaluate([seg.t0, seg.t1]))


def assemble_shell(faces, *, shared=(), name: str = "", tolerance: float = 0.0) -> Shell:
    """A shell with one edge per loop segment, merging the segments listed in `shared`.

    Parameters
    ----------
    faces : sequence of TrimmedFace
    shared : sequence of tuples of (face, loop, segment)
        Segments that run along one common edge (the first one gives the edge
        curve; the edge runs along it with t0 < t1).
    name : str
    tolerance : float
        Stated tolerance of every edge (model units).

    Notes
    -----
    Vertices follow the topology, not distances: a segment's end is the next
    segment's start, and the ends of shared segments are identified (matching
    directions by proximity). A vertex sits at the mean of the 3D points that
    meet there.
    """
    faces = list(faces)
    keys = [(f, l, s) for f, face in enumerate(faces) for l, loop in enumerate(face.loops)
            for s in range(len(loop.segments))]
    seg = {k: faces[k[0]].loops[k[1]].segments[k[2]] for k in keys}
    ends = {k: _segment_ends(faces[k[0]], seg[k]) for k in keys}

    parent: dict = {}

    def find(x):
        parent.setdefault(x, x)
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    def union(a, b):
        parent[find(a)] = find(b)

    for f, l, s in keys:
        n = len(faces[f].loops[l].segments)
        union((f, l, s, 1), (f, l, (s + 1) % n, 0))

    groups, grouped = [], set()
    for group in shared:
        group = tuple(tuple(int(i) for i in u) for u in group)
        first = group[0]
        for other in group[1:]:
            a, b = ends[first], ends[other]
            forward = np.linalg.norm(a - b, axis=1).sum() <= np.linalg.norm(a - b[::-1], axis=1).sum()
            union(first + (0,), other + ((0,) if forward else (1,)))
            union(first + (1,), other + ((1,) if forward else (0,)))
        groups.append(group)
        grouped.update(group)
    groups += [(k,) for k in keys if k not in grouped]

    roots = sorted({find(k + (e,)) for k in keys for e in (0, 1)})
    index = {r: i for i, r in enumerate(roots)}
    acc = np.zeros((len(roots), 3))
    cnt = np.zeros(len(roots))
    for k in keys:
        for e in (0, 1):
            i = index[find(k + (e,))]
            acc[i] += ends[k][e]
            cnt[i] += 1
    vertices = acc / cnt[:, None]

    edges, edge_of = [], {}
    for group in groups:
        first = seg[group[0]]
        ends_v = (index[find(group[0] + (0,))], index[find(group[0] + (1,))])
        if first.t0 <= first.t1:
            edges.append(Edge(first.edge_curve, first.t0, first.t1, ends_v, group, tolerance=tolerance))
        else:  # the edge runs along its curve: t0 < t1, vertices in that order
            edges.append(Edge(first.edge_curve, first.t1, first.t0, ends_v[::-1], group, tolerance=tolerance))
        for u in group:
            edge_of[u] = len(edges) - 1
    new_faces = []
    for f, face in enumerate(faces):
        loops = tuple(Loop(tuple(replace(s, edge_id=edge_of[(f, l, i)]) for i, s in enumerate(loop.segments)))
                      for l, loop in enumerate(face.loops))
        new_faces.append(replace(face, loops=loops))
    return Shell(tuple(new_faces), tuple(edges), vertices, name=name)


def triangulate_polygon(rings, *, hole_points=(), max_area: float, min_angle_deg: float = 30.0):
    """Quality triangulation of a planar polygon with holes (Shewchuk's Triangle, 'pq<angle>a<area>').

    Parameters
    ----------
    rings : sequence of (k, 2) float64
        Closed polylines (first point not repeated): the outer boundary, then the holes.
    hole_points : sequence of (2,) float64
        One point inside each hole.
    max_area : float
        Largest triangle area.
    min_angle_deg : float
        Smallest triangle angle Ruppert refinement guarantees.

    Returns
    -------
    vertices : (n, 2) float64
    triangles : (m, 3) int64
        Counter-clockwise.
    """
    import triangle

    pts, segs, start = [], [], 0
    for ring in rings:
        ring = np.asarray(ring, dtype=np.float64)
        k = len(ring)
        pts.append(ring)
        idx = start + np.arange(k)
        segs.append(np.column_stack([idx, np.roll(idx, -1)]))
        start += k
    data = {"vertices": np.concatenate(pts), "segments": np.concatenate(segs)}
    if len(hole_points):
        data["holes"] = np.asarray(hole_points, dtype=np.float64)
    out = triangle.triangulate(data, f"pq{min_angle_deg:g}a{max_area:.17g}")
    v = np.asarray(out["vertices"], dtype=np.float64)
    t = np.asarray(out["triangles"], dtype=np.int64)
    p = v[t]
    area2 = ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
             - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
    t = np.where((area2 < 0)[:, None], t[:, ::-1], t)
    used = np.unique(t)
    if len(used) != len(v):              # drop unused input points (none expected)
        remap = np.full(len(v), -1, dtype=np.int64)
        remap[used] = np.arange(len(used))
        v, t = v[used], remap[t]
    return np.ascontiguousarray(v), np.ascontiguousarray(t)


def resample_closed(points, spacing: float) -> np.ndarray:
    """Points along a closed polyline (first point not repeated) at about `spacing` apart."""
    p = np.asarray(points, dtype=np.float64)
    q = np.vstack([p, p[:1]])
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))]
    n = max(3, int(np.ceil(s[-1] / spacing)))
    t = np.linspace(0.0, s[-1], n, endpoint=False)
    return np.column_stack([np.interp(t, s, q[:, 0]), np.interp(t, s, q[:, 1])])
