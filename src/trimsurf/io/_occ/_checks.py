"""Finite-geometry checks on a transferred Open CASCADE shape, before any conversion touches it.

A control point of ``250.E+999`` reads as infinity and makes
``BRepBuilderAPI_NurbsConvert`` spin; coordinates near 1e300 overflow every
distance computed later. `check_shape_geometry` looks at the numbers that
define each face's surface, each edge's 3D curve and p-curves and each
vertex -- control points, weights, knots, placements, radii, offsets -- and
refuses the file, naming the entity, when one is not finite or is above
`MAX_ABS` in magnitude (weights: not in [1 / MAX_ABS, MAX_ABS]).
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np

from ...errors import FileFormatError

__all__ = ["MAX_ABS", "check_file_numbers", "check_shape_geometry", "geometry_numbers"]

#: largest magnitude accepted for a coordinate, knot, radius or offset (model units: 1e10 mm = 10,000 km)
MAX_ABS = 1e10

_RADII = ("Radius", "MajorRadius", "MinorRadius", "RefRadius", "Focal", "Offset")


def _coords(arr) -> np.ndarray:
    return np.array([p.Coord() for p in arr], dtype=np.float64).ravel()


def _reals(arr) -> np.ndarray:
    return np.fromiter(arr, dtype=np.float64, count=arr.Length() if hasattr(arr, "Length") else arr.Size())


def geometry_numbers(geom, depth: int = 0) -> list[tuple[str, np.ndarray]]:
    """The defining numbers of an Open CASCADE curve or surface, as (what, values) pairs.

    Control points, weights, knots, the placement's origin, radii and
    offsets; trimmed, offset and swept geometry adds its basis geometry's.
    """
    out: list[tuple[str, np.ndarray]] = []
    if geom is None or depth > 8:
        return out
    if hasattr(geom, "Poles"):
        out.append(("control point", _coords(geom.Poles())))
        rational = (geom.IsURational() or geom.IsVRational()) if hasattr(geom, "IsURational") else (
            geom.IsRational() if hasattr(geom, "IsRational") else False)
        if rational and hasattr(geom, "WeightsArray"):
            out.append(("weight", _reals(geom.WeightsArray())))
        elif rational and hasattr(geom, "Weights"):
            w = geom.Weights()
            if w is not None and not isinstance(w, (int, float)):
                out.append(("weight", _reals(w)))
    for name in ("Knots", "UKnots", "VKnots"):
        if hasattr(geom, name):
            out.append(("knot", _reals(getattr(geom, name)())))
    if hasattr(geom, "Position"):
        pos = geom.Position()
        if hasattr(pos, "Location"):
            out.append(("placement", np.array(pos.Location().Coord(), dtype=np.float64)))
    elif hasattr(geom, "Location") and hasattr(geom, "BasisCurve"):  # surface of revolution: its axis
        loc = geom.Location()
        if hasattr(loc, "Coord"):
            out.append(("axis", np.array(loc.Coord(), dtype=np.float64)))
    for name in _RADII:
        if hasattr(geom, name):
            try:
                value = getattr(geom, name)()
            except Exception:  # noqa: BLE001 - an accessor that needs arguments
                continue
            if isinstance(value, float):
                out.append((name.lower(), np.array([value])))
    if hasattr(geom, "BasisCurve") and hasattr(geom, "FirstParameter") and geom.DynamicType().Name().endswith(
            "TrimmedCurve"):
        out.append(("trim parameter", np.array([geom.FirstParameter(), geom.LastParameter()])))
    for name in ("BasisSurface", "BasisCurve"):
        if hasattr(geom, name):
            out += geometry_numbers(getattr(geom, name)(), depth + 1)
    return out


def _problem(values: np.ndarray, what: str) -> str | None:
    if values.size == 0:
        return None
    finite = np.isfinite(values)
    if not finite.all():
        return f"{what} with a non-finite value ({float(values[~finite][0])})"
    if what == "weight":
        bad = (values <= 1.0 / MAX_ABS) | (values > MAX_ABS)
        if bad.any():
            return f"{what} {values[bad][0]:.6g} outside [{1.0 / MAX_ABS:.0e}, {MAX_ABS:.0e}]"
        return None
    big = np.abs(values) > MAX_ABS
    if big.any():
        return f"{what} value {values[big][0]:.6g} above {MAX_ABS:.0e} in magnitude"
    return None


def _check(geom, where: str, path, error) -> None:
    for what, values in geometry_numbers(geom):
        problem = _problem(values, what)
        if problem is not None:
            kind = geom.DynamicType().Name()
            raise error(f"{path}: {where}: {kind} has a {problem}")


# where a real literal may exceed MAX_ABS: a non-negative exponent, or 11+ digits before the decimal point
_SUSPECT = re.compile(rb"[EeDd]\+?\d+|\d{11,}\.")
_NUMBER_CHARS = frozenset(b"0123456789.+-")


def check_file_numbers(path: str | os.PathLike, fmt: str, error: type[FileFormatError] = FileFormatError) -> None:
    """Refuse a STEP or IGES file holding a real literal that is not finite or above `MAX_ABS` in magnitude.

    Done on the text before Open CASCADE sees it: its transfer of a
    B-spline with a pole at 1e999 does not come back. STEP: literals outside
    quoted strings; IGES: the parameter data (P) section. The message names
    the line (and the STEP entity).
    """
    data = Path(path).read_bytes()
    for m in _SUSPECT.finditer(data):
        start, stop = m.start(), m.end()
        while start > 0 and data[start - 1] in _NUMBER_CHARS:
            start -= 1
        while stop < len(data) and data[stop] in _NUMBER_CHARS:
            stop += 1
        literal = data[start:stop]
        if start > 0 and (chr(data[start - 1]).isalnum() or data[start - 1] in b"_#$"):
            continue  # part of a name or a reference, not a number
        try:
            value = float(literal.replace(b"D", b"E").replace(b"d", b"e"))
        except ValueError:
            continue
        if math.isfinite(value) and abs(value) <= MAX_ABS:
            continue
        line_start = data.rfind(b"\n", 0, start) + 1
        if fmt == "IGES":
            line_end = data.find(b"\n", start)
            line_text = data[line_start:line_end if line_end >= 0 else len(data)]
            if start - line_start >= 64 or line_text[72:73] != b"P":
                continue
        else:
            statement = data.rfind(b";", 0, start) + 1
            if data.count(b"'", statement, start) % 2:  # inside a quoted string
                continue
        line = data.count(b"\n", 0, start) + 1
        entity = ""
        if fmt != "IGES":
            hash_at = data.rfind(b"\n#", 0, start) + 1
            if hash_at > 0:
                label = data[hash_at:hash_at + 12].split(b"=")[0].strip().decode("ascii", "replace")
                entity = f" ({label})"
        text = literal.decode("ascii", "replace")
        what = "is not finite" if not math.isfinite(value) else f"is above {MAX_ABS:.0e} in magnitude"
        raise error(f"{path}: line {line}{entity}: the number {text} {what}")


def _box_is_sane(shape) -> bool:
    """Fast path: Open CASCADE's bounding box of the shape (from control points, in C++) is finite and within
    `MAX_ABS`. The entity-by-entity check then has nothing to find but weights and knots, which the text
    check (`check_file_numbers`) has bounded already, so it runs only when the box is not sane."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib

    try:
        box = Bnd_Box()
        BRepBndLib.Add_s(shape, box, False)
        if box.IsVoid() or box.IsOpen():
            return False
        lo, hi = box.CornerMin(), box.CornerMax()
        corners = np.array([lo.X(), lo.Y(), lo.Z(), hi.X(), hi.Y(), hi.Z()], dtype=np.float64)
    except Exception:  # noqa: BLE001 - then look entity by entity
        return False
    return bool(np.all(np.isfinite(corners)) and np.all(np.abs(corners) <= MAX_ABS))


def _check_faces_have_surfaces(shape, path, error) -> None:
    """Refuse a face without a surface (a .brep face naming a missing surface: bounding it or converting it
    crashes Open CASCADE), naming the first; faces numbered as `map_topology`."""
    from OCP.BRep import BRep_Tool
    from OCP.collections import (
        IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as ShapeMap,
    )
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS

    faces = ShapeMap()
    TopExp.MapShapes_s(shape, TopAbs_FACE, faces)
    for fi in range(1, faces.Extent() + 1):
        if BRep_Tool.Surface_s(TopoDS.Face(faces.FindKey(fi))) is None:
            raise error(f"{path}: face {fi - 1} has no surface")


def check_shape_geometry(shape, path: str | os.PathLike = "", error: type[FileFormatError] = FileFormatError) -> None:
    """Refuse a shape with non-finite or huge geometry (see the module notes); faces numbered as `map_topology`.

    Every face must have a surface. The shape's bounding box is looked at first (cheap); only when it is not
    finite or not within `MAX_ABS` is every entity looked at, to name it.

    Raises
    ------
    FileFormatError (`error`)
        One line: the file, the face (and edge or vertex), the geometry kind and the bad value.
    """
    _check_faces_have_surfaces(shape, path, error)
    if _box_is_sane(shape):
        return
    from OCP.BRep import BRep_Tool
    from OCP.collections import (
        IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as ShapeMap,
    )
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_VERTEX
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS

    faces = ShapeMap()
    TopExp.MapShapes_s(shape, TopAbs_FACE, faces)
    for fi in range(1, faces.Extent() + 1):
        face = TopoDS.Face(faces.FindKey(fi))
        where = f"face {fi - 1}"
        _check(BRep_Tool.Surface_s(face), where, path, error)
        edges = ShapeMap()
        TopExp.MapShapes_s(face, TopAbs_EDGE, edges)
        for ei in range(1, edges.Extent() + 1):
            edge = TopoDS.Edge(edges.FindKey(ei))
            ewhere = f"{where} edge {ei - 1}"
            pc = BRep_Tool.CurveOnSurface_s(edge, face, 0.0, 0.0)
            _check(pc, f"{ewhere} p-curve", path, error)
            if not BRep_Tool.Degenerated_s(edge):
                _check(BRep_Tool.Curve_s(edge, 0.0, 0.0), ewhere, path, error)
            vertices = ShapeMap()
            TopExp.MapShapes_s(edge, TopAbs_VERTEX, vertices)
            for vi in range(1, vertices.Extent() + 1):
                p = np.array(BRep_Tool.Pnt_s(TopoDS.Vertex(vertices.FindKey(vi))).Coord(), dtype=np.float64)
                problem = _problem(p, "point")
                if problem is not None:
                    raise error(f"{path}: {ewhere} vertex {vi - 1}: {problem}")
