"""The shell-level stages' compiled and batched paths equal the reference (Python) paths they replace."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.model import TriMesh as _TriMesh
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
        rows = np.flatnonzero(rng.random(len(T)) < 0.7)         # a subset of the rows (`_State.seam`)
        sub = seams_mod._seam_graph(TriMesh(V, T[rows], face_id=fid[rows]))
        assert np.array_equal(seams_mod._seam_edges(T, fid, n, rows), sub), trial
    assert total > 1000
    assert seams_mod._seam_edges(np.zeros((0, 3), dtype=np.int64), np.zeros(0, dtype=np.int64), 5).shape == (0, 2)


def _fm(xyz, tri, uv=None):
    from trimsurf.tessellate.face import FaceMesh
    import dataclasses

    fields = {f.name: None for f in dataclasses.fields(FaceMesh) if f.default is dataclasses.MISSING
              and f.default_factory is dataclasses.MISSING}
    fields.update(xyz=xyz, triangles=tri, uv=np.zeros((len(xyz), 2)) if uv is None else uv)
    return FaceMesh(**fields)


def test_face_trimeshes_equal_per_face_to_trimesh(shared_data):
    """The batched face meshes of `tessellate_shell` equal each face's `to_trimesh()` (arrays, dtypes,
    read-only, C-contiguous, uv and face_id), on the screw's faces and on random face meshes with
    empty faces and missing (failed) ones."""
    from trimsurf.io import read_shell
    from trimsurf.tessellate import tessellate_shell
    from trimsurf.tessellate.shell import _face_trimeshes

    def same(a, b):
        assert (a is None) == (b is None)
        if a is None:
            return
        for name in ("vertices", "triangles", "uv", "face_id"):
            x, y = getattr(a, name), getattr(b, name)
            assert (x is None) == (y is None)
            if x is not None:
                assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y)
                assert not x.flags.writeable and x.flags.c_contiguous
        assert a.n_triangles == b.n_triangles and np.array_equal(a.edges(), b.edges())

    shell = read_shell(shared_data / "cad" / "occt__screw.step")
    res = tessellate_shell(shell, measure=False)
    assert len(res.face_meshes) == len(shell.faces) and all(m is not None for m in res.face_meshes)
    rng = np.random.default_rng(3)
    fms = {}
    for i in range(12):
        if i % 4 == 3:
            continue                                    # a failed face
        nv = int(rng.integers(3, 40)) if i % 5 else 0
        tri = (np.sort(rng.choice(nv, size=(int(rng.integers(1, 30)), 3)), axis=1) if nv else
               np.zeros((0, 3), dtype=np.int64))
        tri = tri[(tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2])].astype(np.int64)
        fms[i] = _fm(rng.random((nv, 3)), tri, rng.random((nv, 2)))
    got = _face_trimeshes(fms, 12)
    for i in range(12):
        same(got[i], fms[i].to_trimesh() if i in fms else None)


def test_face_trimeshes_raise_as_the_per_face_constructor():
    """A face mesh that `TriMesh` refuses (index out of range, repeated vertex, nan) raises the same
    error from the batch as from its own `to_trimesh()`, for the first such face."""
    import pytest

    from trimsurf.errors import DegenerateError, MeshError
    from trimsurf.tessellate.shell import _face_trimeshes

    good = _fm(np.eye(3), np.array([[0, 1, 2]]))
    cases = [(_fm(np.eye(3), np.array([[0, 1, 3]])), MeshError, "out of range"),
             (_fm(np.eye(3), np.array([[0, 1, 1]])), DegenerateError, "repeats a vertex"),
             (_fm(np.array([[0, 0, np.nan], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]])), MeshError, "non-finite")]
    for bad, err, text in cases:
        with pytest.raises(err, match=text):
            _face_trimeshes({0: good, 2: bad, 3: cases[0][0]}, 4)


def test_against_normal_of_pairs_equals_one_batch(shared_data):
    """`_State.flip_edges` tests the swaps the flipped triangles offer in one batch and looks each pair
    up: the batch's per-triangle results equal the per-pair calls it replaces, on the featuretype's
    faces (planes, rational cylinders, both senses), triangles at every angle to the surface."""
    from trimsurf.io import read_shell

    shell = read_shell(shared_data / "cad" / "trimesh__featuretype.STEP")
    faces = list(shell.faces)
    rng = np.random.default_rng(17)
    m = 600                                              # 300 pairs, each pair on one face
    face_of = np.repeat(rng.integers(0, len(faces), m // 2), 2)
    uv3 = np.empty((m, 3, 2))
    for k in range(m):
        (u0, u1), (v0, v1) = faces[face_of[k]].surface.domain
        c = rng.uniform(0, 1, 2)
        uv3[k] = (c + rng.normal(0, 0.05, (3, 2))).clip(0, 1) * [u1 - u0, v1 - v0] + [u0, v0]
    n0 = np.concatenate([faces[f].oriented_normals(uv3[k:k + 1].mean(axis=1)) for k, f in enumerate(face_of)])
    side = rng.normal(size=(m, 3))
    ang = rng.choice([0.0, 1.0, 1.5707963, 2.0, np.pi], m) + rng.normal(0, 1e-3, m)
    tn = np.cos(ang)[:, None] * n0 + np.sin(ang)[:, None] * side
    batch = seams_mod._against_normal(faces, face_of, uv3, tn)
    pairs = np.concatenate([seams_mod._against_normal(faces, face_of[k:k + 2], uv3[k:k + 2], tn[k:k + 2])
                            for k in range(0, m, 2)])
    assert 0 < batch.sum() < m
    assert np.array_equal(batch, pairs)


def test_first_min_equals_the_lexsort_selection():
    """`stitch._first_min` picks, per point, the pair the lexsort by (point, distance) put first: ties
    (equal distances, also zeros and infinities), single pairs, nans."""
    from trimsurf.tessellate.stitch import _first_min

    rng = np.random.default_rng(5)
    for trial in range(300):
        k = int(rng.integers(1, 400))
        pi = np.sort(rng.integers(0, max(1, k // int(rng.integers(1, 12))), k))
        d = rng.choice([0.0, 1.0, 2.5, np.inf, 1e-300], k) if trial % 3 == 0 else rng.random(k)
        if trial % 10 == 1:
            d[rng.random(k) < 0.2] = np.nan
        order = np.lexsort((d, pi))
        want = order[np.r_[True, pi[order][1:] != pi[order][:-1]]]
        assert np.array_equal(_first_min(pi, d), want), trial


def test_edge_index_pairs_sorted_as_the_lexsort():
    """`_EdgeIndex.pairs` (one key per pair) returns the pairs in the order of np.lexsort((edge, point))."""
    from trimsurf.tessellate.stitch import _EdgeIndex

    rng = np.random.default_rng(6)
    a = rng.random((500, 3))
    b = a + rng.normal(0, 0.02, (500, 3)) * rng.choice([0.1, 1, 10], (500, 1))
    idx = _EdgeIndex(a, b)
    assert len(idx.groups) > 2
    pi, ei = idx.pairs(rng.random((400, 3)), 0.3, 0.05)
    assert len(pi) > 1000
    order = np.lexsort((ei, pi))
    assert np.array_equal(order, np.arange(len(pi)))
    assert len(np.unique(pi * 500 + ei)) == len(pi)


@pytest.mark.parametrize("fname", ["trimesh__featuretype.STEP", "gmsh__U_Joint_2.stp", "occt__bearing.iges"])
def test_derivatives01_equals_the_per_face_kernel(shared_data, fname):
    """The one compiled call over all faces gives bit for bit each face's `_derivatives(.., 1)` (S, S_u,
    S_v): planes, rational and non-rational surfaces of degrees 1 to 8, points inside, on and outside
    the domain (clipped), and -0.0, faces in any order."""
    from trimsurf.io import read_shell

    faces = list(read_shell(shared_data / "cad" / fname).faces)
    rng = np.random.default_rng(8)
    m = 4000
    face_of = rng.integers(0, len(faces), m)
    pts = np.empty((m, 2))
    for k in range(m):
        (u0, u1), (v0, v1) = faces[face_of[k]].surface.domain
        t = rng.choice([rng.uniform(-0.1, 1.1), 0.0, 1.0, rng.uniform(0, 1)], 2)
        pts[k] = u0 + t[0] * (u1 - u0), v0 + t[1] * (v1 - v0)
    pts[:5] = -0.0
    got = seams_mod._derivatives01(faces, face_of, pts)
    for f in np.unique(face_of).tolist():
        r = np.flatnonzero(face_of == f)
        d = seams_mod._derivatives(faces[f].surface, pts[r], 1)
        for a, b in ((got[0, r], d[0, 0]), (got[1, r], d[1, 0]), (got[2, r], d[0, 1])):
            assert np.array_equal(a.view(np.int64), b.view(np.int64)), (fname, f)


@pytest.mark.parametrize("fname,mode,h", [("occt__bearing.iges", "auto", 1.0), ("gmsh__U_Joint_2.stp", "loose", 1.0),
                                          ("occtpr946__ec_turbine-A.stp", "loose", 0.03)])
def test_fold_triangles_among_the_flipped_equals_all(shared_data, fname, mode, h, monkeypatch):
    """Loose mode's fold pruning tests the centroid flip only among the triangles seam reduction found
    flipped at the centroid or a corner: on real loose tessellations the same folded triangles as
    testing every triangle (the turbine at 3 % max edge has 4 flipped at the centroid among 9)."""
    from trimsurf.io import read_shell
    from trimsurf.tessellate import stitch as stitch_mod
    from trimsurf.tessellate import tessellate_shell

    orig = stitch_mod._fold_triangles
    seen = []

    def both(mesh, cuv, faces, among=None):
        got = orig(mesh, cuv, faces, among)
        if among is not None:
            ref = orig(mesh, cuv, faces)
            assert np.array_equal(got, ref)
            seen.append((len(among), mesh.n_triangles))
        return got

    monkeypatch.setattr(stitch_mod, "_fold_triangles", both)
    shell = read_shell(shared_data / "cad" / fname)
    d = shell.diagonal()
    res = tessellate_shell(shell, tolerance=1e-3 * d, max_edge=h * d, measure=False, mode=mode)
    assert res.mode == "loose" and seen and all(0 <= a < m for a, m in seen)
    if "turbine" in fname:
        assert res.report["stitch_folds_pruned"] > 0


def test_scalar_round_is_np_round_12():
    """`_triangulate_polygon`'s duplicate test rounds x / scale to 12 decimals in scalars: the values of
    np.round(xy / scale, 12) (points at every scale, near-duplicates 1e-13..1e-12 of the size apart,
    values that are exact halves after scaling: 2^-k multiples)."""
    rng = np.random.default_rng(12)
    n_diff = 0
    for trial in range(5000):
        m = int(rng.integers(3, 12))
        xy = rng.standard_normal((m, 2)) * 10.0 ** rng.uniform(-8, 8)
        if trial % 3 == 0:
            xy[rng.integers(0, m)] = xy[0] + rng.choice([1e-13, 1e-12, 5e-13, 0.0]) * np.abs(xy).max()
        if trial % 7 == 0:
            xy = np.round(xy * 2.0 ** 40) / 2.0 ** 40        # dyadic: x * 1e12 / scale can be a tie
        rows = xy.tolist()
        scale = max(max(r[0] for r in rows) - min(r[0] for r in rows), max(r[1] for r in rows) - min(r[1] for r in rows))
        if not scale > 0:
            continue
        want = np.round(xy / scale, 12).tolist()
        got = [(round(x / scale * 1e12) / 1e12, round(y / scale * 1e12) / 1e12) for x, y in rows]
        assert [tuple(w) for w in want] == got, trial
        n_diff += len({tuple(w) for w in want}) != m
    assert n_diff > 100


def _orient_reference(mesh):
    """`orient.orient_meshes` of main 1fb9934 (votes gathered edge by edge in a dict)."""
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
    adj: dict = {}
    for a, b, g in zip(key_a.tolist(), key_b.tolist(), agree.tolist()):
        v = adj.setdefault((a, b), [0, 0])
        v[0 if g else 1] += 1
    nbrs: dict = {int(f): [] for f in faces}
    for (a, b), (n_ok, n_bad) in adj.items():
        same_orient = n_ok >= n_bad
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
    return _TriMesh(mesh.vertices, t, uv=mesh.uv, face_id=fid), flipped



def test_orient_meshes_equals_the_dict_votes():
    """`orient_meshes` (votes by np.unique and bincount, face pairs in first-edge order) flips the same
    faces and gives the same triangles as main's dict of votes: random meshes cut into faces, some faces
    reversed, some triangles of a face reversed (disagreeing votes), several components."""
    from scipy.spatial import Delaunay

    from trimsurf.tessellate.orient import orient_meshes

    rng = np.random.default_rng(21)
    n_flipped = 0
    for trial in range(80):
        n = int(rng.integers(6, 200))
        P = rng.random((n, 2))
        T = Delaunay(P).simplices.astype(np.int64)
        if trial % 4 == 0:
            T = np.concatenate([T, T[: len(T) // 3] + n])
            P = np.concatenate([P, P + 2.0])
        cen = P[T].mean(axis=1)
        k = int(rng.integers(1, 9))
        fid = (np.floor(cen[:, 0] * k) + k * np.floor(cen[:, 1] * 2)).astype(np.int64)
        rev = rng.random(fid.max() + 1) < 0.4
        tri = np.where(rev[fid][:, None], T[:, ::-1], T)
        odd = rng.random(len(tri)) < (0.1 if trial % 3 == 0 else 0.0)
        tri = np.where(odd[:, None], tri[:, ::-1], tri)
        mesh = _TriMesh(np.c_[P, np.zeros(len(P))], tri, face_id=fid)
        got, got_f = orient_meshes(mesh)
        want, want_f = _orient_reference(mesh)
        assert got_f == want_f, trial
        assert np.array_equal(got.triangles, want.triangles)
        n_flipped += len(want_f)
    assert n_flipped > 50


def test_flip_edges_memo_is_the_recomputed_candidates(shared_data, monkeypatch):
    """`_State.flip_edges` reusing its batch's candidates until the first swap gives the swaps, triangles,
    (u, v) and bounds of computing each candidate again in the loop: on U_Joint's seams (diagonal swaps
    done), with every flipped triangle listed twice (the second time after its swap, where a stale
    candidate would swap again)."""
    import copy

    from trimsurf.io import read_shell
    from trimsurf.tessellate import tessellate_shell

    shell = read_shell(shared_data / "cad" / "gmsh__U_Joint_2.stp")
    d = shell.diagonal()
    seen = []
    orig = seams_mod._State.flip_edges

    def keep(self, bad):
        if not seen:
            seen.append((copy.deepcopy({k: v for k, v in vars(self).items() if k not in ("faces", "surfaces")}),
                         self, np.array(bad)))
        return orig(self, bad)
    monkeypatch.setattr(seams_mod._State, "flip_edges", keep)
    tessellate_shell(shell, tolerance=1e-3 * d, max_edge=d, measure=False)
    monkeypatch.setattr(seams_mod._State, "flip_edges", orig)
    saved, st, bad = seen[0]
    out = []
    for memo in (True, False):
        monkeypatch.setattr(seams_mod, "_MEMO_SWAPS", memo)
        for k, v in copy.deepcopy(saved).items():
            setattr(st, k, v)
        n = st.flip_edges(np.r_[bad, bad])
        out.append((n, st.T.copy(), st.cuv.copy(), st.dev.copy()))
    assert out[0][0] == out[1][0] >= 2
    for a, b in zip(out[0][1:], out[1][1:]):
        assert np.array_equal(a, b)


def test_packed_surfaces_follow_an_edited_list():
    """The packed surfaces and flat-face cones are rebuilt when an item of the same list object changes."""
    from trimsurf.model import NurbsSurface, TrimmedFace

    P = np.array([[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]], dtype=float)
    faces = [TrimmedFace(NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], P), same_sense=True)]
    assert seams_mod._same_sense(faces).tolist() == [True]
    assert seams_mod._face_cones(faces)[0][0].tolist() == [0.0, 0.0, 1.0]
    faces[0] = TrimmedFace(NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], P), same_sense=False)
    assert seams_mod._same_sense(faces).tolist() == [False]
    assert seams_mod._face_cones(faces)[0][0].tolist() == [-0.0, -0.0, -1.0]
