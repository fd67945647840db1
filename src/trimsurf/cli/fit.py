"""``trimsurf fit MESH -o OUT.step``: fit a trimmed NURBS face to a triangle mesh with holes."""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

from ..errors import InputError, TrimsurfWarning
from ._common import (EXIT_FAILED, EXIT_OK, check_budget, examples, format_table, load_mesh, print_json,
                      print_warning, progress, write_json)

__all__ = ["NAME", "HELP", "DESCRIPTION", "EPILOG", "add_args", "run", "fit_mesh", "problems_of", "AREA_WINDOW",
           "EMBED_CHOICES", "BACKMAP_CHOICES"]

NAME = "fit"
HELP = "fit a trimmed NURBS face (surface + trim loops) to a triangle mesh with holes; write STEP"
DESCRIPTION = """\
Fit a trimmed NURBS face F = (S, {L0, L1, ...}) to a triangle mesh M with holes
(mesh-to-trimmed-nurbs-face, Ruiz et al. 2015): the boundary loops of M, a forward
map phi: M -> R^2, a rectangular grid W covering phi(M), a back-map S: W -> R^3,
and the trim loops L_i = S(lambda_i). The face is written as STEP (Open CASCADE
checks it). M must be a connected, oriented 2-manifold of genus 0 (a disk with
holes); other meshes are rejected (exit 2). The method assumes a near-developable
M: on strongly curved meshes the manifold learners fold (reported).

forward maps (--embed): hlle (Hessian LLE, the paper's best), isomap, laplacian,
lscm and harmonic (libigl), auto (hlle, then lscm, then harmonic: the first without
folds). back-maps (--backmap): lsq (least-squares B-spline on the mesh and an RBF
extrapolation, default), hybrid (RBF control polyhedron + NURBS, the paper's),
rbf (thin-plate spline, written as its least-squares B-spline conversion),
nurbs (iterative extrapolation, cubic S_i as in the paper or bilinear with
--extrapolation-degree 1), greville (hybrid at Greville abscissae).

The written file is read back through Open CASCADE and its face measured
against the mesh: Hausdorff distance both ways (sampled inside the trims),
area face / mesh, BRepCheck validity, self-intersections. These are the
report's figures; --diagnostics adds the in-memory ones.

Exit status: 0 ok, 1 the face is not trustworthy (it deviates more than
--max-deviation, its area is outside --area-ratio, it intersects itself, Open
CASCADE rejects it, its trim loops cross, or the forward map folds; it is
written anyway, and the reason is printed on one line), 2 bad input."""
EPILOG = examples("trimsurf fit part.off -o part.step",
                  "trimsurf fit scan.ply -o scan.step --embed lscm --backmap hybrid --grid 30 20 --report fit.json",
                  "trimsurf fit sheet.obj -o sheet.step --png sheet-fit.png",
                  "trimsurf fit holed_sheet -o sheet.step   # an embedded sample (trimsurf samples --list)")

EMBED_CHOICES = ("auto", "hlle", "isomap", "laplacian", "lscm", "harmonic")
BACKMAP_CHOICES = ("lsq", "hybrid", "rbf", "nurbs", "greville")
_AUTO_ORDER = ("hlle", "lscm", "harmonic")
AREA_WINDOW = (0.9, 1.1)
#: What the STEP file holds for each back-map.
WRITTEN_SURFACE = {"rbf": "cubic B-spline, least-squares conversion of the RBF",
                   "lsq": "cubic B-spline, least squares on the mesh and the RBF extrapolation",
                   "hybrid": "cubic B-spline on P = f(W)", "greville": "cubic B-spline on P = f(Greville points)",
                   "nurbs": "cubic B-spline on the extrapolated control net"}


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("mesh", type=Path, help="triangle mesh (OBJ, PLY, STL, OFF, glTF), or the name of an "
                                               "embedded sample (`trimsurf samples --list`)")
    parser.add_argument("-o", "--output", type=Path, required=True, help="STEP file to write (.step/.stp)")
    parser.add_argument("--embed", choices=EMBED_CHOICES, default="auto",
                        help="forward map phi: M -> R^2 (default auto: hlle, else lscm, else harmonic)")
    parser.add_argument("--backmap", choices=BACKMAP_CHOICES, default="lsq", help="back-map S (default lsq)")
    parser.add_argument("--grid", type=int, nargs=2, metavar=("NU", "NV"), default=None,
                        help="control points of S (default: from the mesh size, about one per 2 vertices of phi(M))")
    parser.add_argument("--trim-degree", type=int, choices=(1, 3), default=1,
                        help="p-curves as polylines through the boundary vertices (1, default) or "
                             "least-squares cubics (3)")
    parser.add_argument("--max-deviation", type=float, default=None, metavar="D",
                        help="largest Hausdorff distance between the mesh and the face read back from the file, "
                             "model units (default 1%% of the bounding-box diagonal); beyond it: exit 1")
    parser.add_argument("--area-ratio", type=float, nargs=2, default=list(AREA_WINDOW), metavar=("LO", "HI"),
                        help="window for the face's area over the mesh's (default 0.9 1.1); outside it: exit 1")
    parser.add_argument("--diagnostics", action="store_true",
                        help="also report the in-memory figures (the back-map on the mesh's parameter "
                             "triangulation before writing)")
    parser.add_argument("--extrapolation-degree", type=int, choices=(1, 3), default=3,
                        help="--backmap nurbs: degree of the surface S_i that extrapolates the control net ring by "
                             "ring (3, default: the paper's cubic; 1: bilinear, measures better, see RESULTS.md)")
    parser.add_argument("--report", type=Path, default=None, help="write the figures as JSON to this file")
    parser.add_argument("--png", type=Path, default=None,
                        help="render the face read back from the file (its tessellation), coloured by its "
                             "distance to the mesh")
    parser.add_argument("--json", action="store_true", help="print the report as JSON on stdout")


def _fit_auto(mesh, *, backmap, grid, trim_degree, name, tell, backmap_options=None):
    """The first of hlle, lscm, harmonic whose forward map neither folds nor crosses its loops (else hlle)."""
    from ..fit import DEVELOPABLE_LIMIT, embed, embedding_quality, fit_trimmed_face, mesh_brep

    brep = mesh_brep(mesh, name=name)
    if brep.total_abs_curvature > DEVELOPABLE_LIMIT:
        warnings.warn(f"{name}: far from developable (total |Gaussian curvature| / 2 pi = "
                      f"{brep.total_abs_curvature:.2f} > {DEVELOPABLE_LIMIT}): outside the method's assumption, "
                      "expect distortion", TrimsurfWarning, stacklevel=2)
    chosen, chosen_uv = _AUTO_ORDER[0], None
    for method in _AUTO_ORDER:
        tell(f"try forward map {method}")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TrimsurfWarning)
            uv = embed(mesh, method, brep=brep)
            q = embedding_quality(mesh, uv, brep)
        if method == _AUTO_ORDER[0]:
            chosen_uv = uv
        if q.n_flipped == 0 and q.n_boundary_crossings == 0:
            chosen, chosen_uv = method, uv
            break
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TrimsurfWarning)
        # the chosen layout is passed on, not computed twice
        return fit_trimmed_face(mesh, embed_method=chosen, uv=chosen_uv, normalize_uv=False, backmap_method=backmap,
                                grid_shape=grid, trim_degree=trim_degree, name=name, progress=tell,
                                backmap_options=backmap_options)


def fit_mesh(mesh, output: Path, *, embed: str = "auto", backmap: str = "lsq", grid=None, trim_degree: int = 1,
             name: str = "fit", png: Path | None = None, tell=None, max_deviation: float | None = None,
             area_window: tuple[float, float] = AREA_WINDOW, diagnostics: bool = False,
             extrapolation_degree: int = 3) -> tuple[dict, object]:
    """Fit, write the STEP file, read it back and measure it; returns (report dict, FitResult).

    The headline figures (``hausdorff``, ``area_ratio``, ``step_valid``,
    ``self_intersections``, ``boundary_deviation``) are measured on the face
    read back from the written file (`trimsurf.fit.measure_written_face`);
    ``problems`` lists why the face fails `max_deviation` (model units,
    default 1% of the mesh's diagonal) or `area_window` (face area / mesh
    area), with the folded forward map named as the cause when it folds.
    With `diagnostics` the in-memory figures (`trimsurf.fit.fit_quality`: the
    back-map S itself on the mesh's parameter triangulation, trims not
    applied) are added under ``in_memory``. Used by the CLI and the demo.
    """
    from .. import io
    from ..fit import fit_quality, fit_trimmed_face, measure_written_face
    from ..model import Shell

    if Path(output).suffix.lower() not in (".step", ".stp"):
        raise InputError(f"{output}: the output must be a STEP file (.step or .stp)")
    diag = mesh.diagonal()
    if max_deviation is None:
        max_deviation = 0.01 * diag
    if not (max_deviation > 0):
        raise InputError(f"--max-deviation must be positive; got {max_deviation!r}")
    lo, hi = (float(x) for x in area_window)
    if not (0 <= lo < hi):
        raise InputError(f"--area-ratio needs 0 <= LO < HI; got {lo:g} {hi:g}")
    tell = tell or (lambda _s: None)
    options = {"extrapolation_degree": extrapolation_degree} if backmap == "nurbs" else None
    t0 = time.perf_counter()
    if embed == "auto":
        result = _fit_auto(mesh, backmap=backmap, grid=grid, trim_degree=trim_degree, name=name, tell=tell,
                           backmap_options=options)
    else:
        result = fit_trimmed_face(mesh, embed_method=embed, backmap_method=backmap, grid_shape=grid,
                                  trim_degree=trim_degree, name=name, progress=tell, backmap_options=options)
    seconds_fit = time.perf_counter() - t0
    tell("write STEP")
    t = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TrimsurfWarning)
        io.write_shell(Shell.from_faces([result.face], name=name), output)
    rejected = [str(w.message) for w in caught if "BRepCheck_Analyzer" in str(w.message)]
    for w in caught:
        if "BRepCheck_Analyzer" not in str(w.message):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    seconds_write = time.perf_counter() - t
    tell("read back and measure")
    w = measure_written_face(output, mesh, tolerance=max_deviation)
    s = result.face.surface
    report = {
        "mesh": name,
        "output": str(output),
        "vertices": mesh.n_vertices,
        "triangles": mesh.n_triangles,
        "loops": result.brep.n_loops,
        "embed": result.embed_method,
        "backmap": result.backmap_method,
        "written_surface": WRITTEN_SURFACE.get(result.backmap_method, "cubic B-spline"),
        **({"extrapolation_degree": extrapolation_degree} if result.backmap_method == "nurbs" else {}),
        "grid": list(result.grid.shape),
        "flipped_in_embedding": result.embedding.n_flipped,
        "boundary_crossings_in_embedding": result.embedding.n_boundary_crossings,
        "length_distortion_rms": result.embedding.rms_length_distortion,
        "total_abs_curvature": result.brep.total_abs_curvature,
        "measured_on": "the STEP file read back through Open CASCADE",
        "diagonal": diag,
        "hausdorff": w.hausdorff,
        "hausdorff_rel": w.hausdorff / diag,
        "hausdorff_mesh_to_face": w.hausdorff_mesh_to_face,
        "hausdorff_face_to_mesh": w.hausdorff_face_to_mesh,
        "rms_deviation": w.rms_mesh_to_face,
        "boundary_deviation": w.boundary_deviation,
        "area": w.area,
        "mesh_area": w.mesh_area,
        "area_ratio": w.area_ratio,
        "step_valid": w.step_valid,
        "self_intersections": w.self_intersections,
        "max_deviation": max_deviation,
        "area_window": [lo, hi],
        "measure": {k: v for k, v in w.as_dict().items() if k in (
            "readable", "n_faces", "deflection", "deflection_measured", "sample_spacing", "n_face_samples",
            "n_mesh_samples", "n_tessellation_triangles", "where_mesh_to_face", "where_face_to_mesh", "error")},
        "step_valid_before_write": not rejected,
        "surface": {"degree": [s.degree_u, s.degree_v], "control_points": list(s.shape)},
        "trim_segments": [len(lp.segments) for lp in result.face.loops],
        "seconds_fit": seconds_fit,
        "seconds_write": seconds_write,
        "seconds_measure": sum(w.seconds.values()),
        "seconds_steps": result.seconds,
        "seconds_measure_steps": w.seconds,
    }
    report["problems"] = problems_of(report)
    if diagnostics:
        tell("in-memory diagnostics")
        q = fit_quality(result, mesh)
        report["in_memory"] = {
            "what": ("the back-map S on the mesh's own parameter triangulation, before writing (trims not applied"
                     + ("; S is the RBF, not the NURBS written)" if result.backmap_method == "rbf" else ")")),
            "hausdorff": q.hausdorff, "hausdorff_rel": q.hausdorff_rel, "rms_deviation": q.rms_deviation,
            "boundary_deviation": q.boundary_deviation, "self_intersections": q.self_intersections_in_face,
            "seconds": q.seconds}
    if png is not None:
        tell("render")
        render_fit_png(w, mesh, png, title=f"{name}, read back: Hausdorff {100 * w.hausdorff / diag:.3g}%, "
                                           f"area x {w.area_ratio:.3g}")
        report["png"] = str(png)
    return report, result


def problems_of(r: dict) -> list[str]:
    """Why the written face is not trustworthy (empty when it is), from a `fit_mesh` report."""
    d = r["diagonal"]
    out = []
    if r["measure"]["error"]:
        out.append(f"the face read back cannot be measured: {r['measure']['error']}")
        if r["measure"]["readable"] and not r["step_valid"]:
            out.append("BRepCheck_Analyzer rejects the shape read back")
    else:
        if not r["step_valid"]:
            out.append("BRepCheck_Analyzer rejects the face read back")
        if not r["hausdorff"] <= r["max_deviation"]:
            out.append(f"the face read back deviates {100 * r['hausdorff'] / d:.3g}% of the diagonal from the mesh "
                       f"(max {100 * r['max_deviation'] / d:.3g}%)")
        lo, hi = r["area_window"]
        if not lo <= r["area_ratio"] <= hi:
            out.append(f"its area is {r['area_ratio']:.3g} x the mesh's (window {lo:g}-{hi:g})")
        if r["self_intersections"] > 0:
            out.append(f"it intersects itself ({r['self_intersections']} triangle pair(s) of its tessellation)")
    if r["boundary_crossings_in_embedding"]:
        out.append(f"the trim loops cross {r['boundary_crossings_in_embedding']} time(s) in (u, v)")
    if r["flipped_in_embedding"]:
        out.append(f"cause: the forward map {r['embed']} folds {r['flipped_in_embedding']} of {r['triangles']} "
                   "triangles")
    return out


def render_fit_png(written, mesh, path: Path, *, title: str = "") -> Path:
    """The face read back (its tessellation) coloured by each point's distance to the mesh (model units)."""
    from ..quality import closest_points_on_mesh
    from ..viz import render_png

    tess = written.tessellation
    if tess is None:
        raise InputError(f"{path}: nothing to render, the written face could not be read back")
    d = closest_points_on_mesh(tess.vertices, mesh).distance
    return render_png(tess, path, mode="scalars", scalars=d, scalar_name="distance to mesh", title=title)


def run(args: argparse.Namespace) -> int:
    if args.grid is not None and min(args.grid) < 4:
        raise InputError(f"--grid needs at least 4 x 4 control points; got {args.grid[0]} x {args.grid[1]}")
    if args.grid is not None:
        check_budget(float(args.grid[0]) * float(args.grid[1]), "fit_control_point",
                     what=f"--grid {args.grid[0]} {args.grid[1]} too large", hint="use a smaller --grid")
    mesh, _ = load_mesh(args.mesh, NAME)
    steps = 9 + (args.png is not None) + bool(args.diagnostics)
    with progress(steps, f"fit {args.mesh.name}") as bar:
        report, _ = fit_mesh(mesh, args.output, embed=args.embed, backmap=args.backmap, grid=args.grid,
                             trim_degree=args.trim_degree, name=args.mesh.name, png=args.png,
                             tell=lambda s: bar.advance(description=s), max_deviation=args.max_deviation,
                             area_window=tuple(args.area_ratio), diagnostics=args.diagnostics,
                             extrapolation_degree=args.extrapolation_degree)
    if args.report is not None:
        write_json(report, args.report)
    if args.json:
        print_json(report)
    else:
        print(format_report(report))
    problems = report["problems"]
    if problems:
        print_warning(f"{args.mesh}: the written face is not trustworthy: {'; '.join(problems)}")
    return EXIT_FAILED if problems else EXIT_OK


def format_report(r: dict) -> str:
    d = r["diagonal"]

    def pct(x):
        return "-" if x is None or x != x else f"{x:.4g} ({100 * x / d:.3g}% of the diagonal)"

    rows = [[f"{r['mesh']} -> {r['output']}"],
            ["vertices", r["vertices"]], ["boundary loops", r["loops"]],
            ["forward map", f"{r['embed']} ({r['flipped_in_embedding']} flipped triangles, "
                            f"{r['boundary_crossings_in_embedding']} loop crossings)"],
            ["back-map", f"{r['backmap']} ({r['grid'][0]} x {r['grid'][1]} control points; written: "
                         f"{r['written_surface']})"],
            ["read back (OCCT)", f"{r['measure']['n_faces']} face(s), "
                                 f"BRepCheck {'valid' if r['step_valid'] else 'INVALID'}"
             + (f"; NOT MEASURED: {r['measure']['error']}" if r["measure"]["error"] else "")],
            ["Hausdorff", f"{pct(r['hausdorff'])}, max {100 * r['max_deviation'] / d:.3g}%"],
            ["  mesh -> face", pct(r["hausdorff_mesh_to_face"])],
            ["  face -> mesh", pct(r["hausdorff_face_to_mesh"])],
            ["RMS deviation", pct(r["rms_deviation"])],
            ["boundary deviation", pct(r["boundary_deviation"])],
            ["area face / mesh", "-" if r["area_ratio"] is None or r["area_ratio"] != r["area_ratio"]
             else f"{r['area_ratio']:.4f} (window {r['area_window'][0]:g}-{r['area_window'][1]:g})"],
            ["self-intersections", r["self_intersections"]],
            ["samples", f"{r['measure']['n_mesh_samples']} mesh, {r['measure']['n_face_samples']} face "
                        f"(spacing {r['measure']['sample_spacing'] or 0:.3g}; maxima sampled, not proven)"]]
    if "in_memory" in r:
        rows.append(["in memory (diagnostic)", f"Hausdorff {100 * r['in_memory']['hausdorff_rel']:.3g}% "
                                               "(S on the parameter triangulation, trims not applied)"])
    rows.append(["seconds", f"fit {r['seconds_fit']:.2f}, write {r['seconds_write']:.2f}, "
                            f"read back + measure {r['seconds_measure']:.2f}"])
    return format_table(rows)
