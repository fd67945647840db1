"""Adaptive domain values: iso-parametric lines nearly equidistant in 3D (paper Sec. 4.2, 5.1).

One parameter direction at a time. A *line family* maps parameters x (k,) to
points (k, L, 3) on L transversal lines (for the u direction of a face: the
points S(x, v_l) on L lines v = v_l spread over the trimmed region; for a trim
curve: L = 1, or one line per face that uses a shared edge). The criteria are
the paper's two: the 3D distance between consecutive values (the *grid size*,
at most `max_edge`) and the geometric deviation of the curve from the chord
(at most `tolerance`), both maximised over all lines, so one set of values
serves the whole face.

Two strategies:

* ``"bisection"``: the paper's algorithm (Sec. 5.1 listing): from each value,
  bisect for the farthest x whose grid size is below `max_edge`, then bisect
  back until the deviation is below `tolerance`.
* ``"equidistributed"`` (default): the same two criteria expressed as a
  density on a fine sampling (pieces needed per fine interval,
  ``max(len / max_edge, sqrt(dev / tolerance))``, since the chord deviation
  falls with the square of the step), values placed at equal increments of
  its integral: the smallest count (from the integral rounded up, in steps of
  about 4 %) whose placement meets both criteria on every interval; only if
  none up to 1.5x does, the intervals that fail are bisected. Same guarantees,
  no short left-over interval at the end, and fewer lines (bisecting every
  failing interval of the first placement gave about 1.5x the lines).
* ``"uniform"``: the paper's baseline (Sec. 3.4): n equidistant parameter
  values with the smallest n that meets both criteria.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ..errors import InputError
from ..geom.nurbs import _clip

__all__ = ["adaptive_values", "interval_criteria", "STRATEGIES"]

STRATEGIES = ("equidistributed", "bisection", "uniform")

LineFamily = Callable[[np.ndarray], np.ndarray]

_N_SUB = 7          # sub-samples per interval when an interval is checked (odd: the midpoint too)
_MAX_ROUNDS = 12    # checking / bisection rounds
#: iso-values per direction beyond which `adaptive_values` refuses (InputError) instead of placing
#: them: the checks cost about 170 bytes per value and line, so a tolerance or grid size far too small
#: for the face could take gigabytes (a backstop: the CLI refuses from an estimate first)
MAX_VALUES = 20000


def unique_values(x: np.ndarray) -> np.ndarray:
    """np.unique of a float array (its sort path, the same array) without the wrappers' cost, which
    dominates on the few values of a line placement (thousands of calls per shell).

    >>> unique_values(np.array([2.0, 0.5, 2.0, 1.0]))
    array([0.5, 1. , 2. ])
    """
    x = np.sort(x, axis=None)
    keep = np.empty(x.shape, dtype=bool)
    keep[:1] = True
    np.not_equal(x[1:], x[:-1], out=keep[1:])
    return x[keep]


def _clipped_values(a: float, init: np.ndarray, b: float) -> np.ndarray:
    """np.unique(np.clip(np.r_[a, init, b], a, b)) (the same array)."""
    return unique_values(_clip(np.concatenate(([a], init, [b])).astype(np.float64, copy=False), a, b))


def interval_criteria(evaluate: LineFamily, x: np.ndarray, *, n_sub: int = _N_SUB,
                      weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Chord length and chord deviation of each interval [x_i, x_{i+1}], maximised over the lines.

    Parameters
    ----------
    evaluate : callable
        x (k,) -> points (k, L, 3).
    x : (n,) float64
        Increasing values.
    n_sub : int
        Interior samples per interval for the deviation.
    weights : (n - 1, L) bool or None
        Which lines count for each interval (e.g. only those inside the trim);
        None: all.

    Returns
    -------
    length, deviation : (n - 1,) float64
        Largest 3D chord length and largest distance of the sampled curve from
        its chord over the lines.
    """
    x = np.asarray(x, dtype=np.float64)
    compiled = getattr(evaluate, "criteria", None)
    if compiled is not None:        # a family that computes the criteria itself (face iso-lines)
        return compiled(x, n_sub, weights)
    n = len(x) - 1
    s = np.linspace(0.0, 1.0, n_sub + 2)
    xs = (x[:-1, None] + (x[1:] - x[:-1])[:, None] * s[None, :]).ravel()
    p = evaluate(xs)
    p = p.reshape(n, n_sub + 2, p.shape[1], 3)
    a, b = p[:, 0], p[:, -1]                                  # (n, L, 3)
    ab = b - a
    den = np.einsum("nld,nld->nl", ab, ab)
    q = p[:, 1:-1] - a[:, None]                               # (n, s, L, 3)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.clip(np.einsum("nsld,nld->nsl", q, ab) / np.where(den > 0, den, 1.0)[:, None], 0.0, 1.0)
    d = np.linalg.norm(q - t[..., None] * ab[:, None], axis=-1).max(axis=1)   # (n, L)
    length = np.sqrt(den)
    if weights is not None:
        w = np.asarray(weights, dtype=bool)
        length = np.where(w, length, 0.0)
        d = np.where(w, d, 0.0)
    return length.max(axis=1, initial=0.0), d.max(axis=1, initial=0.0)


def _check(tolerance: float, max_edge: float) -> None:
    for name, v in (("tolerance", tolerance), ("max_edge", max_edge)):
        if not (np.isfinite(v) and v > 0):
            raise InputError(f"{name} must be a positive finite number; got {v!r}")


def _too_many(n: float, max_values: int, tolerance: float, max_edge: float) -> InputError:
    exc = InputError(f"~{n:.3g} intervals needed (more than {max_values}): tolerance {tolerance:.3g} or "
                     f"max edge {max_edge:.3g} is too small for this curve family")
    exc.needed = float(n)
    return exc


def _bisection(evaluate: LineFamily, a: float, b: float, tolerance: float, max_edge: float,
               max_iter: int = 40, max_values: int = MAX_VALUES) -> np.ndarray:
    """The paper's listing (Sec. 5.1): grid size first, then approximation error, per interval."""
    span = b - a
    eps_x = 1e-12 * max(span, 1e-300)

    def arclen(x0: float, x1: float) -> float:
        return float(interval_criteria(evaluate, np.array([x0, x1]))[0][0])

    def dist(x0: float, x1: float) -> float:
        return float(interval_criteria(evaluate, np.array([x0, x1]))[1][0])

    values = [a]
    while values[-1] < b - eps_x:
        ui = values[-1]
        x0, x1 = ui, b
        it = 0
        # first, check grid size: the farthest x1 with max_arclen(ui, x1) < gridsize
        while arclen(ui, x1) >= max_edge and it < max_iter:
            x2 = 0.5 * (x0 + x1)
            if arclen(ui, x2) >= max_edge:
                x1 = x2
            elif max_edge - arclen(ui, x2) >= 0.05 * max_edge:
                x0 = x2
            else:
                x1 = x2
            it += 1
        # now check approximation error
        x0, x2, it = ui, x1, 0
        if dist(ui, x1) >= tolerance:
            while it < max_iter:
                if dist(ui, x1) >= tolerance:
                    x2 = x1
                    x1 = 0.5 * (x0 + x1)
                else:
                    if x2 - x1 <= 0.05 * (x1 - ui):
                        break           # as close to the max. deviation as needed
                    x0 = x1
                    x1 = 0.5 * (x1 + x2)
                it += 1
            if dist(ui, x1) >= tolerance:   # stopped by max_iter: step back to the last good value
                x1 = x0 if x0 > ui else ui + (x1 - ui) * 0.5
        x1 = max(x1, ui + 1e-9 * span)
        values.append(min(x1, b))
        if len(values) > max_values + 1:
            raise _too_many((len(values) - 1) * span / max(values[-1] - a, 1e-300), max_values, tolerance, max_edge)
    values[-1] = b
    return np.asarray(values)


def _equidistributed(evaluate: LineFamily, a: float, b: float, tolerance: float, max_edge: float,
                     init: np.ndarray, weights_fn=None, max_values: int = MAX_VALUES) -> np.ndarray:
    # fine sampling: split intervals until each is well below both criteria
    x = _clipped_values(a, init, b)
    w = None if weights_fn is None else weights_fn(x)
    length, dev = interval_criteria(evaluate, x, n_sub=3, weights=w)
    for _ in range(8):
        bad = (length > 0.25 * max_edge) | (dev > 0.0625 * tolerance)
        if not bad.any() or len(x) > 20000:
            break
        # only the halves of the split intervals are new: their criteria, from the sequence
        # lo, mid, hi of each (the interval from one hi to the next lo is computed and dropped)
        lo, hi = x[:-1][bad], x[1:][bad]
        mids = 0.5 * (lo + hi)
        seq = np.column_stack([lo, mids, hi]).ravel()
        keep = np.ones(len(seq) - 1, dtype=bool)
        keep[2::3] = False
        w = None if weights_fn is None else weights_fn(seq)
        sub_len, sub_dev = (v[keep] for v in interval_criteria(evaluate, seq, n_sub=3, weights=w))
        # interval i of the old x becomes 1 (kept) or 2 (split) intervals, in order
        count = np.where(bad, 2, 1)
        first = np.cumsum(count) - count
        new_len, new_dev = np.empty(int(count.sum())), np.empty(int(count.sum()))
        ok = ~bad
        new_len[first[ok]], new_dev[first[ok]] = length[ok], dev[ok]
        fb = first[bad]
        new_len[fb], new_dev[fb] = sub_len[0::2], sub_dev[0::2]
        new_len[fb + 1], new_dev[fb + 1] = sub_len[1::2], sub_dev[1::2]
        x = np.sort(np.r_[x, mids])
        length, dev = new_len, new_dev
    need = np.maximum(length / max_edge, np.sqrt(dev / tolerance))
    cum = np.r_[0.0, np.cumsum(need)]
    if not cum[-1] > 0:
        return np.array([a, b]), False
    if not cum[-1] <= max_values:
        raise _too_many(cum[-1], max_values, tolerance, max_edge)

    def place(n: int) -> np.ndarray:
        v = np.interp(np.linspace(0.0, cum[-1], n + 1), cum, x)
        v[0], v[-1] = a, b
        return np.unique(v)

    def ok(v: np.ndarray) -> bool:
        w = None if weights_fn is None else weights_fn(v)
        ln, dv = interval_criteria(evaluate, v, weights=w)
        return bool(np.all(ln <= max_edge) and np.all(dv <= tolerance))

    # the smallest n whose equal-increment placement meets both criteria on every interval: from
    # ceil(integral) up in steps of ~4 % (a failing placement is then bisected by the caller only
    # when none up to 1.5 x passes); one line fewer is tried too, the integral rounds up
    n0 = max(1, int(np.ceil(cum[-1] - 1e-9)))
    if n0 > 1 and cum[-1] - (n0 - 1) < 0.1 and ok(place(n0 - 1)):
        return place(n0 - 1), True
    n = n0
    while n <= 1.5 * n0 + 2:
        v = place(n)
        if ok(v):
            return v, True
        n += max(1, int(0.04 * n))
    return place(n0), False


def _uniform(evaluate: LineFamily, a: float, b: float, tolerance: float, max_edge: float, weights_fn) -> np.ndarray:
    """The smallest n for which n equidistant intervals meet both criteria (doubling, then bisection on n)."""
    def ok(n: int) -> bool:
        x = np.linspace(a, b, n + 1)
        w = None if weights_fn is None else weights_fn(x)
        length, dev = interval_criteria(evaluate, x, weights=w)
        return bool(np.all(length <= max_edge) and np.all(dev <= tolerance))

    hi = 1
    while not ok(hi) and hi < 1 << 10:      # capped: a pole or a cusp may never meet the criteria
        hi *= 2
    lo = hi // 2
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if ok(mid):
            hi = mid
        else:
            lo = mid
    return np.linspace(a, b, hi + 1)


def adaptive_values(evaluate: LineFamily, a: float, b: float, *, tolerance: float, max_edge: float,
                    strategy: str = "equidistributed", init=None, weights_fn=None,
                    max_values: int = MAX_VALUES) -> np.ndarray:
    """Values a = x_0 < ... < x_n = b meeting both 3D criteria on every interval and every line.

    Parameters
    ----------
    evaluate : callable
        x (k,) float64 -> points (k, L, 3).
    a, b : float
        Parameter interval, a < b.
    tolerance : float
        Max. distance of the curves from their chords (model units).
    max_edge : float
        Max. 3D distance between consecutive values (the paper's grid size).
    strategy : {"equidistributed", "bisection", "uniform"}
    init : array or None
        Values that start the fine sampling (e.g. knots); default 16 uniform.
    weights_fn : callable or None
        x (n,) -> (n - 1, L) bool: which lines count on each interval.
    max_values : int
        More intervals than this are refused (InputError) before they are placed.

    Returns
    -------
    (n + 1,) float64, increasing, from a to b.

    Raises
    ------
    InputError
        Bad parameters, or more than `max_values` intervals needed.

    Examples
    --------
    >>> import numpy as np
    >>> circle = lambda t: np.stack([np.cos(t), np.sin(t), 0 * t], axis=-1)[:, None, :]
    >>> x = adaptive_values(circle, 0.0, np.pi, tolerance=1e-2, max_edge=10.0)
    >>> bool(np.all(interval_criteria(circle, x)[1] <= 1e-2)), len(x) - 1
    (True, 12)
    """
    _check(tolerance, max_edge)
    a, b = float(a), float(b)
    if not (np.isfinite(a) and np.isfinite(b) and a < b):
        raise InputError(f"parameter interval must satisfy a < b; got [{a}, {b}]")
    if strategy not in STRATEGIES:
        raise InputError(f"strategy must be one of {', '.join(STRATEGIES)}; got {strategy!r}")
    init = np.linspace(a, b, 17) if init is None else np.asarray(init, dtype=np.float64)
    if strategy == "bisection":
        x = _bisection(evaluate, a, b, tolerance, max_edge, max_values=max_values)
    elif strategy == "uniform":
        x = _uniform(evaluate, a, b, tolerance, max_edge, weights_fn)
        return x
    elif hasattr(evaluate, "family") and (weights_fn is None or weights_fn == getattr(evaluate, "weights", None)):
        # a compiled family: the whole placement in one compiled call (the same numbers)
        from ._line_kernels import equidistributed_kernel

        x0 = _clipped_values(a, init, b)
        x, needed = equidistributed_kernel(*evaluate.family(), x0, a, b, float(tolerance), float(max_edge),
                                           float(max_values))
        if needed >= 0:
            raise _too_many(needed, max_values, tolerance, max_edge)
        return x
    else:
        x, checked = _equidistributed(evaluate, a, b, tolerance, max_edge, init, weights_fn, max_values)
        if checked:     # every interval already met both criteria
            return x
    # check every interval against both criteria; bisect where one fails
    for _ in range(_MAX_ROUNDS):
        w = None if weights_fn is None else weights_fn(x)
        length, dev = interval_criteria(evaluate, x, weights=w)
        bad = (length > max_edge) | (dev > tolerance)
        if not bad.any():
            break
        x = np.sort(np.r_[x, 0.5 * (x[:-1] + x[1:])[bad]])
        if len(x) - 1 > max_values:
            raise _too_many(len(x) - 1, max_values, tolerance, max_edge)
    return x
