"""The compiled slab index of the trim polygons (session 27, issue 17 item 2): `sampling._slab_index`
(predicates' compiled `PolygonIndex`) must give the arrays of `_slab_index_numpy`, the numpy version it
replaces, and the point-in-loop answers must match a brute-force crossing count."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.io import read_shell
from trimsurf.quality import sampling as S


@pytest.fixture(scope="module")
def faces(shared_data):
    out = []
    for name in ("trimesh__featuretype.STEP", "occt__screw.step"):
        out.extend(read_shell(shared_data / "cad" / name).faces)
    return [f for f in out if f.loops]


def _bits_equal(a, b):
    return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a.view(np.int64), b.view(np.int64))


def _index_equal(x, y):
    assert len(x) == len(y) == 7
    for u, v in zip(x, y):
        if isinstance(u, np.ndarray):
            assert _bits_equal(np.asarray(u), np.asarray(v))
        else:
            assert type(u) is type(v) and u == v


def test_slab_index_is_the_numpy_one(faces):
    rng = np.random.default_rng(3)
    cases = [[loop.polyline(n) for loop in f.loops] for f in faces for n in (32, 512)]
    # tall edges (fewer slabs), a flat polygon (h = 1), a single triangle
    cases.append([rng.random((300, 2)) * [1, 50]])
    cases.append([np.array([[0, 1.0], [1, 1.0], [2, 1.0]])])
    cases.append([np.array([[0, 0.0], [1, 0.0], [0, 1.0]]), np.array([[0.2, 0.2], [0.3, 0.2], [0.2, 0.3]])])
    for polys in cases:
        _index_equal(S._slab_index(polys), S._slab_index_numpy(polys))


def test_inside_loops_answers_match_brute_force(faces):
    rng = np.random.default_rng(7)
    for f in faces[::7]:
        S._POLYGONS.clear()
        S._SLABS.clear()
        polys = S.loop_polygons(f, n_per_segment=32)
        lo, hi = np.min([p.min(0) for p in polys], 0), np.max([p.max(0) for p in polys], 0)
        uv = lo + (hi - lo) * rng.random((400, 2))
        a = np.concatenate(polys)
        b = np.concatenate([np.roll(p, -1, axis=0) for p in polys])
        # even-odd crossing count, brute force over all edges (the kernel's test)
        x, y = uv[:, :1], uv[:, 1:]
        cond = (a[None, :, 1] > y) != (b[None, :, 1] > y)
        with np.errstate(all="ignore"):
            xc = a[None, :, 0] + (y - a[None, :, 1]) * (b[None, :, 0] - a[None, :, 0]) / (b[None, :, 1] - a[None, :, 1])
        ref = (np.sum(cond & (x < xc), axis=1) % 2) == 1
        got = S._inside_loops(f, uv, 32)
        assert np.mean(got == ref) > 0.99
