"""Seam reduction (paper Sec. 4.6, 5.4): edge collapse along former face boundaries after stitching.

Stitching splits nearly every boundary edge, so the seams carry many short
edges. A seam vertex v (on exactly two faces, between two seam neighbours)
is collapsed into the seam neighbour u at the shorter seam edge when

* v stays within a quarter of the tolerance of the new seam chord (u, w) (w: v's other seam neighbour),
* no triangle around v flips (normal turns by more than 60 degrees) or degenerates, turns over in
  its face's (u, v) domain, or (given the faces) points against its face's oriented surface normal in 3D,
* the link condition holds (u and v share exactly the two opposite vertices), so the mesh stays 2-manifold.

Shortest edges first; a vertex next to a collapse waits for the next round.
Each round picks collapses whose stars do not overlap and tests them all at
once (one surface evaluation per face), so the checks are batched numpy.

A last pass removes triangles still flipped against the surface normal (e.g.
the tip of a face narrower than the tolerance, between two nearly coincident
trims, where the trims' own chords turn the corner's triangle over) by
collapsing one of their seam edges under the same checks, with the chord
bound relaxed to the tolerance.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..geom._nurbs_kernels import _point_scratch, _surface_point01, surface_derivatives_kernel
from ..geom.nurbs import _clip, _homogeneous, read_only, unit_normals
from ..model import NurbsSurface, TriMesh
from ..model.mesh import compact_indices
from ._collapse import common_neighbours, take_collapse, vertex_triangles

__all__ = ["reduce_seams"]

_COS_FLIP = 0.5   # a triangle whose normal turns by more than 60 degrees counts as flipped


_BARY = np.array([[1 / 3, 1 / 3, 1 / 3], [0.5, 0.5, 0.0], [0.0, 0.5, 0.5], [0.5, 0.0, 0.5]])


def _uv_area(q):
    """Signed doubled area of (m, 3, 2) triangles in the (u, v) domain."""
    return ((q[:, 1, 0] - q[:, 0, 0]) * (q[:, 2, 1] - q[:, 0, 1])
            - (q[:, 2, 0] - q[:, 0, 0]) * (q[:, 1, 1] - q[:, 0, 1]))


# sample points of a triangle for the orientation test: centroid and the three corners
_ORIENT_BARY = np.array([[1 / 3, 1 / 3, 1 / 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


def _normals_rows(V, rows) -> np.ndarray:
    """`_normals(V, np.array(rows))` of a few triangles given as vertex triples, in scalars (the same
    operations per coordinate: IEEE subtraction and products either way), without numpy's per-call cost."""
    ids = [i for r in rows for i in r]
    p = V[ids].tolist()
    out = []
    for k in range(0, len(p), 3):
        (x0, y0, z0), (x1, y1, z1), (x2, y2, z2) = p[k], p[k + 1], p[k + 2]
        a0, a1, a2 = x1 - x0, y1 - y0, z1 - z0
        b0, b1, b2 = x2 - x0, y2 - y0, z2 - z0
        out.append((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0))
    return np.array(out, dtype=np.float64).reshape(len(out), 3)


def _normals(V, T):
    """np.cross(p1 - p0, p2 - p0) of the triangles (the same operations, without np.cross's overhead)."""
    p = V[T]
    a, b = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    out = np.empty(a.shape)
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


@njit(cache=True, nogil=True)
def _seam_select_kernel(T, idx, fid, nv, cv, cu, interior):
    """The collapses cv[q] -> cu[q] a round takes, in order q, as the loop over `_collapse.collapse_sets`
    did (`_State.round`): v and u and v's star (the vertices of v's alive triangles `idx`, by vertex in
    index order) unlocked, else passed over; then v's triangles on two faces (interior: one face, and
    a closed fan: as many star vertices as triangles plus one), exactly two of them holding u (they go)
    and v, u with exactly two common neighbours (the link condition), else skipped for good. A taken
    collapse locks v's star.

    Returns (taken q, moved triangles, their offsets per taken q, gone (s, 2), skipped q)."""
    m = idx.shape[0]
    start, vtri = vertex_triangles(T, idx, nv)
    n = cv.shape[0]
    locked = np.zeros(nv, dtype=np.bool_)
    in_star = np.full(nv, -1, dtype=np.int64)
    in_nu = np.full(nv, -1, dtype=np.int64)
    counted = np.full(nv, -1, dtype=np.int64)
    qs = np.empty(n, dtype=np.int64)
    skipped = np.empty(n, dtype=np.int64)
    moved = np.empty(3 * m, dtype=np.int64)
    gone = np.empty(2 * n, dtype=np.int64)
    ms = np.zeros(n + 1, dtype=np.int64)
    n_sel = n_moved = n_skip = 0
    for q in range(n):
        v, u = cv[q], cu[q]
        if locked[v] or locked[u]:
            continue
        free = True
        n_star = 0
        n_g = 0
        nf = 0
        f0 = f1 = -1
        for r in range(start[v], start[v + 1]):
            t = vtri[r]
            for c in range(3):
                x = T[t, c]
                if locked[x]:
                    free = False
                if in_star[x] != q:
                    in_star[x] = q
                    n_star += 1
            if T[t, 0] == u or T[t, 1] == u or T[t, 2] == u:
                n_g += 1
            f = fid[t]
            if nf == 0:
                f0 = f
                nf = 1
            elif nf == 1:
                if f != f0:
                    f1 = f
                    nf = 2
            elif nf == 2:
                if f != f0 and f != f1:
                    nf = 3
        if not free:
            continue
        n_tv = start[v + 1] - start[v]
        good = n_g == 2
        if interior:
            good = good and nf == 1 and n_star == n_tv + 1
        else:
            good = good and nf == 2
        if good:
            good = common_neighbours(T, start, vtri, v, u, q, in_nu, counted) == 2
        if not good:
            skipped[n_skip] = q
            n_skip += 1
            continue
        qs[n_sel] = q
        # exactly two of v's triangles hold u: the taken collapse's pair is gone[2 n_sel:2 n_sel + 2]
        n_moved, n_gone = take_collapse(T, start, vtri, v, u, locked, moved, n_moved, gone, 2 * n_sel)
        n_sel += 1
        ms[n_sel] = n_moved
    return qs[:n_sel], moved[:n_moved], ms[:n_sel + 1], gone[:2 * n_sel].reshape((n_sel, 2)), skipped[:n_skip]


def _seam_graph(mesh: TriMesh):
    edges = mesh.edges()
    inv = mesh.half_edge_edges()
    cnt = mesh.edge_triangle_counts()
    tri_of = np.repeat(np.arange(mesh.n_triangles), 3)
    f = mesh.face_id[tri_of]
    fmin = np.full(len(edges), np.iinfo(np.int64).max)
    fmax = np.full(len(edges), -1)
    np.minimum.at(fmin, inv, f)
    np.maximum.at(fmax, inv, f)
    seam = (cnt == 2) & (fmin != fmax)
    return edges[seam]


def _seam_edges(T: np.ndarray, fid: np.ndarray, nv: int, idx=None) -> np.ndarray:
    """`_seam_graph(TriMesh(V, T[idx], face_id=fid[idx]))` for a mesh of `nv` vertices (idx None: all rows),
    without building the mesh (no copy and check of V): the undirected edges (sorted, i < j, in
    increasing (i, j) order) on exactly two triangles of different faces."""
    if idx is None:
        idx = np.arange(len(T))
    if not len(idx):
        return np.zeros((0, 2), dtype=np.int64)
    return _seam_edges_kernel(np.ascontiguousarray(T, dtype=np.int64), np.asarray(idx, dtype=np.int64),
                              np.asarray(fid, dtype=np.int64), np.int64(max(int(nv), 1)))


@njit(cache=True, nogil=True)
def _seam_edges_kernel(T, idx, fid, nv):
    """The edges of `_seam_edges`: the half-edges of the rows idx bucketed by their lower vertex (a CSR),
    each bucket's upper vertices in increasing order with their count and lowest and highest face."""
    m = idx.shape[0]
    start = np.zeros(nv + 1, dtype=np.int64)
    for r in range(m):
        t = idx[r]
        for c in range(3):
            a, b = T[t, c], T[t, (c + 1) % 3]
            start[min(a, b) + 1] += 1
    for v in range(nv):
        start[v + 1] += start[v]
    fill = start[:-1].copy()
    hi = np.empty(3 * m, dtype=np.int64)
    fc = np.empty(3 * m, dtype=np.int64)
    for r in range(m):
        t = idx[r]
        for c in range(3):
            a, b = T[t, c], T[t, (c + 1) % 3]
            lo = min(a, b)
            hi[fill[lo]] = max(a, b)
            fc[fill[lo]] = fid[t]
            fill[lo] += 1
    out = np.empty((3 * m, 2), dtype=np.int64)
    k = 0
    for v in range(nv):
        a, b = start[v], start[v + 1]
        for i in range(a + 1, b):           # insertion sort of the (small) bucket by upper vertex
            h, f = hi[i], fc[i]
            j = i - 1
            while j >= a and hi[j] > h:
                hi[j + 1] = hi[j]
                fc[j + 1] = fc[j]
                j -= 1
            hi[j + 1] = h
            fc[j + 1] = f
        i = a
        while i < b:
            j = i
            f0 = f1 = fc[i]
            while j < b and hi[j] == hi[i]:
                f0 = min(f0, fc[j])
                f1 = max(f1, fc[j])
                j += 1
            if j - i == 2 and f0 != f1:
                out[k, 0] = v
                out[k, 1] = hi[i]
                k += 1
            i = j
    return out[:k].copy()


def _by_face(face_of: np.ndarray):
    """(face, its rows in increasing order) per face id in increasing order (one sort, not a scan per face)."""
    face_of = np.asarray(face_of)
    if not len(face_of):
        return []
    order = np.argsort(face_of, kind="stable")
    f = face_of[order]
    cut = np.r_[0, np.flatnonzero(f[1:] != f[:-1]) + 1, len(f)]
    return [(f[a], order[a:b]) for a, b in zip(cut[:-1].tolist(), cut[1:].tolist())]


_ARGS: dict = {}     # id(surface) -> (surface, the kernel's arguments)


def _kernel_args(surface):
    """The compiled surface kernel's arguments of `surface` (as `geom.surface_derivatives` prepares them),
    built once per surface (the entry keeps the surface alive, so an id is never reused while cached)."""
    hit = _ARGS.get(id(surface))
    if hit is not None and hit[0] is surface:
        return hit[1]
    pu, pv = int(surface.degree_u), int(surface.degree_v)
    ku = read_only(np.asarray(surface.knots_u, dtype=np.float64))
    kv = read_only(np.asarray(surface.knots_v, dtype=np.float64))
    args = (pu, pv, ku, kv, _homogeneous(surface.control_points, surface.weights), surface.weights is not None,
            ku[pu], ku[-pu - 1], kv[pv], kv[-pv - 1])
    if len(_ARGS) > 4096:
        _ARGS.clear()
    _ARGS[id(surface)] = (surface, args)
    return args


def _derivatives(surface, uv: np.ndarray, nd: int) -> np.ndarray:
    """`surface.derivatives(uv, nd)` (the same kernel, the same values) without the per-call checks:
    `uv` is a finite float64 (n, 2) array (the caller checks once for all its faces)."""
    pu, pv, ku, kv, pw, rational, u0, u1, v0, v1 = _kernel_args(surface)
    out = np.zeros((nd + 1, nd + 1, uv.shape[0], 3))
    surface_derivatives_kernel(pu, pv, ku, kv, pw, rational, _clip(uv[:, 0], u0, u1), _clip(uv[:, 1], v0, v1),
                               nd, out)
    return out


@njit(cache=True, nogil=True)
def _multi_derivatives_kernel(deg, kofs, knots, pofs, pshape, pw_flat, rational, dom, surf, u, v, order, n0, out):
    """out[0, i] = S, out[1, i] = S_u, out[2, i] = S_v of surface surf[i] (packed by `_packed`) at
    (u[i], v[i]) clipped to its domain as np.clip does: `surface_derivatives_kernel` with nd = 1 per point
    (the same `_surface_point01`), the points taken in `order` (grouped by surface). Points i < n0: S alone
    (nd = 0; `_surface_point01` computes S with the same operations either way), out[1:, i] not written."""
    cur = -1
    zero = np.int64(0)
    one = np.int64(1)
    pu = pv = one
    ku = knots[0:0]
    kv = knots[0:0]
    pw = pw_flat[0:0].reshape((0, 0, 3))
    rat = False
    u0 = u1 = v0 = v1 = 0.0
    ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v, r_v, bu, bv, tmp, skl = _point_scratch(one, one, pshape[0, 2])
    res = np.empty((3, 3))
    for j in range(order.shape[0]):
        i = order[j]
        s = surf[i]
        if s != cur:
            cur = s
            pu, pv = deg[s, 0], deg[s, 1]
            ku = knots[kofs[s, 0]:kofs[s, 1]]
            kv = knots[kofs[s, 1]:kofs[s, 2]]
            pw = pw_flat[pofs[s]:pofs[s + 1]].reshape((pshape[s, 0], pshape[s, 1], pshape[s, 2]))
            rat = rational[s]
            u0, u1, v0, v1 = dom[s, 0], dom[s, 1], dom[s, 2], dom[s, 3]
            ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v, r_v, bu, bv, tmp, skl = _point_scratch(pu, pv, pshape[s, 2])
        x = u[i]
        x = x if x > u0 else u0             # np.clip: min(max(x, lo), hi), as (a > b ? a : b), (a < b ? a : b)
        x = x if x < u1 else u1
        y = v[i]
        y = y if y > v0 else v0
        y = y if y < v1 else v1
        if i < n0:
            _surface_point01(pu, pv, ku, kv, pw, rat, x, y, zero, ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v, r_v, bu,
                             bv, tmp, skl, res)
            for d in range(3):
                out[0, i, d] = res[0, d]
            continue
        _surface_point01(pu, pv, ku, kv, pw, rat, x, y, one, ndu_u, ndu_v, a_u, a_v, l_u, r_u, l_v, r_v, bu, bv,
                         tmp, skl, res)
        for d in range(3):
            out[0, i, d] = res[0, d]
            out[1, i, d] = res[1, d]
            out[2, i, d] = res[2, d]


@njit(cache=True, nogil=True)
def _grouped_order(key, n, n_keys):
    """The indices 0..n-1 grouped by key[i] in [0, n_keys), in increasing order within a group (a counting
    sort: numpy's stable argsort of key[:n])."""
    start = np.zeros(n_keys + 1, dtype=np.int64)
    for i in range(n):
        start[key[i] + 1] += 1
    for k in range(n_keys):
        start[k + 1] += start[k]
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        order[start[key[i]]] = i
        start[key[i]] += 1
    return order


@njit(cache=True, nogil=True)
def _dev_against_kernel(face_of, uv3, x3, tn, corners, use_corners, dbary, obary, deg, kofs, knots, pofs, pshape,
                        pw_flat, rational, dom, same_sense, axis, flat):
    """`_dev_and_against` (and, with no rows in `dbary`, `_against_normal`) in compiled passes, the same
    operations per number.

    Deviation: per triangle max_b |S(uv_b) - x_b| over the points of `dbary` (uv_b, x_b summed in column
    order from 0.0 as einsum does; the norm as sqrt((x^2 + y^2) + z^2); NaN propagates as np.max's).
    Flip test at the points of `obary`: a triangle on a flat face within 87 degrees of its cone axis
    (`_surely_along`: the dot products summed as numpy's einsum does, (x0 y0 + x2 y2) + x1 y1) is not
    against; the others' normals are S_u x S_v through `unit_normals` (np.cross's operations, NaN where
    the length is not positive), negated on a reversed face. With `use_corners`, sample b >= 1 being
    the corner corners[r, b - 1] alone (obary row b a unit row), a vertex's normal on one face at
    bit-equal parameters is evaluated once (a pure function of face and parameters: the same numbers).
    Every surface point in one `_multi_derivatives_kernel` call, grouped by face (as `_derivatives01`
    computes them; evaluating inside the bookkeeping loop ran 2x slower per point), the deviation's
    points with S alone (the same S: nd = 0 skips only the derivatives' operations).

    Returns (dev (r,), against (r,), ok): ok False when a sample point is not finite (the caller's
    numpy path then runs, as `_fast` sends it to the faces' own methods): every deviation point, and
    with `dbary` rows every flip point, else the flip points of the triangles not surely along."""
    m = face_of.shape[0]
    nd, nb = dbary.shape[0], obary.shape[0]
    dev = np.empty(m)
    out = np.zeros(m, dtype=np.bool_)
    ref = np.empty((m, nd, 3))
    ef = np.empty(m * (nd + nb), dtype=np.int64)
    eu = np.empty(m * (nd + nb))
    ev = np.empty(m * (nd + nb))
    slot = np.full((m, nb), -1, dtype=np.int64)
    n = 0
    for r in range(m):          # the deviation's points of every triangle
        f = face_of[r]
        for b in range(nd):
            for k in range(3):
                y = 0.0
                for j in range(3):
                    y += dbary[b, j] * x3[r, j, k]
                ref[r, b, k] = y
            y0 = 0.0
            y1 = 0.0
            for j in range(3):
                y0 += dbary[b, j] * uv3[r, j, 0]
            for j in range(3):
                y1 += dbary[b, j] * uv3[r, j, 1]
            if not (np.isfinite(y0) and np.isfinite(y1)):
                return dev, out, False
            ef[n] = f
            eu[n] = y0
            ev[n] = y1
            n += 1
    n_dev = m * nd              # (= n: their S alone, the deviation reads no derivative; not a literal)
    nvert = 0
    if use_corners:
        for r in range(m):
            for c in range(3):
                nvert = max(nvert, corners[r, c] + 1)
    cache_f = np.full(nvert, -1, dtype=np.int64)
    cache_b = np.zeros((nvert, 2), dtype=np.int64)
    cache_s = np.zeros(nvert, dtype=np.int64)
    pts = np.empty((nb, 2))
    bits = pts.view(np.int64)
    # the flip test's points of the triangles not surely along, face by face (a counting sort: a
    # vertex's corners on one face meet its cache entry)
    nf = flat.shape[0]
    order = _grouped_order(face_of, m, nf)
    for r in order:
        f = face_of[r]
        sure = False
        if flat[f]:
            t0, t1, t2 = tn[r, 0], tn[r, 1], tn[r, 2]
            lt = np.sqrt((t0 * t0 + t1 * t1) + t2 * t2)
            sure = lt > 0 and (t0 * axis[f, 0] + t2 * axis[f, 2]) + t1 * axis[f, 1] > 0.05 * lt
        if sure and nd == 0:
            continue
        for b in range(nb):
            for k in range(2):
                y = 0.0
                for j in range(3):
                    y += obary[b, j] * uv3[r, j, k]
                if not np.isfinite(y):
                    return dev, out, False
                pts[b, k] = y
        if sure:
            continue
        for b in range(nb):
            if use_corners and b >= 1:
                w = corners[r, b - 1]
                if cache_f[w] == f and cache_b[w, 0] == bits[b, 0] and cache_b[w, 1] == bits[b, 1]:
                    slot[r, b] = cache_s[w]
                    continue
                cache_f[w] = f
                cache_b[w, 0] = bits[b, 0]
                cache_b[w, 1] = bits[b, 1]
                cache_s[w] = n
            ef[n] = f
            eu[n] = pts[b, 0]
            ev[n] = pts[b, 1]
            slot[r, b] = n
            n += 1
    # every point in one call, grouped by face (a counting sort)
    eorder = _grouped_order(ef, n, nf)
    d = np.empty((3, n, 3))
    _multi_derivatives_kernel(deg, kofs, knots, pofs, pshape, pw_flat, rational, dom, ef[:n], eu[:n], ev[:n],
                              eorder, n_dev, d)
    i = 0
    for r in range(m):
        mx = 0.0
        for b in range(nd):
            e0 = d[0, i, 0] - ref[r, b, 0]
            e1 = d[0, i, 1] - ref[r, b, 1]
            e2 = d[0, i, 2] - ref[r, b, 2]
            x = np.sqrt((e0 * e0 + e1 * e1) + e2 * e2)
            if b == 0 or x > mx or x != x:
                mx = x
            if mx != mx:
                i += nd - b
                break
            i += 1
        dev[r] = mx
    for r in range(m):
        if slot[r, 0] < 0:
            continue
        t0, t1, t2 = tn[r, 0], tn[r, 1], tn[r, 2]
        for b in range(nb):
            i = slot[r, b]
            a0, a1, a2 = d[1, i, 0], d[1, i, 1], d[1, i, 2]
            b0, b1, b2 = d[2, i, 0], d[2, i, 1], d[2, i, 2]
            c0 = a1 * b2 - a2 * b1
            c1 = a2 * b0 - a0 * b2
            c2 = a0 * b1 - a1 * b0
            ln = np.sqrt((c0 * c0 + c1 * c1) + c2 * c2)
            if ln > 0:
                c0, c1, c2 = c0 / ln, c1 / ln, c2 / ln
            else:
                c0 = c1 = c2 = np.nan
            if not same_sense[face_of[r]]:
                c0, c1, c2 = -c0, -c1, -c2
            dot = (c0 * t0 + c2 * t2) + c1 * t1
            if np.isfinite(dot) and np.sqrt((c0 * c0 + c1 * c1) + c2 * c2) > 0.5 and not dot > 0:
                out[r] = True
                break
    return dev, out, True


def _against_kernel(face_of, uv3, tn, corners, use_corners, bary, deg, kofs, knots, pofs, pshape, pw_flat, rational,
                    dom, same_sense, axis, flat):
    """`_dev_against_kernel`'s flip test alone (no deviation points): (against (r,), ok)."""
    _, against, ok = _dev_against_kernel(face_of, uv3, _NO_X3, tn, corners, use_corners, _NO_BARY, bary, deg, kofs,
                                         knots, pofs, pshape, pw_flat, rational, dom, same_sense, axis, flat)
    return against, ok


_NO_X3 = np.zeros((0, 3, 3))
_NO_BARY = np.zeros((0, 3))


_PACKED: dict = {}   # id(faces) -> (faces, its items' ids, the packed kernel arguments of their surfaces, its items)


def _packed(faces):
    """(the `_kernel_args` of every face's NURBS surface packed into flat arrays for
    `_multi_derivatives_kernel` (other faces: a dummy entry), (nf,) same_sense, every surface a
    NurbsSurface), built once per list of faces."""
    hit = _PACKED.get(id(faces))
    if hit is not None and hit[0] is faces and hit[1] == tuple(map(id, faces)):    # (the entry keeps its items
        return hit[2]                                                                #  alive: their ids are theirs)
    nf = len(faces)
    deg = np.ones((nf, 2), dtype=np.int64)
    kofs = np.zeros((nf, 3), dtype=np.int64)
    pofs = np.zeros(nf + 1, dtype=np.int64)
    pshape = np.zeros((nf, 3), dtype=np.int64)
    rational = np.zeros(nf, dtype=np.bool_)
    dom = np.zeros((nf, 4))
    knots, pws = [], []
    k = 0
    for i, face in enumerate(faces):
        surface = None if face is None else face.surface
        if type(surface) is NurbsSurface:
            pu, pv, ku, kv, pw, rat, u0, u1, v0, v1 = _kernel_args(surface)
            deg[i] = pu, pv
            kofs[i] = k, k + len(ku), k + len(ku) + len(kv)
            k += len(ku) + len(kv)
            knots += [ku, kv]
            pshape[i] = pw.shape
            pws.append(np.ascontiguousarray(pw, dtype=np.float64).ravel())
            pofs[i + 1] = pofs[i] + pw.size
            rational[i] = rat
            dom[i] = u0, u1, v0, v1
        else:
            kofs[i] = k
            pshape[i] = 0, 0, 3
            pofs[i + 1] = pofs[i]
    # (read-only, as `_kernel_args` hands them to the per-face kernel: the same compiled `_surface_point01`)
    args = (deg, kofs, read_only(np.concatenate(knots) if knots else np.zeros(0)), pofs, pshape,
            read_only(np.concatenate(pws) if pws else np.zeros(0)), rational, dom)
    out = (args, np.array([True if f is None else bool(f.same_sense) for f in faces], dtype=bool),
           all(f is None or type(f.surface) is NurbsSurface for f in faces))
    if len(_PACKED) >= 2:       # (it keeps its faces alive: a batch of shells must not pile up)
        _PACKED.clear()
    _PACKED[id(faces)] = (faces, tuple(map(id, faces)), out, tuple(faces))
    return out


def _derivatives01(faces, face_of, pts) -> np.ndarray:
    """(3, p, 3): S, S_u, S_v of faces[face_of[i]].surface at pts[i] in one compiled call, the values of
    `_derivatives(surface, pts, 1)` per face (every used surface a NurbsSurface, `pts` finite)."""
    out = np.empty((3, len(pts), 3))
    if len(pts):
        face_of = np.asarray(face_of, dtype=np.int64)
        _multi_derivatives_kernel(*_packed(faces)[0], face_of, np.ascontiguousarray(pts[:, 0], dtype=np.float64),
                                  np.ascontiguousarray(pts[:, 1], dtype=np.float64),
                                  np.argsort(face_of), np.int64(0), out)    # (grouped by face; any order within)
    return out


def _same_sense(faces) -> np.ndarray:
    """(nf,) bool: faces[f].same_sense (a missing face: True), cached with the packed surfaces."""
    return _packed(faces)[1]


def _fast(surfaces, face_of, pts) -> bool:
    """The direct kernel path applies: NURBS surfaces and finite parameters (else the public methods,
    which raise on bad parameters)."""
    return all(s is None or type(s) is NurbsSurface for s in surfaces) and bool(np.isfinite(pts).all())


def _per_face_dev(surfaces, face_of, uv3, x3):
    """max |S(uv(b)) - x(b)| over the centroid and edge midpoints of each triangle: one evaluation per face."""
    pts = np.einsum("bj,rjk->rbk", _BARY, uv3)
    ref = np.einsum("bj,rjk->rbk", _BARY, x3)
    s = np.empty(ref.shape)
    groups = _by_face(face_of)
    if _fast(surfaces, face_of, pts):
        for f, r in groups:
            s[r] = _derivatives(surfaces[int(f)], pts[r].reshape(-1, 2), 0)[0, 0].reshape(len(r), -1, 3)
    else:
        for f, r in groups:
            s[r] = surfaces[int(f)].evaluate(pts[r].reshape(-1, 2)).reshape(len(r), -1, 3)
    return np.linalg.norm(s - ref, axis=2).max(axis=1) if len(face_of) else np.empty(0)


def _oriented_normals(faces, face_of, pts, corner_key=None) -> np.ndarray:
    """`faces[f].oriented_normals` at the points `pts` (p, 2) of faces `face_of` (p,), in one batch.

    The same kernel and arithmetic per point as the public method (so the same values). With
    `corner_key` (p,) int64 (-1: none), a vertex id: points of one vertex on one face with bit-equal
    parameters are evaluated once.
    """
    out = np.empty((len(pts), 3))
    if not len(pts):
        return out
    surfaces = [None if f is None else f.surface for f in faces]
    if not _fast(surfaces, face_of, pts):
        for f, r in _by_face(face_of):
            out[r] = np.asarray(faces[int(f)].oriented_normals(pts[r]), dtype=np.float64)
        return out
    src = np.arange(len(pts))
    if corner_key is not None:
        pending = np.flatnonzero(corner_key >= 0)
        if len(pending):
            # per vertex one representative among the pending points; those on its face with its
            # parameters take its value; the others (another face, a periodic seam) wait for the next
            bits = np.ascontiguousarray(pts).view(np.int64)
            first = np.full(int(corner_key.max()) + 1, -1, dtype=np.int64)
            while len(pending):
                kv = corner_key[pending]
                first[kv] = pending
                rep = first[kv]
                same = (face_of[rep] == face_of[pending]) & (bits[rep] == bits[pending]).all(axis=1)
                src[pending[same]] = rep[same]
                pending = pending[~same]
    ev = np.flatnonzero(src == np.arange(len(pts)))
    # every face's points in one compiled call (the per-face kernel's values; unit_normals and the
    # sign are per point, so the order does not matter)
    fe = face_of[ev]
    d = _derivatives01(faces, fe, pts[ev])
    n = unit_normals(d[1], d[2])
    flip = ~_same_sense(faces)[fe]
    n[flip] = -n[flip]
    slot = np.empty(len(pts), dtype=np.int64)
    slot[ev] = np.arange(len(ev))
    return n[slot[src]]


_PLANAR: dict = {}   # id(surface) -> (surface, (unit normal, cone half-angle) or None)


def _planar_cone(surface):
    """(n0, alpha): every normal S_u x S_v that the kernel computes on a flat non-rational NURBS surface
    lies within alpha radians of the unit vector n0 (rounding included); None when the surface is
    rational or the bound is not small (0.01 rad).

    S_u is a combination with non-negative weights (B-spline basis functions of degree p - 1 and q
    times p / knot spans) of the net's u differences, S_v likewise of its v differences, so
    S_u x S_v is a non-negative combination of the cross products of a u difference with a v
    difference and lies in the cone they span; the kernel's rounding adds at most
    1024 eps |P|max (|D_u|max + |D_v|max) (the spans' max/min weight ratios) / |c|min to its direction.
    """
    hit = _PLANAR.get(id(surface))
    if hit is not None and hit[0] is surface:
        return hit[1]
    out = None
    if type(surface) is NurbsSurface and surface.weights is None:
        P = np.asarray(surface.control_points, dtype=np.float64)
        pu, pv = int(surface.degree_u), int(surface.degree_v)
        ku, kv = np.asarray(surface.knots_u, dtype=np.float64), np.asarray(surface.knots_v, dtype=np.float64)
        nu, nv = P.shape[:2]
        su = ku[pu + 1:pu + nu] - ku[1:nu]          # u_{i+p+1} - u_{i+1}, i < nu - 1
        sv = kv[pv + 1:pv + nv] - kv[1:nv]
        du = (P[1:, :] - P[:-1, :]).reshape(-1, 3)
        dv = (P[:, 1:] - P[:, :-1]).reshape(-1, 3)
        if (pu >= 1 and pv >= 1 and len(du) and len(dv) and len(du) * len(dv) <= 40000
                and np.all(su > 0) and np.all(sv > 0) and np.all(np.isfinite(P))):
            c = np.cross(du[:, None, :], dv[None, :, :]).reshape(-1, 3)
            lc = np.linalg.norm(c, axis=1)
            total = c.sum(axis=0)
            ln = float(np.linalg.norm(total))
            if ln > 0 and float(lc.min()) > 0:
                n0 = total / ln
                cos = np.clip((c @ n0) / lc, -1.0, 1.0)
                if float(cos.min()) > 0.99:
                    rho = float(su.max() / su.min()) * float(sv.max() / sv.min())
                    alpha = float(np.arccos(cos.min())) + 1024 * np.finfo(float).eps * float(np.abs(P).max()) * (
                        float(np.linalg.norm(du, axis=1).max()) + float(np.linalg.norm(dv, axis=1).max())
                    ) * rho / float(lc.min())
                    if alpha < 0.01:
                        out = (n0, alpha)
    if len(_PLANAR) > 4096:
        _PLANAR.clear()
    _PLANAR[id(surface)] = (surface, out)
    return out


_CONES: dict = {}    # id(faces) -> (faces, its items' ids, (nf, 3) oriented n0 per face, (nf,) flat, its items)


def _face_cones(faces):
    """Per face of `faces`: its oriented flat-cone axis (`_planar_cone`) and whether it has one, built
    once per list of faces (checked item by item)."""
    hit = _CONES.get(id(faces))
    if hit is not None and hit[0] is faces and hit[1] == tuple(map(id, faces)):    # (the entry keeps its items
        return hit[2], hit[3]                                                                #  alive: their ids are theirs)
    axis = np.zeros((len(faces), 3))
    flat = np.zeros(len(faces), dtype=bool)
    for i, face in enumerate(faces):
        cone = None if face is None else _planar_cone(face.surface)
        if cone is not None:
            axis[i] = cone[0] if face.same_sense else -cone[0]
            flat[i] = True
    if len(_CONES) >= 2:        # (it keeps its faces alive: a batch of shells must not pile up)
        _CONES.clear()
    _CONES[id(faces)] = (faces, tuple(map(id, faces)), axis, flat, tuple(faces))
    return axis, flat


def _surely_along(faces, face_of, tri_normals) -> np.ndarray:
    """Per triangle: on a flat face (`_planar_cone`) and within 87 degrees of its oriented normal, so the
    surface normal the kernel computes at any point of the face is finite with a positive dot product
    with the triangle's normal or undefined: never against it (its samples need no evaluation)."""
    axis, flat = _face_cones(faces)
    face_of = np.asarray(face_of, dtype=np.int64)
    t = np.asarray(tri_normals, dtype=np.float64)
    lt = np.linalg.norm(t, axis=1)
    with np.errstate(all="ignore"):
        return flat[face_of] & (lt > 0) & (np.einsum("ij,ij->i", t, axis[face_of]) > 0.05 * lt)


def _against_normal(faces, face_of, uv3, tri_normals, bary=_ORIENT_BARY, corners=None):
    """Per triangle: its 3D normal points against its face's oriented surface normal at a sample point.

    Sample points (`bary`): by default the (u, v) centroid and the three corners;
    points where the surface normal is undefined (a pole) are skipped. One
    evaluation per face. `corners` (r, 3) int64: the triangles' vertices, with the default `bary`:
    a vertex's corner on one face is evaluated once (where its (u, v) is the same).
    """
    if not len(face_of):
        return np.zeros(0, dtype=bool)
    if _all_nurbs(faces):       # the same numbers in one compiled pass (unless a sample point is not finite)
        axis, flat = _face_cones(faces)
        use_corners = corners is not None and bary is _ORIENT_BARY
        res, ok = _against_kernel(np.asarray(face_of, dtype=np.int64), np.ascontiguousarray(uv3, dtype=np.float64),
                                  np.ascontiguousarray(tri_normals, dtype=np.float64),
                                  np.ascontiguousarray(corners, dtype=np.int64) if use_corners else _NO_CORNERS,
                                  np.bool_(use_corners), np.ascontiguousarray(bary, dtype=np.float64),
                                  *_packed(faces)[0], _same_sense(faces), axis, flat)
        if ok:
            return res
    return _against_normal_numpy(faces, face_of, uv3, tri_normals, bary, corners)


_NO_CORNERS = np.zeros((0, 3), dtype=np.int64)


def _all_nurbs(faces) -> bool:
    """Every face's surface a NurbsSurface (a missing face counts): `_fast`'s surface condition."""
    return _packed(faces)[2]


def _against_normal_numpy(faces, face_of, uv3, tri_normals, bary=_ORIENT_BARY, corners=None):
    """`_against_normal` in numpy passes (the reference of `_against_kernel`, and the path for
    surfaces other than NURBS or sample points that are not finite)."""
    if not len(face_of):
        return np.zeros(0, dtype=bool)
    sure = _surely_along(faces, face_of, tri_normals)
    if sure.any():
        res = np.zeros(len(face_of), dtype=bool)
        rest = np.flatnonzero(~sure)
        if len(rest):
            res[rest] = _against_normal_numpy(faces, face_of[rest], uv3[rest], tri_normals[rest], bary,
                                        None if corners is None else corners[rest])
        return res
    # the sample points and the tests of all triangles at once; the normals per face (its surface)
    pts = np.einsum("bj,rjk->rbk", bary, uv3)
    key = None
    if corners is not None and bary is _ORIENT_BARY:
        key = np.full(pts.shape[:2], -1, dtype=np.int64)
        key[:, 1:] = corners
        key = key.ravel()
    with np.errstate(all="ignore"):
        ns = _oriented_normals(faces, np.repeat(face_of, pts.shape[1]), pts.reshape(-1, 2),
                               key).reshape(pts.shape[:2] + (3,))
        dot = np.einsum("rbk,rk->rb", ns, tri_normals)
        valid = np.isfinite(dot) & (np.linalg.norm(ns, axis=2) > 0.5)
    return np.any(valid & ~(dot > 0), axis=1)


def _dev_and_against(surfaces, faces, face_of, uv3, x3, tri_normals):
    """(`_per_face_dev`, `_against_normal`) of the same triangles with one kernel call per face: the
    deviation's points (S only) and the flip test's (S_u, S_v; not on flat faces, `_surely_along`)
    in one batch of first derivatives (the kernel's S is the same with or without them)."""
    if not len(face_of):
        return np.empty(0), np.zeros(0, dtype=bool)
    if _all_nurbs(faces) and all(faces[f].surface is surfaces[f] for f in np.unique(face_of).tolist()):
        axis, flat = _face_cones(faces)
        dev, against, ok = _dev_against_kernel(
            np.asarray(face_of, dtype=np.int64), np.ascontiguousarray(uv3, dtype=np.float64),
            np.ascontiguousarray(x3, dtype=np.float64), np.ascontiguousarray(tri_normals, dtype=np.float64),
            _NO_CORNERS, np.bool_(False), _BARY, _ORIENT_BARY, *_packed(faces)[0], _same_sense(faces), axis, flat)
        if ok:
            return dev, against
    return _dev_and_against_numpy(surfaces, faces, face_of, uv3, x3, tri_normals)


def _dev_and_against_numpy(surfaces, faces, face_of, uv3, x3, tri_normals):
    """`_dev_and_against` in numpy passes (the reference of `_dev_against_kernel`, and the path for other
    surfaces or sample points that are not finite)."""
    if not len(face_of):
        return np.empty(0), np.zeros(0, dtype=bool)
    dpts = np.einsum("bj,rjk->rbk", _BARY, uv3)
    npts = np.einsum("bj,rjk->rbk", _ORIENT_BARY, uv3)
    if not (_fast(surfaces, face_of, dpts) and bool(np.isfinite(npts).all())
            and all(faces[f].surface is surfaces[f] for f in np.unique(face_of).tolist())):
        return _per_face_dev(surfaces, face_of, uv3, x3), _against_normal(faces, face_of, uv3, tri_normals)
    ref = np.einsum("bj,rjk->rbk", _BARY, x3)
    sure = _surely_along(faces, face_of, tri_normals)
    nb, nd = npts.shape[1], dpts.shape[1]
    # the deviation's points of every triangle and the flip test's of those not surely along, every
    # face in one compiled call (the per-face kernel's values; all per point)
    rows = np.flatnonzero(~sure)
    k = nd * len(face_of)
    d = _derivatives01(faces, np.r_[np.repeat(face_of, nd), np.repeat(face_of[rows], nb)],
                       np.concatenate([dpts.reshape(-1, 2), npts[rows].reshape(-1, 2)]))
    s = d[0, :k].reshape(len(face_of), nd, 3)
    dev = np.linalg.norm(s - ref, axis=2).max(axis=1)
    against = np.zeros(len(face_of), dtype=bool)
    if len(rows):
        n = unit_normals(d[1, k:], d[2, k:])
        flip = np.repeat(~_same_sense(faces)[face_of[rows]], nb)
        n[flip] = -n[flip]
        ns = n.reshape(len(rows), nb, 3)
        with np.errstate(all="ignore"):
            dot = np.einsum("rbk,rk->rb", ns, tri_normals[rows])
            valid = np.isfinite(dot) & (np.linalg.norm(ns, axis=2) > 0.5)
        against[rows] = np.any(valid & ~(dot > 0), axis=1)
    return dev, against


def _close(x, y) -> bool:
    """np.allclose(x, y, rtol=1e-5, atol=1e-8) of two finite (u, v) pairs, in scalars."""
    return all(abs(p - q) <= 1e-8 + 1e-5 * abs(q) for p, q in zip(x, y))


def _uv_area_1(p0, p1, p2) -> float:
    """`_uv_area` of one triangle given as three (u, v) pairs (the same operations)."""
    return (p1[0] - p0[0]) * (p2[1] - p0[1]) - (p2[0] - p0[0]) * (p1[1] - p0[1])


def _sign(x: float) -> float:
    return 1.0 if x > 0 else (-1.0 if x < 0 else 0.0)


#: `_State.flip_edges` takes the swap candidates computed for its batch while no swap is done (False: each
#: one computed again in the loop, as before; the tests compare both)
_MEMO_SWAPS = True


class _HalfEdges:
    """Directed edge (a, b) -> triangle, as the dict {(a, b): k} over the alive triangles in order (the
    last triangle wins a repeated edge) with pops and sets after: a sorted array of the edges
    (built by numpy) under a dict of the changes."""

    def __init__(self, T: np.ndarray, ia: np.ndarray, nv1: int):
        t = T[ia]
        keys = np.stack([t[:, 0] * nv1 + t[:, 1], t[:, 1] * nv1 + t[:, 2], t[:, 2] * nv1 + t[:, 0]], axis=1).ravel()
        order = np.argsort(keys, kind="stable")
        self.keys, self.tri = keys[order], ia[order // 3]
        self.nv1 = nv1
        self.changed: dict = {}         # key -> triangle, or None (popped)

    def _key(self, e) -> int:
        return e[0] * self.nv1 + e[1]

    def get(self, e):
        key = self._key(e)
        if key in self.changed:
            return self.changed[key]
        pos = int(np.searchsorted(self.keys, key, side="right")) - 1
        return int(self.tri[pos]) if pos >= 0 and self.keys[pos] == key else None

    def __contains__(self, e) -> bool:
        return self.get(e) is not None

    def pop(self, e, default=None):
        self.changed[self._key(e)] = None

    def __setitem__(self, e, k):
        self.changed[self._key(e)] = k


def _multi_face_numpy(T, alive, fid, nv):
    """(multi, stri): per vertex, whether the alive triangles at it lie on more than one face (True for a
    vertex on none: its lowest face id stays above its highest), and per triangle (alive or not) whether
    two of its corners are such vertices. `_multi_face_kernel`'s reference (the tests compare them)."""
    t, f = T[alive], fid[alive]
    lo = np.full(nv, np.iinfo(np.int64).max)
    hi = np.full(nv, -1, dtype=np.int64)
    fr = np.repeat(f, 3)
    np.minimum.at(lo, t.ravel(), fr)
    np.maximum.at(hi, t.ravel(), fr)
    multi = lo != hi
    return multi, np.count_nonzero(multi[T], axis=1) >= 2


@njit(cache=True, nogil=True)
def _multi_face_kernel(T, alive, fid, nv):
    """`_multi_face_numpy` in one compiled pass (integer minima and maxima: the same flags)."""
    m = T.shape[0]
    lo = np.full(nv, np.iinfo(np.int64).max)
    hi = np.full(nv, -1, dtype=np.int64)
    for t in range(m):
        if alive[t]:
            f = fid[t]
            for c in range(3):
                v = T[t, c]
                lo[v] = min(lo[v], f)
                hi[v] = max(hi[v], f)
    multi = np.empty(nv, dtype=np.bool_)
    for v in range(nv):
        multi[v] = lo[v] != hi[v]
    stri = np.empty(m, dtype=np.bool_)
    for t in range(m):
        stri[t] = (np.int64(multi[T[t, 0]]) + np.int64(multi[T[t, 1]]) + np.int64(multi[T[t, 2]])) >= 2
    return multi, stri


class _State:
    """The mesh being reduced: triangles (with ``alive``), deviation bounds and corner (u, v)."""

    def __init__(self, mesh, tolerance, tri_dev, max_edge, corner_uv, surfaces, faces):
        self.V = mesh.vertices
        self.T = np.array(mesh.triangles, dtype=np.int64)
        self.fid = np.array(mesh.face_id, dtype=np.int64)
        self.dev = np.zeros(len(self.T)) if tri_dev is None else np.asarray(tri_dev, dtype=np.float64).copy()
        self.cuv = (None if corner_uv is None or surfaces is None
                    else np.asarray(corner_uv, dtype=np.float64).copy())
        self.surfaces, self.faces = surfaces, faces
        self.alive = np.ones(len(self.T), dtype=bool)
        self.tolerance, self.max_edge = float(tolerance), max_edge
        # `flipped` per triangle, recomputed only for triangles changed since (a triangle's test
        # depends on its corners, its face and its corner (u, v) alone)
        self._flip = np.zeros(len(self.T), dtype=bool)
        self._dirty = np.ones(len(self.T), dtype=bool)
        self._multi = None                  # vertices on more than one face (`seam`)
        self._stri = None                   # triangles with two such corners (`seam`)

    def _set_rows(self, idx) -> None:
        """Rows `idx` of T changed: update their seam-triangle flags (`seam`)."""
        idx = np.asarray(idx, dtype=np.int64)
        if self._stri is not None and len(idx):
            self._stri[idx] = np.count_nonzero(self._multi[self.T[idx]], axis=1) >= 2

    def seam(self):
        """Seam edges (k, 2) of the alive triangles.

        Only the triangles with two corners on more than one face can hold a seam edge (and they hold
        every triangle of such an edge): the edges of those alone, in the same (sorted) order. The
        vertices on more than one face are found once: no step adds a face to a vertex (a seam collapse
        moves v onto u, which has both of v's faces; an interior one and a diagonal swap stay in one
        face), so the first set holds every later one, which is all the selection needs.
        """
        if self._multi is None:
            # (`_multi_face_numpy`'s flags in one compiled pass: numpy's minimum.at / maximum.at took up to
            # 1 ms each on a mesh's face ids, which come in long runs)
            self._multi, self._stri = _multi_face_kernel(self.T, self.alive, self.fid, np.int64(len(self.V)))
        return _seam_edges(self.T, self.fid, len(self.V), np.flatnonzero(self.alive & self._stri))

    def round(self, seam, cands, chord_tol, skip, uv_check: bool = True, interior: bool = False) -> int:
        """Try the directed collapses `cands` (v into u, in order) whose stars do not overlap; apply the good.

        `cands`: (k, 2) int array-like. Collapses that fail a check are added to `skip` (never tried
        again; a set of keys v * len(V) + u).
        ``uv_check=False`` (the flip pass) drops the (u, v) orientation test (the 3D one stays), and
        lets a triangle already flipped turn by more than 60 degrees: where
        two trims of a face are closer than the tolerance their chords in (u, v) and in
        3D can disagree on a corner's orientation. ``interior=True``: v is instead a vertex
        inside one face (off every seam, its triangles a closed fan of that face) collapsed into
        any neighbour u (no chord test; the deviation is evaluated on the surface).
        Returns the number of collapses done.
        """
        V, T, fid, alive = self.V, self.T, self.fid, self.alive
        nv = len(V)
        # the two seam neighbours of every degree-2 seam vertex (both ways, by first vertex)
        both = np.r_[seam, seam[:, ::-1]]
        both = both[np.argsort(both[:, 0])]     # (v's two neighbours are read symmetrically: any order)
        # the cheap tests of every candidate at once: v on the seam between two neighbours, u one of
        # them, v within chord_tol of the new seam chord (u, w)
        c = np.asarray(cands, dtype=np.int64).reshape(-1, 2)
        if skip and len(c):
            c = c[~np.isin(c[:, 0] * nv + c[:, 1], np.fromiter(skip, dtype=np.int64, count=len(skip)))]
        cv, cu = c[:, 0], c[:, 1]
        first = np.searchsorted(both[:, 0], cv)                               # v's first seam edge
        deg = np.searchsorted(both[:, 0], cv, side="right") - first           # v's seam degree
        if interior:
            ok = deg == 0
        else:
            ok = deg == 2
            f = np.where(ok, first, 0)
            n0 = both[np.minimum(f, len(both) - 1), 1]
            n1 = both[np.minimum(f + 1, len(both) - 1), 1]
            ok &= (cu == n0) | (cu == n1)
            cw = np.where(cu == n0, n1, n0)
            pu, pw, pv = V[cu], V[cw], V[cv]
            d = pw - pu
            den = np.einsum("ij,ij->i", d, d)
            sp = np.clip(np.einsum("ij,ij->i", pv - pu, d) / np.where(den > 0, den, 1.0), 0.0, 1.0)
            far = np.linalg.norm(pv - (pu + sp[:, None] * d), axis=1) > chord_tol
            skip.update((c[ok & far, 0] * nv + c[ok & far, 1]).tolist())
            ok &= ~far
        # the selection (v's star unlocked, the face and link conditions), compiled
        c = c[ok]
        qs, mv, ms, gn, sk = _seam_select_kernel(T, np.flatnonzero(alive), fid, np.int64(nv), c[:, 0].copy(),
                                                 c[:, 1].copy(), np.bool_(interior))
        if len(sk):
            skip.update((c[sk, 0] * nv + c[sk, 1]).tolist())
        if not len(qs):
            return 0
        ok = self._check(c[qs, 0], c[qs, 1], mv, np.repeat(np.arange(len(qs)), np.diff(ms)), gn, uv_check,
                         exempt_flipped=not uv_check)
        if not ok.all():
            skip.update((c[qs[~ok], 0] * nv + c[qs[~ok], 1]).tolist())
        return int(np.count_nonzero(ok))

    def _check(self, cv, cu, mi, ci, gone, uv_check: bool = True, exempt_flipped: bool = False) -> np.ndarray:
        """Batched tests of the selected collapses cv[s] -> cu[s] (moved triangles `mi`, of collapse `ci`;
        the two gone triangles `gone` (s, 2)); applies the ones that pass. Returns (s,) bool.

        ``exempt_flipped``: a triangle already against its face's normal may turn by any angle
        (turning it back is the point); its new normal is tested against the surface's.
        """
        V, T, fid = self.V, self.T, self.fid
        ns = len(cv)
        bad = np.zeros(ns, dtype=bool)
        oldt = T[mi]
        newt = np.where(oldt == cv[ci, None], cu[ci, None], oldt)
        old = _normals(V, oldt)
        new = _normals(V, newt)
        ln_old = np.linalg.norm(old, axis=1)
        ln_new = np.linalg.norm(new, axis=1)
        ref = np.zeros(ns)
        np.maximum.at(ref, ci, ln_old)
        fail = ln_new <= 1e-12 * np.maximum(ref[ci], 1e-300)
        cos = np.einsum("ij,ij->i", old, new) / np.maximum(ln_old * ln_new, 1e-300)
        turned = cos < _COS_FLIP
        if exempt_flipped and self.cuv is not None and self.faces is not None:
            turned &= ~_against_normal(self.faces, fid[mi], self.cuv[mi], old)
        fail |= turned
        if self.max_edge < np.inf:
            pn = V[newt]
            fail |= np.linalg.norm(pn - np.roll(pn, 1, axis=1), axis=2).max(axis=1) > self.max_edge
        if self.cuv is None:
            shift = np.linalg.norm(V[cu] - V[cv], axis=1)
            new_dev = self.dev[mi] + shift[ci]
            new_uv = None
        else:
            cuv = self.cuv
            # v takes u's (u, v) from the collapsed triangle of the same face
            g0, g1 = gone[ci, 0], gone[ci, 1]
            src = np.where(fid[g0] == fid[mi], g0, np.where(fid[g1] == fid[mi], g1, -1))
            nosrc = src < 0
            src = np.where(nosrc, g0, src)
            ts = T[src]
            at_v_src = ts == cv[ci, None]
            at_u_src = ts == cu[ci, None]
            at_v = oldt == cv[ci, None]
            uv_v_src = np.einsum("mc,mck->mk", at_v_src.astype(float), cuv[src])
            uv_u_src = np.einsum("mc,mck->mk", at_u_src.astype(float), cuv[src])
            uv_v = np.einsum("mc,mck->mk", at_v.astype(float), cuv[mi])
            # v's (u, v) must agree between the triangles (else a periodic seam)
            nosrc |= ~np.all(np.abs(uv_v_src - uv_v) <= 1e-8 + 1e-5 * np.abs(uv_v), axis=1)
            fail |= nosrc
            new_uv = np.where(at_v[..., None], uv_u_src[:, None, :], cuv[mi])
            if self.faces is not None:
                new_dev, against = _dev_and_against(self.surfaces, self.faces, fid[mi], new_uv, V[newt], new)
            else:
                new_dev, against = _per_face_dev(self.surfaces, fid[mi], new_uv, V[newt]), False
            # no triangle may turn over in its face's (u, v) domain ...
            if uv_check:
                fail |= np.sign(_uv_area(new_uv)) != np.sign(_uv_area(cuv[mi]))
            # ... nor against the oriented surface normal in 3D (what `measure` counts as flipped)
            fail |= against
        fail |= ~(new_dev <= self.tolerance)
        bad[ci[fail]] = True
        ok = ~bad
        apply = ok[ci]
        T[mi[apply]] = newt[apply]
        self._dirty[mi[apply]] = True
        self._set_rows(mi[apply])
        self.dev[mi[apply]] = new_dev[apply]
        if new_uv is not None:
            self.cuv[mi[apply]] = new_uv[apply]
        self.alive[gone[ok].ravel()] = False
        return ok

    def flip_edges(self, bad) -> int:
        """Swap the diagonal between a flipped triangle and its neighbour of the same face.

        For each triangle in `bad` (still alive, still flipped), each of its edges inside
        its face in turn: triangles (a, b, c) and (b, a, d) become (c, a, d) and (d, b, c)
        when (c, d) is not an edge yet, both new triangles keep their face's (u, v)
        orientation, point along the oriented surface normal in 3D and stay within the
        tolerance on the surface (and `max_edge`). Returns the number of swaps.
        """
        V, T, fid, cuv, alive = self.V, self.T, self.fid, self.cuv, self.alive
        ia = np.flatnonzero(alive)
        he = _HalfEdges(T, ia, len(V) + 1)

        def candidate(k, c):
            """The swap of triangle k's edge c as the mesh is now, after the tests before the 3D normal
            test: (k2, t, t2, new, nuv, nn) or None."""
            t = T[k].tolist()
            a, b, cc = t[c], t[(c + 1) % 3], t[(c + 2) % 3]
            k2 = he.get((b, a))
            if k2 is None or k2 == k or fid[k2] != fid[k] or not alive[k2]:
                return None
            t2 = T[k2].tolist()
            d = t2[(t2.index(b) + 2) % 3]
            if d in (a, b, cc) or (cc, d) in he or (d, cc) in he:
                return None
            uv1 = dict(zip(t, cuv[k].tolist()))
            uv2 = dict(zip(t2, cuv[k2].tolist()))
            if not all(_close(uv1[x], uv2[x]) for x in (a, b)):
                return None         # a periodic seam between them
            uvx = {**uv2, **uv1}
            ref = _sign(_uv_area_1(*cuv[k2].tolist()))
            if ref == 0 or _sign(_uv_area_1(uvx[cc], uvx[a], uvx[d])) != ref \
                    or _sign(_uv_area_1(uvx[d], uvx[b], uvx[cc])) != ref:
                return None
            new = np.array([[cc, a, d], [d, b, cc]], dtype=np.int64)
            nuv = np.array([[uvx[x] for x in r] for r in new.tolist()])
            nn = _normals_rows(V, ((cc, a, d), (d, b, cc)))
            if np.any(np.linalg.norm(nn, axis=1) <= 1e-12 * np.linalg.norm(_normals_rows(V, (t2,)))):
                return None
            return k2, t, t2, new, nuv, nn

        # the 3D normal tests of every swap the first flipped triangles offer now, in one batch; a swap
        # whose triangles an earlier swap changed is tested on its own (`_against_normal` per triangle:
        # the same values in a batch, keyed by face, corners and corner (u, v))
        # (the candidates as the mesh is before any swap: the loop below takes them while no swap is done,
        # candidate() reading only what a swap changes: T, cuv and the half-edges)
        memo = {(k, c): candidate(k, c) for k in np.asarray(bad).tolist() if alive[k] for c in range(3)}
        first = [(k, cand) for (k, _), cand in memo.items() if cand is not None]
        known: dict = {}
        if first:
            f_b = np.repeat(fid[[k for k, _ in first]], 2)
            res = _against_normal(self.faces, f_b, np.concatenate([x[4] for _, x in first]),
                                  np.concatenate([x[5] for _, x in first])).reshape(-1, 2)
            for (k, x), r in zip(first, res.tolist()):
                known[(int(fid[k]), x[3].tobytes(), x[4].tobytes())] = r[0] or r[1]
        n = 0
        for k in np.asarray(bad).tolist():
            if not alive[k]:
                continue
            for c in range(3):
                cand = memo[(k, c)] if n == 0 and _MEMO_SWAPS else candidate(k, c)
                if cand is None:
                    continue
                k2, t, t2, new, nuv, nn = cand
                f2 = np.array([fid[k], fid[k]])
                key = (int(fid[k]), new.tobytes(), nuv.tobytes())
                against = known[key] if key in known else bool(np.any(_against_normal(self.faces, f2, nuv, nn)))
                if against:
                    continue
                cc, d = new[0, 0], new[0, 2]
                if self.max_edge < np.inf and np.linalg.norm(V[cc] - V[d]) > self.max_edge:
                    continue
                ndev = _per_face_dev(self.surfaces, f2, nuv, V[new])
                if not np.all(ndev <= self.tolerance):
                    continue
                for old in (t, t2):
                    for i in range(3):
                        he.pop((old[i], old[(i + 1) % 3]), None)
                T[k], T[k2] = new[0], new[1]
                self._dirty[[k, k2]] = True
                self._set_rows([k, k2])
                cuv[k], cuv[k2] = nuv[0], nuv[1]
                self.dev[k], self.dev[k2] = ndev[0], ndev[1]
                for kk, r in ((k, new[0].tolist()), (k2, new[1].tolist())):
                    for i in range(3):
                        he[(r[i], r[(i + 1) % 3])] = kk
                n += 1
                break
        return n

    def flipped(self) -> np.ndarray:
        """Alive triangles whose normal points against their face's oriented normal at the (u, v) centroid
        or a corner (the centroid alone misses a sliver spanning a fillet, skewed: soapbox loose)."""
        idx = np.flatnonzero(self.alive)
        d = idx[self._dirty[idx]]
        if len(d):
            td = self.T[d]
            self._flip[d] = _against_normal(self.faces, self.fid[d], self.cuv[d], _normals(self.V, td),
                                            bary=_ORIENT_BARY, corners=td)
            self._dirty[d] = False
        return idx[self._flip[idx]]


def reduce_seams(mesh: TriMesh, tolerance: float, *, tri_dev=None, max_edge: float = np.inf,
                 corner_uv=None, surfaces=None, faces=None, max_rounds: int = 6, short: float = 0.5,
                 return_kept: bool = False, return_state: bool = False, return_flipped: bool = False):
    """Collapse short seam edges within `tolerance`; returns the reduced mesh and the number of collapses.

    Parameters
    ----------
    mesh : TriMesh
        With ``face_id``, after stitching.
    tolerance : float
        Deviation bound the collapsed mesh must keep (model units).
    tri_dev : (m,) float64 or None
        Per-triangle deviation bound of the input (e.g. `face.triangle_deviation`);
        a collapse that moves a triangle's corner by d raises its bound by d
        (the triangles differ by at most d at equal barycentric coordinates), and is
        allowed only while the bound stays within `tolerance`. None: all zero.
    max_edge : float
        No collapse may create an edge longer than this.
    corner_uv : (m, 3, 2) float64 or None
        The (u, v) of every triangle corner on its face; with `surfaces` (one per
        face id) the deviation of the new triangles is evaluated on the surface
        (`face.triangle_deviation`) instead of bounded by the corner shift.
    faces : sequence of TrimmedFace or None
        One per face id, with `corner_uv`: a collapse is accepted only if every
        triangle around the collapsed edge keeps its 3D normal on the side of
        its face's oriented surface normal (the `measure` module's flip test),
        besides keeping its orientation in (u, v); and triangles flipped
        against the normal are removed by collapsing a seam edge of theirs.
    short : float
        Only seam edges shorter than `short` times the median seam edge are collapsed.
    return_kept, return_state : bool
        Also return the mask of kept input triangles; with `return_state` too, the kept
        triangles' deviation bounds and corner (u, v) (None without `corner_uv`).
    return_flipped : bool
        With `return_state`: also return, per kept triangle, whether it points against its face's
        oriented normal at its (u, v) centroid or a corner (`_against_normal` with the corners;
        None without `corner_uv` and `faces`).
    """
    if mesh.face_id is None or not mesh.n_triangles:
        if return_state:
            return (mesh, 0, np.ones(mesh.n_triangles, dtype=bool),
                    np.zeros(mesh.n_triangles) if tri_dev is None else np.asarray(tri_dev, dtype=np.float64),
                    None if corner_uv is None else np.asarray(corner_uv, dtype=np.float64)) + (
                        (None,) if return_flipped else ())
        return (mesh, 0, np.ones(mesh.n_triangles, dtype=bool)) if return_kept else (mesh, 0)
    st = _State(mesh, tolerance, tri_dev, max_edge, corner_uv, surfaces, faces)
    V = st.V
    total = 0
    skip: set = set()
    for _ in range(max_rounds):
        seam = st.seam()
        if not len(seam):
            break
        length = np.linalg.norm(V[seam[:, 0]] - V[seam[:, 1]], axis=1)
        limit = short * float(np.median(length))
        e = np.argsort(length)
        e = e[length[e] < limit]
        if not len(e):
            break
        pairs = np.stack([seam[e], seam[e, ::-1]], axis=1).reshape(-1, 2)
        n_round = st.round(seam, pairs, 0.25 * tolerance, skip)
        total += n_round
        if not n_round:
            break
    if st.cuv is not None and faces is not None:
        skip, skip_in = set(), set()
        bad = st.flipped()       # re-evaluated only after a step changed the mesh
        for _ in range(3):
            if not len(bad):
                break
            seam = st.seam()
            if not len(seam):
                break
            # the seam edges of the flipped triangles, both ways, triangle by triangle, corner by corner
            tb = st.T[bad]
            ea, eb = tb.ravel(), np.roll(tb, -1, axis=1).ravel()
            on = np.isin(np.minimum(ea, eb) * len(V) + np.maximum(ea, eb), seam[:, 0] * len(V) + seam[:, 1])
            cands = np.stack([np.c_[ea, eb], np.c_[eb, ea]], axis=1)[on].reshape(-1, 2)
            n_round = st.round(seam, cands, tolerance, skip, uv_check=False) if len(cands) else 0
            if n_round:
                bad = st.flipped()
            # a flipped triangle at a corner where several faces were merged into one vertex (the
            # merge moved it past the face's own nearby grid points: Crankshaft, U_Joint loose):
            # its face-interior corner is collapsed into a neighbour, shortest edge first
            if len(bad):
                e = np.stack([st.T[bad], np.roll(st.T[bad], -1, axis=1)], axis=2).reshape(-1, 2)
                e = e[np.argsort(np.linalg.norm(V[e[:, 0]] - V[e[:, 1]], axis=1), kind="stable")]
                cands = np.stack([e, e[:, ::-1]], axis=1).reshape(-1, 2)
                n_in = st.round(st.seam(), cands, tolerance, skip_in, uv_check=False,
                                interior=True)
                if n_in:
                    bad = st.flipped()
                n_round += n_in
            # a flipped sliver along a seam (its corners on the seam, or one inside the face: soapbox,
            # wing_fuselage loose): swap its diagonal with its neighbour in the same face
            total += n_round           # collapses (diagonal swaps remove no vertex)
            if len(bad):
                n_round += st.flip_edges(bad)
            if not n_round:
                break
            bad = st.flipped()
    T, fid, alive = st.T[st.alive], st.fid[st.alive], st.alive
    used, inv = compact_indices(T, len(V))             # (np.unique(T, return_inverse=True))
    out = TriMesh(V[used], inv.reshape(-1, 3), face_id=fid)
    if return_state:
        state = (out, total, alive, st.dev[alive], None if st.cuv is None else st.cuv[alive])
        if return_flipped:
            flipped = None
            if st.cuv is not None and faces is not None:
                st.flipped()            # (only the triangles changed since its last call)
                flipped = st._flip[alive]
            state += (flipped,)
        return state
    return (out, total, alive) if return_kept else (out, total)
