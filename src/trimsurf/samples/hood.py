"""`hood`: a hood-like face from a 3 x 4 grid of Bézier patches of mixed degrees."""

from __future__ import annotations

import numpy as np

from ..model import NurbsSurface, Shell, TrimmedFace
from ..geom import bezier_grid_to_nurbs, elevate_bezier
from ._build import assemble_shell, rounded_rectangle_loop, with_edge_curves

__all__ = ["hood", "hood_patches", "HOOD_TOLERANCE", "HOOD_DEGREES"]

#: Stated tolerance of the hood's edges (mm).
HOOD_TOLERANCE = 1e-4

#: (degree_u, degree_v) of patch [i][j]; 3 patches along u, 4 along v. One patch has order 8.
HOOD_DEGREES = (((3, 3), (3, 5), (5, 5), (3, 3)),
                ((5, 3), (7, 7), (3, 3), (5, 4)),
                ((3, 3), (4, 3), (5, 5), (3, 3)))

_U_BREAKS = (0.0, 0.3, 0.65, 1.0)
_V_BREAKS = (0.0, 0.2, 0.5, 0.8, 1.0)


def _shape(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """A hood: x back from the front edge (1.15 m), y across (1.5 m), z a crown rising to the rear."""
    s = 2.0 * v - 1.0
    x = 1150.0 * u
    y = 750.0 * s
    z = (70.0 * (1.0 - s ** 2) + 140.0 * u - 40.0 * u ** 2
         + 6.0 * np.exp(-((np.abs(s) - 0.55) ** 2) / 0.01))        # two character lines
    return np.stack([x, y, z], axis=-1)


def _c1_net() -> np.ndarray:
    """Global control net of a C1 piecewise bicubic Bézier surface on the break grid, (10, 13, 3)."""
    def params(breaks):
        b = np.asarray(breaks)
        return np.r_[np.concatenate([b[i] + (b[i + 1] - b[i]) * np.arange(3) / 3 for i in range(len(b) - 1)]), b[-1]]

    pu, pv = params(_U_BREAKS), params(_V_BREAKS)
    net = _shape(*np.meshgrid(pu, pv, indexing="ij"))
    # C1 across a break: the joint point divides its neighbours in the ratio of the adjacent intervals
    for axis, breaks in ((0, _U_BREAKS), (1, _V_BREAKS)):
        d = np.diff(breaks)
        net = np.moveaxis(net, axis, 0).copy()
        for i in range(1, len(d)):
            net[3 * i] = (d[i] * net[3 * i - 1] + d[i - 1] * net[3 * i + 1]) / (d[i - 1] + d[i])
        net = np.moveaxis(net, 0, axis)
    return net


def hood_patches() -> tuple[list[list[np.ndarray]], tuple[float, ...], tuple[float, ...]]:
    """The Bézier patches of the hood and their break values.

    Returns
    -------
    patches : list of lists of (du+1, dv+1, 3) float64
        patches[i][j] has the degrees `HOOD_DEGREES[i][j]` and lives on
        [u_breaks[i], u_breaks[i+1]] x [v_breaks[j], v_breaks[j+1]].
    u_breaks, v_breaks : tuple of float

    Notes
    -----
    Each patch is a degree-elevated piece of one C1 piecewise bicubic surface,
    so neighbours of different degrees meet exactly (C1); patches with both
    degrees >= 4 then have their inner control points (those that touch
    neither the boundary nor the cross-boundary derivative) raised by a bump,
    which uses the extra degrees without breaking C1.
    """
    net = _c1_net()
    patches = []
    for i, row in enumerate(HOOD_DEGREES):
        out = []
        for j, (du, dv) in enumerate(row):
            cp = net[3 * i:3 * i + 4, 3 * j:3 * j + 4]
            cp = elevate_bezier(elevate_bezier(cp, du - 3, axis=0), dv - 3, axis=1)
            if du >= 4 and dv >= 4:
                a = np.sin(np.pi * np.arange(du + 1) / du)[:, None] * np.sin(np.pi * np.arange(dv + 1) / dv)[None, :]
                inner = np.zeros_like(a)
                inner[2:du - 1, 2:dv - 1] = a[2:du - 1, 2:dv - 1]
                cp = cp.copy()
                cp[..., 2] += (2.0 + du) * inner
            out.append(cp)
        patches.append(out)
    return patches, _U_BREAKS, _V_BREAKS


def hood_surface() -> NurbsSurface:
    """The untrimmed hood as one NURBS surface (degree 7 x 7, via `geom.bezier_grid_to_nurbs`)."""
    patches, ub, vb = hood_patches()
    du, dv, ku, kv, cp, w = bezier_grid_to_nurbs(patches, list(ub), list(vb))
    return NurbsSurface(du, dv, ku, kv, cp, w)


def hood() -> Shell:
    """A hood-like face from a 3 x 4 grid of Bézier patches of mixed degrees.

    Degrees 3 to 7 per patch (`HOOD_DEGREES`, one patch of order 8), joined
    C1, converted into one NURBS surface with
    `trimsurf.geom.bezier_grid_to_nurbs`, about 1150 x 1500 x 150 mm, trimmed
    by a rounded rectangle (four lines, four cubic Bézier quarter arcs,
    counter-clockwise). 3D edge curves are fitted to F(p(t)) within
    `HOOD_TOLERANCE`.

    Returns
    -------
    Shell
        One face with eight free edges.
    """
    loop = rounded_rectangle_loop((0.03, 0.03), (0.97, 0.97), (0.09, 0.07))
    face = TrimmedFace(hood_surface(), (loop,), name="hood", tolerance=HOOD_TOLERANCE)
    return assemble_shell([with_edge_curves(face, max_error=0.1 * HOOD_TOLERANCE)], name="hood",
                          tolerance=HOOD_TOLERANCE)
