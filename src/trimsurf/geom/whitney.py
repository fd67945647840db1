"""Whitney extension of piecewise-linear data given on a polyline in the plane.

Given values eps on a boundary polyline (linear along each segment), compute,
exactly and per component,

* the Lipschitz constant of the boundary data (eq. 2 of both papers)
  ``L = sup_{p1 != p2 on the boundary} |eps(p1) - eps(p2)| / |p1 - p2|``,
* the lower and upper Whitney extensions (eqs. 3 and 4)
  ``l(p) = sup_q (eps(q) - L |p - q|)``, ``u(p) = inf_q (eps(q) + L |p - q|)``,
* their average ``a = (l + u) / 2`` (eq. 5).

The suprema run over *every* point q of the polyline, not only its vertices:
on one segment ``eps(q) - L |p - q|`` is concave in the arc length and its
maximiser has a closed form, so each (query, segment) pair costs a few
floating-point operations. Pairs are processed in chunks so memory stays
bounded for any number of queries and segments.

Vector-valued data (shape ``(k, c)``) is treated componentwise, as in
Sec. 3 of whitney-well-definition.txt: each component gets its own L, l, u
and a, and the Lipschitz constants of the components together bound the
Lipschitz constant of the vector function.

References
----------
.. [1] Join mesh patches along a common edge (join-mesh-patches-whitney.txt),
   Sec. II (eq. 1 and the slope criterion), Sec. III-A (eq. 2, the Whitney
   extension) and III-B (eqs. 3, 4 and the piecewise-linear evaluation).
.. [2] Well-definition of trimmed B-reps by Whitney extension
   (whitney-well-definition.txt), Sec. 3, eqs. (1)-(5) and Theorem 1.
.. [3] H. Whitney, "Analytic extensions of differentiable functions defined
   in closed sets", Trans. AMS 36 (1934) 63-89.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..errors import GeometryError, TrimLoopError

__all__ = ["WhitneyExtension", "whitney_extension", "lipschitz_constant"]

_DEFAULT_CHUNK = 1 << 15  # (query, segment) or (vertex, segment) pairs per chunk: 256 kB per temporary (cache-sized)
_BIG = 1e300  # stands in for +inf in a product with h >= 0 so that 0 * _BIG = 0, never NaN
_REL_SLACK = 1e-9  # a user-given L may fall below the computed one by this relative amount (rounding)


class WhitneyExtension(NamedTuple):
    """Lower, upper and average Whitney extensions at the query points.

    Attributes
    ----------
    lower : (q,) or (q, c) float64
        l(p) of eq. (3): the smallest extension with Lipschitz constant L.
    upper : (q,) or (q, c) float64
        u(p) of eq. (4): the largest extension with Lipschitz constant L.
    average : (q,) or (q, c) float64
        a(p) = (l(p) + u(p)) / 2 of eq. (5): interpolates the data, has
        Lipschitz constant L and ``|a| <= max |eps|`` on the boundary.
    lipschitz : float or (c,) float64
        The constant L used, per component (a float for scalar data).
    """

    lower: np.ndarray
    upper: np.ndarray
    average: np.ndarray
    lipschitz: float | np.ndarray


class _Segments(NamedTuple):
    a: np.ndarray        # (m, 2) start points
    d: np.ndarray        # (m, 2) unit directions
    length: np.ndarray   # (m,)
    e_a: np.ndarray      # (m, c) values at the start
    g: np.ndarray        # (m, c) slope of the values along the segment (per unit length)
    start: np.ndarray    # (m,) vertex index of the start
    end: np.ndarray      # (m,) vertex index of the end


def _check_boundary(boundary, values) -> tuple[np.ndarray, np.ndarray, bool]:
    bnd = np.asarray(boundary, dtype=np.float64)
    if bnd.ndim != 2 or bnd.shape[1] != 2:
        raise TrimLoopError(f"whitney: boundary must have shape (k, 2); got {bnd.shape}")
    if bnd.shape[0] < 2:
        raise TrimLoopError(f"whitney: boundary needs at least 2 vertices; got {bnd.shape[0]}")
    if not np.all(np.isfinite(bnd)):
        i = int(np.argwhere(~np.isfinite(bnd))[0, 0])
        raise TrimLoopError(f"whitney: boundary vertex {i} is not finite")
    val = np.asarray(values, dtype=np.float64)
    scalar = val.ndim == 1
    if scalar:
        val = val[:, None]
    if val.ndim != 2 or val.shape[0] != bnd.shape[0] or val.shape[1] < 1:
        raise GeometryError(f"whitney: values must have shape ({bnd.shape[0]},) or ({bnd.shape[0]}, c) "
                            f"to match the boundary; got {np.shape(values)}")
    if not np.all(np.isfinite(val)):
        i = int(np.argwhere(~np.isfinite(val))[0, 0])
        raise GeometryError(f"whitney: value at boundary vertex {i} is not finite")
    return bnd, val, scalar


def _segments(bnd: np.ndarray, val: np.ndarray, closed: bool) -> _Segments:
    k = bnd.shape[0]
    start = np.arange(k if closed else k - 1)
    end = (start + 1) % k
    vec = bnd[end] - bnd[start]
    length = np.hypot(vec[:, 0], vec[:, 1])
    if np.any(length == 0):
        j = int(np.flatnonzero(length == 0)[0])
        raise TrimLoopError(f"whitney: boundary segment {j} (vertices {start[j]} -> {end[j]}) has zero length; "
                            "remove repeated vertices (a closed boundary must not repeat its first vertex)")
    d = vec / length[:, None]
    g = (val[end] - val[start]) / length[:, None]
    return _Segments(bnd[start], d, length, val[start], g, start, end)


def _lipschitz(bnd: np.ndarray, val: np.ndarray, seg: _Segments, chunk_size: int) -> np.ndarray:
    """Exact L per component for piecewise-linear data (see `lipschitz_constant`)."""
    k, c = val.shape
    m = seg.length.shape[0]
    big_l = np.max(np.abs(seg.g), axis=0)  # pairs on one segment: slope |g|
    rows = max(1, chunk_size // m)
    cols = max(1, min(m, chunk_size))
    for i0 in range(0, k, rows):
        vi = np.arange(i0, min(k, i0 + rows))
        p = bnd[vi]
        for j0 in range(0, m, cols):
            sj = slice(j0, min(m, j0 + cols))
            dx = p[:, None, 0] - seg.a[None, sj, 0]
            dy = p[:, None, 1] - seg.a[None, sj, 1]
            ux, uy = seg.d[sj, 0], seg.d[sj, 1]
            x0 = dx * ux + dy * uy          # arc-length coordinate of the vertex along the segment
            h = dx * uy - dy * ux           # signed distance of the vertex to the segment's line
            h2 = h * h
            ln = seg.length[sj]
            own = (vi[:, None] == seg.start[None, sj]) | (vi[:, None] == seg.end[None, sj])
            for comp in range(c):
                g = seg.g[sj, comp]
                cc = seg.e_a[sj, comp][None, :] - val[vi, comp][:, None]  # eps(q(x)) - eps(v) = cc + g x
                # stationary point of (cc + g x) / sqrt(h^2 + (x - x0)^2): x* = x0 + g h^2 / (cc + g x0)
                den = cc + g * x0
                num = g * h2
                shift = np.divide(num, den, out=np.zeros_like(den), where=den != 0)
                xs = np.clip(x0 + shift, 0.0, ln)
                best = np.zeros_like(x0)
                for x in (xs, np.zeros_like(x0), np.broadcast_to(ln, x0.shape)):
                    rx = x - x0
                    dist = np.sqrt(h2 + rx * rx)
                    with np.errstate(divide="ignore", invalid="ignore"):
                        r = np.abs(cc + g * x) / dist
                    np.maximum(best, np.where(own | np.isnan(r), 0.0, r), out=best)
                worst = best.max()
                if not np.isfinite(worst):
                    bi, bj = np.unravel_index(np.argmax(best), best.shape)
                    raise TrimLoopError(
                        f"whitney: boundary vertex {int(vi[bi])} lies on segment {j0 + int(bj)} with a different "
                        f"value (component {comp}); the boundary data is not Lipschitz")
                big_l[comp] = max(big_l[comp], worst)
    return big_l


def _check_chunk(chunk_size) -> int:
    cs = int(chunk_size)
    if cs < 1:
        raise GeometryError(f"whitney: chunk_size must be a positive integer; got {chunk_size!r}")
    return cs


def lipschitz_constant(boundary, values, *, closed: bool = True, chunk_size: int = _DEFAULT_CHUNK):
    """Exact Lipschitz constant of piecewise-linear data on a polyline (eq. 2).

    Parameters
    ----------
    boundary : (k, 2) float64
        Polyline vertices in the plane, k >= 2. A closed boundary must not
        repeat its first vertex at the end.
    values : (k,) or (k, c) float64
        Data eps at the vertices, linear along each segment.
    closed : bool
        Whether a segment joins the last vertex to the first.
    chunk_size : int
        Number of (vertex, segment) pairs processed at once (bounds memory).

    Returns
    -------
    float or (c,) float64
        ``L = sup |eps(p1) - eps(p2)| / |p1 - p2|`` over all pairs of distinct
        boundary points (not only vertices), per component.

    Raises
    ------
    TrimLoopError
        Fewer than 2 vertices, a zero-length segment, or a vertex lying on
        another segment with a different value (L would be infinite).
    GeometryError
        Values of the wrong shape or not finite; bad chunk_size.

    Notes
    -----
    The supremum over two segments is attained with at least one point at a
    segment end: for non-parallel segments ``(s, t) -> q2(t) - q1(s)`` is an
    affine bijection onto a parallelogram, the numerator is affine in
    ``x = q2 - q1`` and ``(alpha + beta.x) / |x|`` is monotone along rays from
    the origin, so ``|.|`` peaks on the parallelogram's edges; for parallel
    segments the denominator is constant where the numerator is affine. So L
    is the largest of the segment slopes ``|g|`` and, for every (vertex v,
    segment q(x)) pair, ``max_x |c + g x| / sqrt(h^2 + (x - x0)^2)``, whose
    only stationary point is ``x* = x0 + g h^2 / (c + g x0)`` (c = eps(q(0))
    - eps(v); x0, h the coordinates of v along and across the segment). The
    cost is O(k^2).

    References
    ----------
    join-mesh-patches-whitney.txt, Sec. III-A, eq. (2);
    whitney-well-definition.txt, Sec. 3, eq. (2).

    Examples
    --------
    >>> import numpy as np
    >>> square = np.array([[0., 0.], [1., 0.], [1., 1.], [0., 1.]])
    >>> float(lipschitz_constant(square, [0., 1., 1., 0.]))
    1.0
    """
    cs = _check_chunk(chunk_size)
    bnd, val, scalar = _check_boundary(boundary, values)
    seg = _segments(bnd, val, bool(closed))
    big_l = _lipschitz(bnd, val, seg, cs)
    return float(big_l[0]) if scalar else big_l


def _extension(queries: np.ndarray, seg: _Segments, big_l: np.ndarray, chunk_size: int):
    q = queries.shape[0]
    m = seg.length.shape[0]
    c = big_l.shape[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        gamma = np.where(big_l > 0, seg.g / big_l, 0.0)
    np.clip(gamma, -1.0, 1.0, out=gamma)
    # offset of the maximiser from the foot of p, per unit of distance h: gamma / sqrt(1 - gamma^2)
    one_m = 1.0 - gamma * gamma
    with np.errstate(divide="ignore"):
        tan = np.where(one_m > 0, gamma / np.sqrt(one_m), np.copysign(_BIG, gamma))
    np.clip(tan, -_BIG, _BIG, out=tan)
    lower = np.full((q, c), -np.inf)
    upper = np.full((q, c), np.inf)
    rows = max(1, chunk_size // m)
    cols = max(1, min(m, chunk_size))
    for i0 in range(0, q, rows):
        si = slice(i0, min(q, i0 + rows))
        p = queries[si]
        for j0 in range(0, m, cols):
            sj = slice(j0, min(m, j0 + cols))
            dx = p[:, None, 0] - seg.a[None, sj, 0]
            dy = p[:, None, 1] - seg.a[None, sj, 1]
            ux, uy = seg.d[sj, 0], seg.d[sj, 1]
            x0 = dx * ux + dy * uy
            h = np.abs(dx * uy - dy * ux)
            h2 = h * h
            ln = seg.length[sj]
            for comp in range(c):
                lc = big_l[comp]
                ea, g, t = seg.e_a[sj, comp], seg.g[sj, comp], tan[sj, comp]
                # l: maximise ea + g x - L sqrt(h^2 + (x - x0)^2) (concave in x) -> x = x0 + h t, clamped
                x = np.clip(x0 + h * t, 0.0, ln)
                rx = x - x0
                val = ea + g * x - lc * np.sqrt(h2 + rx * rx)
                np.maximum(lower[si, comp], val.max(axis=1), out=lower[si, comp])
                # u: minimise ea + g x + L sqrt(...) -> x = x0 - h t, clamped
                x = np.clip(x0 - h * t, 0.0, ln)
                rx = x - x0
                val = ea + g * x + lc * np.sqrt(h2 + rx * rx)
                np.minimum(upper[si, comp], val.min(axis=1), out=upper[si, comp])
    return lower, upper


def whitney_extension(boundary, values, queries, *, closed: bool = True, lipschitz=None,
                      chunk_size: int = _DEFAULT_CHUNK) -> WhitneyExtension:
    """Lower, upper and average Whitney extensions of polyline data (eqs. 3-5).

    Parameters
    ----------
    boundary : (k, 2) float64
        Polyline vertices in the plane (e.g. the uv pre-image of a patch
        boundary), k >= 2. A closed boundary must not repeat its first vertex.
    values : (k,) or (k, c) float64
        Data eps at the vertices; eps is linear along each segment. Vector
        data is extended componentwise (whitney-well-definition.txt, Sec. 3).
    queries : (q, 2) float64
        Points p at which to evaluate the extensions (anywhere in the plane).
    closed : bool
        Whether a segment joins the last vertex to the first.
    lipschitz : float or (c,) float64, optional
        Lipschitz constant(s) to use instead of the computed one. It must not
        be smaller than the exact L of the data (`lipschitz_constant`): with a
        smaller L the bracketing fails (l > u somewhere) and the extensions no
        longer interpolate the data, so that raises. A larger L is allowed (a
        common L for adjacent patches); l, u and a then interpolate the data
        with that constant.
    chunk_size : int
        Number of (query, segment) pairs processed at once; memory is a few
        dozen bytes per pair.

    Returns
    -------
    WhitneyExtension
        ``lower``, ``upper``, ``average`` of shape (q,) for scalar values or
        (q, c) for vector values, and ``lipschitz`` (float or (c,)).

    Raises
    ------
    TrimLoopError
        Bad boundary: wrong shape, fewer than 2 vertices, NaN, zero-length
        segment, or a vertex on another segment with a different value.
    GeometryError
        Values or queries of the wrong shape or not finite, a negative or too
        small ``lipschitz``, a bad ``chunk_size``.

    Notes
    -----
    For a query p and a segment q(x) = A + x d (x in [0, len], |d| = 1) with
    eps(q(x)) = e_A + g x, ``eps(q(x)) - L |p - q(x)|`` is concave in x and
    stationary where ``(x - x0) / sqrt(h^2 + (x - x0)^2) = g / L``, i.e. at
    ``x = x0 + h (g/L) / sqrt(1 - (g/L)^2)`` (x0 and h the coordinates of p
    along and across the segment); clamped to [0, len] it is the exact
    maximiser, also when |g| = L or h = 0. The infimum for u uses -g. The
    results are exact up to rounding: ``l = a = u = eps`` on the boundary,
    ``l <= a <= u`` everywhere, and l, u, a have Lipschitz constant L.

    References
    ----------
    join-mesh-patches-whitney.txt, Sec. III-A (eq. 2) and III-B (eqs. 3, 4);
    whitney-well-definition.txt, Sec. 3, eqs. (3)-(5) and Theorem 1.

    Examples
    --------
    >>> import numpy as np
    >>> square = np.array([[0., 0.], [1., 0.], [1., 1.], [0., 1.]])
    >>> ext = whitney_extension(square, [0., 1., 1., 0.], [[0.5, 0.5], [0.25, 0.0]])
    >>> ext.average.round(12).tolist(), ext.lipschitz
    ([0.5, 0.25], 1.0)
    """
    cs = _check_chunk(chunk_size)
    bnd, val, scalar = _check_boundary(boundary, values)
    qry = np.asarray(queries, dtype=np.float64)
    if qry.ndim == 1 and qry.shape[0] == 2:
        qry = qry[None, :]
    if qry.ndim != 2 or qry.shape[1] != 2:
        raise GeometryError(f"whitney: queries must have shape (q, 2); got {np.shape(queries)}")
    if not np.all(np.isfinite(qry)):
        i = int(np.argwhere(~np.isfinite(qry))[0, 0])
        raise GeometryError(f"whitney: query point {i} is not finite")
    seg = _segments(bnd, val, bool(closed))
    big_l = _lipschitz(bnd, val, seg, cs)
    if lipschitz is not None:
        given = np.asarray(lipschitz, dtype=np.float64)
        if given.ndim == 0:
            given = np.full(big_l.shape, float(given))
        if given.shape != big_l.shape:
            raise GeometryError(f"whitney: lipschitz must be a number or have shape {big_l.shape}; "
                                f"got {np.shape(lipschitz)}")
        if not np.all(np.isfinite(given)) or np.any(given < 0):
            raise GeometryError(f"whitney: lipschitz must be finite and >= 0; got {lipschitz!r}")
        short = given < big_l * (1.0 - _REL_SLACK)
        if np.any(short):
            comp = int(np.flatnonzero(short)[0])
            raise GeometryError(
                f"whitney: lipschitz={given[comp]!r} is below the Lipschitz constant {big_l[comp]!r} of the "
                f"boundary data (component {comp}); the extension would not interpolate the data")
        big_l = np.maximum(given, big_l)
    lower, upper = _extension(qry, seg, big_l, cs)
    average = 0.5 * (lower + upper)
    if scalar:
        return WhitneyExtension(lower[:, 0], upper[:, 0], average[:, 0], float(big_l[0]))
    return WhitneyExtension(lower, upper, average, big_l)
