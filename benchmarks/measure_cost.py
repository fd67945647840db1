"""Cost of the tessellation report's measurement against the meshing itself (issue 17, item 2).

For every model, at eps = 1e-3 x diagonal, tolerance only (max edge = diagonal) and at the CLI's defaults
(max edge 3e-2 x diagonal): CPU time (``time.process_time``, best of ``--reps``) of
``tessellate_shell(..., measure=False)`` and of ``tessellate.measure.measure_result`` on that mesh (the
report's figures, as ``--report`` writes them), with the seed-grid cache of ``geom.projection`` emptied
before each measurement (a fresh process measures each face's surface for the first time), and the
figures measured: ``max_deviation`` and ``max_deviation_bound`` (x eps), flipped triangles. ``kern s``: the CPU
of the compiled kernels (Newton, surface evaluation, seed grids and their k-d queries, mesh search, point in
polygon, (u, v) location, grid points of `memo_points_kernel` where the checkout has it) within one more
measurement, timed per call; ``floor`` = kern s / mesh s, what
the measurement would cost against the meshing with no Python around the kernels at all.

``--reference SRC`` times another checkout's ``src`` in a child process on the same meshes (pickled; ``ref s``,
``ref kern`` its kernels as ``kern s``), e.g.
``--reference /work/main/src``, so old and new measure the same triangles.

Usage: python benchmarks/measure_cost.py [--models a,b] [--reps 3] [--reference SRC] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import subprocess
import sys
import tempfile
import time
from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad"
MODELS = ("occt__screw.step", "gmsh__t20_data.step", "trimesh__featuretype.STEP", "gmsh__U_Joint_2.stp",
          "gmsh__SampleCrankshaft4A.stp", "occt__bearing.iges")
MODES = (("tol", 1.0), ("defaults", 3e-2))

_CHILD = r"""
import json, pickle, sys, time
import trimsurf.geom.projection as P
from trimsurf.tessellate.measure import measure_result
shell, res, reps = pickle.load(open(sys.argv[1], "rb"))
best = None
for _ in range(reps):
    P._SEED_CACHE.clear()
    t = time.process_time(); m = measure_result(res, shell); t = time.process_time() - t
    best = t if best is None else min(best, t)
# one more run with the compiled kernels (and the seed k-d queries) timed: their CPU is the floor that no
# batching of the per-face Python can go below
import importlib
acc = [0.0]
def _timed(f):
    def g(*a, **k):
        t0 = time.process_time()
        try:
            return f(*a, **k)
        finally:
            acc[0] += time.process_time() - t0
    return g
for mod, names in (("trimsurf.geom.projection", ("project_newton_kernel", "surface_derivatives_kernel",
                                                 "seed_grid_kernel", "_nearest_seeds", "memo_points_kernel")),
                   ("trimsurf.geom._nurbs_kernels", ("surface_derivatives_kernel", "curve_points_kernel")),
                   ("trimsurf.quality.closest_point", ("grid_build_kernel", "grid_closest_kernel",
                                                      "hint_closest_kernel", "packed_closest_kernel")),
                   ("trimsurf.quality.sampling", ("_points_in_polygons_kernel", "segments_distance_kernel")),
                   ("trimsurf.quality.deviation", ("uv_locate_kernel", "memo_points_kernel"))):
    mm = importlib.import_module(mod)
    for n in names:
        if hasattr(mm, n):
            setattr(mm, n, _timed(getattr(mm, n)))
P._SEED_CACHE.clear()
measure_result(res, shell)
print(json.dumps({"cpu": best, "max": m["max_deviation"], "bound": m["max_deviation_bound"],
                  "flipped": m["flipped"], "kernels": acc[0]}))
"""


def _measure(src: str | None, shell, res, reps: int, tmp: Path) -> dict:
    f = tmp / "case.pkl"
    f.write_bytes(pickle.dumps((shell, res, reps)))
    env = dict(os.environ)
    env["PYTHONPATH"] = src if src else str(Path(__file__).resolve().parents[1] / "src")
    out = subprocess.run([sys.executable, "-c", _CHILD, str(f)], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--models", default=",".join(MODELS))
    p.add_argument("--reps", type=int, default=3)
    p.add_argument("--reference", help="another checkout's src folder, timed on the same meshes")
    p.add_argument("--json")
    a = p.parse_args(argv)
    from trimsurf.io import read_shell
    from trimsurf.samples import build_sample
    from trimsurf.tessellate import tessellate_shell

    rows = []
    head = (f"{'model':30} {'mode':8} {'tris':>6} {'mesh s':>7} {'measure s':>9} {'ratio':>5} {'max/eps':>9} "
            f"{'bnd/eps':>8} {'kern s':>6} {'floor':>5}")
    if a.reference:
        head += f" {'ref s':>6} {'ref max/eps':>11} {'ref kern':>8}"
    print(head, flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for name in a.models.split(","):
            shell = build_sample(name) if "." not in name else read_shell(DATA / name)
            d = shell.diagonal()
            eps = 1e-3 * d
            for mode, h in MODES:
                mesh_s = None
                for _ in range(a.reps):
                    t = time.process_time()
                    res = tessellate_shell(shell, tolerance=eps, max_edge=h * d, measure=False)
                    t = time.process_time() - t
                    mesh_s = t if mesh_s is None else min(mesh_s, t)
                new = _measure(None, shell, res, a.reps, Path(tmp))
                row = {"model": name, "mode": mode, "triangles": res.mesh.n_triangles, "seconds_mesh": mesh_s,
                       "seconds_measure": new["cpu"], "max_deviation": new["max"], "max_deviation_bound": new["bound"],
                       "flipped": new["flipped"], "eps": eps, "seconds_kernels": new["kernels"]}
                line = (f"{name:30} {mode:8} {res.mesh.n_triangles:6d} {mesh_s:7.3f} {new['cpu']:9.3f} "
                        f"{new['cpu'] / mesh_s:5.2f} {new['max'] / eps:9.6f} {new['bound'] / eps:8.4f} "
                        f"{new['kernels']:6.3f} {new['kernels'] / mesh_s:5.2f}")
                if a.reference:
                    ref = _measure(a.reference, shell, res, a.reps, Path(tmp))
                    row.update(reference_seconds_measure=ref["cpu"], reference_max_deviation=ref["max"],
                               reference_max_deviation_bound=ref["bound"], reference_flipped=ref["flipped"],
                               reference_seconds_kernels=ref["kernels"])
                    line += f" {ref['cpu']:6.3f} {ref['max'] / eps:11.6f} {ref['kernels']:8.3f}"
                rows.append(row)
                print(line, flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
