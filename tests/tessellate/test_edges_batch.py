"""The batched bookkeeping of the conforming edges (issue 17) against the use-by-use / edge-by-edge code it
replaces: `trims._batch_arrays` (the kernel's input arrays in a few numpy passes) against
`trims._batch_arrays_loop`, and `shell._edge_point_ids` (the global vertex ids of the edges' points)
against `shell._edge_point_ids_loop`, array for array."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from trimsurf.io import read_shell
from trimsurf.samples import build_sample
from trimsurf.tessellate.face import face_domain_values
from trimsurf.tessellate.shell import _edge_point_ids, _edge_point_ids_loop, _ptol
from trimsurf.tessellate.trims import ChunkUse, _batch_arrays, _batch_arrays_loop, discretize_chunks


def _edge_chunks(shell, tol, h):
    grids, chunks, edges = {}, [], []
    for ei, e in enumerate(shell.edges):
        uses = []
        for fi, li, si in e.uses:
            f = shell.faces[fi]
            if fi not in grids:
                grids[fi] = face_domain_values(f, tolerance=0.97 * tol, max_edge=h)
            us, vs = grids[fi]
            uses.append(ChunkUse(fi, li, si, f.loops[li].segments[si], f.surface, us, vs, _ptol(f)))
        if uses:
            chunks.append(uses)
            edges.append(ei)
    return chunks, edges


def _same_arrays(a: tuple, b: tuple) -> None:
    assert len(a) == len(b)
    for i, (x, y) in enumerate(zip(a, b)):
        assert x.dtype == y.dtype and x.shape == y.shape, i
        assert x.tobytes() == y.tobytes(), f"array {i} differs"
        assert x.flags.c_contiguous


@pytest.mark.parametrize("model", ["gmsh__t20_data.step", "occt__screw.step", "bspline_box"])
def test_batch_arrays_equal_use_by_use(shared_data, model):
    shell = build_sample(model) if "." not in model else read_shell(shared_data / "cad" / model)
    d = shell.diagonal()
    chunks, _ = _edge_chunks(shell, 1e-3 * d, d)
    singles = [[u] for ch in chunks for u in ch]
    # shared chunks, single uses, and a mix with reversed order (other surfaces / grids first)
    for cl in (chunks, singles, chunks[::-1] + singles[:3]):
        got, ref = _batch_arrays(cl), _batch_arrays_loop(cl)
        _same_arrays(got, ref)
        # the flat arrays are read-only, as the kernels are compiled for them
        assert not any(x.flags.writeable for x in got[2:7])
    # rational and polynomial p-curves in one batch (the homogeneous rows of the rational ones only)
    rat = [u.pcurve.curve.weights is not None for ch in chunks for u in ch]
    if any(rat) and not all(rat):
        _same_arrays(_batch_arrays(singles), _batch_arrays_loop(singles))


@pytest.mark.parametrize("model", ["gmsh__t20_data.step", "occt__screw.step"])
def test_edge_point_ids_equal_edge_by_edge(shared_data, model):
    shell = read_shell(shared_data / "cad" / model)
    d = shell.diagonal()
    tol = 1e-3 * d
    chunks, edges = _edge_chunks(shell, tol, d)
    ch = discretize_chunks(chunks, tolerance=tol, max_edge=d,
                           degenerate=[True if shell.edges[e].is_degenerate else None for e in edges])
    for start in (0, 17):
        n1, n2 = [start], [start]
        got = _edge_point_ids(shell, edges, ch, tol, n1)
        ref = _edge_point_ids_loop(shell, edges, ch, tol, n2)
        assert n1 == n2
        assert len(got) == len(ref) and all(np.array_equal(a, b) for a, b in zip(got, ref))
        assert n1[0] - start > sum(len(c.s) for c in ch) - 2 * len(ch)      # ids were handed out


def test_edge_point_ids_vertex_cases():
    """Shared, reversed, missing and repeated end vertices, a closed edge without vertices (and one
    that is not closed), degenerate edges: the same ids as edge by edge."""
    rng = np.random.default_rng(3)

    def chunk(k, closed=False, degenerate=False):
        xyz = rng.normal(size=(k, 3))
        if closed:
            xyz[-1] = xyz[0]
        return SimpleNamespace(s=np.linspace(0, 1, k), xyz=xyz, degenerate=degenerate)

    E = lambda v, t0=0.0, t1=1.0: SimpleNamespace(vertices=v, t0=t0, t1=t1)  # noqa: E731
    edges = [E((0, 1)), E((1, 2), 1.0, 0.0), E((-1, -1)), E((-1, -1)), E((2, 2)), E((3, -1)), E((-1, 0)),
             E((4, 5)), E((5, 4), 2.0, 1.0), E((6, 6))]
    chunks = [chunk(5), chunk(3), chunk(6, closed=True), chunk(4), chunk(7), chunk(2), chunk(3),
              chunk(2, degenerate=True), chunk(4), chunk(3, degenerate=True)]
    shell = SimpleNamespace(edges=edges)
    order = list(range(len(edges)))
    for perm in (order, order[::-1], [3, 7, 0, 9, 2, 5, 1, 8, 4, 6]):
        n1, n2 = [100], [100]
        got = _edge_point_ids(shell, perm, [chunks[i] for i in perm], 1.0, n1)
        ref = _edge_point_ids_loop(shell, perm, [chunks[i] for i in perm], 1.0, n2)
        assert n1 == n2
        assert all(np.array_equal(a, b) for a, b in zip(got, ref)), perm
    # the closed edge ends on its first id, the other one without vertices does not; degenerate: one id
    got = _edge_point_ids(shell, order, chunks, 1.0, [0])
    assert got[2][-1] == got[2][0] and got[3][-1] != got[3][0]
    assert len(set(got[7].tolist())) == 1 and len(set(got[9].tolist())) == 1
    assert _edge_point_ids(shell, [], [], 1.0, [5]) == []


# --- repair: the batched pass (`repair.quick_repairs`) against `repair_face` face by face


def _same_repair(a, b) -> bool:
    return (a.face is b.face and a.status == b.status and list(a.messages) == list(b.messages)
            and list(a.filled) == list(b.filled) and a.max_g1_angle_deg == b.max_g1_angle_deg)


@pytest.mark.parametrize("model", ["trimesh__featuretype.STEP", "gmsh__U_Joint_2.stp", "occt__screw.step"])
def test_quick_repairs_equal_repair_face(shared_data, model):
    from trimsurf.tessellate.repair import quick_repairs, repair_face

    shell = read_shell(shared_data / "cad" / model)
    tol = 0.97e-3 * shell.diagonal()
    quick = quick_repairs(shell.faces, tolerance=tol)
    assert len(quick) == len(shell.faces)
    taken = [i for i, q in enumerate(quick) if q is not None]
    assert len(taken) >= 0.5 * len(shell.faces)         # the batch does take the faces that need nothing
    for i in taken:
        assert _same_repair(quick[i], repair_face(shell.faces[i], tolerance=tol)), i
    # the G1 flag and its message (a threshold every C0 knot line exceeds)
    quick = quick_repairs(shell.faces, tolerance=tol, g1_angle_deg=0.0)
    flagged = 0
    for i, q in enumerate(quick):
        if q is not None:
            ref = repair_face(shell.faces[i], tolerance=tol, g1_angle_deg=0.0)
            assert _same_repair(q, ref), i
            flagged += q.status == "flagged"
    assert flagged or model == "occt__screw.step"


def test_quick_repairs_leaves_the_faces_repair_changes(monkeypatch):
    """Joints that are no exact join: a gap just above the first test's threshold and one within the
    tolerance in 3D (joined: the face as it was, quick_repairs gives repair_face's answer), an open
    loop (None: repair_face rejects the face)."""
    import dataclasses

    from trimsurf.model import Loop, PCurve, TrimmedFace
    from trimsurf.tessellate.repair import quick_repairs, repair_face

    box = build_sample("bspline_box")
    face = box.faces[0]
    tol = 1e-3 * box.diagonal()
    loop = face.loops[0]
    (u0, u1), (v0, v1) = face.surface.domain
    span = max(u1 - u0, v1 - v0)
    seg = loop.segments[0]

    def shortened(frac, name):
        short = PCurve(seg.curve, seg.t0, seg.t1 - frac * (seg.t1 - seg.t0), edge_id=seg.edge_id)
        return TrimmedFace(face.surface, (Loop((short,) + tuple(loop.segments[1:])),) + tuple(face.loops[1:]),
                           face.same_sense, name, face.tolerance)

    near = shortened(2e-9 * span / abs(seg.t1 - seg.t0), "near")
    within = shortened(1e-7, "within")
    open_ = shortened(0.3, "open")
    faces = [face, near, within, open_]
    import trimsurf.tessellate.repair as rp

    kinds, gap_kinds = [], rp._gap_kinds
    monkeypatch.setattr(rp, "_gap_kinds", lambda *a: kinds.extend(k[0] for k in gap_kinds(*a)) or gap_kinds(*a))
    quick = quick_repairs(faces, tolerance=tol)
    assert kinds == ["joined", "joined", "open"]        # the three joints that fail the first test
    monkeypatch.undo()
    ref = [repair_face(f, tolerance=tol) for f in faces]
    assert [r.status for r in ref] == ["ok", "ok", "ok", "failed"]
    assert quick[3] is None
    for q, r in zip(quick[:3], ref[:3]):
        assert q is not None and _same_repair(q, r)


@pytest.mark.parametrize("model", ["trimesh__featuretype.STEP", "gmsh__U_Joint_2.stp", "occt__screw.step",
                                   "gmsh__t20_data.step"])
def test_g1_batched_equals_g1_reference(shared_data, model):
    """`g1_defects` as it was written (per face, knots by `_full_knots`) against the batched one of
    quick_repairs (knots of all faces in one pass, the angles of all faces together)."""
    from trimsurf.quality.sampling import inside_face
    from trimsurf.tessellate.repair import _POLE_REL, _full_knots, _normals_and_areas, quick_repairs

    def g1_reference(face, n=33):       # the code of g1_defects before the batch (commit 1fb9934)
        s = face.surface
        (u0, u1), (v0, v1) = s.domain
        sides = []
        for axis, knots, p, (a, b), (c, d) in ((0, s.knots_u, s.degree_u, (u0, u1), (v0, v1)),
                                               (1, s.knots_v, s.degree_v, (v0, v1), (u0, u1))):
            lines = [v for v, _, _ in _full_knots(knots[p + 1:-p - 1], p, p)]
            if not lines:
                continue
            eps = 1e-7 * (b - a)
            k = np.array(lines)
            mid = np.empty((len(k), n, 2))
            mid[:, :, axis] = k[:, None]
            mid[:, :, 1 - axis] = np.linspace(c, d, n)
            uv_l, uv_r = mid.copy(), mid.copy()
            uv_l[:, :, axis] = (k - eps)[:, None]
            uv_r[:, :, axis] = (k + eps)[:, None]
            sides.append((uv_l, uv_r, mid))
        if not sides:
            return 0.0
        uv_l, uv_r, mid = sides[0] if len(sides) == 1 else (np.concatenate([x[q] for x in sides]) for q in range(3))
        ins = inside_face(face, mid.reshape(-1, 2), n_per_segment=16).reshape(len(mid), n)
        if not ins.any():
            return 0.0
        flat = ins.ravel()
        m = int(flat.sum())
        dd = s.derivatives(np.concatenate([uv_l.reshape(-1, 2)[flat], uv_r.reshape(-1, 2)[flat]]), 1)
        nl, area_l = _normals_and_areas(dd[1, 0, :m], dd[0, 1, :m])
        nr, area_r = _normals_and_areas(dd[1, 0, m:], dd[0, 1, m:])
        cos = np.clip(np.einsum("ij,ij->i", nl, nr), -1.0, 1.0)
        cnt = ins.sum(axis=1)
        cnt = cnt[cnt > 0]
        start = np.r_[0, np.cumsum(cnt)[:-1]]
        regular = np.ones(len(cos), dtype=bool)
        for area in (area_l, area_r):
            top = np.maximum(np.maximum.reduceat(area, start), 0.0)
            regular &= area > np.repeat(_POLE_REL * np.maximum(top, 1e-300), cnt)
        ang = np.degrees(np.arccos(cos[np.isfinite(cos) & regular]))
        return max(0.0, float(ang.max())) if len(ang) else 0.0

    from trimsurf.tessellate.repair import g1_defects

    shell = read_shell(shared_data / "cad" / model)
    ref = [g1_reference(f) for f in shell.faces]
    assert [g1_defects(f) for f in shell.faces] == ref
    quick = quick_repairs(shell.faces, tolerance=1e-3 * shell.diagonal())
    got = {i: q.max_g1_angle_deg for i, q in enumerate(quick) if q is not None}
    assert got == {i: ref[i] for i in got}
    if model != "occt__screw.step":
        assert sum(g > 0 for g in got.values()) >= 5        # faces with C0 knot lines were batched


def test_gap_kinds_equal_one_by_one(shared_data):
    """The joints of one surface in one evaluation (`repair._gap_kinds`) against the code of one joint."""
    from trimsurf.tessellate.repair import _gap_kinds

    def _gap_kind(s, a, b, span, tolerance):      # repair_face's joint code before the batch (commit 1fb9934)
        gap_uv = float(np.linalg.norm(b - a))
        if gap_uv <= 1e-9 * span:
            return "joined", gap_uv, None
        pa, pb = s.evaluate(np.array([a, b]))
        gap3 = float(np.linalg.norm(pb - pa))
        line_pts = s.evaluate(a + np.linspace(0, 1, 17)[:, None] * (b - a))
        spread = float(np.linalg.norm(line_pts - pa, axis=1).max())
        if spread <= 1e-3 * tolerance and gap_uv > 1e-4 * span:
            return "fill", gap_uv, gap3
        return ("joined" if gap3 <= tolerance else "open"), gap_uv, gap3

    shell = read_shell(shared_data / "cad" / "gmsh__U_Joint_2.stp")
    rng = np.random.default_rng(7)
    n = 0
    for f in shell.faces[:40]:
        (u0, u1), (v0, v1) = f.surface.domain
        span = max(u1 - u0, v1 - v0)
        lo, hi = np.array([u0, v0]), np.array([u1, v1])
        a = lo + rng.random((6, 2)) * (hi - lo)
        step = np.array([0.0, 1e-12, 1e-6, 1e-3, 0.05, 0.5])[:, None] * span
        b = np.clip(a + step * rng.normal(size=(6, 2)), lo, hi)
        tol = 1e-3 * shell.diagonal()
        got = _gap_kinds(f.surface, a, b, span, tol)
        ref = [_gap_kind(f.surface, a[j], b[j], span, tol) for j in range(6)]
        assert got == ref
        n += len({k[0] for k in got})
    assert n > 40           # more than one kind per surface on the whole


def test_quick_repairs_on_the_repair_cases(tmp_path, shared_data):
    """The faces of test_repair.py (patch grids broken outside / inside the trim, a surface broken at a
    knot, creases inside / outside the trim, a flat C0 line, loop gaps joined / rejected, a suit-case
    corner, a pole, three bent patches) through quick_repairs and repair_face: the same result wherever
    quick_repairs takes a face, and it takes those repair_face leaves as they are."""
    from trimsurf.model import Loop, NurbsSurface, TrimmedFace
    from trimsurf.tessellate.repair import quick_repairs, repair_face

    from .test_repair import _bent_plane, _line, _loop, _plane, _read, _square_face, _surf_tokens, _vda

    faces = []
    faces.append(_read(_vda(tmp_path / "o.vda", [("S1", "SURF", _surf_tokens(displace=(1, 1, 0.05)))]
                             + _square_face("S1", 0.1, 0.9))).faces[0])
    faces.append(_read(_vda(tmp_path / "i.vda", [("S1", "SURF", _surf_tokens(displace=(1, 1, 0.05)))]
                             + _square_face("S1", 0.5, 1.5))).faces[0])
    faces += list(_read(_vda(tmp_path / "b.vda", [("S1", "SURF", _surf_tokens(s_breaks=(0.0, 1.0, 1.0))),
                                                   ("S2", "SURF", _surf_tokens(dx=3.0))])).faces)
    cp = np.zeros((4, 2, 3))
    cp[:, :, 0] = [[0, 0], [1, 1], [1, 1], [2, 2]]
    cp[:, 1, 1] = 1.0
    cp[2:, :, 2] = 0.3
    faces.append(TrimmedFace(NurbsSurface(1, 1, [0, 0, 1, 1, 2, 2], [0, 0, 1, 1], cp), name="step"))
    faces.append(TrimmedFace(_bent_plane(30.0), name="crease"))
    faces.append(TrimmedFace(_bent_plane(30.0), (_loop((0.1, 0.1), (0.9, 0.1), (0.9, 0.9), (0.1, 0.9)),),
                             name="half"))
    faces.append(TrimmedFace(_bent_plane(0.0), name="flat"))
    sq = [(0.1, 0.1), (0.9, 0.1), (0.9, 0.9), (0.1, 0.9)]
    for gap in (5e-4, 5e-2):
        segs = list(_loop(*sq).segments)
        segs[1] = _line((0.9, 0.1 + gap), (0.9, 0.9))
        faces.append(TrimmedFace(_plane(), (Loop(tuple(segs)),), name=f"gap{gap}"))
    cp = np.zeros((2, 2, 3))
    cp[1, 0, 0] = 1.0
    cp[:, 1] = [0.5, 1.0, 0.0]
    three = Loop((_line((0, 0), (1, 0)), _line((1, 0), (1, 1)), _line((0, 1), (0, 0))))
    faces.append(TrimmedFace(NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], cp), (three,), name="suitcase"))
    faces.append(TrimmedFace(_plane(), (three,), name="plane"))
    faces.append(read_shell(shared_data / "cad" / "occtpr946__bug32596_abc_0_13.step").faces[11])
    for tol in (1e-3, 2e-3):
        quick = quick_repairs(faces, tolerance=tol)
        ref = [repair_face(f, tolerance=tol) for f in faces]
        for f, q, r in zip(faces, quick, ref):
            if q is None:
                assert r.status in ("failed", "repaired") or r.face is not f, f.name
            else:
                assert _same_repair(q, r), f.name
        taken = {f.name for f, q in zip(faces, quick) if q is not None}
        assert {"FS1", "S2", "crease", "half", "flat", "gap0.0005"} <= taken
        assert not taken & {"step", "gap0.05", "suitcase", "plane"}
        assert [q.status for f, q in zip(faces, quick) if f.name == "crease"] == ["flagged"]
        assert any("outside the trimmed area" in m for m in quick[0].messages)
