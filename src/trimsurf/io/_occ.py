"""Open CASCADE shapes <-> trimsurf models, shared by the STEP and IGES readers and the STEP writer.

Reading
-------
A file is read with Open CASCADE's reader, the whole shape is converted with
``BRepBuilderAPI_NurbsConvert`` (so every surface and its p-curves become
B-splines with one consistent parameterization: analytic surfaces get Open
CASCADE's own conversion) and every face becomes a `TrimmedFace`:

* surface: the face's ``Geom_BSplineSurface`` (location applied), knots with
  their multiplicities expanded, periodic directions made non-periodic;
* loops: ``BRepTools_WireExplorer`` over the wires of the face taken FORWARD,
  outer wire (``BRepTools::OuterWire``) first, holes after. Open CASCADE keeps
  the material on the left of a FORWARD face's wires in (u, v), so outer loops
  come out counter-clockwise and holes clockwise for every face; the face's
  own orientation goes to ``TrimmedFace.same_sense`` (REVERSED -> False: the
  outward normal is -(Su x Sv));
* segments: one `PCurve` per oriented edge, ``t0, t1`` the edge range, swapped
  (t0 > t1) for a REVERSED edge; ``edge_curve`` the edge's 3D B-spline b(t) on
  the same parameter; ``edge_id`` the index in ``Shell.edges``. A seam edge is
  used twice by its face, once per orientation, each with its own p-curve.

Conventions decided here (measured on ``../shared/data/cad``):

* Domain coverage. Open CASCADE evaluates a non-periodic B-spline outside its
  knot range by continuing the end polynomials, and p-curves of real files
  leave the domain (up to 1.5 % of it on gmsh__SampleCrankshaft4A, 0.7 % on
  occt__bearing.iges). trimsurf clamps instead, so where a face's p-curves or
  UV bounds leave the surface domain the end span is extended exactly: knot
  ``a`` before the end is raised to multiplicity p (Open CASCADE knot
  insertion) and the end span's Bézier points are continued by de Casteljau
  extrapolation in homogeneous coordinates. The surface is the same
  (rational) polynomial on a larger domain, with a margin of 1e-6 of the
  domain beyond the farthest sampled p-curve point.
* Periodic seam. A periodic direction is made non-periodic with
  ``SetUNotPeriodic``/``SetVNotPeriodic``, which keeps the knot span
  [k0, k0 + T]. When a face's (u, v) range leaves that span (a face crossing
  the seam), a knot is inserted at the face's lower bound (shifted by whole
  periods into the span), made the origin with ``SetUOrigin``/``SetVOrigin``,
  and the knot vector is translated by the whole periods, so the surface
  domain is [lower bound, lower bound + T] and the p-curves stay as they are.
  None of the faces of the shared data needs it; the tests build one.
* Edge tolerance. ``Edge.tolerance`` is Open CASCADE's tolerance, raised to
  the same-parameter deviation max |S(p(t)) - b(t)| measured by
  ``BRepLib_ValidateEdge`` (47 points per edge and face) where the file's
  curves disagree by more than they state, as ``BRepLib::SameParameter``
  would. gmsh__t20_data (26 of 48 edges, up to 5e-5 of the diagonal) and
  occt__linkrods (8 of 108) need it most: their p-curves lie on the 3D curves
  geometrically but with another parameterization; occtpr946__ec_soapbox-A,
  occtpr946__trj5_k1-pe-214, occtpr946__bug27693_cornetta and
  occt__bearing have a few edges raised by less than 4x.
* Domain extension happens on 279 faces of the shared data, most by tiny
  amounts; it is refused when the extrapolated weights of a rational surface
  would not stay positive (the domain is then kept and evaluation outside it
  clamps), which no face of the shared data needs.

Open CASCADE prints to stdout/stderr on bad files; every call into it here
runs with file descriptors 1 and 2 redirected into a temporary file (the text
is used for the one-line error message). The redirection is process-wide, so
do not read CAD files from several threads at once.
"""

from __future__ import annotations

import contextlib
import ctypes
import math
import os
import re
import sys
import tempfile
from collections.abc import Iterator, Sequence
from typing import NamedTuple

import numpy as np

from ..errors import FileFormatError, GeometryError
from ..model import Edge, Loop, NurbsCurve, NurbsSurface, PCurve, Shell, TrimmedFace
from . import check_readable as check_file

__all__ = ["quiet_occ", "read_shape", "nurbs_shape", "map_topology", "OccTopology", "shape_to_shell",
           "shell_to_shape", "count_faces", "curve_from_occ", "curve_to_occ",
           "surface_from_occ", "surface_to_occ", "check_file", "invalid_faces"]

# relative parametric slack below which a p-curve outside the surface domain is left to clamping
# (the 3D error is then < 1e-12 of the surface's extent)
_REL_PARAM_EPS = 1e-12
# relative margin added when the domain is extended, so points sampled between p-curve samples stay inside
_REL_EXTEND_MARGIN = 1e-6
# p-curve samples per segment when measuring the (u, v) range a face uses
_RANGE_SAMPLES = 65
# control points per edge for the same-parameter deviation (Open CASCADE's BRepCheck uses 23)
_VALIDATE_POINTS = 47


# --------------------------------------------------------------------------------------------------------------
# quiet calls
# --------------------------------------------------------------------------------------------------------------

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
    """Read a STEP or IGES file into an Open CASCADE shape that holds at least one face.

    Parameters
    ----------
    path : str or PathLike
    fmt : {"STEP", "IGES"}
    error : FileFormatError subclass
        Raised, with a one-line message naming `path`, when the file is
        missing, empty, unreadable or holds no faces.

    Returns
    -------
    TopoDS_Shape
    """
    from OCP.IFSelect import IFSelect_RetDone

    p = check_file(path, error)
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
            # TransferRoots on a failed read crashes the process: only transfer after RetDone
            if status == IFSelect_RetDone:
                reader.TransferRoots()
                shape = reader.OneShape()
            else:
                failure = f"status {getattr(status, 'name', status)}"
        except Exception as exc:  # Open CASCADE raises Standard_Failure subclasses
            failure = f"{type(exc).__name__}: {exc}"
    if shape is None:
        detail = _occ_detail(log) or failure
        raise error(f"{path}: not a readable {fmt} file (truncated or malformed: {detail})")
    if shape.IsNull() or count_faces(shape) == 0:
        raise error(f"{path}: the {fmt} file holds no faces")
    return shape


def invalid_faces(shape) -> list[int]:
    """Indices (as in `map_topology`) of the faces ``BRepCheck_Analyzer`` rejects; [] for a valid shape."""
    from OCP.BRepCheck import BRepCheck_Analyzer

    analyzer = BRepCheck_Analyzer(shape)
    if analyzer.IsValid():
        return []
    return [i for i, f in enumerate(map_topology(shape).faces) if not analyzer.IsValid(f)] or [-1]


def count_faces(shape) -> int:
    """Number of distinct faces of an Open CASCADE shape."""
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.collections import IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as ShapeMap

    faces = ShapeMap()
    TopExp.MapShapes_s(shape, TopAbs_FACE, faces)
    return faces.Extent()


def nurbs_shape(shape, *, path: str | os.PathLike = "", error: type[FileFormatError] = FileFormatError):
    """The shape with every curve and surface converted to B-splines (``BRepBuilderAPI_NurbsConvert``)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_NurbsConvert

    failure = ""
    with quiet_occ() as log:
        try:
            converted = BRepBuilderAPI_NurbsConvert(shape, True).Shape()
        except Exception as exc:
            converted, failure = None, f"{type(exc).__name__}: {exc}"
    if converted is None or converted.IsNull():
        detail = _occ_detail(log) or failure
        raise error(f"{path}: Open CASCADE could not convert the shape to B-splines ({detail})")
    return converted


# --------------------------------------------------------------------------------------------------------------
# OCC arrays -> numpy
# --------------------------------------------------------------------------------------------------------------

def _reals(arr) -> np.ndarray:
    return np.fromiter(arr, dtype=np.float64, count=arr.Length())


def _points2(arr) -> np.ndarray:
    """Array2_gp_Pnt (rows along u) -> (nu, nv, 3)."""
    pts = np.array([p.Coord() for p in arr], dtype=np.float64)
    return pts.reshape(arr.NbRows(), arr.NbColumns(), 3)


def _points1(arr, dim: int) -> np.ndarray:
    """Array1_gp_Pnt or Array1_gp_Pnt2d -> (n, dim)."""
    return np.array([p.Coord() for p in arr], dtype=np.float64).reshape(-1, dim)


def _homogeneous(points: np.ndarray, weights: np.ndarray | None) -> np.ndarray:
    w = np.ones(points.shape[:-1]) if weights is None else weights
    return np.concatenate([points * w[..., None], w[..., None]], axis=-1)


def _cartesian(pw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    w = pw[..., -1]
    return pw[..., :-1] / w[..., None], w


# --------------------------------------------------------------------------------------------------------------
# curves
# --------------------------------------------------------------------------------------------------------------

def _curve_to_bspline(curve, first: float, last: float, dim: int):
    """A B-spline copy of an Open CASCADE curve (a B-spline already after NurbsConvert)."""
    if curve.DynamicType().Name() in ("Geom_BSplineCurve", "Geom2d_BSplineCurve"):
        return curve.Copy()
    if dim == 3:
        from OCP.Geom import Geom_TrimmedCurve
        from OCP.GeomConvert import GeomConvert
        return GeomConvert.CurveToBSplineCurve_s(Geom_TrimmedCurve(curve, first, last))
    from OCP.Geom2d import Geom2d_TrimmedCurve
    from OCP.Geom2dConvert import Geom2dConvert
    return Geom2dConvert.CurveToBSplineCurve_s(Geom2d_TrimmedCurve(curve, first, last))


def _is_clamped(flat_knots: np.ndarray, degree: int) -> bool:
    return bool(np.all(flat_knots[:degree + 1] == flat_knots[0]) and np.all(flat_knots[-degree - 1:] == flat_knots[-1]))


def _knot_index(values: np.ndarray, x: float, tol: float) -> int | None:
    hit = np.flatnonzero(np.abs(values - x) <= tol)
    return int(hit[0]) + 1 if hit.size else None


def curve_from_occ(curve, first: float, last: float, dim: int) -> NurbsCurve:
    """Convert an Open CASCADE (2D or 3D) curve to a `NurbsCurve` whose domain holds [first, last].

    A periodic B-spline is made non-periodic; when [first, last] leaves its
    knot span the origin is moved (knot insertion + ``SetOrigin``) and the
    knots are translated by whole periods, so the parameterization is kept.
    """
    bs = _curve_to_bspline(curve, first, last, dim)
    lo, hi = min(first, last), max(first, last)
    shift = 0.0
    if bs.IsPeriodic():
        c0, c1 = bs.FirstParameter(), bs.LastParameter()
        period = c1 - c0
        eps = _REL_PARAM_EPS * period
        if (lo < c0 - eps or hi > c1 + eps) and hi - lo <= period * (1 + 1e-9):
            k = math.floor((lo - c0) / period)
            start = lo - k * period
            shift = k * period
            bs.InsertKnot(start, 1, eps, False)
            index = _knot_index(_reals(bs.Knots()), start, eps)
            if index is not None:
                bs.SetOrigin(index)
            else:  # pragma: no cover - insertion always leaves the knot
                shift = 0.0
        bs.SetNotPeriodic()
    if not _is_clamped(_reals(bs.KnotSequence()), bs.Degree()):
        bs.Segment(bs.FirstParameter(), bs.LastParameter())
    knots = _reals(bs.KnotSequence()) + shift
    poles = _points1(bs.Poles(), dim)
    weights = _reals(bs.WeightsArray()) if bs.IsRational() else None
    return NurbsCurve(bs.Degree(), knots, poles, weights)


def curve_to_occ(curve: NurbsCurve):
    """A ``Geom_BSplineCurve`` or ``Geom2d_BSplineCurve`` of a `NurbsCurve`."""
    from OCP.collections import Array1_gp_Pnt, Array1_gp_Pnt2d, Array1_int
    from OCP.gp import gp_Pnt, gp_Pnt2d

    values, mults = _compress_knots(curve.knots)
    knots_a = _array1_double(values)
    mults_a = Array1_int(1, len(mults))
    for i, m in enumerate(mults, start=1):
        mults_a.SetValue(i, int(m))
    n = curve.n_control_points
    if curve.dim == 3:
        from OCP.Geom import Geom_BSplineCurve
        poles = Array1_gp_Pnt(1, n)
        for i, (x, y, z) in enumerate(curve.control_points.tolist(), start=1):
            poles.SetValue(i, gp_Pnt(x, y, z))
        cls = Geom_BSplineCurve
    else:
        from OCP.Geom2d import Geom2d_BSplineCurve
        poles = Array1_gp_Pnt2d(1, n)
        for i, (x, y) in enumerate(curve.control_points.tolist(), start=1):
            poles.SetValue(i, gp_Pnt2d(x, y))
        cls = Geom2d_BSplineCurve
    if curve.weights is None:
        return cls(poles, knots_a, mults_a, curve.degree)
    return cls(poles, _array1_double(curve.weights), knots_a, mults_a, curve.degree)


def _array1_double(values) -> object:
    from OCP.collections import Array1_double
    values = np.asarray(values, dtype=np.float64).ravel()
    arr = Array1_double(1, len(values))
    for i, x in enumerate(values.tolist(), start=1):
        arr.SetValue(i, x)
    return arr


def _compress_knots(knots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    values, counts = np.unique(np.asarray(knots), return_counts=True)
    return values, counts


# --------------------------------------------------------------------------------------------------------------
# surfaces
# --------------------------------------------------------------------------------------------------------------

def _make_nonperiodic(bs, direction: str, lo: float, hi: float) -> float:
    """Make one direction of a periodic Geom_BSplineSurface non-periodic; return the knot translation."""
    first, last = bs.Bounds()[0:2] if direction == "u" else bs.Bounds()[2:4]
    period = last - first
    eps = _REL_PARAM_EPS * period
    shift = 0.0
    if (lo < first - eps or hi > last + eps) and hi - lo <= period * (1 + 1e-9):
        k = math.floor((lo - first) / period)
        start = lo - k * period
        shift = k * period
        if direction == "u":
            bs.InsertUKnot(start, 1, eps, False)
            index = _knot_index(_reals(bs.UKnots()), start, eps)
            if index is not None:
                bs.SetUOrigin(index)
        else:
            bs.InsertVKnot(start, 1, eps, False)
            index = _knot_index(_reals(bs.VKnots()), start, eps)
            if index is not None:
                bs.SetVOrigin(index)
        if index is None:  # pragma: no cover - insertion always leaves the knot
            shift = 0.0
    if direction == "u":
        bs.SetUNotPeriodic()
    else:
        bs.SetVNotPeriodic()
    return shift


def _bezier_end_multiplicity(bs, direction: str, at_end: bool) -> None:
    """Raise the knot next to one end to multiplicity `degree`, so the end span's poles are its Bézier points."""
    if direction == "u":
        n, deg = bs.NbUKnots(), bs.UDegree()
        if n > 2:
            i = n - 1 if at_end else 2
            bs.InsertUKnot(bs.UKnot(i), deg, 0.0, False)
    else:
        n, deg = bs.NbVKnots(), bs.VDegree()
        if n > 2:
            i = n - 1 if at_end else 2
            bs.InsertVKnot(bs.VKnot(i), deg, 0.0, False)


def _extend_end(knots: np.ndarray, pw: np.ndarray, degree: int, target: float) -> tuple[np.ndarray, np.ndarray]:
    """Continue the last span's polynomial to `target` > knots[-1] (exact, homogeneous, along axis 0).

    Requires the last p + 1 control points to be the end span's Bézier points
    (the knot before the end of multiplicity >= p). The span [a, b] becomes
    [a, target]: its Bézier points are the left half of the de Casteljau
    subdivision at s = (target - a) / (b - a) > 1.
    """
    p = degree
    b = knots[-1]
    a = knots[-p - 2]
    s = (target - a) / (b - a)
    q = pw[-p - 1:].copy()
    new = [q[0].copy()]
    for _ in range(p):
        q = (1.0 - s) * q[:-1] + s * q[1:]
        new.append(q[0].copy())
    out = pw.copy()
    out[-p - 1:] = np.stack(new)
    k = knots.copy()
    k[-p - 1:] = target
    return k, out


def _extend(knots: np.ndarray, pw: np.ndarray, degree: int, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Extend a clamped direction (axis 0 of `pw`) so its domain holds [lo, hi]."""
    d0, d1 = knots[degree], knots[-degree - 1]
    margin = _REL_EXTEND_MARGIN * (d1 - d0)
    if hi > d1:
        knots, pw = _extend_end(knots, pw, degree, hi + margin)
    if lo < d0:
        rk, rp = _extend_end(-knots[::-1], pw[::-1], degree, -(lo - margin))
        knots, pw = -rk[::-1], rp[::-1]
    return knots, pw


def surface_from_occ(surface, uv_lo: np.ndarray, uv_hi: np.ndarray) -> NurbsSurface:
    """Convert an Open CASCADE surface to a `NurbsSurface` whose domain holds the box [uv_lo, uv_hi].

    See the module notes for the periodic-seam and domain-extension conventions.
    """
    if surface.DynamicType().Name() == "Geom_BSplineSurface":
        bs = surface.Copy()
    else:
        from OCP.GeomConvert import GeomConvert
        bs = GeomConvert.SurfaceToBSplineSurface_s(surface)
    shifts = [0.0, 0.0]
    periodic = [bs.IsUPeriodic(), bs.IsVPeriodic()]
    for axis, direction in enumerate("uv"):
        if periodic[axis]:
            shifts[axis] = _make_nonperiodic(bs, direction, float(uv_lo[axis]), float(uv_hi[axis]))
    if not (_is_clamped(_reals(bs.UKnotSequence()), bs.UDegree())
            and _is_clamped(_reals(bs.VKnotSequence()), bs.VDegree())):
        bs.Segment(*bs.Bounds())  # clamp: end knots of multiplicity degree + 1, same surface
    # which ends need an extension (non-periodic directions only)
    u0, u1, v0, v1 = bs.Bounds()
    bounds = ((u0 + shifts[0], u1 + shifts[0]), (v0 + shifts[1], v1 + shifts[1]))
    ends = []
    for axis, direction in enumerate("uv"):
        d0, d1 = bounds[axis]
        eps = _REL_PARAM_EPS * (d1 - d0)
        need_lo = not periodic[axis] and uv_lo[axis] < d0 - eps
        need_hi = not periodic[axis] and uv_hi[axis] > d1 + eps
        ends.append((need_lo, need_hi))
        if need_lo:
            _bezier_end_multiplicity(bs, direction, at_end=False)
        if need_hi:
            _bezier_end_multiplicity(bs, direction, at_end=True)
    poles = _points2(bs.Poles())
    weights = None
    if bs.IsURational() or bs.IsVRational():
        w = bs.WeightsArray()
        weights = np.fromiter(w, dtype=np.float64, count=w.Size()).reshape(w.NbRows(), w.NbColumns())
    ku = _reals(bs.UKnotSequence()) + shifts[0]
    kv = _reals(bs.VKnotSequence()) + shifts[1]
    pu, pv = bs.UDegree(), bs.VDegree()
    if any(a or b for a, b in ends):
        pw = _homogeneous(poles, weights)
        lo_u = min(float(uv_lo[0]), ku[pu]) if ends[0][0] else ku[pu]
        hi_u = max(float(uv_hi[0]), ku[-pu - 1]) if ends[0][1] else ku[-pu - 1]
        nku, npw = _extend(ku, pw, pu, lo_u, hi_u)
        lo_v = min(float(uv_lo[1]), kv[pv]) if ends[1][0] else kv[pv]
        hi_v = max(float(uv_hi[1]), kv[-pv - 1]) if ends[1][1] else kv[-pv - 1]
        nkv, npw_t = _extend(kv, np.swapaxes(npw, 0, 1), pv, lo_v, hi_v)
        npw = np.swapaxes(npw_t, 0, 1)
        if np.all(npw[..., -1] > 0):
            ku, kv = nku, nkv
            poles, w = _cartesian(npw)
            weights = None if weights is None else w
    return NurbsSurface(pu, pv, ku, kv, poles, weights)


def surface_to_occ(surface: NurbsSurface):
    """A ``Geom_BSplineSurface`` of a `NurbsSurface`."""
    from OCP.Geom import Geom_BSplineSurface
    from OCP.collections import Array1_int, Array2_double, Array2_gp_Pnt
    from OCP.gp import gp_Pnt

    nu, nv = surface.shape
    poles = Array2_gp_Pnt(1, nu, 1, nv)
    cp = surface.control_points.tolist()
    for i in range(nu):
        row = cp[i]
        for j in range(nv):
            x, y, z = row[j]
            poles.SetValue(i + 1, j + 1, gp_Pnt(x, y, z))
    args = []
    for knots in (surface.knots_u, surface.knots_v):
        values, mults = _compress_knots(knots)
        m = Array1_int(1, len(mults))
        for i, k in enumerate(mults.tolist(), start=1):
            m.SetValue(i, int(k))
        args.append((_array1_double(values), m))
    (uk, um), (vk, vm) = args
    if surface.weights is None:
        return Geom_BSplineSurface(poles, uk, vk, um, vm, surface.degree_u, surface.degree_v)
    w = Array2_double(1, nu, 1, nv)
    wl = surface.weights.tolist()
    for i in range(nu):
        for j in range(nv):
            w.SetValue(i + 1, j + 1, wl[i][j])
    return Geom_BSplineSurface(poles, w, uk, vk, um, vm, surface.degree_u, surface.degree_v)


# --------------------------------------------------------------------------------------------------------------
# shape -> Shell
# --------------------------------------------------------------------------------------------------------------

def _wires_outer_first(face) -> list:
    from OCP.BRepTools import BRepTools
    from OCP.TopAbs import TopAbs_WIRE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    wires = []
    ex = TopExp_Explorer(face, TopAbs_WIRE)
    while ex.More():
        wires.append(TopoDS.Wire(ex.Current()))
        ex.Next()
    if len(wires) > 1:
        outer = BRepTools.OuterWire_s(face)
        if not outer.IsNull():
            wires.sort(key=lambda w: not w.IsSame(outer))
    return wires


def _wire_edges(wire, face) -> list:
    """Edges of a wire in connection order, oriented as used (BRepTools_WireExplorer; falls back to storage order)."""
    from OCP.BRepTools import BRepTools_WireExplorer
    from OCP.TopoDS import TopoDS, TopoDS_Iterator

    edges = []
    wex = BRepTools_WireExplorer(wire, face)
    while wex.More():
        edges.append(TopoDS.Edge(wex.Current()))
        wex.Next()
    stored = []
    it = TopoDS_Iterator(wire)
    while it.More():
        stored.append(TopoDS.Edge(it.Value()))
        it.Next()
    return edges if len(edges) == len(stored) else stored


def _segment_uv_range(curves: Sequence[PCurve]) -> tuple[np.ndarray, np.ndarray]:
    pts = [c.curve.evaluate(np.linspace(c.t0, c.t1, _RANGE_SAMPLES)) for c in curves]
    allp = np.concatenate(pts, axis=0)
    return allp.min(axis=0), allp.max(axis=0)


def _same_parameter_deviation(edge, face) -> float:
    """max |S(p(t)) - C(t)| of an edge on a face, by Open CASCADE's BRepLib_ValidateEdge."""
    from OCP.Adaptor3d import Adaptor3d_CurveOnSurface
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.BRepLib import BRepLib_ValidateEdge
    from OCP.Geom2dAdaptor import Geom2dAdaptor_Curve
    from OCP.GeomAdaptor import GeomAdaptor_Surface

    pc = BRep_Tool.CurveOnSurface_s(edge, face, 0.0, 0.0)
    if pc is None:
        return 0.0
    a, b = BRep_Tool.Range_s(edge, face)
    cos = Adaptor3d_CurveOnSurface(Geom2dAdaptor_Curve(pc, a, b), GeomAdaptor_Surface(BRep_Tool.Surface_s(face)))
    check = BRepLib_ValidateEdge(BRepAdaptor_Curve(edge), cos, True)
    check.SetControlPointsNumber(_VALIDATE_POINTS)
    check.Process()
    return float(check.GetMaxDistance()) if check.IsDone() else 0.0


class OccTopology(NamedTuple):
    """The Open CASCADE entities behind a converted `Shell`, index for index.

    faces : list of TopoDS_Face, oriented as in the shape (``Shell.faces[i]``)
    loops : per face, per loop, the oriented TopoDS_Edge of each segment, as met by
        ``BRepTools_WireExplorer`` on the FORWARD face (``Shell.faces[i].loops[j].segments[k]``)
    edges : list of TopoDS_Edge, FORWARD (``Shell.edges[e]``)
    vertices : list of TopoDS_Vertex (``Shell.vertices[v]``)
    """

    faces: list
    loops: list
    edges: list
    vertices: list


def map_topology(shape) -> OccTopology:
    """Number the faces, loops, edges and vertices of a shape the way `shape_to_shell` does.

    Faces come in the order of ``TopExp::MapShapes`` (a face shared by two
    solids appears once); edges and vertices in the order the faces' loops
    first meet them.
    """
    from OCP.TopAbs import TopAbs_FACE, TopAbs_FORWARD
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS
    from OCP.collections import IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as ShapeMap

    fmap, emap, vmap = ShapeMap(), ShapeMap(), ShapeMap()
    TopExp.MapShapes_s(shape, TopAbs_FACE, fmap)
    faces, loops = [], []
    for fi in range(1, fmap.Extent() + 1):
        face = TopoDS.Face(fmap.FindKey(fi))
        fwd = TopoDS.Face(face.Oriented(TopAbs_FORWARD))
        face_loops = []
        for wire in _wires_outer_first(fwd):
            edges = _wire_edges(wire, fwd)
            for edge in edges:
                emap.Add(edge)
            if edges:
                face_loops.append(edges)
        faces.append(face)
        loops.append(face_loops)
    edges = []
    for ei in range(1, emap.Extent() + 1):
        edge = TopoDS.Edge(emap.FindKey(ei).Oriented(TopAbs_FORWARD))
        edges.append(edge)
        for v in (TopExp.FirstVertex_s(edge), TopExp.LastVertex_s(edge)):
            if not v.IsNull():
                vmap.Add(v)
    vertices = [TopoDS.Vertex(vmap.FindKey(i)) for i in range(1, vmap.Extent() + 1)]
    return OccTopology(faces, loops, edges, vertices)


def shape_to_shell(shape, *, name: str = "") -> Shell:
    """Convert a NurbsConvert-ed Open CASCADE shape into a `Shell` (see the module notes).

    Entities are numbered as by `map_topology`.
    """
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS
    from OCP.collections import IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as ShapeMap

    topo = map_topology(shape)
    emap, vmap = ShapeMap(), ShapeMap()
    for e in topo.edges:
        emap.Add(e)
    for v in topo.vertices:
        vmap.Add(v)
    edge_curves = [_edge_curve(e) for e in topo.edges]
    edge_uses: list[list[tuple[int, int, int]]] = [[] for _ in topo.edges]
    edge_dev = [0.0] * len(topo.edges)
    faces: list[TrimmedFace] = []
    for fi, (face, face_loops) in enumerate(zip(topo.faces, topo.loops)):
        same_sense = face.Orientation() != TopAbs_REVERSED
        fwd = TopoDS.Face(face.Oriented(TopAbs_FORWARD))
        loops_raw: list[list[tuple[NurbsCurve, float, float, int]]] = []
        for li, edges in enumerate(face_loops):
            segs = []
            for si, edge in enumerate(edges):
                ei = emap.FindIndex(edge) - 1
                pc = BRep_Tool.CurveOnSurface_s(edge, fwd, 0.0, 0.0)
                if pc is None:
                    raise GeometryError(f"{name}: face {fi} edge {ei} has no p-curve")
                a, b = BRep_Tool.Range_s(edge, fwd)
                t0, t1 = (b, a) if edge.Orientation() == TopAbs_REVERSED else (a, b)
                if edge_curves[ei] is not None:
                    edge_dev[ei] = max(edge_dev[ei], _same_parameter_deviation(edge, fwd))
                edge_uses[ei].append((fi, li, si))
                segs.append((curve_from_occ(pc, a, b, 2), t0, t1, ei))
            loops_raw.append(segs)
        u0, u1, v0, v1 = _uv_bounds(fwd)
        lo, hi = np.array([u0, v0]), np.array([u1, v1])
        all_segs = [PCurve(c, t0, t1) for segs in loops_raw for c, t0, t1, _ in segs]
        if all_segs:
            slo, shi = _segment_uv_range(all_segs)
            lo, hi = np.minimum(lo, slo), np.maximum(hi, shi)
        surface = surface_from_occ(BRep_Tool.Surface_s(fwd), lo, hi)
        loops = tuple(Loop(tuple(PCurve(c, t0, t1, edge_curves[ei], ei) for c, t0, t1, ei in segs))
                      for segs in loops_raw)
        faces.append(TrimmedFace(surface, loops, same_sense=same_sense, name=f"{name} face {fi}".strip(),
                                 tolerance=BRep_Tool.Tolerance_s(fwd)))
    edges = []
    for ei, edge in enumerate(topo.edges):
        first, last = TopExp.FirstVertex_s(edge), TopExp.LastVertex_s(edge)
        vids = tuple(vmap.FindIndex(v) - 1 if not v.IsNull() else -1 for v in (first, last))
        t0, t1 = BRep_Tool.Range_s(edge)
        tol = max(BRep_Tool.Tolerance_s(edge), edge_dev[ei])
        edges.append(Edge(edge_curves[ei], t0, t1, vids, tuple(edge_uses[ei]), tolerance=tol,
                          is_degenerate=BRep_Tool.Degenerated_s(edge)))
    vertices = np.array([_vertex_point(v) for v in topo.vertices], dtype=np.float64).reshape(-1, 3)
    return Shell(tuple(faces), tuple(edges), vertices, name=name)


def _uv_bounds(face) -> tuple[float, float, float, float]:
    from OCP.BRepTools import BRepTools
    return BRepTools.UVBounds_s(face)


def _vertex_point(vertex) -> tuple[float, float, float]:
    from OCP.BRep import BRep_Tool
    p = BRep_Tool.Pnt_s(vertex)
    return p.X(), p.Y(), p.Z()


def _edge_curve(edge) -> NurbsCurve | None:
    from OCP.BRep import BRep_Tool
    if BRep_Tool.Degenerated_s(edge):
        return None
    curve = BRep_Tool.Curve_s(edge, 0.0, 0.0)
    if curve is None:
        return None
    a, b = BRep_Tool.Range_s(edge)
    return curve_from_occ(curve, a, b, 3)


# --------------------------------------------------------------------------------------------------------------
# Shell -> shape
# --------------------------------------------------------------------------------------------------------------

def shell_to_shape(shell: Shell, *, sew_tolerance: float | None = None):
    """Build an Open CASCADE shape from a `Shell`, sharing its edges, fixed with ShapeFix_Shape.

    With ``shell.edges`` the faces share one TopoDS_Edge per `Edge` (p-curves
    of both faces on it, two for a seam), so a closed shell stays closed.
    Without topology every loop segment gets its own edge (3D curve from
    ``edge_curve`` or ``BRepLib::BuildCurves3d``) and several faces are sewn
    with ``BRepBuilderAPI_Sewing`` (`sew_tolerance`, default 1e-5 of the
    bounding-box diagonal).

    Returns
    -------
    TopoDS_Shape
        A shell (a solid when the shell is closed), or a compound of the
        sewn pieces.
    """
    from OCP.BRep import BRep_Builder
    from OCP.BRepLib import BRepLib
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopoDS import TopoDS_Compound, TopoDS_Face, TopoDS_Shell, TopoDS_Vertex, TopoDS_Wire
    from OCP.gp import gp_Pnt

    if not shell.faces:
        raise GeometryError(f"{shell.name or 'shell'}: nothing to write, the shell has no faces")
    builder = BRep_Builder()
    occ_faces = []
    surfaces = []
    for fi, face in enumerate(shell.faces):
        surf = surface_to_occ(face.surface)
        f = TopoDS_Face()
        builder.MakeFace(f, surf, max(face.tolerance, 1e-7))
        surfaces.append(surf)
        occ_faces.append(f)

    def vertex(point, tol) -> TopoDS_Vertex:
        v = TopoDS_Vertex()
        builder.MakeVertex(v, gp_Pnt(*map(float, point)), float(tol))
        return v

    use_topology = shell.has_topology and _topology_complete(shell)
    if use_topology:
        occ_vertices = [vertex(p, 1e-7) for p in shell.vertices]
        occ_edges = []
        for ei, e in enumerate(shell.edges):
            occ_edges.append(_make_edge(builder, e, shell, occ_vertices, occ_faces, ei))
        edge_of = {}
        for ei, e in enumerate(shell.edges):
            for use in e.uses:
                edge_of[use] = ei
    for fi, face in enumerate(shell.faces):
        f = occ_faces[fi]
        if not face.loops:
            _natural_bounds(builder, f, surfaces[fi], face)
        for li, loop in enumerate(face.loops):
            wire = TopoDS_Wire()
            builder.MakeWire(wire)
            if use_topology:
                for si, seg in enumerate(loop.segments):
                    edge = occ_edges[edge_of[(fi, li, si)]]
                    builder.Add(wire, edge.Oriented(TopAbs_REVERSED if seg.t0 > seg.t1 else TopAbs_FORWARD))
            else:
                for edge in _loop_edges(builder, loop, f, surfaces[fi], face, vertex):
                    builder.Add(wire, edge)
            wire.Closed(True)
            builder.Add(f, wire)
        if not face.same_sense:
            occ_faces[fi] = f.Reversed()
    groups = _components(shell) if use_topology else [list(range(len(shell.faces)))]
    pieces = []
    for group in groups:
        occ_shell = TopoDS_Shell()
        builder.MakeShell(occ_shell)
        for fi in group:
            builder.Add(occ_shell, occ_faces[fi])
        BRepLib.BuildCurves3d_s(occ_shell)  # only edges without a 3D curve get one
        if not use_topology:
            if len(group) > 1:
                occ_shell = _sew(occ_shell, shell, sew_tolerance)
        pieces.append(_fix(occ_shell))
    if len(pieces) == 1:
        return pieces[0]
    compound = TopoDS_Compound()
    builder.MakeCompound(compound)
    for piece in pieces:
        builder.Add(compound, piece)
    return compound


def _components(shell: Shell) -> list[list[int]]:
    """Faces grouped by shared edges, groups ordered by their first face, faces in index order."""
    parent = list(range(len(shell.faces)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for e in shell.edges:
        fs = e.faces
        for f in fs[1:]:
            a, b = find(fs[0]), find(f)
            if a != b:
                parent[max(a, b)] = min(a, b)
    groups: dict[int, list[int]] = {}
    for i in range(len(shell.faces)):
        groups.setdefault(find(i), []).append(i)
    return [groups[k] for k in sorted(groups)]


def _topology_complete(shell: Shell) -> bool:
    """Whether every loop segment is one use of a shell edge (so edges can be shared)."""
    uses = {u for e in shell.edges for u in e.uses}
    for fi, face in enumerate(shell.faces):
        for li, loop in enumerate(face.loops):
            for si, _ in enumerate(loop.segments):
                if (fi, li, si) not in uses:
                    return False
    return True


def _make_edge(builder, e: Edge, shell: Shell, occ_vertices, occ_faces, ei):
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopoDS import TopoDS_Edge

    edge = TopoDS_Edge()
    tol = max(e.tolerance, 1e-7)
    if e.curve is not None:
        builder.MakeEdge(edge, curve_to_occ(e.curve), tol)
    else:  # a pole, or an edge known by its p-curves only (its 3D curve is built from them later)
        builder.MakeEdge(edge)
        builder.Degenerated(edge, e.is_degenerate)
    # Open CASCADE's FORWARD vertex sits at the low end of the range: for an edge stored against its
    # curve (t0 > t1) vertices[0] = b(t0) is the high end, so the roles swap
    v0, v1 = e.vertices if e.t0 < e.t1 else e.vertices[::-1]
    if 0 <= v0 < len(occ_vertices) and 0 <= v1 < len(occ_vertices):
        builder.Add(edge, occ_vertices[v0].Oriented(TopAbs_FORWARD))
        builder.Add(edge, occ_vertices[v1].Oriented(TopAbs_REVERSED))
    # p-curves: one per face, two (forward first) for a seam used twice by one face
    by_face: dict[int, list[PCurve]] = {}
    for fi, li, si in e.uses:
        by_face.setdefault(fi, []).append(shell.faces[fi].loops[li].segments[si])
    for fi, segs in by_face.items():
        face = occ_faces[fi]
        if len(segs) == 1:
            builder.UpdateEdge(edge, curve_to_occ(segs[0].curve), face, tol)
        else:
            fwd = [s for s in segs if s.t0 < s.t1]
            rev = [s for s in segs if s.t0 > s.t1]
            if not fwd or not rev:
                raise GeometryError(f"{shell.name or 'shell'}: edge {ei} is used twice by face {fi} "
                                    "in the same direction")
            builder.UpdateEdge(edge, curve_to_occ(fwd[0].curve), curve_to_occ(rev[0].curve), face, tol)
    builder.Range(edge, min(e.t0, e.t1), max(e.t0, e.t1))
    builder.SameRange(edge, True)
    builder.SameParameter(edge, True)
    return edge


def _loop_edges(builder, loop: Loop, face, surf, tface: TrimmedFace, vertex) -> list:
    """Edges of one loop of a face without shell topology, sharing vertices between consecutive segments."""
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopoDS import TopoDS_Edge

    segs = loop.segments
    ends = []  # 3D point at the start of each segment
    for s in segs:
        uv = s.curve.evaluate([s.t0])
        ends.append(tface.surface.evaluate(uv)[0])
    starts = np.array(ends)
    gaps = [float(np.linalg.norm(starts[(i + 1) % len(segs)] - tface.surface.evaluate(s.curve.evaluate([s.t1]))[0]))
            for i, s in enumerate(segs)]
    tol = max(1e-7, tface.tolerance, 1.01 * max(gaps) if gaps else 0.0)
    verts = [vertex(p, tol) for p in starts]
    out = []
    for i, s in enumerate(segs):
        edge = TopoDS_Edge()
        lo, hi = min(s.t0, s.t1), max(s.t0, s.t1)
        if s.edge_curve is not None:
            builder.MakeEdge(edge, curve_to_occ(s.edge_curve), tol)
        else:
            builder.MakeEdge(edge)
        builder.UpdateEdge(edge, curve_to_occ(s.curve), face, tol)
        builder.Range(edge, lo, hi)
        va, vb = verts[i], verts[(i + 1) % len(segs)]
        first, last = (va, vb) if s.t0 < s.t1 else (vb, va)
        builder.Add(edge, first.Oriented(TopAbs_FORWARD))
        builder.Add(edge, last.Oriented(TopAbs_REVERSED))
        builder.SameRange(edge, True)
        builder.SameParameter(edge, True)
        out.append(edge.Oriented(TopAbs_FORWARD if s.t0 < s.t1 else TopAbs_REVERSED))
    return out


def _natural_bounds(builder, face, surf, tface: TrimmedFace) -> None:
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.TopAbs import TopAbs_WIRE
    from OCP.TopExp import TopExp_Explorer

    made = BRepBuilderAPI_MakeFace(surf, max(tface.tolerance, 1e-7))
    if not made.IsDone():
        raise GeometryError(f"{tface.name or 'face'}: Open CASCADE could not bound the surface")
    ex = TopExp_Explorer(made.Face(), TopAbs_WIRE)
    while ex.More():
        builder.Add(face, ex.Current())
        ex.Next()


def _sew(occ_shell, shell: Shell, sew_tolerance: float | None):
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Sewing

    tol = sew_tolerance if sew_tolerance is not None else 1e-5 * max(shell.diagonal(), 1e-9)
    sewing = BRepBuilderAPI_Sewing(tol)
    sewing.Add(occ_shell)
    sewing.Perform()
    sewn = sewing.SewedShape()
    return occ_shell if sewn.IsNull() else sewn


def _fix(shape):
    """ShapeFix_Shape, then every closed shell made a solid (oriented outward)."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeSolid
    from OCP.BRepLib import BRepLib
    from OCP.ShapeFix import ShapeFix_Shape
    from OCP.TopAbs import TopAbs_SHELL
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS, TopoDS_Compound

    fixer = ShapeFix_Shape(shape)
    fixer.Perform()
    fixed = fixer.Shape()
    shells = []
    ex = TopExp_Explorer(fixed, TopAbs_SHELL)
    while ex.More():
        shells.append(TopoDS.Shell(ex.Current()))
        ex.Next()
    if not shells:
        return fixed
    out = []
    for sh in shells:
        if BRep_Tool.IsClosed_s(sh):
            solid = BRepBuilderAPI_MakeSolid(sh).Solid()
            BRepLib.OrientClosedSolid_s(solid)
            out.append(solid)
        else:
            out.append(sh)
    if len(out) == 1:
        return out[0]
    builder = BRep_Builder()
    compound = TopoDS_Compound()
    builder.MakeCompound(compound)
    for piece in out:
        builder.Add(compound, piece)
    return compound
