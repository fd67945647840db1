"""Tessellation of one trimmed face: domain values, trim polygons, grid with inserted trims, lift to 3D."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError, TrimLoopError
from ..geom._pcurve_kernels import loop_polylines_kernel
from ..geom.nurbs import _homogeneous, read_only
from ..geom.predicates import PolygonIndex
from ..model import TriMesh, TrimmedFace
from ..model.trim import _pcurve_rows
from .domain import MAX_VALUES, _clipped_values, _too_many, adaptive_values, unique_values
from ._line_kernels import (DUMMY_1D, DUMMY_BOOL, DUMMY_CI, cell_deviation_kernel, cell_surface_kernel,
                            equidistributed_kernel, grid_cells_kernel, inside_grid_kernel, inside_grids_kernel,
                            line_net_kernel, refine_cells_kernel, refine_round_kernel)
from .grid import triangulate_domain
from .repair import remove_polygon_loops, repair_face
from .trims import ChunkUse, discretize_chunk

__all__ = ["tessellate_face", "face_domain_values", "shell_domain_values", "grid_box", "FaceMesh",
           "mesh_face_from_chunks", "check_parameters"]

_N_LINES = 24   # transversal lines per direction when the domain values are chosen (plus knot lines)
#: largest side ratio of a grid cell at or in the trimmed region (3D sides): its two triangles' smallest
#: angle is about atan(1 / ASPECT); a tolerance-only grid on a cylinder would otherwise span the whole
#: straight direction with one cell (screw p5 angle 0.4 deg -> 1.4 deg, linkrods 1.7 -> 4.9). Ours, not
#: the paper's (its grid size bounds the cells instead); `tessellate_shell(aspect=...)`, CLI --max-aspect.
#: Developable faces (`_developable`: planes, cylinders, cones, extrusions) only with LIMIT_DEVELOPABLE
ASPECT = 6.0
#: whether the aspect limit applies to developable faces too. It need not: their normal is the same all
#: along each straight line, so shading (reflection lines, highlights) is as exact on a cell long along
#: the lines as on a square one (benchmarks/aspect_quality.py, RESULTS.md "aspect limit": with False,
#: tolerance-only 0.879x the triangles, 0.568x Open CASCADE's, the same interpolated-normal error, the
#: 5th-percentile angle 3.41 -> 2.18 deg (geometric means, 12 files); the defaults' meshes unchanged).
#: True only in tests and benchmarks that compare with the flat limit's meshes
LIMIT_DEVELOPABLE = False
#: cells whose split deviates at most this many times the tolerance, few in their row and column, get an
#: interior point in the triangulation instead of a grid line through the whole row or column
LOCAL_FIX = 1.5
#: the aspect limit applies where the short side's direction has at least this many cells
MIN_ACROSS = 2
#: grid cells per face beyond which a face is refused (InputError, the face fails) before the grid is
#: refined or triangulated: 2.5e5 cells, 5e5 triangles. The cell checks of a grid near the limit peak
#: at 1.1 GB RSS (fender sample at --tolerance 3e-4, refused after 7 s; 2.4 GB with a limit of 1e6).
#: A backstop for the library: the CLI refuses from an estimate first.
MAX_CELLS = 250_000
#: barycentric points where a triangle's deviation is sampled: centroid, edge midpoints, and the
#: centroids of the three corner sub-triangles
_BARY = np.array([[1 / 3, 1 / 3, 1 / 3], [0.5, 0.5, 0.0], [0.0, 0.5, 0.5], [0.5, 0.0, 0.5],
                  [2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]])
#: `IsoLines.single_interval`: the largest bound of a placement's total density (ceil: 1 interval) taken
#: as one interval without the compiled placement (the margin covers the sums' relative rounding)
_ONE_INTERVAL = 0.99
#: rows of an `IsoLines.family`'s record of its placement's start (`equidistributed_kernel`)
_START_ROWS = 65
# empty arguments of the compiled cell kernels' unused members (one compiled signature for all their uses)
_NO_I, _NO_B, _NO_F = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.bool_), np.zeros(0)
_NO_UV, _NO_P, _NO_D = np.zeros((0, 5, 2)), np.zeros((0, 5, 3)), np.zeros((0, 2))
_NO_IDS2, _NO_TABLE = np.zeros((0, 2), dtype=np.int64), np.zeros((0, 0), dtype=np.int64)
_EPS = float(np.finfo(np.float64).eps)



def check_aspect(aspect) -> float | None:
    """Validated aspect limit of the grid cells: a number >= 1, or None / inf for no limit (-> None).

    >>> check_aspect(6), check_aspect(None), check_aspect(float("inf"))
    (6.0, None, None)
    """
    if aspect is None:
        return None
    try:
        a = float(aspect)
    except (TypeError, ValueError):
        raise InputError(f"aspect must be a number >= 1 or None (no limit); got {aspect!r}") from None
    if a == math.inf:
        return None
    if not (math.isfinite(a) and a >= 1.0):
        raise InputError(f"aspect must be a number >= 1, or inf / None for no limit; got {aspect!r}")
    return a


def _developable(s) -> bool:
    """Whether the surface's lines along one parameter direction are straight (degree 1, one span) with
    the same unit normal all along each line: its two rows of control points have the same weights and
    one is the other scaled about a point by a factor lam > 0, or moved (lam = 1), to 1e-9 of the net's
    size. Then every line is a ruling of a cone (an apex off the face) or a cylinder or a plane (a
    general extrusion) and the surface is developable (exact: the rows are the same curve in the
    homogeneous sense, S(., t) = A + t ((lam - 1) A + tau), whose normal does not depend on t).

    >>> from trimsurf.model import NurbsSurface
    >>> cyl = NurbsSurface(2, 1, [0, 0, 0, 1, 1, 1], [0, 0, 1, 1],
    ...                    [[[1, 0, 0], [1, 0, 5]], [[1, 1, 0], [1, 1, 5]], [[0, 1, 0], [0, 1, 5]]],
    ...                    [[1, 1], [0.7071, 0.7071], [1, 1]])
    >>> bool(_developable(cyl))
    True
    >>> twisted = NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 1]]])
    >>> bool(_developable(twisted))
    False
    """
    cp, w = s.control_points, s.weights
    for axis in (0, 1):
        if not _straight_dir(s, axis):
            continue
        p0, p1 = (cp[0], cp[1]) if axis == 0 else (cp[:, 0], cp[:, 1])
        if w is not None and not (np.array_equal(w[0], w[1]) if axis == 0 else np.array_equal(w[:, 0], w[:, 1])):
            continue
        c0, c1 = p0 - p0.mean(axis=0), p1 - p1.mean(axis=0)
        den = float((c0 * c0).sum())
        lam = float((c0 * c1).sum()) / den if den > 0 else 1.0
        scale = max(float(np.abs(p0).max(initial=0.0)), float(np.abs(p1).max(initial=0.0)))
        if lam > 0 and math.isfinite(scale) and float(np.abs(c1 - lam * c0).max(initial=0.0)) <= 1e-9 * scale:
            return True
    return False


def face_aspect(face: TrimmedFace, aspect: float | None) -> float | None:
    """The aspect limit of `face`'s cells: `aspect`, or None (no limit) on a developable face (`_developable`,
    unless LIMIT_DEVELOPABLE)."""
    if aspect is None or LIMIT_DEVELOPABLE or not _developable(face.surface):
        return aspect
    return None


def check_parameters(tolerance, max_edge) -> tuple[float, float]:
    """Validated (tolerance, max_edge): positive finite floats."""
    out = []
    for name, v in (("tolerance", tolerance), ("max_edge", max_edge)):
        try:
            f = float(v)
        except (TypeError, ValueError):
            raise InputError(f"{name} must be a number; got {v!r}") from None
        if not (np.isfinite(f) and f > 0):
            raise InputError(f"{name} must be a positive finite number; got {v!r}")
        out.append(f)
    return out[0], out[1]


def _linspace(a, b, n: int) -> np.ndarray:
    """np.linspace(a, b, n) for n >= 2 with its arithmetic (arange * step + a, the end exact; the same
    array) without its wrappers (several calls per face).

    >>> bool(np.array_equal(_linspace(0.1, 0.7, 24), np.linspace(0.1, 0.7, 24)))
    True
    """
    if n < 2:
        return np.linspace(a, b, n)
    a, b = float(a), float(b)
    step = (b - a) / (n - 1)
    y = np.arange(n, dtype=np.float64)
    if step == 0.0:             # as np.linspace for a zero (subnormal) step
        y /= n - 1
        y *= b - a
    else:
        y *= step
    y += a
    y[-1] = b
    return y


def _loop_polys(face: TrimmedFace, n: int = 6) -> list:
    return [loop.polyline(n) for loop in face.loops]


def _sample_loops(faces, n_a: int, n_b: int) -> tuple:
    """Every trim segment of `faces` sampled as `loop.polylines(n_a, n_b)` does, all in one compiled call
    (`loop_polylines_kernel`): (out_a, out_b) with n - 1 rows per segment in face, loop, segment order;
    loop_segs, per loop (first segment, segment count); face_loops, per face (first loop, loop count)."""
    si, sf, ck, cpw, loop_segs, face_loops = _loop_arrays(faces)
    m = len(si)
    out_a, out_b = np.empty((m * (n_a - 1), 2)), np.empty((m * (n_b - 1), 2))
    if m:
        loop_polylines_kernel(si, sf, ck, cpw, n_a, n_b, out_a, out_b)
    return out_a, out_b, loop_segs, face_loops


def _loop_arrays(faces) -> tuple:
    """The trim segments of `faces` as `loop_polylines_kernel` takes them: si (m, 7) int64 per segment
    (degree, knots' offset and count, homogeneous control points' offset, rows, columns, rational), sf
    (m, 2) its (t0, t1), the knots and control points flat and read-only (`model.trim._pcurve_rows`' arrays:
    the points homogeneous as `geom.nurbs._homogeneous` makes them), loop_segs and face_loops."""
    segs: list = []
    loop_segs = []
    face_loops = []
    for face in faces:
        face_loops.append((len(loop_segs), len(face.loops)))
        for loop in face.loops:
            loop_segs.append((len(segs), len(loop.segments)))
            segs.extend(loop.segments)
    m = len(segs)
    if not m:
        return np.zeros((0, 7), dtype=np.int64), np.zeros((0, 2)), read_only(np.zeros(0)), read_only(np.zeros(0)), \
            loop_segs, face_loops
    rows, ck, cpw = _pcurve_rows([sg.curve for sg in segs])
    si = np.ascontiguousarray(rows[:, [0, 2, 3, 4, 5, 6, 1]])
    sf = np.array([(sg.t0, sg.t1) for sg in segs], dtype=np.float64).reshape(m, 2)
    return si, sf, read_only(ck), read_only(cpw), loop_segs, face_loops


def _loop_polylines(face: TrimmedFace, n_a: int, n_b: int) -> tuple[list, list]:
    """[loop.polylines(n_a, n_b)[0] for each loop], [... [1] ...]: the same points (`_sample_loops`)."""
    out_a, out_b, loop_segs, _ = _sample_loops([face], n_a, n_b)
    a = [out_a[j * (n_a - 1):(j + c) * (n_a - 1)] for j, c in loop_segs]
    b = [out_b[j * (n_b - 1):(j + c) * (n_b - 1)] for j, c in loop_segs]
    return a, b


def grid_box(face: TrimmedFace, polys: list | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The (u, v) box the grid covers: the outer loop's box within the surface domain (`polys`: the
    loops' `polyline(32)` when the caller has them)."""
    (u0, u1), (v0, v1) = face.surface.domain
    lo, hi = np.array([u0, v0]), np.array([u1, v1])
    if face.loops:
        p = np.concatenate(polys if polys is not None else [loop.polyline(32) for loop in face.loops])
        lo = np.maximum(lo, p.min(axis=0))
        hi = np.minimum(hi, p.max(axis=0))
        if not np.all(hi > lo):
            raise TrimLoopError(f"{face.name or 'face'}: trim loops enclose no area of the surface domain")
    return lo, hi


def _inside_raster(polys: list, lo: np.ndarray, hi: np.ndarray, n: int = 96, index=None):
    """A lookup uv (k, 2) -> inside the trim (bool), from an n x n raster of the grid box, dilated by one
    pixel (only which lines count when domain values are chosen depends on it). `index`: the
    `PolygonIndex` of `polys` when the caller has it."""
    gu = _linspace(lo[0], hi[0], n)
    gv = _linspace(lo[1], hi[1], n)
    if index is None:
        index = PolygonIndex(polys)
    dil = np.empty((n, n), dtype=np.bool_)
    inside_grid_kernel(gu, gv, index.a, index.b, dil, np.empty((n, n), dtype=np.bool_))
    return _raster_lookup(dil, lo, hi, n)


class IsoLines:
    """The line family of a face's iso-lines: x (k,) -> S(x, lines) (axis 0) or S(lines, x) (axis 1),
    shape (k, L, 3), with `criteria` computing `interval_criteria` in one compiled pass (the points of
    pairs (interval, line) that do not count are not evaluated; the result is bit for bit the numpy one).
    """

    def __init__(self, surface, axis: int, lines: np.ndarray, raster=None, _surf=None):
        self.surface = surface
        self.axis = axis
        self.lines = np.asarray(lines, dtype=np.float64)
        self.raster = raster        # `_inside_raster`'s lookup: only intervals at the trim count (`weights`)
        s = surface
        if _surf is None:           # (ku, kv, pw) as `_CellCache._surf` holds them, when the caller has them
            self._ku, self._kv = read_only(s.knots_u), read_only(s.knots_v)
            self._pw = _homogeneous(s.control_points, s.weights)
        else:
            self._ku, self._kv, self._pw = _surf
        (u0, u1), (v0, v1) = s.domain
        self._xr = (u0, u1) if axis == 0 else (v0, v1)
        lr = (v0, v1) if axis == 0 else (u0, u1)
        self._lines_c = read_only(np.clip(self.lines, lr[0], lr[1]))
        self._family = None
        self._straight_v = None

    def __call__(self, x: np.ndarray) -> np.ndarray:
        uv = np.empty((len(x), len(self.lines), 2))
        uv[..., self.axis] = x[:, None]
        uv[..., 1 - self.axis] = self.lines[None, :]
        return self.surface.evaluate(uv.reshape(-1, 2)).reshape(len(x), len(self.lines), 3)

    def weights(self, x: np.ndarray) -> np.ndarray:
        """(len(x) - 1, L) bool: the lines that count on each interval, those inside the trim at an end
        or the middle of the interval (by the raster; all without one)."""
        if self.raster is None:
            return np.ones((len(x) - 1, len(self.lines)), dtype=bool)
        axis, other = self.axis, self.lines
        xm = np.concatenate((x, 0.5 * (x[:-1] + x[1:])))
        uv = np.empty((len(xm), len(other), 2))
        uv[..., axis] = xm[:, None]
        uv[..., 1 - axis] = other[None, :]
        ins = self.raster(uv.reshape(-1, 2)).reshape(len(xm), len(other))
        n = len(x)
        return ins[:n - 1] | ins[1:n] | ins[n:]

    def family(self) -> tuple:
        """The family as `_line_kernels` takes it (kind 0), with `weights` computed inside (built once)."""
        if self._family is None:
            self._family = self._make_family()
        return self._family

    def _make_family(self) -> tuple:
        r = self.raster
        s = self.surface
        pw = self._pw
        if self.axis == 0:      # the lines' own nets: the v contraction once per line, not per point
            pw = np.empty((len(self._lines_c), pw.shape[0], pw.shape[2]))
            line_net_kernel(s.degree_v, self._kv, self._lines_c, self._pw, pw)
            pw = read_only(pw)
        iso_i = np.array([self.axis, r is not None, s.degree_u, s.degree_v, s.weights is not None, self.axis == 0],
                         dtype=np.int64)
        iso_f = np.array([self._xr[0], self._xr[1], self.straight_bound()], dtype=np.float64)
        rgeo = np.zeros(4) if r is None else np.concatenate((r.lo, r.step)).astype(np.float64)
        # cf: the compiled placement's record of its fine sampling's start (both placements of a face
        # start from the same values; `equidistributed_kernel`), up to _START_ROWS - 1 intervals
        return (0, iso_i, iso_f, self._lines_c, read_only(self.lines), DUMMY_BOOL if r is None else r.dil, rgeo,
                self._ku, self._kv, pw, DUMMY_CI, np.zeros((_START_ROWS, 6)), DUMMY_1D, DUMMY_1D, DUMMY_1D, DUMMY_1D,
                DUMMY_1D)

    def straight_bound(self) -> float:
        """-1, or when every line is straight (degree 1 along it, one knot span: a segment, rational or
        not, of two points of the homogeneous net combined with the line's fixed basis) a bound of the
        sampled chord deviation the compiled criteria compute for it (rounding noise: each point is
        a two-term combination of the same two homogeneous points, divided by its weight; bounded
        here ~100x generously by the net's magnitudes)."""
        return self._straight()[0]

    def _straight(self) -> tuple[float, float]:
        """(`straight_bound`, the bound delta of a point's rounding noise it is made of; -1, -1 if not straight)."""
        info = self._info()
        return (-1.0, -1.0) if info is None else (info[0], info[1])

    def _info(self):
        """`_straight_info` of this family (computed once)."""
        if self._straight_v is None:
            self._straight_v = (_straight_info(self.surface, self.axis, self._pw),)
        return self._straight_v[0]

    def single_interval(self, a: float, b: float, tolerance: float, max_edge: float, n_init: int) -> bool:
        """Whether `equidistributed_kernel` certainly places [a, b] (no value between) for this family, from
        the fine sampling's start with `n_init` intervals: straight lines (`straight_bound` within the
        kernel's 1e-3 tolerance, so its straight skip applies) whose fine intervals' densities cannot add
        up to more than _ONE_INTERVAL = 0.99 (the kernel then places ceil(total) = 1 interval, or none for
        a total of 0, and that one passes its check).

        The bound: along a straight line the point moves linearly in x (degree 1, one span; rational only
        with the same weight at both ends of each row, the denominator then constant along the line),
        at a speed of a convex combination of the net's differences P1j - P0j across the moving direction,
        so any chord over [x0, x1] is at most (x1 - x0) / span * D (D: the largest difference) and the
        chords over the fine intervals add up to at most (b - a) / span * D; each computed chord is off by
        at most 2 delta (the points' rounding noise, `straight_bound`; plus an ulp of the parameter at an
        interval's end) over at most 2 * max(n_init, 20001) + 2 fine intervals (the kernel's sampling
        stops past 20000 values, a round at most doubles them); an interval the kernel samples within
        (shorter than its skip length) counts at most sqrt(bound / tolerance) (1 + 1e-9): only the n_init
        first ones can be that short (a split interval is over 0.25 max_edge, its halves over the skip
        length). Argued bounds, as the straight skip's."""
        return _single_interval(self._info(), a, b, tolerance, max_edge, n_init)

    def criteria(self, x: np.ndarray, n_sub: int, weights) -> tuple[np.ndarray, np.ndarray]:
        """`interval_criteria` of this family."""
        from ..geom._nurbs_kernels import iso_line_criteria_kernel
        from ..geom.nurbs import read_only

        n = len(x) - 1
        t = np.linspace(0.0, 1.0, n_sub + 2)
        xs = np.clip(x[:-1, None] + (x[1:] - x[:-1])[:, None] * t[None, :], self._xr[0], self._xr[1])
        w = (np.ones((n, len(self.lines)), dtype=np.bool_) if weights is None
             else np.array(weights, dtype=np.bool_, order="C"))
        length, dev = np.empty(n), np.empty(n)
        s = self.surface
        iso_line_criteria_kernel(s.degree_u, s.degree_v, self._ku, self._kv, self._pw, s.weights is not None,
                                 self.axis, self._lines_c, read_only(xs), w, length, dev)
        return length, dev


_EPS = float(np.finfo(np.float64).eps)


def _net_extremes(s, pw: np.ndarray) -> tuple:
    """(max |control point coordinate|, max |homogeneous coordinate|, min weight, max weight) of a surface."""
    big = float(np.abs(s.control_points).max(initial=0.0))
    hw = float(np.abs(pw).max(initial=0.0))
    w = s.weights
    wmin, wmax = (1.0, 1.0) if w is None else (float(w.min()), float(w.max()))
    return big, hw, wmin, wmax


def _straight_info(s, axis: int, pw: np.ndarray, common: tuple | None = None):
    """What `IsoLines.single_interval` needs of a surface's lines along `axis` (pw: its homogeneous net),
    independent of the interval and the criteria: None if the lines are not straight (degree 1, one
    span) or the net is not finite with positive weights, else (bound, delta, dmax, k0, k1, same_w):
    `straight_bound` and its point noise delta, the largest difference of the net across the moving
    direction, the moving parameter's span, and whether each row's weights are the same at both ends.
    `common`: the surface's `_net_extremes(s, pw)` when the caller has them (both axes share them).

    Straight lines' answers are kept per (surface, axis, net) (`_STRAIGHT`: a face's placement start and
    its line families ask twice; the model's surfaces and nets are read-only, the entry keeps them alive so
    that their ids are theirs)."""
    if not _straight_dir(s, axis):
        return None
    hit = _STRAIGHT.get((id(s), axis))
    if hit is not None and hit[0] is s and hit[1] is pw:
        return hit[2]
    out = _straight_info_computed(s, axis, pw, common)
    if not s.control_points.flags.writeable and not pw.flags.writeable and (
            s.weights is None or not s.weights.flags.writeable):
        if len(_STRAIGHT) > 4096:
            _STRAIGHT.clear()
        _STRAIGHT[(id(s), axis)] = (s, pw, out)
    return out


_STRAIGHT: dict = {}    # (id(surface), axis) -> (surface, net, `_straight_info`) of straight lines


def _straight_info_computed(s, axis: int, pw: np.ndarray, common: tuple | None = None):
    """`_straight_info` computed (lines along `axis` straight)."""
    cp = s.control_points
    if common is None:
        common = _net_extremes(s, pw)
    big, hw, wmin, wmax = common
    w = s.weights
    if not (math.isfinite(big) and math.isfinite(hw) and wmin > 0 and math.isfinite(wmax)):
        return None
    delta = 64.0 * (s.degree_u + s.degree_v + 2) ** 2 * _EPS * (hw + big * wmax) / wmin
    bound = 4.0 * delta + 128.0 * _EPS * big
    diff = cp[1] - cp[0] if axis == 0 else cp[:, 1] - cp[:, 0]
    dmax = float(np.sqrt((diff * diff).sum(axis=-1)).max(initial=0.0))
    k0, k1 = s.domain[axis]
    same_w = w is None or bool(np.array_equal(w[1], w[0]) if axis == 0 else np.array_equal(w[:, 1], w[:, 0]))
    return bound, delta, dmax, float(k0), float(k1), same_w


def _straight_dir(s, axis: int) -> bool:
    """Whether the surface's lines along `axis` are straight as `_straight_info` asks (degree 1, one span)."""
    return (s.degree_u, s.control_points.shape[0]) == (1, 2) if axis == 0 else \
        (s.degree_v, s.control_points.shape[1]) == (1, 2)


def _straight_lead(s, axis: int, a: float, b: float) -> float:
    """(b - a) / span * D of straight lines along `axis` (`_single_interval`'s lead term; only a guess of
    whether a raster is needed is made of it)."""
    cp = s.control_points
    diff = cp[1] - cp[0] if axis == 0 else cp[:, 1] - cp[:, 0]
    k0, k1 = s.domain[axis]
    return ((b - a) / (k1 - k0)) * float(np.sqrt((diff * diff).sum(axis=-1)).max(initial=0.0))


def _single_interval(info, a: float, b: float, tolerance: float, max_edge: float, n_init: int) -> bool:
    """`IsoLines.single_interval` from the family's `_straight_info` (the same decision, its arithmetic)."""
    if info is None:
        return False
    bound, delta, dmax, k0, k1, same_w = info
    lead = ((b - a) / (k1 - k0)) * dmax
    if not lead <= _ONE_INTERVAL * max_edge:    # (the usual answer with a max edge: no need for the rest)
        return False
    if not (0.0 <= bound <= 1e-3 * tolerance) or not same_w:
        return False
    n_max = 2 * max(n_init, 20001) + 2
    # an interval's last sample a + (b - a) * 1.0 may miss b by an ulp: the chords' parameters overlap by
    # at most 2 eps max(|a|, |b|) per interval
    slack = 2.0 * _EPS * max(abs(a), abs(b)) / (k1 - k0) * dmax
    total = (lead + n_max * (2.0 * delta + slack)) / max_edge \
        + n_init * math.sqrt(bound / tolerance) * (1.0 + 1e-9)
    return bool(math.isfinite(total) and total <= _ONE_INTERVAL)


def _knots_in(knots: np.ndarray, a: float, b: float) -> np.ndarray:
    """The distinct knots strictly inside (a, b), increasing (unique_values(knots) masked; without the
    sort when there are none, the usual case).

    A float64 vector (a knot vector's few values) is compared in scalars (IEEE comparisons either way; a
    nan is inside nothing); the distinct inside values are then the sorted set of them, the values
    unique_values keeps, unless a zero is inside (-0.0 and 0.0 are equal: which one unique_values keeps
    depends on its sort): there, and for other vectors, numpy's path.

    >>> _knots_in(np.array([0.0, 0.0, 0.5, 0.5, 0.25, 1.0]), 0.0, 1.0).tolist()
    [0.25, 0.5]
    """
    if type(knots) is np.ndarray and knots.dtype == np.float64 and knots.ndim == 1:
        lo, hi = float(a), float(b)
        inside = [k for k in knots.tolist() if lo < k < hi]
        if not inside:
            return knots[:0].astype(np.float64)
        if 0.0 not in inside:
            return np.array(sorted(set(inside)), dtype=np.float64)
    if not ((knots > a) & (knots < b)).any():
        return knots[:0].astype(np.float64)
    k = unique_values(knots)
    return k[(k > a) & (k < b)]


def _knots_in_numpy(knots: np.ndarray, a: float, b: float) -> np.ndarray:
    """`_knots_in` by numpy's path alone (the tests' reference)."""
    if not ((knots > a) & (knots < b)).any():
        return knots[:0].astype(np.float64)
    k = unique_values(knots)
    return k[(k > a) & (k < b)]


def _with_knots(a, b, n: int, kin: np.ndarray) -> np.ndarray:
    """unique_values(np.concatenate((_linspace(a, b, n), kin))) (the same array): the linspace itself
    when there are no knots and its values increase strictly (nothing to sort or drop; `_increasing`
    says so from a, b and n where it can, else the values are compared)."""
    y = _linspace(a, b, n)
    if not len(kin) and (_increasing(a, b, n) or bool((y[1:] > y[:-1]).all())):
        return y
    return unique_values(np.concatenate((y, kin)))


_U = 2.0 ** -53             # the unit roundoff
_TINY = 2.0 ** -1000        # steps below: subnormal rounding is not relative (`_increasing` does not decide)


def _increasing(a, b, n: int) -> bool:
    """True only if `_linspace(a, b, n)` increases strictly (False: not known). The values are
    y_i = fl(fl(i s) + a) (i < n - 1) and y_{n-1} = b with s = fl((b - a) / (n - 1)); each rounding is
    relative, at most u = 2^-53 (s >= 2^-1000: no value between 0 and the normal range is rounded
    but with an absolute error below 2^-1075, far below s). Then y_{i+1} - y_i >= s - 2u (n - 1) s (1 + u) -
    u (|t_i + a| + |t_{i+1} + a|) and b - y_{n-2} >= s / (1 + u) - 3u (b - a) - u (|a| + 2 (b - a)), both
    positive when s > 8u (|a| + |b| + (b - a)), as required here (with b > a, both finite). Argued bound;
    the tests compare it with the values on many a, b, n, near the bound too."""
    a, b = float(a), float(b)
    if n < 2 or not (math.isfinite(a) and math.isfinite(b) and b > a):
        return False
    s = (b - a) / (n - 1)
    return s >= _TINY and s > 8.0 * _U * (abs(a) + abs(b) + (b - a))


def face_domain_values(face: TrimmedFace, *, tolerance: float, max_edge: float,
                       strategy: str = "equidistributed", n_lines: int = _N_LINES, with_fits: bool = False,
                       aspect: float | None = ASPECT):
    """Adaptive u and v values of a face (paper Sec. 4.2), the criteria evaluated over the whole face.

    For the u values, the lines are v = const for `n_lines` values across the
    trimmed region (and the interior knots); only intervals that touch the
    trimmed region count. Afterwards every grid cell at the trimmed region is
    split along its diagonal and checked (`refine_cells`): lines within the
    tolerance still leave cells whose triangles deviate more (curvature in
    both directions adds up at a triangle's centre, and the twist the
    iso-lines do not see); the lines are placed again for the tolerance
    divided by the worst cell's ratio when that gives fewer cells than
    mid-lines through the bad cells, and a few cells just over the tolerance
    get an interior point when the face is triangulated instead of a line.
    Cells whose sides differ by more than `aspect` are halved across their long side (None: no limit;
    `refine_cells`), except on a developable face (`face_aspect`).

    Returns
    -------
    us, vs : increasing float64 arrays, from the grid box's lower to upper corner.
    fits : (n_cells, 2) float64, only with ``with_fits``
        The grid's `_diagonal_fits` (the same numbers, from the refinement's cell cache): for
        `mesh_face_from_chunks(..., fits=fits)`.
    """
    return _face_values(face, tolerance=tolerance, max_edge=max_edge, strategy=strategy, n_lines=n_lines,
                        with_fits=with_fits, aspect=check_aspect(aspect))


def shell_domain_values(faces, *, tolerance: float, max_edge: float, strategy: str = "equidistributed",
                        n_lines: int = _N_LINES, aspect: float | None = ASPECT) -> list:
    """`face_domain_values(face, ..., with_fits=True)` of each face, or the InputError it raises (the same
    values, the same errors): the loops of all faces sampled, boxed and rasterized at once (`face_fronts`),
    then each face's placement and refinement."""
    out = []
    # the rasters only serve compiled placements: a face straight in both directions (a plane, a bilinear
    # patch) within the grid size needs none (`_single_interval`); a face that does after all builds its own
    edge = max_edge / np.sqrt(2.0)
    aspect = check_aspect(aspect)

    def rasterize(f, lo, hi):
        s = faces[f].surface
        return not all(_straight_dir(s, axis) and _straight_lead(s, axis, lo[axis], hi[axis]) <= _ONE_INTERVAL * edge
                       for axis in (0, 1))

    for face, front in zip(faces, face_fronts(faces, rasterize)):
        try:
            out.append(_face_values(face, tolerance=tolerance, max_edge=max_edge, strategy=strategy,
                                    n_lines=n_lines, with_fits=True, front=front, aspect=aspect))
        except InputError as exc:
            out.append(exc)
    return out


def _face_values(face, *, tolerance, max_edge, strategy="equidistributed", n_lines=_N_LINES, with_fits=False,
                 front=None, aspect=ASPECT):
    """`face_domain_values`, with the face's `_Front` from `shell_domain_values` when given."""
    cache = _CellCache(face.surface)
    us, vs = _domain_values(face, tolerance, max_edge, strategy, n_lines, cache, front, face_aspect(face, aspect))
    if with_fits:
        return us, vs, cache.fits(us, vs)
    return us, vs


class _Front:
    """What `_domain_values` computes first from a face's loops, computed for many faces at once by
    `face_fronts`: the grid box (lo, hi), the trim polygons `polys` (`_loop_polys`), their index (edges
    a -> b as `PolygonIndex` has them) and the inside raster (`_inside_raster`), the same numbers."""

    __slots__ = ("lo", "hi", "polys", "index", "_raster")

    @property
    def raster(self):
        """The inside raster's lookup (None without loops); a face `face_fronts` did not rasterize gets it
        here, from its own edges (`inside_grids_kernel` of this face alone: the same raster)."""
        if self._raster is _PENDING:
            dil = np.empty((1, _RASTER, _RASTER), dtype=np.bool_)
            a, b = self.index.a, self.index.b
            inside_grids_kernel(self.lo.reshape(1, 2).copy(), self.hi.reshape(1, 2).copy(), a, b,
                                np.array([[0, len(a)]], dtype=np.int64), dil)
            step = np.maximum((self.hi - self.lo) / (_RASTER - 1), 1e-300)
            self._raster = _raster_lookup(dil[0], self.lo, self.hi, _RASTER, step)
        return self._raster

    @raster.setter
    def raster(self, value):
        self._raster = value


class _EdgeIndex(PolygonIndex):
    """A `PolygonIndex` whose edges (a, b) were computed by the caller (the same arrays); its slab index,
    which only `contains` uses (the domain values use the edges), is built when first needed."""

    def __init__(self, polygons, a, b):     # (not the base __init__: its slab index is built in `contains`)
        self.polygons, self.a, self.b = polygons, a, b

    def contains(self, points) -> np.ndarray:
        if len(self.a) and not hasattr(self, "edges"):
            from ..geom.predicates import _slab_index
            self.y0, self.h, self.n_slab, self.start, self.edges = _slab_index(self.a, self.b)
        return super().contains(points)


def _raster_lookup(dil, lo, hi, n, step=None):
    """`_inside_raster`'s lookup of the raster `dil` of the box lo, hi."""
    if step is None:
        step = np.maximum((hi - lo) / (n - 1), 1e-300)

    def lookup(uv: np.ndarray) -> np.ndarray:
        i = np.clip(np.rint((uv[:, 0] - lo[0]) / step[0]).astype(np.int64), 0, n - 1)
        j = np.clip(np.rint((uv[:, 1] - lo[1]) / step[1]).astype(np.int64), 0, n - 1)
        return dil[i, j]

    # the raster as the compiled families read it (`_line_kernels`)
    lookup.dil = np.ascontiguousarray(dil, dtype=np.bool_)
    lookup.lo = np.ascontiguousarray(lo, dtype=np.float64)
    lookup.step = np.ascontiguousarray(step, dtype=np.float64)
    return lookup


_RASTER = 96        # `_inside_raster`'s default size
_PENDING = object()  # `_Front._raster` of a face whose raster is built when first read


def face_fronts(faces, rasterize=None) -> list:
    """Per face, its `_Front` (or the TrimLoopError `grid_box` raises for it), for all faces at once: every
    loop segment sampled in one `loop_polylines_kernel` call, the grid boxes by `np.minimum.reduceat`
    (the same minima), the polygon edges by index, the rasters in one `inside_grids_kernel` call. The
    numbers are those `_domain_values` computes per face (`_loop_polylines`, `grid_box`, `PolygonIndex`,
    `_inside_raster`). `rasterize`: per face whether to build its raster here (default all), or a function
    (face index, lo, hi) -> bool; the others build it when first read (`_Front.raster`)."""
    n_a, n_b = 32, 6
    out_a, out_b, loop_segs, face_loops = _sample_loops(faces, n_a, n_b)
    # each loop's next vertex by index (PolygonIndex's), over all loops
    nxt = np.arange(1, len(out_b) + 1)
    for s0, c in loop_segs:
        if c:
            nxt[(s0 + c) * (n_b - 1) - 1] = s0 * (n_b - 1)
    b_all = out_b[nxt] if len(out_b) else out_b.copy()
    nf = len(faces)
    fronts: list = [None] * nf
    los, his = np.empty((nf, 2)), np.empty((nf, 2))
    seg_rows = np.zeros((nf, 2), dtype=np.int64)   # each face's segments (its rows: x (n - 1))
    wanted = rasterize
    rasterize = np.zeros(nf, dtype=np.bool_)
    for f, face in enumerate(faces):
        (u0, u1), (v0, v1) = face.surface.domain
        los[f], his[f] = (u0, v0), (u1, v1)
        l0, nl = face_loops[f]
        if nl:
            seg_rows[f] = (loop_segs[l0][0], loop_segs[l0 + nl - 1][0] + loop_segs[l0 + nl - 1][1])
    have = np.flatnonzero(seg_rows[:, 1] > seg_rows[:, 0])
    if len(have):
        starts = seg_rows[have, 0] * (n_a - 1)
        # reduceat over consecutive ranges: each face's rows start where the previous face's end (no gaps
        # where faces without segments sit between: those are not in `have`), the last range runs to the end
        ends = seg_rows[have, 1] * (n_a - 1)
        mins = np.minimum.reduceat(out_a, starts, axis=0)
        maxs = np.maximum.reduceat(out_a, starts, axis=0)
        assert np.array_equal(ends[:-1], starts[1:]) and (not len(ends) or ends[-1] == len(out_a))
        los[have] = np.maximum(los[have], mins)
        his[have] = np.minimum(his[have], maxs)
    ok_box = np.all(his > los, axis=1)
    for f, face in enumerate(faces):
        fr = _Front()
        l0, nl = face_loops[f]
        fr.lo, fr.hi = los[f].copy(), his[f].copy()
        fr.polys = fr.index = fr.raster = None
        if nl:
            if not ok_box[f]:
                fronts[f] = TrimLoopError(f"{face.name or 'face'}: trim loops enclose no area of the surface domain")
                continue
            fr.polys = [out_b[s0 * (n_b - 1):(s0 + c) * (n_b - 1)] for s0, c in loop_segs[l0:l0 + nl]]
            r0, r1 = seg_rows[f, 0] * (n_b - 1), seg_rows[f, 1] * (n_b - 1)
            fr.index = _EdgeIndex(fr.polys, np.ascontiguousarray(out_b[r0:r1]), np.ascontiguousarray(b_all[r0:r1]))
            if wanted is None or (wanted(f, fr.lo, fr.hi) if callable(wanted) else wanted[f]):
                rasterize[f] = True
            else:
                fr.raster = _PENDING
        fronts[f] = fr
    ras = np.flatnonzero(rasterize)
    if len(ras):
        dil = np.empty((len(ras), _RASTER, _RASTER), dtype=np.bool_)
        rows = np.ascontiguousarray(seg_rows[ras] * (n_b - 1))
        inside_grids_kernel(np.ascontiguousarray(los[ras]), np.ascontiguousarray(his[ras]), out_b, b_all, rows, dil)
        steps = np.maximum((his[ras] - los[ras]) / (_RASTER - 1), 1e-300)
        for q, f in enumerate(ras):
            fr = fronts[f]
            fr.raster = _raster_lookup(dil[q], fr.lo, fr.hi, _RASTER, steps[q].copy())
    return fronts


def _domain_values(face, tolerance, max_edge, strategy, n_lines, cache, front=None, aspect=ASPECT):
    """`face_domain_values` with the face's `_CellCache` (and its `_Front` when the caller has it)."""
    s = face.surface
    if front is not None:
        if isinstance(front, Exception):
            raise front
        lo, hi, polys = front.lo, front.hi, front.polys
        if polys is not None:
            cache._loops = (face, front.index)
            cache._index = (polys, front.index)

        def raster():
            return front.raster
    else:
        # the loops sampled for the grid box (32 per segment) and as trim polygons (`_loop_polys`, 6) at once
        box_polys, polys = None, None
        if face.loops:
            box_polys, polys = _loop_polylines(face, 32, 6)
        lo, hi = grid_box(face, box_polys)
        if polys is not None:       # refine_cells and _worst_cell_ratio index the same trim polygons
            cache.seed(face, polys)
        lazy = []

        def raster():               # (only a compiled placement reads it: built when first needed)
            if not lazy:
                lazy.append(None if polys is None else _inside_raster(polys, lo, hi, index=cache.polygon_index(polys)))
            return lazy[0]
    kin = (_knots_in(s.knots_u, lo[0], hi[0]), _knots_in(s.knots_v, lo[1], hi[1]))     # interior knots in the box
    axes, families = {}, {}

    def start(axis):
        """(a, b, init, x0, straight info) of the axis, once for both placements: x0 is the compiled
        placement's start (`_clipped_values(a, init, b)`, `_start_values`)."""
        if axis not in axes:
            a, b = float(lo[axis]), float(hi[axis])
            init = _with_knots(lo[axis], hi[axis], 17, kin[axis])
            x0 = _start_values(a, init, b)
            common = None
            if _straight_dir(s, axis):      # (the net's extremes: once for both axes)
                if "net" not in axes:
                    axes["net"] = _net_extremes(s, cache._surf[4])
                common = axes["net"]
            axes[axis] = (a, b, init, x0, _straight_info(s, axis, cache._surf[4], common))
        return axes[axis]

    def family(axis):
        """The line family (and its compiled form), built when a placement first needs it: the lines
        and the inside raster are only read by the compiled placement (not by `_single_interval`)."""
        if axis not in families:
            o = 1 - axis
            lines = _with_knots(lo[o], hi[o], n_lines, kin[o])
            families[axis] = IsoLines(s, axis, lines, raster(), _surf=cache._surf[2:5])
        return families[axis]

    def place(line_tol: float, edge: float = max_edge, strategy: str = strategy):
        out = []
        for axis in (0, 1):
            # the cells of the whole grid are bounded too (MAX_CELLS): the v lines by what the u lines leave
            limit = MAX_VALUES if axis == 0 else max(1, min(MAX_VALUES, MAX_CELLS // max(len(out[0]) - 1, 1)))
            a, b, init, x0, info = start(axis)
            # grid size max_edge / sqrt(2): the cell diagonals (triangle edges) stay within max_edge
            try:
                if strategy == "equidistributed":
                    out.append(_place_axis(family, axis, a, b, x0, info, line_tol, edge / np.sqrt(2.0), limit))
                else:
                    evaluate = family(axis)
                    out.append(adaptive_values(evaluate, lo[axis], hi[axis], tolerance=line_tol,
                                               max_edge=edge / np.sqrt(2.0), strategy=strategy, init=init,
                                               weights_fn=None if evaluate.raster is None else evaluate.weights,
                                               max_values=limit))
            except InputError as exc:
                if not hasattr(exc, "needed"):
                    raise
                raise InputError(f"{face.name or 'face'}: the grid would need ~{exc.needed:.3g} iso-lines in "
                                 f"{'uv'[axis]} (at most {limit} here, {MAX_CELLS} cells per face): tolerance "
                                 f"{tolerance:.3g} or max edge {max_edge:.3g} is too small for this face") from None
        return out

    us, vs = place(tolerance)
    if strategy == "uniform":
        return refine_cells(face, us, vs, tolerance=tolerance, max_edge=max_edge, aspect=aspect, cache=cache)
    # iso-lines within the tolerance still leave cells whose triangles deviate more (curvature in both
    # directions adds up at a triangle's centre, plus the twist). Mid-lines through the bad cells
    # (refine_cells) halve every row and column they cross and overshoot 4x; lines placed for the
    # tolerance divided by the worst cell ratio r (about sqrt(r) x the lines) land near the tolerance.
    # The grid with fewer cells wins.
    # The same for the diagonals: lines spaced max_edge / sqrt(2) leave the diagonals of sheared or
    # curved cells just over max_edge, and mid-lines through every such row and column doubled the
    # lines (hood sample at max edge 14.1: 3944 cells over by <= 0.64 %, 110 x 143 -> 151 x 205
    # lines, 2x the uniform grid's triangles); lines placed for max_edge / rd need ~rd x the lines.
    best = first = refine_cells(face, us, vs, tolerance=tolerance, max_edge=max_edge, aspect=aspect, cache=cache)
    r, rd = _worst_cell_ratio(face, us, vs, tolerance, polys, cache, max_edge)
    if r > 1.0 or rd > 1.0:
        best = _fewer_cells(best, lambda: place(tolerance / (1.05 * r) if r > 1.0 else tolerance,
                                                max_edge / (1.002 * rd) if rd > 1.0 else max_edge),
                            face, tolerance, max_edge, aspect, cache)
    if UNIFORM_CANDIDATE and rd > 1.0 and best is first and _cells(best) > UNIFORM_GAIN * _cells((us, vs)):
        # refining for diagonals over max_edge added many lines and re-placing for the worst diagonal did not
        # help: the uniform grid (the paper's baseline, Sec. 3.4) is a candidate too. Lines equidistributed
        # at the grid size leave every cell's diagonal at the limit, so a little shear puts whole rows over
        # it, where the uniform grid's slack (its worst interval sets the spacing) needs fewer mid-lines
        # (fender sample at grid size G: 29 x 18 -> 43 x 18 cells, re-placed 30 x 18 -> 39 x 26, uniform
        # 30 x 18 -> 38 x 19)
        best = _fewer_cells(best, lambda: place(tolerance, strategy="uniform"), face, tolerance, max_edge, aspect,
                            cache)
    return best


#: whether `face_domain_values` (default strategy) tries the uniform grid too where refining for the diagonal
#: made more than UNIFORM_GAIN x the placed cells and re-placing the lines for the worst diagonal did not
#: help (tried more widely, it never won at the defaults on the 17 models but cost CPU: bspline_box +50 %)
UNIFORM_CANDIDATE = True
UNIFORM_GAIN = 1.25


def _cells(grid) -> int:
    return (len(grid[0]) - 1) * (len(grid[1]) - 1)


def _fewer_cells(best, make, face, tolerance, max_edge, aspect, cache):
    """`best` or the refined grid `make()` places, whichever has fewer cells (`best` on a tie, or when the
    other would exceed the cell budget: InputError)."""
    try:
        alt = make()
        if _cells(alt) >= _cells(best):
            return best         # refining only adds lines: the alternative cannot have fewer cells
        alt = refine_cells(face, alt[0], alt[1], tolerance=tolerance, max_edge=max_edge, aspect=aspect, cache=cache)
    except InputError:
        return best
    return alt if _cells(alt) < _cells(best) else best


def _start_values(a: float, init: np.ndarray, b: float) -> np.ndarray:
    """`_clipped_values(a, init, b)` of sorted unique values `init` (`unique_values`' output): init itself
    when it runs from a to b (then nothing is clipped and a, b are in it already; a zero end of the other
    sign than a or b is left to the full path, which keeps the one sorted first), else the full path."""
    if len(init) and init[0] == a and init[-1] == b and (a != 0.0 or math.copysign(1.0, init[0]) == math.copysign(1.0, a)) \
            and (b != 0.0 or math.copysign(1.0, init[-1]) == math.copysign(1.0, b)):
        return init
    return _clipped_values(a, init, b)


def _place_axis(family, axis: int, a: float, b: float, x0: np.ndarray, info, tolerance: float, max_edge: float,
                max_values: int) -> np.ndarray:
    """`adaptive_values(family(axis), a, b, tolerance=..., max_edge=..., init=init, weights_fn=its weights
    (None without a raster), max_values=...)` of the default strategy for a face's iso-lines (the same
    values and errors: its checks, then the compiled placement) from what `_domain_values` keeps per axis
    for both placements: x0 (the clipped start values), info (`_straight_info`, for `_single_interval`,
    which places [a, b] where the compiled placement certainly does); `family(axis)`, the `IsoLines`, is
    only called when the compiled placement runs."""
    tolerance, max_edge = float(tolerance), float(max_edge)
    if not (math.isfinite(tolerance) and tolerance > 0):
        raise InputError(f"tolerance must be a positive finite number; got {tolerance!r}")
    if not (math.isfinite(max_edge) and max_edge > 0):
        raise InputError(f"max_edge must be a positive finite number; got {max_edge!r}")
    if not (math.isfinite(a) and math.isfinite(b) and a < b):
        raise InputError(f"parameter interval must satisfy a < b; got [{a}, {b}]")
    if _single_interval(info, a, b, tolerance, max_edge, len(x0) - 1):
        return np.array([a, b])     # what the kernel places: straight lines within max_edge (a bound)
    x, needed = equidistributed_kernel(*family(axis).family(), x0, a, b, tolerance, max_edge, float(max_values))
    if needed >= 0:
        raise _too_many(needed, max_values, tolerance, max_edge)
    return x


def _near_trim(us, vs, polys):
    """Cells whose centre is inside the trim, dilated by one cell (those crossed by it count too),
    and the cells of the interior (inside with all four neighbours)."""
    ci = 0.5 * (us[:-1] + us[1:])
    cj = 0.5 * (vs[:-1] + vs[1:])
    index = polys if isinstance(polys, PolygonIndex) else PolygonIndex(polys)
    near = np.empty((len(ci), len(cj)), dtype=np.bool_)
    interior = np.empty((len(ci), len(cj)), dtype=np.bool_)
    inside_grid_kernel(ci, cj, index.a, index.b, near, interior)
    return near, interior


def _worst_cell_ratio(face: TrimmedFace, us, vs, tolerance: float, polys, cache=None,
                      max_edge: float = np.inf) -> tuple[float, float]:
    """Largest deviation / tolerance and largest diagonal / max_edge of the split cells at (or near) the
    trimmed region (both diagonals in the band along the trim, as `refine_cells` checks them)."""
    known = None if cache is None else cache.checked
    if known is not None and known[0] is us and known[1] is vs and known[2] == tolerance and (
            (polys is None) == (known[5] is None)
            and (polys is None or cache.polygon_index(polys) is known[5])):
        dev_max, diag_max = known[3], known[4]      # refine_cells' first round checked this grid (the same numbers)
    else:
        # deviations within the tolerance may be bounds: only r > 1 (set by the cells over it) counts
        dev, diag, diag_max = _cell_deviation(face.surface, us, vs, tolerance, cache, exact=False)[:3]
        if polys is not None:
            near, interior = _near_trim(us, vs, polys if cache is None else cache.polygon_index(polys))
            dev = np.where(near, dev, 0.0)
            diag = np.where(near & ~interior, diag_max, np.where(near, diag, 0.0))
        dev_max, diag_max = float(dev.max(initial=0.0)), float(diag.max(initial=0.0))
    return dev_max / tolerance, diag_max / max_edge


_ROUNDS = 6     # refine_cells' rounds


def refine_cells(face: TrimmedFace, us: np.ndarray, vs: np.ndarray, *, tolerance: float,
                 max_edge: float, aspect: float | None = ASPECT, cache=None) -> tuple[np.ndarray, np.ndarray]:
    """Mid-lines through the grid cells (near the trim) whose split leaves the tolerance, whose
    diagonal is longer than max_edge or whose sides differ by more than `aspect` (None: no limit);
    returns the refined (us, vs).

    All rounds in one compiled call (`refine_cells_kernel`): the decisions and numbers of
    `_refine_cells_rounds`, the reference, which runs the rounds from Python (and runs instead where the
    kernel declines: a grid not increasing)."""
    us_in, vs_in = us, vs
    us, vs = _float64_c(us), _float64_c(vs)
    if cache is None:
        cache = _CellCache(face.surface)
    polys = cache.loop_index(face) if face.loops else None
    asp = float(aspect) if aspect else 0.0
    pa, pb = (polys.a, polys.b) if polys is not None else (_NO_D, _NO_D)
    out = refine_cells_kernel(*cache._state(), *cache._surf, _BARY, cache._lin, *cache._buffers(), cache.n, us, vs,
                              pa, pb, polys is not None, float(tolerance), float(max_edge), asp, MIN_ACROSS,
                              float(LOCAL_FIX), MAX_CELLS, _ROUNDS)
    cache._take(out[:11])
    gu, gv, status, rounds, dev0, diag0, rows = out[11:]
    if status == 3:
        return _refine_cells_rounds(face, us_in, vs_in, tolerance=tolerance, max_edge=max_edge, aspect=aspect,
                                    cache=cache)
    cache.checked = (us, vs, tolerance, dev0, diag0, polys)
    if status == 2:
        raise _too_many_cells(face, gu, gv, tolerance, max_edge)
    if rounds == 0:
        gu, gv = us, vs
    if status == 0:
        cache.remember(gu, gv, rows)
    return gu, gv


def _float64_c(x) -> np.ndarray:
    """np.ascontiguousarray(x, dtype=np.float64), x itself where it is one already (also an array a compiled
    kernel returned, whose float64 dtype is another instance, which ascontiguousarray copies): refine_cells'
    first grid is then the placement's arrays, the grid `_worst_cell_ratio` asks for."""
    if type(x) is np.ndarray and x.dtype == np.float64 and x.flags.c_contiguous:
        return x
    return np.ascontiguousarray(x, dtype=np.float64)


def _norm3(a, b) -> float:
    """|b - a| of two 3-lists of floats, as np.sqrt(np.sum((b - a) ** 2)) computes it."""
    q0, q1, q2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    return math.sqrt((q0 * q0 + q1 * q1) + q2 * q2)


def _too_many_cells(face, us, vs, tolerance, max_edge) -> InputError:
    return InputError(f"{face.name or 'face'}: refining the grid would make {len(us) - 1} x {len(vs) - 1} "
                      f"cells (more than {MAX_CELLS}): tolerance {tolerance:.3g} or max edge "
                      f"{max_edge:.3g} is too small for this face")


def _refine_cells_rounds(face: TrimmedFace, us: np.ndarray, vs: np.ndarray, *, tolerance: float,
                         max_edge: float, aspect: float | None = ASPECT, cache=None) -> tuple[np.ndarray, np.ndarray]:
    """`refine_cells` round by round from Python (the reference of `refine_cells_kernel`)."""
    s = face.surface
    us, vs = _float64_c(us), _float64_c(vs)
    if cache is None:   # the rounds share most cells: each cell's surface work once (the same numbers)
        cache = _CellCache(s)
    polys = None
    if face.loops:      # the trim polygons, their slab index built once
        polys = cache.loop_index(face)
    # the twist of the cells: split along the better diagonal, refine rows/columns where it fails;
    # the same for a diagonal longer than max_edge (split across its longer side)
    asp = float(aspect) if aspect else 0.0
    for round_ in range(_ROUNDS):
        # deviations within the tolerance may be bounds within it: only the cells over it use the values
        dev, diag, diag_max, side_u, side_v = _cell_deviation(s, us, vs, tolerance, cache, exact=False)
        if polys is not None:
            # cells crossed by the trim count too (one cell dilation); in the band along the trim
            # the CDT may use either diagonal: both must be short enough (its triangles that leave
            # the tolerance get an interior point in mesh_face_from_chunks)
            near, interior = _near_trim(us, vs, polys)
        else:
            near = interior = np.zeros(dev.shape, dtype=np.bool_)
        # the round's decisions (refine_round_kernel, which masks dev and diag by the band in place):
        # bad cells (over the tolerance) are halved across the direction(s) whose sides bulge most (both
        # where they are alike, e.g. the twist): a mid-line in both directions through every bad cell
        # overshoots; a line through a column (row) where only a few cells leave the tolerance by a
        # little (at most LOCAL_FIX) costs the whole column: those cells get an interior point instead
        # (mesh_face_from_chunks); cells with a diagonal over max_edge, or much longer one way than the
        # other (their two triangles' smallest angle is about atan(1 / aspect)) are halved across the
        # long side, the latter only where the short side's direction has at least MIN_ACROSS cells
        # (not by the width of a narrow face, a fillet: lines along its length would end on its
        # neighbours' edges as extra trim points, fans of thin triangles there)
        split_u, split_v = np.empty(len(us) - 1, dtype=np.bool_), np.empty(len(vs) - 1, dtype=np.bool_)
        long = np.empty(dev.shape, dtype=np.bool_)
        args = (dev, diag, diag_max, side_u, side_v, near, interior, polys is not None, float(tolerance),
                float(max_edge), asp, MIN_ACROSS, LOCAL_FIX, long)
        go, bi, bj = refine_round_kernel(0, *args, _NO_I, _NO_I, _NO_B, _NO_B, split_u, split_v)
        if round_ == 0:      # for _worst_cell_ratio of the same grid
            cache.checked = (us, vs, tolerance, float(dev.max(initial=0.0)), float(diag.max(initial=0.0)), polys)
        if not go:
            break
        cu, cv = np.empty(len(bi), dtype=np.bool_), np.empty(len(bi), dtype=np.bool_)
        if len(bi):         # the bad cells' side bulges (`_side_bulge`)
            cell_surface_kernel(2, *cache._surf, us, vs, bi, bj, _NO_B, _BARY, _NO_UV, _NO_P, 0.0, _NO_F, cu, cv,
                                _NO_D)
        if not refine_round_kernel(1, *args, bi, bj, cu, cv, split_u, split_v)[0]:
            break
        us = unique_values(np.concatenate((us, (0.5 * (us[:-1] + us[1:]))[split_u])))
        vs = unique_values(np.concatenate((vs, (0.5 * (vs[:-1] + vs[1:]))[split_v])))
        if (len(us) - 1) * (len(vs) - 1) > MAX_CELLS:
            raise _too_many_cells(face, us, vs, tolerance, max_edge)
    return us, vs


def _side_bulge(surface, us, vs, ki, kj) -> tuple[np.ndarray, np.ndarray]:
    """Per cell (ki, kj): how far its u sides and its v sides bulge from their chords (the larger of
    the two opposite sides, at the side's parameter midpoint). The numpy reference of what
    `cell_surface_kernel` (op 2) computes for refine_cells' bad cells."""
    u0, u1, v0, v1 = us[ki], us[ki + 1], vs[kj], vs[kj + 1]
    um, vm = 0.5 * (u0 + u1), 0.5 * (v0 + v1)
    uv = np.stack([np.column_stack([u0, v0]), np.column_stack([u1, v0]), np.column_stack([u1, v1]),
                   np.column_stack([u0, v1]), np.column_stack([um, v0]), np.column_stack([um, v1]),
                   np.column_stack([u0, vm]), np.column_stack([u1, vm])], axis=1)
    p = surface.evaluate(uv.reshape(-1, 2)).reshape(-1, 8, 3)
    mids = np.stack([0.5 * (p[:, 0] + p[:, 1]), 0.5 * (p[:, 3] + p[:, 2]), 0.5 * (p[:, 0] + p[:, 3]),
                     0.5 * (p[:, 1] + p[:, 2])], axis=1)
    d = surface_distance(surface, uv[:, 4:].reshape(-1, 2), mids.reshape(-1, 3), steps=1).reshape(-1, 4)
    return np.maximum(d[:, 0], d[:, 1]), np.maximum(d[:, 2], d[:, 3])


def _cell_split(surface, us, vs, ki, kj, tolerance: float | None = None, prefer_main: bool | None = None,
                full: bool = True):
    """Diagonal of cells (ki, kj) (True: (i,j)-(i+1,j+1)), the deviation bound and the cell's lengths.

    Returns (main, dev, diag, diag_max, side_u, side_v); only (main,) with ``full=False``.

    With `tolerance` None, each cell takes the diagonal that best fits the surface
    (the paper). Otherwise every cell takes the face's preferred diagonal
    (`prefer_main`, default: the one that fits better in total) and only cells
    where it would use more than half the tolerance and the other fits better
    switch: alternating diagonals on a nearly flat panel show in the reflection
    lines (the paper's Fig. 2 b), one direction throughout does not.
    """
    u0, u1, v0, v1 = us[ki], us[ki + 1], vs[kj], vs[kj + 1]
    uv = np.stack([np.column_stack([u0, v0]), np.column_stack([u1, v0]), np.column_stack([u1, v1]),
                   np.column_stack([u0, v1]), np.column_stack([0.5 * (u0 + u1), 0.5 * (v0 + v1)])], axis=1)
    p = surface.evaluate(uv.reshape(-1, 2)).reshape(-1, 5, 3)
    # distance of each diagonal's midpoint from the surface (to the foot point, not to S(centre):
    # the tangential offset of a non-uniform parameterization is no misfit)
    cuv = np.repeat(uv[:, 4], 2, axis=0)
    mids = np.stack([0.5 * (p[:, 0] + p[:, 2]), 0.5 * (p[:, 1] + p[:, 3])], axis=1).reshape(-1, 3)
    d = surface_distance(surface, cuv, mids, steps=1).reshape(-1, 2)
    d_main, d_anti = d[:, 0], d[:, 1]
    if tolerance is None:
        main = d_main <= d_anti
    else:
        pref = bool(d_main.sum() <= d_anti.sum()) if prefer_main is None else bool(prefer_main)
        d_pref, d_other = (d_main, d_anti) if pref else (d_anti, d_main)
        # switch only by a clear margin (where both fit alike, e.g. on a cylinder, a near tie must not
        # flip the direction from cell to cell: the reflection lines would wander), or to keep the
        # tolerance
        switch = (((d_pref > 0.5 * tolerance) & (d_other < 0.8 * d_pref))
                  | ((d_pref > 0.9 * tolerance) & (d_other < 0.98 * d_pref)))
        main = np.where(switch, not pref, pref)
    if not full:
        return (main,)
    # deviation at the sample points of the chosen split's two triangles
    t = np.where(main[:, None, None], np.array([[0, 1, 2], [0, 2, 3]])[None], np.array([[0, 1, 3], [1, 2, 3]])[None])
    rows = np.arange(len(ki))[:, None, None]
    tuv = np.einsum("bk,nskd->nsbd", _BARY, uv[rows, t])      # (k, 2, b, 2)
    tx = np.einsum("bk,nskd->nsbd", _BARY, p[rows, t])        # (k, 2, b, 3)
    dev = surface_distance(surface, tuv.reshape(-1, 2), tx.reshape(-1, 3)).reshape(len(ki), -1).max(axis=1)
    return (main, dev) + _cell_lengths(p, main)


_LEN_A, _LEN_B = np.array([0, 1, 0, 3, 0, 1]), np.array([2, 3, 1, 2, 3, 2])   # corners of the 2 diagonals, 4 sides


def _cell_lengths(p: np.ndarray, main: np.ndarray) -> tuple[np.ndarray, ...]:
    """Of cells with corners `p` (k, 4, 3): the split's diagonal, the longer diagonal, the longer u and v sides."""
    # the six lengths in one pass, as np.linalg.norm(..., axis=1) computes each: sqrt of the summed squares
    q = p[:, _LEN_B] - p[:, _LEN_A]
    n = np.sqrt(np.add.reduce(q * q, axis=2))
    d02, d13 = n[:, 0], n[:, 1]
    diag = np.where(main, d02, d13)
    diag_max = np.maximum(d02, d13)
    side_u = np.maximum(n[:, 2], n[:, 3])
    side_v = np.maximum(n[:, 4], n[:, 5])
    return diag, diag_max, side_u, side_v


def _diagonal_fits(surface, us, vs) -> np.ndarray:
    """Per grid cell (ki, kj = meshgrid(..., indexing="ij"), raveled), the distance of its two diagonals'
    midpoints from the surface, (n_cells, 2): (i,j)-(i+1,j+1) and (i+1,j)-(i,j+1). A cell's numbers are
    those `_cell_split` computes for it (the same points, the same per-point kernels)."""
    ki, kj = np.meshgrid(np.arange(len(us) - 1), np.arange(len(vs) - 1), indexing="ij")
    u0, u1 = us[ki.ravel()], us[ki.ravel() + 1]
    v0, v1 = vs[kj.ravel()], vs[kj.ravel() + 1]
    uv = np.stack([np.column_stack([u0, v0]), np.column_stack([u1, v0]), np.column_stack([u1, v1]),
                   np.column_stack([u0, v1]), np.column_stack([0.5 * (u0 + u1), 0.5 * (v0 + v1)])], axis=1)
    p = surface.evaluate(uv.reshape(-1, 2)).reshape(-1, 5, 3)
    cuv = np.repeat(uv[:, 4], 2, axis=0)
    mids = np.stack([0.5 * (p[:, 0] + p[:, 2]), 0.5 * (p[:, 1] + p[:, 3])], axis=1).reshape(-1, 3)
    return surface_distance(surface, cuv, mids, steps=1).reshape(-1, 2)


def _prefer_main(surface, us, vs, fits: np.ndarray | None = None) -> bool:
    """Whether the diagonal (i,j)-(i+1,j+1) fits the face's grid cells better in total (`fits`: the
    cells' `_diagonal_fits` when known)."""
    d = (_diagonal_fits(surface, us, vs) if fits is None else fits).sum(axis=0)
    return bool(d[0] <= d[1])


def _split_from_fits(d: np.ndarray, tolerance: float | None, prefer_main: bool | None) -> np.ndarray:
    """`_cell_split(..., full=False)` of cells whose `_diagonal_fits` are `d` (k, 2)."""
    d_main, d_anti = d[:, 0], d[:, 1]
    if tolerance is None:
        return d_main <= d_anti
    pref = bool(d_main.sum() <= d_anti.sum()) if prefer_main is None else bool(prefer_main)
    d_pref, d_other = (d_main, d_anti) if pref else (d_anti, d_main)
    switch = (((d_pref > 0.5 * tolerance) & (d_other < 0.8 * d_pref))
              | ((d_pref > 0.9 * tolerance) & (d_other < 0.98 * d_pref)))
    return np.where(switch, not pref, pref)


def _cell_deviation(surface, us, vs, tolerance=None, cache=None, exact: bool = True):
    """Per cell: deviation bound of its better split, that diagonal's length, the longer diagonal,
    longest u side, longest v side. With a `_CellCache` (and a tolerance), what an earlier call
    computed for the same cell is taken from it (the same numbers); exact=False: deviations at most
    the tolerance may come as upper bounds at most the tolerance (`_CellCache.deviation`)."""
    if cache is not None and tolerance is not None:
        return cache.deviation(us, vs, tolerance, exact)
    ki, kj = np.meshgrid(np.arange(len(us) - 1), np.arange(len(vs) - 1), indexing="ij")
    pm = None if tolerance is None else _prefer_main(surface, us, vs)
    out = _cell_split(surface, us, vs, ki.ravel(), kj.ravel(), tolerance, pm)[1:]
    return tuple(a.reshape(len(us) - 1, len(vs) - 1) for a in out)


class _CellCache:
    """`_cell_deviation` of one face's grids, each cell's surface work done once.

    The refinement rounds and the two placements of `face_domain_values` check grids that share most
    of their cells. Per cell (keyed by its four parameter values) the cache keeps the surface points
    and diagonal-midpoint distances (`_prefer_main`, the first half of `_cell_split`) and the deviation
    of each split as far as it was needed; a cell's numbers do not depend on the other cells, so the
    result is the uncached one.
    """

    def __init__(self, surface):
        self.surface = surface
        self._surf = (surface.degree_u, surface.degree_v, read_only(surface.knots_u), read_only(surface.knots_v),
                      _homogeneous(surface.control_points, surface.weights), surface.weights is not None)
        # per direction the interval ids (`_line_kernels._interval_ids`: (x0, x1) -> id, a hash table of keys
        # (cap, 2) and entries (cap, 2) = (id, hash)), the ids given so far
        # (the empty arrays are shared: a kernel that adds to an array returns a new one, nid is written)
        self._hk = [_NO_D, _NO_D]
        self._he = [_NO_IDS2, _NO_IDS2]
        self._nid = np.zeros(2, dtype=np.int64)
        self._table = _NO_TABLE             # (u id, v id) -> row (-1: not yet)
        self.n = 0                          # rows in use of the buffers below (capacity doubles)
        self._uv = _NO_UV
        self._p = _NO_P
        self._d = _NO_D                     # distances of the two diagonals' midpoints
        self._dev = _NO_D                   # deviation of the main / anti split (NaN: not yet)
        self._bound = _NO_D                 # an upper bound of it (the screen of `deviation(exact=False)`)
        self._lin = self._bilinear(surface)
        self._loops = None                  # (face, PolygonIndex of its `_loop_polys`)
        self._index = None                  # (polygons, their PolygonIndex)
        #: refine_cells' first grid: (us, vs, tolerance, the largest deviation and diagonal (masked by the trim,
        #: as np.max(..., initial=0.0)), index)
        self.checked = None
        self._known = []                    # (us, vs, rows) of the grids refine_cells returned checked

    @staticmethod
    def _bilinear(surface) -> np.ndarray:
        """(e, noise) for a polynomial patch of degree 1 x 1 and one span (a plane, or a twisted bilinear
        patch), else (-1, 0): a bound of the start distance |S(uv) - x| of every sample of a split cell
        of extents du x dv is e du dv + noise (`cell_deviation_kernel` uses it where only "within the
        screen" counts).

        The sample is x = sum b_k S(uv_k) over a triangle's corners, uv = sum b_k uv_k; on the bilinear
        S = P00 + s (P10 - P00) + t (P01 - P00) + s t E (s, t the patch's normalised parameters, E = P11 -
        P10 - P01 + P00) S(uv) - x = -E sum b_k (s_k - s)(t_k - t), at most |E| ds dt, so e = |E| /
        (span_u span_v) (x (1 + 1e-9) for the extents' rounding); noise: 4 x the rounding bound of a
        computed point of `IsoLines.straight_bound` (the corner points, the sample, its surface point),
        plus the surface's move over the rounding of the sample's parameters. An argued bound, as that
        one.

        `_bilinear_numpy`'s numbers (the same operations on the twelve coordinates as Python floats, the
        sums of three left to right, as numpy's sum and dot of three values add them) at a fraction of its
        cost (a plane per face of a CAD model, ~15 us each)."""
        s = surface
        cp = s.control_points
        if not (s.degree_u == 1 and s.degree_v == 1 and cp.shape[:2] == (2, 2) and s.weights is None):
            return np.array([-1.0, 0.0])
        (p00, p01), (p10, p11) = cp.tolist()
        if not all(map(math.isfinite, p00 + p01 + p10 + p11)):
            return np.array([-1.0, 0.0])        # (big not finite)
        big = max(map(abs, p00 + p01 + p10 + p11))
        ev = [p11[k] - p10[k] - p01[k] + p00[k] for k in range(3)]
        (u0, u1), (v0, v1) = s.domain
        area = (u1 - u0) * (v1 - v0)
        du, dv = u1 - u0, v1 - v0
        if area == 0.0 or du == 0.0 or dv == 0.0:
            return np.array([-1.0, 0.0])        # (e or par not finite)
        e = math.sqrt((ev[0] * ev[0] + ev[1] * ev[1]) + ev[2] * ev[2]) / area * (1.0 + 1e-9)
        eps = _EPS
        d_u = max(_norm3(p00, p10), _norm3(p01, p11)) / du
        d_v = max(_norm3(p00, p01), _norm3(p10, p11)) / dv
        par = 4.0 * eps * (d_u * max(abs(u0), abs(u1)) + d_v * max(abs(v0), abs(v1)))
        if not (math.isfinite(e) and math.isfinite(par)):
            return np.array([-1.0, 0.0])
        delta = 64.0 * 16 * eps * 2.0 * big
        return np.array([e, 4.0 * delta + par])

    @staticmethod
    def _bilinear_numpy(surface) -> np.ndarray:
        """`_bilinear` in numpy (the reference)."""
        s = surface
        cp = s.control_points
        if not (s.degree_u == 1 and s.degree_v == 1 and cp.shape[:2] == (2, 2) and s.weights is None):
            return np.array([-1.0, 0.0])
        big = float(np.abs(cp).max(initial=0.0))
        e = cp[1, 1] - cp[1, 0] - cp[0, 1] + cp[0, 0]
        (u0, u1), (v0, v1) = s.domain
        e = float(np.sqrt(e @ e)) / ((u1 - u0) * (v1 - v0)) * (1.0 + 1e-9)
        # the sample's parameters are rounded (an ulp or two of |u|, |v|): the surface moves by at most
        # its speed (the net's largest difference / span) times that
        eps = np.finfo(np.float64).eps
        d_u = float(np.sqrt(np.sum((cp[1] - cp[0]) ** 2, axis=-1)).max()) / (u1 - u0)
        d_v = float(np.sqrt(np.sum((cp[:, 1] - cp[:, 0]) ** 2, axis=-1)).max()) / (v1 - v0)
        par = 4.0 * eps * (d_u * max(abs(u0), abs(u1)) + d_v * max(abs(v0), abs(v1)))
        if not (np.isfinite(big) and np.isfinite(e) and np.isfinite(par)):
            return np.array([-1.0, 0.0])
        delta = 64.0 * 16 * eps * 2.0 * big
        return np.array([e, 4.0 * delta + par])

    def loop_index(self, face):
        """`PolygonIndex` of the face's `_loop_polys` (computed once: the face of this cache)."""
        if self._loops is None or self._loops[0] is not face:
            self._loops = (face, PolygonIndex(_loop_polys(face)))
        return self._loops[1]

    def seed(self, face, polys):
        """Take `polys` (the face's `_loop_polys`) as both the loop index and the polygon index."""
        index = PolygonIndex(polys)
        self._loops = (face, index)
        self._index = (polys, index)

    def polygon_index(self, polys):
        """`PolygonIndex` of the polygons `polys` (the same list object asked again: built once)."""
        if isinstance(polys, PolygonIndex):
            return polys
        if self._index is None or self._index[0] is not polys:
            self._index = (polys, PolygonIndex(polys))
        return self._index[1]

    uv = property(lambda self: self._uv[:self.n])
    p = property(lambda self: self._p[:self.n])
    d = property(lambda self: self._d[:self.n])
    dev = property(lambda self: self._dev[:self.n])
    bound = property(lambda self: self._bound[:self.n])

    def _state(self) -> tuple:
        """The interval ids and the table, as the compiled kernels take them."""
        return self._hk[0], self._he[0], self._hk[1], self._he[1], self._nid, self._table

    def _buffers(self) -> tuple:
        return self._uv, self._p, self._d, self._dev, self._bound

    def _take(self, out):
        """The cache's arrays (hk_u, he_u, hk_v, he_v, table, uv, p, d, dev, bound, n) a kernel returned."""
        (self._hk[0], self._he[0], self._hk[1], self._he[1], self._table, self._uv, self._p, self._d, self._dev,
         self._bound, self.n) = out
        self.n = int(self.n)

    def remember(self, us, vs, rows):
        """The rows of the grid (us, vs) (these array objects), for `fits` (the last two grids)."""
        self._known = [(us, vs, rows)] + self._known[:1]

    def _cells(self, us, vs):
        """Rows of the grid's cells (computing the new ones' points and midpoint distances), in
        `_cell_split`'s order (ki, kj = meshgrid(..., indexing="ij"), raveled)."""
        us = np.ascontiguousarray(us, dtype=np.float64)
        vs = np.ascontiguousarray(vs, dtype=np.float64)
        # the interval ids, the rows, the new cells' points and distances (`cell_surface_kernel` op 0) in one
        # compiled call
        out = grid_cells_kernel(*self._state(), *self._surf, us, vs, _BARY, *self._buffers(), self.n)
        self._take(out[:10] + out[11:])
        return out[10]

    def fits(self, us, vs) -> np.ndarray:
        """`_diagonal_fits(surface, us, vs)` from the cache (the same numbers; the new cells computed)."""
        for ku, kv, rows in self._known:        # a grid refine_cells returned: its rows are known
            if ku is us and kv is vs:
                return self._d[rows]
        rows = self._cells(us, vs)      # first: new cells may move the buffers
        return self._d[rows]

    def deviation(self, us, vs, tolerance, exact: bool = True):
        """`_cell_deviation`; with exact=False a cell whose deviation is certainly at most the tolerance may
        get an upper bound of it, at most the tolerance, instead (`cell_surface_kernel`'s screen): where
        only "over the tolerance or not" and the values over it count (refine_cells, _worst_cell_ratio)."""
        rows = self._cells(us, vs)
        k = len(rows)
        main = np.empty(k, dtype=np.bool_)
        out = np.empty((5, k))
        dev, diag, diag_max, side_u, side_v = out
        # `cell_check_kernel`, then the deviations it left NaN (`cell_surface_kernel` op 1), kept in the cache
        cell_deviation_kernel(*self._surf, self._d, self._p, self._uv, self._dev, self._bound, rows, float(tolerance),
                              bool(exact), _BARY, main, dev, diag, diag_max, side_u, side_v, self._lin)
        return tuple(out.reshape(5, len(us) - 1, len(vs) - 1))


@dataclass(eq=False)
class FaceMesh:
    """One face's triangulation before assembly.

    Attributes
    ----------
    uv : (n, 2) float64
    xyz : (n, 3) float64
    triangles : (m, 3) int64
        Oriented to the face's outward normal.
    vid : (n,) int64
        Global vertex id of trim points in conforming mode (-1 for face-interior vertices).
    quads : (q, 2) int64
        Pairs of triangles forming untouched grid cells.
    us, vs : float64
        The domain values.
    n_crossed_cells : int
    tri_dev : (m,) float64
        Per triangle, the largest |S(uv) - x| at its centroid and edge midpoints
        (x on the triangle, uv interpolated): a sampled bound of its deviation. Computed when first
        read (`tessellate_shell` in conforming mode with seam reduction does not read it).
    removed_loop_points : int
        Trim-polygon points cut out with the small sub-loops of a self-crossing trim (repair).
    """

    uv: np.ndarray
    xyz: np.ndarray
    triangles: np.ndarray
    vid: np.ndarray
    quads: np.ndarray
    us: np.ndarray
    vs: np.ndarray
    n_crossed_cells: int
    _tri_dev: np.ndarray | None
    removed_loop_points: int = 0
    #: the arguments of `_face_tri_dev` while `_tri_dev` is not computed yet
    _dev_task: tuple | None = field(default=None, repr=False)

    @property
    def tri_dev(self) -> np.ndarray:
        if self._tri_dev is None:
            self._tri_dev = _face_tri_dev(*self._dev_task)
            self._dev_task = None
        return self._tri_dev

    def to_trimesh(self) -> TriMesh:
        return TriMesh(self.xyz, self.triangles, uv=self.uv)


def _point_polyline_distance(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Distance of every point p (n, 3) to the closed polyline q (k, 3), vectorized."""
    a, b = q, np.roll(q, -1, axis=0)
    d = b - a
    den = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    t = np.clip(np.einsum("nij,ij->ni", p[:, None, :] - a[None], d) / den, 0.0, 1.0)
    foot = a[None] + t[..., None] * d[None]
    return np.linalg.norm(p[:, None, :] - foot, axis=2).min(axis=1)


def _check_cut_loop(face: TrimmedFace, poly: np.ndarray, xyz: np.ndarray, seg: np.ndarray,
                    sel: np.ndarray, tolerance: float) -> None:
    """Raise TrimLoopError when the sub-loops cut out of a self-crossing trim polygon are not negligible.

    Cutting a sub-loop is a repair only while every cut point stays within `tolerance`
    (in 3D) of the kept trim: then the triangles still cover the face within the
    tolerance. A sub-loop reaching further is a region the face's boundary really
    encloses twice or inside out (the boundary edges themselves cross on the
    surface); meshing without it would leave part of the face uncovered, silently.
    """
    cut = np.setdiff1d(np.arange(len(poly)), sel)
    if not len(cut) or len(sel) < 2:
        return
    dist = _point_polyline_distance(xyz[cut], xyz[sel])
    worst = int(np.argmax(dist))
    if dist[worst] <= tolerance:
        return
    from ..geom.predicates import polyline_self_intersections

    x = polyline_self_intersections(poly, closed=True)

    def edge(k):
        return f"edge {int(k)}" if k >= 0 else f"segment {-1 - int(k)}"

    n = len(poly)
    pairs = sorted({tuple(sorted((edge(seg[int(r[0]) % n]), edge(seg[int(r[1]) % n])))) for r in x})
    where = ""
    if len(x):
        i, j = int(x[0][0]), int(x[0][1])
        a, b = poly[i], poly[(i + 1) % n]
        c, d = poly[j], poly[(j + 1) % n]
        m = np.array([[b[0] - a[0], c[0] - d[0]], [b[1] - a[1], c[1] - d[1]]])
        try:
            t = np.linalg.solve(m, c - a)[0]
            p = a + t * (b - a)
            where = f", first at (u, v) = ({p[0]:.6g}, {p[1]:.6g})"
        except np.linalg.LinAlgError:
            pass
    between = "; ".join(f"{p} and {q}" if p != q else p for p, q in pairs) or "its boundary curves"
    raise TrimLoopError(
        f"{face.name or 'face'}: trim loop crosses itself on the surface ({len(x)} crossing(s) of "
        f"{between}{where}); the enclosed region is ambiguous and cutting out the smaller sub-loop would "
        f"leave {len(cut)} trim point(s) uncovered, up to {dist[worst]:.3g} from the kept trim "
        f"(at {np.array2string(xyz[cut][worst], precision=4)}; tolerance {tolerance:.3g}): "
        f"the face cannot be repaired")


# the mesh side's own imports (kept here, below the domain values' part of this module)
from ..geom.predicates import _CCW_BOUND  # noqa: E402
from ._mesh_kernels import (cell_main_kernel, deviation_start_bound, face_loops_kernel, lift_kernel,  # noqa: E402
                            trim_loop_kernel)

_NO_IDS = np.zeros(0, dtype=np.int64)


def _face_loops_numpy(face: TrimmedFace, loop_chunks: list, tolerance) -> tuple:
    """`_face_loops` loop by loop (the reference of `face_loops_kernel`, and the path of a loop that
    `remove_polygon_loops` must decide)."""
    polys, xyzs, vids = [], [], []
    removed = 0
    for entries in loop_chunks:
        # each chunk in the loop's direction without its last point (the next chunk's first)
        uv_parts, x_parts, id_parts, seg_ids, counts = [], [], [], [], []
        any_ids = False
        for chunk, ui, ids in entries:
            use = chunk.uses[ui]
            uv, x = chunk.uv[ui], chunk.xyz
            if use.forward:
                uv_parts.append(uv[:-1])
                x_parts.append(x[:-1])
                id_parts.append(None if ids is None else ids[:-1])
            else:
                uv_parts.append(uv[:0:-1])
                x_parts.append(x[:0:-1])
                id_parts.append(None if ids is None else ids[:0:-1])
            any_ids |= ids is not None
            eid = use.pcurve.edge_id
            seg_ids.append(-1 - use.segment if eid is None else int(eid))
            counts.append(len(uv) - 1)
        poly = np.concatenate(uv_parts)
        xyz = np.concatenate(x_parts)
        if any_ids:
            vid = np.concatenate([np.full(c, -1, dtype=np.int64) if i is None else i
                                  for i, c in zip(id_parts, counts)])
        else:
            vid = _NO_IDS
        # consecutive duplicates in (u, v) dropped; a certainly simple polygon keeps every point (what
        # `remove_polygon_loops` returns at once then)
        poly, xyz, vid, keep, status = trim_loop_kernel(poly, xyz, vid, np.bool_(any_ids), _CCW_BOUND)
        if status == 0:
            continue
        if status == 1:
            polys.append(poly)
            xyzs.append(xyz)
            vids.append(vid)
            continue
        sel = remove_polygon_loops(poly)
        if tolerance is not None and len(sel) < len(poly):
            seg = np.repeat(np.array(seg_ids, dtype=np.int64), counts)[keep]
            _check_cut_loop(face, poly, xyz, seg, sel, float(tolerance))
        removed += len(poly) - len(sel)
        polys.append(poly[sel])
        xyzs.append(xyz[sel])
        vids.append(vid[sel])
    if not polys:
        return polys, None, None, removed, None
    return polys, np.concatenate(xyzs), np.concatenate(vids), removed, None


from ._mesh_kernels import curved_kernel  # noqa: E402
from .slivers import collapse_face_slivers  # noqa: E402


def _face_loops(face: TrimmedFace, loop_chunks: list, tolerance) -> tuple:
    """The trim polygons of a face from its loops' chunks (`mesh_face_from_chunks`): (polygons (list of
    (k, 2)), their points' xyz and vertex ids concatenated, points cut out by `remove_polygon_loops`,
    (pts, lens) the polygons packed or None). One compiled pass (`face_loops_kernel`) where every loop is
    certainly simple or has no area; else loop by loop (`_face_loops_numpy`)."""
    # per chunk 2 * its number of points + 1 if it runs forward, then the loops' first chunks
    uvs, xs, idl, meta, loop_start = [], [], [], [], [0]
    n_ids = 0
    for entries in loop_chunks:
        if not entries:
            return _face_loops_numpy(face, loop_chunks, tolerance)
        for chunk, ui, ids in entries:
            uv = chunk.uv[ui]
            uvs.append(uv)
            xs.append(chunk.xyz)
            idl.append(ids)
            n_ids += ids is not None
            pc = chunk.uses[ui].pcurve
            meta.append(2 * len(uv) + (pc.t0 < pc.t1))
        loop_start.append(len(uvs))
    if not uvs:         # no loop
        return _face_loops_numpy(face, loop_chunks, tolerance)
    if n_ids == len(idl):
        ids = np.concatenate(idl)
    elif n_ids == 0:
        ids = np.full(sum(m >> 1 for m in meta), -1, dtype=np.int64)
    else:
        ids = np.concatenate([np.full(m >> 1, -1, dtype=np.int64) if i is None else i for i, m in zip(idl, meta)])
    status, pts, x, vid, lens = face_loops_kernel(
        np.concatenate(uvs), np.concatenate(xs), ids if ids.dtype == np.int64 else ids.astype(np.int64),
        np.array(meta + loop_start, dtype=np.int64), np.int64(len(meta)), _CCW_BOUND)
    if status == 2:
        return _face_loops_numpy(face, loop_chunks, tolerance)
    polys, o = [], 0
    for k in lens.tolist():
        polys.append(pts[o:o + k])
        o += k
    return polys, x, vid, 0, (pts, lens)


def mesh_face_from_chunks(face: TrimmedFace, us: np.ndarray, vs: np.ndarray, loop_chunks: list, *,
                          tolerance: float | None = None, max_edge: float = np.inf,
                          slivers: bool = True, fits: np.ndarray | None = None) -> FaceMesh:
    """Triangulate a face whose loops are given as discretized chunks.

    Parameters
    ----------
    face : TrimmedFace
    us, vs : domain values of the face
    loop_chunks : list (per loop) of list of (Chunk, use index, ids or None)
        In segment order; ``ids`` (k,) global vertex ids of the chunk's points or None.
    tolerance : float or None
        Untouched cells take one diagonal direction, switching only where it
        costs more than half the tolerance (see `_cell_split`); None: the
        paper's best-fitting diagonal per cell.
    max_edge : float
        Limit for edges the sliver reduction creates.
    slivers : bool
        With a tolerance: collapse grid nodes that make thin triangles at the
        trim into the trim vertex (`trimsurf.tessellate.slivers`, paper Sec. 5.1).
    fits : (n_cells, 2) float64 or None
        The grid's `_diagonal_fits` when known (`face_domain_values(..., with_fits=True)`); None:
        computed here.
    """
    polys, trim_xyz, trim_vid, removed, packed = _face_loops(face, loop_chunks, tolerance)
    if not polys:
        raise TrimLoopError(f"{face.name or 'face'}: no trim loop with area")
    s = face.surface

    tol = None if tolerance is None else float(tolerance)
    # every cell's diagonal fits once: the preferred direction and each triangulation's cell splits
    # (the extra-point rounds re-triangulate) read them
    if fits is None or len(fits) != (len(us) - 1) * (len(vs) - 1):
        fits = _diagonal_fits(s, us, vs)
    prefer = None if tol is None else _prefer_main(s, us, vs, fits)
    # every cell's diagonal (`_split_from_fits` is elementwise with the preference given): what a split
    # callback would answer for the cells the triangulation keeps
    cell_main = _cell_main(fits, tol, prefer)
    dt = triangulate_domain(us, vs, polys, cell_main=cell_main, tie_main=prefer, packed=packed)
    known = _TriangleDeviations(s)
    # a plane: a triangle with its corners on it lies in it, its deviation is its corners' offsets at most
    # (a trim point off the surface), which the interior points of the rounds below never remove: skip them
    plane_delta = _plane_offset(s, tol)
    dev = None                  # the rounds compute deviations of the triangles that may be bad only
    if tol is not None and plane_delta is None:
        # the CDT of a crossed cell cuts it other than the cell splits refine_cells checked: where one
        # of its triangles leaves the tolerance, its centroid joins the CDT (an interior point, so the
        # trim polygons, shared with the neighbours, stay as they are)
        extra = np.zeros((0, 2))
        # a trim point off the surface (the mean of two faces' curves, a gap in the model) makes its
        # triangles deviate by its own offset, which no interior point can remove (the surface at the
        # trim points and at the other vertices in one evaluation: per point the same numbers as `lift`);
        # only a triangle whose samples' first distances (an upper bound of its deviation) exceed the
        # tolerance may be bad: the deviation of those alone (the others' is computed when read)
        xyz, trim_off, maybe = _lift_points(s, dt.uv, trim_xyz, dt.triangles, tol, known)
        for it in range(4):
            if it:
                maybe = np.flatnonzero(~(known.start_bound(dt.uv, xyz, dt.triangles) <= tol))
            if not len(maybe):
                break
            tm = dt.triangles[maybe]
            dev_m = known.deviation(dt.uv, xyz, tm)
            off = np.zeros(len(dt.uv))
            off[:dt.n_trim] = trim_off
            bad = np.zeros(len(dt.triangles), dtype=bool)
            bad[maybe] = (dev_m > tol) & (dev_m > off[tm].max(axis=1) + 0.05 * tol)
            if not bad.any():
                break
            extra = np.concatenate([extra, dt.uv[dt.triangles[bad]].mean(axis=1)])
            n_before = len(dt.uv)
            dt = triangulate_domain(us, vs, polys, cell_main=cell_main, extra=extra, tie_main=prefer, packed=packed)
            xyz = _lift_points(s, dt.uv, trim_xyz)[0]
            if len(dt.uv) == n_before:
                break
    else:
        xyz = _lift_points(s, dt.uv, trim_xyz)[0]
    n_trim = dt.n_trim
    vid = np.full(len(dt.uv), -1, dtype=np.int64)
    vid[:n_trim] = trim_vid
    quads = dt.quads
    kept = None
    if tol is not None and slivers:
        # boundary-only reduction of thin triangles (grid nodes next to the trim); trim points stay (those of
        # the trim and Triangle's: grid_node < 0); kept None where no triangle changed (the identity, which
        # leaves the quads and `_face_tri_dev`'s numbers as they are)
        tris, kept = collapse_face_slivers(s, dt.uv, xyz, dt.triangles, not face.same_sense, dt.grid_node, n_trim,
                                           tolerance=tol, max_edge=max_edge)
        if kept is not None:
            quads = kept[quads] if len(quads) else quads
            quads = quads[(quads >= 0).all(axis=1)] if len(quads) else quads
    else:
        tris = np.ascontiguousarray(dt.triangles if face.same_sense else dt.triangles[:, ::-1])
    task = None
    if plane_delta is not None:
        # the exact bound: the distance to the plane is affine on a triangle, its largest at a corner (a
        # trim point off the surface, a lifted point on it up to rounding), and the surface lies within
        # delta of the plane
        delta, normal, height = plane_delta
        off = np.abs(xyz @ normal - height)
        tri_dev = off[tris].max(axis=1) + delta if len(tris) else np.zeros(0)
    else:
        # computed when read (FaceMesh.tri_dev): the same numbers
        tri_dev = None
        task = (s, known if dev is None else None, dt.uv, xyz, dt.triangles, dev, kept, tris, face.same_sense)
    return FaceMesh(dt.uv, xyz, tris, vid, quads, us, vs, dt.n_crossed_cells, tri_dev, removed, task)


def _cell_main(fits: np.ndarray, tol: float | None, prefer: bool | None) -> np.ndarray:
    """`_split_from_fits(fits, tol, prefer)` (prefer given where tol is) in one compiled pass
    (`cell_main_kernel`); `_split_from_fits` is its reference."""
    d = fits if fits.dtype == np.float64 and fits.flags.c_contiguous and fits.ndim == 2 else \
        np.ascontiguousarray(fits, dtype=np.float64).reshape(-1, 2)
    if tol is not None and prefer is None:
        return _split_from_fits(fits, tol, prefer)
    return cell_main_kernel(d, np.bool_(tol is not None), 0.0 if tol is None else float(tol), np.bool_(bool(prefer)))


def _lift_points(s, uv, trim_xyz, tris=None, tol=None, known=None):
    """The points of a triangulation whose first len(trim_xyz) vertices are the trim points: (xyz, trim_off,
    maybe), xyz S(uv) with the trim points' rows `trim_xyz`; with `tris` also each trim point's distance
    |S(uv) - trim_xyz| and the triangles whose start bound (`_TriangleDeviations.start_bound`) is not at
    most `tol` (else None, None). One compiled pass (`_mesh_kernels.lift_kernel`); `_lift_points_numpy` is
    its reference, and its path for (u, v) that are not finite."""
    nt = len(trim_xyz)
    if nt > len(uv):
        return _lift_points_numpy(s, uv, trim_xyz, tris, tol, known)
    with_tris = tris is not None
    status, xyz, off, maybe = lift_kernel(
        _BARY, _contiguous(uv, np.float64), _contiguous(trim_xyz, np.float64),
        _contiguous(tris, np.int64) if with_tris else _NO_TRIS, s.degree_u, s.degree_v,
        read_only(s.knots_u), read_only(s.knots_v), _homogeneous(s.control_points, s.weights), s.weights is not None,
        np.bool_(with_tris), float(tol) if with_tris else 0.0)
    if status:
        return _lift_points_numpy(s, uv, trim_xyz, tris, tol, known)
    return (xyz, off, maybe) if with_tris else (xyz, None, None)


_NO_TRIS = np.zeros((0, 3), dtype=np.int64)


def _contiguous(a: np.ndarray, dtype) -> np.ndarray:
    """np.ascontiguousarray(a, dtype=dtype) without its copy of an array the compiled kernels returned (whose
    dtype is another instance, equal to `dtype`)."""
    return a if a.dtype == dtype and a.flags.c_contiguous else np.ascontiguousarray(a, dtype=dtype)


def _lift_points_numpy(s, uv, trim_xyz, tris=None, tol=None, known=None):
    """`_lift_points` with `NurbsSurface.evaluate` and `_TriangleDeviations.start_bound` (the reference)."""
    nt = len(trim_xyz)
    if tris is None:
        xyz = np.empty((len(uv), 3))
        xyz[:nt] = trim_xyz
        if len(uv) > nt:
            xyz[nt:] = s.evaluate(uv[nt:])
        return xyz, None, None
    xyz = s.evaluate(uv)
    trim_off = np.linalg.norm(xyz[:nt] - trim_xyz, axis=1)
    xyz[:nt] = trim_xyz
    return xyz, trim_off, np.flatnonzero(~(known.start_bound(uv, xyz, tris) <= tol))


def _face_tri_dev(s, known, uv, xyz, dt_triangles, dev, kept, tris, same_sense) -> np.ndarray:
    """`FaceMesh.tri_dev` of a curved face (`mesh_face_from_chunks`)."""
    # the sampled bound of every triangle in the (u, v) orientation of the triangulation: what the rounds
    # computed is taken over (the triangles the slivers' collapse kept), the rest computed
    if dev is None:
        dev = known.deviation(uv, xyz, dt_triangles)
    if kept is None:
        return dev.copy()
    tri_dev = np.full(len(tris), np.nan)
    src = np.flatnonzero(kept >= 0)
    tri_dev[kept[src]] = dev[src]
    new = np.flatnonzero(np.isnan(tri_dev))
    if len(new):
        t_new = tris[new] if same_sense else tris[new][:, ::-1]
        tri_dev[new] = triangle_deviation(s, uv, xyz, np.ascontiguousarray(t_new))
    return tri_dev


def _plane_offset(surface, tolerance: float | None):
    """(delta, unit normal n, height h) when the surface's control points lie within a negligible delta
    of the plane n . x = h (delta at most 1e-9 of the control net's size and 1e-3 of the tolerance;
    positive weights): the surface, in the convex hull of its control points, lies within delta of the
    plane. None for a curved surface (most at once by `_mesh_kernels.curved_kernel`, for the model's arrays,
    which cannot change; `_plane_offset_numpy` is the reference)."""
    cp, w = surface.control_points, surface.weights
    if (not cp.flags.writeable and (w is None or not w.flags.writeable) and cp.ndim == 3 and cp.shape[2] == 3
            and curved_kernel(cp, _NO_W if w is None else w, w is not None, tolerance is not None,
                              0.0 if tolerance is None else float(tolerance))):
        return None
    return _plane_offset_numpy(surface, tolerance)


_NO_W = read_only(np.ones((1, 1)))


def _plane_offset_numpy(surface, tolerance: float | None):
    """`_plane_offset` in numpy: its reference, and its decision where `curved_kernel` cannot settle it."""
    w = surface.weights
    if w is not None and not w.min() > 0:
        return None
    cp = surface.control_points
    (a0, a1, a2), (b0, b1, b2) = (cp[-1, -1] - cp[0, 0]).tolist(), (cp[-1, 0] - cp[0, -1]).tolist()
    # the normal of the control net's diagonals (else, a degenerate net, of the best-fitting plane); the
    # plane with this normal halfway between the extreme control points
    n = (a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0)
    ln2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2]
    s2 = max(a0 * a0 + a1 * a1 + a2 * a2, b0 * b0 + b1 * b1 + b2 * b2)
    p = cp.reshape(-1, 3)
    if ln2 > 1e-12 * s2 * s2:
        size = float(np.sqrt(s2))
        normal = np.array(n) / np.sqrt(ln2)
    else:
        q = p - p.mean(axis=0)
        size = float(np.abs(q).max())
        if not size > 0:
            return None
        normal = np.linalg.svd(q, full_matrices=False)[2][-1]
    dist = p @ normal
    lo, hi = float(dist.min()), float(dist.max())
    delta = 0.5 * (hi - lo)
    limit = 1e-9 * size if tolerance is None else min(1e-9 * size, 1e-3 * tolerance)
    return (delta, normal, 0.5 * (lo + hi)) if delta <= limit else None


class _TriangleDeviations:
    """`triangle_deviation` of one face's triangulations, each triangle computed once: the rounds that
    add interior points re-triangulate the face but keep most triangles. A triangle is known by its
    corners' (u, v) and points in order; its deviation depends on nothing else. The first call only
    keeps its arrays (most faces need one round): their keys are made when a second call comes."""

    def __init__(self, surface):
        self.surface = surface
        self.values: dict = {}
        self._pending = None

    @staticmethod
    def _keys(uv, xyz, triangles) -> list:
        m = len(triangles)
        keys = np.ascontiguousarray(np.concatenate([uv[triangles].reshape(m, 6), xyz[triangles].reshape(m, 9)],
                                                   axis=1))
        return keys.view(np.dtype((np.void, 15 * 8))).ravel().tolist()

    def start_bound(self, uv: np.ndarray, xyz: np.ndarray, triangles: np.ndarray) -> np.ndarray:
        """Per triangle an upper bound of its `deviation` (`_mesh_kernels.deviation_start_bound`; NaN where
        the deviation is NaN)."""
        if not len(triangles):
            return np.zeros(0)
        s = self.surface
        return deviation_start_bound(_BARY, np.ascontiguousarray(uv, dtype=np.float64),
                                     np.ascontiguousarray(xyz, dtype=np.float64),
                                     np.ascontiguousarray(triangles, dtype=np.int64), s.degree_u, s.degree_v,
                                     read_only(s.knots_u), read_only(s.knots_v),
                                     _homogeneous(s.control_points, s.weights), s.weights is not None)

    def deviation(self, uv: np.ndarray, xyz: np.ndarray, triangles: np.ndarray) -> np.ndarray:
        m = len(triangles)
        if not m:
            return np.zeros(0)
        if not self.values and self._pending is None:
            out = triangle_deviation(self.surface, uv, xyz, triangles)
            self._pending = (uv, xyz, triangles, out)
            return out
        if self._pending is not None:
            puv, pxyz, ptri, pout = self._pending
            self._pending = None
            self.values.update(zip(self._keys(puv, pxyz, ptri), pout.tolist()))
        keys = self._keys(uv, xyz, triangles)
        out = np.array([self.values.get(k, np.nan) for k in keys])
        new = np.flatnonzero(np.isnan(out))
        if len(new):
            out[new] = triangle_deviation(self.surface, uv, xyz, triangles[new])
            self.values.update(zip([keys[i] for i in new], out[new].tolist()))
        return out


def surface_distance(surface, uv: np.ndarray, x: np.ndarray, steps: int = 2) -> np.ndarray:
    """Distance of points x (n, 3) to surface points near them, an upper bound of their distance to the surface.

    Starts from |S(uv) - x| and takes `steps` Gauss-Newton steps of the foot point (clipped to the
    surface domain), keeping the smallest distance met. The plain |S(uv) - x| with uv interpolated
    over a triangle also counts the tangential offset of a non-uniform parameterization (a rational
    arc, a stretched knot span), which is no deviation of the mesh from the surface: on a cylinder
    of rational quadratics it doubles the bound and so the lines.

    Parameters
    ----------
    surface : NurbsSurface
    uv : (n, 2) float64
        Starting parameters.
    x : (n, 3) float64

    Returns
    -------
    (n,) float64
    """
    from ..geom._nurbs_kernels import surface_distance_kernel
    from ..geom.nurbs import _homogeneous, read_only

    uv = read_only(np.asarray(uv, dtype=np.float64).reshape(-1, 2))
    x = read_only(np.asarray(x, dtype=np.float64).reshape(-1, 3))
    s = surface
    best = np.empty(len(uv))
    surface_distance_kernel(s.degree_u, s.degree_v, read_only(s.knots_u), read_only(s.knots_v),
                            _homogeneous(s.control_points, s.weights),
                            s.weights is not None, uv, x, int(steps), best)
    return best


def _surface_distance_numpy(surface, uv: np.ndarray, x: np.ndarray, steps: int = 2) -> np.ndarray:
    """`surface_distance` in numpy (the reference of the compiled kernel, for the tests)."""
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2).copy()
    x = np.asarray(x, dtype=np.float64).reshape(-1, 3)
    (u0, u1), (v0, v1) = surface.domain
    best = None
    for it in range(steps + 1):
        if it < steps:
            d = surface.derivatives(uv, 1)
            p, su, sv = d[0, 0], d[1, 0], d[0, 1]
        else:
            p = surface.evaluate(uv)
        r = x - p
        dist = np.linalg.norm(r, axis=1)
        best = dist if best is None else np.minimum(best, dist)
        if it == steps:
            break
        a = np.einsum("nd,nd->n", su, su)
        b = np.einsum("nd,nd->n", su, sv)
        c = np.einsum("nd,nd->n", sv, sv)
        ru = np.einsum("nd,nd->n", su, r)
        rv = np.einsum("nd,nd->n", sv, r)
        det = a * c - b * b
        ok = np.isfinite(det) & (det > 1e-12 * np.maximum(a * c, 1e-300))
        den = np.where(ok, det, 1.0)
        du = np.where(ok, (c * ru - b * rv) / den, 0.0)
        dv = np.where(ok, (a * rv - b * ru) / den, 0.0)
        uv[:, 0] = np.clip(uv[:, 0] + du, u0, u1)
        uv[:, 1] = np.clip(uv[:, 1] + dv, v0, v1)
    return best


def triangle_deviation(surface, uv: np.ndarray, xyz: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Per triangle, the distance to the surface at the sample points b of `_BARY` (upper bounds by
    `surface_distance`, foot points started at the interpolated uv), shape (m,)."""
    if not len(triangles):
        return np.zeros(0)
    from ._mesh_kernels import deviation_samples

    # the edge midpoints (rows 1-3 of _BARY: edges 01, 12, 20) of two triangles sharing an edge are the
    # same numbers (0.5 a + 0.5 b either way round): each is measured once
    suv, sx, rows = deviation_samples(_BARY, np.ascontiguousarray(uv, dtype=np.float64),
                                      np.ascontiguousarray(xyz, dtype=np.float64),
                                      np.ascontiguousarray(triangles, dtype=np.int64))
    return surface_distance(surface, suv, sx)[rows].max(axis=1)


def _triangle_deviation_numpy(surface, uv: np.ndarray, xyz: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """`triangle_deviation` with numpy's einsum and unique (the reference of `deviation_samples`, for the tests)."""
    if not len(triangles):
        return np.zeros(0)
    m = len(triangles)
    tuv = np.einsum("bk,mkd->mbd", _BARY, uv[triangles])
    txyz = np.einsum("bk,mkd->mbd", _BARY, xyz[triangles])
    t = np.asarray(triangles, dtype=np.int64)
    ea, eb = t, t[:, [1, 2, 0]]
    key = (np.minimum(ea, eb) * (int(t.max()) + 1) + np.maximum(ea, eb)).ravel()
    _, first, inv = np.unique(key, return_index=True, return_inverse=True)
    rest = [0] + list(range(4, len(_BARY)))
    d = surface_distance(surface, np.concatenate([tuv[:, rest].reshape(-1, 2), tuv[:, 1:4].reshape(-1, 2)[first]]),
                         np.concatenate([txyz[:, rest].reshape(-1, 3), txyz[:, 1:4].reshape(-1, 3)[first]]))
    k = m * len(rest)
    return np.maximum(d[:k].reshape(m, -1).max(axis=1), d[k:][inv.ravel()].reshape(m, 3).max(axis=1))


def loose_chunks(face: TrimmedFace, face_index: int, us, vs, *, tolerance: float, max_edge: float,
                 strategy: str, reduce: bool = True) -> list:
    """Every loop segment discretized on its own (one use each): the loose-mode trim polygons."""
    (u0, u1), (v0, v1) = face.surface.domain
    ptol = 1e-7 * min(u1 - u0, v1 - v0)
    out = []
    for li, loop in enumerate(face.loops):
        entries = []
        for si, seg in enumerate(loop.segments):
            use = ChunkUse(face_index, li, si, seg, face.surface, us, vs, ptol)
            entries.append((discretize_chunk([use], tolerance=tolerance, max_edge=max_edge, strategy=strategy,
                                             reduce=reduce), 0, None))
        out.append(entries)
    return out


def _rectangle_face(face: TrimmedFace) -> TrimmedFace:
    """An untrimmed face with its domain rectangle as the loop (so one code path serves both)."""
    from ..model import Loop, NurbsCurve, PCurve

    (u0, u1), (v0, v1) = face.surface.domain
    c = [(u0, v0), (u1, v0), (u1, v1), (u0, v1)]
    segs = tuple(PCurve(NurbsCurve(1, [0.0, 0.0, 1.0, 1.0], np.array([c[i], c[(i + 1) % 4]], dtype=np.float64)),
                        0.0, 1.0) for i in range(4))
    return TrimmedFace(face.surface, (Loop(segs),), face.same_sense, face.name, face.tolerance)


def tessellate_face(face: TrimmedFace, *, tolerance: float, max_edge: float, strategy: str = "equidistributed",
                    reduce: bool = True, repair: bool = True, slivers: bool = True,
                    aspect: float | None = ASPECT) -> TriMesh:
    """Tessellate one trimmed face into a regular mesh whose iso-lines are nearly equidistant in 3D.

    Parameters
    ----------
    face : TrimmedFace
    tolerance : float
        Max. geometric deviation of the mesh from the face (model units), the paper's epsilon.
    max_edge : float
        Max. 3D distance between neighbouring vertices on iso-lines and trims
        (the paper's grid size, model units).
    strategy : {"equidistributed", "bisection", "uniform"}
        How domain values are chosen (`trimsurf.tessellate.domain`); "bisection" is the paper's listing.
    reduce : bool
        Polygon reduction of the trim polygons after the iso-values were inserted.
    repair : bool
        Run `repair_face` first (join / fill loop gaps).
    slivers : bool
        Boundary-only reduction of thin triangles at the trims (`trimsurf.tessellate.slivers`).
    aspect : float or None
        Largest side ratio of a grid cell (`ASPECT`; None or inf: no limit; none on a developable face;
        see `tessellate_shell`).

    Returns
    -------
    TriMesh
        With per-vertex ``uv``; triangles counter-clockwise seen from the face's
        outward normal (``same_sense``).

    Raises
    ------
    InputError
        Bad parameters, or a face repair cannot fix (`TrimLoopError`).

    References
    ----------
    G. Sußner, G. Greiner, R. Grosso, "Generating high quality meshes for
    interactive examination of surface quality on car bodies", Sec. 4-5.1.

    Examples
    --------
    >>> from trimsurf.samples import build_sample
    >>> face = build_sample("fender").faces[0]
    >>> mesh = tessellate_face(face, tolerance=1.0, max_edge=50.0)
    >>> mesh.uv.shape == (mesh.n_vertices, 2) and mesh.n_triangles > 100
    True
    """
    if not isinstance(face, TrimmedFace):
        raise InputError(f"tessellate_face needs a TrimmedFace; got {type(face).__name__}")
    tolerance, max_edge = check_parameters(tolerance, max_edge)
    aspect = check_aspect(aspect)
    if repair:
        rep = repair_face(face, tolerance=tolerance)
        if rep.status == "failed":
            raise TrimLoopError("; ".join(rep.messages))
        face = rep.face
    if not face.loops:
        face = _rectangle_face(face)
    us, vs, fits = face_domain_values(face, tolerance=tolerance, max_edge=max_edge, strategy=strategy,
                                      with_fits=True, aspect=aspect)
    chunks = loose_chunks(face, 0, us, vs, tolerance=tolerance, max_edge=max_edge, strategy=strategy, reduce=reduce)
    return mesh_face_from_chunks(face, us, vs, chunks, tolerance=tolerance, max_edge=max_edge,
                                 slivers=slivers, fits=fits).to_trimesh()
