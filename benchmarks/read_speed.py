"""Reading the shared STEP/IGES files into trimsurf's model, against Open CASCADE's own read.

For every file in ../shared/data/cad: the time Open CASCADE takes to read and transfer the file
(STEPControl_Reader / IGESControl_Reader, ``TransferRoots``), and the time ``trimsurf.io.read_shell``
takes for the whole job (the same read, B-spline conversion of every face with its p-curves,
and the copy into NurbsSurface / PCurve / Shell). The ratio is trimsurf / OCCT: what the
conversion into the model costs on top of reading. Best of REPEATS runs each.

``read_shell`` runs the read in a child process forked by a reader server (crashes and hangs of
Open CASCADE contained, `trimsurf.io._occ._isolate`); the "in-process s" column is the same read
with ``TRIMSURF_OCC_IN_PROCESS=1``, so "isolation s" = trimsurf s - in-process s is the cost of
the isolation per read (fork + pickled transfer). The server's one-time start (an interpreter
importing Open CASCADE and reading two tiny files) is in the first read, timed on its own.

With ``--cli`` it instead runs ``trimsurf tessellate FILE -o x.ply --report r.json`` in a fresh
process per run (what a user pays for one command: the reader's start included) and prints the
report's ``seconds_read``, ``seconds_mesh`` and ``seconds_measure``, median of ``--repeats`` runs
per file, with the wall time of the whole command. ``--src DIR`` runs the trimsurf of another source
tree (e.g. an exported older commit: ``git archive COMMIT src | tar -x -C /tmp/old``); given twice,
the two trees run interleaved (file by file, round by round) for a before/after table under the same
load. One untimed run first fills numba's cache of each tree.

``--phases`` prints where the reader child's time goes per file (the text check of the numbers, Open
CASCADE's read and transfer, the geometry check, ``BRepBuilderAPI_NurbsConvert``, the copy into the
model, pickling), measured in this process.

Usage: python benchmarks/read_speed.py [--json out.json] [--data DIR]
       python benchmarks/read_speed.py --phases
       python benchmarks/read_speed.py --cli [--repeats 3] [--src DIR [--src DIR2]] [--files a,b] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from trimsurf import io

REPEATS = 2
DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad"


def occ_read(path: Path) -> int:
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.IGESControl import IGESControl_Reader
    from OCP.STEPControl import STEPControl_Reader
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer

    from trimsurf.io._occ import quiet_occ

    reader = IGESControl_Reader() if path.suffix.lower() in (".iges", ".igs") else STEPControl_Reader()
    with quiet_occ():
        if reader.ReadFile(str(path)) != IFSelect_RetDone:
            raise RuntimeError(f"Open CASCADE cannot read {path}")
        reader.TransferRoots()
        shape = reader.OneShape()
    n, ex = 0, TopExp_Explorer(shape, TopAbs_FACE)
    while ex.More():
        n += 1
        ex.Next()
    return n


def best_of(fn, *args):
    best, out = float("inf"), None
    for _ in range(REPEATS):
        t = time.perf_counter()
        out = fn(*args)
        best = min(best, time.perf_counter() - t)
    return best, out


def cli_run(path: Path, src: Path, tmp: Path) -> dict:
    """One ``trimsurf tessellate`` in a fresh process: the report's entry plus the command's wall time."""
    env = dict(os.environ, PYTHONPATH=str(src) + (os.pathsep + os.environ["PYTHONPATH"]
                                                  if os.environ.get("PYTHONPATH") else ""))
    report = tmp / "r.json"
    report.unlink(missing_ok=True)
    t = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "trimsurf", "tessellate", str(path), "-o", str(tmp / "x.ply"),
                           "--report", str(report)], env=env, cwd=tmp, stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t
    if not report.exists():
        raise RuntimeError(f"{path.name}: trimsurf tessellate exited {done.returncode}: {done.stderr.strip()[-300:]}")
    entry = json.loads(report.read_text())["inputs"][0]
    return {"read": entry["seconds_read"], "mesh": entry["seconds_mesh"], "measure": entry["seconds_measure"],
            "wall": wall, "early": entry.get("seconds_read_started_early")}


def cli_table(files: list[Path], srcs: list[Path], repeats: int) -> dict[str, list[dict]]:
    """Median over `repeats` fresh ``trimsurf tessellate`` processes per file and source tree.

    Rounds interleave the files and the source trees (file 1 tree A, file 1 tree B, file 2 tree A, ...),
    so that a change of the machine's load hits every column alike.
    """
    runs = {str(src): {p.name: [] for p in files} for src in srcs}
    with tempfile.TemporaryDirectory(prefix="trimsurf-read-speed-") as tmp:
        for src in srcs:  # fills numba's cache of each tree
            cli_run(min(files, key=lambda p: p.stat().st_size), src, Path(tmp))
        for _ in range(repeats):
            for p in files:
                for src in srcs:
                    runs[str(src)][p.name].append(cli_run(p, src, Path(tmp)))
    tables = {}
    for src in srcs:
        out = []
        print(f"trimsurf from {src}; median of {repeats} fresh processes per file")
        print(f"{'file':40s} {'read s':>7s} {'mesh s':>7s} {'measure s':>9s} {'read/mesh':>9s} {'command s':>9s}"
              f" {'early s':>7s}")
        for name, rr in runs[str(src)].items():
            med = {k: statistics.median(r[k] for r in rr) for k in ("read", "mesh", "measure", "wall")}
            early = [r["early"] for r in rr if r["early"] is not None]
            med["early"] = statistics.median(early) if early else None
            med["runs"] = rr
            out.append({"file": name} | med)
            print(f"{name[:40]:40s} {med['read']:7.3f} {med['mesh']:7.3f} {med['measure']:9.3f} "
                  f"{med['read'] / med['mesh']:9.2f} {med['wall']:9.2f} "
                  f"{'-' if med['early'] is None else format(med['early'], '7.3f'):>7s}")
        tot = {k: sum(r[k] for r in out) for k in ("read", "mesh", "measure", "wall")}
        print(f"{'total':40s} {tot['read']:7.3f} {tot['mesh']:7.3f} {tot['measure']:9.3f} "
              f"{tot['read'] / tot['mesh']:9.2f} {tot['wall']:9.2f}")
        tables[str(src)] = out
    return tables


def phases_table(files: list[Path]) -> list[dict]:
    """Where the reader child's time goes, per file, in this process (after the server's warm-up).

    The steps `trimsurf.io._occ._isolate.convert_file` runs: the text check of the numbers, Open CASCADE's
    read and transfer, the geometry check, ``BRepBuilderAPI_NurbsConvert``, the copy into the model
    (`shape_to_shell`), and pickling the Shell for the parent. One run each (after one warm-up read).
    """
    import pickle
    import warnings

    import numpy as np

    from trimsurf.io._occ import _checks, _read, nurbs_shape, shape_to_shell
    from trimsurf.io._occ._worker import _warm_up

    _warm_up()
    keys = ("numbers", "read", "check", "nurbs", "model", "pickle")
    print(f"{'file':40s} " + " ".join(f"{k + ' s':>9s}" for k in keys))
    rows = []
    skip = _read.check_file_numbers, _read.check_shape_geometry
    _read.check_file_numbers = _read.check_shape_geometry = lambda *a, **k: None  # timed on their own here
    try:
        for path in files:
            fmt = "IGES" if path.suffix.lower() in (".iges", ".igs") else "STEP"
            t = [time.perf_counter()]
            _checks.check_file_numbers(path, fmt)
            t.append(time.perf_counter())
            shape = _read.read_shape(path, fmt, RuntimeError)
            t.append(time.perf_counter())
            _checks.check_shape_geometry(shape, path)
            t.append(time.perf_counter())
            with warnings.catch_warnings(), np.errstate(all="ignore"):
                warnings.simplefilter("ignore")
                converted = nurbs_shape(shape, path=path)
                t.append(time.perf_counter())
                shell = shape_to_shell(converted, name=path.name, skip_bad_faces=True)
                t.append(time.perf_counter())
            pickle.dumps(shell, protocol=pickle.HIGHEST_PROTOCOL)
            t.append(time.perf_counter())
            row = {"file": path.name} | {k: b - a for k, a, b in zip(keys, t, t[1:])}
            rows.append(row)
            print(f"{path.name[:40]:40s} " + " ".join(f"{row[k]:9.3f}" for k in keys))
    finally:
        _read.check_file_numbers, _read.check_shape_geometry = skip
    print(f"{'total':40s} " + " ".join(f"{sum(r[k] for r in rows):9.3f}" for k in keys))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", type=Path, help="also write the rows as JSON")
    parser.add_argument("--data", type=Path, default=DATA, help="folder of STEP/IGES files")
    parser.add_argument("--cli", action="store_true",
                        help="time seconds_read/mesh/measure of fresh `trimsurf tessellate` processes instead")
    parser.add_argument("--repeats", type=int, default=3, help="--cli: runs per file (median)")
    parser.add_argument("--src", type=Path, action="append",
                        help="--cli: a source tree whose trimsurf runs (default: this one); repeat it to "
                             "compare trees, runs interleaved")
    parser.add_argument("--files", default="", help="--cli: only files whose name holds one of these (a,b)")
    parser.add_argument("--phases", action="store_true",
                        help="where the reader child's time goes per file (in this process) instead")
    args = parser.parse_args(argv)
    files = sorted(p for p in args.data.iterdir() if p.suffix.lower() in (".step", ".stp", ".iges", ".igs"))
    if args.phases:
        rows = phases_table(files)
        if args.json:
            args.json.write_text(json.dumps({"phases": rows}, indent=1))
        return 0
    if args.cli:
        if args.files:
            files = [p for p in files if any(f in p.name for f in args.files.split(","))]
        srcs = [p.resolve() for p in args.src] if args.src else [Path(__file__).resolve().parents[1] / "src"]
        tables = cli_table(files, srcs, args.repeats)
        if args.json:
            args.json.write_text(json.dumps({"repeats": args.repeats, "tables": tables}, indent=1))
        return 0
    rows = []
    smallest = min(files, key=lambda p: p.stat().st_size)
    t = time.perf_counter()
    io.read_shell(smallest)  # starts the reader server (once per process)
    t_server = time.perf_counter() - t
    print(f"first read_shell ({smallest.name}, reader server start included): {t_server:.3f} s")
    print(f"{'file':40s} {'faces':>6s} {'OCCT s':>8s} {'trimsurf s':>11s} {'ratio':>6s} {'in-process s':>12s} "
          f"{'isolation s':>11s}")
    for path in files:
        t_occ, n_occ = best_of(occ_read, path)
        t_ts, shell = best_of(io.read_shell, path)
        os.environ["TRIMSURF_OCC_IN_PROCESS"] = "1"
        try:
            t_in, _ = best_of(io.read_shell, path)
        finally:
            del os.environ["TRIMSURF_OCC_IN_PROCESS"]
        row = {"file": path.name, "faces_occt": n_occ, "faces_trimsurf": len(shell.faces),
               "occt_s": t_occ, "trimsurf_s": t_ts, "ratio": t_ts / t_occ, "in_process_s": t_in,
               "isolation_s": t_ts - t_in}
        rows.append(row)
        print(f"{path.name[:40]:40s} {len(shell.faces):6d} {t_occ:8.3f} {t_ts:11.3f} {row['ratio']:6.2f} "
              f"{t_in:12.3f} {t_ts - t_in:11.3f}")
    total_occ = sum(r["occt_s"] for r in rows)
    total_ts = sum(r["trimsurf_s"] for r in rows)
    total_in = sum(r["in_process_s"] for r in rows)
    print(f"{'total':40s} {sum(r['faces_trimsurf'] for r in rows):6d} {total_occ:8.3f} {total_ts:11.3f} "
          f"{total_ts / total_occ:6.2f} {total_in:12.3f} {total_ts - total_in:11.3f}")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "total_occt_s": total_occ, "total_trimsurf_s": total_ts,
                                         "total_in_process_s": total_in, "server_start_s": t_server},
                                        indent=1))
    return 0 if all(r["faces_occt"] == r["faces_trimsurf"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
