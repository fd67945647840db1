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
read -- or by the ``trimsurf`` command as its first action, so that its start
overlaps the command's own, `trimsurf.io._server` -- and ended when this
process ends) that has imported Open CASCADE once; a
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

import contextlib
import os
import pickle
import signal
import tempfile
import time
import warnings
from pathlib import Path

from ... import errors
from .. import _cache, _server
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
    return _server.in_process()


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
    cache_key = _cache.key(path, fmt)
    message = _cached(cache_key)
    if message is not None:
        return _answer(message, path)
    timeout = read_timeout(path)
    fd, answer = tempfile.mkstemp(prefix="trimsurf-read-", suffix=".pickle")
    os.close(fd)
    try:
        with _server.LOCK:
            asked_at = time.monotonic()
            try:
                srv = _server.server()
                code = srv.run(fmt, str(path), answer, timeout)
            except (EOFError, BrokenPipeError):  # the server ended (killed from outside): start a new one, once
                _server.discard_server()
                srv = _server.server()
                code = srv.run(fmt, str(path), answer, timeout)
            _server.note_read(srv, asked_at)
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
        if message[0] == "ok":
            _cache.store(cache_key, answer, path)
    finally:
        with contextlib.suppress(OSError):
            os.unlink(answer)
    return _answer(message, path)


def _cached(cache_key: str | None):
    """The answer a child gave for the same file and code (`trimsurf.io._cache`), or None."""
    data = _cache.load(cache_key)
    if data is None:
        return None
    try:
        message = pickle.loads(data)
        if message[0] != "ok" or not isinstance(message[1], Shell):
            raise ValueError("not a read shell")
    except Exception:  # noqa: BLE001 - a damaged entry: read the file again
        _cache.drop(cache_key)
        return None
    _server.note_cached_read()
    return message


def _answer(message: tuple, path) -> Shell:
    """The shell of a child's answer (its warnings given again), or its error raised."""
    kind = message[0]
    if kind == "ok":
        _, shell, caught = message
        for category_name, text in caught:
            category = getattr(errors, category_name, errors.TrimsurfWarning)
            warnings.warn(text, category, stacklevel=4)
        return shell
    _, class_name, text = message
    if class_name == "KeyboardInterrupt":
        raise KeyboardInterrupt
    cls = getattr(errors, class_name, None)
    if isinstance(cls, type) and issubclass(cls, errors.InputError):
        raise cls(text)
    raise RuntimeError(f"reading {path} failed in the reader process: {class_name}: {text}")
