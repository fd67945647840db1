"""`fender`: a car-fender-like bicubic trimmed face with a wheel arch and a hole."""

from __future__ import annotations

import numpy as np

from ..model import Loop, NurbsSurface, PCurve, Shell, TrimmedFace
from ._build import assemble_shell, bezier, bspline, ellipse_loop, line, with_edge_curves

__all__ = ["fender", "FENDER_TOLERANCE"]

#: Stated tolerance of the fender's edges (mm): the fitted edge curves are within it of F(p(t)).
FENDER_TOLERANCE = 1e-4


def _greville(knots: np.ndarray, degree: int) -> np.ndarray:
    n = len(knots) - degree - 1
    return np.array([knots[i + 1:i + degree + 1].mean() for i in range(n)])


def fender_surface() -> NurbsSurface:
    """The untrimmed bicubic surface: x along the car (~1 m), z up (~0.65 m), y outward.

    The control points sample a doubly curved shape at the Greville abscissae
    of non-uniform knots: a crown across the length, a rounded shoulder at the
    top and a flare around the wheel arch.
    """
    ku = np.r_[[0.0] * 4, 0.18, 0.37, 0.5, 0.63, 0.82, [1.0] * 4]
    kv = np.r_[[0.0] * 4, 0.3, 0.62, [1.0] * 4]
    gu, gv = np.meshgrid(_greville(ku, 3), _greville(kv, 3), indexing="ij")
    x = 1000.0 * gu + 40.0 * gv                     # slanted rear edge: a sweep
    z = 650.0 * gv - 25.0 * np.sin(np.pi * gu)      # sill line dips in the middle
    y = (90.0 * (1.0 - (2.0 * gu - 1.0) ** 2) * (0.55 + 0.45 * gv)   # crown along the car
         - 70.0 * (gv - 0.55) ** 2                                  # shoulder
         + 30.0 * np.exp(-((gu - 0.5) ** 2 / 0.05 + (gv - 0.2) ** 2 / 0.06)))  # arch flare
    cp = np.stack([x, y, z], axis=-1)
    return NurbsSurface(3, 3, ku, kv, cp)


def _outer_loop() -> Loop:
    curves = [
        line((0.04, 0.04), (0.27, 0.04)),                                        # sill, front
        bspline([(0.27, 0.04), (0.255, 0.33), (0.5, 0.53), (0.745, 0.33), (0.73, 0.04)],
                3, [0.5]),                                                       # wheel arch (concave)
        line((0.73, 0.04), (0.96, 0.04)),                                        # sill, rear
        bezier([(0.96, 0.04), (0.975, 0.45), (0.95, 0.88)]),                     # rear edge
        bezier([(0.95, 0.88), (0.65, 0.98), (0.35, 0.80), (0.04, 0.82)]),        # top (wavy)
        bezier([(0.04, 0.82), (0.015, 0.43), (0.04, 0.04)]),                     # front edge
    ]
    return Loop(tuple(PCurve(c, 0.0, 1.0) for c in curves))


def fender() -> Shell:
    """A car-fender-like freeform trimmed face with a concave wheel arch and a hole.

    One bicubic B-spline face (control net 9 x 6, non-uniform knots, size
    about 1000 x 650 x 120 mm, model units mm) trimmed by an outer loop of six
    B-spline p-curves, counter-clockwise in (u, v), one of them the concave
    wheel arch, and an elliptic hole (four cubic Bézier arcs, clockwise). The
    3D edge curves b(t) are quintic B-splines fitted to F(p(t)) in the
    p-curve's own parameter (same parameter) within `FENDER_TOLERANCE`.

    Returns
    -------
    Shell
        One face; every edge is free (used once).

    Examples
    --------
    >>> shell = fender()
    >>> len(shell.faces), len(shell.faces[0].loops)
    (1, 2)
    """
    face = TrimmedFace(fender_surface(), (_outer_loop(), ellipse_loop((0.84, 0.62), (0.05, 0.07), clockwise=True)),
                       name="fender", tolerance=FENDER_TOLERANCE)
    return assemble_shell([with_edge_curves(face, max_error=0.1 * FENDER_TOLERANCE)], name="fender",
                          tolerance=FENDER_TOLERANCE)
