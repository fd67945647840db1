"""Where ``trimsurf tessellate``'s ``seconds_measure`` goes, old tree against new (issue 17, item 2).

Each run is a fresh process running ``trimsurf tessellate FILE -o x.ply --report r.json`` (the CLI's
defaults, or ``--tol-only``: max edge = diagonal) through ``trimsurf.cli.main``, exactly as
``python -m trimsurf`` does, with two timers added around the CLI's own functions: the CPU
(``time.process_time``; the preload thread is joined before, the reader server is another process) of
``tessellate.measure.measure_result`` (the measurement in memory) and of
``cli.tessellate._guarantees_met`` (the written file read back and checked), their sum
(``cli_measure_cpu``: the CPU behind the report's ``seconds_measure``), the meshing's CPU (``mesh_cpu``:
``tessellate_shell`` less its measurement) and ``ratio_cpu`` = cli_measure_cpu / mesh_cpu. The report gives
``seconds_read``, ``seconds_mesh`` and ``seconds_measure`` (wall). Trees and models alternate run by
run (``--src A --src B``: A, B, A, B, ... per model per round), so both see the same load; the table gives
the median and the best of ``--runs`` per cell, and whether the report's figures (every field but
timings) are identical between the trees.

Usage: python benchmarks/cli_measure.py --src /tmp/main27/src --src src [--runs 5] [--models screw,U_Joint]
       [--tol-only] [--json out.json] [--rel 1e-9]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad"
if not DATA.exists():
    DATA = Path("/work/shared/data/cad")
MODELS = {"screw": "occt__screw.step", "t20": "gmsh__t20_data.step", "featuretype": "trimesh__featuretype.STEP",
          "U_Joint": "gmsh__U_Joint_2.stp", "soapbox": "occtpr946__ec_soapbox-A.stp"}

_CHILD = r"""
import json, sys, time
import trimsurf.cli as cli
import trimsurf.cli.tessellate as ct
import trimsurf.tessellate as ts
import trimsurf.tessellate.measure as me
acc = {"measure_cpu": 0.0, "check_cpu": 0.0, "tessellate_cpu": 0.0}
def timed(f, key):
    def g(*a, **k):
        c = time.process_time()
        try:
            return f(*a, **k)
        finally:
            acc[key] += time.process_time() - c
    return g
me.measure_result = timed(me.measure_result, "measure_cpu")
ct._guarantees_met = timed(ct._guarantees_met, "check_cpu")
ts.tessellate_shell = timed(ts.tessellate_shell, "tessellate_cpu")
rc = cli.main(sys.argv[1:])
acc["mesh_cpu"] = acc.pop("tessellate_cpu") - acc["measure_cpu"]
acc["cli_measure_cpu"] = acc["measure_cpu"] + acc["check_cpu"]
acc["ratio_cpu"] = acc["cli_measure_cpu"] / acc["mesh_cpu"]
acc["process_cpu"] = time.process_time()
acc["rc"] = rc
print("@@" + json.dumps(acc))
"""

TIMINGS = ("seconds", "seconds_read", "seconds_mesh", "seconds_measure", "seconds_read_started_early",
           "seconds_kernels_early", "seconds_kernels_wait", "output", "input")


def _run(src: str, model: Path, tmp: Path, tol_only: bool) -> dict:
    rep, out = tmp / "r.json", tmp / "x.ply"
    rep.unlink(missing_ok=True)
    env = dict(os.environ, PYTHONPATH=src)
    args = ["tessellate", str(model), "-o", str(out), "--report", str(rep)]
    if tol_only:
        from trimsurf.io import read_shell

        args += ["--max-edge", repr(read_shell(model).diagonal())]
    p = subprocess.run([sys.executable, "-c", _CHILD, *args], env=env, capture_output=True, text=True, timeout=900)
    line = next((ln for ln in p.stdout.splitlines() if ln.startswith("@@")), None)
    if line is None:
        raise RuntimeError(f"{src} {model.name}: {p.stderr[-2000:]}")
    acc = json.loads(line[2:])
    entry = json.loads(rep.read_text())["inputs"][0]
    figures = {k: v for k, v in entry.items() if k not in TIMINGS and not k.startswith("seconds")}
    return acc | {k: entry.get(k) for k in ("seconds_read", "seconds_mesh", "seconds_measure")} | {
        "figures": json.dumps(figures, sort_keys=True)}


def _within(a: str, b: str, rel: float) -> bool:
    """Two runs' report figures (JSON) equal, floats within `rel` relative (session 29: figures may move in
    the last bits)."""
    x, y = json.loads(a), json.loads(b)
    if x.keys() != y.keys():
        return False
    for k, u in x.items():
        v = y[k]
        if isinstance(u, float) and isinstance(v, float):
            if not (u == v or abs(u - v) <= rel * abs(u)):
                return False
        elif u != v:
            return False
    return True


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--src", action="append", required=True, help="a tree's src (twice: old, new)")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--tol-only", action="store_true", help="max edge = diagonal (default: the CLI's defaults)")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--rel", type=float, default=0.0, help="figures equal within this relative difference")
    a = ap.parse_args()
    models = [MODELS.get(m, m) for m in a.models.split(",")]
    rows: dict = {}
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for src in a.src:                       # one untimed run each: numba's cache of that tree
            _run(src, DATA / models[0], tmp, a.tol_only)
        for r in range(a.runs):
            for m in models:
                for src in a.src:
                    rows.setdefault((m, src), []).append(_run(src, DATA / m, tmp, a.tol_only))
            print(f"round {r + 1}/{a.runs} done, load {os.getloadavg()[0]:.1f}", file=sys.stderr, flush=True)
    cols = ("seconds_read", "seconds_mesh", "seconds_measure", "mesh_cpu", "measure_cpu", "check_cpu",
            "cli_measure_cpu", "ratio_cpu", "process_cpu")
    print(f"{'model':16s} {'src':14s} " + " ".join(f"{c[:15]:>15s}" for c in cols) + "  figures")
    out = []
    for m in models:
        ref = rows[(m, a.src[0])][0]["figures"]
        for src in a.src:
            rs = rows[(m, src)]
            cells = []
            for c in cols:
                vals = [x[c] for x in rs]
                cells.append(f"{statistics.median(vals):7.3f}/{min(vals):7.3f}")
            same = all(x["figures"] == ref for x in rs)
            near = all(_within(ref, x["figures"], a.rel) for x in rs)
            print(f"{m[:16]:16s} {src[-14:]:14s} " + " ".join(cells)
                  + ("  same" if same else f"  within {a.rel:g}" if near else "  DIFFER"))
            out.append({"model": m, "src": src, "runs": rs, "figures_same_as_first_tree": same})
    print("cells: median/best of", a.runs, "runs; seconds_* from the report (wall), *_cpu in the CLI process")
    if a.json:
        a.json.write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
