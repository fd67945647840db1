"""Bézier curves and tensor-product Bézier patches: Bernstein bases, evaluation, degree
elevation and power-basis (monomial) conversion.

Every function works on arrays of any dimension ``dim``; rational data are handled in
homogeneous coordinates (weighted points ``(w*P, w)``), either by passing the
homogeneous array itself (elevation, monomial conversion are linear) or through the
``weights=`` keyword of the evaluation functions.

The Bernstein bases are computed with the triangular (de Casteljau) recurrence
``B_i^k = (1 - t) B_i^{k-1} + t B_{i-1}^{k-1}``: every step is a convex combination of
non-negative numbers, so degree 20 and beyond evaluate to a few ulps (no binomial
coefficient times powers, no cancellation).

References
----------
L. Piegl, W. Tiller, *The NURBS Book*, 2nd ed., Springer 1997: A1.2/A1.3 (Bernstein
polynomials), A1.5 (de Casteljau), A4.2/A4.4 (rational derivatives), Eq. (5.36) (Bézier
degree elevation), Sec. 6.6 (power basis <-> Bézier).
"""

from __future__ import annotations

from math import comb

import numpy as np

from ..errors import GeometryError
from .nurbs import _as_params, _rational_curve

__all__ = ["bernstein", "bernstein_derivatives", "elevate_bezier", "bezier_curve_points",
           "bezier_curve_derivatives", "bezier_patch_points", "bezier_patch_derivatives",
           "monomial_to_bezier", "bezier_to_monomial"]


# ----------------------------------------------------------------------------- validation


def _check_degree(degree, name: str = "degree", *, minimum: int = 0) -> int:
    if isinstance(degree, (bool, np.bool_)) or not isinstance(degree, (int, np.integer)):
        raise GeometryError(f"{name} must be an integer; got {degree!r}")
    if degree < minimum:
        raise GeometryError(f"{name} must be >= {minimum}; got {degree}")
    return int(degree)


def _check_count(value, name: str, *, minimum: int) -> int:
    return _check_degree(value, name, minimum=minimum)


def _as_float(value, name: str, *, min_ndim: int = 0) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise GeometryError(f"{name} must be a numeric array; {exc}") from None
    if arr.ndim < min_ndim:
        raise GeometryError(f"{name} must have at least {min_ndim} dimensions; got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise GeometryError(f"{name} contains NaN or infinite values")
    return arr


def _check_axis(axis, ndim: int, name: str) -> int:
    if isinstance(axis, (bool, np.bool_)) or not isinstance(axis, (int, np.integer)):
        raise GeometryError(f"axis must be an integer; got {axis!r}")
    if not -ndim <= axis < ndim:
        raise GeometryError(f"axis {axis} is out of range for {name} with {ndim} dimensions")
    return int(axis) % ndim


def _check_weights(weights, shape: tuple[int, ...], name: str) -> np.ndarray | None:
    if weights is None:
        return None
    w = _as_float(weights, f"{name} weights")
    if w.shape != shape:
        raise GeometryError(f"{name} weights must have shape {shape}; got {w.shape}")
    if np.any(w <= 0):
        raise GeometryError(f"{name} weights must be positive; smallest is {w.min()!r}")
    return w


# ----------------------------------------------------------------------------- Bernstein bases


def _bernstein_levels(degree: int, t: np.ndarray, lowest: int) -> list[np.ndarray]:
    """Bernstein bases of degrees lowest..degree, each (n, k+1), by the triangular recurrence.

    Works in place on a (degree + 1, n) table so every step is a contiguous vector operation.
    """
    n = t.shape[0]
    s = 1.0 - t
    table = np.zeros((degree + 1, n))
    table[0] = 1.0
    levels = [table[:1].T.copy()] if lowest == 0 else []
    tmp = np.empty(n)
    for k in range(1, degree + 1):
        np.multiply(t, table[k - 1], out=table[k])
        for j in range(k - 1, 0, -1):
            np.multiply(t, table[j - 1], out=tmp)
            table[j] *= s
            table[j] += tmp
        table[0] *= s
        if k >= lowest:
            levels.append(table[:k + 1].T.copy())
    return levels


def bernstein(degree: int, t) -> np.ndarray:
    """Bernstein polynomials B_i^p(t), i = 0..p, batched over t.

    Parameters
    ----------
    degree : int
        Polynomial degree p >= 0.
    t : (n,) float64
        Parameters; any real value is evaluated as is (no clamping), [0, 1] is the
        Bézier domain.

    Returns
    -------
    (n, degree + 1) float64
        ``B[m, i] = C(p, i) t_m^i (1 - t_m)^(p - i)``.

    Notes
    -----
    Computed with the recurrence ``B_i^k = (1 - t) B_i^{k-1} + t B_{i-1}^{k-1}``
    (NURBS Book A1.3), O(p^2) per parameter; for t in [0, 1] every value is accurate
    to a few ulps relative, also for degree 20 and beyond.

    References
    ----------
    Piegl & Tiller, *The NURBS Book*, A1.2, A1.3.

    Examples
    --------
    >>> bernstein(2, [0.5])
    array([[0.25, 0.5 , 0.25]])
    """
    p = _check_degree(degree)
    tt = _as_params(t, "t", None)
    return _bernstein_levels(p, tt, p)[0]


def bernstein_derivatives(degree: int, t, *, n_derivs: int = 1) -> np.ndarray:
    """Bernstein polynomials and their derivatives up to order `n_derivs`.

    Parameters
    ----------
    degree : int
        Polynomial degree p >= 0.
    t : (n,) float64
    n_derivs : int
        Highest derivative order (>= 0). Orders above p are zero.

    Returns
    -------
    (n_derivs + 1, n, degree + 1) float64
        ``D[k, m, i] = d^k B_i^p / dt^k (t_m)``.

    Notes
    -----
    ``d^k B_i^p/dt^k = p!/(p-k)! * sum_j (-1)^(k-j) C(k, j) B_{i-j}^{p-k}``
    (forward differences of the degree p - k basis).

    Examples
    --------
    >>> bernstein_derivatives(2, [0.5], n_derivs=1)[1]
    array([[-1.,  0.,  1.]])
    """
    p = _check_degree(degree)
    nd = _check_count(n_derivs, "n_derivs", minimum=0)
    tt = _as_params(t, "t", None)
    n = tt.shape[0]
    out = np.zeros((nd + 1, n, p + 1))
    top = min(nd, p)
    levels = _bernstein_levels(p, tt, p - top)  # degrees p - top .. p
    out[0] = levels[-1]
    for k in range(1, top + 1):
        d = levels[top - k]  # degree p - k, shape (n, p - k + 1)
        for _ in range(k):  # raise by one: new[i] = d[i-1] - d[i]
            e = np.zeros((n, d.shape[1] + 1))
            e[:, :-1] -= d
            e[:, 1:] += d
            d = e
        factor = 1.0
        for r in range(k):
            factor *= p - r
        out[k] = factor * d
    return out


# ----------------------------------------------------------------------------- elevation


def _elevation_matrix(degree: int, times: int) -> np.ndarray:
    """(degree + times + 1, degree + 1) matrix E with Q = E @ P (repeated one-step elevation)."""
    e = np.eye(degree + 1)
    for p in range(degree, degree + times):
        step = np.zeros((p + 2, p + 1))
        i = np.arange(p + 2)
        a = i / (p + 1.0)
        step[i[1:], i[1:] - 1] = a[1:]
        step[i[:-1], i[:-1]] = 1.0 - a[:-1]
        e = step @ e
    return e


def _apply_along(matrix: np.ndarray, arr: np.ndarray, axis: int) -> np.ndarray:
    moved = np.moveaxis(arr, axis, 0)
    out = np.tensordot(matrix, moved, axes=(1, 0))
    return np.moveaxis(out, 0, axis)


def elevate_bezier(control_points, times: int = 1, *, axis: int = 0) -> np.ndarray:
    """Raise the degree of Bézier control points along one axis, leaving the curve/patch unchanged.

    Parameters
    ----------
    control_points : (..., p + 1, ..., dim) float64
        Control points with the Bézier index along `axis` (degree p = shape[axis] - 1).
        For rational data pass homogeneous points (w*P, w): elevation is linear.
    times : int
        How many degrees to add (>= 0).
    axis : int
        The Bézier index axis (0 for a curve (p + 1, dim); 0 or 1 for a patch
        (p + 1, q + 1, dim)).

    Returns
    -------
    float64 array with ``shape[axis] = p + times + 1``.

    Notes
    -----
    Each step is ``Q_i = i/(p+1) P_{i-1} + (1 - i/(p+1)) P_i`` (convex combinations,
    numerically stable); `times` steps are composed into one matrix and applied once.

    References
    ----------
    Piegl & Tiller, *The NURBS Book*, Eq. (5.36); Farin, *Curves and Surfaces for CAGD*, 6.1.

    Examples
    --------
    >>> elevate_bezier([[0.0], [2.0]])
    array([[0.],
           [1.],
           [2.]])
    """
    cp = _as_float(control_points, "control_points", min_ndim=1)
    ax = _check_axis(axis, cp.ndim, "control_points")
    if cp.ndim >= 2 and ax == cp.ndim - 1:
        raise GeometryError("axis must not be the last (coordinate) axis of control_points")
    r = _check_count(times, "times", minimum=0)
    p = cp.shape[ax] - 1
    if p < 0:
        raise GeometryError("control_points has no control point along the Bézier axis")
    if r == 0:
        return cp.copy()
    return _apply_along(_elevation_matrix(p, r), cp, ax)


# ----------------------------------------------------------------------------- evaluation


def _rational_surface(sklw: np.ndarray, nd: int) -> np.ndarray:
    a, w = sklw[..., :-1], sklw[..., -1:]
    skl = np.zeros_like(a)
    for k in range(nd + 1):
        for l in range(nd - k + 1):
            v = a[k, l].copy()
            for j in range(1, l + 1):
                v -= comb(l, j) * w[0, j] * skl[k, l - j]
            for i in range(1, k + 1):
                v -= comb(k, i) * w[i, 0] * skl[k - i, l]
                for j in range(1, l + 1):
                    v -= comb(k, i) * comb(l, j) * w[i, j] * skl[k - i, l - j]
            skl[k, l] = v / w[0, 0]
    return skl


def _homogeneous(cp: np.ndarray, w: np.ndarray | None) -> np.ndarray:
    if w is None:
        return cp
    return np.concatenate([cp * w[..., None], w[..., None]], axis=-1)


def bezier_curve_derivatives(control_points, t, *, weights=None, n_derivs: int = 1) -> np.ndarray:
    """Points and derivatives of a (rational) Bézier curve on [0, 1].

    Parameters
    ----------
    control_points : (p + 1, dim) float64
        Cartesian control points.
    t : (n,) float64
        Parameters, clamped to [0, 1].
    weights : (p + 1,) float64 or None
        Positive weights; None for a polynomial curve.
    n_derivs : int
        Highest derivative order.

    Returns
    -------
    (n_derivs + 1, n, dim) float64 : CK[k] = d^k C / dt^k.

    References
    ----------
    Piegl & Tiller, *The NURBS Book*, A1.3, A4.2.

    Examples
    --------
    >>> bezier_curve_derivatives([[0.0], [1.0], [4.0]], [1.0], n_derivs=1)[:, 0]
    array([[4.],
           [6.]])
    """
    cp = _as_float(control_points, "control_points")
    if cp.ndim != 2 or cp.shape[0] < 1:
        raise GeometryError(f"control_points must have shape (p + 1, dim); got {cp.shape}")
    w = _check_weights(weights, cp.shape[:1], "control_points")
    nd = _check_count(n_derivs, "n_derivs", minimum=0)
    tt = np.clip(_as_params(t, "t", None), 0.0, 1.0)
    pw = _homogeneous(cp, w)
    basis = bernstein_derivatives(cp.shape[0] - 1, tt, n_derivs=nd)
    ckw = np.einsum("kni,id->knd", basis, pw)
    return ckw if w is None else _rational_curve(ckw, nd)


def bezier_curve_points(control_points, t, *, weights=None) -> np.ndarray:
    """Points of a (rational) Bézier curve at t in [0, 1] (clamped); shape (n, dim).

    Examples
    --------
    >>> bezier_curve_points([[0.0, 0.0], [1.0, 2.0], [2.0, 0.0]], [0.5])
    array([[1., 1.]])
    """
    return bezier_curve_derivatives(control_points, t, weights=weights, n_derivs=0)[0]


def bezier_patch_derivatives(control_points, uv, *, weights=None, n_derivs: int = 1) -> np.ndarray:
    """Points and partial derivatives of a (rational) tensor-product Bézier patch on [0, 1]^2.

    Parameters
    ----------
    control_points : (p + 1, q + 1, dim) float64
        Cartesian control points, first index along u.
    uv : (n, 2) float64
        Parameters, clamped to [0, 1]^2.
    weights : (p + 1, q + 1) float64 or None
    n_derivs : int
        Highest total derivative order d.

    Returns
    -------
    SKL : (d + 1, d + 1, n, dim) float64
        SKL[k, l] = d^(k+l) S / du^k dv^l for k + l <= d; zero elsewhere (the layout of
        `trimsurf.geom.surface_derivatives`).

    References
    ----------
    Piegl & Tiller, *The NURBS Book*, A1.3, A3.6, A4.4.

    Examples
    --------
    >>> net = [[[0.0], [1.0]], [[1.0], [2.0]]]   # S(u, v) = u + v
    >>> bezier_patch_derivatives(net, [[0.25, 0.5]], n_derivs=1)[:, :, 0, 0]
    array([[0.75, 1.  ],
           [1.  , 0.  ]])
    """
    cp = _as_float(control_points, "control_points")
    if cp.ndim != 3 or cp.shape[0] < 1 or cp.shape[1] < 1:
        raise GeometryError(f"control_points must have shape (p + 1, q + 1, dim); got {cp.shape}")
    w = _check_weights(weights, cp.shape[:2], "control_points")
    nd = _check_count(n_derivs, "n_derivs", minimum=0)
    uv = np.clip(_as_params(uv, "uv", 2), 0.0, 1.0)
    pw = _homogeneous(cp, w)
    bu = bernstein_derivatives(cp.shape[0] - 1, uv[:, 0], n_derivs=nd)
    bv = bernstein_derivatives(cp.shape[1] - 1, uv[:, 1], n_derivs=nd)
    # x[l, n, i, d] = sum_j bv[l, n, j] pw[i, j, d] (one GEMM); skl[k, l, n, d] = sum_i bu[k, n, i] x[l, n, i, d]
    p1, q1, dd = pw.shape
    x = (bv @ pw.transpose(1, 0, 2).reshape(q1, p1 * dd)).reshape(nd + 1, -1, p1, dd)
    sklw = (bu[:, None, :, None, :] @ x[None])[:, :, :, 0, :]
    if w is not None:
        return _rational_surface(sklw, nd)
    out = np.zeros_like(sklw)
    for k in range(nd + 1):
        out[k, :nd + 1 - k] = sklw[k, :nd + 1 - k]
    return out


def bezier_patch_points(control_points, uv, *, weights=None) -> np.ndarray:
    """Points of a (rational) tensor-product Bézier patch at uv in [0, 1]^2; shape (n, dim).

    Examples
    --------
    >>> net = [[[0.0], [1.0]], [[1.0], [2.0]]]
    >>> bezier_patch_points(net, [[0.25, 0.5]])
    array([[0.75]])
    """
    return bezier_patch_derivatives(control_points, uv, weights=weights, n_derivs=0)[0, 0]


# ----------------------------------------------------------------------------- power basis


def _local_map(interval, origin) -> tuple[float, float]:
    """(c, h) with s - origin = c + h r for the local parameter r in [0, 1]."""
    if interval is None:
        if origin is not None:
            raise GeometryError("origin needs an interval (s0, s1)")
        return 0.0, 1.0
    try:
        s0, s1 = (float(x) for x in interval)
    except (TypeError, ValueError):
        raise GeometryError(f"interval must be a pair (s0, s1); got {interval!r}") from None
    if not (np.isfinite(s0) and np.isfinite(s1) and s1 > s0):
        raise GeometryError(f"interval must be finite with s0 < s1; got ({s0}, {s1})")
    o = s0 if origin is None else float(origin)
    if not np.isfinite(o):
        raise GeometryError(f"origin must be finite; got {origin!r}")
    return s0 - o, s1 - s0


def _power_to_local(p: int, c: float, h: float) -> np.ndarray:
    """T with b = T a: coefficients of r^j from those of (s - origin)^k, s - origin = c + h r."""
    t = np.zeros((p + 1, p + 1))
    for j in range(p + 1):
        for k in range(j, p + 1):
            t[j, k] = comb(k, j) * c ** (k - j) * h ** j
    return t


def _local_to_power(p: int, c: float, h: float) -> np.ndarray:
    """Inverse of `_power_to_local`: a_k = sum_j b_j h^-j C(j, k) (-c)^(j-k)."""
    t = np.zeros((p + 1, p + 1))
    for k in range(p + 1):
        for j in range(k, p + 1):
            t[k, j] = comb(j, k) * (-c) ** (j - k) / h ** j
    return t


def _monomial_to_bezier_matrix(p: int) -> np.ndarray:
    """M with P = M b for x(r) = sum_j b_j r^j: P_i = sum_{j<=i} C(i, j) / C(p, j) b_j."""
    m = np.zeros((p + 1, p + 1))
    for i in range(p + 1):
        for j in range(i + 1):
            m[i, j] = comb(i, j) / comb(p, j)
    return m


def _bezier_to_monomial_matrix(p: int) -> np.ndarray:
    """Inverse of `_monomial_to_bezier_matrix`: b_j = C(p, j) sum_{i<=j} (-1)^(j-i) C(j, i) P_i."""
    m = np.zeros((p + 1, p + 1))
    for j in range(p + 1):
        for i in range(j + 1):
            m[j, i] = comb(p, j) * comb(j, i) * (-1.0) ** (j - i)
    return m


def _check_coefficient_array(arr, name: str, axis) -> tuple[np.ndarray, int]:
    a = _as_float(arr, name, min_ndim=1)
    ax = _check_axis(axis, a.ndim, name)
    if a.shape[ax] < 1:
        raise GeometryError(f"{name} has no entry along axis {ax}")
    return a, ax


def monomial_to_bezier(coeffs, *, axis: int = 0, interval=None, origin=None) -> np.ndarray:
    """Bézier control points on the local parameter r in [0, 1] of a power-basis polynomial.

    Parameters
    ----------
    coeffs : (..., p + 1, ..., dim) float64
        Power-basis coefficients a_0..a_p along `axis` (vector valued along the other
        axes). For a tensor patch with coefficients a_ij convert along axis 0, then
        along axis 1.
    axis : int
        Axis of the coefficient index.
    interval : (s0, s1) or None
        None: the polynomial is in the normalized local parameter,
        ``x(r) = sum_k a_k r^k``, r in [0, 1].
        (s0, s1): the polynomial is in the unscaled parameter s over the segment
        [s0, s1], ``x(s) = sum_k a_k (s - origin)^k``; the returned control points
        describe it on r = (s - s0) / (s1 - s0).
    origin : float or None
        Expansion point of the unscaled form; default s0 (the VDAFS convention of a
        local, unnormalized segment parameter s - s0). Pass 0.0 for coefficients of
        plain powers s^k. Only with `interval`.

    Returns
    -------
    float64 array of the same shape: Bézier control points P_0..P_p along `axis`.

    Notes
    -----
    First ``b_j = sum_k a_k C(k, j) c^(k-j) h^j`` (c = s0 - origin, h = s1 - s0) gives
    the coefficients in r, then ``P_i = sum_{j<=i} C(i, j) / C(p, j) b_j``. The
    conversion is linear, so homogeneous (rational) coefficients convert as well.
    With origin far from the interval (c >> h) the shift loses digits like any
    re-expansion of a power series; the default origin = s0 is exact up to rounding of
    the scaling.

    References
    ----------
    Piegl & Tiller, *The NURBS Book*, Sec. 6.6 (Eq. 6.39-6.42).

    Examples
    --------
    >>> monomial_to_bezier([[0.0], [0.0], [1.0]])          # x(r) = r^2
    array([[0.],
           [0.],
           [1.]])
    >>> monomial_to_bezier([[0.0], [1.0]], interval=(2.0, 4.0))   # x(s) = s - 2 on [2, 4]
    array([[0.],
           [2.]])
    """
    a, ax = _check_coefficient_array(coeffs, "coeffs", axis)
    c, h = _local_map(interval, origin)
    p = a.shape[ax] - 1
    matrix = _monomial_to_bezier_matrix(p) @ _power_to_local(p, c, h)
    return _apply_along(matrix, a, ax)


def bezier_to_monomial(control_points, *, axis: int = 0, interval=None, origin=None) -> np.ndarray:
    """Power-basis coefficients of a Bézier polynomial; the inverse of `monomial_to_bezier`.

    Parameters
    ----------
    control_points : (..., p + 1, ..., dim) float64
        Bézier control points along `axis`, on the local parameter r in [0, 1].
    axis, interval, origin
        As in `monomial_to_bezier`: with ``interval=None`` returns a_k of
        ``x(r) = sum a_k r^k``; with ``interval=(s0, s1)`` returns a_k of
        ``x(s) = sum a_k (s - origin)^k`` where r = (s - s0) / (s1 - s0).

    Returns
    -------
    float64 array of the same shape.

    References
    ----------
    Piegl & Tiller, *The NURBS Book*, Sec. 6.6.

    Examples
    --------
    >>> bezier_to_monomial([[0.0], [0.0], [1.0]])
    array([[0.],
           [0.],
           [1.]])
    """
    b, ax = _check_coefficient_array(control_points, "control_points", axis)
    c, h = _local_map(interval, origin)
    p = b.shape[ax] - 1
    matrix = _local_to_power(p, c, h) @ _bezier_to_monomial_matrix(p)
    return _apply_along(matrix, b, ax)
