"""Triangle shape: corner angles and aspect ratios.

Aspect ratios
-------------
``edge_altitude`` = longest edge / shortest altitude = L_max^2 / (2 A);
2 / sqrt(3) ~ 1.1547 for an equilateral triangle.
``radius_ratio`` = circumradius / (2 inradius) = L1 L2 L3 s / (8 A^2)
(s the semi-perimeter); 1 for an equilateral triangle. Both are infinite
for a zero-area triangle.

References
----------
J. R. Shewchuk, What is a good linear finite element? Interpolation,
conditioning, anisotropy, and quality measures, 2002 (Sec. 6: aspect ratios).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..model import TriMesh
from ._results import ResultMixin

__all__ = ["triangle_angles", "aspect_ratios", "TriangleQuality", "triangle_quality"]


def _check_mesh(mesh, name: str) -> None:
    if not isinstance(mesh, TriMesh):
        raise InputError(f"{name} needs a TriMesh; got {type(mesh).__name__}")


def triangle_angles(mesh: TriMesh) -> np.ndarray:
    """Corner angles in degrees, shape (m, 3): column k is the angle at `mesh.triangles[:, k]`.

    Computed as atan2(|e1 x e2|, e1 . e2), accurate for needle triangles too;
    a zero-length edge gives angles of 0 or 180 degrees, never NaN.

    Examples
    --------
    >>> m = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    >>> triangle_angles(m).round(9).tolist()
    [[90.0, 45.0, 45.0]]
    """
    _check_mesh(mesh, "triangle_angles")
    p = mesh.vertices[mesh.triangles]
    out = np.empty((mesh.n_triangles, 3))
    for k in range(3):
        e1 = p[:, (k + 1) % 3] - p[:, k]
        e2 = p[:, (k + 2) % 3] - p[:, k]
        out[:, k] = np.arctan2(np.linalg.norm(np.cross(e1, e2), axis=1), np.einsum("ij,ij->i", e1, e2))
    return np.degrees(out)


def aspect_ratios(mesh: TriMesh) -> tuple[np.ndarray, np.ndarray]:
    """(edge_altitude, radius_ratio) per triangle, each (m,) float64 (see module docstring)."""
    _check_mesh(mesh, "aspect_ratios")
    p = mesh.vertices[mesh.triangles]
    lengths = np.linalg.norm(p[:, [1, 2, 0]] - p, axis=2)
    area = mesh.triangle_areas()
    with np.errstate(divide="ignore", invalid="ignore"):
        edge_altitude = lengths.max(axis=1) ** 2 / (2.0 * area)
        s = 0.5 * lengths.sum(axis=1)
        radius_ratio = lengths.prod(axis=1) * s / (8.0 * area ** 2)
    zero = area <= 0
    edge_altitude[zero] = np.inf
    radius_ratio[zero] = np.inf
    return edge_altitude, radius_ratio


@dataclass(frozen=True, eq=False)
class TriangleQuality(ResultMixin):
    """Angle and aspect-ratio statistics of a mesh's triangles.

    Attributes
    ----------
    n_triangles : int
    min_angle_deg, p5_min_angle_deg, max_angle_deg : float
        Smallest corner angle, 5th percentile of the per-triangle smallest
        angle, largest corner angle.
    mean_min_angle_deg : float
    histogram_edges_deg : (k+1,) float64
    histogram_counts : (k,) int64
        Counts of all corner angles (3 per triangle) in the bins.
    share_min_angle_below : float
        Share of triangles whose smallest angle is below `min_angle_threshold_deg`.
    min_angle_threshold_deg : float
    max_edge_altitude, p95_edge_altitude : float
    max_radius_ratio, p95_radius_ratio : float
    worst_triangle : int
        Triangle with the smallest angle.
    n_zero_area : int
        Triangles of zero area (distinct indices, collinear corners).
    """

    n_triangles: int
    min_angle_deg: float
    p5_min_angle_deg: float
    max_angle_deg: float
    mean_min_angle_deg: float
    histogram_edges_deg: np.ndarray
    histogram_counts: np.ndarray
    share_min_angle_below: float
    min_angle_threshold_deg: float
    max_edge_altitude: float
    p95_edge_altitude: float
    max_radius_ratio: float
    p95_radius_ratio: float
    worst_triangle: int
    n_zero_area: int


def triangle_quality(mesh: TriMesh, *, bin_width_deg: float = 10.0,
                     min_angle_threshold_deg: float = 10.0) -> TriangleQuality:
    """Triangle angles (min, 5th percentile, max, histogram) and aspect ratios of a mesh.

    Parameters
    ----------
    mesh : TriMesh
        At least one triangle.
    bin_width_deg : float
        Histogram bin width; bins cover [0, 180] degrees.
    min_angle_threshold_deg : float
        Triangles with a smaller smallest angle are counted in `share_min_angle_below`.

    Returns
    -------
    TriangleQuality

    Raises
    ------
    InputError
        Not a TriMesh, no triangles, or a bin width that does not divide 180 into at most 1800 bins.

    Examples
    --------
    >>> m = TriMesh([[0, 0, 0], [1, 0, 0], [0.5, 3 ** 0.5 / 2, 0]], [[0, 1, 2]])
    >>> q = triangle_quality(m)
    >>> round(q.min_angle_deg, 9), round(q.max_radius_ratio, 9)
    (60.0, 1.0)
    """
    _check_mesh(mesh, "triangle_quality")
    if not mesh.n_triangles:
        raise InputError("triangle_quality needs a mesh with at least one triangle")
    bin_width_deg = float(bin_width_deg)
    if not (np.isfinite(bin_width_deg) and 0.1 <= bin_width_deg <= 180.0):
        raise InputError(f"bin_width_deg must be in [0.1, 180]; got {bin_width_deg!r}")
    ang = triangle_angles(mesh)
    tmin = ang.min(axis=1)
    edges = np.arange(0.0, 180.0 + 0.5 * bin_width_deg, bin_width_deg)
    edges[-1] = 180.0
    counts, _ = np.histogram(ang.ravel(), bins=edges)
    ea, rr = aspect_ratios(mesh)
    return TriangleQuality(
        n_triangles=mesh.n_triangles,
        min_angle_deg=float(tmin.min()),
        p5_min_angle_deg=float(np.percentile(tmin, 5)),
        max_angle_deg=float(ang.max()),
        mean_min_angle_deg=float(tmin.mean()),
        histogram_edges_deg=edges,
        histogram_counts=counts.astype(np.int64),
        share_min_angle_below=float(np.mean(tmin < min_angle_threshold_deg)),
        min_angle_threshold_deg=float(min_angle_threshold_deg),
        max_edge_altitude=float(ea.max()),
        p95_edge_altitude=float(np.percentile(ea, 95, method="higher")),  # no inf - inf
        max_radius_ratio=float(rr.max()),
        p95_radius_ratio=float(np.percentile(rr, 95, method="higher")),
        worst_triangle=int(np.argmin(tmin)),
        n_zero_area=int(np.count_nonzero(mesh.triangle_areas() <= 0)),
    )
