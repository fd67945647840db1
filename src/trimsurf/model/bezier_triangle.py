"""Triangular Bézier patches and surfaces made of them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import geom
from ..errors import GeometryError
from ._arrays import as_float_array

__all__ = ["BezierTriangle", "BezierTriangleSurface"]


@dataclass(frozen=True, slots=True, eq=False)
class BezierTriangle:
    """One triangular Bézier patch of degree n.

    Control points are ordered as `trimsurf.geom.triangle_indices(n)`: index
    triples (i, j, k), i + j + k = n, i descending, then j descending.
    """

    degree: int
    control_points: np.ndarray  # ((n+1)(n+2)/2, dim)

    def __post_init__(self) -> None:
        n = int(self.degree)
        cp = as_float_array(self.control_points, "BezierTriangle.control_points", ndim=2)
        if n < 1 or cp.shape[0] != (n + 1) * (n + 2) // 2:
            raise GeometryError(f"a degree-{n} triangular patch needs {(n + 1) * (n + 2) // 2} control points; "
                                f"got {cp.shape[0]}")
        object.__setattr__(self, "degree", n)
        object.__setattr__(self, "control_points", cp)

    def evaluate(self, bary) -> np.ndarray:
        """Points at barycentric coordinates `bary` (k, 3); returns (k, dim)."""
        return geom.bezier_triangle_points(self.control_points, self.degree, bary)


@dataclass(frozen=True, slots=True, eq=False)
class BezierTriangleSurface:
    """A set of triangular Bézier patches of one degree (one per mesh triangle or split)."""

    degree: int
    control_points: np.ndarray  # (n_patches, (n+1)(n+2)/2, 3)

    def __post_init__(self) -> None:
        n = int(self.degree)
        cp = as_float_array(self.control_points, "BezierTriangleSurface.control_points", ndim=3, last=3)
        if cp.shape[1] != (n + 1) * (n + 2) // 2:
            raise GeometryError(f"degree-{n} patches need {(n + 1) * (n + 2) // 2} control points each; "
                                f"got {cp.shape[1]}")
        object.__setattr__(self, "degree", n)
        object.__setattr__(self, "control_points", cp)

    @property
    def n_patches(self) -> int:
        return int(self.control_points.shape[0])

    def patch(self, i: int) -> BezierTriangle:
        return BezierTriangle(self.degree, self.control_points[i])
