"""`s_cone`: a thick S wrapped isometrically onto a cone, with its exact flat layout."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..model import TriMesh
from ._build import resample_closed, triangulate_polygon

__all__ = ["s_cone", "cone_point", "S_CONE_SIN_HALF_ANGLE"]

#: sin of the cone's half-angle: a full turn around the cone unrolls to 2 pi * 0.2 = 72 degrees.
S_CONE_SIN_HALF_ANGLE = 0.2

_R, _Y0, _BETA, _WIDTH = 1.0, 2.0, np.radians(60.0), 0.55


def _s_outline(spacing: float) -> np.ndarray:
    """Boundary of the thick S in the plane (apex of the unrolled cone at the origin), (k, 2)."""
    n = 400
    t1 = np.linspace(-np.pi / 2 - _BETA, np.pi / 2, n)                    # lower arc, counter-clockwise
    t2 = np.linspace(-np.pi / 2, -1.5 * np.pi - _BETA, n)[1:]             # upper arc, clockwise
    c = np.r_[np.c_[_R * np.cos(t1), _Y0 + _R + _R * np.sin(t1)],
              np.c_[_R * np.cos(t2), _Y0 + 3 * _R + _R * np.sin(t2)]]
    # unit normals of the two arcs (exact): outward on the lower, inward on the upper
    nrm = np.r_[np.c_[np.cos(t1), np.sin(t1)], -np.c_[np.cos(t2), np.sin(t2)]]
    h = 0.5 * _WIDTH
    ring = np.r_[c + h * nrm, (c - h * nrm)[::-1]]
    ring = resample_closed(ring, spacing)
    area2 = np.sum(ring[:, 0] * np.roll(ring[:, 1], -1) - np.roll(ring[:, 0], -1) * ring[:, 1])
    return ring if area2 > 0 else ring[::-1]


def cone_point(uv: np.ndarray, *, sin_half_angle: float = S_CONE_SIN_HALF_ANGLE) -> np.ndarray:
    """Wrap flat points onto the cone: the isometry of the unrolled sector onto the cone.

    A flat point at distance r from the origin and polar angle phi goes to
    distance r from the apex (the origin) on the generator at angle
    theta = phi / sin(alpha) around the axis (-z) (the convention of the
    ``s_cone_*`` meshes in ``../shared/data/meshes``).
    Distances measured along the cone (geodesics not crossing the cut) equal
    flat distances, and the map keeps orientation: counter-clockwise flat
    triangles get normals pointing away from the axis.

    Parameters
    ----------
    uv : (n, 2) float64
    sin_half_angle : float

    Returns
    -------
    (n, 3) float64
    """
    uv = np.asarray(uv, dtype=np.float64)
    r = np.hypot(uv[:, 0], uv[:, 1])
    theta = np.arctan2(uv[:, 1], uv[:, 0]) / sin_half_angle
    ca = np.sqrt(1.0 - sin_half_angle ** 2)
    return np.column_stack([r * sin_half_angle * np.cos(theta), r * sin_half_angle * np.sin(theta), -r * ca])


def s_cone(*, max_area: float = 0.01) -> TriMesh:
    """An S-shaped strip on a cone, with the flat layout as `TriMesh.uv`.

    A thick S (two circular arcs of radius 1 and 240 degrees each, width
    0.55) drawn in the plane 1.7 to 6.3 units from the origin, triangulated
    with Triangle ('pq30a<max_area>'), and wrapped isometrically onto a cone
    of half-angle asin 0.2 with its apex at the origin and its axis along -z,
    going about 250 degrees around it (`cone_point`). `uv` holds the exact
    flat coordinates: the ground truth of a developable parameterization.
    The 3D triangles are chords of the cone, so straight 3D edge lengths are
    slightly shorter (about 1%) than the flat ones; distances along the cone
    equal them.

    Parameters
    ----------
    max_area : float
        Largest triangle area in the plane; the default gives about 400 vertices.

    Returns
    -------
    TriMesh
        A disk: one boundary loop, Euler characteristic 1.

    Examples
    --------
    >>> m = s_cone()
    >>> len(m.boundary_loops()), m.euler_characteristic()
    (1, 1)
    """
    if not (np.isfinite(max_area) and 1e-4 <= max_area <= 0.5):
        raise InputError(f"s_cone: max_area must be in [1e-4, 0.5]; got {max_area!r}")
    spacing = float(np.sqrt(2.0 * max_area))
    uv, tris = triangulate_polygon([_s_outline(spacing)], max_area=max_area)
    return TriMesh(cone_point(uv), tris, uv=uv)
