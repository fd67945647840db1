"""Per-file preparation of the report's measurement (issue 17, item 2): what the first `measure_result` of
a file pays that a second one on the same shell does not (loop polylines, point-in-polygon indexes, span
bounds of the surfaces, seed grids ...), which `measure_cost.py` does not see (it empties only the seed
cache and keeps the best of its repetitions).

Each run is a fresh process: read the shell, `tessellate_shell(..., measure=False)` at eps = 1e-3 x diagonal,
tolerance only (max edge = diagonal); ``--mode warm`` first measures another copy of the same shell (every
kernel loaded and module state warm: first - second is then the per-file preparation alone), ``--mode cold``
does not (the CLI's case, one file per process: the first also loads the kernels). Then
`tessellate.measure.measure_result(res, shell)` twice, the seed cache of `geom.projection` emptied before
each; CPU (``time.process_time``). With ``--reference SRC`` the runs alternate between SRC and this
checkout (old, new, old, new ...), so both see the same machine load.

Usage: python benchmarks/measure_prep.py [--models U_Joint,featuretype] [--runs 5] [--mode warm]
       [--reference /tmp/old/src]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"
DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad"

_CHILD = r"""
import gc, sys, time
from pathlib import Path
from trimsurf.io import read_shell
from trimsurf.tessellate import tessellate_shell
from trimsurf.tessellate.measure import measure_result
import trimsurf.geom.projection as P
path, mode = sys.argv[1], sys.argv[2]
shell = read_shell(path); d = shell.diagonal()
r = tessellate_shell(shell, tolerance=1e-3 * d, max_edge=d, measure=False)
if mode == "warm":
    shell2 = read_shell(path)
    r2 = tessellate_shell(shell2, tolerance=1e-3 * d, max_edge=d, measure=False)
    P._SEED_CACHE.clear(); measure_result(r2, shell2)
out = []
for _ in range(2):
    P._SEED_CACHE.clear(); gc.collect()
    c = time.process_time(); measure_result(r, shell); out.append(time.process_time() - c)
print(out[0], out[1])
"""


def _run(src: Path, path: Path, mode: str) -> tuple[float, float]:
    env = dict(os.environ, PYTHONPATH=str(src))
    out = subprocess.run([sys.executable, "-c", _CHILD, str(path), mode], env=env, capture_output=True,
                         text=True, check=True).stdout.split()
    return float(out[-2]), float(out[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", default="U_Joint,featuretype")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--mode", choices=("warm", "cold"), default="warm")
    ap.add_argument("--reference", type=Path, default=None)
    a = ap.parse_args()
    files = sorted(p for p in DATA.iterdir() if p.suffix.lower() in (".step", ".stp", ".iges", ".igs"))
    srcs = ([("old", a.reference)] if a.reference else []) + [("new", SRC)]
    print(f"mode {a.mode}, {a.runs} fresh processes each, CPU s: median (min) of first, second, first - second")
    for key in a.models.split(","):
        path = next(p for p in files if key in p.name)
        res: dict = {name: [] for name, _ in srcs}
        for _ in range(a.runs):
            for name, src in srcs:
                res[name].append(_run(src, path, a.mode))
        for name, _ in srcs:
            f = [x[0] for x in res[name]]
            s = [x[1] for x in res[name]]
            p = [x[0] - x[1] for x in res[name]]
            print(f"{key:12s} {name}  first {statistics.median(f):.4f} ({min(f):.4f})  second "
                  f"{statistics.median(s):.4f} ({min(s):.4f})  prep {statistics.median(p):.4f} ({min(p):.4f})")


if __name__ == "__main__":
    main()
