"""Filling curve networks with triangular Bézier patches (MNN paper, sections 4 and 6).

Every filler works on all facets at once (arrays over facets and their three sides).
Facet side k runs from corner k to corner k + 1; the network curve on it and, for
the G2 network, its cross-boundary field are taken in that orientation.

Exact G1 across the network curves comes from one rule shared by all fillers
(Chiyokura and Kimura): along a curve C(t) the cross-boundary derivative of each
patch is ``D(t) = k(t) g(t) + h(t) C'(t)`` with scalar polynomials k, h and a vector
field g(t) common to both patches of the curve (the linear field of unit vectors
N x C' at the ends for the cubic network, the optimized cubic field d(t) for the
G2 network), so both patches have the tangent plane span(C'(t), g(t)) along it.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.special import comb

from ..geom import bezier_triangle_derivatives, triangle_indices
from .network import CurveNetwork

__all__ = ["FacetPatches", "fill_split_quartic", "fill_single_quintic", "fill_split_sextic",
           "fill_single_septic"]


class FacetPatches:
    """Patches of one degree: ``control_points (P, N, 3)``, ``facet (P,)`` and ``sub (P,)``.

    ``sub`` is -1 for a single patch over the whole facet (corners 0, 1, 2 of the facet
    at barycentric e1, e2, e3), or k = 0, 1, 2 for the split patch over
    (corner k, corner k + 1, centroid).
    """

    __slots__ = ("degree", "control_points", "facet", "sub")

    def __init__(self, degree, control_points, facet, sub):
        self.degree = int(degree)
        self.control_points = np.ascontiguousarray(control_points, dtype=np.float64)
        self.facet = np.asarray(facet, dtype=np.int64)
        self.sub = np.asarray(sub, dtype=np.int64)


def _unit(x):
    n = np.linalg.norm(x, axis=-1, keepdims=True)
    return x / np.where(n > 0, n, 1.0)


def _dot(a, b):
    return np.einsum("...i,...i->...", a, b)


def _bprod(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Bernstein coefficients of the product of a scalar polynomial a (..., p+1) and a vector one b (..., q+1, 3)."""
    p, q = a.shape[-1] - 1, b.shape[-2] - 1
    out = np.zeros(a.shape[:-1] + (p + q + 1, b.shape[-1]))
    for i in range(p + 1):
        for j in range(q + 1):
            c = comb(p, i) * comb(q, j) / comb(p + q, i + j)
            out[..., i + j, :] += c * a[..., i, None] * b[..., j, :]
    return out


def _elevate_curve(c: np.ndarray, to: int) -> np.ndarray:
    """Degree-elevate Bézier curves c (..., n+1, d) to degree `to`."""
    while c.shape[-2] - 1 < to:
        n = c.shape[-2] - 1
        k = np.arange(1, n + 1)[:, None] / (n + 1)
        mid = k * c[..., :-1, :] + (1 - k) * c[..., 1:, :]
        c = np.concatenate([c[..., :1, :], mid, c[..., -1:, :]], axis=-2)
    return c


def _facet_data(net: CurveNetwork):
    """Corners (F,3,3), side curves (F,3,n+1,3), normals (F,3,3), side cross fields or None."""
    topo = net.topology
    T = topo.triangles
    fe, fw = topo.facet_edges, topo.facet_forward
    curves = net.curves[fe]
    curves = np.where(fw[:, :, None, None], curves, curves[:, :, ::-1])
    fields = None
    if net.cross_fields is not None:
        fields = net.cross_fields[fe]
        fields = np.where(fw[:, :, None, None], fields, fields[:, :, ::-1])
    return topo.vertices[T], curves, net.normals[T], fields, fe, fw


def _ck_field(net: CurveNetwork) -> np.ndarray:
    """Per-edge unit vectors g(0), g(1) = N x C' at both ends (M, 2, 3), canonical orientation."""
    c = net.curves
    e = net.topology.edges
    n = c.shape[1] - 1
    g0 = _unit(np.cross(net.normals[e[:, 0]], n * (c[:, 1] - c[:, 0])))
    g1 = _unit(np.cross(net.normals[e[:, 1]], n * (c[:, -1] - c[:, -2])))
    return np.stack([g0, g1], axis=1)


def _decompose(D, g, t):
    """Coefficients (k, h) with D ~ k g + h t (least squares in span(g, t))."""
    gg, gt, tt = _dot(g, g), _dot(g, t), _dot(t, t)
    gd, td = _dot(g, D), _dot(t, D)
    det = gg * tt - gt * gt
    det = np.where(np.abs(det) > 1e-300, det, 1e-300)
    return (tt * gd - gt * td) / det, (gg * td - gt * gd) / det


@lru_cache(maxsize=8)
def _positions(n: int) -> dict:
    idx = triangle_indices(n)
    return {tuple(int(x) for x in r): p for p, r in enumerate(idx)}


def _assemble(n: int, points: dict, shape) -> np.ndarray:
    pos = _positions(n)
    if set(points) != set(pos):  # pragma: no cover - internal consistency
        raise AssertionError(f"missing control points {set(pos) - set(points)}")
    order = sorted(pos, key=pos.get)
    return np.stack([np.broadcast_to(points[k], shape + (3,)) for k in order], axis=-2)


def _roll(x, s):
    """x[:, (k + s) % 3] for k = 0, 1, 2 (axis 1)."""
    return np.roll(x, -s, axis=1)


# ----------------------------------------------------------------------------- G1: quartic split


def fill_split_quartic(net: CurveNetwork, *, modified: bool = True) -> FacetPatches:
    """Shirman-Séquin split: three quartic patches per facet, exactly G1 (MNN paper, section 4).

    Each facet is split at its centroid Z into (V_k, V_k+1, Z). The inner boundary
    curves V_k -> Z are cubics (V_k, S_k, P_k, Z); S_k, the first inner control point,
    is the centroid of V_k and the neighbouring network control points B_k, C_k, and
    with ``modified=True`` the vector S_k - V_k is scaled by |s| / |l|: l joins V_k to
    the midpoint M of the opposite side, s is the circular arc from V_k through F(1/2)
    (F the opposite network curve) tangent to S_k - V_k ("Fig. 3"). Outer rows come from
    the Chiyokura-Kimura cross-boundary field; P_k, Z and the three inner points solve the
    G1 conditions ``D_left + D_right = mu(t) T`` across the inner curves exactly
    (mu linear from 3/rho_k at V_k to 3 at Z).

    Returns
    -------
    FacetPatches
        Degree 4, 3 F patches (facet f, sub k).
    """
    if net.degree != 3:
        raise ValueError("fill_split_quartic needs a cubic (G1) network")
    Vc, Ec, Nc, _, fe, fw = _facet_data(net)
    F = len(Vc)
    g = _ck_field(net)[fe]                       # (F, 3, 2, 3), canonical ends
    g = np.where(fw[:, :, None, None], g, g[:, :, ::-1])
    B = Ec[:, :, 1]                              # side k near V_k
    C = _roll(Ec, -1)[:, :, 2]                   # side k-1 near V_k
    S = Vc + (B + C - 2 * Vc) / 3.0
    rho = np.ones((F, 3))
    if modified:
        Fo = _roll(Ec, 1)                        # side k+1: opposite to V_k
        half = (Fo[:, :, 0] + 3 * Fo[:, :, 1] + 3 * Fo[:, :, 2] + Fo[:, :, 3]) / 8.0
        Mid = 0.5 * (Fo[:, :, 0] + Fo[:, :, 3])
        d = S - Vc
        ch = half - Vc
        c = np.linalg.norm(ch, axis=2)
        cos = np.clip(_dot(d, ch) / np.maximum(np.linalg.norm(d, axis=2) * c, 1e-300), -1, 1)
        th = np.minimum(np.arccos(cos), 1.75)
        arc = c * np.where(th > 1e-8, th / np.sin(np.where(th > 1e-8, th, 1.0)), 1.0)
        rho = arc / np.maximum(np.linalg.norm(Mid - Vc, axis=2), 1e-300)
        S = Vc + rho[..., None] * (S - Vc)
    S1 = _roll(S, 1)
    e = _elevate_curve(Ec, 4)                    # (F, 3, 5, 3)
    # Chiyokura-Kimura: D(t) = k(t) g(t) + h(t) E'(t), direction Z - V_k in sub-patch k
    dE = 3 * (Ec[:, :, 1:] - Ec[:, :, :-1])      # E' (F, 3, 3, 3)
    D0 = 3 * (S - Vc)
    D1 = 3 * (S1 - Ec[:, :, 2])
    k0, h0 = _decompose(D0, g[:, :, 0], dE[:, :, 0])
    k1, h1 = _decompose(D1, g[:, :, 1], dE[:, :, 2])
    D = _elevate_curve(_bprod(np.stack([k0, k1], -1), g), 3) + _bprod(np.stack([h0, h1], -1), dE)  # (F,3,4,3)
    r1 = e[:, :, 1] + D[:, :, 1] / 4
    r2 = e[:, :, 2] + D[:, :, 2] / 4
    mu0 = 3.0 / rho
    mu1 = 3.0
    r2prev = _roll(r2, -1)                       # sub-patch k-1's row point next to V_k
    P = S + (4 * (r1 + r2prev) - 2 * Vc - 6 * S - mu1 * (S - Vc)) / (2 * mu0[..., None])
    Z = P.mean(axis=1)
    R = (mu0[..., None] * (Z[:, None] - P) + 2 * mu1 * (P - S)) / 4 + S + P
    q = R.sum(axis=1, keepdims=True) / 2 - _roll(R, 2)
    P1 = _roll(P, 1)
    pts = {(4, 0, 0): Vc, (3, 1, 0): e[:, :, 1], (2, 2, 0): e[:, :, 2], (1, 3, 0): e[:, :, 3],
           (0, 4, 0): e[:, :, 4], (3, 0, 1): (Vc + 3 * S) / 4, (2, 1, 1): r1, (1, 2, 1): r2,
           (0, 3, 1): (e[:, :, 4] + 3 * S1) / 4, (2, 0, 2): (S + P) / 2, (1, 1, 2): q,
           (0, 2, 2): (S1 + P1) / 2, (1, 0, 3): (3 * P + Z[:, None]) / 4,
           (0, 1, 3): (3 * P1 + Z[:, None]) / 4, (0, 0, 4): np.repeat(Z[:, None], 3, axis=1)}
    cp = _assemble(4, pts, (F, 3)).reshape(3 * F, 15, 3)
    return FacetPatches(4, cp, np.repeat(np.arange(F), 3), np.tile(np.arange(3), F))


# ----------------------------------------------------------------------------- single patches


def _single_points(n: int, e: np.ndarray, rows: dict, interior: dict) -> dict:
    """Control points of single patches from side rows: e (F, 3, n+1, 3) side curves,
    rows {m: (F, 3, 3)} first-row points r_m of side k, interior {(i,j,l): (F, 3)}."""
    pts = {}
    for k in range(3):
        for m in range(n + 1):
            cnt = [0, 0, 0]
            cnt[k], cnt[(k + 1) % 3] = n - m, m
            pts[tuple(cnt)] = e[:, k, m]
        for m, r in rows.items():
            cnt = [0, 0, 0]
            cnt[k], cnt[(k + 1) % 3], cnt[(k + 2) % 3] = n - 1 - m, m, 1
            pts[tuple(cnt)] = r[:, k]
    pts.update(interior)
    return pts


def fill_single_quintic(net: CurveNetwork, *, twist: str = "average") -> FacetPatches:
    """One quintic patch per facet from a Chiyokura-Kimura field with averaged twists (not G1 in general).

    This is NOT Peters' construction (that is `fill_peters_quintic`, which starts from this
    patch). The sides are the degree-elevated network curves; the first rows come from the
    Chiyokura-Kimura field ``D = k g + h E'`` (cross-boundary derivative towards the
    opposite corner). At each corner the twist control point is claimed by both sides.
    With ``twist="match"`` k and h are quadratic and their middle coefficients (two per
    side, six per facet) are chosen, with the least change from linear k, h, so that both
    sides claim the same tangential twist; the normal parts still differ (the vertex
    enclosure problem of a cubic G1 network: the paper's "some error in the G1
    surface-surface match") and are averaged (facets where matching would flip the sign
    of k keep linear k, h). ``twist="average"`` (default) averages the claims of linear
    k, h. Measured max G1 error, average / match: shifted octahedron 18.3 / 1.9 degrees,
    but car panel 0.69 / 0.71, nefertiti 12.3 / 12.7, hole_sphere1 0.38 / 0.62, lilium
    1.5 / 1.7 (G1 network): matching wins only on coarse, symmetric-ish meshes. The
    remaining G1 error is what `g1_continuity` reports.
    """
    if net.degree != 3:
        raise ValueError("fill_single_quintic needs a cubic (G1) network")
    if twist not in ("match", "average"):
        raise ValueError(f"twist must be 'match' or 'average'; got {twist!r}")
    Vc, Ec, Nc, _, fe, fw = _facet_data(net)
    F = len(Vc)
    g = _ck_field(net)[fe]
    g = np.where(fw[:, :, None, None], g, g[:, :, ::-1])
    e = _elevate_curve(Ec, 5)
    dE = 3 * (Ec[:, :, 1:] - Ec[:, :, :-1])          # E' (quadratic)
    ddE = 2 * (dE[:, :, 1:] - dE[:, :, :-1])         # E'' (linear)
    E2 = _roll(Ec, 2)   # side k+2: V_{k+2} -> V_k
    E1 = _roll(Ec, 1)   # side k+1: V_{k+1} -> V_{k+2}
    D0 = 3 * (E2[:, :, 2] - Vc)
    D1 = 3 * (E1[:, :, 1] - Ec[:, :, 2])
    k0, h0 = _decompose(D0, g[:, :, 0], dE[:, :, 0])
    k1, h1 = _decompose(D1, g[:, :, 1], dE[:, :, 2])
    km, hm = 0.5 * (k0 + k1), 0.5 * (h0 + h1)
    if twist == "match":
        dg = g[:, :, 1] - g[:, :, 0]
        # D'(0) = 2 (km - k0) g0 + k0 g' + 2 (hm - h0) E'(0) + h0 E''(0)
        # D'(1) = 2 (k1 - km) g1 + k1 g' + 2 (h1 - hm) E'(1) + h1 E''(1)
        c0 = (-2 * k0[..., None] * g[:, :, 0] + k0[..., None] * dg - 2 * h0[..., None] * dE[:, :, 0]
              + h0[..., None] * ddE[:, :, 0])
        c1 = (2 * k1[..., None] * g[:, :, 1] + k1[..., None] * dg + 2 * h1[..., None] * dE[:, :, 2]
              + h1[..., None] * ddE[:, :, 1])
        # corner k: D'_k(0) + D'_{k+2}(1) = 20 (e_{k+2,3} - e_{k,1}) + 4 (D_{k+2}(1) - D_k(0))
        rhs = 20 * (_roll(e, 2)[:, :, 3] - e[:, :, 1]) + 4 * (_roll(D1, 2) - D0) - c0 - _roll(c1, 2)
        A = np.zeros((F, 3, 3, 6))                  # unknowns [km_k, hm_k] at 2k, 2k + 1
        for k in range(3):
            k2 = (k + 2) % 3
            A[:, k, :, 2 * k] = 2 * g[:, k, 0]
            A[:, k, :, 2 * k + 1] = 2 * dE[:, k, 0]
            A[:, k, :, 2 * k2] += -2 * g[:, k2, 1]
            A[:, k, :, 2 * k2 + 1] += -2 * dE[:, k2, 2]
        t1 = _unit(dE[:, :, 0])
        basis = np.stack([t1, np.cross(Nc, t1)], axis=2)                    # tangent planes
        At = np.einsum("fkcd,fkdu->fkcu", basis, A).reshape(F, 6, 6)
        bt = np.einsum("fkcd,fkd->fkc", basis, rhs).reshape(F, 6)
        xnat = np.stack([km, hm], axis=2).reshape(F, 6)
        AAt = At @ At.transpose(0, 2, 1)
        scale = np.maximum(np.abs(AAt).max(axis=(1, 2)), 1e-300)
        AAt = AAt + 1e-12 * scale[:, None, None] * np.eye(6)
        lam = np.linalg.solve(AAt, (bt - np.einsum("fcu,fu->fc", At, xnat))[..., None])[..., 0]
        x = (xnat + np.einsum("fcu,fc->fu", At, lam)).reshape(F, 3, 2)
        # keep a facet's matched twists only where k keeps its sign (no fold) and the change
        # stays moderate (an ill-conditioned corner system asks for wild k, h)
        kx, hx = x[..., 0], x[..., 1]
        ok = ((kx * k0 > 0) & (kx * k1 > 0)
              & (np.abs(kx - km) <= 5.0 * np.maximum(np.abs(k0), np.abs(k1)))).all(axis=1)
        km = np.where(ok[:, None], kx, km)
        hm = np.where(ok[:, None], hx, hm)
    kc = np.stack([k0, km, k1], -1)
    hc = np.stack([h0, hm, h1], -1)
    D = _elevate_curve(_bprod(kc, g), 4) + _bprod(hc, dE)                  # (F, 3, 5, 3)
    r = {m: e[:, :, m] + D[:, :, m] / 5 for m in (1, 2, 3)}
    tw = 0.5 * (r[1] + _roll(r[3], 2))          # at V_k: side k (m=1) and side k+2 (m=3)
    rows = {2: r[2]}
    inter = {}
    for k in range(3):
        cnt = [1, 1, 1]
        cnt[k] = 3
        inter[tuple(cnt)] = tw[:, k]
    cp = _assemble(5, _single_points(5, e, rows, inter), (F,))
    return FacetPatches(5, cp, np.arange(F), np.full(F, -1))


# ----------------------------------------------------------------------------- G2 network fillers


def _third_difference_energy(n: int) -> np.ndarray:
    """Sum of squared third differences of a triangular control net along its three net directions."""
    pos = _positions(n)
    rows = []
    for d in ((1, -1, 0), (0, 1, -1), (-1, 0, 1)):
        for key in pos:
            pts = [tuple(key[c] + q * d[c] for c in range(3)) for q in range(4)]
            if all(p in pos for p in pts):
                r = np.zeros(len(pos))
                for p, w in zip(pts, (1.0, -3.0, 3.0, -1.0)):
                    r[pos[p]] += w
                rows.append(r)
    R = np.array(rows)
    return R.T @ R


@lru_cache(maxsize=8)
def _split_operator(n: int, energy: str = "third", ref_degree: int = 0):
    """Linear map from the known points of a C1 centroid split of degree n to the rest.

    Known per facet: the rows l = 0 and l = 1 of the three sub-patches (3 (2n + 1) points,
    in the order side k: row 0 m = 0..n-1, then row 1 m = 0..n-1). Unknown: all points with
    l >= 2 (inner-curve points shared). The unknowns minimise a thin-plate energy of the
    three sub-patches subject to the C1 conditions across the inner curves (centroid split:
    ``b_k(n-1-m, 1, m) + b_{k-1}(1, n-1-m, m) + b_k(n-m, 0, m) = 3 b_k(n-1-m, 0, m+1)``).
    With `ref_degree` > 0 the energy is instead the squared distance (sampled) of the three
    sub-patches from a reference patch of that degree over the whole facet, plus 1e-6 of
    the third-difference energy; the map then also takes the reference control points.
    Returns (L (n_unknown, n_known [+ N_ref]), index map (3, N_n) into [known; unknown]).
    """
    idx = triangle_indices(n)
    Np = len(idx)
    gid = {}
    known, unknown = [], []

    def key(k, i, j, l):
        # canonical key for shared points: inner curve k points (i, 0, l) == sub k-1 (0, i, l)
        if l == n:
            return ("Z",)
        if j == 0:
            return ("in", k, l)
        if i == 0:
            return ("in", (k + 1) % 3, l)
        return ("p", k, i, j, l)

    for k in range(3):
        for m in range(n):
            known.append(("row0", k, m))
        for m in range(n):
            known.append(("row1", k, m))
    kpos = {kk: p for p, kk in enumerate(known)}
    for k in range(3):
        for (i, j, l) in idx:
            if l >= 2:
                kk = key(k, int(i), int(j), int(l))
                if kk not in gid:
                    gid[kk] = len(unknown)
                    unknown.append(kk)
    nk, nu = len(known), len(unknown)
    imap = np.zeros((3, Np), dtype=np.int64)
    for k in range(3):
        for p, (i, j, l) in enumerate(idx):
            i, j, l = int(i), int(j), int(l)
            if l == 0:
                imap[k, p] = kpos[("row0", k, j)] if j < n else kpos[("row0", (k + 1) % 3, 0)]
            elif l == 1:
                imap[k, p] = kpos[("row1", k, j)] if j < n - 1 else kpos[("row1", (k + 1) % 3, 0)]
            else:
                imap[k, p] = nk + gid[key(k, i, j, l)]
    pos = _positions(n)
    # thin-plate energy of one sub-patch in (s, t), sampled on a fine barycentric grid
    gridn = n + 4
    bary = np.array([(a, b, gridn - a - b) for a in range(gridn + 1) for b in range(gridn + 1 - a)], float) / gridn
    D = bezier_triangle_derivatives(np.eye(Np)[None], n, bary, n_derivs=2)[:, :, 0]  # (3,3,k,Np)
    Q = sum(c * D[a, b].T @ D[a, b] for (a, b, c) in ((2, 0, 1.0), (1, 1, 2.0), (0, 2, 1.0)))
    if energy == "third":
        Q = _third_difference_energy(n)
    H = np.zeros((nk + nu, nk + nu))
    for k in range(3):
        sel = imap[k]
        H[np.ix_(sel, sel)] += Q
    nr = 0
    if ref_degree:
        from ..geom import bezier_triangle_points
        nr = (ref_degree + 1) * (ref_degree + 2) // 2
        g = n + 3
        sub = np.array([(a, b, g - a - b) for a in range(g + 1) for b in range(g + 1 - a)], float) / g
        B = bezier_triangle_points(np.eye(Np), n, sub)                       # (k, Np)
        H *= 1e-6
        Gref = np.zeros((nk + nu, nr))
        for k in range(3):
            beta = np.zeros((len(sub), 3))
            beta[:, k] += sub[:, 0]
            beta[:, (k + 1) % 3] += sub[:, 1]
            beta += sub[:, 2:3] / 3.0
            R = bezier_triangle_points(np.eye(nr), ref_degree, beta)         # (k, nr)
            sel = imap[k]
            H[np.ix_(sel, sel)] += B.T @ B
            np.add.at(Gref, sel, B.T @ R)
    rows = []
    for k in range(3):
        km = (k - 1) % 3
        for m in range(1, n):
            r = np.zeros(nk + nu)
            r[imap[k, pos[(n - 1 - m, 1, m)]]] += 1
            r[imap[km, pos[(1, n - 1 - m, m)]]] += 1
            r[imap[k, pos[(n - m, 0, m)]]] += 1
            r[imap[k, pos[(n - 1 - m, 0, m + 1)]]] -= 3
            rows.append(r)
    Cm = np.array(rows)
    Huu, Huk = H[nk:, nk:], H[nk:, :nk]
    Cu, Ck = Cm[:, nk:], Cm[:, :nk]
    kkt = np.block([[Huu, Cu.T], [Cu, np.zeros((len(Cm), len(Cm)))]])
    rhs = np.vstack([-Huk, -Ck])
    if ref_degree:
        rhs = np.hstack([rhs, np.vstack([Gref[nk:], np.zeros((len(Cm), nr))])])
    sol = np.linalg.lstsq(kkt, rhs, rcond=None)[0][:nu]
    sol.setflags(write=False)
    imap.setflags(write=False)
    return sol, imap


def _split_from_rows(n, Vc, e, r_rows, energy="third", reference=None):
    """Assemble a C1 centroid split of degree n from side curves e (F,3,n+1,3) and
    first rows r_rows (F, 3, n, 3) (m = 0..n-1 of sub-patch k); `reference` optional
    (F, N_7, 3) degree-7 patches the interior is fitted to."""
    F = len(Vc)
    known = np.concatenate([e[:, :, :n], r_rows], axis=2)   # (F, 3, 2n, 3) in (side, row0 m / row1 m) order
    known = known.reshape(F, 3 * 2 * n, 3)
    if reference is not None:
        known = np.concatenate([known, reference], axis=1)
    L, imap = _split_operator(n, energy, 7 if reference is not None else 0)
    unknown = np.einsum("uk,fkd->fud", L, known)
    allp = np.concatenate([known[:, :6 * n], unknown], axis=1)
    cp = allp[:, imap]                                        # (F, 3, N, 3)
    return cp.reshape(3 * F, -1, 3)


def fill_split_sextic(net: CurveNetwork, *, fit_single: bool = True) -> FacetPatches:
    """Modified Shirman-Séquin split for the G2 network: three degree-6 patches per facet.

    The outer rows interpolate the network curves and the optimized cubic cross-boundary
    field d(t): ``D(t) = k(t) d(t) + h(t) C'(t)`` (k, h linear), so neighbouring facets
    meet G1 exactly; the sub-patches meet C1 across the inner curves (centroid split,
    first inner control points at the centroid of V_k and its two network neighbours).
    The remaining freedom (one precomputed linear map) fits the sub-patches to the single
    degree-7 patch of the facet (`fit_single`, least squares on samples), or minimizes the
    third differences of the control nets.
    """
    if net.degree != 5 or net.cross_fields is None:
        raise ValueError("fill_split_sextic needs the quintic G2 network")
    Vc, Ec, Nc, Fd, fe, fw = _facet_data(net)
    e = _elevate_curve(Ec, 6)
    D = _g2_side_derivatives_split(Vc, Ec, Fd, e)
    r = e[:, :, :6] + D / 6
    F = len(Vc)
    if fit_single:
        ref, _, kc = _septic_points(net)
        bad = _singular(ref, 7, Vc, kc, 0.05)       # a singular single patch is no reference
        cp = _split_from_rows(6, Vc, e, r, reference=ref).reshape(F, 3, -1, 3)
        if bad.any():
            cp[bad] = _split_from_rows(6, Vc[bad], e[bad], r[bad]).reshape(-1, 3, cp.shape[2], 3)
        cp = cp.reshape(3 * F, -1, 3)
    else:
        cp = _split_from_rows(6, Vc, e, r)
    return FacetPatches(6, cp, np.repeat(np.arange(F), 3), np.tile(np.arange(3), F))


def _g2_side_derivatives_split(Vc, Ec, Fd, e):
    """Cross-boundary derivative coefficients (F, 3, 6, 3) of the sextic split, direction Z - V_k."""
    # corner points b_k(5, 0, 1) = centroid of V_k and its two sextic neighbours (C1 at V_k)
    corner = (Vc + e[:, :, 1] + _roll(e, -1)[:, :, 5]) / 3
    D0 = 6 * (corner - Vc)
    D1 = 6 * (_roll(corner, 1) - e[:, :, 5])
    dE = 5 * (Ec[:, :, 1:] - Ec[:, :, :-1])        # C' (quartic)
    k0, h0 = _decompose(D0, Fd[:, :, 0], dE[:, :, 0])
    k1, h1 = _decompose(D1, Fd[:, :, 3], dE[:, :, 4])
    return (_elevate_curve(_bprod(np.stack([k0, k1], -1), Fd), 5)
            + _bprod(np.stack([h0, h1], -1), dE))


def fill_single_septic(net: CurveNetwork, *, fallback: bool = True, min_jacobian: float = 0.05):
    """One degree-7 patch per facet for the G2 network (MNN paper, section 6), G1 across curves.

    ``D(t) = k(t) d(t) + h(t) C'(t)`` with k cubic and h quadratic. At each corner the
    twist point is shared by two sides; since the network is G2 (common second
    fundamental form, d' consistent with it) the normal parts of both sides' twists
    agree, and the tangential parts are matched by choosing k'(0), k'(1) and the middle
    coefficient of h per side (a 6 x 9 minimum-change problem per facet). Facets whose
    patch would be singular (cross-boundary derivative parallel to the curve, or a
    Jacobian below `min_jacobian` of its median) are filled with the degree-6 split,
    elevated to degree 7, when `fallback` is set.

    Returns
    -------
    patches : FacetPatches
        Degree 7.
    n_fallback : int
        Facets filled with the split.
    """
    if net.degree != 5 or net.cross_fields is None:
        raise ValueError("fill_single_septic needs the quintic G2 network")
    cp, Vc, kc = _septic_points(net)
    F = len(Vc)
    n_fb = 0
    if fallback:
        bad = _singular(cp, 7, Vc, kc, min_jacobian)
        n_fb = int(bad.sum())
        if n_fb:
            split = fill_split_sextic(net, fit_single=False)
            from ..geom import elevate_bezier_triangle
            scp = elevate_bezier_triangle(split.control_points, 6, 1).reshape(F, 3, -1, 3)
            keep = np.flatnonzero(~bad)
            fb = np.flatnonzero(bad)
            cps = np.concatenate([cp[keep], scp[fb].reshape(-1, cp.shape[1], 3)])
            facet = np.r_[keep, np.repeat(fb, 3)]
            sub = np.r_[np.full(len(keep), -1), np.tile(np.arange(3), len(fb))]
            return FacetPatches(7, cps, facet, sub), n_fb
    return FacetPatches(7, cp, np.arange(F), np.full(F, -1)), n_fb


def _septic_points(net: CurveNetwork):
    """Control points (F, 36, 3) of the single degree-7 patches, corners (F, 3, 3), k coefficients."""
    Vc, Ec, Nc, Fd, fe, fw = _facet_data(net)
    F = len(Vc)
    e = _elevate_curve(Ec, 7)
    dC = 5 * (Ec[:, :, 1:] - Ec[:, :, :-1])          # C' quartic coefficients (F,3,5,3)
    ddC = 4 * (dC[:, :, 1:] - dC[:, :, :-1])         # C'' cubic
    dd = 3 * (Fd[:, :, 1:] - Fd[:, :, :-1])          # d' quadratic
    E2 = _roll(Ec, 2)
    E1 = _roll(Ec, 1)
    D0 = 5 * (E2[:, :, 4] - Vc)
    D1 = 5 * (E1[:, :, 1] - Ec[:, :, 4])
    k0, h0 = _decompose(D0, Fd[:, :, 0], dC[:, :, 0])
    k1, h1 = _decompose(D1, Fd[:, :, 3], dC[:, :, 4])
    # D'(0) = kp0 d(0) + 2 (hm - h0) C'(0) + [k0 d'(0) + h0 C''(0)]
    # D'(1) = kp1 d(1) + 2 (h1 - hm) C'(1) + [k1 d'(1) + h1 C''(1)]
    c0 = k0[..., None] * dd[:, :, 0] + h0[..., None] * ddC[:, :, 0] - 2 * h0[..., None] * dC[:, :, 0]
    c1 = k1[..., None] * dd[:, :, 2] + h1[..., None] * ddC[:, :, 3] + 2 * h1[..., None] * dC[:, :, 4]
    # corner k: D'_k(0) + D'_{k+2}(1) = 42 (e_{k+2,5} - e_{k,1}) + 6 (D_{k+2}(1) - D_k(0))
    rhs = (42 * (_roll(e, 2)[:, :, 5] - e[:, :, 1]) + 6 * (_roll(D1, 2) - D0)
           - c0 - _roll(c1, 2))
    # unknowns per facet: [kp0_k, kp1_k, hm_k] for k = 0, 1, 2 -> column 3k + (0, 1, 2)
    A = np.zeros((F, 3, 3, 9))
    for k in range(3):
        k2 = (k + 2) % 3
        A[:, k, :, 3 * k + 0] = Fd[:, k, 0]
        A[:, k, :, 3 * k + 2] = 2 * dC[:, k, 0]
        A[:, k, :, 3 * k2 + 1] = Fd[:, k2, 3]
        A[:, k, :, 3 * k2 + 2] += -2 * dC[:, k2, 4]
    # tangential parts only (normal parts agree for a G2 network)
    t1 = _unit(dC[:, :, 0])
    t2 = np.cross(Nc, t1)
    basis = np.stack([t1, t2], axis=2)                                   # (F, 3, 2, 3)
    At = np.einsum("fkcd,fkdu->fkcu", basis, A).reshape(F, 6, 9)
    bt = np.einsum("fkcd,fkd->fkc", basis, rhs).reshape(F, 6)
    xnat = np.stack([k1 - k0, k1 - k0, 0.5 * (h0 + h1)], axis=2).reshape(F, 9)
    AAt = At @ At.transpose(0, 2, 1)
    res = bt - np.einsum("fcu,fu->fc", At, xnat)
    scale = np.maximum(np.abs(AAt).max(axis=(1, 2)), 1e-300)
    AAt = AAt + 1e-13 * scale[:, None, None] * np.eye(6)
    lam = np.linalg.solve(AAt, res[..., None])[..., 0]
    x = (xnat + np.einsum("fcu,fc->fu", At, lam)).reshape(F, 3, 3)
    kp0, kp1, hm = x[..., 0], x[..., 1], x[..., 2]
    kc = np.stack([k0, k0 + kp0 / 3, k1 - kp1 / 3, k1], -1)
    hc = np.stack([h0, hm, h1], -1)
    D = _bprod(kc, Fd) + _bprod(hc, dC)                                # (F, 3, 7, 3)
    r = {m: e[:, :, m] + D[:, :, m] / 7 for m in range(1, 6)}
    twist = 0.5 * (r[1] + _roll(r[5], 2))
    rows = {2: r[2], 3: r[3], 4: r[4]}
    inter = {}
    for k in range(3):
        cnt = [1, 1, 1]
        cnt[k] = 5
        inter[tuple(cnt)] = twist[:, k]
    # the three points with all indices >= 2 take the least sum of squared third differences
    # of the net (reproduces quadratic patches; one constant 3 x 33 map)
    free = [(3, 2, 2), (2, 3, 2), (2, 2, 3)]
    pts = _single_points(7, e, rows, inter)
    for a in free:
        pts[a] = np.zeros_like(twist[:, 0])
    cp = _assemble(7, pts, (F,))
    pos = _positions(7)
    fi = np.array([pos[a] for a in free])
    Q = _third_difference_energy(7)
    rest = np.setdiff1d(np.arange(len(pos)), fi)
    Mfree = -np.linalg.solve(Q[np.ix_(fi, fi)], Q[np.ix_(fi, rest)])
    cp[:, fi] = np.einsum("ar,frd->fad", Mfree, cp[:, rest])
    return cp, Vc, kc


def _singular(cp, n, Vc, kc, min_jacobian):
    """Facets whose single patch is singular or folds: k(t) changes sign, or small Jacobian."""
    t = np.linspace(0, 1, 9)
    from ._hermite import bernstein
    kv = np.einsum("tc,fkc->fkt", bernstein(3, t), kc)
    sign_change = (kv.min(axis=2) * kv.max(axis=2) <= 0).any(axis=1)
    g = 8
    bary = np.array([(a, b, g - a - b) for a in range(g + 1) for b in range(g + 1 - a)], float) / g
    D = bezier_triangle_derivatives(cp, n, bary, n_derivs=1)
    cr = np.cross(D[1, 0], D[0, 1])                     # (F, k, 3)
    nf = _unit(np.cross(Vc[:, 1] - Vc[:, 0], Vc[:, 2] - Vc[:, 0]))
    jac = np.einsum("fkd,fd->fk", cr, nf)
    med = np.median(np.linalg.norm(cr, axis=2), axis=1)
    return sign_change | (jac.min(axis=1) < min_jacobian * med)
