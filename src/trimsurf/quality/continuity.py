"""G0 and G1 continuity across a boundary shared by two surfaces or faces.

Side A's boundary curve is sampled at `n_samples` parameters; for each sample
X_a the closest point X_b on side B's boundary curve is found (nearest point
of a dense polyline, then Gauss-Newton on the curve parameter). G0 is the gap
|X_a - X_b|; G1 is the angle between the unit normals at X_a and X_b. The
tangent-plane angle (0..90 degrees) ignores orientation; the oriented angle
uses `TrimmedFace.same_sense` and is near 180 degrees when two faces of a
shell disagree about their outward side.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import InputError
from ..model import NurbsSurface, PCurve, Shell, TrimmedFace
from ._results import ResultMixin
from .closest_point import point_segment_closest

__all__ = ["Continuity", "boundary_continuity", "edge_continuity", "face_continuity", "surface_continuity"]

_DENSE = 8          # side-B polyline points per side-A sample
_NEWTON_STEPS = 8   # Gauss-Newton refinements of the side-B parameter

# side of a boundary: (surface, sign of the outward normal, uv(t) -> (uv, duv/dt), t0, t1)
_Side = tuple[NurbsSurface, int, Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]], float, float]


@dataclass(frozen=True, eq=False)
class Continuity(ResultMixin):
    """Position gap (G0) and normal angle (G1) along a shared boundary.

    Attributes
    ----------
    max_gap, rms_gap : float
        Model units.
    where_gap : (3,) float64
        Side-A boundary point with the largest gap.
    t_gap : float
        Its side-A curve parameter.
    max_angle_deg : float
        Largest angle between the tangent planes (0..90).
    where_angle : (3,) float64
    t_angle : float
    max_oriented_angle_deg : float
        Largest angle between the oriented normals (0..180).
    orientation_consistent : bool
        Oriented normals agree (dot > 0) at every sample.
    n_samples : int
    n_singular : int
        Samples left out of G1 because a normal is undefined.
    segments : tuple
        What was compared (e.g. ``((loop_a, seg_a), (loop_b, seg_b))`` or iso-boundary names).
    """

    max_gap: float
    rms_gap: float
    where_gap: np.ndarray
    t_gap: float
    max_angle_deg: float
    where_angle: np.ndarray
    t_angle: float
    max_oriented_angle_deg: float
    orientation_consistent: bool
    n_samples: int
    n_singular: int
    segments: tuple


def _pcurve_side(face: TrimmedFace, seg: PCurve) -> _Side:
    def uv(t):
        d = seg.curve.derivatives(t, 1)
        return d[0], d[1]
    return face.surface, 1 if face.same_sense else -1, uv, seg.t0, seg.t1


def _iso_side(surface: NurbsSurface, name: str) -> _Side:
    (u0, u1), (v0, v1) = surface.domain
    fixed = {"u0": u0, "u1": u1, "v0": v0, "v1": v1}[name]
    along_u = name[0] == "v"

    def uv(t):
        t = np.asarray(t, dtype=np.float64)
        one = np.ones_like(t)
        if along_u:
            return np.column_stack([t, fixed * one]), np.column_stack([one, 0 * one])
        return np.column_stack([fixed * one, t]), np.column_stack([0 * one, one])
    lo, hi = (u0, u1) if along_u else (v0, v1)
    return surface, 1, uv, lo, hi


def _points(side: _Side, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    surf, _, uv_of, _, _ = side
    uv, _ = uv_of(t)
    return surf.evaluate(uv), uv


def _closest_on_side(side: _Side, x: np.ndarray, n_dense: int) -> tuple[np.ndarray, np.ndarray]:
    """Parameters t on side B nearest to points x, and the points."""
    surf, _, uv_of, t0, t1 = side
    td = np.linspace(t0, t1, n_dense)
    poly = surf.evaluate(uv_of(td)[0])
    a, b = poly[:-1], poly[1:]
    n, k = len(x), len(a)
    _, s = point_segment_closest(np.repeat(x, k, axis=0), np.tile(a, (n, 1)), np.tile(b, (n, 1)))
    q = np.tile(a, (n, 1)) + s[:, None] * np.tile(b - a, (n, 1))
    d = np.linalg.norm(q - np.repeat(x, k, axis=0), axis=1).reshape(n, k)
    j = np.argmin(d, axis=1)
    t = td[j] + s.reshape(n, k)[np.arange(n), j] * (td[j + 1] - td[j])
    lo, hi = min(t0, t1), max(t0, t1)
    for _ in range(_NEWTON_STEPS):
        uv, duv = uv_of(t)
        der = surf.derivatives(uv, 1)
        xt = der[1, 0] * duv[:, :1] + der[0, 1] * duv[:, 1:]
        r = der[0, 0] - x
        den = np.einsum("ij,ij->i", xt, xt)
        step = np.where(den > 0, -np.einsum("ij,ij->i", r, xt) / np.where(den > 0, den, 1.0), 0.0)
        t = np.clip(t + step, lo, hi)
    return t, surf.evaluate(uv_of(t)[0])


def _continuity(side_a: _Side, side_b: _Side, n_samples: int, segments: tuple) -> Continuity:
    n_samples = int(n_samples)
    if n_samples < 2:
        raise InputError(f"n_samples must be >= 2; got {n_samples}")
    surf_a, sign_a, uv_a_of, ta0, ta1 = side_a
    surf_b, sign_b, uv_b_of, _, _ = side_b
    ta = np.linspace(ta0, ta1, n_samples)
    uv_a = uv_a_of(ta)[0]
    xa = surf_a.evaluate(uv_a)
    tb, xb = _closest_on_side(side_b, xa, min(_DENSE * n_samples, 2048))
    gap = np.linalg.norm(xa - xb, axis=1)
    na = sign_a * surf_a.normals(uv_a)
    nb = sign_b * surf_b.normals(uv_b_of(tb)[0])
    cos = np.einsum("ij,ij->i", na, nb)
    ok = np.isfinite(cos)
    cos = np.clip(np.where(ok, cos, 1.0), -1.0, 1.0)
    plane = np.degrees(np.arccos(np.abs(cos)))
    oriented = np.degrees(np.arccos(cos))
    kg = int(np.argmax(gap))
    ka = int(np.argmax(np.where(ok, plane, -1.0)))
    return Continuity(
        max_gap=float(gap[kg]), rms_gap=float(np.sqrt(np.mean(gap ** 2))), where_gap=xa[kg].copy(),
        t_gap=float(ta[kg]), max_angle_deg=float(plane[ok].max(initial=0.0)), where_angle=xa[ka].copy(),
        t_angle=float(ta[ka]), max_oriented_angle_deg=float(oriented[ok].max(initial=0.0)),
        orientation_consistent=bool(np.all(cos[ok] > 0)), n_samples=n_samples,
        n_singular=int((~ok).sum()), segments=segments)


def _segment(face: TrimmedFace, index) -> PCurve:
    try:
        loop, seg = (int(i) for i in index)
        return face.loops[loop].segments[seg]
    except (TypeError, ValueError, IndexError) as exc:
        raise InputError(f"face {face.name or '?'}: no loop segment {index!r}") from exc


def boundary_continuity(face_a: TrimmedFace, segment_a, face_b: TrimmedFace, segment_b, *,
                        n_samples: int = 64) -> Continuity:
    """G0/G1 continuity along loop segment `segment_a` of `face_a` against `segment_b` of `face_b`.

    Parameters
    ----------
    face_a, face_b : TrimmedFace
    segment_a, segment_b : (int, int)
        (loop index, segment index) of the p-curves that run along the shared boundary.
    n_samples : int
        Samples along side A (>= 2).

    Returns
    -------
    Continuity

    Raises
    ------
    InputError
        Wrong types or segment indices.
    """
    for f in (face_a, face_b):
        if not isinstance(f, TrimmedFace):
            raise InputError(f"boundary_continuity needs TrimmedFaces; got {type(f).__name__}")
    sa, sb = _segment(face_a, segment_a), _segment(face_b, segment_b)
    return _continuity(_pcurve_side(face_a, sa), _pcurve_side(face_b, sb), n_samples,
                       (tuple(segment_a), tuple(segment_b)))


def edge_continuity(shell: Shell, edge_id: int, *, n_samples: int = 64) -> Continuity:
    """G0/G1 continuity across edge `edge_id` of a shell, between its two face sides.

    Raises
    ------
    InputError
        Not a Shell, an edge index out of range, or an edge without exactly two uses.
    """
    if not isinstance(shell, Shell):
        raise InputError(f"edge_continuity needs a Shell; got {type(shell).__name__}")
    if not 0 <= int(edge_id) < len(shell.edges):
        raise InputError(f"shell {shell.name or '?'} has no edge {edge_id} ({len(shell.edges)} edges)")
    uses = shell.edges[int(edge_id)].uses
    if len(uses) != 2:
        raise InputError(f"shell {shell.name or '?'} edge {edge_id} has {len(uses)} face sides; need 2")
    (fa, la, ga), (fb, lb, gb) = uses
    return boundary_continuity(shell.faces[fa], (la, ga), shell.faces[fb], (lb, gb), n_samples=n_samples)


def _coarse_gap(side_a: _Side, side_b: _Side) -> float:
    ta = np.linspace(side_a[3], side_a[4], 9)
    xa, _ = _points(side_a, ta)
    tb = np.linspace(side_b[3], side_b[4], 65)
    xb, _ = _points(side_b, tb)
    _, s = point_segment_closest(np.repeat(xa, 64, axis=0), np.tile(xb[:-1], (9, 1)), np.tile(xb[1:], (9, 1)))
    q = np.tile(xb[:-1], (9, 1)) + s[:, None] * np.tile(xb[1:] - xb[:-1], (9, 1))
    d = np.linalg.norm(q - np.repeat(xa, 64, axis=0), axis=1).reshape(9, 64).min(axis=1)
    return float(d.max())


def face_continuity(face_a: TrimmedFace, face_b: TrimmedFace, *, n_samples: int = 64) -> Continuity:
    """G0/G1 continuity between two faces along the loop segments they share.

    Segments are matched by `PCurve.edge_id` when both faces carry it;
    otherwise the pair of segments whose images lie closest (smallest
    one-sided gap on a coarse sample) is taken.

    Raises
    ------
    InputError
        Wrong types or a face without loops.
    """
    for f in (face_a, face_b):
        if not isinstance(f, TrimmedFace):
            raise InputError(f"face_continuity needs TrimmedFaces; got {type(f).__name__}")
        if not f.loops:
            raise InputError(f"face {f.name or '?'} has no loops; use surface_continuity for untrimmed surfaces")
    segs_a = [(i, j, s) for i, lp in enumerate(face_a.loops) for j, s in enumerate(lp.segments)]
    segs_b = [(i, j, s) for i, lp in enumerate(face_b.loops) for j, s in enumerate(lp.segments)]
    shared = [(a, b) for a in segs_a for b in segs_b if a[2].edge_id >= 0 and a[2].edge_id == b[2].edge_id]
    if not shared:
        scored = [(_coarse_gap(_pcurve_side(face_a, a[2]), _pcurve_side(face_b, b[2])), k, (a, b))
                  for k, (a, b) in enumerate((a, b) for a in segs_a for b in segs_b)]
        shared = [min(scored)[2]]
    results = [boundary_continuity(face_a, a[:2], face_b, b[:2], n_samples=n_samples) for a, b in shared]
    if len(results) == 1:
        return results[0]
    worst_gap = max(results, key=lambda r: r.max_gap)
    worst_ang = max(results, key=lambda r: r.max_angle_deg)
    n = sum(r.n_samples for r in results)
    return Continuity(
        max_gap=worst_gap.max_gap,
        rms_gap=float(np.sqrt(sum(r.rms_gap ** 2 * r.n_samples for r in results) / n)),
        where_gap=worst_gap.where_gap, t_gap=worst_gap.t_gap, max_angle_deg=worst_ang.max_angle_deg,
        where_angle=worst_ang.where_angle, t_angle=worst_ang.t_angle,
        max_oriented_angle_deg=max(r.max_oriented_angle_deg for r in results),
        orientation_consistent=all(r.orientation_consistent for r in results), n_samples=n,
        n_singular=sum(r.n_singular for r in results), segments=tuple(r.segments for r in results))


def surface_continuity(surface_a: NurbsSurface, surface_b: NurbsSurface, *, n_samples: int = 64) -> Continuity:
    """G0/G1 continuity between two surfaces along the pair of boundary iso-curves that lie closest.

    The four domain boundaries ("u0", "u1", "v0", "v1") of each surface are
    compared on a coarse sample; the pair with the smallest one-sided gap is
    measured. Normals are F_u x F_v of each surface (no orientation).

    Examples
    --------
    >>> a = NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]])
    >>> b = NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], [[[1, 0, 0], [1, 1, 0]], [[2, 0, 1], [2, 1, 1]]])
    >>> c = surface_continuity(a, b)
    >>> c.segments, round(c.max_gap, 12), round(c.max_angle_deg, 6)
    (('u1', 'u0'), 0.0, 45.0)
    """
    for s in (surface_a, surface_b):
        if not isinstance(s, NurbsSurface):
            raise InputError(f"surface_continuity needs NurbsSurfaces; got {type(s).__name__}")
    names = ("u0", "u1", "v0", "v1")
    scored = [(_coarse_gap(_iso_side(surface_a, a), _iso_side(surface_b, b)), a, b) for a in names for b in names]
    _, a, b = min(scored)
    return _continuity(_iso_side(surface_a, a), _iso_side(surface_b, b), n_samples, (a, b))
