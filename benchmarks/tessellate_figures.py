"""The tessellation's figures on every model, for a change that MAY change the meshes (issue 17, item 3).

For every real file in ../shared/data/cad and the samples fender, hood, gap_pair, bspline_box, in two
settings (tol: eps = 1e-3 of the diagonal, max edge = the diagonal; paper: max edge 3 % of the diagonal,
trimsurf's defaults), `tessellate_shell` with its own measurement (``measure=True``: refined two-sided
deviation, topology, flips against the surface normal) plus the two-sided metric of
benchmarks/tessellate_vs_occt.py (``shell_deviation``, density 3, 32 x 32 face samples) and the 5th
percentile of the per-triangle smallest angle; meshing CPU time (``measure=False``), best of ``--runs``.

Run once per source tree (the trimsurf on PYTHONPATH), then compare the two JSON files:

    PYTHONPATH=/tmp/old/src python benchmarks/tessellate_figures.py --json old.json
    PYTHONPATH=src python benchmarks/tessellate_figures.py --json new.json
    python benchmarks/tessellate_figures.py --compare old.json new.json

``--aspect A`` meshes with ``tessellate_shell(aspect=A)`` (inf: no limit), e.g. to compare an aspect limit
against the default on one tree.

The comparison marks a row "NO" when the new mesh measures beyond eps (either metric), has a flipped
triangle, is not consistently oriented, has more boundary or non-manifold edges or failed faces than the
old one, or is no longer watertight where the old one was.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad"
SAMPLES = ("fender", "hood", "gap_pair", "bspline_box")
MODES = {"tol": 1.0, "paper": 3e-2}      # max edge / diagonal


def figures(models: list[str] | None, runs: int, aspect: float | None = None) -> list[dict]:
    """The rows; `aspect`: tessellate_shell's aspect limit (None: its default; inf: no limit)."""
    import numpy as np

    from trimsurf.io import read_shell
    from trimsurf.quality import shell_deviation, triangle_quality
    from trimsurf.samples import build_sample
    from trimsurf.tessellate import tessellate_shell

    names = [(p.name, p) for p in sorted(DATA.iterdir()) if p.suffix.lower() in (".step", ".stp", ".iges", ".igs")]
    names += [(s, s) for s in SAMPLES]
    kw = {} if aspect is None else {"aspect": aspect}
    if models:
        names = [m for m in names if any(k in m[0] for k in models)]
    rows = []
    for name, src in names:
        shell = build_sample(src) if isinstance(src, str) else read_shell(src)
        d = shell.diagonal()
        eps = 1e-3 * d
        for mode, rel_h in MODES.items():
            h = rel_h * d
            best = np.inf
            for _ in range(runs):
                t = time.process_time()
                tessellate_shell(shell, tolerance=eps, max_edge=h, measure=False, **kw)
                best = min(best, time.process_time() - t)
            res = tessellate_shell(shell, tolerance=eps, max_edge=h, measure=True, **kw)
            r = res.report
            dev = shell_deviation(res.mesh, shell, density=3, n_domain=32)
            q = triangle_quality(res.mesh)
            row = {"model": name, "mode": mode, "triangles": res.mesh.n_triangles, "dev": r["max_deviation"] / eps,
                   "bench_dev": float(dev.max_two_sided) / eps, "p5": q.p5_min_angle_deg, "min_angle": q.min_angle_deg,
                   "boundary": r["boundary_edges"], "nonmanifold": r["nonmanifold_edges"], "flipped": r["flipped"],
                   "oriented": r["orientation_consistent"], "watertight": r["watertight"],
                   "failed": r["faces_failed"], "cpu": best}
            rows.append(row)
            print(json.dumps(row), flush=True)
    return rows


def compare(old: list[dict], new: list[dict]) -> int:
    a = {(r["model"], r["mode"]): r for r in old}
    b = {(r["model"], r["mode"]): r for r in new}
    print(f"{'model':28s} {'mode':5s} | {'tris':>6s} {'new':>6s} {'ratio':>5s} | {'dev/eps':>7s} {'new':>6s} | "
          f"{'bench':>6s} {'new':>6s} | {'p5':>5s} {'new':>5s} | {'cpu s':>5s} {'new':>5s} | guarantees")
    logs: dict = {m: {"tri": [], "cpu": []} for m in MODES}
    bad = 0
    for k in a:
        if k not in b:
            continue
        x, y = a[k], b[k]
        ok = (y["dev"] <= 1 and y["bench_dev"] <= 1 and y["flipped"] == 0 and y["oriented"]
              and (y["watertight"] or not x["watertight"]) and y["boundary"] <= x["boundary"]
              and y["nonmanifold"] <= x["nonmanifold"] and y["failed"] <= x["failed"])
        bad += not ok
        logs[k[1]]["tri"].append(math.log(y["triangles"] / x["triangles"]))
        logs[k[1]]["cpu"].append(math.log(y["cpu"] / x["cpu"]))
        print(f"{k[0][:28]:28s} {k[1]:5s} | {x['triangles']:6d} {y['triangles']:6d} "
              f"{y['triangles'] / x['triangles']:5.3f} | {x['dev']:7.4f} {y['dev']:6.4f} | "
              f"{x['bench_dev']:6.4f} {y['bench_dev']:6.4f} | {x['p5']:5.2f} {y['p5']:5.2f} | "
              f"{x['cpu']:5.3f} {y['cpu']:5.3f} | {'ok' if ok else 'NO'}")
    for m, v in logs.items():
        if v["tri"]:
            tri, cpu = math.exp(sum(v["tri"]) / len(v["tri"])), math.exp(sum(v["cpu"]) / len(v["cpu"]))
            print(f"{m}: geometric mean new/old over {len(v['tri'])} models: triangles {tri:.3f}, "
                  f"meshing CPU {cpu:.3f}")
    print("every guarantee kept" if not bad else f"{bad} rows lose a guarantee")
    return 1 if bad else 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", type=Path, help="write the rows as JSON")
    parser.add_argument("--models", default="", help="comma-separated parts of model names")
    parser.add_argument("--runs", type=int, default=2, help="meshing CPU: best of this many runs")
    parser.add_argument("--aspect", type=float, default=None,
                        help="tessellate_shell's aspect limit of the grid cells (default: its default; inf: none)")
    parser.add_argument("--compare", nargs=2, type=Path, metavar=("OLD", "NEW"), help="compare two JSON files")
    args = parser.parse_args(argv)
    if args.compare:
        return compare(json.loads(args.compare[0].read_text()), json.loads(args.compare[1].read_text()))
    rows = figures([m for m in args.models.split(",") if m], args.runs, args.aspect)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
