"""Joining real CAD models: accuracy inside the triangles, folding, sewing -- Whitney join vs midpoint baseline.

For every model of ../shared/data/cad (an unsewn one, e.g. ``occt__bearing.iges``, is sewn first by
`trimsurf.join.sew_shell`) at the CLI's default deflection d = 0.1 % of the bounding-box diagonal, two
inputs:

* ``conforming``: Open CASCADE meshes all faces together (`io.occ_mesh_faces`): neighbours share their
  edge nodes;
* ``independent``: every face meshed alone at its own deflection in [0.5 d, d]
  (`trimsurf.join.mesh_faces_independently`): the boundary nodes of neighbours differ (the paper's case).

Both are joined by `join_shell` (deflection d) and by the midpoint baseline (`midpoint_join`).
Columns: ``in_dev`` the input meshes' largest deviation from their faces; ``dev`` / ``p99`` the output's
(both sampled inside the triangles: barycentric grid of 6 per edge with corners, edge midpoints and
centroids, every sample projected exactly onto its face's surface, `trimsurf.quality.shell_deviation`;
p99 over the per-triangle maxima); ``flip`` triangles whose normal points against the face's outward
normal (`quality.flipped_triangles_normal`, the same test for both methods); ``open`` topologically open
edges (one triangle, no welding) and, in brackets, those on joints; ``min_ang`` the smallest 3D triangle
angle (degrees); ``s`` seconds of the join alone (meshing and measuring not included).

The JSON rows also give, for W, the faces left unjoined (``bad_faces``), re-meshed over their whole (u, v)
domain (``remeshed_faces``), the input mesh vertices merged into a coinciding neighbour
(``collapsed_vertices``) and the chords split where dR crossed (``crossing_chords_split``).

Usage: python benchmarks/join_real.py [--json out.json] [--models NAME ...]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import traceback
from pathlib import Path

import numpy as np

import trimsurf.io as tio
from trimsurf.join import join_shell, midpoint_join, mesh_faces_independently, needs_sewing, sew_shell
from trimsurf.join._accuracy import input_deviation, mesh_deviation_inside
from trimsurf.quality import flipped_triangles_normal

CAD = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad"
if not CAD.exists():
    CAD = Path("/work/shared/data/cad")


def flips(shell, mesh) -> int:
    n = 0
    for f, face in enumerate(shell.faces):
        sel = mesh.face_id == f
        if sel.any():
            n += flipped_triangles_normal(mesh.submesh(sel), face).n_flipped
    return n


def min_angle(mesh) -> float:
    p = mesh.vertices[mesh.triangles]
    out = np.inf
    for c in range(3):
        u = p[:, (c + 1) % 3] - p[:, c]
        v = p[:, (c + 2) % 3] - p[:, c]
        ang = np.degrees(np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), (u * v).sum(axis=1)))
        out = min(out, float(ang.min(initial=180.0)))
    return out


def measure(shell, mesh, seconds: float, on_joint_open: int) -> dict:
    dev = mesh_deviation_inside(mesh, shell)
    return {"dev": dev["max_deviation"], "p99": dev["p99_deviation"], "flip": flips(shell, mesh),
            "open": int(len(mesh.boundary_edges())), "open_joins": int(on_joint_open),
            "min_ang": min_angle(mesh), "s": seconds, "triangles": int(mesh.n_triangles)}


def run_model(path: Path) -> list[dict]:
    shell = tio.read_shell(path)
    sewn = needs_sewing(shell)
    if sewn:
        shell = sew_shell(shell)
    d = 1e-3 * shell.diagonal()
    rows = []
    for kind in ("conforming", "independent"):
        meshes = tio.occ_mesh_faces(shell, linear_deflection=d) if kind == "conforming" \
            else mesh_faces_independently(shell, d)
        row = {"model": path.name, "input": kind, "sewn": sewn, "deflection": d,
               "in_dev": input_deviation(shell, meshes, density=6)}
        t = time.perf_counter()
        res = join_shell(shell, meshes, deflection=d, measure=False)
        tw = time.perf_counter() - t
        from trimsurf.join._shell import _summary
        rep = _summary(shell, res, True)
        row["whitney"] = measure(shell, res.mesh, tw, rep["boundary_edges_on_joins"])
        row["whitney"]["bad_faces"] = len(res.bad_faces)
        row["whitney"]["remeshed_faces"] = len(res.remeshed_faces)
        row["whitney"]["collapsed_vertices"] = rep["collapsed_vertices"]
        row["whitney"]["crossing_chords_split"] = res.report["crossing_chords_split"]
        t = time.perf_counter()
        base = midpoint_join(shell, meshes)
        tb = time.perf_counter() - t
        be = base.mesh.boundary_edges()
        on_j = int(np.count_nonzero(base.on_joint[be].all(axis=1))) if len(be) else 0
        row["baseline"] = measure(shell, base.mesh, tb, on_j)
        rows.append(row)
        print_row(row)
    return rows


HEADER = (f"{'model':<38} {'input':<11} {'in_dev/d':>8} | {'W dev/d':>7} {'p99/d':>6} {'flip':>4} {'open':>9} "
          f"{'min_ang':>7} {'s':>6} | {'B dev/d':>7} {'flip':>4} {'open':>9} {'min_ang':>7} {'s':>5}")


def print_row(r: dict) -> None:
    d = r["deflection"]
    w, b = r["whitney"], r["baseline"]
    name = r["model"] + (" (sewn)" if r["sewn"] else "")
    print(f"{name:<38} {r['input']:<11} {r['in_dev'] / d:>8.2f} | {w['dev'] / d:>7.2f} {w['p99'] / d:>6.2f} "
          f"{w['flip']:>4} {w['open']:>4} ({w['open_joins']:>2}) {w['min_ang']:>7.2f} {w['s']:>6.2f} | "
          f"{b['dev'] / d:>7.2f} {b['flip']:>4} {b['open']:>4} ({b['open_joins']:>2}) {b['min_ang']:>7.2f} "
          f"{b['s']:>5.2f}", flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", type=Path, help="also write the rows as JSON")
    parser.add_argument("--models", nargs="+", help="only these files of the CAD folder")
    args = parser.parse_args(argv)
    paths = sorted(p for p in CAD.iterdir() if p.suffix.lower() in (".step", ".stp", ".iges", ".igs"))
    if args.models:
        paths = [p for p in paths if p.name in args.models]
    from trimsurf.samples.folding_pair import folding_pair, folding_pair_meshes
    fold = folding_pair()
    join_shell(fold, folding_pair_meshes(fold))   # compile the numba kernels outside the timing
    print(HEADER, flush=True)
    rows = []
    for p in paths:
        try:
            rows.extend(run_model(p))
        except Exception as exc:  # a model that fails is reported, the others still run
            print(f"{p.name}: FAILED {type(exc).__name__}: {exc}", flush=True)
            traceback.print_exc()
            rows.append({"model": p.name, "error": f"{type(exc).__name__}: {exc}"})
        if args.json:
            args.json.write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
