"""What every subcommand shares: exit codes, one-line errors and warnings, JSON output, progress, tables."""

from __future__ import annotations

import contextlib
import json
import math
import sys
import warnings
from dataclasses import asdict, is_dataclass
from pathlib import Path
from typing import Iterator

import numpy as np

from ..errors import TrimsurfWarning

__all__ = ["EXIT_OK", "EXIT_FAILED", "EXIT_INPUT", "one_line", "print_error", "print_warning", "cli_warnings",
           "jsonable", "print_json", "write_json", "progress", "format_table", "examples"]

EXIT_OK = 0        # success
EXIT_FAILED = 1    # some part failed (or an internal error)
EXIT_INPUT = 2     # bad input or usage

PROG = "trimsurf"


def one_line(message: object) -> str:
    """`message` as one line: whitespace (including newlines) collapsed."""
    text = " ".join(str(message).split())
    return text or type(message).__name__


def print_error(message: object) -> None:
    """``trimsurf: error: <message>`` on stderr, one line."""
    print(f"{PROG}: error: {one_line(message)}", file=sys.stderr, flush=True)


def print_warning(message: object) -> None:
    """``trimsurf: warning: <message>`` on stderr, one line."""
    print(f"{PROG}: warning: {one_line(message)}", file=sys.stderr, flush=True)


@contextlib.contextmanager
def cli_warnings() -> Iterator[None]:
    """Show every `TrimsurfWarning` as one stderr line (each time); other warnings keep their filters."""
    with warnings.catch_warnings():
        warnings.simplefilter("always", TrimsurfWarning)
        previous = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            if issubclass(category, TrimsurfWarning):
                print_warning(message)
            else:
                previous(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        yield


def jsonable(value):
    """`value` with numpy scalars/arrays, paths, tuples and dataclasses turned into JSON values.

    Non-finite floats become None (JSON has no NaN).
    """
    if hasattr(value, "as_dict"):
        return jsonable(value.as_dict())
    if is_dataclass(value) and not isinstance(value, type):
        return jsonable(asdict(value))
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, set)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, Path):
        return str(value)
    return value


def print_json(value) -> None:
    """`value` as indented JSON on stdout."""
    json.dump(jsonable(value), sys.stdout, indent=2, allow_nan=False)
    sys.stdout.write("\n")
    sys.stdout.flush()


def write_json(value, path: Path) -> None:
    """`value` as indented JSON in `path`, written to a temporary file and renamed."""
    from ..io._atomic import atomic_path

    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(jsonable(value), indent=2, allow_nan=False) + "\n", encoding="utf-8")


class _NoProgress:
    def advance(self, n: int = 1, *, description: str | None = None) -> None:
        pass


class _RichProgress:
    def __init__(self, progress, task) -> None:
        self._progress, self._task = progress, task

    def advance(self, n: int = 1, *, description: str | None = None) -> None:
        kw = {} if description is None else {"description": description}
        self._progress.update(self._task, advance=n, **kw)


@contextlib.contextmanager
def progress(total: int, description: str) -> Iterator[_NoProgress | _RichProgress]:
    """A progress bar on stderr when stderr is a terminal; silent otherwise.

    Yields an object with ``advance(n=1, *, description=None)``.
    """
    if not sys.stderr.isatty():
        yield _NoProgress()
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=Console(stderr=True), transient=True) as bar:
        yield _RichProgress(bar, bar.add_task(description, total=total))


def format_table(rows, *, indent: int = 0) -> str:
    """Rows of cells as left-aligned text columns (a row of one cell is a heading line)."""
    rows = [[str(c) for c in r] for r in rows]
    ncol = max((len(r) for r in rows if len(r) > 1), default=1)
    widths = [max((len(r[i]) for r in rows if len(r) > 1 and i < len(r)), default=0) for i in range(ncol)]
    pad = " " * indent
    out = []
    for r in rows:
        if len(r) == 1:
            out.append(pad + r[0])
        else:
            out.append(pad + "  ".join(c.ljust(widths[i]) for i, c in enumerate(r)).rstrip())
    return "\n".join(out)


def examples(*lines: str) -> str:
    """An argparse epilog: 'examples:' and the command lines, indented."""
    return "examples:\n" + "\n".join(f"  {line}" for line in lines)
