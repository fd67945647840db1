"""``trimsurf tessellate`` loads its kernels during the first read (trimsurf.cli._preload), and only those it calls.

The claims checked, each in a fresh interpreter running the command on occt__screw.step:
without the preload, the compiled kernels the command calls are exactly `_preload.KERNELS` (none listed
that is not called, none called that is not listed); with it, the thread loads every one of them from
numba's cache and the command, once the thread is joined, loads or compiles no kernel itself; the
mesh written is byte-identical either way.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from trimsurf.cli import _preload

SRC = str(Path(_preload.__file__).resolve().parents[2])

# the command in this process, counting the dispatcher calls that had to load or compile (a call with argument
# types the dispatcher has no code for goes through Dispatcher._compile_for_args)
_SCRIPT = r"""
import json, sys
from numba.core import dispatcher
from trimsurf.cli import _preload
calls = []
numba_cfa = dispatcher.Dispatcher._compile_for_args
def cfa(self, *args, **kws):
    calls.append([self.py_func.__module__, self.py_func.__name__])
    return numba_cfa(self, *args, **kws)
dispatcher.Dispatcher._compile_for_args = cfa
seen = {}
numba_join = _preload.Preload.join
def join(self, **kw):
    out = numba_join(self, **kw)
    seen.setdefault("loaded", self.loaded)
    seen.setdefault("error", repr(self.error) if self.error else None)
    seen.setdefault("calls_before_join", len(calls))
    return out
_preload.Preload.join = join
from trimsurf.cli import main
sys.argv[0] = "trimsurf"
rc = main(sys.argv[1:])
import importlib
used = [[m, n] for m, names in _preload.KERNELS.items() for n in names
        if getattr(importlib.import_module(m), n).overloads]
print(json.dumps({"rc": rc, "calls": calls, "used": used, **seen}))
"""


def _run(shared_data, out: Path, **env) -> dict:
    e = dict(os.environ, PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""), **env)
    e.pop("TRIMSURF_OCC_IN_PROCESS", None)
    p = subprocess.run([sys.executable, "-c", _SCRIPT, "tessellate", str(shared_data / "cad" / "occt__screw.step"),
                        "-o", str(out), "--report", str(out.with_suffix(".json"))],
                       capture_output=True, text=True, env=e, timeout=600)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout.strip().splitlines()[-1])


def test_the_preload_loads_exactly_the_kernels_the_command_calls(shared_data, tmp_path):
    listed = {(m, n) for m, names in _preload.KERNELS.items() for n in names}
    without = _run(shared_data, tmp_path / "a.ply", TRIMSURF_PRELOAD="0")   # (compiles them if the cache is cold)
    assert without["rc"] == 0 and "loaded" not in without
    called = {tuple(c) for c in without["calls"]}
    assert called - listed == set(), "kernels the command calls that the preload does not load"
    # a kernel another kernel calls gets its code when that one is compiled (cold cache), with no call of
    # its own through the dispatcher: "used" = it has code at the end of the run
    used = called | {tuple(c) for c in without["used"]}
    assert listed - used == set(), "kernels the preload loads that the command does not call"
    assert len(without["calls"]) == len(called)   # one specialization each
    wanted = _run(shared_data, tmp_path / "b.ply")
    assert wanted["rc"] == 0 and wanted["error"] is None
    # at least one specialization per listed kernel (the cache may hold more: other tests call some kernels
    # with other argument types, and the preload loads every cached one)
    assert wanted["loaded"] >= len(listed)
    assert wanted["calls"] == [], "kernels loaded or compiled by the command itself after the preload"
    assert (tmp_path / "a.ply").read_bytes() == (tmp_path / "b.ply").read_bytes()
    report = json.loads((tmp_path / "b.json").read_text())["inputs"][0]
    assert 0.0 <= report["seconds_kernels_wait"] <= report["seconds_kernels_early"]
    assert report["seconds_read"] + report["seconds_kernels_wait"] <= report["seconds"]
