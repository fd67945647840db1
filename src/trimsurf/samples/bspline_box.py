"""`bspline_box`: a closed pillow-shaped solid bounded by six bicubic B-spline faces."""

from __future__ import annotations

import numpy as np

from ..model import Loop, NurbsCurve, NurbsSurface, PCurve, Shell, TrimmedFace
from ._build import assemble_shell, line

__all__ = ["bspline_box", "BOX_HALF_SIZE", "BOX_TOLERANCE"]

#: Half edge lengths of the box before bulging (mm).
BOX_HALF_SIZE = (150.0, 100.0, 60.0)

#: Stated tolerance of the box's edges (mm); shared edges coincide exactly.
BOX_TOLERANCE = 1e-6

_KNOTS = np.array([0.0, 0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 1.0])
# Greville abscissae of _KNOTS mapped to [-1, 1]; symmetric by construction, so a shared
# edge gets bit-identical control points from both of its faces.
_COORDS = np.array([-1.0, -2.0 / 3.0, 0.0, 2.0 / 3.0, 1.0])
_BULGE_FACE, _BULGE_EDGE = 0.22, 0.08


def _pillow(p: np.ndarray) -> np.ndarray:
    """Map points of the cube [-1, 1]^3 to the pillow: faces and edges bulge outward, corners stay."""
    sq = p ** 2
    out = np.empty_like(p)
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        bulge = 1.0 + _BULGE_FACE * (1 - sq[..., b]) * (1 - sq[..., c]) + _BULGE_EDGE * (2 - sq[..., b] - sq[..., c])
        out[..., a] = BOX_HALF_SIZE[a] * p[..., a] * bulge
    return out


def _face(axis: int, sign: float) -> TrimmedFace:
    """The face of the pillow on the cube side x_axis = sign.

    u runs along axis+1 and v along axis+2 (cyclic), so Su x Sv points along
    +axis: outward for sign +1 (same_sense True), inward for sign -1 (False).
    """
    b, c = (axis + 1) % 3, (axis + 2) % 3
    gb, gc = np.meshgrid(_COORDS, _COORDS, indexing="ij")
    p = np.empty(gb.shape + (3,))
    p[..., axis], p[..., b], p[..., c] = sign, gb, gc
    cp = _pillow(p)
    surface = NurbsSurface(3, 3, _KNOTS, _KNOTS, cp)
    iso = lambda pts: NurbsCurve(3, _KNOTS, pts)  # noqa: E731 - boundary curve b(t) = S(p(t)), exact
    loop = Loop((PCurve(line((0, 0), (1, 0)), 0.0, 1.0, edge_curve=iso(cp[:, 0])),
                 PCurve(line((1, 0), (1, 1)), 0.0, 1.0, edge_curve=iso(cp[-1, :])),
                 PCurve(line((0, 1), (1, 1)), 1.0, 0.0, edge_curve=iso(cp[:, -1])),
                 PCurve(line((0, 0), (0, 1)), 1.0, 0.0, edge_curve=iso(cp[0, :]))))
    name = f"bspline_box.{'+' if sign > 0 else '-'}{'xyz'[axis]}"
    return TrimmedFace(surface, (loop,), same_sense=sign > 0, name=name, tolerance=BOX_TOLERANCE)


def bspline_box() -> Shell:
    """A closed solid bounded by six bicubic B-spline faces (a pillow-shaped box).

    The faces of a 300 x 200 x 120 mm box (model units mm) bulge outward
    (middle of a face by 22%, middle of an edge by 8%); corners stay sharp.
    Each face is a bicubic B-spline with 5 x 5 control points on its full
    domain [0, 1]^2; its loop is the domain boundary (counter-clockwise) with
    the exact boundary iso-curves as edge curves, so the two faces at an edge
    have bit-identical edge curves. The shell has 12 shared edges and 8
    vertices and is closed; outward normals come from `same_sense` (True on the
    +x, +y, +z faces, False on the others, whose Su x Sv points inward).

    Returns
    -------
    Shell

    Examples
    --------
    >>> bspline_box().is_closed()
    True
    """
    faces = [_face(axis, sign) for axis in range(3) for sign in (1.0, -1.0)]
    by_curve: dict[bytes, list[tuple[int, int, int]]] = {}
    for f, face in enumerate(faces):
        for s, seg in enumerate(face.loops[0].segments):
            pts = seg.edge_curve.control_points
            key = min(pts.tobytes(), pts[::-1].tobytes())
            by_curve.setdefault(key, []).append((f, 0, s))
    shared = [tuple(uses) for uses in by_curve.values()]
    if len(shared) != 12 or any(len(u) != 2 for u in shared):  # pragma: no cover - construction invariant
        raise RuntimeError("bspline_box: every one of the 12 edges must have exactly two faces")
    return assemble_shell(faces, shared=shared, name="bspline_box", tolerance=BOX_TOLERANCE)
