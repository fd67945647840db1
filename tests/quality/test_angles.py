"""Triangle angles and aspect ratios."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from trimsurf.errors import InputError
from trimsurf.model import TriMesh
from trimsurf.quality import aspect_ratios, triangle_angles, triangle_quality


def equilateral_mesh(n: int = 8) -> TriMesh:
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    v = np.column_stack([(i + 0.5 * j).ravel(), (np.sqrt(3) / 2 * j).ravel(), np.zeros(n * n)])
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    return TriMesh(v, np.vstack([np.column_stack([a, b, d]), np.column_stack([b, c, d])]))


def test_equilateral_mesh():
    m = equilateral_mesh()
    q = triangle_quality(m)
    # sqrt(3) / 2 is rounded once: angles are 60 degrees to ~1e-13
    assert_allclose(triangle_angles(m), 60.0, rtol=0, atol=1e-12)
    assert_allclose([q.min_angle_deg, q.max_angle_deg, q.p5_min_angle_deg], 60.0, rtol=0, atol=1e-12)
    assert_allclose(q.max_radius_ratio, 1.0, rtol=0, atol=1e-12)
    assert_allclose(q.max_edge_altitude, 2 / np.sqrt(3), rtol=0, atol=1e-12)
    assert q.histogram_counts[5] + q.histogram_counts[6] == 3 * m.n_triangles  # bins [50, 60) and [60, 70)
    assert q.histogram_counts.sum() == 3 * m.n_triangles and q.share_min_angle_below == 0.0


def test_right_triangle_and_needle():
    m = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0.01, 0], [5, 0, 0]], [[0, 1, 2], [0, 4, 3]])
    ang = triangle_angles(m)
    assert_allclose(ang[0], [90, 45, 45], rtol=0, atol=1e-12)
    assert_allclose(ang[1, 1], np.degrees(np.arctan(0.01 / 5)), rtol=0, atol=1e-12)
    q = triangle_quality(m)
    assert q.share_min_angle_below == 0.5 and q.worst_triangle == 1
    ea, rr = aspect_ratios(m)
    assert_allclose(ea[0], 2 / 1.0, rtol=0, atol=1e-12)        # hypotenuse^2 / (2 A) = 2 / 1
    # right isosceles, legs 1: R = sqrt(2) / 2, r = (2 - sqrt(2)) / 2, R / (2 r) = (1 + sqrt(2)) / 2
    assert_allclose(rr[0], (1 + np.sqrt(2)) / 2, rtol=0, atol=1e-12)


def test_zero_area_triangle():
    m = TriMesh([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]], [[0, 1, 2], [0, 1, 3]])
    q = triangle_quality(m)
    assert q.n_zero_area == 1 and q.min_angle_deg == 0.0 and q.max_angle_deg == 180.0
    assert q.max_radius_ratio == np.inf and q.max_edge_altitude == np.inf
    assert q.as_dict()["max_radius_ratio"] is None  # JSON has no infinity


def test_bad_input():
    with pytest.raises(InputError, match="needs a TriMesh"):
        triangle_angles(np.zeros((3, 3)))
    with pytest.raises(InputError, match="at least one triangle"):
        triangle_quality(TriMesh(np.zeros((3, 3)), np.zeros((0, 3))))
    with pytest.raises(InputError, match="bin_width_deg"):
        triangle_quality(equilateral_mesh(3), bin_width_deg=0)
