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


def test_hinted_search_gives_the_same_distances_bit_for_bit():
    """A hint (any triangle: near, far, or the true nearest) only bounds the search: the distances equal the
    unhinted search's exactly (the report's figures must not move), and the point lies on the triangle named."""
    from trimsurf.quality.closest_point import _closest, _TriangleLocator

    rng = np.random.default_rng(7)
    v = rng.uniform(0, 1, (400, 3))
    t = rng.integers(0, 400, (1200, 3))
    t = t[(t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])][:800]
    q = np.concatenate([rng.uniform(-0.5, 1.5, (3000, 3)), v[t[:500]].mean(axis=1)])   # centroids: ties at 0
    loc = _TriangleLocator(v, t)
    plain = _closest(q, loc)
    for hint in (rng.integers(0, len(t), len(q)), plain.triangle, np.zeros(len(q), dtype=np.int64)):
        r = _closest(q, loc, hint=hint)
        assert np.array_equal(r.distance, plain.distance)
        on = np.einsum("kj,kjd->kd", r.barycentric, v[t[r.triangle]])
        np.testing.assert_allclose(on, r.point, rtol=0, atol=1e-14)
    np.testing.assert_allclose(plain.distance[:300], brute_force(q[:300], v, t), rtol=0, atol=1e-14)
