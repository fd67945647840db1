"""The numpy shortcuts of the tessellation's hot paths give the very bits of the calls they replace."""
import numpy as np

from trimsurf.geom.nurbs import _clip
from trimsurf.model import NurbsCurve, PCurve
from trimsurf.tessellate.domain import _clipped_values, unique_values


def _bits(a):
    return np.asarray(a, dtype=np.float64).view(np.int64)


def test_pcurve_parameters_are_np_linspace_bit_for_bit():
    rng = np.random.default_rng(7)
    curve = NurbsCurve(1, [-1e6, -1e6, 1e6, 1e6], np.array([[0.0, 0.0], [1.0, 1.0]]))
    for _ in range(3000):
        t0 = float(rng.normal() * 10.0 ** rng.integers(-6, 5))
        t1 = t0 + float(rng.normal() * 10.0 ** rng.integers(-12, 5)) or 1.0
        n = int(rng.integers(1, 70))
        if t1 == t0:            # an empty range is no p-curve
            continue
        got = PCurve(curve, t0, t1).parameters(n)
        assert np.array_equal(_bits(got), _bits(np.linspace(t0, t1, n))), (t0, t1, n)


def test_unique_values_and_clipped_values_are_np_unique_bit_for_bit():
    rng = np.random.default_rng(8)
    for _ in range(2000):
        x = np.round(rng.normal(size=int(rng.integers(0, 40))), int(rng.integers(0, 3)))
        x[rng.random(len(x)) < 0.1] = -0.0
        x[rng.random(len(x)) < 0.1] = 0.0
        assert np.array_equal(_bits(unique_values(x)), _bits(np.unique(x)))
        a, b = sorted(rng.normal(size=2))
        want = np.unique(np.clip(np.r_[a, x, b], a, b))
        assert np.array_equal(_bits(_clipped_values(a, x, b)), _bits(want))
        assert np.array_equal(_bits(_clip(x, a, b)), _bits(np.clip(x, a, b)))


def test_loop_polylines_are_each_polyline_bit_for_bit():
    from trimsurf.model import Loop

    w = np.sqrt(0.5)
    quarter = NurbsCurve(2, [0, 0, 0, 1, 1, 1], np.array([[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
                         np.array([1.0, w, 1.0]))
    back = NurbsCurve(1, [0, 0, 1, 1], np.array([[0.0, 1.0], [1.0, 0.0]]))
    loop = Loop((PCurve(quarter, 0.1, 0.93), PCurve(back, 0.0, 1.0)))
    for got, n in zip(loop.polylines(32, 6, 7), (32, 6, 7)):
        assert np.array_equal(_bits(got), _bits(loop.polyline(n)))
