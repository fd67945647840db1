"""Batch scaling: parts per minute of `trimsurf batch` on the shared CAD folder with 1 and 2 Dask workers,
the overhead against the same jobs run one after the other in one process, and a projection for 1,000 parts
on 8 / 64 / 512 workers from the measured per-part times (list scheduling; the straggler effect included).

    PYTHONPATH=src .venv/bin/python benchmarks/batch_scaling.py [--jobs tessellate] [--json out.json]

Every run redoes every job (force). The single-process baseline calls the same task function
(`trimsurf.batch.run_job`) in this process, part after part, with the same outputs written, so the difference
is what Dask (cluster start, scheduling, transfer, worker processes) costs. The projection draws 1,000 part
times from the measured distribution (with replacement, fixed seed), adds the measured per-task overhead and
assigns them in input order to the worker that frees first (what Dask's scheduler does for independent
tasks); the makespan cannot be below the longest part (straggler) nor below total / workers.
"""

from __future__ import annotations

import argparse
import heapq
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CAD = (ROOT / ".." / "shared" / "data" / "cad").resolve()


def load() -> str:
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


def in_process(parts, jobs, out: Path) -> list[float]:
    """Each part's jobs run one after the other in this process (the task function, no Dask); seconds per part."""
    from trimsurf.batch import record_key, run_job

    times = []
    for part in parts:
        t0 = time.perf_counter()
        mesh = None
        for job in jobs:
            key = record_key(part, job, tuple(jobs))
            spec = {"part": part.name, "path": str(part.path), "sha256": part.sha256, "job": job,
                    "options": key["options"], "out": str(out), "run": f"inproc-{time.time()}", "timeout": None,
                    "memory_limit": None, "mesh": mesh, "env": None, "record": key, "hook": None}
            row = run_job(spec)
            if job == "tessellate" and row["status"] != "failed":
                mesh = str(out / part.name / "mesh.ply")
        times.append(time.perf_counter() - t0)
        print(f"  in process: {part.name:40s} {times[-1]:7.2f} s", file=sys.stderr, flush=True)
    return times


def on_dask(inputs, jobs, out: Path, n_workers: int) -> dict:
    from trimsurf.batch import run

    started = {}
    t0 = time.perf_counter()
    rows = run(inputs, out=out, jobs=",".join(jobs), n_workers=n_workers, force=True,
               on_start=lambda c: started.setdefault("t", time.perf_counter()))
    wall = time.perf_counter() - t0
    return {"workers": n_workers, "wall_s": wall, "startup_s": started["t"] - t0, "run_s": wall - (started["t"] - t0),
            "rows": rows}


def list_schedule(times: np.ndarray, n_workers: int) -> float:
    """Makespan of assigning `times` in order to the worker that frees first."""
    free = [0.0] * n_workers
    for t in times:
        heapq.heapreplace(free, free[0] + float(t))
    return max(free)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", default="tessellate")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--parts", type=int, default=1000, help="parts of the projection (default 1000)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--replay", type=Path, help="recompute the tables from an earlier --json (no runs)")
    args = ap.parse_args(argv)
    from trimsurf.batch import collect_parts

    jobs = [j for j in args.jobs.split(",") if j]
    parts = collect_parts([CAD])
    n = len(parts)
    if args.replay:
        old = json.loads(args.replay.read_text())
        jobs, base_times, loads = old["jobs"], np.array(old["in_process_s"]), old["load"]
        runs = [dict(r, rows=[{"part": p.name, "seconds": t, "status": "ok"} for p, t in zip(parts, r["task_s"])])
                for r in old["dask"]]
    else:
        loads = [load()]
        print(f"{n} parts from {CAD}, jobs {','.join(jobs)}; {loads[0]}", file=sys.stderr)
        tmp = Path(tempfile.mkdtemp(prefix="batch-scaling-"))
        try:
            base_times = np.array(in_process(parts, jobs, tmp / "inproc"))
            loads.append(load())
            runs = []
            for w in (1, 2):
                r = on_dask([CAD], jobs, tmp / f"dask{w}", w)
                loads.append(load())
                runs.append(r)
                print(f"  {w} worker(s): {r['wall_s']:.1f} s (cluster start {r['startup_s']:.1f} s)", file=sys.stderr)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)

    base = float(base_times.sum())
    one = runs[0]
    task_s = {1: [], 2: []}
    for r in runs:
        per_part: dict[str, float] = {}
        for row in r["rows"]:
            per_part[row["part"]] = per_part.get(row["part"], 0.0) + (row["seconds"] or 0.0)
        task_s[r["workers"]] = [per_part[p.name] for p in parts]
    # what Dask adds per task once the cluster runs: the 1-worker run's time past the tasks' own seconds
    overhead_per_part = max(0.0, (one["run_s"] - sum(task_s[1])) / n)
    failed = sum(row["status"] == "failed" for r in runs for row in r["rows"])

    lines = []
    lines.append(f"{n} parts ({CAD.name}/), jobs {','.join(jobs)}, {os.cpu_count()} cores")
    lines.append(f"{'run':24s} {'wall s':>8s} {'start s':>8s} {'parts/min':>10s} {'vs 1 process':>13s}")
    lines.append(f"{'one process (no Dask)':24s} {base:8.1f} {'-':>8s} {60 * n / base:10.2f} {1.0:13.2f}")
    for r in runs:
        lines.append(f"{str(r['workers']) + ' worker(s) (Dask)':24s} {r['wall_s']:8.1f} {r['startup_s']:8.1f} "
                     f"{60 * n / r['wall_s']:10.2f} {base / r['wall_s']:13.2f}")
    lines.append(f"overhead, 1 worker against one process: {one['wall_s'] - base:+.1f} s in all "
                 f"({100 * (one['wall_s'] - base) / base:+.1f} %), of which cluster start {one['startup_s']:.1f} s; "
                 f"per task past its own seconds {overhead_per_part:.2f} s")
    lines.append(f"per-part seconds in one process: min {base_times.min():.2f}, median {np.median(base_times):.2f}, "
                 f"mean {base_times.mean():.2f}, max {base_times.max():.2f} "
                 f"({parts[int(base_times.argmax())].name})")
    rng = np.random.default_rng(args.seed)
    pick = rng.integers(0, n, size=args.parts)
    draw = base_times[pick] + overhead_per_part
    sizes = np.array([p.path.stat().st_size for p in parts], dtype=float)[pick]
    by_size = draw[np.argsort(-sizes, kind="stable")]  # the batch submits the largest files first
    r = float(np.corrcoef(np.array([p.path.stat().st_size for p in parts], dtype=float), base_times)[0, 1])
    lines.append(f"projection, {args.parts} parts drawn from the {n} measured times (+{overhead_per_part:.2f} s each), "
                 f"list scheduling (each part to the worker that frees first) in input order, largest file first "
                 f"(file size vs seconds: r = {r:.2f}), longest first (times known: a bound); cluster start not "
                 "included")
    lines.append(f"{'workers':>8s} {'makespan s':>11s} {'total/W s':>10s} {'longest s':>10s} {'parts/min':>10s} "
                 f"{'efficiency':>11s} {'largest file first s':>21s} {'longest first s':>16s}")
    proj = []
    for w in (8, 64, 512):
        span = list_schedule(draw, w)
        lpt = list_schedule(np.sort(draw)[::-1], w)  # if part times were known in advance: longest first
        size_first = list_schedule(by_size, w)
        ideal = draw.sum() / w
        proj.append({"workers": w, "makespan_s": span, "total_over_w_s": ideal, "longest_s": float(draw.max()),
                     "parts_per_min": 60 * args.parts / span, "efficiency": ideal / span,
                     "largest_file_first_s": size_first,
                     "longest_first_s": lpt})
        lines.append(f"{w:8d} {span:11.1f} {ideal:10.1f} {draw.max():10.1f} {60 * args.parts / span:10.1f} "
                     f"{ideal / span:11.2f} {size_first:21.1f} {lpt:16.1f}")
    lines.append("load (uptime) before / after in-process / after 1 worker / after 2 workers:")
    lines += [f"  {x}" for x in loads]
    if failed:
        lines.append(f"{failed} job(s) failed in the Dask runs")
    print("\n".join(lines))
    if args.json and not args.replay:
        args.json.write_text(json.dumps({
            "parts": [p.name for p in parts], "jobs": jobs, "in_process_s": base_times.tolist(),
            "dask": [{k: v for k, v in r.items() if k != "rows"} | {"task_s": task_s[r["workers"]]} for r in runs],
            "overhead_per_part_s": overhead_per_part, "projection": proj, "load": loads}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
