"""STEP read and write through Open CASCADE (``cadquery-ocp``).

`read` returns a `Shell` of trimmed NURBS faces with their shared edges (the
conversion and its conventions are described in `trimsurf.io._occ`); `write`
writes a `Shell` (or one face, or a sequence of faces) as a STEP AP214 file in
millimetres that Open CASCADE reads back as a valid shape.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Sequence
from pathlib import Path

from ..errors import GeometryError, StepReadError, TrimsurfWarning
from ..model import Shell, TrimmedFace
from . import _occ
from ._atomic import atomic_path

__all__ = ["read", "write", "shell_from_faces"]

#: Kept for callers: the same as `Shell.from_faces`.
shell_from_faces = Shell.from_faces


def read_occ_shape(path: str | os.PathLike):
    """The Open CASCADE shape `read` converts: the file's shape after ``BRepBuilderAPI_NurbsConvert``."""
    shape = _occ.read_shape(path, "STEP", StepReadError)
    return _occ.nurbs_shape(shape, path=path, error=StepReadError)


def read(path: str | os.PathLike) -> Shell:
    """Read a STEP file into a `Shell`.

    Parameters
    ----------
    path : str or PathLike

    Returns
    -------
    Shell
        One `TrimmedFace` per distinct face of the file (NURBS surface, p-curves
        of every loop, 3D edge curves) and the edges the faces share.

    Raises
    ------
    StepReadError
        The file is missing, empty, truncated or malformed, or holds no faces.
        The message is one line naming the file; Open CASCADE's own output is
        suppressed. Also raised when a record has incorrect syntax, a number
        is not finite or above 1e10 in magnitude, or Open CASCADE crashes or
        does not finish on the file: the read runs in a child process with a
        time limit (`trimsurf.io._occ._isolate`).

    Warns
    -----
    FaceSkippedWarning
        A face that cannot be converted is left out (named in the message);
        the other faces are read.
    """
    _occ.check_file(path, StepReadError)
    return _occ.read_isolated(path, "STEP", StepReadError)


def read_in_process(path: str | os.PathLike) -> Shell:
    """`read` in the calling process (what the child process of `read` runs; crashes are not contained)."""
    return _occ.shape_to_shell(read_occ_shape(path), name=Path(path).name, skip_bad_faces=True)


def write(shell: Shell | TrimmedFace | Sequence[TrimmedFace], path: str | os.PathLike, *,
          sew_tolerance: float | None = None) -> None:
    """Write a `Shell` (or one or several `TrimmedFace`) as a STEP file in millimetres.

    Shared edges of the shell become shared STEP edges, so a closed shell is
    written as a closed solid. Faces without shared-edge topology (a shell
    without edges, e.g. from VDAFS or `Shell.from_faces`) are sewn with
    ``BRepBuilderAPI_Sewing``. The file is written to a temporary file and
    renamed: a failed write leaves no file behind.

    Parameters
    ----------
    shell : Shell, TrimmedFace or sequence of TrimmedFace
    path : str or PathLike
    sew_tolerance : float, optional
        Largest gap (model units) that sewing closes between faces without
        topology; None means 1e-5 of the bounding-box diagonal. Ignored when
        the shell has edges. ``trimsurf.io.write_shell`` always uses the
        default; call this function to set it.

    Warns
    -----
    TrimsurfWarning
        ``BRepCheck_Analyzer`` rejects the built shape (inconsistent input,
        e.g. a self-intersecting trim loop); the file is written anyway.

    Raises
    ------
    GeometryError
        Open CASCADE could not build or write the shape, `shell` holds no
        faces or something else than trimmed faces, or `sew_tolerance` is
        not a positive finite number.
    OSError
        The target folder cannot be created or written.
    """
    shape = shape_for_writing(shell, path, sew_tolerance=sew_tolerance)
    with atomic_path(path) as tmp:
        _write_step_file(shape, tmp, path)


def shape_for_writing(shell: Shell | TrimmedFace | Sequence[TrimmedFace], path: str | os.PathLike = "", *,
                      sew_tolerance: float | None = None, stacklevel: int = 3, action: str = "writing it anyway"):
    """The Open CASCADE shape `write` writes (also written by the BREP writer and `trimsurf.io.to_occ`).

    Raises and warns as `write` does; `path` only names the target in messages.
    """
    if sew_tolerance is not None and (isinstance(sew_tolerance, bool) or not isinstance(sew_tolerance, (int, float))
                                      or not math.isfinite(sew_tolerance) or sew_tolerance <= 0):
        raise GeometryError(f"{path}: sew_tolerance must be a positive finite number or None; got {sew_tolerance!r}")
    if not isinstance(shell, Shell):
        shell = Shell.from_faces(shell, name=Path(path).stem)
    with _occ.quiet_occ():
        try:
            shape = _occ.shell_to_shape(shell, sew_tolerance=None if sew_tolerance is None else float(sew_tolerance))
            bad = _occ.invalid_faces(shape)
        except GeometryError:
            raise
        except Exception as exc:  # Open CASCADE's Standard_Failure
            raise GeometryError(f"{path}: Open CASCADE could not build the shape: "
                                f"{type(exc).__name__}: {exc}") from None
    if bad:
        where = "the shape" if bad == [-1] else f"{len(bad)} face(s)"
        warnings.warn(f"{path}: BRepCheck_Analyzer rejects {where} of the built shape (inconsistent input "
                      f"faces, e.g. self-intersecting trim loops); {action}", TrimsurfWarning, stacklevel=stacklevel)
    return shape


def _write_step_file(shape, tmp: Path, path) -> None:
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.Interface import Interface_Static
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    with _occ.quiet_occ() as log:
        Interface_Static.SetCVal_s("write.step.unit", "MM")
        Interface_Static.SetCVal_s("write.step.schema", "AP214IS")
        writer = STEPControl_Writer()
        transferred = writer.Transfer(shape, STEPControl_AsIs)
        status = writer.Write(str(tmp)) if transferred == IFSelect_RetDone else transferred
    if status != IFSelect_RetDone:
        detail = _occ._occ_detail(log)
        raise GeometryError(f"{path}: Open CASCADE could not write the STEP file "
                            f"({getattr(status, 'name', status)}{': ' + detail if detail else ''})")
