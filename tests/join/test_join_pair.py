"""Joining two patches: the folding case of the paper (Fig. 2 / Fig. 7), gap_pair, bad meshes."""

from __future__ import annotations

import numpy as np
import pytest

import trimsurf.io as tio
from trimsurf.errors import InputError
from trimsurf.join import join_shell, midpoint_join, patch_errors
from trimsurf.join._boundary import delete_loops, median_polyline
from trimsurf.model import TriMesh
from trimsurf.samples import build_sample
from trimsurf.samples.folding_pair import FOLD_TRIANGLE, folding_pair, folding_pair_meshes

from ._checks import check_patch, flipped


@pytest.fixture(scope="module")
def fold():
    shell = folding_pair()
    return shell, folding_pair_meshes(shell)


def _flips_per_face(shell, mesh):
    out = []
    for f, face in enumerate(shell.faces):
        sub = mesh.submesh(mesh.face_id == f)
        uv = tio_uv(face, sub)
        out.append(flipped(face, uv, sub.vertices, sub.triangles if face.same_sense else sub.triangles[:, ::-1]))
    return out


def tio_uv(face, mesh):
    from trimsurf.join._patch import project_points
    return project_points(face, mesh.vertices).uv


def test_fold_baseline_flips_trimsurf_does_not(fold):
    shell, meshes = fold
    # the input meshes are fine: nothing turned over
    for face, m in zip(shell.faces, meshes):
        assert flipped(face, m.uv, m.vertices, m.triangles if face.same_sense else m.triangles[:, ::-1]) == 0
    base = midpoint_join(shell, meshes).mesh
    assert _flips_per_face(shell, base)[0] >= 1
    # the turned triangle is the one of Fig. 2: (l4, c2, c1) with l4 moved to the midpoint of l4 and r2
    names = ["l1", "l2", "l3", "l4", "t1", "c1", "c2"]
    left = base.submesh(base.face_id == 0)
    corner = {n: left.vertices[np.argmin(np.linalg.norm(left.vertices - shell.faces[0].surface.evaluate(
        [meshes[0].uv[i]])[0], axis=1))] for i, n in enumerate(names) if n != "l4"}
    assert set(FOLD_TRIANGLE) - {"l4"} <= set(corner)
    res = join_shell(shell, meshes)
    assert res  # no bad face
    assert _flips_per_face(shell, res.mesh) == [0, 0]
    assert [f.flipped_after for f in res.faces] == [0, 0]


def test_fold_guarantees(fold):
    shell, meshes = fold
    res = join_shell(shell, meshes)
    diag = shell.diagonal()
    for face, r in zip(shell.faces, res.patches):
        check_patch(face, r, diag=diag)
    # the joint: no boundary edge of the merged mesh lies on the shared edge x = 1
    be = res.mesh.boundary_edges()
    x = res.mesh.vertices[be][:, :, 0]
    assert not np.any(np.all(np.abs(x - 1.0) < 1e-9, axis=1))
    assert len(res.mesh.non_manifold_edges()) == 0
    assert res.mesh.is_consistently_oriented()


def test_central_mesh_uv_untouched(fold):
    shell, meshes = fold
    res = join_shell(shell, meshes)
    for face, m, r in zip(shell.faces, meshes, res.patches):
        src = r.central_source
        kept = src >= 0
        # central vertices keep the (u, v) they were projected to (mesh on the surface: their own uv)
        np.testing.assert_allclose(r.uv[kept], m.uv[src[kept]], rtol=0, atol=1e-12)
        # and every central triangle that was not split is in the output unchanged
        central = ~r.external
        t = src[r.triangles[central]]
        assert r.n_central > 0 and len(t) >= 1
        orig = {tuple(sorted(x)) for x in m.triangles.tolist()}
        whole = t[(t >= 0).all(axis=1)]
        assert all(tuple(sorted(x)) in orig for x in whole.tolist())


def test_gap_pair_case1_and_case2():
    shell = build_sample("gap_pair")
    diag = shell.diagonal()
    meshes = tio.occ_mesh_faces(shell, linear_deflection=1e-3 * diag)
    for use_curves in (True, False):
        res = join_shell(shell, meshes, use_edge_curves=use_curves)
        assert res
        for face, r in zip(shell.faces, res.patches):
            check_patch(face, r, diag=diag)
        assert [e.case for e in res.edges if e.joined] == [1 if use_curves else 2]
        # shared edge: both faces use the same points, so the merged mesh has no boundary there
        m = res.mesh
        be = m.boundary_edges()
        joined = res.edges[[e.key for e in res.edges if e.joined][0]]
        on_joint = np.isin(be, np.arange(len(m.vertices))[
            np.min(np.linalg.norm(m.vertices[:, None] - joined.points[None], axis=2), axis=1) < 1e-12])
        assert not np.any(on_joint.all(axis=1))
        assert len(m.non_manifold_edges()) == 0


def test_case2_median_polyline_and_join(fold):
    shell, meshes = fold
    left = meshes[0].vertices[:4]                      # l1..l4
    right = meshes[1].vertices[[0, 9]]                 # r1 (u=0, v=0), r2 (u=0, v=1)
    med, s = median_polyline(left, right)
    # ends paired (l1 with r1, l4 with r2) and every vertex of either chain contributes a fraction
    np.testing.assert_allclose(med[-1], 0.5 * (left[-1] + right[-1]), rtol=0, atol=1e-15)
    np.testing.assert_allclose(med[0], 0.5 * (left[0] + right[0]), rtol=0, atol=1e-15)
    assert len(med) == 4
    res = join_shell(shell, meshes, use_edge_curves=False)
    ed = next(e for e in res.edges if e.joined)
    assert ed.case == 2
    assert res and all(f.flipped_after == 0 for f in res.faces)
    for face, r in zip(shell.faces, res.patches):
        check_patch(face, r, diag=shell.diagonal())


def test_delete_loops():
    # a polyline whose (u, v) image crosses itself once: the loop between the crossing segments goes
    uv = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, -1.0], [3.0, -1.0]])
    pts = np.column_stack([uv, np.zeros(len(uv))])
    p2, w2, _, n_cut = delete_loops(pts, uv)
    assert n_cut == 1
    np.testing.assert_allclose(w2, [[0, 0], [1, 0], [1, -1], [3, -1]], atol=1e-15)


def test_long_edge_splitting_keeps_guarantees():
    # Sec. III-D: splitting long edges of thin triangles and reprojecting the new vertex can only bring the
    # piecewise-linear height closer to the Whitney average; every guarantee still holds after it
    shell = build_sample("gap_pair")
    diag = shell.diagonal()
    meshes = tio.occ_mesh_faces(shell, linear_deflection=1e-3 * diag)
    plain = join_shell(shell, meshes)
    split = join_shell(shell, meshes, split_long_edges=True)
    assert sum(r.n_split_long for r in split.patches) > 0
    for f, r0, r1 in zip(shell.faces, plain.patches, split.patches):
        c0, c1 = check_patch(f, r0, diag=diag), check_patch(f, r1, diag=diag)
        assert c1["max_gradient"] <= c0["max_gradient"] * (1 + 1e-9)
        assert c1["n_incl_violations"] == 0
    assert split.mesh.n_triangles > plain.mesh.n_triangles


def test_bad_mesh_reported_not_moved(fold):
    shell, meshes = fold
    far = TriMesh(meshes[1].vertices + [0.0, 0.0, 0.5], meshes[1].triangles, uv=meshes[1].uv)
    res = join_shell(shell, [meshes[0], far])
    assert not res
    assert res.bad_faces == [1]
    rep = res.faces[1]
    assert rep.status == "bad" and rep.max_distance == pytest.approx(0.5, rel=0.2)
    sub = res.mesh.submesh(res.mesh.face_id == 1)
    assert sub.n_triangles == far.n_triangles
    np.testing.assert_array_equal(np.sort(sub.vertices, axis=0), np.sort(far.vertices, axis=0))


def test_non_injective_mesh_is_remeshed(fold):
    # a mesh whose projection turns triangles over (M^-1 not injective, Sec. II): no longer left unjoined
    # (a crack along the shared edge) but re-triangulated over its whole (u, v) domain, sharing the edge's
    # vertices with its neighbour
    shell, meshes = fold
    v = meshes[1].vertices.copy()
    v[[10, 11]] = v[[11, 10]]
    turned = TriMesh(v, meshes[1].triangles)
    res = join_shell(shell, [meshes[0], turned])
    assert res and res.bad_faces == [] and res.remeshed_faces == [1]
    assert res.faces[1].status == "remeshed" and "injective" in res.faces[1].message
    assert res.report["n_remeshed"] == 1 and res.report["remeshed_faces"][0]["face"] == 1
    assert res.report["boundary_edges_on_joins"] == 0 and len(res.mesh.boundary_edges()) == \
        len(join_shell(shell, meshes).mesh.boundary_edges())        # only the pair's free edges are open
    assert res.report["flipped_after"] == 0
    assert res.report["max_deviation"] <= res.report["deflection"]
    # none of the turned mesh's triangles is kept: face 1 is Triangle's mesh of the whole domain
    r = res.patches[1]
    assert r.n_central == 0 and r.external.all()


def test_bad_arguments(fold):
    shell, meshes = fold
    with pytest.raises(InputError, match="one mesh per face"):
        join_shell(shell, meshes[:1])
    with pytest.raises(InputError, match="TriMesh"):
        join_shell(shell, [meshes[0], "x"])
    with pytest.raises(InputError, match="Shell"):
        join_shell("x", meshes)


def test_patch_errors_criteria(fold):
    shell, meshes = fold
    res = join_shell(shell, meshes)
    for f, face in enumerate(shell.faces):
        sub = res.mesh.submesh(res.mesh.face_id == f)
        e = patch_errors(sub, face, scale=res.patches[f].scale)
        # the mean-square criterion never exceeds the sup criterion (Sec. II)
        assert np.all(e.per_triangle_rms <= e.per_triangle_sup + 1e-12)
        assert e.abs_error <= res.patches[f].eps_max + 1e-8


def test_bad_input_public_functions(fold):
    shell, meshes = fold
    with pytest.raises(InputError, match="one mesh per face"):
        midpoint_join(shell, meshes[:1])
    with pytest.raises(InputError, match="TriMesh and a TrimmedFace"):
        patch_errors("x", shell.faces[0])
    with pytest.raises(InputError, match="edge_spacing"):
        join_shell(shell, meshes, edge_spacing=-1.0)
    with pytest.raises(InputError, match="min_angle_deg"):
        join_shell(shell, meshes, min_angle_deg=40.0)


def test_untrimmed_face_uses_its_domain_rectangle():
    # a face without loops is the whole domain: dR is the rectangle's image (Case 2 / p-curve images)
    from trimsurf.model import Shell, TrimmedFace

    shell0 = folding_pair()
    face = TrimmedFace(shell0.faces[0].surface, (), name="plain")
    shell = Shell.from_faces([face])
    mesh = folding_pair_meshes(shell0)[0]
    res = join_shell(shell, [mesh])
    assert res and res.faces[0].status == "joined"
    check = res.patches[0]
    assert check.n_removed > 0 and res.mesh.n_triangles > 0
    assert res.report["flipped_after"] == 0
