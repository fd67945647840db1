"""Normal deviation and the joining paper's height-field slope."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from trimsurf.errors import InputError
from trimsurf.model import TriMesh
from trimsurf.quality import height_field_slope, normal_deviation

from ._meshes import SPHERE_R, circumradii, grid_mesh, lattice_mesh, plane_patch, rect_face, sphere_patch


def test_plane_mesh_has_zero_normal_deviation_and_flipped_has_180():
    s = plane_patch()
    m = grid_mesh(s, 6, lo=0.0, hi=1.0)
    # arccos near 1 turns a rounding of 1e-16 in the cosine into ~1e-8 rad: 1e-6 degrees
    assert normal_deviation(m, s).max_deg <= 1e-6
    assert_allclose(normal_deviation(m.flipped(), s).max_deg, 180.0, rtol=0, atol=1e-6)
    # a face whose outward side is -(Su x Sv) turns the verdict around
    face = rect_face(s, (0, 0), (1, 1), same_sense=False)
    assert_allclose(normal_deviation(m, face).max_deg, 180.0, rtol=0, atol=1e-6)
    assert normal_deviation(m.flipped(), face).max_deg <= 1e-6


def test_inscribed_sphere_mesh_normal_angle_is_asin_rc_over_r():
    s = sphere_patch()
    m = lattice_mesh(s, 9)
    r = normal_deviation(m, s, density=2)
    # The plane of an inscribed triangle is normal to the direction of its circumcentre; the sphere normal
    # at the foot of a point at in-plane distance rho from it makes the angle atan(rho / delta), largest at
    # the corners (rho = rc): asin(rc / R). Corners are sampled, so the figure is exact up to the
    # projection tolerance (~1e-9 rad).
    expected = np.degrees(np.arcsin(circumradii(m) / SPHERE_R))
    assert_allclose(r.per_triangle_max_deg, expected, rtol=0, atol=1e-6)
    assert_allclose(r.max_deg, expected.max(), rtol=0, atol=1e-6)
    assert r.n_singular == 0
    assert_allclose(expected[r.worst_triangle], expected.max(), rtol=0, atol=1e-6)  # symmetric ties


def test_height_field_slope_over_a_plane():
    s = plane_patch()                      # z = 1, x = 2 u, y = v; normal Su x Sv = +z
    m = grid_mesh(s, 5, lo=0.0, hi=1.0)
    eta = np.random.default_rng(4).uniform(-0.01, 0.01, m.n_vertices)
    lifted = TriMesh(m.vertices + eta[:, None] * [0, 0, 1], m.triangles)
    uv = m.uv
    t = m.triangles
    for metric, where in (("uv", uv), ("3d", m.vertices)):
        r = height_field_slope(lifted, s, metric=metric)
        expected = np.max([np.abs(eta[t[:, i]] - eta[t[:, k]]) / np.linalg.norm(where[t[:, i]] - where[t[:, k]],
                                                                                axis=1)
                           for i, k in ((0, 1), (1, 2), (2, 0))], axis=0)
        # heights and feet come from projections converged to 1e-10 of the diagonal: 1e-9 absolute on slopes
        # of order 0.1 over corner distances of order 0.25
        assert_allclose(r.heights, eta, rtol=0, atol=1e-10)
        assert_allclose(r.per_triangle, expected, rtol=0, atol=1e-9)
        assert_allclose(r.max_slope, expected.max(), rtol=0, atol=1e-9)
        assert_allclose(r.max_abs_height, np.abs(eta).max(), rtol=0, atol=1e-10)  # eq. (1) at the corners


def test_height_field_slope_over_a_sphere_is_radial():
    s = sphere_patch()
    m = lattice_mesh(s, 7)
    eps = np.random.default_rng(5).uniform(-1e-3, 1e-3, m.n_vertices)
    v = m.vertices * ((SPHERE_R + eps) / SPHERE_R)[:, None]  # radial offsets: eta = eps, foot uv = mesh uv
    r = height_field_slope(TriMesh(v, m.triangles), s)
    t = m.triangles
    expected = np.max([np.abs(eps[t[:, i]] - eps[t[:, k]]) / np.linalg.norm(m.uv[t[:, i]] - m.uv[t[:, k]], axis=1)
                       for i, k in ((0, 1), (1, 2), (2, 0))], axis=0)
    assert_allclose(r.heights, eps, rtol=0, atol=1e-10)
    assert_allclose(r.per_triangle, expected, rtol=0, atol=1e-8)  # 1e-10 feet over corner distances >= 0.02
    assert r.n_undefined == 0


def test_bad_input():
    s = plane_patch()
    m = grid_mesh(s, 3)
    with pytest.raises(InputError, match="metric must be 'uv' or '3d'"):
        height_field_slope(m, s, metric="xyz")
    with pytest.raises(InputError, match="NurbsSurface or TrimmedFace"):
        normal_deviation(m, m)
    with pytest.raises(InputError, match="needs a TriMesh"):
        height_field_slope(s, s)
