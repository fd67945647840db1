"""The issue's guarantees measured on real data: no triangle flipped against the surface normal, within
tolerance, 2-manifold; seam reduction never trades one of them for fewer triangles."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from trimsurf.io import read_shell
from trimsurf.model import Shell
from trimsurf.tessellate import default_parameters, tessellate_shell
from trimsurf.tessellate.measure import flipped_against_normal, measure_mesh

BUG32596 = "occtpr946__bug32596_abc_0_13.step"


def _sub_shell(shell: Shell, keep) -> Shell:
    """The faces `keep` of `shell` with their shared edges (edge indices kept: loops refer to them)."""
    keep = sorted(keep)
    new = {f: i for i, f in enumerate(keep)}
    edges = [replace(e, uses=tuple((new[f], li, si) for f, li, si in e.uses if f in new)) for e in shell.edges]
    return Shell(tuple(shell.faces[i] for i in keep), tuple(edges), shell.vertices, name=shell.name)


@pytest.fixture(scope="module")
def bug32596(shared_data):
    return read_shell(shared_data / "cad" / BUG32596)


@pytest.fixture(scope="module")
def thin_tips(bug32596):
    """bug32596 faces 3, 4, 13 and 65 (0.009 wide in u) end in tips where their two trims are closer
    than the tolerance; with their neighbours, at the whole model's tolerance and grid size."""
    tips = [3, 4, 13, 65]
    adj = bug32596.adjacency()
    keep = set(tips).union(*(adj[f] for f in tips))
    sub = _sub_shell(bug32596, keep)
    tol, h = default_parameters(bug32596)
    res = tessellate_shell(sub, tolerance=tol, max_edge=h, measure=False)
    return sub, res, [sorted(keep).index(f) for f in tips]


def test_thin_face_tips_not_flipped(thin_tips):
    """At each tip the triangle between the last trim points had its 3D normal against the surface's
    (the two trims' chords cross over in 3D while they do not in (u, v)); no triangulation with those
    boundary edges avoids it, so seam reduction collapses a seam edge of it (4 -> 0 flipped)."""
    sub, res, tips = thin_tips
    assert res.mode == "conforming" and res.ok
    fid = res.mesh.face_id
    assert all(np.count_nonzero(fid == f) > 10 for f in tips)         # the tip faces are tessellated
    assert flipped_against_normal(res.mesh, sub) == 0
    m = measure_mesh(res.mesh, sub)
    assert m["flipped"] == 0
    assert m["max_deviation"] <= res.tolerance
    assert m["nonmanifold_edges"] == 0 and m["orientation_consistent"]


def test_tips_stay_flipped_without_seam_reduction(thin_tips):
    """Without seam reduction the tips stay flipped: its repair pass is what removes them."""
    sub, res, _ = thin_tips
    plain = tessellate_shell(sub, tolerance=res.tolerance, max_edge=res.max_edge, reduce_seams=False,
                             measure=False)
    assert flipped_against_normal(plain.mesh, sub) > 0


def test_bug32596_whole_model(bug32596):
    """Closed model: watertight, 2-manifold, oriented, within tolerance, no flips; face 65 (edges 20
    and 56 cross on the surface) meshed, not skipped; no face flagged (face 11's 141 degree normal jump
    is at the pole of a surface of revolution, where the normal is undefined: 6e-5 degrees elsewhere)."""
    res = tessellate_shell(bug32596)
    r = res.report
    assert res.ok and r["faces_failed"] == 0
    assert 65 in set(res.mesh.face_id.tolist())
    assert [f.index for f in res.faces if f.status == "flagged"] == []
    assert r["boundary_edges"] == 0 and r["nonmanifold_edges"] == 0 and r["orientation_consistent"]
    assert r["flipped"] == 0
    assert r["uncovered_faces"] == []
    assert r["max_deviation"] <= res.tolerance


@pytest.mark.parametrize("fname", ["gmsh__t20_data.step", "occtpr946__ec_turbine-A.stp"])
def test_sliver_collapse_keeps_the_guarantees_on_every_face(shared_data, fname):
    """Boundary sliver collapse (batched rounds) on every face of a real part: fewer thin triangles at
    the trims, and every face still counter-clockwise in (u, v), not flipped, within the tolerance; on t20
    and on the turbine blade (rational B-splines up to degree 11, 489 poles; an open shell)."""
    from trimsurf.model import TriMesh
    from trimsurf.quality import flipped_triangles_normal, triangle_angles
    from trimsurf.tessellate import tessellate_face

    shell = read_shell(shared_data / "cad" / fname)
    tol, h = default_parameters(shell)
    thin_with = thin_without = 0
    for i, face in enumerate(shell.faces):
        with_s = tessellate_face(face, tolerance=tol, max_edge=h)
        without = tessellate_face(face, tolerance=tol, max_edge=h, slivers=False)
        assert with_s.n_triangles <= without.n_triangles
        thin_with += int(np.count_nonzero(triangle_angles(with_s).min(axis=1) < 12.0))
        thin_without += int(np.count_nonzero(triangle_angles(without).min(axis=1) < 12.0))
        p = with_s.uv[with_s.triangles]
        area = ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
        assert np.all(area > 0) or np.all(area < 0)
        one = Shell.from_faces([face])
        m = measure_mesh(TriMesh(with_s.vertices, with_s.triangles, face_id=np.zeros(with_s.n_triangles, int)), one)
        # no triangle with an area is flipped; one face alone keeps the zero-area triangles of a pole (two
        # corners at one 3D point, no orientation: the turbine's sphere face 35, 1 of them off zero by
        # rounding, 1e-15 mm^2); the shell's seam reduction collapses them (0 flipped in the whole model)
        flipped = flipped_triangles_normal(with_s, face).flipped
        assert np.all(with_s.triangle_areas()[flipped] <= 1e-12 * shell.diagonal() ** 2), f"face {i}"
        if m["flipped"]:
            assert fname == "occtpr946__ec_turbine-A.stp" and i == 35, f"face {i}"
        assert m["max_deviation"] <= tol, f"face {i}"
    assert thin_with < thin_without                          # the reduction ran and removed slivers


# -- which non-manifold edges the model explains (tessellate.measure.explained_nonmanifold_edges) --------

def _sheet(face_id, pts, tris):
    from trimsurf.model import TriMesh

    return TriMesh(np.asarray(pts, float), np.asarray(tris), face_id=np.full(len(tris), face_id))


def test_explained_nonmanifold_three_faces_along_a_curve_and_coincident_faces():
    from trimsurf.model import TriMesh
    from trimsurf.tessellate.measure import explained_nonmanifold_edges

    # edge (0,1) on the x axis; three fins, one triangle of each face, each face's boundary runs along it
    v = np.array([[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0], [0.5, 0, 1]], float)
    t = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    fins = TriMesh(v, t, face_id=np.array([0, 1, 2]))
    own = [_sheet(i, v, t[i:i + 1]) for i in range(3)]
    assert explained_nonmanifold_edges(fins, own, 1e-6).tolist() == [True]
    # the same edge, but face 2's own boundary lies 0.1 away (it was moved onto the edge): not explained
    moved = v.copy()
    moved[[0, 1], 1] += 0.1
    own[2] = _sheet(2, moved, t[2:3])
    assert explained_nonmanifold_edges(fins, own, 1e-2).tolist() == [False]
    assert explained_nonmanifold_edges(fins, own, 0.2).tolist() == [True]
    # two coincident faces (two touching solids' interface): two triangles of each, either side of the edge
    t2 = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 2], [1, 0, 3]])
    twin = TriMesh(v, t2, face_id=np.array([0, 0, 1, 1]))
    assert explained_nonmanifold_edges(twin, [None, None], 1e-6).tolist() == [True]


def test_unexplained_nonmanifold_fold_of_one_face_onto_a_neighbour():
    """A face with two triangles on one edge and a neighbour with one (a pinch of the face's trims stitched
    onto the neighbour, the turbine's face 1 in --loose): not explained, even when every boundary runs
    along the edge; nor are two triangles of one face folded onto the same side."""
    from trimsurf.model import TriMesh
    from trimsurf.tessellate.measure import explained_nonmanifold_edges

    v = np.array([[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0], [0.5, 0, 1]], float)
    t = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    mesh = TriMesh(v, t, face_id=np.array([0, 0, 1]))
    own = [_sheet(0, v, t[:2]), _sheet(1, v, t[2:])]
    # face 0's own mesh has the edge inside; give it its own copy with the edge on its boundary too
    own[0] = _sheet(0, v, t[:1])
    assert explained_nonmanifold_edges(mesh, own, 1.0).tolist() == [False]
    # coincident faces, but face 1's two triangles fold onto the same side of the edge
    t2 = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 2], [0, 1, 4]])
    folded = TriMesh(v, t2, face_id=np.array([0, 0, 1, 1]))
    assert explained_nonmanifold_edges(folded, [None, None], 1.0).tolist() == [False]
