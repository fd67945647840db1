"""Stitching of separately tessellated faces (paper Sec. 4.4, 5.2) and merging into one mesh.

For every boundary vertex v of a face, the boundary edges of *other* faces
near it are found with one global k-d tree (the paper's BSP tree; O(n log n)):
candidates are the boundary edges whose midpoint lies within r_max / 2 + eps
of v (r_max the longest boundary edge). The closest such edge e_c within eps
takes v: when the projection v_p of v onto e_c is within eps of an end of e_c,
that end is merged into v (every group of merged vertices ends at its mean);
otherwise e_c is split at v (T-junction removed). Check-back (Fig. 13 b): the
boundary edges of v's own faces closest to v_p must be edges at v, else the
split is ignored. A second pass sees vertices shared by two faces: their faces
are those of their two boundary edges, and their own edges are never candidates.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph
from scipy.spatial import cKDTree

from ..model import TriMesh
from ..model.mesh import compact_indices

__all__ = ["merge_face_meshes", "stitch_mesh"]


def _point_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    ab = b - a
    den = np.einsum("ij,ij->i", ab, ab)
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.where(den > 0, den, 1.0), 0.0, 1.0)
    q = a + t[:, None] * ab
    return np.linalg.norm(p - q, axis=1), t


def _sequential_fans(poly: list, corners: list) -> list:
    """Triangles filling the triangle `corners` with the points of `poly` on its edges, edge by edge.

    Each split edge (i, j) is fanned from the vertex opposite it in the
    triangle that holds it at that moment: always a complete triangulation
    (every inserted point and sub-edge present), whatever the shapes.
    """
    n = len(poly)
    tris = [tuple(corners)]
    for c in range(3):
        i, j = corners[c], corners[(c + 1) % 3]
        ki, kj = poly.index(i), poly.index(j)
        chain = [poly[(ki + m) % n] for m in range((kj - ki) % n + 1)]
        if len(chain) <= 2:
            continue
        for k, t in enumerate(tris):
            if any(t[m] == i and t[(m + 1) % 3] == j for m in range(3)):
                m = [t[x] for x in range(3)].index(i)
                opp = t[(m + 2) % 3]
                tris[k:k + 1] = [(p, q, opp) for p, q in zip(chain[:-1], chain[1:])]
                break
    return tris


_RINGS: dict = {}


def _ring(m: int) -> np.ndarray:
    """The segments (m, 2) of a closed polygon of m points: (k, k + 1 mod m), built once per m (read-only)."""
    seg = _RINGS.get(m)
    if seg is None:
        seg = np.column_stack([np.arange(m), (np.arange(m) + 1) % m])
        seg.setflags(write=False)
        _RINGS[m] = seg
    return seg


def _triang():
    """Triangle's core call (`triangle.core.triang`), imported on first use."""
    global _TRIANG
    if _TRIANG is None:
        from triangle.core import triang
        _TRIANG = triang
    return _TRIANG


_TRIANG = None


def _triangulate_polygon(V: np.ndarray, poly: list, corners: list) -> list:
    """Triangles filling a triangle whose edges carry inserted points (`poly`, in its orientation).

    A constrained Delaunay triangulation of the polygon in the triangle's plane
    (Triangle); where Triangle would add points or fails, fans edge by edge
    (`_sequential_fans`), so no inserted point is ever dropped.
    """
    poly = [p for k, p in enumerate(poly) if p != poly[k - 1]]
    n_extra = len(poly) - 3
    if n_extra <= 0:
        return [tuple(corners)]
    m = len(poly)
    if len(set(poly)) != m:
        return [tuple(corners)]
    P = V[poly]
    o = np.add.reduce(P, axis=0) / m          # P.mean(axis=0): the same sum and division
    # the plane's frame in scalars: the same operations as np.cross and np.linalg.norm (x.dot(x)) of
    # 3-vectors, so the same values, without their per-call overhead (one call per split triangle)
    p0, p1, p2 = V[corners[0]].tolist(), V[corners[1]].tolist(), V[corners[2]].tolist()
    a0, a1, a2 = p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]
    b0, b1, b2 = p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]
    nrm = np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])
    nrm /= max(math.sqrt(nrm.dot(nrm)), 1e-300)
    e1 = np.array([a0, a1, a2])
    e1 /= max(math.sqrt(e1.dot(e1)), 1e-300)
    (n0, n1, n2), (c0, c1, c2) = nrm.tolist(), e1.tolist()
    e2 = np.array([n1 * c2 - n2 * c1, n2 * c0 - n0 * c2, n0 * c1 - n1 * c0])
    d = P - o
    xy = np.empty((m, 2))
    xy[:, 0] = d @ e1           # (a matrix-vector product per polygon: BLAS, whose rounding a batch
    xy[:, 1] = d @ e2           # of other shapes need not repeat)
    # Triangle crashes (segmentation fault) on repeated vertices: fans instead
    rows = xy.tolist()
    xs, ys = [r[0] for r in rows], [r[1] for r in rows]
    if math.isfinite(math.fsum(xs) + math.fsum(ys)):
        # np.ptp(xy, axis=0).max() in scalars (max, min and one subtraction per axis: exact either way)
        scale = max(max(xs) - min(xs), max(ys) - min(ys))
    else:       # a nan (Python's max skips it, numpy's returns it) or an infinity: numpy's
        scale = float((xy.max(axis=0) - xy.min(axis=0)).max())
    if scale <= 0:
        return _sequential_fans(poly, corners)
    # np.round(xy / scale, 12) per value in scalars (x / scale, times 1e12, rounded half to even, over
    # 1e12: the same operations; |x / scale| <= 1, so the integer is exact): only compared (-0.0 == 0.0)
    if scale != scale or not math.isfinite(scale):
        r = np.round(xy / scale, 12).tolist()
    else:
        r = [(round(x / scale * 1e12) / 1e12, round(y / scale * 1e12) / 1e12) for x, y in rows]
    if len({(x, y) for x, y in r}) != m:         # (as np.unique(axis=0): -0.0 equals 0.0)
        return _sequential_fans(poly, corners)
    try:
        # `triangle.triangulate(.., "pQ")` without its dict renaming (the same call of Triangle)
        res, _ = _triang()({"pointlist": xy, "segmentlist": _ring(m)}, "QzpQ")
    except Exception:   # noqa: BLE001 - a degenerate polygon: fans
        return _sequential_fans(poly, corners)
    if len(res["pointlist"]) != m or "trianglelist" not in res:
        return _sequential_fans(poly, corners)
    out = []
    for t in res["trianglelist"].tolist():
        a, b, c = (poly[i] for i in t)
        if len({a, b, c}) == 3:
            out.append((a, b, c))
    return out


def _boundary(mesh: TriMesh):
    he = mesh.half_edges()
    inv = mesh.half_edge_edges()
    cnt = mesh.edge_triangle_counts()
    b = np.flatnonzero(cnt[inv] == 1)
    return he[b], b // 3           # directed boundary edges and their triangles


class _EdgeIndex:
    """The boundary edges' midpoints in k-d trees, one per class of edge lengths (within a factor of 4).

    `pairs(points, radius, eps)` are the (point, edge) pairs with the edge's midpoint within `radius`
    of the point that can be within `eps` of it (every such pair is found): per class the ball is
    the class's longest half-length + eps, or `radius` when that is not smaller. Among the pairs
    within `eps` these are exactly those of one tree queried with `radius` (a few long edges no longer
    make every point a candidate of every edge near it), in the same order (point, then edge).
    """

    def __init__(self, a: np.ndarray, b: np.ndarray):
        self.mid = 0.5 * (a + b)
        length = np.linalg.norm(b - a, axis=1)
        cls = np.floor(np.log2(np.maximum(length, 1e-300)) / 2.0).astype(np.int64)
        order = np.argsort(cls, kind="stable")
        cuts = np.flatnonzero(np.diff(cls[order])) + 1
        self.groups = [(g, 0.5 * float(length[g].max()), cKDTree(self.mid[g])) for g in np.split(order, cuts)]

    def pairs(self, points: np.ndarray, radius: float, eps: float) -> tuple[np.ndarray, np.ndarray]:
        ptree = cKDTree(points)
        pi, ei = [], []
        for g, half, tree in self.groups:
            r = (half + eps) * (1.0 + 1e-9) + 1e-300
            r = radius if r >= radius * (1.0 - 1e-9) else r
            hit = tree.sparse_distance_matrix(ptree, r, output_type="ndarray")
            if len(hit):
                pi.append(hit["j"].astype(np.int64))
                ei.append(g[hit["i"]])
        if not pi:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        pi, ei = np.concatenate(pi), np.concatenate(ei)
        # np.lexsort((ei, pi)) as one key per pair (each pair once: the classes split the edges)
        order = np.argsort(pi * len(self.mid) + ei)
        return pi[order], ei[order]


def _first_min(pi: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Per run of equal `pi` (sorted), the index of its smallest `d`, the first of equal ones: what
    ``order = np.lexsort((d, pi)); order[np.r_[True, pi[order][1:] != pi[order][:-1]]]`` selects (without
    the sort; that sort where `d` holds a nan)."""
    if np.isnan(d).any():
        order = np.lexsort((d, pi))
        return order[np.r_[True, pi[order][1:] != pi[order][:-1]]]
    start = np.flatnonzero(np.r_[True, pi[1:] != pi[:-1]])
    low = np.minimum.reduceat(d, start)
    at = np.flatnonzero(d == np.repeat(low, np.diff(np.r_[start, len(d)])))
    return at[np.r_[True, pi[at[1:]] != pi[at[:-1]]]]


def _closest_edges(points, vfaces, edges_a, edges_b, edge_face, tree, radius, eps, *, same_face: bool,
                   point_vertex=None, bedges=None):
    """For each point, the closest boundary edge of another face (or of its own faces) within eps.

    Parameters
    ----------
    vfaces : (p, k) int64
        The faces each point belongs to (the faces of the boundary edges at a
        boundary vertex: two after an earlier stitch pass merged faces there).
    point_vertex : (p,) int64 or None
        The mesh vertex of each point; with `bedges`, edges at that vertex are never
        candidates of the other-face search (after a first pass a vertex is shared
        by two faces, and its own edges would be found at distance 0).
    """
    if not len(points):
        return np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0)
    pi, ei = tree.pairs(points, radius, eps)
    if not len(pi):
        return np.full(len(points), -1), np.full(len(points), np.inf), np.zeros(len(points))
    own = (edge_face[ei][:, None] == vfaces[pi]).any(axis=1)
    keep = own if same_face else ~own
    if not same_face and point_vertex is not None:
        keep &= (bedges[ei, 0] != point_vertex[pi]) & (bedges[ei, 1] != point_vertex[pi])
    pi, ei = pi[keep], ei[keep]
    if not len(pi):
        return np.full(len(points), -1), np.full(len(points), np.inf), np.zeros(len(points))
    d, t = _point_segment(points[pi], edges_a[ei], edges_b[ei])
    best = np.full(len(points), -1, dtype=np.int64)
    bd = np.full(len(points), np.inf)
    bt = np.zeros(len(points))
    sel = _first_min(pi, d)
    ok = d[sel] <= eps
    best[pi[sel][ok]] = ei[sel][ok]
    bd[pi[sel][ok]] = d[sel][ok]
    bt[pi[sel][ok]] = t[sel][ok]
    return best, bd, bt


def stitch_mesh(mesh: TriMesh, eps: float, tri_dev=None, *, tolerance: float | None = None,
                return_origin: bool = False, corner_uv=None, near=None):
    """Stitch the face boundaries of a mesh with ``face_id`` within distance `eps` (paper Sec. 5.2).

    Parameters
    ----------
    mesh : TriMesh
        With ``face_id``.
    eps : float
        The paper's epsilon: largest distance bridged (model units).
    tri_dev : (m,) float64 or None
        Per-triangle deviation bound, carried through (raised by how far a triangle's corners move).
    tolerance : float or None
        Also bridge gaps wider than `eps` (up to `tolerance`) where the deviation bounds of the
        triangles that bend or move stay within `tolerance`.
    corner_uv : (m, 3, 2) float64 or None
        The (u, v) of every triangle corner on its face, carried through: a point inserted on
        an edge gets the (u, v) at its parameter along the edge. Given, the result is
        ``(mesh, info, dev, origin, corner_uv)``.
    near : ((k, 3) float64, float) or None
        Only boundary vertices within the given distance of one of the points are stitched
        (a local repair); None: all.

    Returns
    -------
    (TriMesh, dict, (m',) float64)
        The stitched mesh (vertices merged, T-junctions split), counts
        ``stitch_merged``, ``stitch_split``, ``stitch_rejected_checkback``, and the deviation bounds
        (with ``return_origin``, also the input index of every output triangle, -1 for new ones).
    """
    dev = np.zeros(mesh.n_triangles) if tri_dev is None else np.asarray(tri_dev, dtype=np.float64).copy()
    cuv = None if corner_uv is None else np.asarray(corner_uv, dtype=np.float64)
    V = mesh.vertices.copy()
    T = mesh.triangles.copy()
    fid = mesh.face_id
    bedges, btri = _boundary(mesh)
    info = {"stitch_merged": 0, "stitch_split": 0, "stitch_rejected_checkback": 0}
    if not len(bedges):
        if cuv is not None:
            return mesh, info, dev, np.arange(mesh.n_triangles), cuv
        if return_origin:
            return mesh, info, dev, np.arange(mesh.n_triangles)
        return mesh, info, dev
    a, b = V[bedges[:, 0]], V[bedges[:, 1]]
    efac = fid[btri]
    r_max = float(np.linalg.norm(b - a, axis=1).max())
    tree = _EdgeIndex(a, b)
    reach = eps if tolerance is None else max(eps, float(tolerance))
    radius = 0.5 * r_max + reach
    bverts = np.unique(bedges)
    if near is not None:
        d_near, _ = cKDTree(np.asarray(near[0], dtype=np.float64)).query(V[bverts])
        bverts = bverts[d_near <= near[1]]
    # the faces of each boundary vertex: those of its outgoing and incoming boundary edges (one face
    # before stitching; two where an earlier pass merged the corners of two faces)
    vfaces = np.full((len(V), 2), -1, dtype=np.int64)      # -1: no boundary edge that way
    vfaces[bedges[:, 0], 0] = efac
    vfaces[bedges[:, 1], 1] = efac
    pts = V[bverts]
    ec, dist, t = _closest_edges(pts, vfaces[bverts], a, b, efac, tree, radius, reach, same_face=False,
                                 point_vertex=bverts, bedges=bedges)
    has = ec >= 0
    vi, ec, t, dist = bverts[has], ec[has], t[has], dist[has]
    # check-back: from v_p, the closest boundary edge of v's own faces must be an edge at v
    vp = a[ec] + t[:, None] * (b[ec] - a[ec])
    back, _, _ = _closest_edges(vp, vfaces[vi], a, b, efac, tree, radius, max(reach, 1e-300) * 2.0,
                                same_face=True)
    ok_back = (back >= 0) & ((bedges[np.maximum(back, 0), 0] == vi) | (bedges[np.maximum(back, 0), 1] == vi))
    # ... and for a split, no face narrower than eps may lie between v and e_c, nearer to v_p than v
    # (its two sides are v's and e_c's true partners): a third face with one edge nearer to v_p than v
    # and another running back along it within eps of v_p. Merges at the ends of e_c are exempt.
    length = np.linalg.norm(b[ec] - a[ec], axis=1)
    inner = (t * length > eps) & ((1.0 - t) * length > eps)
    excl = np.column_stack([vfaces[vi], efac[ec]])
    e3, d3, _ = _closest_edges(vp, excl, a, b, efac, tree, radius, reach, same_face=False,
                               point_vertex=vi, bedges=bedges)
    cand = np.flatnonzero(inner & (e3 >= 0) & (d3 < dist))
    if len(cand):
        thin = np.zeros(len(cand), dtype=bool)
        c_pi, c_ei = tree.pairs(vp[cand], radius, eps)
        c_at = np.searchsorted(c_pi, np.arange(len(cand) + 1))
        lists = [c_ei[c_at[r]:c_at[r + 1]] for r in range(len(cand))]
        for r, (k, js) in enumerate(zip(cand.tolist(), lists)):
            j3 = int(e3[k])
            js = np.asarray(js, dtype=np.int64)
            js = js[(efac[js] == efac[j3]) & (js != j3)]
            if len(js):
                # the face's other side: running back (antiparallel within 30 degrees) within eps
                d3v = (b[j3] - a[j3]) / max(float(np.linalg.norm(b[j3] - a[j3])), 1e-300)
                dj = (b[js] - a[js]) / np.maximum(np.linalg.norm(b[js] - a[js], axis=1), 1e-300)[:, None]
                js = js[dj @ d3v < -0.866]
            if len(js):
                dd, _ = _point_segment(np.repeat(vp[[k]], len(js), axis=0), a[js], b[js])
                thin[r] = dd.min() <= eps
        ok_back[cand[thin]] = False
    # ... and a split must not make an edge the mesh already has between two triangles (v shared by
    # two faces after a first pass, inserted into a third face's edge: a non-manifold edge)
    inner_edges = mesh.edges()[mesh.edge_triangle_counts() >= 2]
    nv1 = len(V) + 1
    ikeys = np.sort(inner_edges[:, 0] * nv1 + inner_edges[:, 1])

    def _exists(x, y):
        k = np.minimum(x, y) * nv1 + np.maximum(x, y)
        pos = np.minimum(np.searchsorted(ikeys, k), max(len(ikeys) - 1, 0))
        return (ikeys[pos] == k) if len(ikeys) else np.zeros(len(k), dtype=bool)
    twice = _exists(vi, bedges[ec, 0]) | _exists(vi, bedges[ec, 1])
    ok_back &= ~(inner & twice)
    info["stitch_rejected_checkback"] = int(np.count_nonzero(~ok_back))
    vi, ec, t, dist = vi[ok_back], ec[ok_back], t[ok_back], dist[ok_back]
    length = np.linalg.norm(b[ec] - a[ec], axis=1)
    near_a = t * length <= eps
    near_b = ((1.0 - t) * length <= eps) & ~near_a
    if tolerance is not None:
        # beyond eps only while the triangles that bend (split) or move (merge) keep their deviation
        # bound within the tolerance: the gap between one face's chord and the other's points on the
        # curved edge is up to the faces' own tolerance plus the model's gap
        vdev = np.zeros(len(V))
        np.maximum.at(vdev, T.ravel(), np.repeat(dev, 3))
        end = np.where(near_a, bedges[ec, 0], bedges[ec, 1])
        dm = np.linalg.norm(V[vi] - V[end], axis=1)
        fits = np.where(near_a | near_b, np.maximum(vdev[vi], vdev[end]),
                        np.maximum(vdev[vi], dev[btri[ec]])) + 0.5 * np.where(near_a | near_b, dm, dist) <= tolerance
        ok = (dist <= eps) | fits
        info["stitch_rejected_deviation"] = int(np.count_nonzero(~ok))
        vi, ec, t, dist, near_a, near_b = vi[ok], ec[ok], t[ok], dist[ok], near_a[ok], near_b[ok]
    # merge v with the near end of e_c
    pairs = np.r_[np.column_stack([vi[near_a], bedges[ec[near_a], 0]]),
                  np.column_stack([vi[near_b], bedges[ec[near_b], 1]])]
    info["stitch_merged"] = int(len(pairs))
    moved = np.zeros(len(V))
    label = None
    if len(pairs):
        # merged ends meet at the mean of their group (a pair: half-way, each face moves by half the
        # distance); a vertex in several pairs joins one group, so every member ends at one point
        n = len(V)
        g = sparse.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        _, label = csgraph.connected_components(g, directed=False)
        size = np.bincount(label)
        grouped = size[label] > 1
        mean = np.zeros((len(size), 3))
        np.add.at(mean, label[grouped], V[grouped])
        mean /= np.maximum(size, 1)[:, None]
        newpos = mean[label[grouped]]
        moved[grouped] = np.linalg.norm(newpos - V[grouped], axis=1)
        V[grouped] = newpos
    # split e_c at v (the others); a gap wider than eps is closed from both sides: v moves half-way
    # to its foot on e_c (its triangles' bound rises by half the gap, so does that of e_c's triangle)
    split = ~(near_a | near_b)
    s_v, s_e, s_t = vi[split], ec[split], t[split]
    wide = (dist[split] > eps) & (moved[s_v] == 0)
    if np.any(wide):
        w_v = s_v[wide]
        foot = a[s_e[wide]] + s_t[wide, None] * (b[s_e[wide]] - a[s_e[wide]])
        half = 0.5 * (foot - V[w_v])
        moved[w_v] = np.linalg.norm(half, axis=1)
        V[w_v] += half
    dev = dev + moved[T].max(axis=1)
    s_d = np.linalg.norm(V[s_v] - (a[s_e] + s_t[:, None] * (b[s_e] - a[s_e])), axis=1)
    new_tris, new_dev, new_uv, drop = [], [], [], np.zeros(len(T), dtype=bool)
    if len(s_v):
        # the points inserted on each boundary edge, in order, grouped by triangle
        order = np.lexsort((s_t, s_e))
        s_v, s_e, s_t, s_d = s_v[order], s_e[order], s_t[order], s_d[order]
        starts = np.r_[0, np.flatnonzero(np.diff(s_e)) + 1, len(s_e)]
        per_tri: dict = {}
        # per split edge: its triangle, ends, inserted points and parameters (lists), largest distance
        cut = starts.tolist()
        sv_l, st_l = s_v.tolist(), s_t.tolist()
        e_first = s_e[starts[:-1]]
        e_tri, e_a, e_b = btri[e_first].tolist(), bedges[e_first, 0].tolist(), bedges[e_first, 1].tolist()
        e_max = np.maximum.reduceat(s_d, starts[:-1]).tolist()     # each slice's max (a nan stays)
        for k in range(len(cut) - 1):
            per_tri.setdefault(e_tri[k], []).append((e_a[k], e_b[k], sv_l[cut[k]:cut[k + 1]], e_max[k],
                                                     st_l[cut[k]:cut[k + 1]]))
        tris = list(per_tri)
        drop[tris] = True
        rows, dev_l = T[tris].tolist(), dev[tris].tolist()
        uv_rows = cuv[tris].tolist() if cuv is not None else None
        for r, (tri, splits) in enumerate(per_tri.items()):
            corners = rows[r]
            inserted = {(i, j): pts for i, j, pts, _, _ in splits}
            bend = max(sp[3] for sp in splits)
            if cuv is not None:
                # (u, v) on this face: the corners' own, an inserted point's along its edge (in scalars:
                # the same operations per coordinate as on the (2,) arrays)
                uv_of = {x: tuple(uv_rows[r][c]) for c, x in enumerate(corners)}
                for i, j, pts, _, ts in splits:
                    (ui, vi), (uj, vj) = uv_of[i], uv_of[j]
                    for x, tx in zip(pts, ts):
                        uv_of[x] = (ui + tx * (uj - ui), vi + tx * (vj - vi))
            # the triangle's boundary polygon with the inserted points, in its own orientation
            poly = []
            for c in range(3):
                i, j = corners[c], corners[(c + 1) % 3]
                poly.append(i)
                poly.extend(inserted.get((i, j), []))
            for t in _triangulate_polygon(V, poly, corners):
                new_tris.append((*t, tri))
                new_dev.append(dev_l[r] + bend)
                if cuv is not None:
                    new_uv.append([uv_of[x] for x in t])
        info["stitch_split"] = int(len(s_v))
    keep = ~drop
    origin = np.flatnonzero(keep)
    if new_tris:
        nt = np.array(new_tris, dtype=np.int64)
        T = np.concatenate([T[keep], nt[:, :3]])
        fid = np.concatenate([fid[keep], fid[nt[:, 3]]])
        dev = np.concatenate([dev[keep], np.asarray(new_dev)])
        origin = np.r_[origin, np.full(len(nt), -1, dtype=np.int64)]
        if cuv is not None:
            cuv = np.concatenate([cuv[keep], np.asarray(new_uv, dtype=np.float64).reshape(-1, 3, 2)])
    else:
        T, fid, dev = T[keep], fid[keep], dev[keep]
        if cuv is not None:
            cuv = cuv[keep]
    # merge vertex pairs (union of the "same vertex" graph); the kept vertex is the lowest index
    if label is not None:
        n = len(V)
        rep = np.full(label.max() + 1, n, dtype=np.int64)
        np.minimum.at(rep, label, np.arange(n))
        T = rep[label][T]
    ok = (T[:, 0] != T[:, 1]) & (T[:, 1] != T[:, 2]) & (T[:, 0] != T[:, 2])
    T, fid, dev, origin = T[ok], fid[ok], dev[ok], origin[ok]
    used, inv = compact_indices(T, len(V))             # (np.unique(T, return_inverse=True))
    if cuv is not None:
        return TriMesh(V[used], inv.reshape(-1, 3), face_id=fid), info, dev, origin, cuv[ok]
    if return_origin:
        return TriMesh(V[used], inv.reshape(-1, 3), face_id=fid), info, dev, origin
    return TriMesh(V[used], inv.reshape(-1, 3), face_id=fid), info, dev


def merge_face_meshes(face_meshes: dict, *, tolerance: float, stitch: bool = True, reduce_seams: bool = True,
                      max_edge: float = np.inf, faces=None) -> tuple[TriMesh, dict]:
    """Concatenate face meshes (with face_id), stitch their boundaries, reduce the seams.

    Parameters
    ----------
    face_meshes : dict of FaceMesh
        Tessellated within ``tolerance / 2``.
    tolerance : float
        Stitching bridges gaps up to ``tolerance / 2`` and keeps every triangle's
        deviation bound within `tolerance`.
    faces : sequence of TrimmedFace or None
        Indexed by face id. Given, every triangle corner's (u, v) on its face is carried
        through stitching, and seam reduction evaluates the collapsed triangles on the
        surfaces and removes triangles flipped against the surface normal
        (`seams.reduce_seams`); else it bounds deviations by the corner shifts.

    Returns
    -------
    (TriMesh, dict)
        The merged mesh and the stitching figures (``triangles_unstitched``,
        ``triangles_stitched``, merge / split counts, seam collapses).
    """
    from ..quality.topology import weld_vertices

    verts, tris, fids, devs, quads, cuvs = [], [], [], [], [], []
    off = toff = 0
    for i in sorted(face_meshes):
        fm = face_meshes[i]
        verts.append(fm.xyz)
        tris.append(fm.triangles + off)
        fids.append(np.full(len(fm.triangles), i, dtype=np.int64))
        devs.append(fm.tri_dev)
        cuvs.append(fm.uv[fm.triangles])
        if len(fm.quads):
            quads.append(fm.quads + toff)
        off += len(fm.xyz)
        toff += len(fm.triangles)
    q = np.concatenate(quads).astype(np.int64) if quads else np.zeros((0, 2), dtype=np.int64)

    def remap(q, n_before, index_of_old):
        """Quads through a stage: index_of_old (n_before,) new index or -1."""
        if not len(q):
            return q
        q = index_of_old[q]
        return q[(q >= 0).all(axis=1)]
    mesh = TriMesh(np.concatenate(verts), np.concatenate(tris), face_id=np.concatenate(fids))
    dev = np.concatenate(devs)
    cuv = np.concatenate(cuvs) if faces is not None else None
    info: dict = {"triangles_unstitched": mesh.n_triangles}
    # vertices that coincide exactly (a face's own seam, poles) are one vertex
    w = weld_vertices(mesh, 1e-9 * tolerance)
    keep = np.ones(mesh.n_triangles, dtype=bool)
    keep[w.dropped_triangles] = False
    q = remap(q, mesh.n_triangles, np.where(keep, np.cumsum(keep) - 1, -1))
    mesh, dev = w.mesh, dev[keep]
    if cuv is not None:
        cuv = cuv[keep]
    if stitch:
        # a second pass catches vertices whose closest edge was split in the first; a third, those whose
        # edge got its ends from two other faces' merges in the second (U_Joint's five-face corners)
        for p in range(3):
            if p == 2 and not len(mesh.boundary_edges()):
                break
            n_before = mesh.n_triangles
            out = stitch_mesh(mesh, 0.5 * tolerance, dev, tolerance=tolerance, return_origin=True,
                              corner_uv=cuv)
            mesh, st, dev, origin = out[:4]
            if cuv is not None:
                cuv = out[4]
            index = np.full(n_before, -1, dtype=np.int64)
            index[origin[origin >= 0]] = np.flatnonzero(origin >= 0)
            q = remap(q, n_before, index)
            for k, v in st.items():
                info[k] = info.get(k, 0) + v
    info["triangles_stitched"] = mesh.n_triangles
    flipped = None
    if stitch and reduce_seams:
        from .seams import reduce_seams as _reduce

        n_before = mesh.n_triangles
        kw = {} if cuv is None else {"corner_uv": cuv, "faces": faces,
                                     "surfaces": [None if f is None else f.surface for f in faces]}
        mesh, n, alive, dev, cuv, flipped = _reduce(mesh, tolerance, tri_dev=dev, max_edge=max_edge,
                                                    return_kept=True, return_state=True, return_flipped=True, **kw)
        q = remap(q, n_before, np.where(alive, np.cumsum(alive) - 1, -1))
        info["seam_collapses"] = n
    if stitch and cuv is not None and faces is not None:
        # folds left where a face is narrower than the stitching distance: removed and stitched across
        pruned = _prune_folds(mesh, dev, cuv, q, faces, tolerance, flipped=flipped)
        if pruned is not None:
            mesh, dev, cuv, q, n_pruned = pruned
            info["stitch_folds_pruned"] = n_pruned
    info["quads"] = q
    return mesh, info


def _fold_triangles(mesh: TriMesh, cuv, faces, among=None) -> np.ndarray:
    """Triangles of a face folded over by stitching: flipped against the face's oriented normal, or two
    of one face's triangles on one non-manifold edge (a neck of the face narrower than the stitching
    distance, both its sides stitched onto one neighbour).

    `among`: the only triangles that can be flipped at their (u, v) centroid, e.g. those flipped at
    their centroid or a corner (`reduce_seams`'s ``return_flipped``); the test is per triangle."""
    from .seams import _against_normal, _normals

    # at the (u, v) centroid, as the measure module counts flips (the corners are stricter: a pole)
    centroid = np.array([[1 / 3, 1 / 3, 1 / 3]])
    if among is None:
        bad = _against_normal(faces, mesh.face_id, cuv, _normals(mesh.vertices, mesh.triangles), bary=centroid)
    else:
        bad = np.zeros(mesh.n_triangles, dtype=bool)
        if len(among):
            bad[among] = _against_normal(faces, mesh.face_id[among], cuv[among],
                                         _normals(mesh.vertices, mesh.triangles[among]), bary=centroid)
    counts = mesh.edge_triangle_counts()
    if np.any(counts > 2):
        inv = mesh.half_edge_edges()
        tri = np.arange(3 * mesh.n_triangles) // 3
        for e in np.flatnonzero(counts > 2).tolist():
            t = tri[inv == e]
            f = mesh.face_id[t]
            _, first, cnt = np.unique(f, return_index=True, return_counts=True)
            if np.all(cnt == 2):
                continue            # coincident faces (two touching solids' interface): not a fold
            for k in np.flatnonzero(cnt > 1):
                bad[t[f == f[first[k]]]] = True
    return np.flatnonzero(bad)


def _prune_folds(mesh: TriMesh, dev, cuv, q, faces, tolerance: float, flipped=None):
    """Remove thin folded triangles (`_fold_triangles`) and stitch the hole they leave; kept only if better.

    Where a face is narrower than the stitching distance (the turbine's face 1 at the point where its
    hole touches its outer trim), both its sides get stitched onto one neighbour and its triangles fold.
    Without them, the neighbours across the neck are within the stitching distance of each other and
    stitch directly. The result is kept only when it has no more boundary or non-manifold edges and
    fewer folded triangles, the triangles stitching made are not flipped (at their (u, v) centroid or a
    corner) and keep their deviation bound within the tolerance, and the removed triangles' surface
    points (corners, edge midpoints, centroid) lie within the tolerance of the result; else None.
    """
    from ..quality.closest_point import closest_points_on_mesh
    from ..quality.sampling import sample_face_domain
    from .seams import _BARY, _against_normal, _normals

    # (`flipped`: per triangle, flipped at its centroid or a corner; only those can be at the centroid)
    bad = _fold_triangles(mesh, cuv, faces, among=None if flipped is None else np.flatnonzero(flipped))
    # only thin ones: every point of a removed triangle within the stitching distance of its edges
    # (inradius 2 area / perimeter), so the neighbours stitched across it stay within the tolerance
    p = mesh.vertices[mesh.triangles[bad]]
    area2 = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    perimeter = np.linalg.norm(p - np.roll(p, 1, axis=1), axis=2).sum(axis=1)
    bad = bad[area2 <= 0.5 * tolerance * perimeter]
    if not len(bad):
        return None
    n_b0, n_nm0 = len(mesh.boundary_edges()), len(mesh.non_manifold_edges())
    n_bad0 = len(_fold_triangles(mesh, cuv, faces))
    keep = np.ones(mesh.n_triangles, dtype=bool)
    keep[bad] = False
    hole = mesh.vertices[np.unique(mesh.triangles[bad])]     # only the hole's vertices are stitched
    index = np.where(keep, np.cumsum(keep) - 1, -1)
    used, inv = compact_indices(mesh.triangles[keep], mesh.n_vertices)     # (np.unique(.., return_inverse=True))
    m = TriMesh(mesh.vertices[used], inv.reshape(-1, 3), face_id=mesh.face_id[keep])
    d, c = dev[keep], cuv[keep]
    new = np.zeros(m.n_triangles, dtype=bool)
    qq = index[q] if len(q) else q
    qq = qq[(qq >= 0).all(axis=1)] if len(qq) else qq
    for _ in range(2):
        if not len(m.boundary_edges()):
            break
        n_before = m.n_triangles
        m, _, d, origin, c = stitch_mesh(m, 0.5 * tolerance, d, tolerance=tolerance, corner_uv=c,
                                         near=(hole, tolerance))
        idx = np.full(n_before, -1, dtype=np.int64)
        idx[origin[origin >= 0]] = np.flatnonzero(origin >= 0)
        new = np.where(origin >= 0, new[np.maximum(origin, 0)], True)
        if len(qq):
            qq = idx[qq]
            qq = qq[(qq >= 0).all(axis=1)]
    if (len(m.boundary_edges()) > n_b0 or len(m.non_manifold_edges()) > n_nm0
            or len(_fold_triangles(m, c, faces)) >= n_bad0):
        return None
    if np.any(new) and (np.any(d[new] > tolerance)
                        or np.any(_against_normal(faces, m.face_id[new], c[new], _normals(m.vertices, m.triangles[new])))):
        return None
    # each face of the removed triangles stays covered by its own triangles (as the measure module
    # counts): its removed triangles' surface points and a sampling of its trimmed domain
    fb = mesh.face_id[bad]
    for f in np.unique(fb).tolist():
        own = m.face_id == f
        if not np.any(own):
            return None
        uv = np.einsum("bj,rjk->rbk", np.r_[_BARY, np.eye(3)], cuv[bad[fb == f]]).reshape(-1, 2)
        pts = np.concatenate([faces[f].surface.evaluate(uv), faces[f].surface.evaluate(sample_face_domain(faces[f], n=32))])
        if float(closest_points_on_mesh(pts, m.submesh(own)).distance.max()) > tolerance:
            return None
    return m, d, c, qq, int(len(bad))
