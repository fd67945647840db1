"""Open CASCADE's native ``.brep`` files (``BRepTools::Read`` / ``BRepTools::Write``), read and written like STEP.

`read` returns a `Shell` exactly as the STEP reader does (the shape is
checked for finite geometry, converted with ``BRepBuilderAPI_NurbsConvert``
and copied face by face, see `trimsurf.io._occ`), in the same child process
with a time limit, so a malformed file that crashes Open CASCADE is a
one-line `BrepReadError`. Only the ASCII format is read (what ``BRepTools``
and DRAW's ``save`` write; binary ``.bbrep`` is not). `write` writes the
shape the STEP writer would write (shared edges, sewing of faces without
topology), without triangulations, in Open CASCADE's current ASCII version.
A .brep file carries no units: coordinates are the model's.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from ..errors import BrepReadError, GeometryError
from ..model import Shell, TrimmedFace
from . import _occ
from ._atomic import atomic_path

__all__ = ["read", "write"]


def read_occ_shape(path: str | os.PathLike):
    """The Open CASCADE shape `read` converts: the file's shape after ``BRepBuilderAPI_NurbsConvert``."""
    shape = _occ.read_shape(path, "BREP", BrepReadError)
    return _occ.nurbs_shape(shape, path=path, error=BrepReadError)


def read(path: str | os.PathLike) -> Shell:
    """Read an Open CASCADE ``.brep`` file into a `Shell`.

    Raises
    ------
    BrepReadError
        The file is missing, empty, not an ASCII BREP file, truncated or
        malformed, holds no faces, holds a number that is not finite or above
        1e10 in magnitude, or Open CASCADE crashes or does not finish on it
        (one line naming the file).

    Warns
    -----
    FaceSkippedWarning
        A face that cannot be converted is left out (named in the message).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from trimsurf.samples import build_sample
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "box.brep"
    >>> write(build_sample("bspline_box"), path)
    >>> len(read(path).faces)
    6
    """
    _occ.check_file(path, BrepReadError)
    return _occ.read_isolated(path, "BREP", BrepReadError)


def read_in_process(path: str | os.PathLike) -> Shell:
    """`read` in the calling process (what the child process of `read` runs; crashes are not contained)."""
    return _occ.shape_to_shell(read_occ_shape(path), name=Path(path).name, skip_bad_faces=True)


def write(shell: Shell | TrimmedFace | Sequence[TrimmedFace], path: str | os.PathLike) -> None:
    """Write a `Shell` (or one or several `TrimmedFace`) as an Open CASCADE ASCII ``.brep`` file.

    The shape is the one `trimsurf.io._step.write` writes; the file is
    written to a temporary file and renamed.

    Raises
    ------
    GeometryError
        Open CASCADE could not build or write the shape, or `shell` holds no faces.
    """
    from ._step import shape_for_writing

    shape = shape_for_writing(shell, path)
    with atomic_path(path) as tmp:
        _write_brep_file(shape, tmp, path)


def _write_brep_file(shape, tmp: Path, path) -> None:
    from OCP.BRepTools import BRepTools
    from OCP.TopTools import TopTools_FormatVersion

    failure = ""
    with _occ.quiet_occ() as log:
        try:
            ok = BRepTools.Write_s(shape, str(tmp), False, False, TopTools_FormatVersion.TopTools_FormatVersion_CURRENT)
        except Exception as exc:  # Standard_Failure
            ok, failure = False, f"{type(exc).__name__}: {exc}"
    if not ok:
        detail = _occ._occ_detail(log) or failure
        raise GeometryError(f"{path}: Open CASCADE could not write the BREP file{': ' + detail if detail else ''}")
