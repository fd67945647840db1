"""The reader server: the process that forks the children reading CAD files (see `trimsurf.io._occ._isolate`).

This module imports nothing heavy (no numpy, no model, no Open CASCADE), so
that the ``trimsurf`` command can start the server as its very first action
(`start_early`, called from the top of `trimsurf.cli`): the server's own
start -- a fresh interpreter importing Open CASCADE, numpy and trimsurf's
model, ~1 s -- then runs on another core while the command imports its own
modules and parses its arguments, instead of after them, when the first file
is read.

What the early start costs the command itself (``subprocess.Popen``, a few
ms) is kept and added to the first read's time by the callers that report
it (`take_read_timing`); what ran concurrently is reported apart
(``early_start_s``), never hidden.
"""

from __future__ import annotations

import atexit
import contextlib
import json
import os
import select
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

__all__ = ["start_early", "start_for", "server", "discard_server", "take_read_timing", "LOCK"]

#: allowance for starting the server (importing Open CASCADE on a loaded machine)
SERVER_START_S = 120.0

#: subcommands of ``trimsurf`` that read CAD files in the command's own process, and the suffixes they read
#: through the server (VDAFS is read by hand, in process)
_READING_COMMANDS = frozenset({"tessellate", "info", "view", "certify", "join"})
_SERVER_SUFFIXES = (".step", ".stp", ".iges", ".igs", ".brep")


def in_process() -> bool:
    """Read in this process: asked for with TRIMSURF_OCC_IN_PROCESS=1, or no ``fork`` (not POSIX)."""
    return os.environ.get("TRIMSURF_OCC_IN_PROCESS", "").strip() not in ("", "0") or not hasattr(os, "fork")


def _child_env() -> dict[str, str]:
    """The server's environment: ours, this trimsurf first on PYTHONPATH, one BLAS/OpenMP thread (it forks)."""
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        env[name] = "1"
    return env


class Server:
    """The fork server process and its two pipes (see `trimsurf.io._occ._worker`)."""

    def __init__(self, *, early: bool = False) -> None:
        start = time.monotonic()
        to_server_r, self.to_server = os.pipe()
        self.from_server, from_server_w = os.pipe()
        self.pid_owner = os.getpid()
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "trimsurf.io._occ._worker", str(to_server_r), str(from_server_w)],
                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                pass_fds=(to_server_r, from_server_w), env=_child_env())
        finally:
            os.close(to_server_r)
            os.close(from_server_w)
        self.buffer = b""
        self.early = early
        self.used = False
        self.spawned_at = start
        #: what starting the server cost this process (Popen), seconds
        self.spawn_cost = time.monotonic() - start
        #: when the server was ready to fork readers (its own time.monotonic(), the same clock on Linux)
        self.ready_at: float | None = None

    def alive(self) -> bool:
        return self.pid_owner == os.getpid() and self.proc.poll() is None

    def _line(self, deadline: float | None) -> str | None:
        """The next line from the server; None at the deadline; raises EOFError when the server ended."""
        while b"\n" not in self.buffer:
            wait = None if deadline is None else max(0.0, deadline - time.monotonic())
            ready, _, _ = select.select([self.from_server], [], [], wait)
            if not ready:
                return None
            chunk = os.read(self.from_server, 4096)
            if not chunk:
                raise EOFError("the reader server ended")
            self.buffer += chunk
        line, self.buffer = self.buffer.split(b"\n", 1)
        return line.decode()

    def run(self, fmt: str, path: str, answer: str, timeout: float) -> int | None:
        """Exit status of the child that read `path` (minus the signal if killed); None after `timeout`."""
        # one JSON line (paths may hold tabs or newlines); the child reads from our working folder, so
        # relative paths, and the messages naming them, stay the caller's
        request = json.dumps(["READ", fmt, path, answer, os.getcwd()]) + "\n"
        self.used = True
        os.write(self.to_server, request.encode("utf-8", "surrogateescape"))
        # the server answers "PID <pid> <ready time>" at once after its start-up; the time limit runs from the fork
        first = self._line(time.monotonic() + SERVER_START_S)
        if first is None or not first.startswith("PID "):
            raise EOFError("the reader server did not answer")
        words = first.split()
        pid = int(words[1])
        if self.ready_at is None and len(words) > 2:
            self.ready_at = float(words[2])
        deadline = time.monotonic() + timeout
        try:
            last = self._line(deadline)
        except BaseException:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
            raise
        if last is None:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
            self._line(time.monotonic() + 10.0)  # the server's EXIT line for the killed child
            return None
        return int(last.split()[1])

    def close(self) -> None:
        if not self.used:  # started early for a read that never came: nothing to wait for
            with contextlib.suppress(OSError):
                self.proc.kill()
        for fd in (self.to_server, self.from_server):
            with contextlib.suppress(OSError):
                os.close(fd)
        with contextlib.suppress(Exception):
            self.proc.wait(timeout=5)


LOCK = threading.Lock()
_SERVER: Server | None = None
_TIMING: dict[str, float] = {}


def server() -> Server:
    """The running server, started now if there is none (or it ended)."""
    global _SERVER
    if _SERVER is None or not _SERVER.alive():
        _SERVER = Server()
    return _SERVER


def start_for(path) -> None:
    """Start the server now (without waiting for it) if reading `path` will go through it and none runs.

    Not when the read will come from the cache (`trimsurf.io._cache`)."""
    if _SERVER is not None and _SERVER.alive():
        return
    suffix = Path(path).suffix.lower()
    if in_process() or suffix not in _SERVER_SUFFIXES or _cached(path):
        return
    with LOCK:
        with contextlib.suppress(OSError):  # no fork/exec possible now: the read itself tries again (and says so)
            server()


def discard_server() -> None:
    global _SERVER
    if _SERVER is not None:
        with contextlib.suppress(Exception):
            _SERVER.proc.kill()
        _SERVER.close()
    _SERVER = None


@atexit.register
def _stop_server() -> None:
    if _SERVER is not None and _SERVER.pid_owner == os.getpid():
        _SERVER.close()


def note_read(srv: Server, asked_at: float) -> None:
    """Record what the server's start cost the read asked for at `asked_at` (`take_read_timing`)."""
    _TIMING.clear()
    if srv.early and srv.ready_at is not None:
        _TIMING["spawn_cost_s"] = srv.spawn_cost
        _TIMING["early_start_s"] = max(0.0, min(srv.ready_at, asked_at) - srv.spawned_at)
        srv.early = False  # counted once, with the first read


def note_cached_read() -> None:
    """Record that the read asked for now came from the cache (`take_read_timing`)."""
    _TIMING.clear()
    _TIMING["from_cache"] = 1.0
    if _SERVER is not None and _SERVER.early:
        _TIMING["spawn_cost_s"] = _SERVER.spawn_cost
        _SERVER.early = False


def _cached(path) -> bool:
    """Whether reading `path` will come from the cache of read shells."""
    from . import _cache

    fmt = _cache.FORMATS.get(Path(path).suffix.lower())
    folder = _cache.cache_dir()
    return fmt is not None and folder is not None and folder.is_dir() and _cache.has(_cache.key(path, fmt))


def take_read_timing() -> dict[str, float]:
    """What the last read's server start cost outside the read call, and clear it.

    ``spawn_cost_s``: this process's cost of starting the server early (add it to the read's time);
    ``early_start_s``: the server's own start-up that ran before the read was asked for, concurrently
    with the caller (wall time on another core, not waited for); ``from_cache``: 1.0 when the shell came
    from the cache of read shells (`trimsurf.io._cache`), without the server. Empty when the read used a
    server started by the read itself (its whole start is then inside the read's time) or none.
    """
    out = dict(_TIMING)
    _TIMING.clear()
    return out


def _wants_reader(argv: list[str]) -> bool:
    """Whether ``trimsurf`` `argv` (without the program) reads a CAD file through the server.

    A file whose read will come from the cache of read shells (`trimsurf.io._cache`) needs no server."""
    words = [a for a in argv if not a.startswith("-")]
    if not words or words[0] not in _READING_COMMANDS:
        return False
    for word in words[1:]:
        with contextlib.suppress(OSError, ValueError):
            p = Path(word)
            if p.suffix.lower() in _SERVER_SUFFIXES and p.is_file() and not _cached(word):
                return True
            if words[0] == "tessellate" and p.is_dir():
                if any(q.suffix.lower() in _SERVER_SUFFIXES for q in p.iterdir()):
                    return True
    return False


def _is_trimsurf_command() -> bool:
    """This process is the ``trimsurf`` command (console script or ``python -m trimsurf``), not a library caller."""
    prog = Path(sys.argv[0]) if sys.argv and sys.argv[0] else None
    if prog is None:
        return False
    return prog.name == "trimsurf" or (prog.name == "__main__.py" and prog.parent.name == "trimsurf")


def start_early() -> bool:
    """Start the reader server now if this process is a ``trimsurf`` command that will read a CAD file.

    Called first thing when `trimsurf.cli` is imported, before its heavy imports. A library caller
    (any other program importing trimsurf) is left alone: its server starts at its first read.
    Returns whether a server was started.
    """
    global _SERVER
    if _SERVER is not None or in_process() or not _is_trimsurf_command() or not _wants_reader(sys.argv[1:]):
        return False
    try:
        _SERVER = Server(early=True)
    except OSError:  # no fork/exec possible now: the first read tries again (and reports it)
        return False
    return True
