"""``trimsurf info FILE``: what a CAD or mesh file holds, and the problems found in it."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..errors import FileFormatError, InputError, MeshError
from ..geom import polyline_self_intersections
from ..model import Shell, TriMesh
from ..tolerance import default_tolerance
from ._common import EXIT_FAILED, EXIT_OK, examples, format_table, print_json, sample_input

__all__ = ["NAME", "HELP", "add_args", "run", "shell_report", "mesh_report", "format_report"]

NAME = "info"
HELP = "describe a CAD file (faces, surfaces, loops, edges, problems) or a mesh file (topology, quality)"
DESCRIPTION = """\
Describe a CAD file (STEP, IGES, BREP, VDAFS) or a mesh file (OBJ, PLY, STL, OFF, glTF,
VTK/VTU, Gmsh MSH, Abaqus INP, Nastran BDF).

For CAD files: faces, surface kinds (degrees, rational or not, control-net size),
loops and their segments, bounding box and diagonal, edges (shared, free,
non-manifold, degenerate), whether the shell is closed, and the problems found:
open trim loops (with gap sizes), trim loops that cross themselves in (u, v)
(with the first crossing), p-curves leaving the surface domain, and 3D edge
curves that miss the surface (max |F(p(t)) - b(t)| per face against the edge
tolerance). For meshes: vertices, triangles, boundary loops, components, Euler
characteristic, watertight, oriented, non-manifold edges, degenerate triangles,
smallest angle."""
EPILOG = examples("trimsurf info fender   # an embedded sample (trimsurf samples --list)",
                  "trimsurf info --json scan.ply > scan-info.json",
                  "trimsurf info --strict part.step || echo 'part.step needs repair'")

_N_SAMPLES = 33  # points per trim segment for the checks
# points per trim segment of the polyline checked for self-crossing loops (a p-curve is smooth between
# knots; 64 resolves the crossings of real data, e.g. occtpr946__bug32596_abc_0_13 face 65)
_N_CROSSING_SAMPLES = 64


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", type=Path, help="CAD or mesh file; the format comes from the suffix; or the name of "
                                               "an embedded sample (`trimsurf samples --list`)")
    parser.add_argument("--json", action="store_true", help="print one JSON object on stdout instead of text")
    parser.add_argument("--strict", action="store_true",
                        help="treat any problem found (open or self-crossing trim loop, p-curve outside the domain, "
                             "edge-curve gap) as bad input: print the report, then one error line and exit 2")


def run(args: argparse.Namespace) -> int:
    from .. import io

    path: Path = args.file
    suffix = path.suffix.lower()
    sample = sample_input(path, NAME)
    if sample is not None:
        obj = sample.build()
        report = mesh_report(obj, name=str(path)) if sample.kind == "mesh" else shell_report(obj, name=str(path))
        if sample.kind == "shell":
            report["skipped_faces"] = []
    elif suffix in io.MESH_SUFFIXES:
        report = mesh_report(io.read_mesh(path), name=str(path))
    elif suffix in io.CAD_SUFFIXES:
        with io.skipped_faces() as skipped:
            shell = io.read_shell(path)
        report = shell_report(shell, name=str(path))
        report["skipped_faces"] = skipped  # faces of the file left out (each already on stderr)
    else:
        raise FileFormatError(f"{path}: unknown file suffix {suffix!r}; expected a CAD file "
                              f"({', '.join(io.CAD_SUFFIXES)}) or a mesh file ({', '.join(io.MESH_SUFFIXES)})")
    if args.json:
        print_json(report)
    else:
        print(format_report(report))
    problems = report.get("problems") or []
    if args.strict and problems:
        first = problems[0].get("message", problems[0].get("kind", "problem"))
        raise InputError(f"{path}: {len(problems)} problem(s) found, first: {first}")
    return EXIT_FAILED if report.get("skipped_faces") else EXIT_OK


# ----------------------------------------------------------------------------- CAD


def _surface_kind(surface) -> str:
    kind = "NURBS" if surface.is_rational else "B-spline"
    return f"{kind} {surface.degree_u}x{surface.degree_v}"


def _face_checks(f: int, face, edges, tol_point: float, tol_param: float) -> tuple[dict, list[dict]]:
    """Per-face figures and problems: open loops, self-crossing loops, p-curves outside the domain, edge-curve gaps.

    A segment's limit is its edge's stated tolerance, else the face's, else
    the default point tolerance of the shell.
    """
    surface = face.surface
    (u0, u1), (v0, v1) = surface.domain
    extent = max(u1 - u0, v1 - v0)
    problems: list[dict] = []
    face_limit = face.tolerance if face.tolerance > 0 else tol_point
    edge_gap, worst_ratio, outside = 0.0, 0.0, 0.0

    def limit_of(seg) -> float:
        if 0 <= seg.edge_id < len(edges) and edges[seg.edge_id].tolerance > 0:
            return max(edges[seg.edge_id].tolerance, face_limit)
        return face_limit

    for l, loop in enumerate(face.loops):
        segs = loop.segments
        ends = np.array([s.end for s in segs])
        starts = np.roll(np.array([s.start for s in segs]), -1, axis=0)
        uv_gap = np.linalg.norm(starts - ends, axis=1)
        xyz_gap = np.linalg.norm(surface.evaluate(starts) - surface.evaluate(ends), axis=1)
        for s in range(len(segs)):
            lim = max(limit_of(segs[s]), limit_of(segs[(s + 1) % len(segs)]))
            if xyz_gap[s] > lim:
                problems.append({"kind": "open_loop", "face": f, "loop": l, "segment": s,
                                 "gap": float(xyz_gap[s]), "gap_uv": float(uv_gap[s]), "limit": lim,
                                 "message": f"face {f} loop {l}: open after segment {s}: gap {xyz_gap[s]:.3g} "
                                            f"(uv {uv_gap[s]:.3g}, tolerance {lim:.3g})"})
        for s, seg in enumerate(segs):
            t = seg.parameters(_N_SAMPLES)
            uv = seg.evaluate(t)
            out = max(float(np.max(np.maximum(u0 - uv[:, 0], uv[:, 0] - u1))),
                      float(np.max(np.maximum(v0 - uv[:, 1], uv[:, 1] - v1))), 0.0)
            if out > tol_param * max(extent, 1.0):
                outside = max(outside, out)
                problems.append({"kind": "pcurve_outside_domain", "face": f, "loop": l, "segment": s,
                                 "distance_uv": out,
                                 "message": f"face {f} loop {l} segment {s}: p-curve leaves the domain by {out:.3g}"})
            if seg.edge_curve is not None:
                gap = float(np.linalg.norm(surface.evaluate(uv) - seg.edge_curve.evaluate(t), axis=1).max())
                lim = limit_of(seg)
                edge_gap = max(edge_gap, gap)
                if gap > lim:
                    problems.append({"kind": "edge_curve_gap", "face": f, "loop": l, "segment": s,
                                     "edge": seg.edge_id, "gap": gap, "limit": lim,
                                     "message": f"face {f} loop {l} segment {s}: edge curve misses F(p(t)) by "
                                                f"{gap:.3g} (tolerance {lim:.3g})"})
                worst_ratio = max(worst_ratio, gap / lim)
    for l, loop in enumerate(face.loops):
        crossing = _self_crossing(loop, tol_param * max(extent, 1.0))
        if crossing is not None:
            n, (u, v), (sa, sb) = crossing
            problems.append({"kind": "self_crossing_loop", "face": f, "loop": l, "n_crossings": n,
                             "uv": [u, v], "segments": [sa, sb],
                             "message": f"face {f} loop {l}: trim loop crosses itself ({n} crossing(s) of its "
                                        f"sampled polyline), first at (u, v) = ({u:.6g}, {v:.6g}) between "
                                        f"segments {sa} and {sb}"})
    figures = {"index": f, "name": face.name, "surface": _surface_kind(surface),
               "degree_u": surface.degree_u, "degree_v": surface.degree_v, "rational": surface.is_rational,
               "control_net": list(surface.shape), "domain": [list(surface.domain[0]), list(surface.domain[1])],
               "n_loops": len(face.loops), "segments_per_loop": [len(loop) for loop in face.loops],
               "same_sense": face.same_sense, "tolerance": face.tolerance, "edge_curve_gap_max": edge_gap,
               "edge_curve_gap_over_tolerance": worst_ratio, "pcurve_outside_max": outside}
    return figures, problems


def _self_crossing(loop, same_uv: float) -> tuple[int, tuple[float, float], tuple[int, int]] | None:
    """Self-crossings of a trim loop's polyline in (u, v) (`_N_CROSSING_SAMPLES` points per segment).

    Returns None for a simple loop, else (number of crossing polyline
    edge pairs, (u, v) of the first crossing, the loop segments of its two
    polyline edges). A point within `same_uv` of the one before it (a
    zero-length p-curve, a pole) is dropped first, so its neighbours do not
    count as touching.
    """
    n = _N_CROSSING_SAMPLES
    poly = loop.polyline(n)
    seg_of = np.repeat(np.arange(len(loop)), n - 1)
    keep = np.linalg.norm(poly - np.roll(poly, 1, axis=0), axis=1) > same_uv
    if np.count_nonzero(keep) < 3:
        return None
    poly, seg_of = poly[keep], seg_of[keep]
    pairs = polyline_self_intersections(poly)
    if not len(pairs):
        return None
    i, j = (int(k) for k in pairs[0])
    a, b = poly[i], poly[(i + 1) % len(poly)]
    c, d = poly[j], poly[(j + 1) % len(poly)]
    r, q = b - a, d - c
    den = r[0] * q[1] - r[1] * q[0]
    if den != 0.0:  # proper crossing: a + s r
        s = ((c[0] - a[0]) * q[1] - (c[1] - a[1]) * q[0]) / den
        point = a + min(max(s, 0.0), 1.0) * r
    else:  # parallel edges that touch or overlap: a shared end point
        point = next((p for p in (a, b) if np.all(np.minimum(c, d) <= p) and np.all(p <= np.maximum(c, d))), c)
    return len(pairs), (float(point[0]), float(point[1])), (int(seg_of[i]), int(seg_of[j]))


#: how `Shell.bounding_box` finds the model's extent (printed by ``info``)
EXTENT_SOURCE = "trimmed faces (points on the trims and inside them), not surfaces' control nets"


def _tessellate_defaults(diag: float) -> dict:
    """The defaults ``trimsurf tessellate`` derives from the diagonal (None where it is not finite)."""
    from ..tessellate.shell import REL_MAX_EDGE, REL_TOLERANCE

    ok = bool(np.isfinite(diag) and diag > 0)
    return {"tolerance": REL_TOLERANCE * diag if ok else None, "max_edge": REL_MAX_EDGE * diag if ok else None}


def shell_report(shell: Shell, *, name: str = "") -> dict:
    """Figures and problems of a `Shell`, as a JSON-ready dict (what ``trimsurf info`` prints).

    Parameters
    ----------
    shell : Shell
    name : str
        File or sample name shown in the report.

    Returns
    -------
    dict
        kind, name, n_faces, surface_kinds ({kind: count}), faces (per face:
        surface kind, degrees, rational, control net, loops and segments,
        edge-curve gap), bounding_box, diagonal, tolerance, edges (total,
        shared, free, non_manifold, degenerate), n_vertices, closed, problems
        (list of {kind, face, ..., message}).
    """
    lo, hi = shell.bounding_box()
    with np.errstate(all="ignore"):
        diag = float(np.linalg.norm(hi - lo))
    tol = default_tolerance(diag)
    faces, problems = [], []
    for f, face in enumerate(shell.faces):
        fig, prob = _face_checks(f, face, shell.edges, tol.point, tol.parameter)
        faces.append(fig)
        problems += prob
    kinds: dict[str, int] = {}
    for fig in faces:
        key = f"{fig['surface']}"
        kinds[key] = kinds.get(key, 0) + 1
    n_uses = np.array([len(e.uses) for e in shell.edges], dtype=np.int64)
    degenerate = np.array([e.is_degenerate for e in shell.edges], dtype=bool)
    edges = {"total": len(shell.edges), "shared": int(np.sum((n_uses == 2) & ~degenerate)),
             "free": len(shell.free_edges()), "non_manifold": len(shell.non_manifold_edges()),
             "degenerate": int(degenerate.sum())}
    return {"kind": "shell", "name": name or shell.name, "n_faces": len(shell.faces),
            "surface_kinds": dict(sorted(kinds.items(), key=lambda kv: -kv[1])),
            "n_loops": int(sum(f["n_loops"] for f in faces)),
            "n_segments": int(sum(sum(f["segments_per_loop"]) for f in faces)),
            "bounding_box": {"min": lo.tolist(), "max": hi.tolist()}, "diagonal": diag,
            "extent_source": EXTENT_SOURCE,
            "tolerance": {"point": tol.point, "parameter": tol.parameter},
            "tessellate_defaults": _tessellate_defaults(diag),
            "has_topology": shell.has_topology, "edges": edges, "n_vertices": int(len(shell.vertices)),
            "closed": shell.is_closed(), "n_problems": len(problems), "problems": problems, "faces": faces}


# ----------------------------------------------------------------------------- meshes


def _mesh_figures(mesh: TriMesh) -> dict:
    """Topology and angle figures, from `trimsurf.quality` when it is there, else from TriMesh helpers."""
    try:
        from ..quality import topology_report, triangle_quality
    except ImportError:
        topology_report = triangle_quality = None
    if topology_report is not None and mesh.n_triangles:
        topo = topology_report(mesh)
        q = triangle_quality(mesh)
        return {"n_boundary_loops": topo.n_boundary_loops, "n_components": topo.n_components,
                "euler_characteristic": topo.euler_characteristic, "genus": topo.genus,
                "is_watertight": topo.is_watertight, "is_consistently_oriented": topo.is_consistently_oriented,
                "n_non_manifold_edges": topo.n_non_manifold_edges,
                "n_non_manifold_vertices": topo.n_non_manifold_vertices,
                "n_degenerate_triangles": q.n_zero_area, "min_angle_deg": q.min_angle_deg,
                "p5_min_angle_deg": q.p5_min_angle_deg}
    figures = {"n_boundary_loops": None, "n_components": mesh.n_components(),
               "euler_characteristic": mesh.euler_characteristic(), "genus": None,
               "is_watertight": mesh.is_watertight(), "is_consistently_oriented": mesh.is_consistently_oriented(),
               "n_non_manifold_edges": int(len(mesh.non_manifold_edges())), "n_non_manifold_vertices": None,
               "n_degenerate_triangles": int(len(mesh.degenerate_triangles())), "min_angle_deg": None,
               "p5_min_angle_deg": None}
    try:
        figures["n_boundary_loops"] = len(mesh.boundary_loops())
    except MeshError:  # a non-manifold boundary vertex
        pass
    if mesh.n_triangles:
        p = mesh.vertices[mesh.triangles]
        ang = []
        for i in range(3):
            e1, e2 = p[:, (i + 1) % 3] - p[:, i], p[:, (i + 2) % 3] - p[:, i]
            n1, n2 = np.linalg.norm(e1, axis=1), np.linalg.norm(e2, axis=1)
            with np.errstate(invalid="ignore", divide="ignore"):
                ang.append(np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", e1, e2) / (n1 * n2), -1, 1))))
        smallest = np.nanmin(np.stack(ang), axis=0)
        figures["min_angle_deg"] = float(np.nanmin(smallest))
        figures["p5_min_angle_deg"] = float(np.nanpercentile(smallest, 5))
    return figures


def mesh_report(mesh: TriMesh, *, name: str = "") -> dict:
    """Figures of a `TriMesh`, as a JSON-ready dict (what ``trimsurf info`` prints for meshes).

    Returns
    -------
    dict
        kind, name, n_vertices, n_triangles, n_boundary_loops, n_components,
        euler_characteristic, genus, is_watertight, is_consistently_oriented,
        n_non_manifold_edges, n_degenerate_triangles, min_angle_deg,
        p5_min_angle_deg, bounding_box, diagonal, has_uv, has_face_id.
    """
    lo, hi = (mesh.bounding_box() if mesh.n_vertices else (np.zeros(3), np.zeros(3)))
    report = {"kind": "mesh", "name": name, "n_vertices": mesh.n_vertices, "n_triangles": mesh.n_triangles}
    report.update(_mesh_figures(mesh))
    report.update({"bounding_box": {"min": lo.tolist(), "max": hi.tolist()}, "diagonal": mesh.diagonal(),
                   "has_uv": mesh.uv is not None, "has_face_id": mesh.face_id is not None})
    return report


# ----------------------------------------------------------------------------- text


def _g(x) -> str:
    if x is None:
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, float):
        return f"{x:.6g}"
    return str(x)


def _box(report: dict) -> str:
    lo, hi = report["bounding_box"]["min"], report["bounding_box"]["max"]
    return "[" + ", ".join(f"{a:.6g}..{b:.6g}" for a, b in zip(lo, hi)) + "]"


def format_report(report: dict) -> str:
    """The report of `shell_report` or `mesh_report` as a short aligned text table."""
    if report["kind"] == "mesh":
        keys = [("vertices", "n_vertices"), ("triangles", "n_triangles"), ("boundary loops", "n_boundary_loops"),
                ("components", "n_components"), ("Euler characteristic", "euler_characteristic"),
                ("genus", "genus"), ("watertight", "is_watertight"), ("oriented", "is_consistently_oriented"),
                ("non-manifold edges", "n_non_manifold_edges"), ("degenerate triangles", "n_degenerate_triangles"),
                ("min angle (deg)", "min_angle_deg"), ("5% min angle (deg)", "p5_min_angle_deg"),
                ("diagonal", "diagonal"), ("uv", "has_uv")]
        rows = [[f"{report['name']} (mesh)"]] + [[k, _g(report[v])] for k, v in keys]
        rows.append(["bounding box", _box(report)])
        return format_table(rows)
    e = report["edges"]
    rows = [[f"{report['name']} (CAD shell)"],
            ["faces", _g(report["n_faces"])],
            ["surfaces", ", ".join(f"{n} x {k}" for k, n in report["surface_kinds"].items())],
            ["loops / segments", f"{report['n_loops']} / {report['n_segments']}"],
            ["edges", f"{e['total']} (shared {e['shared']}, free {e['free']}, non-manifold {e['non_manifold']}, "
                      f"degenerate {e['degenerate']})"],
            ["vertices", _g(report["n_vertices"])],
            ["closed", _g(report["closed"])],
            ["bounding box", _box(report)],
            ["diagonal", _g(report["diagonal"])],
            ["extent from", report["extent_source"]],
            ["tessellate defaults", f"tolerance {_g(report['tessellate_defaults']['tolerance'])}, "
                                    f"max edge {_g(report['tessellate_defaults']['max_edge'])}"],
            ["tolerance", f"point {report['tolerance']['point']:.3g}, "
                          f"parameter {report['tolerance']['parameter']:.3g}"],
            ["problems", _g(report["n_problems"])]]
    if report.get("skipped_faces"):
        rows.append(["skipped faces", f"{len(report['skipped_faces'])} (could not be converted; see stderr)"])
    text = format_table(rows)
    faces = report["faces"]
    if faces:
        frows = [["face", "surface", "net", "loops", "segments", "edge gap", "gap/tol"]]
        for f in faces[:20]:
            frows.append([f["index"], f["surface"], "x".join(map(str, f["control_net"])), f["n_loops"],
                          "+".join(map(str, f["segments_per_loop"])), f"{f['edge_curve_gap_max']:.3g}",
                          f"{f['edge_curve_gap_over_tolerance']:.3g}"])
        if len(faces) > 20:
            frows.append([f"... {len(faces) - 20} more faces (--json lists all)"])
        text += "\n\n" + format_table(frows)
    if report["problems"]:
        lines = [p["message"] for p in report["problems"][:20]]
        if len(report["problems"]) > 20:
            lines.append(f"... {len(report['problems']) - 20} more (--json lists all)")
        text += "\n\nproblems:\n" + "\n".join(f"  {m}" for m in lines)
    return text
