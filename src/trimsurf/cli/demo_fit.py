"""Demo step of the fit capability: every mesh sample -> trimmed NURBS face (STEP) + picture of its deviation."""

from __future__ import annotations

from ..errors import InputError
from .demo_steps import StepContext, StepOutput, step


@step("fit", kinds=("mesh",))
def _fit(ctx: StepContext) -> StepOutput:
    """Fit a trimmed NURBS face to the mesh (forward map + back-map + trims), write STEP, read it back, measure it
    and render the face read back coloured by its distance to the mesh."""
    from .fit import fit_mesh

    path = ctx.out("fit.step")
    png = ctx.out("fit.png")
    try:
        report, _ = fit_mesh(ctx.obj, path, embed="auto", backmap="lsq", name=ctx.sample, png=png)
    except InputError as exc:           # e.g. a closed sample: not a disk with holes
        return StepOutput(figures={"skipped": str(exc)})
    keys = ("vertices", "loops", "embed", "backmap", "flipped_in_embedding", "hausdorff", "hausdorff_rel",
            "rms_deviation", "boundary_deviation", "area_ratio", "self_intersections", "step_valid", "problems",
            "seconds_fit", "seconds_write", "seconds_measure")
    images = [png]
    if ctx.sample == "s_cone" and not ctx.quick:
        images.append(_table5_picture(ctx))
    return StepOutput(figures={k: report[k] for k in keys}, files=[path], images=images)


def _table5_picture(ctx: StepContext):
    """The paper's Table 5 / Fig. 9 side by side: the S strip's layout by HLLE (no folds) and by Isomap (folded)."""
    import numpy as np

    from ..fit import embed, embedding_quality
    from ..model import TriMesh
    from ..viz import render_compare_png

    mesh = ctx.obj
    flats, titles = [], []
    for method in ("hlle", "isomap"):
        uv = embed(mesh, method)
        q = embedding_quality(mesh, uv)
        flags = np.zeros(mesh.n_triangles)
        flags[q.flipped] = 1.0
        flats.append(TriMesh(np.c_[uv, np.zeros(len(uv))], mesh.triangles))
        titles.append(f"{method}: {q.n_flipped} flipped triangles, {q.n_boundary_crossings} loop crossings")
    path = ctx.out("fit-layouts.png")
    return render_compare_png(flats, path, titles=tuple(titles), mode="mesh", camera="+z")
