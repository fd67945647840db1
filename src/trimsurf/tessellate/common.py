"""Common parameterization of faces that share a boundary (paper Sec. 5.1, Fig. 12).

Where two faces meet along an edge that is an iso-parametric line of both
(u or v constant on both p-curves, as between the patches of a car panel, a
fillet and its neighbours, the faces of a box or of a body of revolution), the
iso-lines that end on the edge are made to end at the same points from both
sides. Highlight lines then run on across the boundary instead of jumping
(Fig. 12 b vs a), and the shared edge carries no pairs of nearly coincident
iso points (which give needle triangles in conforming mode). Only
tangent-continuous joints are linked: across a crease highlights break anyway.

How: every face's transversal parameter direction ``(face, axis)`` is a node;
a shared iso-parametric edge links two nodes by the exact map
``x_b = p_b(t(x_a))[axis_b]`` through the edge parameter t (p-curves evaluated,
not interpolated, so both faces' iso-lines hit the edge at the same t to
rounding). Each connected class of nodes (a ring of box faces, all faces of a
revolved part) gets ONE set of values: all nodes' values are mapped to the
class's root node, merged into the coarsest subset of their union that is
nowhere coarser than any node's own values (so each face keeps its own
tolerance and grid-size criteria, and the class has about as many lines as its
finest face, not the sum), and mapped back to every node. Values outside the
part of a face that the edges cover stay the face's own.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from ..model import Shell

__all__ = ["common_parameterization", "iso_axis", "merge_finest"]

_N = 65          # samples of a p-curve for the iso test and the monotonicity check
_CLUSTER = 0.3   # lines of different faces closer than this x the local spacing become one
_SLACK = 1.1     # a merged step may exceed the finest face's local spacing by this factor
_MAX_ANGLE = 10.0  # faces whose normals differ by more along the edge (a crease) are not linked


def iso_axis(pcurve, surface, rel_tol: float = 1e-7) -> int | None:
    """The axis (0: u, 1: v) a p-curve runs along when the other coordinate is constant, else None."""
    lo, hi = sorted((pcurve.t0, pcurve.t1))
    uv = pcurve.curve.evaluate(np.linspace(lo, hi, _N))
    (u0, u1), (v0, v1) = surface.domain
    ext = np.array([u1 - u0, v1 - v0])
    spread = uv.max(axis=0) - uv.min(axis=0)
    const = spread <= rel_tol * ext
    if const[1] and not const[0]:
        return 0
    if const[0] and not const[1]:
        return 1
    return None


class _Side:
    """One p-curve of an iso-parametric edge: x(t) = p(t)[axis], strictly monotone on [lo, hi]."""

    def __init__(self, pcurve, axis: int):
        self.p, self.axis = pcurve, axis
        self.lo, self.hi = sorted((pcurve.t0, pcurve.t1))
        self.t = np.linspace(self.lo, self.hi, 4 * _N)
        self.x = self.coord(self.t)
        d = np.diff(self.x)
        self.ok = bool(np.all(d > 0) or np.all(d < 0))
        self.xmin, self.xmax = float(self.x.min()), float(self.x.max())

    def coord(self, t: np.ndarray) -> np.ndarray:
        return self.p.curve.evaluate(np.asarray(t, dtype=np.float64))[:, self.axis]

    def t_of(self, x: np.ndarray) -> np.ndarray:
        """The edge parameter where the p-curve has coordinate x (regula falsi to rounding); NaN outside."""
        x = np.asarray(x, dtype=np.float64)
        out = np.full(len(x), np.nan)
        inside = (x > self.xmin) & (x < self.xmax)
        if not inside.any():
            return out
        xi = x[inside]
        inc = self.x[-1] > self.x[0]
        xs, ts = (self.x, self.t) if inc else (self.x[::-1], self.t[::-1])
        k = np.clip(np.searchsorted(xs, xi), 1, len(xs) - 1)
        a, b = ts[k - 1], ts[k]
        fa, fb = xs[k - 1] - xi, xs[k] - xi
        t = a.copy()
        side = np.zeros(len(xi), dtype=np.int8)
        for _ in range(60):
            den = fb - fa
            t = np.where(den != 0, a - fa * (b - a) / np.where(den != 0, den, 1.0), 0.5 * (a + b))
            t = np.clip(t, np.minimum(a, b), np.maximum(a, b))
            ft = self.coord(t) - xi
            if np.all(np.abs(ft) <= 1e-14 * (self.xmax - self.xmin)):
                break
            left = np.sign(ft) == np.sign(fa)          # the root lies in [t, b]
            a, fa = np.where(left, t, a), np.where(left, ft, fa)
            b, fb = np.where(left, b, t), np.where(left, fb, ft)
            # Illinois: halve the value of an end kept twice in a row
            fb = np.where(left & (side == 1), 0.5 * fb, fb)
            fa = np.where(~left & (side == -1), 0.5 * fa, fa)
            side = np.where(left, 1, -1).astype(np.int8)
        out[inside] = t
        return out


def _link_map(src: _Side, dst: _Side):
    """x_src -> x_dst through the shared edge parameter (NaN outside the edge)."""
    def f(x):
        t = src.t_of(x)
        out = np.full(len(t), np.nan)
        ok = np.isfinite(t)
        if ok.any():
            out[ok] = dst.coord(t[ok])
        return out
    return f


def _crease_deg(fa, pa, fb, pb) -> float:
    """Largest angle between the two faces' oriented normals along the edge (sampled; NaN at poles ignored)."""
    lo, hi = sorted((pa.t0, pa.t1))
    t = np.linspace(lo, hi, 9)
    na = fa.oriented_normals(pa.curve.evaluate(t))
    nb = fb.oriented_normals(pb.curve.evaluate(t))
    cos = np.einsum("ij,ij->i", na, nb)
    cos = cos[np.isfinite(cos)]
    return float(np.degrees(np.arccos(np.clip(cos.min(), -1.0, 1.0)))) if len(cos) else 180.0


def _links(shell: Shell, faces: list, grids: dict, max_angle_deg: float):
    """Shared iso-parametric edges: (node_a, node_b, map a->b, map b->a), node = (face, axis)."""
    out = []
    for edge in shell.edges:
        if len(edge.uses) != 2:
            continue
        (fa, la, sa), (fb, lb, sb) = edge.uses
        if fa == fb or fa not in grids or fb not in grids:
            continue
        try:
            pa = faces[fa].loops[la].segments[sa]
            pb = faces[fb].loops[lb].segments[sb]
        except IndexError:
            continue
        ax_a = iso_axis(pa, faces[fa].surface)
        ax_b = iso_axis(pb, faces[fb].surface)
        if ax_a is None or ax_b is None:
            continue
        # the same edge parameter on both p-curves (the chunk discretization relies on it too)
        la_, ha_ = sorted((pa.t0, pa.t1))
        lb_, hb_ = sorted((pb.t0, pb.t1))
        if not (abs(la_ - lb_) <= 1e-9 * (ha_ - la_) and abs(ha_ - hb_) <= 1e-9 * (ha_ - la_)):
            continue
        if max_angle_deg < 180.0 and _crease_deg(faces[fa], pa, faces[fb], pb) > max_angle_deg:
            continue            # a crease: reflection lines break there anyway
        a, b = _Side(pa, ax_a), _Side(pb, ax_b)
        if not (a.ok and b.ok):
            continue
        out.append(((fa, ax_a), (fb, ax_b), _link_map(a, b), _link_map(b, a)))
    return out


class _LooseSide(_Side):
    """An iso-parametric loop segment of a face without topology, with its 3D samples."""

    def __init__(self, face_index: int, face, pcurve, axis: int):
        super().__init__(pcurve, axis)
        self.face_index, self.face = face_index, face
        self.xyz = face.surface.evaluate(pcurve.curve.evaluate(self.t))

    def project(self, pts: np.ndarray, tol: float) -> np.ndarray:
        """Edge parameters t of the closest points of the segment (in 3D) to `pts`; NaN farther than `tol`."""
        d = np.linalg.norm(pts[:, None, :] - self.xyz[None, :, :], axis=-1)
        k = d.argmin(axis=1)
        a = self.t[np.clip(k - 1, 0, len(self.t) - 1)]
        b = self.t[np.clip(k + 1, 0, len(self.t) - 1)]
        surf, curve = self.face.surface, self.p.curve

        def dist(t):
            return np.linalg.norm(surf.evaluate(curve.evaluate(t)) - pts, axis=1)
        g = 0.5 * (np.sqrt(5.0) - 1.0)          # golden section on the bracket around the nearest sample
        c, e = b - g * (b - a), a + g * (b - a)
        fc, fe = dist(c), dist(e)
        for _ in range(40):
            left = fc < fe
            b = np.where(left, e, b)
            a = np.where(left, a, c)
            c2 = b - g * (b - a)
            e2 = a + g * (b - a)
            c, e = c2, e2
            fc, fe = dist(c), dist(e)
        t = 0.5 * (a + b)
        return np.where(dist(t) <= tol, t, np.nan)


def _loose_map(src: _LooseSide, dst: _LooseSide, tol: float):
    """x_src -> x_dst through the 3D point (closest point on dst's segment); NaN where the segments part."""
    def f(x):
        t = src.t_of(x)
        out = np.full(len(t), np.nan)
        ok = np.isfinite(t)
        if ok.any():
            pts = src.face.surface.evaluate(src.p.curve.evaluate(t[ok]))
            tb = dst.project(pts, tol)
            good = np.isfinite(tb)
            vals = np.full(len(tb), np.nan)
            if good.any():
                vals[good] = dst.coord(tb[good])
            out[ok] = vals
        return out
    return f


def _loose_links(faces: list, grids: dict, tolerance: float, max_angle_deg: float):
    """Iso-parametric loop segments of different faces that run along each other in 3D (no topology)."""
    sides = []
    for fi in sorted(grids):
        face = faces[fi]
        for loop in face.loops:
            for seg in loop.segments:
                ax = iso_axis(seg, face.surface)
                if ax is None:
                    continue
                sd = _LooseSide(fi, face, seg, ax)
                if sd.ok and np.linalg.norm(sd.xyz[-1] - sd.xyz[0]) > tolerance:
                    sides.append(sd)
    if len(sides) < 2:
        return []
    lo = np.array([sd.xyz.min(axis=0) for sd in sides]) - tolerance
    hi = np.array([sd.xyz.max(axis=0) for sd in sides]) + tolerance
    over = np.all((lo[:, None] <= hi[None]) & (lo[None] <= hi[:, None]), axis=-1)
    out = []
    for i, j in zip(*np.nonzero(np.triu(over, 1))):
        a, b = sides[i], sides[j]
        if a.face_index == b.face_index:
            continue
        # a stretch of both segments within the tolerance of the other (every 4th sample checked)
        da = np.linalg.norm(a.xyz[::4, None] - b.xyz[None], axis=-1).min(axis=1)
        db = np.linalg.norm(b.xyz[::4, None] - a.xyz[None], axis=-1).min(axis=1)
        if (da <= tolerance).sum() < 3 or (db <= tolerance).sum() < 3:
            continue
        if max_angle_deg < 180.0:
            ka = np.flatnonzero(da <= tolerance) * 4
            tb = b.project(a.xyz[ka], tolerance)
            good = np.isfinite(tb)
            if not good.any():
                continue
            na = a.face.oriented_normals(a.p.curve.evaluate(a.t[ka[good]]))
            nb = b.face.oriented_normals(b.p.curve.evaluate(tb[good]))
            cos = np.einsum("ij,ij->i", na, nb)
            cos = cos[np.isfinite(cos)]
            # faces of a loose model may come in either sense: a fold (normals opposite) is as smooth
            if not len(cos) or np.degrees(np.arccos(np.clip(np.abs(cos).min(), -1, 1))) > max_angle_deg:
                continue
        out.append(((a.face_index, a.axis), (b.face_index, b.axis),
                    _loose_map(a, b, tolerance), _loose_map(b, a, tolerance)))
    return out


def merge_finest(sets: list, lo: float, hi: float, *, cluster: float = _CLUSTER, slack: float = _SLACK) -> np.ndarray:
    """About the coarsest subset of the union of value sets that is nowhere coarser than any of them.

    Each set covers [min, max] of its values; at a point x it asks for a spacing
    no larger than its own interval around x. Values of different sets closer
    than `cluster` x that spacing are one line (the first set's value, else
    their mean), since two lines that close only make needle triangles. Walking
    the rest from `lo`, the next value kept is the farthest one whose step stays
    within `slack` x the smallest interval any set has along the step.

    Parameters
    ----------
    sets : list of 1-D float arrays
        The first set's values are preferred (the class root's own lines).
    lo, hi : float
        The ends (always kept).
    cluster, slack : float

    Examples
    --------
    >>> a = np.linspace(0, 1, 5)           # spacing 0.25
    >>> b = np.linspace(0, 1, 9)[:5]       # spacing 0.125 on [0, 0.5]
    >>> merge_finest([a, b], 0.0, 1.0).tolist()
    [0.0, 0.125, 0.25, 0.375, 0.5, 0.75, 1.0]
    >>> merge_finest([a, a + 0.01], 0.0, 1.0).tolist()    # nearly the same lines twice: kept once
    [0.0, 0.25, 0.5, 0.75, 1.0]
    """
    sets = [np.unique(np.asarray(s, dtype=np.float64)) for s in sets]
    first = sets[0] if sets else np.zeros(0)
    u = np.unique(np.concatenate(sets + [np.array([lo, hi])]))
    u = u[(u >= lo) & (u <= hi)]
    if len(u) < 3:
        return u

    def need_at(x):
        need = np.full(len(x), np.inf)
        for s in sets:
            if len(s) < 2:
                continue
            k = np.searchsorted(s, x)
            cov = (k > 0) & (k < len(s))
            kk = np.clip(k, 1, len(s) - 1)
            need = np.where(cov, np.minimum(need, s[kk] - s[kk - 1]), need)
        return np.where(np.isfinite(need), need, hi - lo)

    # 1. clusters of nearly coincident lines -> one value; a line that close to an end -> the end
    need = need_at(0.5 * (u[:-1] + u[1:]))
    reps, k, n = [lo], 1, len(u)
    while k < n - 1:
        j = k
        # the cluster's span against the spacing on both sides of it (a set's last line must not be
        # pulled into another set's longer interval)
        m = min(need[k - 1], need[k])
        while j + 1 < n - 1 and u[j + 1] - u[k] <= cluster * min(m, need[j + 1]):
            m = min(m, need[j + 1])
            j += 1
        group = u[k:j + 1]
        own = group[np.isin(group, first)]
        reps.append(float(own[0]) if len(own) else float(group.mean()))
        k = j + 1
    u = np.array(reps + [hi])
    if len(u) > 2:
        need = need_at(0.5 * (u[:-1] + u[1:]))
        drop = np.zeros(len(u), dtype=bool)
        drop[1] = u[1] - u[0] <= cluster * need[:2].min()
        drop[-2] |= u[-1] - u[-2] <= cluster * need[-2:].min()
        u = u[~drop]
    # 2. greedy: the longest steps nowhere coarser than any set (with slack)
    scale = slack * need_at(0.5 * (u[:-1] + u[1:]))
    keep = [0]
    a, n = 0, len(u)
    while a < n - 1:
        b = a + 1
        m = scale[a]
        while b < n - 1 and u[b + 1] - u[a] <= min(m, scale[b]):
            m = min(m, scale[b])
            b += 1
        keep.append(b)
        a = b
    return u[keep]


def common_parameterization(shell: Shell, faces: list, grids: dict, *, max_angle_deg: float = _MAX_ANGLE,
                            tolerance: float | None = None) -> set:
    """One set of transversal domain values per class of faces linked by shared iso-parametric edges, in place.

    Parameters
    ----------
    shell : Shell
        With edges (`Edge.uses`).
    faces : list of TrimmedFace
        The (repaired) faces, index as in the shell.
    grids : dict face index -> (us, vs)
        The faces' domain values; updated.
    max_angle_deg : float
        Only edges along which the faces meet tangent-continuously (oriented
        normals within this angle) link faces: across a crease reflection lines
        break anyway, and linking there (all faces of a revolved part share one
        angular parameter) only forces the finest face's lines onto all of them.
        180: every shared iso-parametric edge.
    tolerance : float or None
        A shell without shared edges (VDA-FS, loose IGES): iso-parametric loop
        segments of different faces that run within `tolerance` of each other in
        3D are linked (through closest points); None: shared edges only.

    Returns
    -------
    set of int
        The faces whose domain values changed.
    """
    adj: dict = {}
    links = _links(shell, faces, grids, max_angle_deg)
    if not any(len(e.uses) == 2 for e in shell.edges) and tolerance is not None:
        links = _loose_links(faces, grids, tolerance, max_angle_deg)
    for a, b, fab, fba in links:
        # node -> [(neighbour, map node -> neighbour, map neighbour -> node)], one entry per shared edge
        adj.setdefault(a, []).append((b, fab, fba))
        adj.setdefault(b, []).append((a, fba, fab))
    changed: set = set()
    seen: set = set()

    def values(node):
        return np.asarray(grids[node[0]][node[1]], dtype=np.float64)

    for start in sorted(adj, key=lambda nd: (-len(values(nd)), nd)):
        if start in seen:
            continue
        # BFS tree from the node with the most values; a node maps to the root through every edge it
        # shares with its parent (two faces may meet along several edges, each covering part of a range)
        parent = {start: None}
        order = [start]
        seen.add(start)
        queue = deque([start])
        while queue:
            p = queue.popleft()
            for c, _, _ in adj[p]:
                if c not in seen:
                    seen.add(c)
                    parent[c] = p
                    order.append(c)
                    queue.append(c)
        if len(order) < 2:
            continue
        to_root = {start: lambda x: np.asarray(x, dtype=np.float64)}
        for c in order[1:]:
            ups = [f_cp for q, f_cp, _ in adj[c] if q == parent[c]]
            to_root[c] = (lambda x, g=to_root[parent[c]], hs=tuple(ups): _nan_safe(g, _first(hs, x)))
        root_vals = values(start)
        lo, hi = float(root_vals[0]), float(root_vals[-1])
        mapped = {}
        for nd in order:
            v = values(nd)
            inner = v[1:-1]                      # the grid box ends stay the face's own
            mapped[nd] = (v, inner, to_root[nd](inner))
        sets = [r[np.isfinite(r)] for _, _, r in mapped.values()]
        sets[0] = root_vals
        common = merge_finest(sets, lo, hi)
        back = {start: common[1:-1]}
        for c in order[1:]:
            downs = [f_pc for q, _, f_pc in adj[c] if q == parent[c]]
            img = [f(back[parent[c]]) for f in downs] if len(back[parent[c]]) else []
            back[c] = np.concatenate([x[np.isfinite(x)] for x in img]) if img else np.zeros(0)
        for nd in order:
            v, inner, r = mapped[nd]
            # values outside the part of the face the edges cover (no image at the root) stay its own
            own = inner[~np.isfinite(r)] if nd != start else np.zeros(0)
            vals = np.unique(np.r_[v[0], own, back[nd], v[-1]])
            vals = vals[(vals >= v[0]) & (vals <= v[-1])]
            vals = _drop_near(vals, v[0], v[-1])
            if len(vals) != len(v) or np.any(vals != v):
                fi, ax = nd
                us, vs = grids[fi]
                grids[fi] = (vals, vs) if ax == 0 else (us, vals)
                changed.add(fi)
    return changed


def _first(maps, x) -> np.ndarray:
    """Per value, the first finite image among several partial maps (NaN where none covers it)."""
    x = np.asarray(x, dtype=np.float64)
    out = np.full(len(x), np.nan)
    for f in maps:
        todo = ~np.isfinite(out) & np.isfinite(x)
        if not todo.any():
            break
        out[todo] = f(x[todo])
    return out


def _nan_safe(f, x):
    x = np.asarray(x, dtype=np.float64)
    out = np.full(len(x), np.nan)
    ok = np.isfinite(x)
    if ok.any():
        out[ok] = f(x[ok])
    return out


def _drop_near(vals: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Values closer than 1e-9 of the range to their predecessor removed (the ends kept)."""
    if len(vals) < 3:
        return vals
    eps = 1e-9 * (hi - lo)
    keep = np.r_[True, np.diff(vals) > eps]
    out = vals[keep]
    out[-1] = vals[-1]                 # the upper end stays exactly (it replaces a value just below it)
    return out
