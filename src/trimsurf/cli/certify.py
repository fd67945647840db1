"""``trimsurf certify MODEL``: make a trimmed B-rep well defined (Whitney perturbation) and certify it."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..errors import InputError
from ._common import EXIT_FAILED, EXIT_OK, examples, format_table, load_shell, print_json, print_warning, progress, write_json

__all__ = ["NAME", "HELP", "DESCRIPTION", "EPILOG", "add_args", "run", "format_certificate"]

NAME = "certify"
HELP = "certify a CAD model: Whitney-perturbed faces meet exactly along the edge curves, normal bounds, " \
       "no extraneous intersections"
DESCRIPTION = """\
Say precisely which solid an inconsistent trimmed B-rep defines, and prove it
well formed or say where it is not (whitney-well-definition.txt).

Every face F is perturbed to G = F + a, a the componentwise Whitney average of
the boundary discrepancy eps = b_k(p_k^-1(p)) - F(p) between the 3D edge
curves b_k and the images of the p-curves: G interpolates b_k, so adjacent
faces meet exactly along their edges, |a| never exceeds the largest
discrepancy, and a has the boundary's Lipschitz constants L. From L and the
first fundamental form a certified bound on the angle between the normals of
F and G follows (Sec. 4, in a corrected rigorous form). A Volino-Thalmann
test (normal cones widened by that bound, over a hierarchy of the faces'
Bezier pieces) then excludes intersections between faces other than along
their shared edges and vertices, and self-intersections.

The discrepancy pairs each point of b_k with its closest point on the surface
(--pairing). Between the Whitney samples the perturbed faces of a shared edge
need not meet exactly: edges are sampled until a rigorous bound of that gap is
below the model's point tolerance (the file's, else 1e-6 of the diagonal).

Per face: max_discrepancy, lipschitz (per component x, y, z), normal_bound_deg
(bound_kind "rigorous": from control nets over the whole face; "sampled"
otherwise), certified; per adjacent pair: whether extraneous intersections are
excluded; per shared edge: gap_bound and the gap measured at 10,000 random
points (gap_max).
Exit status 0 when everything is certified, 1 when something is not (the
lines say which faces and where), 2 for unreadable input.

MODEL is a STEP, IGES, BREP or VDAFS file, or the name of an embedded sample
(`trimsurf samples --list`)."""
EPILOG = examples("trimsurf certify part.step --report part-cert.json",
                  "trimsurf certify part.step --write-mesh well-defined.ply",
                  "trimsurf certify gap_pair --validate --json")


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", help="CAD model (STEP, IGES, VDAFS) or an embedded sample name")
    parser.add_argument("--write-mesh", type=Path, metavar="OUT",
                        help="write the well-defined mesh (faces meet exactly along the edge curves) here")
    parser.add_argument("--report", type=Path, metavar="REPORT.json", help="write the JSON report here")
    parser.add_argument("--json", action="store_true", help="print the JSON report on stdout instead of the table")
    parser.add_argument("--rtol", type=float, default=1e-2,
                        help="boundary sampling stops when the Lipschitz constants change by less than this "
                             "(relative; default 0.01)")
    parser.add_argument("--spacing", type=float, metavar="D",
                        help="largest spacing of the boundary samples in model units (default 1%% of the diagonal); "
                             "also the edge length of the well-defined mesh along edges")
    parser.add_argument("--point-tolerance", type=float, metavar="TOL",
                        help="shared edges are sampled until the perturbed faces provably meet within this "
                             "(default: the tolerance the STEP file states, else 1e-6 of the diagonal)")
    parser.add_argument("--pairing", choices=("surface", "curve", "parameter"), default="surface",
                        help="pair each edge curve point with the closest point of the surface (default), of the "
                             "trim curve, or the point at the same parameter")
    parser.add_argument("--max-normal-angle", type=float, default=90.0, metavar="DEG",
                        help="a face is certified when its normal bound is below this (default 90)")
    parser.add_argument("--no-intersections", action="store_true",
                        help="skip the extraneous-intersection test (faces only; pairs are then not certified)")
    parser.add_argument("--validate", action="store_true",
                        help="also check the certificate on a fine tessellation with the exact triangle test")


def _fmt(x: float | None) -> str:
    return "unbounded" if x is None else f"{x:.3g}"


def format_certificate(report: dict, *, max_rows: int = 40) -> str:
    """The report of `ShellCertificate.as_dict` as a text table and the problems found."""
    rows = [["face", "max_discrepancy", "lipschitz (x, y, z)", "normal_bound_deg", "bound", "certified"]]
    for f in report["faces"][:max_rows]:
        rows.append([f["face"], _fmt(f["max_discrepancy"]), ", ".join(_fmt(v) for v in f["lipschitz"]),
                     _fmt(f["normal_bound_deg"]) if f["normal_bound_deg"] is not None else "-",
                     f.get("bound_kind", "-"), "yes" if f["certified"] else "NO"])
    if len(report["faces"]) > max_rows:
        rows.append([f"... {len(report['faces']) - max_rows} more faces (--json lists all)"])
    text = format_table(rows)
    adj = [p for p in report["pairs"] if p["adjacent"]]
    if adj:
        prow = [["adjacent pair", "shared edges", "extraneous intersections excluded"]]
        for p in adj[:max_rows]:
            prow.append([f"{p['faces'][0]}-{p['faces'][1]}", ",".join(map(str, p["shared_edges"])),
                         "yes" if p["intersections_excluded"] else "NO"])
        if len(adj) > max_rows:
            prow.append([f"... {len(adj) - max_rows} more pairs (--json lists all)"])
        text += "\n\n" + format_table(prow)
    if report.get("edges"):
        gm = report.get("edge_gap_max")
        text += (f"\n\nshared edges: {report['n_edges_within_tolerance']}/{len(report['edges'])} meet within the point "
                 f"tolerance {_fmt(report['point_tolerance'])}; gap between the perturbed faces bounded by "
                 f"{_fmt(report['edge_gap_bound'])}" + ("" if gm is None else f", measured {_fmt(gm)}")
                 + f" (diagonal {_fmt(report['diagonal'])})")
    if report["problems"]:
        text += "\n\nnot certified:\n" + "\n".join(f"  {m}" for m in report["problems"][:max_rows])
        if len(report["problems"]) > max_rows:
            text += f"\n  ... {len(report['problems']) - max_rows} more (--json lists all)"
    if "validation" in report:
        v = report["validation"]
        text += (f"\n\nvalidation on {v['n_triangles']} triangles: watertight {v['watertight']}, "
                 f"intersecting face pairs {v['intersecting_face_pairs']}, contradictions {v['contradictions']}")
    return text + "\n\n" + report["summary"]


def run(args: argparse.Namespace) -> int:
    from ..certify import certify_shell

    for name in ("rtol", "spacing", "max_normal_angle", "point_tolerance"):
        v = getattr(args, name)
        if v is not None and not (np.isfinite(v) and v > 0):
            raise InputError(f"--{name.replace('_', '-')} must be a positive number; got {v!r}")
    if not args.rtol < 1:
        raise InputError(f"--rtol must be below 1; got {args.rtol!r}")
    from ..certify import file_point_tolerance

    shell = load_shell(args.model, "certify")
    n = len(shell.faces)
    tol, source = args.point_tolerance, "option"
    if tol is None:
        tol = file_point_tolerance(args.model)
        source = "file" if tol is not None else "1e-6 of the diagonal"
    counts = {"pairs": 0}

    def tick(stage: str, k: int) -> None:
        if stage == "faces":
            bar.advance(k)
        else:
            counts["pairs"] += k
            bar.advance(0, description=f"intersections: {counts['pairs']} face pairs")

    with progress(n, f"certify {Path(args.model).name}: faces") as bar:
        cert = certify_shell(shell, rtol=args.rtol, max_chord=args.spacing,
                             max_normal_angle_deg=args.max_normal_angle, intersections=not args.no_intersections,
                             progress=tick, pairing=args.pairing, point_tolerance=tol)
    report = cert.as_dict()
    report["model"] = str(args.model)
    report["point_tolerance_source"] = source
    if args.validate:
        report["validation"] = cert.validate_with_mesh()
    if args.write_mesh:
        from .. import io
        mesh = cert.well_defined_mesh()
        io.write_mesh(mesh, args.write_mesh)
        report["mesh"] = {"path": str(args.write_mesh), "n_vertices": mesh.n_vertices,
                          "n_triangles": mesh.n_triangles}
    if args.report:
        write_json(report, args.report)
    if args.json:
        print_json(report)
    else:
        print(format_certificate(report))
    if not cert.certified:
        first = report["problems"][0] if report["problems"] else "see the report"
        print_warning(f"{len(report['problems'])} item(s) not certified; first: {first}")
        return EXIT_FAILED
    return EXIT_OK
