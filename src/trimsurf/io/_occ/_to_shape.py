"""`Shell` -> Open CASCADE shape: faces, shared edges, sewing and fixing (for the STEP writer)."""

from __future__ import annotations

import numpy as np

from ...errors import GeometryError
from ...model import Edge, Loop, PCurve, Shell, TrimmedFace
from ._geometry import curve_to_occ, surface_to_occ


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
    from OCP.gp import gp_Pnt
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopoDS import (
        TopoDS_Face,
        TopoDS_Shell,
        TopoDS_Vertex,
        TopoDS_Wire,
    )

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
    return compound(pieces)


def compound(shapes: list):
    """The one shape of `shapes`, or a ``TopoDS_Compound`` of them (null shapes left out)."""
    from OCP.BRep import BRep_Builder
    from OCP.TopoDS import TopoDS_Compound

    if len(shapes) == 1:
        return shapes[0]
    builder = BRep_Builder()
    result = TopoDS_Compound()
    builder.MakeCompound(result)
    for s in shapes:
        if not s.IsNull():
            builder.Add(result, s)
    return result


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
    from OCP.BRep import BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeSolid
    from OCP.BRepLib import BRepLib
    from OCP.ShapeFix import ShapeFix_Shape
    from OCP.TopAbs import TopAbs_SHELL
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

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
    return compound(out)
