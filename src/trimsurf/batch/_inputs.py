"""The parts of a batch: input files, folders (recursive) and manifests, each with a unique name and a hash."""

from __future__ import annotations

import csv
import hashlib
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import InputError

__all__ = ["Part", "collect_parts", "file_sha256", "MANIFEST_COLUMNS", "PART_OPTIONS"]

#: per-part options a manifest may give (column -> meaning); empty cells take the batch's option
PART_OPTIONS = {"tolerance": "max deviation of the tessellation, model units",
                "max_edge": "max 3D grid size of the tessellation, model units",
                "timeout": "time limit of each job of the part, seconds"}
MANIFEST_COLUMNS = ("path",) + tuple(PART_OPTIONS)


@dataclass(frozen=True, slots=True)
class Part:
    """One input file of a batch.

    Attributes
    ----------
    name : str
        Folder name of its outputs under ``OUT/`` (unique within the batch).
    path : Path
        The CAD file.
    sha256 : str
        Hash of the file's bytes (a part whose hash and options match its record is skipped).
    options : dict
        Per-part options (`PART_OPTIONS`) from a manifest; None where the batch's apply.
    """

    name: str
    path: Path
    sha256: str
    options: dict = field(default_factory=dict)


def file_sha256(path: str | os.PathLike) -> str:
    """The SHA-256 of the file's bytes, hex."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _cad_suffixes() -> tuple[str, ...]:
    from ..io import CAD_SUFFIXES

    return CAD_SUFFIXES


def _positive(text: str, column: str, where: str) -> float | None:
    text = text.strip()
    if not text:
        return None
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"{where}: {column} must be a positive number; got {text!r}")
    return value


def _manifest(path: Path) -> list[tuple[Path, dict]]:
    """(file, options) rows of a manifest CSV: a ``path`` column (relative to the manifest) and `PART_OPTIONS`."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = list(csv.DictReader(fh))
            header = list(rows[0].keys()) if rows else []
    except UnicodeDecodeError:
        raise InputError(f"{path}: manifest is not UTF-8 text") from None
    except csv.Error as exc:
        raise InputError(f"{path}: not a valid CSV manifest: {exc}") from None
    if not rows:
        raise InputError(f"{path}: manifest has no rows (expected a header with a 'path' column and one row per part)")
    header = [h for h in header if h is not None]
    if "path" not in header:
        raise InputError(f"{path}: manifest has no 'path' column (columns: {', '.join(header)})")
    unknown = [h for h in header if h not in MANIFEST_COLUMNS]
    if unknown:
        raise InputError(f"{path}: unknown manifest column(s) {', '.join(map(repr, unknown))}; expected "
                         f"{', '.join(MANIFEST_COLUMNS)}")
    out = []
    for i, row in enumerate(rows, start=2):
        where = f"{path}: line {i}"
        if None in row:
            raise InputError(f"{where}: more cells than columns")
        name = (row.get("path") or "").strip()
        if not name:
            raise InputError(f"{where}: empty path")
        file = Path(name)
        file = file if file.is_absolute() else path.parent / file
        opts = {k: _positive(row.get(k) or "", k, where) for k in PART_OPTIONS if k in row}
        out.append((file, {k: v for k, v in opts.items() if v is not None}))
    return out


def _files(inputs) -> list[tuple[Path, dict]]:
    suffixes = _cad_suffixes()
    out: list[tuple[Path, dict]] = []
    for item in inputs:
        p = Path(item)
        if p.is_dir():
            found = sorted(q for q in p.rglob("*") if q.is_file() and q.suffix.lower() in suffixes)
            if not found:
                raise InputError(f"{p}: folder holds no STEP, IGES or VDAFS file (searched recursively)")
            out.extend((q, {}) for q in found)
        elif p.suffix.lower() == ".csv":
            if not p.is_file():
                raise InputError(f"{p}: no such manifest file")
            rows = _manifest(p)
            for q, _ in rows:
                if q.suffix.lower() not in suffixes:
                    raise InputError(f"{p}: {q}: not a CAD file; expected one of {', '.join(suffixes)}")
            out.extend(rows)
        elif p.suffix.lower() not in suffixes:
            raise InputError(f"{p}: not a CAD file, folder or manifest (.csv); expected one of {', '.join(suffixes)}")
        else:
            out.append((p, {}))
    missing = [str(q) for q, _ in out if not q.is_file()]
    if missing:
        more = f" (and {len(missing) - 1} more)" if len(missing) > 1 else ""
        raise InputError(f"{missing[0]}: no such file{more}")
    return out


_UNSAFE = re.compile(r"[^A-Za-z0-9._+-]+")


def _names(paths: list[Path]) -> list[str]:
    """Folder names: the file stem made safe; stems that collide get a hash of the resolved path."""
    stems = [(_UNSAFE.sub("_", p.stem).strip("._") or "part") for p in paths]
    count: dict[str, int] = {}
    for s in stems:
        count[s.lower()] = count.get(s.lower(), 0) + 1
    out = []
    for p, s in zip(paths, stems):
        if count[s.lower()] > 1:
            s = f"{s}-{hashlib.sha256(str(p.resolve()).encode('utf-8', 'surrogateescape')).hexdigest()[:8]}"
        out.append(s)
    return out


def collect_parts(inputs) -> list[Part]:
    """The parts of a batch from files, folders (searched recursively) and manifests (``.csv``).

    A file given twice (also through a folder or a manifest) is one part; the
    options of its first mention apply.

    Raises
    ------
    InputError
        No input, a path that does not exist, a file that is not CAD, a folder
        without CAD files, a malformed manifest.
    """
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    inputs = list(inputs)
    if not inputs:
        raise InputError("no input given")
    for item in inputs:
        if not Path(item).exists() and Path(item).suffix.lower() != ".csv":
            raise InputError(f"{item}: no such file or folder")
    seen: dict[Path, tuple[Path, dict]] = {}
    for p, opts in _files(inputs):
        seen.setdefault(p.resolve(), (p, opts))
    items = list(seen.values())
    names = _names([p for p, _ in items])
    return [Part(name, p, file_sha256(p), opts) for name, (p, opts) in zip(names, items)]
