"""Reading a VDA-FS file into a `Shell`."""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import TrimsurfWarning, VdafsReadError
from ...geom.knots import (
    bezier_curve_to_nurbs,
    bezier_grid_to_nurbs,
)
from ...geom.predicates import points_in_polygons, polygon_signed_area
from ...model import Loop, NurbsCurve, NurbsSurface, PCurve, Shell, TrimmedFace
from ...tolerance import Tolerance, default_tolerance
from ._entities import _PARSERS, _Curve, _Face, _Params, _Surf
from ._records import _records, _statements

# samples per CONS when a trim loop's sense and containment are measured
_ORIENT_SAMPLES = 32
_SKIPPED = frozenset({"POINT", "PSET", "MDI", "CIRCLE", "TOP", "GROUP", "SET", "TMAT", "TLIST"})



def _warn(message: str) -> None:
    warnings.warn(message, TrimsurfWarning, stacklevel=3)


@dataclass(frozen=True, eq=False)
class PatchGrid:
    """A SURF's patch grid as read: the paper's check of domain values and shared control points (Sec. 4.1).

    The reader records it and builds the surface anyway; `trimsurf.tessellate.repair`
    rejects a face whose grid is broken where the face uses it (by name, with the
    patch pair and the gap), so one broken SURF does not make the whole file unreadable.

    Attributes
    ----------
    where : str
        ``"file:line: SURF name"``.
    s_breaks, t_breaks : (nps + 1,), (npt + 1,) float64
        The SURF's global parameters (domain values) as read.
    gaps_s : (nps - 1, npt) float64
        Largest distance between the shared boundary control points of patches
        (i, j) and (i + 1, j) (orders unified by degree elevation first).
    gaps_t : (nps, npt - 1) float64
        The same for patches (i, j) and (i, j + 1).
    """

    where: str
    s_breaks: np.ndarray
    t_breaks: np.ndarray
    gaps_s: np.ndarray
    gaps_t: np.ndarray

    def breaks_problem(self) -> str:
        """Why the domain values are unusable (``""`` when they are finite and increase strictly)."""
        for what, br in (("s", self.s_breaks), ("t", self.t_breaks)):
            if not np.all(np.isfinite(br)):
                return f"its {what} breakpoints are not finite: {br.tolist()}"
            bad = np.flatnonzero(np.diff(br) <= 0)
            if len(bad):
                k = int(bad[0])
                return (f"its {what} breakpoints do not increase strictly: {what}({k + 1}) = {float(br[k])!r}, "
                        f"{what}({k + 2}) = {float(br[k + 1])!r}")
        return ""

    def seams(self):
        """Every shared patch boundary: (gap, patch_a, patch_b, (u-range, v-range) of the boundary), 1-based patches."""
        s, t = self.s_breaks, self.t_breaks
        for (i, j), g in np.ndenumerate(self.gaps_s):
            yield float(g), (i + 1, j + 1), (i + 2, j + 1), ((s[i + 1], s[i + 1]), (t[j], t[j + 1]))
        for (i, j), g in np.ndenumerate(self.gaps_t):
            yield float(g), (i + 1, j + 1), (i + 1, j + 2), ((s[i], s[i + 1]), (t[j + 1], t[j + 1]))


@dataclass(frozen=True, slots=True, eq=False)
class PatchGridSurface(NurbsSurface):
    """The NURBS surface of a VDA-FS SURF, carrying the reader's `PatchGrid` for repair."""

    patch_grid: PatchGrid | None = None


def _seam_gaps(patches: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Largest distance between the shared boundary control points of adjacent patches, per pair."""
    gs = np.linalg.norm(patches[:-1, :, -1] - patches[1:, :, 0], axis=-1).max(axis=-1)
    gt = np.linalg.norm(patches[:, :-1, :, -1] - patches[:, 1:, :, 0], axis=-1).max(axis=-1)
    return gs, gt


def _close_seams(patches: np.ndarray) -> np.ndarray:
    """Adjacent Bezier patches made to share their boundary rows (the average of both sides)."""
    out = patches.copy()
    if out.shape[0] > 1:
        mean = 0.5 * (out[:-1, :, -1] + out[1:, :, 0])
        out[:-1, :, -1] = mean
        out[1:, :, 0] = mean
    if out.shape[1] > 1:
        mean = 0.5 * (out[:, :-1, :, -1] + out[:, 1:, :, 0])
        out[:, :-1, :, -1] = mean
        out[:, 1:, :, 0] = mean
    return out


def _surface(surf: _Surf, where: str, tol: Tolerance) -> NurbsSurface:
    """The SURF as one NURBS (boundary rows averaged), with its `PatchGrid`; warns on a broken grid.

    Breakpoints that do not increase strictly are replaced by 0, 1, 2, ... so
    that a surface exists; repair rejects every face on it.
    """
    gs, gt = _seam_gaps(surf.patches)
    grid = PatchGrid(where, surf.s_breaks, surf.t_breaks, gs, gt)
    s_br, t_br = surf.s_breaks, surf.t_breaks
    problem = grid.breaks_problem()
    if problem:
        _warn(f"{where}: {problem}; faces on it cannot be tessellated")
        s_br, t_br = np.arange(len(s_br), dtype=np.float64), np.arange(len(t_br), dtype=np.float64)
    worst = max([g for g, *_ in grid.seams()], default=0.0)
    if worst > tol.point:
        g, a, b, _ = max(grid.seams(), key=lambda x: x[0])
        _warn(f"{where}: adjacent patches {a} and {b} do not meet: largest gap {g:.3g} "
              f"(tolerance {tol.point:.3g}); the boundary control points were averaged")
    pu, pv, ku, kv, cp, _ = bezier_grid_to_nurbs(_close_seams(surf.patches), s_br, t_br)
    return PatchGridSurface(pu, pv, ku, kv, cp, patch_grid=grid)


def _curve(curve: _Curve, where: str, tol_point: float) -> NurbsCurve:
    """Bezier segments with C0 joints -> B-spline with interior knots of multiplicity p.

    Joints whose two segment ends differ are averaged (with a warning above `tol_point`).
    """
    segs = curve.segments.copy()
    if len(segs) > 1:
        ends, starts = segs[:-1, -1], segs[1:, 0]
        gaps = np.linalg.norm(ends - starts, axis=1)
        mean = 0.5 * (ends + starts)
        segs[:-1, -1] = mean
        segs[1:, 0] = mean
        worst = int(np.argmax(gaps))
        if gaps[worst] > tol_point:
            _warn(f"{where}: segments {worst + 1} and {worst + 2} do not meet: gap {gaps[worst]:.3g} "
                  f"(tolerance {tol_point:.3g}); the joint was averaged")
    p, knots, cp, _ = bezier_curve_to_nurbs(segs, curve.breaks)
    return NurbsCurve(p, knots, cp)


def _reparameterized(curve: NurbsCurve, w_range: tuple[float, float], s_range: tuple[float, float]) -> NurbsCurve:
    """The curve c(s) as a curve in w, with s = s1 + (w - w0) (s2 - s1) / (w1 - w0)."""
    (w0, w1), (s1, s2) = w_range, s_range
    if (s1, s2) == (w0, w1):
        return curve
    knots = w0 + (curve.knots - s1) * ((w1 - w0) / (s2 - s1))
    if s2 < s1:
        return NurbsCurve(curve.degree, knots[::-1], curve.control_points[::-1])
    return NurbsCurve(curve.degree, knots, curve.control_points)


def _default_tolerance(surfs: dict[str, _Surf]) -> Tolerance:
    if not surfs:
        return Tolerance()
    pts = np.concatenate([s.patches.reshape(-1, 3) for s in surfs.values()])
    return default_tolerance(float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0))))


def read(path: str | os.PathLike, *, tol: Tolerance | None = None) -> Shell:
    """Read the SURF, CURVE, CONS and FACE entities of a VDA-FS 2.0 file into a `Shell`.

    Parameters
    ----------
    path : str or os.PathLike
        A VDA-FS file (records of at most 80 columns).
    tol : Tolerance, optional
        Gaps above ``tol.point`` (between patches of a SURF or segments of a
        CURVE) and above ``tol.parameter`` times the larger side of a SURF's
        domain (between CONS in a trim loop, segments of a CONS) are reported.
        Default: `default_tolerance` of the control points' bounding-box diagonal.

    Returns
    -------
    Shell
        One `TrimmedFace` per FACE (named after it, loops in file order: the
        outer boundary first) and one untrimmed face per SURF that no FACE uses;
        no edges. The p-curves' edge curves are the CONS's CURVEs.

    Raises
    ------
    VdafsReadError
        Empty, truncated or malformed file (records, statements, numbers), or a
        FACE or CONS that refers to a missing SURF, CONS or CURVE.

    Warns
    -----
    TrimsurfWarning
        A trim loop with a gap, patches or segments that do not meet, a trim
        range outside its CONS, a CONS of zero length in a loop, an entity
        type outside the subset.

    Notes
    -----
    See the module docstring for the layout and the exactness of the
    monomial to Bezier conversion.

    Examples
    --------
    >>> import trimsurf.io._vdafs as vdafs, pathlib, tempfile
    >>> text = [
    ...     "DEMO     = HEADER / 1",
    ...     "a header record",
    ...     "S1       = SURF / 1, 1, 0., 1., 0., 1.,",
    ...     " 2, 2, 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.",
    ...     "DEMO     = END"]
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "demo.vda"
    >>> _ = path.write_text("\\n".join(text) + "\\n")
    >>> face = vdafs.read(path).faces[0]
    >>> face.surface.evaluate([[0.5, 0.25]])   # x = s, y = t, z = s t
    array([[0.5  , 0.25 , 0.125]])
    """
    path = Path(path)
    statements = _statements(path, _records(path))
    entities: dict[str, dict] = {k: {} for k in _PARSERS}
    lines: dict[str, int] = {}
    order: list[tuple[str, str]] = []
    for st in statements:
        if st.keyword in ("HEADER", "END", "BEGINSET", "ENDSET"):
            continue
        if st.keyword in _SKIPPED:
            if st.keyword == "TLIST":
                _warn(f"{path}:{st.line}: TLIST {st.name}: transformed copies are not created")
            continue
        parser = _PARSERS.get(st.keyword)
        if parser is None:
            _warn(f"{path}:{st.line}: {st.keyword} {st.name}: entity type outside the VDA-FS subset "
                  f"(SURF, CURVE, CONS, FACE); skipped")
            continue
        if st.name in lines:
            raise VdafsReadError(f"{path}:{st.line}: {st.keyword} {st.name}: the name is already used "
                                 f"on line {lines[st.name]}")
        lines[st.name] = st.line
        entities[st.keyword][st.name] = parser(_Params(path, st))
        order.append((st.keyword, st.name))

    surfs, curves, conses, faces = (entities[k] for k in ("SURF", "CURVE", "CONS", "FACE"))
    tol = _default_tolerance(surfs) if tol is None else tol
    built_surfs: dict[str, NurbsSurface] = {}
    built_curves: dict[str, NurbsCurve] = {}

    def surface(name: str) -> NurbsSurface:
        if name not in built_surfs:
            s = surfs[name]
            built_surfs[name] = _surface(s, f"{path}:{s.line}: SURF {name}", tol)
        return built_surfs[name]

    def curve3d(name: str) -> NurbsCurve:
        if name not in built_curves:
            c = curves[name]
            built_curves[name] = _curve(c, f"{path}:{c.line}: CURVE {name}", tol.point)
        return built_curves[name]

    used = {f.surf for f in faces.values()}
    out: list[TrimmedFace] = []
    for keyword, name in order:
        if keyword == "SURF" and name not in used:
            out.append(TrimmedFace(surface(name), (), name=name))
        elif keyword == "FACE":
            out.append(_face(path, faces[name], surfs, conses, curves, surface, curve3d, tol))
    if not out:
        raise VdafsReadError(f"{path}: no SURF or FACE entity; nothing to read")
    return Shell(tuple(out), name=str(path))


def _face(path: Path, face: _Face, surfs, conses, curves, surface, curve3d, tol: Tolerance) -> TrimmedFace:
    where = f"{path}:{face.line}: FACE {face.name}"
    if face.surf not in surfs:
        raise VdafsReadError(f"{where}: refers to SURF {face.surf}, which is not in the file")
    surf = surface(face.surf)
    (u0, u1), (v0, v1) = surf.domain
    tol_uv = tol.parameter * max(u1 - u0, v1 - v0)
    loops = []
    for k, items in enumerate(face.loops):
        segments = []
        names = []
        for cons_name, w1, w2, line in items:
            here = f"{path}:{line}: FACE {face.name}"
            cons = conses.get(cons_name)
            if cons is None:
                raise VdafsReadError(f"{here}: trim loop {k + 1} refers to CONS {cons_name}, "
                                     f"which is not in the file")
            if cons.surf != face.surf:
                raise VdafsReadError(f"{here}: CONS {cons_name} lies on SURF {cons.surf}, not on the face's "
                                     f"SURF {face.surf}")
            if cons.curve is not None and cons.curve not in curves:
                raise VdafsReadError(f"{path}:{cons.line}: CONS {cons_name} (used by FACE {face.name}) refers "
                                     f"to CURVE {cons.curve}, which is not in the file")
            plane = _curve(cons.plane, f"{path}:{cons.line}: CONS {cons_name}", tol_uv)
            c0, c1 = plane.domain
            if w1 == w2:
                _warn(f"{here}: trim loop {k + 1}: CONS {cons_name} is used over the empty range "
                      f"[{w1!r}, {w2!r}]; left out")
                continue
            if min(w1, w2) < c0 - tol.parameter * (c1 - c0) or max(w1, w2) > c1 + tol.parameter * (c1 - c0):
                _warn(f"{here}: trim loop {k + 1}: range [{w1!r}, {w2!r}] of CONS {cons_name} exceeds its "
                      f"domain [{c0!r}, {c1!r}]; evaluated clamped")
            edge = None
            if cons.curve is not None:
                space = curve3d(cons.curve)
                (k0, k1), (lo, hi) = space.domain, sorted(cons.s_range)
                if lo < k0 - tol.parameter * (k1 - k0) or hi > k1 + tol.parameter * (k1 - k0):
                    _warn(f"{path}:{cons.line}: CONS {cons_name}: its range [{cons.s_range[0]!r}, "
                          f"{cons.s_range[1]!r}] on CURVE {cons.curve} exceeds the curve's domain "
                          f"[{k0!r}, {k1!r}]")
                edge = _reparameterized(space, (c0, c1), cons.s_range)
            segments.append(PCurve(plane, w1, w2, edge_curve=edge))
            names.append(cons_name)
        if not segments:
            raise VdafsReadError(f"{where}: trim loop {k + 1} has no CONS of non-zero length")
        loop = Loop(tuple(segments))
        gaps = loop.gaps()
        worst = int(np.argmax(gaps))
        if gaps[worst] > tol_uv:
            _warn(f"{where}: trim loop {k + 1} is not closed: gap {gaps[worst]:.3g} in (u, v) after CONS "
                  f"{names[worst]} (tolerance {tol_uv:.3g})")
        loops.append(loop)
    return TrimmedFace(surf, _oriented_loops(loops, where, tol_uv), name=face.name)


def _reversed_loop(loop: Loop) -> Loop:
    """The loop run the other way: segments in reverse order, each used from t1 to t0."""
    return Loop(tuple(PCurve(s.curve, s.t1, s.t0, s.edge_curve, s.edge_id) for s in reversed(loop.segments)))


def _distances_to_polygon(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Distance of each point (n, 2) to the closed polygon (k, 2), shape (n,)."""
    a, b = polygon, np.roll(polygon, -1, axis=0)
    d = b - a
    dd = np.einsum("ij,ij->i", d, d)
    out = np.empty(len(points))
    step = max(1, (1 << 20) // max(1, len(a)))  # bounds memory: points x edges pairs at once
    for i in range(0, len(points), step):
        p = points[i:i + step, None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.einsum("nkj,kj->nk", p - a[None], d) / dd
        s = np.clip(np.nan_to_num(s, nan=0.0), 0.0, 1.0)
        out[i:i + step] = np.linalg.norm(p - (a[None] + s[..., None] * d[None]), axis=2).min(axis=1)
    return out


def _oriented_loops(loops: list[Loop], where: str, tol_uv: float) -> tuple[Loop, ...]:
    """Loops in the model's orientation: the first (outer) counter-clockwise in (u, v), the others clockwise.

    A loop of the wrong sense is reversed (`_reversed_loop`) silently: VDA-FS
    does not fix the sense. Roles come from the file order (the first loop is
    the outer boundary); a warning names the FACE when the file's loops do
    not fit these roles: a loop of (nearly) zero area, a hole not inside the
    outer loop, or a hole inside another hole. Points within `tol_uv` of the
    other loop count as inside (loops may touch).
    """
    polys = [loop.polyline(_ORIENT_SAMPLES) for loop in loops]
    out = []
    for k, (loop, poly) in enumerate(zip(loops, polys)):
        area = polygon_signed_area(poly)
        perimeter = float(np.sum(np.linalg.norm(np.roll(poly, -1, axis=0) - poly, axis=1)))
        if abs(area) <= tol_uv * perimeter:
            _warn(f"{where}: trim loop {k + 1} encloses (nearly) no area ({area:.3g}); its sense is kept as read")
        elif (area > 0) != (k == 0):
            loop = _reversed_loop(loop)
        out.append(loop)
    if len(polys) > 1:
        outer = polys[0]
        for k in range(1, len(polys)):
            pts = polys[k]
            outside = ~points_in_polygons(pts, [outer])
            if outside.any() and _distances_to_polygon(pts[outside], outer).max() > tol_uv:
                _warn(f"{where}: trim loop {k + 1} (a hole) is not inside the outer trim loop 1 "
                      "(loops in the wrong order, or crossing)")
                continue
            for j in range(1, len(polys)):
                if j != k and _inside_beyond(polys[j][:1], polys[k], tol_uv):
                    _warn(f"{where}: trim loop {j + 1} (a hole) lies inside the hole trim loop {k + 1}")
    return tuple(out)


def _inside_beyond(points: np.ndarray, polygon: np.ndarray, tol: float) -> bool:
    """Whether some point lies inside `polygon` by more than `tol`."""
    inside = points_in_polygons(points, [polygon])
    return bool(inside.any() and _distances_to_polygon(points[inside], polygon).max() > tol)
