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

Usage: python benchmarks/read_speed.py [--json out.json] [--data DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
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


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", type=Path, help="also write the rows as JSON")
    parser.add_argument("--data", type=Path, default=DATA, help="folder of STEP/IGES files")
    args = parser.parse_args(argv)
    files = sorted(p for p in args.data.iterdir() if p.suffix.lower() in (".step", ".stp", ".iges", ".igs"))
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
