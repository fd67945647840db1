"""The naive baseline of Sec. I (Fig. 2): sewing by midpoints of points interpolated along both boundaries."""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from ..errors import InputError
from ..model import Shell, TriMesh
from ._boundary import arc_length_fractions, edge_table
from ._chains import mesh_chains
from ._patch import project_mesh

__all__ = ["midpoint_join", "BaselineResult"]

_POLE_REL = 1e-9        # mesh vertices of a degenerate edge within this x diagonal of each other are the pole
_SAME_FRACTION = 1e-9   # two chain vertices this close in normalised arc length are paired (one vertex)


class BaselineResult(NamedTuple):
    """The sewn mesh and which of its vertices lie on the joints (moved to or inserted from a median)."""

    mesh: TriMesh
    on_joint: np.ndarray   # (n,) bool


def midpoint_join(shell: Shell, meshes: Sequence[TriMesh]) -> BaselineResult:
    """Join face meshes by moving both boundaries onto their midpoint polyline (the paper's baseline).

    For every edge two faces share, the mesh boundary chains along it are
    paired by normalised arc length (end vertex with end vertex, l1 with r1
    and l4 with r2 in Fig. 2); every chain vertex moves to the midpoint of
    itself and the point at its arc length on the other chain, and the other
    chain's vertices are inserted into this mesh by splitting the boundary
    triangles. Vertices at the same arc length on both chains (the ends
    always, every node where the meshes already matched) become one vertex,
    so the sewn mesh is closed along every joint (seams of one face
    included) without welding. Interior vertices do not move, so a boundary vertex can move
    across an interior edge and turn a triangle over (the folding of Fig. 2,
    second case).

    Parameters
    ----------
    shell : Shell
    meshes : sequence of TriMesh
        One per face.

    Returns
    -------
    BaselineResult
        ``mesh``: the sewn mesh with ``face_id``, triangles oriented like the
        faces; ``on_joint``: its vertices on the sewn edges.

    Raises
    ------
    InputError
        Not one TriMesh per face.

    Examples
    --------
    >>> from trimsurf.samples.folding_pair import folding_pair, folding_pair_meshes
    >>> shell = folding_pair()
    >>> base = midpoint_join(shell, folding_pair_meshes(shell))
    >>> base.mesh.n_triangles, int(base.on_joint.sum())
    (67, 4)
    """
    if len(meshes) != len(shell.faces):
        raise InputError(f"midpoint_join: need one mesh per face ({len(shell.faces)}); got {len(meshes)}")
    nf = len(shell.faces)
    verts = [np.array(m.vertices, dtype=np.float64) for m in meshes]
    tris = []
    chains = []
    for face, m in zip(shell.faces, meshes):
        if m.n_triangles == 0 or not face.loops:
            tris.append(m.triangles.copy())
            chains.append({})
            continue
        pr = project_mesh(face, m)
        tris.append(pr.triangles.copy())   # counter-clockwise in (u, v)
        chains.append(mesh_chains(face, pr.uv, pr.triangles))
    gid_of = [dict() for _ in range(nf)]      # local vertex -> global id
    gpos: list[np.ndarray] = []
    splits = [dict() for _ in range(nf)]      # (a, b) boundary edge -> [(s, local vertex)]
    same: list[tuple[int, int]] = []          # pairs of global ids at the same arc length: one vertex
    edges, _ = edge_table(shell)
    diag = shell.diagonal()
    for ed in edges:
        if ed.degenerate:   # a pole: every mesh vertex along it is the pole (one vertex, as in the Whitney join)
            for f, li, si, _ in ed.uses:
                c = chains[f].get((li, si))
                if c is None:
                    continue
                # only vertices that really are at the pole (a chain found along a real edge is not)
                p = verts[f][c]
                if np.linalg.norm(p - p[0], axis=1).max() > _POLE_REL * diag:
                    continue
                ids = []
                for v in c.tolist():
                    if v not in gid_of[f]:
                        gid_of[f][v] = len(gpos)
                        gpos.append(verts[f][v].copy())
                    ids.append(gid_of[f][v])
                same.extend((ids[0], g) for g in ids[1:])
            continue
        if len(ed.uses) != 2:
            continue
        (fa, la, sa_, fwa), (fb, lb, sb_, fwb) = ed.uses   # fa == fb: a seam, sewn like any joint
        ca, cb = chains[fa].get((la, sa_)), chains[fb].get((lb, sb_))
        if ca is None or cb is None:
            continue
        ca = ca if fwa else ca[::-1]   # both in the edge's direction
        cb = cb if fwb else cb[::-1]
        pa, pb = verts[fa][ca].copy(), verts[fb][cb].copy()
        sa, sb = arc_length_fractions(pa), arc_length_fractions(pb)
        at_a = np.column_stack([np.interp(sb, sa, pa[:, c]) for c in range(3)])  # a's points at b's fractions
        at_b = np.column_stack([np.interp(sa, sb, pb[:, c]) for c in range(3)])
        for (f, chain, own, other_at) in ((fa, ca, pa, at_b), (fb, cb, pb, at_a)):
            for i, v in enumerate(chain):
                g = gid_of[f].get(int(v))
                if g is None:
                    g = len(gpos)
                    gpos.append(0.5 * (own[i] + other_at[i]))
                    gid_of[f][int(v)] = g
        # the other chain's vertices go into each mesh: split the boundary edge they fall on; a vertex at
        # the same arc length as one of this chain's (the ends always) is that vertex (merged below)
        for (f, chain, s_own, f2, chain2, s2) in ((fa, ca, sa, fb, cb, sb), (fb, cb, sb, fa, ca, sa)):
            for k, s in enumerate(s2):
                g = gid_of[f2][int(chain2[k])]
                hit = np.flatnonzero(np.abs(s_own - s) <= _SAME_FRACTION)
                if len(hit):
                    same.append((gid_of[f][int(chain[hit[0]])], g))
                    continue
                j = int(np.clip(np.searchsorted(s_own, s) - 1, 0, len(chain) - 2))
                key = (int(chain[j]), int(chain[j + 1]))
                splits[f].setdefault(key, []).append((float(s), g))
    # paired vertices become one vertex (union-find over the global ids; corners of several faces too)
    parent = np.arange(len(gpos))

    def root(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for a, b in same:
        ra, rb = root(a), root(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    rep = np.array([root(i) for i in range(len(gpos))], dtype=np.int64)
    gp = np.array(gpos).reshape(-1, 3)
    if len(gp):
        acc = np.zeros_like(gp)
        np.add.at(acc, rep, gp)
        cnt = np.bincount(rep, minlength=len(gp)).astype(float)
        gp = acc / np.maximum(cnt, 1.0)[:, None]
    gid_of = [{v: int(rep[g]) for v, g in d.items()} for d in gid_of]
    splits = [{k: [(s, int(rep[g])) for s, g in items] for k, items in d.items()} for d in splits]
    gpos = list(gp)
    # build the merged mesh
    out_v = [np.array(gpos).reshape(-1, 3)]
    n = len(gpos)
    out_t, out_f = [], []
    for f in range(nf):
        m = meshes[f]
        if m.n_triangles == 0:
            continue
        idx = np.empty(m.n_vertices, dtype=np.int64)
        own = np.ones(m.n_vertices, dtype=bool)
        for v, g in gid_of[f].items():
            idx[v] = g
            own[v] = False
        idx[own] = n + np.arange(int(own.sum()))
        out_v.append(verts[f][own])
        n += int(own.sum())
        t = idx[tris[f]]
        t, centres = _split_edges(t, {(int(idx[a]), int(idx[b])): [g for _, g in sorted(items)]
                                      for (a, b), items in splits[f].items()}, n)
        if centres:   # triangles with points on several edges: a star around their centroid (a new vertex)
            allv = np.concatenate(out_v)
            out_v.append(np.array([allv[c].mean(axis=0) for c in centres]))
            n += len(centres)
        t = t[(t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])]
        if not shell.faces[f].same_sense:
            t = t[:, ::-1]
        out_t.append(t)
        out_f.append(np.full(len(t), f))
    v = np.concatenate(out_v)
    t = np.concatenate(out_t)
    used = np.zeros(len(v), dtype=bool)
    used[t.ravel()] = True
    remap = np.full(len(v), -1, dtype=np.int64)
    remap[used] = np.arange(int(used.sum()))
    joint = np.zeros(len(v), dtype=bool)
    joint[: len(gpos)] = True
    return BaselineResult(TriMesh(v[used], remap[t], face_id=np.concatenate(out_f)), joint[used])


def _split_edges(tris: np.ndarray, splits: dict, n_next: int) -> tuple[np.ndarray, list]:
    """Split triangles whose directed edges (a, b) (either direction) get the points `splits[(a, b)]`.

    One split edge: a fan from the opposite corner. Points on several edges (a corner triangle between
    two joints): a star around a new centroid vertex, numbered from `n_next`; returns the triangles and
    the corners of each such triangle (for the centroid's position).
    """
    if not splits:
        return tris, []
    out, centres = [], []
    for tri in tris.tolist():
        ring, n_split = [], 0
        for c in range(3):
            a, b = tri[c], tri[(c + 1) % 3]
            if (a, b) in splits:
                pts = splits[(a, b)]
            elif (b, a) in splits:
                pts = splits[(b, a)][::-1]
            else:
                pts = []
            n_split += bool(pts)
            ring.append([a] + list(pts))
        if n_split == 0:
            out.append(tri)
        elif n_split == 1:
            c = next(k for k in range(3) if len(ring[k]) > 1)
            chain = ring[c] + [tri[(c + 1) % 3]]
            o = tri[(c + 2) % 3]
            out.extend([chain[j], chain[j + 1], o] for j in range(len(chain) - 1) if chain[j] != chain[j + 1])
        else:
            poly = [v for part in ring for v in part]
            cidx = n_next + len(centres)
            centres.append(tri)
            out.extend([poly[j], poly[(j + 1) % len(poly)], cidx] for j in range(len(poly))
                       if poly[j] != poly[(j + 1) % len(poly)])
    return np.array(out, dtype=np.int64).reshape(-1, 3), centres
