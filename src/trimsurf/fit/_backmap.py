"""Step 4: back-maps S: W -> R^3 (Sec. 4.2): NURBS extrapolation, thin-plate-spline RBF, the hybrid, and better fits.

=============  ==================================================================================
method         surface S
=============  ==================================================================================
``nurbs``      Sec. 4.2.1: control points grown ring by ring from a block W_0 inside phi(M):
               phi^-1(w) (barycentric) where w in phi(M), else the extrapolation S_i(w)
``rbf``        Sec. 4.2.2, eq. (10)-(11): thin-plate-spline RBF with S(u_i) = x_i
               (the face written to STEP carries its least-squares cubic B-spline conversion)
``hybrid``     Sec. 4.2.3: P = f(W) with f the RBF, S the cubic NURBS on P (the paper's choice)
``greville``   as hybrid, but P = f at the Greville abscissae of S's knots (beyond the paper)
``lsq``        least-squares cubic B-spline on W's knots through the vertices and a dense sample of
               H(W): mesh points inside phi(M), the RBF extrapolation outside (beyond the paper)
=============  ==================================================================================
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.interpolate import BSpline, RBFInterpolator

from ..errors import InputError
from ..model import NurbsSurface, TriMesh
from ._grid import ParameterGrid, clamped_knots, greville, locate

__all__ = ["BackMap", "BACKMAPS", "backmap", "rbf_map", "nurbs_extrapolation", "hybrid", "greville_hybrid",
           "lsq_fit"]

#: RBF centres above this count are thinned (a dense TPS solve is O(n^3)).
RBF_MAX_CENTRES = 2500


@dataclass(frozen=True, eq=False)
class BackMap:
    """A back-map S: R^2 -> R^3 over the grid W.

    Attributes
    ----------
    method : str
    surface : NurbsSurface
        The NURBS S (for ``rbf``: its NURBS conversion, written to STEP).
    grid : ParameterGrid
    evaluate : callable
        ``evaluate(uv (k, 2)) -> (k, 3)``: S itself (the RBF for ``rbf``, else the NURBS).
    control_grid : (nu, nv, 3) float64
        P = f(W) before the NURBS was built (the control polyhedron of the paper).
    """

    method: str
    surface: NurbsSurface
    grid: ParameterGrid
    evaluate: Callable[[np.ndarray], np.ndarray]
    control_grid: np.ndarray


def _nurbs_on_grid(grid: ParameterGrid, ctrl: np.ndarray, degree: int = 3) -> NurbsSurface:
    nu, nv = grid.shape
    pu, pv = min(degree, nu - 1), min(degree, nv - 1)
    ku = clamped_knots(grid.u[0], grid.u[-1], nu, pu)
    kv = clamped_knots(grid.v[0], grid.v[-1], nv, pv)
    return NurbsSurface(pu, pv, ku, kv, np.ascontiguousarray(ctrl))


def _bspline_fn(surface: NurbsSurface) -> Callable[[np.ndarray], np.ndarray]:
    return lambda uv: surface.evaluate(np.asarray(uv, dtype=np.float64).reshape(-1, 2))


def rbf_map(mesh: TriMesh, uv: np.ndarray, *, max_centres: int = RBF_MAX_CENTRES, smoothing: float = 0.0,
            seed: int = 0) -> RBFInterpolator:
    """f: R^2 -> R^3, the thin-plate-spline RBF with f(u_i) = x_i (eq. (10); phi(r) = r^2 ln r, eq. (11)).

    A linear polynomial R(w) is added (the stabilising polynomial of eq. (10)).
    Meshes with more than `max_centres` vertices use every boundary vertex and
    an even spread of interior vertices (one per cell of a uniform (u, v) grid)
    as centres.
    """
    n = len(uv)
    idx = np.arange(n)
    if n > max_centres:
        bnd = np.unique(mesh.boundary_edges())
        n_cells = max(max_centres - len(bnd), 16)
        lo, hi = uv.min(axis=0), uv.max(axis=0)
        ext = np.maximum(hi - lo, 1e-300)
        # cell size so that about n_cells cells hold data (the data fill only part of the box)
        h = np.sqrt(ext[0] * ext[1] / n_cells)
        for _ in range(8):
            cell = np.floor((uv - lo) / h).astype(np.int64)
            key = cell[:, 0] * (int(ext[1] / h) + 2) + cell[:, 1]
            rng = np.random.default_rng(seed)
            perm = rng.permutation(n)
            _, first = np.unique(key[perm], return_index=True)
            if len(first) >= 0.8 * n_cells:
                break
            h *= 0.8
        idx = np.union1d(perm[first], bnd)
    return RBFInterpolator(uv[idx], mesh.vertices[idx], kernel="thin_plate_spline", degree=1, smoothing=smoothing)


def hybrid(mesh: TriMesh, uv: np.ndarray, grid: ParameterGrid, *, f: RBFInterpolator | None = None) -> BackMap:
    """Sec. 4.2.3: control polyhedron P = f(W) from the RBF, S the cubic B-spline with control points P."""
    f = rbf_map(mesh, uv) if f is None else f
    ctrl = f(grid.points().reshape(-1, 2)).reshape(*grid.shape, 3)
    s = _nurbs_on_grid(grid, ctrl)
    return BackMap("hybrid", s, grid, _bspline_fn(s), ctrl)


def greville_hybrid(mesh: TriMesh, uv: np.ndarray, grid: ParameterGrid, *, f: RBFInterpolator | None = None
                    ) -> BackMap:
    """As `hybrid`, but P_ij = f(xi_i, eta_j) at the Greville abscissae of S's clamped knots.

    A B-spline whose control points sample a function at the Greville
    abscissae reproduces linear functions exactly and has an O(h^2) error,
    where P = f(W) on the uniform grid is off by O(h) near the clamped ends.
    """
    f = rbf_map(mesh, uv) if f is None else f
    base = _nurbs_on_grid(grid, np.zeros((*grid.shape, 3)))
    gu, gv = greville(base.knots_u, base.degree_u), greville(base.knots_v, base.degree_v)
    uu, vv = np.meshgrid(gu, gv, indexing="ij")
    ctrl = f(np.column_stack([uu.ravel(), vv.ravel()])).reshape(*grid.shape, 3)
    s = _nurbs_on_grid(grid, ctrl)
    return BackMap("greville", s, grid, _bspline_fn(s), ctrl)


def _dense_grid(grid: ParameterGrid, base: NurbsSurface, oversample: int) -> np.ndarray:
    """A regular grid of `oversample` points per knot span over H(W), (k, 2)."""
    nu, nv = grid.shape
    su = np.linspace(grid.u[0], grid.u[-1], oversample * (nu - base.degree_u) + 1)
    sv = np.linspace(grid.v[0], grid.v[-1], oversample * (nv - base.degree_v) + 1)
    uu, vv = np.meshgrid(su, sv, indexing="ij")
    return np.column_stack([uu.ravel(), vv.ravel()])


def _lsq_control_points(grid: ParameterGrid, base: NurbsSurface, pts: np.ndarray, vals: np.ndarray,
                        smooth: float) -> np.ndarray:
    """Control points (nu, nv, 3) of the cubic B-spline on W's knots fitting vals at pts by least squares, with
    a thin-plate penalty `smooth` relative to the data term (sparse normal equations)."""
    from scipy import sparse
    from scipy.sparse import linalg as sla

    nu, nv = grid.shape
    # data weight: each sample stands for an equal share of the parameter area
    bu = BSpline.design_matrix(np.clip(pts[:, 0], grid.u[0], grid.u[-1]), base.knots_u, base.degree_u).tocsr()
    bv = BSpline.design_matrix(np.clip(pts[:, 1], grid.v[0], grid.v[-1]), base.knots_v, base.degree_v).tocsr()
    # row-wise Kronecker product: B[k, i * nv + j] = bu[k, i] * bv[k, j]
    bu_c, bv_c = bu.tocoo(), bv.tocoo()
    rows_u, cols_u, val_u = bu_c.row, bu_c.col, bu_c.data
    order_u = np.argsort(rows_u, kind="stable")
    rows_u, cols_u, val_u = rows_u[order_u], cols_u[order_u], val_u[order_u]
    rows_v, cols_v, val_v = bv_c.row, bv_c.col, bv_c.data
    order_v = np.argsort(rows_v, kind="stable")
    rows_v, cols_v, val_v = rows_v[order_v], cols_v[order_v], val_v[order_v]
    cu = np.bincount(rows_u, minlength=len(pts))
    cv = np.bincount(rows_v, minlength=len(pts))
    if np.all(cu == cu[0]) and np.all(cv == cv[0]):
        a, b = int(cu[0]), int(cv[0])
        ci = cols_u.reshape(-1, a)[:, :, None] * nv + cols_v.reshape(-1, b)[:, None, :]
        cvals = val_u.reshape(-1, a)[:, :, None] * val_v.reshape(-1, b)[:, None, :]
        rr = np.repeat(np.arange(len(pts)), a * b)
        B = sparse.csr_matrix((cvals.ravel(), (rr, ci.ravel())), shape=(len(pts), nu * nv))
    else:  # pragma: no cover - design_matrix always gives degree + 1 entries per row
        B = sparse.csr_matrix(sparse.vstack([sparse.kron(bu[k], bv[k]) for k in range(len(pts))]))
    # second differences of the control net along u, v and mixed: a discrete thin-plate energy
    def d2(n: int) -> sparse.csr_matrix:
        return sparse.diags([1.0, -2.0, 1.0], [0, 1, 2], shape=(n - 2, n)).tocsr()

    def d1(n: int) -> sparse.csr_matrix:
        return sparse.diags([-1.0, 1.0], [0, 1], shape=(n - 1, n)).tocsr()

    iu, iv = sparse.identity(nu), sparse.identity(nv)
    R = sparse.vstack([sparse.kron(d2(nu), iv), sparse.kron(iu, d2(nv)),
                       np.sqrt(2.0) * sparse.kron(d1(nu), d1(nv))]).tocsr()
    BtB = (B.T @ B).tocsc()
    lam = smooth * float(BtB.diagonal().mean()) / max(float((R.T @ R).diagonal().mean()), 1e-300)
    A = (BtB + lam * (R.T @ R)).tocsc()
    return sla.splu(A).solve(np.asarray(B.T @ vals)).reshape(nu, nv, 3)


def lsq_fit(mesh: TriMesh, uv: np.ndarray, grid: ParameterGrid, *, f: RBFInterpolator | None = None,
            oversample: int = 3, smooth: float = 1e-6, far_keep: int | None = 1) -> BackMap:
    """Least-squares cubic B-spline on W's knots through the mesh vertices and a dense RBF sample around them.

    Data: every vertex (u_i, x_i), and a regular grid of `oversample` points
    per knot span over H(W) with values phi^-1(w) (the mesh point, by
    barycentric coordinates) where w lies in phi(M), and the RBF
    extrapolation f(w) of M elsewhere (holes, concavities, the margin of W).
    So every knot span has data however the mesh is spread. Outside phi(M)
    and more than two knot spans from every vertex the grid is thinned to
    `far_keep` points per knot span (None: all); only control points without
    data of their own rest on those. A small thin-plate (second-difference)
    penalty `smooth`, relative to the data term, keeps control points
    without data defined. Solved by sparse normal equations.
    """
    f = rbf_map(mesh, uv) if f is None else f
    base = _nurbs_on_grid(grid, np.zeros((*grid.shape, 3)))
    dense = _dense_grid(grid, base, oversample)
    tri, bary = locate(uv, mesh.triangles, dense)
    inside = tri >= 0
    if far_keep is not None and oversample > far_keep:
        # outside phi(M) and more than two knot spans from every vertex: only control points without data of
        # their own rest on these RBF values; keep `far_keep` per knot span there (the RBF is the costly part)
        from scipy.spatial import cKDTree

        h = max(grid.u[1] - grid.u[0], grid.v[1] - grid.v[0])
        far = ~inside & (cKDTree(uv).query(dense, distance_upper_bound=2 * h)[0] > 2 * h)
        ns = oversample * (grid.shape[1] - base.degree_v) + 1
        iu, iv = np.divmod(np.arange(len(dense)), ns)
        step = oversample // far_keep
        drop = far & ((iu % step != 0) | (iv % step != 0))
        dense, tri, bary, inside = dense[~drop], tri[~drop], bary[~drop], inside[~drop]
    dense_vals = np.empty((len(dense), 3))
    dense_vals[inside] = np.einsum("kj,kjd->kd", bary[inside], mesh.vertices[mesh.triangles[tri[inside]]])
    if (~inside).any():
        dense_vals[~inside] = f(dense[~inside])
    pts = np.vstack([uv, dense])
    vals = np.vstack([mesh.vertices, dense_vals])
    ctrl = _lsq_control_points(grid, base, pts, vals, smooth)
    s = _nurbs_on_grid(grid, ctrl)
    return BackMap("lsq", s, grid, _bspline_fn(s), ctrl)


def rbf_surface(mesh: TriMesh, uv: np.ndarray, grid: ParameterGrid, *, f: RBFInterpolator | None = None,
                oversample: int = 3, smooth: float = 1e-6) -> BackMap:
    """Sec. 4.2.2: S = f, the thin-plate-spline RBF itself; for STEP it is converted to a cubic B-spline.

    The conversion (``surface``, what a STEP file holds) is the least-squares
    cubic B-spline on W's knots through the RBF's own values: at the vertex
    parameters u_i and on a grid of `oversample` points per knot span over
    H(W) (the RBF inside phi(M) too, not the mesh). ``evaluate`` is the RBF;
    the figures of the written face are those of the conversion.
    """
    f = rbf_map(mesh, uv) if f is None else f
    base = _nurbs_on_grid(grid, np.zeros((*grid.shape, 3)))
    pts = np.vstack([uv, _dense_grid(grid, base, oversample)])
    ctrl = _lsq_control_points(grid, base, pts, f(pts), smooth)
    conv = _nurbs_on_grid(grid, ctrl)
    return BackMap("rbf", conv, grid, lambda w: f(np.asarray(w, dtype=np.float64).reshape(-1, 2)), ctrl)


# ----------------------------------------------------------------------------- Sec. 4.2.1


def _uniform_knots(coords: np.ndarray, degree: int, h: float) -> np.ndarray:
    """Uniform (unclamped) knots of spacing h whose Greville abscissae are the uniform `coords`."""
    k = np.arange(len(coords) + degree + 1)
    return coords[0] + (k - (degree + 1) / 2.0) * h


def _extrapolate(ctrl: np.ndarray, cu: np.ndarray, cv: np.ndarray, pts: np.ndarray, h: tuple[float, float],
                 degree: int) -> np.ndarray:
    """S_i(w) for the B-spline on the block's control net (Greville abscissae at the block's grid points),
    evaluated beyond its domain by continuing its end polynomial pieces."""
    pu, pv = min(degree, len(cu) - 1), min(degree, len(cv) - 1)
    tu, tv = _uniform_knots(cu, pu, h[0]), _uniform_knots(cv, pv, h[1])
    bu = BSpline.design_matrix(pts[:, 0], tu, pu, extrapolate=True).toarray()   # (k, nu)
    bv = BSpline.design_matrix(pts[:, 1], tv, pv, extrapolate=True).toarray()   # (k, nv)
    return np.einsum("ka,abd,kb->kd", bu, ctrl, bv)


def _largest_inside_block(inside: np.ndarray) -> tuple[int, int, int, int]:
    """(i0, i1, j0, j1) of a large all-True block of `inside` (largest square, then grown greedily)."""
    nu, nv = inside.shape
    best = np.zeros((nu + 1, nv + 1), dtype=np.int64)
    for i in range(nu):
        for j in range(nv):
            if inside[i, j]:
                best[i + 1, j + 1] = 1 + min(best[i, j + 1], best[i + 1, j], best[i, j])
    s = int(best.max())
    if s == 0:
        raise InputError("nurbs extrapolation: no grid point of W falls inside phi(M); use a finer --grid")
    i1, j1 = np.unravel_index(int(np.argmax(best)), best.shape)
    i0, j0 = i1 - s, j1 - s
    grown = True
    while grown:
        grown = False
        for di0, di1, dj0, dj1 in ((-1, 0, 0, 0), (0, 1, 0, 0), (0, 0, -1, 0), (0, 0, 0, 1)):
            a0, a1, b0, b1 = i0 + di0, i1 + di1, j0 + dj0, j1 + dj1
            if a0 >= 0 and b0 >= 0 and a1 <= nu and b1 <= nv and inside[a0:a1, b0:b1].all():
                i0, i1, j0, j1 = a0, a1, b0, b1
                grown = True
    return int(i0), int(i1), int(j0), int(j1)


def nurbs_extrapolation(mesh: TriMesh, uv: np.ndarray, grid: ParameterGrid, *, extrapolation_degree: int = 3
                        ) -> BackMap:
    """Sec. 4.2.1: the control polyhedron grown by iterative extrapolation (Fig. 3).

    S_i, the surface extrapolated at each ring, is the B-spline of degree
    `extrapolation_degree` on the control net P_i so far (its Greville
    abscissae at W_i's grid points), continued beyond its domain by its end
    polynomial pieces: 3 is the paper's cubic NURBS (eq. (9)); 1 (bilinear)
    is kept as an option (benchmarks/RESULTS.md compares the two).

    1. W_0: a block of W inside phi(M) (the largest square of grid points
       inside, grown while it stays inside); 2. its control points
       P_0 = phi^-1(W_0) by barycentric coordinates in the parameter
       triangulation; 3. S_i: the B-spline on P_i; 4.-5. W_i grows by one
       ring of grid points; a new w gets phi^-1(w) when w lies in phi(M), else
       the extrapolation S_i(w); 6. repeat until W_i = W; 7. S: the cubic
       NURBS (eq. (9)) on P.
    """
    if extrapolation_degree not in (1, 2, 3):
        raise InputError(f"extrapolation_degree must be 1, 2 or 3; got {extrapolation_degree!r}")
    pts = grid.points()
    nu, nv = grid.shape
    tri, bary = locate(uv, mesh.triangles, pts.reshape(-1, 2))
    inside = (tri >= 0).reshape(nu, nv)
    mapped = np.full((nu * nv, 3), np.nan)
    ok = tri >= 0
    mapped[ok] = np.einsum("kj,kjd->kd", bary[ok], mesh.vertices[mesh.triangles[tri[ok]]])
    mapped = mapped.reshape(nu, nv, 3)
    i0, i1, j0, j1 = _largest_inside_block(inside)
    ctrl = np.full((nu, nv, 3), np.nan)
    ctrl[i0:i1, j0:j1] = mapped[i0:i1, j0:j1]
    while (i0, i1, j0, j1) != (0, nu, 0, nv):
        a0, a1, b0, b1 = max(i0 - 1, 0), min(i1 + 1, nu), max(j0 - 1, 0), min(j1 + 1, nv)
        new = np.zeros((nu, nv), dtype=bool)
        new[a0:a1, b0:b1] = True
        new[i0:i1, j0:j1] = False
        ii, jj = np.nonzero(new)
        ext = _extrapolate(ctrl[i0:i1, j0:j1], grid.u[i0:i1], grid.v[j0:j1], pts[ii, jj],
                           (grid.u[1] - grid.u[0], grid.v[1] - grid.v[0]), extrapolation_degree)
        ctrl[ii, jj] = np.where(inside[ii, jj][:, None], mapped[ii, jj], ext)
        i0, i1, j0, j1 = a0, a1, b0, b1
    s = _nurbs_on_grid(grid, ctrl)
    return BackMap("nurbs", s, grid, _bspline_fn(s), ctrl)


BACKMAPS = {"hybrid": hybrid, "rbf": rbf_surface, "nurbs": nurbs_extrapolation, "greville": greville_hybrid,
            "lsq": lsq_fit}


def backmap(mesh: TriMesh, uv: np.ndarray, grid: ParameterGrid, method: str = "lsq", **options) -> BackMap:
    """S by `method` (see the module table); `uv` are the vertex parameters U = phi(X)."""
    if method not in BACKMAPS:
        raise InputError(f"unknown back-map {method!r}; expected one of {', '.join(BACKMAPS)}")
    return BACKMAPS[method](mesh, uv, grid, **options)
