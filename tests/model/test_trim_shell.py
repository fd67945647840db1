"""Trimmed faces, loops and shells: construction, validation, orientation helpers."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from trimsurf.errors import GeometryError, TrimLoopError
from trimsurf.model import Edge, Loop, NurbsCurve, NurbsSurface, PCurve, Shell, TrimmedFace
from trimsurf.tolerance import Tolerance, default_tolerance


def line(a, b):
    return NurbsCurve(1, [0, 0, 1, 1], np.array([a, b], dtype=float))


def square_loop(lo=0.0, hi=1.0, *, ccw=True):
    c = [(lo, lo), (hi, lo), (hi, hi), (lo, hi)]
    if not ccw:
        c = c[::-1]
    return Loop(tuple(PCurve(line(c[i], c[(i + 1) % 4]), 0.0, 1.0) for i in range(4)))


def plane():
    cp = np.array([[[0, 0, 0], [0, 2, 0]], [[3, 0, 0], [3, 2, 0]]], dtype=float)
    return NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], cp)


def test_loop_orientation_gaps_and_polyline():
    outer, hole = square_loop(), square_loop(0.25, 0.75, ccw=False)
    assert_allclose(outer.signed_area(), 1.0, rtol=0, atol=1e-14)
    assert_allclose(hole.signed_area(), -0.25, rtol=0, atol=1e-14)
    assert outer.is_closed(1e-12)
    assert outer.polyline(5).shape == (16, 2)
    face = TrimmedFace(plane(), (outer, hole))
    assert face.outer_loop is outer and face.holes == (hole,)
    n = face.oriented_normals([[0.5, 0.5]])
    assert_allclose(n, [[0, 0, 1]], atol=1e-15)
    flipped = TrimmedFace(plane(), (outer, hole), same_sense=False)
    assert_allclose(flipped.oriented_normals([[0.5, 0.5]]), [[0, 0, -1]], atol=1e-15)


def test_open_loop_reports_its_gap():
    segs = list(square_loop().segments)
    segs[2] = PCurve(line((1.0, 1.0), (0.0, 1.1)), 0.0, 1.0)  # ends 0.1 off the next start
    loop = Loop(tuple(segs))
    assert not loop.is_closed(1e-9)
    assert_allclose(loop.gaps().max(), 0.1, rtol=0, atol=1e-14)


def test_reversed_pcurve_range():
    seg = PCurve(line((0, 0), (1, 0)), 1.0, 0.0)
    assert_allclose(seg.start, [1, 0])
    assert_allclose(seg.end, [0, 0])


def test_shell_topology_queries():
    face = TrimmedFace(plane(), (square_loop(),))
    e_shared = Edge(None, 0, 1, (0, 1), ((0, 0, 0), (1, 0, 2)))
    e_free = Edge(None, 0, 1, (1, 2), ((0, 0, 1),))
    e_nm = Edge(None, 0, 1, (2, 0), ((0, 0, 2), (1, 0, 1), (2, 0, 0)))
    shell = Shell((face, face, face), (e_shared, e_free, e_nm), np.zeros((3, 3)))
    assert shell.free_edges() == [1]
    assert shell.non_manifold_edges() == [2]
    assert not shell.is_closed()
    assert shell.adjacency() == {0: {1, 2}, 1: {0, 2}, 2: {0, 1}}
    assert_allclose(shell.diagonal(), np.sqrt(13), rtol=1e-14)


def test_vertex_index_minus_one_means_no_vertex():
    face = TrimmedFace(plane(), (square_loop(),))
    shell = Shell((face,), (Edge(None, 0, 1, (-1, -1), ((0, 0, 0),)), Edge(None, 0, 1, (0, -1), ((0, 0, 1),))),
                  np.zeros((1, 3)))
    assert [e.vertices for e in shell.edges] == [(-1, -1), (0, -1)]
    assert Shell((face,), (Edge(None, 0, 1, (-1, -1), ((0, 0, 0),)),)).has_topology  # no vertices at all
    for bad in ((-2, 0), (0, 1)):
        with pytest.raises(GeometryError, match=r"refers to vertex .* shell has 1 \(-1 means no vertex\)"):
            Shell((face,), (Edge(None, 0, 1, bad, ((0, 0, 0),)),), np.zeros((1, 3)))


def test_shell_from_faces():
    face = TrimmedFace(plane(), (square_loop(),))
    shell = Shell.from_faces([face, face], name="two")
    assert shell.faces == (face, face) and shell.edges == () and shell.vertices.shape == (0, 3)
    assert shell.name == "two" and not shell.has_topology and not shell.is_closed()
    assert Shell.from_faces(face).faces == (face,)
    with pytest.raises(GeometryError, match=r"Shell.from_faces: item 1 is a str, not a TrimmedFace"):
        Shell.from_faces([face, "face"])


def test_bad_input():
    with pytest.raises(TrimLoopError, match="at least one segment"):
        Loop(())
    with pytest.raises(GeometryError, match="must be 2D"):
        PCurve(NurbsCurve(1, [0, 0, 1, 1], np.zeros((2, 3))), 0, 1)
    with pytest.raises(GeometryError, match="non-empty"):
        PCurve(line((0, 0), (1, 0)), 0.5, 0.5)
    face = TrimmedFace(plane(), (square_loop(),))
    with pytest.raises(GeometryError, match="refers to face 3"):
        Shell((face,), (Edge(None, 0, 1, (0, 0), ((3, 0, 0),)),), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="point must be a positive"):
        Tolerance(point=0.0)


def test_default_tolerance_scales_with_diagonal():
    assert default_tolerance(200.0).point == pytest.approx(2e-5)
    assert default_tolerance(float("nan")).point == pytest.approx(1e-7)
