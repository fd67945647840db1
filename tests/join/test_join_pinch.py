"""Issue 13: the midpoint baseline sews the turbine. A face whose hole touches its outer loop (turbine face 1)
has one mesh boundary loop through the touching vertex twice; its chains must follow the face's loops."""

from __future__ import annotations

import numpy as np

import trimsurf.io as tio
from trimsurf.join import midpoint_join, mesh_faces_independently
from trimsurf.join._chains import mesh_boundary_loops, mesh_chains
from trimsurf.join._patch import project_mesh
from trimsurf.model import Shell

from .test_join_accuracy import _subshell


def test_boundary_loop_through_a_pinch_vertex():
    # two fans meeting at vertex 0 (a bow tie): one boundary walk that passes vertex 0 twice, each time
    # leaving by the fan it came in by
    tris = np.array([[0, 1, 2], [0, 2, 3], [0, 4, 5], [0, 5, 6]])
    loops = mesh_boundary_loops(tris, 7)
    assert len(loops) == 2 and sorted(len(lp) for lp in loops) == [4, 4]
    for lp in loops:
        assert 0 in lp.tolist() and len(set(lp.tolist()) - {0}) == 3
        assert set(lp.tolist()) - {0} in ({1, 2, 3}, {4, 5, 6})


def test_turbine_pinched_face_chains_and_baseline_sews(shared_data):
    whole = tio.read_shell(shared_data / "cad" / "occtpr946__ec_turbine-A.stp")
    d = 1e-3 * whole.diagonal()
    shell = _subshell(whole, [0, 1])
    meshes = mesh_faces_independently(shell, d)
    face = shell.faces[1]
    # face 1: an outer loop of two pieces and a circular hole that touches it at one vertex
    assert len(face.loops) == 2 and len(face.loops[1].segments) == 1
    pr = project_mesh(face, meshes[1])
    assert len(mesh_boundary_loops(pr.triangles, len(pr.uv))) == 1
    chains = mesh_chains(face, pr.uv, pr.triangles)
    hole = chains[(1, 0)]
    seg = face.loops[1].segments[0]
    curve = seg.curve.evaluate(np.linspace(seg.t0, seg.t1, 2001))
    dist = np.min(np.linalg.norm(pr.uv[hole][:, None] - curve[None], axis=2), axis=1)
    assert dist.max() < 1e-3 * np.ptp(curve, axis=0).max()      # the hole's chain runs along the hole only
    assert hole[0] == hole[-1] and len(hole) < len(pr.uv)
    # the baseline closes the circle shared by faces 0 and 1: no open edge between two joint vertices
    base = midpoint_join(shell, meshes)
    be = base.mesh.boundary_edges()
    assert not base.on_joint[be].all(axis=1).any()
    assert len(base.mesh.non_manifold_edges()) == 0


def test_pinch_in_an_inconsistently_oriented_mesh_does_not_crash():
    # the second fan turned the other way: no fan walk exists; the plain walk is taken instead of a KeyError
    tris = np.array([[0, 1, 2], [0, 2, 3], [0, 4, 5], [0, 6, 5]])
    loops = mesh_boundary_loops(tris, 7)
    assert sum(len(lp) for lp in loops) >= 4
