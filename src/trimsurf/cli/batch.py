"""``trimsurf batch INPUT... -o OUT/ --jobs tessellate,certify,view``: whole part libraries on Dask."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from ..errors import InputError
from ._common import EXIT_FAILED, EXIT_OK, examples, format_table, print_warning, progress

__all__ = ["NAME", "HELP", "DESCRIPTION", "EPILOG", "add_args", "run"]

NAME = "batch"
HELP = "tessellate, certify and view many CAD files on a Dask cluster: resumable, crash-isolated, with an index page"
DESCRIPTION = """\
Run jobs (tessellate, certify, view) on every part of a library: each part and
job is a dask.distributed task, on a local cluster of worker processes (one per
core) or on a running scheduler (--scheduler; its workers must see INPUT and
OUT at the same paths).

INPUT: CAD files, folders (searched recursively), or manifests: a CSV with a
'path' column (relative to the manifest) and optional per-part 'tolerance',
'max_edge' (tessellation, model units) and 'timeout' (seconds) columns.

Each job writes under OUT/<part>/ (tessellate: mesh.ply and tessellate.json,
measured as `trimsurf tessellate` measures; certify: certify.json; view:
zebra.png, thumb.png and the viewer page view.html), then its record (input
hash and options). A job whose record matches and whose outputs exist is not
run again (--force redoes it), so a stopped batch started again finishes only
what is missing. A job that crashes its worker (a native crash), runs past
--per-part-timeout or exhausts memory is retried once, then recorded as failed
with the reason (signal, timeout, out of memory, or the error line); the
batch goes on and the worker is replaced.

As parts finish: OUT/results.csv and OUT/results.parquet (one row per part and
job: status, reason, faces, triangles, max_deviation, flips, watertight,
certified_faces, seconds, worker, ...) and OUT/index.html (self-contained,
sortable by status, deviation and time, a zebra thumbnail per part, links to
its viewer page and reports). Status: ok; not_met (written, a guarantee not
met: flipped triangles, deviation over the tolerance, skipped faces, not
certified); failed (nothing written). Exit status 0 when every job is ok, 1
otherwise, 2 for bad input."""
EPILOG = examples("trimsurf batch cad/ -o review/ --jobs tessellate,view",
                  "trimsurf batch parts.csv -o review/ --jobs tessellate,certify,view --per-part-timeout 600",
                  "trimsurf batch /shared/cad -o /shared/review --scheduler tcp://10.0.0.5:8786")


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("inputs", nargs="+", type=Path, metavar="INPUT",
                        help="CAD files (STEP, IGES, BREP, VDAFS), folders of them (recursive), or manifest .csv files")
    parser.add_argument("-o", "--output", dest="out", type=Path, required=True, metavar="OUT/",
                        help="output folder (created; parts that are already done there are skipped)")
    parser.add_argument("--jobs", default="tessellate", metavar="JOB,...",
                        help="comma-separated: tessellate, certify, view (default: tessellate)")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="address of a running Dask scheduler (tcp://host:port); default: a local cluster")
    parser.add_argument("--workers", type=int, default=None, metavar="N",
                        help="worker processes of the local cluster (default: one per core)")
    parser.add_argument("--per-part-timeout", type=float, default=None, metavar="S",
                        help="seconds each job of a part may run before it is stopped (default: no limit; "
                             "reads keep their own limit, TRIMSURF_READ_TIMEOUT)")
    parser.add_argument("--force", action="store_true", help="redo every job, even those already done")
    parser.add_argument("--tolerance", type=float, default=None, metavar="EPS",
                        help="tessellation: max deviation, model units (default 1e-3 x bounding-box diagonal)")
    parser.add_argument("--max-edge", type=float, default=None, metavar="H",
                        help="tessellation: max 3D grid size, model units (default 3e-2 x diagonal)")


def run(args: argparse.Namespace) -> int:
    from ..batch import dashboard_link
    from ..batch import run as run_batch

    for name in ("per_part_timeout", "tolerance", "max_edge"):
        v = getattr(args, name)
        if v is not None and not (math.isfinite(v) and v > 0):
            raise InputError(f"--{name.replace('_', '-')} must be a positive number; got {v!r}")
    if args.workers is not None and args.workers < 1:
        raise InputError(f"--workers must be at least 1; got {args.workers}")
    if args.workers is not None and args.scheduler is not None:
        raise InputError("--workers sizes the local cluster; with --scheduler the cluster has its own workers")

    with progress(1, "batch") as bar:
        state = {"total": None}

        def on_start(client) -> None:
            link = dashboard_link(client)
            where = args.scheduler or "local cluster"
            n = len(client.scheduler_info().get("workers", {}))
            print(f"trimsurf: batch on {where} ({n} worker{'' if n == 1 else 's'}), "
                  + (f"dashboard {link}" if link else "no dashboard (it needs bokeh on the scheduler)"),
                  file=sys.stderr, flush=True)

        def tick(row: dict, done: int, total: int) -> None:
            if state["total"] is None:  # known once the inputs are hashed: the bar's length
                state["total"] = total
                if getattr(bar, "_progress", None) is not None:
                    bar._progress.update(bar._task, total=total)
            bar.advance(1, description=f"{row['part']} {row['job']}: {row['status']}")

        rows = run_batch(args.inputs, out=args.out, jobs=args.jobs, scheduler=args.scheduler,
                         n_workers=args.workers, per_part_timeout=args.per_part_timeout, force=args.force,
                         tolerance=args.tolerance, max_edge=args.max_edge, progress=tick, on_start=on_start)
    jobs = list(dict.fromkeys(r["job"] for r in rows))
    table = [["job", "ok", "not met", "failed", "reused", "seconds"]]
    for j in jobs:
        rj = [r for r in rows if r["job"] == j]
        table.append([j, sum(r["status"] == "ok" for r in rj), sum(r["status"] == "not_met" for r in rj),
                      sum(r["status"] == "failed" for r in rj), sum(bool(r["reused"]) for r in rj),
                      f"{sum(r['seconds'] or 0.0 for r in rj):.1f}"])
    print(format_table(table))
    print(f"results: {args.out / 'results.csv'}, {args.out / 'results.parquet'}; index: {args.out / 'index.html'}")
    bad = [r for r in rows if r["status"] != "ok"]
    for r in bad:
        print_warning(f"{r['part']} {r['job']}: {r['status']}: {r['reason']}")
    return EXIT_FAILED if bad else EXIT_OK
