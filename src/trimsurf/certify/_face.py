"""Per-face certificate: discrepancy, Lipschitz constants, l <= u check, normal bound over the face.

The normal bound of `trimsurf.certify._normal` is a pointwise bound. Its
maximum over the face is bounded rigorously (`rigorous_normal_bound`): over
every Bézier piece of F meeting the trimmed (polygonal) domain, the control
nets bound |F_u|, |F_v| from above and |F_u x F_v| from below, hence kappa,
and the normal cone bounds L_n (`trimsurf.certify._intersect.bezier_piece_normal_bound`);
pieces whose bound is loose are subdivided. ``bound_kind`` says "rigorous";
it says "sampled" only for surfaces with more than 4096 Bézier pieces, whose
bound is the maximum over an ``n_domain x n_domain`` grid plus the boundary
samples (also reported for every face as ``normal_bound_sampled_deg``). At a
singular point of F (a pole: E G - F^2 = 0) the bound is 180 degrees unless
L = 0: Sec. 4 needs a regular parametrization.

The l <= u check evaluates the lower and upper Whitney extensions at the grid
points. With L the exact constant of the data l <= u holds everywhere
(Theorem 1); where rounding makes l > u, L is raised by 2 % steps until it holds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geom import points_in_polygons
from ..model import NurbsSurface
from ..quality._results import ResultMixin
from ._boundary import FaceBoundary
from ._normal import normal_angle_bound
from ._perturb import PerturbedFace

__all__ = ["FaceCertificate", "face_certificate", "domain_samples", "check_bracket"]

_MAX_RAISES = 60        # l <= u repair: at most this many 2 % raises of L


@dataclass(frozen=True, eq=False)
class FaceCertificate(ResultMixin):
    """What is certified about one face (the figures of ``trimsurf certify``).

    Attributes
    ----------
    face : int
    name : str
    max_discrepancy : float
        max |eps| = max |b_k - F(p_k)| over the boundary samples (model units).
    max_discrepancy_bound : float
        max_discrepancy plus the interpolation error between samples: an estimate from above of
        sup |eps| on the continuous boundary.
    perturbation_bound : float
        Bound on |a| = |G - F| everywhere in the face (Theorem 1, per component).
    lipschitz : (3,) float64
        Per-component Lipschitz constants of eps used for the extension (model units per (u, v) unit).
    lipschitz_sampled : (3,) float64
        Before the final refinement check.
    lipschitz_check_ratio : float
        1 + (largest increase of L after halving every sample interval once more) / max L: how far the
        data's constant (exact for the data, hence for G) is from that of the continuous discrepancy.
    lipschitz_rel_change : float
        Relative change of L in the last refinement round.
    interp_error : float
        Largest distance of eps from its piecewise-linear interpolant at the last midpoints.
    min_bracket_gap : float
        min (u - l) over the domain samples (>= 0 when the extension is consistent).
    n_samples : int
        Boundary samples (Whitney data points).
    normal_bound_deg : float
        Largest angle between the normals of F and G over the face (180 = no bound): rigorous over the
        whole face (control-net bounds on Bézier pieces) where ``bound_kind`` is "rigorous", the maximum
        over the domain samples where it is "sampled".
    normal_bound_sampled_deg : float
        The pointwise bound's maximum over the domain samples (a lower estimate of the rigorous one).
    bound_kind : str
        "rigorous" or "sampled" (surfaces with too many Bézier pieces).
    normal_bound_first_order_deg : float
        arccos(1 - kappa^2 L_n^2 / 2), the corrected form of the paper's bound.
    normal_bound_paper_abs_deg : float
        arccos(1 - L^2/2 (E + 2|F| + G)/(EG - F^2)) with L = max L_i.
    worst_uv : (2,) float64
        Where the normal bound is largest.
    certified : bool
        normal_bound_deg < max_normal_angle_deg and l <= u (set again after the intersection test).
    problems : list of str
    """

    face: int
    name: str
    max_discrepancy: float
    max_discrepancy_bound: float
    perturbation_bound: float
    lipschitz: np.ndarray
    lipschitz_sampled: np.ndarray
    lipschitz_check_ratio: float
    lipschitz_rel_change: float
    interp_error: float
    min_bracket_gap: float
    n_samples: int
    normal_bound_deg: float
    normal_bound_sampled_deg: float
    bound_kind: str
    normal_bound_first_order_deg: float
    normal_bound_paper_abs_deg: float
    worst_uv: np.ndarray
    certified: bool
    problems: list


def _crossing(rect, segs_a: np.ndarray, segs_b: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """The segments (of those in idx) that meet the closed rectangle (Liang-Barsky clipping)."""
    u0, u1, v0, v1 = rect
    a, b = segs_a[idx], segs_b[idx]
    near = ((np.minimum(a[:, 0], b[:, 0]) <= u1) & (np.maximum(a[:, 0], b[:, 0]) >= u0)
            & (np.minimum(a[:, 1], b[:, 1]) <= v1) & (np.maximum(a[:, 1], b[:, 1]) >= v0))
    return idx[near][_meets_rect(rect, a[near], b[near])]


def _meets_rect(rect, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether each segment a -> b meets the closed rectangle (u0, u1, v0, v1), (n,) bool (Liang-Barsky)."""
    u0, u1, v0, v1 = rect
    d = b - a
    t0 = np.zeros(len(d))
    t1 = np.ones(len(d))
    ok = np.ones(len(d), dtype=bool)
    for p_, q_ in ((-d[:, 0], a[:, 0] - u0), (d[:, 0], u1 - a[:, 0]), (-d[:, 1], a[:, 1] - v0),
                   (d[:, 1], v1 - a[:, 1])):
        par = p_ == 0
        ok &= ~(par & (q_ < 0))
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(par, 0.0, q_ / np.where(par, 1.0, p_))
        t0 = np.where(~par & (p_ < 0), np.maximum(t0, r), t0)
        t1 = np.where(~par & (p_ > 0), np.minimum(t1, r), t1)
    return ok & (t0 <= t1)


def _inside(x: float, y: float, segs_a: np.ndarray, segs_b: np.ndarray) -> bool:
    """Even-odd ray cast (towards +u) of one point against all boundary segments."""
    ay, by = segs_a[:, 1], segs_b[:, 1]
    span = (ay > y) != (by > y)
    a, b = segs_a[span], segs_b[span]
    xc = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return bool(np.count_nonzero(xc > x) % 2)


def rect_meets_domain(rect, segs_a: np.ndarray, segs_b: np.ndarray, polys) -> bool:
    """Whether the closed (u, v) rectangle meets the polygonal domain (exact): a boundary segment meets the
    rectangle (Liang-Barsky clipping), or, when none does, the rectangle's centre is inside."""
    u0, u1, v0, v1 = rect
    if np.any(_meets_rect(rect, segs_a, segs_b)):
        return True
    return bool(points_in_polygons(np.array([[0.5 * (u0 + u1), 0.5 * (v0 + v1)]]), polys)[0])


def rigorous_normal_bound(g: PerturbedFace, reference_rad: float, *, max_depth: int = 5, max_pieces: int = 4096,
                          budget: int = 400) -> tuple[float, np.ndarray] | None:
    """The largest normal bound of Sec. 4 over the whole trimmed face, from control nets (rigorous).

    The surface's Bézier pieces that meet the face's (polygonal) domain (`rect_meets_domain`) each get the
    bound of `trimsurf.certify._intersect.bezier_piece_normal_bound`, which holds at every point of the
    piece; a piece whose bound is above 1.5 times `reference_rad` (the sampled maximum) or has no cone is
    split in four by de Casteljau (up to `max_depth` times, `budget` pieces in all) and only the parts
    meeting the domain are kept. Returns (phi_max, uv of the worst piece's centre), or None when the surface
    has more than `max_pieces` pieces or is not a NURBS surface (then the bound stays sampled).
    """
    from ..geom import bezier_extract_surface
    from ._intersect import _split_half, bezier_piece_normal_bound

    s = g.face.surface
    if not isinstance(s, NurbsSurface):     # e.g. a subdivision face's piecewise-linear surface
        return None
    bez = bezier_extract_surface(s.degree_u, s.degree_v, s.knots_u, s.knots_v, s.control_points, s.weights)
    ub, vb = bez.u_breaks, bez.v_breaks
    if (len(ub) - 1) * (len(vb) - 1) > max_pieces:
        return None
    w = np.ones(bez.control_points.shape[:-1]) if bez.weights is None else bez.weights
    hom = np.concatenate([bez.control_points * w[..., None], w[..., None]], axis=-1)
    polys = [lp.uv for lp in g.boundary.loops]
    segs_a = np.concatenate(polys)
    segs_b = np.concatenate([np.roll(p, -1, axis=0) for p in polys])
    everything = np.arange(len(segs_a))

    def meets(rect, idx):
        """(meets the domain, the boundary segments crossing the rect): a rect no segment crosses is wholly
        inside or wholly outside the domain; its children then need no test."""
        cross = _crossing(rect, segs_a, segs_b, idx)
        if len(cross):
            return True, cross
        return _inside(0.5 * (rect[0] + rect[1]), 0.5 * (rect[2] + rect[3]), segs_a, segs_b), cross

    stack = []
    for i in range(len(ub) - 1):
        for j in range(len(vb) - 1):
            rect = (float(ub[i]), float(ub[i + 1]), float(vb[j]), float(vb[j + 1]))
            ok, cross = meets(rect, everything)
            if ok:
                stack.append((hom[i, j], rect, 0, cross))
    worst, where = 0.0, np.zeros(2)
    target = 1.5 * reference_rad + 1e-12
    used = 0
    while stack:
        h, rect, depth, cross = stack.pop()
        used += 1
        res = bezier_piece_normal_bound(h, rect, g.lipschitz)
        phi = np.pi if res is None else res[2]
        if phi > target and depth < max_depth and used + 4 <= budget:
            um, vm = 0.5 * (rect[0] + rect[1]), 0.5 * (rect[2] + rect[3])
            left, right = _split_half(h, 0)
            for hu, (a, b) in ((left, (rect[0], um)), (right, (um, rect[1]))):
                bottom, top = _split_half(hu, 1)
                for hv, (c, d) in ((bottom, (rect[2], vm)), (top, (vm, rect[3]))):
                    r2 = (a, b, c, d)
                    if not len(cross):                  # the parent lies wholly inside the domain
                        stack.append((hv, r2, depth + 1, cross))
                        continue
                    ok, c2 = meets(r2, cross)
                    if ok:
                        stack.append((hv, r2, depth + 1, c2))
            continue
        if phi >= worst:
            worst, where = phi, np.array([0.5 * (rect[0] + rect[1]), 0.5 * (rect[2] + rect[3])])
    return float(worst), where


def domain_samples(g: PerturbedFace, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) points of the trimmed domain: an n x n grid inside the loops plus the boundary samples.

    Returns
    -------
    inside : (k, 2) float64
        Grid points inside.
    boundary : (b, 2) float64
    """
    polys = [lp.uv for lp in g.boundary.loops]
    lo, hi = polys[0].min(axis=0), polys[0].max(axis=0)
    gu, gv = np.meshgrid(np.linspace(lo[0], hi[0], n + 2)[1:-1], np.linspace(lo[1], hi[1], n + 2)[1:-1],
                         indexing="ij")
    grid = np.column_stack([gu.ravel(), gv.ravel()])
    # the grid only samples the domain: loops thinned to at most 2000 vertices each are enough for it
    thin = [p[:: max(1, len(p) // 2000)] for p in polys]
    grid = grid[points_in_polygons(grid, [t for t in thin if len(t) >= 3] or polys)]
    return grid, np.concatenate(polys)


def check_bracket(g: PerturbedFace, uv: np.ndarray) -> tuple[PerturbedFace, float, bool]:
    """Check l <= u at `uv`; raise L by 2 % steps while it fails. Returns (face, min(u - l), raised)."""
    raised = False
    for _ in range(_MAX_RAISES):
        lower, upper = g.bracket(uv)
        gap = float(np.min(upper - lower)) if len(uv) else 0.0
        scale = 1e-12 * max(float(np.abs(g._v).max(initial=0.0)), 1e-300)
        if gap >= -scale:
            return g, gap, raised
        g = PerturbedFace(g.face, g.boundary, g.lipschitz * 1.02)
        raised = True
    return g, gap, raised


def face_certificate(g: PerturbedFace, *, n_domain: int = 40,
                     max_normal_angle_deg: float = 90.0) -> tuple[FaceCertificate, PerturbedFace]:
    """Discrepancy, Lipschitz, l <= u and the normal bound of one perturbed face.

    Returns the certificate and the (possibly L-raised) perturbed face.
    """
    fb: FaceBoundary = g.boundary
    inside, bnd = domain_samples(g, n_domain)
    uv = np.concatenate([inside, bnd])
    g, gap, _ = check_bracket(g, inside if len(inside) else bnd[:1])
    d = g.face.surface.derivatives(uv, 1)
    su, sv = d[1, 0], d[0, 1]
    nrm = np.cross(su, sv)
    length = np.linalg.norm(nrm, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        nrm = nrm / length[:, None]
    nb = normal_angle_bound(su, sv, nrm, g.lipschitz)
    worst = int(np.argmax(nb.phi_rad))
    phi_sampled = float(np.degrees(nb.phi_rad[worst]))
    phi, kind = phi_sampled, "sampled"
    problems = []
    if phi_sampled < max_normal_angle_deg:
        rig = rigorous_normal_bound(g, float(nb.phi_rad[worst]))
        if rig is not None:
            phi, kind = max(float(np.degrees(rig[0])), phi_sampled), "rigorous"
            if phi >= max_normal_angle_deg:
                problems.append(f"face {fb.face}: rigorous normal bound {phi:.3g} deg (control nets, near uv "
                                f"({rig[1][0]:.6g}, {rig[1][1]:.6g})) not below {max_normal_angle_deg:g} deg "
                                f"(sampled maximum {phi_sampled:.3g} deg)")
    if phi_sampled >= max_normal_angle_deg:
        e, f_, g_ = (float(np.dot(a, b)) for a, b in ((su[worst], su[worst]), (su[worst], sv[worst]),
                                                       (sv[worst], sv[worst])))
        det_rel = (e * g_ - f_ * f_) / max((e + g_) ** 2, 1e-300)
        if not np.isfinite(nrm[worst]).all() or det_rel < 1e-10:
            why = f"F is singular there (a pole: EG - F^2 = {det_rel:.2g} (E + G)^2), Sec. 4 needs a regular patch"
        else:
            why = f"kappa*L = {nb.kappa_lf[worst]:.3g}" + (" >= 1" if nb.kappa_lf[worst] >= 1 else "")
        problems.append(f"face {fb.face}: normal bound {phi_sampled:.3g} deg at uv ({uv[worst, 0]:.6g}, {uv[worst, 1]:.6g}) "
                        f"not below {max_normal_angle_deg:g} deg ({why})")
    if fb.crossings is not None and len(fb.crossings):
        c0 = fb.crossings[0]
        problems.append(f"face {fb.face}: its trim polygon crosses itself ({len(fb.crossings)} crossing(s), first near "
                        f"uv ({c0[0]:.6g}, {c0[1]:.6g})): the boundary data has no Lipschitz constant there")
    if gap < 0:
        problems.append(f"face {fb.face}: l > u by {-gap:.3g} after raising L")
    cert = FaceCertificate(
        face=fb.face, name=g.face.name, max_discrepancy=fb.max_discrepancy,
        max_discrepancy_bound=fb.max_discrepancy + fb.interp_error, perturbation_bound=g.perturbation_bound,
        lipschitz=g.lipschitz.copy(), lipschitz_sampled=fb.lipschitz_sampled.copy(),
        lipschitz_check_ratio=fb.lipschitz_check_ratio, lipschitz_rel_change=fb.lipschitz_rel_change,
        interp_error=fb.interp_error, min_bracket_gap=gap, n_samples=fb.n_samples,
        normal_bound_deg=phi, normal_bound_sampled_deg=phi_sampled, bound_kind=kind,
        normal_bound_first_order_deg=float(np.degrees(np.max(nb.phi_first_order_rad))),
        normal_bound_paper_abs_deg=float(np.degrees(np.max(nb.phi_paper_abs_rad))), worst_uv=uv[worst].copy(),
        certified=not problems, problems=problems)
    return cert, g
