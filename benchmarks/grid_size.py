"""Grid size as the paper means it (issue 17, deliverable 4): triangles, longest edge, 5th-percentile angle
and deviation for the two readings of the grid-size parameter, adaptive against uniform lines.

The paper (tessellation-reflection-lines, Sec. 1): "Grid size means the distance between two vertices on
iso-parametric lines". trimsurf's ``max_edge`` H bounds every triangle edge, so its iso-lines are spaced
H / sqrt(2) (the cell diagonals, triangle edges, stay within H). The paper's grid size G is therefore
``max_edge = sqrt(2) G`` (iso-line spacing G, diagonals up to sqrt(2) G). For every model, at eps = 1e-3 x
diagonal and G = 3e-2 x diagonal (the CLI's defaults), both readings with the adaptive (equidistributed)
and the uniform domain values; deviation measured two-sided with refined sampling (`measure_mesh`).

Usage: python benchmarks/grid_size.py [--models a,b] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from trimsurf.io import read_shell
from trimsurf.samples import build_sample, sample_names
from trimsurf.tessellate import default_parameters, tessellate_shell
from trimsurf.tessellate.measure import measure_mesh

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad"
MODELS = ("gmsh__t20_data.step", "occt__screw.step", "gmsh__wrenchnut.stp", "trimesh__featuretype.STEP",
          "occtpr946__ec_soapbox-A.stp", "occtpr946__trj5_k1-pe-214.stp", "fender", "hood")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--models", default=",".join(MODELS))
    p.add_argument("--json")
    a = p.parse_args(argv)
    rows = []
    print(f"{'model':28} {'reading':10} {'lines':6} {'tris':>7} {'dev/eps':>7} {'bnd/eps':>7} {'edge/G':>6} "
          f"{'p5':>5} {'mesh s':>6}")
    for name in a.models.split(","):
        shell = build_sample(name) if name in sample_names() else read_shell(DATA / name)
        eps, g = default_parameters(shell)
        for reading, h in (("edge<=G", g), ("spacing=G", np.sqrt(2.0) * g)):
            for strat in ("equidistributed", "uniform"):
                t = time.perf_counter()
                res = tessellate_shell(shell, tolerance=eps, max_edge=h, strategy=strat, measure=False)
                sec = time.perf_counter() - t
                m = measure_mesh(res.mesh, shell)
                row = {"model": name, "reading": reading, "strategy": strat, "eps": eps, "grid": g, "max_edge": h,
                       "triangles": m["triangles"], "dev_eps": m["max_deviation"] / eps,
                       "bound_eps": m["max_deviation_bound"] / eps, "longest_over_grid": m["max_edge"] / g,
                       "p5": m["p5_angle_deg"], "seconds_mesh": sec, "seconds_measure": m["seconds_measure"]}
                rows.append(row)
                print(f"{name[:28]:28} {reading:10} {strat[:5]:6} {row['triangles']:7d} {row['dev_eps']:7.3f} "
                      f"{row['bound_eps']:7.3f} {row['longest_over_grid']:6.3f} {row['p5']:5.1f} {sec:6.1f}",
                      flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
