"""The compiled closest-point search (`quality._kernels`) against brute force over every triangle."""

import numpy as np

from trimsurf.model import TriMesh
from trimsurf.quality.closest_point import closest_points_on_mesh, point_triangle_closest


def brute_force(q, v, t):
    best = np.full(len(q), np.inf)
    for tri in t:
        c, _ = point_triangle_closest(q, *(np.broadcast_to(v[tri[k]], q.shape) for k in range(3)))
        best = np.minimum(best, np.linalg.norm(q - c, axis=1))
    return best


def test_exact_on_a_random_soup_with_flat_triangles():
    rng = np.random.default_rng(1)
    v = rng.uniform(0, 1, (300, 3))
    t = rng.integers(0, 300, (900, 3))
    t = t[(t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])][:600]
    v[t[:30, 2]] = 0.5 * (v[t[:30, 0]] + v[t[:30, 1]])          # collinear corners: zero area
    q = rng.uniform(-0.5, 1.5, (4000, 3))
    r = closest_points_on_mesh(q, TriMesh(v, t))
    ref = brute_force(q, v, t)
    # a zero-area triangle is its three edges: never nearer than the true distance, never farther
    np.testing.assert_allclose(r.distance, ref, rtol=0, atol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(q - r.point, axis=1), r.distance, rtol=0, atol=1e-14)
    w = r.barycentric
    assert np.all(w >= -1e-15) and np.allclose(w.sum(axis=1), 1.0)
    tri = t[r.triangle]
    np.testing.assert_allclose(np.einsum("kj,kjd->kd", w, v[tri]), r.point, rtol=0, atol=1e-14)
