"""``trimsurf view INPUT``: reflection lines, highlights and curvature as a PNG and an interactive web page."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..errors import FileFormatError, InputError
from ..model import Shell, TriMesh
from ._common import EXIT_OK, examples, format_table, print_json, progress, sample_input, write_json

__all__ = ["NAME", "HELP", "DESCRIPTION", "EPILOG", "add_args", "run", "load_view_input", "mesh_with_face_uv"]

NAME = "view"
HELP = "render reflection lines (zebra), highlights or curvature of a mesh or CAD file to PNG and/or HTML"
DESCRIPTION = """\
Show the surface quality of a mesh or CAD file the way inspection tools do.

zebra: reflection lines of a striped environment; the stripe coordinate is
computed per vertex from the reflected view ray and interpolated linearly
across each triangle by the renderer, so thin or badly arranged triangles show
as kinks and wiggles (as in the tessellation paper's Fig. 2). highlight: a
glossy surface lit by one movable light (Blinn-Phong per vertex). curvature:
Gaussian, mean or max |principal| curvature as a red-to-blue colour map with a
colour bar (discrete estimate on meshes; exact from the NURBS derivatives with
--exact). mesh: flat shading with the triangle edges.

CAD input (STEP, IGES, BREP, VDAFS) is tessellated with `trimsurf tessellate`'s
defaults first; --exact adds the exact surface (dense (u, v) refinement with
exact normals and curvatures) beside it, to tell mesh artefacts from surface
features. --compare puts a second model beside the first, same camera.
--png writes an offscreen picture, --html a self-contained interactive page
(three.js inlined, opens offline; toggles and sliders for every mode). With
neither, INPUT_STEM.MODE.png is written in the current directory. An INPUT
that is not a file but the name of a built-in sample (`trimsurf samples
--list`) uses that sample."""
EPILOG = examples("trimsurf view part.step --exact --png part-zebra.png",
                  "trimsurf view scan.ply --mode curvature --curvature gaussian --html scan.html",
                  "trimsurf view ours.ply --compare occt.stl --png compare.png --report view.json")


def _pair(text: str, kind, n: int, name: str):
    try:
        parts = [kind(x) for x in text.replace("x", ",").split(",")]
    except ValueError:
        parts = []
    if len(parts) != n:
        raise argparse.ArgumentTypeError(f"{name} must be {n} comma-separated numbers; got {text!r}")
    return tuple(parts)


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", metavar="INPUT", help="mesh (OBJ, PLY, STL, OFF, glTF) or CAD file "
                        "(STEP, IGES, BREP, VDAFS), or a sample name")
    parser.add_argument("--mode", choices=("zebra", "highlight", "curvature", "mesh"), default="zebra",
                        help="what to show (default: zebra)")
    parser.add_argument("--png", type=Path, metavar="OUT.png", help="write an offscreen picture")
    parser.add_argument("--html", type=Path, metavar="OUT.html", help="write a self-contained interactive page")
    parser.add_argument("--compare", metavar="OTHER", help="a second mesh or CAD file shown beside INPUT, "
                        "same camera")
    parser.add_argument("--exact", action="store_true",
                        help="CAD input: add the exact-surface reference panel (exact normals and curvatures)")
    parser.add_argument("--curvature", choices=("mean", "gaussian", "max_abs"), default="mean",
                        help="curvature mode: which curvature (default: mean)")
    parser.add_argument("--range", type=lambda s: _pair(s, float, 2, "--range"), metavar="LO,HI",
                        help="fixed colour range for curvature (default: 2nd..98th percentile, symmetric)")
    parser.add_argument("--stripes", type=float, metavar="N",
                        help="zebra stripe pairs over the half turn of the environment (default: about 10 "
                             "across the model)")
    parser.add_argument("--stripe-angle", type=float, default=0.0, metavar="DEG",
                        help="direction of the light rows seen from the eye, 0 = horizontal (default: 0)")
    parser.add_argument("--stripe-width", type=float, default=0.5, metavar="W",
                        help="black fraction of each stripe period, in (0, 1) (default: 0.5)")
    parser.add_argument("--light", type=lambda s: _pair(s, float, 3, "--light"), default=None,
                        metavar="X,Y,Z", help="highlight: direction to the light in the camera frame "
                                              "(x right, y up, z towards you; default: the light that puts "
                                              "the highlight in the middle of the model)")
    parser.add_argument("--view", choices=("iso", "+x", "-x", "+y", "-y", "+z", "-z"), default="iso",
                        help="side the camera looks from (default: iso; write --view=-z for a minus side)")
    parser.add_argument("--size", type=lambda s: _pair(s, int, 2, "--size"), default=(800, 600),
                        metavar="WxH", help="PNG size of one panel in pixels (default: 800x600)")
    parser.add_argument("--json", action="store_true", help="print the report as JSON on stdout")
    parser.add_argument("--report", type=Path, metavar="FILE.json", help="write the report as JSON")


def mesh_with_face_uv(result) -> TriMesh | None:
    """The faces of a `TessellationResult` as one mesh with per-face ``uv`` and ``face_id`` (vertices unshared).

    The exact reference needs each vertex's (u, v) on its own face; the
    joined ``result.mesh`` shares seam vertices between faces and has no uv.
    Returns None when a face failed or has no uv.
    """
    parts = getattr(result, "face_meshes", None)
    if not parts or any(m is None or m.uv is None for m in parts):
        return None
    V, T, UV, F, off = [], [], [], [], 0
    for f, m in enumerate(parts):
        V.append(m.vertices)
        T.append(m.triangles + off)
        UV.append(m.uv)
        F.append(np.full(m.n_triangles, f, dtype=np.int64))
        off += m.n_vertices
    return TriMesh(np.concatenate(V), np.concatenate(T), uv=np.concatenate(UV), face_id=np.concatenate(F))


def load_view_input(name: str) -> tuple[str, TriMesh, Shell | None, TriMesh | None, dict]:
    """Read INPUT: (label, mesh to show, shell or None, mesh for the exact reference or None, info).

    A CAD file (or shell sample) is tessellated with `trimsurf.tessellate`'s defaults.
    """
    from .. import io

    path = Path(name)
    info: dict = {"input": name}
    sample = sample_input(name, "view")
    if sample is None:
        suffix = path.suffix.lower()
        if suffix in io.MESH_SUFFIXES:
            obj = io.read_mesh(path)
        elif suffix in io.CAD_SUFFIXES:
            obj = io.read_shell(path)
        else:
            raise FileFormatError(f"{path}: unknown file suffix {suffix!r}; expected a CAD file "
                                  f"({', '.join(io.CAD_SUFFIXES)}) or a mesh file ({', '.join(io.MESH_SUFFIXES)})")
        label = path.stem
    else:
        obj, label = sample.build(), name
    if isinstance(obj, TriMesh):
        _check_extent(name, obj)
        info.update({"kind": "mesh", "n_triangles": obj.n_triangles})
        return label, obj, None, None, info
    from ..tessellate import tessellate_shell

    result = tessellate_shell(obj)
    mesh = result.mesh
    if not mesh.n_triangles:
        raise InputError(f"{name}: no face could be tessellated; nothing to show")
    _check_extent(name, mesh)
    info.update({"kind": "shell", "n_faces": len(obj.faces), "n_triangles": mesh.n_triangles,
                 "tessellation": {"tolerance": result.tolerance, "max_edge": result.max_edge, "mode": result.mode}})
    return label, mesh, obj, mesh_with_face_uv(result), info


def _check_extent(name: str, mesh: TriMesh) -> None:
    """Refuse a mesh the renderers cannot frame: non-finite or huge coordinates, or a box of no extent."""
    from ..io._meshfile import COORDINATE_LIMIT

    with np.errstate(all="ignore"):
        big = float(np.max(np.abs(mesh.vertices))) if mesh.n_vertices else 0.0
        extent = float(np.max(np.ptp(mesh.vertices, axis=0))) if mesh.n_vertices else 0.0
    if not big <= COORDINATE_LIMIT:
        raise InputError(f"{name}: coordinates up to {big:.3g}, beyond the supported magnitude {COORDINATE_LIMIT:g}")
    # an extent below 1e-13 of the coordinates (float64 keeps ~16 digits) or below 1e-30 cannot be framed
    if not (extent > 1e-13 * big and extent > 1e-30):
        raise InputError(f"{name}: the mesh's extent {extent:.3g} is too small to render next to its "
                         f"coordinates (up to {big:.3g})")


def run(args: argparse.Namespace) -> int:
    from ..viz import render_compare_png, stripe_straightness, write_html

    if not 0 < args.stripe_width < 1:
        raise InputError(f"--stripe-width must be in (0, 1); got {args.stripe_width}")
    if args.stripes is not None and not args.stripes > 0:
        raise InputError(f"--stripes must be positive; got {args.stripes}")
    if args.range is not None and not args.range[0] < args.range[1]:
        raise InputError(f"--range needs LO < HI; got {args.range[0]}, {args.range[1]}")
    for out, suffix in ((args.png, ".png"), (args.html, ".html")):
        if out is not None and out.suffix.lower() != suffix:
            raise InputError(f"{out}: expected a {suffix} file name")
    png = args.png
    if png is None and args.html is None:
        png = Path(f"{Path(args.input).stem}.{args.mode}.png")
    n_steps = 1 + (args.compare is not None) + (png is not None) + (args.html is not None)
    with progress(n_steps, "view") as bar:
        label, mesh, shell, exact_mesh, info = load_view_input(args.input)
        bar.advance(description="read")
        panels: list[tuple[TriMesh, object, str]] = [(mesh, None, label)]
        if args.exact:
            if shell is None:
                raise InputError(f"{args.input}: --exact needs CAD input (a mesh has no exact surface)")
            panels.append((exact_mesh if exact_mesh is not None else mesh, shell, f"{label} (exact surface)"))
        report = {"input": info, "mode": args.mode}
        if args.compare is not None:
            clabel, cmesh, cshell, cexact, cinfo = load_view_input(args.compare)
            bar.advance(description="read compare")
            panels.append((cmesh, None, clabel))
            report["compare"] = cinfo
        meshes = [p[0] for p in panels]
        common = dict(mode=args.mode, camera=args.view, n_stripes=args.stripes, stripe_angle_deg=args.stripe_angle,
                      stripe_width=args.stripe_width, light=args.light, curvature=args.curvature)
        titles = [p[2] for p in panels]
        exacts = [p[1] for p in panels]
        if png is not None:
            render_compare_png(meshes, png, titles=titles, exact=exacts, window_size=args.size, clim=args.range,
                               **common)
            report["png"] = str(png)
            if args.mode == "zebra":  # per panel: how far stripe edges wiggle off smooth curves
                from PIL import Image

                with Image.open(png) as im:
                    img = np.asarray(im.convert("RGB"))
                w = args.size[0]
                report["stripe_straightness"] = [
                    {"panel": t, **stripe_straightness(img[:, i * w:(i + 1) * w])._asdict()}
                    for i, t in enumerate(titles)]
            bar.advance(description="png")
        if args.html is not None:
            write_html(meshes, args.html, titles=titles, title=f"trimsurf view {label}", exact=exacts, **common)
            report["html"] = str(args.html)
            report["html_bytes"] = args.html.stat().st_size
            bar.advance(description="html")
    if args.report is not None:
        write_json(report, args.report)
    if args.json:
        print_json(report)
    else:
        rows = [[f"{label}: {info['kind']}, {info['n_triangles']} triangles"]]
        if "compare" in report:
            rows.append([f"compare {report['compare']['input']}: {report['compare']['n_triangles']} triangles"])
        if "png" in report:
            rows.append(["png", report["png"]])
        for s in report.get("stripe_straightness", []):
            rows.append([f"stripe edges off smooth curves, {s['panel']}",
                         f"p99 {s['p99_px']:.2f} px, {100 * s['frac_over_1px']:.1f} % beyond 1 px "
                         f"({s['n_edges']} edges)"])
        if "html" in report:
            rows.append(["html", f"{report['html']} ({report['html_bytes'] / 1e6:.2f} MB)"])
        print(format_table(rows))
    return EXIT_OK
