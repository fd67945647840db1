"""Self-intersections of a triangle mesh, without testing all pairs.

Candidate pairs come from k-d trees over the triangles' bounding spheres
(centroid, centroid-to-corner radius), one tree per bucket of similar radii,
then an axis-aligned box filter; only those pairs get the exact test. Pairs are
classified by the vertices they share:

* none: the interval test of Möller on the line where the two planes meet,
  or, for coplanar pairs, a separating-axis test on the six edge normals;
* one vertex s: the triangles meet beyond s exactly when the edge opposite s
  in one crosses the other triangle (non-coplanar), or when their corner
  wedges at s overlap (coplanar);
* an edge: they meet beyond it only when folded flat onto each other
  (coplanar with the opposite corners on the same side);
* three vertices: a duplicated triangle, always counted.

Touching counts as intersecting (a vertex on another triangle, a T-junction).
Distances below ``tol.point`` are snapped to zero, so contact closer than the
point tolerance counts too. Zero-area triangles are left out of the test and
counted separately (`trimsurf.quality.triangle_quality` reports them).

References
----------
T. Möller, A fast triangle-triangle intersection test, J. Graphics Tools 2(2)
(1997) 25-30. C. Ericson, *Real-Time Collision Detection*, 2005, Sec. 4.4
(separating axis test).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from ..model import TriMesh
from ..tolerance import Tolerance, default_tolerance
from ._results import ResultMixin
from .closest_point import _radius_buckets

__all__ = ["triangles_intersect", "SelfIntersections", "self_intersections"]

_CHUNK = 1 << 17  # candidate pairs tested at once


def _dot(x, y):
    return np.einsum("...j,...j->...", x, y)


def _unit_normals(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    length = np.linalg.norm(n, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return n / length[:, None], length


def _plane_distances(points: np.ndarray, t: np.ndarray, unit_n: np.ndarray, eps: float) -> np.ndarray:
    """Signed distances (n, k) of points (n, k, 3) to the planes of t, snapped to 0 within eps."""
    d = _dot(points - t[:, None, 0], unit_n[:, None, :])
    return np.where(np.abs(d) <= eps, 0.0, d)


def _interval(p: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where a triangle crosses the other plane, as an interval of the projections p (n, 3)."""
    lo = np.full(len(p), np.inf)
    hi = np.full(len(p), -np.inf)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        di, dj = d[:, i], d[:, j]
        ok = (di * dj <= 0) & ~((di == 0) & (dj == 0))
        with np.errstate(divide="ignore", invalid="ignore"):
            t = p[:, i] + (p[:, j] - p[:, i]) * np.where(ok, di / (di - dj), 0.0)
        lo = np.where(ok, np.minimum(lo, t), lo)
        hi = np.where(ok, np.maximum(hi, t), hi)
    return lo, hi


def _project_2d(t1: np.ndarray, t2: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop the coordinate where the normal n is largest (n, 3, 3) -> (n, 3, 2)."""
    drop = np.argmax(np.abs(n), axis=1)
    keep = np.array([[1, 2], [0, 2], [0, 1]])[drop][:, None, :]
    return np.take_along_axis(t1, keep, axis=2), np.take_along_axis(t2, keep, axis=2)


def _sat_2d(a: np.ndarray, b: np.ndarray, eps: float) -> np.ndarray:
    """Closed triangles (n, 3, 2) overlap or touch (within eps): no separating edge normal."""
    overlap = np.ones(len(a), dtype=bool)
    for tri in (a, b):
        for i in range(3):
            e = tri[:, (i + 1) % 3] - tri[:, i]
            axis = np.column_stack([-e[:, 1], e[:, 0]])
            length = np.linalg.norm(axis, axis=1)
            length[length == 0] = 1.0
            axis = axis / length[:, None]
            pa = _dot(a, axis[:, None, :])
            pb = _dot(b, axis[:, None, :])
            overlap &= (pa.max(axis=1) >= pb.min(axis=1) - eps) & (pb.max(axis=1) >= pa.min(axis=1) - eps)
    return overlap


def triangles_intersect(t1, t2, *, eps: float = 0.0) -> np.ndarray:
    """Whether closed triangles t1[i] and t2[i] intersect (touching counts), row by row.

    Parameters
    ----------
    t1, t2 : (n, 3, 3) float64
        Corner coordinates; shared vertices are not treated specially here.
    eps : float
        Distances to the other triangle's plane at most `eps` count as zero.

    Returns
    -------
    (n,) bool

    References
    ----------
    Möller (1997) interval test; separating axes for coplanar pairs.

    Examples
    --------
    >>> a = [[[0, 0, 0], [2, 0, 0], [0, 2, 0]]]
    >>> b = [[[0.5, 0.5, -1], [0.5, 0.5, 1], [3, 3, 0.2]]]
    >>> triangles_intersect(a, b).tolist()
    [True]
    """
    a = np.asarray(t1, dtype=np.float64).reshape(-1, 3, 3)
    b = np.asarray(t2, dtype=np.float64).reshape(-1, 3, 3)
    if a.shape != b.shape:
        raise InputError(f"t1 and t2 must have the same shape (n, 3, 3); got {a.shape} and {b.shape}")
    na, _ = _unit_normals(a)
    nb, _ = _unit_normals(b)
    da = _plane_distances(a, b, nb, eps)               # corners of a against the plane of b
    db = _plane_distances(b, a, na, eps)
    apart = (np.all(da > 0, axis=1) | np.all(da < 0, axis=1) | np.all(db > 0, axis=1) | np.all(db < 0, axis=1))
    coplanar = np.all(da == 0, axis=1) | np.all(db == 0, axis=1)
    hit = np.zeros(len(a), dtype=bool)
    cp = np.flatnonzero(coplanar & ~apart)
    if cp.size:
        a2, b2 = _project_2d(a[cp], b[cp], na[cp])
        hit[cp] = _sat_2d(a2, b2, eps)
    gen = np.flatnonzero(~coplanar & ~apart)
    if gen.size:
        direction = np.cross(na[gen], nb[gen])
        pa = _dot(a[gen], direction[:, None, :])
        pb = _dot(b[gen], direction[:, None, :])
        lo_a, hi_a = _interval(pa, da[gen])
        lo_b, hi_b = _interval(pb, db[gen])
        hit[gen] = np.maximum(lo_a, lo_b) <= np.minimum(hi_a, hi_b)
    return hit


def _segment_hits_triangle(p: np.ndarray, q: np.ndarray, t: np.ndarray, unit_n: np.ndarray,
                           eps: float) -> np.ndarray:
    """Closed segment [p, q] meets triangle t (not coplanar), rows (n, 3) / (n, 3, 3)."""
    dp = _dot(p - t[:, 0], unit_n)
    dq = _dot(q - t[:, 0], unit_n)
    dp = np.where(np.abs(dp) <= eps, 0.0, dp)
    dq = np.where(np.abs(dq) <= eps, 0.0, dq)
    crosses = (dp * dq <= 0) & ~((dp == 0) & (dq == 0))
    with np.errstate(divide="ignore", invalid="ignore"):
        x = p + (q - p) * np.where(crosses, dp / (dp - dq), 0.0)[:, None]
    inside = crosses.copy()
    for i in range(3):
        e = t[:, (i + 1) % 3] - t[:, i]
        out = np.cross(e, unit_n)                      # points away from the triangle (CCW about unit_n)
        length = np.linalg.norm(out, axis=1)
        length[length == 0] = 1.0
        inside &= _dot(x - t[:, i], out) / length <= eps
    return inside


def _wedges_overlap(s, a1, b1, a2, b2, n, angle_eps: float) -> np.ndarray:
    """Coplanar wedges at s spanned by (a1, b1) and (a2, b2) share interior points, rows (n, 3)."""
    u1, v1, u2, v2 = a1 - s, b1 - s, a2 - s, b2 - s

    def cross_n(x, y):
        xy = _dot(np.cross(x, y), n)
        return xy / (np.linalg.norm(x, axis=1) * np.linalg.norm(y, axis=1))

    flip1 = cross_n(u1, v1) < 0
    u1, v1 = np.where(flip1[:, None], v1, u1), np.where(flip1[:, None], u1, v1)
    flip2 = cross_n(u2, v2) < 0
    u2, v2 = np.where(flip2[:, None], v2, u2), np.where(flip2[:, None], u2, v2)

    def strictly_inside(d, u, v):
        return (cross_n(u, d) > angle_eps) & (cross_n(d, v) > angle_eps)

    def same_ray(x, y):
        return (np.abs(cross_n(x, y)) <= angle_eps) & (_dot(x, y) > 0)

    return (strictly_inside(u2, u1, v1) | strictly_inside(v2, u1, v1) | strictly_inside(u1, u2, v2)
            | strictly_inside(v1, u2, v2) | (same_ray(u1, u2) & same_ray(v1, v2)))


@dataclass(frozen=True, eq=False)
class SelfIntersections(ResultMixin):
    """Pairs of triangles of one mesh that intersect beyond their shared vertices or edge.

    Attributes
    ----------
    n_pairs : int
    pairs : (k, 2) int64
        Triangle index pairs (i < j), sorted.
    n_triangles_involved : int
    n_candidates : int
        Pairs that passed the bounding-sphere and box filters (the exact tests done).
    n_degenerate_skipped : int
        Zero-area triangles left out.
    eps : float
        Distance snapped to zero (model units).
    """

    n_pairs: int
    pairs: np.ndarray
    n_triangles_involved: int
    n_candidates: int
    n_degenerate_skipped: int
    eps: float


def _candidate_pairs(p: np.ndarray, eps: float) -> np.ndarray:
    """Triangle pairs (k, 2), i < j, whose bounding spheres and boxes overlap."""
    centroid = p.mean(axis=1)
    radius = np.sqrt(np.max(np.sum((p - centroid[:, None]) ** 2, axis=2), axis=1))
    groups = _radius_buckets(radius)
    trees = [(idx, cKDTree(centroid[idx]), float(radius[idx].max())) for idx in groups]
    found = []
    for gi, (ia, ta, ra) in enumerate(trees):
        pairs = ta.query_pairs(2 * ra + eps, output_type="ndarray")
        found.append(ia[pairs])
        for ib, tb, rb in trees[gi + 1:]:
            sdm = ta.sparse_distance_matrix(tb, ra + rb + eps, output_type="ndarray")
            found.append(np.column_stack([ia[sdm["i"]], ib[sdm["j"]]]))
    pairs = np.concatenate(found).reshape(-1, 2).astype(np.int64)
    pairs.sort(axis=1)
    i, j = pairs[:, 0], pairs[:, 1]
    keep = np.linalg.norm(centroid[i] - centroid[j], axis=1) <= radius[i] + radius[j] + eps
    lo, hi = p.min(axis=1), p.max(axis=1)
    keep &= np.all((lo[i] <= hi[j] + eps) & (lo[j] <= hi[i] + eps), axis=1)
    return pairs[keep]


def _test_pairs(p: np.ndarray, tris: np.ndarray, pairs: np.ndarray, eps: float, angle_eps: float) -> np.ndarray:
    """Exact test of candidate pairs, handling shared vertices; returns a hit mask."""
    ti, tj = tris[pairs[:, 0]], tris[pairs[:, 1]]
    eq = ti[:, :, None] == tj[:, None, :]              # eq[k, a, b]: corner a of i is corner b of j
    n_shared = eq.sum(axis=(1, 2))
    hit = np.zeros(len(pairs), dtype=bool)
    a, b = p[pairs[:, 0]], p[pairs[:, 1]]

    sel = np.flatnonzero(n_shared == 0)
    if sel.size:
        hit[sel] = triangles_intersect(a[sel], b[sel], eps=eps)

    sel = np.flatnonzero(n_shared == 1)
    if sel.size:
        e = eq[sel]
        ca = np.argmax(e.any(axis=2), axis=1)          # corner of i that is shared
        cb = np.argmax(e.any(axis=1), axis=1)
        r = np.arange(sel.size)
        A, B = a[sel], b[sel]
        s = A[r, ca]
        a1, b1 = A[r, (ca + 1) % 3], A[r, (ca + 2) % 3]
        a2, b2 = B[r, (cb + 1) % 3], B[r, (cb + 2) % 3]
        na, _ = _unit_normals(A)
        nb, _ = _unit_normals(B)
        d1 = _plane_distances(B, A, na, eps)           # corners of j against plane of i
        coplanar = np.all(d1 == 0, axis=1)
        res = np.zeros(sel.size, dtype=bool)
        c = np.flatnonzero(coplanar)
        if c.size:
            res[c] = _wedges_overlap(s[c], a1[c], b1[c], a2[c], b2[c], na[c], angle_eps)
        g = np.flatnonzero(~coplanar)
        if g.size:
            res[g] = (_segment_hits_triangle(a1[g], b1[g], B[g], nb[g], eps)
                      | _segment_hits_triangle(a2[g], b2[g], A[g], na[g], eps))
        hit[sel] = res

    sel = np.flatnonzero(n_shared == 2)
    if sel.size:
        e = eq[sel]
        oa = np.argmin(e.any(axis=2), axis=1)          # corner of i not shared
        ob = np.argmin(e.any(axis=1), axis=1)
        r = np.arange(sel.size)
        A, B = a[sel], b[sel]
        o1, o2 = A[r, oa], B[r, ob]
        s0, s1 = A[r, (oa + 1) % 3], A[r, (oa + 2) % 3]
        na, _ = _unit_normals(A)
        coplanar = np.abs(_dot(o2 - s0, na)) <= eps
        edge = s1 - s0
        same_side = _dot(np.cross(edge, o1 - s0), np.cross(edge, o2 - s0)) > 0
        hit[sel] = coplanar & same_side

    hit[n_shared == 3] = True
    return hit


def self_intersections(mesh: TriMesh, *, tol: Tolerance | None = None) -> SelfIntersections:
    """Pairs of triangles of `mesh` that intersect other than at their shared vertices or edge.

    Parameters
    ----------
    mesh : TriMesh
    tol : Tolerance or None
        ``tol.point`` is the distance snapped to zero and ``tol.angle_rad`` the
        angle below which two rays at a shared vertex are the same; default
        ``default_tolerance(mesh.diagonal())``.

    Returns
    -------
    SelfIntersections

    Raises
    ------
    InputError
        Not a TriMesh, or `tol` not a Tolerance.

    Notes
    -----
    Cost is about O(m log m + k) for k candidate pairs; k stays near 10 m on
    meshes without slivers much longer than their neighbours.

    Examples
    --------
    >>> tet = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    >>> self_intersections(tet).n_pairs
    0
    """
    if not isinstance(mesh, TriMesh):
        raise InputError(f"self_intersections needs a TriMesh; got {type(mesh).__name__}")
    if tol is None:
        tol = default_tolerance(mesh.diagonal())
    if not isinstance(tol, Tolerance):
        raise InputError(f"tol must be a trimsurf.tolerance.Tolerance; got {type(tol).__name__}")
    eps = float(tol.point)
    empty = np.zeros((0, 2), dtype=np.int64)
    good = np.arange(mesh.n_triangles, dtype=np.int64)
    good = good[_not_sliver(mesh, good, eps)]
    n_degenerate = mesh.n_triangles - len(good)
    if len(good) < 2:
        return SelfIntersections(0, empty, 0, 0, n_degenerate, eps)
    tris = mesh.triangles[good]
    p = mesh.vertices[tris]
    cand = _candidate_pairs(p, eps)
    hits = [cand[s:s + _CHUNK][_test_pairs(p, tris, cand[s:s + _CHUNK], eps, tol.angle_rad)]
            for s in range(0, len(cand), _CHUNK)]
    pairs = good[np.concatenate(hits)] if hits else empty
    pairs = np.sort(pairs, axis=1).reshape(-1, 2)
    pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))] if len(pairs) else empty
    return SelfIntersections(int(len(pairs)), pairs, int(len(np.unique(pairs))), int(len(cand)),
                             int(n_degenerate), eps)


def _not_sliver(mesh: TriMesh, idx: np.ndarray, eps: float) -> np.ndarray:
    """Triangles whose height over their longest edge exceeds eps (not collapsed to a segment)."""
    p = mesh.vertices[mesh.triangles[idx]]
    longest = np.linalg.norm(p[:, [1, 2, 0]] - p, axis=2).max(axis=1)
    area = mesh.triangle_areas()[idx]
    with np.errstate(divide="ignore", invalid="ignore"):
        height = np.where(longest > 0, 2 * area / longest, 0.0)
    return height > eps
