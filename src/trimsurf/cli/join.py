"""``trimsurf join MODEL``: join separately meshed faces into one mesh without folding (Whitney reprojection)."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from ..errors import InputError
from ._common import (EXIT_FAILED, EXIT_OK, check_budget, estimate_shell_triangles, examples, format_table,
                      load_shell, print_warning, progress, write_json)

__all__ = ["NAME", "HELP", "DESCRIPTION", "EPILOG", "add_args", "run"]

NAME = "join"
HELP = "join per-face meshes of a CAD model along the shared edges (Whitney reprojection, no folding)"
DESCRIPTION = """\
Join mesh patches of adjacent faces along their common edges, as in
join-mesh-patches-whitney.txt: every mesh is projected to its face's (u, v)
domain, peripheral triangles are removed, the strip up to the (projected) edge
curves is triangulated anew with Ruppert refinement (min angle 21.96 deg), and
every vertex is put at the Whitney average of the boundary discrepancy. The
result is one mesh whose patch boundaries share their vertices exactly, with
absolute error and slope no larger than along the boundary, and no flipped
triangle.

MODEL is a STEP/IGES/BREP/VDAFS file or the name of an embedded sample
(`trimsurf samples --list`, e.g. folding_pair). Without --meshes the faces
are meshed first (Open CASCADE's mesher, or trimsurf's tessellator with
--mesher trimsurf); with --independent every face is meshed alone at its own
deflection (between 0.5 and 1 times D), so neighbours' edge nodes differ (the
paper's case). A model whose faces share no edge (an unsewn IGES surface
model) is sewn first (Open CASCADE's sewing). With --meshes give one mesh file per face, in face order
(as `trimsurf info MODEL` lists them). A face whose mesh does not lie near it
is reported with the distance found, left as it is, and the exit status is 1.
So is a joined face with flipped triangles (possible only where the face breaks
the paper's hypotheses, e.g. at a pole of its parametrization); the warning
names the faces.

Meshes outside the paper's hypotheses: coinciding corners of a face mesh
(triangles with two corners at one point) are merged first, which leaves its
surface unchanged. A face whose mesh still turns triangles over when projected
to (u, v) (the inverse map is not injective), or crosses the face's boundary
there, is re-meshed: its whole (u, v) domain is triangulated anew as the
strips are (Triangle, Ruppert refinement, refined to the deflection) with the
joined edge polylines as its boundary, so it shares its edge vertices with its
neighbours; a warning names such faces ("remeshed_faces" in the report) and
the exit status stays 0. A model edge shorter than the tolerance whose ends
are one vertex becomes that one point; edge polylines whose chords cross in a
face's (u, v) domain are refined where that makes the boundary a polygon.
Where the trim curves themselves cross, the face is left unjoined (exit
status 1).

Accuracy: the strip Triangle re-meshes is refined until every triangle's
sampled deviation from its face is within the deflection D (--deflection;
default 0.1% of the diagonal when meshing here, the input meshes' own
measured deviation with --meshes). The report gives the output's
max_deviation and p99_deviation measured inside the triangles (barycentric
samples, 6 per edge, projected exactly onto the faces) beside the paper's
vertex criteria; the exit status is 1 when max_deviation exceeds D.

--baseline midpoint sews by midpoints of the two boundaries instead (the
naive method the paper shows folding), for comparison."""
EPILOG = examples("trimsurf join part.step -o joined.ply --report join.json",
                  "trimsurf join folding_pair --independent -o fold.ply",
                  "trimsurf join part.step --meshes f0.obj f1.obj f2.obj -o joined.obj",
                  "trimsurf join part.step --baseline midpoint -o sewn.ply --report sewn.json")


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", help="CAD model (STEP, IGES, VDAFS) or an embedded sample name")
    parser.add_argument("--meshes", type=Path, nargs="+", metavar="FACE_MESH",
                        help="one mesh file per face, in face order (default: mesh each face separately)")
    parser.add_argument("-o", "--output", type=Path, required=True, help="joined mesh (OBJ, PLY, STL, OFF, glTF)")
    parser.add_argument("--report", type=Path, metavar="REPORT.json", help="write the JSON report here")
    parser.add_argument("--no-edge-curves", action="store_true",
                        help="Case 2 of the paper: ignore the 3D edge curves; use the median of the two mesh "
                             "boundaries along each shared edge (loops deleted)")
    parser.add_argument("--baseline", choices=["midpoint"],
                        help="join by the naive midpoint sewing of Sec. I instead (for comparison)")
    parser.add_argument("--independent", action="store_true",
                        help="mesh every face alone (Open CASCADE) at its own deflection in [0.5 D, D]: "
                             "neighbours' boundary nodes differ")
    parser.add_argument("--mesher", choices=["occ", "trimsurf"], default="occ",
                        help="how faces are meshed when --meshes is not given (default: occ)")
    parser.add_argument("--deflection", type=float, metavar="D",
                        help="largest deviation from the faces allowed inside the output triangles, and the "
                             "meshing tolerance when faces are meshed here (default 0.1%% of the model diagonal; "
                             "with --meshes: the input meshes' measured deviation)")
    parser.add_argument("--min-angle", type=float, default=None, metavar="DEG",
                        help="minimum angle of the re-triangulated strip (default 21.96, the paper's bound)")
    parser.add_argument("--split-long-edges", action="store_true",
                        help="Sec. III-D: split long edges of thin triangles and reproject the new vertices")
    parser.add_argument("--max-distance", type=float, metavar="D",
                        help="a mesh vertex farther than D from its face makes that face's mesh bad input "
                             "(default 1%% of the model diagonal)")


def _positive(value, name: str):
    if value is not None and not (np.isfinite(value) and value > 0):
        raise InputError(f"{name} must be a positive number; got {value!r}")


def _face_meshes(shell, args, deflection: float):
    from .. import io

    if args.meshes and args.independent:
        raise InputError("--independent meshes the faces here; it cannot go with --meshes")
    if args.independent:
        from ..join import mesh_faces_independently

        return mesh_faces_independently(shell, deflection), "independent"
    if args.meshes:
        if len(args.meshes) != len(shell.faces):
            raise InputError(f"{args.model}: the model has {len(shell.faces)} faces; --meshes gave "
                             f"{len(args.meshes)} files (one mesh per face, in face order)")
        return [io.read_mesh(p) for p in args.meshes], "files"
    if args.mesher == "trimsurf":
        from ..tessellate import tessellate_face

        out = []
        with progress(len(shell.faces), "meshing faces") as bar:
            for face in shell.faces:
                out.append(tessellate_face(face, tolerance=deflection, max_edge=20 * deflection))
                bar.advance()
        return out, "trimsurf"
    return io.occ_mesh_faces(shell, linear_deflection=deflection), "occ"


def _baseline_report(shell, meshes, base) -> dict:
    from ..join import patch_errors
    from ..join._patch import parameter_scale, project_points
    from ..quality import flipped_triangles_normal

    mesh = base.mesh
    flipped_before = flipped_after = 0
    abs_after = slope_after = 0.0
    for f, face in enumerate(shell.faces):
        if meshes[f].n_triangles:
            flipped_before += flipped_triangles_normal(meshes[f], face).n_flipped
        sub = mesh.submesh(mesh.face_id == f)
        if not sub.n_triangles:
            continue
        flipped_after += flipped_triangles_normal(sub, face).n_flipped
        scale = parameter_scale(face, project_points(face, sub.vertices).uv)
        e = patch_errors(sub, face, scale=scale, density=1)
        abs_after = max(abs_after, e.abs_error)
        slope_after = max(slope_after, e.max_slope)
    be = mesh.boundary_edges()
    from ..join import mesh_deviation_inside

    inside = mesh_deviation_inside(mesh, shell)
    return {"max_deviation": inside["max_deviation"], "p99_deviation": inside["p99_deviation"],
            "worst_face": inside["worst_face"], "deviation_samples_per_edge": inside["deviation_samples_per_edge"],
            "vertices": mesh.n_vertices, "triangles": mesh.n_triangles,
            "joined_edges": sum(1 for e in shell.edges if len({u[0] for u in e.uses}) == 2),
            "flipped_before": int(flipped_before), "flipped_after": int(flipped_after),
            "abs_error_boundary": None, "abs_error_after": abs_after, "lipschitz_boundary": None,
            "max_slope_after": slope_after, "min_angle_external_deg": None,
            "boundary_edges_on_joins": int(np.count_nonzero(base.on_joint[be].all(axis=1))) if len(be) else 0,
            "boundary_edges": int(len(be)), "non_manifold_edges": int(len(mesh.non_manifold_edges())),
            "bad_faces": []}


def run(args: argparse.Namespace) -> int:
    from .. import io
    from ..join import PAPER_MIN_ANGLE_DEG, input_deviation, join_shell, midpoint_join, needs_sewing, sew_shell

    t0 = time.perf_counter()
    for name in ("deflection", "max_distance", "min_angle"):
        _positive(getattr(args, name), f"--{name.replace('_', '-')}")
    if args.output.suffix.lower() not in io.MESH_SUFFIXES:
        raise InputError(f"{args.output}: unknown mesh suffix {args.output.suffix!r}; expected one of "
                         f"{', '.join(io.MESH_SUFFIXES)}")
    shell = load_shell(args.model, "join")
    sewn = False
    if not args.meshes and needs_sewing(shell):   # an unsewn surface model: which faces adjoin?
        shell, sewn = sew_shell(shell), True
    diag = shell.diagonal()
    deflection = args.deflection if args.deflection is not None else 1e-3 * diag
    if source_is_meshed := not args.meshes:
        if deflection < 1e-7:  # Open CASCADE's Precision::Confusion: no mesher resolves finer
            raise InputError(f"--deflection {deflection:g} too small: below Open CASCADE's precision 1e-7")
        if args.mesher == "trimsurf":  # the tessellator's own budget, before it runs (as `trimsurf tessellate`)
            check_budget(3.0 * estimate_shell_triangles(shell, deflection, 20 * deflection), "tessellate_triangle",
                         what=f"--deflection {deflection:g} too small", hint="use a larger --deflection")
    meshes, source = _face_meshes(shell, args, deflection)
    input_dev = input_deviation(shell, meshes, density=4)
    # the join re-triangulates the strips along shared edges: ~2x the face meshes' triangles (U_Joint), 12-14.5x
    # where it refines input meshes that deviate far more than the deflection (gap_pair)
    refines = (args.deflection is not None or source != "files") and input_dev > 2 * deflection
    check_budget(sum(m.n_triangles for m in meshes) * (13.0 if refines else 2.5), "join_triangle",
                 per_part=[m.n_triangles * (13.0 if refines else 2.5) for m in meshes],
                 what=f"--deflection {deflection:g} too small" if source_is_meshed else "--meshes too fine",
                 hint="use a larger --deflection" if source_is_meshed else "give coarser face meshes")
    if source == "files" and args.deflection is None:
        deflection = None   # the input meshes' own measured deviation (join_shell's default)
    min_angle = args.min_angle if args.min_angle is not None else PAPER_MIN_ANGLE_DEG
    if args.baseline == "midpoint":
        base = midpoint_join(shell, meshes)
        report = _baseline_report(shell, meshes, base)
        report["deflection"] = deflection if deflection is not None else input_dev
        mesh = base.mesh
        faces = []
    else:
        with progress(len(shell.faces), "joining faces") as bar:
            res = join_shell(shell, meshes, use_edge_curves=not args.no_edge_curves, min_angle_deg=min_angle,
                             split_long_edges=args.split_long_edges, max_distance=args.max_distance,
                             deflection=deflection, progress=lambda done, total: bar.advance())
        report = dict(res.report)
        mesh = res.mesh
        faces = [f.as_dict() for f in res.faces]
    io.write_mesh(mesh, args.output)
    report.update({"model": str(args.model), "output": str(args.output), "method": args.baseline or "whitney",
                   "meshes": source, "sewn": sewn, "input_deviation": input_dev,
                   "edge_curves": not args.no_edge_curves, "min_angle_deg": min_angle,
                   "seconds": time.perf_counter() - t0, "faces": faces})
    if args.report:
        write_json(report, args.report)
    rows = [["vertices", report["vertices"]], ["triangles", report["triangles"]],
            ["joined edges", report["joined_edges"]],
            ["flipped before -> after", f"{report['flipped_before']} -> {report['flipped_after']}"],
            ["abs error boundary -> after", f"{_fmt(report['abs_error_boundary'])} -> "
                                            f"{_fmt(report['abs_error_after'])}"],
            ["slope: boundary L -> max after", f"{_fmt(report['lipschitz_boundary'])} -> "
                                               f"{_fmt(report['max_slope_after'])}"],
            ["min angle external (deg)", _fmt(report["min_angle_external_deg"])],
            ["deviation in triangles: input -> max (p99)", f"{_fmt(input_dev)} -> {_fmt(report['max_deviation'])} "
                                                           f"({_fmt(report['p99_deviation'])})"],
            ["deflection", _fmt(report["deflection"])],
            ["boundary edges on joins", report["boundary_edges_on_joins"]],
            ["seconds", f"{report['seconds']:.2f}"]]
    print(format_table(rows))
    for bad in report["bad_faces"]:
        print_warning(f"face {bad['face']} ({bad['name']}): {bad['message']}; left unjoined")
    remeshed = report.get("remeshed_faces") or []
    if remeshed:
        names = ", ".join(str(f["face"]) for f in remeshed[:10]) + (f" and {len(remeshed) - 10} more"
                                                                     if len(remeshed) > 10 else "")
        print_warning(f"{len(remeshed)} face(s) re-meshed over their whole (u, v) domain (input mesh not "
                      f"invertible: {remeshed[0]['message']}): faces {names}")
    # the paper's guarantee (no folding) rests on Sec. II's hypotheses, e.g. a regular parametrization; where a
    # face breaks them (a pole) the join can still flip triangles: say where, and do not report success
    flipped = [f for f in faces if f["status"] in ("joined", "remeshed") and f["flipped_after"] > 0]
    if flipped:
        where = ", ".join(f"{f['face']} ({f['flipped_after']})" for f in flipped[:10])
        more = f" and {len(flipped) - 10} more" if len(flipped) > 10 else ""
        print_warning(f"{report['flipped_after']} flipped triangles after joining, on faces {where}{more}")
    too_far = report["max_deviation"] is not None and report["max_deviation"] > report["deflection"]
    if too_far:
        print_warning(f"the joined mesh deviates {report['max_deviation']:.4g} from the faces (worst: face "
                      f"{report['worst_face']}), more than the deflection {report['deflection']:.4g} (input meshes: "
                      f"{input_dev:.4g})")
    return EXIT_FAILED if report["bad_faces"] or flipped or too_far else EXIT_OK


def _fmt(x) -> str:
    return "-" if x is None else f"{x:.4g}"
