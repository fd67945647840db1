"""Whitney extension of piecewise-linear data given on polylines in the plane.

Given values eps on one or more boundary polylines (closed loops -- a face's
outer loop and its holes -- or open polylines; linear along each segment),
compute, exactly and per component,

* the Lipschitz constant of the boundary data (eq. 2 of both papers)
  ``L = sup_{p1 != p2 on the boundary} |eps(p1) - eps(p2)| / |p1 - p2|``,
  over all pairs of points of all the polylines (`lipschitz_loops`),
* the lower and upper Whitney extensions (eqs. 3 and 4)
  ``l(p) = sup_q (eps(q) - L |p - q|)``, ``u(p) = inf_q (eps(q) + L |p - q|)``,
* their average ``a = (l + u) / 2`` (eq. 5) (`whitney_average`).

The suprema run over *every* point q of the polylines, not only their
vertices: on one segment ``eps(q) - L |p - q|`` is concave in the arc length
and its maximiser has a closed form, so each (query, segment) pair costs a few
floating-point operations. The compiled kernel (numba) skips blocks of
segments that provably cannot hold the supremum (infimum) -- a bound from the
block's largest value and its distance to the query -- so most queries
evaluate two or three blocks; the result is still the exact supremum
(infimum), equal to evaluating every pair (tested against such a brute force).
This one implementation serves `trimsurf.join` (scalar heights over a face's
loops) and `trimsurf.certify` (3-vector discrepancies, per-component L).

Vector-valued data (shape ``(k, c)``) is treated componentwise, as in
Sec. 3 of whitney-well-definition.txt: each component gets its own L, l, u
and a, and the Lipschitz constants of the components together bound the
Lipschitz constant of the vector function.

`lipschitz_constant` and `whitney_extension` are the one-polyline forms;
`boundary_data` + `lipschitz_loops` / `whitney_average` take several
polylines and keep the segment data (and the exact L, computed once) for
repeated queries.

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
from numba import njit

from .._numba_load import install as _install_lazy_bitcode
from ..errors import GeometryError, TrimLoopError

_install_lazy_bitcode()     # before this module's kernels load (trimsurf._numba_load)

__all__ = ["WhitneyExtension", "whitney_extension", "lipschitz_constant", "BoundaryData", "boundary_data",
           "lipschitz_loops", "WhitneyAverage", "whitney_average"]

_DEFAULT_CHUNK = 1 << 15  # accepted for compatibility: the compiled kernels need no temporaries
_BLOCK = 16  # consecutive segments per pruning block
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


class BoundaryData(NamedTuple):
    """Piecewise-linear data eps on one or more polylines in the plane (`boundary_data` builds it).

    Segment ``j`` runs from ``points[start[j]]`` to ``points[end[j]]``; eps is
    linear along it: ``eps(a[j] + x d[j]) = e_a[j] + g[j] x`` for x in
    ``[0, length[j]]``. Values are stored as (., c) arrays; ``scalar`` says
    whether the caller gave scalar data (results are then returned 1-D).
    """

    a: np.ndarray        # (m, 2) segment start points
    d: np.ndarray        # (m, 2) unit directions
    length: np.ndarray   # (m,)
    e_a: np.ndarray      # (m, c) eps at the start
    g: np.ndarray        # (m, c) d eps / d arc length
    start: np.ndarray    # (m,) vertex index of the start
    end: np.ndarray      # (m,) vertex index of the end
    points: np.ndarray   # (k, 2) all vertices (the loops concatenated)
    values: np.ndarray   # (k, c) eps at them
    scalar: bool         # scalar data given: 1-D results
    strict: bool         # raise on a vertex lying on another segment with another value (L infinite)
    cache: dict          # exact L and pruning blocks, filled on first use


class WhitneyAverage(NamedTuple):
    """l, u and a = (l + u) / 2 of eqs. (3)-(5) at the queries, the L used and the pruning work.

    ``lower``, ``upper``, ``average`` have shape (n,) for scalar data and (n, c)
    otherwise; ``lipschitz`` is a float or (c,). ``mean_blocks_visited`` is the
    mean number of segment blocks evaluated per query, side and component.
    """

    lower: np.ndarray
    upper: np.ndarray
    average: np.ndarray
    lipschitz: float | np.ndarray
    mean_blocks_visited: float


def _check_values(bnd: np.ndarray, values, i_loop: int | None) -> tuple[np.ndarray, bool]:
    where = "" if i_loop is None else f" of loop {i_loop}"
    val = np.asarray(values, dtype=np.float64)
    scalar = val.ndim == 1
    if scalar:
        val = val[:, None]
    if val.ndim != 2 or val.shape[0] != bnd.shape[0] or val.shape[1] < 1:
        raise GeometryError(f"whitney: values{where} must have shape ({bnd.shape[0]},) or ({bnd.shape[0]}, c) "
                            f"to match the boundary; got {np.shape(values)}")
    if not np.all(np.isfinite(val)):
        i = int(np.argwhere(~np.isfinite(val))[0, 0])
        raise GeometryError(f"whitney: value at boundary vertex {i}{where} is not finite")
    return val, scalar


def _check_boundary(boundary, values, i_loop: int | None = None,
                    min_vertices: int = 2) -> tuple[np.ndarray, np.ndarray, bool]:
    where = "" if i_loop is None else f" of loop {i_loop}"
    bnd = np.asarray(boundary, dtype=np.float64)
    if bnd.ndim != 2 or bnd.shape[1] != 2:
        raise TrimLoopError(f"whitney: boundary{where} must have shape (k, 2); got {bnd.shape}")
    if bnd.shape[0] < min_vertices:
        raise TrimLoopError(f"whitney: boundary{where} needs at least {min_vertices} vertices; got {bnd.shape[0]}")
    if not np.all(np.isfinite(bnd)):
        i = int(np.argwhere(~np.isfinite(bnd))[0, 0])
        raise TrimLoopError(f"whitney: boundary vertex {i}{where} is not finite")
    val, scalar = _check_values(bnd, values, i_loop)
    return bnd, val, scalar


def boundary_data(loops, values, *, closed: bool = True, strict: bool = True) -> BoundaryData:
    """Segments of several polylines (a face's outer loop and holes, or open polylines) with vertex values.

    Parameters
    ----------
    loops : sequence of (k_i, 2) float64
        Polylines in the plane. A closed loop must not repeat its first
        vertex at the end.
    values : sequence of (k_i,) or (k_i, c) float64
        eps at the vertices of each polyline, linear along each segment; all
        scalar or all with the same number c of components.
    closed : bool
        Whether a segment joins the last vertex of each polyline to its first.
    strict : bool
        True: a polyline needs >= 2 vertices, a zero-length segment raises, and
        so does (in `lipschitz_loops`) a vertex lying on another segment with
        another value. False (sampled data, e.g. certify's): zero-length
        segments are dropped (their end vertices stay, as ends of the
        neighbouring segments) and such vertex-segment pairs are ignored.

    Returns
    -------
    BoundaryData

    Raises
    ------
    TrimLoopError
        A polyline of the wrong shape, too few vertices, points not finite, a
        zero-length segment (strict).
    GeometryError
        Values of the wrong shape, not finite, or with differing components.

    Examples
    --------
    >>> import numpy as np
    >>> bd = boundary_data([np.array([[0., 0.], [1., 0.], [0., 1.]])], [np.array([0., 1., 0.])])
    >>> bd.length.round(6).tolist(), round(lipschitz_loops(bd), 12)
    ([1.0, 1.414214, 1.0], 1.0)
    """
    loops, values = list(loops), list(values)
    if len(loops) != len(values) or not loops:
        raise GeometryError(f"whitney: need one value array per loop and at least one loop; got {len(loops)} "
                            f"loops and {len(values)} value arrays")
    pts, vals, starts, ends = [], [], [], []
    off = 0
    scalar = None
    one = len(loops) == 1
    for li, (lp, val) in enumerate(zip(loops, values)):
        bnd, v, sc = _check_boundary(lp, val, None if one else li, 2 if strict else 1)
        if scalar is None:
            scalar = sc
        elif sc != scalar or v.shape[1] != vals[0].shape[1]:
            raise GeometryError(f"whitney: values of loop {li} have shape {v.shape}; loop 0 has {vals[0].shape}")
        k = bnd.shape[0]
        idx = np.arange(k if closed else k - 1)
        starts.append(off + idx)
        ends.append(off + (idx + 1) % k)
        pts.append(bnd)
        vals.append(v)
        off += k
    p = np.ascontiguousarray(np.concatenate(pts))
    v = np.ascontiguousarray(np.concatenate(vals))
    s = np.concatenate(starts).astype(np.int64)
    e = np.concatenate(ends).astype(np.int64)
    vec = p[e] - p[s]
    length = np.hypot(vec[:, 0], vec[:, 1])
    if np.any(length == 0):
        if strict:
            j = int(np.flatnonzero(length == 0)[0])
            raise TrimLoopError(f"whitney: boundary segment {j} (vertices {s[j]} -> {e[j]}) has zero length; "
                                "remove repeated vertices (a closed boundary must not repeat its first vertex)")
        ok = length > 0
        s, e, vec, length = s[ok], e[ok], vec[ok], length[ok]
    d = np.ascontiguousarray(vec / length[:, None])
    g = np.ascontiguousarray((v[e] - v[s]) / length[:, None])
    return BoundaryData(np.ascontiguousarray(p[s]), d, length, np.ascontiguousarray(v[s]), g, s, e, p, v,
                        bool(scalar), bool(strict), {})


@njit(cache=True, nogil=True, inline="always")
def _raise_by_pair(i, j, pts, vals, a, d, length, g, start, end, best, bad):  # pragma: no cover - compiled
    """Raise ``best`` (per component) to the sup of |eps(q) - eps(v_i)| / |q - v_i| over q on segment j.

    The numerator is affine along the segment and the quotient has one stationary point, so the sup is
    at that point or at an end. A zero distance with a non-zero numerator is recorded in ``bad``.
    """
    sa, sb = start[j], end[j]
    if i == sa or i == sb:
        return
    ux, uy, ln = d[j, 0], d[j, 1], length[j]
    dx, dy = pts[i, 0] - a[j, 0], pts[i, 1] - a[j, 1]
    x0 = dx * ux + dy * uy          # coordinate of the vertex along the segment
    h = dx * uy - dy * ux           # and across it
    h2 = h * h
    xc = min(max(x0, 0.0), ln) - x0
    dmin = np.sqrt(h2 + xc * xc)    # distance vertex - segment: every denominator is >= dmin
    for cc in range(vals.shape[1]):
        ev = vals[i, cc]
        # the numerator is affine along the segment: |.| <= its larger end value
        if max(abs(vals[sa, cc] - ev), abs(vals[sb, cc] - ev)) <= best[cc] * dmin:
            continue
        gj = g[j, cc]
        c0 = vals[sa, cc] - ev      # eps(q(x)) - eps(v) = c0 + g x
        den = c0 + gj * x0
        xs = x0
        if den != 0.0:              # the only stationary point of (c0 + g x) / sqrt(h^2 + (x - x0)^2)
            xs = x0 + gj * h2 / den
        if xs < 0.0:
            xs = 0.0
        elif xs > ln:
            xs = ln
        for t in range(3):
            x = xs if t == 0 else (0.0 if t == 1 else ln)
            rx = x - x0
            dist = np.sqrt(h2 + rx * rx)
            num = abs(c0 + gj * x)
            if dist == 0.0:
                if num > 0.0 and bad[0] < 0:
                    bad[0], bad[1], bad[2] = i, j, cc
                continue
            r = num / dist
            if r > best[cc]:
                best[cc] = r


@njit(cache=True, nogil=True)
def _segment_slopes(g):  # pragma: no cover - compiled
    """Per component, the largest |slope| along one segment (pairs on the same segment)."""
    best = np.zeros(g.shape[1])
    for j in range(g.shape[0]):
        for cc in range(g.shape[1]):
            if abs(g[j, cc]) > best[cc]:
                best[cc] = abs(g[j, cc])
    return best


@njit(cache=True, nogil=True)
def _lipschitz_kernel(pts, vals, a, d, length, g, start, end):  # pragma: no cover - compiled
    """Exact L per component; the first (vertex, segment, component) with an infinite quotient, or -1."""
    best = _segment_slopes(g)
    bad = np.full(3, -1, dtype=np.int64)
    for j in range(a.shape[0]):
        for i in range(pts.shape[0]):
            _raise_by_pair(i, j, pts, vals, a, d, length, g, start, end, best, bad)
    return best, bad


@njit(cache=True, nogil=True)
def _lipschitz_kernel_pruned(pts, vals, a, d, length, g, start, end, bc, br, bmax, bmin, bstart,
                             bend):  # pragma: no cover - compiled
    """`_lipschitz_kernel` with blocks of segments skipped when they provably cannot raise L.

    For a vertex v at distance r from a block's bounding disc, every quotient |eps(q) - eps(v)| / |q - v|
    with q on the block is at most max(|e_max - eps(v)|, |e_min - eps(v)|) / r (e_max, e_min the block's
    extreme values): a block whose bound does not beat the current L for any component is skipped. The
    result is the same exact supremum as the unpruned kernel (only pairs that cannot attain it are skipped).
    """
    c = vals.shape[1]
    best = _segment_slopes(g)
    bad = np.full(3, -1, dtype=np.int64)
    for i in range(pts.shape[0]):
        px, py = pts[i, 0], pts[i, 1]
        for b in range(bc.shape[0]):
            dx, dy = px - bc[b, 0], py - bc[b, 1]
            gap = np.sqrt(dx * dx + dy * dy) - br[b]
            if gap > 0.0:
                skip = True
                for cc in range(c):
                    ev = vals[i, cc]
                    if max(abs(bmax[b, cc] - ev), abs(bmin[b, cc] - ev)) > best[cc] * gap:
                        skip = False
                        break
                if skip:
                    continue
            for j in range(bstart[b], bend[b]):
                _raise_by_pair(i, j, pts, vals, a, d, length, g, start, end, best, bad)
    return best, bad


def lipschitz_loops(data: BoundaryData):
    """Exact L of eq. (2) per component, over all pairs of points of all the polylines of `data`.

    A hole and the outer loop constrain each other: the supremum also runs
    over pairs on different polylines. Computed once per `data` (cached).
    Costs O(k m) with k vertices and m segments (see `lipschitz_constant`)
    in the worst case; blocks of segments whose value range and distance
    show they cannot raise the current value are skipped, and so are
    (vertex, segment) pairs whose end quotients bound them, so that in
    practice the cost is about k m / 16 block tests plus a few pairs.

    Returns
    -------
    float (scalar data) or (c,) float64

    Raises
    ------
    TrimLoopError
        (strict data) a vertex lies on another segment with a different value:
        L is infinite.
    """
    big_l = data.cache.get("lipschitz")
    if big_l is None:
        if len(data.length) > 4 * _BLOCK:
            bstart, bend, bc, br, bmax, bmin = _blocks(data, _BLOCK)
            big_l, bad = _lipschitz_kernel_pruned(data.points, data.values, data.a, data.d, data.length, data.g,
                                                  data.start, data.end, bc, br, bmax, bmin, bstart, bend)
        else:
            big_l, bad = _lipschitz_kernel(data.points, data.values, data.a, data.d, data.length, data.g,
                                           data.start, data.end)
        if data.strict and bad[0] >= 0:
            raise TrimLoopError(f"whitney: boundary vertex {bad[0]} lies on segment {bad[1]} with a different value "
                                f"(component {bad[2]}); the boundary data is not Lipschitz")
        data.cache["lipschitz"] = big_l
    return float(big_l[0]) if data.scalar else big_l.copy()


def _blocks(data: BoundaryData, block: int):
    """Blocks of `block` consecutive segments: bounding disc (centre, radius), max and min of eps."""
    key = ("blocks", block)
    out = data.cache.get(key)
    if out is None:
        m = len(data.length)
        bstart = np.arange(0, m, block, dtype=np.int64)
        bend = np.minimum(bstart + block, m).astype(np.int64)
        b_pt = data.a + data.d * data.length[:, None]
        e_b = data.e_a + data.g * data.length[:, None]
        lo = np.minimum.reduceat(np.minimum(data.a, b_pt), bstart, axis=0)
        hi = np.maximum.reduceat(np.maximum(data.a, b_pt), bstart, axis=0)
        centre = 0.5 * (lo + hi)
        owner = np.repeat(np.arange(len(bstart)), bend - bstart)
        r2 = np.maximum(((data.a - centre[owner]) ** 2).sum(axis=1), ((b_pt - centre[owner]) ** 2).sum(axis=1))
        radius = np.sqrt(np.maximum.reduceat(r2, bstart)) * (1.0 + 1e-12)
        bmax = np.maximum.reduceat(np.maximum(data.e_a, e_b), bstart, axis=0)
        bmin = np.minimum.reduceat(np.minimum(data.e_a, e_b), bstart, axis=0)
        out = (bstart, bend, np.ascontiguousarray(centre), radius, np.ascontiguousarray(bmax),
               np.ascontiguousarray(bmin))
        data.cache[key] = out
    return out


@njit(cache=True, nogil=True)
def _eval_block(px, py, a, d, length, e_a, g, tan, lc, cc, sgn, j0, j1, best):  # pragma: no cover - compiled
    """max over segments j0..j1-1 of sgn * (the segment's extremum); sgn=+1: sup of eq. (3), -1: inf of eq. (4)."""
    for j in range(j0, j1):
        dx, dy = px - a[j, 0], py - a[j, 1]
        ux, uy = d[j, 0], d[j, 1]
        x0 = dx * ux + dy * uy
        h = abs(dx * uy - dy * ux)
        # e_a + g x - sgn L sqrt(h^2 + (x - x0)^2) is concave (sgn=+1) / convex (-1) in x; its stationary
        # point x0 + sgn h (g/L) / sqrt(1 - (g/L)^2), clamped to [0, len], is the exact extremum
        x = x0 + sgn * h * tan[j, cc]
        if x < 0.0:
            x = 0.0
        elif x > length[j]:
            x = length[j]
        rx = x - x0
        v = sgn * (e_a[j, cc] + g[j, cc] * x) - lc * np.sqrt(h * h + rx * rx)
        if v > best:
            best = v
    return best


@njit(cache=True, nogil=True)
def _extension_kernel(q, a, d, length, e_a, g, tan, big_l, bc, br, bmax, bmin, bstart, bend,
                      lower, upper):  # pragma: no cover - compiled
    nb = bc.shape[0]
    c = big_l.shape[0]
    gap = np.empty(nb)
    warm = np.zeros((c, 2), dtype=np.int64)   # block holding the optimum for the previous query
    visits = 0
    for i in range(q.shape[0]):
        px, py = q[i, 0], q[i, 1]
        for b in range(nb):
            dx, dy = px - bc[b, 0], py - bc[b, 1]
            gp = np.sqrt(dx * dx + dy * dy) - br[b]
            gap[b] = gp if gp > 0.0 else 0.0
        for cc in range(c):
            lc = big_l[cc]
            for side in range(2):
                sgn = 1.0 if side == 0 else -1.0
                # neighbouring queries share their optimal block: evaluate it first for a tight start, then
                # every block whose bound (e_max - L gap, or -(e_min + L gap) for the infimum) beats the best
                wb = warm[cc, side]
                best = _eval_block(px, py, a, d, length, e_a, g, tan, lc, cc, sgn, bstart[wb], bend[wb], -np.inf)
                visits += 1
                for b in range(nb):
                    if b == wb:
                        continue
                    bound = bmax[b, cc] - lc * gap[b] if side == 0 else -(bmin[b, cc] + lc * gap[b])
                    if bound > best:
                        nbest = _eval_block(px, py, a, d, length, e_a, g, tan, lc, cc, sgn, bstart[b], bend[b],
                                            best)
                        visits += 1
                        if nbest > best:
                            best = nbest
                            warm[cc, side] = b
                if side == 0:
                    lower[i, cc] = best
                else:
                    upper[i, cc] = -best
    return visits


def _check_queries(queries) -> np.ndarray:
    qry = np.asarray(queries, dtype=np.float64)
    if qry.ndim == 1 and qry.shape[0] == 2:
        qry = qry[None, :]
    if qry.ndim != 2 or qry.shape[1] != 2:
        raise GeometryError(f"whitney: queries must have shape (q, 2); got {np.shape(queries)}")
    if not np.all(np.isfinite(qry)):
        i = int(np.argwhere(~np.isfinite(qry))[0, 0])
        raise GeometryError(f"whitney: query point {i} is not finite")
    return np.ascontiguousarray(qry)


def _lipschitz_to_use(data: BoundaryData, lipschitz, check: bool) -> np.ndarray:
    c = data.values.shape[1]
    if lipschitz is None:
        return np.atleast_1d(np.asarray(lipschitz_loops(data), dtype=np.float64))
    given = np.asarray(lipschitz, dtype=np.float64)
    if given.ndim == 0:
        given = np.full(c, float(given))
    if given.shape != (c,):
        raise GeometryError(f"whitney: lipschitz must be a number or have shape ({c},); got {np.shape(lipschitz)}")
    if not np.all(np.isfinite(given)) or np.any(given < 0):
        raise GeometryError(f"whitney: lipschitz must be finite and >= 0; got {lipschitz!r}")
    if not check:
        return given
    big_l = np.atleast_1d(np.asarray(lipschitz_loops(data), dtype=np.float64))
    short = given < big_l * (1.0 - _REL_SLACK)
    if np.any(short):
        comp = int(np.flatnonzero(short)[0])
        raise GeometryError(
            f"whitney: lipschitz={given[comp]!r} is below the Lipschitz constant {big_l[comp]!r} of the "
            f"boundary data (component {comp}); the extension would not interpolate the data")
    return np.maximum(given, big_l)


def whitney_average(data: BoundaryData, queries, *, lipschitz=None, check: bool = True,
                    block: int = _BLOCK) -> WhitneyAverage:
    """Exact lower, upper and average Whitney extensions (eqs. 3-5) of `data` at the queries, pruned.

    For a query p and a segment s with values in [e_min(s), e_max(s)],
    ``eps(q) - L |p - q| <= e_max(s) - L dist(p, s)`` for every q on s, so a
    block of `block` consecutive segments (bounded by a disc) whose bound does
    not beat the best value found so far cannot hold the supremum of eq. (3)
    and is skipped; likewise for the infimum of eq. (4). The block that held
    the optimum for the previous query is evaluated first. Only pairs that
    provably cannot attain the optimum are skipped: the result is the exact
    supremum (infimum) over every point of the polylines, the same as
    evaluating every (query, segment) pair in closed form (tested), at a
    fraction of the cost when there are many segments.

    Parameters
    ----------
    data : BoundaryData
        From `boundary_data`.
    queries : (n, 2) float64
    lipschitz : float or (c,) float64, optional
        L per component; default the exact L of the data (`lipschitz_loops`).
        A given L must not be below the exact one (checked unless `check` is
        False: then the caller guarantees it, e.g. a certified bound computed
        elsewhere, and the O(k m) computation of the exact L is skipped).
    check : bool
        Compare a given `lipschitz` with the exact L of the data.
    block : int
        Consecutive segments per pruning block.

    Returns
    -------
    WhitneyAverage

    Raises
    ------
    GeometryError
        Queries of the wrong shape or not finite; a `lipschitz` of the wrong
        shape, negative, or below the exact L of the data.

    Examples
    --------
    >>> import numpy as np
    >>> square = np.array([[0., 0.], [1., 0.], [1., 1.], [0., 1.]])
    >>> w = whitney_average(boundary_data([square], [[0., 1., 1., 0.]]), [[0.5, 0.5], [0.25, 0.0]])
    >>> w.average.round(12).tolist(), w.lipschitz
    ([0.5, 0.25], 1.0)
    """
    q = _check_queries(queries)
    big_l = _lipschitz_to_use(data, lipschitz, check)
    n, c = len(q), len(big_l)
    lower = np.full((n, c), -np.inf)
    upper = np.full((n, c), np.inf)
    visits = 0
    if n and len(data.length):
        with np.errstate(divide="ignore", invalid="ignore"):
            gamma = np.where(big_l > 0, data.g / np.where(big_l > 0, big_l, 1.0), 0.0)
        np.clip(gamma, -1.0, 1.0, out=gamma)
        # offset of the extremum from the foot of p, per unit of distance h: gamma / sqrt(1 - gamma^2)
        one_m = 1.0 - gamma * gamma
        with np.errstate(divide="ignore", invalid="ignore"):
            tan = np.where(one_m > 0, gamma / np.sqrt(np.where(one_m > 0, one_m, 1.0)), np.copysign(_BIG, gamma))
        tan = np.ascontiguousarray(np.clip(tan, -_BIG, _BIG))
        bstart, bend, bc, br, bmax, bmin = _blocks(data, max(1, int(block)))
        visits = _extension_kernel(q, data.a, data.d, data.length, data.e_a, data.g, tan, big_l, bc, br, bmax, bmin,
                                   bstart, bend, lower, upper)
    average = 0.5 * (lower + upper)
    mean_visits = visits / (2 * c * n) if n else 0.0
    if data.scalar:
        return WhitneyAverage(lower[:, 0], upper[:, 0], average[:, 0], float(big_l[0]), mean_visits)
    return WhitneyAverage(lower, upper, average, big_l, mean_visits)


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
        Accepted for compatibility (must be >= 1); the compiled kernel works
        pair by pair and needs no temporaries.

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
    cost is O(k^2), less where the end quotients of a (vertex, segment) pair
    show it cannot raise the current value (`lipschitz_loops`).

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
    _check_chunk(chunk_size)
    bnd, val, scalar = _check_boundary(boundary, values)
    data = boundary_data([bnd], [val[:, 0] if scalar else val], closed=bool(closed))
    return lipschitz_loops(data)


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
        Accepted for compatibility (must be >= 1); the compiled, pruned kernel
        (`whitney_average`) needs no temporaries.

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
    _check_chunk(chunk_size)
    bnd, val, scalar = _check_boundary(boundary, values)
    qry = _check_queries(queries)
    data = boundary_data([bnd], [val[:, 0] if scalar else val], closed=bool(closed))
    w = whitney_average(data, qry, lipschitz=lipschitz)
    return WhitneyExtension(w.lower, w.upper, w.average, w.lipschitz)
