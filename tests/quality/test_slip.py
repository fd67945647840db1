"""A deviation inside a triangle, away from its vertices and from the fixed sample nodes, must be reported.

One acute triangle inscribed in the unit sphere (vertices exactly on the surface, so their deviation is
0): its largest distance to the sphere is at its circumcentre (the foot of the sphere's centre on its
plane), 1 - h, here at barycentric (0.47, 0.35, 0.18): no node of the 3-division grid, no edge point.
"""

import numpy as np

from trimsurf.model import NurbsSurface, TriMesh
from trimsurf.quality import surface_deviation
from trimsurf.tessellate.measure import REFINE

S2 = np.sqrt(0.5)


def sphere_octant():
    w = np.outer([1, S2, 1], [1, S2, 1])
    cp = np.array([[[0, 0, 1], [0, 0, 1], [0, 0, 1]], [[1, 0, 1], [1, 1, 1], [0, 1, 1]],
                   [[1, 0, 0], [1, 1, 0], [0, 1, 0]]], float)
    return NurbsSurface(2, 2, [0, 0, 0, 1, 1, 1], [0, 0, 0, 1, 1, 1], cp, w)


def inscribed_triangle(half_angle_deg=35.0, corners_deg=(0, 160, 220)):
    """Vertices on the unit sphere on a circle of angular radius `half_angle_deg` about (1, 1, 1); the
    triangle's angles are half the arcs between them (here 30, 70, 80 deg)."""
    n0 = np.ones(3) / np.sqrt(3)
    e1 = np.array([1.0, -1.0, 0.0]) / np.sqrt(2)
    e2 = np.cross(n0, e1)
    h, r = np.cos(np.radians(half_angle_deg)), np.sin(np.radians(half_angle_deg))
    a = np.radians(corners_deg)
    return h * n0 + r * (np.cos(a)[:, None] * e1 + np.sin(a)[:, None] * e2), 1.0 - h


def test_deviation_inside_a_triangle_away_from_all_samples_is_reported():
    p, truth = inscribed_triangle()
    mesh = TriMesh(p, [[0, 1, 2]])
    sphere = sphere_octant()
    np.testing.assert_allclose(np.linalg.norm(p, axis=1), 1.0, atol=1e-15)
    fixed = surface_deviation(mesh, sphere, density=3, two_sided=False)
    refined = surface_deviation(mesh, sphere, density=3, two_sided=False, refine=REFINE)
    tolerance = 0.98 * truth
    # the fixed grid lets the maximum slip between its nodes (3.3 % low: "within tolerance")
    assert fixed.max_mesh_to_target < tolerance
    # the sampling that follows the triangle's size and curvature reports it: beyond the tolerance, within
    # REFINE of the true maximum, and the curvature bound at or above it
    assert refined.max_mesh_to_target > tolerance
    assert truth * (1 - REFINE) <= refined.max_mesh_to_target <= truth + 1e-12
    assert refined.max_bound >= truth
    assert refined.n_refined >= 1
