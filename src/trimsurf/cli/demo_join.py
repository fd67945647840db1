"""Demo step of the join capability: the paper's folding case, midpoint sewing vs Whitney join (zebra pictures)."""

from __future__ import annotations

import numpy as np

from .demo_steps import StepContext, StepOutput, step


def _flip_flags(shell, mesh):
    """Per-triangle 1.0 where the normal points against the face's outward normal, else 0.0."""
    from ..quality import flipped_triangles_normal

    flags = np.zeros(mesh.n_triangles)
    for f, face in enumerate(shell.faces):
        idx = np.flatnonzero(mesh.face_id == f)
        if len(idx):
            flags[idx[flipped_triangles_normal(mesh.submesh(mesh.face_id == f), face).flipped]] = 1.0
    return flags


@step("join", kinds=("shell",))
def _join(ctx: StepContext) -> StepOutput:
    """Join Open CASCADE's per-face meshes of every multi-face sample; on folding_pair, baseline vs trimsurf."""
    shell = ctx.obj
    if not any(len(e.uses) == 2 for e in shell.edges):
        return StepOutput(figures={"skipped": "no shared edge to join"})
    if ctx.sample == "folding_pair":
        return _folding_case(ctx)
    from ..io import occ_mesh_faces, write_mesh
    from ..join import join_shell

    meshes = occ_mesh_faces(shell, linear_deflection=(2e-3 if ctx.quick else 5e-4) * shell.diagonal())
    res = join_shell(shell, meshes, deflection=(2e-3 if ctx.quick else 5e-4) * shell.diagonal())
    path = ctx.out("joined.ply")
    write_mesh(res.mesh, path)
    keys = ("vertices", "triangles", "joined_edges", "flipped_before", "flipped_after", "abs_error_boundary",
            "abs_error_after", "lipschitz_boundary", "max_slope_after", "min_angle_external_deg",
            "boundary_edges_on_joins", "deflection", "max_deviation", "p99_deviation", "seconds")
    return StepOutput(figures={k: res.report[k] for k in keys}, files=[path])


def _folding_case(ctx: StepContext) -> StepOutput:
    """The folding configuration of the paper (Fig. 2 second case, Figs. 7-9): midpoint sewing vs Whitney join."""
    from ..io import write_mesh
    from ..join import join_shell, midpoint_join
    from ..samples.folding_pair import folding_pair_meshes
    from ..viz import render_compare_png

    fold = ctx.obj
    fmeshes = folding_pair_meshes(fold)
    base = midpoint_join(fold, fmeshes).mesh
    res = join_shell(fold, fmeshes)
    good = res.mesh
    path = ctx.out("joined.ply")
    write_mesh(good, path)
    fb, fg = _flip_flags(fold, base), _flip_flags(fold, good)
    figures = {"fold_flipped_midpoint": int(fb.sum()), "fold_flipped_whitney": int(fg.sum()),
               "min_angle_external_deg": res.report["min_angle_external_deg"],
               "boundary_edges_on_joins": res.report["boundary_edges_on_joins"]}
    t_base = f"midpoint sewing (Sec. I): {int(fb.sum())} flipped"
    t_good = f"Whitney join: {int(fg.sum())} flipped"
    whole = render_compare_png([base, good], ctx.out("join-fold-zebra.png"), titles=(t_base, t_good),
                               mode="zebra", camera="+z", n_stripes=14.0)
    # close-up of the corner where l4 moved across the edge c1-c2: the turned triangle overlaps its neighbours
    corner = fmeshes[0].vertices[3]
    focus = corner + [-0.03, -0.05, 0.0]
    cam = (tuple(focus + [0.0, 0.0, 0.6]), tuple(focus), (0.0, 1.0, 0.0))
    close = render_compare_png([base, good], ctx.out("join-fold-closeup.png"), titles=(t_base, t_good),
                               mode="mesh", camera=cam)
    return StepOutput(figures=figures, files=[path], images=[whole, close])
