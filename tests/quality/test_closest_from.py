"""The first pass's surface -> mesh search from a bound gives the distances of the plain search, bit for bit.

`deviation._closest_from(pts, loc, at)` searches every point first within `at` (the compiled grid search
keeps a bound it is given and replaces it only by a strictly nearer triangle) and searches the points it
left at `at` again from infinity. The checks: random meshes and points, `at` below, inside and above the
distances (and exactly equal to one of them), NaN / inf / 0; a version that does not search the points left
at `at` again, or redoes only those above it (the search never returns more than `at`), fails.
"""

import numpy as np
import pytest

import trimsurf.quality.deviation as D
from trimsurf.quality.closest_point import _closest, _TriangleLocator


def _mesh(rng, n=400):
    # a wavy sheet of triangles: distances of points above it vary over the grid
    k = int(np.sqrt(n / 2)) + 1
    x, y = np.meshgrid(np.linspace(0, 1, k), np.linspace(0, 1, k), indexing="ij")
    z = 0.05 * np.sin(6 * x) * np.cos(5 * y) + rng.normal(0, 1e-3, x.shape)
    v = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    idx = np.arange(k * k).reshape(k, k)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    t = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return v, t


def _cases(seed):
    rng = np.random.default_rng(seed)
    v, t = _mesh(rng)
    loc = _TriangleLocator(v, t)
    pts = np.column_stack([rng.uniform(-0.2, 1.2, 600), rng.uniform(-0.2, 1.2, 600), rng.normal(0, 0.05, 600)])
    ref = _closest(pts, loc).distance
    return loc, pts, ref


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_same_distances_bit_for_bit(seed):
    loc, pts, ref = _cases(seed)
    ats = [1e-9, float(np.quantile(ref, 0.1)), float(np.median(ref)), float(np.quantile(ref, 0.9)),
           float(ref.max()), 10.0 * float(ref.max()), float(ref[17]), np.nan, np.inf, 0.0, -1.0]
    for at in ats:
        d = D._closest_from(pts, loc, at)
        assert np.array_equal(d, ref), at
    # `at` equal to a point's own distance: that point is left at `at` and must be searched again
    assert np.count_nonzero(ref == ref[17]) >= 1


def test_most_points_found_within_the_bound():
    """Not vacuous: with `at` about the largest distance, the first search finds most points (no redo)."""
    loc, pts, ref = _cases(3)
    at = float(np.quantile(ref, 0.95))
    calls = []
    kernel = D._cp.grid_closest_kernel

    def spy(q, *args):
        calls.append(len(q))
        return kernel(q, *args)

    D._cp.grid_closest_kernel = spy
    try:
        d = D._closest_from(pts, loc, at)
    finally:
        D._cp.grid_closest_kernel = kernel
    assert np.array_equal(d, ref)
    assert calls[0] == len(pts) and sum(calls[1:]) <= 0.1 * len(pts)


def _broken(pts, loc, at, strict=False, redo=True):
    n = len(pts)
    q = np.ascontiguousarray(pts, dtype=np.float64)
    lo, hi, origin, h, dims, start, items = loc.grid
    best_d = np.full(n, float(at))
    args = (np.zeros(n, dtype=np.int64), np.zeros((n, 3)), np.zeros((n, 3)))
    D._cp.grid_closest_kernel(q, loc.a, loc.b, loc.c, lo, hi, origin, h, dims, start, items, best_d, *args)
    if redo:
        r = np.flatnonzero(best_d > at) if strict else np.flatnonzero(~(best_d < at))
        best_d[r] = _closest(np.ascontiguousarray(q[r]), loc).distance
    return best_d


def test_broken_versions_fail():
    loc, pts, ref = _cases(4)
    at = float(np.median(ref))
    assert np.array_equal(_broken(pts, loc, at), ref)                    # the stand-in is the real rule
    assert not np.array_equal(_broken(pts, loc, at, redo=False), ref)    # points left at `at`
    at = float(ref[5])                                                   # a point exactly at the bound
    assert not np.array_equal(_broken(pts, loc, at, strict=True), ref)
