"""Boundary-only reduction of thin triangles along the trims (paper Sec. 5.1, last step).

After the lift to 3D, a grid node that lies very close to a trim polygon makes
thin triangles between the trim and the grid. Such a node is collapsed into
the trim vertex at the short edge when the result keeps every triangle
counter-clockwise in (u, v), its 3D normal on the side of the surface normal, within the tolerance of the surface (evaluated
at centroids and edge midpoints) and within max_edge. Trim vertices never
move, so shared edges stay conforming. Each round picks collapses whose stars
do not overlap and tests them all at once (one surface evaluation per round).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .._numba_load import install as _install_lazy_bitcode
from ._collapse import common_neighbours, take_collapse, vertex_triangles

_install_lazy_bitcode()     # before this module's kernels load (trimsurf._numba_load)

__all__ = ["collapse_boundary_slivers"]

_BARY = np.array([[1 / 3, 1 / 3, 1 / 3], [0.5, 0.5, 0.0], [0.0, 0.5, 0.5], [0.5, 0.0, 0.5]])
# orientation test points: centroid and corners
_ORIENT_BARY = np.array([[1 / 3, 1 / 3, 1 / 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


def _turned_in_3d(surface, uv3: np.ndarray, x3: np.ndarray, sgn: float) -> np.ndarray:
    """Per triangle: its 3D normal points against the surface normal (sgn: the face's (u, v) sense).

    Tested at the (u, v) centroid and the corners of every triangle, vectorized; points
    where the surface normal is undefined (a pole) are skipped.
    """
    n = np.cross(x3[:, 1] - x3[:, 0], x3[:, 2] - x3[:, 0])
    pts = np.einsum("bk,mkd->mbd", _ORIENT_BARY, uv3).reshape(-1, 2)
    with np.errstate(all="ignore"):
        ns = np.asarray(surface.normals(pts), dtype=np.float64).reshape(len(uv3), -1, 3)
        dot = sgn * np.einsum("mbk,mk->mb", ns, n)
        valid = np.isfinite(dot) & (np.linalg.norm(ns, axis=2) > 0.5)
    return np.any(valid & ~(dot > 0), axis=1)


def _min_angles_deg(P: np.ndarray) -> np.ndarray:
    """Smallest angle (degrees) of triangles P (m, 3, 3), 0 for a degenerate one: the corners' cosines
    compiled (`_corner_cosines`, the numbers of `_min_angles_deg_numpy`), numpy's arc cosine."""
    ang = np.degrees(np.arccos(_corner_cosines(np.ascontiguousarray(P, dtype=np.float64))))
    return np.where(np.isnan(ang), 0.0, ang).min(axis=1)       # nan_to_num (arccos gives no inf)


@njit(cache=True, nogil=True, error_model="numpy")
def _corner_cosines(P):
    """Per triangle P[t] (3 corners in 3D), the cosine of each corner's angle by the law of cosines, clipped
    to [-1, 1] (NaN kept): the same operations in the same order as `_min_angles_deg_numpy` (a side's length
    sqrt((dx^2 + dy^2) + dz^2) as np.linalg.norm sums it)."""
    m = P.shape[0]
    out = np.empty((m, 3))
    L = np.empty(3)
    for t in range(m):
        for c in range(3):      # side c opposite corner c: P[c + 1] - P[c + 2]
            p, q = (c + 1) % 3, (c + 2) % 3
            dx, dy, dz = P[t, p, 0] - P[t, q, 0], P[t, p, 1] - P[t, q, 1], P[t, p, 2] - P[t, q, 2]
            L[c] = np.sqrt((dx * dx + dy * dy) + dz * dz)
        for c in range(3):
            out[t, c] = _clipped_cosine(L[c], L[(c + 1) % 3], L[(c + 2) % 3])
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _clipped_cosine(opposite, l1, l2):
    """The cosine of the angle between sides l1 and l2 opposite side `opposite` (law of cosines), clipped to
    [-1, 1], NaN kept: scalars only (no array reference to count per call in the kernels that use it)."""
    cs = (l1 * l1 + l2 * l2 - opposite * opposite) / (2 * l1 * l2)
    if cs < -1.0:
        return -1.0
    if cs > 1.0:
        return 1.0
    return cs


def _min_angles_deg_numpy(P: np.ndarray) -> np.ndarray:
    """`_min_angles_deg` in numpy (the reference of `_corner_cosines`, for the tests)."""
    # sides a = |P1 P2|, b = |P2 P0|, c = |P0 P1| in one pass; the cosine of the angle opposite each side
    # from the other two (b, c), (c, a), (a, b): the law of cosines per angle
    L = np.linalg.norm(P[:, [1, 2, 0]] - P[:, [2, 0, 1]], axis=2)
    L1, L2 = L[:, [1, 2, 0]], L[:, [2, 0, 1]]
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.clip((L1 * L1 + L2 * L2 - L * L) / (2 * L1 * L2), -1, 1)
    ang = np.degrees(np.arccos(cos))
    return np.where(np.isnan(ang), 0.0, ang).min(axis=1)       # nan_to_num (arccos gives no inf)


def _uv_area(uv: np.ndarray, T: np.ndarray) -> np.ndarray:
    p = uv[T]
    return (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1])


@njit(cache=True, nogil=True)
def _select_collapses_kernel(T, idx, nv, inner, trim):
    """The collapses inner[q] -> trim[q] taken in order q, as the loop over `collapse_sets` would: v's
    triangles (the alive ones `idx`, by vertex in index order) must hold u in one or two of them (they
    go), v and u and v's star must be unlocked, v and u must have as many common neighbours as
    triangles go (the link condition); a taken collapse locks v's star and u.

    Returns (q taken, moved triangles, their offsets per taken q, gone triangles, their offsets)."""
    m = idx.shape[0]
    start, vtri = vertex_triangles(T, idx, nv)
    n = inner.shape[0]
    locked = np.zeros(nv, dtype=np.bool_)
    in_nu = np.full(nv, -1, dtype=np.int64)
    counted = np.full(nv, -1, dtype=np.int64)
    qs = np.empty(n, dtype=np.int64)
    moved = np.empty(3 * m, dtype=np.int64)
    gone = np.empty(3 * m, dtype=np.int64)
    ms = np.zeros(n + 1, dtype=np.int64)
    gs = np.zeros(n + 1, dtype=np.int64)
    n_sel = n_moved = n_gone = 0
    for q in range(n):
        v, u = inner[q], trim[q]
        if locked[v] or locked[u]:
            continue
        free = True
        n_g = 0
        for r in range(start[v], start[v + 1]):
            t = vtri[r]
            for c in range(3):
                if locked[T[t, c]]:
                    free = False
            if T[t, 0] == u or T[t, 1] == u or T[t, 2] == u:
                n_g += 1
        if n_g == 0 or n_g > 2 or not free:
            continue
        if common_neighbours(T, start, vtri, v, u, q, in_nu, counted) != n_g:
            continue
        qs[n_sel] = q
        n_moved, n_gone = take_collapse(T, start, vtri, v, u, locked, moved, n_moved, gone, n_gone)
        locked[u] = True
        n_sel += 1
        ms[n_sel] = n_moved
        gs[n_sel] = n_gone
    return qs[:n_sel], moved[:n_moved], ms[:n_sel + 1], gone[:n_gone], gs[:n_sel + 1]


@njit(cache=True, nogil=True, error_model="numpy")
def _sliver_candidates_kernel(T, alive, is_trim, xyz, uv, angle, cos_lim, with_sign):
    """One round's candidates of `collapse_boundary_slivers`: the alive triangles (idx), those with trim
    and inner corners (mixed), and of those whose smallest angle is not known yet (NaN in `angle`) the
    ones it cannot settle (unsure). Where every corner's cosine (the sides and the law of cosines of
    `_min_angles_deg`, the same arithmetic) is at most cos_lim, the cosine of an angle a little above
    the threshold, the triangle is not thin whatever the last bits of the arc cosine: its `angle` is set
    to inf (only "thin or not" is read of a triangle that is not thin); the unsure ones get
    `_min_angles_deg` itself. with_sign: also the face's (u, v) sense (the sign of the sum of the
    triangles' orientation signs, as np.sum(np.sign(_uv_area)) >= 0; else 0.0)."""
    m = T.shape[0]
    sgn = 0.0
    if with_sign:
        tot = 0.0
        for t in range(m):
            a, b, c = T[t, 0], T[t, 1], T[t, 2]
            area = ((uv[b, 0] - uv[a, 0]) * (uv[c, 1] - uv[a, 1])
                    - (uv[c, 0] - uv[a, 0]) * (uv[b, 1] - uv[a, 1]))
            if area > 0:
                tot += 1.0
            elif area < 0:
                tot -= 1.0
            elif area != area:
                tot = np.nan
        sgn = 1.0 if tot >= 0 else -1.0
    n_alive = 0
    for t in range(m):
        if alive[t]:
            n_alive += 1
    idx = np.empty(n_alive, dtype=np.int64)
    mixed = np.empty(n_alive, dtype=np.int64)
    unsure = np.empty(n_alive, dtype=np.int64)
    k = n_mixed = n_unsure = 0
    L = np.empty(3)
    for t in range(m):
        if not alive[t]:
            continue
        idx[k] = t
        k += 1
        n_tr = 0
        for c in range(3):
            if is_trim[T[t, c]]:
                n_tr += 1
        if n_tr == 0 or n_tr == 3:
            continue
        mixed[n_mixed] = t
        n_mixed += 1
        if angle[t] == angle[t]:
            continue
        for c in range(3):      # side c opposite corner c: P[c + 1] - P[c + 2]
            p, q = T[t, (c + 1) % 3], T[t, (c + 2) % 3]
            dx, dy, dz = xyz[p, 0] - xyz[q, 0], xyz[p, 1] - xyz[q, 1], xyz[p, 2] - xyz[q, 2]
            L[c] = np.sqrt((dx * dx + dy * dy) + dz * dz)
        sure = True
        for c in range(3):
            l1, l2 = L[(c + 1) % 3], L[(c + 2) % 3]
            cs = (l1 * l1 + l2 * l2 - L[c] * L[c]) / (2 * l1 * l2)
            if not cs <= cos_lim:       # NaN too
                sure = False
        if sure:
            angle[t] = np.inf
        else:
            unsure[n_unsure] = t
            n_unsure += 1
    return sgn, idx, mixed[:n_mixed], unsure[:n_unsure]


@njit(cache=True, nogil=True, error_model="numpy")
def _sliver_pick_kernel(T, idx, mixed, angle, is_trim, xyz, min_angle, nv):
    """The thin triangles of a round (mixed ones with `angle` below min_angle), per thin triangle its
    shortest edge between an inner and a trim vertex (the first shortest, a NaN length first, as
    np.argmin), and the collapses `_select_collapses_kernel` takes of them.

    Returns (thin angles, inner, trim, and `_select_collapses_kernel`'s five arrays)."""
    n = 0
    for r in range(mixed.shape[0]):
        if angle[mixed[r]] < min_angle:
            n += 1
    thin_ang = np.empty(n)
    inner = np.empty(n, dtype=np.int64)
    trim = np.empty(n, dtype=np.int64)
    k = 0
    for r in range(mixed.shape[0]):
        t = mixed[r]
        if not angle[t] < min_angle:
            continue
        thin_ang[k] = angle[t]
        best = np.inf
        bc = -1
        for c in range(3):
            a, b = T[t, c], T[t, (c + 1) % 3]
            if is_trim[a] != is_trim[b]:
                dx, dy, dz = xyz[a, 0] - xyz[b, 0], xyz[a, 1] - xyz[b, 1], xyz[a, 2] - xyz[b, 2]
                e = np.sqrt((dx * dx + dy * dy) + dz * dz)
            else:
                e = np.inf
            if best != best:            # a NaN came first: np.argmin's answer
                continue
            if e != e or bc < 0 or e < best:
                best, bc = e, c
        a, b = T[t, bc], T[t, (bc + 1) % 3]
        if is_trim[a]:
            inner[k], trim[k] = b, a
        else:
            inner[k], trim[k] = a, b
        k += 1
    if n == 0:
        e = np.empty(0, dtype=np.int64)
        return thin_ang, inner, trim, e, e, np.zeros(1, dtype=np.int64), e, np.zeros(1, dtype=np.int64)
    qs, mv, ms, gn, gs = _select_collapses_kernel(T, idx, nv, inner, trim)
    return thin_ang, inner, trim, qs, mv, ms, gn, gs


def _apply_round(surface, uv, xyz, T, alive, changed, angle, sgn, inner, trim, thin_ang, picks,
                 tolerance, max_edge) -> bool:
    """Apply the collapses inner[q] -> trim[q] a round picked (`picks`: `_select_collapses_kernel`'s five
    arrays) that pass `_check`, in place on T, alive, changed, angle; False if none passes."""
    qs, mv, ms, gn, gs = picks
    cv, cu = inner[qs], trim[qs]
    ci = np.repeat(np.arange(len(qs)), np.diff(ms))
    ok = _check(surface, uv, xyz, T, cv, cu, thin_ang[qs], mv, ci, sgn, tolerance, max_edge)
    if not ok.any():
        return False
    # the good collapses at once (their stars do not overlap): v becomes u in the moved triangles
    good = ok[ci]
    if good.any():
        mvg = mv[good]
        tm = T[mvg]
        T[mvg] = np.where(tm == cv[ci[good], None], cu[ci[good], None], tm)
        changed[mvg] = True
        angle[mvg] = np.nan
    alive[gn[np.repeat(ok, np.diff(gs))]] = False
    return True


def collapse_boundary_slivers(surface, uv: np.ndarray, xyz: np.ndarray, triangles: np.ndarray, is_trim: np.ndarray,
                              *, tolerance: float, max_edge: float, min_angle_deg: float = 12.0,
                              rounds: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Collapse grid nodes into trim vertices where they make thin triangles.

    Parameters
    ----------
    surface : NurbsSurface
    uv, xyz : (n, 2), (n, 3) float64
    triangles : (m, 3) int64
        Oriented as the face wants them (counter-clockwise in (u, v) or all clockwise).
    is_trim : (n,) bool
        Vertices on the trim polygons (never moved).
    tolerance, max_edge : float
    min_angle_deg : float
        Triangles with a smaller angle are candidates.

    Returns
    -------
    triangles : (m', 3) int64
        The reduced triangles.
    kept : (m,) int64
        For every input triangle its index in the output, -1 if removed or changed.
    """
    T = triangles.copy()
    alive = np.ones(len(T), dtype=bool)
    changed = np.zeros(len(T), dtype=bool)
    angle = np.full(len(T), np.nan)
    out = _sliver_rounds(surface, uv, xyz, T, is_trim, alive, changed, angle, None, tolerance, max_edge,
                         min_angle_deg, rounds)
    return (T, np.arange(len(T), dtype=np.int64)) if out is None else out


def _cos_limit(min_angle_deg: float) -> float:
    """A triangle whose every cosine is at most this one is not thin (a margin far above the arc cosine's
    rounding): `_sliver_candidates_kernel`."""
    return math.cos(math.radians(min_angle_deg + 1e-6))


def _sliver_rounds(surface, uv, xyz, T, is_trim, alive, changed, angle, first, tolerance, max_edge, min_angle_deg,
                   rounds):
    """The rounds of `collapse_boundary_slivers` on T (in place; alive, changed, angle its state): (triangles,
    kept), or None where the first round found no triangle whose angle was unsure (none is thin: T stays
    as it is, kept the identity). `first`: the first round's (sgn, idx, mixed, unsure) when computed
    (`_face_sliver_start_kernel`), else None."""
    nv = len(uv)
    cos_lim = _cos_limit(min_angle_deg)
    sgn = None
    for r in range(rounds):
        # candidates: triangles with trim and inner vertices, thin (their angles only: per triangle the same;
        # computed again once it changed)
        if r == 0 and first is not None:
            sg, idx, mixed, unsure = first
        else:
            sg, idx, mixed, unsure = _sliver_candidates_kernel(T, alive, is_trim, xyz, uv, angle, cos_lim,
                                                               np.bool_(sgn is None))
        if sgn is None:
            sgn = sg
            if not len(unsure):
                # the first round: every candidate's angle was settled "not thin" (inf), so no triangle is
                # thin: what `_sliver_pick_kernel` and `_sliver_result_kernel` would return (T is a copy)
                return None
        if not len(idx):
            break
        if len(unsure):
            angle[unsure] = _min_angles_deg(xyz[T[unsure]])
        # per thin triangle the shortest edge from an inner vertex to a trim vertex, and the collapses of
        # this round whose stars do not overlap, in the thin triangles' order (the topology of
        # `collapse_sets`, compiled)
        thin_ang, inner, trim, qs, mv, ms, gn, gs = _sliver_pick_kernel(T, idx, mixed, angle, is_trim, xyz,
                                                                        float(min_angle_deg), nv)
        if not len(qs):
            break
        if not _apply_round(surface, uv, xyz, T, alive, changed, angle, sgn, inner, trim, thin_ang,
                            (qs, mv, ms, gn, gs), tolerance, max_edge):
            break
    return _sliver_result_kernel(T, alive, changed)


def collapse_face_slivers(surface, uv: np.ndarray, xyz: np.ndarray, triangles: np.ndarray, reverse: bool,
                          grid_node: np.ndarray, n_trim: int, *, tolerance: float, max_edge: float,
                          min_angle_deg: float = 12.0, rounds: int = 3) -> tuple:
    """`collapse_boundary_slivers` of a face's triangulation (`face.mesh_face_from_chunks`): the triangles
    `triangles[:, ::-1]` where `reverse`, the trim vertices those with `grid_node` < 0 or among the first
    `n_trim`; the copy, the fixed vertices and the first round's candidates made in one compiled pass
    (`_face_sliver_start_kernel`). Returns (triangles, kept), kept None where no triangle changed (the
    identity: the triangles are the given ones, reversed where asked)."""
    T, is_trim, angle, sg, idx, mixed, unsure = _face_sliver_start_kernel(
        triangles, np.bool_(reverse), grid_node, np.int64(n_trim), xyz, uv, _cos_limit(min_angle_deg))
    if not len(unsure):         # `_sliver_rounds`' first exit
        return T, None
    alive = np.ones(len(T), dtype=bool)
    changed = np.zeros(len(T), dtype=bool)
    out = _sliver_rounds(surface, uv, xyz, T, is_trim, alive, changed, angle, (sg, idx, mixed, unsure), tolerance,
                         max_edge, min_angle_deg, rounds)
    return (T, None) if out is None else out


@njit(cache=True, nogil=True, error_model="numpy")
def _face_sliver_start_kernel(tris, reverse, grid_node, n_trim, xyz, uv, cos_lim):
    """`collapse_face_slivers`' start: T (a copy of tris, each row reversed where `reverse`), is_trim
    (grid_node < 0 or among the first n_trim vertices), angle (NaN, then what the candidates settle) and
    the first round's `_sliver_candidates_kernel` (sgn, idx, mixed, unsure) on every triangle alive."""
    m = tris.shape[0]
    T = np.empty((m, 3), dtype=np.int64)
    for t in range(m):
        if reverse:
            T[t, 0], T[t, 1], T[t, 2] = tris[t, 2], tris[t, 1], tris[t, 0]
        else:
            T[t, 0], T[t, 1], T[t, 2] = tris[t, 0], tris[t, 1], tris[t, 2]
    n = grid_node.shape[0]
    is_trim = np.empty(n, dtype=np.bool_)
    for i in range(n):
        is_trim[i] = grid_node[i] < 0 or i < n_trim
    alive = np.ones(m, dtype=np.bool_)
    angle = np.full(m, np.nan)
    sgn, idx, mixed, unsure = _sliver_candidates_kernel(T, alive, is_trim, xyz, uv, angle, cos_lim, np.bool_(True))
    return T, is_trim, angle, sgn, idx, mixed, unsure


@njit(cache=True, nogil=True)
def _sliver_result_kernel(T, alive, changed):
    """(T[alive], kept): kept[t] the row of triangle t among the alive ones, -1 if gone or changed."""
    m = T.shape[0]
    kept = np.full(m, -1, dtype=np.int64)
    n = 0
    for t in range(m):
        if alive[t]:
            if not changed[t]:
                kept[t] = n
            n += 1
    out = np.empty((n, 3), dtype=np.int64)
    n = 0
    for t in range(m):
        if alive[t]:
            out[n, 0], out[n, 1], out[n, 2] = T[t, 0], T[t, 1], T[t, 2]
            n += 1
    return out, kept


def _collapse_boundary_slivers_numpy(surface, uv: np.ndarray, xyz: np.ndarray, triangles: np.ndarray,
                                     is_trim: np.ndarray, *, tolerance: float, max_edge: float,
                                     min_angle_deg: float = 12.0, rounds: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """`collapse_boundary_slivers` in numpy (the reference of the compiled rounds, for the tests)."""
    T = triangles.copy()
    alive = np.ones(len(T), dtype=bool)
    changed = np.zeros(len(T), dtype=bool)
    sign0 = np.sign(_uv_area(uv, T))
    sgn = 1.0 if np.sum(sign0) >= 0 else -1.0
    nv = len(uv)
    angle = np.full(len(T), np.nan)
    for _ in range(rounds):
        idx = np.flatnonzero(alive)
        if not len(idx):
            break
        # candidates: triangles with trim and inner vertices, thin (their angles only: per triangle the same)
        tt = is_trim[T[idx]]
        mixed = idx[tt.any(axis=1) & ~tt.all(axis=1)]
        need = mixed[np.isnan(angle[mixed])]         # a triangle's angle: computed again once it changed
        angle[need] = _min_angles_deg_numpy(xyz[T[need]])
        ang = angle[mixed]
        thin_m = ang < min_angle_deg
        thin, thin_ang = mixed[thin_m], ang[thin_m]
        if not len(thin):
            break
        # per thin triangle the shortest edge from an inner vertex to a trim vertex
        Tt = T[thin]
        ea, eb = Tt, np.roll(Tt, -1, axis=1)
        mixed = is_trim[ea] != is_trim[eb]
        elen = np.where(mixed, np.linalg.norm(xyz[ea] - xyz[eb], axis=2), np.inf)
        c = elen.argmin(axis=1)
        r = np.arange(len(thin))
        a_, b_ = ea[r, c], eb[r, c]
        inner = np.where(is_trim[a_], b_, a_)
        trim = np.where(is_trim[a_], a_, b_)
        # the collapses of this round whose stars do not overlap, in the thin triangles' order (the
        # topology of `collapse_sets`, compiled)
        qs, mv, ms, gn, gs = _select_collapses_kernel(T, idx, nv, inner, trim)
        if not len(qs):
            break
        if not _apply_round(surface, uv, xyz, T, alive, changed, angle, sgn, inner, trim, thin_ang,
                            (qs, mv, ms, gn, gs), tolerance, max_edge):
            break
    kept = np.full(len(T), -1, dtype=np.int64)
    kept[alive] = np.arange(int(alive.sum()))
    kept[changed] = -1
    return T[alive], kept


def _check(surface, uv, xyz, T, cv, cu, a0, mi, ci, sgn, tolerance, max_edge) -> np.ndarray:
    """Batched tests of the selected collapses (cv[s] into cu[s]; mi their moved triangles, ci the
    collapse of each, a0 the smallest angle of the thin triangle each removes): (s,) bool, True where
    every moved triangle stays counter-clockwise (in the face's sense) in (u, v), within max_edge and the
    tolerance, not turned against the surface normal in 3D, and no thinner than the thin triangle the
    collapse removes. The moved triangles' corners, their (u, v) sense, sides and cosines in one compiled
    pass (`_check_shape_kernel`), the arc cosines and the surface tests in numpy; `_check_numpy` is the
    reference."""
    ns = len(cv)
    if not len(mi):
        return np.ones(ns, dtype=bool)
    newt, fail, cos = _check_shape_kernel(uv, xyz, T, mi, cv, cu, ci, float(sgn), float(max_edge))
    # the collapse must not make a thinner triangle than the one it removes (`_min_angles_deg`)
    ang = np.degrees(np.arccos(cos))
    fail |= np.where(np.isnan(ang), 0.0, ang).min(axis=1) < a0[ci]
    bad = np.zeros(ns, dtype=bool)
    bad[ci[fail]] = True
    # the surface tests only for the triangles of collapses no test above refused (per triangle the same)
    rest = np.flatnonzero(~bad[ci])
    if len(rest):
        nt = newt[rest]
        _surface_tests(surface, uv, xyz[nt], nt, ci[rest], bad, sgn, tolerance)
    return ~bad


def _surface_tests(surface, uv, pr, nt, cr, bad, sgn, tolerance) -> None:
    """bad[cr[k]] = True where moved triangle nt[k] (points pr[k]) leaves the tolerance or turns against the
    surface normal in 3D."""
    tuv = np.einsum("bk,mkd->mbd", _BARY, uv[nt])
    txyz = np.einsum("bk,mkd->mbd", _BARY, pr)
    dev = np.linalg.norm(surface.evaluate(tuv.reshape(-1, 2)).reshape(txyz.shape) - txyz, axis=2)
    f2 = ~(dev.max(axis=1) <= tolerance)
    # no moved triangle may turn against the surface normal in 3D (a flip the (u, v) test misses)
    f2 |= _turned_in_3d(surface, uv[nt], pr, sgn)
    bad[cr[f2]] = True


@njit(cache=True, nogil=True, error_model="numpy")
def _check_shape_kernel(uv, xyz, T, mi, cv, cu, ci, sgn, max_edge):
    """`_check_numpy`'s first tests per moved triangle k (mi[k], of collapse ci[k]: cv into cu): its corners
    after the collapse (newt), fail where its (u, v) area (`_uv_area`) times sgn is not positive or its
    longest side (sqrt((dx^2 + dy^2) + dz^2), as np.linalg.norm sums it; none where a side is NaN, as
    the max of numpy) exceeds max_edge, and its corners' cosines (`_corner_cosines`): the same operations
    in the same order."""
    m = mi.shape[0]
    newt = np.empty((m, 3), dtype=np.int64)
    fail = np.empty(m, dtype=np.bool_)
    cos = np.empty((m, 3))
    L = np.empty(3)
    for k in range(m):
        t = mi[k]
        v, u = cv[ci[k]], cu[ci[k]]
        for c in range(3):
            x = T[t, c]
            newt[k, c] = u if x == v else x
        a, b, c3 = newt[k, 0], newt[k, 1], newt[k, 2]
        area = ((uv[b, 0] - uv[a, 0]) * (uv[c3, 1] - uv[a, 1])
                - (uv[c3, 0] - uv[a, 0]) * (uv[b, 1] - uv[a, 1]))
        f = area * sgn <= 0
        longest = -np.inf
        has_nan = False
        for c in range(3):      # side c: corner c minus the one before it
            p, q = newt[k, c], newt[k, (c + 2) % 3]
            dx, dy, dz = xyz[p, 0] - xyz[q, 0], xyz[p, 1] - xyz[q, 1], xyz[p, 2] - xyz[q, 2]
            e = np.sqrt((dx * dx + dy * dy) + dz * dz)
            if e != e:
                has_nan = True
            elif e > longest:
                longest = e
        if not has_nan and longest > max_edge:
            f = True
        fail[k] = f
        for c in range(3):      # `_corner_cosines`: side c opposite corner c (P[c + 1] - P[c + 2])
            p, q = newt[k, (c + 1) % 3], newt[k, (c + 2) % 3]
            dx, dy, dz = xyz[p, 0] - xyz[q, 0], xyz[p, 1] - xyz[q, 1], xyz[p, 2] - xyz[q, 2]
            L[c] = np.sqrt((dx * dx + dy * dy) + dz * dz)
        for c in range(3):
            cos[k, c] = _clipped_cosine(L[c], L[(c + 1) % 3], L[(c + 2) % 3])
    return newt, fail, cos


def _check_numpy(surface, uv, xyz, T, cv, cu, a0, mi, ci, sgn, tolerance, max_edge) -> np.ndarray:
    """Batched tests of the selected collapses (cv[s] into cu[s]; mi their moved triangles, ci the
    collapse of each, a0 the smallest angle of the thin triangle each removes): (s,) bool, True where
    every moved triangle stays counter-clockwise (in the face's sense) in (u, v), within max_edge and the
    tolerance, not turned against the surface normal in 3D, and no thinner than the thin triangle the
    collapse removes. `_check` in numpy (its reference, for the tests)."""
    ns = len(cv)
    if not len(mi):
        return np.ones(ns, dtype=bool)
    oldt = T[mi]
    newt = np.where(oldt == cv[ci, None], cu[ci, None], oldt)
    fail = _uv_area(uv, newt) * sgn <= 0
    pn = xyz[newt]
    fail |= np.linalg.norm(pn - np.roll(pn, 1, axis=1), axis=2).max(axis=1) > max_edge
    # the collapse must not make a thinner triangle than the one it removes
    fail |= _min_angles_deg(pn) < a0[ci]
    bad = np.zeros(ns, dtype=bool)
    bad[ci[fail]] = True
    # the surface tests only for the triangles of collapses no test above refused (per triangle the same)
    rest = np.flatnonzero(~bad[ci])
    if len(rest):
        nt, pr = newt[rest], pn[rest]
        tuv = np.einsum("bk,mkd->mbd", _BARY, uv[nt])
        txyz = np.einsum("bk,mkd->mbd", _BARY, pr)
        dev = np.linalg.norm(surface.evaluate(tuv.reshape(-1, 2)).reshape(txyz.shape) - txyz, axis=2)
        f2 = ~(dev.max(axis=1) <= tolerance)
        # no moved triangle may turn against the surface normal in 3D (a flip the (u, v) test misses)
        f2 |= _turned_in_3d(surface, uv[nt], pr, sgn)
        bad[ci[rest[f2]]] = True
    return ~bad
