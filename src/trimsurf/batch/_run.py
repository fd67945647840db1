"""`run`: the parts and jobs of a batch as Dask tasks, their rows as they finish, resumable from the records."""

from __future__ import annotations

import contextlib
import logging
import math
import os
import time
import uuid
from collections.abc import Callable, Iterable
from pathlib import Path

from ..errors import InputError
from ._index import write_index
from ._inputs import Part, collect_parts
from ._jobs import JOBS, MAX_ATTEMPTS, died_reason, empty_row, job_outputs, read_record, run_job, settle
from ._table import write_tables

__all__ = ["run", "local_cluster", "record_key"]

#: the index page is rewritten at most this often while the batch runs (and at its end), seconds; the tables
#: with every row
INDEX_EVERY_S = 5.0

#: seconds to wait for a --scheduler to answer
CONNECT_TIMEOUT_S = 10.0


def _positive(value, name: str) -> None:
    if value is not None and not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise InputError(f"{name} must be a positive number; got {value!r}")


def _jobs(jobs) -> tuple[str, ...]:
    if isinstance(jobs, str):
        jobs = [j.strip() for j in jobs.split(",") if j.strip()]
    jobs = list(jobs)
    if not jobs:
        raise InputError(f"jobs: give at least one of {', '.join(JOBS)}")
    unknown = [j for j in jobs if j not in JOBS]
    if unknown:
        raise InputError(f"jobs: unknown job {unknown[0]!r}; expected some of {', '.join(JOBS)}")
    return tuple(j for j in JOBS if j in jobs)


def record_key(part: Part, job: str, jobs: tuple[str, ...], *, tolerance=None, max_edge=None) -> dict:
    """What a job's record must hold to be reused: the job, its options and the trimsurf version."""
    from .. import __version__

    opts: dict = {}
    if job in ("tessellate", "view"):
        opts = {"tolerance": part.options.get("tolerance", tolerance),
                "max_edge": part.options.get("max_edge", max_edge)}
    if job == "view":
        opts["mesh_from_tessellate"] = "tessellate" in jobs
    return {"job": job, "options": opts, "trimsurf": __version__}


def _reusable(out: Path, part: Part, job: str, key: dict) -> dict | None:
    """The row of the record of an earlier batch when it matches the input and options and its outputs exist."""
    rec = read_record(out, part.name, job)
    if not rec or rec.get("input_sha256") != part.sha256 or rec.get("key") != key:
        return None
    row = rec.get("row") or {}
    if row.get("status") not in ("ok", "not_met"):
        return None
    if not all((out / part.name / name).is_file() for name in rec.get("outputs", job_outputs(job))):
        return None
    return dict(row, reused=True, input=str(part.path))


def _cluster_class():
    import dask
    from distributed import LocalCluster

    class BatchCluster(LocalCluster):
        """A LocalCluster that keeps every nanny: a worker killed by a part is always restarted.

        `SpecCluster` closes a nanny for good when no worker of its name is registered 15 s
        (``distributed.deploy.lost-worker-timeout``) after a worker left; a worker that a crashing
        part kills again while it restarts then lost its nanny (measured: 1 of 2 workers gone
        after a hang, a native crash and a memory hog in a row).
        """

        def _update_worker_status(self, op, msg):
            with dask.config.set({"distributed.deploy.lost-worker-timeout": "3650 days"}):
                super()._update_worker_status(op, msg)

    return BatchCluster


def local_cluster(n_workers: int | None = None, *, memory_limit="auto", env: dict | None = None):
    """A `distributed.LocalCluster` for batches: worker processes with one thread each, on 127.0.0.1.

    One worker per core by default. A job whose worker dies is retried once
    (``distributed.scheduler.allowed-failures`` = 1); a worker that dies is
    always replaced by its nanny. The dashboard is served when bokeh is
    installed (on a free port).
    """
    import dask

    n = n_workers or os.cpu_count() or 1
    # one task at a time per worker (saturation 1): a task queued behind one that kills the worker is not
    # counted as a suspect of that death
    with dask.config.set({"distributed.scheduler.allowed-failures": MAX_ATTEMPTS - 1,
                          "distributed.scheduler.worker-saturation": 1.0}):
        return _cluster_class()(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                dashboard_address="127.0.0.1:0", worker_dashboard_address="127.0.0.1:0",
                                silence_logs=logging.CRITICAL, memory_limit=memory_limit, env=env or {})


@contextlib.contextmanager
def _connect(client, scheduler: str | None, n_workers: int | None):
    """The client to submit to: the given one, one connected to `scheduler`, or a new local cluster's."""
    if client is not None:
        yield client
        return
    from distributed import Client

    if scheduler is not None:
        try:
            c = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError(f"--scheduler {scheduler}: cannot connect: {' '.join(str(exc).split())}") from None
        try:
            yield c
        finally:
            c.close()
        return
    with local_cluster(n_workers) as cluster, Client(cluster) as c:
        yield c


def dashboard_link(client) -> str | None:
    """The Dask dashboard's address when the scheduler serves one (it needs bokeh), else None."""
    import urllib.request

    try:
        if "dashboard" not in client.scheduler_info().get("services", {}):
            return None
        link = client.dashboard_link
        with urllib.request.urlopen(link, timeout=2) as answer:
            page = answer.read(4096).decode("utf-8", "replace")
            # without bokeh the scheduler answers the dashboard's address with "Dask needs bokeh... for the dashboard"
            return link if answer.status == 200 and "for the dashboard" not in page else None
    except Exception:  # no answer, 404 without bokeh, ...: no dashboard to show
        return None


def run(inputs: str | os.PathLike | Iterable[str | os.PathLike], *, jobs: str | Iterable[str] = ("tessellate",),
        client=None, out: str | os.PathLike | None = None, scheduler: str | None = None,
        n_workers: int | None = None, per_part_timeout: float | None = None, per_part_memory: float | None = None,
        force: bool = False, tolerance: float | None = None, max_edge: float | None = None,
        progress: Callable[[dict, int, int], None] | None = None, on_start: Callable[[object], None] | None = None,
        _env: dict | None = None, _hooks: dict | None = None) -> list[dict]:
    """Run `jobs` on every part of `inputs` as Dask tasks; the results table as a list of rows.

    Parameters
    ----------
    inputs : path or iterable of paths
        CAD files, folders (searched recursively) and manifests (``.csv`` with a
        ``path`` column and optional ``tolerance``, ``max_edge``, ``timeout``).
    out : path or None
        Output folder (default: ``trimsurf-batch`` beside the first input, i.e.
        in the folder holding it): ``OUT/<part>/`` per part (mesh.ply, tessellate.json,
        certify.json, zebra.png, thumb.png, view.html, ``<job>.record.json``),
        ``OUT/results.csv``, ``OUT/results.parquet``, ``OUT/index.html``.
    jobs : str or iterable of str
        Some of ``tessellate``, ``certify``, ``view`` (comma-separated or a list).
        view shows the tessellate job's mesh (or tessellates itself without it).
    client : distributed.Client or None
        Submit to this client; else to `scheduler`; else to a new `local_cluster`.
    scheduler : str or None
        Address of a running Dask scheduler (``tcp://host:port``); its workers
        must see `inputs` and `out` at the same paths.
    n_workers : int or None
        Workers of the local cluster (default one per core).
    per_part_timeout : float or None
        Seconds each job of a part may run (a manifest's ``timeout`` column
        overrides it per part); past it the job's worker is stopped and the
        job retried once. None: no limit (reads keep their own limit,
        ``TRIMSURF_READ_TIMEOUT``).
    per_part_memory : float or None
        Bytes a job's worker may hold; default 0.9 of the worker's memory limit.
    force : bool
        Redo every job, even those whose record matches.
    tolerance, max_edge : float or None
        Tessellation options (model units) for parts whose manifest row gives none.
    progress : callable(row, n_done, n_total) or None
        Called with each finished (or reused) row.
    on_start : callable(client) or None
        Called once the client is connected, before the first task.

    Returns
    -------
    list of dict
        One row per part and job, in input order (columns `COLUMNS`); status
        ``ok``, ``not_met`` (written, a guarantee not met) or ``failed``.

    Raises
    ------
    InputError
        Bad inputs, jobs or options, an output folder that cannot be written, an
        unreachable scheduler.

    Notes
    -----
    A job that crashes its worker, runs past its time limit or exhausts memory
    is retried once (Dask's ``allowed-failures`` on the local cluster; a third
    start in the same batch gives up at once on any scheduler), then recorded as
    failed with the reason. A finished job writes its record at once: a batch
    that is stopped and run again redoes only what is missing.
    """
    from ..cli._common import check_output_folder

    jobs = _jobs(jobs)
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    inputs = list(inputs)
    if out is None:
        if not inputs:
            raise InputError("no input given")
        out = Path(inputs[0]).absolute().parent / "trimsurf-batch"
    for value, name in ((per_part_timeout, "per_part_timeout"), (per_part_memory, "per_part_memory"),
                        (tolerance, "tolerance"), (max_edge, "max_edge")):
        _positive(value, name)
    if n_workers is not None and not (isinstance(n_workers, int) and n_workers > 0):
        raise InputError(f"n_workers must be a positive integer; got {n_workers!r}")
    out = Path(out)
    check_output_folder(out, option="-o")
    parts = collect_parts(inputs)
    for name in {p.name for p in parts} & {"results.csv", "results.parquet", "index.html"}:
        raise InputError(f"a part named {name!r} would clash with the batch's own files in {out}")
    out.mkdir(parents=True, exist_ok=True)
    hooks = dict(_hooks or {})
    batch = uuid.uuid4().hex[:12]
    order = [(p.name, j) for p in parts for j in jobs]
    rows: dict[tuple[str, str], dict] = {}
    specs: dict[tuple[str, str], dict] = {}
    for part in parts:
        for job in jobs:
            key = record_key(part, job, jobs, tolerance=tolerance, max_edge=max_edge)
            reused = None if force else _reusable(out, part, job, key)
            if reused is not None:
                rows[(part.name, job)] = reused
                continue
            timeout = part.options.get("timeout", per_part_timeout)
            # absolute paths: the workers of a --scheduler need not share our working folder
            specs[(part.name, job)] = {"part": part.name, "path": str(part.path.absolute()), "sha256": part.sha256,
                                       "job": job,
                                       "options": key["options"], "out": str(out.resolve()), "run": batch,
                                       "timeout": timeout, "memory_limit": per_part_memory, "mesh": None,
                                       "env": _env, "record": key, "hook": hooks.get((part.name, job)),
                                       "size": part.path.stat().st_size}
    total, done = len(order), 0
    for k in order:
        if k in rows and progress is not None:
            done += 1
            progress(rows[k], done, total)

    def table() -> list[dict]:
        return [rows[k] for k in order if k in rows]

    last_index = [0.0]

    def write(final: bool = False) -> None:
        current = table()
        write_tables(current, out)  # each row as it arrives
        if final or time.monotonic() - last_index[0] >= INDEX_EVERY_S:  # the page inlines every thumbnail
            write_index(current, out, jobs=jobs)
            last_index[0] = time.monotonic()

    try:
        if specs:
            done = _submit_all(specs, rows, jobs, out, client, scheduler, n_workers, progress, on_start, write,
                               done, total)
    finally:
        write(final=True)
    return table()


def _submit_all(specs, rows, jobs, out: Path, client, scheduler, n_workers, progress, on_start, write, done, total):
    from distributed import as_completed
    from distributed.scheduler import KilledWorker

    with _connect(client, scheduler, n_workers) as c:
        if on_start is not None:
            on_start(c)
        pending = as_completed()
        by_key: dict[str, tuple[str, str]] = {}

        def submit(k: tuple[str, str]) -> None:
            spec = specs[k]
            again = resubmitted.get(k, 0)
            # larger files first: a long part started last would end the batch alone (benchmarks/batch_scaling.py)
            fut = c.submit(run_job, spec, pure=False, priority=spec["size"],
                           key=f"trimsurf-batch-{spec['run']}-{spec['job']}-{spec['part']}"
                           + (f"-{again}" if again else ""))
            by_key[fut.key] = k
            pending.add(fut)

        waiting_for_mesh = set()
        resubmitted: dict[tuple[str, str], int] = {}
        for k in specs:
            part, job = k
            if job == "view" and "tessellate" in jobs:
                tess = rows.get((part, "tessellate"))
                if tess is None:
                    waiting_for_mesh.add(part)
                    continue
                specs[k]["mesh"] = str(out.resolve() / part / "mesh.ply")
            submit(k)

        def finish(k: tuple[str, str], row: dict) -> None:
            nonlocal done
            rows[k] = row
            done += 1
            if progress is not None:
                progress(row, done, total)
            write()

        for fut in pending:
            k = by_key.pop(fut.key)
            spec = specs[k]
            try:
                row = fut.result()
            except KilledWorker:
                # Dask counts every task a dying worker held; one that did not run its attempts yet goes again
                if _attempts(out, spec) < MAX_ATTEMPTS and resubmitted.get(k, 0) < MAX_ATTEMPTS:
                    resubmitted[k] = resubmitted.get(k, 0) + 1
                    fut.release()
                    submit(k)
                    continue
                row = _died(spec, out)
            except Exception as exc:  # a worker lost for another reason (scheduler restart, ...): the batch goes on
                row = empty_row(spec["part"], spec["job"], spec["path"])
                row.update(status="failed", reason=f"task lost: {type(exc).__name__}: {' '.join(str(exc).split())}")
            fut.release()  # the row is here: Dask need not keep (nor recompute) it when its worker dies
            finish(k, row)
            part, job = k
            if job == "tessellate" and part in waiting_for_mesh:
                waiting_for_mesh.discard(part)
                view = (part, "view")
                if row["status"] == "failed":
                    vrow = empty_row(part, "view", spec["path"])
                    vrow.update(status="failed", reason="no mesh to show: the tessellate job failed")
                    finish(view, vrow)
                else:
                    specs[view]["mesh"] = str(out.resolve() / part / "mesh.ply")
                    submit(view)
    return done


def _attempts(out: Path, spec: dict) -> int:
    """Attempts of the job in this batch so far, from its guard's file (0 when none started)."""
    import json

    try:
        attempt = json.loads((out / spec["part"] / f".{spec['job']}.attempt.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return 0
    return int(attempt.get("attempt", 0)) if attempt.get("run") == spec["run"] else 0


def _died(spec: dict, out: Path) -> dict:
    """The row of a job whose worker died on each attempt (Dask's KilledWorker), with the reason its guard left."""
    import json

    part_dir = out / spec["part"]
    reason = died_reason(part_dir, spec["job"])
    attempt_file = part_dir / f".{spec['job']}.attempt.json"
    try:
        worker = json.loads(attempt_file.read_text(encoding="utf-8")).get("worker")
    except (OSError, ValueError):
        worker = None
    attempts = max(1, _attempts(out, spec))
    settle(part_dir, spec["job"])
    row = empty_row(spec["part"], spec["job"], spec["path"])
    row.update(status="failed", reason=reason, attempts=attempts, worker=worker)
    return row
