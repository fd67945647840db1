"""Reading files with Open CASCADE quietly, and the whole-shape B-spline conversion."""

from __future__ import annotations

import contextlib
import ctypes
import os
import re
import sys
import tempfile
import warnings
from collections.abc import Iterator
from pathlib import Path

from ...errors import FaceSkippedWarning, FileFormatError, TrimsurfWarning
from .. import check_readable as check_file
from ._checks import check_file_numbers, check_shape_geometry
from ._to_shell import map_topology


def _flush_c_stdio() -> None:
    with contextlib.suppress(Exception):
        ctypes.CDLL(None).fflush(None)


@contextlib.contextmanager
def quiet_occ() -> Iterator[list[str]]:
    """Run a block with fds 1 and 2 redirected into a temporary file.

    Yields a list that, after the block, holds the non-empty lines Open
    CASCADE printed (ANSI colour codes removed).
    """
    lines: list[str] = []
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    _flush_c_stdio()
    saved = [os.dup(1), os.dup(2)]
    with tempfile.TemporaryFile(mode="w+b") as sink:
        os.dup2(sink.fileno(), 1)
        os.dup2(sink.fileno(), 2)
        try:
            yield lines
        finally:
            _flush_c_stdio()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
            sink.seek(0)
            text = sink.read().decode("utf-8", "replace")
            for raw in text.splitlines():
                line = _strip_ansi(raw).strip(" *\t")
                if line:
                    lines.append(line)


_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")


def _strip_ansi(text: str) -> str:
    return _ANSI.sub("", text)


def _occ_detail(lines: list[str]) -> str:
    """The most telling line Open CASCADE printed (an error line if any), shortened."""
    pick = [ln for ln in lines if "ERR" in ln or "Fail" in ln or "rror" in ln] or lines
    if not pick:
        return ""
    text = " ".join(pick[0].split())
    for prefix in ("ERR StepFile : Undefined Parsing:", "ERR StepFile :"):
        if text.startswith(prefix):
            text = text[len(prefix):].strip()
    return text[:160]


# --------------------------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------------------------

def read_shape(path: str | os.PathLike, fmt: str, error: type[FileFormatError]):
    """Read a STEP, IGES or BREP file into an Open CASCADE shape that holds at least one face.

    Parameters
    ----------
    path : str or PathLike
    fmt : {"STEP", "IGES", "BREP"}
    error : FileFormatError subclass
        Raised, with a one-line message naming `path`, when the file is
        missing, empty, unreadable or holds no faces.

    Returns
    -------
    TopoDS_Shape
    """
    from OCP.IFSelect import IFSelect_RetDone

    p = check_file(path, error)
    check_file_numbers(p, fmt, error)
    if fmt == "BREP":
        return _read_brep(p, path, error)
    if fmt == "STEP":
        from OCP.STEPControl import STEPControl_Reader
        reader = STEPControl_Reader()
    else:
        from OCP.IGESControl import IGESControl_Reader
        reader = IGESControl_Reader()
    shape, failure = None, ""
    with quiet_occ() as log:
        try:
            status = reader.ReadFile(str(p))
            if status != IFSelect_RetDone:
                failure = f"status {getattr(status, 'name', status)}"
        except Exception as exc:  # Open CASCADE raises Standard_Failure subclasses
            status, failure = None, f"{type(exc).__name__}: {exc}"
    if status == IFSelect_RetDone:
        _refuse_syntax_errors(reader, log, path, fmt, error)
        # TransferRoots on a failed read crashes the process: only transfer after RetDone
        with quiet_occ() as log:
            try:
                reader.TransferRoots()
                shape = reader.OneShape()
            except Exception as exc:
                failure = f"{type(exc).__name__}: {exc}"
    if shape is None:
        detail = _occ_detail(log) or failure
        raise error(f"{path}: not a readable {fmt} file (truncated or malformed: {detail})")
    if shape.IsNull() or count_faces(shape) == 0:
        raise error(f"{path}: the {fmt} file holds no faces")
    check_shape_geometry(shape, path, error)
    return shape


#: what an ASCII .brep file starts with (``BRepTools::Write``; DRAW's ``save`` adds a DBRep_DrawableShape line)
BREP_MAGIC = b"CASCADE Topology V"


def _read_brep(p: Path, path, error: type[FileFormatError]):
    """An Open CASCADE ASCII .brep file (``BRepTools::Read``) as a shape with faces, checked as STEP is."""
    from OCP.BRep import BRep_Builder
    from OCP.BRepTools import BRepTools
    from OCP.TopoDS import TopoDS_Shape

    with open(p, "rb") as fh:
        head = fh.read(4096)
    if BREP_MAGIC not in head:
        raise error(f"{path}: not an Open CASCADE BREP file (no '{BREP_MAGIC.decode()}' header; binary "
                    "BREP is not supported)")
    shape, ok, failure = TopoDS_Shape(), False, ""
    with quiet_occ() as log:
        try:
            ok = bool(BRepTools.Read_s(shape, str(p), BRep_Builder()))
        except Exception as exc:  # Standard_Failure
            failure = f"{type(exc).__name__}: {exc}"
    if not ok or shape.IsNull():
        detail = _occ_detail(log) or failure or "Open CASCADE read no shape"
        raise error(f"{path}: not a readable BREP file (truncated or malformed: {detail})")
    if count_faces(shape) == 0:
        raise error(f"{path}: the BREP file holds no faces")
    check_shape_geometry(shape, path, error)
    return shape


def _refuse_syntax_errors(reader, log: list[str], path, fmt: str, error: type[FileFormatError]) -> None:
    """Refuse a file whose records Open CASCADE's parser flags as "Incorrect Syntax" (before the transfer).

    The parser reads on past a malformed record, and transferring what it made
    of it can crash the process; a file with such records is refused. The
    message gives the parser's count and the first check failure it recorded.
    """
    flagged = [ln for ln in log if "Incorrect Syntax" in ln]
    if not flagged:
        return
    count = flagged[0].rsplit(":", 1)[-1].strip()
    first = _first_check_failure(reader, path)
    raise error(f"{path}: not a valid {fmt} file: Open CASCADE's reader found {count} record(s) with incorrect "
                f"syntax{': ' + first if first else ''}")


def _first_check_failure(reader, path) -> str:
    """'#N: message' of the check failure most likely to be the syntax error, or ''.

    A failure that says a parameter is "not a" Real/String/... or is undefined
    is preferred over the others (real files carry harmless semantic
    failures, e.g. an si_unit with the wrong parameter count). Entities are
    numbered in file order, so the label is the N-th record's.
    """
    found: list[tuple[int, str]] = []
    try:
        checks = reader.WS().ModelCheckList(False)
        checks.Start()
        while checks.More() and len(found) < 1000:
            check = checks.Value()
            if check.NbFails():
                found.append((checks.Number(), check.CFail(1, True)))
            checks.Next()
    except Exception:  # noqa: BLE001 - the message only
        pass
    if not found:
        return ""
    number, text = next(((n, t) for n, t in found if " not a " in t or "ndefined" in t or "yntax" in t), found[0])
    label = f"entity {number}" if number else ""
    if number:
        with contextlib.suppress(OSError, StopIteration):
            records = re.finditer(rb"(?m)^\s*(#\d+)\s*=", Path(path).read_bytes())
            for _ in range(number - 1):
                next(records)
            label = next(records).group(1).decode()
    return f"{label + ': ' if label else ''}{text}"[:160]


def invalid_faces(shape) -> list[int]:
    """Indices (as in `map_topology`) of the faces ``BRepCheck_Analyzer`` rejects; [] for a valid shape."""
    from OCP.BRepCheck import BRepCheck_Analyzer

    analyzer = BRepCheck_Analyzer(shape)
    if analyzer.IsValid():
        return []
    return [i for i, f in enumerate(map_topology(shape).faces) if not analyzer.IsValid(f)] or [-1]


def count_faces(shape) -> int:
    """Number of distinct faces of an Open CASCADE shape."""
    from OCP.collections import (
        IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as ShapeMap,
    )
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp

    faces = ShapeMap()
    TopExp.MapShapes_s(shape, TopAbs_FACE, faces)
    return faces.Extent()


def nurbs_shape(shape, *, path: str | os.PathLike = "", error: type[FileFormatError] = FileFormatError):
    """The shape with every curve and surface converted to B-splines (``BRepBuilderAPI_NurbsConvert``).

    When the conversion of the whole shape fails (Open CASCADE refuses, e.g.,
    a face that crosses the seam of a periodic B-spline surface: "Knots
    interval values too close"), the faces are converted one by one: a face
    whose own conversion fails is kept as it is when its surface is already a
    B-spline or Bézier surface (`surface_from_occ` handles periodic ones), and
    left out with a `FaceSkippedWarning` otherwise. The faces then no longer
    share their edges (as in an unsewn IGES file); a `TrimsurfWarning` says so.
    """
    from OCP.BRepBuilderAPI import BRepBuilderAPI_NurbsConvert

    failure = ""
    with quiet_occ() as log:
        try:
            converted = BRepBuilderAPI_NurbsConvert(shape, True).Shape()
        except Exception as exc:
            converted, failure = None, f"{type(exc).__name__}: {exc}"
    if converted is None or converted.IsNull():
        detail = _occ_detail(log) or failure
        converted = _nurbs_faces_one_by_one(shape, path, detail)
        if converted is None:
            raise error(f"{path}: Open CASCADE could not convert the shape to B-splines ({detail})")
    return converted


def _nurbs_faces_one_by_one(shape, path, detail: str):
    """A compound of the faces of `shape`, each converted on its own (see `nurbs_shape`); None if none is left."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_NurbsConvert
    from OCP.TopoDS import TopoDS_Compound

    builder = BRep_Builder()
    compound = TopoDS_Compound()
    builder.MakeCompound(compound)
    kept = 0
    for fi, face in enumerate(map_topology(shape).faces):
        with quiet_occ():
            try:
                builder.Add(compound, BRepBuilderAPI_NurbsConvert(face, True).Shape())
                kept += 1
                continue
            except Exception as exc:  # noqa: BLE001 - Standard_Failure
                reason = f"{type(exc).__name__}: {exc}"
            kind = BRep_Tool.Surface_s(face).DynamicType().Name()
        if kind in ("Geom_BSplineSurface", "Geom_BezierSurface"):
            builder.Add(compound, face)
            kept += 1
        else:
            warnings.warn(f"{path}: face {fi} skipped: Open CASCADE could not convert it to a B-spline ({reason})",
                          FaceSkippedWarning, stacklevel=3)
    if not kept:
        return None
    warnings.warn(f"{path}: Open CASCADE could not convert the whole shape to B-splines ({detail}); its faces "
                  "were converted one by one and no longer share edges", TrimsurfWarning, stacklevel=3)
    return compound
