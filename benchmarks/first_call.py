"""First call vs warm call per stage, each in fresh processes (issue 17: what a user of one command waits for).

    PYTHONPATH=src python benchmarks/first_call.py --variant new:src --variant main:/tmp/main25/src
    PYTHONPATH=src python benchmarks/first_call.py --variant lazy:src --variant eager:src:TRIMSURF_NUMBA_LAZY_BITCODE=0
    PYTHONPATH=src python benchmarks/first_call.py --cli --variant preload:src --variant none:src:TRIMSURF_PRELOAD=0

Library (default): a fresh interpreter per run imports trimsurf.io and trimsurf.tessellate (`import`),
reads the model and takes its diagonal (`read`: numba starts here, at the first B-spline evaluation),
then calls ``tessellate_shell(measure=False)`` three times (`mesh1`, the first call, and `mesh_warm`, the
best of the other two), then ``tessellate_shell(measure=True)`` three times (`full1`: the first call
that measures, and `full_warm`). ``mesh1 - mesh_warm`` is the per-process first-call cost of meshing;
``full1 - full_warm`` that of measuring. Tolerance 1e-3 x diagonal, max edge = diagonal.

--cli: a fresh process per run runs ``trimsurf tessellate MODEL -o x.ply --report r.json`` (its default
tolerance and max edge) twice, the second run being the warm reference. Columns: the process's CPU
through the first run (cli_cpu: user + sys, its imports included, the reader server's not), the
preload thread's CPU (cli._preload), the main thread's CPU / wall of the first and of the warm run
(main1, main_warm: the read, the wait for the preload, tessellation with its report, the write and
the written file's check) and of the same from the budget check on, i.e. after the read and the wait
(after_read1, after_read_warm), then the first run's report fields (wall). ``main1 - main_warm`` is
what the command's first run waits for beyond the work itself, where it has a core of its own. On a
busy machine the wall times mostly measure the other processes.

Every figure is the best (smallest) over --runs runs, CPU seconds (time.process_time) and wall seconds;
the variants' runs alternate (a loaded machine drifts). A variant is LABEL:SRC[:NAME=VALUE,...], SRC
going first on PYTHONPATH, the NAME=VALUE pairs set in its environment. --pyc gives every variant its
own bytecode cache (PYTHONPYCACHEPREFIX, PYTHONDONTWRITEBYTECODE unset; one unmeasured run fills it),
as an installed package has; without it the environment's setting stands (this machine sets
PYTHONDONTWRITEBYTECODE=1: every trimsurf module is compiled from source in every process).
The numba cache must be warm (run once first); a run that compiles shows up as an outlier, not hidden.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "cad"
if not DATA.exists():
    DATA = Path("/work/shared/data/cad")
MODELS = {"screw": "occt__screw.step", "featuretype": "trimesh__featuretype.STEP", "U_Joint": "gmsh__U_Joint_2.stp",
          "t20": "gmsh__t20_data.step", "bearing": "occt__bearing.iges"}

_LIB = r"""
import json, sys, time
def clock():
    return time.process_time(), time.perf_counter()
def since(c):
    n = clock()
    return [n[0] - c[0], n[1] - c[1]]
out = {}
c = clock()
from trimsurf.io import read_shell
from trimsurf.tessellate import tessellate_shell
out["import"] = since(c)
c = clock()
shell = read_shell(sys.argv[1]); d = shell.diagonal()
out["read"] = since(c)
for key, measure in (("mesh", False), ("full", True)):
    runs = []
    for i in range(3):
        c = clock()
        tessellate_shell(shell, tolerance=1e-3 * d, max_edge=d, measure=measure)
        runs.append(since(c))
    out[key + "1"] = runs[0]
    out[key + "_warm"] = [min(r[0] for r in runs[1:]), min(r[1] for r in runs[1:])]
print("RESULT " + json.dumps(out))
"""

# the command in this process, twice (the second run is the warm reference; argv[0] named trimsurf before trimsurf.cli
# is imported, so that the reader server starts early, as for the console script); the main thread's CPU / wall of
# each run, in all and from the budget check on (after the read and the wait for the preload)
_CLI = r"""
import json, resource, sys, time
argv = sys.argv[1:]
sys.argv = ["trimsurf"] + argv
import trimsurf.cli.tessellate as T
from trimsurf.cli import main
marks = []
budget = T.check_tessellate_budget
def mark(*a, **k):
    marks.append((time.thread_time(), time.perf_counter()))
    return budget(*a, **k)
T.check_tessellate_budget = mark
pre = []
try:
    from trimsurf.cli import _preload
    numba_join = _preload.Preload.join
    def join(self, **kw):
        out = numba_join(self, **kw)
        pre.append(self.cpu_seconds)
        return out
    _preload.Preload.join = join
except ImportError:
    pass
out = {}
for run in ("1", "_warm"):
    n = len(marks)
    c, t = time.thread_time(), time.perf_counter()
    rc = main(argv)
    ce, te = time.thread_time(), time.perf_counter()
    assert rc == 0, rc
    out["main" + run] = [ce - c, te - t]
    out["after_read" + run] = [ce - marks[n][0], te - marks[n][1]]
    if run == "1":
        r = resource.getrusage(resource.RUSAGE_SELF)
        out["cli_cpu"] = [r.ru_utime + r.ru_stime, None]
        out["preload_cpu"] = [pre[0] if pre else None, None]
        out["report"] = json.load(open(argv[argv.index("--report") + 1]))["inputs"][0]
print("RESULT " + json.dumps(out))
"""

LIB_COLUMNS = ["import", "read", "mesh1", "mesh_warm", "full1", "full_warm"]
CLI_COLUMNS = ["cli_cpu", "preload_cpu", "main1", "main_warm", "after_read1", "after_read_warm", "seconds_read",
               "seconds_mesh", "seconds_measure", "seconds", "seconds_kernels_wait"]


def _variant(text: str) -> tuple[str, str, dict]:
    label, _, rest = text.partition(":")
    src, _, pairs = rest.partition(":")
    env = dict(p.split("=", 1) for p in pairs.split(",") if p)
    return label, str(Path(src or "src").resolve()), env


def _env(src: str, extra: dict, pyc: Path | None, label: str) -> dict:
    env = dict(os.environ, PYTHONPATH=src, **extra)
    env.pop("TRIMSURF_OCC_IN_PROCESS", None)
    if pyc is not None:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = str(pyc / label)
    return env


def _run_lib(path: Path, env: dict) -> dict:
    p = subprocess.run([sys.executable, "-c", _LIB, str(path)], env=env, capture_output=True, text=True, timeout=1800)
    if p.returncode:
        raise RuntimeError(p.stderr[-2000:])
    out = json.loads(p.stdout.split("RESULT ", 1)[1])
    return {k: tuple(v) for k, v in out.items()}


def _run_cli(path: Path, env: dict, work: Path) -> dict:
    mesh, report = work / "out.ply", work / "report.json"
    p = subprocess.run([sys.executable, "-c", _CLI, "tessellate", str(path), "-o", str(mesh), "--report", str(report)],
                       env=env, capture_output=True, text=True, timeout=1800)
    if p.returncode:
        raise RuntimeError(p.stderr[-2000:])
    raw = json.loads(p.stdout.split("RESULT ", 1)[1])
    e = raw.pop("report")
    out = {k: tuple(v) for k, v in raw.items()}
    for k in CLI_COLUMNS[6:]:
        out[k] = (None, e.get(k))
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--variant", action="append", default=None, help="LABEL:SRC[:NAME=VALUE,...] (repeatable)")
    ap.add_argument("--models", default="screw,featuretype,U_Joint")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--cli", action="store_true", help="the trimsurf tessellate command instead of the library")
    ap.add_argument("--pyc", action="store_true", help="a bytecode cache per variant (as an installed package)")
    args = ap.parse_args(argv)
    variants = [_variant(v) for v in (args.variant or ["new:src"])]
    columns = CLI_COLUMNS if args.cli else LIB_COLUMNS
    with tempfile.TemporaryDirectory(prefix="first_call_") as tmp:
        work = Path(tmp)
        pyc = work / "pyc" if args.pyc else None
        best: dict = {}
        for model in args.models.split(","):
            path = DATA / MODELS.get(model, model)
            envs = {label: _env(src, extra, pyc, label) for label, src, extra in variants}
            if pyc is not None:     # fill each variant's bytecode cache once
                for label in envs:
                    _run_cli(path, envs[label], work) if args.cli else _run_lib(path, envs[label])
            for _ in range(args.runs):
                for label in envs:
                    r = _run_cli(path, envs[label], work) if args.cli else _run_lib(path, envs[label])
                    row = best.setdefault((model, label), {})
                    for k, (cpu, wall) in r.items():
                        old = row.get(k, (None, None))
                        row[k] = tuple(v if o is None else (o if v is None else min(o, v))
                                       for o, v in zip(old, (cpu, wall)))
                print(f"  {model}: run done", file=sys.stderr, flush=True)
    how = "CLI" if args.cli else "library"
    pyc_note = ("own bytecode cache" if args.pyc
                else "PYTHONDONTWRITEBYTECODE=" + os.environ.get("PYTHONDONTWRITEBYTECODE", ""))
    print(f"first_call.py ({how}; best of {args.runs} fresh processes; {pyc_note}); CPU / wall seconds")
    diffs = [("main1", "main_warm")] if args.cli else [("mesh1", "mesh_warm"), ("full1", "full_warm")]
    print("| model | variant | " + " | ".join(columns) + "".join(f" | {a}-warm" for a, _ in diffs) + " |")
    print("|---" * (len(columns) + 2 + len(diffs)) + "|")

    def cell(v):
        cpu, wall = v
        if cpu is None:
            return "-" if wall is None else f"{wall:.3f}"
        return f"{cpu:.3f}" if wall is None else f"{cpu:.3f} / {wall:.3f}"

    for (model, label), row in best.items():
        cells = [cell(row.get(k, (None, None))) for k in columns]
        for a, b in diffs:
            cells.append(f"{row[a][0] - row[b][0]:.3f} / {row[a][1] - row[b][1]:.3f}")
        print(f"| {model} | {label} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
