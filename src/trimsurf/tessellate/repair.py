"""Basic CAD repair of a trimmed face (paper Sec. 4.1, Fig. 7, 8).

* Patch grids: a surface made of Bézier patches must have one degree per row
  and column (the readers assemble patch grids into one NURBS with
  `geom.bezier_grid_to_nurbs`, which elevates the degrees). Its domain values
  must be finite and increase strictly, and adjacent patches must share their
  boundary control points: `patch_grid_defect` checks the grid the VDA-FS
  reader recorded (`PatchGrid`: breakpoints, gap per shared boundary) and,
  for any surface, interior knots of multiplicity degree + 1 (a break in the
  surface). A face whose grid is broken where it is used (a gap above the
  tolerance on a patch boundary inside the trim) is rejected by name, with the
  patch pair and the gap; a broken boundary outside the trim is only reported.
* G1 continuity inside the trimmed area along internal C0 knot lines (knots of
  full multiplicity): checked, and a surface that fails is *flagged* (still
  tessellated, reported), as the paper colours such faces.
* Trim loops: consecutive segments whose ends differ within the tolerance are
  joined; a missing segment of zero 3D length (the "suit-case corner" of a
  degenerate surface, Fig. 8) is filled with a straight (u, v) segment; a gap
  that is neither makes the face unusable (reported by name, skipped).
  Loops of the trim polygon and self-overlaps are removed by
  `remove_polygon_loops` once the loops are polygons.

`repair_face` checks one face; `quick_repairs` does the same for all faces of a shell in batched passes
and leaves to `repair_face` only the faces it would change or reject.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..geom._nurbs_kernels import curve_points_kernel
from ..geom.nurbs import _clip, _homogeneous, read_only
from ..geom.predicates import polyline_self_intersections
from ..model import Loop, NurbsCurve, PCurve, TrimmedFace

__all__ = ["FaceRepair", "repair_face", "quick_repairs", "g1_defects", "patch_grid_defect", "remove_polygon_loops"]


@dataclass(eq=False)
class FaceRepair:
    """What repair did to one face.

    Attributes
    ----------
    face : TrimmedFace
        The repaired face (loops joined and filled); the input when nothing changed.
    status : {"ok", "repaired", "flagged", "failed"}
    messages : list of str
    filled : list of (loop, segment)
        Segments inserted to close a loop (they have no edge).
    max_g1_angle_deg : float
        Largest normal jump across an internal C0 knot line inside the trim (0 when none).
    """

    face: TrimmedFace
    status: str
    messages: list = field(default_factory=list)
    filled: list = field(default_factory=list)
    max_g1_angle_deg: float = 0.0


def _line(a, b) -> NurbsCurve:
    return NurbsCurve(1, [0.0, 0.0, 1.0, 1.0], np.array([a, b], dtype=np.float64))


_POLE_REL = 1e-6     # |Su x Sv| below this x its largest value along the knot line: a pole, skipped


def _full_knots(knots: np.ndarray, p: int, least: int) -> list:
    """(value, index of its first occurrence, count) of the distinct knots occurring at least `least`
    times (np.unique's values, return_index and return_counts, in a plain loop: knot vectors are short
    and this runs for every face)."""
    k = knots.tolist()
    out = []
    i = 0
    while i < len(k):
        j = i + 1
        while j < len(k) and k[j] == k[i]:
            j += 1
        if j < len(k) and not k[j] > k[i]:          # not sorted (np.unique sorts): its own path
            vals, first, counts = np.unique(knots, return_index=True, return_counts=True)
            return [(float(v), int(f), int(c)) for v, f, c in zip(vals, first, counts) if c >= least]
        if j - i >= least:
            out.append((k[i], i, j - i))
        i = j
    return out


def _normals_and_areas(su: np.ndarray, sv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(`geom.unit_normals`(su, sv), |su x sv|): one cross product for both (the same numbers as
    np.cross and np.linalg.norm: c0 = a1 b2 - a2 b1, ..., |c| = sqrt((c0^2 + c1^2) + c2^2))."""
    a0, a1, a2 = su[:, 0], su[:, 1], su[:, 2]
    b0, b1, b2 = sv[:, 0], sv[:, 1], sv[:, 2]
    nrm = np.empty(su.shape)
    nrm[:, 0] = a1 * b2 - a2 * b1
    nrm[:, 1] = a2 * b0 - a0 * b2
    nrm[:, 2] = a0 * b1 - a1 * b0
    sq = nrm * nrm
    length = np.sqrt((sq[:, 0] + sq[:, 1]) + sq[:, 2])
    pos = (length > 0)[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(pos, nrm / np.where(pos, length[:, None], 1.0), np.nan), length


def g1_defects(face: TrimmedFace, *, n: int = 33) -> float:
    """Largest angle (degrees) between the normals on both sides of an internal C0 knot line, inside the trim.

    Points where the parameterization is singular (a pole: |Su x Sv| = 0) are left out: the normal
    there is not defined by the derivatives, and the jump of the one-sided limits is no G1 defect.
    A surface without interior knots of multiplicity >= degree (no C0 knot line) has none: 0.0.
    """
    s = face.surface
    lines = [[v for v, _, _ in _full_knots(knots[p + 1:-p - 1], p, p)]
             for knots, p in ((s.knots_u, s.degree_u), (s.knots_v, s.degree_v))]
    side = _g1_samples(face, lines, n)
    if side is None:
        return 0.0
    return float(_g1_angles(*side, np.array([0, len(side[4])], dtype=np.int64))[0])


def _g1_samples(face: TrimmedFace, lines: list, n: int):
    """`g1_defects`' samples of one face with the C0 knot lines `lines` = [u values, v values]: per point
    inside the trim (u, v) just left and just right of its line, and per line its count of such points
    (the lines with none left out); None when there is none."""
    from ..quality.sampling import inside_face

    s = face.surface
    (u0, u1), (v0, v1) = s.domain
    sides = []          # per direction: (u, v) just left and just right of its knot lines, and on them
    for axis, (a, b), (c, d) in ((0, (u0, u1), (v0, v1)), (1, (v0, v1), (u0, u1))):
        if not lines[axis]:
            continue
        eps = 1e-7 * (b - a)
        k = np.array(lines[axis])
        mid = np.empty((len(k), n, 2))
        mid[:, :, axis] = k[:, None]
        mid[:, :, 1 - axis] = np.linspace(c, d, n)
        uv_l, uv_r = mid.copy(), mid.copy()
        uv_l[:, :, axis] = (k - eps)[:, None]
        uv_r[:, :, axis] = (k + eps)[:, None]
        sides.append((uv_l, uv_r, mid))
    if not sides:
        return None
    # one inside test and one evaluation on each side for all lines (the same numbers per point)
    uv_l, uv_r, mid = sides[0] if len(sides) == 1 else (np.concatenate([x[q] for x in sides]) for q in range(3))
    ins = inside_face(face, mid.reshape(-1, 2), n_per_segment=16).reshape(len(mid), n)
    if not ins.any():
        return None
    flat = ins.ravel()
    m = int(flat.sum())
    # both sides in one evaluation (point by point: the same numbers as one call per side)
    dd = s.derivatives(np.concatenate([uv_l.reshape(-1, 2)[flat], uv_r.reshape(-1, 2)[flat]]), 1)
    cnt = ins.sum(axis=1)
    return dd[1, 0, :m], dd[0, 1, :m], dd[1, 0, m:], dd[0, 1, m:], cnt[cnt > 0]


def _g1_samples_faces(items: list, n: int) -> tuple:
    """`_g1_samples(face, lines, n)` of every (face, lines) in `items`, the faces one after the other as
    `quick_repairs` concatenates them: ((su_l, sv_l, su_r, sv_r, cnt), per face its number of lines with
    points (0: `_g1_samples` returns None)). The sample points of all lines at once (np.linspace's
    arithmetic per line: arange x step + start, the end exact), the inside test per face, the
    derivatives per face in one call of the compiled kernel `surface_derivatives` calls (`seams._derivatives`:
    its arguments prepared once per surface, the parameters clipped as it clips them), so the numbers of
    `_g1_samples`; per face where a line's step is 0 (np.linspace's other path), a surface is
    not a NurbsSurface or a point not finite."""
    from ..model import NurbsSurface
    from ..quality.sampling import inside_face
    from .seams import _derivatives

    rows = []           # per line: face, axis, knot value, its axis' domain (a, b), the other's (c, d)
    for q, (face, lines) in enumerate(items):
        (u0, u1), (v0, v1) = face.surface.domain
        rows.extend((q, 0, k, u0, u1, v0, v1) for k in lines[0])
        rows.extend((q, 1, k, v0, v1, u0, u1) for k in lines[1])
    r = np.array(rows, dtype=np.float64).reshape(-1, 7)
    q_of, axis, k, a, b, c, d = (r[:, i] for i in range(7))
    q_of = q_of.astype(np.int64)
    step = (d - c) / (n - 1)
    surfaces = [face.surface for face, _ in items]
    if not len(r) or (step == 0).any() or not all(type(s) is NurbsSurface for s in surfaces):
        return _g1_samples_per_face(items, n)
    lin = np.arange(n, dtype=np.float64)[None, :] * step[:, None]
    lin += c[:, None]
    lin[:, -1] = d
    along = (axis == 0)[:, None]
    eps = 1e-7 * (b - a)
    kk = np.broadcast_to(k[:, None], lin.shape)
    mid = np.empty((len(r), n, 2))
    mid[:, :, 0] = np.where(along, kk, lin)
    mid[:, :, 1] = np.where(along, lin, kk)
    uv_l, uv_r = mid.copy(), mid.copy()
    for side, x in ((uv_l, k - eps), (uv_r, k + eps)):
        xx = np.broadcast_to(x[:, None], lin.shape)
        side[:, :, 0] = np.where(along, xx, lin)
        side[:, :, 1] = np.where(along, lin, xx)
    ins = np.empty((len(r), n), dtype=bool)
    cuts = np.r_[0, np.cumsum(np.bincount(q_of, minlength=len(items)))].tolist()
    for q, (face, _) in enumerate(items):
        if cuts[q + 1] > cuts[q]:
            ins[cuts[q]:cuts[q + 1]] = inside_face(face, mid[cuts[q]:cuts[q + 1]].reshape(-1, 2),
                                                   n_per_segment=16).reshape(-1, n)
    flat = ins.ravel()
    cnt = ins.sum(axis=1)
    pts = np.concatenate([uv_l.reshape(-1, 2)[flat], uv_r.reshape(-1, 2)[flat]])
    if not np.isfinite(pts).all():
        return _g1_samples_per_face(items, n)
    n_lines = np.bincount(q_of[cnt > 0], minlength=len(items)).astype(np.int64)
    m = len(pts) // 2
    fo = np.repeat(q_of, cnt)
    # per face its points (both sides) in one evaluation
    order = np.argsort(np.concatenate([fo, fo]), kind="stable")
    at = np.searchsorted(np.concatenate([fo, fo])[order], np.arange(len(items) + 1)).tolist()
    su, sv = np.empty((len(pts), 3)), np.empty((len(pts), 3))
    for q in range(len(items)):
        if at[q + 1] > at[q]:
            r = order[at[q]:at[q + 1]]
            dd = _derivatives(surfaces[q], pts[r], 1)
            su[r], sv[r] = dd[1, 0], dd[0, 1]
    return (su[:m], sv[:m], su[m:], sv[m:], cnt[cnt > 0]), n_lines


def _g1_samples_per_face(items: list, n: int) -> tuple:
    """`_g1_samples_faces` face by face (`_g1_samples`): its reference, and its path for the rest."""
    side = [_g1_samples(face, lines, n) for face, lines in items]
    n_lines = np.array([0 if x is None else len(x[4]) for x in side], dtype=np.int64).reshape(-1)
    side = [x for x in side if x is not None]
    if not side:
        e = np.zeros((0, 3))
        return (e, e, e, e, np.zeros(0, dtype=np.int64)), n_lines
    return tuple(np.concatenate([x[i] for x in side]) for i in range(5)), n_lines


def _g1_angles(su_l, sv_l, su_r, sv_r, cnt, face_start) -> np.ndarray:
    """`g1_defects`' largest angle per face from its samples (`_g1_samples`, several faces one after
    the other: face f has the lines face_start[f] .. face_start[f + 1] - 1 of cnt); elementwise, so the
    same numbers whether the faces come one by one or together."""
    nl, area_l = _normals_and_areas(su_l, sv_l)
    nr, area_r = _normals_and_areas(su_r, sv_r)
    cos = np.clip(np.einsum("ij,ij->i", nl, nr), -1.0, 1.0)
    # a pole (|Su x Sv| = 0, e.g. the axis of a surface of revolution) has no normal to compare: per line,
    # the points whose area is above _POLE_REL x the line's largest on both sides
    start = np.r_[0, np.cumsum(cnt)[:-1]]
    regular = np.ones(len(cos), dtype=bool)
    for area in (area_l, area_r):
        top = np.maximum(np.maximum.reduceat(area, start), 0.0)
        regular &= area > np.repeat(_POLE_REL * np.maximum(top, 1e-300), cnt)
    ok = np.isfinite(cos) & regular
    ang = np.full(len(cos), -np.inf)
    ang[ok] = np.degrees(np.arccos(cos[ok]))
    # per face the largest (0 where no point is left)
    pts = np.r_[0, np.cumsum(cnt)][face_start]
    out = np.zeros(len(face_start) - 1)
    has = pts[1:] > pts[:-1]
    if has.any():
        out[has] = np.maximum(np.maximum.reduceat(ang, pts[:-1][has]), 0.0)
    return out


def _inside_trim(face: TrimmedFace, u_range, v_range, n: int = 17) -> bool:
    """Whether some point of the (u, v) segment from (u0, v0) to (u1, v1) lies inside the face's trim."""
    if not face.loops:
        return True
    from ..quality.sampling import inside_face

    w = np.linspace(0.0, 1.0, n)
    uv = np.column_stack([u_range[0] + w * (u_range[1] - u_range[0]), v_range[0] + w * (v_range[1] - v_range[0])])
    return bool(inside_face(face, uv, n_per_segment=16).any())


def _knot_breaks(s):
    """Breaks of a surface at interior knots of multiplicity degree + 1: (gap, axis, knot value), largest first."""
    out = []
    for axis, knots, p in ((0, s.knots_u, s.degree_u), (1, s.knots_v, s.degree_v)):
        lo, hi = knots[p], knots[-p - 1]
        for v, f, c in _full_knots(knots, p, p + 1):
            if lo < v < hi:
                cp = np.moveaxis(s.control_points, axis, 0)
                out.append((float(np.linalg.norm(cp[f - 1] - cp[f], axis=-1).max()), axis, float(v)))
    return sorted(out, reverse=True)


def patch_grid_defect(face: TrimmedFace, tolerance: float) -> tuple[str | None, list]:
    """Check the domain values and shared boundary control points of a face's patch grid (paper Sec. 4.1).

    Parameters
    ----------
    face : TrimmedFace
    tolerance : float
        Largest distance allowed between the shared boundary control points of adjacent patches.

    Returns
    -------
    failure : str or None
        Why the face cannot be tessellated (it names the face, the SURF, the patch pair and the gap),
        or None.
    notes : list of str
        Broken boundaries outside the trim (harmless: the trimmed face does not use them).
    """
    name = face.name or "face"
    s = face.surface
    notes: list = []
    grid = getattr(s, "patch_grid", None)      # recorded by the VDA-FS reader (`io._vdafs.PatchGrid`)
    if grid is not None:
        problem = grid.breaks_problem()
        if problem:
            return f"{name}: {grid.where}: {problem}; the patch grid has no valid domain", notes
        for gap, a, b, (ur, vr) in sorted(grid.seams(), key=lambda x: -x[0]):
            if gap <= tolerance:
                break
            where = f"{name}: {grid.where}: adjacent patches {a} and {b} do not share their boundary " \
                    f"control points ({gap:.3g} apart > tolerance {tolerance:.3g})"
            if _inside_trim(face, ur, vr):
                return where + " inside the trimmed area; cannot be repaired", notes
            notes.append(where + " outside the trimmed area; ignored")
    (u0, u1), (v0, v1) = s.domain
    for gap, axis, k in _knot_breaks(s):
        if gap <= tolerance:
            break
        ur, vr = ((k, k), (v0, v1)) if axis == 0 else ((u0, u1), (k, k))
        where = (f"{name}: the surface breaks apart at {'uv'[axis]} = {k:.6g} (a knot of multiplicity "
                 f"degree + 1; {gap:.3g} apart > tolerance {tolerance:.3g})")
        if _inside_trim(face, ur, vr):
            return where + " inside the trimmed area; cannot be repaired", notes
        notes.append(where + " outside the trimmed area; ignored")
    return None, notes


def _ends(seg: PCurve) -> np.ndarray:
    """seg.curve.evaluate([seg.t0, seg.t1]) (the same numbers: `geom.curve_derivatives`' compiled path
    without its wrappers, which cost more than the two points on a face's few segments)."""
    c = seg.curve
    knots, cp = c.knots, c.control_points           # (t0, t1 finite: PCurve checks them)
    if knots.flags.writeable or not knots.flags.c_contiguous or knots.dtype != np.float64:
        knots = read_only(knots)
    p = int(c.degree)
    t = _clip(np.array([seg.t0, seg.t1], dtype=np.float64), knots[p], knots[-p - 1])
    rational = c.weights is not None
    if rational or cp.flags.writeable or not cp.flags.c_contiguous or cp.dtype != np.float64:
        cp = read_only(_homogeneous(cp, c.weights))
    out = np.empty((2, cp.shape[-1] - rational))
    curve_points_kernel(p, knots, cp, rational, t, out)
    return out


_LINE17 = np.linspace(0, 1, 17)
_LINE17.flags.writeable = False


def _gap_kind(s, a: np.ndarray, b: np.ndarray, span: float, tolerance: float) -> tuple:
    """What `repair_face` makes of a segment end a and the next segment's start b (in (u, v)) that are not
    the same point by its first test: ("joined" | "fill" | "open", gap in (u, v), gap in 3D or None).

    Joined: a gap below 1e-9 x the domain, or ends that differ within tolerance in 3D (joined by taking
    the next start); fill: a missing segment of zero 3D length (suit-case corner, Fig. 8); open: neither.
    """
    return _gap_kinds(s, a[None], b[None], span, tolerance)[0]


def _gap_kinds(s, a: np.ndarray, b: np.ndarray, span: float, tolerance: float) -> list:
    """`_gap_kind` of the joints a[j] -> b[j] (J, 2) of one surface, its points in one evaluation (point
    by point: the same numbers as one evaluation per joint), each joint's norms as `_gap_kind` takes them."""
    gap_uv = [float(np.linalg.norm(bj - aj)) for aj, bj in zip(a, b)]
    far = [j for j, g in enumerate(gap_uv) if not g <= 1e-9 * span]
    out = [("joined", g, None) for g in gap_uv]
    if not far:
        return out
    af, bf = a[far], b[far]
    m = len(far)
    uv = np.empty((m, 19, 2))
    uv[:, 0], uv[:, 1] = af, bf
    uv[:, 2:] = af[:, None, :] + _LINE17[None, :, None] * (bf - af)[:, None, :]
    pts = s.evaluate(uv.reshape(-1, 2)).reshape(m, 19, 3)
    for q, j in enumerate(far):
        pa, pb = pts[q, 0], pts[q, 1]
        gap3 = float(np.linalg.norm(pb - pa))
        spread = float(np.linalg.norm(pts[q, 2:] - pa, axis=1).max())
        big = gap_uv[j] > 1e-4 * span
        if spread <= 1e-3 * tolerance and big:
            out[j] = ("fill", gap_uv[j], gap3)
        elif gap3 <= tolerance:
            out[j] = ("joined", gap_uv[j], gap3)
        else:
            out[j] = ("open", gap_uv[j], gap3)
    return out


def repair_face(face: TrimmedFace, *, tolerance: float, g1_angle_deg: float = 1.0) -> FaceRepair:
    """Check and repair one face (paper Sec. 4.1).

    Parameters
    ----------
    face : TrimmedFace
    tolerance : float
        3D distance within which loop ends are joined and a segment counts as degenerate.
    g1_angle_deg : float
        Normal jump above which a C0 knot line inside the trim flags the face.

    Returns
    -------
    FaceRepair
        ``status == "failed"`` when the face cannot be tessellated (its message says why).
    """
    msgs: list[str] = []
    name = face.name or "face"
    s = face.surface
    if not np.all(np.isfinite(s.control_points)):
        return FaceRepair(face, "failed", [f"{name}: surface has non-finite control points"])
    (u0, u1), (v0, v1) = s.domain
    if not (u1 > u0 and v1 > v0):
        return FaceRepair(face, "failed", [f"{name}: empty parameter domain"])
    failure, notes = patch_grid_defect(face, tolerance)
    if failure:
        return FaceRepair(face, "failed", [failure])
    msgs.extend(notes)
    loops, filled, status = [], [], "ok"
    span = max(u1 - u0, v1 - v0)
    for li, loop in enumerate(face.loops):
        segs = list(loop.segments)
        # each segment's start and end in one evaluation (the same points as .start / .end)
        ends = [_ends(sg) for sg in segs]
        out: list[PCurve] = []
        for si, seg in enumerate(segs):
            out.append(seg)
            a, b = ends[si][1], ends[(si + 1) % len(segs)][0]
            # joined ends: the same point, or a gap below 1e-9 x the domain (decided without the norm where
            # sqrt(2) x the larger coordinate difference, with room for the norm's rounding, is below it)
            d0, d1 = abs(float(b[0] - a[0])), abs(float(b[1] - a[1]))
            if d0 == 0.0 and d1 == 0.0 or 1.4142135623730951 * (1.0 + 1e-12) * max(d0, d1) <= 1e-9 * span:
                continue
            kind, gap_uv, gap3 = _gap_kind(s, a, b, span, tolerance)
            if kind == "joined":
                continue
            if kind == "fill":
                # a missing segment of zero 3D length (suit-case corner, Fig. 8): fill it
                if True:
                    out.append(PCurve(_line(a, b), 0.0, 1.0))
                    filled.append((li, len(out) - 1))
                    msgs.append(f"{name}: loop {li} closed after segment {si} "
                                f"(gap {gap_uv:.3g} in (u, v), {gap3:.3g} in 3D)")
                    status = "repaired"
            else:
                return FaceRepair(face, "failed", [f"{name}: trim loop {li} is open after segment {si} "
                                                   f"(gap {gap3:.3g} in 3D > tolerance {tolerance:.3g})"])
        loops.append(out)
    # (new Loop objects only when a segment was inserted: otherwise the face is returned as it was)
    repaired = (TrimmedFace(s, tuple(Loop(tuple(out)) for out in loops), face.same_sense, face.name, face.tolerance)
                if filled else face)
    g1 = g1_defects(repaired)
    if g1 > g1_angle_deg:
        msgs.append(f"{name}: not G1 inside the trim (normals jump {g1:.2f} deg across a patch boundary)")
        status = "flagged"
    return FaceRepair(repaired, status, msgs, filled, g1)


_SQRT2_ROOM = 1.4142135623730951 * (1.0 + 1e-12)


def quick_repairs(faces: list, *, tolerance: float, g1_angle_deg: float = 1.0) -> list:
    """`repair_face` of a shell's faces whose trim loops need nothing, batched; None for the others
    (their `repair_face` decides: the shell calls it for those only).

    A face is taken here when its control points are finite, its domain is not empty, its patch grid
    and knots have no defect (`patch_grid_defect`, called where the face has a patch grid or a knot of
    multiplicity degree + 1: no failure; its notes are kept) and every joint of its loops is joined as
    `repair_face` joins it: the same point or a gap below 1e-9 x the domain by its first test (the
    segment ends of all faces in one compiled call, `_chunk_kernels.pcurve_ends_kernel`: `_ends`'
    numbers), else by `_gap_kinds` (the gap below 1e-9 x the domain, or within the tolerance in 3D).
    Then `repair_face` changes no loop: its result is the face as it was with its notes and the G1 check,
    here for all faces together (`_knot_runs` for the knot lines, `_g1_samples` per face, `_g1_angles`
    over all: `g1_defects`' numbers). Returns one FaceRepair or None per face.
    """
    from ._chunk_kernels import pcurve_ends_kernel
    from ..model.trim import _pcurve_rows

    out: list = [None] * len(faces)
    cand, spans, seg_face, nxt = [], [], [], []
    segs: list = []
    finite = _all_finite([face.surface.control_points for face in faces])
    for fi, face in enumerate(faces):
        s = face.surface
        (u0, u1), (v0, v1) = s.domain
        if not (u1 > u0 and v1 > v0) or not finite[fi]:
            continue
        cand.append(fi)
        spans.append(max(u1 - u0, v1 - v0))
        for loop in face.loops:
            o, m = len(segs), len(loop.segments)
            if not m:
                continue
            segs.extend(loop.segments)
            nxt.extend(range(o + 1, o + m))
            nxt.append(o)
            seg_face.extend([len(cand) - 1] * m)
    joined = np.ones(len(cand), dtype=bool)
    if segs:
        rows, ck, cpw = _pcurve_rows([sg.curve for sg in segs])
        t = np.array([(sg.t0, sg.t1) for sg in segs], dtype=np.float64).reshape(-1, 2)
        ends = np.empty((len(segs), 2, 2))
        pcurve_ends_kernel(rows, read_only(ck), read_only(cpw), t, ends)
        a, b = ends[:, 1], ends[np.array(nxt, dtype=np.int64), 0]
        d0, d1 = np.abs(b[:, 0] - a[:, 0]), np.abs(b[:, 1] - a[:, 1])
        sf = np.array(seg_face, dtype=np.int64)
        ok = (d0 == 0.0) & (d1 == 0.0) | (_SQRT2_ROOM * np.maximum(d0, d1) <= 1e-9 * np.array(spans)[sf])
        # the other joints as repair_face decides them (one by one: few); a face with one to fill or open
        # is repair_face's
        bad = np.flatnonzero(~ok)
        for c in np.unique(sf[bad]).tolist():
            i = bad[sf[bad] == c]
            kinds = _gap_kinds(faces[cand[c]].surface, a[i], b[i], spans[c], tolerance)
            joined[c] = all(k[0] == "joined" for k in kinds)
    # the knots of all surfaces at once: per face the C0 knot lines g1_defects samples and whether
    # patch_grid_defect has anything to look at (a patch grid, or a knot of multiplicity degree + 1)
    take = [c for c in range(len(cand)) if joined[c]]
    surfs = [faces[cand[c]].surface for c in take]
    g1_lines, busy, odd = [], np.zeros(len(take), dtype=bool), np.zeros(len(take), dtype=bool)
    for ax in range(2):
        knots = [f.knots_v if ax else f.knots_u for f in surfs]
        deg = np.fromiter(((f.degree_v if ax else f.degree_u) for f in surfs), dtype=np.int64, count=len(surfs))
        # C0 lines: runs of >= p equal values in knots[p + 1:-p - 1] (`_full_knots`)
        owner, value, count, unsorted = _knot_runs([k[p + 1:-p - 1] for k, p in zip(knots, deg.tolist())])
        sel = count >= deg[owner]
        g1_lines.append((owner[sel], value[sel]))
        odd[unsorted] = True        # (knots not sorted: repair_face)
        # breaks: runs of >= p + 1 equal values strictly inside (knots[p], knots[-p - 1]) (`_knot_breaks`)
        owner, value, count, unsorted = _knot_runs(knots)
        lo = np.array([k[p] for k, p in zip(knots, deg.tolist())], dtype=np.float64).reshape(-1)
        hi = np.array([k[-p - 1] for k, p in zip(knots, deg.tolist())], dtype=np.float64).reshape(-1)
        brk = (count >= deg[owner] + 1) & (lo[owner] < value) & (value < hi[owner])
        busy[owner[brk]] = True
        odd[unsorted] = True
    lines_of = [[[], []] for _ in take]
    for ax, (owner, value) in enumerate(g1_lines):
        for o, v in zip(owner.tolist(), value.tolist()):
            lines_of[o][ax].append(v)
    face_g1 = np.zeros(len(take))
    with_lines, g1_items = [], []
    for q, c in enumerate(take):
        face = faces[cand[c]]
        if odd[q]:
            continue
        if busy[q] or getattr(face.surface, "patch_grid", None) is not None:
            failure, notes = patch_grid_defect(face, tolerance)
            if failure:
                continue
        else:
            notes = []
        if lines_of[q][0] or lines_of[q][1]:
            g1_items.append((face, lines_of[q]))
            with_lines.append(q)
        out[cand[c]] = (face, notes)
    if g1_items:
        # the samples of all faces with C0 knot lines in one evaluation (`_g1_samples_faces`)
        side, lines_per_face = _g1_samples_faces(g1_items, 33)
        has = lines_per_face > 0
        if has.any():
            fs = np.r_[0, np.cumsum(lines_per_face[has])]
            face_g1[np.asarray(with_lines, dtype=np.int64)[has]] = _g1_angles(*side, fs)
    for q, c in enumerate(take):
        fi = cand[c]
        if out[fi] is None:
            continue
        face, notes = out[fi]
        msgs = list(notes)
        status = "ok"
        g1 = float(face_g1[q])
        if g1 > g1_angle_deg:
            msgs.append(f"{face.name or 'face'}: not G1 inside the trim (normals jump {g1:.2f} deg across a patch "
                        f"boundary)")
            status = "flagged"
        out[fi] = FaceRepair(face, status, msgs, [], g1)
    return out


def _all_finite(arrays: list) -> list:
    """[bool(np.all(np.isfinite(a))) for a in arrays], in one pass over the arrays joined (float64
    arrays, none empty; else one by one)."""
    if not arrays or not all(type(a) is np.ndarray and a.dtype == np.float64 and a.size for a in arrays):
        return [bool(np.all(np.isfinite(a))) for a in arrays]
    sizes = np.fromiter((a.size for a in arrays), dtype=np.int64, count=len(arrays))
    flags = np.isfinite(np.concatenate([a.ravel() for a in arrays]))
    return np.logical_and.reduceat(flags, np.cumsum(sizes) - sizes).tolist()


def _knot_runs(knots: list) -> tuple:
    """The runs of equal values of several knot vectors in one pass: (owner, value, count) per run, in
    order, and the owners whose vector is not sorted (`_full_knots` takes np.unique's path there)."""
    n = len(knots)
    lens = np.fromiter(map(len, knots), dtype=np.int64, count=n)
    if not lens.sum():
        e = np.zeros(0, dtype=np.int64)
        return e, np.zeros(0), e, e
    k = np.concatenate(knots)
    owner = np.repeat(np.arange(n), lens)
    same = owner[1:] == owner[:-1]
    new = np.ones(len(k), dtype=bool)
    new[1:] = (k[1:] != k[:-1]) | ~same
    starts = np.flatnonzero(new)
    count = np.diff(np.r_[starts, len(k)])
    unsorted = np.unique(owner[1:][same & ~(k[1:] >= k[:-1])])
    return owner[starts], k[starts], count, unsorted


def _area(p: np.ndarray) -> float:
    q = np.roll(p, -1, axis=0)
    return 0.5 * float(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))


def remove_polygon_loops(poly: np.ndarray) -> np.ndarray:
    """Indices of the points of a closed polygon that remain after cutting out its small loops.

    Where two segments cross, the sub-loop of smaller area is removed; repeated until the polygon is simple (or 32 rounds).

    Examples
    --------
    >>> import numpy as np
    >>> bow = np.array([[0, 0], [2, 0], [2, 2], [2.5, 1.5], [1.5, 1.5], [2, 2.5], [0, 2]], float)
    >>> remove_polygon_loops(bow).tolist()
    [0, 1, 4, 5, 6]
    """
    idx = np.arange(len(poly))
    for _ in range(32):
        if len(idx) < 4:
            break
        x = polyline_self_intersections(poly[idx], closed=True)
        if not len(x):
            break
        i, j = sorted((int(x[0][0]), int(x[0][1])))
        # points i+1 .. j form one sub-loop, the rest the other: cut the one of smaller area
        inner = idx[i + 1:j + 1]
        outer = np.r_[idx[:i + 1], idx[j + 1:]]
        a_in = abs(_area(poly[inner])) if len(inner) > 2 else 0.0
        a_out = abs(_area(poly[outer])) if len(outer) > 2 else 0.0
        idx = outer if a_in <= a_out else inner
    return idx
