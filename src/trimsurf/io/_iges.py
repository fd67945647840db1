"""IGES read through Open CASCADE (``cadquery-ocp``).

`read` returns a `Shell` of trimmed NURBS faces (conversion and conventions in
`trimsurf.io._occ`). An unsewn IGES surface model gives every face its own
edges, so its shell has free edges; stitching is the tessellation's work.
Writing IGES is not supported: write STEP.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import FileFormatError, IgesReadError
from ..model import Shell
from . import _occ

__all__ = ["read", "write"]


def read_occ_shape(path: str | os.PathLike):
    """The Open CASCADE shape `read` converts: the file's shape after ``BRepBuilderAPI_NurbsConvert``."""
    _check_sections(_occ.check_file(path, IgesReadError), path)
    shape = _occ.read_shape(path, "IGES", IgesReadError)
    return _occ.nurbs_shape(shape, path=path, error=IgesReadError)


def read(path: str | os.PathLike) -> Shell:
    """Read an IGES file into a `Shell`.

    Raises
    ------
    IgesReadError
        The file is missing, empty, malformed, or holds no faces (one line
        naming the file; Open CASCADE's own output is suppressed), holds a
        number that is not finite or above 1e10 in magnitude, or Open CASCADE
        crashes or does not finish on it (the read runs in a child process
        with a time limit, `trimsurf.io._occ._isolate`).

    Warns
    -----
    FaceSkippedWarning
        A face that cannot be converted is left out (named in the message).
    """
    _occ.check_file(path, IgesReadError)
    return _occ.read_isolated(path, "IGES", IgesReadError)


def read_in_process(path: str | os.PathLike) -> Shell:
    """`read` in the calling process (what the child process of `read` runs; crashes are not contained)."""
    return _occ.shape_to_shell(read_occ_shape(path), name=Path(path).name, skip_bad_faces=True)


def write(shell: Shell, path: str | os.PathLike) -> None:
    """Not supported: trimsurf writes STEP (.step/.stp) and VDAFS, not IGES."""
    raise FileFormatError(f"{path}: writing IGES is not supported; write a .step file instead")


def _check_sections(p: Path, path) -> None:
    """Check the fixed-format layout: a final Terminate (T) record whose counts match the sections.

    Open CASCADE reads a truncated IGES file without complaint (it keeps the
    entities it got), so truncation is detected here: every record carries
    its section letter in column 73, and the T record states how many S, G,
    D and P records the file has. Compressed and binary IGES are not checked.
    """
    lines = [ln for ln in p.read_bytes().splitlines() if ln.strip()]
    if lines and len(lines[0]) >= 73 and lines[0][72:73] in (b"B", b"C"):
        return
    last = lines[-1] if lines else b""
    if len(last) < 73 or last[72:73] != b"T":
        raise IgesReadError(f"{path}: not a complete IGES file (no Terminate record at the end: "
                            "truncated or not IGES)")
    counts = {}
    for ln in lines:
        if len(ln) >= 73:
            key = ln[72:73]
            counts[key] = counts.get(key, 0) + 1
    stated = last[:32]
    for i, letter in enumerate(b"SGDP"):
        field = stated[8 * i:8 * i + 8]
        if field[:1] != bytes([letter]):
            raise IgesReadError(f"{path}: malformed IGES Terminate record {last[:32].decode('ascii', 'replace')!r}")
        try:
            expected = int(field[1:])
        except ValueError:
            raise IgesReadError(f"{path}: malformed IGES Terminate record "
                                f"{last[:32].decode('ascii', 'replace')!r}") from None
        found = counts.get(bytes([letter]), 0)
        if found != expected:
            raise IgesReadError(f"{path}: truncated IGES file: the Terminate record states {expected} "
                                f"{chr(letter)} records, the file has {found}")
