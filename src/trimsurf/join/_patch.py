"""One patch of the join (Sec. III-B, steps 1 and 3-5): central mesh, external region, reprojection.

The boundary dR (step 2: the projected piecewise-linear b_k) is built by the
caller (`_shell`), which shares every boundary point between the faces that
use its edge. Here, for one face:

* step 1 -- the mesh vertices are projected to (u, v) (`project_mesh`), with
  the checks Sec. II assumes: each vertex near the surface, and M^-1
  injective (no triangle turned over in (u, v));
* step 3 -- peripheral triangles are removed, at least one layer, until the
  central mesh lies strictly inside dR (`central_mask`);
* step 4 -- the region between dR and the central mesh is triangulated with
  Shewchuk's Triangle (Ruppert refinement, minimum angle `min_angle_deg`);
  points Triangle inserts on dR are handed back to the caller, which inserts
  them into the shared edge polyline (so the neighbour gets them too) and
  runs the face again; points inserted on the central mesh's boundary split
  the central triangles there (step 6, merging);
* step 5 -- every vertex is reprojected to F(p) + a(p) n(p), a the Whitney
  average of the boundary discrepancy eps (eqs. 3, 4); vertices on dR are
  the shared boundary points themselves.

Beside a collapsed edge (a pole) the parametrization is singular, outside
Sec. II's hypothesis of a Jacobian of full rank. Where the face ends in a
cusp there, Triangle is given a ring of points beside the pole (`_pole_ring`)
and the caller flips external edges where a triangle still turns over in 3D
(`repair_pole_turns`); such faces claim no angle bound.
"""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

from ..errors import InputError
from ..geom import orient2d, points_in_polygons, project_to_surface
from ..model import TrimmedFace, TriMesh
from ..geom.whitney import BoundaryData, boundary_data, whitney_average
from ._chains import loops_from_edges

__all__ = ["MeshProjection", "project_mesh", "PatchResult", "join_patch", "repair_pole_turns",
           "PAPER_MIN_ANGLE_DEG"]

#: The paper's guaranteed minimum angle of the external region (Sec. III-B): arctan(sin t / (2 - cos t)),
#: t = 26.45 deg.
PAPER_MIN_ANGLE_DEG = float(np.degrees(np.arctan(np.sin(np.radians(26.45)) / (2 - np.cos(np.radians(26.45))))))
#: Minimum boundary angle the paper's hypothesis asks for (Sec. III-B).
PAPER_BOUNDARY_ANGLE_DEG = 26.45
_MARGIN = 0.5          # the central boundary keeps this fraction of the median (u, v) edge length away from dR
_SLIVER_REL = 1e-12    # a (u, v) triangle smaller than this x extent^2 has no orientation to turn
_MAX_PEEL = 200        # layers of peripheral triangles removed at most


class MeshProjection(NamedTuple):
    """Step 1: a face mesh projected to (u, v)."""

    uv: np.ndarray            # (n, 2)
    distance: np.ndarray      # (n,) |v - F(uv)|
    triangles: np.ndarray     # (m, 3) counter-clockwise in (u, v)
    n_turned: int             # triangles turned over in (u, v) (M^-1 not injective if > 0)
    max_distance: float
    boundary_edges: np.ndarray  # (k, 2) directed boundary edges of the mesh (in `triangles`' orientation)
    foot: np.ndarray | None = None    # (n, 3) F(uv) where the projection evaluated it last (NaN rows: not known)
    normal: np.ndarray | None = None  # (n, 3) unit Su x Sv there (zero where undefined)
    speeds: np.ndarray | None = None  # (n, 2) |Su|, |Sv| there


def _surface_args(face: TrimmedFace):
    s = face.surface
    return s.degree_u, s.degree_v, s.knots_u, s.knots_v, s.control_points, s.weights


def project_points(face: TrimmedFace, points, uv0=None):
    """Closest points on the face surface (warm-started at `uv0`); returns `geom.projection.Projection`."""
    return project_to_surface(np.asarray(points, dtype=np.float64).reshape(-1, 3), *_surface_args(face), uv0=uv0)


class _Proj(NamedTuple):
    uv: np.ndarray
    distance: np.ndarray
    foot: np.ndarray | None = None     # F(uv) from the last Gauss-Newton evaluation (NaN rows: not known)
    normal: np.ndarray | None = None
    speeds: np.ndarray | None = None   # |Su|, |Sv| there


def project_near(face: TrimmedFace, points: np.ndarray, uv0: np.ndarray, *, spacing: float) -> _Proj:
    """Closest points for points near the surface with good (u, v) guesses: Gauss-Newton, else the full search.

    Points that converge from `uv0` within a quarter of `spacing` of the surface keep that result; the
    others are projected by `geom.project_to_surface` (seeded search) from `uv0`.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not len(points):
        return _Proj(np.zeros((0, 2)), np.zeros(0))
    lo_c, hi_c = face.surface.control_bbox()
    tol = 1e-10 * float(np.linalg.norm(hi_c - lo_c))
    uv, foot, dist, ok, nrm, speeds = _newton_from_uv(face, points, np.asarray(uv0, dtype=np.float64), tol=tol,
                                                      max_dist=0.25 * spacing, with_normals=True)
    if not ok.all():
        rest = project_points(face, points[~ok], uv0=np.asarray(uv0)[~ok])
        uv[~ok], dist[~ok] = rest.uv, rest.distance
        foot[~ok] = np.nan
        nrm[~ok] = np.nan
        speeds[~ok] = np.nan
    return _Proj(uv, dist, foot, nrm, speeds)


def heights(face: TrimmedFace, uv, points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """eta = (x - F(p)) . n(p) (Sec. II), F(p) and n(p) = Su x Sv / |Su x Sv| (NaN rows at a pole -> eta 0)."""
    s = face.surface
    d = s.derivatives(uv, 1)
    foot = d[0, 0]
    nrm = np.cross(d[1, 0], d[0, 1])
    ln = np.linalg.norm(nrm, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        nrm = nrm / ln[:, None]
    bad = ~np.isfinite(nrm).all(axis=1) | (ln == 0)
    nrm[bad] = 0.0
    eta = np.einsum("ij,ij->i", np.asarray(points) - foot, nrm)
    return eta, foot, nrm


def parameter_scale(face: TrimmedFace, uv: np.ndarray, speeds: np.ndarray | None = None) -> np.ndarray:
    """(|Su|, |Sv|) medians over `uv` (at most 2000 of them): the scale of the working parameters w.

    `speeds`: (|Su|, |Sv|) at `uv` if already evaluated (NaN rows: not known).
    """
    step = max(1, len(uv) // 2000)
    known = None if speeds is None else speeds[::step]
    if known is not None and np.isfinite(known).all():
        su, sv = known[:, 0], known[:, 1]
    else:
        d = face.surface.derivatives(uv[::step], 1)
        su = np.linalg.norm(d[1, 0], axis=1)
        sv = np.linalg.norm(d[0, 1], axis=1)
    out = np.array([np.median(su[su > 0]) if np.any(su > 0) else 1.0,
                    np.median(sv[sv > 0]) if np.any(sv > 0) else 1.0])
    return out


def cached_scale(face: TrimmedFace, proj: MeshProjection, cache: dict | None) -> np.ndarray:
    """`parameter_scale` of a projected mesh, computed once per face (``cache["scale"]``)."""
    if cache is None:
        return parameter_scale(face, proj.uv, proj.speeds)
    if "scale" not in cache:
        cache["scale"] = parameter_scale(face, proj.uv, proj.speeds)
    return cache["scale"]


def _newton_from_uv(face: TrimmedFace, points: np.ndarray, uv0: np.ndarray, *, tol: float, max_dist: float,
                    iterations: int = 4, with_normals: bool = False):
    """Closest points by Gauss-Newton from the mesh's own (u, v); returns (uv, foot, distance, ok).

    ``ok`` marks points that converged (tangential residual |(S - P).S_u| / |S_u| and the same for v at
    most `tol`, as `geom.project_to_surface`'s test, at the final, domain-clipped (u, v)) and lie within `max_dist`
    of the surface (far below the mesh spacing, so no other sheet of the surface can be closer). The
    others go to `geom.project_to_surface`.
    """
    s = face.surface
    (u0, u1), (v0, v1) = s.domain
    lo, hi = np.array([u0, v0]), np.array([u1, v1])
    uv = np.clip(uv0, lo, hi)
    for it in range(iterations + 1):
        d = s.derivatives(uv, 1)
        foot, su, sv = d[0, 0], d[1, 0], d[0, 1]
        r = foot - points
        gu, gv = np.einsum("ij,ij->i", su, r), np.einsum("ij,ij->i", sv, r)
        e, f, g = np.einsum("ij,ij->i", su, su), np.einsum("ij,ij->i", su, sv), np.einsum("ij,ij->i", sv, sv)
        # stationary in the free directions; at a domain edge, the distance grows inwards (KKT)
        tu, tv = tol * np.sqrt(e), tol * np.sqrt(g)
        ok_u = (np.abs(gu) <= tu) | ((uv[:, 0] <= lo[0]) & (gu >= -tu)) | ((uv[:, 0] >= hi[0]) & (gu <= tu))
        ok_v = (np.abs(gv) <= tv) | ((uv[:, 1] <= lo[1]) & (gv >= -tv)) | ((uv[:, 1] >= hi[1]) & (gv <= tv))
        conv = ok_u & ok_v
        if it == iterations or conv.all():
            break
        det = e * g - f * f
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.column_stack([-(g * gu - f * gv) / det, -(e * gv - f * gu) / det])
            # active set: a parameter held at its bound (distance growing outwards) stays; Newton in the other
            held_u = ((uv[:, 0] <= lo[0]) & (gu >= -tu)) | ((uv[:, 0] >= hi[0]) & (gu <= tu))
            held_v = ((uv[:, 1] <= lo[1]) & (gv >= -tv)) | ((uv[:, 1] >= hi[1]) & (gv <= tv))
            step[held_u] = np.column_stack([np.zeros(int(held_u.sum())), -gv[held_u] / g[held_u]])
            step[held_v] = np.column_stack([-gu[held_v] / e[held_v], np.zeros(int(held_v.sum()))])
        step[~np.isfinite(step).all(axis=1) | conv | (held_u & held_v)] = 0.0
        uv = np.clip(uv + step, lo, hi)
    dist = np.linalg.norm(foot - points, axis=1)
    if not with_normals:
        return uv, foot, dist, conv & (dist <= max_dist)
    # F and n at the returned (u, v) (the last evaluation): as `_foot_normal` would give them
    nrm = np.cross(su, sv)
    ln = np.linalg.norm(nrm, axis=1)
    nrm = np.where(ln[:, None] > 0, nrm / np.where(ln > 0, ln, 1.0)[:, None], 0.0)
    speeds = np.column_stack([np.linalg.norm(su, axis=1), np.linalg.norm(sv, axis=1)])   # as parameter_scale
    return uv, foot.copy(), dist, conv & (dist <= max_dist), nrm, speeds


def project_mesh(face: TrimmedFace, mesh: TriMesh) -> MeshProjection:
    """Step 1: project the mesh vertices to (u, v) (warm start: the mesh's own uv, if any)."""
    if mesh.n_triangles == 0:
        raise InputError(f"{face.name or 'face'}: mesh has no triangles")
    if mesh.uv is not None and np.all(np.isfinite(mesh.uv)):
        tt = mesh.triangles[:: max(1, mesh.n_triangles // 20000)]   # a sample of the edges is enough
        spacing = float(np.median(np.linalg.norm(mesh.vertices[tt[:, 0]] - mesh.vertices[tt[:, 1]], axis=1)))
        pr = project_near(face, mesh.vertices, mesh.uv, spacing=spacing)
    else:
        pr = project_points(face, mesh.vertices)
    t = mesh.triangles
    sign = orient2d(pr.uv[t[:, 0]], pr.uv[t[:, 1]], pr.uv[t[:, 2]])
    a = pr.uv[t]
    area = 0.5 * ((a[:, 1, 0] - a[:, 0, 0]) * (a[:, 2, 1] - a[:, 0, 1])
                  - (a[:, 2, 0] - a[:, 0, 0]) * (a[:, 1, 1] - a[:, 0, 1]))
    major = 1 if area.sum() >= 0 else -1
    tris = t if major > 0 else np.ascontiguousarray(t[:, ::-1])
    # turned over: the opposite sign, beyond a sliver of zero area (rounding in the projection)
    ext = float(np.ptp(pr.uv, axis=0).max()) if len(pr.uv) else 0.0
    n_turned = int(np.count_nonzero((sign == -major) & (np.abs(area) > _SLIVER_REL * ext * ext)))
    return MeshProjection(pr.uv, pr.distance, tris, n_turned, float(pr.distance.max(initial=0.0)),
                          _boundary_edges(tris, len(pr.uv)), getattr(pr, "foot", None), getattr(pr, "normal", None),
                          getattr(pr, "speeds", None))


class PatchResult(NamedTuple):
    """Steps 3-5 for one face; vertex arrays cover central, boundary and external vertices."""

    uv: np.ndarray             # (N, 2)
    points: np.ndarray         # (N, 3) reprojected (boundary: the shared points)
    heights: np.ndarray        # (N,) a(p) (boundary: eps)
    gid: np.ndarray            # (N,) shared boundary id, -1 for the face's own vertices
    triangles: np.ndarray      # (T, 3) counter-clockwise in (u, v)
    external: np.ndarray       # (T,) bool: triangle of the external region
    central_source: np.ndarray  # (N,) index of the input mesh vertex (-1 if new)
    lipschitz: float           # L of eq. (2) over dR
    eps_max: float             # max |eps| on dR
    min_angle_external_deg: float
    min_input_angle_deg: float  # smallest angle between the PSLG's segments inside the external region
    boundary_steiner: list     # [(loop, segment, fraction, vertex)] points Triangle put on dR
    n_central: int             # central triangles kept (before splitting)
    n_removed: int             # peripheral triangles removed
    n_split_long: int          # long edges split (Sec. III-D)
    whitney_blocks: float      # mean pruning blocks evaluated per query
    scale: np.ndarray          # (2,) the metric: slopes and angles are measured in w = uv * scale
    boundary: BoundaryData     # dR in w with eps (for later splits)
    seconds: dict              # time per step: central, triangulate, whitney
    central_keep: np.ndarray   # (m,) bool: input triangles kept in the central mesh
    boundary_steiner_allowed: bool  # False: the last pass forbade points on dR (the angle bound may fail there)
    pole_flips: int = 0        # edges flipped beside a pole (`repair_pole_turns`): no angle bound claimed


def _boundary_edges(tris: np.ndarray, n: int) -> np.ndarray:
    he = np.stack([tris, np.roll(tris, -1, axis=1)], axis=2).reshape(-1, 2)
    key = np.minimum(he[:, 0], he[:, 1]) * n + np.maximum(he[:, 0], he[:, 1])
    _, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
    return he[cnt[inv] == 1]


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, chunk: int = 1 << 21) -> np.ndarray:
    """min over segments (a_j, b_j) of the distance to each point p_i."""
    out = np.full(len(p), np.inf)
    ab = b - a
    l2 = np.maximum((ab * ab).sum(1), 1e-300)
    step = max(1, chunk // max(1, len(a)))
    for s in range(0, len(p), step):
        q = p[s:s + step, None, :]
        t = np.clip(((q - a[None]) * ab[None]).sum(-1) / l2[None], 0.0, 1.0)
        d = q - (a[None] + t[..., None] * ab[None])
        out[s:s + step] = np.sqrt((d * d).sum(-1)).min(axis=1)
    return out


def _crossing_edges(p0, p1, a, b, chunk: int = 1 << 21) -> np.ndarray:
    """Which segments (p0_i, p1_i) touch any of the segments (a_j, b_j) (bounding-box prefilter, exact test)."""
    hit = np.zeros(len(p0), dtype=bool)
    if not len(p0) or not len(a):
        return hit
    lo1, hi1 = np.minimum(p0, p1), np.maximum(p0, p1)
    lo2, hi2 = np.minimum(a, b), np.maximum(a, b)
    step = max(1, chunk // len(a))
    for s in range(0, len(p0), step):
        sl = slice(s, s + step)
        ov = ((lo1[sl, None, 0] <= hi2[None, :, 0]) & (lo2[None, :, 0] <= hi1[sl, None, 0])
              & (lo1[sl, None, 1] <= hi2[None, :, 1]) & (lo2[None, :, 1] <= hi1[sl, None, 1]))
        i, j = np.nonzero(ov)
        if not len(i):
            continue
        d1 = orient2d(a[j], b[j], p0[sl][i])
        d2 = orient2d(a[j], b[j], p1[sl][i])
        d3 = orient2d(p0[sl][i], p1[sl][i], a[j])
        d4 = orient2d(p0[sl][i], p1[sl][i], b[j])
        touch = (d1 * d2 <= 0) & (d3 * d4 <= 0)
        hit[s + i[touch]] = True
    return hit


def central_mask(uv: np.ndarray, tris: np.ndarray, loops_uv: list[np.ndarray], *, margin: float,
                 initial: np.ndarray | None = None, mesh_boundary: np.ndarray | None = None,
                 min_boundary_angle_deg: float = PAPER_BOUNDARY_ANGLE_DEG,
                 initial_boundary: np.ndarray | None = None):
    """Step 3: triangles of the central mesh (at least one peripheral layer removed, the rest inside dR).

    `initial`: a mask to start from (one from an earlier run on a slightly
    different dR); it is checked and peeled further where needed.
    `mesh_boundary`: the input mesh's boundary edges, if known. Returns the
    mask and the central mesh's directed boundary edges.
    """
    n = len(uv)
    a = np.concatenate(loops_uv)
    b = np.concatenate([np.roll(lp, -1, axis=0) for lp in loops_uv])
    if initial is not None:
        keep = np.asarray(initial, dtype=bool).copy()
    else:
        # one layer: every triangle touching the input mesh's boundary
        be = _boundary_edges(tris, n) if mesh_boundary is None else mesh_boundary
        on_b = np.zeros(n, dtype=bool)
        on_b[be.ravel()] = True
        keep = ~on_b[tris].any(axis=1)
    be = np.zeros((0, 2), dtype=np.int64)
    for it in range(_MAX_PEEL):
        if not keep.any():
            be = np.zeros((0, 2), dtype=np.int64)
            break
        t = tris[keep]
        # the boundary of `initial` may be given (from the run that produced it)
        be = initial_boundary if (it == 0 and initial is not None and initial_boundary is not None) \
            else _boundary_edges(t, n)
        bad_v = np.zeros(n, dtype=bool)
        # non-manifold boundary vertices (two outgoing boundary edges)
        cnt = np.bincount(be[:, 0], minlength=n)
        bad_v |= cnt > 1
        bv = np.unique(be.ravel())
        inside = points_in_polygons(uv[bv], loops_uv)
        near = _point_segment_distance(uv[bv], a, b) <= margin
        bad_v[bv[~inside | near]] = True
        cross = _crossing_edges(uv[be[:, 0]], uv[be[:, 1]], a, b)
        bad_v[be[cross].ravel()] = True
        # the external region's angle at a central boundary vertex (360 deg minus the central triangles'
        # angles there) below the paper's 26.45 deg: peel there too, so Ruppert's hypothesis holds
        if min_boundary_angle_deg > 0:
            on_bv = np.zeros(n, dtype=bool)
            on_bv[bv] = True
            tb = t[on_bv[t].any(axis=1)]
            ang = _angles_deg(uv[tb])
            ssum = np.bincount(tb.ravel(), weights=ang.ravel(), minlength=n)
            sharp = on_bv & (360.0 - ssum < min_boundary_angle_deg) & ~bad_v
            bad_v |= sharp
        # a dR vertex inside the central region (a hole the mesh covers)
        if not bad_v.any():
            loops_c = loops_from_edges(be)
            inner = points_in_polygons(a, [uv[lp] for lp in loops_c]) if loops_c else np.zeros(len(a), bool)
            if inner.any():
                q = a[inner]
                tri_uv = uv[t]
                lo, hi = tri_uv.min(axis=1), tri_uv.max(axis=1)
                hitt = np.zeros(len(t), dtype=bool)
                for s in range(0, len(q), 256):
                    qq = q[s:s + 256]
                    hitt |= ((lo[:, None, :] <= qq[None] + margin) & (qq[None] - margin <= hi[:, None, :])).all(
                        axis=2).any(axis=1)
                bad_v[t[hitt].ravel()] = True
        if not bad_v.any():
            break
        idx = np.flatnonzero(keep)
        keep[idx[bad_v[t].any(axis=1)]] = False
    else:  # peeled _MAX_PEEL times: give up on a central mesh
        keep[:] = False
        be = np.zeros((0, 2), dtype=np.int64)
    return keep, be


_CUSP_FAN_DEG = 1.0    # a pole whose face opens by less than this (seen from the pole, one ring away) is a cusp


def _pole_ring(face: TrimmedFace, scale: np.ndarray, loops_w: list[np.ndarray], loops_xyz: list[np.ndarray],
               loops_gid: list[np.ndarray], segments: np.ndarray, vertices: np.ndarray,
               central_loops: list) -> np.ndarray:
    """Points Triangle is given beside a cusp pole: one apex of an equilateral triangle over every pole piece.

    Along a collapsed edge the parametrization is singular (the paper assumes a Jacobian of full rank,
    Sec. II). Where the face ends in a cusp -- its width falls faster than the distance to the pole, so
    seen from the pole it opens by less than `_CUSP_FAN_DEG` at the apexes' distance (U_Joint's thin
    faces: 0.006-0.04 deg) -- a triangle with a corner at the pole and its two other corners at
    different distances from the pole line turns over in 3D although it is well shaped in (u, v). With
    the apexes at one distance from the pole line, the triangles between the pole and the apexes have
    their two other corners at the same distance, which keeps their 3D orientation. A pole where the
    face opens by more (a cone's or a sphere's apex, a surface of revolution's axis) gets no ring: its
    parametrization is polar and Triangle's strip does not turn there. Apexes outside R, in the central
    mesh, or nearer than half their height to any other segment are left out.
    """
    out = []
    sa, sb = vertices[segments[:, 0]], vertices[segments[:, 1]]
    for lp, xyz, g in zip(loops_w, loops_xyz, loops_gid):
        k = len(lp)
        nxt = (np.arange(k) + 1) % k
        on_pole = (g == g[nxt]) & (g >= 0)
        for pole_id in np.unique(g[on_pole]):
            piece = np.flatnonzero(on_pole & (g == pole_id))
            a, b = lp[piece], lp[nxt[piece]]
            d = b - a
            h = np.linalg.norm(d, axis=1)
            ok = h > 0
            if not ok.any():
                continue
            a, b, d, h = a[ok], b[ok], d[ok], h[ok]
            left = np.column_stack([-d[:, 1], d[:, 0]]) / h[:, None]
            mid = 0.5 * (a + b)
            height = 0.5 * np.sqrt(3.0) * h
            for side in (1.0, -1.0):
                q = mid + side * left * height[:, None]
                inside = points_in_polygons(q, loops_w)
                if central_loops:
                    inside &= ~points_in_polygons(q, central_loops)
                if inside.sum() * 2 >= len(q):
                    break
            keep = inside & (_point_segment_distance(q, sa, sb) >= 0.5 * height * (1 - 1e-9))
            if keep.sum() < 2:
                continue
            ray = face.surface.evaluate(q[keep] / scale) - xyz[piece[0]]
            ln = np.linalg.norm(ray, axis=1)
            if not np.all(ln > 0):
                continue
            ray /= ln[:, None]
            fan = float(np.degrees(np.arccos(np.clip(ray @ ray.T, -1.0, 1.0))).max())
            if fan < _CUSP_FAN_DEG:
                out.append(q[keep])
    return np.concatenate(out) if out else np.zeros((0, 2))


def _interior_point(poly: np.ndarray) -> np.ndarray:
    """A point strictly inside a simple polygon (centroid of the largest triangle of its triangulation)."""
    import triangle

    k = len(poly)
    seg = np.column_stack([np.arange(k), (np.arange(k) + 1) % k])
    out = triangle.triangulate({"vertices": poly, "segments": seg}, "pQ")
    t = out["triangles"]
    v = out["vertices"]
    p = v[t]
    area = np.abs((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                  - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
    return p[int(np.argmax(area))].mean(axis=0)


def _angles_deg(p: np.ndarray) -> np.ndarray:
    """Angles (m, 3) of triangles p (m, 3, 2) at each corner, degrees."""
    out = np.empty(p.shape[:2])
    for c in range(3):
        u = p[:, (c + 1) % 3] - p[:, c]
        v = p[:, (c + 2) % 3] - p[:, c]
        cr = np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
        dt = (u * v).sum(1)
        out[:, c] = np.degrees(np.arctan2(cr, dt))
    return out


def _pslg_min_angle(vertices: np.ndarray, tris: np.ndarray, n_input: int) -> float:
    """Smallest angle at an input vertex between two consecutive input segments, inside the region.

    Measured from the output triangulation: at every input vertex the angles of
    its triangles between segments add up; the smallest sum is the smallest
    angle the input PSLG presents to the refinement (the paper's hypothesis
    asks for >= 26.45 deg).
    """
    ang = _angles_deg(vertices[tris])
    # angle sectors at input vertices: sum triangle angles between consecutive segments -- approximated
    # by the smallest corner angle at an input vertex whose two edges are both input segments
    return float(ang[tris < n_input].min(initial=180.0))


def join_patch(face: TrimmedFace, proj: MeshProjection, mesh: TriMesh, loops_uv: list[np.ndarray],
               loops_xyz: list[np.ndarray], loops_eps: list[np.ndarray], loops_gid: list[np.ndarray], *,
               min_angle_deg: float, allow_boundary_steiner: bool = True, split_long_edges: bool = False,
               lipschitz: float | None = None, central_init: np.ndarray | None = None,
               cache: dict | None = None, max_deviation: float | None = None) -> PatchResult:
    """Steps 3-5 (and the central part of step 6) for one face; see the module notes.

    `max_deviation`: Triangle's refinement goes on (area limits on the offending triangles) until every
    external triangle's sampled deviation from the surface, after reprojection, is within it
    (`_refine_to_deviation`); None: quality refinement only (the paper's step 4 as written).
    """
    import triangle

    # work in scaled parameters w = (u |Su|, v |Sv|) (median speeds over the mesh): an affine change of
    # parameters, so every statement of the paper holds in w, and the Ruppert angles mean something in 3D
    scale = cached_scale(face, proj, cache)
    uv = proj.uv * scale
    loops_uv = [lp * scale for lp in loops_uv]
    tris = proj.triangles
    n = len(uv)
    # the margin: a tenth of the median (u, v) edge length of the mesh
    e = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    elen = np.linalg.norm(uv[e[:, 0]] - uv[e[:, 1]], axis=1)
    margin = _MARGIN * float(np.median(elen)) if len(elen) else 0.0
    bdata = boundary_data(loops_uv, loops_eps)
    t0 = time.perf_counter()
    keep, central_be = central_mask(uv, tris, loops_uv, margin=margin, initial=central_init,
                                    mesh_boundary=proj.boundary_edges,
                                    initial_boundary=None if cache is None else cache.get("central_be"))
    if cache is not None:
        cache["central_be"] = central_be
    t_central = time.perf_counter() - t0
    central = tris[keep]
    n_removed = int((~keep).sum())
    # PSLG: dR loops, then the central boundary loops
    rverts = np.concatenate(loops_uv)
    nr = len(rverts)
    # a point dR passes twice (a hole touching the outer loop: turbine face 1) is one vertex for Triangle
    uniq, vpos = _pinch_vertices(rverts, np.concatenate(loops_gid))
    nu = len(uniq)
    segs, marks = [], []
    off = 0
    for li, lp in enumerate(loops_uv):
        k = len(lp)
        idx = off + np.arange(k)
        segs.append(vpos[np.column_stack([idx, off + (np.arange(k) + 1) % k])])
        marks.append(2 + idx)  # marker 2 + global dR segment index
        off += k
    holes = [_interior_point(lp) for lp in loops_uv[1:]]
    cb_vertices = np.zeros(0, dtype=np.int64)
    cb_edges = np.zeros((0, 2), dtype=np.int64)
    if len(central):
        be = central_be
        cb_vertices = np.unique(be.ravel())
        local = np.full(n, -1, dtype=np.int64)
        local[cb_vertices] = nu + np.arange(len(cb_vertices))
        cb_edges = be
        segs.append(local[be])
        marks.append(2 + nr + np.arange(len(be)))
        # one hole point per connected component of the central mesh: a triangle centroid
        from scipy import sparse
        from scipy.sparse import csgraph
        ed = np.concatenate([central[:, [0, 1]], central[:, [1, 2]]])
        g = sparse.coo_matrix((np.ones(len(ed), dtype=np.int8), (ed[:, 0], ed[:, 1])), shape=(n, n)).tocsr()
        _, lab = csgraph.connected_components(g, directed=False)
        first = np.unique(lab[central[:, 0]], return_index=True)[1]
        holes.extend(uv[central[first]].mean(axis=1))
    n_fixed = nu + len(cb_vertices)       # dR and central boundary; then the pole rings' points, if any
    ring = _pole_ring(face, scale, loops_uv, loops_xyz, loops_gid, np.concatenate(segs),
                      np.concatenate([rverts[uniq], uv[cb_vertices]]),
                      [uv[lp] for lp in loops_from_edges(central_be)] if len(central) else [])
    pv = np.concatenate([rverts[uniq], uv[cb_vertices], ring])
    _check_pslg(face, pv, np.concatenate(segs), len(loops_uv))
    data = {"vertices": pv, "segments": np.concatenate(segs), "segment_markers": np.concatenate(marks)[:, None]}
    if holes:
        data["holes"] = np.asarray(holes)
    flags = f"pq{min_angle_deg:.6g}Q" + ("" if allow_boundary_steiner else "Y")
    n_in = len(pv)
    t0 = time.perf_counter()
    out = triangle.triangulate(data, flags)
    t_tri = time.perf_counter() - t0
    t0 = time.perf_counter()
    n_refine = 0
    reused = None   # step 5 at Triangle's vertices, from the refinement's last pass
    if max_deviation is not None and np.isfinite(max_deviation):
        if cache is not None and "second_derivatives" not in cache:
            cache["second_derivatives"] = _second_derivative_bound(face.surface, scale)
        m2 = _second_derivative_bound(face.surface, scale) if cache is None else cache["second_derivatives"]
        out, n_refine, reused = _refine_to_deviation(face, out, flags, nr, np.concatenate(loops_xyz)[uniq], bdata,
                                                     lipschitz, scale, float(max_deviation),
                                                     float(np.abs(np.concatenate(loops_eps)).max(initial=0.0)),
                                                     second_derivatives=m2)
    t_refine = time.perf_counter() - t0
    tv = np.asarray(out["vertices"], dtype=np.float64)
    tt = np.asarray(out["triangles"], dtype=np.int64)
    vm = np.asarray(out["vertex_markers"]).ravel()
    if not np.allclose(tv[:n_in], pv, rtol=0, atol=0):
        raise InputError(f"{face.name or 'face'}: Triangle changed the input vertices (duplicate boundary points?)")
    p = tv[tt]
    area2 = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1])
    tt = np.where((area2 < 0)[:, None], tt[:, ::-1], tt)
    new = np.arange(n_fixed, len(tv))
    on_seg = vm[new] >= 2
    seg_of = vm[new] - 2
    # points on dR: reported back (loop, segment, fraction) for the caller to share with the neighbour
    steiner = []
    on_r = on_seg & (seg_of < nr)
    if on_r.any():
        loop_start = np.cumsum([0] + [len(lp) for lp in loops_uv])
        for vi, sj in zip(new[on_r], seg_of[on_r]):
            li = int(np.searchsorted(loop_start, sj, side="right") - 1)
            si = int(sj - loop_start[li])
            a = loops_uv[li][si]
            b = loops_uv[li][(si + 1) % len(loops_uv[li])]
            frac = float(np.linalg.norm(tv[vi] - a) / np.linalg.norm(b - a))
            steiner.append((li, si, frac, int(vi)))
    ext_angles = _angles_deg(tv[tt]) if len(tt) else np.zeros((0, 3))
    min_ext = float(ext_angles.min(initial=180.0))
    min_in = _pslg_min_angle(tv, tt, n_fixed)
    # ---- assemble the combined mesh: central vertices (input ids), dR, central boundary, new points
    # vertex numbering: [0, n) input mesh vertices; [n, n + nr) dR vertices; then Triangle's new points
    tmap = np.empty(len(tv), dtype=np.int64)
    tmap[:nu] = n + uniq
    tmap[nu:n_fixed] = cb_vertices
    tmap[n_fixed:] = n + nr + np.arange(len(new))
    all_uv = np.concatenate([uv, rverts, tv[n_fixed:]])
    ext_tris = tmap[tt]
    # merging (step 6): central triangles with points inserted on their boundary edges are split
    on_c = on_seg & (seg_of >= nr)
    central_out = central
    if on_c.any():
        central_out, extra = _split_central(central, cb_edges, seg_of[on_c] - nr, tmap[new[on_c]], all_uv)
        all_uv = np.concatenate([all_uv, extra])
    tris_all = np.concatenate([central_out, ext_tris])
    external = np.r_[np.zeros(len(central_out), bool), np.ones(len(ext_tris), bool)]
    n_split = 0
    if split_long_edges:
        all_uv, tris_all, external, n_split = _split_long(all_uv, tris_all, external, min_angle_deg,
                                                           protected=n + np.arange(nr), n_fixed=n + nr)
    # ---- step 5: reprojection with the Whitney average
    nt = len(all_uv)
    used = np.zeros(nt, dtype=bool)
    used[tris_all.ravel()] = True
    used[n + uniq] = True     # (a dR point that is another's pinch copy is not a vertex of its own)
    a_all = np.zeros(nt)
    foot, nrm = np.zeros((nt, 3)), np.zeros((nt, 3))
    known_a = np.zeros(nt, dtype=bool)      # a(p) already evaluated (the refinement's last pass)
    known_f = np.zeros(nt, dtype=bool)      # F(p), n(p) already evaluated
    if reused is not None:
        # the refinement evaluated a(p) at every Triangle vertex (the central boundary's w are the mesh's own,
        # bit for bit) and F, n at the dR and new points: step 5 does not evaluate them again
        a_all[tmap] = reused.average
        known_a[tmap] = True
        new_pt = tmap >= n
        foot[tmap[new_pt]], nrm[tmap[new_pt]] = reused.foot[new_pt], reused.normal[new_pt]
        known_f[tmap[new_pt]] = True
    t0 = time.perf_counter()
    ask = used & ~known_a
    wa = whitney_average(bdata, all_uv[ask], lipschitz=lipschitz)
    t_whitney = time.perf_counter() - t0
    a_all[ask] = wa.average
    n_q = int(ask.sum()) + (0 if reused is None else len(reused.average))
    blocks = ((wa.mean_blocks_visited * int(ask.sum()) + (0.0 if reused is None else
                                                          reused.blocks * len(reused.average))) / max(n_q, 1))
    all_w = all_uv
    all_uv = all_w / scale
    all_uv[:n] = proj.uv                     # the central mesh's (u, v) exactly as projected
    all_uv[n:n + nr] = rverts / scale
    eps_r = np.concatenate(loops_eps)
    a_all[n:n + nr] = eps_r  # exact on dR (a = eps there, eq. 3-4)
    pts = np.zeros((nt, 3))
    # F and n at the mesh's own vertices depend only on their (u, v): evaluated once per face
    need = used & ~known_f
    if cache is not None and "foot" in cache:
        foot[:n], nrm[:n] = cache["foot"], cache["normal"]
        need[:n] = False
    elif proj.foot is not None:
        # step 1 evaluated F and its normal at these (u, v) already (its last Gauss-Newton step)
        foot[:n], nrm[:n] = proj.foot, proj.normal
        need[:n] = ~np.isfinite(proj.foot).all(axis=1)
    else:
        need[:n] = True
    f_, n_ = _foot_normal(face, all_uv[need])
    foot[need], nrm[need] = f_, n_
    if cache is not None and "foot" not in cache:
        cache["foot"], cache["normal"] = foot[:n].copy(), nrm[:n].copy()
    pts[used] = foot[used] + a_all[used, None] * nrm[used]
    pts[n:n + nr] = np.concatenate(loops_xyz)
    gid = np.full(nt, -1, dtype=np.int64)
    gid[n:n + nr] = np.concatenate(loops_gid)
    src = np.full(nt, -1, dtype=np.int64)
    src[:n] = np.arange(n)
    # drop unused input vertices (the removed periphery)
    remap = np.full(nt, -1, dtype=np.int64)
    remap[used] = np.arange(int(used.sum()))
    steiner = [(li, si, frac, int(remap[tmap[vi]])) for li, si, frac, vi in steiner]
    return PatchResult(all_uv[used], pts[used], a_all[used], gid[used], remap[tris_all], external,
                       src[used], float(wa.lipschitz), float(np.abs(eps_r).max()), min_ext, min_in, steiner,
                       int(keep.sum()), n_removed, n_split, float(blocks), scale, bdata,
                       {"central": t_central, "triangulate": t_tri, "whitney": t_whitney,
                        "refine": t_refine, "refine_passes": n_refine}, keep,
                       bool(allow_boundary_steiner))


_REFINE_ROUNDS = 12      # Triangle refinement passes at most (each shrinks the offending triangles' areas 2-10x)
_REFINE_SAFETY = 0.9     # refine to this fraction of the tolerance (the grid samples miss a little between them)
_REFINE_DENSITY = 4      # barycentric divisions per edge of the samples (15 per triangle)
_REFINE_MAX_TRIANGLES = 400_000   # per face: a tolerance that needs more is not met (the report says so)


class _Reprojection(NamedTuple):
    """Step 5 at Triangle's vertices (the refinement's last pass), reused by step 5."""

    average: np.ndarray   # (k,) a(p)
    foot: np.ndarray      # (k, 3) F(p)
    normal: np.ndarray    # (k, 3) n(p) (zero where undefined)
    blocks: float         # mean pruning blocks per query


def _second_derivative_bound(surface, scale: np.ndarray) -> float:
    """M >= |D^2 F(w)[h, h]| / |h|^2 over the whole domain, in the working parameters w = (u, v) * scale.

    From the control points of F_uu, F_uv and F_vv (the B-spline hodographs: the derivative of a B-spline
    is a B-spline whose control points are the scaled differences, and a B-spline lies in the convex hull
    of its control points): with A = max|F_uu| / s_u^2, B = max|F_uv| / (s_u s_v), C = max|F_vv| / s_v^2,
    ``|D^2 F[h, h]| <= A h_1^2 + 2 B |h_1 h_2| + C h_2^2 <= lambda_max([[A, B], [B, C]]) |h|^2``.
    Infinite for a rational surface (no such control-net bound of the quotient here: its triangles are
    always sampled).

    Examples
    --------
    >>> from trimsurf.model import NurbsSurface
    >>> k = [0, 0, 0, 1, 1, 1]
    >>> cp = [[[x, y, z] for y in (0, 0.5, 1)] for x, z in ((0, 0), (0.5, 0), (1, 1))]   # (u, v, u^2)
    >>> float(_second_derivative_bound(NurbsSurface(2, 2, k, k, cp), np.array([1.0, 1.0])))
    2.0
    """
    if surface.is_rational:
        return float("inf")

    def hodograph(cp, degree, knots, axis):
        n = cp.shape[axis]
        if degree < 1 or n < 2:
            return None, degree - 1, knots[1:-1]
        den = knots[degree + 1:degree + n] - knots[1:n]
        shape = [1, 1, 1]
        shape[axis] = n - 1
        den = den.reshape(shape)
        with np.errstate(divide="ignore", invalid="ignore"):
            q = np.where(den > 0, degree * np.diff(cp, axis=axis) / np.where(den > 0, den, 1.0), 0.0)
        return q, degree - 1, knots[1:-1]

    def max_norm(q):
        return 0.0 if q is None or not q.size else float(np.sqrt((q * q).sum(axis=-1)).max())

    cp = surface.control_points
    pu, pv = surface.degree_u, surface.degree_v
    qu, pu1, ku1 = hodograph(cp, pu, surface.knots_u, 0)
    qv, pv1, kv1 = hodograph(cp, pv, surface.knots_v, 1)
    quu = hodograph(qu, pu1, ku1, 0)[0] if qu is not None else None
    qvv = hodograph(qv, pv1, kv1, 1)[0] if qv is not None else None
    quv = hodograph(qu, pv, surface.knots_v, 1)[0] if qu is not None else None
    su, sv = float(scale[0]), float(scale[1])
    a, b, c = max_norm(quu) / su ** 2, max_norm(quv) / (su * sv), max_norm(qvv) / sv ** 2
    return 0.5 * (a + c) + float(np.hypot(0.5 * (a - c), b))


def _refine_to_deviation(face: TrimmedFace, out: dict, flags: str, nr: int, r_xyz: np.ndarray, bdata, lipschitz,
                         scale: np.ndarray, tol: float, eps_max: float, *, second_derivatives: float = np.inf
                         ) -> tuple[dict, int, _Reprojection]:
    """Refine Triangle's external region until each triangle, reprojected, is within `tol` of the surface.

    Every vertex goes where step 5 puts it (F(p) + a(p) n(p); the dR points are the shared points
    themselves); each triangle is sampled (`triangle_deviation`) and the ones above the target get an
    area limit shrunk by the ratio (chord error ~ area), for Triangle's ``-r -a`` refinement with the same
    quality bound (so the angle guarantee of Sec. III-B holds for the refined region too). The target is
    ``max(0.9 tol, 1.5 max|eps|)``: a triangle cannot be closer to the surface than the heights a(p)
    at its corners, up to max|eps| on dR (Sec. III-A).

    A triangle that provably meets the target is not sampled: with X_i its corners, w_i their working
    parameters and M = `second_derivatives` (`_second_derivative_bound`), every point of the triangle is
    within ``max_i |X_i - F(w_i)| + M r^2 / 2`` of F at its interpolated parameter, r <= (longest edge in
    w) / sqrt(3) the radius of its smallest enclosing disc (linear interpolation error, Waldron 1998;
    Jung's theorem). The sampled figure of such a triangle is below that bound too, so skipping it
    changes nothing. Returns Triangle's output, the passes run, and a(p), F(p), n(p) at its vertices
    (the last pass's; step 5 reuses them).
    """
    import triangle

    from ._accuracy import triangle_deviation

    target = max(_REFINE_SAFETY * tol, 1.5 * eps_max)
    rflags = "r" + flags.replace("Q", "aQ")
    it = 0
    while True:
        tv = np.asarray(out["vertices"], dtype=np.float64)
        tt = np.asarray(out["triangles"], dtype=np.int64)
        wa = whitney_average(bdata, tv, lipschitz=lipschitz)
        uv = tv / scale
        foot, nrm = _foot_normal(face, uv)
        pts = foot + wa.average[:, None] * nrm
        pts[:len(r_xyz)] = r_xyz
        reproj = _Reprojection(wa.average, foot, nrm, wa.mean_blocks_visited)
        # the a-priori bound: corners' distance to F plus the interpolation error of F over the triangle
        off = np.linalg.norm(pts - foot, axis=1)
        p = tv[tt]
        l2 = np.maximum.reduce([((p[:, 1] - p[:, 0]) ** 2).sum(1), ((p[:, 2] - p[:, 1]) ** 2).sum(1),
                                ((p[:, 0] - p[:, 2]) ** 2).sum(1)])
        bound = off[tt].max(axis=1) + second_derivatives * l2 / 6.0
        check = np.flatnonzero(~(bound * (1.0 + 1e-9) <= target))
        if not len(check):
            return out, it, reproj
        tc = tt[check]
        # the dR segments themselves are left out: their deviation is the boundary's own (the error already
        # present along the edges, Sec. III), which no refinement of the region changes (a point Triangle puts
        # on dR lies on b(t) or, in Case 2, on the polyline itself); refining for it only makes slivers
        seg = np.asarray(out["segments"], dtype=np.int64)
        on_r = np.asarray(out["segment_markers"]).ravel() < 2 + nr
        n_v = len(tv)
        r_seg = np.sort(seg[on_r], axis=1)
        e = np.sort(np.stack([tc, np.roll(tc, -1, axis=1)], axis=2), axis=2)   # edge c: corners c, c + 1
        skip = np.isin(e[..., 0] * n_v + e[..., 1], r_seg[:, 0] * n_v + r_seg[:, 1])
        dev = np.zeros(len(tt))
        dev[check] = triangle_deviation(face, pts, uv, tc, density=_REFINE_DENSITY, exact_above=target,
                                        skip_edges=skip)
        bad = dev > target
        if not bad.any() or it == _REFINE_ROUNDS or len(tt) > _REFINE_MAX_TRIANGLES:
            return out, it, reproj
        p = p[bad]
        area = 0.5 * np.abs((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                            - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
        limit = np.full(len(tt), -1.0)
        limit[bad] = area * np.clip(0.8 * target / dev[bad], 0.1, 0.5)
        data = {"vertices": tv, "vertex_markers": out["vertex_markers"], "triangles": tt,
                "segments": out["segments"], "segment_markers": out["segment_markers"],
                "triangle_max_area": limit}
        out = triangle.triangulate(data, rflags)
        it += 1


def _pinch_vertices(rverts: np.ndarray, rgid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """dR points that are one point: the same shared id and (u, v) within 1e-9 of dR's extent.

    Returns the indices of the points Triangle gets (the first of each such group) and, for every dR
    point, the index of its Triangle vertex among them.

    Examples
    --------
    >>> w = np.array([[0., 0], [1, 0], [1, 1], [0.5, 0.5], [0.6, 0.5], [0.5, 0.6], [0.5, 0.5]])
    >>> uniq, vpos = _pinch_vertices(w, np.array([0, 1, 2, 3, 4, 5, 3]))
    >>> uniq.tolist(), vpos.tolist()
    ([0, 1, 2, 3, 4, 5], [0, 1, 2, 3, 4, 5, 3])
    """
    nr = len(rverts)
    first = np.arange(nr)
    vals, cnt = np.unique(rgid[rgid >= 0], return_counts=True)
    if np.any(cnt > 1):
        tol = 1e-9 * float(np.ptp(rverts, axis=0).max(initial=0.0))
        for v in vals[cnt > 1].tolist():
            idx = np.flatnonzero(rgid == v)
            for a in range(len(idx)):
                if first[idx[a]] != idx[a]:
                    continue
                near = np.linalg.norm(rverts[idx[a + 1:]] - rverts[idx[a]], axis=1) <= tol
                near &= first[idx[a + 1:]] == idx[a + 1:]
                first[idx[a + 1:][near]] = idx[a]
    uniq = np.flatnonzero(first == np.arange(nr))
    pos = np.empty(nr, dtype=np.int64)
    pos[uniq] = np.arange(len(uniq))
    return uniq, pos[first]


def _check_pslg(face: TrimmedFace, vertices: np.ndarray, segments: np.ndarray, n_loops: int) -> None:
    """Refuse input Triangle cannot take (it may crash on it): repeated points or crossing segments."""
    from ..geom import segment_intersections

    name = face.name or "face"
    order = np.lexsort((vertices[:, 1], vertices[:, 0]))
    same = np.all(vertices[order[1:]] == vertices[order[:-1]], axis=1)
    if same.any():
        i = int(order[1:][same][0])
        raise InputError(f"{name}: the boundary curves project to (u, v) with a repeated point "
                         f"({vertices[i, 0]:.6g}, {vertices[i, 1]:.6g})")
    a, b = vertices[segments[:, 0]], vertices[segments[:, 1]]
    mid = 0.5 * (a + b)
    rad = 0.5 * np.linalg.norm(b - a, axis=1)
    from scipy.spatial import cKDTree
    pairs = cKDTree(mid).query_pairs(2.0 * float(rad.max()) + 1e-300, output_type="ndarray")
    if not len(pairs):
        return
    i, j = pairs[:, 0], pairs[:, 1]
    near = np.linalg.norm(mid[i] - mid[j], axis=1) <= rad[i] + rad[j]
    i, j = i[near], j[near]
    share = ((segments[i, 0] == segments[j, 0]) | (segments[i, 0] == segments[j, 1])
             | (segments[i, 1] == segments[j, 0]) | (segments[i, 1] == segments[j, 1]))
    i, j = i[~share], j[~share]
    hit = segment_intersections(a[i], b[i], a[j], b[j])
    if hit.any():
        k = int(np.flatnonzero(hit)[0])
        raise InputError(f"{name}: the boundary curves projected to (u, v) cross themselves or the central mesh "
                         f"near ({mid[i[k], 0]:.6g}, {mid[i[k], 1]:.6g}) (segments {int(i[k])} and {int(j[k])})")


def _foot_normal(face: TrimmedFace, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """F(uv) and the unit normal Su x Sv / |Su x Sv| (zero where it is undefined)."""
    d = face.surface.derivatives(uv, 1)
    nrm = np.cross(d[1, 0], d[0, 1])
    ln = np.linalg.norm(nrm, axis=1)
    nrm = np.where(ln[:, None] > 0, nrm / np.where(ln > 0, ln, 1.0)[:, None], 0.0)
    return d[0, 0], nrm


def _split_central(central: np.ndarray, cb_edges: np.ndarray, edge_idx: np.ndarray, vid: np.ndarray,
                   uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split central triangles whose boundary edges received points (fan from the opposite corner).

    Returns the triangles and the (u, v) of the centroid vertices added (numbered from ``len(uv)``) for
    the rare triangle with points on several edges.
    """
    # boundary edge (a, b) -> its triangle: the directed edge appears in exactly one central triangle
    key_tri = {}
    on_b = np.zeros(int(central.max()) + 1, dtype=bool)
    on_b[cb_edges.ravel()] = True
    cand = np.flatnonzero(on_b[central].sum(axis=1) >= 2)
    for ti, (x, y, z) in zip(cand.tolist(), central[cand].tolist()):
        key_tri[(x, y)] = (ti, z)
        key_tri[(y, z)] = (ti, x)
        key_tri[(z, x)] = (ti, y)
    per_tri: dict[int, list] = {}
    for ei, v in zip(edge_idx.tolist(), vid.tolist()):
        a, b = cb_edges[ei]
        ti, _ = key_tri[(int(a), int(b))]
        per_tri.setdefault(ti, []).append((int(a), int(b), v))
    out = [central[np.setdiff1d(np.arange(len(central)), list(per_tri))]]
    extra_uv = []
    n_base = len(uv)
    for ti, items in per_tri.items():
        tri = central[ti].tolist()
        ring = []
        for c in range(3):
            a, b = tri[c], tri[(c + 1) % 3]
            pts = [v for (x, y, v) in items if x == a and y == b]
            pts.sort(key=lambda v: float(np.linalg.norm(uv[v] - uv[a])))
            ring.append(a)
            ring.extend(pts)
        split_edges = {(x, y) for (x, y, _) in items}
        if len(split_edges) == 1:
            (a, b), = split_edges
            c = [x for x in tri if x not in (a, b)][0]
            i = ring.index(a)
            chain = ring[i:] + ring[:i]           # a, p1, ..., pk, b, c
            chain = chain[:chain.index(b) + 1]
            out.append(np.array([[chain[j], chain[j + 1], c] for j in range(len(chain) - 1)], dtype=np.int64))
        else:  # points on several edges: a star around the centroid
            cidx = n_base + len(extra_uv)
            extra_uv.append(uv[tri].mean(axis=0))
            out.append(np.array([[ring[j], ring[(j + 1) % len(ring)], cidx] for j in range(len(ring))],
                                dtype=np.int64))
    return np.concatenate(out), np.array(extra_uv, dtype=np.float64).reshape(-1, 2)


def _split_long(uv, tris, external, min_angle_deg, *, protected, n_fixed):
    """Sec. III-D: split the longest edge of every triangle whose (u, v) minimum angle is below the bound.

    Both triangles on the edge are split at its midpoint (conforming); edges
    on dR are never split (they are shared with the neighbour). One pass.
    """
    p = uv[tris]
    ang = _angles_deg(p)
    thin = ang.min(axis=1) < min_angle_deg
    if not thin.any():
        return uv, tris, external, 0
    prot = np.zeros(len(uv), dtype=bool)
    prot[protected] = True
    e = np.stack([tris, np.roll(tris, -1, axis=1)], axis=2)  # (m, 3, 2): edge c from corner c to c+1
    elen = np.linalg.norm(uv[e[..., 0]] - uv[e[..., 1]], axis=2)
    longest = np.argmax(elen, axis=1)
    cand = e[np.flatnonzero(thin), longest[thin]]
    cand = cand[~(prot[cand[:, 0]] & prot[cand[:, 1]])]
    if not len(cand):
        return uv, tris, external, 0
    key = np.unique(np.sort(cand, axis=1), axis=0)
    n = len(uv)
    mid = {(int(a), int(b)): n + i for i, (a, b) in enumerate(key)}
    new_uv = 0.5 * (uv[key[:, 0]] + uv[key[:, 1]])
    tris, external = _split_by(tris, external, mid)
    return np.concatenate([uv, new_uv]), tris, external, int(len(key))

def reproject(face: TrimmedFace, result: PatchResult, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Step 5 at new points: Whitney average a(p) and F(p) + a(p) n(p) for `uv` (k, 2) of a joined patch."""
    wa = whitney_average(result.boundary, uv * result.scale, lipschitz=result.lipschitz)
    d = face.surface.derivatives(uv, 1)
    nrm = np.cross(d[1, 0], d[0, 1])
    ln = np.linalg.norm(nrm, axis=1)
    nrm = np.where(ln[:, None] > 0, nrm / np.where(ln > 0, ln, 1.0)[:, None], 0.0)
    return wa.average, d[0, 0] + wa.average[:, None] * nrm


def split_edges(face: TrimmedFace, result: PatchResult, edges: np.ndarray) -> PatchResult:
    """Split interior edges (k, 2) of a joined patch at their (u, v) midpoints, reprojecting the new vertices.

    Used where an interior edge joins two shared boundary points that another
    face also joins (the merged mesh would be non-manifold there).
    """
    if not len(edges):
        return result
    key = np.unique(np.sort(np.asarray(edges, dtype=np.int64), axis=1), axis=0)
    n = len(result.uv)
    mid = {(int(a), int(b)): n + i for i, (a, b) in enumerate(key)}
    new_uv = 0.5 * (result.uv[key[:, 0]] + result.uv[key[:, 1]])
    tris, ext = _split_by(result.triangles, result.external, mid)
    a, pts = reproject(face, result, new_uv)
    return result._replace(uv=np.concatenate([result.uv, new_uv]), points=np.concatenate([result.points, pts]),
                           heights=np.concatenate([result.heights, a]),
                           gid=np.r_[result.gid, np.full(len(key), -1, dtype=np.int64)], triangles=tris,
                           external=ext, central_source=np.r_[result.central_source, np.full(len(key), -1)])


def _split_by(tris: np.ndarray, external: np.ndarray, mid: dict) -> tuple[np.ndarray, np.ndarray]:
    """Split every triangle at the midpoints `mid[(a, b)]` (a < b) of its edges (conforming bisection)."""
    out_t, out_e = [], []
    hit_any = np.zeros(len(tris), dtype=bool)
    s = np.sort(tris, axis=1)
    pairs = [(s[:, 0], s[:, 1]), (s[:, 1], s[:, 2]), (s[:, 0], s[:, 2])]
    keys = set(mid)
    for a, b in pairs:
        hit_any |= np.array([(int(x), int(y)) in keys for x, y in zip(a, b)], dtype=bool)
    out_t.append(tris[~hit_any])
    out_e.append(external[~hit_any])
    for ti in np.flatnonzero(hit_any):
        pending = [list(tris[ti])]
        for c0 in range(3):
            x0, y0 = int(tris[ti][c0]), int(tris[ti][(c0 + 1) % 3])
            m = mid.get((min(x0, y0), max(x0, y0)))
            if m is None:
                continue
            nxt = []
            for t in pending:
                for c in range(3):
                    if {t[c], t[(c + 1) % 3]} == {x0, y0}:
                        x, y, z = t[c], t[(c + 1) % 3], t[(c + 2) % 3]
                        nxt.extend([[x, m, z], [m, y, z]])
                        break
                else:
                    nxt.append(t)
            pending = nxt
        out_t.append(np.array(pending, dtype=np.int64))
        out_e.append(np.full(len(pending), external[ti]))
    return np.concatenate(out_t), np.concatenate(out_e)


def split_boundary_edge(result: PatchResult, a: int, b: int, uv: np.ndarray) -> tuple[PatchResult, int]:
    """Insert a vertex at `uv` on the boundary edge (a, b) of a joined patch (fan split of its triangle).

    The caller sets the new vertex's position, height and id (it is a shared
    boundary point) and recomputes the reprojection. Returns the patch and
    the new vertex's index.
    """
    t = result.triangles
    hit = np.flatnonzero(((t == a) | (t == b)).sum(axis=1) == 2)
    if len(hit) != 1:
        raise InputError(f"join: boundary edge ({a}, {b}) lies in {len(hit)} triangles; cannot insert a point")
    ti = int(hit[0])
    tri = t[ti].tolist()
    v = len(result.uv)
    c = [x for x in tri if x not in (a, b)][0]
    i = tri.index(c)
    x, y = tri[(i + 1) % 3], tri[(i + 2) % 3]   # the edge (x, y) in the triangle's orientation, c opposite
    new = np.array([[x, v, c], [v, y, c]], dtype=np.int64)
    tris = np.concatenate([np.delete(t, ti, axis=0), new])
    ext = np.r_[np.delete(result.external, ti), [result.external[ti]] * 2]
    return result._replace(uv=np.concatenate([result.uv, np.asarray(uv, float)[None]]),
                           points=np.concatenate([result.points, np.zeros((1, 3))]),
                           heights=np.r_[result.heights, 0.0], gid=np.r_[result.gid, -1],
                           triangles=tris, external=ext, central_source=np.r_[result.central_source, -1]), v


def _turned_in_3d(face: TrimmedFace, uv: np.ndarray, points: np.ndarray, tris: np.ndarray,
                  gid: np.ndarray) -> np.ndarray:
    """Triangles (counter-clockwise in (u, v)) whose 3D normal points against Su x Sv at their (u, v) centroid.

    Triangles collapsed at a pole (two corners with one shared id: dropped when the faces are merged) and
    triangles of zero area are not counted.
    """
    p = points[tris]
    n3 = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    _, ns = _foot_normal(face, uv[tris].mean(axis=1))
    g = np.where(gid[tris] >= 0, gid[tris], -1 - tris)
    collapsed = (g[:, 0] == g[:, 1]) | (g[:, 1] == g[:, 2]) | (g[:, 0] == g[:, 2])
    return (np.einsum("ij,ij->i", n3, ns) < 0) & ~collapsed


def repair_pole_turns(face: TrimmedFace, result: PatchResult, *, max_passes: int = 20) -> tuple[PatchResult, int]:
    """Flip interior edges of the external region where a triangle near a pole turns over in 3D.

    Near a collapsed edge (a pole) the parametrization is singular -- the paper assumes a Jacobian of
    full rank (Sec. II) -- and a triangle that is well shaped in (u, v) can be a sliver in 3D whose
    orientation the reprojection's heights decide. Such a triangle's edge is flipped when the two
    triangles on it form a strictly convex quadrilateral in (u, v) (so the patch stays a triangulation of
    its region: M^-1 stays injective) and both new triangles face the surface normal's way. Edges on dR,
    on the central mesh's boundary, or whose flip would join two shared boundary points are not flipped.
    Returns the patch and the number of flips.
    """
    tris = result.triangles.copy()
    ext = result.external
    uv, pts, gid = result.uv, result.points, result.gid
    n_flips = 0
    for _ in range(max_passes):
        bad = np.flatnonzero(_turned_in_3d(face, uv, pts, tris, gid) & ext)
        if not len(bad):
            break
        # directed edge (a, b) -> triangle
        he = np.stack([tris, np.roll(tris, -1, axis=1)], axis=2).reshape(-1, 2)
        owner = {(int(a), int(b)): k // 3 for k, (a, b) in enumerate(he.tolist())}
        changed = False
        for t in bad.tolist():
            for c in range(3):
                a, b, x = (int(v) for v in (tris[t, c], tris[t, (c + 1) % 3], tris[t, (c + 2) % 3]))
                o = owner.get((b, a))
                if o is None or not ext[o]:
                    continue
                y = int(next(v for v in tris[o] if v != a and v != b))
                if gid[x] >= 0 and gid[y] >= 0:
                    continue
                new = np.array([[a, y, x], [y, b, x]], dtype=np.int64)
                w = uv[new]
                if not np.all(orient2d(w[:, 0], w[:, 1], w[:, 2]) > 0):
                    continue
                if _turned_in_3d(face, uv, pts, new, gid).any():
                    continue
                tris[t], tris[o] = new
                n_flips += 1
                changed = True
                break
            if changed:
                break
        if not changed:
            break
    if not n_flips:
        return result, 0
    return result._replace(triangles=tris, pole_flips=result.pole_flips + n_flips), n_flips
