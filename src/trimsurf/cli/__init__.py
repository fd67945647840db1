"""The ``trimsurf`` command: parse, call the library, print, exit.

Each subcommand is a module with ``NAME``, ``HELP``, ``DESCRIPTION``,
``EPILOG`` (two or three examples), ``add_args(parser)`` and
``run(args) -> int``. Results go to stdout, errors, warnings and progress to
stderr. Exit status: 0 ok, 1 some part failed (or an internal error), 2 bad
input or usage.
"""

from __future__ import annotations

# first of all: a command that will read a CAD file starts the reader server now, so that its start
# (an interpreter importing Open CASCADE) overlaps the imports below instead of following them
from ..io._server import start_early as _start_reader_early

_start_reader_early()

import argparse
import contextlib
import os
import signal
import sys
import threading
import traceback
import warnings

import numpy as np

from .. import __version__
from ..errors import FaceSkippedWarning, InputError
from . import batch, certify, demo, fit, info, join, reconstruct, samples, tessellate, view
from ._common import (_TERMINATED, EXIT_FAILED, EXIT_INPUT, EXIT_OK, Terminated, check_output_file,
                      check_output_folder, cli_warnings, examples, print_error)

__all__ = ["main", "build_parser", "SUBCOMMANDS"]

SUBCOMMANDS = (info, samples, tessellate, join, certify, reconstruct, fit, view, batch, demo)


#: output options checked before any work: attribute -> (option as typed, allowed suffixes or None)
_OUTPUT_FILES = {"output": ("-o", None), "report": ("--report", None), "png": ("--png", (".png",)),
                 "html": ("--html", (".html",)), "write_mesh": ("--write-mesh", None)}


def check_outputs(args: argparse.Namespace) -> None:
    """Refuse output paths that cannot be written before the work starts (`InputError`, exit 2).

    Every output file option (-o, --report, --png, --html, --write-mesh): not a
    folder, its folder exists and is writable, the suffix fits (--png: .png).
    ``demo --out`` is a folder (created if its parent exists); ``tessellate -o``
    may be a folder and is checked by tessellate itself.
    """
    if args.command == "demo":
        check_output_folder(args.out, option="--out")
        return
    if args.command == "samples" and getattr(args, "out", None) is not None:
        check_output_file(args.out, option="--out")
    for name, (option, suffixes) in _OUTPUT_FILES.items():
        if name == "output" and args.command == "tessellate":
            continue
        check_output_file(getattr(args, name, None), option=option, suffixes=suffixes)


@contextlib.contextmanager
def _sigterm_as_interrupt():
    """While the block runs (in the main thread), SIGTERM raises `Terminated`; the old handler is restored."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        _TERMINATED.set()
        raise Terminated()

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``trimsurf`` with every subcommand."""
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                        help="show tracebacks (for bug reports)")
    parser = argparse.ArgumentParser(
        prog="trimsurf", formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Move geometry between CAD and meshes with guarantees: tessellate, join, certify, "
                    "reconstruct, fit, show.",
        epilog=examples("trimsurf demo --out demo-out", "trimsurf info part.step",
                        "trimsurf samples --list"))
    parser.add_argument("--version", action="version", version=f"trimsurf {__version__}")
    parser.add_argument("--debug", action="store_true", default=False, help="show tracebacks (for bug reports)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for mod in SUBCOMMANDS:
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.DESCRIPTION, epilog=mod.EPILOG,
                           formatter_class=argparse.RawDescriptionHelpFormatter, parents=[common])
        mod.add_args(p)
        p.set_defaults(run=mod.run)
    return parser


@contextlib.contextmanager
def _faces_skipped():
    """Count the `FaceSkippedWarning` shown in the block (a list that gets one item per warning)."""
    seen: list[str] = []
    previous = warnings.showwarning

    def show(message, category, *args, **kwargs):
        if issubclass(category, FaceSkippedWarning):
            seen.append(str(message))
        previous(message, category, *args, **kwargs)

    warnings.showwarning = show
    try:
        yield seen
    finally:
        warnings.showwarning = previous


def main(argv: list[str] | None = None) -> int:
    """Run ``trimsurf`` with `argv` (default ``sys.argv[1:]``); returns the exit status.

    Bad input (`InputError`, unreadable paths, Ctrl-C) prints one line
    ``trimsurf: error: ...`` on stderr and returns 2; usage errors return 2;
    any other exception is a bug: one line plus a hint, status 1 (with
    ``--debug`` the exception propagates with its traceback).
    """
    _TERMINATED.clear()
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version (0) and usage errors (2)
        return exc.code if isinstance(exc.code, int) else EXIT_INPUT
    try:
        # numpy floating-point warnings never reach the terminal: inputs are checked for finite, bounded
        # values at read time, and every figure reported is measured on the output
        with cli_warnings(), np.errstate(all="ignore"), _sigterm_as_interrupt(), _faces_skipped() as skipped:
            check_outputs(args)
            status = int(args.run(args))
        # a face of an input file was left out: some part failed
        return EXIT_FAILED if skipped and status == EXIT_OK else status
    except MemoryError:
        if args.debug:
            traceback.print_exc()
        print_error(f"out of memory in {args.command} (coarser options, e.g. a larger tolerance or grid size, "
                    "need less)")
        return EXIT_INPUT
    except Terminated:
        print_error("terminated")
        return EXIT_INPUT
    except InputError as exc:
        if args.debug:
            traceback.print_exc()
        print_error(exc)
        return EXIT_INPUT
    except BrokenPipeError:
        # the reader of stdout went away (``trimsurf info x | head``): nothing to say to it; stdout goes to
        # devnull so the interpreter's final flush does not complain either
        with contextlib.suppress(OSError, ValueError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_FAILED
    except OSError as exc:
        if args.debug:
            traceback.print_exc()
        where = f"{exc.filename}: " if exc.filename else ""
        print_error(f"{where}{exc.strerror or exc}")
        return EXIT_INPUT
    except KeyboardInterrupt:
        print_error("interrupted")
        return EXIT_INPUT
    except Exception as exc:
        if _TERMINATED.is_set():  # raised inside native code (numba, C callbacks) and wrapped there
            print_error("terminated")
            return EXIT_INPUT
        if args.debug:
            raise
        print_error(f"internal error: {type(exc).__name__}: {exc} (a bug; rerun with --debug for the traceback "
                    f"and report it)")
        return EXIT_FAILED
