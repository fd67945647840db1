"""What reading a CAD file costs against meshing it (issue 17, item 2: reading at most the meshing time).

Per model, three measurements, each the best of ``--reps`` fresh processes (runs interleaved model by
model and, with two ``--src``, tree by tree, so both trees see the same load):

* ``cli read`` / ``cli mesh`` / ``early``: the report of ``python -m trimsurf tessellate FILE -o x.ply
  --report r.json`` (defaults): ``seconds_read`` (wall time of the read call plus what the command paid to
  start the reader server early), ``seconds_mesh``, and ``seconds_read_started_early`` (the server's
  start-up that ran on another core before the read was asked for; not in ``seconds_read``);
  ``read/mesh`` = cli read / cli mesh.
* ``script read``: wall time of the first ``trimsurf.io.read_shell(FILE)`` in a fresh ``python -c`` after
  ``import trimsurf`` (a library caller: the reader server starts at this first read, nothing overlaps
  it), and ``script cpu``: the CPU of that read in the calling process, the server and its child
  together (``RUSAGE_CHILDREN`` after the server is stopped).
* ``cli cpu@read``: the command's own CPU when it asks the server for the read (the same runs, through a
  wrapper that records ``time.process_time()`` on entry of ``trimsurf.io._server.Server.run``), and
  ``est. idle read`` = max(0, server cpu - cli cpu@read) + in-proc cpu: what ``seconds_read`` would be on
  an idle machine if the command and the server each had a core (an estimate from CPU times, for runs
  under load, where the wall times are mostly waiting for a core; the transfer of the result is left out).
* ``read cpu``: the CPU of the command's thread in its ``read_shell`` call (``time.thread_time``: not the
  server, its child, nor the command's kernel-loading thread, `trimsurf.cli._preload`);
  ``cmd cpu``: CPU of the whole command, with the reader server and its children (``RUSAGE_CHILDREN``);
  ``cached``: 1 when the report says the shell came from the cache of read shells
  (``read_from_cache``, `trimsurf.io._cache`); then ``est. idle read`` = ``read cpu`` (no server, no child).
* ``server cpu``: CPU (``time.process_time``, interpreter start included) of a fresh interpreter doing
  what the reader server does before it can fork its first reader (``trimsurf.io._occ._worker.serve``: the
  imports, then ``_warm_up``): what a command's first read waits for when the command reaches it sooner.
  One value per tree (it does not depend on the file).
* ``in-proc cpu``: CPU (``time.process_time``) of ``read_shell`` in the calling process
  (``TRIMSURF_OCC_IN_PROCESS=1``: Open CASCADE's read, ``BRepBuilderAPI_NurbsConvert`` and the copy
  into the model, no server), the second call in the process (the first pays one-time set-up).

One untimed run per tree first fills numba's cache. ``--cache off`` (default) runs every command and script
with ``TRIMSURF_READ_CACHE=0``, so each read is a first read without the cache; ``--cache cold`` gives each
process an empty cache folder (a first read, which stores its entry); ``--cache warm`` gives each tree a cache
folder of its own, filled by one untimed command per model, so the timed reads of a tree with the cache are
repeated reads. ``--src DIR`` times another source tree (e.g.
``--src /tmp/main25/src --src src`` for before/after).

Usage: python benchmarks/read_cost.py [--models screw,t20] [--reps 3] [--src OLD --src NEW] [--cache off|warm]
       [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad"
MODELS = {"screw": "occt__screw.step", "t20": "gmsh__t20_data.step", "featuretype": "trimesh__featuretype.STEP",
          "U_Joint": "gmsh__U_Joint_2.stp", "crankshaft": "gmsh__SampleCrankshaft4A.stp",
          "soapbox": "occtpr946__ec_soapbox-A.stp"}

_SCRIPT = r"""
import json, resource, sys, time
import trimsurf
t0 = time.perf_counter(); c0 = time.process_time()
from trimsurf.io import read_shell
shell = read_shell(sys.argv[1])
wall = time.perf_counter() - t0
cpu = time.process_time() - c0
from trimsurf.io import _server
_server.discard_server()
ch = resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({"wall": wall, "cpu": cpu + ch.ru_utime + ch.ru_stime, "faces": len(shell.faces)}))
"""

_IN_PROCESS = r"""
import json, sys, time, warnings
warnings.simplefilter("ignore")
from trimsurf.io import read_shell
best = None
for i in range(int(sys.argv[2]) + 1):
    c = time.process_time(); read_shell(sys.argv[1]); c = time.process_time() - c
    if i:
        best = c if best is None else min(best, c)
print(json.dumps({"cpu": best}))
"""


_SERVER_START = r"""
import gc, json, time
gc.disable()
import numpy, OCP.BRepBuilderAPI, OCP.BRepTools, OCP.IGESControl, OCP.STEPControl
from trimsurf.io import _brep, _iges, _step
from trimsurf.io._occ import _isolate, _worker
_worker._warm_up()
print(json.dumps({"cpu": time.process_time()}))
"""


# `python -m trimsurf ...` with the command's CPU recorded when it first asks the reader server for a read, and
# its own CPU in its first read_shell call
_CLI = r"""
import json, os, runpy, sys, time
import trimsurf.io
from trimsurf.io import _server
_run = _server.Server.run
_read_shell = trimsurf.io.read_shell
_seen = {}
def _save():
    with open(os.environ["READ_COST_OUT"], "w") as fh:
        json.dump(_seen, fh)
def run(self, *args, **kwargs):
    _seen.setdefault("cpu_at_read", time.process_time())
    return _run(self, *args, **kwargs)
def read_shell(*args, **kwargs):
    c, t = time.process_time(), time.thread_time()
    try:
        return _read_shell(*args, **kwargs)
    finally:
        if "read_cpu" not in _seen:
            _seen.setdefault("cpu_at_read", c)
            _seen["read_cpu"] = time.thread_time() - t
            _save()
_server.Server.run = run
trimsurf.io.read_shell = read_shell
sys.argv = [os.path.join(os.path.dirname(sys.argv[0]), "trimsurf"), *sys.argv[1:]]
runpy.run_module("trimsurf", run_name="__main__", alter_sys=True)
"""


#: TRIMSURF_READ_CACHE of the runs per tree (``--cache``): "0" (off) or a folder of their own
_CACHE: dict[str, str] = {}


def _env(src: str, **extra) -> dict:
    cache = _CACHE.get(src, "0")
    if cache == "cold":  # an empty folder per run: every read is a first read that stores its entry
        cache = tempfile.mkdtemp(prefix="read-cache-cold-")
    env = dict(os.environ, PYTHONPATH=src, TRIMSURF_READ_CACHE=cache, **extra)
    if "TRIMSURF_OCC_IN_PROCESS" not in extra:
        env.pop("TRIMSURF_OCC_IN_PROCESS", None)
    return env


def cli_run(src: str, path: Path, tmp: Path) -> dict:
    report, at_read = tmp / "r.json", tmp / "at_read.json"
    at_read.unlink(missing_ok=True)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    run = subprocess.run([sys.executable, "-c", _CLI, "tessellate", str(path), "-o", str(tmp / "x.ply"),
                          "--report", str(report)], env=_env(src, READ_COST_OUT=str(at_read)),
                         capture_output=True, text=True, timeout=900)
    if run.returncode not in (0, 1):
        raise SystemExit(f"{path}: trimsurf failed ({run.returncode}): {run.stderr[-2000:]}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    e = json.loads(report.read_text())["inputs"][0]
    seen = json.loads(at_read.read_text())
    return {"read": e["seconds_read"], "mesh": e["seconds_mesh"], "early": e.get("seconds_read_started_early", 0.0),
            "cpu_at_read": seen["cpu_at_read"], "read_cpu": seen["read_cpu"],
            "cmd_cpu": after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime,
            "cached": float(bool(e.get("read_from_cache")))}


def script_run(src: str, path: Path) -> dict:
    run = subprocess.run([sys.executable, "-c", _SCRIPT, str(path)], env=_env(src), capture_output=True, text=True,
                         timeout=900, check=True)
    return json.loads(run.stdout.strip().splitlines()[-1])


def in_process_run(src: str, path: Path, reps: int) -> dict:
    run = subprocess.run([sys.executable, "-c", _IN_PROCESS, str(path), str(reps)],
                         env=_env(src, TRIMSURF_OCC_IN_PROCESS="1"), capture_output=True, text=True, timeout=900,
                         check=True)
    return json.loads(run.stdout.strip().splitlines()[-1])


def server_start_run(src: str) -> float:
    run = subprocess.run([sys.executable, "-c", _SERVER_START], env=_env(src), capture_output=True, text=True,
                         timeout=900, check=True)
    return json.loads(run.stdout.strip().splitlines()[-1])["cpu"]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--models", default=",".join(MODELS), help=f"names ({', '.join(MODELS)}) or file names")
    p.add_argument("--reps", type=int, default=3)
    p.add_argument("--src", action="append", help="source tree(s) to time (default: this checkout's src)")
    p.add_argument("--json")
    p.add_argument("--cache", choices=("off", "cold", "warm"), default="off",
                   help="the cache of read shells (trimsurf.io._cache): off (TRIMSURF_READ_CACHE=0, the default), "
                        "cold (an empty folder per process: a first read that stores its entry), or warm (a folder "
                        "per tree, filled by one untimed command per model before the timed runs); a tree without "
                        "the cache ignores it")
    a = p.parse_args(argv)
    srcs = [str(Path(s).resolve()) for s in (a.src or [Path(__file__).resolve().parents[1] / "src"])]
    models = [(m, DATA / MODELS.get(m, m)) for m in a.models.split(",")]
    rows: dict[str, dict[str, dict]] = {s: {} for s in srcs}
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        for i, src in enumerate(srcs):
            if a.cache != "off":
                _CACHE[src] = "cold" if a.cache == "cold" else str(tmp / f"read-cache-{i}")
            cli_run(src, models[0][1], tmp)  # fill numba's cache of each tree
            if a.cache == "warm":
                for _, path in models[1:]:
                    cli_run(src, path, tmp)
        server_cpu = {s: min(server_start_run(s) for _ in range(a.reps)) for s in srcs}
        for name, path in models:
            best = {s: {} for s in srcs}
            for _ in range(a.reps):
                for src in srcs:
                    got = cli_run(src, path, tmp)
                    got |= {"script_" + k: v for k, v in script_run(src, path).items() if k != "faces"}
                    for k, v in got.items():
                        best[src][k] = min(best[src].get(k, v), v)
            for src in srcs:
                best[src]["in_process_cpu"] = in_process_run(src, path, a.reps)["cpu"]
                rows[src][name] = best[src]
            for src in srcs:
                b = best[src]
                b["est_idle_read"] = b["read_cpu"] if b["cached"] else \
                    max(0.0, server_cpu[src] - b["cpu_at_read"]) + b["in_process_cpu"]
                print(f"{name:12} {Path(src).parent.name + '/' + Path(src).name:24} cli read {b['read']:.3f}  "
                      f"mesh {b['mesh']:.3f}  read/mesh {b['read'] / b['mesh']:.2f}  early {b['early']:.3f}  "
                      f"script read {b['script_wall']:.3f} cpu {b['script_cpu']:.3f}  "
                      f"in-proc cpu {b['in_process_cpu']:.3f}  cli cpu@read {b['cpu_at_read']:.3f}  "
                      f"est. idle read {b['est_idle_read']:.3f}  read cpu in cmd {b['read_cpu']:.3f}  "
                      f"cmd cpu {b['cmd_cpu']:.3f}  cached {b['cached']:.0f}", file=sys.stderr, flush=True)
    for src in srcs:
        print(f"\ntrimsurf from {src}; best of {a.reps} fresh processes per model (seconds); "
              f"server cpu {server_cpu[src]:.3f}; read cache {a.cache}")
        print(f"{'model':12} {'cli read':>8} {'cli mesh':>8} {'read/mesh':>9} {'early':>6} {'script read':>11} "
              f"{'script cpu':>10} {'in-proc cpu':>11} {'cli cpu@read':>12} {'est. idle read':>14} "
              f"{'read cpu':>8} {'cmd cpu':>7} {'cached':>6}")
        for name, b in rows[src].items():
            print(f"{name:12} {b['read']:8.3f} {b['mesh']:8.3f} {b['read'] / b['mesh']:9.2f} {b['early']:6.3f} "
                  f"{b['script_wall']:11.3f} {b['script_cpu']:10.3f} {b['in_process_cpu']:11.3f} "
                  f"{b['cpu_at_read']:12.3f} {b['est_idle_read']:14.3f} {b['read_cpu']:8.3f} {b['cmd_cpu']:7.3f} "
                  f"{b['cached']:6.0f}")
    if a.json:
        Path(a.json).write_text(json.dumps({"server_cpu": server_cpu, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
