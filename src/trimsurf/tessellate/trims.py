"""Trim polygons (paper Sec. 4.3, 5.1): trim curves sampled to the 3D criteria, iso-values inserted,
then polygon reduction that keeps the iso-line points.

The unit of work is a *chunk*: one boundary curve together with every face
that uses it. In conforming mode a chunk is a shared B-rep edge (two uses, or
two uses on the same face for a seam), discretized once, so both faces get the
same 3D points and each face its own (u, v) preimages; in loose mode every
loop segment is its own chunk with one use. The parameter of a chunk is
s in [0, 1], mapped linearly onto each use's p-curve range.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..model import NurbsSurface, PCurve
from ..model.trim import _pcurve_rows
from .domain import adaptive_values, interval_criteria, unique_values

__all__ = ["ChunkUse", "Chunk", "discretize_chunk", "discretize_chunks", "iso_crossings", "SHARED_CHORD"]

#: chord tolerance of a shared edge, times the tolerance: the seam reduction (`seams.reduce_seams`)
#: collapses a vertex lying within 0.25 x tolerance of its neighbours' chord, so the joint chord may
#: deviate from the curve by more than either chord did. 1.0 measured up to 1.045 x tolerance
#: (linkrods), 0.75 (the full quarter) doubles the points of arcs whose iso-line points are spaced
#: at the tolerance (featuretype 1746 -> 2658 triangles); 0.9 measured within the tolerance on every
#: model of ../shared/data/cad and the samples, but still split every interval between the iso-line
#: crossings of an arc whose face placed its lines at its own tolerance (`shell.SAMPLING_MARGIN` = 0.97:
#: crossing chords at 0.90-0.97 x tolerance got a midpoint each; featuretype 1746 -> 2158 triangles
#: tolerance-only). 0.97, the faces' own tolerance, measured within the tolerance on every model there
#: and the 4 samples at both settings (session 28, benchmarks/RESULTS.md "shared edges' chord tolerance").
SHARED_CHORD = 0.97


@dataclass(eq=False)
class ChunkUse:
    """One face's view of a chunk."""

    face: int
    loop: int
    segment: int
    pcurve: PCurve
    surface: NurbsSurface
    us: np.ndarray          # the face's domain values (iso-lines), u
    vs: np.ndarray          # and v
    param_tol: float        # (u, v) distance below which two parameters are the same
    _kernel_args: tuple | None = field(default=None, init=False, repr=False)   # `points`' arrays, built once

    @property
    def forward(self) -> bool:
        return self.pcurve.t0 < self.pcurve.t1

    def t_of(self, s: np.ndarray) -> np.ndarray:
        lo, hi = sorted((self.pcurve.t0, self.pcurve.t1))
        return lo + np.asarray(s, dtype=np.float64) * (hi - lo)

    def uv(self, s: np.ndarray) -> np.ndarray:
        """p(t(s)) clipped into the grid box of the face."""
        return self.points(s, with_xyz=False)[0]

    def xyz(self, s: np.ndarray) -> np.ndarray:
        """S(p(t(s))), p clipped into the grid box of the face, shape (n, 3)."""
        return self.points(s)[1]

    def points(self, s: np.ndarray, with_xyz: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """(uv (n, 2), xyz (n, 3)) at the chunk parameters s, in one compiled pass (xyz left
        uninitialized without `with_xyz`)."""
        from ..geom._nurbs_kernels import pcurve_surface_kernel
        from ..geom.nurbs import read_only

        s = read_only(np.asarray(s, dtype=np.float64).reshape(-1))
        uv, xyz = np.empty((len(s), 2)), np.empty((len(s) if with_xyz else 0, 3))
        pcurve_surface_kernel(*self.kernel_args(), s, with_xyz, uv, xyz)
        return uv, xyz

    def kernel_args(self) -> tuple:
        """The arguments of `pcurve_surface_kernel` before s (built once)."""
        if self._kernel_args is None:
            from ..geom.nurbs import _homogeneous, read_only

            c, f = self.pcurve.curve, self.surface
            lo, hi = sorted((self.pcurve.t0, self.pcurve.t1))
            box = read_only([self.us[0], self.us[-1], self.vs[0], self.vs[-1]])
            self._kernel_args = (
                (c.degree, read_only(c.knots), _homogeneous(c.control_points, c.weights),
                 c.weights is not None, float(lo), float(hi), box, f.degree_u, f.degree_v, read_only(f.knots_u),
                 read_only(f.knots_v), _homogeneous(f.control_points, f.weights), f.weights is not None))
        return self._kernel_args


@dataclass(eq=False)
class Chunk:
    """A discretized boundary curve.

    Attributes
    ----------
    s : (k,) float64
        Chunk parameters, increasing from 0 to 1.
    uses : list of ChunkUse
    uv : list of (k, 2) float64
        Per use, the (u, v) of every point, iso coordinates snapped exactly onto the use's grid lines.
    xyz : (k, 3) float64
        The shared 3D points (mean of the uses' S(p(t)), so each face is off by at most half the gap).
    is_iso : (k,) bool
        Points that lie on an iso-line of some use (kept by the reduction).
    degenerate : bool
        The curve has no 3D length (a pole or "suit-case corner" segment): one vertex.
    """

    s: np.ndarray
    uses: list
    uv: list
    xyz: np.ndarray
    is_iso: np.ndarray
    degenerate: bool


def _snap(values: np.ndarray, grid: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Values within `tol` of a grid value set exactly onto it; returns (snapped, was_snapped)."""
    j = np.clip(np.searchsorted(grid, values), 1, len(grid) - 1)
    lo, hi = grid[j - 1], grid[j]
    near = np.where(np.abs(values - lo) <= np.abs(values - hi), lo, hi)
    hit = np.abs(values - near) <= tol
    return np.where(hit, near, values), hit


def iso_crossings(s: np.ndarray, coord: np.ndarray, grid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where a sampled coordinate (s, coord) passes strictly across grid values (linear interpolation).

    Returns
    -------
    s_cross : (c,) float64
    value : (c,) float64
        The grid value crossed at each.
    """
    a, b = coord[:-1], coord[1:]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    first = np.searchsorted(grid, lo, side="right")
    last = np.searchsorted(grid, hi, side="left")
    cnt = np.maximum(last - first, 0)
    if not cnt.sum():
        return np.zeros(0), np.zeros(0)
    seg = np.repeat(np.arange(len(a)), cnt)
    offs = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    val = grid[first[seg] + offs]
    f = (val - a[seg]) / (b[seg] - a[seg])
    return s[seg] + f * (s[seg + 1] - s[seg]), val


def _refine_crossing(use: ChunkUse, s: np.ndarray, axis: int, value: np.ndarray, lo: np.ndarray,
                     hi: np.ndarray) -> np.ndarray:
    """Solve p(t(s))[axis] = value on [lo, hi] (Illinois regula falsi, vectorized)."""
    flo = use.uv(lo)[:, axis] - value
    fhi = use.uv(hi)[:, axis] - value
    side = np.zeros(len(s), dtype=np.int8)
    for _ in range(40):
        den = fhi - flo
        s = np.where(np.abs(den) > 0, lo - flo * (hi - lo) / np.where(den != 0, den, 1.0), 0.5 * (lo + hi))
        s = np.clip(s, np.minimum(lo, hi), np.maximum(lo, hi))
        fs = use.uv(s)[:, axis] - value
        if np.all(np.abs(fs) <= 1e-3 * use.param_tol):
            break
        left = np.sign(fs) == np.sign(flo)
        lo, flo = np.where(left, s, lo), np.where(left, fs, flo)
        hi, fhi = np.where(left, hi, s), np.where(left, fhi, fs)
        # Illinois: halve the stale end's value when the same end is kept twice
        fhi = np.where(left & (side == 1), 0.5 * fhi, fhi)
        flo = np.where(~left & (side == -1), 0.5 * flo, flo)
        side = np.where(left, 1, -1).astype(np.int8)
    return s


class _ChunkLines:
    """The line family of a chunk: s (k,) -> the points of every use, (k, len(uses), 3), with
    `criteria` computing `interval_criteria` in compiled passes."""

    def __init__(self, uses: list):
        self.uses = uses
        self._family = None

    def __call__(self, s: np.ndarray) -> np.ndarray:
        return np.stack([u.xyz(s) for u in self.uses], axis=1)

    def family(self) -> tuple:
        """The family as `_line_kernels` takes it (kind 1: the uses' arrays in flat read-only arrays)."""
        if self._family is None:
            from ..geom.nurbs import read_only
            from ._line_kernels import DUMMY_1D as D1, DUMMY_3D as D3, DUMMY_BOOL as DB

            args = [u.kernel_args() for u in self.uses]
            ci = np.zeros((len(args), 18), dtype=np.int64)
            cf = np.zeros((len(args), 6))
            flat = ([], [], [], [], [])         # p-curve knots, its control points, surface knots u, v, net
            off = [0, 0, 0, 0, 0]
            for j, (cp, kc, cw, crat, lo, hi, box, pu, pv, ku, kv, pw, srat) in enumerate(args):
                parts = (kc, cw, ku, kv, pw)
                o = list(off)
                for q, arr in enumerate(parts):
                    flat[q].append(arr.ravel())
                    off[q] += arr.size
                ci[j] = (cp, crat, pu, pv, srat, o[0], len(kc), o[1], *cw.shape, o[2], len(ku), o[3], len(kv), o[4],
                         *pw.shape)
                cf[j] = (lo, hi, *box)
            ck, cpw, cku, ckv, cpw4 = (read_only(np.concatenate(f)) for f in flat)
            self._family = (1, np.zeros(5, dtype=np.int64), np.zeros(2), D1, D1, DB, np.zeros(4), D1, D1, D3,
                            ci, cf, ck, cpw, cku, ckv, cpw4)
        return self._family

    def criteria(self, x: np.ndarray, n_sub: int, weights) -> tuple[np.ndarray, np.ndarray]:
        from ..geom._nurbs_kernels import chord_criteria_kernel

        n, m = len(x) - 1, n_sub + 2
        t = np.linspace(0.0, 1.0, m)
        xs = (x[:-1, None] + (x[1:] - x[:-1])[:, None] * t[None, :]).ravel()
        p = self(xs).reshape(n, m, len(self.uses), 3)
        w = (np.ones((n, len(self.uses)), dtype=np.bool_) if weights is None
             else np.array(weights, dtype=np.bool_, order="C"))
        length, dev = np.empty(n), np.empty(n)
        chord_criteria_kernel(np.ascontiguousarray(p), w, length, dev)
        return length, dev


def _evaluator(uses: list):
    return _ChunkLines(uses)


_S9, _S33 = np.linspace(0.0, 1.0, 9), np.linspace(0.0, 1.0, 33)     # the start samples of every chunk
_S9.flags.writeable = _S33.flags.writeable = False


def discretize_chunk(uses: list, *, tolerance: float, max_edge: float, strategy: str = "equidistributed",
                     reduce: bool = True, degenerate: bool | None = None) -> Chunk:
    """Sample a boundary curve to the 3D criteria on every use, insert every use's iso-values, reduce.

    `discretize_chunks` for one chunk (see there; the parameters and result are this one's).
    """
    return discretize_chunks([uses], tolerance=tolerance, max_edge=max_edge, strategy=strategy, reduce=reduce,
                             degenerate=[degenerate])[0]


def _batch_arrays(chunks: list) -> tuple:
    """The uses of all chunks as one chunk family (`_line_kernels.family` kind 1: ci, cf and the flat
    read-only arrays ck, cpw, cku, ckv, cpw4; a surface stored once whatever its number of uses) and
    their grids (gi, gf) and parameter tolerances, for `_chunk_kernels.discretize_chunks_kernel`.

    Attribute by attribute over all uses, the arrays in a few numpy passes (the same arrays as
    `_batch_arrays_loop`, use by use; the p-curves' homogeneous control points computed as
    `geom.nurbs._homogeneous` computes them, cp x w then w)."""
    from ..geom.nurbs import _homogeneous, read_only

    uses = [u for ch in chunks for u in ch]
    n = len(uses)
    pcs = [u.pcurve for u in uses]
    curves = [p.curve for p in pcs]
    ci = np.empty((n, 18), dtype=np.int64)
    cf = np.empty((n, 6))
    gi = np.empty((n, 4), dtype=np.int64)
    # the p-curves: knots, and the control points homogeneous where rational, flat
    rows_, ck_flat, cpw_flat = _pcurve_rows(curves)
    ci[:, 0:2] = rows_[:, 0:2]
    ci[:, 5:10] = rows_[:, 2:7]
    t0 = np.array([p.t0 for p in pcs], dtype=np.float64).reshape(n)
    t1 = np.array([p.t1 for p in pcs], dtype=np.float64).reshape(n)
    fwd = t0 <= t1
    cf[:, 0] = np.where(fwd, t0, t1)
    cf[:, 1] = np.where(fwd, t1, t0)
    # the surfaces, each once
    surf: dict = {}
    s_of = [surf.setdefault(id(u.surface), (len(surf), u.surface))[0] for u in uses]
    sk_u, sk_v, spw, srow = [], [], [], []
    o_ku = o_kv = o_pw = 0
    for _, f in surf.values():         # (concatenated below: the model's arrays as they are)
        ku, kv = f.knots_u, f.knots_v
        pw = f.control_points if f.weights is None else _homogeneous(f.control_points, f.weights)
        srow.append((f.degree_u, f.degree_v, f.weights is not None, o_ku, len(ku), o_kv, len(kv), o_pw, *pw.shape))
        sk_u.append(ku)
        sk_v.append(kv)
        spw.append(pw.ravel())
        o_ku += len(ku)
        o_kv += len(kv)
        o_pw += pw.size
    srow = np.array(srow, dtype=np.int64).reshape(-1, 11)[np.array(s_of, dtype=np.int64)]
    ci[:, 2:5] = srow[:, :3]
    ci[:, 10:18] = srow[:, 3:]
    # the grids, each once
    grid: dict = {}
    g_of = [grid.setdefault((id(u.us), id(u.vs)), (len(grid), u))[0] for u in uses]
    gf, grow, o_g = [], [], 0
    for _, u in grid.values():
        grow.append((o_g, len(u.us), o_g + len(u.us), len(u.vs), u.us[0], u.us[-1], u.vs[0], u.vs[-1]))
        gf.append(u.us)
        gf.append(u.vs)
        o_g += len(u.us) + len(u.vs)
    g_idx = np.array(g_of, dtype=np.int64)
    gi[:] = np.array([r[:4] for r in grow], dtype=np.int64).reshape(-1, 4)[g_idx]
    cf[:, 2:] = np.array([r[4:] for r in grow], dtype=np.float64).reshape(-1, 4)[g_idx]
    ptol = np.array([u.param_tol for u in uses], dtype=np.float64).reshape(n)
    flat = [read_only(x) for x in (ck_flat, cpw_flat, np.concatenate(sk_u), np.concatenate(sk_v),
                                   np.concatenate(spw))]
    c_off = np.zeros(len(chunks) + 1, dtype=np.int64)
    np.cumsum(np.fromiter(map(len, chunks), dtype=np.int64, count=len(chunks)), out=c_off[1:])
    return ci, cf, *flat, gi, read_only(np.concatenate(gf)), ptol, c_off


def _batch_arrays_loop(chunks: list) -> tuple:
    """`_batch_arrays` use by use (its reference in the tests)."""
    from ..geom.nurbs import _homogeneous, read_only

    uses = [u for ch in chunks for u in ch]
    n = len(uses)
    ci = np.empty((n, 18), dtype=np.int64)
    cf = np.empty((n, 6))
    gi = np.empty((n, 4), dtype=np.int64)
    ptol = np.empty(n)
    ck, cpw, sk_u, sk_v, spw, gf = [], [], [], [], [], []
    o_ck = o_cw = o_ku = o_kv = o_pw = o_g = 0
    surf: dict = {}
    grid: dict = {}
    for j, u in enumerate(uses):
        c, f = u.pcurve.curve, u.surface
        t0, t1 = u.pcurve.t0, u.pcurve.t1
        lo, hi = (t0, t1) if t0 <= t1 else (t1, t0)
        kc = read_only(c.knots)
        cw = _homogeneous(c.control_points, c.weights)
        ck.append(kc)
        cpw.append(cw.ravel())
        sd = surf.get(id(f))
        if sd is None:
            ku, kv = read_only(f.knots_u), read_only(f.knots_v)
            pw = _homogeneous(f.control_points, f.weights)
            sd = surf[id(f)] = (f, o_ku, len(ku), o_kv, len(kv), o_pw, *pw.shape)
            sk_u.append(ku)
            sk_v.append(kv)
            spw.append(pw.ravel())
            o_ku += len(ku)
            o_kv += len(kv)
            o_pw += pw.size
        gd = grid.get((id(u.us), id(u.vs)))
        if gd is None:
            gd = grid[(id(u.us), id(u.vs))] = (u.us, u.vs, o_g, len(u.us), o_g + len(u.us), len(u.vs))
            gf.append(u.us)
            gf.append(u.vs)
            o_g += len(u.us) + len(u.vs)
        ci[j] = (c.degree, c.weights is not None, f.degree_u, f.degree_v, f.weights is not None, o_ck, len(kc),
                 o_cw, *cw.shape, *sd[1:])
        cf[j] = (lo, hi, u.us[0], u.us[-1], u.vs[0], u.vs[-1])
        gi[j] = gd[2:]
        ptol[j] = u.param_tol
        o_ck += len(kc)
        o_cw += cw.size
    flat = [read_only(np.concatenate(x)) for x in (ck, cpw, sk_u, sk_v, spw)]
    c_off = np.zeros(len(chunks) + 1, dtype=np.int64)
    np.cumsum([len(ch) for ch in chunks], out=c_off[1:])
    return ci, cf, *flat, gi, read_only(np.concatenate(gf)), ptol, c_off


_S9W, _S33W = np.linspace(0.0, 1.0, 9), np.linspace(0.0, 1.0, 33)     # the kernel's (writable) copies

#: straight chunks skip the placement (it gives [0, 1]; see `discretize_chunks`); False: the tests' reference
_STRAIGHT_SHORTCUT = True


def discretize_chunks(chunks: list, *, tolerance: float, max_edge: float, strategy: str = "equidistributed",
                      reduce: bool = True, degenerate: list | None = None) -> list:
    """`discretize_chunk` of several chunks (the uses of each), in one compiled call
    (`_chunk_kernels.discretize_chunks_kernel`, the numbers of `_discretize_chunk_numpy`).

    Parameters
    ----------
    chunks : list of list of ChunkUse
    tolerance, max_edge, strategy, reduce
        As `discretize_chunk`; a strategy other than "equidistributed" runs the numpy path.
    degenerate : list of (bool or None), or None
        Per chunk, as `discretize_chunk`'s (None: all None).

    Returns
    -------
    list of Chunk
    """
    if degenerate is None:
        degenerate = [None] * len(chunks)
    if strategy != "equidistributed" or not chunks:
        return [_discretize_chunk_numpy(uses, tolerance=tolerance, max_edge=max_edge, strategy=strategy,
                                        reduce=reduce, degenerate=deg) for uses, deg in zip(chunks, degenerate)]
    from ._chunk_kernels import discretize_chunks_kernel
    from ._line_kernels import DUMMY_1D as D1, DUMMY_3D as D3, DUMMY_BOOL as DB
    from .domain import MAX_VALUES

    ci, cf, ck, cpw, cku, ckv, cpw4, gi, gf, ptol, c_off = _batch_arrays(chunks)
    forced = np.array([-1 if d is None else int(bool(d)) for d in degenerate], dtype=np.int64)
    fam0 = (1, np.zeros(5, dtype=np.int64), np.zeros(2), D1, D1, DB, np.zeros(4), D1, D1, D3)
    args = (*fam0, ci, cf, ck, cpw, cku, ckv, cpw4, gi, gf, ptol, c_off)
    tail = (float(tolerance), float(SHARED_CHORD), float(max_edge), float(MAX_VALUES))
    # per chunk the placement's start values and whether it is degenerate (the 33-point probe), the
    # placement (`domain.adaptive_values`' compiled path), the iso-values, the reduction and the shared
    # points, in one call (mode 2). A straight chunk takes [0, 1] without the placement:
    #    `equidistributed_kernel` returns [0, 1] whenever the sum `total` of max(len_i / h, sqrt(dev_i / tol))
    #    over its fine intervals is below 1.1 (one value placed: [0, 1]; with total in (1, 1.1) the n0 - 1 = 1
    #    of its first try) and [0, 1] passes its check, which the kernel computes with the same call
    #    (`_chunk_criteria` on [0, 1], 9 points, stop). It takes a chunk whose every use's points are affine in
    #    s (a straight segment at constant speed: `_chunk_kernels._straight_scale`, exact tests on the
    #    arrays): with ell the largest |P_j(1) - P_j(0)| (<= h: the check), every fine interval's length is
    #    ell x its width in s (<= ell / 8 < h / 4: no bisection for length), its sampled deviation rounding
    #    only, below noise = 1e-13 x the surfaces' scale (some 20 x the rounding of the point and distance
    #    arithmetic, argued, not proven to the last bit) <= 1e-3 x tol (no bisection for deviation), so over
    #    its k start values total <= ell / h + (k - 1) (sqrt(noise / tol) + noise / h) <= 1.05.
    #    `_STRAIGHT_SHORTCUT = False` runs the placement on every chunk (the tests' reference).
    info, pts, uv = discretize_chunks_kernel(*args, forced, _S9W, _S33W, _S9W, c_off, *tail,
                                             np.array([bool(reduce), 5, 9, 2, _STRAIGHT_SHORTCUT], dtype=np.int64))
    s, xyz, iso = pts[:, 0].copy(), pts[:, 1:4].copy(), pts[:, 4] > 0.5
    out = []
    o = ouv = 0
    for c, (uses, (k, degen, status)) in enumerate(zip(chunks, info.tolist())):
        if status:              # more intervals than MAX_VALUES: the numpy path refuses (InputError)
            out.append(_discretize_chunk_numpy(uses, tolerance=tolerance, max_edge=max_edge, strategy=strategy,
                                               reduce=reduce, degenerate=degenerate[c]))
            continue
        cx = xyz[o:o + k]
        if degen:
            cx[:] = cx.mean(axis=0)
        out.append(Chunk(s[o:o + k], list(uses), [uv[a:a + k] for a in range(ouv, ouv + len(uses) * k, k)],
                         cx, iso[o:o + k], bool(degen)))
        o += k
        ouv += len(uses) * k
    return out


def _placement_starts(chunks: list, *, tolerance: float, max_edge: float, degenerate: list) -> tuple:
    """Per chunk (mode 0 of `discretize_chunks_kernel`, the tests' view of step one): the placement's start
    values, whether it is degenerate and whether it is straight (takes [0, 1] without the placement)."""
    from ._chunk_kernels import discretize_chunks_kernel
    from ._line_kernels import DUMMY_1D as D1, DUMMY_3D as D3, DUMMY_BOOL as DB
    from .domain import MAX_VALUES

    ci, cf, ck, cpw, cku, ckv, cpw4, gi, gf, ptol, c_off = _batch_arrays(chunks)
    forced = np.array([-1 if d is None else int(bool(d)) for d in degenerate], dtype=np.int64)
    fam0 = (1, np.zeros(5, dtype=np.int64), np.zeros(2), D1, D1, DB, np.zeros(4), D1, D1, D3)
    info, pts, _ = discretize_chunks_kernel(*fam0, ci, cf, ck, cpw, cku, ckv, cpw4, gi, gf, ptol, c_off, forced,
                                            _S9W, _S33W, _S9W, c_off, float(tolerance), float(SHARED_CHORD),
                                            float(max_edge), float(MAX_VALUES),
                                            np.array([1, 5, 9, 0, _STRAIGHT_SHORTCUT], dtype=np.int64))
    x0 = np.split(pts[:, 0], np.cumsum(info[:, 0])[:-1])
    return x0, info[:, 1] != 0, info[:, 2] == 2


def _discretize_chunk_numpy(uses: list, *, tolerance: float, max_edge: float, strategy: str = "equidistributed",
                            reduce: bool = True, degenerate: bool | None = None) -> Chunk:
    """`discretize_chunk` with numpy and the per-step kernels (the reference of the compiled
    `discretize_chunks`, and its path for the strategies other than "equidistributed").

    Parameters
    ----------
    uses : list of ChunkUse
        All faces that run along the curve (one in loose mode).
    tolerance, max_edge : float
        The paper's geometric deviation and grid size (model units).
    strategy : str
        See `trimsurf.tessellate.domain.adaptive_values`.
    reduce : bool
        Polygon reduction after the iso-values were inserted (paper Sec. 5.1).
    degenerate : bool or None
        Force the degenerate (zero 3D length) treatment; None: decide from the samples.

    Returns
    -------
    Chunk
    """
    evaluate = _evaluator(uses)
    # a shared edge keeps some room for the seam reduction (SHARED_CHORD)
    chord_tol = tolerance if len(uses) < 2 else SHARED_CHORD * tolerance
    knots = uses[0].pcurve.curve.knots
    lo, hi = sorted((uses[0].pcurve.t0, uses[0].pcurve.t1))
    kn = (unique_values(knots[(knots > lo) & (knots < hi)]) - lo) / (hi - lo)
    init = unique_values(np.concatenate((_S9, kn)))
    probe = evaluate(_S33)
    extent = float(np.linalg.norm(probe - probe[:1], axis=-1).max())
    if degenerate is None:
        degenerate = extent <= 1e-3 * tolerance
    if degenerate:
        s = np.array([0.0, 1.0])
    else:
        s = adaptive_values(evaluate, 0.0, 1.0, tolerance=chord_tol, max_edge=max_edge, strategy=strategy,
                            init=init)
    # insert the iso-values of every use (the crossings of its u and v grid lines); repeat on the new
    # points, since a curve that dips across a line and back inside one interval shows up only then;
    # then every use's (u, v) snapped onto its grid lines, the crossings exactly onto theirs (compiled)
    s_all, uvs, iso = _insert_iso_values(evaluate, uses, s)
    # merge points that (nearly) coincide in some use: a back-step of 1e-8 makes a trim polygon cross itself
    if len(s_all) > 2:
        gap = np.full(len(s_all) - 1, np.inf)
        for use, uv in zip(uses, uvs):
            gap = np.minimum(gap, np.linalg.norm(np.diff(uv, axis=0), axis=1) / (100.0 * use.param_tol))
        drop = np.zeros(len(s_all), dtype=bool)
        for k in np.flatnonzero(gap <= 1.0):
            # drop the inner point of the pair, never an end; prefer a point that is no iso point
            cand = [c for c in (k, k + 1) if 0 < c < len(s_all) - 1 and not drop[c]]
            if not cand:
                continue
            c = min(cand, key=lambda c: (iso[c], c))
            other = k + 1 if c == k else k
            drop[c] = True
            # the kept point takes over the grid coordinates the dropped one had (so no iso-line is lost)
            for use, uv in zip(uses, uvs):
                for axis, grid in ((0, use.us), (1, use.vs)):
                    if np.isin(uv[c, axis], grid) and not np.isin(uv[other, axis], grid):
                        uv[other, axis] = uv[c, axis]
            iso[other] |= iso[c]
        if drop.any():
            keep = ~drop
            s_all, iso = s_all[keep], iso[keep]
            uvs = [uv[keep] for uv in uvs]
    if reduce and not degenerate and len(s_all) > 2:
        # the points to keep are the grid-line crossings; on a shared edge, a point inside a run along a
        # grid line (an edge on a face's box side or along an iso-curve) is none: its neighbours' chord
        # runs along the line as well, and the crossings' points are then spaced evenly. A single-use
        # trim keeps both as they were: its chords at the full tolerance, measured on the samples only,
        # reached 1.02 x tolerance on the hood sample's box sides, and loose mode's stitching matches
        # the two faces' own points (even spacing left 3 boundary edges off the bearing's free edges).
        # (numpy: a compiled version, `chunk_reduce_kernel` of 1ca5597, was 8% faster on the 34 runs of
        # /work/wt/same_output.py but cost ~6 s CPU of numba compilation on a cold cache)
        shared = len(uses) >= 2
        must = _crossing_points(uses, uvs) if shared else iso.copy()
        must[[0, -1]] = True
        s_all, uvs, iso = _reduce(evaluate, s_all, uvs, must, chord_tol, max_edge, uses, flags=iso)
        if shared:
            s_all, uvs, iso = _even_spacing(evaluate, s_all, uvs, iso, chord_tol, max_edge, uses)
    xyz = np.mean([u.surface.evaluate(uv) for u, uv in zip(uses, uvs)], axis=0)
    if degenerate:
        xyz[:] = xyz.mean(axis=0)
    return Chunk(s_all, list(uses), uvs, xyz, iso, bool(degenerate))


def _same_cell(uses, uvs, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether points a and b lie in one closed grid cell of every use (the chord crosses no iso-line)."""
    return _in_one_cell(uses, [uv[a] for uv in uvs], [uv[b] for uv in uvs])


def _crossing_points(uses, uvs) -> np.ndarray:
    """Points that lie on a grid line of some use which the polygon does not run along on both sides."""
    must = np.zeros(len(uvs[0]), dtype=bool)
    for use, uv in zip(uses, uvs):
        for axis, grid in ((0, use.us), (1, use.vs)):
            c = uv[:, axis]
            on = np.isin(c, grid)
            along = np.zeros(len(c), dtype=bool)
            along[1:-1] = (c[:-2] == c[1:-1]) & (c[2:] == c[1:-1])
            must |= on & ~along
    return must


def _reduce(evaluate, s, uvs, iso, tolerance, max_edge, uses, flags=None):
    """Remove points that are no iso-line point while the chord of their neighbours meets both criteria
    and crosses no iso-line of any use. With `flags`, returns those of the kept points instead of iso."""
    keep = np.ones(len(s), dtype=bool)
    for parity in (0, 1, 0, 1):
        idx = np.flatnonzero(keep)
        if len(idx) < 3:
            break
        cand = np.arange(1, len(idx) - 1)
        cand = cand[(cand % 2 == parity) & ~iso[idx[cand]]]
        if not len(cand):
            continue
        a, b = s[idx[cand - 1]], s[idx[cand + 1]]
        pairs = np.column_stack([a, b]).ravel()
        length, dev = interval_criteria(evaluate, pairs)
        length, dev = length[::2], dev[::2]
        ok = (length <= max_edge) & (dev <= tolerance) & _same_cell(uses, uvs, idx[cand - 1], idx[cand + 1])
        keep[idx[cand[ok]]] = False
    return s[keep], [uv[keep] for uv in uvs], (iso if flags is None else flags)[keep]


def _in_one_cell(uses, uv_a: list, uv_b: list) -> np.ndarray:
    """Whether the points uv_a[i] and uv_b[i] (per use, (n, 2)) lie in one closed grid cell of every use."""
    ok = np.ones(len(uv_a[0]), dtype=bool)
    for use, a, b in zip(uses, uv_a, uv_b):
        for axis, grid in ((0, use.us), (1, use.vs)):
            lo = np.minimum(a[:, axis], b[:, axis])
            hi = np.maximum(a[:, axis], b[:, axis])
            ok &= np.searchsorted(grid, lo, side="right") >= np.searchsorted(grid, hi, side="left")
    return ok


def _even_spacing(evaluate, s, uvs, iso, tolerance, max_edge, uses):
    """Between consecutive grid-line crossings, the fewest equally spaced points (in s) that meet both
    criteria, where they are no more than the reduction kept there.

    The 3D samples are placed along the whole curve, before the crossings are known: one that meets the
    chord tolerance a little short of a crossing stays next to it (a pair of nearly coincident points, a
    thin triangle fan in the cells of the face that has no line there). Evenly spaced points between the
    crossings keep the count and the criteria and space the polygon evenly. An interval whose even
    points would leave one grid cell (a curve that dips towards a line) keeps the reduction's points.
    """
    must = _crossing_points(uses, uvs)
    must[[0, -1]] = True
    mi = np.flatnonzero(must)
    m_old = np.diff(mi) - 1
    cand = np.flatnonzero(m_old > 0)
    if not len(cand):
        return s, uvs, iso
    a, b, m = s[mi[cand]], s[mi[cand + 1]], m_old[cand]
    ends_a = [uv[mi[cand]] for uv in uvs]
    ends_b = [uv[mi[cand + 1]] for uv in uvs]
    best = np.zeros(len(cand), dtype=np.int64)          # sub-intervals chosen, 0: keep the old points
    for n in range(1, int(m.max()) + 2):
        sel = np.flatnonzero((best == 0) & (n <= m + 1))
        if not len(sel):
            break
        f = np.arange(n + 1) / n
        grid_s = a[sel, None] + (b - a)[sel, None] * f[None, :]          # (k, n + 1)
        pairs = np.column_stack([grid_s[:, :-1].ravel(), grid_s[:, 1:].ravel()]).ravel()
        length, dev = interval_criteria(evaluate, pairs)
        ok = ((length[::2] <= max_edge) & (dev[::2] <= tolerance)).reshape(-1, n).all(axis=1)
        # (u, v) of the sequence end, interior points, end; every chord in one closed cell of every use
        seq = []
        for ui, use in enumerate(uses):
            uvq = np.empty((len(sel), n + 1, 2))
            uvq[:, 0], uvq[:, -1] = ends_a[ui][sel], ends_b[ui][sel]
            if n > 1:
                inner = use.uv(grid_s[:, 1:-1].ravel())
                for axis, g in ((0, use.us), (1, use.vs)):
                    inner[:, axis] = _snap(inner[:, axis], g, use.param_tol)[0]
                uvq[:, 1:-1] = inner.reshape(len(sel), n - 1, 2)
            seq.append(uvq)
        cell = _in_one_cell(uses, [q[:, :-1].reshape(-1, 2) for q in seq],
                            [q[:, 1:].reshape(-1, 2) for q in seq]).reshape(-1, n).all(axis=1)
        best[sel[ok & cell]] = n
    done = np.flatnonzero(best > 0)
    if not len(done):
        return s, uvs, iso
    drop = np.zeros(len(s), dtype=bool)
    new_s = []
    for k in done:
        drop[mi[cand[k]] + 1:mi[cand[k] + 1]] = True
        n = best[k]
        if n > 1:
            new_s.append(a[k] + (b[k] - a[k]) * np.arange(1, n) / n)
    new_s = np.concatenate(new_s) if new_s else np.zeros(0)
    s_out = np.r_[s[~drop], new_s]
    order = np.argsort(s_out, kind="stable")
    uvs_out, iso_new = [], np.zeros(len(new_s), dtype=bool)
    for use, uv in zip(uses, uvs):
        inner = use.uv(new_s)
        for axis, g in ((0, use.us), (1, use.vs)):
            inner[:, axis], hit = _snap(inner[:, axis], g, use.param_tol)
            iso_new |= hit
        uvs_out.append(np.r_[uv[~drop], inner][order])
    return s_out[order], uvs_out, np.r_[iso[~drop], iso_new][order]


def _grids(uses: list):
    """The uses' grids (us, vs) padded into one array (L, 2, g), their lengths (L, 2), param_tol (L,)."""
    g = max(max(len(u.us), len(u.vs)) for u in uses)
    grids = np.zeros((len(uses), 2, g))
    gl = np.zeros((len(uses), 2), dtype=np.int64)
    for j, u in enumerate(uses):
        grids[j, 0, :len(u.us)], grids[j, 1, :len(u.vs)] = u.us, u.vs
        gl[j] = len(u.us), len(u.vs)
    return grids, gl, np.array([float(u.param_tol) for u in uses])


def _insert_iso_values(evaluate, uses: list, s: np.ndarray):
    """The crossings of every use's u and v grid lines inserted into s (four rounds: a curve that dips
    across a line and back inside one interval shows up only on the new points), near-duplicates
    dropped, each use's (u, v) snapped onto its grid lines and the crossings set exactly onto theirs.
    Returns (s_all, uvs: list of (k, 2) per use, iso (k,) bool); `_chunk_kernels.chunk_iso_kernel` (the
    iso step of the chunk kernel itself)."""
    from ._chunk_kernels import chunk_iso_kernel

    grids, gl, ptol = _grids(uses)
    s_all, uv, iso = chunk_iso_kernel(*evaluate.family()[10:14], grids, gl, ptol,
                                      np.ascontiguousarray(s, dtype=np.float64))
    return s_all, list(uv), iso


def _insert_iso_values_numpy(uses: list, s: np.ndarray):
    """`_insert_iso_values` with numpy (the reference the compiled kernel is tested against)."""
    forced = []
    s_all = s
    for _ in range(4):
        extra = []
        for ui, use in enumerate(uses):
            uv = use.uv(s_all)
            for sc, fu, axis, val in forced:
                if fu == ui:
                    uv[np.searchsorted(s_all, sc), axis] = val
            for axis, grid in ((0, use.us), (1, use.vs)):
                coord, _ = _snap(uv[:, axis], grid, use.param_tol)
                sc, val = iso_crossings(s_all, coord, grid)
                if len(sc):
                    k = np.clip(np.searchsorted(s_all, sc, side="right") - 1, 0, len(s_all) - 2)
                    sc = _refine_crossing(use, sc, axis, val, s_all[k], s_all[k + 1])
                    fresh = np.abs(s_all[np.clip(np.searchsorted(s_all, sc), 0, len(s_all) - 1)] - sc) > 1e-13
                    sc, val = sc[fresh], val[fresh]
                    extra.append(sc)
                    forced.extend((float(a), ui, axis, float(v)) for a, v in zip(sc, val))
        if not extra or not sum(len(e) for e in extra):
            break
        s_all = np.unique(np.r_[s_all, np.concatenate(extra)])
    forced = [(sc, ui, axis, val) for sc, ui, axis, val in forced]
    # drop near-duplicate parameters
    keep = np.r_[True, np.diff(s_all) > 1e-13]
    s_all = s_all[keep]
    uvs, iso = [], np.zeros(len(s_all), dtype=bool)
    for use in uses:
        uv = use.uv(s_all)
        for axis, grid in ((0, use.us), (1, use.vs)):
            uv[:, axis], hit = _snap(uv[:, axis], grid, use.param_tol)
            iso |= hit
        uvs.append(uv)
    # the crossings lie exactly on their iso-line (whatever the solver's last digit)
    for sc, ui, axis, val in forced:
        k = int(np.clip(np.searchsorted(s_all, sc), 0, len(s_all) - 1))
        if k > 0 and abs(s_all[k - 1] - sc) < abs(s_all[k] - sc):
            k -= 1
        uvs[ui][k, axis] = val
        iso[k] = True
    iso[[0, -1]] = True
    return s_all, uvs, iso
