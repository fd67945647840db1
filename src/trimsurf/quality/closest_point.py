"""Closest points on triangles and on triangle meshes, batched.

`point_triangle_closest` is Ericson's Voronoi-region test, vectorized over
rows. `closest_points_on_mesh` finds the exact closest point on a mesh for
many query points, in a compiled kernel (`quality._kernels`): the triangles'
bounding boxes are binned in a uniform grid of cells about one triangle in
size, and each query tries the triangles of the cells in cube shells around
its own cell, skipping cells farther than its best distance so far, until
that distance is at most the shells' radius (no unseen triangle can be
nearer). The answer is exact (not sampled): the minimum over every triangle
that could be nearer, each distance Ericson's test per pair.

References
----------
C. Ericson, *Real-Time Collision Detection*, Morgan Kaufmann 2005, Sec. 5.1.5
(ClosestPtPointTriangle).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, MeshError
from ..model import TriMesh
from ._kernels import grid_build_kernel, grid_closest_kernel, hint_closest_kernel
from ._numeric import median
from ._results import ResultMixin

__all__ = ["point_triangle_closest", "point_segment_closest", "closest_points_on_mesh", "ClosestPoints"]



def _dot(x, y):
    return np.einsum("ij,ij->i", x, y)


def point_segment_closest(points, a, b) -> tuple[np.ndarray, np.ndarray]:
    """Closest point on segments [a, b] to points, row by row.

    Parameters
    ----------
    points, a, b : (n, d) float64

    Returns
    -------
    closest : (n, d) float64
    t : (n,) float64
        Position along the segment, 0 at `a`, 1 at `b` (0 for a zero-length segment).
    """
    p, a, b = (np.asarray(x, dtype=np.float64) for x in (points, a, b))
    ab = b - a
    den = _dot(ab, ab)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(den > 0, _dot(p - a, ab) / den, 0.0)
    t = np.clip(t, 0.0, 1.0)
    return a + t[:, None] * ab, t


def point_triangle_closest(points, a, b, c) -> tuple[np.ndarray, np.ndarray]:
    """Closest point on triangles (a, b, c) to points, row by row.

    Parameters
    ----------
    points, a, b, c : (n, 3) float64

    Returns
    -------
    closest : (n, 3) float64
    barycentric : (n, 3) float64
        Weights of (a, b, c) of the closest point, each in [0, 1], summing to 1.

    Notes
    -----
    A zero-area triangle is treated as the union of its three edges.

    Examples
    --------
    >>> q, w = point_triangle_closest([[0.2, 0.2, 1.0]], [[0, 0, 0]], [[1, 0, 0]], [[0, 1, 0]])
    >>> q.round(12).tolist(), w.round(12).tolist()
    ([[0.2, 0.2, 0.0]], [[0.6, 0.2, 0.2]])
    """
    p, a, b, c = (np.atleast_2d(np.asarray(x, dtype=np.float64)) for x in (points, a, b, c))
    ab, ac = b - a, c - a
    ap, bp, cp = p - a, p - b, p - c
    d1, d2 = _dot(ab, ap), _dot(ac, ap)
    d3, d4 = _dot(ab, bp), _dot(ac, bp)
    d5, d6 = _dot(ab, cp), _dot(ac, cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    n = len(p)
    v = np.empty(n)
    w = np.empty(n)
    with np.errstate(divide="ignore", invalid="ignore"):
        den = va + vb + vc
        v[:] = vb / den                                 # interior
        w[:] = vc / den
        e_bc = (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        v = np.where(e_bc, 1.0 - t_bc, v)
        w = np.where(e_bc, t_bc, w)
        e_ac = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
        t_ac = d2 / (d2 - d6)
        v = np.where(e_ac, 0.0, v)
        w = np.where(e_ac, t_ac, w)
        in_c = (d6 >= 0) & (d5 <= d6)
        v = np.where(in_c, 0.0, v)
        w = np.where(in_c, 1.0, w)
        e_ab = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
        t_ab = d1 / (d1 - d3)
        v = np.where(e_ab, t_ab, v)
        w = np.where(e_ab, 0.0, w)
        in_b = (d3 >= 0) & (d4 <= d3)
        v = np.where(in_b, 1.0, v)
        w = np.where(in_b, 0.0, w)
        in_a = (d1 <= 0) & (d2 <= 0)
        v = np.where(in_a, 0.0, v)
        w = np.where(in_a, 0.0, w)
    bad = ~(np.isfinite(v) & np.isfinite(w))
    bad |= (v < 0) | (w < 0) | (v + w > 1)
    if bad.any():  # zero-area triangles: closest point on the three edges
        i = np.flatnonzero(bad)
        best_v, best_w = np.zeros(len(i)), np.zeros(len(i))
        best_d = np.full(len(i), np.inf)
        for s, e, to_vw in ((a, b, lambda t: (t, 0 * t)), (a, c, lambda t: (0 * t, t)),
                            (b, c, lambda t: (1 - t, t))):
            q, t = point_segment_closest(p[i], s[i], e[i])
            d = _dot(p[i] - q, p[i] - q)
            better = d < best_d
            vv, ww = to_vw(t)
            best_v = np.where(better, vv, best_v)
            best_w = np.where(better, ww, best_w)
            best_d = np.where(better, d, best_d)
        v[i], w[i] = best_v, best_w
    bary = np.column_stack([1.0 - v - w, v, w])
    closest = bary[:, 0:1] * a + bary[:, 1:2] * b + bary[:, 2:3] * c
    return closest, bary


@dataclass(frozen=True, eq=False)
class ClosestPoints(ResultMixin):
    """Closest points on a mesh.

    Attributes
    ----------
    distance : (n,) float64
    triangle : (n,) int64
        Index of a triangle holding the closest point.
    point : (n, 3) float64
    barycentric : (n, 3) float64
        Weights of the triangle's corners at `point`.
    """

    distance: np.ndarray
    triangle: np.ndarray
    point: np.ndarray
    barycentric: np.ndarray


def _radius_buckets(radius: np.ndarray, factor: float = 4.0) -> list[np.ndarray]:
    """Triangle indices grouped so radii within a group differ by at most `factor` (large groups first)."""
    pos = radius[radius > 0]
    base = pos.min() if pos.size else 1.0
    level = np.floor(np.log(np.maximum(radius, base) / base) / np.log(factor)).astype(np.int64)
    groups = [np.flatnonzero(level == k) for k in np.unique(level)]
    return groups


class _TriangleLocator:
    """One mesh's triangles (corners a, b, c) and their search grid, built once and reused."""

    def __init__(self, vertices: np.ndarray, triangles: np.ndarray):
        self.a, self.b, self.c = (np.ascontiguousarray(vertices[triangles[:, k]], dtype=np.float64)
                                  for k in range(3))
        self._grid = None

    @property
    def grid(self):
        """(box lo, box hi, origin, cell side, dims, start, items): the triangles' boxes, binned in a dense
        grid (CSR) of cells about the median triangle's size (larger where the boxes would fill more than
        16 cells per triangle on average or the grid exceed 2^21 cells)."""
        if self._grid is None:
            lo = np.minimum(np.minimum(self.a, self.b), self.c)
            hi = np.maximum(np.maximum(self.a, self.b), self.c)
            origin = lo.min(axis=0)
            span = hi.max(axis=0) - origin
            ext = (hi - lo).max(axis=1)
            h = median(ext)
            h = max(h, float(span.max()) * 2.0 ** -20, 1e-300)
            while True:
                dims = np.floor(span / h).astype(np.int64) + 1
                fill = np.prod(np.floor((hi - lo) / h) + 2, axis=1).sum()
                if np.prod(dims.astype(np.float64)) <= 2 ** 21 and fill <= 16 * len(lo) + 4096:
                    break
                h *= 1.5
            n_cells = int(np.prod(dims))
            start = np.zeros(n_cells + 1, dtype=np.int64)
            grid_build_kernel(lo, hi, origin, h, dims, True, start, np.zeros(0, dtype=np.int64))
            np.cumsum(start, out=start)
            items = np.empty(int(start[-1]), dtype=np.int64)
            fill_at = start[:-1].copy()
            grid_build_kernel(lo, hi, origin, h, dims, False, fill_at, items)
            self._grid = (lo, hi, origin, h, dims, start, items)
        return self._grid

    def exact(self, q: np.ndarray, tri: np.ndarray):
        closest, bary = point_triangle_closest(q, self.a[tri], self.b[tri], self.c[tri])
        d = np.sqrt(_dot(q - closest, q - closest))
        return d, closest, bary


def closest_points_on_mesh(points, mesh: TriMesh) -> ClosestPoints:
    """Exact closest points on a triangle mesh for many query points.

    Parameters
    ----------
    points : (n, 3) float64
    mesh : TriMesh
        At least one triangle.

    Returns
    -------
    ClosestPoints

    Raises
    ------
    InputError
        `points` not of shape (n, 3) or not finite.
    MeshError
        `mesh` has no triangles.

    Notes
    -----
    Cost grows with the number of triangles within ``d + R`` of a query
    (``d`` its distance, ``R`` the radius of the triangles there): queries far
    from a finely meshed region visit many triangles.

    Examples
    --------
    >>> m = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    >>> closest_points_on_mesh([[1.0, 1.0, 0.0]], m).distance.round(12).tolist()
    [0.707106781187]
    """
    q = np.atleast_2d(np.asarray(points, dtype=np.float64))
    if q.ndim != 2 or q.shape[1] != 3:
        raise InputError(f"points must have shape (n, 3); got {q.shape}")
    if not np.all(np.isfinite(q)):
        raise InputError("points has a non-finite value")
    if not isinstance(mesh, TriMesh) or not mesh.n_triangles:
        raise MeshError("closest_points_on_mesh needs a TriMesh with at least one triangle")
    loc = _TriangleLocator(mesh.vertices, mesh.triangles)
    return _closest(q, loc)


def _closest(q: np.ndarray, loc: _TriangleLocator, hint: np.ndarray | None = None) -> ClosestPoints:
    """Exact closest points of `q` on `loc`'s triangles. `hint` (n,) int: a triangle near each query (e.g.
    the one whose footprint it samples; -1: none); the search starts from its distance as the bound to beat, which
    prunes the cells and triangles farther than that. The distances are the same (the exact minimum over
    the triangles); where two triangles are equally near, the one reported may differ."""
    n = len(q)
    best_d = np.full(n, np.inf)
    best_t = np.zeros(n, dtype=np.int64)
    best_p = np.zeros((n, 3))
    best_w = np.zeros((n, 3))
    if n == 0:
        return ClosestPoints(best_d, best_t, best_p, best_w)
    q = np.ascontiguousarray(q, dtype=np.float64)
    if hint is not None:
        hint = np.ascontiguousarray(hint, dtype=np.int64)
        has = hint >= 0                 # -1: no hint (the search starts from nothing)
        if has.all():
            hint_closest_kernel(q, loc.a, loc.b, loc.c, hint, best_d, best_t, best_p, best_w)
        elif has.any():
            i = np.flatnonzero(has)
            d, t, p, w = best_d[i], best_t[i], best_p[i], best_w[i]
            hint_closest_kernel(np.ascontiguousarray(q[i]), loc.a, loc.b, loc.c, hint[i], d, t, p, w)
            best_d[i], best_t[i], best_p[i], best_w[i] = d, t, p, w
    lo, hi, origin, h, dims, start, items = loc.grid
    grid_closest_kernel(q, loc.a, loc.b, loc.c, lo, hi, origin, h, dims, start, items, best_d, best_t, best_p,
                        best_w)
    return ClosestPoints(best_d, best_t, best_p, best_w)
