"""B-spline and NURBS evaluation, batched over many parameters.

All functions take raw arrays (degree, knots, control points, weights) so the
model classes, the projection and every capability share one implementation.
Parameters outside the domain are clamped to it. ``weights=None`` means a
polynomial (non-rational) B-spline.

References
----------
L. Piegl, W. Tiller, *The NURBS Book*, 2nd ed., Springer 1997:
A2.1 (FindSpan), A2.3 (DersBasisFuns), A3.2 / A3.6 (curve and surface
derivatives), A4.2 / A4.4 (rational derivatives).
"""

from __future__ import annotations

from math import comb

import numpy as np

from ..errors import GeometryError

__all__ = ["find_spans", "basis_functions", "curve_derivatives", "curve_points", "surface_derivatives",
           "surface_points", "unit_normals", "first_fundamental_form"]

_CHUNK = 1 << 15  # points per evaluation chunk: bounds the (n, p+1, q+1, 4) gather to a few MB
# the clip ufunc itself: np.clip's Python wrappers cost more than the clip of the few parameters a
# p-curve sample has (thousands of calls per shell); same ufunc, same values
_clip = getattr(getattr(getattr(np, "_core", None), "umath", None), "clip", np.clip)


def _kernels():
    """The compiled kernels, imported on first use: importing this module (as the STEP reader's process
    does, through `trimsurf.model`) does not import numba."""
    from . import _nurbs_kernels

    return _nurbs_kernels


def _as_params(t, name: str, cols: int | None) -> np.ndarray:
    arr = np.asarray(t, dtype=np.float64)
    if cols is None:
        arr = np.atleast_1d(arr)
        if arr.ndim != 1:
            raise GeometryError(f"{name} must have shape (n,); got {arr.shape}")
    else:
        if arr.ndim == 1 and arr.shape[0] == cols:
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[1] != cols:
            raise GeometryError(f"{name} must have shape (n, {cols}); got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise GeometryError(f"{name} contains NaN or infinite values")
    return arr


def find_spans(degree: int, knots: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Knot span index i with knots[i] <= t < knots[i+1] for each t (A2.1, batched).

    Parameters
    ----------
    degree : int
    knots : (m + 1,) float64
    t : (n,) float64
        Parameters, clamped to the domain [knots[degree], knots[-degree-1]].

    Returns
    -------
    (n,) int64, in [degree, n_ctrl - 1]; the domain end maps to the last non-empty span.
    """
    knots = np.asarray(knots, dtype=np.float64)
    n_ctrl = knots.shape[0] - degree - 1
    spans = np.searchsorted(knots, t, side="right") - 1
    _clip(spans, degree, n_ctrl - 1, out=spans)
    # at the domain end, step back over empty spans (repeated end knots)
    end = knots[n_ctrl]
    at_end = t >= end
    if np.any(at_end):
        last = n_ctrl - 1
        while last > degree and knots[last] >= end:
            last -= 1
        spans[at_end] = last
    return spans.astype(np.int64)


def basis_functions(degree: int, knots: np.ndarray, spans: np.ndarray, t: np.ndarray,
                    n_derivs: int = 0) -> np.ndarray:
    """Non-zero basis functions and their derivatives (A2.3, batched over t).

    Returns
    -------
    ders : (n_derivs + 1, n, degree + 1) float64
        ders[k, i, r] = d^k N_{spans[i] - degree + r, degree}(t[i]) / dt^k.
        Derivatives above the degree are zero.
    """
    ders = np.empty((int(n_derivs) + 1, t.shape[0], int(degree) + 1))
    _kernels().basis_functions_kernel(int(degree), read_only(knots),
                                      np.ascontiguousarray(spans, dtype=np.int64), np.ascontiguousarray(t, dtype=np.float64),
                                      int(n_derivs), ders)
    return ders


def read_only(a) -> np.ndarray:
    """`a` as a C-contiguous float64 array that cannot be written (a view where `a` can).

    The compiled kernels see every input array read-only: numba compiles one version per
    combination of writable and read-only arguments, so mixed inputs would multiply the
    first-call compile time.
    """
    v = np.ascontiguousarray(a, dtype=np.float64)
    if v.flags.writeable:
        v = v.view()
        v.flags.writeable = False
    return v


_HOMOGENEOUS: dict = {}     # id(control points) -> (control points, weights, homogeneous array)


def _homogeneous(control_points: np.ndarray, weights: np.ndarray | None) -> np.ndarray:
    cp = np.asarray(control_points, dtype=np.float64)
    if weights is None:
        return read_only(cp)
    # read-only arrays (the model's) cannot change: their homogeneous array is built once (the entry
    # keeps both arrays alive, so an id is never reused while it is cached)
    frozen = (not cp.flags.writeable and isinstance(weights, np.ndarray) and not weights.flags.writeable)
    hit = _HOMOGENEOUS.get(id(cp)) if frozen else None
    if hit is not None and hit[0] is cp and hit[1] is weights:
        return hit[2]
    w = np.asarray(weights, dtype=np.float64)[..., None]
    pw = read_only(np.concatenate([cp * w, w], axis=-1))
    if not frozen:
        return pw
    if len(_HOMOGENEOUS) > 4096:
        _HOMOGENEOUS.clear()
    _HOMOGENEOUS[id(cp)] = (cp, weights, pw)
    return pw


def _clamp(t: np.ndarray, knots: np.ndarray, degree: int) -> np.ndarray:
    return _clip(t, knots[degree], knots[-degree - 1])


def curve_derivatives(degree: int, knots, control_points, weights, t, *, n_derivs: int = 0) -> np.ndarray:
    """Points and derivatives of a B-spline/NURBS curve (A3.2, A4.2).

    Parameters
    ----------
    degree : int
    knots : (n_ctrl + degree + 1,) float64
    control_points : (n_ctrl, dim) float64
    weights : (n_ctrl,) float64 or None
    t : (n,) float64
    n_derivs : int
        Highest derivative order.

    Returns
    -------
    (n_derivs + 1, n, dim) float64 : CK[k] = d^k C / dt^k.

    Examples
    --------
    >>> import numpy as np
    >>> curve_derivatives(1, [0, 0, 1, 1], np.array([[0., 0.], [2., 0.]]), None, [0.5], n_derivs=1)[:, 0]
    array([[1., 0.],
           [2., 0.]])
    """
    knots = np.asarray(knots, dtype=np.float64)
    t = _clamp(_as_params(t, "t", None), knots, degree)
    pw = _homogeneous(control_points, weights)
    dim = pw.shape[-1] - (weights is not None)
    nd = int(n_derivs)
    if nd == 0:         # points only: the compiled kernel, one pass per point
        out = np.empty((1, t.shape[0], dim))
        _kernels().curve_points_kernel(int(degree), read_only(knots), read_only(pw),
                                       weights is not None, np.ascontiguousarray(t), out[0])
        return out
    out = np.empty((nd + 1, t.shape[0], dim))
    for s in range(0, t.shape[0], _CHUNK):
        tc = t[s:s + _CHUNK]
        spans = find_spans(degree, knots, tc)
        ders = basis_functions(degree, knots, spans, tc, nd)
        idx = spans[:, None] - degree + np.arange(degree + 1)
        ck = np.einsum("kni,nid->knd", ders, pw[idx])
        out[:, s:s + _CHUNK] = ck if weights is None else _rational_curve(ck, nd)
    return out


def _rational_curve(ckw: np.ndarray, nd: int) -> np.ndarray:
    a, w = ckw[..., :-1], ckw[..., -1]
    ck = np.empty_like(a)
    for k in range(nd + 1):
        v = a[k].copy()
        for i in range(1, k + 1):
            v -= comb(k, i) * w[i][:, None] * ck[k - i]
        ck[k] = v / w[0][:, None]
    return ck


def curve_points(degree: int, knots, control_points, weights, t) -> np.ndarray:
    """Points C(t), shape (n, dim)."""
    return curve_derivatives(degree, knots, control_points, weights, t, n_derivs=0)[0]


def surface_derivatives(degree_u: int, degree_v: int, knots_u, knots_v, control_points, weights, uv, *,
                        n_derivs: int = 0) -> np.ndarray:
    """Points and partial derivatives of a B-spline/NURBS surface (A3.6, A4.4), batched.

    Parameters
    ----------
    degree_u, degree_v : int
    knots_u, knots_v : float64 knot vectors
    control_points : (nu, nv, 3) float64
    weights : (nu, nv) float64 or None
    uv : (n, 2) float64
    n_derivs : int
        Highest total derivative order d.

    Returns
    -------
    SKL : (d + 1, d + 1, n, 3) float64
        SKL[k, l] = d^(k+l) S / du^k dv^l for k + l <= d; zero elsewhere.
    """
    ku = np.asarray(knots_u, dtype=np.float64)
    kv = np.asarray(knots_v, dtype=np.float64)
    uv = _as_params(uv, "uv", 2)
    u = _clamp(uv[:, 0], ku, degree_u)
    v = _clamp(uv[:, 1], kv, degree_v)
    pw = np.ascontiguousarray(_homogeneous(control_points, weights))
    nd = int(n_derivs)
    out = np.zeros((nd + 1, nd + 1, uv.shape[0], 3))
    _kernels().surface_derivatives_kernel(int(degree_u), int(degree_v), read_only(ku), read_only(kv),
                                          pw, weights is not None, np.ascontiguousarray(u), np.ascontiguousarray(v), nd, out)
    return out


def surface_points(degree_u: int, degree_v: int, knots_u, knots_v, control_points, weights, uv) -> np.ndarray:
    """Points S(u, v), shape (n, 3)."""
    return surface_derivatives(degree_u, degree_v, knots_u, knots_v, control_points, weights, uv,
                               n_derivs=0)[0, 0]


def unit_normals(su: np.ndarray, sv: np.ndarray) -> np.ndarray:
    """Unit normals su x sv / |su x sv|, shape (n, 3); NaN rows where the cross product vanishes."""
    nrm = np.cross(su, sv)
    length = np.linalg.norm(nrm, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(length > 0, nrm / np.where(length > 0, length, 1.0), np.nan)


def first_fundamental_form(su: np.ndarray, sv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """First fundamental form E = su.su, F = su.sv, G = sv.sv, each (n,)."""
    return (np.einsum("nd,nd->n", su, su), np.einsum("nd,nd->n", su, sv), np.einsum("nd,nd->n", sv, sv))
