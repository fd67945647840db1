"""Orientation fixing across adjacent faces (paper Sec. 4.5, 5.3)."""

from __future__ import annotations

import numpy as np

from ..model import TriMesh

__all__ = ["orient_meshes"]


def orient_meshes(mesh: TriMesh) -> tuple[TriMesh, list]:
    """Give adjacent faces one orientation: breadth-first over faces sharing an edge (paper Sec. 5.3).

    Faces are kept whole: a face whose triangles disagree with the neighbour it
    was reached from (over the majority of their common edges) is flipped and
    marked, and not touched again.

    Parameters
    ----------
    mesh : TriMesh
        With ``face_id``; vertices shared between faces (after stitching).

    Returns
    -------
    (TriMesh, list of int)
        The re-oriented mesh and the faces that were flipped.
    """
    if mesh.face_id is None or not mesh.n_triangles:
        return mesh, []
    fid = mesh.face_id
    he = mesh.half_edges()
    inv = mesh.half_edge_edges()
    counts = mesh.edge_triangle_counts()
    tri_of = np.repeat(np.arange(mesh.n_triangles), 3)
    # pairs of half-edges on manifold edges between different faces
    order = np.argsort(inv, kind="stable")
    s_inv = inv[order]
    same = (s_inv[1:] == s_inv[:-1]) & (counts[s_inv[1:]] == 2)
    h1, h2 = order[:-1][same], order[1:][same]
    f1, f2 = fid[tri_of[h1]], fid[tri_of[h2]]
    cross = f1 != f2
    h1, h2, f1, f2 = h1[cross], h2[cross], f1[cross], f2[cross]
    agree = he[h1, 0] != he[h2, 0]            # opposite directions: consistent
    faces = np.unique(fid)
    # vote per face pair
    key_a, key_b = np.minimum(f1, f2), np.maximum(f1, f2)
    # (face pairs in the order of their first edge, as a dict filled edge by edge would hold them)
    n_f = int(fid.max()) + 1
    pair = key_a * n_f + key_b
    uniq, first, inv = np.unique(pair, return_index=True, return_inverse=True)
    n_ok = np.bincount(inv, weights=agree, minlength=len(uniq))
    n_all = np.bincount(inv, minlength=len(uniq))
    by_first = np.argsort(first, kind="stable")
    nbrs: dict = {int(f): [] for f in faces}
    for a, b, ok_, all_ in zip((uniq[by_first] // n_f).tolist(), (uniq[by_first] % n_f).tolist(),
                               n_ok[by_first].tolist(), n_all[by_first].tolist()):
        same_orient = ok_ >= all_ - ok_
        nbrs[a].append((b, same_orient))
        nbrs[b].append((a, same_orient))
    flip = {}
    remain = set(int(f) for f in faces)
    while remain:
        start = min(remain)
        remain.discard(start)
        flip[start] = False
        queue = [start]
        while queue:
            f = queue.pop(0)
            for g, same_orient in nbrs[f]:
                if g in remain:
                    flip[g] = flip[f] if same_orient else not flip[f]
                    remain.discard(g)
                    queue.append(g)
    # a component whose majority of triangles was flipped: flip it back (keep the CAD orientation)
    flipped = [f for f, v in flip.items() if v]
    if not flipped:
        return mesh, []
    tri_flip = np.isin(fid, flipped)
    n_area = np.bincount(fid, minlength=int(fid.max()) + 1)
    if n_area[flipped].sum() > 0.5 * mesh.n_triangles:
        tri_flip = ~tri_flip
        flipped = [int(f) for f in faces if f not in set(flipped)]
    t = np.where(tri_flip[:, None], mesh.triangles[:, ::-1], mesh.triangles)
    return TriMesh(mesh.vertices, t, uv=mesh.uv, face_id=fid), flipped

