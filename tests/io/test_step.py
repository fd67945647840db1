"""STEP (and the shared Open CASCADE conversion): agreement with Open CASCADE's own evaluation on the real
files, loop and shell conventions, round trips, seam and domain handling, bad input and atomic writes.

The helpers at the top (``load``, ``check_*``) are reused by ``test_iges.py``.
"""

from __future__ import annotations

import functools
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from trimsurf.errors import FileFormatError, GeometryError, StepReadError, TrimsurfWarning
from trimsurf.io import _iges, _occ, _step, read_shell, write_shell
from trimsurf.model import Edge, Loop, NurbsCurve, NurbsSurface, PCurve, Shell, TrimmedFace
from trimsurf.samples import bspline_box

CAD = (Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "cad").resolve()
STEP_FILES = sorted(p.name for p in CAD.glob("*") if p.suffix.lower() in (".step", ".stp"))
# faces after import, from ../shared/data/cad/README.md
README_FACES = {
    "gmsh__SampleCrankshaft4A.stp": 137, "gmsh__U_Joint_2.stp": 133, "gmsh__t20_data.step": 21,
    "gmsh__wing_fuselage.step": 16, "gmsh__wrenchnut.stp": 36, "occt__bearing.iges": 213,
    "occt__linkrods.step": 37, "occt__screw.step": 10, "occtpr946__bug27693_cornetta-step.stp": 110,
    "occtpr946__bug32596_abc_0_13.step": 99, "occtpr946__ec_soapbox-A.stp": 86,
    "occtpr946__trj5_k1-pe-214.stp": 52, "trimesh__featuretype.STEP": 96, "occtpr946__ec_turbine-A.stp": 53,
}
# faces whose seam p-curves NurbsConvert leaves partly unconverted (repaired by the reader, see
# trimsurf.io._occ._to_shell._repair_seam_pcurves)
SEAM_REPAIRED = {"occtpr946__ec_turbine-A.stp": (8, 9, 34, 35)}
# open shells (README: free edges > 0)
OPEN_FILES = {"occtpr946__ec_turbine-A.stp"}
REL = 1e-9  # the acceptance tolerance, relative to the file's bounding-box diagonal
N_UV = 6  # random (u, v) per face
N_T = 3  # random t per loop segment


class Loaded:
    """One file read once: the NurbsConvert-ed OCC shape, our Shell, the OCC entities index for index."""

    def __init__(self, name: str):
        path = CAD / name
        module = _iges if path.suffix.lower() in (".iges", ".igs") else _step
        start = time.perf_counter()
        self.shape = module.read_occ_shape(path)
        self.shell = _occ.shape_to_shell(self.shape, name=name)
        self.read_seconds = time.perf_counter() - start
        self.topo = _occ.map_topology(self.shape)
        self.diag = occ_diagonal(self.shape)


@functools.lru_cache(maxsize=None)
def load(name: str) -> Loaded:
    """Read each real file once per test session."""
    return Loaded(name)


def occ_diagonal(shape) -> float:
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib

    box = Bnd_Box()
    BRepBndLib.Add_s(shape, box)
    return float(np.sqrt(box.SquareExtent()))


def _forward(face):
    from OCP.TopAbs import TopAbs_FORWARD
    from OCP.TopoDS import TopoDS
    return TopoDS.Face(face.Oriented(TopAbs_FORWARD))


def _reversed_edge(edge):
    from OCP.TopoDS import TopoDS
    return TopoDS.Edge(edge.Reversed())


def occ_surface_d2(surface, uv: np.ndarray) -> np.ndarray:
    """Open CASCADE's S, Su, Sv, Suu, Suv, Svv at each (u, v): shape (6, n, 3)."""
    from OCP.gp import gp_Pnt, gp_Vec

    p, du, dv, duu, dvv, duv = gp_Pnt(), gp_Vec(), gp_Vec(), gp_Vec(), gp_Vec(), gp_Vec()
    out = np.empty((6, len(uv), 3))
    for i, (u, v) in enumerate(uv.tolist()):
        surface.D2(u, v, p, du, dv, duu, dvv, duv)
        for k, w in enumerate((p, du, dv, duu, duv, dvv)):
            out[k, i] = w.X(), w.Y(), w.Z()
    return out


def occ_curve_points(curve, ts: np.ndarray, dim: int) -> np.ndarray:
    if dim == 2:
        return np.array([(q.X(), q.Y()) for q in map(curve.Value, ts.tolist())])
    return np.array([(q.X(), q.Y(), q.Z()) for q in map(curve.Value, ts.tolist())])


def check_surfaces_match_occ(name: str) -> float:
    """Our NurbsSurface vs Open CASCADE's surface of the NurbsConvert-ed face, inside UVBounds; returns max error."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepTools import BRepTools

    data = load(name)
    rng = np.random.default_rng(20251122)
    worst = 0.0
    for fi, face in enumerate(data.shell.faces):
        fwd = _forward(data.topo.faces[fi])
        u0, u1, v0, v1 = BRepTools.UVBounds_s(fwd)
        if fi in SEAM_REPAIRED.get(name, ()):     # UVBounds counts the unconverted seam p-curves
            (u0, u1), (v0, v1) = np.clip([u0, u1], *face.surface.domain[0]), np.clip([v0, v1], *face.surface.domain[1])
        # random inside the face's UV bounds, plus the two corners for S and its first derivatives only (a
        # corner may sit on a C1 knot, where the one-sided second derivatives differ between implementations)
        uv = np.column_stack([rng.uniform(u0, u1, N_UV), rng.uniform(v0, v1, N_UV)])
        uv = np.vstack([uv, [[u0, v0], [u1, v1]]])
        ref = occ_surface_d2(BRep_Tool.Surface_s(fwd), uv)
        ref[3:, N_UV:] = 0.0
        d = face.surface.derivatives(uv, 2)
        ours = np.stack([d[0, 0], d[1, 0], d[0, 1], d[2, 0], d[1, 1], d[0, 2]])
        ours[3:, N_UV:] = 0.0
        # Points: 1e-9 of the diagonal. A derivative of order (a, b) of a surface whose extent is at most
        # ~diag over a parameter domain of lengths (Lu, Lv) has the natural size diag / (Lu^a Lv^b); rounding
        # in the evaluation scales with that size, so its tolerance is 1e-9 of it (measured errors: points
        # <= 6e-15, first derivatives <= 2e-13, second <= 3e-10 of these scales).
        (a0, a1), (b0, b1) = face.surface.domain
        lu, lv = a1 - a0, b1 - b0
        scales = data.diag / np.array([1.0, lu, lv, lu * lu, lu * lv, lv * lv])
        err = np.linalg.norm(ours - ref, axis=2).max(axis=1) / scales
        assert np.all(err <= REL), f"{name} face {fi}: errors / tolerance scale {err} (S, Su, Sv, Suu, Suv, Svv)"
        worst = max(worst, float(err[0]))
    return worst


def check_curves_match_occ(name: str) -> None:
    """p-curves vs Open CASCADE's Geom2d p-curves, edge curves vs Geom curves, at random t of every segment."""
    from OCP.BRep import BRep_Tool

    data = load(name)
    rng = np.random.default_rng(7)
    for fi, face in enumerate(data.shell.faces):
        fwd = _forward(data.topo.faces[fi])
        (a0, a1), (b0, b1) = face.surface.domain
        uv_scale = max(a1 - a0, b1 - b0)
        for li, loop in enumerate(face.loops):
            for si, seg in enumerate(loop.segments):
                edge = data.topo.loops[fi][li][si]
                ts = rng.uniform(min(seg.t0, seg.t1), max(seg.t0, seg.t1), N_T)
                pc = BRep_Tool.CurveOnSurface_s(edge, fwd, 0.0, 0.0)
                ref = occ_curve_points(pc, ts, 2)
                if BRep_Tool.IsClosed_s(edge, fwd) and fi in SEAM_REPAIRED.get(name, ()):
                    # a seam p-curve NurbsConvert left unconverted: ours is the partner's shifted by a period
                    other = BRep_Tool.CurveOnSurface_s(_reversed_edge(edge), fwd, 0.0, 0.0)
                    shifts = np.array([[0, 0], [a1 - a0, 0], [a0 - a1, 0], [0, b1 - b0], [0, b0 - b1]])
                    cands = [ref] + [occ_curve_points(other, ts, 2) + d for d in shifts]
                    ref = min(cands, key=lambda c: np.abs(seg.evaluate(ts) - c).max())
                # p-curves live in (u, v): 1e-9 of the surface's parameter range (measured <= 2e-12)
                assert_allclose(seg.evaluate(ts), ref, rtol=0, atol=REL * uv_scale,
                                err_msg=f"{name} face {fi} loop {li} segment {si}: p-curve")
                if seg.edge_curve is not None:
                    c3 = BRep_Tool.Curve_s(edge, 0.0, 0.0)
                    # 3D edge curves: 1e-9 of the diagonal (measured <= 2e-15)
                    assert_allclose(seg.edge_curve.evaluate(ts), occ_curve_points(c3, ts, 3), rtol=0,
                                    atol=REL * data.diag, err_msg=f"{name} face {fi} loop {li} segment {si}: edge")


def check_segments_on_surface(name: str) -> None:
    """|F(p(t)) - b(t)| within the edge tolerance on every segment (validates loop, orientation, seam conventions).

    The factor 1.5 covers random t falling between the 47 control points at which the reader measured the
    same-parameter deviation that raised a tolerance (measured worst ratio 1.04).
    """
    data = load(name)
    rng = np.random.default_rng(11)
    for fi, face in enumerate(data.shell.faces):
        for li, loop in enumerate(face.loops):
            for si, seg in enumerate(loop.segments):
                if seg.edge_curve is None:
                    continue
                ts = np.concatenate([[seg.t0, seg.t1], rng.uniform(min(seg.t0, seg.t1), max(seg.t0, seg.t1), N_T)])
                gap = np.linalg.norm(face.surface.evaluate(seg.evaluate(ts)) - seg.edge_curve.evaluate(ts), axis=1)
                tol = data.shell.edges[seg.edge_id].tolerance
                assert gap.max() <= 1.5 * tol + REL * data.diag, (
                    f"{name} face {fi} loop {li} segment {si}: |F(p(t)) - b(t)| = {gap.max():.3g} > 1.5 x {tol:.3g}")


def check_raised_tolerances_bounded(name: str) -> None:
    """Raised edge tolerances come from real same-parameter deviations of the data, all < 1e-4 of the diagonal."""
    from OCP.BRep import BRep_Tool

    data = load(name)
    for ei, (edge, occ_edge) in enumerate(zip(data.shell.edges, data.topo.edges)):
        stated = BRep_Tool.Tolerance_s(occ_edge)
        assert edge.tolerance >= stated
        if edge.tolerance > 1.01 * stated:
            assert edge.tolerance <= 1e-4 * data.diag, f"{name} edge {ei}: tolerance raised to {edge.tolerance:.3g}"


def check_loops(name: str) -> None:
    """Outer loop counter-clockwise in (u, v), holes clockwise; segments chain through shared vertices.

    Segment i ends at the vertex where segment i + 1 starts, and F(p(t)) at both ends lies within that
    vertex's Open CASCADE tolerance (x 1.01 + 1e-9 diag for rounding): this validates the direction
    (t0 > t1 for reversed edges) and order of the segments. p-curves need not meet in (u, v): where the
    file's tolerances are large they do not (gaps up to 1e-2 in u on gmsh__SampleCrankshaft4A).
    """
    from OCP.BRep import BRep_Tool

    data = load(name)
    shell = data.shell
    vtol = [BRep_Tool.Tolerance_s(v) for v in data.topo.vertices]
    for fi, face in enumerate(shell.faces):
        assert face.loops, f"{name} face {fi} has no loop"
        for li, loop in enumerate(face.loops):
            area = loop.signed_area()
            assert (area > 0) == (li == 0), f"{name} face {fi} loop {li}: signed area {area:.3g}"
            ends = []
            for si, seg in enumerate(loop.segments):
                edge = shell.edges[seg.edge_id]
                v_start, v_end = edge.vertices if seg.t0 < seg.t1 else edge.vertices[::-1]
                ends.append((v_start, v_end))
                xyz = face.surface.evaluate(seg.evaluate([seg.t0, seg.t1]))
                for point, vid in zip(xyz, (v_start, v_end)):
                    dist = np.linalg.norm(point - shell.vertices[vid])
                    assert dist <= 1.01 * vtol[vid] + REL * data.diag, (
                        f"{name} face {fi} loop {li} segment {si}: end {dist:.3g} from vertex {vid}")
            for si in range(len(ends)):
                assert ends[si][1] == ends[(si + 1) % len(ends)][0], f"{name} face {fi} loop {li} breaks at {si}"


def check_edge_uses(name: str) -> None:
    """Every use points at a segment that names the edge back; a seam is used in both directions by one face."""
    shell = load(name).shell
    for ei, edge in enumerate(shell.edges):
        assert edge.uses, f"{name} edge {ei} has no use"
        for fi, li, si in edge.uses:
            assert shell.faces[fi].loops[li].segments[si].edge_id == ei
        per_face: dict[int, list[PCurve]] = {}
        for fi, li, si in edge.uses:
            per_face.setdefault(fi, []).append(shell.faces[fi].loops[li].segments[si])
        for fi, segs in per_face.items():
            if len(segs) == 2:  # seam: traversed once each way, on two different p-curves
                assert (segs[0].t0 < segs[0].t1) != (segs[1].t0 < segs[1].t1), f"{name} seam edge {ei}"
    n_segments = sum(len(loop) for f in shell.faces for loop in f.loops)
    assert sum(len(e.uses) for e in shell.edges) == n_segments


# ---------------------------------------------------------------------------------------------------------------
# real files
# ---------------------------------------------------------------------------------------------------------------

def test_real_step_files_are_all_covered():
    assert len(STEP_FILES) == 13 and set(STEP_FILES) <= set(README_FACES)


@pytest.mark.parametrize("name", STEP_FILES)
def test_face_counts_match_readme(name):
    shell = load(name).shell
    assert len(shell.faces) == README_FACES[name]
    assert all(isinstance(f, TrimmedFace) for f in shell.faces)


@pytest.mark.parametrize("name", STEP_FILES)
def test_surfaces_agree_with_open_cascade(name):
    check_surfaces_match_occ(name)


@pytest.mark.parametrize("name", STEP_FILES)
def test_pcurves_and_edge_curves_agree_with_open_cascade(name):
    check_curves_match_occ(name)


@pytest.mark.parametrize("name", STEP_FILES)
def test_segments_lie_on_the_surface_within_edge_tolerance(name):
    check_segments_on_surface(name)
    check_raised_tolerances_bounded(name)


@pytest.mark.parametrize("name", STEP_FILES)
def test_loops_are_oriented_outer_ccw_holes_cw(name):
    check_loops(name)


@pytest.mark.parametrize("name", STEP_FILES)
def test_extent_is_open_cascade_optimal_box(name):
    """Shell.bounding_box samples the trimmed faces (issue 16, item 10): on every real file its diagonal
    is Open CASCADE's optimal box's (BRepBndLib::AddOptimal, exact on the faces' restrictions) to 1e-3
    (measured <= 2.6e-4 below it; a sampled inner bound, above it only by the optimal box's own
    numerical slack: 1.4e-7 on the crankshaft)."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib

    data = load(name)
    box = Bnd_Box()
    BRepBndLib.AddOptimal_s(data.shape, box, False, False)
    lo, hi = box.CornerMin(), box.CornerMax()
    occ = float(np.linalg.norm([hi.X() - lo.X(), hi.Y() - lo.Y(), hi.Z() - lo.Z()]))
    ours = data.shell.diagonal()
    assert occ * (1 - 1e-3) <= ours <= occ * (1 + 1e-6), (ours, occ)


def test_open_turbine_shell_has_the_readme_free_edges():
    """The turbine blade is an open shell: 14 free edges (README), every other edge used twice."""
    shell = load("occtpr946__ec_turbine-A.stp").shell
    check_edge_uses("occtpr946__ec_turbine-A.stp")
    uses = [len(e.uses) for e in shell.edges if not e.is_degenerate]
    assert uses.count(1) == 14 and set(uses) == {1, 2}
    assert not shell.is_closed() and not shell.non_manifold_edges()


@pytest.mark.parametrize("name", sorted(set(STEP_FILES) - OPEN_FILES))
def test_closed_files_give_closed_manifold_shells(name):
    # every STEP file here but the turbine is closed (README: free edges 0)
    shell = load(name).shell
    check_edge_uses(name)
    assert shell.is_closed()
    assert not shell.non_manifold_edges()
    for ei, edge in enumerate(shell.edges):
        if not edge.is_degenerate:
            assert len(edge.uses) == 2, f"{name} edge {ei} has {len(edge.uses)} uses"
    assert len(shell.vertices) == len({v for e in shell.edges for v in e.vertices})


def test_reversed_faces_flip_same_sense():
    from OCP.TopAbs import TopAbs_REVERSED

    data = load("occt__screw.step")
    flags = [f.same_sense for f in data.shell.faces]
    expected = [face.Orientation() != TopAbs_REVERSED for face in data.topo.faces]
    assert flags == expected and not all(flags)


def test_seam_edges_are_used_twice_by_their_face():
    shell = load("occt__screw.step").shell  # cylinder, cone and torus faces carry seams
    seams = [e for e in shell.edges if len(e.faces) == 1 and len(e.uses) == 2]
    assert seams
    for e in seams:
        (fa, la, sa), (fb, lb, sb) = e.uses
        a, b = shell.faces[fa].loops[la].segments[sa], shell.faces[fb].loops[lb].segments[sb]
        # the two p-curves of a seam are apart in (u, v) (one period) but map to the same 3D curve
        assert np.linalg.norm(a.evaluate([a.t0]) - b.evaluate([b.t1])) > 1e-3
        t = np.linspace(min(a.t0, a.t1), max(a.t0, a.t1), 5)
        face = shell.faces[fa]
        assert_allclose(face.surface.evaluate(a.evaluate(t)), face.surface.evaluate(b.evaluate(t)), rtol=0,
                        atol=1e-9 * load("occt__screw.step").diag)


def test_reading_is_quiet(capfd):
    shell = _step.read(CAD / "occt__screw.step")
    out, err = capfd.readouterr()
    assert out == "" and err == ""
    assert len(shell.faces) == 10 and shell.name == "occt__screw.step"


def test_largest_file_reads_in_seconds():
    # ~1.5 s measured on the idle 2-core machine (read + NurbsConvert + conversion); generous for a loaded box
    assert load("occt__linkrods.step").read_seconds < 20


# ---------------------------------------------------------------------------------------------------------------
# periodic seam and domain extension (synthetic: no face of the shared data crosses a seam)
# ---------------------------------------------------------------------------------------------------------------

def _periodic_cylinder():
    from OCP.Geom import Geom_CylindricalSurface, Geom_RectangularTrimmedSurface
    from OCP.GeomConvert import GeomConvert
    from OCP.gp import gp_Ax3, gp_Dir, gp_Pnt

    cyl = Geom_CylindricalSurface(gp_Ax3(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), 2.0)
    # the cylinder's v is infinite: a finite, u-periodic B-spline on [0, 2 pi] x [0, 3]
    bs = GeomConvert.SurfaceToBSplineSurface_s(Geom_RectangularTrimmedSurface(cyl, 0.0, 3.0, False))
    assert bs.IsUPeriodic()
    return bs


@pytest.mark.parametrize("direction", ["u", "v"])
def test_face_crossing_a_periodic_seam_keeps_its_parameters(direction):
    bs = _periodic_cylinder()
    lo, hi = np.array([-1.0, 0.0]), np.array([1.0, 3.0])  # crosses u = 0 (the seam)
    if direction == "v":  # the same surface with u and v exchanged: periodic in v
        bs.ExchangeUV()
        lo, hi = lo[::-1].copy(), hi[::-1].copy()
    axis = "uv".index(direction)
    surf = _occ.surface_from_occ(bs, lo, hi)
    d0, d1 = surf.domain[axis]
    assert d0 <= -1.0 and d1 >= 1.0 and d1 - d0 == pytest.approx(2 * np.pi)
    rng = np.random.default_rng(3)
    uv = np.column_stack([rng.uniform(lo[0], hi[0], 50), rng.uniform(lo[1], hi[1], 50)])
    ref = occ_surface_d2(bs, uv)  # Open CASCADE evaluates a periodic surface periodically
    # exact conversion: rounding only (radius 2, so 1e-12 absolute is ~1e-12 of the size)
    assert_allclose(surf.evaluate(uv), ref[0], rtol=0, atol=1e-12)
    d = surf.derivatives(uv, 1)
    assert_allclose(d[1, 0], ref[1], rtol=0, atol=1e-11)
    assert_allclose(d[0, 1], ref[2], rtol=0, atol=1e-11)
    # the input surface is not modified
    assert bs.IsUPeriodic() if direction == "u" else bs.IsVPeriodic()


def test_periodic_curve_range_crossing_its_origin():
    from OCP.Geom import Geom_Circle
    from OCP.GeomConvert import GeomConvert
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt

    circle = GeomConvert.CurveToBSplineCurve_s(Geom_Circle(gp_Ax2(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), 1.5))
    assert circle.IsPeriodic()
    curve = _occ.curve_from_occ(circle, 5.0, 7.0, 3)
    assert curve.domain[0] <= 5.0 and curve.domain[1] >= 7.0
    ts = np.linspace(5.0, 7.0, 9)
    assert_allclose(curve.evaluate(ts), occ_curve_points(circle, ts, 3), rtol=0, atol=1e-12)


def test_domain_is_extended_like_open_cascade_extrapolates():
    from OCP.Geom import Geom_BSplineSurface
    from OCP.collections import Array1_int, Array2_double, Array2_gp_Pnt
    from OCP.gp import gp_Pnt

    rng = np.random.default_rng(5)
    nu, nv = 5, 4
    poles, weights = Array2_gp_Pnt(1, nu, 1, nv), Array2_double(1, nu, 1, nv)
    for i in range(nu):
        for j in range(nv):
            poles.SetValue(i + 1, j + 1, gp_Pnt(i, j, float(rng.normal())))
            weights.SetValue(i + 1, j + 1, float(rng.uniform(0.8, 1.25)))
    uk = _occ._array1_double([0.0, 0.3, 1.0])
    um = Array1_int(1, 3)
    for i, m in enumerate((4, 1, 4), start=1):
        um.SetValue(i, m)
    vk = _occ._array1_double([0.0, 2.0])
    vm = Array1_int(1, 2)
    vm.SetValue(1, 4)
    vm.SetValue(2, 4)
    bs = Geom_BSplineSurface(poles, weights, uk, vk, um, vm, 3, 3)
    surf = _occ.surface_from_occ(bs, np.array([-0.05, 0.0]), np.array([1.02, 2.1]))
    (u0, u1), (v0, v1) = surf.domain
    assert u0 <= -0.05 and u1 >= 1.02 and v0 == 0.0 and v1 >= 2.1
    uv = np.column_stack([rng.uniform(-0.05, 1.02, 40), rng.uniform(0.0, 2.1, 40)])
    ref = occ_surface_d2(bs, uv)  # outside its knot range Open CASCADE continues the end polynomials
    # the extension is exact up to rounding of a de Casteljau extrapolation of ~5 % (poles are O(1))
    assert_allclose(surf.evaluate(uv), ref[0], rtol=0, atol=1e-12)
    d = surf.derivatives(uv, 2)
    assert_allclose(d[1, 0], ref[1], rtol=0, atol=1e-10)
    assert_allclose(d[1, 1], ref[4], rtol=0, atol=1e-8)


def test_extension_that_would_lose_positive_weights_keeps_the_domain():
    from OCP.Geom import Geom_BSplineSurface
    from OCP.collections import Array1_int, Array2_double, Array2_gp_Pnt
    from OCP.gp import gp_Pnt

    poles, weights = Array2_gp_Pnt(1, 4, 1, 2), Array2_double(1, 4, 1, 2)
    for i in range(4):
        for j in range(2):
            poles.SetValue(i + 1, j + 1, gp_Pnt(i, j, 0.0))
            weights.SetValue(i + 1, j + 1, (1.0, 0.05, 3.0, 1.0)[i])
    knots = _occ._array1_double([0.0, 1.0])
    mu, mv = Array1_int(1, 2), Array1_int(1, 2)
    for m in (mu, mv):
        m.SetValue(1, 4 if m is mu else 2)
        m.SetValue(2, 4 if m is mu else 2)
    bs = Geom_BSplineSurface(poles, weights, knots, knots, mu, mv, 3, 1)
    # extrapolating the weights 1, 0.05, 3, 1 to u = -1 gives a negative weight: the surface keeps [0, 1]
    surf = _occ.surface_from_occ(bs, np.array([-1.0, 0.0]), np.array([1.0, 1.0]))
    assert surf.domain == ((0.0, 1.0), (0.0, 1.0))
    assert np.all(surf.weights > 0)


@st.composite
def _nurbs_curves(draw):
    degree = draw(st.integers(1, 5))
    n = draw(st.integers(degree + 1, degree + 6))
    dim = draw(st.sampled_from([2, 3]))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    inner = np.sort(rng.uniform(-1.0, 3.0, n - degree - 1))
    inner = np.round(inner, 3)  # repeated interior knots happen
    lo, hi = -1.5, 3.5
    knots = np.concatenate([[lo] * (degree + 1), inner, [hi] * (degree + 1)])
    # no interior knot may exceed multiplicity `degree` (keep the curve continuous)
    _, counts = np.unique(knots[degree + 1:-degree - 1], return_counts=True)
    assume_ok = bool(np.all(counts <= degree))
    weights = rng.uniform(0.5, 2.0, n) if draw(st.booleans()) else None
    return NurbsCurve(degree, knots, rng.normal(size=(n, dim)), weights), assume_ok


@settings(max_examples=30, deadline=None)
@given(_nurbs_curves())
def test_curve_conversion_round_trip_is_exact(case):
    curve, ok = case
    assume(ok)
    occ = _occ.curve_to_occ(curve)
    back = _occ.curve_from_occ(occ, *curve.domain, curve.dim)
    assert_allclose(back.knots, curve.knots, rtol=0, atol=0)
    assert_allclose(back.control_points, curve.control_points, rtol=0, atol=0)
    assert (back.weights is None) == (curve.weights is None)
    ts = np.linspace(*curve.domain, 13)
    # same polynomial pieces, different summation order: rounding only (points are O(1))
    assert_allclose(curve.evaluate(ts), occ_curve_points(occ, ts, curve.dim), rtol=0, atol=1e-12)


@settings(max_examples=15, deadline=None)
@given(st.integers(1, 4), st.integers(1, 4), st.integers(0, 2**32 - 1), st.booleans())
def test_surface_conversion_round_trip_is_exact(pu, pv, seed, rational):
    from trimsurf.model import NurbsSurface

    rng = np.random.default_rng(seed)
    nu, nv = pu + 1 + int(rng.integers(0, 3)), pv + 1 + int(rng.integers(0, 3))
    ku = np.concatenate([[0.0] * (pu + 1), np.sort(rng.uniform(0.05, 0.95, nu - pu - 1)), [1.0] * (pu + 1)])
    kv = np.concatenate([[2.0] * (pv + 1), np.sort(rng.uniform(2.1, 4.9, nv - pv - 1)), [5.0] * (pv + 1)])
    weights = rng.uniform(0.5, 2.0, (nu, nv)) if rational else None
    surf = NurbsSurface(pu, pv, ku, kv, rng.normal(size=(nu, nv, 3)), weights)
    occ = _occ.surface_to_occ(surf)
    back = _occ.surface_from_occ(occ, np.array([0.0, 2.0]), np.array([1.0, 5.0]))
    assert_allclose(back.knots_u, ku, rtol=0, atol=0)
    assert_allclose(back.knots_v, kv, rtol=0, atol=0)
    assert_allclose(back.control_points, surf.control_points, rtol=0, atol=0)
    uv = np.column_stack([rng.uniform(0, 1, 10), rng.uniform(2, 5, 10)])
    assert_allclose(surf.evaluate(uv), occ_surface_d2(occ, uv)[0], rtol=0, atol=1e-12)


# ---------------------------------------------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------------------------------------------

def _distance_to_curve(points: np.ndarray, curve, t0: float, t1: float) -> np.ndarray:
    """Distance of each point (n, 3) to the curve on [t0, t1]: nearest of 400 samples, then Newton steps."""
    lo, hi = min(t0, t1), max(t0, t1)
    ts = np.linspace(lo, hi, 400)
    samples = curve.evaluate(ts)
    t = ts[np.argmin(np.linalg.norm(points[:, None, :] - samples[None], axis=2), axis=1)]
    for _ in range(8):
        d = curve.derivatives(t, 2)
        r = d[0] - points
        f1 = np.einsum("nk,nk->n", r, d[1])
        f2 = np.einsum("nk,nk->n", d[1], d[1]) + np.einsum("nk,nk->n", r, d[2])
        t = np.clip(t - f1 / np.where(np.abs(f2) > 1e-300, f2, 1.0), lo, hi)
    return np.linalg.norm(curve.evaluate(t) - points, axis=1)


def _same_geometry(a: Shell, b: Shell, diag: float, edge_tolerances: list[float]) -> None:
    """Surfaces equal to 1e-9 diag; trims: read-back p-curves map onto the original edge curves.

    Open CASCADE's STEP reader heals edges whose p-curves deviate from their 3D curve by more than the file's
    uncertainty (the average edge tolerance), re-approximating p-curves or 3D curves, which may change their
    parameterization. So the images F(p(t)) of the read-back p-curves are compared with the original 3D edge
    curves geometrically (closest-point distance to b), within 1.5 x the original edge tolerance.
    """
    rng = np.random.default_rng(1)
    assert len(a.faces) == len(b.faces)
    for fi, (fa, fb) in enumerate(zip(a.faces, b.faces)):
        (u0, u1), (v0, v1) = fa.surface.domain
        uv = np.column_stack([rng.uniform(u0, u1, 20), rng.uniform(v0, v1, 20)])
        # the round-trip tolerance (measured: 4e-13 of the diagonal, STEP's printed precision)
        assert_allclose(fb.surface.evaluate(uv), fa.surface.evaluate(uv), rtol=0, atol=REL * diag)
        assert fa.same_sense == fb.same_sense
        assert [len(lp) for lp in fa.loops] == [len(lp) for lp in fb.loops]
        for la, lb in zip(fa.loops, fb.loops):
            for sa, sb in zip(la.segments, lb.segments):
                if sa.edge_curve is None:
                    continue
                image = fb.surface.evaluate(sb.evaluate(sb.parameters(7)))
                gap = _distance_to_curve(image, sa.edge_curve, sa.t0, sa.t1)
                tol = edge_tolerances[sa.edge_id]
                assert gap.max() <= 1.5 * tol + REL * diag, f"face {fi}: read-back trim off by {gap.max():.3g}"


@pytest.mark.parametrize("name", ["gmsh__t20_data.step", "occt__screw.step"])
def test_step_round_trip(name, tmp_path):
    from OCP.BRepCheck import BRepCheck_Analyzer

    data = load(name)
    out = tmp_path / f"copy_{name}"
    _step.write(data.shell, out)
    shape = _step.read_occ_shape(out)
    assert BRepCheck_Analyzer(shape).IsValid()
    back = _occ.shape_to_shell(shape, name=out.name)
    assert back.is_closed() and data.shell.is_closed()
    assert len(back.edges) == len(data.shell.edges)
    _same_geometry(data.shell, back, data.diag, [e.tolerance for e in data.shell.edges])
    assert sorted(p.name for p in tmp_path.iterdir()) == [out.name]


def test_write_two_solids_keeps_face_order(tmp_path):
    data = load("gmsh__wing_fuselage.step")
    out = tmp_path / "wf.step"
    write_shell(data.shell, out)
    back = read_shell(out)
    assert back.is_closed()
    _same_geometry(data.shell, back, data.diag, [e.tolerance for e in data.shell.edges])


def test_write_single_trimmed_face(tmp_path):
    from OCP.BRepCheck import BRepCheck_Analyzer

    data = load("gmsh__t20_data.step")
    face = data.shell.faces[3]
    out = tmp_path / "one.stp"
    _step.write(face, out)
    assert BRepCheck_Analyzer(_step.read_occ_shape(out)).IsValid()
    back = _step.read(out)
    assert len(back.faces) == 1 and len(back.free_edges()) == len(face.outer_loop) + sum(map(len, face.holes))
    _same_geometry(Shell((face,)), back, data.diag, [e.tolerance for e in data.shell.edges])


def test_untrimmed_face_is_written_on_its_whole_domain(tmp_path):
    from OCP.BRepCheck import BRepCheck_Analyzer

    surface = load("gmsh__t20_data.step").shell.faces[0].surface
    out = tmp_path / "patch.step"
    _step.write(TrimmedFace(surface), out)
    assert BRepCheck_Analyzer(_step.read_occ_shape(out)).IsValid()
    back = _step.read(out)
    assert len(back.faces) == 1 and len(back.faces[0].loops) == 1
    # the boundary of the whole domain: its (u, v) box is the surface's domain
    lo, hi = back.faces[0].outer_loop.polyline(8).min(axis=0), back.faces[0].outer_loop.polyline(8).max(axis=0)
    (u0, u1), (v0, v1) = surface.domain
    assert_allclose([lo, hi], [[u0, v0], [u1, v1]], rtol=0, atol=1e-9 * max(u1 - u0, v1 - v0))


def test_edges_without_3d_curves_get_them_built(tmp_path):
    from OCP.BRepCheck import BRepCheck_Analyzer

    data = load("occt__screw.step")
    edges = tuple(type(e)(None, e.t0, e.t1, e.vertices, e.uses, e.tolerance, e.is_degenerate)
                  for e in data.shell.edges)
    faces = tuple(TrimmedFace(f.surface, tuple(Loop(tuple(PCurve(s.curve, s.t0, s.t1, None, s.edge_id)
                                                          for s in lp.segments)) for lp in f.loops),
                              f.same_sense, tolerance=f.tolerance) for f in data.shell.faces)
    out = tmp_path / "no3d.step"
    _step.write(Shell(faces, edges, data.shell.vertices), out)
    assert BRepCheck_Analyzer(_step.read_occ_shape(out)).IsValid()
    back = _step.read(out)
    assert back.is_closed() and len(back.edges) == len(edges)
    assert all(e.curve is not None for e in back.edges if not e.is_degenerate)


def test_faces_without_topology_are_sewn(tmp_path):
    data = load("gmsh__t20_data.step")
    faces = [TrimmedFace(f.surface, tuple(Loop(tuple(PCurve(s.curve, s.t0, s.t1, s.edge_curve) for s in lp.segments))
                                          for lp in f.loops), f.same_sense) for f in data.shell.faces]
    shell = _step.shell_from_faces(faces)
    assert not shell.has_topology
    out = tmp_path / "sewn.step"
    _step.write(shell, out)
    back = _step.read(out)
    assert len(back.faces) == len(faces) and back.is_closed()


def _reversed_curve(c: NurbsCurve) -> NurbsCurve:
    """c run backwards on the same domain [a, b]: r(s) = c(a + b - s)."""
    a, b = c.domain
    w = None if c.weights is None else c.weights[::-1]
    return NurbsCurve(c.degree, (a + b) - c.knots[::-1], c.control_points[::-1], w)


def _box_with_edge_stored_backwards(ei: int) -> Shell:
    """bspline_box with edge `ei` (and its p-curves, same parameter) on reversed curves: t0 > t1, same vertices."""
    box = bspline_box()
    e = box.edges[ei]
    a, b = e.curve.domain
    faces = list(box.faces)
    for fi, li, si in e.uses:
        f = faces[fi]
        loops = list(f.loops)
        segs = list(loops[li].segments)
        s = segs[si]
        assert s.curve.domain == (a, b)  # shared parameter: the p-curves are reversed on the same map
        segs[si] = PCurve(_reversed_curve(s.curve), a + b - s.t0, a + b - s.t1, _reversed_curve(s.edge_curve),
                          s.edge_id)
        loops[li] = Loop(tuple(segs))
        faces[fi] = TrimmedFace(f.surface, tuple(loops), f.same_sense, f.name, f.tolerance)
    edges = list(box.edges)
    edges[ei] = Edge(_reversed_curve(e.curve), a + b - e.t0, a + b - e.t1, e.vertices, e.uses, e.tolerance)
    return Shell(tuple(faces), tuple(edges), box.vertices, name="flipped_box")


def test_edge_stored_against_its_curve_is_written_valid(tmp_path):
    from OCP.BRepCheck import BRepCheck_Analyzer

    # edge 1 of the box: its old writing put the vertices at the wrong ends, which BRepCheck rejected
    # (a TrimsurfWarning, an error here); every edge is flipped in turn in the loop below
    box = bspline_box()
    for ei in range(len(box.edges)):
        shell = _box_with_edge_stored_backwards(ei)
        e = shell.edges[ei]
        assert e.t0 > e.t1
        # the flipped edge still starts at vertex[0]: b(t0) is that vertex (the box's edges are exact)
        assert_allclose(e.curve.evaluate([e.t0, e.t1]), shell.vertices[list(e.vertices)], rtol=0, atol=1e-9)
        out = tmp_path / f"flipped{ei}.step"
        _step.write(shell, out)
        assert BRepCheck_Analyzer(_step.read_occ_shape(out)).IsValid()
        back = _step.read(out)
        assert back.is_closed() and len(back.edges) == 12 and len(back.vertices) == 8
        # the vertices stay where they were (box corners; tolerance: the exact corners, rounding only)
        assert_allclose(np.sort(back.vertices, axis=0), np.sort(box.vertices, axis=0), rtol=0, atol=1e-9)


def test_edges_without_vertices_are_read_with_index_minus_one(monkeypatch):
    box = bspline_box()
    edges = list(box.edges)
    e = edges[0]
    edges[0] = Edge(e.curve, e.t0, e.t1, (-1, -1), e.uses, tolerance=e.tolerance)
    shell = Shell(box.faces, tuple(edges), box.vertices)
    # ShapeFix_Shape would add the missing vertices: build the shape without it
    monkeypatch.setattr(_occ._to_shape, "_fix", lambda shape: shape)
    back = _occ.shape_to_shell(_occ.nurbs_shape(_occ.shell_to_shape(shell)), name="no_vertices")
    assert [ed.vertices for ed in back.edges].count((-1, -1)) == 1
    assert all(min(ed.vertices) >= 0 for ed in back.edges if ed.vertices != (-1, -1))
    assert len(back.vertices) == 8 and back.is_closed()


def _box_faces_with_gap(gap: float) -> Shell:
    """The box's faces without topology, face 0 moved by `gap` along z (its edges too)."""
    box = bspline_box()
    d = np.array([0.0, 0.0, gap])
    faces = []
    for fi, f in enumerate(box.faces):
        shift = d if fi == 0 else np.zeros(3)
        s = f.surface
        surface = NurbsSurface(s.degree_u, s.degree_v, s.knots_u, s.knots_v, s.control_points + shift, s.weights)
        loops = tuple(Loop(tuple(PCurve(g.curve, g.t0, g.t1, NurbsCurve(g.edge_curve.degree, g.edge_curve.knots,
                                                                         g.edge_curve.control_points + shift))
                                 for g in lp.segments)) for lp in f.loops)
        faces.append(TrimmedFace(surface, loops, f.same_sense, f.name, f.tolerance))
    return Shell.from_faces(faces, name="gapped_box")


def test_sew_tolerance_controls_which_gaps_are_closed(tmp_path):
    shell = _box_faces_with_gap(1e-3)  # the default sewing tolerance is 1e-5 * 478 mm = 4.8e-3 mm > gap
    assert not shell.has_topology
    out = tmp_path / "sewn.step"
    _step.write(shell, out)
    assert _step.read(out).is_closed()
    _step.write(shell, out, sew_tolerance=1e-5)  # below the gap: face 0 stays apart
    back = _step.read(out)
    assert not back.is_closed() and len(back.free_edges()) == 4
    _step.write(shell, out, sew_tolerance=1e-2)
    assert _step.read(out).is_closed()
    for bad in (0.0, -1.0, float("nan"), "1e-3", True):
        with pytest.raises(GeometryError, match="sew_tolerance must be a positive finite number"):
            _step.write(shell, tmp_path / "bad.step", sew_tolerance=bad)
    assert not (tmp_path / "bad.step").exists()


def test_writing_a_shape_open_cascade_rejects_warns(tmp_path):
    # NurbsConvert's p-curves of face 65 of this file self-intersect (the analytic original is valid), so
    # BRepCheck rejects that face of the written shape: the file is written, with a warning
    data = load("occtpr946__bug32596_abc_0_13.step")
    out = tmp_path / "abc.step"
    with pytest.warns(TrimsurfWarning, match="rejects 1 face"):
        _step.write(data.shell, out)
    assert len(_step.read(out).faces) == 99


def test_write_bad_input(tmp_path):
    with pytest.raises(GeometryError, match="not a TrimmedFace"):
        _step.write(["not a face"], tmp_path / "x.step")
    with pytest.raises(GeometryError, match="no faces"):
        _step.write(Shell(()), tmp_path / "empty.step")
    with pytest.raises(GeometryError, match="item 1"):
        _step.shell_from_faces([load("occt__screw.step").shell.faces[0], 3])  # the old name still works
    assert list(tmp_path.iterdir()) == []


def test_write_into_new_folder_leaves_only_the_file(tmp_path):
    out = tmp_path / "new" / "dir" / "screw.step"
    _step.write(load("occt__screw.step").shell, out)
    assert [p.name for p in out.parent.iterdir()] == ["screw.step"]


def test_failing_write_leaves_no_file(tmp_path, monkeypatch):
    def half_write(shape, tmp, path):
        Path(tmp).write_text("ISO-10303-21;\nHEADER;\n")  # a partial file, then failure
        raise GeometryError(f"{path}: simulated failure")

    monkeypatch.setattr(_step, "_write_step_file", half_write)
    out = tmp_path / "fail.step"
    with pytest.raises(GeometryError, match="simulated"):
        _step.write(load("occt__screw.step").shell, out)
    assert list(tmp_path.iterdir()) == []


def test_write_under_a_file_fails_cleanly(tmp_path):
    blocker = tmp_path / "afile"
    blocker.write_text("x")
    with pytest.raises(OSError):
        _step.write(load("occt__screw.step").shell, blocker / "out.step")
    assert [p.name for p in tmp_path.iterdir()] == ["afile"]


# ---------------------------------------------------------------------------------------------------------------
# bad input
# ---------------------------------------------------------------------------------------------------------------

NO_FACES_STEP = """ISO-10303-21;
HEADER;
FILE_DESCRIPTION((''),'2;1');
FILE_NAME('nofaces.step','2025-01-01T00:00:00',(''),(''),'','','');
FILE_SCHEMA(('AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }'));
ENDSEC;
DATA;
#1=CARTESIAN_POINT('',(0.,0.,0.));
ENDSEC;
END-ISO-10303-21;
"""


def _truncated(tmp_path: Path) -> Path:
    data = (CAD / "gmsh__t20_data.step").read_bytes()
    path = tmp_path / "truncated_t20.step"
    path.write_bytes(data[: len(data) // 2])
    return path


@pytest.mark.parametrize("case, match", [
    ("empty", "empty"), ("truncated", "truncated"), ("garbage", "not a readable STEP"),
    ("nofaces", "no faces"), ("missing", "no such file"),
])
def test_bad_step_files_raise_one_line_and_print_nothing(case, match, tmp_path, capfd):
    path = {
        "empty": tmp_path / "empty_file.step",
        "truncated": None,
        "garbage": tmp_path / "garbage_text.step",
        "nofaces": tmp_path / "no_faces.step",
        "missing": tmp_path / "missing_file.step",
    }[case]
    if case == "empty":
        path.write_bytes(b"")
    elif case == "truncated":
        path = _truncated(tmp_path)
    elif case == "garbage":
        path.write_text("this is not a STEP file\n{[(\n")
    elif case == "nofaces":
        path.write_text(NO_FACES_STEP)
    with pytest.raises(StepReadError, match=match) as info:
        _step.read(path)
    message = str(info.value)
    assert str(path) in message and "\n" not in message
    out, err = capfd.readouterr()
    assert out == "" and err == ""
    # the public dispatcher raises the same kind
    with pytest.raises(FileFormatError, match=path.name):
        read_shell(path)
    capfd.readouterr()
