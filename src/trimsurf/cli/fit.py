"""``trimsurf fit MESH -o OUT.step``: fit a trimmed NURBS face to a triangle mesh with holes."""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

from ..errors import InputError, TrimsurfWarning
from ._common import (EXIT_FAILED, EXIT_OK, check_budget, examples, format_table, print_json, print_warning,
                      progress, write_json)

__all__ = ["NAME", "HELP", "DESCRIPTION", "EPILOG", "add_args", "run", "fit_mesh", "EMBED_CHOICES",
           "BACKMAP_CHOICES"]

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
rbf (thin-plate spline), nurbs (iterative extrapolation), greville (hybrid at
Greville abscissae).

Exit status: 0 ok, 1 the face is not trustworthy (folded forward map, crossing
trim loops, a self-intersecting face, or Open CASCADE rejects the face; it is
written anyway), 2 bad input."""
EPILOG = examples("trimsurf fit part.off -o part.step",
                  "trimsurf fit scan.ply -o scan.step --embed lscm --backmap hybrid --grid 30 20 --report fit.json",
                  "trimsurf fit sheet.obj -o sheet.step --png sheet-fit.png")

EMBED_CHOICES = ("auto", "hlle", "isomap", "laplacian", "lscm", "harmonic")
BACKMAP_CHOICES = ("lsq", "hybrid", "rbf", "nurbs", "greville")
_AUTO_ORDER = ("hlle", "lscm", "harmonic")


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("mesh", type=Path, help="triangle mesh (OBJ, PLY, STL, OFF, glTF)")
    parser.add_argument("-o", "--output", type=Path, required=True, help="STEP file to write (.step/.stp)")
    parser.add_argument("--embed", choices=EMBED_CHOICES, default="auto",
                        help="forward map phi: M -> R^2 (default auto: hlle, else lscm, else harmonic)")
    parser.add_argument("--backmap", choices=BACKMAP_CHOICES, default="lsq", help="back-map S (default lsq)")
    parser.add_argument("--grid", type=int, nargs=2, metavar=("NU", "NV"), default=None,
                        help="control points of S (default: from the mesh size, about one per 2 vertices of phi(M))")
    parser.add_argument("--trim-degree", type=int, choices=(1, 3), default=1,
                        help="p-curves as polylines through the boundary vertices (1, default) or "
                             "least-squares cubics (3)")
    parser.add_argument("--report", type=Path, default=None, help="write the figures as JSON to this file")
    parser.add_argument("--png", type=Path, default=None,
                        help="render the evaluated trimmed face, coloured by its distance to the mesh")
    parser.add_argument("--json", action="store_true", help="print the report as JSON on stdout")


def _fit_auto(mesh, *, backmap, grid, trim_degree, name, tell):
    """The first of hlle, lscm, harmonic whose forward map neither folds nor crosses its loops (else hlle)."""
    from ..fit import DEVELOPABLE_LIMIT, embed, embedding_quality, fit_trimmed_face, mesh_brep

    brep = mesh_brep(mesh, name=name)
    if brep.total_abs_curvature > DEVELOPABLE_LIMIT:
        warnings.warn(f"{name}: far from developable (total |Gaussian curvature| / 2 pi = "
                      f"{brep.total_abs_curvature:.2f} > {DEVELOPABLE_LIMIT}): outside the method's assumption, "
                      "expect distortion", TrimsurfWarning, stacklevel=2)
    chosen = _AUTO_ORDER[0]
    for method in _AUTO_ORDER:
        tell(f"try forward map {method}")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TrimsurfWarning)
            q = embedding_quality(mesh, embed(mesh, method, brep=brep), brep)
        if q.n_flipped == 0 and q.n_boundary_crossings == 0:
            chosen = method
            break
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TrimsurfWarning)
        return fit_trimmed_face(mesh, embed_method=chosen, backmap_method=backmap, grid_shape=grid,
                                trim_degree=trim_degree, name=name, progress=tell)


def fit_mesh(mesh, output: Path, *, embed: str = "auto", backmap: str = "lsq", grid=None, trim_degree: int = 1,
             name: str = "fit", png: Path | None = None, tell=None) -> tuple[dict, object]:
    """Fit, write the STEP file, measure; returns (report dict, FitResult). Used by the CLI and the demo."""
    from .. import io
    from ..fit import fit_quality, fit_trimmed_face
    from ..model import Shell

    if Path(output).suffix.lower() not in (".step", ".stp"):
        raise InputError(f"{output}: the output must be a STEP file (.step or .stp)")
    tell = tell or (lambda _s: None)
    t0 = time.perf_counter()
    if embed == "auto":
        result = _fit_auto(mesh, backmap=backmap, grid=grid, trim_degree=trim_degree, name=name, tell=tell)
    else:
        result = fit_trimmed_face(mesh, embed_method=embed, backmap_method=backmap, grid_shape=grid,
                                  trim_degree=trim_degree, name=name, progress=tell)
    tell("write STEP")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TrimsurfWarning)
        io.write_shell(Shell.from_faces([result.face], name=name), output)
    rejected = [str(w.message) for w in caught if "BRepCheck_Analyzer" in str(w.message)]
    for w in caught:
        if "BRepCheck_Analyzer" not in str(w.message):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    seconds = time.perf_counter() - t0
    tell("measure")
    q = fit_quality(result, mesh)
    s = result.face.surface
    report = {
        "mesh": name,
        "output": str(output),
        "vertices": mesh.n_vertices,
        "triangles": mesh.n_triangles,
        "loops": result.brep.n_loops,
        "embed": result.embed_method,
        "backmap": result.backmap_method,
        "grid": list(result.grid.shape),
        "flipped_in_embedding": result.embedding.n_flipped,
        "boundary_crossings_in_embedding": result.embedding.n_boundary_crossings,
        "length_distortion_rms": result.embedding.rms_length_distortion,
        "total_abs_curvature": result.brep.total_abs_curvature,
        "hausdorff": q.hausdorff,
        "hausdorff_rel": q.hausdorff_rel,
        "rms_deviation": q.rms_deviation,
        "boundary_deviation": q.boundary_deviation,
        "self_intersections_in_face": q.self_intersections_in_face,
        "diagonal": q.diagonal,
        "step_valid": not rejected,
        "surface": {"degree": [s.degree_u, s.degree_v], "control_points": list(s.shape)},
        "trim_segments": [len(lp.segments) for lp in result.face.loops],
        "seconds": seconds,
        "seconds_steps": result.seconds,
        "seconds_measure": q.seconds,
    }
    if png is not None:
        tell("render")
        render_fit_png(result, mesh, png, title=f"{name}: {result.embed_method} + {result.backmap_method}, "
                                                f"Hausdorff {100 * q.hausdorff_rel:.3g}% of the diagonal")
        report["png"] = str(png)
    return report, result


def render_fit_png(result, mesh, path: Path, *, title: str = "") -> Path:
    """The evaluated trimmed face coloured by each point's distance to the mesh (model units)."""
    from ..fit import evaluated_face_mesh
    from ..quality import closest_points_on_mesh
    from ..viz import render_png

    fm = evaluated_face_mesh(result, mesh, levels=1)
    d = closest_points_on_mesh(fm.vertices, mesh).distance
    return render_png(fm, path, mode="scalars", scalars=d, scalar_name="distance to mesh", title=title)


def run(args: argparse.Namespace) -> int:
    from .. import io

    if args.grid is not None and min(args.grid) < 4:
        raise InputError(f"--grid needs at least 4 x 4 control points; got {args.grid[0]} x {args.grid[1]}")
    if args.grid is not None:
        check_budget(float(args.grid[0]) * float(args.grid[1]), "fit_control_point",
                     what=f"--grid {args.grid[0]} {args.grid[1]} too large", hint="use a smaller --grid")
    mesh = io.read_mesh(args.mesh)
    steps = 8 + (args.png is not None)
    with progress(steps, f"fit {args.mesh.name}") as bar:
        report, _ = fit_mesh(mesh, args.output, embed=args.embed, backmap=args.backmap, grid=args.grid,
                             trim_degree=args.trim_degree, name=args.mesh.name, png=args.png,
                             tell=lambda s: bar.advance(description=s))
    if args.report is not None:
        write_json(report, args.report)
    if args.json:
        print_json(report)
    else:
        print(format_report(report))
    problems = []
    if report["flipped_in_embedding"]:
        problems.append(f"the forward map folds {report['flipped_in_embedding']} triangle(s)")
    if report["boundary_crossings_in_embedding"]:
        problems.append(f"the trim loops cross {report['boundary_crossings_in_embedding']} time(s) in (u, v)")
    if report["self_intersections_in_face"] > 0:
        problems.append(f"the trimmed face intersects itself ({report['self_intersections_in_face']} triangle "
                        "pair(s) of its evaluation)")
    if not report["step_valid"]:
        problems.append("Open CASCADE's BRepCheck_Analyzer rejects the face")
    for p in problems:
        print_warning(f"{args.mesh}: {p}; the face is not trustworthy")
    return EXIT_FAILED if problems else EXIT_OK


def format_report(r: dict) -> str:
    d = r["diagonal"]
    rows = [[f"{r['mesh']} -> {r['output']}"],
            ["vertices", r["vertices"]], ["boundary loops", r["loops"]],
            ["forward map", f"{r['embed']} ({r['flipped_in_embedding']} flipped triangles, "
                            f"{r['boundary_crossings_in_embedding']} loop crossings)"],
            ["back-map", f"{r['backmap']} ({r['grid'][0]} x {r['grid'][1]} control points)"],
            ["Hausdorff", f"{r['hausdorff']:.4g} ({100 * r['hausdorff'] / d:.3g}% of the diagonal {d:.4g})"],
            ["RMS deviation", f"{r['rms_deviation']:.4g} ({100 * r['rms_deviation'] / d:.3g}%)"],
            ["boundary deviation", f"{r['boundary_deviation']:.4g} ({100 * r['boundary_deviation'] / d:.3g}%)"],
            ["self-intersections", r["self_intersections_in_face"]],
            ["STEP valid (OCCT)", "yes" if r["step_valid"] else "NO"],
            ["seconds", f"{r['seconds']:.2f} (+ {r['seconds_measure']:.2f} measuring)"]]
    return format_table(rows)
