"""A planar straight-line graph Triangle always finishes on.

Shewchuk's Triangle computes the crossing point of two crossing constraint
segments in floating point and inserts it; when the segments meet at a tiny
angle, or their endpoints nearly coincide, the inserted point misses both lines,
the split pieces cross again, and the insertion never ends (the turbine blade of
issue 16: two trim points 7e-16 apart in a planar face, one of the hole's loop
and one of the outer loop, and Triangle spinning for hours on 308 points).
Without crossings Triangle only flips edges and splits a segment at a vertex
lying exactly on it, which ends: `clean_pslg` hands it such a graph.

1. Vertices closer than `eps` merge (the first of each cluster stays).
2. A vertex within `eps` of a segment it is not an end of splits the segment.
3. Segments that still cross (exact `orient2d`, the same signs Triangle sees)
   are split at their crossing point, computed here; steps 1-3 repeat until no
   crossing is left (a few rounds), else `TrimLoopError`.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from .._numba_load import install as _install_lazy_bitcode
from ..errors import TrimLoopError
from ..geom.predicates import _CCW_BOUND, _may_cross, orient2d

_install_lazy_bitcode()     # before this module's kernels load (trimsurf._numba_load)

__all__ = ["clean_pslg", "crossing_segments"]

#: rounds of merge / split / cut before giving up
_ROUNDS = 8


def _length_classes(length: np.ndarray) -> list:
    """Segment indices grouped by length within a factor of 4 (so each group's search radius fits it)."""
    cls = np.floor(np.log2(np.maximum(length, 1e-300)) / 2.0).astype(np.int64)
    order = np.argsort(cls, kind="stable")
    cuts = np.flatnonzero(np.diff(cls[order])) + 1
    return np.split(order, cuts)


def _merge(q: np.ndarray, seg: np.ndarray, eps: float):
    """Representative (lowest index) of each vertex within `eps` of another; segments renumbered, degenerate
    and repeated ones dropped."""
    n = len(q)
    rep = np.arange(n)
    pairs = cKDTree(q).query_pairs(eps, output_type="ndarray")
    if len(pairs):
        g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        _, label = connected_components(g, directed=False)
        first = np.full(label.max() + 1, n, dtype=np.int64)
        np.minimum.at(first, label, np.arange(n))
        rep = first[label]
    seg = rep[seg]
    seg = seg[seg[:, 0] != seg[:, 1]]
    return rep, _unique_segments(seg)


def _unique_segments(seg: np.ndarray) -> np.ndarray:
    """np.unique(np.sort(seg, axis=1), axis=0) of non-negative indices, by one int64 key per segment."""
    if not len(seg):
        return seg.reshape(0, 2)
    lo, hi = np.minimum(seg[:, 0], seg[:, 1]), np.maximum(seg[:, 0], seg[:, 1])
    n = int(hi.max()) + 1
    if lo.min() < 0 or n > (1 << 31):
        return np.unique(np.sort(seg, axis=1), axis=0)
    key = np.unique(lo.astype(np.int64) * n + hi)
    return np.column_stack([key // n, key % n]).astype(seg.dtype, copy=False)


def _vertex_segment_pairs(q: np.ndarray, seg: np.ndarray, vertices: np.ndarray, eps: float):
    """(segment, vertex, t) for vertices within `eps` of a segment they are not an end of; t its parameter."""
    a, b = q[seg[:, 0]], q[seg[:, 1]]
    d = b - a
    length = np.linalg.norm(d, axis=1)
    mid = 0.5 * (a + b)
    vtree = cKDTree(q[vertices])
    rows = []
    for group in _length_classes(length):
        r = 0.5 * float(length[group].max()) + eps
        hit = cKDTree(mid[group]).sparse_distance_matrix(vtree, r, output_type="ndarray")
        if len(hit):
            rows.append(np.column_stack([group[hit["i"]], vertices[hit["j"]]]))
    if not rows:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0)
    s, v = np.concatenate(rows).T
    keep = (seg[s, 0] != v) & (seg[s, 1] != v)
    s, v = s[keep], v[keep]
    w = q[v] - a[s]
    t = np.einsum("nd,nd->n", w, d[s]) / np.maximum(length[s] ** 2, 1e-300)
    t = np.clip(t, 0.0, 1.0)
    dist = np.linalg.norm(w - t[:, None] * d[s], axis=1)
    near = (dist < eps) & (t > 0.0) & (t < 1.0)
    return s[near], v[near], t[near]


def _split(seg: np.ndarray, s: np.ndarray, v: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Segments `s` split at vertices `v` (in the order of their parameters `t`); the others kept."""
    if not len(s):
        return seg
    hit = np.unique(s)
    rows_s = np.r_[hit, hit, s]
    rows_v = np.r_[seg[hit, 0], seg[hit, 1], v]
    rows_t = np.r_[np.zeros(len(hit)), np.ones(len(hit)), t]
    order = np.lexsort((rows_t, rows_s))
    rows_s, rows_v = rows_s[order], rows_v[order]
    same = rows_s[:-1] == rows_s[1:]
    pieces = np.column_stack([rows_v[:-1][same], rows_v[1:][same]])
    keep = np.ones(len(seg), dtype=bool)
    keep[hit] = False
    out = np.concatenate([seg[keep], pieces])
    return _unique_segments(out[out[:, 0] != out[:, 1]])


def _candidate_segment_pairs(q: np.ndarray, seg: np.ndarray) -> np.ndarray:
    """Pairs (i < j) of segments whose bounding circles meet and whose boxes meet (closed boxes): the pairs of
    `_candidate_segment_pairs_kdtree` that `crossing_segments` keeps past its box test, found by a compiled
    bucket grid (`_box_pairs_kernel`) and the same circle test in numpy (the same numbers), in the same
    (sorted) order.

    The circle test's pairs the k-d trees find are those within the radius of the longer one's length class
    (r >= the sum of the two radii), so a pair the circle test keeps is within r of each other; one only the
    k-d trees' rounding could leave out lies at distance r = the sum of the radii, its circles touching, its
    segments meeting at most at their ends: never a proper crossing (argued, not proven to the last bit)."""
    if not _BOX_PAIRS or not np.all(np.isfinite(q)):
        return _candidate_segment_pairs_kdtree(q, seg)
    p = _box_pairs_kernel(np.ascontiguousarray(q), np.ascontiguousarray(seg))
    if not len(p):
        return np.zeros((0, 2), dtype=np.int64)
    a, b = q[seg[:, 0]], q[seg[:, 1]]
    length = np.linalg.norm(b - a, axis=1)
    mid = 0.5 * (a + b)
    i, j = p[:, 0], p[:, 1]
    near = np.linalg.norm(mid[i] - mid[j], axis=1) <= 0.5 * (length[i] + length[j]) + 1e-300
    key = np.sort(i[near] * len(seg) + j[near])           # (each pair once: np.unique(p, axis=0)'s order)
    return np.column_stack([key // len(seg), key % len(seg)])


#: `_candidate_segment_pairs` by the compiled box pairs (False: the k-d trees, as before; the tests compare both)
_BOX_PAIRS = True


def _candidate_segment_pairs_kdtree(q: np.ndarray, seg: np.ndarray) -> np.ndarray:
    """Pairs (i < j) of segments whose bounding circles meet (k-d trees per length class)."""
    a, b = q[seg[:, 0]], q[seg[:, 1]]
    length = np.linalg.norm(b - a, axis=1)
    mid = 0.5 * (a + b)
    groups = _length_classes(length)          # shortest first
    out = []
    for k, gk in enumerate(groups):
        # class k against itself and every shorter class: within the sum of the radii, at most 2 r_k
        shorter = np.concatenate(groups[:k + 1])
        r = float(length[gk].max()) + 1e-300
        hit = cKDTree(mid[gk]).sparse_distance_matrix(cKDTree(mid[shorter]), r, output_type="ndarray")
        if len(hit):
            i, j = gk[hit["i"]], shorter[hit["j"]]
            near = np.linalg.norm(mid[i] - mid[j], axis=1) <= 0.5 * (length[i] + length[j]) + 1e-300
            out.append(np.column_stack([i[near], j[near]]))
    if not out:
        return np.zeros((0, 2), dtype=np.int64)
    p = np.sort(np.concatenate(out), axis=1)
    p = p[p[:, 0] != p[:, 1]]
    return np.unique(p, axis=0) if len(p) else p.reshape(0, 2)


@njit(cache=True, nogil=True)
def _box_pairs_kernel(q, seg):
    """Every pair (i < j) of segments whose closed boxes meet (min <= max on both axes), each once, in no
    particular order: a bucket grid over the boxes, a pair reported in the bucket of its boxes' common
    corner (the larger of the two minima on each axis). Finite points."""
    m = seg.shape[0]
    if m < 2:
        return np.zeros((0, 2), dtype=np.int64)
    x0, y0, x1, y1 = np.inf, np.inf, -np.inf, -np.inf
    for k in range(m):
        for e in range(2):
            v = seg[k, e]
            x0 = min(x0, q[v, 0])
            y0 = min(y0, q[v, 1])
            x1 = max(x1, q[v, 0])
            y1 = max(y1, q[v, 1])
    g = max(1, int(np.sqrt(m)))
    while True:
        hx, hy = (x1 - x0) / g, (y1 - y0) / g
        if not hx > 0:
            hx = 1.0
        if not hy > 0:
            hy = 1.0
        total = 0
        for k in range(m):
            a, b = seg[k, 0], seg[k, 1]
            ia, ib = _bucket_range(min(q[a, 0], q[b, 0]), max(q[a, 0], q[b, 0]), x0, hx, g)
            ja, jb = _bucket_range(min(q[a, 1], q[b, 1]), max(q[a, 1], q[b, 1]), y0, hy, g)
            total += (ib - ia + 1) * (jb - ja + 1)
        if g == 1 or total <= 8 * m:
            break
        g = max(1, g // 2)
    cnt = np.zeros(g * g + 1, dtype=np.int64)
    for k in range(m):
        a, b = seg[k, 0], seg[k, 1]
        ia, ib = _bucket_range(min(q[a, 0], q[b, 0]), max(q[a, 0], q[b, 0]), x0, hx, g)
        ja, jb = _bucket_range(min(q[a, 1], q[b, 1]), max(q[a, 1], q[b, 1]), y0, hy, g)
        for i in range(ia, ib + 1):
            for j in range(ja, jb + 1):
                cnt[i * g + j + 1] += 1
    for c in range(g * g):
        cnt[c + 1] += cnt[c]
    fill = cnt[:-1].copy()
    sb = np.empty(cnt[-1], dtype=np.int64)
    for k in range(m):
        a, b = seg[k, 0], seg[k, 1]
        ia, ib = _bucket_range(min(q[a, 0], q[b, 0]), max(q[a, 0], q[b, 0]), x0, hx, g)
        ja, jb = _bucket_range(min(q[a, 1], q[b, 1]), max(q[a, 1], q[b, 1]), y0, hy, g)
        for i in range(ia, ib + 1):
            for j in range(ja, jb + 1):
                sb[fill[i * g + j]] = k
                fill[i * g + j] += 1
    out = np.empty((0, 2), dtype=np.int64)
    for rnd in range(2):            # count, then fill
        n = 0
        for c in range(g * g):
            for s in range(cnt[c], cnt[c + 1]):
                k = sb[s]
                a, b = seg[k, 0], seg[k, 1]
                kx0, kx1 = min(q[a, 0], q[b, 0]), max(q[a, 0], q[b, 0])
                ky0, ky1 = min(q[a, 1], q[b, 1]), max(q[a, 1], q[b, 1])
                for t in range(s + 1, cnt[c + 1]):
                    l = sb[t]
                    cc, d = seg[l, 0], seg[l, 1]
                    lx0, lx1 = min(q[cc, 0], q[d, 0]), max(q[cc, 0], q[d, 0])
                    ly0, ly1 = min(q[cc, 1], q[d, 1]), max(q[cc, 1], q[d, 1])
                    cx, cy = max(kx0, lx0), max(ky0, ly0)
                    if not (cx <= min(kx1, lx1) and cy <= min(ky1, ly1)):
                        continue
                    ia, _ = _bucket_range(cx, cx, x0, hx, g)
                    ja, _ = _bucket_range(cy, cy, y0, hy, g)
                    if ia * g + ja != c:
                        continue            # (the pair's bucket is another one: reported there)
                    if rnd == 1:
                        out[n, 0], out[n, 1] = min(k, l), max(k, l)
                    n += 1
        if rnd == 0:
            out = np.empty((n, 2), dtype=np.int64)
    return out


def _orient_certain(a, b, c) -> np.ndarray:
    """Sign of orient2d(a, b, c) where the floating-point value is certain (Shewchuk's bound), else 0."""
    left = (a[:, 0] - c[:, 0]) * (b[:, 1] - c[:, 1])
    right = (a[:, 1] - c[:, 1]) * (b[:, 0] - c[:, 0])
    det = left - right
    sign = np.sign(det).astype(np.int64)
    sign[np.abs(det) <= _CCW_BOUND * (np.abs(left) + np.abs(right))] = 0
    return sign


def crossing_segments(vertices: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Pairs (i, j) of segments that cross properly (interiors meet in one point), by the exact orient2d.

    Parameters
    ----------
    vertices : (n, 2) float64
    segments : (m, 2) int64

    Returns
    -------
    (k, 2) int64

    Examples
    --------
    >>> import numpy as np
    >>> v = np.array([[0, 0], [1, 1], [0, 1], [1, 0]], float)
    >>> crossing_segments(v, np.array([[0, 1], [2, 3]])).tolist()
    [[0, 1]]
    """
    q = np.asarray(vertices, dtype=np.float64)
    seg = np.asarray(segments, dtype=np.int64).reshape(-1, 2)
    if len(seg) < 2:
        return np.zeros((0, 2), dtype=np.int64)
    p = _candidate_segment_pairs(q, seg)
    i, j = p[:, 0], p[:, 1]
    shared = ((seg[i, 0] == seg[j, 0]) | (seg[i, 0] == seg[j, 1]) | (seg[i, 1] == seg[j, 0])
              | (seg[i, 1] == seg[j, 1]))
    i, j = i[~shared], j[~shared]
    a, b, c, d = q[seg[i, 0]], q[seg[i, 1]], q[seg[j, 0]], q[seg[j, 1]]
    # a proper crossing lies in both boxes (this drops the collinear pieces of one grid line)
    meet = np.all((np.maximum(np.minimum(a, b), np.minimum(c, d)) <= np.minimum(np.maximum(a, b), np.maximum(c, d))),
                  axis=1)
    i, j, a, b, c, d = i[meet], j[meet], a[meet], b[meet], c[meet], d[meet]
    # floating-point signs where they are certain; the exact orient2d only for the uncertain pairs
    s1, s2, s3, s4 = (_orient_certain(x, y, z) for x, y, z in ((a, b, c), (a, b, d), (c, d, a), (c, d, b)))
    apart = (s1 * s2 > 0) | (s3 * s4 > 0)
    cross = ~apart & (s1 * s2 < 0) & (s3 * s4 < 0)
    unsure = np.flatnonzero(~apart & ~cross)
    if len(unsure):
        u = unsure
        cross[u] = ((orient2d(a[u], b[u], c[u]) * orient2d(a[u], b[u], d[u]) < 0)
                    & (orient2d(c[u], d[u], a[u]) * orient2d(c[u], d[u], b[u]) < 0))
    return np.column_stack([i[cross], j[cross]]).astype(np.int64)


def clean_pslg(vertices: np.ndarray, segments: np.ndarray, *, eps: float):
    """Merge near-duplicate vertices, split segments at vertices on them and at crossings, for Triangle.

    Parameters
    ----------
    vertices : (n, 2) float64
        Points as Triangle will see them (scaled to about the unit square).
    segments : (m, 2) int64
        Constraint segments.
    eps : float
        Distance (in the units of `vertices`) below which two vertices are one and
        a vertex lies on a segment.

    Returns
    -------
    vertices : (n + k, 2) float64
        The input points, then k crossing points added.
    segments : (m', 2) int64
        No two of them cross (exact predicate), none is degenerate or repeated, none
        passes within `eps` of a vertex it does not end at.
    rep : (n + k,) int64
        The vertex each one merged into (itself when kept); segments use only kept ones.

    Raises
    ------
    TrimLoopError
        Crossings left after the rounds (never seen; a face fails instead of hanging).

    Examples
    --------
    >>> import numpy as np
    >>> v = np.array([[0, 0], [1, 0], [1, 1e-17], [1, 1], [0.5, 0]], float)
    >>> q, s, rep = clean_pslg(v, np.array([[0, 1], [2, 3]]), eps=1e-10)
    >>> rep.tolist(), s.tolist()
    ([0, 1, 1, 3, 4], [[0, 4], [1, 3], [1, 4]])
    """
    q = np.asarray(vertices, dtype=np.float64).reshape(-1, 2)
    seg = np.asarray(segments, dtype=np.int64).reshape(-1, 2)
    n0 = len(q)
    rep = np.arange(n0)
    if n0 and _is_clean(q, seg, eps):
        # nothing closer than 2 eps, no crossing possible: what the rounds below return at once
        seg = seg[seg[:, 0] != seg[:, 1]]
        return q, _unique_segments(seg), rep
    for _ in range(_ROUNDS):
        r, seg = _merge(q, seg, eps)
        rep = r[rep]
        kept = np.flatnonzero(r == np.arange(len(q)))
        for _ in range(4 * _ROUNDS):
            if not len(seg):
                break
            s, v, t = _vertex_segment_pairs(q, seg, kept, eps)
            if not len(s):
                break
            seg = _split(seg, s, v, t)
        x = crossing_segments(q, seg)
        if not len(x):
            return q, seg, rep
        # every crossing cut this round: one new point per crossing pair, on both segments
        a, b, c, d = q[seg[x[:, 0], 0]], q[seg[x[:, 0], 1]], q[seg[x[:, 1], 0]], q[seg[x[:, 1], 1]]
        e, f = b - a, d - c
        den = e[:, 0] * f[:, 1] - e[:, 1] * f[:, 0]
        w = c - a
        ta = np.clip((w[:, 0] * f[:, 1] - w[:, 1] * f[:, 0]) / den, 0.0, 1.0)
        p = a + ta[:, None] * e
        tc = np.clip(np.einsum("nd,nd->n", p - c, f) / np.maximum(np.einsum("nd,nd->n", f, f), 1e-300), 0.0, 1.0)
        new = len(q) + np.arange(len(p))
        q = np.concatenate([q, p])
        rep = np.r_[rep, new]
        seg = _split(seg, np.r_[x[:, 0], x[:, 1]], np.r_[new, new], np.r_[ta, tc])
    raise TrimLoopError(f"constraint segments still cross after {_ROUNDS} rounds of splitting "
                        f"({len(crossing_segments(q, seg))} crossing(s)); the trim polygons cannot be triangulated")


def _is_clean(q: np.ndarray, seg: np.ndarray, eps: float) -> bool:
    """True when `clean_pslg` has nothing to do: no two vertices within 2 `eps`, no vertex within 2 `eps`
    of a segment it does not end at, and no two segments without a common end whose boxes meet and
    whose floating-point orientations are not certainly apart (Shewchuk's bound, as `crossing_segments`).
    A conservative filter: False sends the graph through the full rounds."""
    if not np.all(np.isfinite(q)) or (len(seg) and (seg.min() < 0 or seg.max() >= len(q))):
        return False
    return _is_clean_kernel(np.ascontiguousarray(q), np.ascontiguousarray(seg), float(eps), _CCW_BOUND)


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def _bucket_range(lo, hi, x0, h, g):
    a = min(max(int((lo - x0) / h), 0), g - 1)
    b = min(max(int((hi - x0) / h), 0), g - 1)
    return a, b


@njit(cache=True, nogil=True)
def _is_clean_kernel(q, seg, eps, bound):
    n, m = q.shape[0], seg.shape[0]
    r = 2.0 * eps
    x0, y0, x1, y1 = q[0, 0], q[0, 1], q[0, 0], q[0, 1]
    for i in range(n):
        x0 = min(x0, q[i, 0])
        y0 = min(y0, q[i, 1])
        x1 = max(x1, q[i, 0])
        y1 = max(y1, q[i, 1])
    x0 -= 2 * r
    y0 -= 2 * r
    x1 += 2 * r
    y1 += 2 * r
    g = max(1, int(np.sqrt(n + m)))
    while True:
        hx, hy = (x1 - x0) / g, (y1 - y0) / g
        total = 0
        for k in range(m):
            a, b = seg[k, 0], seg[k, 1]
            ia, ib = _bucket_range(min(q[a, 0], q[b, 0]) - r, max(q[a, 0], q[b, 0]) + r, x0, hx, g)
            ja, jb = _bucket_range(min(q[a, 1], q[b, 1]) - r, max(q[a, 1], q[b, 1]) + r, y0, hy, g)
            total += (ib - ia + 1) * (jb - ja + 1)
        if g == 1 or total <= 16 * (m + n):
            break
        g = max(1, g // 2)
    # vertices: one bucket each, the segments' boxes dilated by 2 r cover what lies within r
    cnt = np.zeros(g * g + 1, dtype=np.int64)
    vcnt = np.zeros(g * g + 1, dtype=np.int64)
    for k in range(m):
        a, b = seg[k, 0], seg[k, 1]
        ia, ib = _bucket_range(min(q[a, 0], q[b, 0]) - r, max(q[a, 0], q[b, 0]) + r, x0, hx, g)
        ja, jb = _bucket_range(min(q[a, 1], q[b, 1]) - r, max(q[a, 1], q[b, 1]) + r, y0, hy, g)
        for i in range(ia, ib + 1):
            for j in range(ja, jb + 1):
                cnt[i * g + j + 1] += 1
    for v in range(n):
        ia, ib = _bucket_range(q[v, 0] - r, q[v, 0] + r, x0, hx, g)
        ja, jb = _bucket_range(q[v, 1] - r, q[v, 1] + r, y0, hy, g)
        for i in range(ia, ib + 1):
            for j in range(ja, jb + 1):
                vcnt[i * g + j + 1] += 1
    for c in range(g * g):
        cnt[c + 1] += cnt[c]
        vcnt[c + 1] += vcnt[c]
    sfill = cnt[:-1].copy()
    vfill = vcnt[:-1].copy()
    sb = np.empty(cnt[-1], dtype=np.int64)
    vb = np.empty(vcnt[-1], dtype=np.int64)
    for k in range(m):
        a, b = seg[k, 0], seg[k, 1]
        ia, ib = _bucket_range(min(q[a, 0], q[b, 0]) - r, max(q[a, 0], q[b, 0]) + r, x0, hx, g)
        ja, jb = _bucket_range(min(q[a, 1], q[b, 1]) - r, max(q[a, 1], q[b, 1]) + r, y0, hy, g)
        for i in range(ia, ib + 1):
            for j in range(ja, jb + 1):
                sb[sfill[i * g + j]] = k
                sfill[i * g + j] += 1
    for v in range(n):
        ia, ib = _bucket_range(q[v, 0] - r, q[v, 0] + r, x0, hx, g)
        ja, jb = _bucket_range(q[v, 1] - r, q[v, 1] + r, y0, hy, g)
        for i in range(ia, ib + 1):
            for j in range(ja, jb + 1):
                vb[vfill[i * g + j]] = v
                vfill[i * g + j] += 1
    r2 = r * r
    for c in range(g * g):
        # vertex pairs
        for s in range(vcnt[c], vcnt[c + 1]):
            v = vb[s]
            for t in range(s + 1, vcnt[c + 1]):
                w = vb[t]
                dx, dy = q[v, 0] - q[w, 0], q[v, 1] - q[w, 1]
                if dx * dx + dy * dy <= r2:
                    return False
        # vertex near a segment it does not end at (closed segment)
        for s in range(vcnt[c], vcnt[c + 1]):
            v = vb[s]
            px, py = q[v, 0], q[v, 1]
            for t in range(cnt[c], cnt[c + 1]):
                k = sb[t]
                a, b = seg[k, 0], seg[k, 1]
                if a == v or b == v:
                    continue
                ax, ay = q[a, 0], q[a, 1]
                dx, dy = q[b, 0] - ax, q[b, 1] - ay
                wx, wy = px - ax, py - ay
                ll = dx * dx + dy * dy
                u = (wx * dx + wy * dy) / ll if ll > 0 else 0.0
                u = min(max(u, 0.0), 1.0)
                ex, ey = wx - u * dx, wy - u * dy
                if not ex * ex + ey * ey > r2:
                    return False
        # segment pairs without a common end
        for s in range(cnt[c], cnt[c + 1]):
            k = sb[s]
            a, b = seg[k, 0], seg[k, 1]
            ax, ay, bx, by = q[a, 0], q[a, 1], q[b, 0], q[b, 1]
            for t in range(s + 1, cnt[c + 1]):
                l = sb[t]
                cc, d = seg[l, 0], seg[l, 1]
                if cc == a or cc == b or d == a or d == b:
                    continue
                if _may_cross(ax, ay, bx, by, q[cc, 0], q[cc, 1], q[d, 0], q[d, 1], bound):
                    return False
    return True
