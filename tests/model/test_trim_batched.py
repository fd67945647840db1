"""The batched trim paths (session 27, issue 17 item 2) against the per-segment / numpy ones they replace:
`Loop.polyline` and `loops_polylines` (one compiled call for all segments) must give the points of
`Loop._polyline_by_segment` bit for bit (the slab index's tests: tests/quality/test_slab_index_compiled.py)."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.io import read_shell
from trimsurf.model import NurbsCurve
from trimsurf.model.trim import Loop, PCurve, loops_polylines
from trimsurf.quality import sampling as S

_NS = (2, 3, 8, 32, 512)


@pytest.fixture(scope="module")
def faces(shared_data):
    out = []
    for name in ("trimesh__featuretype.STEP", "occt__screw.step"):
        out.extend(read_shell(shared_data / "cad" / name).faces)
    return [f for f in out if f.loops]


def _bits_equal(a, b):
    return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a.view(np.int64), b.view(np.int64))


def _synthetic_loop():
    # a rational quarter circle run backwards over part of its range, a cubic, a line: degrees 1-3
    w = np.sqrt(0.5)
    arc = NurbsCurve(2, np.array([0, 0, 0, 1, 1, 1.0]), np.array([[1.0, 0], [1, 1], [0, 1]]),
                     np.array([1, w, 1]))
    cub = NurbsCurve(3, np.array([0, 0, 0, 0, 0.3, 1, 1, 1, 1.0]),
                     np.array([[0, 1.0], [-0.4, 0.7], [-0.5, 0.2], [-0.2, 0.1], [0.9, 0.0]]))
    line = NurbsCurve(1, np.array([-2, -2, 5, 5.0]), np.array([[0.9, 0.0], [1.0, 0.0]]))
    return Loop((PCurve(arc, 0.9, 0.1), PCurve(cub, 0.0, 1.0), PCurve(line, -2.0, 4.7)))


def test_polyline_batched_is_per_segment_bit_for_bit(faces):
    loops = [loop for f in faces for loop in f.loops] + [_synthetic_loop()]
    assert sum(len(lp) for lp in loops) > 500
    for n in _NS:
        for loop in loops:
            got, ref = loop.polyline(n), loop._polyline_by_segment(n)
            assert _bits_equal(got, ref), n
            assert got.base is None


def test_loops_polylines_splits_each_loop(faces):
    multi = [f for f in faces if len(f.loops) > 1]
    assert multi
    for f in multi:
        for n in (8, 512):
            got = loops_polylines(f.loops, n)
            assert len(got) == len(f.loops)
            for g, loop in zip(got, f.loops):
                assert _bits_equal(g, loop._polyline_by_segment(n))
    assert loops_polylines((), 32) == []
    assert loops_polylines(multi[0].loops, 1)[0].shape == (0, 2)      # n < 2: the per-segment path


def test_face_polygons_use_batched_points(faces):
    f = faces[0]
    S._POLYGONS.clear()
    S._SLABS.clear()
    polys = S.loop_polygons(f, n_per_segment=32)
    for p, loop in zip(polys, f.loops):
        assert _bits_equal(p, loop._polyline_by_segment(32))
        assert not p.flags.writeable


def test_packed_segments_cached_per_loops_tuple(faces):
    from trimsurf.model import trim

    f = next(f for f in faces if len(f.loops) > 1)
    trim._PACKED.clear()
    first = loops_polylines(f.loops, 8)
    assert trim._PACKED[id(f.loops)][0] is f.loops
    for n in (8, 32, 512):           # later densities from the cached arrays
        for g, loop in zip(loops_polylines(f.loops, n), f.loops):
            assert _bits_equal(g, loop._polyline_by_segment(n))
    assert all(_bits_equal(a, b) for a, b in zip(first, loops_polylines(f.loops, 8)))
    f.loops[0].polyline(8)           # a single loop (a fresh list) is not cached
    assert len(trim._PACKED) == 1


def _random_curve(rng, p):
    # clamped knots with repeated interior knots (up to multiplicity p), integers and not, rational or not
    n_int = int(rng.integers(0, 6))
    inner = np.sort(np.concatenate([rng.random(n_int), np.repeat(rng.random(1), int(rng.integers(1, p + 1)))]))
    lo, hi = float(rng.normal()), 0.0
    hi = lo + float(rng.uniform(0.5, 5))
    knots = np.concatenate([[lo] * (p + 1), lo + inner * (hi - lo), [hi] * (p + 1)])
    n_ctrl = len(knots) - p - 1
    w = rng.uniform(0.2, 3.0, n_ctrl) if rng.random() < 0.5 else None
    return NurbsCurve(p, knots, rng.normal(size=(n_ctrl, 2)) * 10.0 ** rng.integers(-3, 4), w)


def test_kernel_matches_curve_points_on_random_curves():
    """`loop_polylines_kernel` (`_curve_point` written out) against `NurbsCurve.evaluate` (the compiled
    `curve_points_kernel`) bit for bit: degrees 1-7, repeated interior knots, parameters on knots,
    ranges run backwards, ranges reaching past the domain (clamped), tiny ranges."""
    rng = np.random.default_rng(11)
    segs = []
    for i in range(300):
        c = _random_curve(rng, int(rng.integers(1, 8)))
        lo, hi = float(c.knots[0]), float(c.knots[-1])
        kn = c.knots[c.degree + 1:-c.degree - 1]
        kind = i % 5
        if kind == 0:
            t0, t1 = lo, hi
        elif kind == 1:
            t0, t1 = hi, lo
        elif kind == 2 and len(kn):
            t0, t1 = float(kn[0]), float(rng.choice([lo, hi]))
        elif kind == 3:
            t0, t1 = lo - 0.3, hi + 0.2            # clamped into the domain
        else:
            t0 = float(rng.uniform(lo, hi))
            t1 = float(np.nextafter(t0, np.inf)) if i % 2 else t0 + 1e-300
        if t0 == t1:
            t1 = hi if t0 != hi else lo
        segs.append(PCurve(c, t0, t1))
    loops = [Loop(tuple(segs[i:i + 7])) for i in range(0, len(segs), 7)]
    for n in (2, 3, 5, 33, 100):
        for g, loop in zip(loops_polylines(loops, n), loops):
            assert _bits_equal(g, loop._polyline_by_segment(n)), n
