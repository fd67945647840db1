"""Open CASCADE shape -> `Shell`: faces, loops, p-curves, edges, vertices."""

from __future__ import annotations

import functools
import warnings
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from ...errors import FaceSkippedWarning, GeometryError
from ...model import Edge, Loop, NurbsCurve, PCurve, Shell, TrimmedFace
from ._geometry import curve_from_occ, curve_points, curves_points, linspaces, surface_from_occ

# p-curve samples per segment when measuring the (u, v) range a face uses
_RANGE_SAMPLES = 65
# control points per edge for the same-parameter deviation (Open CASCADE's BRepCheck uses 23)
_VALIDATE_POINTS = 47



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


def _segment_uv_ranges(faces: Sequence[Sequence[PCurve]]) -> list:
    """Per face, (min, max) in (u, v) of `_RANGE_SAMPLES` equally spaced points of each of its p-curves (None
    for a face without any), all faces in one batch."""
    curves = [c for segs in faces for c in segs]
    if not curves:
        return [None] * len(faces)
    ts = linspaces(np.array([c.t0 for c in curves]), np.array([c.t1 for c in curves]), _RANGE_SAMPLES)
    pts = np.stack(curves_points([c.curve for c in curves], list(ts)))  # (curves, samples, 2)
    lo_c, hi_c = pts.min(axis=1), pts.max(axis=1)
    out, k = [], 0
    for segs in faces:
        n = len(segs)
        out.append((lo_c[k:k + n].min(axis=0), hi_c[k:k + n].max(axis=0)) if n else None)
        k += n
    return out


@functools.cache
def _validate_classes() -> tuple:
    """The Open CASCADE classes `_same_parameter_deviation` builds (imported once: ~10 us a call otherwise)."""
    from OCP.Adaptor3d import Adaptor3d_CurveOnSurface
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.BRepLib import BRepLib_ValidateEdge
    from OCP.Geom2dAdaptor import Geom2dAdaptor_Curve
    from OCP.GeomAdaptor import GeomAdaptor_Surface

    return Adaptor3d_CurveOnSurface, BRepAdaptor_Curve, BRepLib_ValidateEdge, Geom2dAdaptor_Curve, GeomAdaptor_Surface


def _same_parameter_deviation(edge, pc, a: float, b: float, surface) -> float:
    """max |S(p(t)) - C(t)| of an edge on a face, by Open CASCADE's BRepLib_ValidateEdge.

    `pc`, `a`, `b`: the edge's p-curve on the face and its range (``BRep_Tool::CurveOnSurface``), `surface`:
    the face's surface (``BRep_Tool::Surface``).
    """
    curve_on_surface, edge_curve, validate, pcurve_adaptor, surface_adaptor = _validate_classes()
    cos = curve_on_surface(pcurve_adaptor(pc, a, b), surface_adaptor(surface))
    check = validate(edge_curve(edge), cos, True)
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
    from OCP.collections import (
        IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as ShapeMap,
    )
    from OCP.TopAbs import TopAbs_FACE, TopAbs_FORWARD
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS

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


def shape_to_shell(shape, *, name: str = "", skip_bad_faces: bool = False) -> Shell:
    """Convert a NurbsConvert-ed Open CASCADE shape into a `Shell` (see the module notes).

    Entities are numbered as by `map_topology`. With `skip_bad_faces`, a face
    whose conversion fails (invalid knots, a missing p-curve, an Open CASCADE
    exception) is left out with a `FaceSkippedWarning` naming it (its index
    as in `map_topology`); the other faces and the edges they use are kept,
    numbered in order. Without it the first failure raises.

    Raises
    ------
    GeometryError
        A face cannot be converted (without `skip_bad_faces`), or every face
        failed (with it).
    """
    from OCP.BRep import BRep_Tool
    from OCP.collections import (
        IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as ShapeMap,
    )
    from OCP.TopExp import TopExp

    topo = map_topology(shape)
    emap, vmap = ShapeMap(), ShapeMap()
    for e in topo.edges:
        emap.Add(e)
    for v in topo.vertices:
        vmap.Add(v)
    edge_curves: list[NurbsCurve | None] = [None] * len(topo.edges)
    edge_done = [False] * len(topo.edges)
    edge_uses: list[list[tuple[int, int, int]]] = [[] for _ in topo.edges]
    edge_dev = [0.0] * len(topo.edges)
    converted: list[tuple] = []  # (surface, loops_raw, same_sense, name, tolerance)
    failed: dict[int, Exception] = {}
    # first every face's loops (p-curves, edge curves, seam repair), then the (u, v) range their p-curves
    # sample, for all faces in one batch, then every face's surface: each face meets the same steps in the
    # same order as one face at a time; a face's failure is that of its first failing step
    pending = []
    stop: Exception | None = None
    for fi, (face, face_loops) in enumerate(zip(topo.faces, topo.loops)):
        try:
            pending.append((fi, face, *_face_loops(fi, face, face_loops, emap, edge_curves, edge_done, name)))
        except Exception as exc:  # GeometryError from the model, Standard_Failure from Open CASCADE
            if not skip_bad_faces:
                stop = exc  # raised below unless an earlier face fails at its surface
                break
            failed[fi] = exc
    ranges = _segment_uv_ranges([item[4] for item in pending])
    for (fi, face, fwd, loops_raw, all_segs, repaired, uses, devs), seg_range in zip(pending, ranges):
        try:
            item = _face_item(fi, face, fwd, loops_raw, all_segs, repaired, seg_range, name)
        except Exception as exc:
            if not skip_bad_faces:
                raise
            failed[fi] = exc
            continue
        out_index = len(converted)
        converted.append(item)
        for ei, li, si in uses:
            edge_uses[ei].append((out_index, li, si))
        for ei, dev in devs.items():
            edge_dev[ei] = max(edge_dev[ei], dev)
    if stop is not None:
        raise stop
    skipped: list[str] = []
    for fi in sorted(failed):
        exc = failed[fi]
        message = f"{name + ': ' if name else ''}face {fi} skipped: {type(exc).__name__}: {exc}"
        skipped.append(" ".join(message.split()))
        warnings.warn(skipped[-1], FaceSkippedWarning, stacklevel=2)
    if skipped and not converted:
        raise GeometryError(f"{name + ': ' if name else ''}no face could be converted ({len(skipped)} skipped; "
                            f"first: {skipped[0]})")
    # edges used by a kept face, renumbered in order
    kept = [ei for ei in range(len(topo.edges)) if edge_uses[ei] or not skipped]
    new_id = {ei: k for k, ei in enumerate(kept)}
    faces: list[TrimmedFace] = []
    for surface, loops_raw, same_sense, face_name, tolerance in converted:
        loops = tuple(Loop(tuple(PCurve(c, t0, t1, edge_curves[ei], new_id[ei]) for c, t0, t1, ei in segs))
                      for segs in loops_raw)
        faces.append(TrimmedFace(surface, loops, same_sense=same_sense, name=face_name, tolerance=tolerance))
    edges = []
    for ei in kept:
        edge = topo.edges[ei]
        if not edge_done[ei]:
            edge_curves[ei] = _edge_curve(edge)
        first, last = TopExp.FirstVertex_s(edge), TopExp.LastVertex_s(edge)
        vids = tuple(vmap.FindIndex(v) - 1 if not v.IsNull() else -1 for v in (first, last))
        t0, t1 = BRep_Tool.Range_s(edge)
        tol = max(BRep_Tool.Tolerance_s(edge), edge_dev[ei])
        edges.append(Edge(edge_curves[ei], t0, t1, vids, tuple(edge_uses[ei]), tolerance=tol,
                          is_degenerate=BRep_Tool.Degenerated_s(edge)))
    vertices = np.array([_vertex_point(v) for v in topo.vertices], dtype=np.float64).reshape(-1, 3)
    return Shell(tuple(faces), tuple(edges), vertices, name=name)


def _face_loops(fi: int, face, face_loops, emap, edge_curves, edge_done, name: str):
    """One face's loops: (FORWARD face, loops_raw, [PCurve], repaired, [(edge, loop, segment)], {edge: deviation})."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopoDS import TopoDS

    fwd = TopoDS.Face(face.Oriented(TopAbs_FORWARD))
    loops_raw: list[list[tuple[NurbsCurve, float, float, int]]] = []
    uses: list[tuple[int, int, int]] = []
    devs: dict[int, float] = {}
    repaired = False
    surface = None
    for li, edges in enumerate(face_loops):
        segs, occ_pcurves = [], []
        for si, edge in enumerate(edges):
            ei = emap.FindIndex(edge) - 1
            if not edge_done[ei]:
                edge_curves[ei] = _edge_curve(edge)
                edge_done[ei] = True
            pc = BRep_Tool.CurveOnSurface_s(edge, fwd, 0.0, 0.0)
            if pc is None:
                raise GeometryError(f"{name}: face {fi} edge {ei} has no p-curve")
            a, b = BRep_Tool.Range_s(edge, fwd)
            t0, t1 = (b, a) if edge.Orientation() == TopAbs_REVERSED else (a, b)
            uses.append((ei, li, si))
            segs.append((curve_from_occ(pc, a, b, 2), t0, t1, ei))
            occ_pcurves.append((pc, a, b))
        if surface is None:
            surface = BRep_Tool.Surface_s(fwd)
        fixed = _repair_seam_pcurves(segs, [BRep_Tool.IsClosed_s(e, fwd) for e in edges], surface)
        repaired = repaired or bool(fixed)
        for si, edge in enumerate(edges):
            ei = segs[si][3]
            if edge_curves[ei] is not None and si not in fixed:
                devs[ei] = max(devs.get(ei, 0.0), _same_parameter_deviation(edge, *occ_pcurves[si], surface))
        loops_raw.append(segs)
    all_segs = [PCurve(c, t0, t1) for segs in loops_raw for c, t0, t1, _ in segs]
    return fwd, loops_raw, all_segs, repaired, uses, devs


def _face_item(fi: int, face, fwd, loops_raw, all_segs, repaired: bool, seg_range, name: str) -> tuple:
    """One face's (surface, loops_raw, same_sense, name, tolerance); `seg_range`: its p-curves' (u, v) range."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_REVERSED

    same_sense = face.Orientation() != TopAbs_REVERSED
    if all_segs and repaired:       # UVBounds would count the seam p-curves replaced
        lo, hi = seg_range
    else:
        u0, u1, v0, v1 = _uv_bounds(fwd)
        lo, hi = np.array([u0, v0]), np.array([u1, v1])
        if all_segs:
            slo, shi = seg_range
            lo, hi = np.minimum(lo, slo), np.maximum(hi, shi)
    surface = surface_from_occ(BRep_Tool.Surface_s(fwd), lo, hi)
    return surface, loops_raw, same_sense, f"{name} face {fi}".strip(), BRep_Tool.Tolerance_s(fwd)


def _repair_seam_pcurves(segs: list, closed: list, surface) -> set:
    """Give a seam use that leaves its loop a translate of its partner's p-curve by the period; in place.

    ``BRepBuilderAPI_NurbsConvert`` (OCCT 8.0.1) converts only one of the two p-curves of some seam
    edges: on occtpr946__ec_turbine-A (faces 8, 9, 34, 35: torus, cylinder, cone, sphere) the other
    one is left in the old parameterization, or is the p-curve of another face (21 to 41 off in 3D).
    A seam use whose ends miss its neighbours' ends in (u, v) is replaced by the candidate among its
    own and its partner's p-curve, shifted by 0 or one period of a closed direction, that meets both.

    Parameters
    ----------
    segs : list of (NurbsCurve, t0, t1, edge index)
        One loop's segments, in order; changed in place.
    closed : list of bool
        Whether each segment's edge is a seam of the face (``BRep_Tool::IsClosed``).
    surface : Geom_Surface
        The face's (converted) surface.

    Returns
    -------
    set of int
        Indices of the segments replaced.
    """
    n = len(segs)
    if n < 3 or not any(closed):
        return set()
    u0, u1, v0, v1 = surface.Bounds()
    shifts = [np.zeros(2)]
    if surface.IsUClosed() and np.isfinite(u1 - u0):
        shifts += [np.array([u1 - u0, 0.0]), np.array([u0 - u1, 0.0])]
    if surface.IsVClosed() and np.isfinite(v1 - v0):
        shifts += [np.array([0.0, v1 - v0]), np.array([0.0, v0 - v1])]
    span = max(abs(u1 - u0) if np.isfinite(u1 - u0) else 0.0, abs(v1 - v0) if np.isfinite(v1 - v0) else 0.0, 1.0)
    tol = 1e-6 * span

    def ends(curve, t0, t1):
        p = curve_points(curve, np.array([t0, t1]))
        return p[0], p[1]

    def gap(si, curve):
        t0, t1 = segs[si][1], segs[si][2]
        a, b = ends(curve, t0, t1)
        prev = segs[(si - 1) % n]
        nxt = segs[(si + 1) % n]
        return (float(np.linalg.norm(a - ends(prev[0], prev[1], prev[2])[1]))
                + float(np.linalg.norm(b - ends(nxt[0], nxt[1], nxt[2])[0])))

    fixed = set()
    for si in range(n):
        if not closed[si] or gap(si, segs[si][0]) <= tol:
            continue
        curve, t0, t1, ei = segs[si]
        partners = [segs[k][0] for k in range(n) if k != si and segs[k][3] == ei]
        best, best_gap = None, np.inf
        for base in [curve, *partners]:
            for d in shifts[1:] if base is curve else shifts:
                cand = NurbsCurve(base.degree, base.knots, base.control_points + d, base.weights)
                g = gap(si, cand)
                if g < best_gap:
                    best, best_gap = cand, g
        if best is not None and best_gap <= tol:
            segs[si] = (best, t0, t1, ei)
            fixed.add(si)
    return fixed


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
