"""`octahedron`: the shifted octahedron of the minimum-norm-network paper."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..model import TriMesh

__all__ = ["octahedron"]


def octahedron(*, shift_deg: float = 30.0, azimuth_deg: float = 30.0) -> TriMesh:
    """The shifted octahedron: a regular octahedron with one vertex moved on its circumsphere.

    "A frequently used example is the reconstruction of a sphere from a
    regular octahedron. We tighten this example by moving one vertex out of
    position but preserve its radial distance from the origin" (MNN paper,
    section 5, Fig. 4). The paper gives no angle; here the top vertex
    (0, 0, 1) is turned by `shift_deg` away from the z axis, towards the
    azimuth `azimuth_deg` (from +x towards +y). All six vertices stay on the
    unit sphere.

    Parameters
    ----------
    shift_deg : float
        Polar angle of the moved vertex, in [0, 40] degrees (beyond, the
        polyhedron stops being convex).
    azimuth_deg : float

    Returns
    -------
    TriMesh
        6 vertices, 8 triangles, closed, outward (counter-clockwise seen from outside).

    References
    ----------
    MNN paper (../shared/papers/mnn-surface-reconstruction.txt), "The Shifted Octahedron".

    Examples
    --------
    >>> m = octahedron()
    >>> m.n_vertices, m.n_triangles, m.euler_characteristic()
    (6, 8, 2)
    """
    if not (np.isfinite(shift_deg) and 0.0 <= shift_deg <= 40.0):
        raise InputError(f"octahedron: shift_deg must be in [0, 40]; got {shift_deg!r}")
    if not np.isfinite(azimuth_deg):
        raise InputError(f"octahedron: azimuth_deg must be finite; got {azimuth_deg!r}")
    th, ph = np.radians(shift_deg), np.radians(azimuth_deg)
    v = np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
    v[4] = [np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)]
    tris = []
    for sx, ix in ((1, 0), (-1, 1)):
        for sy, iy in ((1, 2), (-1, 3)):
            for sz, iz in ((1, 4), (-1, 5)):
                tris.append([ix, iy, iz] if sx * sy * sz > 0 else [ix, iz, iy])
    return TriMesh(v, np.array(tris, dtype=np.int64))
