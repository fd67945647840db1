"""Demo steps of `trimsurf.reconstruct`: the MNN paper's examples (shifted octahedron, boundary problem,
car part, machinery part with its design curves), Shirman-Séquin baseline vs G1 and G2 minimum norm
networks (split, Peters' single quintics, single degree-7 patches), as Gaussian-curvature pictures,
with every fill's sampled G1 error and curvature jump across patch edges."""

from __future__ import annotations

import numpy as np

from .demo_steps import StepContext, StepOutput, step

__all__: list[str] = []

_PANEL = (460, 400)
_VARIANTS = (("Shirman-Sequin", dict(network="shirman-sequin", fill="split")),
             ("G1 MNN, split", dict(network="g1", fill="split")),
             ("G2 MNN, single", dict(network="g2", fill="single")))
# the small examples also with Peters' single quintics (the paper fills its Fig. 5 network with them)
_WITH_PETERS = _VARIANTS[:2] + (("G1 MNN, Peters", dict(network="g1", fill="peters")),) + _VARIANTS[2:]
# the machinery part as in the paper's Fig. 7a/7b: Shirman-Sequin vs G2 D2 L2 split vs G2 single
_MACHINERY = (("Shirman-Sequin", dict(network="shirman-sequin", fill="split")),
              ("G2 D2 L2 split", dict(network="g2", fill="split", direction="d2", length="l2")),
              ("G2 D2 L2 single", dict(network="g2", fill="single", direction="d2", length="l2")))


def _case(ctx: StepContext, name: str, mesh, density: int, sphere: bool, zebra: bool = False,
          variants=_VARIANTS, features=()) -> tuple[dict, list]:
    from ..reconstruct import radial_deviation, reconstruct_mesh, save_patches
    from ..viz import render_compare_png

    figures: dict = {}
    panels, scalars, titles, smooth = [], [], [], []
    for label, kw in variants:
        rec = reconstruct_mesh(mesh, feature_chains=features, **kw)
        r = rec.report
        key = kw["network"].replace("-", "_") + ("_" + kw["fill"] if variants is _MACHINERY
                                                 or kw["fill"] == "peters" else "")
        figures[f"{name}.{key}.g1_angle_max_deg"] = r["g1_angle_max_deg"]
        figures[f"{name}.{key}.g1_error_max_deg"] = r["g1_error_max_deg"]
        figures[f"{name}.{key}.curvature_jump_max"] = r["curvature_jump_max"]
        figures[f"{name}.{key}.iterations"] = r["iterations"]
        if sphere:
            dmax, drms = radial_deviation(rec.patches, np.zeros(3), 1.0, density=density)
            figures[f"{name}.{key}.radial_deviation_max"] = dmax
            figures[f"{name}.{key}.radial_deviation_rms"] = drms
            label = f"{label}: radial dev {dmax:.3f}"
        if features:
            figures[f"{name}.{key}.feature_kink_max_deg"] = r["feature_kink_max_deg"]
            figures[f"{name}.{key}.seconds"] = r["seconds"]
            label = f"{label}: kink {r['feature_kink_max_deg']:.2g} deg"
        m, K = rec.patches.curvature_mesh(density)
        if zebra:
            smooth.append(rec.patches.evaluate_mesh(density))
        panels.append(m)
        scalars.append(K)
        titles.append(label)
        if kw["network"] == "g1" and kw["fill"] != "peters":
            save_patches(rec.patches, ctx.out(f"{name}.g1.npz"))
    allk = np.concatenate(scalars)
    lo, hi = np.percentile(allk, [2, 98])
    if sphere:   # symmetric about the sphere's K = 1
        half = max(abs(lo - 1), abs(hi - 1), 0.25)
        lo, hi = 1 - half, 1 + half
    path = ctx.out(f"{name}.gaussian_curvature.png")
    render_compare_png(panels, path, titles=titles, mode="scalars", scalars=scalars,
                       scalar_name="Gaussian curvature (exact, from the patches)", window_size=_PANEL,
                       clim=(float(lo), float(hi)))
    images = [path]
    if zebra:
        zpath = ctx.out(f"{name}.zebra.png")
        render_compare_png(smooth, zpath, titles=[t.split(":")[0] for t in titles], mode="zebra", window_size=_PANEL)
        images.append(zpath)
    return figures, images


@step("reconstruct", kinds=("mesh",))
def _reconstruct(ctx: StepContext) -> StepOutput:
    """MNN reconstruction: baseline vs G1 vs G2 on the paper's examples (octahedron) or G1 on other meshes."""
    from ..reconstruct import reconstruct_mesh
    from ..samples import boundary_problem, car_panel, machinery_part, machinery_part_features, octahedron

    if ctx.sample != "octahedron":
        feats = machinery_part_features() if ctx.sample == "machinery_part" else ()
        rec = reconstruct_mesh(ctx.obj, network="g1", fill="split", feature_chains=feats)
        r = rec.report
        return StepOutput(figures={k: r[k] for k in ("vertices", "patches", "iterations", "g0_gap",
                                                       "g1_angle_max_deg", "g1_error_max_deg",
                                                       "curvature_jump_max", "vertex_interpolation_error",
                                                       "folded_edges", "feature_kink_max_deg", "seconds")})
    density = 6 if ctx.quick else 10
    figures: dict = {}
    images = []
    cases = [("shifted_octahedron", octahedron(), True), ("boundary_problem", boundary_problem(), True),
             ("car_panel", car_panel(grid=29 if ctx.quick else 41), False)]
    for name, mesh, sphere in cases:
        f, im = _case(ctx, name, mesh, density, sphere, zebra=name == "car_panel" and not ctx.quick,
                      variants=_VARIANTS if name == "car_panel" else _WITH_PETERS)
        figures.update(f)
        images.extend(im)
    f, im = _case(ctx, "machinery_part", machinery_part(), density, False, variants=_MACHINERY,
                  features=machinery_part_features())
    figures.update(f)
    images.extend(im)
    return StepOutput(figures=figures, images=images, files=list(images))
