"""Trimmed faces: a surface, the p-curves of its loops in (u, v), optional 3D edge curves."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import GeometryError, TrimLoopError
from .nurbs import NurbsCurve, NurbsSurface

__all__ = ["PCurve", "Loop", "TrimmedFace"]


@dataclass(frozen=True, slots=True, eq=False)
class PCurve:
    """One segment of a trim loop: a 2D curve p(t) in the face's (u, v) domain.

    Parameters
    ----------
    curve : NurbsCurve
        The 2D curve p(t) in (u, v).
    t0, t1 : float
        The part of `curve` that belongs to the loop, traversed from t0 to t1
        (t0 > t1 means the loop runs against the curve's own direction).
    edge_curve : NurbsCurve or None
        The 3D edge curve b(t) of this segment, sharing the parameter t with
        p(t) ("same parameter", as in Open CASCADE): ideally b(t) = F(p(t)).
        Real data differs by a small gap (the boundary discrepancy).
    edge_id : int
        Index of the shared edge in `Shell.edges`, or -1 when unknown.
    """

    curve: NurbsCurve
    t0: float
    t1: float
    edge_curve: NurbsCurve | None = None
    edge_id: int = -1

    def __post_init__(self) -> None:
        if self.curve.dim != 2:
            raise GeometryError(f"PCurve.curve must be 2D; got dim {self.curve.dim}")
        if self.edge_curve is not None and self.edge_curve.dim != 3:
            raise GeometryError(f"PCurve.edge_curve must be 3D; got dim {self.edge_curve.dim}")
        t0, t1 = float(self.t0), float(self.t1)
        if not (np.isfinite(t0) and np.isfinite(t1)) or t0 == t1:
            raise GeometryError(f"PCurve range must be finite and non-empty; got [{t0}, {t1}]")
        object.__setattr__(self, "t0", t0)
        object.__setattr__(self, "t1", t1)
        object.__setattr__(self, "edge_id", int(self.edge_id))

    def parameters(self, n: int) -> np.ndarray:
        """n equally spaced parameters from t0 to t1 (in loop direction)."""
        n = int(n)
        if n < 2:
            return np.linspace(self.t0, self.t1, n)
        # np.linspace's arithmetic (arange * step + start, the end exact) without its wrappers
        step = (self.t1 - self.t0) / (n - 1)
        y = np.arange(n, dtype=np.float64)
        if step == 0.0:             # as np.linspace for a subnormal step
            y /= n - 1
            y *= self.t1 - self.t0
        else:
            y *= step
        y += self.t0
        y[-1] = self.t1
        return y

    def evaluate(self, t) -> np.ndarray:
        """Points p(t) in (u, v), shape (n, 2)."""
        return self.curve.evaluate(t)

    @property
    def start(self) -> np.ndarray:
        return self.curve.evaluate([self.t0])[0]

    @property
    def end(self) -> np.ndarray:
        return self.curve.evaluate([self.t1])[0]


@dataclass(frozen=True, slots=True, eq=False)
class Loop:
    """A closed chain of p-curves; each segment's end meets the next one's start."""

    segments: tuple[PCurve, ...]

    def __post_init__(self) -> None:
        segs = tuple(self.segments)
        if not segs:
            raise TrimLoopError("a trim loop needs at least one segment")
        object.__setattr__(self, "segments", segs)

    def __len__(self) -> int:
        return len(self.segments)

    def gaps(self) -> np.ndarray:
        """Distance in (u, v) from each segment's end to the next segment's start, shape (k,)."""
        ends = np.array([s.end for s in self.segments])
        starts = np.array([s.start for s in self.segments])
        return np.linalg.norm(np.roll(starts, -1, axis=0) - ends, axis=1)

    def is_closed(self, tol: float) -> bool:
        """Whether every gap is at most `tol` (parameter units)."""
        return bool(np.all(self.gaps() <= tol))

    def polyline(self, n_per_segment: int = 32) -> np.ndarray:
        """Sampled loop in (u, v), shape (k * (n_per_segment - 1), 2), not repeating the first point.

        All segments in one compiled call (`loops_polylines`); the points are those of
        `_polyline_by_segment` (each segment's `evaluate(parameters(n))`), bit for bit."""
        n = int(n_per_segment)
        if n >= 2:
            return loops_polylines([self], n)[0]    # (a list: not cached by `_packed_segments`)
        return self._polyline_by_segment(n)

    def _polyline_by_segment(self, n_per_segment: int = 32) -> np.ndarray:
        """`polyline`, segment by segment (one curve evaluation each): the reference of the batched path."""
        parts = [s.evaluate(s.parameters(n_per_segment))[:-1] for s in self.segments]
        return np.concatenate(parts, axis=0)

    def polylines(self, *n_per_segment: int) -> tuple[np.ndarray, ...]:
        """`polyline(n)` for each n, every segment evaluated once for all of them (the same points)."""
        return self._polylines_by_segment(*n_per_segment)

    def _polylines_by_segment(self, *n_per_segment: int) -> tuple[np.ndarray, ...]:
        parts: list[list[np.ndarray]] = [[] for _ in n_per_segment]
        for s in self.segments:
            ts = [s.parameters(n) for n in n_per_segment]
            p = s.evaluate(np.concatenate(ts))
            o = 0
            for part, t in zip(parts, ts):
                part.append(p[o:o + len(t) - 1])
                o += len(t)
        return tuple(np.concatenate(part, axis=0) for part in parts)

    def signed_area(self, n_per_segment: int = 32) -> float:
        """Signed area of the sampled loop in (u, v): > 0 counter-clockwise."""
        p = self.polyline(n_per_segment)
        q = np.roll(p, -1, axis=0)
        return 0.5 * float(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))


def loops_polylines(loops, n_per_segment: int = 32) -> list[np.ndarray]:
    """`[loop.polyline(n_per_segment) for loop in loops]`, every segment of every loop sampled in one
    compiled call (`geom._pcurve_kernels.loop_polylines_kernel`, the meshing's: `PCurve.parameters`'
    arithmetic, clamped into the curve's domain as `geom.nurbs.curve_derivatives` clamps, each point as
    `curve_points_kernel` computes it), so the same points bit for bit as segment by segment.

    Each loop's array is its own (not a view of a shared one). n_per_segment < 2, or a segment whose
    parameter step is not finite, takes the segment-by-segment path (its results and errors)."""
    given = loops
    loops = tuple(loops)
    n = int(n_per_segment)
    if n < 2 or not any(loop.segments for loop in loops):
        return [loop._polyline_by_segment(n) for loop in loops]
    from ..geom._pcurve_kernels import loop_polylines_kernel

    si, sf, ck, cpw = _packed_segments(loops, given is loops)
    m = len(si)
    with np.errstate(over="ignore", invalid="ignore"):
        if not np.all(np.isfinite((sf[:, 1] - sf[:, 0]) / (n - 1))):
            return [loop._polyline_by_segment(n) for loop in loops]
    out = [np.empty((len(loop.segments) * (n - 1), 2)) for loop in loops]
    flat = out[0] if len(loops) == 1 else np.empty((m * (n - 1), 2))
    loop_polylines_kernel(si, sf, ck, cpw, np.int64(n), np.int64(2), flat,
                          np.empty((m, 2)))
    if len(loops) > 1:
        o = 0
        for a in out:
            a[...] = flat[o:o + len(a)]
            o += len(a)
    return out


def _pcurve_rows(curves: list) -> tuple:
    """The 2D curves' arrays as the compiled kernels take them, in a few numpy passes: rows (n, 7) int64
    (degree, rational, offset and count of the knots in ck, offset of the control points in cpw, their
    rows, columns), ck (the knots one after the other), cpw (the control points, homogeneous (x w, w)
    where rational, as `geom.nurbs._homogeneous` makes them, flat)."""
    n = len(curves)
    dim = 2                     # (p-curves are 2D: `PCurve` checks)
    cps = [c.control_points for c in curves]
    kcs = [c.knots for c in curves]
    nkc = np.fromiter(map(len, kcs), dtype=np.int64, count=n)
    rows = np.fromiter(map(len, cps), dtype=np.int64, count=n)
    ws = [c.weights for c in curves]
    rat = np.array([w is not None for w in ws], dtype=bool).reshape(n)
    cp_all = np.concatenate(cps)
    full = np.empty((len(cp_all), dim + 1))
    full[:, :dim] = cp_all
    row_rat = np.repeat(rat, rows)
    if rat.any():
        w_all = np.concatenate([w for w in ws if w is not None])
        full[row_rat, :dim] = cp_all[row_rat] * w_all[:, None]
        full[row_rat, dim] = w_all
    mask = np.ones(full.shape, dtype=bool)
    mask[~row_rat, dim] = False
    cols = dim + rat.astype(np.int64)
    sizes = rows * cols
    out = np.empty((n, 7), dtype=np.int64)
    out[:, 0] = [c.degree for c in curves]
    out[:, 1] = rat
    out[:, 2] = np.cumsum(nkc) - nkc
    out[:, 3] = nkc
    out[:, 4] = np.cumsum(sizes) - sizes
    out[:, 5] = rows
    out[:, 6] = cols
    return out, np.concatenate(kcs), full[mask]


#: `_packed_segments` of the last loop tuples asked for (a face's `loops`, kept alive in the entry so its
#: id is not reused while cached): measuring a face asks for its polylines at several densities
_PACKED: dict = {}
_PACKED_SIZE = 2048


def _packed_segments(loops: tuple, cache: bool) -> tuple:
    """The segments of `loops` as `loop_polylines_kernel` takes them (si, sf and the flat read-only knots
    and homogeneous control points, as `tessellate.face._loop_arrays` builds them); kept per tuple when
    `cache` (the tuple is the caller's own, e.g. `TrimmedFace.loops`)."""
    hit = _PACKED.get(id(loops)) if cache else None
    if hit is not None and hit[0] is loops:
        return hit[1]
    from ..geom.nurbs import read_only

    segs = [s for loop in loops for s in loop.segments]
    m = len(segs)
    sf = np.array([(sg.t0, sg.t1) for sg in segs], dtype=np.float64).reshape(m, 2)
    rows, ck, cpw = _pcurve_rows([sg.curve for sg in segs])
    si = np.ascontiguousarray(rows[:, [0, 2, 3, 4, 5, 6, 1]])
    packed = (si, sf, read_only(ck), read_only(cpw))     # si, sf writable: the meshing's specialization
    if cache:
        if len(_PACKED) >= _PACKED_SIZE:
            _PACKED.pop(next(iter(_PACKED)))
        _PACKED[id(loops)] = (loops, packed)
    return packed


@dataclass(frozen=True, slots=True, eq=False)
class TrimmedFace:
    """A surface F(u, v) restricted to the region bounded by its loops.

    Parameters
    ----------
    surface : NurbsSurface
    loops : tuple of Loop
        Outer loop first (counter-clockwise in (u, v)), holes after (clockwise).
        An empty tuple means the whole rectangular domain.
    same_sense : bool
        True when the face's outward normal is Su x Sv, False when it is -(Su x Sv).
    name : str
        Where the face came from (file entity, sample name), for messages.
    tolerance : float
        The source's stated tolerance for this face (model units), 0 if unknown.
    """

    surface: NurbsSurface
    loops: tuple[Loop, ...] = ()
    same_sense: bool = True
    name: str = ""
    tolerance: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "loops", tuple(self.loops))
        object.__setattr__(self, "same_sense", bool(self.same_sense))
        object.__setattr__(self, "tolerance", float(self.tolerance))

    @property
    def outer_loop(self) -> Loop | None:
        return self.loops[0] if self.loops else None

    @property
    def holes(self) -> tuple[Loop, ...]:
        return self.loops[1:]

    @property
    def has_edge_curves(self) -> bool:
        return any(s.edge_curve is not None for loop in self.loops for s in loop.segments)

    def sample_points(self, n: int = 17) -> np.ndarray:
        """Points of the face itself, inside its trims: for the extent of a model, never the whole surface.

        The loops sampled with `n` points per segment and the points of an `n` x `n` grid over the
        loops' (u, v) box that lie inside them (even-odd rule); an untrimmed face: an `n` x `n` grid of
        its domain. Non-finite points are left out. The box of these points is a sampled (not proven)
        inner bound of the face's box, exact on the trims and off by at most the surface's bulge
        between grid points inside.

        Returns
        -------
        (k, 3) float64

        Examples
        --------
        >>> from trimsurf.samples import build_sample
        >>> face = build_sample("fender").faces[0]
        >>> face.sample_points(5).shape[1]
        3
        """
        from ..geom.predicates import points_in_polygons

        n = max(int(n), 2)
        (u0, u1), (v0, v1) = self.surface.domain
        full = np.stack(np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n)), axis=-1).reshape(-1, 2)
        uv = full
        if self.loops:
            with np.errstate(all="ignore"):
                polys = loops_polylines(self.loops, n)
                polys = [np.clip(p, [u0, v0], [u1, v1]) for p in polys if np.all(np.isfinite(p)) and len(p) >= 3]
            if polys:
                edge = np.concatenate(polys)
                lo, hi = edge.min(axis=0), edge.max(axis=0)
                grid = np.stack(np.meshgrid(np.linspace(lo[0], hi[0], n), np.linspace(lo[1], hi[1], n)),
                                axis=-1).reshape(-1, 2)
                uv = np.concatenate([edge, grid[points_in_polygons(grid, polys)]])
        with np.errstate(all="ignore"):
            x = self.surface.evaluate(uv)
        x = x[np.all(np.isfinite(x), axis=1)]
        if not len(x) and uv is not full:
            with np.errstate(all="ignore"):
                x = self.surface.evaluate(full)
            x = x[np.all(np.isfinite(x), axis=1)]
        return x

    def oriented_normals(self, uv) -> np.ndarray:
        """Unit outward normals (surface normals flipped when `same_sense` is False), (n, 3)."""
        n = self.surface.normals(uv)
        return n if self.same_sense else -n
