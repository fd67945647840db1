"""G1 error and curvature jump of every reconstruction fill, on the paper's examples and real meshes.

For each mesh and (network, fill): the largest normal-angle jump across any patch edge
(network curves and inner split curves) and the largest jump of the normal curvature
perpendicular to a patch edge (1/model unit), both sampled at 17 points inside every patch
edge (maxima over samples, not bounds), the fill time, and for Peters' fill the vertices
whose G1 equations keep a residual (vertex enclosure problem).

Usage: python benchmarks/reconstruct_fills.py [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from trimsurf import io
from trimsurf.reconstruct import reconstruct_mesh
from trimsurf.samples import boundary_problem, car_panel, octahedron

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "meshes"
FILLS = (("shirman-sequin", "split"), ("g1", "split"), ("g1", "single"), ("g1", "peters"), ("g2", "split"),
         ("g2", "single"))


def meshes():
    yield "shifted octahedron", octahedron()
    yield "regular octahedron", octahedron(shift_deg=0.0)
    yield "boundary problem", boundary_problem()
    yield "car panel", car_panel()
    for name in ("hole_sphere1.off", "nefertiti.off", "venus_front.off", "lilium.obj"):
        if (DATA / name).is_file():
            yield name, io.read_mesh(DATA / name)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    rows = []
    for name, mesh in meshes():
        for network, fill in FILLS:
            r = reconstruct_mesh(mesh, network=network, fill=fill).report
            rows.append({"mesh": name, "vertices": r["vertices"], "network": network, "fill": fill,
                         "g1_error_max_deg": r["g1_error_max_deg"], "curvature_jump_max": r["curvature_jump_max"],
                         "mean_curvature_jump_max": r["mean_curvature_jump_max"],
                         "g1_residual_vertices": r["g1_residual_vertices"], "fill_s": r["fill_seconds"]})
            print(f"  {name} {network} {fill}: {r['g1_error_max_deg']:.3g} deg", file=sys.stderr)
    if args.json:
        print(json.dumps({"benchmark": "reconstruct_fills", "rows": rows}, indent=2))
        return 0
    print(f"{'mesh':20} {'V':>6} {'network':15} {'fill':7} {'G1 max deg':>10} {'k jump':>9} {'H jump':>9} "
          f"{'resid v':>7} {'fill s':>7}")
    for r in rows:
        print(f"{r['mesh']:20} {r['vertices']:>6} {r['network']:15} {r['fill']:7} {r['g1_error_max_deg']:>10.3g} "
              f"{r['curvature_jump_max']:>9.3g} {r['mean_curvature_jump_max']:>9.3g} {r['g1_residual_vertices']:>7} "
              f"{r['fill_s']:>7.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
