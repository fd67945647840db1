"""The boundary discrepancy eps = b_k - F (b_k paired with its foot on F) of every face, sampled adaptively.

Sampling is done per *edge*, on the edge curve's parameter t, so that the two
faces of a shared edge carry their Whitney data at the same parameters: at
each sample t_i both perturbed patches pass through b(t_i) exactly, which is
what makes the well-defined mesh watertight by construction (Sec. 3.1 of
whitney-well-definition.txt: the perturbed patches are "mutually consistent
with the explicit boundary curves b(t)").

Adaptive refinement
-------------------
Start: every knot span of b and of the p-curves gets ``degree + 2`` samples.
Round: for each sample interval [t_i, t_i+1] and each face using the edge,
evaluate eps exactly at the parameter midpoint and compare it with the
average of the end values (the piecewise-linear interpolant). The interval
is split when the deviation changes the local slope by more than
``rtol * L`` (L the face's current per-component Lipschitz constant) or more
than ``abs_tol`` in value, or when the p-curve bends away from its chord by
more than 5 % of the chord. Rounds stop when nothing is split, or when the
face Lipschitz constants changed by less than ``rtol`` over the last round
(the sampled L "stops changing"), or after ``max_rounds``. L over all pairs
(O(k^2), `loops_lipschitz`, i.e. `trimsurf.geom.whitney.lipschitz_loops`)
is computed before the rounds, after them and on
the check data; during the rounds the constant watched is the start value
raised by the local slopes (the near pairs, O(k)), which is the part of L
that refinement changes (far pairs converge with the interpolant, O(h^2)).

Pairing
-------
Which point of the face a point b(t) of the edge curve is compared with
(`_eval_use`): by default its closest point on the surface (its foot), so that
eps is b's distance from F (t20 face 1: 1.03e-3 instead of 6.1e-3 at the same
parameter near a vertex, and L 0.03-0.06 instead of 0.4-2.5); the face's
Whitney boundary C is then the polygon through the feet, and the corners are
the feet of the vertices. A use whose edge curve runs beyond the surface's
domain keeps the same-parameter pairing (its feet would pile up on the
domain's boundary). "curve" (closest point of the trim curve) and
"parameter" (the file's same-parameter pairing) are kept to compare.

The gap between samples
-----------------------
The perturbed faces of a shared edge pass through the same targets at the
samples; between them they may differ. A rigorous bound per interval
(`trimsurf.certify._gap`, from control-net bounds of the derivatives of F and
of the p-curves, and L) drives a last refinement of the shared edges until the
bound is below the point tolerance (or `max_gap_rounds` / `max_gap_samples_per_edge`
are reached; the edge then reports its bound).

L: exact for the data, convergent to the continuous constant
-------------------------------------------------------------
The perturbed face is G = F + a, a the Whitney average of the piecewise-linear
data on the polygon C through the samples. Theorem 1 needs L of *that* data,
and `loops_lipschitz` computes it exactly (the supremum over all pairs of
points of C, not only vertices, in closed form: see
`trimsurf.geom.whitney.lipschitz_constant`). So L is not an estimate: a is
L-Lipschitz, l <= a <= u, and the normal bound that uses L holds for G. As the
sampling is refined the data's constant converges to that of the continuous
discrepancy along the true boundary: for two points of one segment the
quotient is that of its end samples, which lie on the true boundary, so it is
one of the continuous quotients (at most the continuous constant); for points on
different segments the data and the polygon differ from the continuous ones by
O(h^2), so the quotients differ by O(h^2 / r) at distance r. The check halves
every interval once more and reports the ratio of the two constants as
``lipschitz_check_ratio`` (how far the data's constant still is from the
limit); it no longer raises L (an earlier version extrapolated, a heuristic).
On faces with a known discrepancy (tests/certify) L lies within 2 % of a
brute-force value from 4000 boundary points.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from ..errors import TrimLoopError
from ..geom.whitney import boundary_data, lipschitz_loops
from ._crossing import polygon_crossings
from ._gap import BoundsCache, interval_bounds, polygon_remainder, use_remainder
from ..model import NurbsCurve, PCurve, Shell, TrimmedFace

__all__ = ["FaceBoundary", "BoundaryLoop", "sample_boundaries"]

_CHORD_BEND = 0.05      # split where the p-curve leaves its chord by more than this fraction of the chord
_STUCK = 2.0 ** -20     # a sample interval this short (of its edge's range) is not split for the gap any more
                        # before its bound is taken over its own boxes of the surfaces (`_gap.tight_boxes`)



def loops_lipschitz(loops_uv, loops_eps) -> np.ndarray:
    """Exact per-component L of eq. (2) of the piecewise-linear data on a face's closed loops (all pairs).

    Sampled data: repeated consecutive samples (zero-length segments) are skipped, not an error.
    """
    return lipschitz_loops(boundary_data(loops_uv, loops_eps, strict=False))

@dataclass
class BoundaryLoop:
    """Samples of one loop of a face, in loop order (closed, first point not repeated).

    Attributes
    ----------
    uv : (k, 2) float64
        p_k(t_i) in the face's domain.
    eps : (k, 3) float64
        b_k(t_i) - F(p_k(t_i)): the discrepancy (vector).
    target : (k, 3) float64
        b_k(t_i) (or the shell vertex at a corner): where the perturbed patch passes.
    edge_key : (k,) int64
        Index of the sampled edge (into `EdgeSampling.keys`) each sample belongs to.
    t : (k,) float64
        Edge parameter of each sample.
    segment : (k,) int64
        Index of the loop segment each sample belongs to.
    vertex : (k,) int64
        Shell vertex at a sample that is an edge end (-1 elsewhere).
    """

    uv: np.ndarray
    eps: np.ndarray
    target: np.ndarray
    edge_key: np.ndarray
    t: np.ndarray
    segment: np.ndarray
    vertex: np.ndarray = None


@dataclass
class FaceBoundary:
    """The sampled boundary discrepancy of one face."""

    face: int
    loops: list[BoundaryLoop]
    lipschitz: np.ndarray                 # (3,) per component, after the check
    lipschitz_sampled: np.ndarray         # (3,) before the check
    lipschitz_check_ratio: float          # max over components of L_refined / L_sampled (1 = no change)
    lipschitz_rel_change: float           # relative change of L over the last refinement round
    interp_error: float                   # max |eps - PL interpolant| at the last midpoints
    n_rounds: int
    history: list[list[float]] = field(default_factory=list)
    crossings: np.ndarray = None          # (k, 2) uv points where a loop's Whitney polygon crosses itself

    @property
    def n_samples(self) -> int:
        return int(sum(len(lp.uv) for lp in self.loops))

    @property
    def max_discrepancy(self) -> float:
        return float(max((np.linalg.norm(lp.eps, axis=1).max() for lp in self.loops), default=0.0))


@dataclass
class _Use:
    face: int
    loop: int
    seg: int
    pcurve: PCurve
    bcurve: NurbsCurve | None
    descending: bool          # runs from hi to lo
    pairing: str = "surface"  # how eps pairs b(t) with the face (see `_eval_use`)


@dataclass
class _Edge:
    lo: float
    hi: float
    t: np.ndarray
    uses: list[_Use]
    corner_lo: np.ndarray | None
    corner_hi: np.ndarray | None
    vertex_lo: int = -1
    vertex_hi: int = -1
    degenerate: bool = False
    shell_edge: int = -1
    tau: dict = None                  # (face, loop, seg) -> p-curve parameter at each sample (the pairing)
    poly: dict = None                 # (face, loop, seg) -> the Whitney polygon's vertices at the samples
    gap_bound: float = 0.0            # rigorous bound of max |G_A - G_B| along the edge (shared edges)
    gap_tolerance: float = 0.0        # the point tolerance the sampling aimed the bound at
    interval_bound: np.ndarray = None  # per sample interval


def _face_loops(face: TrimmedFace):
    """The face's loops, or the rectangle of its domain when it has none (eps = 0 there)."""
    if face.loops:
        return face.loops
    from ..model import Loop
    (u0, u1), (v0, v1) = face.surface.domain
    pts = [(u0, v0), (u1, v0), (u1, v1), (u0, v1)]
    segs = []
    for i in range(4):
        a, b = pts[i], pts[(i + 1) % 4]
        segs.append(PCurve(NurbsCurve(1, [0.0, 0.0, 1.0, 1.0], np.array([a, b], dtype=np.float64)), 0.0, 1.0))
    return (Loop(tuple(segs)),)


def _initial_t(lo: float, hi: float, curves: list[NurbsCurve]) -> np.ndarray:
    brk = [lo, hi]
    deg = 1
    for c in curves:
        kn = c.knots[(kn_ := c.knots) > lo]
        del kn_
        kn = kn[kn < hi]
        brk.extend(np.unique(kn).tolist())
        deg = max(deg, c.degree)
    brk = np.unique(np.asarray(brk))
    if len(brk) > 257:
        brk = np.unique(np.r_[np.quantile(brk, np.linspace(0, 1, 257)), lo, hi])
    per = deg + 2
    ts = [np.linspace(a, b, per, endpoint=False) for a, b in zip(brk[:-1], brk[1:])]
    return np.unique(np.r_[np.concatenate(ts), hi])


def _dedupe_t(t: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Sorted parameters with near-duplicates (closer than 1e-6 of the range) removed; lo and hi kept exactly."""
    t = np.unique(np.clip(np.r_[lo, t, hi], lo, hi))
    tol = 1e-6 * (hi - lo)
    keep = [0]
    for i in range(1, len(t)):
        if t[i] - t[keep[-1]] > tol:
            keep.append(i)
    out = t[keep]
    if out[-1] != hi:
        out[-1] = hi
    return out


def _build_edges(shell: Shell) -> tuple[list[_Edge], dict]:
    edges: list[_Edge] = []
    by_id: dict[int, int] = {}
    where: dict[tuple[int, int, int], int] = {}
    verts = shell.vertices
    for f, face in enumerate(shell.faces):
        for l, loop in enumerate(_face_loops(face)):
            for s, seg in enumerate(loop.segments):
                lo, hi = sorted((seg.t0, seg.t1))
                desc = seg.t0 > seg.t1
                eid = seg.edge_id
                shared = None
                bcurve = seg.edge_curve
                corner = (None, None, -1, -1)
                if face.loops and 0 <= eid < len(shell.edges):
                    e = shell.edges[eid]
                    if bcurve is None and e.curve is not None:
                        bcurve = e.curve
                    elo, ehi = sorted((e.t0, e.t1))
                    span = max(ehi - elo, 1e-300)
                    if abs(elo - lo) <= 1e-9 * span and abs(ehi - hi) <= 1e-9 * span:
                        lo, hi = elo, ehi
                        shared = eid
                    cv, ids = [], []
                    for tv in (lo, hi):
                        vi = e.vertices[0] if abs(tv - e.t0) <= abs(tv - e.t1) else e.vertices[1]
                        cv.append(verts[vi].copy() if 0 <= vi < len(verts) else None)
                        ids.append(vi if 0 <= vi < len(verts) else -1)
                    corner = tuple(cv) + tuple(ids)
                use = _Use(f, l, s, seg, bcurve, desc)
                if shared is not None and shared in by_id:
                    k = by_id[shared]
                    edges[k].uses.append(use)
                else:
                    curves = [seg.curve] + ([bcurve] if bcurve is not None else [])
                    degen = bool(shared is not None and shell.edges[shared].is_degenerate)
                    edges.append(_Edge(lo, hi, _initial_t(lo, hi, curves), [use], *corner, degenerate=degen))
                    k = len(edges) - 1
                    if shared is not None:
                        by_id[shared] = k
                        edges[k].shell_edge = shared
                where[(f, l, s)] = k
    # add the other uses' p-curve knots to shared edges
    for e in edges:
        if len(e.uses) > 1:
            e.t = np.unique(np.r_[e.t, _initial_t(e.lo, e.hi, [u.pcurve.curve for u in e.uses[1:]])])
        e.t = _dedupe_t(e.t, e.lo, e.hi)
    return edges, where


def _densify(shell: Shell, e: _Edge, max_chord: float) -> None:
    """Insert parameters so consecutive samples are at most `max_chord` apart on every use (in space)."""
    t = e.t
    worst = np.zeros(len(t) - 1)
    for u in e.uses:
        _, fp, target, _, _ = _eval_use(shell, e, u, t)
        worst = np.maximum(worst, np.linalg.norm(np.diff(fp, axis=0), axis=1))
        worst = np.maximum(worst, np.linalg.norm(np.diff(target, axis=0), axis=1))
    n = np.minimum(np.ceil(worst / max_chord).astype(np.int64), 64)
    extra = [np.linspace(a, b, k, endpoint=False)[1:] for a, b, k in zip(t[:-1], t[1:], n) if k > 1]
    if extra:
        e.t = _dedupe_t(np.r_[t, np.concatenate(extra)], e.lo, e.hi)


def _eval_use(shell: Shell, edge: _Edge, use: _Use, t: np.ndarray, *, corners: bool = True):
    """uv, F(uv), target b(t) (corner vertices at the ends), eps and the p-curve parameter tau at edge parameters t.

    pairing "surface": uv is the foot of b(t) on F (the closest point of the surface, Gauss-Newton from
    the closest point of the trim curve; at the edge ends the foot of the vertex):
    eps is then b's distance from the surface and the face's Whitney boundary C runs through the feet;
    "curve": uv = p(tau(t)) with tau(t) the parameter of the point of the trim curve F(p(tau)) closest to
    b(t) (Gauss-Newton from tau = t, kept where it is closer than the same-parameter point and increases
    with t); "parameter": tau = t (the same-parameter pairing of the file). tau is returned in every case
    (the closest point of the trim curve for "surface").
    """
    face = shell.faces[use.face]
    target = use.bcurve.evaluate(t) if use.bcurve is not None else None
    if use.bcurve is not None:
        # make b end exactly at its vertices: blend the end mismatch linearly in t (Sec. 3.1 assumes
        # "v always coincides with an endpoint of b"; the blend is at most the vertex mismatch)
        s = ((t - edge.lo) / (edge.hi - edge.lo))[:, None]
        ends = use.bcurve.evaluate(np.array([edge.lo, edge.hi]))
        if edge.corner_lo is not None:
            target += (1.0 - s) * (edge.corner_lo - ends[0])
        if edge.corner_hi is not None:
            target += s * (edge.corner_hi - ends[1])
    tau = np.asarray(t, dtype=np.float64).copy()
    uv = use.pcurve.curve.evaluate(tau)
    fp = face.surface.evaluate(uv)
    if target is not None and use.pairing in ("curve", "surface") and len(t):
        tau, uv, fp = _closest_tau(face.surface, use.pcurve.curve, tau, uv, fp, target, edge.lo, edge.hi)
        if use.pairing == "surface":
            # the ends too: a corner's point is the foot of its vertex (the same for both of its segments),
            # so eps is b's normal distance from F everywhere, also at the corners
            uv, fp = _closest_on_surface(face.surface, uv, fp, target, np.ones(len(t), dtype=bool))
    if target is None:
        target = fp.copy()
    if corners:
        if edge.corner_lo is not None:
            target[t == edge.lo] = edge.corner_lo
        if edge.corner_hi is not None:
            target[t == edge.hi] = edge.corner_hi
    return uv, fp, target, target - fp, tau


def _feet_inside(shell: Shell, e: _Edge, use: _Use, n: int = 65) -> bool:
    """Whether the feet of b on F lie inside F's domain along the whole use (probed at n parameters).

    Where b runs beyond the surface's domain its feet would pile up on the domain's boundary (one foot
    for several points of b: no Lipschitz constant); such a use keeps the same-parameter pairing."""
    if use.bcurve is None:
        return True
    t = np.linspace(e.lo, e.hi, n)
    surface = shell.faces[use.face].surface
    (u0, u1), (v0, v1) = surface.domain
    lo, hi = np.array([u0, v0]), np.array([u1, v1])
    uv = use.pcurve.curve.evaluate(t)
    target = _eval_use(shell, e, dataclasses.replace(use, pairing="parameter"), t)[2]
    cur = uv.copy()
    for _ in range(12):
        d = surface.derivatives(np.clip(cur, lo, hi), 1)
        su, sv, r = d[1, 0], d[0, 1], target - d[0, 0]
        ee, ff, gg = (np.einsum("ij,ij->i", a, b) for a, b in ((su, su), (su, sv), (sv, sv)))
        ru, rv = np.einsum("ij,ij->i", r, su), np.einsum("ij,ij->i", r, sv)
        det = ee * gg - ff * ff
        ok = det > 1e-14 * np.maximum(ee * gg, 1e-300)
        with np.errstate(divide="ignore", invalid="ignore"):
            du = np.where(ok, (gg * ru - ff * rv) / det, 0.0)
            dv = np.where(ok, (ee * rv - ff * ru) / det, 0.0)
        cur = cur + np.column_stack([du, dv])
    slack = 1e-9 * (hi - lo)
    return bool(np.all((cur >= lo - slack) & (cur <= hi + slack)))


def _closest_on_surface(surface, uv, fp, target, free, iterations: int = 12):
    """Gauss-Newton foot points of the targets on F from uv, within F's domain (kept where closer than uv)."""
    cur = uv.copy()
    (u0, u1), (v0, v1) = surface.domain
    lo, hi = np.array([u0, v0]), np.array([u1, v1])
    for _ in range(iterations):
        d = surface.derivatives(cur, 1)
        su, sv, r = d[1, 0], d[0, 1], target - d[0, 0]
        e, f, g = (np.einsum("ij,ij->i", a, b) for a, b in ((su, su), (su, sv), (sv, sv)))
        ru, rv = np.einsum("ij,ij->i", r, su), np.einsum("ij,ij->i", r, sv)
        det = e * g - f * f
        ok = free & (det > 1e-14 * np.maximum(e * g, 1e-300))
        with np.errstate(divide="ignore", invalid="ignore"):
            du = np.where(ok, (g * ru - f * rv) / det, 0.0)
            dv = np.where(ok, (e * rv - f * ru) / det, 0.0)
        # projected Gauss-Newton: the foot stays on the surface's domain (a b beyond the face's boundary
        # pairs with the boundary's nearest point)
        cur = np.clip(cur + np.column_stack([du, dv]), lo, hi)
        if not np.any(np.abs(du) + np.abs(dv) > 1e-15 * (1.0 + np.abs(cur).max())):
            break
    cfp = surface.evaluate(cur)
    better = free & (np.linalg.norm(cfp - target, axis=1) < np.linalg.norm(fp - target, axis=1))
    return np.where(better[:, None], cur, uv), np.where(better[:, None], cfp, fp)


def _closest_tau(surface, curve, t, uv, fp, target, lo, hi, iterations: int = 12):
    """Closest-point pairing: tau(t) minimising |F(p(tau)) - b(t)| near tau = t (see `_eval_use`)."""
    tau = t.copy()
    fixed = (t == lo) | (t == hi)
    span = hi - lo
    cur_uv, cur_fp = uv, fp
    for _ in range(iterations):
        dc = curve.derivatives(tau, 1)
        ds = surface.derivatives(dc[0], 1)
        dphi = ds[1, 0] * dc[1][:, :1] + ds[0, 1] * dc[1][:, 1:]
        den = np.einsum("ij,ij->i", dphi, dphi)
        num = np.einsum("ij,ij->i", target - ds[0, 0], dphi)
        step = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
        step[fixed] = 0.0
        step = np.clip(step, -0.25 * span, 0.25 * span)
        tau = np.clip(tau + step, lo, hi)
        if not np.any(np.abs(step) > 1e-15 * span):
            break
    cur_uv = curve.evaluate(tau)
    cur_fp = surface.evaluate(cur_uv)
    worse = np.linalg.norm(cur_fp - target, axis=1) > np.linalg.norm(fp - target, axis=1)
    tau[worse], cur_uv[worse], cur_fp[worse] = t[worse], uv[worse], fp[worse]
    if len(t) > 1 and np.all(np.diff(t) > 0) and not np.all(np.diff(tau) > 0):
        return t.copy(), uv, fp             # not monotone: keep the same-parameter pairing on this use
    if np.any(~fixed & ((tau <= lo) | (tau >= hi))):
        return t.copy(), uv, fp             # b runs beyond the trim curve's end: the same, for the same reason
    return tau, cur_uv, cur_fp


def _assemble_face(shell: Shell, edges: list[_Edge], where: dict, f: int, merge_tol: float,
                   cache: dict, corner_info: dict | None = None) -> list[BoundaryLoop]:
    face = shell.faces[f]
    loops = []
    for l, loop in enumerate(_face_loops(face)):
        parts = []
        for s in range(len(loop.segments)):
            k = where[(f, l, s)]
            e = edges[k]
            use = next(u for u in e.uses if (u.face, u.loop, u.seg) == (f, l, s))
            uv, _, target, eps, _ = cache[(f, l, s)]
            t = e.t
            if use.descending:
                uv, target, eps, t = uv[::-1], target[::-1], eps[::-1], t[::-1]
            parts.append((uv.copy(), eps.copy(), target.copy(), np.full(len(t), k, dtype=np.int64), t.copy(),
                          np.full(len(t), s, dtype=np.int64)))
        uv, eps, tgt, key, tt, sg = [], [], [], [], [], []
        n = len(parts)
        for i, (puv, peps, ptg, pk, pt, ps) in enumerate(parts):
            nxt = parts[(i + 1) % n]
            keep_end = np.linalg.norm(puv[-1] - nxt[0][0]) > merge_tol
            sl = slice(None) if keep_end else slice(0, -1)
            if not keep_end and n >= 1:
                # the corner: one point for both segments, in the middle of the (tiny) uv gap of the loop,
                # passing through the vertex (or the mean of the two targets when there is none)
                shift = 0.5 * float(np.linalg.norm(puv[-1] - nxt[0][0]))
                mean_tg = 0.5 * (ptg[-1] + nxt[2][0])
                if corner_info is not None:
                    # for the gap bound: how far the corner point moved off each p-curve, and its target
                    for seg_i, t_end in ((i, pt[-1]), ((i + 1) % n, nxt[4][0])):
                        key_c = (f, l, int(parts[seg_i][5][0]), float(t_end))
                        corner_info[key_c] = (shift, mean_tg.copy(), 0.5 * (puv[-1] + nxt[0][0]))
                nxt[0][0] = 0.5 * (puv[-1] + nxt[0][0])
                nxt[2][0] = mean_tg
                nxt[1][0] = nxt[2][0] - face.surface.evaluate(nxt[0][:1])[0]
            uv.append(puv[sl]); eps.append(peps[sl]); tgt.append(ptg[sl]); key.append(pk[sl]); tt.append(pt[sl])
            sg.append(ps[sl])
        uv, eps, tgt = np.concatenate(uv), np.concatenate(eps), np.concatenate(tgt)
        key, tt, sg = np.concatenate(key), np.concatenate(tt), np.concatenate(sg)
        # drop repeated points (degenerate pieces), keeping the first
        d = np.linalg.norm(uv - np.roll(uv, 1, axis=0), axis=1)
        keep = d > merge_tol
        if not keep.any():
            raise TrimLoopError(f"face {f} ({face.name}) loop {l}: the trim loop collapses to a point in (u, v)")
        uv, eps, tgt, key, tt, sg = uv[keep], eps[keep], tgt[keep], key[keep], tt[keep], sg[keep]
        if len(uv) < 3:
            raise TrimLoopError(f"face {f} ({face.name}) loop {l}: fewer than 3 distinct boundary points in (u, v)")
        vid = np.full(len(uv), -1, dtype=np.int64)
        for i, (k, t) in enumerate(zip(key.tolist(), tt.tolist())):
            e = edges[k]
            if t == e.lo:
                vid[i] = e.vertex_lo
            elif t == e.hi:
                vid[i] = e.vertex_hi
        loops.append(BoundaryLoop(uv, eps, tgt, key, tt, sg, vid))
    return loops


def use_polygon(e: _Edge, u: _Use, cache: dict, corner_info: dict, merge_tol: float | None):
    """A use's Whitney polygon along the edge as its face has it, at every sample of the edge.

    Returns uv, target, tau, shift and keep (all per sample): corners merged (`_assemble_face`), and samples
    the face drops (closer than `merge_tol` in (u, v) to the previous one in loop order; the use's ends are
    kept) replaced by the linear interpolation in t of the kept ones: the face's polygon C' and its data
    run straight from kept sample to kept sample, so that is where the face's boundary is at those t.
    """
    uv, _, target, _, tau = cache[(u.face, u.loop, u.seg)]
    shift = np.zeros(len(tau))
    target = target.copy()
    uv = uv.copy()
    for end_i, t_end in ((0, e.lo), (len(tau) - 1, e.hi)):
        info = corner_info.get((u.face, u.loop, u.seg, float(t_end)))
        if info is not None:
            shift[end_i] = info[0]
            target[end_i] = info[1]
            if u.pairing == "surface":
                uv[end_i] = info[2]
    keep = np.ones(len(uv), dtype=bool)
    if merge_tol is not None and len(uv) > 2:
        d = np.linalg.norm(np.diff(uv, axis=0), axis=1) > merge_tol
        if u.descending:                    # loop order runs from hi to lo: compare with the next sample
            keep[:-1] = d
        else:
            keep[1:] = d
        keep[0] = keep[-1] = True
    if not keep.all():
        t, tk = e.t, e.t[keep]
        uv = np.column_stack([np.interp(t, tk, uv[keep, i]) for i in range(2)])
        target = np.column_stack([np.interp(t, tk, target[keep, i]) for i in range(3)])
        tau = np.interp(t, tk, tau[keep])
        shift = np.where(keep, shift, 0.0)
    return uv, target, tau, shift, keep


def edge_interval_bounds(shell: Shell, e: _Edge, cache: dict, corner_info: dict, lipschitz: dict,
                         bcache: BoundsCache, tighten: np.ndarray | None = None,
                         merge_tol: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Rigorous bound of the gap between the perturbed faces on each sample interval of a shared edge,
    as (fixed, remainder) (`trimsurf.certify._gap.interval_bounds`); remainders over `tighten` (per
    interval) are bounded again over their intervals' own boxes of the surface (`_gap.tight_boxes`).

    Each face's polygon is the one it has (`use_polygon`): where it merges samples away, its remainder is
    that of the longer interval between the samples it keeps (a face's polygon through samples it dropped
    measured a gap of 6e-10 on U_Joint edge 308, next to its pole vertex, where the bound said 1.9e-12)."""
    rems, tgts = [], []
    for u in e.uses:
        mt = None if merge_tol is None else merge_tol[u.face]
        uv, target, tau, shift, keep = use_polygon(e, u, cache, corner_info, mt)
        surface = shell.faces[u.face].surface
        idx = np.flatnonzero(keep)
        tk = None if tighten is None or np.isscalar(tighten) else np.minimum.reduceat(tighten, idx[:-1])
        tk = tighten if tk is None else tk
        if u.pairing == "surface":
            r = polygon_remainder(surface, uv[idx], bcache, tk)
        else:
            r = use_remainder(surface, u.pcurve.curve, uv[idx], tau[idx], lipschitz[u.face], shift[idx], bcache, tk)
        rems.append(r[np.cumsum(keep)[:-1] - 1])          # edge interval i lies in the kept interval before it
        tgts.append(target)
    return interval_bounds(rems, tgts)


def sample_boundaries(shell: Shell, *, rtol: float = 1e-2, abs_tol: float | None = None, max_rounds: int = 8,
                      max_samples_per_edge: int = 2048, check: bool = True, max_chord: float | None = None,
                      faces=None, pairing: str = "surface", point_tolerance: float | None = None,
                      max_gap_rounds: int = 6, max_gap_samples_per_edge: int = 1 << 14,
                      ) -> tuple[list[FaceBoundary], list[_Edge], dict]:
    """Adaptively sampled boundary discrepancy of every face (see the module docstring).

    Parameters
    ----------
    shell : Shell
    rtol : float
        Relative change of the slope (and of L between rounds) at which refinement stops.
    abs_tol : float or None
        Value deviations below this are noise (default 1e-12 times the diagonal).
    max_rounds : int
    max_samples_per_edge : int
    check : bool
        Halve every interval once more and report how much L grows (``lipschitz_check_ratio``: how far
        the sampled constant is from that of the continuous discrepancy; L itself is exact for the data).
    max_chord : float or None
        Start with samples at most this far apart in space (and in (u, v), relative to the face's
        extent): the spacing of the well-defined mesh along its edges.
    faces : iterable of int or None
        Faces whose boundaries are wanted (default all).
    pairing : {"surface", "curve", "parameter"}
        How eps pairs the edge curve b(t) with the face: the closest point of the surface (default; the
        face's Whitney boundary runs through the feet of b), the closest point F(p(tau)) of the trim curve,
        or the same parameter (tau = t, for comparison). See `_eval_use`.
    point_tolerance : float or None
        Shared edges are sampled until the rigorous bound of the gap between the perturbed faces
        (`trimsurf.certify._gap`) is below this (default 1e-6 of the diagonal); None with ``faces`` given
        skips the gap phase when not every face is wanted.
    max_gap_rounds, max_gap_samples_per_edge : int
        Limits of that refinement (an edge whose bound stays above the tolerance says so).

    Returns
    -------
    boundaries : list of FaceBoundary
        One per face of `shell` (None for faces not asked for).
    edges, where
        The per-edge samples and the (face, loop, segment) -> edge index map.
    """
    diag = shell.diagonal()
    if abs_tol is None:
        abs_tol = 1e-12 * max(diag, 1e-300)
    wanted = set(range(len(shell.faces))) if faces is None else set(int(f) for f in faces)
    if pairing not in ("surface", "curve", "parameter"):
        raise ValueError(f"pairing must be 'surface', 'curve' or 'parameter'; got {pairing!r}")
    edges, where = _build_edges(shell)
    for e in edges:
        for u in e.uses:
            u.pairing = pairing
            if pairing == "surface" and not _feet_inside(shell, e, u):
                u.pairing = "parameter"
    if max_chord is not None and max_chord > 0:
        for e in edges:
            _densify(shell, e, float(max_chord))
    merge_tol = {}
    for f in wanted:
        (u0, u1), (v0, v1) = shell.faces[f].surface.domain
        # loops whose p-curves miss each other by less than this (relative to the domain) are closed;
        # two samples closer than this are one point (else L ~ |grad F| from the p-curves' gaps)
        merge_tol[f] = 1e-7 * max(u1 - u0, v1 - v0)
    relevant = [k for k, e in enumerate(edges) if any(u.face in wanted for u in e.uses)]

    cache: dict = {}
    corner_info: dict = {}

    def evaluate_all(ks):
        for k in ks:
            e = edges[k]
            for u in e.uses:
                if u.face in wanted:
                    cache[(u.face, u.loop, u.seg)] = _eval_use(shell, e, u, e.t)

    def face_l(f, full=True):
        """The face's loops and L: all pairs (O(k^2)), or during the rounds the start value raised by the
        local slopes (the near pairs, O(k), which is what refinement changes)."""
        loops = _assemble_face(shell, edges, where, f, merge_tol[f], cache, corner_info)
        if full:
            return loops, loops_lipschitz([lp.uv for lp in loops], [lp.eps for lp in loops])
        local = np.zeros(3)
        for lp in loops:
            d = np.linalg.norm(np.roll(lp.uv, -1, axis=0) - lp.uv, axis=1)
            local = np.maximum(local, (np.abs(np.roll(lp.eps, -1, axis=0) - lp.eps) / d[:, None]).max(axis=0))
        return loops, np.maximum(start_l[f], local)

    evaluate_all(relevant)
    cur = {f: face_l(f) for f in wanted}
    start_l = {f: cur[f][1].copy() for f in wanted}
    history = {f: [cur[f][1].tolist()] for f in wanted}
    rel_change = {f: np.inf for f in wanted}
    interp = {f: 0.0 for f in wanted}
    n_rounds = 0
    for _ in range(max_rounds):
        n_rounds += 1
        changed = []
        for k in relevant:
            e = edges[k]
            t = e.t
            if len(t) >= max_samples_per_edge:
                continue
            tm = 0.5 * (t[:-1] + t[1:])
            split = np.zeros(len(tm), dtype=bool)
            for u in e.uses:
                if u.face not in wanted:
                    continue
                uv, _, _, eps, _ = cache[(u.face, u.loop, u.seg)]
                uvm, _, _, epsm, _ = _eval_use(shell, e, u, tm, corners=False)
                dev = np.abs(epsm - 0.5 * (eps[:-1] + eps[1:]))
                h = np.linalg.norm(uv[1:] - uv[:-1], axis=1)
                big_l = cur[u.face][1]
                interp[u.face] = max(interp[u.face], float(np.linalg.norm(dev, axis=1).max(initial=0.0)))
                slope_bad = np.any(dev > np.maximum(0.5 * rtol * big_l[None, :] * h[:, None], abs_tol), axis=1)
                bend = np.linalg.norm(uvm - 0.5 * (uv[:-1] + uv[1:]), axis=1) > _CHORD_BEND * h
                split |= slope_bad | bend
            split &= (t[1:] - t[:-1]) > (e.hi - e.lo) * 2.0 ** -16
            if split.any():
                room = max_samples_per_edge - len(t)
                idx = np.flatnonzero(split)[:room]
                e.t = np.sort(np.r_[t, tm[idx]])
                changed.append(k)
        if not changed:
            for f in wanted:
                rel_change[f] = 0.0 if not np.isfinite(rel_change[f]) else rel_change[f]
            break
        evaluate_all(changed)
        touched = {u.face for k in changed for u in edges[k].uses if u.face in wanted}
        stable = True
        for f in touched:
            old = cur[f][1]
            cur[f] = face_l(f, full=False)
            new = cur[f][1]
            rc = float(np.max(np.abs(new - old)) / new.max()) if np.any(new > 0) else 0.0
            rel_change[f] = rc
            history[f].append(new.tolist())
            stable &= rc <= rtol
        for f in wanted - touched:
            rel_change[f] = 0.0 if not np.isfinite(rel_change[f]) else rel_change[f]
        if stable:
            break

    tol = 1e-6 * diag if point_tolerance is None else float(point_tolerance)
    final = {f: face_l(f) for f in wanted}
    shared_k = [k for k in relevant if len(edges[k].uses) >= 2 and not edges[k].degenerate
                and all(u.face in wanted for u in edges[k].uses)]
    bcache = BoundsCache()
    needs_l = {u.face for e in edges for u in e.uses if u.pairing != "surface"}
    stale: set = set()
    for gap_round in range(max_gap_rounds + 1):
        changed = []
        for k in shared_k:
            e = edges[k]
            lips = {f: final[f][1] for f in final}
            fixed, rem = edge_interval_bounds(shell, e, cache, corner_info, lips, bcache, merge_tol=merge_tol)
            b = fixed + rem
            # refinement reduces only the remainder (as the square of the interval), not a corner's mismatch
            room_tol = np.maximum(tol - fixed, 0.25 * tol)
            bad = (b > tol) & (rem > 0.25 * room_tol) & np.isfinite(rem)    # unbounded: refinement cannot help
            # where the edge is done (or an interval is already tiny) and still over tol, bound the surfaces'
            # derivatives over the intervals' own boxes instead of over the fixed pieces meeting them: a
            # polygon segment along a pole line (U_Joint edges 308, 310: 0.10 -> 2.5e-5) is not helped by
            # splitting (its feet stay spread along the pole), only by the box's own net
            last = gap_round == max_gap_rounds or not bad.any() or len(e.t) >= max_gap_samples_per_edge
            sel = (b > tol) & np.isfinite(rem) & (last | (np.diff(e.t) <= (e.hi - e.lo) * _STUCK))
            if sel.any():
                fixed, rem = edge_interval_bounds(shell, e, cache, corner_info, lips, bcache,
                                                  np.where(sel, 0.0, np.inf), merge_tol)
                b = fixed + rem
                bad = (b > tol) & (rem > 0.25 * room_tol) & np.isfinite(rem)
                bad &= ~sel                     # bounded over their own boxes: not split further
            e.interval_bound, e.gap_bound, e.gap_tolerance = b, float(b.max(initial=0.0)), tol
            if gap_round == max_gap_rounds or not bad.any() or len(e.t) >= max_gap_samples_per_edge:
                continue
            # the remainder shrinks as the square of the interval: aim at 0.8 of the room left
            pieces = np.minimum(np.ceil(np.sqrt(rem[bad] / (0.8 * room_tol[bad]))), 64).astype(np.int64)
            t = e.t
            i_bad = np.flatnonzero(bad)
            extra = np.concatenate([t[i] + (t[i + 1] - t[i]) * np.arange(1, m) / m for i, m in zip(i_bad, pieces)])
            room = max_gap_samples_per_edge - len(t)
            if len(extra) > room:
                extra = extra[np.linspace(0, len(extra) - 1, max(room, 0)).astype(np.int64)] if room > 0 else extra[:0]
            if len(extra):
                e.t = np.unique(np.r_[t, extra])
                changed.append(k)
        if not changed:
            break
        evaluate_all(changed)
        touched = {u.face for k in changed for u in edges[k].uses if u.face in wanted}
        stale |= touched
        # L enters the bound only for uses not paired on the surface: recompute it (O(k m), pruned) for
        # those faces now, for the others once after the rounds
        for f in touched:
            if f in needs_l:
                final[f] = face_l(f)
                stale.discard(f)
    for f in stale:
        final[f] = face_l(f)
    for e in edges:
        e.tau, e.poly = {}, {}
        for u in e.uses:
            key = (u.face, u.loop, u.seg)
            if key not in cache:
                continue
            e.tau[key] = cache[key][4]
            uv = cache[key][0].copy()
            for end_i, t_end in ((0, e.lo), (len(uv) - 1, e.hi)):
                info = corner_info.get(key + (float(t_end),))
                if info is not None:
                    uv[end_i] = info[2]
            if u.face in merge_tol:
                # the face's own polygon: samples it merges away replaced by the line between those it keeps
                p_uv, _, p_tau, _, keep = use_polygon(e, u, cache, corner_info, merge_tol[u.face])
                if not keep.all():
                    uv = p_uv if u.pairing == "surface" else uv
                    e.tau[key] = p_tau
            e.poly[key] = uv           # the Whitney polygon's vertices along this edge (corners merged)

    out: list[FaceBoundary | None] = [None] * len(shell.faces)
    for f in sorted(wanted):
        loops, big_l = final[f]             # all pairs, on the final samples
        if len(history[f]) > 1:
            history[f].append(big_l.tolist())
        ratio = 1.0
        final_l = big_l.copy()
        if check:
            fine_uv, fine_eps = [], []
            for li, lp in enumerate(loops):
                # halve every interval with exact values (one level finer than the data)
                k = len(lp.uv)
                nxt = np.roll(np.arange(k), -1)
                mids_uv = np.empty((k, 2))
                mids_eps = np.empty((k, 3))
                same = (lp.segment == lp.segment[nxt]) & (np.abs(lp.t - lp.t[nxt]) > 0)
                mids_uv[:] = 0.5 * (lp.uv + lp.uv[nxt])
                mids_eps[:] = 0.5 * (lp.eps + lp.eps[nxt])
                for sgi in np.unique(lp.segment):
                    e = edges[where[(f, li, int(sgi))]]
                    use = next(u for u in e.uses if (u.face, u.loop, u.seg) == (f, li, int(sgi)))
                    own = lp.segment == sgi
                    # the last interval of a segment ends at the corner, which belongs to the next segment
                    t_end = e.lo if use.descending else e.hi
                    last = own & ~same & (lp.t != t_end)
                    sel = np.flatnonzero((same & own) | last)
                    t_next = np.where(last[sel], t_end, lp.t[nxt[sel]])
                    tm = 0.5 * (lp.t[sel] + t_next)
                    uvm, _, _, epsm, _ = _eval_use(shell, e, use, tm, corners=False)
                    mids_uv[sel], mids_eps[sel] = uvm, epsm
                uv2 = np.empty((2 * k, 2))
                ep2 = np.empty((2 * k, 3))
                uv2[0::2], uv2[1::2] = lp.uv, mids_uv
                ep2[0::2], ep2[1::2] = lp.eps, mids_eps
                ok = np.linalg.norm(uv2 - np.roll(uv2, 1, axis=0), axis=1) > merge_tol[f]
                fine_uv.append(uv2[ok])
                fine_eps.append(ep2[ok])
            fine_l = loops_lipschitz(fine_uv, fine_eps)
            with np.errstate(divide="ignore", invalid="ignore"):
                r = np.where(big_l > 0, fine_l / big_l, np.where(fine_l > abs_tol, np.inf, 1.0))
            ratio = 1.0 + float(np.max(fine_l - big_l)) / float(big_l.max()) if big_l.max() > 0 else float(np.max(r))
            # informative only: L is exact for the data that defines G (see the module docstring)
        # a loop whose polygon crosses itself (e.g. a p-curve running past the corner where the next one
        # starts) has two values at the crossing: no Lipschitz constant, the extension does not interpolate
        cross = []
        for lp in loops:
            hits = polygon_crossings(lp.uv)
            cross += [0.5 * (lp.uv[i] + lp.uv[(i + 1) % len(lp.uv)]) for i in hits[:, 0]]
        out[f] = FaceBoundary(f, loops, final_l, big_l, ratio, float(rel_change[f]), interp[f], n_rounds,
                              history[f], np.array(cross).reshape(-1, 2))
    for k in shared_k:
        e = edges[k]
        if any(out[u.face] is not None and len(out[u.face].crossings) for u in e.uses):
            e.gap_bound = float("inf")           # the faces' extensions are not certified to interpolate
            e.interval_bound = np.full(max(len(e.t) - 1, 0), np.inf)
    return out, edges, where
