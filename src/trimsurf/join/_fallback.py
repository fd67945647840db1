"""What the join does with a face mesh that breaks Sec. II's hypotheses (M^-1 not injective).

Two steps, in order:

1. `collapse_coincident`: an input mesh may hold triangles with two corners at one 3D point (Open
   CASCADE's meshes of faces with a model edge shorter than its precision: U_Joint's 5e-6 edges, the
   sewn bearing's face 14). Such a triangle has no area and no orientation in 3D, but its corners
   project to different (u, v) and it may turn over there. Merging the coinciding corners leaves the
   mesh's surface unchanged (the triangles removed have zero area) and often makes the projection
   injective again: the face is then joined as the paper says.
2. Where the projection still turns triangles over (or the central mesh crosses dR), the face is
   re-meshed (`join_shell` passes an empty central mesh to `join_patch`): the paper's step 4 over the
   whole (u, v) domain -- Triangle's constrained Delaunay triangulation of dR (the shared edge
   polylines, so the face shares its boundary vertices with its neighbours), Ruppert refinement at the
   same minimum angle, refined until every triangle's sampled deviation is within the deflection, every
   vertex put at F(p) + a(p) n(p) (step 5). The input mesh is then used only for the parameter scale.
   Such faces are reported as ``"remeshed"``.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from ..model import TriMesh

__all__ = ["collapse_coincident"]


def collapse_coincident(mesh: TriMesh, tol: float) -> tuple[TriMesh, int]:
    """Merge the ends of every mesh edge at most `tol` long (3D); drop the triangles that collapse.

    Returns the cleaned mesh (vertices renumbered; ``uv`` kept for the surviving vertices) and the number
    of vertices merged away. With nothing to merge, the mesh itself and 0.

    Examples
    --------
    >>> v = np.array([[0., 0, 0], [1, 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> t = np.array([[0, 1, 3], [1, 2, 3]])     # the second triangle has two corners at (1, 0, 0)
    >>> m, k = collapse_coincident(TriMesh(v, t), 0.0)
    >>> k, m.n_vertices, m.triangles.tolist()
    (1, 3, [[0, 1, 2]])
    """
    e = mesh.edges()
    if not len(e):
        return mesh, 0
    length = np.linalg.norm(mesh.vertices[e[:, 0]] - mesh.vertices[e[:, 1]], axis=1)
    short = e[length <= tol]
    if not len(short):
        return mesh, 0
    n = mesh.n_vertices
    g = sparse.coo_matrix((np.ones(len(short), dtype=np.int8), (short[:, 0], short[:, 1])), shape=(n, n))
    _, lab = csgraph.connected_components(g, directed=False)
    # each group's representative: its smallest vertex index
    rep = np.full(lab.max() + 1, n, dtype=np.int64)
    np.minimum.at(rep, lab, np.arange(n))
    to = rep[lab]
    t = to[mesh.triangles]
    ok = (t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])
    t = t[ok]
    used = np.zeros(n, dtype=bool)
    used[t.ravel()] = True
    remap = np.full(n, -1, dtype=np.int64)
    remap[used] = np.arange(int(used.sum()))
    uv = None if mesh.uv is None else mesh.uv[used]
    fid = None if mesh.face_id is None else mesh.face_id[ok]
    merged = int(n - len(np.unique(to)))
    return TriMesh(mesh.vertices[used], remap[t], uv=uv, face_id=fid), merged


def crossing_segments(loops_uv: list[np.ndarray], loops_gid: list[np.ndarray]) -> np.ndarray:
    """Indices (into the loops' concatenation; segment k runs from point k to the next of its loop) of dR
    segments that cross or touch another segment they share no end with (pinch copies, `_pinch_vertices`,
    count as one end).

    Examples
    --------
    >>> sq = np.array([[0., 0], [2, 0], [2, 2], [0, 2]])
    >>> bow = np.array([[0., 0], [2, 0], [0, 2], [2, 2]])       # segments 1 and 3 cross
    >>> crossing_segments([sq], [np.arange(4)]).tolist(), crossing_segments([bow], [np.arange(4)]).tolist()
    ([], [1, 3])
    """
    from scipy.spatial import cKDTree

    from ..geom import segment_intersections
    from ._patch import _pinch_vertices

    w = np.concatenate(loops_uv)
    _, vpos = _pinch_vertices(w, np.concatenate(loops_gid))
    off = np.cumsum([0] + [len(lp) for lp in loops_uv])
    seg = np.concatenate([np.column_stack([off[i] + np.arange(len(lp)), off[i] + (np.arange(len(lp)) + 1) % len(lp)])
                          for i, lp in enumerate(loops_uv)])
    a, b = w[seg[:, 0]], w[seg[:, 1]]
    mid = 0.5 * (a + b)
    rad = 0.5 * np.linalg.norm(b - a, axis=1)
    if not len(seg):
        return np.zeros(0, dtype=np.int64)
    pairs = cKDTree(mid).query_pairs(2.0 * float(rad.max()) + 1e-300, output_type="ndarray")
    if not len(pairs):
        return np.zeros(0, dtype=np.int64)
    i, j = pairs[:, 0], pairs[:, 1]
    near = np.linalg.norm(mid[i] - mid[j], axis=1) <= rad[i] + rad[j]
    i, j = i[near], j[near]
    v = vpos[seg]
    share = ((v[i, 0] == v[j, 0]) | (v[i, 0] == v[j, 1]) | (v[i, 1] == v[j, 0]) | (v[i, 1] == v[j, 1]))
    i, j = i[~share], j[~share]
    hit = segment_intersections(a[i], b[i], a[j], b[j])
    return np.unique(np.concatenate([i[hit], j[hit]]))
