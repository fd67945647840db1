"""Peters' filling of a cubic G1 network: one quintic patch per facet (MNN paper, sections 2.2 and 4).

Peters, *Smooth interpolation of a mesh of curves* (Constr. Approx. 7, 1991), as the MNN
paper uses it: every facet of the cubic network is filled with ONE quintic triangular
Bézier patch whose sides are the (degree-elevated) network curves. Two patches p, q that
share a curve c(t) meet G1 when their cross-boundary derivatives satisfy, for all t,

    alpha(t) D_p(t) + beta(t) D_q(t) = gamma(t) c'(t)                            (G1)

with scalar weight polynomials: alpha, beta linear, gamma cubic (D_p, D_q are quartic,
c' quadratic, so both sides are quintic). The MNN paper gives neither the weights'
degrees nor formulas; these are the lowest degrees that fit a quintic patch on a cubic
network and let alpha/beta differ at the two ends (it must: it is fixed by the tangents
there). alpha, beta and gamma at the two ends are
fixed by the curve tangents at the vertices (alpha(0) D_p(0) + beta(0) D_q(0) is
parallel to c'(0) in the vertex's tangent plane; normalized alpha + beta = 2); the
inner coefficients gamma_1, gamma_2 and the six inner control points of every patch
(three corner twists, three side-middle points) are unknowns. The Bernstein
coefficients 1..4 of (G1) are linear equations in them (12 per shared curve).

Vertex enclosure problem (VEP): around an inner vertex of valence n the normal
components of coefficient 1 form a cyclic n x n system in the twists' heights; its
determinant is prod(alpha_0) - (-1)^n prod(beta_0) and prod(alpha_0) = prod(beta_0)
always (the tangent cross-products telescope), so for even n it is singular: the
system is solvable only if the network's curves satisfy Peters' vertex enclosure
constraint on their curvatures. A G1 MNN network does not in general; a G2 network
(common second fundamental form) does. As the MNN paper says, with these weight
degrees the problem does not decouple into local ones ("either the weight-polynomials
have to be degree-reduced, which results in a surface that is not G1, or a global
linear system has to be solved"): we solve the global sparse least-squares system
(damped, see `fill_peters_quintic`), starting from and staying close to the
Chiyokura-Kimura quintic (`fill_single_quintic`). The result is G1 wherever the system is consistent (odd
valence, boundary vertices, even valence where the VEP happens to be solvable); at
the other vertices the equations keep the least-squares residual and the surface has
"some error in the G1 surface-surface match" (MNN paper, section 4), which the report
measures.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse.linalg import splu
from scipy.special import comb

from .fill import FacetPatches, _positions, fill_single_quintic
from .network import CurveNetwork

__all__ = ["fill_peters_quintic"]

_N = 5
# relative residual of the G1 equations above which a vertex counts as not G1 (~1e-6 rad)
_RESIDUAL_TOL = 1e-6
# the six inner control points of a quintic (three corner twists, three side middles)
_INNER = ((3, 1, 1), (1, 3, 1), (1, 1, 3), (2, 2, 1), (1, 2, 2), (2, 1, 2))


def _row_tables():
    """Positions of row 0 (side k, m = 0..5) and row 1 (m = 0..4) of every side, and the
    inner-point slot (0..5, or -1 on the boundary) of row 1."""
    pos = _positions(_N)
    inner = {key: i for i, key in enumerate(_INNER)}
    r0 = np.zeros((3, _N + 1), np.int64)
    r1 = np.zeros((3, _N), np.int64)
    slot = np.full((3, _N), -1, np.int64)
    for k in range(3):
        for m in range(_N + 1):
            cnt = [0, 0, 0]
            cnt[k], cnt[(k + 1) % 3] = _N - m, m
            r0[k, m] = pos[tuple(cnt)]
        for m in range(_N):
            cnt = [0, 0, 0]
            cnt[k], cnt[(k + 1) % 3], cnt[(k + 2) % 3] = _N - 1 - m, m, 1
            r1[k, m] = pos[tuple(cnt)]
            slot[k, m] = inner.get(tuple(cnt), -1)
    return r0, r1, slot, np.array([pos[k] for k in _INNER])


def _end_weights(Dp, Dq, c, n):
    """alpha, beta, gamma with alpha Dp + beta Dq = gamma c in the plane normal to n, alpha + beta = 2."""
    a = np.einsum("ei,ei->e", np.cross(Dq, c), n)
    b = -np.einsum("ei,ei->e", np.cross(Dp, c), n)
    s = a + b
    s = np.where(np.abs(s) > 1e-300, s, 1.0)
    a, b = 2 * a / s, 2 * b / s
    g = np.einsum("ei,ei->e", a[:, None] * Dp + b[:, None] * Dq, c) / np.maximum(np.einsum("ei,ei->e", c, c), 1e-300)
    return a, b, g


def fill_peters_quintic(net: CurveNetwork, *, iterations: int = 8, damping: float = 1e-3) -> tuple[FacetPatches, dict]:
    """Peters' scheme: one quintic per facet, G1 by scalar weight functions (see the module text).

    Parameters
    ----------
    net : CurveNetwork
        A cubic network ("g1" or "shirman-sequin").
    iterations, damping : int, float
        The least-squares system is solved by `iterations` damped steps (proximal point
        iteration, Tikhonov weight `damping` times the largest squared column norm of one
        curve's equations), each from the last: components the equations fix well converge
        to the exact solution, nearly singular ones (where G1 would need large
        control-point moves: the VEP, and curves whose weights have nearly the same ratio
        alpha/beta at both ends) stay near the reference. Measured on nefertiti (G1 MNN
        network), damping 1e-1 / 1e-3 / 1e-5 / 1e-9: G1 error 3.70 / 3.67 / 3.39 / 4.40
        degrees, curvature jump across the edges 63 / 84 / 152 / 27736 per model unit (the
        split fill: 101); on the icosphere (VEP solvable) 5e-4 / 2e-5 / 7e-10 / 3e-13 degrees.

    Returns
    -------
    patches : FacetPatches
        Degree 5, one patch per facet (sub = -1).
    info : dict
        ``g1_condition_residual_max`` (largest residual of the G1 equations relative to the
        curve's derivative size; ~1e-15 where the system is consistent and solved undamped),
        ``vep_even_vertices`` (inner vertices of even valence, where the vertex enclosure
        constraint applies), ``g1_residual_vertices`` (vertices at which the G1 equations of
        an incident curve keep a relative residual above 1e-6: the VEP, or both ends of a
        curve coupled when its weights have the same ratio alpha/beta at both ends),
        ``weight_sign_changes`` (curves where alpha or beta is not positive at an end: the
        weights vanish inside and the joint cannot be G1 there).
    """
    if net.degree != 3:
        raise ValueError("fill_peters_quintic needs a cubic (G1) network")
    topo = net.topology
    T = topo.triangles
    F = len(T)
    ref = fill_single_quintic(net)
    cp = ref.control_points.copy()                              # (F, 21, 3)
    r0, r1, slot, inner_pos = _row_tables()
    fe, fw = topo.facet_edges, topo.facet_forward
    M = len(topo.edges)
    fa = np.full(M, -1)
    sa = np.full(M, -1)
    fb = np.full(M, -1)
    sb = np.full(M, -1)
    f_idx, s_idx = np.nonzero(fw)
    fa[fe[f_idx, s_idx]], sa[fe[f_idx, s_idx]] = f_idx, s_idx
    f_idx, s_idx = np.nonzero(~fw)
    fb[fe[f_idx, s_idx]], sb[fe[f_idx, s_idx]] = f_idx, s_idx
    e_in = np.flatnonzero((fa >= 0) & (fb >= 0))
    fa, sa, fb, sb = fa[e_in], sa[e_in], fb[e_in], sb[e_in]
    ne = len(e_in)
    info = {"vep_even_vertices": 0, "g1_residual_vertices": 0, "g1_condition_residual_max": 0.0,
            "weight_sign_changes": 0}
    valence = np.bincount(topo.edges.ravel(), minlength=topo.n_vertices)
    info["vep_even_vertices"] = int(((valence % 2 == 0) & ~topo.boundary_vertices).sum())
    if ne == 0:
        return FacetPatches(_N, cp, np.arange(F), np.full(F, -1)), info
    # cross-boundary derivatives (quartic) of p (side sa, towards its third corner) and q (reversed to the edge's t)
    Dp = _N * (cp[fa[:, None], r1[sa]] - cp[fa[:, None], r0[sa, :_N]])           # (ne, 5, 3)
    Dq = (_N * (cp[fb[:, None], r1[sb]] - cp[fb[:, None], r0[sb, :_N]]))[:, ::-1]
    c = net.curves[e_in]
    dc = 3 * (c[:, 1:] - c[:, :-1])                                               # c' (ne, 3, 3)
    E = topo.edges[e_in]
    a0, b0, g0 = _end_weights(Dp[:, 0], Dq[:, 0], dc[:, 0], net.normals[E[:, 0]])
    a1, b1, g3 = _end_weights(Dp[:, 4], Dq[:, 4], dc[:, 2], net.normals[E[:, 1]])
    info["weight_sign_changes"] = int(((a0 <= 0) | (b0 <= 0) | (a1 <= 0) | (b1 <= 0)).sum())
    scale = np.maximum(np.linalg.norm(dc, axis=2).mean(axis=1), 1e-300)          # gamma variables times this
    gam = np.stack([g0, (2 * g0 + g3) / 3, (g0 + 2 * g3) / 3, g3], axis=1)          # reference gamma (cubic)
    alpha = np.stack([a0, a1], 1)
    beta = np.stack([b0, b1], 1)

    def lin(w, D, j):   # Bernstein coefficient j (of 6) of linear w times quartic D
        out = 0.0
        if j <= 4:
            out = out + (_N - j) / _N * w[:, 0, None] * D[:, j]
        if j >= 1:
            out = out + j / _N * w[:, 1, None] * D[:, j - 1]
        return out

    def gc(j):          # coefficient j of gamma (cubic) times c' (quadratic)
        out = 0.0
        for i in range(max(0, j - 2), min(3, j) + 1):
            out = out + comb(3, i) * comb(2, j - i) / comb(5, j) * gam[:, i, None] * dc[:, j - i]
        return out

    J = (1, 2, 3, 4)
    resid = np.stack([lin(alpha, Dp, j) + lin(beta, Dq, j) - gc(j) for j in J], axis=1)   # (ne, 4, 3)
    # Jacobian of the residual of edge e (12 rows: j = 1..4 times xyz) in its unknowns, dense per
    # edge: the four corner twists it touches (p at a, p at b, q at a, q at b; shared with the
    # neighbouring curves) and its private unknowns (the side-middle points of p and q, and
    # gamma_1, gamma_2 times `scale`), which are eliminated edge by edge (Schur complement)
    I3 = np.eye(3)
    At = np.zeros((ne, 4, 3, 4, 3))
    Ap = np.zeros((ne, 4, 3, 8))
    for ji, j in enumerate(J):
        for m in (1, 2, 3):
            cp_ = (_N - j) / _N * a0 * (m == j) + j / _N * a1 * (m == j - 1)
            cq_ = (_N - j) / _N * b0 * (m == j) + j / _N * b1 * (m == j - 1)
            if m == 2:
                Ap[:, ji, :, 0:3] += _N * cp_[:, None, None] * I3
                Ap[:, ji, :, 3:6] += _N * cq_[:, None, None] * I3
            else:
                At[:, ji, :, 0 if m == 1 else 1, :] += _N * cp_[:, None, None] * I3
                At[:, ji, :, 2 if m == 1 else 3, :] += _N * cq_[:, None, None] * I3
        for i in (1, 2):
            if 0 <= j - i <= 2:
                w = -comb(3, i) * comb(2, j - i) / comb(5, j)
                Ap[:, ji, :, 5 + i] = w * dc[:, j - i] / scale[:, None]
    At = At.reshape(ne, 12, 12)
    Ap = Ap.reshape(ne, 12, 8)
    # global twist columns: 9 per facet (3 corner twists x xyz)
    tw_col = np.stack([9 * fa + 3 * slot[sa, 1], 9 * fa + 3 * slot[sa, 3],
                       9 * fb + 3 * slot[sb, 3], 9 * fb + 3 * slot[sb, 1]], axis=1)       # (ne, 4)
    cols = (tw_col[:, :, None] + np.arange(3)).reshape(ne, 12)
    scale2 = max(float(np.einsum("eij,eij->ej", At, At).max()), float(np.einsum("eij,eij->ej", Ap, Ap).max()), 1e-300)
    mu = damping * scale2
    Kinv = np.linalg.inv(np.einsum("eri,erj->eij", Ap, Ap) + mu * np.eye(8))            # (ne, 8, 8)
    ApK = np.einsum("eri,eij->erj", Ap, Kinv)                                            # (ne, 12, 8)
    Q = np.eye(12) - np.einsum("eri,esi->ers", ApK, Ap)                                  # I - Ap K^-1 Ap^T
    QAt = np.einsum("ers,esc->erc", Q, At)
    Sblk = np.einsum("erc,erd->ecd", At, QAt)                                            # (ne, 12, 12)
    n_t = 9 * F
    S = sparse.csr_matrix((Sblk.reshape(-1), (np.repeat(cols, 12, axis=1).reshape(-1),
                                               np.tile(cols, (1, 12)).reshape(-1))), shape=(n_t, n_t))
    S = (S + mu * sparse.identity(n_t, format="csr")).tocsc()
    # S is symmetric positive definite: diagonal pivots are stable and keep the MMD ordering
    lu = splu(S, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    rhs = -resid.reshape(ne, 12)
    x_t = np.zeros(n_t)
    x_p = np.zeros((ne, 8))
    res = rhs.copy()
    for _ in range(max(int(iterations), 1)):
        g = np.zeros(n_t)
        np.add.at(g, cols, np.einsum("ers,er->es", QAt, res))
        dt = lu.solve(g)
        x_t += dt
        dp = np.einsum("erj,er->ej", ApK, res - np.einsum("erc,ec->er", At, dt[cols]))
        x_p += dp
        res = rhs - np.einsum("erc,ec->er", At, x_t[cols]) - np.einsum("erj,ej->er", Ap, x_p)
    d_pts = np.zeros((F, 6, 3))
    d_pts[:, :3] = x_t.reshape(F, 3, 3)
    np.add.at(d_pts, (fa, slot[sa, 2]), x_p[:, 0:3])
    np.add.at(d_pts, (fb, slot[sb, 2]), x_p[:, 3:6])
    cp[:, inner_pos] += d_pts
    # final residual, relative to the curve derivative size
    rel = np.linalg.norm(res.reshape(ne, 4, 3), axis=2) / scale[:, None]        # (ne, 4)
    info["g1_condition_residual_max"] = float(rel.max())
    bad = np.zeros(topo.n_vertices, bool)
    bad[E[rel[:, 0] > _RESIDUAL_TOL, 0]] = True
    bad[E[rel[:, 3] > _RESIDUAL_TOL, 1]] = True
    info["g1_residual_vertices"] = int(bad.sum())
    return FacetPatches(_N, cp, np.arange(F), np.full(F, -1)), info
