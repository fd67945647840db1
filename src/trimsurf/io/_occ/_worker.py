"""The child side of `trimsurf.io._occ._isolate`: a small fork server that reads CAD files in children.

``python -m trimsurf.io._occ._worker FD_IN FD_OUT`` imports Open CASCADE once,
then serves requests, one line each, from the file descriptor FD_IN::

    ["READ", FMT, PATH, ANSWER, WORKING_FOLDER]     (a JSON array)

For each it forks a child that reads the STEP, IGES or BREP file PATH into a
`Shell` and writes, pickled, to the file ANSWER either ("ok", shell,
[(warning class, message)]) or ("error", exception class name, message).
The server answers on FD_OUT with ``PID <pid> <ready>`` right after the fork
(``ready``: its ``time.monotonic()`` when its start-up was done) and
``EXIT <status>`` when the child ends (status: exit code, or minus the
signal number). It ends when FD_IN is closed (its parent ended), killing a
child still running. The server itself never calls Open CASCADE, so a crash
or a hang stays in the child.
"""

from __future__ import annotations

import gc
import json
import os
import pickle
import select
import signal
import sys
import time
import warnings


def read_to_file(fmt: str, path: str, answer: str) -> None:
    """Read `path` and write the pickled answer to `answer` (what each forked child does)."""
    import numpy as np

    from ._isolate import convert_file

    try:
        with warnings.catch_warnings(record=True) as caught, np.errstate(all="ignore"):
            warnings.simplefilter("always")
            shell = convert_file(path, fmt)
        kept = [(w.category.__name__, str(w.message)) for w in caught
                if w.category.__module__ == "trimsurf.errors"]
        message = ("ok", shell, kept)
    except Exception as exc:  # noqa: BLE001 - everything goes back to the parent as one line
        message = ("error", type(exc).__name__, str(exc))
    with open(answer, "wb") as fh:
        pickle.dump(message, fh, protocol=pickle.HIGHEST_PROTOCOL)


def _warm_up() -> None:
    """Convert a box made in memory once, so the lazy set-up of a first conversion (Open CASCADE's conversion
    tools, ~7 ms) is done here and inherited by every forked child instead of repeated in each. The reader
    evaluates its p-curves without numba (`_geometry.curves_points`), so no compiled kernel is loaded here
    or in a child (loading the first one made numba import scipy.linalg: 0.18 s of this warm-up before)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox

            from ._read import nurbs_shape
            from ._to_shell import shape_to_shell

            shape_to_shell(nurbs_shape(BRepPrimAPI_MakeBox(1.0, 2.0, 3.0).Shape()), name="box")
        except Exception:  # noqa: BLE001 - a warm-up only
            pass


def _status(raw: int) -> int:
    if os.WIFSIGNALED(raw):
        return -os.WTERMSIG(raw)
    return os.WEXITSTATUS(raw) if os.WIFEXITED(raw) else 1


def serve(fd_in: int, fd_out: int) -> int:
    # everything the reader needs, imported once before any fork; the cyclic garbage collector is off
    # meanwhile (Open CASCADE's bindings create ~10^5 objects: collections were ~15 % of their import)
    gc.disable()
    import numpy  # noqa: F401
    import OCP.BRepBuilderAPI  # noqa: F401
    import OCP.BRepTools  # noqa: F401
    import OCP.IGESControl  # noqa: F401
    import OCP.STEPControl  # noqa: F401

    from .. import _brep, _iges, _step  # noqa: F401
    from . import _isolate  # noqa: F401

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides; Ctrl-C reaches it too
    _warm_up()
    gc.enable()
    gc.freeze()  # what is imported stays: the children's collections skip it (and its pages stay shared)
    ready_at = time.monotonic()
    buffer = b""
    while True:
        while b"\n" not in buffer:
            chunk = os.read(fd_in, 65536)
            if not chunk:
                return 0
            buffer += chunk
        line, buffer = buffer.split(b"\n", 1)
        try:
            kind, fmt, path, answer, cwd = json.loads(line.decode("utf-8", "surrogateescape"))
        except ValueError:
            continue
        if kind != "READ":
            continue
        # the child holds the write end of `done` until it ends, however it ends: the server wakes at once
        done_r, done_w = os.pipe()
        pid = os.fork()
        if pid == 0:  # the child
            code = 1
            try:
                os.close(fd_in)
                os.close(done_r)
                os.chdir(cwd)
                read_to_file(fmt, path, answer)
                code = 0
            finally:
                os._exit(code)
        os.close(done_w)
        os.write(fd_out, f"PID {pid} {ready_at!r}\n".encode())
        try:
            while True:
                done, raw = os.waitpid(pid, os.WNOHANG)
                if done:
                    break
                ready, _, _ = select.select([fd_in, done_r], [], [], 0.5)
                if done_r in ready:
                    done, raw = os.waitpid(pid, 0)
                    break
                if fd_in in ready:  # a request while a child runs is not part of the protocol: only EOF (parent gone)
                    peek = os.read(fd_in, 65536)
                    if not peek:
                        os.kill(pid, signal.SIGKILL)
                        os.waitpid(pid, 0)
                        return 0
                    buffer += peek
        finally:
            os.close(done_r)
        os.write(fd_out, f"EXIT {_status(raw)}\n".encode())


if __name__ == "__main__":
    # no interpreter tear-down (~0.1 s with Open CASCADE loaded): nothing is left to flush
    os._exit(serve(int(sys.argv[1]), int(sys.argv[2])))
