"""Exact closest points on triangles and meshes."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from trimsurf.errors import InputError, MeshError
from trimsurf.io import read_mesh
from trimsurf.model import TriMesh
from trimsurf.quality import closest_points_on_mesh, point_segment_closest, point_triangle_closest

from ._meshes import icosphere

A, B, C = np.array([0.0, 0, 0]), np.array([2.0, 0, 0]), np.array([0.0, 1, 0])


@pytest.mark.parametrize("p, expected", [
    ([-1, -1, 3], [0, 0, 0]),           # vertex region A
    ([3, -1, 0], [2, 0, 0]),            # vertex region B
    ([-1, 2, -2], [0, 1, 0]),           # vertex region C
    ([1, -5, 1], [1, 0, 0]),            # edge AB
    ([-3, 0.5, 0], [0, 0.5, 0]),        # edge AC
    ([2, 1, 7], [1.6, 0.2, 0]),         # edge BC: B + (1/5) (-2, 1), foot of (2, 1) on x + 2 y = 2
    ([0.5, 0.25, -4], [0.5, 0.25, 0]),  # interior
])
def test_voronoi_regions(p, expected):
    q, w = point_triangle_closest([p], [A], [B], [C])
    assert_allclose(q[0], expected, rtol=0, atol=1e-15)  # all coordinates exact in binary up to one rounding
    assert_allclose(w @ np.array([A, B, C]), q, rtol=0, atol=1e-15)


def test_matches_dense_sampling_on_random_triangles():
    rng = np.random.default_rng(1)
    n = 2000
    a, b, c, p = (rng.normal(size=(n, 3)) for _ in range(4))
    q, w = point_triangle_closest(p, a, b, c)
    d = np.linalg.norm(q - p, axis=1)
    s = np.linspace(0, 1, 41)
    uu, vv = np.meshgrid(s, s)
    keep = uu + vv <= 1
    uu, vv = uu[keep], vv[keep]
    grid = a[:, None] * (1 - uu - vv)[None, :, None] + b[:, None] * uu[None, :, None] + c[:, None] * vv[None, :, None]
    ds = np.linalg.norm(grid - p[:, None], axis=2).min(axis=1)
    # exact distance never exceeds any sample's distance (1e-14: rounding) ...
    assert np.all(d <= ds + 1e-14)
    # ... and the nearest sample is within the grid's covering radius h <= longest edge / 40
    h = np.max([np.linalg.norm(b - a, axis=1), np.linalg.norm(c - a, axis=1), np.linalg.norm(c - b, axis=1)],
               axis=0) / 40
    assert np.all(ds - d <= h)
    assert np.all(w >= -1e-15) and np.allclose(w.sum(axis=1), 1.0, rtol=0, atol=1e-14)


def test_zero_area_triangle_uses_its_edges():
    q, w = point_triangle_closest([[1, 1, 0]], [[0, 0, 0]], [[1, 0, 0]], [[2, 0, 0]])
    assert_allclose(q, [[1, 0, 0]], rtol=0, atol=0)
    q, _ = point_segment_closest([[5.0, 1.0]], [[0.0, 0.0]], [[2.0, 0.0]])
    assert_allclose(q, [[2.0, 0.0]], rtol=0, atol=0)


def test_mesh_closest_points_match_brute_force(shared_data):
    m = read_mesh(shared_data / "meshes" / "nefertiti.off")
    rng = np.random.default_rng(2)
    lo, hi = m.bounding_box()
    q = lo + (hi - lo) * rng.uniform(-0.2, 1.2, size=(300, 3))
    r = closest_points_on_mesh(q, m)
    p = m.vertices[m.triangles]
    k = len(p)
    qq = np.repeat(q, k, axis=0)
    cl, _ = point_triangle_closest(qq, np.tile(p[:, 0], (len(q), 1)), np.tile(p[:, 1], (len(q), 1)),
                                   np.tile(p[:, 2], (len(q), 1)))
    brute = np.linalg.norm(cl - qq, axis=1).reshape(len(q), k).min(axis=1)
    assert_allclose(r.distance, brute, rtol=0, atol=1e-12)  # same formula, only the search differs
    assert_allclose(np.linalg.norm(r.point - q, axis=1), r.distance, rtol=0, atol=1e-12)


def test_mesh_with_very_uneven_triangles():
    # one huge triangle next to a fine sphere: radius buckets must still find the exact answer
    s = icosphere(2, radius=0.1)
    big = TriMesh(np.vstack([s.vertices, [[-50, -50, -1], [50, -50, -1], [0, 50, -1]]]),
                  np.vstack([s.triangles, [[s.n_vertices, s.n_vertices + 1, s.n_vertices + 2]]]))
    q = np.array([[0, 0, -0.95], [0, 0, 0.5], [30, -40, 3]])
    # the sphere mesh is inscribed in radius 0.1: from (0, 0, 0.5) the distance is 0.4 plus at most the
    # sagitta of its triangles (< 2e-3 at level 2); the plane z = -1 is exact
    assert_allclose(closest_points_on_mesh(q, big).distance, [0.05, 0.4, 4.0], rtol=0, atol=2e-3)


def test_bad_input():
    m = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(InputError, match=r"shape \(n, 3\)"):
        closest_points_on_mesh([[0, 0]], m)
    with pytest.raises(InputError, match="non-finite"):
        closest_points_on_mesh([[0, np.nan, 0]], m)
    with pytest.raises(MeshError, match="at least one triangle"):
        closest_points_on_mesh([[0, 0, 0]], TriMesh(np.zeros((3, 3)), np.zeros((0, 3))))
