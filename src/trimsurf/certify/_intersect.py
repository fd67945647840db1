"""No extraneous intersections: a Volino-Thalmann test over a bounding-volume hierarchy of Bézier pieces.

Sec. 3.2 and 4 of whitney-well-definition.txt: adjoining perturbed patches meet
along b_k by construction; what remains is to exclude any *other* intersection
(between two faces, or of a face with itself), with the Volino-Thalmann method
and the normal bound of Sec. 4.

Hierarchy
---------
Every face's surface F is split into its Bézier pieces (knot spans, The NURBS
Book A5.7); pieces that do not meet the trimmed domain are dropped; pieces are
grouped by halving the span-index ranges, and a piece can be halved further
in u and v by de Casteljau subdivision (up to `max_extra_depth` times). Each
node carries

* a box: the control points of F over the node (a rational Bézier piece with
  positive weights lies in their convex hull) widened by the certified bound
  on |a_i| per component, so it contains the perturbed patch G = F + a;
* a normal cone of G: the cone spanned by the Bézier coefficients of the
  normal polynomial N = (w P_u - w_u P) x (w P_v - w_v P) of the piece (it
  contains every normal of F there, for rational pieces too since w^4 > 0),
  widened by the normal bound of Sec. 4 bounded over the whole piece from its
  control net (`bezier_piece_normal_bound`; a piece whose coefficient cone
  reaches 90 degrees is subdivided); grouped nodes take
  the union of their children's cones; only for surfaces with more than
  `max_pieces` spans, normals sampled on a 5 x 5 grid widened by half the
  largest angle between neighbours;
* its boundary tags: the edges and vertices of the shell whose Whitney samples lie in the node.

Test (Volino and Thalmann 1994)
-------------------------------
A region whose normal cone has half-angle below 90 degrees and whose contour,
projected along the cone axis, does not cross itself, is a graph over the
plane normal to the axis, hence free of self-intersection. Two regions that
are adjacent (touching pieces of one face, or pieces of two faces carrying a
common edge or vertex) cannot meet other than along their common boundary if
the union of their cones is below 90 degrees and their projections along the
common axis do not overlap (sampled interior points of each outside the
projected outline of the other). Non-adjacent regions must have disjoint
boxes. Otherwise the larger node is split and the test recurses; a pair that
is still undecided at the finest level is reported (faces, (u, v) boxes and a
point in space).

Soundness: boxes are rigorous; the cones of G are rigorous on Bézier pieces
(the cone of F's normal polynomial widened by the control-net bound of Sec. 4 over the
piece; sampled on a 5 x 5 grid only for surfaces with more than `max_pieces` spans);
contours and overlaps are tested on sampled outlines
(piecewise-linear in (u, v), mapped exactly through G). The independent check
(`validate_with_mesh`) tessellates the well-defined shell finely and runs the
exact triangle-triangle test of `trimsurf.quality.self_intersections`.

References
----------
P. Volino, N. Magnenat Thalmann, "Efficient self-collision detection on
smoothly discretized surface animations using geometrical shape regularity",
Computer Graphics Forum 13(3) (1994) 155-166.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from ..geom import bezier_extract_surface, points_in_polygons, polyline_self_intersections
from ._normal import normal_angle_bound
from ._perturb import PerturbedFace

__all__ = ["IntersectionFinding", "FaceHierarchy", "build_hierarchy", "excluded_self", "excluded_pair"]

_GRID = 5             # normal samples per direction per node
_CONTOUR = 8          # contour samples per rect side
_MARGIN = 1e-3        # radians kept below 90 degrees


@dataclass
class IntersectionFinding:
    """Where the test could not exclude an intersection."""

    faces: tuple[int, int]
    uv_box_a: tuple[float, float, float, float]
    uv_box_b: tuple[float, float, float, float]
    point: tuple[float, float, float]
    reason: str

    def as_dict(self) -> dict:
        return {"faces": list(self.faces), "uv_box_a": list(self.uv_box_a), "uv_box_b": list(self.uv_box_b),
                "point": list(self.point), "reason": self.reason}


@dataclass(eq=False)
class _Node:
    face: int
    rect: tuple[float, float, float, float]      # u0, u1, v0, v1
    hcp: np.ndarray | None                       # homogeneous Bézier piece (p+1, q+1, 4) for leaf pieces
    depth: int
    children: list["_Node"] = field(default_factory=list)
    lo: np.ndarray = None
    hi: np.ndarray = None
    axis: np.ndarray = None
    half: float = 0.0
    tags: frozenset = frozenset()
    pts: np.ndarray = None                       # points whose convex hull contains F over the node
    phi_max: float = np.inf                      # largest sampled normal bound of Sec. 4 on the node
    cone: tuple = None                           # the cone used by the test (`FaceHierarchy.cone`)
    err: np.ndarray = None                       # per-component bound on |a_i| (G within err of F)
    _split_done: bool = False

    @property
    def diag(self) -> float:
        return float(np.linalg.norm(self.hi - self.lo))


class FaceHierarchy:
    """The bounding-volume hierarchy of one perturbed face (see the module docstring)."""

    def __init__(self, g: PerturbedFace, face_index: int, *, max_extra_depth: int = 4, max_pieces: int = 4096):
        self.g = g
        self.face = face_index
        self.max_extra_depth = int(max_extra_depth)
        s = g.face.surface
        bez = bezier_extract_surface(s.degree_u, s.degree_v, s.knots_u, s.knots_v, s.control_points, s.weights)
        w = np.ones(bez.control_points.shape[:-1]) if bez.weights is None else bez.weights
        self._h = np.concatenate([bez.control_points * w[..., None], w[..., None]], axis=-1)
        self._ub, self._vb = bez.u_breaks, bez.v_breaks
        self._loops = [lp.uv for lp in g.boundary.loops]
        # G at a boundary sample is its target exactly (b_k(t_i)): no extension to evaluate there
        self._exact = {(float(u), float(v)): tg for lp in g.boundary.loops for (u, v), tg in zip(lp.uv, lp.target)}
        self._cache: dict = {}
        bnd = np.concatenate(self._loops)
        self._bnd = bnd
        # tags: edge key k >= 0, shell vertex v as -(v + 1)
        self._bnd_tag = np.concatenate([lp.edge_key.astype(np.int64) for lp in g.boundary.loops])
        self._bnd_vtag = np.concatenate([-(lp.vertex.astype(np.int64) + 1) for lp in g.boundary.loops])
        self._err = np.abs(g._v).max(axis=0, initial=0.0)       # per-component bound on |a_i|
        (u0, u1), (v0, v1) = s.domain
        self._tol = 1e-9 * max(u1 - u0, v1 - v0)
        m, n = len(self._ub) - 1, len(self._vb) - 1
        if m * n > max_pieces:
            self._h = None  # too many pieces: one level of grouping only from sampling
        self.root = self._group(0, m, 0, n, 0)

    # -- construction -----------------------------------------------------------------
    def _meets_domain(self, rect) -> bool:
        u0, u1, v0, v1 = rect
        t = self._tol
        b = self._bnd
        if np.any((b[:, 0] >= u0 - t) & (b[:, 0] <= u1 + t) & (b[:, 1] >= v0 - t) & (b[:, 1] <= v1 + t)):
            return True
        gu, gv = np.meshgrid(np.linspace(u0, u1, 3), np.linspace(v0, v1, 3))
        return bool(points_in_polygons(np.column_stack([gu.ravel(), gv.ravel()]), self._loops).any())

    def _group(self, i0, i1, j0, j1, depth) -> _Node | None:
        rect = (float(self._ub[i0]), float(self._ub[i1]), float(self._vb[j0]), float(self._vb[j1]))
        if not self._meets_domain(rect):
            return None
        if i1 - i0 == 1 and j1 - j0 == 1:
            node = _Node(self.face, rect, None if self._h is None else self._h[i0, j0], depth)
            self._finish(node)
            return node
        node = _Node(self.face, rect, None, depth)
        if i1 - i0 >= j1 - j0:
            mid = (i0 + i1) // 2
            kids = [self._group(i0, mid, j0, j1, depth + 1), self._group(mid, i1, j0, j1, depth + 1)]
        else:
            mid = (j0 + j1) // 2
            kids = [self._group(i0, i1, j0, mid, depth + 1), self._group(i0, i1, mid, j1, depth + 1)]
        node.children = [k for k in kids if k is not None]
        node._split_done = True
        if len(node.children) == 1:
            return node.children[0]
        node.lo = np.min([k.lo for k in node.children], axis=0)
        node.hi = np.max([k.hi for k in node.children], axis=0)
        node.pts = np.concatenate([k.pts for k in node.children])
        if len(node.pts) > 512:
            node.pts = _corners(node.lo, node.hi)
        node.axis, node.half = _cone_union([(k.axis, k.half) for k in node.children])
        node.tags = frozenset().union(*[k.tags for k in node.children])
        return node

    def _finish(self, node: _Node) -> None:
        u0, u1, v0, v1 = node.rect
        if node.hcp is not None:
            pts = (node.hcp[..., :3] / node.hcp[..., 3:]).reshape(-1, 3)
            node.pts = pts
            node.lo = pts.min(axis=0) - self._err
            node.hi = pts.max(axis=0) + self._err
        gu, gv = np.meshgrid(np.linspace(u0, u1, _GRID), np.linspace(v0, v1, _GRID), indexing="ij")
        uv = np.column_stack([gu.ravel(), gv.ravel()])
        d = self.g.face.surface.derivatives(uv, 1)
        su, sv = d[1, 0], d[0, 1]
        if node.hcp is None:   # box from samples and a chord allowance (only for huge control nets)
            p = d[0, 0]
            ext = 0.25 * (np.linalg.norm(su, axis=1).max() * (u1 - u0) + np.linalg.norm(sv, axis=1).max() * (v1 - v0))
            node.lo = p.min(axis=0) - self._err - ext
            node.hi = p.max(axis=0) + self._err + ext
            node.pts = _corners(node.lo, node.hi)
        nrm = np.cross(su, sv)
        ln = np.linalg.norm(nrm, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            nrm = nrm / ln[:, None]
        if not np.all(np.isfinite(nrm)) or np.any(ln <= 0):
            node.axis, node.half = np.array([0.0, 0.0, 1.0]), np.pi
        else:
            if not self.g.face.same_sense:
                nrm = -nrm
            phi = normal_angle_bound(su, sv, nrm, self.g.lipschitz).phi_rad
            node.phi_max = float(np.max(phi))
            axis = nrm.mean(axis=0)
            na = np.linalg.norm(axis)
            if na < 1e-12:
                node.axis, node.half = np.array([0.0, 0.0, 1.0]), np.pi
            else:
                axis /= na
                ang = np.arccos(np.clip(nrm @ axis, -1, 1))
                grid = nrm.reshape(_GRID, _GRID, 3)
                nb = max(float(np.arccos(np.clip(np.einsum("ijk,ijk->ij", grid[1:], grid[:-1]), -1, 1)).max()),
                         float(np.arccos(np.clip(np.einsum("ijk,ijk->ij", grid[:, 1:], grid[:, :-1]), -1, 1)).max()))
                node.axis, node.half = axis, float(np.max(ang + phi) + 0.5 * nb)
        b = self._bnd
        t = self._tol
        inside = (b[:, 0] >= u0 - t) & (b[:, 0] <= u1 + t) & (b[:, 1] >= v0 - t) & (b[:, 1] <= v1 + t)
        vt = self._bnd_vtag[inside]
        node.tags = frozenset(self._bnd_tag[inside].tolist()) | frozenset(vt[vt < 0].tolist())

    def cone(self, node: _Node) -> tuple[np.ndarray, float]:
        """The normal cone of G over the node used by the test (computed when first needed).

        Bézier pieces: the rigorous cone of the normal polynomial's coefficients widened by the normal
        bound of Sec. 4 over the whole piece from its control net (`bezier_piece_normal_bound`; none, i.e.
        180 degrees, where the coefficients reach 90 degrees: the piece must be subdivided); grouped nodes: the union of their children's cones; pieces of
        surfaces with too many spans to extract: the sampled cone of `_finish`."""
        if node.cone is not None:
            return node.cone
        result = (node.axis, node.half)
        if node.hcp is not None:
            exact = bezier_piece_normal_bound(node.hcp, node.rect, self.g.lipschitz)
            if exact is None or exact[2] >= np.pi:   # no cone below 90 degrees, or no normal bound: subdivide
                result = (node.axis, np.pi)
            else:
                axis, half, phi = exact
                if not self.g.face.same_sense:
                    axis = -axis
                result = (axis, float(half + phi))
        elif node.hcp is None and node.children:
            result = _cone_union([self.cone(k) for k in node.children])
        node.cone = result
        return result

    def children(self, node: _Node) -> list[_Node]:
        """The node's children, splitting a Bézier piece into four by de Casteljau when allowed."""
        if node._split_done:
            return node.children
        node._split_done = True
        if node.hcp is None or node.depth >= self._leaf_depth_limit(node):
            return node.children
        u0, u1, v0, v1 = node.rect
        um, vm = 0.5 * (u0 + u1), 0.5 * (v0 + v1)
        left, right = _split_half(node.hcp, 0)
        kids = []
        for hu, (a, b) in ((left, (u0, um)), (right, (um, u1))):
            bottom, top = _split_half(hu, 1)
            for hv, (c, d) in ((bottom, (v0, vm)), (top, (vm, v1))):
                rect = (a, b, c, d)
                if self._meets_domain(rect):
                    k = _Node(self.face, rect, hv, node.depth + 1)
                    k._extra = getattr(node, "_extra", 0) + 1
                    self._finish(k)
                    kids.append(k)
        node.children = kids
        return kids

    def _leaf_depth_limit(self, node: _Node) -> int:
        return node.depth + (1 if getattr(node, "_extra", 0) < self.max_extra_depth else 0)

    def contour(self, node: _Node, n: int = _CONTOUR) -> np.ndarray:
        """G on the node's (u, v) rectangle boundary, counter-clockwise, (4n, 3)."""
        key = ("contour", id(node), n)
        if key in self._cache:
            return self._cache[key]
        u0, u1, v0, v1 = node.rect
        s = np.linspace(0.0, 1.0, n, endpoint=False)
        uv = np.concatenate([np.column_stack([u0 + (u1 - u0) * s, np.full(n, v0)]),
                             np.column_stack([np.full(n, u1), v0 + (v1 - v0) * s]),
                             np.column_stack([u1 - (u1 - u0) * s, np.full(n, v1)]),
                             np.column_stack([np.full(n, u0), v1 - (v1 - v0) * s])])
        self._cache[key] = self.g.evaluate(uv)
        return self._cache[key]

    def trimmed_outline(self, node: _Node) -> tuple[list[np.ndarray], np.ndarray]:
        """The node's part of the trimmed domain: every loop clipped to the rect, mapped by G (the region
        is their even-odd union), and G at interior samples away from the trim boundary."""
        key = ("trim", id(node))
        if key in self._cache:
            return self._cache[key]
        polys = [q for q in (_clip_rect(lp, node.rect) for lp in self._loops) if len(q) >= 3]
        u0, u1, v0, v1 = node.rect
        gu, gv = np.meshgrid(np.linspace(u0, u1, 7)[1:-1], np.linspace(v0, v1, 7)[1:-1], indexing="ij")
        pts = np.column_stack([gu.ravel(), gv.ravel()])
        if len(pts):
            pts = pts[points_in_polygons(pts, self._loops)]
            # away from the trim boundary: 1/12 of the rect size
            if len(pts):
                d = np.min(np.linalg.norm(pts[:, None, :] - self._bnd[None, :, :], axis=2), axis=1)
                pts = pts[d > max(u1 - u0, v1 - v0) / 12.0]
        outlines = [self._evaluate_outline(q) for q in polys]
        inner = self.g.evaluate(pts) if len(pts) else np.zeros((0, 3))
        self._cache[key] = (outlines, inner)
        return outlines, inner

    def _evaluate_outline(self, q: np.ndarray) -> np.ndarray:
        out = np.empty((len(q), 3))
        todo = []
        for i, (u, v) in enumerate(q):
            tg = self._exact.get((float(u), float(v)))
            if tg is None:
                todo.append(i)
            else:
                out[i] = tg
        if todo:
            out[todo] = self.g.evaluate(q[todo])
        return out


@lru_cache(maxsize=256)
def _product_weights(ma: int, mb: int) -> np.ndarray:
    """S[r, i, k] = C(ma, i) C(mb, k) / C(ma + mb, r) where i + k = r: Bernstein product weights."""
    from math import comb

    w = np.zeros((ma + mb + 1, ma + 1, mb + 1))
    for i in range(ma + 1):
        for k in range(mb + 1):
            w[i + k, i, k] = comb(ma, i) * comb(mb, k) / comb(ma + mb, i + k)
    return w


def _bprod(a: np.ndarray, b: np.ndarray, op) -> np.ndarray:
    """Bézier coefficients of op(f, g) for tensor Bézier polynomials f, g (bilinear op: product, cross).

    a : (ma+1, na+1, da), b : (mb+1, nb+1, db); returns (ma+mb+1, na+nb+1, d)."""
    su = _product_weights(a.shape[0] - 1, b.shape[0] - 1)
    sv = _product_weights(a.shape[1] - 1, b.shape[1] - 1)
    vals = op(a[:, :, None, None, :], b[None, None, :, :, :])      # (ma+1, na+1, mb+1, nb+1, d)
    # sum_{i,k} su[r,i,k] sum_{j,l} sv[s,j,l] vals[i,j,k,l,:] as two tensordots (no einsum path search)
    t1 = np.tensordot(su, vals, axes=([1, 2], [0, 2]))            # (r, na+1, nb+1, d)
    return np.moveaxis(np.tensordot(sv, t1, axes=([1, 2], [1, 2])), 0, 1)   # (r, s, d)


def _mul(x, y):
    return x * y


def _dot(x, y):
    return (x * y).sum(axis=-1, keepdims=True)


def _bezier_normal_cone(h: np.ndarray) -> tuple[np.ndarray, float] | None:
    """A cone containing every normal of a rational Bézier patch (homogeneous control points (p+1, q+1, 4)).

    N = (w P_u - w_u P) x (w P_v - w_v P) / w^4 (P the weighted points) is a polynomial over w^4 > 0; its
    Bézier coefficients c_kl span a convex cone that contains every normal direction. None when the
    coefficients do not lie in an open half-space (no cone below 180 degrees)."""
    coef = _normal_coefficients(h)
    if coef is None:
        return None
    c = coef[2].reshape(-1, 3)
    n = np.linalg.norm(c, axis=1)
    scale = n.max(initial=0.0)
    if scale <= 0:
        return None
    c = c[n > 1e-14 * scale] / n[n > 1e-14 * scale][:, None]
    axis = c.mean(axis=0)
    na = np.linalg.norm(axis)
    if na < 1e-12:
        return None
    axis /= na
    half = float(np.arccos(np.clip(c @ axis, -1, 1)).max())
    if half >= 0.5 * np.pi:
        return None
    return axis, half


def _normal_coefficients(h: np.ndarray):
    """Bézier coefficients (local parameters on [0, 1]^2) of A = w P_u - w_u P, B = w P_v - w_v P and
    N = A x B for a rational Bézier patch (homogeneous control points (p+1, q+1, 4)); F_u = A / w^2 (local),
    the normal of F is N / w^4. For a polynomial patch A, B are the derivative control points."""
    pw, w = h[..., :3], h[..., 3]
    p, q = pw.shape[0] - 1, pw.shape[1] - 1
    if p < 1 or q < 1:
        return None
    du = p * (pw[1:] - pw[:-1])
    dv = q * (pw[:, 1:] - pw[:, :-1])
    if np.allclose(w, w.flat[0], rtol=1e-14, atol=0.0):
        s = 1.0 / w.flat[0]
        a, b = du * s, dv * s               # P / w exactly: A / w^2 = du / w with w constant
        return a, b, _bprod(a, b, np.cross), 1.0, 1.0
    wu = p * (w[1:] - w[:-1])
    wv = q * (w[:, 1:] - w[:, :-1])
    a = _bprod(w[..., None], du, _mul) - _bprod(wu[..., None], pw, _mul)
    b = _bprod(w[..., None], dv, _mul) - _bprod(wv[..., None], pw, _mul)
    return a, b, _bprod(a, b, np.cross), float(w.min()), float(w.max())


def bezier_piece_normal_bound(h: np.ndarray, rect, lipschitz) -> tuple[np.ndarray, float, float] | None:
    """Rigorous normal cone of F over a rational Bézier piece and the largest normal bound of Sec. 4 on it.

    With a, b, c the Bézier coefficients of A, B and N = A x B (`_normal_coefficients`; local parameters,
    rect sizes h_u, h_v), by the convex-hull property, over the whole piece:

    * every normal N lies in the cone of the c_k (axis e, half-angle theta) and
      ``|N| >= min_k c_k . e`` (a convex combination), so in global (u, v)
      ``|F_u x F_v| >= min_k (c_k . e) / (w_max^4 h_u h_v)``;
    * ``|F_u| <= max_k |a_k| / (w_min^2 h_u)``, ``|F_v| <= max_k |b_k| / (w_min^2 h_v)``;
    * ``|F_u . F_v| <= max_k |d_k| / (w_min^4 h_u h_v)``, d the coefficients of A . B;
    * ``lambda_min = |F_u x F_v|^2 / lambda_max`` and lambda_max = (E + G + sqrt((E - G)^2 + 4 F^2)) / 2
      is increasing in E, G and |F|, so with their bounds ``kappa = 1 / sqrt(lambda_min) <=
      sqrt(lambda_max bound) / |N|_min``;
    * ``|n_i| <= min(1, |e_i| + sin theta)`` for a unit normal n in the cone, so
      ``L_n <= min(L_F, sum_i min(1, |e_i| + sin theta) L_i)``;

    and ``tan(phi) <= kappa L_n / (1 - kappa L_F)`` (`trimsurf.certify._normal`). Returns
    (axis, half-angle, phi) with phi = pi where kappa L_F >= 1, or None when the coefficients do not lie
    in an open half-space (no cone below 90 degrees: subdivide).
    """
    coef = _normal_coefficients(h)
    if coef is None:
        return None
    a, b, c, wmin, wmax = coef
    c = c.reshape(-1, 3)
    n = np.linalg.norm(c, axis=1)
    scale = n.max(initial=0.0)
    if scale <= 0:
        return None
    axis = (c / np.where(n > 0, n, 1.0)[:, None])[n > 1e-14 * scale].mean(axis=0)
    na = np.linalg.norm(axis)
    if na < 1e-12:
        return None
    axis /= na
    proj = c @ axis
    nmin = float(proj.min())
    if nmin <= 0:
        return None
    cosang = np.clip(proj / np.where(n > 0, n, 1.0), -1, 1)
    half = float(np.arccos(cosang[n > 0]).max(initial=0.0))
    if half >= 0.5 * np.pi:
        return None
    hu, hv = rect[1] - rect[0], rect[3] - rect[2]
    fu = float(np.linalg.norm(a.reshape(-1, 3), axis=1).max()) / (wmin * wmin * hu)
    fv = float(np.linalg.norm(b.reshape(-1, 3), axis=1).max()) / (wmin * wmin * hv)
    ff = float(np.abs(_bprod(a, b, _dot)).max()) / (wmin ** 4 * hu * hv)     # |F_u . F_v|
    nglob = nmin / (wmax ** 4 * hu * hv)
    big_l = np.broadcast_to(np.asarray(lipschitz, float), (3,))
    lf = float(np.linalg.norm(big_l))
    if lf == 0:
        return axis, half, 0.0
    # lambda_max = (E + G + sqrt((E - G)^2 + 4 F^2)) / 2 grows with E, G and |F|: bounded by their bounds
    e2, g2 = fu * fu, fv * fv
    lam_max = 0.5 * (e2 + g2 + np.sqrt((e2 - g2) ** 2 + 4.0 * ff * ff))
    kappa = np.sqrt(lam_max) / nglob
    ln = min(lf, float(np.minimum(1.0, np.abs(axis) + np.sin(half)) @ big_l))
    if kappa * lf >= 1:
        return axis, half, float(np.pi)
    return axis, half, float(np.arctan(kappa * ln / (1.0 - kappa * lf)))


def _split_half(h: np.ndarray, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """de Casteljau split of a Bézier array at 1/2 along `axis`."""
    p = np.moveaxis(h, axis, 0)
    left, right = [p[0]], [p[-1]]
    cur = p
    for _ in range(1, p.shape[0]):
        cur = 0.5 * (cur[:-1] + cur[1:])
        left.append(cur[0])
        right.append(cur[-1])
    return np.moveaxis(np.stack(left), 0, axis), np.moveaxis(np.stack(right[::-1]), 0, axis)


def _cone_union(cones) -> tuple[np.ndarray, float]:
    axis, half = cones[0]
    axis = np.asarray(axis, float)
    for a2, h2 in cones[1:]:
        if half >= np.pi or h2 >= np.pi:
            return np.array([0.0, 0.0, 1.0]), np.pi
        theta = float(np.arccos(np.clip(axis @ a2, -1, 1)))
        if theta + h2 <= half:
            continue
        if theta + half <= h2:
            axis, half = np.asarray(a2, float), h2
            continue
        new_half = 0.5 * (theta + half + h2)
        if new_half >= np.pi:
            return np.array([0.0, 0.0, 1.0]), np.pi
        if theta < 1e-12:
            half = max(half, h2)
            continue
        # rotate axis towards a2 by (new_half - half)
        rot = new_half - half
        perp = np.asarray(a2, float) - np.cos(theta) * axis
        pn = np.linalg.norm(perp)
        if pn < 1e-12:        # opposite axes: any perpendicular direction
            perp = _basis(axis)[:, 0]
        else:
            perp /= pn
        axis = np.cos(rot) * axis + np.sin(rot) * perp
        half = new_half
    return axis, float(half)


def _clip_rect(poly: np.ndarray, rect) -> np.ndarray:
    """Sutherland-Hodgman clipping of a polygon by an axis-aligned rectangle."""
    u0, u1, v0, v1 = rect
    out = np.asarray(poly, float)
    for axis, bound, keep_ge in ((0, u0, True), (0, u1, False), (1, v0, True), (1, v1, False)):
        if not len(out):
            break
        cur = out
        prev = np.roll(cur, 1, axis=0)
        inside_c = cur[:, axis] >= bound if keep_ge else cur[:, axis] <= bound
        inside_p = prev[:, axis] >= bound if keep_ge else prev[:, axis] <= bound
        cross = inside_c != inside_p
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (bound - prev[:, axis]) / (cur[:, axis] - prev[:, axis])
            hit = prev + t[:, None] * (cur - prev)
        # per vertex: [crossing point if the edge crosses] then [the vertex if inside], in order
        both = np.stack([hit, cur], axis=1).reshape(-1, 2)
        mask = np.stack([cross, inside_c], axis=1).reshape(-1)
        out = both[mask]
    return out


def _basis(axis: np.ndarray) -> np.ndarray:
    a = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(axis, a)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    return np.stack([e1, e2], axis=1)


def _simple(points3: np.ndarray, basis: np.ndarray) -> bool:
    p2 = points3 @ basis
    keep = np.linalg.norm(p2 - np.roll(p2, 1, axis=0), axis=1) > 0
    p2 = p2[keep]
    return len(p2) >= 3 and len(polyline_self_intersections(p2)) == 0


def _corners(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])


def _boxes_disjoint(a: _Node, b: _Node, ea: np.ndarray, eb: np.ndarray) -> bool:
    """Separated by an axis-aligned box test, or by a separating axis among the cone axes and their
    combinations (projections of the convex hulls of the control points, widened by the |a_i| bounds)."""
    if np.any(a.hi < b.lo) or np.any(b.hi < a.lo):
        return True
    axes = [a.axis, b.axis, a.axis + b.axis, a.axis - b.axis, np.cross(a.axis, b.axis)]
    for ax in axes:
        n = np.linalg.norm(ax)
        if n < 1e-12:
            continue
        ax = ax / n
        pa, pb = a.pts @ ax, b.pts @ ax
        ra, rb = float(np.abs(ax) @ ea), float(np.abs(ax) @ eb)
        if pa.max() + ra < pb.min() - rb or pb.max() + rb < pa.min() - ra:
            return True
    return False


def _rects_touch(a: _Node, b: _Node, tol: float) -> bool:
    return (a.rect[0] <= b.rect[1] + tol and b.rect[0] <= a.rect[1] + tol
            and a.rect[2] <= b.rect[3] + tol and b.rect[2] <= a.rect[3] + tol)


class _Budget:
    def __init__(self, n: int):
        self.left = n


def excluded_self(h: FaceHierarchy, *, budget: int = 20000, findings: list | None = None) -> bool:
    """Whether the VT test excludes self-intersection of the perturbed face (findings appended where not)."""
    findings = [] if findings is None else findings
    bud = _Budget(budget)
    if h.root is None:
        return True
    return _self_ok(h, h.root, bud, findings)


def _finding(a: _Node, b: _Node, reason: str) -> IntersectionFinding:
    lo = np.maximum(a.lo, b.lo)
    hi = np.minimum(a.hi, b.hi)
    c = 0.5 * (lo + hi)
    return IntersectionFinding((a.face, b.face), tuple(map(float, a.rect)), tuple(map(float, b.rect)),
                               tuple(map(float, c)), reason)


def _self_ok(h: FaceHierarchy, node: _Node, bud: _Budget, findings: list) -> bool:
    bud.left -= 1
    axis, half = h.cone(node)
    if half < 0.5 * np.pi - _MARGIN and _simple(h.contour(node), _basis(axis)):
        return True
    kids = h.children(node)
    if not kids or bud.left <= 0:
        findings.append(_finding(node, node, "normal cone of a finest piece reaches 90 degrees"
                                 if bud.left > 0 else "test budget exhausted"))
        return False
    for i, k in enumerate(kids):
        if not _self_ok(h, k, bud, findings):
            return False
        for k2 in kids[i + 1:]:
            if not _pair_ok(h, k, h, k2, bud, findings):
                return False
    return True


def excluded_pair(ha: FaceHierarchy, hb: FaceHierarchy, *, budget: int = 20000,
                  findings: list | None = None) -> bool:
    """Whether the VT test excludes intersections of two faces other than along common edges/vertices."""
    findings = [] if findings is None else findings
    if ha.root is None or hb.root is None:
        return True
    return _pair_ok(ha, ha.root, hb, hb.root, _Budget(budget), findings)


def _adjacent_ok(ha: FaceHierarchy, a: _Node, hb: FaceHierarchy, b: _Node) -> bool:
    axis, half = _cone_union([ha.cone(a), hb.cone(b)])
    if half >= 0.5 * np.pi - _MARGIN:
        return False
    basis = _basis(axis)
    if not (_simple(ha.contour(a), basis) and _simple(hb.contour(b), basis)):
        return False
    same = ha is hb
    for (h1, n1), (h2, n2) in (((ha, a), (hb, b)), ((hb, b), (ha, a))):
        if same:
            outlines = [h2.contour(n2)]
            u0, u1, v0, v1 = n1.rect
            gu, gv = np.meshgrid(np.linspace(u0, u1, 7)[1:-1], np.linspace(v0, v1, 7)[1:-1], indexing="ij")
            inner = h1.g.evaluate(np.column_stack([gu.ravel(), gv.ravel()]))
        else:
            outlines, _ = h2.trimmed_outline(n2)
            _, inner = h1.trimmed_outline(n1)
        if not outlines or not len(inner):
            continue
        if points_in_polygons(inner @ basis, [o @ basis for o in outlines]).any():
            return False
    return True


def _pair_ok(ha: FaceHierarchy, a: _Node, hb: FaceHierarchy, b: _Node, bud: _Budget, findings: list) -> bool:
    bud.left -= 1
    if _boxes_disjoint(a, b, ha._err, hb._err):
        return True
    if ha is hb:
        adjacent = _rects_touch(a, b, ha._tol) or bool(a.tags & b.tags)
    else:
        adjacent = bool(a.tags & b.tags)
    if adjacent and _adjacent_ok(ha, a, hb, b):
        return True
    if bud.left <= 0:
        findings.append(_finding(a, b, "test budget exhausted"))
        return False
    ka = ha.children(a)
    kb = hb.children(b)
    if not ka and not kb:
        findings.append(_finding(a, b, "adjacent pieces fold onto each other (normal cones or projections overlap)"
                                 if adjacent else "boxes of finest pieces overlap"))
        return False
    if ka and (not kb or a.diag >= b.diag):
        return all(_pair_ok(ha, k, hb, b, bud, findings) for k in ka)
    return all(_pair_ok(ha, a, hb, k, bud, findings) for k in kb)


def build_hierarchy(g: PerturbedFace, face_index: int, **options) -> FaceHierarchy:
    """The BVH of one perturbed face (see `FaceHierarchy`)."""
    return FaceHierarchy(g, face_index, **options)
