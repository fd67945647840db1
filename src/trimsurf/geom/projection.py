"""Closest-point projection (point inversion) onto NURBS surfaces and curves, batched.

Seeding: the surface (curve) is sampled on a grid adapted to its knot spans and
degree, and each point starts from its nearest sample (``scipy.spatial.cKDTree``).
Then a batched, box-constrained Newton iteration minimises the squared distance
``D(u, v) = |S(u, v) - P|^2 / 2`` (The NURBS Book, Sec. 6.1, point inversion,
with the full Hessian including the ``(S - P).S_uu`` terms):

* the Hessian ``H = [[Su.Su + r.Suu, Su.Sv + r.Suv], [., Sv.Sv + r.Svv]]``
  (``r = S - P``), scaled by the speeds |Su|, |Sv| so nothing depends on how
  the parameters are scaled, is used when it is positive definite, else
  ``H - 2 lam_min I`` (its negative eigenvalue flipped, so the step follows the
  negative curvature downhill), and the Gauss-Newton matrix (first fundamental
  form) after a failed line search, so every step is a descent direction;
* the trial point is clamped to the parameter domain; if D increases the step
  is halved (backtracking);
* a parameter sitting on a domain edge with the gradient pointing outwards is
  fixed (active set) and the iteration continues along the edge;
* creases (interior knots of multiplicity >= degree, e.g. every knot of a
  degree-1 polyline) are treated like internal edges: a step stops at one, the
  point then crosses it with fresh one-sided derivatives, and a point that wants
  straight back is at a crease minimum;
* a point has converged when the tangential part of the residual is below
  ``tol_rel`` times the bounding-box diagonal of the control net in every
  free parameter direction: ``|r.Su| / |Su| <= tol`` and ``|r.Sv| / |Sv| <= tol``;
  then one last Newton step is applied without a new evaluation (the foot moved
  to first order, an error of order tol^2), which brings the parameters of
  well-conditioned points to rounding level.

Only the not-yet-converged points are evaluated at each step.

References
----------
L. Piegl, W. Tiller, *The NURBS Book*, 2nd ed., Springer 1997, Sec. 6.1
(point inversion and projection for curves and surfaces, eqs. 6.3-6.8).
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from ..errors import GeometryError
from ._nurbs_kernels import project_newton_kernel, surface_derivatives_kernel
from ._seed_kernels import memo_points_kernel, retry_seeds_kernel, seed_grid_kernel
from .nurbs import _homogeneous, curve_derivatives, read_only, surface_derivatives

__all__ = ["Projection", "CurveProjection", "project_to_surface", "project_to_curve"]

_MIN_SAMPLES = 16      # seed samples per direction at least (single-span Bézier patches of low degree)
_MAX_HALVINGS = 12     # backtracking steps before a point falls back to Gauss-Newton
_OBJ_SLACK = 8 * np.finfo(np.float64).eps  # relative rounding allowance when comparing squared distances
_FLOOR = 1e-9          # smallest curvature of the Newton model, relative to |Su|^2 (|Sv|^2, |C'|^2)
_N_CANDIDATES = 8      # nearest seeds examined for a second start in another basin
_DEGENERATE = 1e-12    # a grid line of the seeds shorter than this x diagonal is a collapsed (pole) edge
_SMOOTH_RAD = 1e-8     # a crease whose two sides meet at a smaller angle is smooth (no restart across it)
_COMPILED_RETRY = True  # `_retry_seeds` of surfaces in `_seed_kernels.retry_seeds_kernel` (False: the numpy expressions)
_NOISE = 1e-3          # a trial point may lie farther by this fraction of tol (rounding in S - P hides smaller changes)


class Projection(NamedTuple):
    """Result of `project_to_surface`.

    Attributes
    ----------
    uv : (n, 2) float64
        Parameters of the closest point found, inside the domain.
    foot : (n, 3) float64
        S(uv).
    distance : (n,) float64
        |P - S(uv)|.
    converged : (n,) bool
        The iteration met the tolerance (stationary in the free directions).
    on_boundary : (n,) bool
        The unconstrained minimiser lies outside the domain: the foot is on a
        domain edge and the distance keeps decreasing outwards.
    iterations : int
        Newton iterations run (for the slowest point).
    """

    uv: np.ndarray
    foot: np.ndarray
    distance: np.ndarray
    converged: np.ndarray
    on_boundary: np.ndarray
    iterations: int


class CurveProjection(NamedTuple):
    """Result of `project_to_curve` (fields as in `Projection`, with t (n,) for uv)."""

    t: np.ndarray
    foot: np.ndarray
    distance: np.ndarray
    converged: np.ndarray
    on_boundary: np.ndarray
    iterations: int


# --------------------------------------------------------------------------- validation

def _knot_vector(knots, degree: int, n_ctrl: int, name: str) -> np.ndarray:
    kn = np.asarray(knots, dtype=np.float64)
    if kn.ndim != 1 or kn.shape[0] != n_ctrl + degree + 1:
        raise GeometryError(f"{name}: need {n_ctrl + degree + 1} knots for {n_ctrl} control points of degree "
                            f"{degree}; got shape {kn.shape}")
    if not np.all(np.isfinite(kn)) or np.any(np.diff(kn) < 0):
        raise GeometryError(f"{name}: knots must be finite and non-decreasing")
    if not kn[degree] < kn[-degree - 1]:
        raise GeometryError(f"{name}: empty parameter domain [{kn[degree]}, {kn[-degree - 1]}]")
    return kn


def _degree(degree, name: str) -> int:
    if isinstance(degree, bool) or int(degree) != degree or int(degree) < 1:
        raise GeometryError(f"{name}: degree must be an integer >= 1; got {degree!r}")
    return int(degree)


def _weights(weights, shape: tuple[int, ...], name: str) -> np.ndarray | None:
    if weights is None:
        return None
    w = np.asarray(weights, dtype=np.float64)
    if w.shape != shape:
        raise GeometryError(f"{name}: weights must have shape {shape}; got {w.shape}")
    if not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise GeometryError(f"{name}: weights must be positive and finite")
    return None if np.all(w == 1.0) else w


def _points(points, dim: int, name: str) -> np.ndarray:
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim == 1 and pts.shape[0] == dim:
        pts = pts[None, :]
    if pts.ndim != 2 or pts.shape[1] != dim:
        raise GeometryError(f"{name}: points must have shape (n, {dim}); got {np.shape(points)}")
    if not np.all(np.isfinite(pts)):
        i = int(np.argwhere(~np.isfinite(pts))[0, 0])
        raise GeometryError(f"{name}: point {i} is not finite")
    return pts


def _options(tol_rel, max_iter, name: str) -> tuple[float, int]:
    tol_rel = float(tol_rel)
    if not (np.isfinite(tol_rel) and tol_rel > 0):
        raise GeometryError(f"{name}: tol_rel must be a positive number; got {tol_rel!r}")
    if int(max_iter) != max_iter or int(max_iter) < 1:
        raise GeometryError(f"{name}: max_iter must be a positive integer; got {max_iter!r}")
    return tol_rel, int(max_iter)


def _start(start, n: int, d: int, lo: np.ndarray, hi: np.ndarray, name: str, arg: str) -> np.ndarray | None:
    """Warm-start parameters as (n, d) float64 clamped to the domain, or None."""
    if start is None:
        return None
    x = np.asarray(start, dtype=np.float64)
    if d == 1 and x.ndim == 1:
        x = x[:, None]
    if x.shape != (n, d):
        want = f"({n},)" if d == 1 else f"({n}, {d})"
        raise GeometryError(f"{name}: {arg} must have shape {want}, one start per point; got {np.shape(start)}")
    if not np.all(np.isfinite(x)):
        i = int(np.argwhere(~np.isfinite(x))[0, 0])
        raise GeometryError(f"{name}: {arg} of point {i} is not finite")
    return np.clip(x, lo, hi)


def _diagonal(control_points: np.ndarray) -> float:
    pts = control_points.reshape(-1, control_points.shape[-1])
    diag = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))
    return diag if diag > 0 else 1.0


# --------------------------------------------------------------------------- seeding

def _samples_1d(knots: np.ndarray, degree: int, per_span: int | None) -> np.ndarray:
    """Parameters spread over the domain: ``per_span`` samples in each non-empty knot span."""
    lo, hi = knots[degree], knots[-degree - 1]
    brk = np.unique(knots[(knots >= lo) & (knots <= hi)])
    n_spans = brk.shape[0] - 1
    if per_span is None:
        per_span = max(degree + 1, -(-_MIN_SAMPLES // n_spans))
    frac = np.arange(per_span) / per_span
    t = (brk[:-1, None] + frac[None, :] * np.diff(brk)[:, None]).ravel()
    return np.append(t, hi)


def _seed_values(seed_grid, knots_list, degrees, name: str) -> list[np.ndarray]:
    if seed_grid is None or isinstance(seed_grid, (int, np.integer, float, np.floating)):
        per_span = None
        if seed_grid is not None:
            if isinstance(seed_grid, bool) or int(seed_grid) != seed_grid or int(seed_grid) < 1:
                raise GeometryError(f"{name}: seed_grid as a number must be a positive integer (samples per "
                                    f"knot span); got {seed_grid!r}")
            per_span = int(seed_grid)
        return [_samples_1d(k, p, per_span) for k, p in zip(knots_list, degrees)]
    if not isinstance(seed_grid, (tuple, list)) or len(seed_grid) != len(knots_list):
        raise GeometryError(f"{name}: seed_grid must be an int or {len(knots_list)} arrays of parameters")
    out = []
    for vals, k, p in zip(seed_grid, knots_list, degrees):
        arr = np.asarray(vals, dtype=np.float64).ravel()
        if arr.size == 0 or not np.all(np.isfinite(arr)):
            raise GeometryError(f"{name}: seed_grid parameter arrays must be non-empty and finite")
        out.append(np.unique(np.clip(arr, k[p], k[-p - 1])))
    return out


class _Seeds(NamedTuple):
    """Samples of the surface (curve) on a parameter grid, with what the retry test needs."""

    axes: list              # 1-D sample parameters per direction
    params: np.ndarray      # (ns, d) sample parameters, C order over the grid
    ders: tuple | None      # derivative arrays at the samples (point first); None: points only (`_seed_state`)
    radius: np.ndarray      # (ns,) largest distance from a sample to its grid neighbours
    tree: cKDTree


def _seed_state(seeds: _Seeds, idx: np.ndarray) -> tuple | None:
    """The derivative arrays (point first) at the seed samples `idx`, as a Newton start state; None for
    seeds built from their points alone (`_build_seeds` with ``points``): the Newton run then evaluates
    its start itself (`project_newton_kernel` with ``eval_start``: the same `_eval_d2` at the same
    parameters, so the same state bit for bit)."""
    if seeds.ders is None:
        return None
    return tuple(d[idx] for d in seeds.ders)


def _build_seeds(axes: list, evaluate, diag: float, *, check_poles: bool = True, points=None) -> _Seeds:
    """The seed samples on the grid `axes`. ``evaluate(params)`` gives the derivative arrays (point
    first); with ``points``, ``points(params)`` the same points as ``evaluate(params)[0]`` bit for bit, only
    the points are computed (no derivatives: ``ders`` is None, and each Newton run from a seed evaluates
    its start, `_seed_state`)."""
    shape = tuple(a.shape[0] for a in axes)
    params = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(axes))
    if points is None:
        ders = evaluate(params)
        xyz = ders[0]
    else:
        ders = None
        xyz = points(params)
    pts = xyz.reshape(*shape, -1)
    if len(axes) == 2 and pts.shape[2] == 3:
        # the neighbour radii and the boundary lines' spread in one compiled pass (the same numbers as the
        # numpy expressions below)
        radius = np.empty(shape)
        spread = np.empty(4)
        seed_grid_kernel(np.ascontiguousarray(pts, dtype=np.float64), radius, spread)
    else:
        radius, spread = None, None
    if len(axes) == 2 and check_poles:
        # a degenerate domain edge (a pole: one point for every v) gives identical seeds that carry no
        # direction; sample such a grid line a quarter spacing inside instead
        moved = False
        for axis in (0, 1):
            ax = axes[axis]
            if ax.shape[0] < 2:
                continue
            for e, (end, inner) in enumerate(((0, 1), (-1, -2))):
                width = spread[2 * axis + e] if spread is not None else np.ptp(np.take(pts, end, axis=axis),
                                                                                axis=0).max()
                if width <= _DEGENERATE * diag:
                    ax = ax.copy()
                    ax[end] = ax[end] + 0.25 * (ax[inner] - ax[end])
                    moved = True
            axes[axis] = ax
        if moved:
            return _build_seeds(axes, evaluate, diag, check_poles=False, points=points)
    if radius is None:
        radius = np.zeros(shape)
        pad = np.pad(pts, [(1, 1)] * len(axes) + [(0, 0)], mode="edge")
        for off in np.ndindex(*([3] * len(axes))):
            window = pad[tuple(slice(o, o + n) for o, n in zip(off, shape))]
            np.maximum(radius, np.linalg.norm(window - pts, axis=-1), out=radius)
    return _Seeds(axes, params, ders, radius.ravel(), cKDTree(pts.reshape(len(params), -1)))


def _retry_seeds(seeds: _Seeds, nearest: np.ndarray, seed_dist: np.ndarray, foot_params: np.ndarray,
                 distance: np.ndarray, tol: float,
                 used: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Points whose closest point may lie in another basin, and the seed to restart each from.

    Any surface point near a sample s lies within ``radius[s]`` of it, so a sample
    with ``|P - s| - radius[s] < distance - tol`` may have a point closer by more than
    the tolerance nearby. Samples within two grid cells of the foot found belong to
    the basin already searched (across a kinked crease that far side is searched by
    `_crease_starts`; across a smooth one the basin goes on); so does the sample
    ``used[i]`` the point already started from (-1: none).
    """
    if len(seeds.axes) == 2 and _COMPILED_RETRY:
        points = np.empty(nearest.shape[0], dtype=np.int64)
        seed = np.empty(nearest.shape[0], dtype=np.int64)
        has_used = used is not None
        count = retry_seeds_kernel(seeds.axes[0], seeds.axes[1], seeds.radius, nearest, seed_dist, foot_params,
                                   distance, float(tol), used if has_used else points, has_used, points, seed)
        return points[:count], seed[:count]
    shape = tuple(a.shape[0] for a in seeds.axes)
    far = np.zeros(nearest.shape, dtype=bool)
    grid_index = np.unravel_index(nearest, shape)
    for axis, (vals, gi) in enumerate(zip(seeds.axes, grid_index)):
        cell = np.clip(np.searchsorted(vals, foot_params[:, axis], side="right") - 1, 0, vals.shape[0] - 1)
        far |= (gi < cell[:, None] - 2) | (gi > cell[:, None] + 3)
    if used is not None:
        far &= nearest != used[:, None]
    cand = far & (seed_dist - seeds.radius[nearest] < (distance - tol)[:, None])
    points = np.flatnonzero(cand.any(axis=1))
    first = np.argmax(cand[points], axis=1)
    return points, nearest[points, first]


def _crease_starts(axes: list, foot_params: np.ndarray, distance: np.ndarray, tol: float, breaks: list) -> list:
    """Restarts on the far side of the creases next to each foot, as (rows, x0, barrier) batches.

    A crease (knot of multiplicity >= degree) bounds a box on which the distance is
    smooth. Newton explores one side of a crease near its foot, and the far side's
    seed samples (those on the crease line itself belong to the box above it) may
    have led there, so the far side within two grid cells of the foot is never
    searched: a point on a concave crease can end at a local minimum just across it.
    Every point farther than ``tol`` from the surface whose foot lies within two
    grid cells of a crease restarts in each neighbouring box across it (across a
    u and a v crease at once too: the diagonal box at a crease corner), at the
    foot's parameters moved onto the crease's far side and barred from stepping
    straight back (``barrier`` for `_newton`); it ends at a minimum in that box
    or on its crease lines.
    """
    n, d = foot_params.shape
    off = distance > tol
    moves = []  # per axis: [(mask, value, crease, upwards)] for the creases below and above the foot
    for axis in range(d):
        brk, vals = breaks[axis], axes[axis]
        if brk.shape[0] <= 2:
            moves.append([])
            continue
        _, _, idx = _boxes(brk, foot_params[:, axis])
        pos = np.searchsorted(vals, foot_params[:, axis])
        options = []
        for upwards in (False, True):
            c = brk[idx + 1] if upwards else brk[idx]
            interior = (idx + 1 < brk.shape[0] - 1) if upwards else (idx > 0)
            near = off & interior & (np.abs(pos - np.searchsorted(vals, c)) <= 2)
            options.append((near, c if upwards else np.nextafter(c, -np.inf), c, upwards))
        moves.append(options)
    out = []
    for combo in itertools.product(*[[None] + m for m in moves]):
        if all(m is None for m in combo):
            continue
        mask = np.logical_and.reduce([m[0] for m in combo if m is not None])
        rows = np.flatnonzero(mask)
        if not rows.size:
            continue
        x0 = foot_params[rows].copy()
        crease = np.full((rows.size, d), np.nan)
        up = np.zeros((rows.size, d), dtype=bool)
        for axis, m in enumerate(combo):
            if m is not None:
                x0[:, axis] = m[1][rows]
                crease[:, axis] = m[2][rows]
                up[:, axis] = m[3]
        out.append((rows, x0, (crease, up)))
    return out


def _cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross(a, b)`` of (n, 3) rows: the same operations (a1 b2 - a2 b1, ...) without its axis handling."""
    out = np.empty(a.shape)
    np.subtract(a[:, 1] * b[:, 2], a[:, 2] * b[:, 1], out=out[:, 0])
    np.subtract(a[:, 2] * b[:, 0], a[:, 0] * b[:, 2], out=out[:, 1])
    np.subtract(a[:, 0] * b[:, 1], a[:, 1] * b[:, 0], out=out[:, 2])
    return out


def _kink_rad(d1_far: np.ndarray, d1_near: np.ndarray) -> np.ndarray:
    """Angle (rad) between the tangents (curves) or normals (surfaces) from first derivatives (m, d, k)
    on the two sides of a crease; NaN where one is degenerate."""
    if d1_far.shape[1] == 1:
        a, b = d1_far[:, 0], d1_near[:, 0]
    else:
        a, b = _cross3(d1_far[:, 0], d1_far[:, 1]), _cross3(d1_near[:, 0], d1_near[:, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        a = a / np.linalg.norm(a, axis=1, keepdims=True)
        b = b / np.linalg.norm(b, axis=1, keepdims=True)
        return 2.0 * np.arctan2(np.linalg.norm(a - b, axis=1), np.linalg.norm(a + b, axis=1))


def _merge(result, sub, idx: np.ndarray, *, replace: bool = False):
    """`result` with the rows `idx` replaced by `sub` where `sub` is closer (everywhere if `replace`)."""
    better = np.ones(idx.shape[0], dtype=bool) if replace else sub.distance < result.distance[idx]
    rows = idx[better]
    fields = []
    for name in result._fields:
        value = getattr(result, name)
        if name == "iterations":
            fields.append(max(value, sub.iterations))
            continue
        value = value.copy()
        value[rows] = getattr(sub, name)[better]
        fields.append(value)
    return type(result)(*fields)


def _workers(n_queries: int) -> int:
    """Threads for a k-d tree query: starting them costs more than a small batch's search."""
    return -1 if n_queries >= 20_000 else 1


def _nearest_seeds(tree: cKDTree, pts: np.ndarray, k: int):
    """Nearest seed (distance, index) of every point, and (k > 1) its k nearest (distances, indices).

    The k nearest are asked once; their first column is the nearest seed wherever it is unique. A point
    with an exact tie (e.g. at the coincident seeds of a closed surface's seam) asks ``k=1`` again, so
    the nearest seed is the k = 1 query's, tie-breaking included.
    """
    if k == 1:
        seed_dist, first = tree.query(pts, k=1, workers=_workers(len(pts)))
        return seed_dist, first, None, None
    sd_all, near_all = tree.query(pts, k=k, workers=_workers(len(pts)))
    seed_dist, first = sd_all[:, 0].copy(), near_all[:, 0].copy()
    tie = np.flatnonzero(sd_all[:, 1] == sd_all[:, 0])
    if tie.size:
        seed_dist[tie], first[tie] = tree.query(pts[tie], k=1)
    return seed_dist, first, sd_all, near_all


def _take(raw: _Raw, rows: np.ndarray) -> _Raw:
    """The rows `rows` of a `_Raw`."""
    return _Raw(raw.params[rows], raw.foot[rows], raw.distance[rows], raw.converged[rows], raw.on_boundary[rows],
                raw.iterations)


#: `skip_below`: a warm-started run that converged at most this fraction of the point's threshold away
#: (less ``_SETTLED_SLACK`` x tol) is final for the caller; the rest of the search could only bring it closer
_SETTLED_FRACTION = 0.9
_SETTLED_SLACK = 100.0


def _solve(pts, seeds: _Seeds, evaluate, newton, retry: bool, tol: float, breaks: list, start=None,
           first_derivatives=None, skip_below=None, first_run=None):
    """Newton from `start` (warm) or the nearest seed, then (if `retry`) restarts that may do better.

    A warm start that does not converge, or ends farther from P than the nearest seed
    sample (a run from that sample could not), is redone from the nearest seed. With
    `retry`, points farther than ``tol`` from the surface restart across the creases
    next to their foot (`_crease_starts`) and once from a far seed sample that may
    hold a closer point (`_retry_seeds`); the closer result is kept. ``newton(p, x0, state, barrier)``
    starts from ``state`` = (S, D1, D2) at x0, or with None evaluates them at x0 itself.
    `first_derivatives` (optional):
    D1 alone at parameters, the same numbers as ``evaluate(x)[1]``, for the kink test of the creases.

    `skip_below` (n,) with `start`: a point whose warm-started run converged at distance
    ``d <= 0.9 skip_below - 100 tol`` keeps that run's result and is not searched further. What follows
    could only change it to a closer result (a redo replaces it only when a seed is closer than d, and
    its run from there ends within the Newton iteration's allowance, at most ~10 tol, of that seed's
    distance; the restarts keep only closer results), so for such a point the full search's distance
    lies in [0, d + 10 tol]: a caller that only asks whether the distance reaches `skip_below` gets the
    same answer. `first_run`: the warm-started run of `pts` from `start`, already computed.
    """
    if start is not None and skip_below is not None:
        result = newton(pts, start, None)
        settled = result.converged & (result.distance <= _SETTLED_FRACTION * skip_below - _SETTLED_SLACK * tol)
        rest = np.flatnonzero(~settled)
        if rest.size:
            sub = _solve(pts[rest], seeds, evaluate, newton, retry, tol, breaks, start[rest], first_derivatives,
                         first_run=_take(result, rest))
            result = _merge(result, sub, rest, replace=True)
        return result
    k = min(_N_CANDIDATES, seeds.params.shape[0]) if retry else 1
    seed_dist, first, sd_all, near_all = _nearest_seeds(seeds.tree, pts, k)
    used = first.copy()
    if start is None:
        result = newton(pts, seeds.params[first], _seed_state(seeds, first))
    else:
        result = newton(pts, start, None) if first_run is None else first_run
        redo = np.flatnonzero(~result.converged | (result.distance > seed_dist))
        used[:] = -1
        if redo.size:
            f = first[redo]
            sub = newton(pts[redo], seeds.params[f], _seed_state(seeds, f))
            result = _merge(result, sub, redo, replace=True)
            used[redo] = f
    if not retry:
        return result
    d1 = first_derivatives if first_derivatives is not None else (lambda x: evaluate(x)[1])
    for rows, x0, barrier in _crease_starts(seeds.axes, result.params, result.distance, tol, breaks):
        # a crease with matching tangents (normals) on both sides (e.g. the double knots of a rational
        # circle) is no kink: Newton crosses it like any other point, nothing to restart there
        here = np.where(np.isnan(barrier[0]), x0, np.where(barrier[1], np.nextafter(barrier[0], -np.inf),
                                                               barrier[0]))
        kink = _kink_rad(d1(x0), d1(here)) > _SMOOTH_RAD
        if not kink.any():
            continue
        rows, x0, barrier = rows[kink], x0[kink], (barrier[0][kink], barrier[1][kink])
        sub = newton(pts[rows], x0, None, barrier)
        result = _merge(result, sub, rows)
    ask = np.flatnonzero(result.distance > tol)  # within tol of the surface nothing closer by tol exists
    if k == 1 or not ask.size:
        return result
    sd, near = sd_all[ask], near_all[ask]
    idx, s = _retry_seeds(seeds, near, sd, result.params[ask], result.distance[ask], tol, used[ask])
    if idx.size:
        sub = newton(pts[ask[idx]], seeds.params[s], _seed_state(seeds, s))
        result = _merge(result, sub, ask[idx])
    return result


# --------------------------------------------------------------------------- Newton iteration

class _Raw(NamedTuple):
    params: np.ndarray       # (n, d)
    foot: np.ndarray         # (n, k)
    distance: np.ndarray     # (n,)
    converged: np.ndarray    # (n,) bool
    on_boundary: np.ndarray  # (n,) bool
    iterations: int


def _accept_limit(obj: np.ndarray, tol: float) -> np.ndarray:
    """Largest squared distance a trial point may have: |r|^2 plus what rounding in S - P can hide.

    Near a foot at distance d the decrease a Newton step achieves (~ residual^2) drowns in the
    rounding of |S - P|^2 (~ d * eps * |S|); a growth of the distance by ``_NOISE * tol`` is
    accepted so the iteration can finish.
    """
    noise = _NOISE * tol
    return obj * (1.0 + _OBJ_SLACK) + 2.0 * np.sqrt(obj) * noise + noise * noise


def _breakpoints(knots: np.ndarray, degree: int) -> np.ndarray:
    """Domain ends and the interior knots where the curve may have a crease (multiplicity >= degree)."""
    lo, hi = knots[degree], knots[-degree - 1]
    vals, counts = np.unique(knots[(knots > lo) & (knots < hi)], return_counts=True)
    return np.r_[lo, vals[counts >= degree], hi]


def _boxes(breaks: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For parameters x: the crease-free interval holding x, as [lower, upper] with upper one ulp
    below the next interior breakpoint (so that evaluation there uses the span below it)."""
    idx = np.clip(np.searchsorted(breaks, x, side="right") - 1, 0, breaks.shape[0] - 2)
    upper = breaks[idx + 1]
    inner = idx + 1 < breaks.shape[0] - 1
    return breaks[idx], np.where(inner, np.nextafter(upper, -np.inf), upper), idx


def _step_matrix(H, E, g, fixed, use):
    """Newton step for the distance in the free parameters, (m, d) from H, E (m, d, d), g (m, d).

    The system is scaled by the speeds |S_i| (Jacobi), so the tests and the regularisation do not
    depend on how each parameter is scaled (near-degenerate edges have |Sv| << |Su|). Where the
    scaled Hessian is not positive definite (near a saddle or a focal point of the distance) it is
    shifted by twice its smallest eigenvalue, which flips the sign of that eigenvalue (saddle-free
    Newton), so the step follows the negative curvature downhill; after a failed line search
    (``use`` False) the Gauss-Newton matrix E is used. Returns the step and whether it is a plain
    Newton step (no shift, no Gauss-Newton).
    """
    m, d = g.shape
    diag = np.einsum("mii->mi", E)
    tiny = 1e-30 * diag.sum(axis=1, keepdims=True) + np.finfo(np.float64).tiny
    sc = np.sqrt(np.maximum(diag, tiny))
    M = np.where(use[:, None, None], H, E) / (sc[:, :, None] * sc[:, None, :])
    gs = np.where(fixed, 0.0, g / sc)
    eye = np.eye(d, dtype=bool)
    # fixed parameters: identity rows and columns, zero gradient -> zero step
    M = np.where(fixed[:, :, None] | fixed[:, None, :], eye.astype(np.float64), M)
    if d == 1:
        lam = M[:, 0, 0]
    else:
        a, b, c = M[:, 0, 0], M[:, 0, 1], M[:, 1, 1]
        lam = 0.5 * (a + c) - np.sqrt(0.25 * (a - c) ** 2 + b * b)
    shift = np.where(lam < _FLOOR, np.maximum(-2.0 * lam, _FLOOR), 0.0)
    M = M + shift[:, None, None] * eye
    if d == 1:
        step = -gs / M[:, :, 0]
    else:
        a, b, c = M[:, 0, 0], M[:, 0, 1], M[:, 1, 1]
        det = a * c - b * b
        step = np.stack([(-c * gs[:, 0] + b * gs[:, 1]) / det, (b * gs[:, 0] - a * gs[:, 1]) / det], axis=1)
    return step / sc, use & (shift == 0)


def _gram(D1: np.ndarray) -> np.ndarray:
    """E[m, i, j] = D1[m, i] . D1[m, j] (pairwise dot products are much faster than one einsum)."""
    m, d, _ = D1.shape
    E = np.empty((m, d, d))
    for i in range(d):
        for j in range(i, d):
            E[:, i, j] = E[:, j, i] = np.einsum("mk,mk->m", D1[:, i], D1[:, j])
    return E


def _newton(pts, x, state, evaluate, lo, hi, breaks, tol, max_iter, barrier=None) -> _Raw:
    """Batched, box-constrained Newton minimisation of |S(x) - P|^2 over d = 1 or 2 parameters.

    ``state`` = (S (m, k), D1 (m, d, k), D2 (m, d, d, k)) at ``x`` (m, d). Creases (knots of
    multiplicity >= degree) split the domain into boxes: a step never crosses one; a point at a box
    end that wants to go on moves one ulp across the crease (fresh one-sided derivatives), and a
    point that, without having moved since, wants to go back across the crease it just crossed is at
    a crease minimum in that parameter (fixed, like a domain edge, but not reported on_boundary).
    ``barrier`` = (crease (n, d), upwards (n, d) bool), NaN for none: start as if each point had
    just crossed that crease in that direction (a restart on the far side of a crease).
    """
    n, d = x.shape
    foot = np.empty((n, pts.shape[1]))
    conv = np.zeros(n, dtype=bool)
    onb = np.zeros(n, dtype=bool)
    gn = np.zeros(n, dtype=bool)              # force a Gauss-Newton step (after a failed line search)
    crossed = np.full((n, d), np.nan)          # crease value last crossed, per parameter
    crossed_up = np.zeros((n, d), dtype=bool)  # ... and whether upwards
    crossed_x = np.full((n, d), np.nan)        # parameters right after that crossing
    if barrier is not None:
        crossed, crossed_up = barrier[0].copy(), barrier[1].copy()
        crossed_x = np.where(np.isnan(crossed).all(axis=1)[:, None], np.nan, x)
    act = np.arange(n)
    S, D1, D2 = state
    it = 0
    while act.size and it < max_iter:
        it += 1
        P, xa = pts[act], x[act]
        r = S - P
        g = np.einsum("mdk,mk->md", D1, r)
        E = _gram(D1)
        speed = np.sqrt(np.einsum("mii->mi", E))
        with np.errstate(divide="ignore", invalid="ignore"):
            ok = np.where(speed > 0, np.abs(g) / speed, 0.0) <= tol
        box_lo, box_hi, bidx = zip(*(_boxes(breaks[i], xa[:, i]) for i in range(d)))
        box_lo, box_hi, bidx = np.stack(box_lo, 1), np.stack(box_hi, 1), np.stack(bidx, 1)
        down = (xa <= box_lo) & (g > 0) & ~ok      # wants to leave its box downwards
        up = (xa >= box_hi) & (g < 0) & ~ok        # ... upwards
        edge = (down & (box_lo <= lo)) | (up & (box_hi >= hi))
        brk_up = np.stack([breaks[i][bidx[:, i] + 1] for i in range(d)], axis=1)
        # a crease minimum: wants back across the crease it crossed, and has not moved since (the
        # other parameter may have changed what the far side wants)
        still = np.all(xa == crossed_x[act], axis=1)[:, None]
        crease = still & ((down & ~edge & crossed_up[act] & (crossed[act] == box_lo))
                          | (up & ~edge & ~crossed_up[act] & (crossed[act] == brk_up)))
        cross = (down | up) & ~edge & ~crease
        if np.any(cross):
            rows = np.flatnonzero(cross.any(axis=1))
            cr = cross[rows]
            nx = xa[rows].copy()
            going_up = up[rows] & cr
            nx = np.where(cr & ~going_up, np.nextafter(box_lo[rows], -np.inf), nx)
            nx = np.where(going_up, brk_up[rows], nx)
            ia = act[rows]
            crossed[ia] = np.where(cr, np.where(going_up, brk_up[rows], box_lo[rows]), crossed[ia])
            crossed_up[ia] = np.where(cr, going_up, crossed_up[ia])
            x[ia] = nx
            crossed_x[ia] = nx
            gn[ia] = False
            sub = evaluate(nx)
            S, D1, D2 = (arr.copy() for arr in (S, D1, D2))
            for arr, val in zip((S, D1, D2), sub):
                arr[rows] = val
            continue  # re-test the moved points with their one-sided derivatives
        fixed = edge | crease
        done = np.all(fixed | ok, axis=1)
        H = E + np.einsum("mijk,mk->mij", D2, r)
        use = ~gn[act]
        step, plain = _step_matrix(H, E, g, fixed, use)
        if np.any(done):
            # polish: within tol the iteration is quadratic, so one more Newton step (no evaluation;
            # the foot follows to first order) takes the parameters to rounding level
            pol = np.flatnonzero(done & plain)
            new_x = np.clip(xa[pol] + step[pol], box_lo[pol], box_hi[pol])
            move = np.einsum("md,mdk->mk", new_x - xa[pol], D1[pol])
            small = np.linalg.norm(move, axis=1) <= 10.0 * tol
            idx = act[done]
            foot[idx] = S[done]
            x[act[pol[small]]] = new_x[small]
            foot[act[pol[small]]] = S[pol[small]] + move[small]
            conv[idx] = True
            onb[idx] = edge[done].any(axis=1)
            keep = ~done
            act, P, xa, r, step = act[keep], P[keep], xa[keep], r[keep], step[keep]
            box_lo, box_hi = box_lo[keep], box_hi[keep]
            S, D1, D2 = S[keep], D1[keep], D2[keep]
            if not act.size:
                break
        obj = np.einsum("mk,mk->m", r, r)
        limit = _accept_limit(obj, tol)
        # backtracking line search on D, evaluating 2nd derivatives at each trial point
        trial = np.clip(xa + step, box_lo, box_hi)
        new = evaluate(trial)
        rn = new[0] - P
        bad = np.einsum("mk,mk->m", rn, rn) > limit
        halvings = 0
        while np.any(bad) and halvings < _MAX_HALVINGS:
            halvings += 1
            bi = np.flatnonzero(bad)
            step[bi] *= 0.5
            tx = np.clip(xa[bi] + step[bi], box_lo[bi], box_hi[bi])
            sub = evaluate(tx)
            trial[bi] = tx
            for arr, val in zip(new, sub):
                arr[bi] = val
            rs = sub[0] - P[bi]
            bad[bi] = np.einsum("mk,mk->m", rs, rs) > limit[bi]
        # points whose step failed keep their state and retry with Gauss-Newton; give up if that failed too
        stuck = bad & gn[act]
        gn[act] = bad
        acc = ~bad
        x[act[acc]] = trial[acc]
        S, D1, D2 = (np.where(acc.reshape((-1,) + (1,) * (old.ndim - 1)), nw, old)
                     for nw, old in zip(new, (S, D1, D2)))
        if np.any(stuck):
            foot[act[stuck]] = S[stuck]
            keep = ~stuck
            act, S, D1, D2 = act[keep], S[keep], D1[keep], D2[keep]
    if act.size:  # max_iter reached
        foot[act] = S
    distance = np.linalg.norm(pts - foot, axis=1)
    return _Raw(x, foot, distance, conv, onb, it)


def _newton_compiled(pts, x, state, surf, lo, hi, breaks, tol, max_iter, barrier=None) -> _Raw:
    """`_newton` for a surface (d = 2) in the compiled kernel `project_newton_kernel`, point by point.

    ``surf`` = (degree_u, degree_v, knots_u, knots_v, homogeneous control points, rational).
    """
    pu, pv, ku, kv, pw, rational = surf
    n = x.shape[0]
    foot = np.empty((n, 3))
    conv = np.zeros(n, dtype=bool)
    onb = np.zeros(n, dtype=bool)
    if barrier is None:
        crossed, crossed_up = np.full((n, 2), np.nan), np.zeros((n, 2), dtype=bool)
    else:
        crossed, crossed_up = np.ascontiguousarray(barrier[0], dtype=np.float64), np.ascontiguousarray(barrier[1])
    if state is None:  # the kernel evaluates the start itself
        S, D1, D2 = np.empty((0, 3)), np.empty((0, 2, 3)), np.empty((0, 2, 2, 3))
    else:
        S, D1, D2 = (np.ascontiguousarray(a, dtype=np.float64) for a in state)
    x = np.ascontiguousarray(x, dtype=np.float64)
    it = project_newton_kernel(int(pu), int(pv), read_only(ku), read_only(kv), pw, bool(rational),
                               np.ascontiguousarray(pts, dtype=np.float64), x, S, D1, D2,
                               np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64),
                               read_only(breaks[0]), read_only(breaks[1]), float(tol), int(max_iter),
                               crossed, crossed_up, barrier is not None, _FLOOR, _MAX_HALVINGS, _OBJ_SLACK,
                               _NOISE * tol, foot, conv, onb, state is None)
    distance = np.linalg.norm(pts - foot, axis=1)
    return _Raw(x, foot, distance, conv, onb, int(it))


# --------------------------------------------------------------------------- surfaces

def _surface_eval(args, uv: np.ndarray):
    skl = surface_derivatives(*args, uv, n_derivs=2)
    d1 = np.stack([skl[1, 0], skl[0, 1]], axis=1)
    d2 = np.stack([np.stack([skl[2, 0], skl[1, 1]], axis=1), np.stack([skl[1, 1], skl[0, 2]], axis=1)], axis=1)
    return skl[0, 0], d1, d2


def _surface_eval_compiled(surf, uv: np.ndarray):
    """`_surface_eval` (the same numbers, 2-2.5x faster) in `project_newton_kernel` without iterating
    (``max_iter = -1``: its `_eval_d2` at x, clamped to the domain), so no kernel of its own is compiled.
    ``surf`` as for `_newton_compiled`."""
    uv = np.array(uv, dtype=np.float64).reshape(-1, 2)
    n = len(uv)
    S, D1, D2, foot = np.empty((n, 3)), np.empty((n, 2, 3)), np.empty((n, 2, 2, 3)), np.empty((n, 3))
    z = np.zeros(2)
    project_newton_kernel(*surf, foot, uv, S, D1, D2, z, z, read_only(z), read_only(z), 0.0, -1,
                          np.full((n, 2), np.nan), np.zeros((n, 2), dtype=bool), False, _FLOOR, _MAX_HALVINGS,
                          _OBJ_SLACK, 0.0, foot, np.zeros(n, dtype=bool), np.zeros(n, dtype=bool), True)
    return S, D1, D2


def project_to_surface(points, degree_u: int, degree_v: int, knots_u, knots_v, control_points, weights=None, *,
                       tol_rel: float = 1e-10, max_iter: int = 50, seed_grid=None,
                       retry: bool = True, uv0=None, compiled: bool = False, skip_below=None) -> Projection:
    """Closest points on a NURBS surface to many points (point inversion), batched.

    Parameters
    ----------
    points : (n, 3) float64
        Points P to project.
    degree_u, degree_v : int
        Degrees of the surface.
    knots_u : (nu + degree_u + 1,) float64
    knots_v : (nv + degree_v + 1,) float64
    control_points : (nu, nv, 3) float64
    weights : (nu, nv) float64 or None
        Positive weights; None for a polynomial surface.
    tol_rel : float
        Convergence tolerance relative to the bounding-box diagonal of the
        control net: the tangential residual ``|(S - P).Su| / |Su|`` (and the
        same with Sv) must fall below ``tol_rel * diagonal``.
    max_iter : int
        Largest number of Newton iterations.
    seed_grid : int or (array, array), optional
        Seed samples: an int is the number of samples per knot span in each
        direction (default ``max(degree + 1, ceil(16 / n_spans))``); two
        arrays give the u and v sample parameters explicitly.
    retry : bool
        Restart every point farther than the tolerance from the surface once
        across each crease next to its foot, and once from the nearest seed
        sample outside the basin already searched where such a sample may hold
        a closer point (see Notes). Costs about 10-60 % more time.
    uv0 : (n, 2) float64, optional
        Warm start: Newton begins at these parameters (clamped to the domain)
        instead of the nearest seed sample, e.g. the (u, v) interpolated from
        a tessellation's vertices. A point whose run does not converge, or
        ends farther from P than the nearest seed sample, is redone from that
        sample; the `retry` restarts apply as without `uv0`.
    compiled : bool
        Run the Newton iteration point by point in a compiled kernel
        (`_nurbs_kernels.project_newton_kernel`: the same steps, tests and
        restarts without per-iteration array calls; feet equal to rounding).
    skip_below : (n,) float64, optional
        With `uv0`, for callers that only need to know which points lie at
        least this far from the surface (e.g. whether a sample raises a
        running maximum): a point whose warm-started run converges at
        ``d <= 0.9 skip_below - 100 tol`` (tol the absolute tolerance) keeps
        that run's result without the redo and restarts; its full search
        could only have ended closer (within ~10 tol above the true minimum
        it finds), so its distance stays below `skip_below` either way. Other
        points are searched exactly as without it.

    Returns
    -------
    Projection
        ``uv (n, 2)``, ``foot (n, 3)``, ``distance (n,)``, ``converged (n,)``,
        ``on_boundary (n,)`` and ``iterations``.

    Raises
    ------
    GeometryError
        Points, knots, control points, weights or options of the wrong shape
        or value.

    Notes
    -----
    Each point descends from its nearest seed sample (or from `uv0`, then
    checked against that sample), so its distance never exceeds that
    sample's; the result is a local minimiser of the distance.
    Where the surface comes back within a seed spacing of itself (tight folds,
    far points near the medial axis) the nearest sample can lie in the wrong
    basin. With ``retry`` every point with a sample s more than two grid cells
    from its foot, or beyond a crease from it, and
    ``|P - s| - radius(s) < distance`` (radius(s): largest
    distance from s to its grid neighbours) is restarted from the nearest such
    s, keeping the closer result. Measured with 20k random points on a
    strongly waved bicubic surface (curvature radius ~0.1 of the diagonal),
    the share left in a non-global minimum fell from 0.1 % to 0 % for points
    anywhere in the bounding box and from 0.4 % to 0.09 % for points within
    10 % of the diagonal (0 % either way within 1 %); on a surface rolled up
    to 1.5 turns, from 4 % to 0 %; at 10-60 % more time. A denser
    ``seed_grid`` helps further; a surface that folds over itself within two
    seed cells (seen on faces of occt__linkrods.step, whose v lines turn back)
    can still end a point on the wrong sheet. Near a crease (a knot of
    multiplicity >= degree, e.g. any interior knot of degree 1) the far side
    is searched separately: a point whose foot lies within two seed cells of a
    crease restarts just across it (without stepping straight back), which
    catches local minima on the wrong side of a concave crease (measured on
    random rational B-splines of degree 1-3 with random knots, 1809 surfaces
    x 300 surface points: 3 points left at a wrong minimum before, 0 after).
    A domain edge that collapses to
    a point (a pole) is sampled a quarter spacing inside, so seeds near it
    carry the direction of approach.

    References
    ----------
    The NURBS Book, Sec. 6.1, eqs. (6.6)-(6.8) (Newton iteration for surface
    point inversion).

    Examples
    --------
    >>> import numpy as np
    >>> cp = np.array([[[0., 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]])
    >>> pr = project_to_surface([[0.25, 0.5, 2.0]], 1, 1, [0, 0, 1, 1], [0, 0, 1, 1], cp)
    >>> pr.uv.round(12).tolist(), pr.distance.tolist()
    ([[0.25, 0.5]], [2.0])
    """
    name = "project_to_surface"
    pu, pv = _degree(degree_u, name), _degree(degree_v, name)
    cp = np.asarray(control_points, dtype=np.float64)
    # the surface's checked arrays, seed parameters and creases, by its exact definition (a measurement
    # projects onto each face several times), kept in `_SEED_CACHE`
    ku_in, kv_in = np.asarray(knots_u, dtype=np.float64), np.asarray(knots_v, dtype=np.float64)
    w_in = None if weights is None else np.asarray(weights, dtype=np.float64)
    grid_key = seed_grid if isinstance(seed_grid, (int, np.integer)) and not isinstance(seed_grid, bool) \
        else None
    prep_key = None
    if grid_key is not None or seed_grid is None:
        prep_key = ("prepared", pu, pv, ku_in.shape, ku_in.tobytes(), kv_in.shape, kv_in.tobytes(), cp.shape,
                    cp.tobytes(), None if w_in is None else (w_in.shape, w_in.tobytes()),
                    None if grid_key is None else int(grid_key))
    prep = _SEED_CACHE.get(prep_key) if prep_key is not None else None
    if prep is None:
        if cp.ndim != 3 or cp.shape[2] != 3:
            raise GeometryError(f"{name}: control_points must have shape (nu, nv, 3); got {cp.shape}")
        if not np.all(np.isfinite(cp)):
            raise GeometryError(f"{name}: control_points contain NaN or infinite values")
        ku = _knot_vector(knots_u, pu, cp.shape[0], f"{name} (u)")
        kv = _knot_vector(knots_v, pv, cp.shape[1], f"{name} (v)")
        w = _weights(weights, cp.shape[:2], name)
        axes = _seed_values(seed_grid, (ku, kv), (pu, pv), name)
        breaks = [_breakpoints(ku, pu), _breakpoints(kv, pv)]
        ku, kv, w = ku.copy(), kv.copy(), None if w is None else w.copy()    # not the caller's arrays
        prep = (ku, kv, w, _diagonal(cp), tuple(axes), breaks,
                (pu, pv, ku.tobytes(), kv.tobytes(), cp.shape, cp.tobytes(), None if w is None else w.tobytes(),
                 tuple(a.tobytes() for a in axes)))
        if prep_key is not None:
            if len(_SEED_CACHE) >= _SEED_CACHE_SIZE:
                _SEED_CACHE.pop(next(iter(_SEED_CACHE)))
            _SEED_CACHE[prep_key] = prep
    ku, kv, w, diag, axes, breaks, key = prep
    axes = list(axes)
    pts = _points(points, 3, name)
    tol_rel, max_iter = _options(tol_rel, max_iter, name)
    tol = tol_rel * diag
    args = (pu, pv, ku, kv, cp, w)
    lo = np.array([ku[pu], kv[pv]])
    hi = np.array([ku[-pu - 1], kv[-pv - 1]])

    n = pts.shape[0]
    start = _start(uv0, n, 2, lo, hi, name, "uv0")
    if n == 0:
        z = np.zeros(0, dtype=bool)
        return Projection(np.zeros((0, 2)), np.zeros((0, 3)), np.zeros(0), z, z.copy(), 0)

    if compiled:
        pw = _homogeneous(cp, w)
        surf = (pu, pv, read_only(ku), read_only(kv), pw, w is not None)

        def evaluate(uv):
            # not called on this path: the seeds are points alone, and every Newton run (from a seed too)
            # evaluates its start itself
            return _surface_eval_compiled(surf, uv)
    else:
        def evaluate(uv):
            return _surface_eval(args, uv)

    seeds = _SEED_CACHE.pop(key, None)
    if seeds is None:
        points = None
        if compiled:
            def seed_points(uv):
                # the points alone (`surface_derivatives_kernel`'s numbers with nd = 0: the same operations
                # as `_eval_d2`'s point, so the same numbers; computed by `memo_points_kernel`, each grid
                # line's basis once); a run from a sample evaluates its derivatives in the Newton kernel
                # (`_seed_state` gives None)
                out = np.empty((len(uv), 3))
                memo_points_kernel(*surf, np.ascontiguousarray(np.clip(uv[:, 0], lo[0], hi[0])),
                                   np.ascontiguousarray(np.clip(uv[:, 1], lo[1], hi[1])), out)
                return out
            points = seed_points
        seeds = _build_seeds(axes, evaluate, tol / tol_rel, points=points)
        if len(_SEED_CACHE) >= _SEED_CACHE_SIZE:
            _SEED_CACHE.pop(next(iter(_SEED_CACHE)))
    _SEED_CACHE[key] = seeds                # most recently used last

    if compiled:
        def newton(p, x0, state, barrier=None):
            return _newton_compiled(p, x0.copy(), state, surf, lo, hi, breaks, tol, max_iter, barrier)
    else:
        def newton(p, x0, state, barrier=None):
            if state is None:
                state = evaluate(x0)
            return _newton(p, x0.copy(), state, evaluate, lo, hi, breaks, tol, max_iter, barrier)

    if compiled:
        def first_derivatives(uv):
            # the lean first-derivative path: the same operations as with second derivatives (same numbers)
            skl = np.zeros((2, 2, len(uv), 3))
            surface_derivatives_kernel(*surf, np.ascontiguousarray(np.clip(uv[:, 0], lo[0], hi[0])),
                                       np.ascontiguousarray(np.clip(uv[:, 1], lo[1], hi[1])), 1, skl)
            return np.stack([skl[1, 0], skl[0, 1]], axis=1)
    else:
        first_derivatives = None
    below = None
    if skip_below is not None and start is not None:
        below = np.asarray(skip_below, dtype=np.float64).reshape(-1)
        if below.shape != (n,):
            raise GeometryError(f"{name}: skip_below must have shape ({n},); got {np.shape(skip_below)}")
    raw = _solve(pts, seeds, evaluate, newton, bool(retry), tol, breaks, start, first_derivatives, below)
    return Projection(raw.params, raw.foot, raw.distance, raw.converged, raw.on_boundary, raw.iterations)


#: seed grids of the last surfaces projected onto, by their exact definition (knots, control points,
#: weights, seed parameters as bytes), least recently used dropped first: measuring a mesh projects onto
#: each face several times (a first pass over all faces, then the refinement rounds), so the cache must
#: hold a whole shell's faces (16 rebuilt every face's seeds on t20's 21 faces: 42 builds, 0.39 s)
#: The same dict holds, under keys starting with "prepared", each surface's checked knots, weights,
#: control-net diagonal, seed parameters, creases and seed key, by its exact input bytes (so a shell's
#: faces take two entries each).
_SEED_CACHE: dict = {}
_SEED_CACHE_SIZE = 1024


# --------------------------------------------------------------------------- curves

def project_to_curve(points, degree: int, knots, control_points, weights=None, *, tol_rel: float = 1e-10,
                     max_iter: int = 50, seed_grid=None, retry: bool = True, t0=None) -> CurveProjection:
    """Closest points on a NURBS curve (2D or 3D) to many points, batched.

    Parameters
    ----------
    points : (n, dim) float64
        Points P, dim equal to the curve's (2 or 3).
    degree : int
    knots : (n_ctrl + degree + 1,) float64
    control_points : (n_ctrl, dim) float64
    weights : (n_ctrl,) float64 or None
    tol_rel : float
        Convergence when ``|(C - P).C'| / |C'| <= tol_rel * diagonal`` of the
        control polygon's bounding box.
    max_iter : int
        Largest number of Newton iterations.
    seed_grid : int or (array,), optional
        Samples per knot span (default ``max(degree + 1, ceil(16 / n_spans))``)
        or explicit sample parameters.
    retry : bool
        Restart across the creases next to the foot and once from a far seed
        sample that may hold a closer point (as in `project_to_surface`).
    t0 : (n,) float64, optional
        Warm start parameters (clamped to the domain), checked and redone
        from the seeds where bad, as `uv0` in `project_to_surface`.

    Returns
    -------
    CurveProjection
        ``t (n,)``, ``foot (n, dim)``, ``distance (n,)``, ``converged (n,)``,
        ``on_boundary (n,)`` (the unconstrained minimiser lies beyond an end),
        ``iterations``.

    Raises
    ------
    GeometryError
        Inputs of the wrong shape or value.

    References
    ----------
    The NURBS Book, Sec. 6.1, eqs. (6.3)-(6.5) (Newton iteration for curve
    point inversion).

    Examples
    --------
    >>> import numpy as np
    >>> pr = project_to_curve([[0.5, 1.0]], 1, [0, 0, 1, 1], np.array([[0., 0.], [2., 0.]]))
    >>> pr.t.round(12).tolist(), pr.distance.tolist()
    ([0.25], [1.0])
    """
    name = "project_to_curve"
    p = _degree(degree, name)
    cp = np.asarray(control_points, dtype=np.float64)
    if cp.ndim != 2 or cp.shape[1] not in (2, 3):
        raise GeometryError(f"{name}: control_points must have shape (n, 2) or (n, 3); got {cp.shape}")
    if not np.all(np.isfinite(cp)):
        raise GeometryError(f"{name}: control_points contain NaN or infinite values")
    kn = _knot_vector(knots, p, cp.shape[0], name)
    w = _weights(weights, cp.shape[:1], name)
    dim = cp.shape[1]
    pts = _points(points, dim, name)
    tol_rel, max_iter = _options(tol_rel, max_iter, name)
    tol = tol_rel * _diagonal(cp)
    args = (p, kn, cp, w)
    lo, hi = kn[p], kn[-p - 1]
    n = pts.shape[0]
    lo_, hi_ = np.array([lo]), np.array([hi])
    start = _start(t0, n, 1, lo_, hi_, name, "t0")
    if n == 0:
        z = np.zeros(0, dtype=bool)
        return CurveProjection(np.zeros(0), np.zeros((0, dim)), np.zeros(0), z, z.copy(), 0)

    def evaluate(t):
        ck = curve_derivatives(*args, t[:, 0], n_derivs=2)
        return ck[0], ck[1][:, None], ck[2][:, None, None]

    axes = _seed_values(seed_grid, (kn,), (p,), name)
    seeds = _build_seeds(axes, evaluate, tol / tol_rel)
    breaks = [_breakpoints(kn, p)]

    def newton(pp, x0, state, barrier=None):
        if state is None:
            state = evaluate(x0)
        return _newton(pp, x0.copy(), state, evaluate, lo_, hi_, breaks, tol, max_iter, barrier)

    raw = _solve(pts, seeds, evaluate, newton, bool(retry), tol, breaks, start)
    return CurveProjection(raw.params[:, 0], raw.foot, raw.distance, raw.converged, raw.on_boundary, raw.iterations)
