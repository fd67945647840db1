"""What every subcommand shares: exit codes, one-line errors and warnings, JSON output, progress, tables."""

from __future__ import annotations

import contextlib
import json
import math
import os
import sys
import threading
import warnings
from dataclasses import asdict, is_dataclass
from pathlib import Path
from typing import Iterator

import numpy as np

from ..errors import FileFormatError, InputError, TrimsurfWarning

__all__ = ["Terminated", "EXIT_OK", "EXIT_FAILED", "EXIT_INPUT", "one_line", "print_error", "print_warning",
           "cli_warnings", "jsonable", "print_json", "write_json", "progress", "format_table", "examples", "BudgetError",
           "memory_budget", "check_budget", "estimate_shell_triangles", "check_output_file",
           "check_output_folder", "BYTES_PER"]

EXIT_OK = 0        # success
EXIT_FAILED = 1    # some part failed (or an internal error)
EXIT_INPUT = 2     # bad input or usage

PROG = "trimsurf"


#: set when SIGTERM arrived during a command (see `cli.main`): a batch must not go on after it
_TERMINATED = threading.Event()


class Terminated(BaseException):
    """SIGTERM, raised in the main thread so that every ``finally`` (temporary files) runs, as for Ctrl-C."""


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


def kernels_cold() -> bool:
    """Whether most compiled kernels of trimsurf loaded so far have no numba cache on disk yet: the first
    run after an install compiles them (tens of seconds), later runs load them. (A kernel only ever
    inlined into others has no cache of its own, hence "most".) False when unsure."""
    n = missing = 0
    for name, module in list(sys.modules.items()):
        if not name.startswith("trimsurf.") or module is None:
            continue
        for obj in list(vars(module).values()):
            index = getattr(getattr(getattr(obj, "_cache", None), "_cache_file", None), "_index_path", None)
            if isinstance(index, str) and getattr(obj, "__module__", None) == name:
                n += 1
                missing += not Path(index).exists()
    return n > 0 and 2 * missing > n


@contextlib.contextmanager
def progress(total: int, description: str) -> Iterator[_NoProgress | _RichProgress]:
    """A progress bar on stderr when stderr is a terminal; silent otherwise.

    Yields an object with ``advance(n=1, *, description=None)``.
    """
    if not sys.stderr.isatty():
        yield _NoProgress()
        return
    if kernels_cold():
        print_warning("first run: compiling trimsurf's numerical kernels (once per install and version; "
                      "a first tessellation with its report: ~25 s of CPU)")
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


# -- resource budgets ------------------------------------------------------------

class BudgetError(InputError):
    """Options that would make an output (or a working set) larger than the memory budget."""


#: default memory budget of one command, bytes; ``TRIMSURF_MEMORY_BUDGET`` (e.g. ``16G``, ``500M``) overrides
DEFAULT_MEMORY_BUDGET = 2 * 2 ** 30

#: peak memory per output element, bytes, measured on this project's samples (RSS above the ~0.2 GB baseline):
#: tessellate bspline_box --max-edge 5 / 2: 88,852 / 741,564 triangles -> 0.83 / 2.78 GB peak (3.5-7 KB each);
#: reconstruct octahedron --density 200 / 400: 0.96 / 3.84 M triangles -> 0.38 / 1.03 GB (~230 B each);
#: fit holed_sheet --grid 100 100 / 200 200: 1e4 / 4e4 control points -> 0.59 / 1.41 GB (~27 KB each)
#: (the issue's --grid 400 400 took 5.1 GB: 32 KB each). join gap_pair --deflection 1e-3 / 1e-4 / 1e-5 (the join
#: refining until its triangles are within the deflection): 9,267 / 21,068 / 58,757 joined triangles (12-14.5x the
#: Open CASCADE face meshes' 640 / 1,656 / 4,871) -> 0.64 / 0.79 / 1.33 GB peak (8.8 / 17.6 / 85 s): the cost per
#: joined triangle grows (~15 KB at 59k), see `_bytes`; the issue's --deflection 1e-6 (15,035 face triangles) ran
#: past 120 s and 4 GB. join U_Joint at its default: 9,812 face triangles -> 19,277 (2x), 0.63 GB, 22 s.
BYTES_PER = {"tessellate_triangle": 4000, "reconstruct_triangle": 250, "fit_control_point": 32000,
             "join_triangle": 9000}


def _bytes(kind: str, count: float) -> float:
    """Peak bytes of `count` elements of `kind`; the join's per-triangle cost grows as (n / 3e4)^0.9 beyond 3e4."""
    if kind == "join_triangle":
        return BYTES_PER[kind] * count * max(1.0, count / 3e4) ** 0.9
    return BYTES_PER[kind] * count


def _parse_bytes(text: str) -> float:
    text = text.strip().upper().removesuffix("B")
    scale = {"K": 2 ** 10, "M": 2 ** 20, "G": 2 ** 30, "T": 2 ** 40}.get(text[-1:], 1)
    value = float(text[:-1] if text[-1:] in "KMGT" and text[-1:] else text)
    if not (math.isfinite(value) and value > 0):
        raise ValueError(text)
    return value * scale


def memory_budget() -> float:
    """The memory budget in bytes: ``TRIMSURF_MEMORY_BUDGET`` (``16G``, ``500M``, bytes) or 2 GiB."""
    raw = os.environ.get("TRIMSURF_MEMORY_BUDGET")
    if not raw:
        return float(DEFAULT_MEMORY_BUDGET)
    try:
        return _parse_bytes(raw)
    except (ValueError, IndexError):
        raise InputError(f"TRIMSURF_MEMORY_BUDGET={raw!r}: expected a size such as 8G, 500M or a byte count"
                         ) from None


def _size(nbytes: float) -> str:
    for unit, scale in (("TB", 2 ** 40), ("GB", 2 ** 30), ("MB", 2 ** 20)):
        if nbytes >= scale:
            return f"{nbytes / scale:.3g} {unit}"
    return f"{nbytes / 2 ** 10:.3g} KB"


def check_budget(count: float, kind: str, *, what: str, hint: str, per_part=None) -> None:
    """Raise `BudgetError` when `count` elements of `kind` (a `BYTES_PER` key) exceed the memory budget.

    `what` starts the message (``--max-edge 0.001 too small``), `hint` ends it
    (``use a larger --max-edge``). A non-finite count is over any budget.
    `per_part` (counts of independent parts, e.g. one per face, summing to
    `count`) prices each part on its own (`_bytes` grows faster than linearly).

    Examples
    --------
    >>> check_budget(1e3, "reconstruct_triangle", what="--density 2 too large", hint="lower --density")
    >>> check_budget(1e12, "reconstruct_triangle", what="--density 9999 too large", hint="lower --density")
    Traceback (most recent call last):
    ...
    trimsurf.cli._common.BudgetError: --density 9999 too large: would make ~1e+12 triangles (~227 TB, above the memory budget of 2 GB); lower --density, or raise the budget with TRIMSURF_MEMORY_BUDGET=...
    """
    budget = memory_budget()
    need = _bytes(kind, count) if per_part is None else float(sum(_bytes(kind, c) for c in per_part))
    if need <= budget:
        return
    noun = "control points" if kind.endswith("control_point") else "triangles"
    amount = f"~{count:.3g} {noun}" if math.isfinite(count) else f"unboundedly many {noun}"
    cost = f"~{_size(need)}, " if math.isfinite(need) else ""
    raise BudgetError(f"{what}: would make {amount} ({cost}above the memory budget of {_size(budget)}); {hint}, "
                      f"or raise the budget with TRIMSURF_MEMORY_BUDGET=...")


def _trim_box(face) -> tuple[tuple[float, float], tuple[float, float]]:
    """The (u, v) box of the face's outer trim loop within its surface's domain (the whole domain without one)."""
    (u0, u1), (v0, v1) = face.surface.domain
    loop = face.outer_loop
    if loop is None:
        return (u0, u1), (v0, v1)
    try:
        uv = np.asarray(loop.polyline(8), dtype=float)
    except Exception:  # a loop that cannot be evaluated: the face fails later, the surface is the bound
        return (u0, u1), (v0, v1)
    uv = uv[np.isfinite(uv).all(axis=1)]
    if not len(uv):
        return (u0, u1), (v0, v1)
    a0, b0 = max(u0, float(uv[:, 0].min())), min(u1, float(uv[:, 0].max()))
    a1, b1 = max(v0, float(uv[:, 1].min())), min(v1, float(uv[:, 1].max()))
    return ((a0, b0) if a0 < b0 else (u0, u1)), ((a1, b1) if a1 < b1 else (v0, v1))


def estimate_shell_triangles(shell, tolerance: float, max_edge: float | None = None, *, n: int = 9) -> float:
    """Triangles a mesh of `shell` within `tolerance` and with edges up to `max_edge` needs, roughly.

    Each face's surface is sampled on an n x n grid over the (u, v) box of its
    outer trim loop. Per grid cell and direction (u, v): the side length L and
    the sagitta delta of the sample polyline there (|P+ - 2P + P-| / 16 per
    cell) give m = max(L / max_edge, sqrt(delta / tolerance)) segments (a
    chord's deviation falls with the square of the number of pieces), and the
    cell 2 m_u m_v triangles. Bounded by the geometry: poles and collapsed
    rows (L -> 0, delta -> 0) add nothing, unlike a curvature estimate.
    Measured against the tessellator in tests/cli/test_hardening.py.
    """
    total = 0.0
    with np.errstate(all="ignore"):
        for face in shell.faces:
            (u0, u1), (v0, v1) = _trim_box(face)
            uu, vv = np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n), indexing="ij")
            p = face.surface.evaluate(np.column_stack([uu.ravel(), vv.ravel()])).reshape(n, n, 3)
            m_dir = []
            for axis in (0, 1):
                q = np.moveaxis(p, axis, 0)                                   # (n along axis, n, 3)
                side = np.linalg.norm(q[1:] - q[:-1], axis=-1)                # (n - 1, n)
                length = 0.5 * (side[:, 1:] + side[:, :-1])                   # per cell (n - 1, n - 1)
                sag = np.linalg.norm(q[2:] - 2 * q[1:-1] + q[:-2], axis=-1) / 16.0   # (n - 2, n)
                sag = np.concatenate([sag[:1], sag, sag[-1:]])                # ends take their neighbour's
                sag = np.maximum(sag[1:], sag[:-1])                           # per cell row (n - 1, n)
                sag = np.maximum(sag[:, 1:], sag[:, :-1])                     # (n - 1, n - 1)
                m = np.sqrt(sag / tolerance)
                if max_edge is not None:
                    m = np.maximum(m, length / max_edge)
                m_dir.append(np.moveaxis(m, 0, axis))
            total += float(np.sum(2.0 * m_dir[0] * m_dir[1]))
    return total if math.isfinite(total) else math.inf


# -- outputs, checked before the work ----------------------------------------------

def check_output_file(path: Path | None, *, option: str = "", suffixes: tuple[str, ...] | None = None) -> None:
    """Refuse an output file path before any work: a folder, a missing or non-folder parent, no write access.

    `suffixes` (lower case, with dots) restricts the file name's suffix. The
    message names `path` as the user gave it (with `option`, e.g. ``--report``).
    """
    if path is None:
        return
    path = Path(path)
    where = f"{option} {path}" if option else str(path)
    if suffixes is not None and path.suffix.lower() not in suffixes:
        raise InputError(f"{where}: expected a {' or '.join(suffixes)} file name; got "
                         f"{path.suffix or 'no suffix'!r}")
    if path.is_dir():
        raise InputError(f"{where}: is a folder; give a file name")
    parent = path.parent
    if not parent.exists():
        raise InputError(f"{where}: folder {parent} does not exist")
    if not parent.is_dir():
        raise InputError(f"{where}: {parent} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{where}: folder {parent} is not writable")
    if path.exists() and not os.access(path, os.W_OK):
        raise InputError(f"{where}: file is not writable")


def check_output_folder(path: Path, *, option: str = "") -> None:
    """Refuse an output folder path before any work: a file, a missing parent, no write access.

    A folder that does not exist yet is fine when its parent does (it is created).
    """
    path = Path(path)
    where = f"{option} {path}" if option else str(path)
    if path.exists():
        if not path.is_dir():
            raise InputError(f"{where}: is not a folder (a file is there); an output folder is needed")
        if not os.access(path, os.W_OK | os.X_OK):
            raise InputError(f"{where}: folder is not writable")
        return
    check_output_file(path, option=option)


#: the one line that tells where the embedded samples' names are listed
SAMPLE_HELP = "or the name of an embedded sample (`trimsurf samples --list`)"
_KIND_WORDS = {"shell": "a CAD shell", "mesh": "a mesh"}


def sample_input(name, command: str, kind: str | None = None):
    """The embedded `Sample` that INPUT `name` names, or None when a file or folder of that path exists.

    A path that exists always wins over a sample of the same name (read it). Shared by every command
    that takes a model (``trimsurf tessellate/join/certify/fit/info/view/reconstruct MODEL``); the
    sample is not built here (``sample.build()``), so inputs can be checked before any work.

    Parameters
    ----------
    name : str or Path
    command : str
        The command's name, for the message.
    kind : {"shell", "mesh"} or None
        The kind of model the command needs; None: either.

    Raises
    ------
    InputError
        `name` is neither an existing path nor a sample name, or names a sample of the other kind.

    Examples
    --------
    >>> sample_input("fender", "tessellate", "shell").kind
    'shell'
    >>> sample_input("octahedron", "tessellate", "shell")
    Traceback (most recent call last):
    ...
    trimsurf.errors.InputError: octahedron: sample is a mesh; tessellate needs a CAD shell
    """
    from ..samples import SAMPLES

    if Path(name).exists():
        return None
    sample = SAMPLES.get(str(name))
    if sample is None:
        raise InputError(f"{name}: no such file, and not a sample name (`trimsurf samples --list` lists them)")
    if kind is not None and sample.kind != kind:
        hint = f" (tessellate it first: trimsurf tessellate {name} -o {name}.ply)" if kind == "mesh" else ""
        raise InputError(f"{name}: sample is {_KIND_WORDS[sample.kind]}; {command} needs {_KIND_WORDS[kind]}{hint}")
    return sample


def load_shell(name: str, command: str):
    """A Shell from a CAD file path or an embedded sample name (``trimsurf <command> MODEL``).

    Raises
    ------
    InputError
        A mesh sample, or a path that is neither a CAD file nor a sample name.
    """
    from .. import io

    sample = sample_input(name, command, "shell")
    if sample is not None:
        return sample.build()
    path = Path(name)
    if path.suffix.lower() not in io.CAD_SUFFIXES:
        raise InputError(f"{name}: not a CAD file ({', '.join(io.CAD_SUFFIXES)}) nor a sample name")
    return io.read_shell(path)


def load_mesh(name, command: str):
    """A TriMesh from a mesh file path or an embedded mesh sample name; returns (mesh, label).

    Raises
    ------
    InputError
        A shell sample, or a path that is neither a file nor a sample name.
    """
    from .. import io

    sample = sample_input(name, command, "mesh")
    if sample is not None:
        return sample.build(), str(name)
    path = Path(name)
    if path.suffix.lower() not in io.MESH_SUFFIXES:
        raise FileFormatError(f"{path}: not a mesh file (expected {', '.join(io.MESH_SUFFIXES)})")
    return io.read_mesh(path), str(path)
