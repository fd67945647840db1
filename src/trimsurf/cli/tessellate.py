"""``trimsurf tessellate INPUT... -o OUT``: regular low-count meshes of trimmed B-reps, checked and reported."""

from __future__ import annotations

import argparse
import contextlib
import math
import time
from pathlib import Path

import numpy as np

from ..errors import FileFormatError, InputError
from ._common import (_TERMINATED, EXIT_FAILED, EXIT_INPUT, EXIT_OK, check_budget, check_output_file,
                      check_output_folder, estimate_shell_triangles, examples, format_table, print_error,
                      print_warning, progress, sample_input, write_json)

__all__ = ["NAME", "HELP", "DESCRIPTION", "EPILOG", "add_args", "run", "write_quad_mesh", "REPORT_FIELDS"]

NAME = "tessellate"
HELP = "tessellate STEP/IGES/BREP/VDAFS faces into one regular, watertight mesh within a tolerance"
DESCRIPTION = """\
Tessellate the trimmed faces of CAD files into one mesh per file whose iso-parametric
lines are nearly equidistant in 3D (good reflection lines), with few triangles
(Sussner, Greiner, Grosso). Every face is repaired (trim gaps joined, suit-case
corners filled, non-G1 surfaces flagged), gridded by adaptive domain values, its
trims inserted into the grid (constrained Delaunay only in crossed cells). Faces
that share B-rep edges (STEP) are meshed conforming, so a closed model comes out
watertight; faces without topology (VDAFS, IGES surface models, --loose) are
stitched, oriented and their seams reduced.

Every output is measured: max deviation from the true faces (dense sampling and
projection), longest edge, smallest and 5th-percentile angle, boundary and
non-manifold edges, triangles flipped against the surface normal, orientation.
Defaults: tolerance 1e-3 and max edge 3e-2 of each model's bounding-box diagonal.
Faces that repair cannot fix are named on stderr and skipped (exit status 1, the
rest is written); a written mesh with flipped triangles, with non-manifold edges
the model's own faces do not explain (three faces meeting along a curve, coincident
faces of touching solids) or whose measured deviation exceeds the tolerance (e.g. a
file whose own vertices lie off their faces) is named on stderr, exit status 1;
unreadable files exit 2."""
EPILOG = examples("trimsurf tessellate part.step -o part.ply",
                  "trimsurf tessellate fender -o fender.ply   # an embedded sample (trimsurf samples --list)",
                  "trimsurf tessellate cad/ -o meshes/ --tolerance 0.05 --max-edge 10 --report report.json",
                  "trimsurf tessellate panel.vda -o panel.obj --loose --quads",
                  "trimsurf tessellate body.step -o body.glb --common   # highlights run on across smooth seams")

#: the issue's report fields, per input and in total
REPORT_FIELDS = ("triangles", "vertices", "faces_in", "max_deviation", "max_edge", "min_angle_deg",
                 "p5_angle_deg", "boundary_edges", "nonmanifold_edges", "flipped", "orientation_consistent",
                 "seconds", "tolerance", "max_edge_used")


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("inputs", nargs="+", type=Path, metavar="INPUT",
                        help="STEP, IGES, BREP or VDAFS files, or folders of them, or the name of an embedded "
                             "sample (`trimsurf samples --list`)")
    parser.add_argument("-o", "--output", type=Path, required=True, metavar="OUT",
                        help="mesh file (.ply .obj .stl .glb .off .vtu .msh .inp ...) for one input, else a folder")
    parser.add_argument("--tolerance", type=float, default=None, metavar="EPS",
                        help="max deviation from the faces, model units (default 1e-3 x bounding-box diagonal)")
    parser.add_argument("--max-edge", type=float, default=None, metavar="H",
                        help="longest triangle edge, model units (iso-lines spaced H / sqrt(2) so the "
                             "cell diagonals stay within H; default 3e-2 x diagonal)")
    parser.add_argument("--grid-size", type=float, default=None, metavar="G",
                        help="the paper's grid size instead of --max-edge: iso-lines (and trim points) "
                             "at most G apart in 3D, cell diagonals up to sqrt(2) G (= --max-edge "
                             "sqrt(2) G; about half the triangles of --max-edge G)")
    parser.add_argument("--max-aspect", type=float, default=None, metavar="A",
                        help="largest side ratio (3D) of a grid cell near the trimmed region: a longer cell "
                             "is halved across its long side, so its two triangles' smallest angle stays "
                             "above about atan(1/A) (default 6: 9.5 deg); binds mostly where --max-edge does "
                             "not (a large --max-edge); 'inf': no limit (fewer, thinner triangles)")
    parser.add_argument("--quads", action="store_true",
                        help="keep untouched grid cells as quads (OBJ or PLY output)")
    parser.add_argument("--loose", action="store_true",
                        help="ignore shared-edge topology: tessellate faces separately and stitch them")
    parser.add_argument("--common", action="store_true",
                        help="common parameterization: iso-lines of faces that meet smoothly along an "
                             "iso-parametric shared edge end at the same points, so reflection lines run "
                             "on across it (paper Fig. 12; conforming mode; up to ~1.2x triangles)")
    parser.add_argument("--bisection", action="store_true",
                        help="domain values by the paper's bisection instead of equidistribution")
    parser.add_argument("--format", default=".ply", metavar="SUFFIX",
                        help="mesh suffix of the files written into an output folder (default .ply)")
    parser.add_argument("--report", type=Path, default=None, metavar="REPORT.json",
                        help="write the per-input and total figures as JSON")
    parser.add_argument("--jobs", type=int, default=1, metavar="N",
                        help="worker processes for the per-face and per-edge stages (default 1); "
                             "the output is the same whatever N")


def _sample(path: Path):
    """The embedded shell sample INPUT `path` names, or None: a CAD file (read, or named missing when
    read) or an existing path. Raises InputError for a name that is neither (`_common.sample_input`)."""
    from ..io import CAD_SUFFIXES

    return None if path.suffix.lower() in CAD_SUFFIXES else sample_input(path, NAME, "shell")


def _inputs(paths: list[Path]) -> list[Path]:
    """The CAD files and sample names to tessellate, in order; a folder gives its CAD files (sorted)."""
    from ..io import CAD_SUFFIXES

    out: list[Path] = []
    for p in paths:
        if p.is_dir():
            found = sorted(q for q in p.iterdir() if q.is_file() and q.suffix.lower() in CAD_SUFFIXES)
            if not found:
                raise InputError(f"{p}: folder holds no STEP, IGES, BREP or VDAFS file")
            out.extend(found)
        elif _sample(p) is not None:
            out.append(p)
        elif p.suffix.lower() not in CAD_SUFFIXES:
            raise FileFormatError(f"{p}: not a CAD file; expected one of {', '.join(CAD_SUFFIXES)}")
        else:
            out.append(p)
    return out


def _targets(inputs: list[Path], output: Path, fmt: str, many: bool) -> list[Path]:
    from ..io import MESH_SUFFIXES

    fmt = fmt if fmt.startswith(".") else "." + fmt
    if fmt.lower() not in MESH_SUFFIXES:
        raise InputError(f"--format {fmt!r}: expected one of {', '.join(MESH_SUFFIXES)}")
    if not many and output.suffix.lower() in MESH_SUFFIXES and not output.is_dir():
        check_output_file(output, option="-o")
        return [output]
    if output.suffix and output.suffix.lower() not in MESH_SUFFIXES and not output.is_dir() and not many:
        raise InputError(f"{output}: unknown mesh suffix {output.suffix!r}; expected one of {', '.join(MESH_SUFFIXES)}")
    if output.exists() and not output.is_dir():
        raise InputError(f"{output}: several inputs need an output folder, not a file")
    if many and not output.exists() and output.suffix.lower() in MESH_SUFFIXES:
        raise InputError(f"-o {output}: {len(inputs)} inputs need an output folder, and {output.name} is a mesh "
                         "file name; give a folder (e.g. -o meshes/)")
    check_output_folder(output, option="-o")
    targets = [output / (p.stem + fmt) for p in inputs]
    seen: dict[Path, Path] = {}
    for p, t in zip(inputs, targets):
        if t in seen:
            raise InputError(f"{p} and {seen[t]} would both be written to {t}; tessellate them separately")
        seen[t] = p
    return targets


def write_quad_mesh(mesh, quads: np.ndarray, path: Path) -> None:
    """Write `mesh` with the triangle pairs `quads` merged into quad faces (OBJ or PLY, ASCII).

    Each pair (t1, t2) shares one edge; the quad runs around both triangles.
    """
    from ..io._atomic import atomic_path

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".obj", ".ply"):
        raise InputError(f"{path}: --quads needs an OBJ or PLY output; got {path.suffix!r}")
    t = mesh.triangles
    in_quad = np.zeros(len(t), dtype=bool)
    polys = []
    for a, b in np.asarray(quads, dtype=np.int64):
        ta, tb = t[a].tolist(), t[b].tolist()
        extra = [v for v in tb if v not in ta]
        if len(extra) != 1:
            continue
        # insert tb's free vertex between the two shared vertices of ta
        for k in range(3):
            i, j = ta[k], ta[(k + 1) % 3]
            if i in tb and j in tb:
                polys.append(ta[:k + 1] + extra + ta[k + 1:])
                in_quad[a] = in_quad[b] = True
                break
    polys.extend(t[~in_quad].tolist())
    v = mesh.vertices
    if suffix == ".obj":
        lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in v.tolist()]
        lines += ["f " + " ".join(str(i + 1) for i in p) for p in polys]
    else:
        lines = ["ply", "format ascii 1.0", f"element vertex {len(v)}", "property double x", "property double y",
                 "property double z", f"element face {len(polys)}", "property list uchar int vertex_indices",
                 "end_header"]
        lines += [f"{x:.17g} {y:.17g} {z:.17g}" for x, y, z in v.tolist()]
        lines += [f"{len(p)} " + " ".join(str(i) for i in p) for p in polys]
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _entry(path: Path, res, seconds: float) -> dict:
    r = res.report
    out = {"input": str(path)}
    for k in REPORT_FIELDS:
        out[k] = r.get(k)
    out["seconds"] = seconds
    # the split: meshing (tessellate_shell without its measurement) and measuring (in memory, and the
    # written file read back); reading is added by the caller
    out["seconds_mesh"] = r.get("seconds_tessellate")
    out["seconds_measure"] = r.get("seconds_measure")
    out["mode"] = res.mode
    out["watertight"] = r.get("watertight")
    out["within_tolerance"] = r.get("within_tolerance")
    out["nonmanifold_edges_explained"] = r.get("nonmanifold_edges_explained")
    out["guarantees_met"] = r.get("guarantees_met")
    out["faces_failed"] = r.get("faces_failed")
    out["faces_flagged"] = r.get("faces_flagged")
    out["faces_repaired"] = r.get("faces_repaired")
    out["faces_common_parameterization"] = r.get("faces_common_parameterization", 0)
    out["faces"] = r.get("faces")
    return out


def _total(entries: list[dict]) -> dict:
    def agg(key, fn):
        vals = [e[key] for e in entries if e.get(key) is not None]
        return fn(vals) if vals else None

    return {"inputs": len(entries), "triangles": agg("triangles", sum), "vertices": agg("vertices", sum),
            "faces_in": agg("faces_in", sum), "max_deviation": agg("max_deviation", max),
            "max_edge": agg("max_edge", max), "min_angle_deg": agg("min_angle_deg", min),
            "p5_angle_deg": agg("p5_angle_deg", min), "boundary_edges": agg("boundary_edges", sum),
            "nonmanifold_edges": agg("nonmanifold_edges", sum), "flipped": agg("flipped", sum),
            "orientation_consistent": agg("orientation_consistent", all), "seconds": agg("seconds", sum),
            "tolerance": agg("tolerance", max), "max_edge_used": agg("max_edge_used", max),
            "faces_failed": agg("faces_failed", sum)}


def check_tessellate_budget(shell, path, tolerance, max_edge) -> None:
    """Refuse (exit 2) options whose mesh would not fit the memory budget (`_common.check_budget`)."""
    from ..tessellate.shell import default_parameters

    if tolerance is None or max_edge is None:
        d_tol, d_h = default_parameters(shell)
        tolerance = d_tol if tolerance is None else tolerance
        max_edge = d_h if max_edge is None else max_edge
    # calibrated: the tessellator wrote 0.7-1.8x this on the samples and on t20, U_Joint (tests/cli/test_hardening.py)
    n = 3.0 * estimate_shell_triangles(shell, tolerance, max_edge)
    h_n = 3.0 * estimate_shell_triangles(shell, math.inf, max_edge)
    if h_n >= 0.5 * n:
        what, hint = f"{path}: --max-edge {max_edge:g} too small", "use a larger --max-edge"
    else:
        what, hint = f"{path}: --tolerance {tolerance:g} too small", "use a larger --tolerance"
    check_budget(n, "tessellate_triangle", what=what, hint=hint)


def run(args: argparse.Namespace) -> int:
    from ..io import read_shell, skipped_faces, write_mesh
    from ..io._server import take_read_timing

    for name in ("tolerance", "max_edge", "grid_size"):
        v = getattr(args, name, None)
        if v is not None and not (np.isfinite(v) and v > 0):
            raise InputError(f"--{name.replace('_', '-')} must be a positive number; got {v!r}")
    if args.jobs < 1:
        raise InputError(f"--jobs must be a positive integer; got {args.jobs}")
    aspect = getattr(args, "max_aspect", None)
    if aspect is not None and not (aspect >= 1.0):      # (NaN too; inf: no limit)
        raise InputError(f"--max-aspect must be a number >= 1 (inf: no limit); got {aspect!r}")
    if getattr(args, "grid_size", None) is not None:
        if args.max_edge is not None:
            raise InputError("give --max-edge or --grid-size, not both")
        args.max_edge = math.sqrt(2.0) * args.grid_size
    inputs = _inputs(args.inputs)
    many = len(inputs) > 1 or any(p.is_dir() for p in args.inputs)
    targets = _targets(inputs, args.output, args.format, many)
    check_output_file(args.report, option="--report")
    if args.quads:
        for t in targets:
            if t.suffix.lower() not in (".obj", ".ply"):
                raise InputError(f"{t}: --quads needs an OBJ or PLY output; got {t.suffix!r}")
    entries, status, unreadable, n_failed = [], EXIT_OK, 0, 0
    # while the reader server reads the first file, a thread loads what the tessellation will certainly
    # run (modules, numba, its kernels: cli._preload); joined right after that read
    preload = _start_preload(inputs[0], targets[0])
    with progress(len(inputs), "tessellate") as bar, _joined(preload), _frozen_gc() as freeze:
        for path, target in zip(inputs, targets):
            t0 = time.perf_counter()
            kernels: dict = {}
            try:
                with skipped_faces() as skipped:
                    sample = _sample(path)
                    shell = read_shell(path) if sample is None else sample.build()
                # the wall time of the read, plus what this command paid to start the reader server early
                # (trimsurf.io._server); the server's start-up that ran meanwhile on another core is
                # reported apart, as seconds_read_started_early
                read_timing = take_read_timing()
                seconds_read = time.perf_counter() - t0 + read_timing.get("spawn_cost_s", 0.0)
                if preload is not None:     # what the thread ran during the read, and what is waited for now
                    preload.join()
                    kernels = {"seconds_kernels_early": preload.seconds, "seconds_kernels_wait": preload.waited}
                    preload = None
                freeze()
                from ..tessellate import tessellate_shell

                check_tessellate_budget(shell, path, args.tolerance, args.max_edge)
                res = tessellate_shell(shell, tolerance=args.tolerance, max_edge=args.max_edge,
                                       mode="loose" if args.loose else "auto",
                                       strategy="bisection" if args.bisection else "equidistributed",
                                       common=args.common, jobs=args.jobs,
                                       **({} if aspect is None else {"aspect": aspect}))
            except Exception as exc:
                if not many or getattr(args, "debug", False) or _TERMINATED.is_set():
                    raise
                # a batch goes on: the file is named on stderr and in the report
                bad_input = isinstance(exc, (InputError, OSError, MemoryError))
                message = _failure(exc, path)
                print_error(message)
                entries.append({"input": str(path), "output": None, "error": message,
                                "seconds": time.perf_counter() - t0})
                unreadable += bad_input
                n_failed += 1
                status = EXIT_FAILED
                bar.advance(1, description=path.name)
                continue
            status = EXIT_FAILED if skipped else status
            for f in res.failed_faces:
                print_warning(f"{path}: face {f.index} ({f.name}) skipped: {'; '.join(f.messages)}")
                status = EXIT_FAILED
            written = None
            if res.mesh.n_triangles:
                if args.quads:
                    write_quad_mesh(res.mesh, res.quads, target)
                else:
                    write_mesh(res.mesh, target)
                written = str(target)
                t_check = time.perf_counter()
                if not _guarantees_met(path, target, res, shell):
                    status = EXIT_FAILED
                res.report["seconds_measure"] = (res.report.get("seconds_measure") or 0.0) \
                    + time.perf_counter() - t_check
            else:
                print_warning(f"{path}: no face could be tessellated; nothing written")
                status = EXIT_FAILED
            seconds = time.perf_counter() - t0 + read_timing.get("spawn_cost_s", 0.0)
            entries.append(_entry(path, res, seconds) | {
                "output": written, "faces_skipped_at_read": skipped, "seconds_read": seconds_read,
                "seconds_read_started_early": read_timing.get("early_start_s", 0.0),
                "read_from_cache": bool(read_timing.get("from_cache"))} | kernels)
            bar.advance(1, description=path.name)
    if unreadable == len(inputs):
        status = EXIT_INPUT
    rows = [["input", "triangles", "max dev", "tolerance", "max edge", "p5 angle", "boundary", "non-manifold",
             "flipped", "seconds"]]
    def num(v, f):
        return "-" if v is None else format(v, f)

    for e in entries:
        if "error" in e:
            rows.append([Path(e["input"]).name, "failed"] + ["-"] * 7 + [num(e["seconds"], ".2f")])
            continue
        rows.append([Path(e["input"]).name, e["triangles"], num(e["max_deviation"], ".3g"), num(e["tolerance"], ".3g"),
                     num(e["max_edge"], ".3g"), num(e["p5_angle_deg"], ".1f"), num(e["boundary_edges"], "d"),
                     num(e["nonmanifold_edges"], "d"), num(e["flipped"], "d"), num(e["seconds"], ".2f")])
    print(format_table(rows))
    if args.report is not None:
        failed = [{"input": e["input"], "error": e["error"]} for e in entries if "error" in e]
        write_json({"inputs": entries, "total": _total(entries), "failed_inputs": failed}, args.report)
    if many and n_failed:
        print_warning(f"{n_failed} of {len(inputs)} inputs failed: "
                      + ", ".join(Path(e["input"]).name for e in entries if "error" in e))
    return status


def _start_preload(first: Path, target: Path):
    """The started `cli._preload.Preload` if `first` is read by the reader server (so that this process
    waits idle meanwhile), else None: a VDAFS file or TRIMSURF_OCC_IN_PROCESS=1 (the read itself runs
    here), or TRIMSURF_PRELOAD=0."""
    import os

    from ..io import _server
    from ..io._meshfile import MESHIO_FORMATS

    if (os.environ.get("TRIMSURF_PRELOAD", "").strip() == "0" or _server.in_process()
            or first.suffix.lower() not in _server._SERVER_SUFFIXES):
        return None
    from . import _preload

    return _preload.Preload("meshio" if target.suffix.lower() in MESHIO_FORMATS else "trimesh").start()


@contextlib.contextmanager
def _joined(preload):
    """On the way out (an error, Ctrl-C): the preload thread is stopped and joined if it still runs."""
    try:
        yield
    finally:
        if preload is not None:
            preload.join(stop=True)


@contextlib.contextmanager
def _frozen_gc():
    """Yields `freeze`: once called (after the first read, the modules loaded), every object then alive
    -- the modules, numba's and Open CASCADE's registries, the compiled kernels' wrappers: ~150K objects
    -- is left out of the cyclic garbage collector's full collections (`gc.freeze`), which otherwise walk
    them all each time (measured on gmsh__U_Joint_2 at the defaults: 2 full collections, 0.07-0.09 s CPU,
    during the tessellation and its measurement). Nothing is freed differently: reference counting
    frees as before, and on the way out `gc.unfreeze` hands the frozen objects back to the collector
    (so an in-process caller, e.g. a test run, keeps nothing alive)."""
    import gc

    done = []

    def freeze():
        if not done:
            gc.freeze()
            done.append(True)

    try:
        yield freeze
    finally:
        if done:
            gc.unfreeze()


def _guarantees_met(path: Path, target: Path, res, shell) -> bool:
    """Measure the written file (read back); one warning line if a promise is broken.

    Broken: flipped triangles, non-manifold edges beyond those the model's own
    faces explain (`tessellate.measure.explained_nonmanifold_edges`), or a measured
    max deviation over the tolerance (``within_tolerance`` False). Non-manifold
    edges are counted on the file read back; flips too where the file keeps each
    triangle's face (PLY's face_id, VTK, VTU), else on the mesh in memory that was written
    (OBJ, OFF, STL, glTF, --quads). The written figures replace the in-memory ones
    in ``res.report``. Where the file read back holds exactly the mesh that `measure_result`
    measured (vertices bit for bit, triangles, face ids: `tessellate.measure.figures_of_same_mesh`,
    e.g. PLY, which keeps float64), those figures are the file's figures and are taken as they are;
    a file that differs anywhere is measured afresh.
    """
    from ..io import read_mesh
    from ..quality import topology_report
    from ..tessellate.measure import explained_nonmanifold_edges, figures_of_same_mesh, flipped_against_normal

    r = res.report
    back = read_mesh(target)
    same = figures_of_same_mesh(back, res.mesh, shell, reversed_faces=r.get("faces_flipped", ()),
                                face_meshes=res.face_meshes, tolerance=res.tolerance)
    r["nonmanifold_edges"] = same["nonmanifold_edges"] if "nonmanifold_edges" in same \
        else int(topology_report(back).n_non_manifold_edges)
    if back.face_id is not None:
        if "flipped" in same:
            r["flipped"], r["nonmanifold_edges_explained"] = same["flipped"], same["nonmanifold_edges_explained"]
        else:
            r["flipped"] = flipped_against_normal(back, shell, reversed_faces=r.get("faces_flipped", ()))
            r["nonmanifold_edges_explained"] = int(explained_nonmanifold_edges(back, res.face_meshes,
                                                                               res.tolerance).sum())
    flipped = int(r.get("flipped") or 0)
    excess = r["nonmanifold_edges"] - int(r.get("nonmanifold_edges_explained") or 0)
    over = r.get("within_tolerance") is False
    r["guarantees_met"] = flipped == 0 and excess <= 0 and not over
    if not r["guarantees_met"]:
        what = [f"{flipped} flipped triangles"] if flipped else []
        what += [f"{excess} non-manifold edges the model does not explain"] if excess > 0 else []
        what += [f"max deviation {r['max_deviation']:.4g} over the tolerance {res.tolerance:.4g}"] if over else []
        print_warning(f"{path}: guarantee not met in {target}: {', '.join(what)}")
    return r["guarantees_met"]


def _failure(exc: BaseException, path: Path) -> str:
    """One line for a batch input that failed, naming the file once."""
    if isinstance(exc, MemoryError):
        return f"{path}: out of memory (use a larger --tolerance or --max-edge)"
    if isinstance(exc, OSError):
        return f"{exc.filename or path}: {exc.strerror or exc}"
    if not isinstance(exc, InputError):
        return (f"{path}: internal error: {type(exc).__name__}: {' '.join(str(exc).split())} (a bug; rerun with "
                "--debug for the traceback and report it)")
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if str(path) in text else f"{path}: {text}"
