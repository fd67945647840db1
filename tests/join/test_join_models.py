"""Whole models: every face meshed by Open CASCADE separately, joined into one watertight mesh."""

from __future__ import annotations

import numpy as np
import pytest

import trimsurf.io as tio
from trimsurf.join import join_shell

from ._checks import check_patch

# model -> connected components of the joined mesh (the wrenchnut is two solids that only touch)
MODELS = {"gmsh__t20_data.step": 1, "occtpr946__trj5_k1-pe-214.stp": 1, "gmsh__wrenchnut.stp": 2}


@pytest.mark.parametrize("name", MODELS)
def test_step_model_joined_watertight(shared_data, name):
    shell = tio.read_shell(shared_data / "cad" / name)
    diag = shell.diagonal()
    meshes = tio.occ_mesh_faces(shell, linear_deflection=2e-3 * diag)
    res = join_shell(shell, meshes, deflection=2e-3 * diag)
    assert res, [f.message for f in res.faces if f.status != "joined"]
    m = res.mesh
    # closed models: the per-face meshes become one closed, consistently oriented 2-manifold
    assert len(m.boundary_edges()) == 0
    assert len(m.non_manifold_edges()) == 0
    assert m.is_consistently_oriented()
    assert sum(f.flipped_after for f in res.faces) == 0
    for f, face in enumerate(shell.faces):
        check_patch(face, res.patches[f], diag=diag)
    # one closed component per solid
    assert m.n_components() == MODELS[name]


def test_step_model_case2(shared_data):
    shell = tio.read_shell(shared_data / "cad" / "gmsh__t20_data.step")
    diag = shell.diagonal()
    meshes = tio.occ_mesh_faces(shell, linear_deflection=2e-3 * diag)
    res = join_shell(shell, meshes, use_edge_curves=False, deflection=2e-3 * diag)
    assert res
    assert all(e.case == 2 for e in res.edges)
    assert len(res.mesh.boundary_edges()) == 0 and len(res.mesh.non_manifold_edges()) == 0
    for f, face in enumerate(shell.faces):
        check_patch(face, res.patches[f], diag=diag)


def test_last_pass_points_shared_by_splitting(shared_data, monkeypatch):
    # with a single pass, the points Triangle puts on shared edges reach the neighbours by splitting their
    # boundary triangles (step 6); the result must still be closed, manifold and within the bounds
    import trimsurf.join._shell as shell_mod

    monkeypatch.setattr(shell_mod, "_MAX_STEINER_ROUNDS", 1)
    shell = tio.read_shell(shared_data / "cad" / "occtpr946__trj5_k1-pe-214.stp")
    diag = shell.diagonal()
    meshes = tio.occ_mesh_faces(shell, linear_deflection=2e-3 * diag)
    res = join_shell(shell, meshes, deflection=2e-3 * diag)
    assert res.report["steiner_points_shared_by_split"] > 0
    m = res.mesh
    assert len(m.boundary_edges()) == 0 and len(m.non_manifold_edges()) == 0
    assert m.is_consistently_oriented() and res.report["flipped_after"] == 0
    for f, face in enumerate(shell.faces):
        check_patch(face, res.patches[f], diag=diag)


def test_refined_strip_within_deflection_and_angle_bound(shared_data):
    # the size refinement (Triangle -r -a with the same -q) keeps Sec. III-B's angle bound where it is
    # claimed, and every external triangle's sampled deviation within the deflection (dR segments aside)
    from trimsurf.join._accuracy import triangle_deviation

    shell = tio.read_shell(shared_data / "cad" / "gmsh__t20_data.step")
    diag = shell.diagonal()
    d = 1e-3 * diag
    meshes = tio.occ_mesh_faces(shell, linear_deflection=d)
    res = join_shell(shell, meshes, deflection=d, measure=False)
    coarse = join_shell(shell, meshes, deflection=float("inf"), measure=False)
    assert res.mesh.n_triangles > coarse.mesh.n_triangles
    worst = worst_coarse = 0.0
    for face, r, rc in zip(shell.faces, res.patches, coarse.patches):
        check_patch(face, r, diag=diag)
        worst = max(worst, float(triangle_deviation(face, r.points, r.uv, r.triangles[r.external], density=6).max()))
        worst_coarse = max(worst_coarse, float(triangle_deviation(face, rc.points, rc.uv,
                                                                  rc.triangles[rc.external], density=6).max()))
    assert worst <= d < worst_coarse
