"""Same shells from two source trees: every file of ../shared/data/cad read by each, compared bit for bit.

For each tree (``--src``, given twice: old then new) a child process with that tree first on PYTHONPATH
reads every STEP/IGES file with ``trimsurf.io.read_shell`` (through the reader server, as a user's call
does) and, with ``--in-process``, also in the calling process (``TRIMSURF_OCC_IN_PROCESS=1``, the path
``from_occ`` and the tests use). It writes a canonical form of each `Shell` -- every dataclass field,
every array as (dtype, shape, bytes), every float as its hex form -- plus which p-curves share their
edge's curve object and the warnings the read gave. The two trees' forms are compared field by field;
the first difference is printed with its path (e.g. ``faces[3].loops[0].segments[2].curve.knots``).

Usage: python benchmarks/read_identity.py --src /tmp/main25/src --src src [--files a,b] [--in-process]
Exit status 0 when every file is identical.
"""

from __future__ import annotations

import argparse
import os
import pickle
import subprocess
import sys
import tempfile
from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad"

_CHILD = r"""
import dataclasses, os, pickle, sys, time, warnings
import numpy as np

def canon(obj):
    if isinstance(obj, np.ndarray):
        return ("nd", obj.dtype.str, obj.shape, obj.tobytes(), obj.flags.writeable)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return (type(obj).__name__, tuple((f.name, canon(getattr(obj, f.name))) for f in dataclasses.fields(obj)
                                          if not f.name.startswith("_")))
    if isinstance(obj, (tuple, list)):
        return tuple(canon(x) for x in obj)
    if isinstance(obj, float):
        return ("f", obj.hex())
    if isinstance(obj, np.generic):
        return ("np", type(obj).__name__, obj.tobytes())
    return (type(obj).__name__, obj)

def sharing(shell):
    out = []
    for f in shell.faces:
        for lp in f.loops:
            for s in lp.segments:
                e = shell.edges[s.edge_id] if 0 <= s.edge_id < len(shell.edges) else None
                out.append(None if e is None else (s.edge_curve is e.curve))
    return out

from trimsurf.io import read_shell
files, out = sys.argv[1].split("|"), sys.argv[2]
result = {}
for f in files:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            shell = read_shell(f)
            result[f] = (canon(shell), sharing(shell), None)
        except Exception as exc:
            result[f] = (None, None, f"{type(exc).__name__}: {exc}")
    result[f] = result[f] + (sorted(f"{w.category.__name__}: {w.message}" for w in caught),)
pickle.dump(result, open(out, "wb"))
"""


def _run(src: str, files: list[str], in_process: bool, tmp: Path) -> dict:
    out = tmp / f"canon_{abs(hash((src, in_process)))}.pkl"
    env = dict(os.environ, PYTHONPATH=src)
    env.pop("TRIMSURF_OCC_IN_PROCESS", None)
    if in_process:
        env["TRIMSURF_OCC_IN_PROCESS"] = "1"
    run = subprocess.run([sys.executable, "-c", _CHILD, "|".join(files), str(out)], env=env, capture_output=True,
                         text=True, timeout=1800)
    if run.returncode != 0:
        raise SystemExit(f"reading with {src} failed:\n{run.stderr[-3000:]}")
    with open(out, "rb") as fh:
        return pickle.load(fh)


def first_difference(a, b, path: str = "") -> str | None:
    """Path and values of the first difference between two canonical forms, or None."""
    if type(a) is not type(b):
        return f"{path}: {type(a).__name__} != {type(b).__name__}"
    if isinstance(a, tuple):
        if len(a) != len(b):
            return f"{path}: length {len(a)} != {len(b)}"
        # a dataclass: (name, ((field, value), ...))
        if len(a) == 2 and isinstance(a[0], str) and isinstance(a[1], tuple) and all(
                isinstance(x, tuple) and len(x) == 2 and isinstance(x[0], str) for x in a[1]):
            if a[0] != b[0]:
                return f"{path}: {a[0]} != {b[0]}"
            for (fa, va), (fb, vb) in zip(a[1], b[1]):
                if fa != fb:
                    return f"{path}: field {fa} != {fb}"
                d = first_difference(va, vb, f"{path}.{fa}")
                if d:
                    return d
            return None
        if a and a[0] == "nd":
            if a != b:
                return f"{path}: array differs (dtype {a[1]}/{b[1]}, shape {a[2]}/{b[2]}, writeable {a[4]}/{b[4]})"
            return None
        for i, (x, y) in enumerate(zip(a, b)):
            d = first_difference(x, y, f"{path}[{i}]")
            if d:
                return d
        return None
    return None if a == b else f"{path}: {a!r} != {b!r}"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--src", action="append", required=True, help="source tree (give two: old, new)")
    p.add_argument("--files", default="", help="only files whose name holds one of these (a,b)")
    p.add_argument("--in-process", action="store_true", help="also compare reads in the calling process")
    p.add_argument("--data", type=Path, default=DATA)
    a = p.parse_args(argv)
    if len(a.src) != 2:
        p.error("give --src twice (old, new)")
    files = sorted(str(f) for f in a.data.iterdir() if f.suffix.lower() in (".step", ".stp", ".iges", ".igs"))
    if a.files:
        files = [f for f in files if any(k in Path(f).name for k in a.files.split(","))]
    modes = [False, True] if a.in_process else [False]
    n_same = n_all = 0
    with tempfile.TemporaryDirectory() as tmp:
        for in_process in modes:
            old, new = (_run(str(Path(s).resolve()), files, in_process, Path(tmp)) for s in a.src)
            for f in files:
                n_all += 1
                (ca, sa, ea, wa), (cb, sb, eb, wb) = old[f], new[f]
                diff = first_difference(ca, cb, "shell")
                if diff is None and sa != sb:
                    diff = "which p-curves share their edge's curve object"
                if diff is None and ea != eb:
                    diff = f"error: {ea!r} != {eb!r}"
                if diff is None and wa != wb:
                    diff = f"warnings: {wa} != {wb}"
                n_same += diff is None
                where = "in process" if in_process else "server"
                print(f"{Path(f).name:40} {where:10} {'identical' if diff is None else 'DIFFERENT: ' + diff}",
                      flush=True)
    print(f"{n_same}/{n_all} identical")
    return 0 if n_same == n_all else 1


if __name__ == "__main__":
    sys.exit(main())
