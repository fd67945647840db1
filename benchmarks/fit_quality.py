"""Fitting trimmed NURBS faces to meshes: every mesh x every forward map x every back-map (paper Tables 1-6).

For every mesh in ../shared/data/meshes, the samples ``s_cone`` and ``holed_sheet``, and a 20K-vertex S strip
on a cone: the mesh's B-rep check (meshes the method rejects are listed with the reason), then for each
forward map (hlle, isomap, laplacian, lscm, harmonic) and each back-map (nurbs, rbf, hybrid, greville, lsq)
the fit time, and the face WRITTEN to STEP and read back through Open CASCADE
(`trimsurf.fit.measure_written_face`): two-sided sampled Hausdorff distance as a fraction of the
bounding-box diagonal, area face / mesh, self-intersections of its tessellation, BRepCheck of the file;
with the folds of the forward map.

``--extrapolation``: the NURBS extrapolation back-map (Sec. 4.2.1) with a cubic extrapolating surface S_i
(the paper's) against a bilinear one, read back, on the meshes where the forward map does not fold.

Reference tool, side by side: scikit-learn's Isomap, SpectralEmbedding (Laplacian Eigenmaps) and
LocallyLinearEmbedding(method='hessian') on the S strips whose exact flat layout is known (``*.uv.npy``).
Every layout, scikit-learn's and trimsurf's, goes through the same normalisation
(`trimsurf.fit.normalize_parameters`: one global 2 x 2 stretch to the mesh's edge lengths, turned and
centred) and is then compared with the exact layout after the best similarity: layout error = largest
distance over the layout size. Ratios trimsurf / scikit-learn.

Usage: python benchmarks/fit_quality.py [--json out.json] [--quick]
                                        [--reference-only | --end-to-end-only | --extrapolation]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from trimsurf.errors import InputError, TrimsurfWarning
import tempfile

from trimsurf.fit import embed, fit_trimmed_face, measure_written_face, mesh_brep, normalize_parameters
from trimsurf.io import read_mesh, write_shell
from trimsurf.samples import holed_sheet, s_cone

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "meshes"
BIG_MAX_AREA = 0.00018          # s_cone(max_area=...) -> about 20K vertices
EMBED_ORDER = ("hlle", "isomap", "laplacian", "lscm", "harmonic")
BACKMAP_ORDER = ("nurbs", "rbf", "hybrid", "greville", "lsq")


def meshes(quick: bool, no_big: bool = False):
    for path in sorted(DATA.iterdir()):
        if path.suffix.lower() in (".off", ".obj", ".ply", ".stl"):
            if quick and not no_big and path.stat().st_size > 300_000:
                continue
            yield path.name, (lambda p=path: read_mesh(p))
    yield "sample:s_cone", s_cone
    yield "sample:holed_sheet", holed_sheet
    if not quick and not no_big:
        yield "s_cone_20k", lambda: s_cone(max_area=BIG_MAX_AREA)


def procrustes(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a - a.mean(axis=0), b - b.mean(axis=0)
    # best similarity (scikit-learn's maps are not to scale), then rigid error over the size
    u, s, vt = np.linalg.svd(a.T @ b)
    r = u @ vt
    scale = s.sum() / np.sum(a * a)
    return float(np.abs(scale * a @ r - b).max() / np.ptp(b, axis=0).max())


def written(mesh, result, name):
    """The face written to STEP and read back through Open CASCADE, measured against the mesh."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "fit.step"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TrimsurfWarning)
            write_shell(result.face, path)
        return measure_written_face(path, mesh)


def fit_rows(name, build, *, backmaps=BACKMAP_ORDER, embeds=EMBED_ORDER, options=None):
    mesh = build()
    try:
        brep = mesh_brep(mesh, name=name)
    except InputError as exc:
        return [{"mesh": name, "vertices": mesh.n_vertices, "skipped": str(exc)}]
    rows = []
    for emb in embeds:
        for bm in backmaps:
            row = {"mesh": name, "vertices": mesh.n_vertices, "loops": brep.n_loops,
                   "abs_curvature": round(brep.total_abs_curvature, 3), "embed": emb, "backmap": bm}
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", TrimsurfWarning)
                    t = time.perf_counter()
                    r = fit_trimmed_face(mesh, embed_method=emb, backmap_method=bm, name=name,
                                         backmap_options=options)
                    row["seconds"] = time.perf_counter() - t
                w = written(mesh, r, name)
                d = mesh.diagonal()
                row.update(grid=list(r.grid.shape), flipped=r.embedding.n_flipped,
                           crossings=r.embedding.n_boundary_crossings, hausdorff_rel=w.hausdorff / d,
                           rms_rel=w.rms_mesh_to_face / d, boundary_rel=w.boundary_deviation / d,
                           area_ratio=w.area_ratio, self_intersections=w.self_intersections,
                           step_valid=w.step_valid, measure_seconds=sum(w.seconds.values()))
                if w.error:
                    row["error"] = f"read back, not measured: {w.error}"
            except Exception as exc:  # noqa: BLE001 - a benchmark row records the failure
                row["error"] = f"{type(exc).__name__}: {exc}"
            rows.append(row)
            print(_fmt(row), file=sys.stderr, flush=True)
    return rows


def sklearn_rows(quick: bool):
    from sklearn.manifold import Isomap, LocallyLinearEmbedding, SpectralEmbedding

    names = ["s_cone_v451"] + ([] if quick else ["s_cone_v4044"])
    refs = {"isomap": lambda: Isomap(n_neighbors=10, n_components=2),
            "laplacian": lambda: SpectralEmbedding(n_components=2, n_neighbors=10, random_state=0),
            "hlle": lambda: LocallyLinearEmbedding(n_neighbors=12, n_components=2, method="hessian",
                                                   eigen_solver="dense" if False else "arpack", random_state=0)}
    rows = []
    for nm in names:
        mesh = read_mesh(DATA / f"{nm}.off")
        exact = np.load(DATA / f"{nm}.uv.npy")
        for meth in ("hlle", "isomap", "laplacian", "lscm", "harmonic"):
            t = time.perf_counter()
            uv = embed(mesh, meth)                     # embed() ends with normalize_parameters
            ours_s = time.perf_counter() - t
            row = {"mesh": nm, "vertices": mesh.n_vertices, "embed": meth, "trimsurf_seconds": ours_s,
                   "trimsurf_error": procrustes(uv, exact)}
            if meth in refs:
                try:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        t = time.perf_counter()
                        ref = refs[meth]().fit_transform(mesh.vertices)
                        row["sklearn_seconds"] = time.perf_counter() - t
                    ref = normalize_parameters(mesh, ref)      # the same normalisation as trimsurf's layouts
                    row["sklearn_error"] = procrustes(ref, exact)
                    row["time_ratio"] = ours_s / row["sklearn_seconds"]
                    row["error_ratio"] = row["trimsurf_error"] / row["sklearn_error"]
                except Exception as exc:  # noqa: BLE001
                    row["sklearn_error_message"] = f"{type(exc).__name__}: {exc}"
            rows.append(row)
            print(row, file=sys.stderr, flush=True)
    return rows


def _fmt(row) -> str:
    if "skipped" in row:
        return f"| {row['mesh']} | {row['vertices']} | skipped: {row['skipped']} |"
    if "error" in row:
        return f"| {row['mesh']} | {row['embed']} | {row['backmap']} | error: {row['error']} |"
    return (f"| {row['mesh']} | {row['vertices']} | {row['loops']} | {row['abs_curvature']:.2f} | {row['embed']} | "
            f"{row['backmap']} | {row['seconds']:.2f} | {row['flipped']} | {row['crossings']} | "
            f"{100 * row['hausdorff_rel']:.3g} | {row['area_ratio']:.3g} | {100 * row['rms_rel']:.3g} | "
            f"{100 * row['boundary_rel']:.3g} | "
            f"{row['self_intersections'] if row['self_intersections'] >= 0 else 'not counted'} | "
            f"{'yes' if row['step_valid'] else 'NO'} |")


def extrapolation_table(quick: bool) -> int:
    """Sec. 4.2.1 with S_i cubic (the paper's) and bilinear, read back; forward maps that do not fold."""
    names = ["s_cone_v451.off", "alligator.obj", "lilium.obj", "hole_sphere1.off", "beetle_peyre.off",
             "nefertiti.off"] + ([] if quick else ["s_cone_v4044.off"])
    cases = [(n, lambda n=n: read_mesh(DATA / n)) for n in names] + [("sample:holed_sheet", holed_sheet)]
    print("| mesh | V | forward map | cubic S_i: Hausdorff % diag | area ratio | self-int | "
          "bilinear S_i: Hausdorff % diag | area ratio | self-int |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, build in cases:
        mesh = build()
        for emb in ("hlle", "lscm"):
            cells = []
            for degree in (3, 1):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", TrimsurfWarning)
                    r = fit_trimmed_face(mesh, embed_method=emb, backmap_method="nurbs", name=name,
                                         backmap_options={"extrapolation_degree": degree})
                w = written(mesh, r, name)
                cells += [f"{100 * w.hausdorff / mesh.diagonal():.3g}", f"{w.area_ratio:.3g}",
                          str(w.self_intersections) if w.self_intersections >= 0 else "not counted"]
            print(f"| {name} | {mesh.n_vertices} | {emb} ({r.embedding.n_flipped} flipped) | "
                  + " | ".join(cells) + " |", flush=True)
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", type=Path, help="also write the rows as JSON")
    parser.add_argument("--quick", action="store_true", help="small meshes only, no 20K mesh")
    parser.add_argument("--reference-only", action="store_true",
                        help="only the side-by-side forward maps against scikit-learn")
    parser.add_argument("--end-to-end-only", action="store_true",
                        help="only the 20K-vertex mesh with the default pipeline (hlle + lsq), timed end to end")
    parser.add_argument("--embeds", default=",".join(EMBED_ORDER),
                        help="comma-separated forward maps of the main table (default all)")
    parser.add_argument("--no-big", action="store_true", help="leave the 20K-vertex strip out of the main table")
    parser.add_argument("--extrapolation", action="store_true",
                        help="only the NURBS extrapolation back-map, cubic vs bilinear extrapolating surface")
    args = parser.parse_args(argv)
    if args.extrapolation:
        return extrapolation_table(args.quick)
    if args.reference_only:
        rows, ref = [], sklearn_rows(args.quick)
    elif args.end_to_end_only:
        rows = fit_rows("s_cone_20k", lambda: s_cone(max_area=BIG_MAX_AREA), backmaps=("lsq",), embeds=("hlle",))
        ref = []
    else:
        rows = []
        embeds = tuple(e for e in args.embeds.split(",") if e)
        for name, build in meshes(args.quick, args.no_big):
            rows.extend(fit_rows(name, build, embeds=embeds))
        ref = sklearn_rows(args.quick)
    if rows:
        print("| mesh | V | loops | int abs K / 2pi | embed | backmap | fit s | flipped | loop crossings | "
              "read back: Hausdorff % diag | area face / mesh | RMS % diag | boundary % diag | self-int | "
              "BRepCheck |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        for row in rows:
            print(_fmt(row))
    if ref:
        print()
        print("| mesh | V | forward map | trimsurf s | trimsurf layout error | scikit-learn s | "
              "scikit-learn layout error | time ratio | error ratio |")
        print("|---|---|---|---|---|---|---|---|---|")
        for r in ref:
            sk_s = f"{r['sklearn_seconds']:.3f}" if "sklearn_seconds" in r else "-"
            sk_e = f"{r['sklearn_error']:.2e}" if "sklearn_error" in r else r.get("sklearn_error_message", "-")
            tr = f"{r['time_ratio']:.2f}" if "time_ratio" in r else "-"
            er = f"{r['error_ratio']:.3f}" if "error_ratio" in r else "-"
            print(f"| {r['mesh']} | {r['vertices']} | {r['embed']} | {r['trimsurf_seconds']:.3f} | "
                  f"{r['trimsurf_error']:.2e} | {sk_s} | {sk_e} | {tr} | {er} |")
    if args.json:
        args.json.write_text(json.dumps({"fits": rows, "reference": ref}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
