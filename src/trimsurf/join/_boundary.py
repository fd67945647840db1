"""Boundary curves b_k as shared polylines: Case 1 (edge curves) and Case 2 (median of mesh boundaries).

Every edge of the shell gets ONE polyline in 3D, in the edge's own direction
(b(t0) -> b(t1)); both faces on the edge project the same points, so after
reprojection their boundary vertices coincide exactly (Sec. III-B, step 6).

* Case 1 (Sec. III-B): the edge curve b(t) sampled at about equal arc
  length, with about the spacing of the adjoining meshes' boundaries.
* Case 2 (Sec. III-C): no b(t). Where one face uses the edge, the mesh's own
  boundary chain along it; where two do, the median polyline of the two
  chains (pairs of points at equal normalised arc length, as in Sec. I), with
  loops deleted.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..geom import polyline_self_intersections
from ..model import Shell

__all__ = ["EdgePolyline", "edge_table", "sample_edge_curve", "median_polyline", "delete_loops",
           "arc_length_fractions"]


@dataclass
class EdgePolyline:
    """One boundary curve b_k of the shell as a polyline (canonical direction t0 -> t1)."""

    key: int
    curve: object                    # NurbsCurve or None
    t0: float
    t1: float
    vertices: tuple[int, int]        # shell vertex ids of the ends, -1 if none
    uses: list = field(default_factory=list)  # (face, loop, segment, forward)
    degenerate: bool = False
    points: np.ndarray | None = None  # (K, 3)
    tpar: np.ndarray | None = None    # (K,) curve parameters (Case 1) or interpolated (Case 2)
    case: int = 1
    gid: np.ndarray | None = None     # (K,) global ids of the points

    @property
    def faces(self) -> set[int]:
        return {u[0] for u in self.uses}

    @property
    def joined(self) -> bool:
        return len(self.uses) >= 2


def edge_table(shell: Shell) -> tuple[list[EdgePolyline], dict[tuple[int, int, int], int]]:
    """One `EdgePolyline` per shell edge (or per loop segment without an edge) and (face, loop, seg) -> key."""
    edges: list[EdgePolyline] = []
    use_key: dict[tuple[int, int, int], int] = {}
    for e in shell.edges:
        k = len(edges)
        ed = EdgePolyline(k, e.curve, float(e.t0), float(e.t1), e.vertices, degenerate=bool(e.is_degenerate))
        for f, li, si in e.uses:
            seg = shell.faces[f].loops[li].segments[si]
            fwd = (seg.t1 - seg.t0) * (e.t1 - e.t0) > 0
            ed.uses.append((f, li, si, bool(fwd)))
            use_key[(f, li, si)] = k
        edges.append(ed)
    for f, face in enumerate(shell.faces):
        for li, loop in enumerate(face.loops):
            for si, seg in enumerate(loop.segments):
                if (f, li, si) in use_key:
                    continue
                k = len(edges)
                ed = EdgePolyline(k, seg.edge_curve, seg.t0, seg.t1, (-1, -1))
                ed.uses.append((f, li, si, True))
                use_key[(f, li, si)] = k
                edges.append(ed)
    return edges, use_key


def arc_length_fractions(points: np.ndarray) -> np.ndarray:
    """Normalised cumulative chord length of a polyline, (K,) from 0 to 1."""
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    c = np.r_[0.0, np.cumsum(seg)]
    return c / c[-1] if c[-1] > 0 else np.linspace(0.0, 1.0, len(points))


def sample_edge_curve(curve, t0: float, t1: float, spacing: float, *, min_segments: int = 2,
                      chord_tolerance: float | None = None, max_rounds: int = 12):
    """Points of b(t) on [t0, t1] (in that order) about `spacing` apart in arc length; returns (points, t).

    With `chord_tolerance`, segments whose chord misses b at the parameter
    midpoint by more than that are halved (repeatedly), so the polyline is
    within about that distance of the curve.
    """
    dense_t = np.linspace(t0, t1, 257)
    dense = curve.evaluate(dense_t)
    length = float(np.linalg.norm(np.diff(dense, axis=0), axis=1).sum())
    n_seg = max(min_segments, int(np.ceil(length / spacing)) if spacing > 0 else min_segments)
    n_seg = min(n_seg, 100000)
    dense_t = np.linspace(t0, t1, 16 * n_seg + 1)
    dense = curve.evaluate(dense_t)
    s = arc_length_fractions(dense)
    t = np.interp(np.linspace(0.0, 1.0, n_seg + 1), s, dense_t)
    t[0], t[-1] = t0, t1
    pts = curve.evaluate(t)
    if chord_tolerance is not None and chord_tolerance > 0:
        for _ in range(max_rounds):
            tm = 0.5 * (t[:-1] + t[1:])
            pm = curve.evaluate(tm)
            dev = np.linalg.norm(pm - 0.5 * (pts[:-1] + pts[1:]), axis=1)
            bad = dev > chord_tolerance
            if not bad.any() or len(t) > 100000:
                break
            # the midpoints just evaluated join the polyline (no second evaluation of b)
            t = np.r_[t, tm[bad]]
            order = np.argsort(t, kind="stable")
            t, pts = t[order], np.concatenate([pts, pm[bad]])[order]
    return pts, t


def _at(points: np.ndarray, s: np.ndarray, where: np.ndarray) -> np.ndarray:
    return np.column_stack([np.interp(where, s, points[:, c]) for c in range(points.shape[1])])


def median_polyline(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Median of two polylines with common direction: midpoints of points at equal normalised arc length.

    Returns the median (K, 3) and its parameters s in [0, 1] (the union of
    both polylines' vertex fractions). This is the pairing of Sec. I (Fig. 2):
    the midpoint baseline moves the mesh vertices onto it; Case 2 uses it as
    the surrogate b_k.
    """
    sa, sb = arc_length_fractions(a), arc_length_fractions(b)
    s = np.unique(np.r_[sa, sb])
    keep = np.r_[True, np.diff(s) > 1e-12]
    s = s[keep]
    return 0.5 * (_at(a, sa, s) + _at(b, sb, s)), s


def delete_loops(points: np.ndarray, uv: np.ndarray, params: np.ndarray | None = None, *, max_rounds: int = 100):
    """Cut the loops out of an open polyline whose (u, v) image crosses itself (Sec. III-C).

    For the first crossing segments i < j the vertices i+1..j are replaced by
    the crossing point (interpolated in 3D and in the parameters at the
    crossing's fraction along segment i); repeated until the (u, v) image is
    simple. Returns (points, uv, params, number of loops deleted).
    """
    pts, w = np.asarray(points, float).copy(), np.asarray(uv, float).copy()
    par = None if params is None else np.asarray(params, float).copy()
    n_cut = 0
    for _ in range(max_rounds):
        pairs = polyline_self_intersections(w, closed=False)
        if not len(pairs):
            break
        i, j = (int(x) for x in pairs[0])
        p0, p1, q0, q1 = w[i], w[i + 1], w[j], w[j + 1]
        r, s = p1 - p0, q1 - q0
        den = r[0] * s[1] - r[1] * s[0]
        f = 0.5 if den == 0 else float(np.clip(((q0 - p0)[0] * s[1] - (q0 - p0)[1] * s[0]) / den, 0.0, 1.0))
        xp = pts[i] + f * (pts[i + 1] - pts[i])
        xw = p0 + f * r
        pts = np.concatenate([pts[:i + 1], xp[None], pts[j + 1:]])
        w = np.concatenate([w[:i + 1], xw[None], w[j + 1:]])
        if par is not None:
            xpar = par[i] + f * (par[i + 1] - par[i])
            par = np.concatenate([par[:i + 1], [xpar], par[j + 1:]])
        # drop zero-length segments the cut may create
        ok = np.r_[True, np.linalg.norm(np.diff(w, axis=0), axis=1) > 0]
        ok[-1] = True
        pts, w = pts[ok], w[ok]
        if par is not None:
            par = par[ok]
        n_cut += 1
    return pts, w, par, n_cut
