"""Reading a CAD file with Open CASCADE in a child process, with a time limit.

Open CASCADE's readers and its B-spline conversion can crash the process (a
segmentation fault inside ``TransferRoots`` on a malformed record) or spin
(a control point of 1e999). `read_isolated` runs the whole read -- file
checks, reading, transfer, ``BRepBuilderAPI_NurbsConvert`` and the copy into
a `Shell` -- in a child process and ships the `Shell` back pickled, so that a
crash or a hang becomes a one-line `FileFormatError` naming the file and the
caller goes on.

The children are forked by a small server process
(`trimsurf.io._occ._worker`, started once with ``subprocess`` on the first
read, ended when this process ends) that has imported Open CASCADE once; a
read costs one ``fork`` and the transfer of the pickled result through a
temporary file. The server is a fresh interpreter that never calls Open
CASCADE itself: no fork of a parent that may hold threads, no re-import of
the caller's main script (``multiprocessing``'s spawn and forkserver
methods re-run an unguarded caller script in the child: measured, and
avoided). Set ``TRIMSURF_READ_TIMEOUT`` (seconds) to change
the time limit, and ``TRIMSURF_OCC_IN_PROCESS=1`` to read in the calling
process (debugging; crashes are then not contained).
"""

from __future__ import annotations

import atexit
import contextlib
import json
import os
import pickle
import select
import signal
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from pathlib import Path

from ... import errors
from ...errors import FileFormatError
from ...model import Shell

__all__ = ["read_isolated", "read_timeout", "convert_file"]

#: time limit: a base plus a rate per megabyte (real files read at ~1 s/MB on a loaded 2-core machine)
TIMEOUT_BASE_S = 30.0
TIMEOUT_PER_MB_S = 30.0


def read_timeout(path: str | os.PathLike) -> float:
    """The time limit (seconds) for reading `path`: ``TRIMSURF_READ_TIMEOUT`` or 30 s + 30 s per MB."""
    env = os.environ.get("TRIMSURF_READ_TIMEOUT", "").strip()
    if env:
        try:
            value = float(env)
        except ValueError:
            raise FileFormatError(f"TRIMSURF_READ_TIMEOUT must be a number of seconds; got {env!r}") from None
        if value > 0:
            return value
    size = Path(path).stat().st_size
    return TIMEOUT_BASE_S + TIMEOUT_PER_MB_S * size / 1e6


def convert_file(path: str, fmt: str) -> Shell:
    """Read a STEP, IGES or BREP file into a `Shell` in this process (what the child runs)."""
    if fmt == "BREP":
        from .. import _brep
        return _brep.read_in_process(path)
    if fmt == "IGES":
        from .. import _iges
        return _iges.read_in_process(path)
    from .. import _step
    return _step.read_in_process(path)


def _in_process() -> bool:
    """Read in this process: asked for with TRIMSURF_OCC_IN_PROCESS=1, or no ``fork`` (not POSIX)."""
    return os.environ.get("TRIMSURF_OCC_IN_PROCESS", "").strip() not in ("", "0") or not hasattr(os, "fork")


def _child_env() -> dict[str, str]:
    """The server's environment: ours, this trimsurf first on PYTHONPATH, one BLAS/OpenMP thread (it forks)."""
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parents[3])
    env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        env[name] = "1"
    return env


class _Server:
    """The fork server process and its two pipes (see `trimsurf.io._occ._worker`)."""

    def __init__(self) -> None:
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
        os.write(self.to_server, request.encode("utf-8", "surrogateescape"))
        # the server answers PID at once after its start-up; the time limit runs from the fork
        first = self._line(time.monotonic() + _SERVER_START_S)
        if first is None or not first.startswith("PID "):
            raise EOFError("the reader server did not answer")
        pid = int(first.split()[1])
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
        for fd in (self.to_server, self.from_server):
            with contextlib.suppress(OSError):
                os.close(fd)
        with contextlib.suppress(Exception):
            self.proc.wait(timeout=5)


_LOCK = threading.Lock()
_SERVER: _Server | None = None
_SERVER_START_S = 120.0  # allowance for starting the server (importing Open CASCADE on a loaded machine)


def _server() -> _Server:
    global _SERVER
    if _SERVER is None or not _SERVER.alive():
        _SERVER = _Server()
    return _SERVER


def _discard_server() -> None:
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


def _signal_name(code: int) -> str:
    try:
        return signal.Signals(code).name
    except ValueError:
        return f"signal {code}"


def read_isolated(path: str | os.PathLike, fmt: str, error: type[FileFormatError]) -> Shell:
    """Read a STEP, IGES or BREP file into a `Shell` in a child process (see the module notes).

    Warnings the read gives (faces skipped, ...) are given again here.

    Raises
    ------
    FileFormatError (`error`)
        The file cannot be read, Open CASCADE crashed on it, or the read took
        longer than `read_timeout`; one line naming `path`.
    """
    if _in_process():
        return convert_file(str(path), fmt)
    timeout = read_timeout(path)
    fd, answer = tempfile.mkstemp(prefix="trimsurf-read-", suffix=".pickle")
    os.close(fd)
    try:
        with _LOCK:
            try:
                code = _server().run(fmt, str(path), answer, timeout)
            except (EOFError, BrokenPipeError):  # the server ended (killed from outside): start a new one, once
                _discard_server()
                code = _server().run(fmt, str(path), answer, timeout)
        if code is None:
            raise error(f"{path}: reading the {fmt} file did not finish within {timeout:.3g} s (stopped; Open "
                        "CASCADE is probably stuck on a malformed file; TRIMSURF_READ_TIMEOUT=SECONDS allows "
                        "more)")
        message = None
        if code == 0:
            with open(answer, "rb") as fh:
                message = pickle.load(fh)
        if message is None:
            how = f"crashed ({_signal_name(-code)})" if code < 0 else f"ended with status {code}"
            raise error(f"{path}: Open CASCADE {how} while reading the {fmt} file (the file is probably malformed)")
    finally:
        with contextlib.suppress(OSError):
            os.unlink(answer)
    kind = message[0]
    if kind == "ok":
        _, shell, caught = message
        for category_name, text in caught:
            category = getattr(errors, category_name, errors.TrimsurfWarning)
            warnings.warn(text, category, stacklevel=3)
        return shell
    _, class_name, text = message
    if class_name == "KeyboardInterrupt":
        raise KeyboardInterrupt
    cls = getattr(errors, class_name, None)
    if isinstance(cls, type) and issubclass(cls, errors.InputError):
        raise cls(text)
    raise RuntimeError(f"reading {path} failed in the reader process: {class_name}: {text}")
