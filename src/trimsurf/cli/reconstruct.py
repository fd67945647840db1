"""``trimsurf reconstruct MESH -o OUT``: a smooth G1 Bézier surface (from a G1 or G2 network) through mesh vertices."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from ..errors import FileFormatError, InputError
from ._common import (EXIT_FAILED, EXIT_OK, check_budget, examples, format_table, load_mesh, print_json, print_warning,
                      progress, write_json)

__all__ = ["NAME", "HELP", "DESCRIPTION", "EPILOG", "add_args", "run", "load_mesh_input", "write_output"]

NAME = "reconstruct"
HELP = ("fit a smooth G1 triangular Bezier surface through the vertices of a triangle mesh (G1 or G2 minimum norm "
        "networks)")
DESCRIPTION = """\
Reconstruct a smooth surface through every vertex of a triangle mesh, keeping its
topology (Kolb, Pottmann, Seidel: minimum norm networks). A curve network is
built over the mesh edges and optimized by one sparse linear solve per normal
update (--network g1: cubic curves, 2 unknowns per vertex; g2: quintic curves
and a cubic cross-boundary field, 5 unknowns per vertex; shirman-sequin: the
unoptimized baseline). It is then filled with triangular Bezier patches;
every network, G1 or G2, is filled to a G1 surface (the G2 network's extra
continuity is in its curves, not in the surface). --fill split: three patches
per facet, G1 (degree 4, or 6 for g2). --fill peters (cubic networks): Peters'
scheme, one quintic per facet joined by scalar weight functions and solved as
one least-squares system: G1 where the vertex enclosure problem is solvable,
some G1 error elsewhere (the MNN paper's words), measured. --fill single: for
g2 one degree-7 patch per facet (G1, the split as fallback where it would be
singular); for cubic networks one quintic per facet from a Chiyokura-Kimura
field with averaged corner twists (not G1 in general; the error is measured).

MESH is a mesh file (OBJ, PLY, STL, OFF, glTF) or the name of a built-in mesh
sample (octahedron, boundary_problem, car_panel, ...). OUT by suffix: .npz or
.json = the patch set (control nets; read back with
trimsurf.reconstruct.load_patches), a mesh suffix = the surface evaluated at
--density subdivisions per patch side, .step/.stp = STEP with every triangular
patch as a tensor-product patch with one collapsed edge. The report (--report)
has vertices, patches, iterations, g0_gap, g1_error_max_deg (largest jump of
the normal across any patch edge), curvature_jump_max and
mean_curvature_jump_max (largest jump of the normal curvature perpendicular to
a patch edge, and of the mean curvature, 1/length), all sampled at
g1_sampling points inside every patch edge (maxima over samples, not bounds),
vertex_interpolation_error, seconds, and radial_deviation_max/_rms when all
vertices lie on a sphere. Exit status 1 (after writing OUT and the report) when
the measured G1 error exceeds --max-g1-deg (default 1e-6 degrees for the fills
that are G1 by construction; e.g. a noisy scan whose network folds at some
corners)."""
EPILOG = examples("trimsurf reconstruct octahedron -o octa.npz --report octa.json",
                  "trimsurf reconstruct scan.ply -o scan-smooth.ply --network g2 --fill single --density 12",
                  "trimsurf reconstruct car_panel -o panel.step --network g1 --direction d2 --length l2",
                  "trimsurf reconstruct machinery_part -o part.ply --network g2 --fill single --features sample")


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("mesh", metavar="MESH", help="mesh file (OBJ, PLY, STL, OFF, glTF) or a mesh sample name")
    parser.add_argument("-o", "--output", type=Path, required=True, metavar="OUT",
                        help="output: .npz/.json patch set, a mesh file (evaluated surface) or .step/.stp")
    parser.add_argument("--network", choices=("g1", "g2", "shirman-sequin"), default="g1",
                        help="curve network (default: g1)")
    parser.add_argument("--fill", choices=("split", "single", "peters"), default="split",
                        help="how the network is filled with patches (default: split)")
    parser.add_argument("--direction", choices=("d1", "d2"), default="d2",
                        help="tangent directions: d1 normal projection, d2 plane curves (default: d2)")
    parser.add_argument("--length", choices=("l0", "l1", "l2", "l3"), default="l2",
                        help="tangent lengths: l1 chord, l2 circle segment, l3 de Boor-Hollig-Sabin, "
                             "l0 projected chord (default: l2)")
    parser.add_argument("--second", choices=("zero", "l3", "l4"), default="zero",
                        help="g2 network: second-derivative curve parameter s: zero, l3 (from the de Boor-Hollig-"
                             "Sabin cubic; implies --length l3) or l4 (l3 with the direction of s optimized too) "
                             "(default: zero)")
    parser.add_argument("--functional", choices=("arc-length", "simple", "laplace-beltrami"), default="arc-length",
                        help="network functional (default: arc-length = simple functional per unit length)")
    parser.add_argument("--normals", choices=("angle", "area", "inverse_area"), default="angle",
                        help="weights of the initial vertex normals (default: angle)")
    parser.add_argument("--iterations", type=int, default=20, metavar="N",
                        help="at most N normal-update iterations (default: 20)")
    parser.add_argument("--features", type=Path, metavar="CHAINS.json",
                        help="JSON list of vertex-index chains along mesh edges that must become G1 curves, "
                             "or 'sample' for the design curves of a sample that has them (machinery_part)")
    parser.add_argument("--density", type=int, default=None, metavar="N",
                        help="subdivisions per patch side for mesh output and deviation figures "
                             "(default: 8, fewer for large meshes)")
    parser.add_argument("--max-g1-deg", type=float, default=None, metavar="DEG",
                        help="largest G1 error (degrees, sampled across patch edges) accepted; above it the run "
                             "exits with status 1 (default: 1e-6 for the fills that are G1 by construction, i.e. "
                             "split and g2 single; no limit for peters and the cubic single fill, whose error is "
                             "reported)")
    parser.add_argument("--report", type=Path, metavar="REPORT.json", help="write the report as JSON")
    parser.add_argument("--json", action="store_true", help="print the report as JSON instead of a table")


def load_mesh_input(name: str):
    """A `TriMesh` from a mesh file or a mesh sample name; returns (mesh, label)."""
    return load_mesh(name, "reconstruct")


_SAMPLE_FEATURES = {"machinery_part": "machinery_part_features"}
# G1 error (degrees, sampled) above which a fill that is G1 by construction counts as failed
G1_EXACT_DEG = 1e-6


def _read_features(path: Path | None, label: str = ""):
    if path is None:
        return ()
    if str(path) == "sample" and not path.exists():
        if label not in _SAMPLE_FEATURES:
            raise InputError(f"--features sample: {label} has no design curves (samples with them: "
                             f"{', '.join(_SAMPLE_FEATURES)})")
        from .. import samples

        return tuple(getattr(samples, _SAMPLE_FEATURES[label])())
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise FileFormatError(f"{path}: cannot read feature chains ({exc})") from None
    if not isinstance(data, list) or not all(isinstance(c, list) and all(isinstance(i, int) for i in c) for c in data):
        raise FileFormatError(f"{path}: feature chains must be a JSON list of lists of vertex indices")
    return tuple(data)


def write_output(ps, path: Path, density: int) -> str:
    """Write the patch set, its evaluated mesh or STEP by suffix; returns the kind written."""
    from .. import io
    from ..reconstruct import save_patches

    suffix = path.suffix.lower()
    if suffix in (".npz", ".json"):
        save_patches(ps, path)
        return "patches"
    if suffix in io.MESH_SUFFIXES:
        io.write_mesh(ps.evaluate_mesh(density), path)
        return "mesh"
    if suffix in (".step", ".stp"):
        from ..reconstruct import patches_to_shell

        io.write_shell(patches_to_shell(ps), path)
        return "step"
    raise InputError(f"{path}: unknown output suffix {suffix!r}; use .npz, .json, a mesh suffix "
                     f"({', '.join(io.MESH_SUFFIXES)}) or .step")


def run(args: argparse.Namespace) -> int:
    from ..reconstruct import radial_deviation, reconstruct_mesh, sphere_fit

    if args.iterations < 1:
        raise InputError(f"--iterations must be >= 1; got {args.iterations}")
    if args.density is not None and args.density < 1:
        raise InputError(f"--density must be >= 1; got {args.density}")
    if args.second != "zero" and args.network != "g2":
        raise InputError(f"--second {args.second} sets the g2 network's second derivatives; use --network g2")
    if args.fill == "peters" and args.network == "g2":
        raise InputError("--fill peters fills cubic networks; use --fill single or split with --network g2")
    if args.max_g1_deg is not None and not args.max_g1_deg >= 0:
        raise InputError(f"--max-g1-deg must be >= 0; got {args.max_g1_deg}")
    g1_exact = args.fill == "split" or (args.fill == "single" and args.network == "g2")
    g1_limit = args.max_g1_deg if args.max_g1_deg is not None else (G1_EXACT_DEG if g1_exact else None)
    from .. import io

    suffix = args.output.suffix.lower()
    if suffix not in (".npz", ".json", ".step", ".stp") + tuple(io.MESH_SUFFIXES):
        raise InputError(f"{args.output}: unknown output suffix {suffix!r}; use .npz, .json, a mesh suffix "
                         f"({', '.join(io.MESH_SUFFIXES)}) or .step")
    t0 = time.perf_counter()
    stages = ["read", "network", "fill", "check", "write"]
    with progress(len(stages), "reconstruct") as bar:
        mesh, label = load_mesh_input(args.mesh)
        bar.advance(description="network")
        features = _read_features(args.features, label)
        density = args.density or (8 if mesh.n_triangles <= 20000 else 4 if mesh.n_triangles <= 200000 else 2)
        # the evaluated surface (mesh output, deviation figures): density^2 triangles per patch
        if args.density is not None or suffix in io.MESH_SUFFIXES:
            check_budget(mesh.n_triangles * (3 if args.fill == "split" else 1) * float(density) ** 2,
                         "reconstruct_triangle", hint="use a smaller --density or write .npz",
                         what=f"--density {density} too large" if args.density is not None else
                         f"{label}: a mesh output at the default --density {density}")

        def stage(name):
            if name in ("fill", "check"):
                bar.advance(description=name)

        rec = reconstruct_mesh(mesh, network=args.network, fill=args.fill, direction=args.direction,
                               length=args.length, functional=args.functional, weighting=args.normals,
                               max_iterations=args.iterations, feature_chains=features, progress=stage,
                               second=args.second)
        report = {"input": label, **rec.report, "density": density}
        c, r, res = sphere_fit(mesh.vertices)
        if mesh.n_vertices >= 4 and r > 0 and res <= 1e-9 * r:
            dmax, drms = radial_deviation(rec.patches, c, r, density=density)
            report.update(radial_deviation_max=dmax, radial_deviation_rms=drms, sphere_radius=r)
        bar.advance(description="write")
        kind = write_output(rec.patches, args.output, density)
        report["output"] = str(args.output)
        report["output_kind"] = kind
        bar.advance()
    report["seconds"] = time.perf_counter() - t0
    report["g1_limit_deg"] = g1_limit
    report["g1_ok"] = g1_limit is None or report["g1_error_max_deg"] <= g1_limit
    if args.report is not None:
        write_json(report, args.report)
    if args.json:
        print_json(report)
    else:
        rows = [[f"reconstruct {label} -> {args.output} ({kind})"]]
        for key in ("vertices", "patches", "degree", "iterations", "converged", "g0_gap", "g1_error_max_deg",
                    "g1_angle_max_deg", "g1_angle_inner_max_deg", "curvature_jump_max", "mean_curvature_jump_max",
                    "g1_sampling", "g1_residual_vertices", "vertex_interpolation_error", "single_patch_fallbacks",
                    "inverted_corners", "folded_edges", "feature_kink_max_deg", "second", "length",
                    "radial_deviation_max", "radial_deviation_rms", "seconds"):
            if key in report:
                v = report[key]
                rows.append([key, f"{v:.3g}" if isinstance(v, float) else str(v)])
        print(format_table(rows, indent=0))
    if not report["g1_ok"]:
        folds = report["inverted_corners"] or report["folded_edges"]
        why = (f"; {report['inverted_corners']} facet corners folded in the tangent plane (noisy mesh), "
               f"{report['folded_edges']} folded curves" if folds else "")
        print_warning(f"G1 error {report['g1_error_max_deg']:.3g} deg (sampled) exceeds {g1_limit:g} deg{why}")
        return EXIT_FAILED
    return EXIT_OK
