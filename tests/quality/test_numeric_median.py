"""`quality._numeric.median` is ``float(np.median(x))`` bit for bit (the measurement's thresholds and grid
spacings come from it): random sizes 1..64, odd and even, ties, tiny and huge magnitudes, a NaN, the empty
array; and the even-size mean it must take (a version returning the upper middle value fails)."""

import warnings

import numpy as np
import pytest

from trimsurf.quality import _numeric


def _same(a: float, b: float) -> bool:
    return (np.isnan(a) and np.isnan(b)) or np.float64(a).tobytes() == np.float64(b).tobytes()


def test_equals_numpy_median():
    rng = np.random.default_rng(3)
    for n in range(1, 65):
        for scale in (1e-300, 1e-9, 1.0, 1e200):
            x = rng.standard_normal(n) * scale
            if n > 3:
                x[: n // 3] = x[-1]          # ties
            ref = float(np.median(x))
            got = _numeric.median(x)
            assert _same(got, ref), (n, scale, got, ref)
            assert _same(_numeric.median(np.abs(x) + 0.1), float(np.median(np.abs(x) + 0.1)))


def test_nan_and_empty():
    x = np.array([1.0, np.nan, 3.0, 2.0])
    assert np.isnan(_numeric.median(x)) and np.isnan(np.median(x))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert np.isnan(_numeric.median(np.zeros(0)))


def test_even_size_takes_the_mean(monkeypatch):
    real = np.partition

    def upper_only(a, kth):           # a broken median: the upper middle value for even sizes
        p = real(a, kth)
        if len(kth) == 3:
            p[kth[0]] = p[kth[1]]
        return p

    monkeypatch.setattr(_numeric.np, "partition", upper_only)
    with pytest.raises(AssertionError):
        test_equals_numpy_median()
