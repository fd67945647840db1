"""The shell-level stages' compiled and batched paths equal the reference (Python) paths they replace."""

from __future__ import annotations

import numpy as np

from trimsurf.tessellate import seams as seams_mod


def _seam_select_reference(T, alive, fid, nv, c, interior):
    """`_State.round`'s selection loop over `_collapse.collapse_sets` (main 1fb9934) that
    `_seam_select_kernel` replaces: (taken (v, u, moved, gone), skipped (v, u))."""
    from trimsurf.tessellate._collapse import collapse_sets

    ia = np.flatnonzero(alive)
    flat = T[ia].ravel()
    order = np.argsort(flat, kind="stable")
    vstart = np.searchsorted(flat[order], np.arange(nv + 1)).tolist()
    vtri = ia[order // 3].tolist()
    Tl, fl = T.tolist(), fid.tolist()
    locked = bytearray(nv)
    sel, skip = [], []
    for v, u in c.tolist():
        if locked[v] or locked[u]:
            continue
        tv, star, common, gone, moved = collapse_sets(Tl, vtri, vstart, v, u)
        if any(locked[x] for x in star):
            continue
        if len({fl[k] for k in tv}) != (1 if interior else 2) or (interior and len(star) != len(tv) + 1):
            skip.append((v, u))
            continue
        if len(common) != 2 or len(gone) != 2:
            skip.append((v, u))
            continue
        sel.append((v, u, moved, gone))
        for x in star:
            locked[x] = 1
    return sel, skip


def test_seam_select_kernel_equals_collapse_sets_loop():
    """The compiled seam selection takes the same collapses (same moved and gone triangles, same order) and
    skips the same ones as the loop over `collapse_sets`: Delaunay meshes of random points split into
    two or three "faces" by a line, some triangles dead, candidate pairs along edges and random ones,
    seam (two faces) and interior (one face) rules."""
    from scipy.spatial import Delaunay

    rng = np.random.default_rng(25)
    n_taken = n_skipped = 0
    for trial in range(60):
        n = int(rng.integers(10, 300))
        P = rng.random((n, 2))
        T = Delaunay(P).simplices.astype(np.int64)
        cen = P[T].mean(axis=1)
        fid = (cen[:, 0] > rng.random()).astype(np.int64) + (trial % 3 == 0) * (cen[:, 1] > 0.7)
        alive = rng.random(len(T)) < (0.9 if trial % 2 else 1.0)
        e = T[rng.integers(0, len(T), 3 * n)]
        k = rng.integers(0, 3, len(e))
        v = e[np.arange(len(e)), k]
        u = np.where(rng.random(len(e)) < 0.8, e[np.arange(len(e)), (k + 1) % 3], rng.integers(0, n, len(e)))
        c = np.stack([v, u], axis=1)[v != u]
        for interior in (False, True):
            qs, mv, ms, gn, sk = seams_mod._seam_select_kernel(T, np.flatnonzero(alive), fid, np.int64(n),
                                                               c[:, 0].copy(), c[:, 1].copy(), np.bool_(interior))
            ref, ref_skip = _seam_select_reference(T, alive, fid, n, c, interior)
            got = [(int(c[q, 0]), int(c[q, 1]), mv[ms[i]:ms[i + 1]].tolist(), gn[i].tolist())
                   for i, q in enumerate(qs.tolist())]
            assert got == [(a, b, m, g) for a, b, m, g in ref], (trial, interior)
            assert [tuple(x) for x in c[sk].tolist()] == ref_skip, (trial, interior)
            n_taken += len(ref)
            n_skipped += len(ref_skip)
    assert n_taken > 100 and n_skipped > 100


def test_seam_edges_equals_seam_graph_of_the_mesh():
    """`_seam_edges` (no TriMesh built) gives `_seam_graph`'s edges in its order: random meshes with
    two to four faces, non-manifold and boundary edges, unused vertices, an empty one."""
    from scipy.spatial import Delaunay

    from trimsurf.model import TriMesh

    rng = np.random.default_rng(7)
    total = 0
    for trial in range(40):
        n = int(rng.integers(4, 400))
        P = rng.random((n, 2))
        T = Delaunay(P).simplices.astype(np.int64)
        T = T[rng.random(len(T)) < 0.9]
        if trial % 5 == 0 and len(T):
            T = np.concatenate([T, T[: len(T) // 4][:, ::-1]])      # edges on three and four triangles
        fid = rng.integers(0, 2 + trial % 3, len(T)).astype(np.int64)
        V = np.c_[P, np.zeros(n)]
        ref = seams_mod._seam_graph(TriMesh(V, T, face_id=fid))
        got = seams_mod._seam_edges(T, fid, n)
        assert got.dtype == ref.dtype and got.shape == ref.shape and np.array_equal(got, ref), trial
        total += len(ref)
    assert total > 1000
    assert seams_mod._seam_edges(np.zeros((0, 3), dtype=np.int64), np.zeros(0, dtype=np.int64), 5).shape == (0, 2)
