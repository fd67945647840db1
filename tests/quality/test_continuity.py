"""G0 / G1 continuity across shared boundaries."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose

from trimsurf.errors import InputError
from trimsurf.model import Edge, NurbsSurface, Shell
from trimsurf.quality import boundary_continuity, edge_continuity, face_continuity, surface_continuity

from ._meshes import rect_face, sphere_patch


def bilinear(p00, p10, p01, p11) -> NurbsSurface:
    return NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], [[p00, p01], [p10, p11]])


def moved(s: NurbsSurface, offset) -> NurbsSurface:
    return NurbsSurface(s.degree_u, s.degree_v, s.knots_u, s.knots_v, s.control_points + offset, s.weights)


@pytest.mark.parametrize("angle_deg", [0.0, 30.0, 90.0])
def test_two_planes_at_a_dihedral_angle(angle_deg):
    a = bilinear([0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0])
    c, s = np.cos(np.radians(angle_deg)), np.sin(np.radians(angle_deg))
    b = bilinear([1, 0, 0], [1 + c, 0, s], [1, 1, 0], [1 + c, 1, s])
    r = surface_continuity(a, b, n_samples=17)
    assert r.segments == ("u1", "u0")
    assert r.max_gap <= 1e-15
    # normals (0, 0, 1) and (-s, 0, c): the angle is exact up to arccos rounding near 0 (~1e-6 degrees)
    assert_allclose(r.max_angle_deg, min(angle_deg, 180 - angle_deg), rtol=0, atol=1e-6)


def test_faces_of_one_surface_are_g1_and_a_shift_is_g0_gap():
    s = sphere_patch()
    fa = rect_face(s, (0.1, 0.1), (0.5, 0.9), edge_ids=(-1, 7, -1, -1))
    fb = rect_face(s, (0.5, 0.1), (0.9, 0.9), edge_ids=(-1, -1, -1, 7))
    r = face_continuity(fa, fb)
    assert r.segments == ((0, 1), (0, 3))
    # the same surface on both sides: gap and angle vanish up to the curve-parameter refinement (1e-12)
    assert r.max_gap <= 1e-12 and r.max_angle_deg <= 1e-5 and r.orientation_consistent
    shifted = rect_face(moved(s, [0, 0, 1e-3]), (0.5, 0.1), (0.9, 0.9), edge_ids=(-1, -1, -1, 7))
    r = face_continuity(fa, shifted)
    # a translation keeps normals; the shifted curve is never farther than 1e-3 (the translated twin), and
    # at the lower end of the edge its nearest point is the shifted end point itself, exactly 1e-3 away
    assert_allclose(r.max_gap, 1e-3, rtol=0, atol=1e-9)
    assert r.max_angle_deg < 0.1
    json.dumps(r.as_dict(arrays=True), allow_nan=False)


def test_matching_without_edge_ids_and_orientation():
    s = sphere_patch()
    fa, fb = rect_face(s, (0.1, 0.1), (0.5, 0.9)), rect_face(s, (0.5, 0.1), (0.9, 0.9), same_sense=False)
    r = face_continuity(fa, fb)
    assert r.segments == ((0, 1), (0, 3)) and r.max_gap <= 1e-12
    assert not r.orientation_consistent and r.max_oriented_angle_deg > 179.99 and r.max_angle_deg <= 1e-5


def test_edge_continuity_on_a_shell():
    s = sphere_patch()
    fa, fb = rect_face(s, (0.1, 0.1), (0.5, 0.9)), rect_face(moved(s, [0, 2e-4, 0]), (0.5, 0.1), (0.9, 0.9))
    shell = Shell((fa, fb), (Edge(None, 0, 1, (0, 1), ((0, 0, 1), (1, 0, 3))),), np.zeros((2, 3)))
    r = edge_continuity(shell, 0)
    direct = boundary_continuity(fa, (0, 1), fb, (0, 3))
    assert r.max_gap == direct.max_gap
    # the boundary is the meridian at azimuth 45 deg: the shift has 2e-4 cos 45 deg across its plane,
    # a lower bound of every gap; the translated twin bounds it above
    assert 2e-4 * np.sqrt(0.5) - 1e-12 <= r.max_gap <= 2e-4 + 1e-12


def test_bad_input():
    s = sphere_patch()
    fa = rect_face(s)
    shell = Shell((fa,), (Edge(None, 0, 1, (0, 1), ((0, 0, 1),)),), np.zeros((2, 3)))
    with pytest.raises(InputError, match="edge 0 has 1 face sides"):
        edge_continuity(shell, 0)
    with pytest.raises(InputError, match="no edge 3"):
        edge_continuity(shell, 3)
    with pytest.raises(InputError, match=r"no loop segment \(0, 9\)"):
        boundary_continuity(fa, (0, 9), fa, (0, 0))
    with pytest.raises(InputError, match="n_samples must be >= 2"):
        boundary_continuity(fa, (0, 1), fa, (0, 3), n_samples=1)
    with pytest.raises(InputError, match="needs NurbsSurfaces"):
        surface_continuity(fa, s)
    with pytest.raises(InputError, match="has no loops"):
        face_continuity(fa, type(fa)(s))
