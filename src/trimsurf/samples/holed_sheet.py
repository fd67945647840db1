"""`holed_sheet`: a gently bent sheet with two holes, nearly developable."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..model import TriMesh
from ._build import resample_closed, triangulate_polygon

__all__ = ["holed_sheet", "bend_sheet", "SHEET_SIZE"]

#: Flat size of the sheet (mm).
SHEET_SIZE = (400.0, 250.0)

_BEND_RADIUS = 500.0                       # cylinder radius of the bend (mm)
_BUMP = (2.0, 300.0, 190.0, 30.0)         # amplitude, centre x, centre y, sigma (mm)


def bend_sheet(uv: np.ndarray) -> np.ndarray:
    """Map flat sheet points (mm) to 3D: a cylindrical bend about an axis along y, plus a small bump.

    The bend alone is an isometry; the bump (2 mm high, 30 mm wide) makes the
    sheet slightly non-developable.
    """
    uv = np.asarray(uv, dtype=np.float64)
    a, cx, cy, sig = _BUMP
    s = (uv[:, 0] - 0.5 * SHEET_SIZE[0]) / _BEND_RADIUS
    bump = a * np.exp(-((uv[:, 0] - cx) ** 2 + (uv[:, 1] - cy) ** 2) / (2 * sig ** 2))
    r = _BEND_RADIUS - bump                 # the bump moves along the cylinder's normal, towards its axis
    return np.column_stack([r * np.sin(s), uv[:, 1], _BEND_RADIUS - r * np.cos(s)])


def holed_sheet(*, max_area: float = 150.0) -> TriMesh:
    """A near-developable mesh with two holes: a bent 400 x 250 mm sheet.

    The flat sheet has a round hole (radius 40 mm) and an elliptic one
    (55 x 30 mm); it is triangulated with Triangle ('pq30a<max_area>') and
    bent around a cylinder of radius 500 mm with a 2 mm bump (`bend_sheet`).
    `uv` holds the flat coordinates.

    Parameters
    ----------
    max_area : float
        Largest triangle area in the flat sheet (mm^2); the default gives
        about 600 vertices.

    Returns
    -------
    TriMesh
        One component with three boundary loops, Euler characteristic -1.

    Examples
    --------
    >>> m = holed_sheet()
    >>> len(m.boundary_loops()), m.euler_characteristic()
    (3, -1)
    """
    if not (np.isfinite(max_area) and 5.0 <= max_area <= 5000.0):
        raise InputError(f"holed_sheet: max_area must be in [5, 5000] mm^2; got {max_area!r}")
    w, h = SHEET_SIZE
    spacing = float(np.sqrt(2.0 * max_area))
    outer = resample_closed([(0.0, 0.0), (w, 0.0), (w, h), (0.0, h)], spacing)
    a = np.linspace(0.0, 2 * np.pi, 721)[:-1]
    hole1 = resample_closed(np.c_[110.0 + 40.0 * np.cos(a), 125.0 + 40.0 * np.sin(a)][::-1], spacing)
    hole2 = resample_closed(np.c_[285.0 + 55.0 * np.cos(a), 110.0 + 30.0 * np.sin(a)][::-1], spacing)
    uv, tris = triangulate_polygon([outer, hole1, hole2], hole_points=[(110.0, 125.0), (285.0, 110.0)],
                                   max_area=max_area)
    return TriMesh(bend_sheet(uv), tris, uv=uv)
