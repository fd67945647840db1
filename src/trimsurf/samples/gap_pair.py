"""`gap_pair`: two adjacent trimmed faces whose shared edge is inconsistent (a small gap)."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..model import Loop, NurbsCurve, NurbsSurface, PCurve, Shell, TrimmedFace
from ._build import assemble_shell, line, with_edge_curves

__all__ = ["gap_pair", "GAP_REL", "GAP_PAIR_TOLERANCE"]

#: Largest distance between a face's p-curve image F_k(p_k(t)) and the shared edge curve b(t),
#: relative to the bounding-box diagonal of the pair.
GAP_REL = 1e-3

#: Stated tolerance of the edges and faces (mm); far below the gap, so the edge is inconsistent.
GAP_PAIR_TOLERANCE = 1e-4

_KNOTS_U = np.r_[[0.0] * 4, 0.5, [1.0] * 4]
_KNOTS_V = np.r_[[0.0] * 4, 0.3, 0.6, [1.0] * 4]


def _greville(knots: np.ndarray, degree: int = 3) -> np.ndarray:
    return np.array([knots[i + 1:i + degree + 1].mean() for i in range(len(knots) - degree - 1)])


def _surfaces() -> tuple[NurbsSurface, NurbsSurface]:
    """Two bicubic surfaces meeting at x = 500 mm along their boundaries u = 1 (left) and u = 0 (right).

    They share the boundary row of control points exactly (so S1(1, v) = S2(0, v))
    and meet at a crease of a few degrees, like a fender meeting a door.
    """
    gu, gv = np.meshgrid(_greville(_KNOTS_U), _greville(_KNOTS_V), indexing="ij")
    y = 600.0 * gv
    ridge = 40.0 * np.sin(np.pi * gv) + 25.0 * gv ** 2          # shared boundary height profile

    x1 = 500.0 * gu
    z1 = ridge + 0.12 * (x1 - 500.0) - 30.0 * ((x1 - 500.0) / 500.0) ** 2 * (1 + gv)
    x2 = 500.0 + 500.0 * gu
    z2 = ridge - 0.05 * (x2 - 500.0) + 20.0 * np.sin(np.pi * (x2 - 500.0) / 500.0) * gv
    cp1, cp2 = np.stack([x1, y, z1], -1), np.stack([x2, y, z2], -1)
    cp2[0] = cp1[-1]                                             # identical boundary row
    return (NurbsSurface(3, 3, _KNOTS_U, _KNOTS_V, cp1), NurbsSurface(3, 3, _KNOTS_U, _KNOTS_V, cp2))


def _inset(profile: np.ndarray) -> NurbsCurve:
    """The p-curve (a(t), t) with the cubic B-spline inset a(t) given by its coefficients.

    The Greville abscissae as second coordinate reproduce t exactly.
    """
    t = np.r_[[0.0] * 4, 1 / 3, 2 / 3, [1.0] * 4]
    return NurbsCurve(3, t, np.column_stack([profile, _greville(t)]))


def gap_pair(*, gap_rel: float = GAP_REL) -> Shell:
    """Two adjacent trimmed faces with an inconsistent shared edge.

    Two bicubic B-spline faces (each 500 x 600 mm, model units mm) meet along
    x = 500 mm, where their surfaces share the boundary curve exactly. That
    curve is the shared edge's 3D curve b(t) (`Shell.edges[0]`, used by both
    faces). The faces' p-curves along it are pulled into their domains by a
    smooth inset that varies along the edge, so each image F_k(p_k(t)) misses
    b(t) by a gap of between about 0.2 and 1 times ``gap_rel`` times the
    bounding-box diagonal (largest exactly ``gap_rel * diagonal`` to 1%), and the
    two images are up to about twice that apart: the boundary discrepancy
    that the Whitney perturbation (certify) and the patch join remove.

    Face 0's p-curve runs with b(t) (t from 0 to 1), face 1's against it
    (t from 1 to 0), as in a consistently oriented shell. Both faces' loops are
    closed in (u, v) and counter-clockwise; the other six edges are free and
    their edge curves match F(p(t)) within `GAP_PAIR_TOLERANCE`.

    Parameters
    ----------
    gap_rel : float
        Largest gap between a p-curve image and b(t), relative to the diagonal.

    Returns
    -------
    Shell
        Two faces, seven edges (one shared by both faces), six vertices.
    """
    if not (np.isfinite(gap_rel) and 0 < gap_rel < 0.05):
        raise InputError(f"gap_pair: gap_rel must be in (0, 0.05); got {gap_rel!r}")
    s1, s2 = _surfaces()
    kv = _KNOTS_V
    b = NurbsCurve(3, kv, s1.control_points[-1])               # b(t) = S1(1, t) = S2(0, t), exact

    # insets in u (shape chosen to vary along the edge); scaled below to the requested gap
    shape1 = np.array([0.4, 0.6, 1.0, 0.7, 0.3, 0.5])
    shape2 = np.array([0.2, 0.9, 0.5, 0.3, 0.8, 0.6])
    t = np.linspace(0.0, 1.0, 2001)
    diag = _diagonal(s1, s2)
    # |F(p(t)) - b(t)| ~ a(t) |S_u|; scale the insets so the largest gap is gap_rel * diagonal (two passes)
    scale1 = scale2 = gap_rel * diag / 500.0
    for _ in range(2):
        a1, a2 = _inset(scale1 * shape1), _inset(scale2 * shape2)
        p1 = NurbsCurve(3, a1.knots, np.column_stack([1.0 - a1.control_points[:, 0], a1.control_points[:, 1]]))
        p2 = NurbsCurve(3, a2.knots, a2.control_points)
        g1 = np.linalg.norm(s1.evaluate(p1.evaluate(t)) - b.evaluate(t), axis=1).max()
        g2 = np.linalg.norm(s2.evaluate(p2.evaluate(t)) - b.evaluate(t), axis=1).max()
        scale1 *= gap_rel * diag / g1
        scale2 *= gap_rel * diag / g2

    a1_0, a1_1 = p1.evaluate([0.0, 1.0])[:, 0]
    a2_0, a2_1 = p2.evaluate([0.0, 1.0])[:, 0]
    loop1 = Loop((PCurve(line((0.0, 0.0), (a1_0, 0.0)), 0.0, 1.0),
                  PCurve(p1, 0.0, 1.0, edge_curve=b),
                  PCurve(line((a1_1, 1.0), (0.0, 1.0)), 0.0, 1.0),
                  PCurve(line((0.0, 1.0), (0.0, 0.0)), 0.0, 1.0)))
    loop2 = Loop((PCurve(line((a2_0, 0.0), (1.0, 0.0)), 0.0, 1.0),
                  PCurve(line((1.0, 0.0), (1.0, 1.0)), 0.0, 1.0),
                  PCurve(line((1.0, 1.0), (a2_1, 1.0)), 0.0, 1.0),
                  PCurve(p2, 1.0, 0.0, edge_curve=b)))
    tol = GAP_PAIR_TOLERANCE
    f1 = with_edge_curves(TrimmedFace(s1, (loop1,), name="gap_pair.left", tolerance=tol), max_error=0.1 * tol)
    f2 = with_edge_curves(TrimmedFace(s2, (loop2,), name="gap_pair.right", tolerance=tol), max_error=0.1 * tol)
    return assemble_shell([f1, f2], shared=[((0, 0, 1), (1, 0, 3))], name="gap_pair", tolerance=tol)


def _diagonal(s1: NurbsSurface, s2: NurbsSurface) -> float:
    """Bounding-box diagonal from a 9 x 9 sample of both surfaces, as `Shell.diagonal`."""
    g = np.linspace(0.0, 1.0, 9)
    uv = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    pts = np.concatenate([s1.evaluate(uv), s2.evaluate(uv)])
    return float(np.linalg.norm(pts.max(0) - pts.min(0)))
