"""What a Dask worker runs for one part and one job: the library call, its outputs, its record and its guard.

`run_job` is the task function: it takes a plain dict (`spec`, picklable, no
closures) and returns one row of the results table. It never raises for a
failure of the part (bad input, an error of the library): the row says
``failed`` with the one-line reason. What it cannot catch -- a native crash
of the worker process, a job that overruns its time limit (even inside native
code holding the GIL), a job that exhausts memory -- kills the worker; the
guard leaves the reason on disk first (`faulthandler` writes the signal or
the timeout and the Python frame, the memory watchdog its measurement), so
the client can name it after Dask reports the worker lost (`died_reason`).
"""

from __future__ import annotations

import contextlib
import faulthandler
import io as _io
import json
import os
import re
import signal
import threading
import time
import warnings
from pathlib import Path

__all__ = ["JOBS", "COLUMNS", "STATUSES", "MAX_ATTEMPTS", "run_job", "died_reason", "record_path", "read_record",
           "job_outputs", "empty_row", "settle"]

#: the jobs, in the order they run for a part
JOBS = ("tessellate", "certify", "view")

#: columns of the results table (one row per part and job)
COLUMNS = ("part", "job", "status", "reason", "faces", "triangles", "max_deviation", "flips", "watertight",
           "certified_faces", "seconds", "worker", "attempts", "reused", "input")

#: ok: done, every guarantee met; not_met: done and written, some guarantee not met (the reason says which);
#: failed: nothing written (error, crash, timeout, out of memory)
STATUSES = ("ok", "not_met", "failed")

#: a part's job runs at most twice in one batch (once, and one retry after its worker died)
MAX_ATTEMPTS = 2

#: what each job writes into OUT/<part>/ (besides its record)
_OUTPUTS = {"tessellate": ("mesh.ply", "tessellate.json"), "certify": ("certify.json",),
            "view": ("zebra.png", "thumb.png", "view.html")}

#: share of its worker's memory limit a job may use before its guard stops it (Dask's nanny stops it at 0.95)
MEMORY_SHARE = 0.9

#: thumbnail size on the index page, pixels
THUMB_SIZE = (240, 180)


def job_outputs(job: str) -> tuple[str, ...]:
    """The file names `job` writes into its part's folder."""
    return _OUTPUTS[job]


def empty_row(part: str, job: str, path: str) -> dict:
    """A row with every column, none measured yet."""
    row = dict.fromkeys(COLUMNS)
    row.update(part=part, job=job, input=path, reused=False, attempts=0)
    return row


def record_path(out: str | os.PathLike, part: str, job: str) -> Path:
    """``OUT/<part>/<job>.record.json``: input hash, options, row and outputs of a finished job."""
    return Path(out) / part / f"{job}.record.json"


def read_record(out, part: str, job: str) -> dict | None:
    """The record of a finished job, or None (missing or unreadable)."""
    try:
        return json.loads(record_path(out, part, job).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


# -- the guard: attempts, crash and timeout reports, memory watchdog ----------------------------------------

def _attempt_path(part_dir: Path, job: str) -> Path:
    return part_dir / f".{job}.attempt.json"


def _crash_path(part_dir: Path, job: str) -> Path:
    return part_dir / f".{job}.crash.txt"


_FATAL = {"Segmentation fault": "SIGSEGV", "Floating-point exception": "SIGFPE", "Floating point exception": "SIGFPE",
          "Aborted": "SIGABRT", "Bus error": "SIGBUS", "Illegal instruction": "SIGILL"}
_FRAME = re.compile(r'^\s*File "(?P<file>[^"]*)", line (?P<line>\d+) in (?P<func>\S+)')


def _frame(lines: list[str], thread: int | None) -> str:
    """' in FUNC (FILE:LINE)': the innermost frame of the task's thread `thread` in a faulthandler dump."""
    if thread is None:
        return ""
    tag = f"0x{thread:016x}"
    start = next((i for i, ln in enumerate(lines) if tag in ln and "most recent call first" in ln), None)
    if start is None:
        return ""
    for ln in lines[start:]:
        m = _FRAME.match(ln)
        if m:
            return f" in {m['func']} ({Path(m['file']).name}:{m['line']})"
    return ""


def died_reason(part_dir: str | os.PathLike, job: str) -> str:
    """Why the last attempt of `job` killed its worker, from what its guard left in `part_dir`."""
    part_dir = Path(part_dir)
    try:
        attempt = json.loads(_attempt_path(part_dir, job).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        attempt = {}
    if attempt.get("reason"):
        return attempt["reason"]
    try:
        lines = _crash_path(part_dir, job).read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        lines = []
    thread = attempt.get("thread")
    head = lines[0] if lines else ""
    if head.startswith("Timeout ("):
        return f"timeout: stopped after {attempt.get('timeout', 0):g} s{_frame(lines, thread)}"
    if head.startswith("Fatal Python error:"):
        what = head.split(":", 1)[1].strip()
        name = _FATAL.get(what, what)
        return f"worker crashed ({name}){_frame(lines, thread)}"
    return ("worker died without a crash report (killed from outside, or out of memory past the worker's "
            "limit)")


def settle(part_dir: str | os.PathLike, job: str) -> None:
    """After the last attempt died: drop the attempt file, keep a crash dump as ``<job>.crash.txt``."""
    part_dir = Path(part_dir)
    with contextlib.suppress(OSError):
        _attempt_path(part_dir, job).unlink()
    crash = _crash_path(part_dir, job)
    with contextlib.suppress(OSError):
        if crash.stat().st_size:
            crash.replace(part_dir / f"{job}.crash.txt")
        else:
            crash.unlink()


def _write_json(path: Path, value: dict) -> None:
    from ..cli._common import write_json

    write_json(value, path)


def _worker_name() -> str:
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return f"local:{os.getpid()}"


def _memory_limit(spec: dict) -> float | None:
    """Bytes the job may hold: the batch's per-part limit, else `MEMORY_SHARE` of the worker's limit (if any)."""
    if spec.get("memory_limit"):
        return float(spec["memory_limit"])
    try:
        from distributed import get_worker

        limit = get_worker().memory_manager.memory_limit
    except (ImportError, ValueError, AttributeError):
        return None
    return MEMORY_SHARE * limit if limit else None


class _GiveUp(Exception):
    """The job already killed its worker `MAX_ATTEMPTS` times in this batch."""


def _memory_watch(limit: float, stop: threading.Event, attempt_file: Path, attempt: dict) -> None:
    """Kill this process when its resident memory passes `limit` bytes, leaving the reason in `attempt_file`."""
    import psutil

    proc = psutil.Process()
    while not stop.wait(0.25):
        rss = proc.memory_info().rss
        if rss > limit:
            attempt["reason"] = (f"out of memory: {rss / 2 ** 30:.2f} GB resident, above the limit of "
                                 f"{limit / 2 ** 30:.2f} GB (stopped)")
            with contextlib.suppress(Exception):
                _write_json(attempt_file, attempt)
            os.kill(os.getpid(), signal.SIGKILL)


@contextlib.contextmanager
def _guard(spec: dict, part_dir: Path, job: str):
    """Count the attempt; report a crash, a timeout or memory exhaustion to disk before the worker dies."""
    attempt_file, crash_file = _attempt_path(part_dir, job), _crash_path(part_dir, job)
    try:
        previous = json.loads(attempt_file.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        previous = None
    if previous is not None and previous.get("run") != spec["run"]:
        previous = None  # left by an earlier batch that was stopped: this batch starts counting anew
    reasons = list(previous.get("reasons", [])) if previous else []
    if previous is not None:  # the worker of the previous attempt died
        reasons.append(died_reason(part_dir, job))
    n = len(reasons) + 1
    if n > MAX_ATTEMPTS:
        raise _GiveUp(reasons[-1])
    attempt = {"run": spec["run"], "attempt": n, "reasons": reasons, "pid": os.getpid(),
               "thread": threading.get_ident(), "worker": _worker_name(), "timeout": spec.get("timeout"),
               "started": time.time()}
    _write_json(attempt_file, attempt)
    was_enabled = faulthandler.is_enabled()
    stop = threading.Event()
    with open(crash_file, "w", encoding="utf-8") as fh:
        faulthandler.enable(file=fh)
        if spec.get("timeout"):
            # a C thread of faulthandler's: fires even while native code holds the GIL, dumps the frames, _exit(1)
            faulthandler.dump_traceback_later(spec["timeout"], exit=True, file=fh)
        watch, limit = None, _memory_limit(spec)
        if limit:
            watch = threading.Thread(target=_memory_watch, args=(limit, stop, attempt_file, attempt),
                                     daemon=True, name="trimsurf-memory-watch")
            watch.start()
        try:
            yield n
        finally:
            stop.set()
            faulthandler.cancel_dump_traceback_later()
            faulthandler.disable()
            if was_enabled:
                faulthandler.enable()
            if watch is not None:
                watch.join()
            # the job ended in this process (done, or an error the row names): nothing for the client to read
            for p in (crash_file, attempt_file):
                with contextlib.suppress(OSError):
                    p.unlink()


@contextlib.contextmanager
def _environment(env: dict | None):
    """Set `env` in os.environ for the block (the batch's test hooks: reader settings), then restore."""
    if not env:
        yield
        return
    saved = {k: os.environ.get(k) for k in env}
    os.environ.update({k: str(v) for k, v in env.items()})
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


# -- the jobs ---------------------------------------------------------------------------------------------

def _tessellate(spec: dict, part_dir: Path, row: dict) -> list[str]:
    """`trimsurf tessellate` for one file: mesh.ply (measured read back) and tessellate.json."""
    from ..cli._common import write_json
    from ..cli.tessellate import _entry, _guarantees_met, check_tessellate_budget
    from ..io import read_shell, skipped_faces, write_mesh
    from ..tessellate import tessellate_shell

    path, opts = Path(spec["path"]), spec["options"]
    t0 = time.perf_counter()
    with skipped_faces() as skipped:
        shell = read_shell(path)
    check_tessellate_budget(shell, path, opts.get("tolerance"), opts.get("max_edge"))
    res = tessellate_shell(shell, tolerance=opts.get("tolerance"), max_edge=opts.get("max_edge"))
    problems = [f"face {f.index} ({f.name}) skipped: {'; '.join(f.messages)}" for f in res.failed_faces]
    problems += [f"at read: {m}" for m in skipped]
    if not res.mesh.n_triangles:
        from ..errors import InputError

        raise InputError(f"{path}: no face could be tessellated; nothing written"
                         + (f" ({problems[0]})" if problems else ""))
    target = part_dir / "mesh.ply"
    write_mesh(res.mesh, target)
    said = _io.StringIO()
    with contextlib.redirect_stderr(said):
        met = _guarantees_met(path, target, res, shell)
    if not met:
        problems.insert(0, " ".join(said.getvalue().split()).removeprefix("trimsurf: warning: "))
    entry = _entry(path, res, time.perf_counter() - t0) | {"output": str(target), "faces_skipped_at_read": skipped}
    write_json(entry, part_dir / "tessellate.json")
    row.update(faces=entry["faces_in"], triangles=entry["triangles"], max_deviation=entry["max_deviation"],
               flips=entry["flipped"], watertight=entry["watertight"])
    if problems:
        row.update(status="not_met", reason="; ".join(problems))
    return ["mesh.ply", "tessellate.json"]


def _certify(spec: dict, part_dir: Path, row: dict) -> list[str]:
    """`trimsurf certify` for one file at its defaults: certify.json."""
    from ..certify import certify_shell, file_point_tolerance
    from ..cli._common import write_json
    from ..io import read_shell

    path = Path(spec["path"])
    shell = read_shell(path)
    tol = file_point_tolerance(path)
    cert = certify_shell(shell, point_tolerance=tol)
    report = cert.as_dict()
    report["model"] = str(path)
    report["point_tolerance_source"] = "file" if tol is not None else "1e-6 of the diagonal"
    write_json(report, part_dir / "certify.json")
    row.update(faces=len(report["faces"]), certified_faces=sum(bool(f["certified"]) for f in report["faces"]))
    if not cert.certified:
        first = report["problems"][0] if report["problems"] else "see certify.json"
        row.update(status="not_met", reason=f"{len(report['problems'])} item(s) not certified; first: {first}")
    return ["certify.json"]


def _view(spec: dict, part_dir: Path, row: dict) -> list[str]:
    """`trimsurf view --mode zebra` of the part's mesh: zebra.png, thumb.png (index page), view.html."""
    from PIL import Image

    from ..io import read_mesh, read_shell
    from ..io._atomic import atomic_path
    from ..viz import render_compare_png, write_html

    if spec.get("mesh"):
        mesh = read_mesh(spec["mesh"])
    else:  # no tessellate job in this batch: the view tessellates at the part's options, as `trimsurf view` does
        from ..tessellate import tessellate_shell

        opts = spec["options"]
        mesh = tessellate_shell(read_shell(spec["path"]), tolerance=opts.get("tolerance"),
                                max_edge=opts.get("max_edge")).mesh
    if not mesh.n_triangles:
        from ..errors import InputError

        raise InputError(f"{spec['path']}: no triangles to show")
    png = part_dir / "zebra.png"
    render_compare_png([mesh], png, titles=[spec["part"]], mode="zebra", window_size=(800, 600))
    with Image.open(png) as im:
        thumb = im.convert("RGB")
        thumb.thumbnail(THUMB_SIZE)
        with atomic_path(part_dir / "thumb.png") as tmp:
            thumb.save(tmp, format="PNG", optimize=True)
    write_html([mesh], part_dir / "view.html", titles=[spec["part"]], title=f"trimsurf batch: {spec['part']}",
               mode="zebra")
    row.update(triangles=mesh.n_triangles)
    return ["zebra.png", "thumb.png", "view.html"]


_RUN = {"tessellate": _tessellate, "certify": _certify, "view": _view}


def _failure(exc: BaseException, path: Path) -> str:
    from ..cli.tessellate import _failure as failure_line

    return failure_line(exc, path)


def run_job(spec: dict) -> dict:
    """Run one job of one part on this worker (the Dask task); returns its row of the results table.

    `spec` keys: ``part``, ``path``, ``sha256``, ``job``, ``options`` (the
    job's options), ``out``, ``run`` (id of the batch), ``timeout`` (s or
    None), ``memory_limit`` (bytes or None), ``mesh`` (view: the part's
    tessellation), ``env`` (variables set while the job runs), ``record``
    (what the record must hold to be reused).
    """
    part_dir = Path(spec["out"]) / spec["part"]
    part_dir.mkdir(parents=True, exist_ok=True)
    job, path = spec["job"], Path(spec["path"])
    done = read_record(spec["out"], spec["part"], job)
    if done and done.get("run") == spec["run"] and done.get("key") == spec["record"]:
        # run already in this batch, its result lost with its worker before the client had it: Dask recomputes
        return done["row"]
    row = empty_row(spec["part"], job, str(path))
    row.update(status="ok", reason="", worker=_worker_name())
    t0 = time.perf_counter()
    try:
        with _environment(spec.get("env")), _guard(spec, part_dir, job) as attempt, \
                warnings.catch_warnings(), np_errstate():
            row["attempts"] = attempt
            warnings.simplefilter("ignore")  # the figures in the row and the reports say what matters
            if spec.get("hook"):
                _test_hook(spec["hook"])
            outputs = _RUN[job](spec, part_dir, row)
    except _GiveUp as exc:
        settle(part_dir, job)
        row.update(status="failed", reason=str(exc), attempts=MAX_ATTEMPTS)
        return row
    except Exception as exc:  # bad input, out of memory, a bug: the batch goes on; the reason names the file
        row.update(status="failed", reason=_failure(exc, path), seconds=time.perf_counter() - t0)
        return row
    row["seconds"] = time.perf_counter() - t0
    record = {"input": str(path), "input_sha256": spec["sha256"], "job": job, "run": spec["run"], "key": spec["record"],
              "row": row,
              "outputs": outputs}
    _write_json(record_path(spec["out"], spec["part"], job), record)
    return row


@contextlib.contextmanager
def np_errstate():
    import numpy as np

    with np.errstate(all="ignore"):
        yield


def _test_hook(hook: str) -> None:
    """Test-only misbehaviour of a job (``trimsurf.batch.run(..., _hooks=...)``): a crash, a hang, a memory hog."""
    if hook == "segfault":
        os.kill(os.getpid(), signal.SIGSEGV)
    elif hook == "hang":  # a regular expression with catastrophic backtracking holds the GIL in C for hours
        re.match(r"(a+)+$", "a" * 64 + "b")
    elif hook == "memory":
        hog = []
        while True:
            hog.append(bytearray(50 * 2 ** 20))
            for k in range(0, len(hog[-1]), 4096):
                hog[-1][k] = 1
    else:
        raise ValueError(f"unknown test hook {hook!r}")
