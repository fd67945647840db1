"""Skeptical check of the measured deviation on a real model: the report's figure is not below the true
maximum over dense independent points.

Independent points, both directions, none of them the measurement's own samples:

- surface -> mesh: Open CASCADE's mesh nodes of every face at a deflection of eps / 25 (exact points of
  the face's surface, placed by another program), each measured to the written triangles of its face;
- mesh -> surface: a barycentric grid of 12 divisions per edge on every written triangle (78 points per
  triangle), projected onto its face.

occt__screw.step at eps = 1e-3 of the diagonal: the fixed 3 x 3 barycentric and 32 x 32 domain sampling
reported 0.5641 eps while the dense points reach 0.5728 eps (gmsh__wrenchnut.stp: 0.9458 vs 0.9622).
"""

from __future__ import annotations

import numpy as np

from trimsurf.io import occ_mesh_faces, read_shell
from trimsurf.quality import shell_deviation
from trimsurf.quality.closest_point import closest_points_on_mesh
from trimsurf.tessellate import tessellate_shell
from trimsurf.tessellate.measure import REFINE, measure_mesh


def test_reported_deviation_holds_the_dense_independent_maximum(shared_data):
    shell = read_shell(shared_data / "cad" / "occt__screw.step")
    eps = 1e-3 * shell.diagonal()
    res = tessellate_shell(shell, tolerance=eps, measure=False)
    mesh = res.mesh
    rep = measure_mesh(mesh, shell)
    old = measure_mesh(mesh, shell, refine=None)
    # surface -> mesh over Open CASCADE's nodes, face by face
    t2m = 0.0
    n_points = 0
    for i, occ in enumerate(occ_mesh_faces(shell, linear_deflection=eps / 25, angular_deflection=0.1)):
        sel = mesh.face_id == i
        if occ is None or not occ.n_vertices or not sel.any():
            continue
        t2m = max(t2m, float(closest_points_on_mesh(occ.vertices, mesh.submesh(sel)).distance.max()))
        n_points += occ.n_vertices
    m2s = shell_deviation(mesh, shell, density=12, two_sided=False).max_mesh_to_target
    truth = max(t2m, m2s)
    assert n_points > 5 * mesh.n_vertices
    # the slip this guards against: the fixed sampling reported less than the dense points show
    assert old["max_deviation"] < truth * (1 - 5e-3)
    # the refined figure: within REFINE below the truth at worst (it stops when the bound leaves no more
    # than that), and the curvature bound at or above it
    assert rep["max_deviation"] >= truth * (1 - REFINE)
    assert rep["max_deviation_bound"] >= truth
    assert rep["max_deviation_bound"] <= rep["max_deviation"] * (1 + REFINE) + 1e-12
    assert rep["max_deviation"] <= eps
