"""The per-face triangulation's shortcuts (issue 17, session 24): compiled kernels against the numpy code
they replace (bit for bit), the planar faces' exact deviation bound."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.io import read_shell
from trimsurf.tessellate import face as face_mod
from trimsurf.tessellate import grid as grid_mod
from trimsurf.tessellate import slivers as slivers_mod
from trimsurf.tessellate import tessellate_shell
from trimsurf.tessellate.face import (_BARY, _plane_offset, _triangle_deviation_numpy, surface_distance,
                                      triangle_deviation)


@pytest.fixture(scope="module")
def featuretype(shared_data):
    return read_shell(shared_data / "cad" / "trimesh__featuretype.STEP")


@pytest.fixture(scope="module")
def t20(shared_data):
    return read_shell(shared_data / "cad" / "gmsh__t20_data.step")


def test_triangle_deviation_kernel_equals_numpy(t20):
    """`deviation_samples` (sample points summed as einsum sums, shared edge midpoints once) gives
    `triangle_deviation` bit for bit, for batches of 1 to 3000 triangles, shared edges, repeated and
    reversed rows, on rational and polynomial surfaces."""
    rng = np.random.default_rng(11)
    for face in t20.faces[:6]:
        s = face.surface
        (u0, u1), (v0, v1) = s.domain
        uv = np.column_stack([rng.uniform(u0, u1, 400), rng.uniform(v0, v1, 400)])
        xyz = s.evaluate(uv) + rng.normal(scale=1e-3, size=(400, 3))
        for m in (1, 2, 7, 50, 3000):
            tris = rng.integers(0, 40 if m > 7 else 400, (m, 3))      # few vertices: many shared edges
            tris = np.r_[tris, tris[:3, ::-1], tris[:2]]
            got = triangle_deviation(s, uv, xyz, tris)
            assert np.array_equal(got, _triangle_deviation_numpy(s, uv, xyz, tris))
            # and it is the full sampling: the max over all seven samples of each triangle
            full = surface_distance(s, np.einsum("bk,mkd->mbd", _BARY, uv[tris]).reshape(-1, 2),
                                    np.einsum("bk,mkd->mbd", _BARY, xyz[tris]).reshape(-1, 3))
            assert np.array_equal(got, full.reshape(len(tris), -1).max(axis=1))


def test_grid_nodes_kernel_equals_numpy():
    """The grid nodes (merged into trim points they equal, the first of equal trim points) and the kept
    cells' triangles of the compiled path equal the numpy reference, on random grids whose trim points
    sit on grid nodes, on grid lines, repeat, or lie anywhere."""
    rng = np.random.default_rng(5)
    for trial in range(40):
        nu, nv = rng.integers(2, 9, 2)
        us = np.cumsum(rng.uniform(0.1, 1.0, nu))
        vs = np.cumsum(rng.uniform(0.1, 1.0, nv))
        k = int(rng.integers(3, 30))
        pts = np.column_stack([rng.uniform(us[0], us[-1], k), rng.uniform(vs[0], vs[-1], k)])
        on = rng.random(k) < 0.5
        pts[on, 0] = us[rng.integers(0, nu, on.sum())]
        on2 = rng.random(k) < 0.5
        pts[on2, 1] = vs[rng.integers(0, nv, on2.sum())]
        pts = np.r_[pts, pts[rng.integers(0, k, 3)]]                   # repeated trim points
        crossed = rng.random((nu - 1, nv - 1)) < 0.3
        keep = ~crossed & (rng.random((nu - 1, nv - 1)) < 0.6)
        ki, kj = np.nonzero(keep)
        main = rng.random(len(ki)) < 0.5
        node_uv, node_gn, trim_gn, tris = grid_mod._grid_nodes_kernel(pts, us, vs, crossed, keep, ki, kj, main)
        uv, gn, ref_tris = grid_mod._grid_nodes_numpy(pts, us, vs, crossed, keep, ki, kj, main)
        assert np.array_equal(np.r_[pts, node_uv], uv), trial
        assert np.array_equal(np.r_[trim_gn, node_gn], gn), trial
        assert np.array_equal(tris, ref_tris), trial


def _planar_face_meshes(shell, tol, h):
    out = []
    orig = face_mod.mesh_face_from_chunks

    def rec(face, *a, **k):
        fm = orig(face, *a, **k)
        out.append((face, fm))
        return fm

    import trimsurf.tessellate.shell as shell_mod

    shell_mod.mesh_face_from_chunks, saved = rec, shell_mod.mesh_face_from_chunks
    try:
        tessellate_shell(shell, tolerance=tol, max_edge=h, measure=False)
    finally:
        shell_mod.mesh_face_from_chunks = saved
    return [(f, fm) for f, fm in out if _plane_offset(f.surface, tol) is not None]


def _plane_distance(face, tol, x):
    delta, normal, height = _plane_offset(face.surface, tol)
    return np.abs(x @ normal - height), delta


def _check_planar(face, fm, tol, d):
    s = face.surface
    t = fm.triangles if face.same_sense else fm.triangles[:, ::-1]
    sampled = triangle_deviation(s, fm.uv, fm.xyz, t)
    off = np.linalg.norm(s.evaluate(fm.uv) - fm.xyz, axis=1)
    # the rounds' test (mesh_face_from_chunks): bad = dev > tol and dev > corner offset + 0.05 tol
    assert not np.any((sampled > tol) & (sampled > off[fm.triangles].max(axis=1) + 0.05 * tol))
    assert np.all(fm.tri_dev >= sampled - 1e-12 * d)
    # dense barycentric points of each triangle against the plane (an independent best-fitting one)
    p = s.control_points.reshape(-1, 3)
    c = p.mean(axis=0)
    normal = np.linalg.svd(p - c)[2][-1]
    w = np.random.default_rng(0).dirichlet(np.ones(3), 64)
    x = np.einsum("sk,mkd->msd", w, fm.xyz[fm.triangles])
    dist = np.abs((x - c) @ normal).max(axis=1)
    assert np.all(dist <= fm.tri_dev + 1e-12 * d)
    return sampled


def test_planar_faces_exact_bound_and_no_rounds(featuretype):
    """On the planar faces (featuretype: 49 of 96) the deviation rounds are skipped: their sampled
    deviations (what the rounds test) never exceed the rounds' threshold, and tri_dev, the corners'
    distances to the plane, bounds both the sampled deviation and the distance to the plane of dense
    points of every triangle."""
    d = featuretype.diagonal()
    tol = 1e-3 * d
    faces = _planar_face_meshes(featuretype, tol, d)
    assert len(faces) >= 40
    for face, fm in faces:
        _check_planar(face, fm, tol, d)


def test_planar_face_trim_off_the_plane(featuretype):
    """A planar face whose trim points lie off the plane (a gap in the model: the mean of two faces'
    curves): tri_dev carries their offset (0.3 tol here) to the triangles at the trim, still bounds every
    dense point, and no interior point would have helped (the rounds' test finds nothing)."""
    from trimsurf.tessellate.face import face_domain_values, loose_chunks, mesh_face_from_chunks

    d = featuretype.diagonal()
    tol = 1e-3 * d
    face = next(f for f in featuretype.faces if _plane_offset(f.surface, tol) is not None and len(f.loops) > 1)
    us, vs = face_domain_values(face, tolerance=tol, max_edge=0.05 * d)
    chunks = loose_chunks(face, 0, us, vs, tolerance=tol, max_edge=0.05 * d, strategy="equidistributed")
    _, normal, _ = _plane_offset(face.surface, tol)
    for entries in chunks:
        for chunk, _, _ in entries:
            chunk.xyz[:] = chunk.xyz + 0.3 * tol * normal
    fm = mesh_face_from_chunks(face, us, vs, chunks, tolerance=tol, max_edge=0.05 * d)
    dist, _ = _plane_distance(face, tol, fm.xyz)
    at_trim = dist > 0.2 * tol                  # the shifted trim points (the lifted ones lie in the plane)
    assert at_trim.sum() > 10 and not at_trim.all()
    touching = at_trim[fm.triangles].any(axis=1)
    assert np.all(fm.tri_dev[touching] >= 0.3 * tol * (1 - 1e-9))
    sampled = _check_planar(face, fm, tol, d)
    assert sampled.max() > 0.25 * tol          # the sampling sees the offset too: the shift took effect


def test_plane_offset_rejects_curved_and_bent(t20):
    """A cylinder or a plane bent by more than 1e-3 of the tolerance is no plane."""
    tol = 1e-3 * t20.diagonal()
    kinds = [(_plane_offset(f.surface, tol) is not None, f.surface) for f in t20.faces]
    assert any(k for k, _ in kinds) and not all(k for k, _ in kinds)
    from dataclasses import replace

    for planar, s in kinds:
        if planar and s.control_points.shape[0] * s.control_points.shape[1] >= 4:
            cp = s.control_points.copy()
            cp[-1, -1] += 2e-3 * tol * np.cross(cp[-1, 0] - cp[0, 0], cp[0, -1] - cp[0, 0]) / np.linalg.norm(
                np.cross(cp[-1, 0] - cp[0, 0], cp[0, -1] - cp[0, 0]))
            assert _plane_offset(replace(s, control_points=cp), tol) is None
            break
    else:
        pytest.fail("no planar face in t20")


def _select_reference(T, idx, nv, inner, trim):
    """The selection loop over `collapse_sets` that `_select_collapses_kernel` replaces."""
    from trimsurf.tessellate._collapse import collapse_sets

    flat = T[idx].ravel()
    order = np.argsort(flat, kind="stable")
    vstart = np.searchsorted(flat[order], np.arange(nv + 1)).tolist()
    vtri = idx[order // 3].tolist()
    Tl = T.tolist()
    locked = np.zeros(nv, dtype=bool)
    sel = []
    for q, (v, u) in enumerate(zip(inner.tolist(), trim.tolist())):
        if locked[v] or locked[u]:
            continue
        _, star, common, gone, moved = collapse_sets(Tl, vtri, vstart, v, u)
        if not gone or len(gone) > 2 or any(locked[x] for x in star) or len(common) != len(gone):
            continue
        sel.append((q, moved, gone))
        locked[list(star | {u})] = True
    return sel


def test_select_collapses_kernel_equals_collapse_sets_loop():
    """The compiled selection takes the same collapses, with the same moved and gone triangles in the same
    order, as the loop over `collapse_sets`: Delaunay meshes of random points, some triangles dead, random
    (v, u) pairs along edges and not."""
    from scipy.spatial import Delaunay

    rng = np.random.default_rng(4)
    for trial in range(30):
        n = int(rng.integers(10, 300))
        T = Delaunay(rng.random((n, 2))).simplices.astype(np.int64)
        alive = rng.random(len(T)) < 0.9
        idx = np.flatnonzero(alive)
        e = T[rng.integers(0, len(T), 3 * n)]
        c = rng.integers(0, 3, len(e))
        inner = e[np.arange(len(e)), c]
        trim = np.where(rng.random(len(e)) < 0.8, e[np.arange(len(e)), (c + 1) % 3], rng.integers(0, n, len(e)))
        keep = inner != trim
        inner, trim = inner[keep], trim[keep]
        qs, mv, ms, gn, gs = slivers_mod._select_collapses_kernel(T, idx, n, inner, trim)
        ref = _select_reference(T, idx, n, inner, trim)
        assert qs.tolist() == [r[0] for r in ref], trial
        assert [mv[ms[k]:ms[k + 1]].tolist() for k in range(len(qs))] == [r[1] for r in ref]
        assert [gn[gs[k]:gs[k + 1]].tolist() for k in range(len(qs))] == [r[2] for r in ref]
        assert len(ref) > 0


def test_min_angles_one_pass_equals_per_side():
    """`_min_angles_deg` (sides and cosines in one pass) equals the per-side law of cosines bit for bit,
    on random, thin and degenerate triangles at three scales."""
    def ref(P):
        a = np.linalg.norm(P[:, 1] - P[:, 2], axis=1)
        b = np.linalg.norm(P[:, 2] - P[:, 0], axis=1)
        c = np.linalg.norm(P[:, 0] - P[:, 1], axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            ca = np.clip((b * b + c * c - a * a) / (2 * b * c), -1, 1)
            cb = np.clip((a * a + c * c - b * b) / (2 * a * c), -1, 1)
            cc = np.clip((a * a + b * b - c * c) / (2 * a * b), -1, 1)
        ang = np.degrees(np.arccos(np.stack([ca, cb, cc], axis=1)))
        return np.where(np.isnan(ang), 0.0, ang).min(axis=1)

    rng = np.random.default_rng(1)
    for scale in (1e-6, 1.0, 1e3):
        P = rng.normal(size=(20000, 3, 3)) * scale
        P[::7, 1] = P[::7, 0] + 1e-9 * scale * rng.normal(size=(len(P[::7]), 3))     # thin
        P[::11, 2] = P[::11, 0]                                                     # degenerate
        assert np.array_equal(ref(P), slivers_mod._min_angles_deg(P))


def _dist_to_polygon(p, poly):
    a, b = poly, np.roll(poly, -1, axis=0)
    d = b - a
    t = np.clip(np.einsum("nkd,kd->nk", p[:, None] - a[None], d) / np.einsum("kd,kd->k", d, d), 0, 1)
    return np.linalg.norm(p[:, None] - (a[None] + t[..., None] * d[None]), axis=2).min(axis=1)


def test_triangulate_domain_crossing_points_mapped_back():
    """Trim polygons crossing each other and the grid lines: the crossing points `clean_pslg` inserts
    come back from Triangle's (scaled, sheared) coordinates onto the polygons, and the triangles cover
    the even-odd region."""
    us = np.linspace(0.0, 1.0, 6)
    vs = np.linspace(0.0, 1.0, 5)
    outer = np.array([[0.1, 0.1], [0.9, 0.1], [0.9, 0.9], [0.1, 0.9]])
    other = np.array([[0.5, 0.5], [0.97, 0.63], [0.61, 0.97]])       # crosses x = 0.9 and y = 0.9
    for tie in (None, True, False):
        dt = grid_mod.triangulate_domain(us, vs, [outer, other], tie_main=tie)
        new = np.flatnonzero((np.arange(len(dt.uv)) >= dt.n_trim) & (dt.grid_node < 0))
        p = dt.uv[new]
        d_outer, d_other = _dist_to_polygon(p, outer), _dist_to_polygon(p, other)
        # every new point is where a trim segment crossed a cell side or the other loop: on a loop ...
        assert np.all(np.minimum(d_outer, d_other) < 1e-12)
        # ... and the loops' two crossings are among them, on both
        assert np.count_nonzero((d_outer < 1e-12) & (d_other < 1e-12)) >= 2
        q = dt.uv[dt.triangles]
        area = 0.5 * ((q[:, 1, 0] - q[:, 0, 0]) * (q[:, 2, 1] - q[:, 0, 1])
                      - (q[:, 2, 0] - q[:, 0, 0]) * (q[:, 1, 1] - q[:, 0, 1]))
        assert np.all(area > 0)
        # even-odd: the square plus the triangle minus twice their overlap (by a fine raster)
        g = (np.arange(2000) + 0.5) / 2000
        X, Y = np.meshgrid(g, g)
        pts = np.column_stack([X.ravel(), Y.ravel()])
        from trimsurf.geom.predicates import points_in_polygons

        expect = points_in_polygons(pts, [outer, other]).mean()
        assert abs(area.sum() - expect) < 2e-3
