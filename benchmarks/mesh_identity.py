"""Same meshes, less time? Hash what `tessellate_shell` makes of every shared CAD file and sample.

For every real file in ../shared/data/cad and the samples fender, hood, bspline_box, in two settings
(tol: eps = 1e-3 of the diagonal, max edge = the diagonal; paper: max edge 3 % of the diagonal), it
tessellates (``measure=False``) and prints the triangle count, a SHA-1 of the vertex and triangle
arrays, and the meshing CPU time (best of ``--runs``). ``--src DIR`` runs the trimsurf of a source tree
(e.g. an exported older commit: ``git archive COMMIT src | tar -x -C /tmp/old``) in a child process;
given twice, both trees run one after the other, model by model, and the table compares them: a
changed hash is a changed mesh; the CPU ratio is new / old, geometric mean at the end. Hashes are
bitwise: compare trees on one machine (another numpy or CPU can change the last bits).

Usage: python benchmarks/mesh_identity.py [--src OLD/src --src src] [--models a,b] [--runs 2] [--json out.json]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad"
SAMPLES = ("fender", "hood", "bspline_box")
MODES = {"tol": 1.0, "paper": 3e-2}      # max edge / diagonal


def model_names(data: Path, only: list[str] | None) -> list[str]:
    names = sorted(p.name for p in data.iterdir() if p.suffix.lower() in (".step", ".stp", ".iges", ".igs"))
    names += list(SAMPLES)
    return [n for n in names if not only or any(o in n for o in only)]


def hash_models(names: list[str], data: Path, runs: int) -> dict:
    """{model/mode: {tris, hash, cpu}} in this process (the trimsurf on sys.path)."""
    import numpy as np

    from trimsurf.io import read_shell
    from trimsurf.samples import build_sample
    from trimsurf.tessellate import tessellate_shell

    out = {}
    for name in names:
        shell = build_sample(name) if name in SAMPLES else read_shell(data / name)
        d = shell.diagonal()
        for mode, h in MODES.items():
            best, res = None, None
            for _ in range(runs):
                t = time.process_time()
                res = tessellate_shell(shell, tolerance=1e-3 * d, max_edge=h * d, measure=False)
                t = time.process_time() - t
                best = t if best is None else min(best, t)
            m = res.mesh
            digest = hashlib.sha1(np.ascontiguousarray(m.vertices).tobytes()
                                  + np.ascontiguousarray(m.triangles).tobytes()).hexdigest()[:12]
            out[f"{name}/{mode}"] = {"tris": int(m.n_triangles), "hash": digest, "cpu": best}
    return out


def run_tree(src: Path | None, names: list[str], data: Path, runs: int) -> dict:
    """hash_models in a child process with `src` first on PYTHONPATH (this process's trimsurf if None)."""
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = str(src.resolve()) + os.pathsep + env.get("PYTHONPATH", "")
    code = ("import json, sys; from pathlib import Path; sys.path.insert(0, %r); import mesh_identity as m; "
            "print(json.dumps(m.hash_models(%r, Path(%r), %d)))" % (str(Path(__file__).parent), names,
                                                                     str(data), runs))
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"mesh_identity: the run of {src or 'this trimsurf'} failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--src", type=Path, action="append", default=[], help="a source tree (twice: old, new)")
    ap.add_argument("--models", default="", help="comma-separated substrings of model names")
    ap.add_argument("--runs", type=int, default=2, help="meshing runs per model and mode; CPU is the best")
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    if args.runs < 2:
        ap.error("--runs must be at least 2 (the first run of a process loads numba's cache)")
    if len(args.src) > 2:
        ap.error("--src: at most two trees (old, new)")
    names = model_names(args.data, [m for m in args.models.split(",") if m])
    trees = args.src or [None]
    results = [{} for _ in trees]
    if len(trees) == 2:
        print(f"{'model':38s} {'mode':5s} {'tris':>6s} {'hash old':>12s} {'hash new':>12s} {'old s':>7s} {'new s':>7s} "
              f"{'new/old':>7s}")
    for name in names:
        for k, src in enumerate(trees):
            # one child per tree and model: the best of --runs (>= 2) leaves out the first run's loading
            # of numba's cache
            results[k].update(run_tree(src, [name], args.data, args.runs))
        for mode in MODES:
            key = f"{name}/{mode}"
            rows = [r[key] for r in results]
            if len(rows) == 2:
                a, b = rows
                same = "" if a["hash"] == b["hash"] else f"  CHANGED ({a['tris']} -> {b['tris']} triangles)"
                print(f"{name[:38]:38s} {mode:5s} {b['tris']:6d} {a['hash']:>12s} {b['hash']:>12s} {a['cpu']:7.3f} "
                      f"{b['cpu']:7.3f} {b['cpu'] / a['cpu']:7.3f}{same}", flush=True)
            else:
                r = rows[0]
                print(f"{name[:38]:38s} {mode:5s} tris {r['tris']:6d} hash {r['hash']} cpu {r['cpu']:.3f}", flush=True)
    if len(trees) == 2:
        import math

        keys = list(results[0])
        same = sum(results[0][k]["hash"] == results[1][k]["hash"] for k in keys)
        gm = math.exp(sum(math.log(results[1][k]["cpu"] / results[0][k]["cpu"]) for k in keys) / len(keys))
        print(f"identical meshes {same}/{len(keys)}; meshing CPU geometric mean new/old {gm:.3f}")
    if args.json:
        args.json.write_text(json.dumps({"trees": [str(t) for t in trees], "results": results}, indent=1))


if __name__ == "__main__":
    main()
