"""Boundary chains of a face mesh: the mesh boundary vertices that run along each trim segment."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..model import TrimmedFace

__all__ = ["mesh_boundary_loops", "loops_from_edges", "mesh_chains"]


def mesh_boundary_loops(triangles: np.ndarray, n: int) -> list[np.ndarray]:
    """Boundary loops (vertex indices in the direction of the triangles' boundary edges).

    Where the boundary passes a vertex twice (a pinch: two fans of triangles meeting at one vertex, e.g.
    a face whose hole touches its outer loop), each loop goes on along the boundary edge of the fan it
    came in by, so the two loops stay apart (both hold the pinch vertex).
    """
    triangles = np.asarray(triangles, dtype=np.int64)
    he = np.stack([triangles, np.roll(triangles, -1, axis=1)], axis=2).reshape(-1, 2)
    key = np.minimum(he[:, 0], he[:, 1]) * n + np.maximum(he[:, 0], he[:, 1])
    _, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
    be = he[cnt[inv] == 1]
    if not len(be) or np.bincount(be[:, 0], minlength=n).max() <= 1:
        return loops_from_edges(be, min_length=2)
    # pinches: follow the fan around the vertex from the incoming boundary edge to its outgoing one
    third = {}
    for t in triangles.tolist():
        for c in range(3):
            third[(t[c], t[(c + 1) % 3])] = t[(c + 2) % 3]
    boundary = {(int(a), int(b)) for a, b in be.tolist()}

    def successor(a: int, b: int) -> int:
        x = third[(a, b)]                      # (b, x) is the next edge around b in the triangle of (a, b)
        for _ in range(len(third)):
            if (b, x) in boundary:
                return x
            x = third[(x, b)]                  # cross the interior edge (b, x) into the triangle of (x, b)
        raise RuntimeError("boundary walk did not end")   # pragma: no cover - not a triangle mesh

    loops, used = [], set()
    try:
        for a, b in sorted(boundary):
            if (a, b) in used:
                continue
            lp, e = [], (a, b)
            while e not in used:
                used.add(e)
                lp.append(e[0])
                e = (e[1], successor(*e))
            if len(lp) >= 2:
                loops.append(np.array(lp, dtype=np.int64))
    except KeyError:   # not consistently oriented around the pinch: no fan to follow, the plain walk
        return loops_from_edges(be, min_length=2)
    return loops


def loops_from_edges(be: np.ndarray, *, min_length: int = 3) -> list[np.ndarray]:
    """Closed loops (vertex index arrays) from the directed boundary edges `be` (k, 2) of a manifold triangle set.

    Loops shorter than `min_length` vertices are dropped.
    """
    nxt: dict[int, int] = {}
    for a, b in be.tolist():
        nxt.setdefault(a, b)
    loops, seen = [], set()
    for s in nxt:
        if s in seen:
            continue
        lp, v = [], s
        while v not in seen and v in nxt:
            seen.add(v)
            lp.append(v)
            v = nxt[v]
        if len(lp) >= min_length:
            loops.append(np.array(lp, dtype=np.int64))
    return loops


def mesh_chains(face: TrimmedFace, uv: np.ndarray, triangles: np.ndarray) -> dict[tuple[int, int], np.ndarray]:
    """For every segment (loop, seg) of the face, the mesh boundary vertices along it, in loop direction.

    The mesh vertex nearest (in (u, v)) to each corner of the face's loop is
    taken as that corner; the chain of segment s runs along the mesh boundary
    from corner s to corner s + 1 (both included), so consecutive chains share
    their corner vertex. `triangles` must be counter-clockwise in (u, v) (as
    `MeshProjection.triangles`), so outer boundaries run counter-clockwise
    like the face's outer loop. Segments without a usable chain are missing.
    """
    loops = mesh_boundary_loops(triangles, len(uv))
    if not loops:
        return {}
    allb = np.concatenate(loops)
    which = np.concatenate([np.full(len(lp), i) for i, lp in enumerate(loops)])
    pos = np.concatenate([np.arange(len(lp)) for lp in loops])
    tree = cKDTree(uv[allb])
    out = {}
    for li, loop in enumerate(face.loops):
        corners = np.array([s.start for s in loop.segments])
        _, k = tree.query(corners)
        ml = which[k]
        if np.any(ml != ml[0]):
            continue
        mloop = loops[int(ml[0])]
        kp = pos[k]
        m = len(mloop)
        nseg = len(loop.segments)
        # a pinch vertex (a hole touching the outer loop) lies twice on the mesh loop: every occurrence of
        # a corner is a candidate end, and the chain that runs closest to the segment's p-curve is taken
        occ = [np.flatnonzero(mloop == mloop[p]) for p in kp]
        pinched = any(len(o) > 1 for o in occ)
        for si in range(nseg):
            cands = []
            for a in (occ[si] if pinched else [int(kp[si])]):
                if nseg == 1:
                    later = (occ[si] - a) % m
                    steps = int(later[later > 0].min()) if np.any(later > 0) else m
                    cands.append((a + np.arange(steps + 1)) % m)
                    continue
                for b in (occ[(si + 1) % nseg] if pinched else [int(kp[(si + 1) % nseg])]):
                    steps = (int(b) - int(a)) % m
                    cands.append((int(a) + np.arange(steps + 1)) % m)
            idx = cands[0] if len(cands) == 1 else cands[int(np.argmin(
                [_distance_to_segment(loop.segments[si], uv[mloop[c]]) for c in cands]))]
            if len(idx) >= 2:
                out[(li, si)] = mloop[idx]
    return out



def _distance_to_segment(seg, uv: np.ndarray) -> float:
    """Median (u, v) distance of the points `uv` to the trim segment's p-curve (sampled densely)."""
    t = np.linspace(seg.t0, seg.t1, 257)
    dist, _ = cKDTree(seg.curve.evaluate(t)).query(uv)
    return float(np.median(dist))
