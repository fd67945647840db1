"""Triangular Bézier patches of any degree: evaluation, derivatives, degree elevation.

A degree-n patch has N = (n+1)(n+2)/2 control points b_I, I = (i, j, k), i + j + k = n,
ordered as `triangle_indices` (i descending, then j descending). At barycentric
coordinates (u, v, w), u + v + w = 1,

    x(u, v, w) = sum_I b_I B_I^n(u, v, w),   B_I^n = n! / (i! j! k!) u^i v^j w^k.

Every function is batched over many parameters and, where the control points are given
as (P, N, dim), over many patches sharing one parameter set (the reconstruction
capability evaluates thousands of patches at once).

The bases are computed with the de Casteljau recurrence
``B_I^m = u B_{I-e1}^{m-1} + v B_{I-e2}^{m-1} + w B_{I-e3}^{m-1}`` (positive weights
inside the triangle, no factorials), so degree 20 is as accurate as degree 3.

References
----------
G. Farin, *Curves and Surfaces for CAGD*, 5th ed., ch. 17 (triangular Bézier patches:
de Casteljau, directional derivatives Eq. 17.14, degree elevation Eq. 17.20).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..errors import GeometryError

__all__ = ["triangle_indices", "bezier_triangle_points", "bezier_triangle_derivatives",
           "elevate_bezier_triangle"]

# Rows of `bary` must sum to 1 within this (input validation, not a geometric tolerance).
_BARY_SUM_TOL = 1e-9


def _check_degree(degree, name: str = "degree") -> int:
    if isinstance(degree, (bool, np.bool_)) or not isinstance(degree, (int, np.integer)):
        raise GeometryError(f"{name} must be an integer; got {degree!r}")
    if degree < 0:
        raise GeometryError(f"{name} must be >= 0; got {degree}")
    return int(degree)


def _n_points(n: int) -> int:
    return (n + 1) * (n + 2) // 2


@lru_cache(maxsize=64)
def _indices(n: int) -> np.ndarray:
    i = np.repeat(np.arange(n, -1, -1), np.arange(1, n + 2))
    j = np.concatenate([np.arange(n - a, -1, -1) for a in range(n, -1, -1)])
    out = np.stack([i, j, n - i - j], axis=1).astype(np.int64)
    out.setflags(write=False)
    return out


def _position(m: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Position of (i, j, m - i - j) in `triangle_indices(m)`."""
    return (m - i) * (m - i + 1) // 2 + (m - i - j)


@lru_cache(maxsize=64)
def _children(m: int) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """For level m: for each direction e_c, (dst, src) with I = dst in level m, I - e_c = src in level m - 1."""
    idx = _indices(m)
    out = []
    for c in range(3):
        dst = np.flatnonzero(idx[:, c] >= 1)
        lower = idx[dst].copy()
        lower[:, c] -= 1
        out.append((dst, _position(m - 1, lower[:, 0], lower[:, 1])))
    return tuple(out)


@lru_cache(maxsize=64)
def _parents(m: int) -> np.ndarray:
    """(3, N_m) positions in level m + 1 of I + e1, I + e2, I + e3 for I in level m."""
    idx = _indices(m)
    out = np.empty((3, idx.shape[0]), dtype=np.int64)
    for c in range(3):
        up = idx.copy()
        up[:, c] += 1
        out[c] = _position(m + 1, up[:, 0], up[:, 1])
    return out


def triangle_indices(n: int) -> np.ndarray:
    """Index triples (i, j, k), i + j + k = n, of a degree-n triangular Bézier patch.

    Parameters
    ----------
    n : int
        Degree (>= 0).

    Returns
    -------
    ((n+1)(n+2)/2, 3) int64
        Ordered by i descending, then j descending (the control-point order of
        `trimsurf.model.BezierTriangle`); the position of (i, j, k) is
        ``(n-i)(n-i+1)/2 + (n-i-j)``.

    Examples
    --------
    >>> triangle_indices(1)
    array([[1, 0, 0],
           [0, 1, 0],
           [0, 0, 1]])
    """
    return _indices(_check_degree(n, "n")).copy()


def _check_patch(control_points, degree) -> tuple[np.ndarray, int, bool]:
    n = _check_degree(degree)
    try:
        cp = np.asarray(control_points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise GeometryError(f"control_points must be a numeric array; {exc}") from None
    if cp.ndim not in (2, 3):
        raise GeometryError(f"control_points must have shape (N, dim) or (n_patches, N, dim); got {cp.shape}")
    if cp.shape[-2] != _n_points(n):
        raise GeometryError(f"a degree-{n} triangular patch needs {_n_points(n)} control points; "
                            f"got {cp.shape[-2]}")
    if not np.all(np.isfinite(cp)):
        raise GeometryError("control_points contains NaN or infinite values")
    batched = cp.ndim == 3
    return (cp if batched else cp[None]), n, batched


def _check_bary(bary) -> np.ndarray:
    try:
        b = np.asarray(bary, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise GeometryError(f"bary must be a numeric array; {exc}") from None
    if b.ndim == 1 and b.shape[0] == 3:
        b = b[None]
    if b.ndim != 2 or b.shape[1] != 3:
        raise GeometryError(f"bary must have shape (k, 3); got {b.shape}")
    if not np.all(np.isfinite(b)):
        raise GeometryError("bary contains NaN or infinite values")
    if b.shape[0]:
        err = np.abs(b.sum(axis=1) - 1.0)
        if err.max() > _BARY_SUM_TOL:
            row = int(np.argmax(err))
            raise GeometryError(f"bary rows must sum to 1; row {row} sums to {b[row].sum()!r}")
    return b


def _basis_levels(n: int, bary: np.ndarray, lowest: int) -> list[np.ndarray]:
    """Bases of degrees lowest..n at `bary`, each (k, N_m), by the de Casteljau recurrence."""
    k = bary.shape[0]
    b = np.ones((k, 1))
    levels = [b] if lowest == 0 else []
    for m in range(1, n + 1):
        nb = np.zeros((k, _n_points(m)))
        for c, (dst, src) in enumerate(_children(m)):
            nb[:, dst] += bary[:, c:c + 1] * b[:, src]
        b = nb
        if m >= lowest:
            levels.append(b)
    return levels


def _evaluate(matrix: np.ndarray, cp: np.ndarray) -> np.ndarray:
    """sum_I matrix[q, I] cp[p, I, d] -> (P, k, dim), as one GEMM over all patches."""
    n_patches, n_ctrl, dim = cp.shape
    flat = cp.transpose(1, 0, 2).reshape(n_ctrl, n_patches * dim)
    out = (matrix @ flat).reshape(matrix.shape[0], n_patches, dim)
    return np.ascontiguousarray(out.transpose(1, 0, 2))


@lru_cache(maxsize=64)
def _difference_matrix(m: int, c: int) -> np.ndarray:
    """(N_{m-1}, N_m) matrix of (D b)_I = b_{I+e_c} - b_{I+e1} (c = 1: along s, c = 2: along t)."""
    par = _parents(m - 1)
    rows = np.arange(par.shape[1])
    out = np.zeros((par.shape[1], _n_points(m)))
    out[rows, par[c]] += 1.0
    out[rows, par[0]] -= 1.0
    out.setflags(write=False)
    return out


@lru_cache(maxsize=64)
def _derivative_operators(n: int, top: int) -> dict[tuple[int, int], np.ndarray]:
    """n!/(n-a-b)! D_s^a D_t^b as (N_{n-a-b}, N_n) matrices for a + b <= top."""
    ops = {(0, 0): np.eye(_n_points(n))}
    for total in range(1, top + 1):
        m = n - total + 1
        for a in range(total, -1, -1):
            b = total - a
            if a > 0:
                ops[(a, b)] = (n - total + 1) * _difference_matrix(m, 1) @ ops[(a - 1, b)]
            else:
                ops[(a, b)] = (n - total + 1) * _difference_matrix(m, 2) @ ops[(a, b - 1)]
    return ops


@lru_cache(maxsize=64)
def _triangle_elevation_matrix(n: int, times: int) -> np.ndarray:
    """(N_{n+times}, N_n) matrix of `times` elevation steps."""
    e = np.eye(_n_points(n))
    for m in range(n + 1, n + times + 1):
        idx = _indices(m)
        new = np.zeros((_n_points(m), e.shape[1]))
        for c, (dst, src) in enumerate(_children(m)):
            new[dst] += (idx[dst, c] / m)[:, None] * e[src]
        e = new
    e.setflags(write=False)
    return e


def bezier_triangle_points(control_points, degree: int, bary) -> np.ndarray:
    """Points of triangular Bézier patches at barycentric coordinates.

    Parameters
    ----------
    control_points : (N, dim) or (P, N, dim) float64
        One patch, or P patches of the same degree, ordered as `triangle_indices`.
    degree : int
        Degree n (N = (n+1)(n+2)/2).
    bary : (k, 3) float64
        Barycentric coordinates (u, v, w), rows summing to 1 (values outside the
        triangle extrapolate the polynomial).

    Returns
    -------
    (k, dim) float64, or (P, k, dim) for batched control points.

    Examples
    --------
    >>> net = [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]      # degree 1: the triangle itself
    >>> bezier_triangle_points(net, 1, [[0.2, 0.3, 0.5]])
    array([[0.2, 0.3]])
    """
    cp, n, batched = _check_patch(control_points, degree)
    b = _check_bary(bary)
    out = _evaluate(_basis_levels(n, b, n)[0], cp)
    return out if batched else out[0]


def bezier_triangle_derivatives(control_points, degree: int, bary, *, n_derivs: int = 1) -> np.ndarray:
    """Points and partial derivatives of triangular Bézier patches.

    The patch is parametrized by (s, t) with ``bary = (1 - s - t, s, t)``; derivatives
    are ``d^(a+b) x / ds^a dt^b``, i.e. directional derivatives along e2 - e1 (a times)
    and e3 - e1 (b times) in barycentric space.

    Parameters
    ----------
    control_points : (N, dim) or (P, N, dim) float64
    degree : int
    bary : (k, 3) float64
        Barycentric coordinates, rows summing to 1.
    n_derivs : int
        Highest total derivative order d, 0 <= d <= 2.

    Returns
    -------
    D : (d + 1, d + 1, k, dim) float64, or (d + 1, d + 1, P, k, dim) for batched patches
        ``D[a, b] = d^(a+b) x / ds^a dt^b`` for a + b <= d; zero elsewhere (the layout of
        `trimsurf.geom.surface_derivatives`).

    Notes
    -----
    ``d^(a+b) x/ds^a dt^b = n!/(n-a-b)! sum_{|I|=n-a-b} (D_s^a D_t^b b)_I B_I^{n-a-b}``
    with ``(D_s b)_I = b_{I+e2} - b_{I+e1}`` and ``(D_t b)_I = b_{I+e3} - b_{I+e1}``.

    References
    ----------
    Farin, *Curves and Surfaces for CAGD*, Eq. (17.14).

    Examples
    --------
    >>> net = [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]
    >>> bezier_triangle_derivatives(net, 1, [[0.2, 0.3, 0.5]])[1, 0]   # dx/ds
    array([[-1.,  1.]])
    """
    cp, n, batched = _check_patch(control_points, degree)
    b = _check_bary(bary)
    if isinstance(n_derivs, (bool, np.bool_)) or not isinstance(n_derivs, (int, np.integer)) \
            or not 0 <= n_derivs <= 2:
        raise GeometryError(f"n_derivs must be 0, 1 or 2; got {n_derivs!r}")
    d = int(n_derivs)
    top = min(d, n)
    levels = _basis_levels(n, b, n - top)  # degrees n - top .. n
    ops = _derivative_operators(n, top)
    keys = sorted(ops)
    # one GEMM for all derivatives: rows [basis_{n-a-b} @ op_ab for each (a, b)]
    stacked = np.concatenate([levels[top - a - bb] @ ops[(a, bb)] for a, bb in keys], axis=0)
    n_patches, n_ctrl, dim = cp.shape
    values = stacked @ cp.transpose(1, 0, 2).reshape(n_ctrl, n_patches * dim)
    values = values.reshape(len(keys), b.shape[0], n_patches, dim)
    out = np.zeros((d + 1, d + 1, n_patches, b.shape[0], dim))
    for q, (a, bb) in enumerate(keys):
        out[a, bb] = values[q].transpose(1, 0, 2)
    return out if batched else out[:, :, 0]


def elevate_bezier_triangle(control_points, degree: int, times: int = 1) -> np.ndarray:
    """Raise the degree of triangular Bézier patches, leaving them unchanged.

    Parameters
    ----------
    control_points : (N, dim) or (P, N, dim) float64
    degree : int
        Current degree n.
    times : int
        Degrees to add (>= 0).

    Returns
    -------
    (N', dim) or (P, N', dim) float64, N' = (n+times+1)(n+times+2)/2, ordered as
    ``triangle_indices(n + times)``.

    Notes
    -----
    One step: ``b'_I = (i b_{I-e1} + j b_{I-e2} + k b_{I-e3}) / (n + 1)`` for |I| = n + 1
    (a convex combination).

    References
    ----------
    Farin, *Curves and Surfaces for CAGD*, Eq. (17.20).

    Examples
    --------
    >>> elevate_bezier_triangle([[0.0], [1.0], [2.0]], 1)[:, 0]
    array([0. , 0.5, 1. , 1. , 1.5, 2. ])
    """
    cp, n, batched = _check_patch(control_points, degree)
    if isinstance(times, (bool, np.bool_)) or not isinstance(times, (int, np.integer)) or times < 0:
        raise GeometryError(f"times must be an integer >= 0; got {times!r}")
    if times == 0:
        out = cp.copy()
    else:
        out = _evaluate(_triangle_elevation_matrix(n, int(times)), cp)
    return out if batched else out[0]
