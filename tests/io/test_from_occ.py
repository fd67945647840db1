"""In-memory Open CASCADE shapes: `from_occ` converts as the STEP reader does, `to_occ` builds what STEP writes.

CadQuery 2.8.0 and build123d 0.13.0 cannot be installed beside the pinned
cadquery-ocp 8.0.1.1.0 (CadQuery requires cadquery-ocp < 8.0; build123d brings
a second Open CASCADE build, cadquery-ocp-novtk, into the same ``OCP``
folder: README, "Python CAD ecosystem"). Their objects are what these tests
build by hand: a ``TopoDS_Shape`` behind a ``.wrapped`` attribute (CadQuery
``Shape``, build123d ``Part``), a ``vals()`` list (CadQuery ``Workplane``), a
``part`` attribute (build123d ``BuildPart``).
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from trimsurf.errors import GeometryError, InputError
from trimsurf.io import _occ, from_occ, read_shell, to_occ
from trimsurf.samples import build_sample
from trimsurf.tessellate import tessellate_shell


def filleted_box(dx=30.0, dy=20.0, dz=10.0, radius=2.0, origin=(0.0, 0.0, 0.0)):
    """BRepPrimAPI_MakeBox + BRepFilletAPI_MakeFillet on every edge: the CadQuery ``box().fillet()`` part."""
    from OCP.BRepFilletAPI import BRepFilletAPI_MakeFillet
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.gp import gp_Pnt
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    box = BRepPrimAPI_MakeBox(gp_Pnt(*origin), dx, dy, dz).Shape()
    fillet = BRepFilletAPI_MakeFillet(box)
    ex = TopExp_Explorer(box, TopAbs_EDGE)
    while ex.More():
        fillet.Add(radius, TopoDS.Edge(ex.Current()))
        ex.Next()
    return fillet.Shape()


def cylinder_with_hole():
    """A build123d-like part: a cylinder minus a through box (BRepAlgoAPI_Cut), cylinder and plane faces."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder
    from OCP.gp import gp_Pnt

    cyl = BRepPrimAPI_MakeCylinder(10.0, 25.0).Shape()
    cut = BRepAlgoAPI_Cut(cyl, BRepPrimAPI_MakeBox(gp_Pnt(-3, -3, -1), 6.0, 6.0, 30.0).Shape())
    return cut.Shape()


def write_step(shape, path):
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    with _occ.quiet_occ():
        writer = STEPControl_Writer()
        writer.Transfer(shape, STEPControl_AsIs)
        writer.Write(str(path))
    return path


class Wrapped:
    """A CadQuery Shape / build123d Part: the TopoDS_Shape in ``.wrapped``."""

    def __init__(self, shape):
        self.wrapped = shape


class Workplane:
    """A CadQuery Workplane: its objects through ``vals()``."""

    def __init__(self, *shapes):
        self._objects = [Wrapped(s) for s in shapes] + ["a non-shape object on the stack"]

    def vals(self):
        return list(self._objects)


class BuildPart:
    """A build123d BuildPart builder: the result in ``.part``."""

    def __init__(self, shape):
        self.part = Wrapped(shape)


def _guarantees(result) -> dict:
    rep = result.report
    assert result.ok and rep["faces_failed"] == 0
    assert rep["max_deviation"] <= rep["tolerance"], (rep["max_deviation"], rep["tolerance"])
    assert result.mesh.is_watertight() and result.mesh.is_consistently_oriented()
    assert rep["flipped"] == 0 and rep["nonmanifold_edges"] == 0
    return rep


@pytest.mark.parametrize("make", [filleted_box, cylinder_with_hole])
def test_in_memory_part_tessellates_as_its_step_export(make, tmp_path):
    shape = make()
    shell = from_occ(shape, name="part")
    via_step = read_shell(write_step(shape, tmp_path / "part.step"))
    assert shell.is_closed() and via_step.is_closed()
    assert (len(shell.faces), len(shell.edges)) == (len(via_step.faces), len(via_step.edges))
    diag = shell.diagonal()
    # the STEP writer orders the faces its own way and places planes on its own axes (another (u, v)): the same
    # faces, compared by the centroid and count of their control points
    assert sorted(map(_face_key, shell.faces)) == sorted(map(_face_key, via_step.faces))
    direct, exported = tessellate_shell(shell), tessellate_shell(via_step)
    rd, re = _guarantees(direct), _guarantees(exported)
    assert rd["mode"] == re["mode"] == "conforming"
    assert rd["tolerance"] == pytest.approx(re["tolerance"], rel=1e-12)
    # not the same triangles (planes get other (u, v) axes, so other grids) but as many within 10 %, and the
    # same extent (the extreme points lie on shared edges, discretized alike)
    assert abs(direct.mesh.n_triangles - exported.mesh.n_triangles) <= 0.1 * exported.mesh.n_triangles
    lo_d, hi_d = direct.mesh.bounding_box()
    lo_e, hi_e = exported.mesh.bounding_box()
    np.testing.assert_allclose(np.r_[lo_d, hi_d], np.r_[lo_e, hi_e], rtol=0, atol=1e-9 * diag)


def _face_key(face) -> tuple:
    cp = face.surface.control_points
    return tuple(np.round(np.r_[cp.reshape(-1, cp.shape[-1]).mean(axis=0), cp.size], 6))


def test_filleted_box_faces():
    shell = from_occ(filleted_box())
    # 6 planes, 12 fillet cylinders, 8 corner spheres
    assert len(shell.faces) == 26 and shell.is_closed()


def test_wrappers_give_the_same_shell():
    shape = filleted_box()
    ref = from_occ(shape)
    for obj in (Wrapped(shape), Workplane(shape), BuildPart(shape), [Wrapped(shape)]):
        got = from_occ(obj)
        assert len(got.faces) == len(ref.faces) and len(got.edges) == len(ref.edges)
        for a, b in zip(got.faces, ref.faces):
            assert_array_equal(a.surface.control_points, b.surface.control_points)


def test_several_shapes_become_one_compound():
    two = from_occ(Workplane(filleted_box(), filleted_box(origin=(50.0, 0.0, 0.0))))
    assert len(two.faces) == 52 and two.is_closed()


def test_input_shape_is_not_modified():
    from OCP.BRep import BRep_Tool
    from OCP.BRepCheck import BRepCheck_Analyzer

    shape = filleted_box()
    kinds = [BRep_Tool.Surface_s(f).DynamicType().Name() for f in _occ.map_topology(shape).faces]
    from_occ(shape)
    assert [BRep_Tool.Surface_s(f).DynamicType().Name() for f in _occ.map_topology(shape).faces] == kinds
    assert "Geom_Plane" in kinds and BRepCheck_Analyzer(shape).IsValid()


def test_to_occ_round_trip_and_validity():
    from OCP.BRepCheck import BRepCheck_Analyzer

    shell = build_sample("bspline_box")
    shape = to_occ(shell)
    assert shape.ShapeType().name == "TopAbs_SOLID" and BRepCheck_Analyzer(shape).IsValid()
    back = from_occ(shape)
    assert back.is_closed() and len(back.faces) == len(shell.faces)
    for a, b in zip(back.faces, shell.faces):
        np.testing.assert_allclose(a.surface.control_points, b.surface.control_points, rtol=0,
                                   atol=1e-12 * shell.diagonal())
    one = to_occ(shell.faces[0])
    assert _occ.count_faces(one) == 1


def test_bad_input():
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
    from OCP.gp import gp_Pnt
    from OCP.TopoDS import TopoDS_Shape

    with pytest.raises(InputError, match="expected an Open CASCADE TopoDS_Shape.*got int"):
        from_occ(42)
    with pytest.raises(InputError, match="empty sequence"):
        from_occ([])
    with pytest.raises(InputError, match="Workplane holds no shape"):
        from_occ(Workplane())
    with pytest.raises(GeometryError, match="null"):
        from_occ(TopoDS_Shape())
    with pytest.raises(GeometryError, match="point: holds no faces|holds no faces"):
        from_occ(BRepBuilderAPI_MakeVertex(gp_Pnt(1, 2, 3)).Shape(), name="point")
    with pytest.raises(GeometryError, match="far: face .* above 1e\\+10"):
        from_occ(filleted_box(origin=(1e11, 0.0, 0.0)), name="far")

    from OCP.BRep import BRep_Builder
    from OCP.TopoDS import TopoDS_Face

    no_surface = TopoDS_Face()
    BRep_Builder().MakeFace(no_surface)  # converting it would crash the process: refused first
    with pytest.raises(GeometryError, match="bare: face 0 has no surface"):
        from_occ(no_surface, name="bare")

    class TopoDS_Solid:  # noqa: N801 - a class of another OCP build has the same name, not the same type
        pass

    with pytest.raises(InputError, match="another OCP build"):
        from_occ(Wrapped(TopoDS_Solid()))
    with pytest.raises(InputError, match="to_occ: expected a Shell"):
        to_occ("box.step")
    with pytest.raises(GeometryError, match="no faces"):
        to_occ([])
