"""Session 27's cheaper measurement steps against the paths they replace, bit for bit.

- `geom.projection`: the compiled path's seed grids evaluate the points alone and each sample's
  derivatives on its first start (`_seed_state`) instead of every sample's second derivatives up front;
- `quality._kernels.grid_closest_kernel`: the shell search stops once the best distance is within the
  exact distance to the searched cube's faces (was: (r - 1) x the cell side);
- `quality.deviation._groups`: the refinement's (k, k_prev, k_first) groups without ``np.unique(axis=0)``.
"""

import numpy as np
import pytest

import trimsurf.geom.projection as P
from trimsurf.geom import project_to_surface, surface_points
from trimsurf.quality._kernels import hint_closest_kernel
from trimsurf.quality.closest_point import _closest, _TriangleLocator
from trimsurf.quality.deviation import _groups


def _eager(monkeypatch):
    """`_build_seeds` as before: every sample's derivatives evaluated with the grid."""
    orig = P._build_seeds

    def build(axes, evaluate, diag, *, check_poles=True, points=None):
        return orig(axes, evaluate, diag, check_poles=check_poles)
    monkeypatch.setattr(P, "_build_seeds", build)


def _project_both(monkeypatch, surf, pts, **kw):
    P._SEED_CACHE.clear()
    lazy = project_to_surface(pts, *surf, compiled=True, **kw)
    lazy2 = project_to_surface(pts[::-1].copy(), *surf, compiled=True, **kw)     # the cached, half-filled seeds
    P._SEED_CACHE.clear()
    with monkeypatch.context() as m:
        _eager(m)
        eager = project_to_surface(pts, *surf, compiled=True, **kw)
        eager2 = project_to_surface(pts[::-1].copy(), *surf, compiled=True, **kw)
    P._SEED_CACHE.clear()
    for a, b in ((lazy, eager), (lazy2, eager2)):
        for name in ("uv", "foot", "distance", "converged", "on_boundary"):
            assert np.array_equal(getattr(a, name), getattr(b, name)), name
        assert a.iterations == b.iterations


def _shell_faces(shared_data, name):
    from trimsurf.io import read_shell
    shell = read_shell(shared_data / "cad" / name)
    return shell


@pytest.mark.parametrize("name", ["occt__screw.step", "gmsh__t20_data.step"])
def test_lazy_seed_derivatives_give_the_eager_projection(shared_data, monkeypatch, name):
    # every face of two real shells: points near the face, far, and on it, with and without warm starts and
    # the settled-run threshold; the seed points the tree is built on are `_eval_d2`'s points bit for bit
    shell = _shell_faces(shared_data, name)
    diag = shell.diagonal()
    rng = np.random.default_rng(3)
    for face in shell.faces:
        s = face.surface
        surf = (s.degree_u, s.degree_v, s.knots_u, s.knots_v, s.control_points, s.weights)
        (u0, u1), (v0, v1) = s.domain
        uv = np.c_[rng.uniform(u0, u1, 60), rng.uniform(v0, v1, 60)]
        on = s.evaluate(uv)
        pts = np.concatenate([on, on + rng.normal(scale=3e-3 * diag, size=on.shape),
                              on + rng.normal(scale=0.2 * diag, size=on.shape)])
        _project_both(monkeypatch, surf, pts)
        uv0 = np.r_[uv, uv, uv] + rng.normal(scale=0.05, size=(180, 2)) * [u1 - u0, v1 - v0]
        _project_both(monkeypatch, surf, pts, uv0=uv0, skip_below=np.full(len(pts), 1e-3 * diag))


def test_lazy_seed_points_are_the_state_points(shared_data):
    # the tree and the radii use the points-only evaluation (session 28: `memo_points_kernel`); a start from a
    # seed is evaluated by the Newton kernel itself (`_seed_state` None): `_eval_d2`'s point, the same numbers
    from trimsurf.geom.nurbs import _homogeneous, read_only
    shell = _shell_faces(shared_data, "occt__screw.step")
    for face in shell.faces:
        s = face.surface
        P._SEED_CACHE.clear()
        project_to_surface(s.evaluate(np.array([[np.mean(s.domain[0]), np.mean(s.domain[1])]])), s.degree_u,
                           s.degree_v, s.knots_u, s.knots_v, s.control_points, s.weights, compiled=True)
        seeds = [v for v in P._SEED_CACHE.values() if isinstance(v, P._Seeds)]
        assert len(seeds) == 1 and seeds[0].ders is None
        sd = seeds[0]
        surf = (s.degree_u, s.degree_v, read_only(s.knots_u), read_only(s.knots_v),
                _homogeneous(s.control_points, s.weights), s.weights is not None)
        full = P._surface_eval_compiled(surf, sd.params)
        assert np.array_equal(sd.tree.data.view(np.uint64), full[0].view(np.uint64))
        assert P._seed_state(sd, np.arange(len(sd.params))) is None
    P._SEED_CACHE.clear()


@pytest.mark.parametrize("pu, pv, seed", [(1, 1, 102), (2, 3, 5), (3, 3, 7)])
def test_lazy_seeds_on_random_bsplines_with_creases(monkeypatch, pu, pv, seed):
    from ..geom.test_projection import random_bspline
    surf, uv = random_bspline(pu, pv, seed)
    rng = np.random.default_rng(seed)
    pts = surface_points(*surf, uv)
    pts = np.concatenate([pts, pts + rng.normal(scale=0.05, size=pts.shape), rng.uniform(-1, 5, (300, 3))])
    _project_both(monkeypatch, surf, pts)


def _brute(q, loc):
    """The exact minimum over every triangle of `_tri_closest`'s distance (the kernel's own numbers)."""
    m = len(loc.a)
    best = np.full(len(q), np.inf)
    d, t, p, w = np.empty(len(q)), np.empty(len(q), dtype=np.int64), np.empty((len(q), 3)), np.empty((len(q), 3))
    for k in range(m):
        hint_closest_kernel(q, loc.a, loc.b, loc.c, np.full(len(q), k, dtype=np.int64), d, t, p, w)
        np.minimum(best, d, out=best)
    return best


def test_mesh_search_stops_at_the_cube_wall_exactly():
    # queries at 0.05-3 cell sides from a random triangle soup, and on a fine grid near cell walls: the search's
    # distance is the exact minimum over all triangles, bit for bit (a stop before a nearer triangle's shell
    # would leave a larger value)
    rng = np.random.default_rng(11)
    v = rng.uniform(0, 1, (500, 3))
    t = rng.integers(0, 500, (1500, 3))
    t = t[(t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])][:250]
    loc = _TriangleLocator(v, t)
    h = loc.grid[3]
    c = v[t].mean(axis=1)
    dirs = rng.normal(size=(6000, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    q = c[rng.integers(0, len(t), 6000)] + dirs * rng.uniform(0.05, 3.0, (6000, 1)) * h
    origin = loc.grid[2]
    cells = np.floor((q - origin) / h)
    q = np.concatenate([q, origin + (cells + rng.choice([1e-9, 0.5, 1 - 1e-9], size=q.shape)) * h])
    got = _closest(q, loc)
    ref = _brute(q, loc)
    assert np.array_equal(got.distance, ref)
    assert np.array_equal(_closest(q, loc, hint=rng.integers(0, len(t), len(q))).distance, ref)


def test_groups_are_numpys_unique_rows():
    rng = np.random.default_rng(2)
    for _ in range(500):
        n = int(rng.integers(1, 200))
        k = rng.integers(3, 33, n)
        kp = np.where(rng.random(n) < 0.3, 0, rng.integers(0, 33, n))
        k1 = rng.integers(0, 4, n)
        ref = np.unique(np.column_stack([k, kp, k1]), axis=0)
        got = _groups(k, kp, k1)
        assert got.dtype == ref.dtype and got.tolist() == ref.tolist()
    assert _groups(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64)).shape == (0, 3)


@pytest.mark.parametrize("name", ["occt__screw.step", "trimesh__featuretype.STEP", "gmsh__wing_fuselage.step"])
def test_second_forms_from_one_compiled_evaluation(shared_data, name):
    # `_curvature_bound` takes the forms at the vertices' feet and the centres from one compiled evaluation
    # (`_second_forms_two`): the numbers of two `_second_forms` calls, NaN where they are NaN (each group with
    # its own median for the singular test: poles of the fuselage's nose included)
    from trimsurf.quality.deviation import _second_forms, _second_forms_two
    shell = _shell_faces(shared_data, name)
    rng = np.random.default_rng(5)
    for face in shell.faces:
        s = face.surface
        (u0, u1), (v0, v1) = s.domain
        a = np.c_[rng.uniform(u0, u1, 80), rng.uniform(v0, v1, 80)]
        a[:4] = [[u0, v0], [u1, v1], [u0, v1], [u1, v0]]                  # domain corners (poles)
        b = np.c_[rng.uniform(u0, u1, 30), rng.choice([v0, v1, 0.5 * (v0 + v1)], 30)]
        for ua, ub in ((a, b), (a, b[:0]), (a[:0], b), (a[:1], b)):
            for (w, k), uv in zip(_second_forms_two(s, ua, ub), (ua, ub)):
                if not len(uv):                     # (`_second_forms` is never asked for no points)
                    assert w.shape == (0, 3, 3) and k.shape == (0,)
                    continue
                w_ref, k_ref = _second_forms(s, uv)
                assert np.array_equal(w, w_ref, equal_nan=True) and np.array_equal(k, k_ref, equal_nan=True)


def test_enclosing_radius_cross_is_numpys():
    from trimsurf.quality.deviation import _cross
    rng = np.random.default_rng(6)
    for scale in (1e-9, 1.0, 1e7):
        p = rng.normal(size=(20000, 3, 3)) * scale
        a, b = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
        assert np.array_equal(_cross(a, b), np.cross(a, b))


def test_compiled_retry_seeds_are_the_numpy_ones(monkeypatch):
    # `_retry_seeds` of a surface's seed grid in `retry_seeds_kernel`: the same points and seeds as the numpy
    # expressions on random grids, feet (NaN, on grid lines, outside the axes), distances at the limit, with
    # and without the seed each point started from
    rng = np.random.default_rng(8)
    for trial in range(60):
        nu, nv = int(rng.integers(2, 30)), int(rng.integers(2, 30))
        axes = [np.sort(rng.uniform(0, 1, nu)), np.sort(rng.uniform(-1, 1, nv))]
        radius = rng.uniform(0, 0.3, nu * nv)
        n, k = 400, min(8, nu * nv)
        nearest = rng.integers(0, nu * nv, (n, k))
        seed_dist = rng.uniform(0, 1, (n, k))
        foot = np.c_[rng.uniform(-0.2, 1.2, n), rng.uniform(-1.2, 1.2, n)]
        foot[:40, 0] = axes[0][rng.integers(0, nu, 40)]          # exactly on grid lines
        foot[40:50] = np.nan
        dist = rng.uniform(0, 1.2, n)
        dist[50:80] = seed_dist[50:80, 0] - radius[nearest[50:80, 0]] + 1e-3   # limits met exactly
        tol = 1e-3
        used = np.where(rng.random(n) < 0.5, nearest[:, 0], -1)
        seeds = P._Seeds(axes, None, None, radius, None)
        for u in (used, None):
            monkeypatch.setattr(P, "_COMPILED_RETRY", False)
            ref = P._retry_seeds(seeds, nearest, seed_dist, foot, dist, tol, u)
            monkeypatch.setattr(P, "_COMPILED_RETRY", True)
            got = P._retry_seeds(seeds, nearest, seed_dist, foot, dist, tol, u)
            assert np.array_equal(got[0], ref[0]) and np.array_equal(got[1], ref[1])
            assert trial or len(ref[0]) > 20


def test_nonneg_is_nanmax_with_zero():
    from trimsurf.quality.deviation import _nonneg
    for x in (np.nan, -np.inf, -1.0, -0.0, 0.0, 5e-324, 0.3, np.inf):
        assert _nonneg(float(x)) == float(np.nanmax([x, 0.0]))


def _group_nodes_inline(k, k_prev, k_first, surface_only):
    """`_sample_more`'s node selection as it was written inline before `_group_nodes`."""
    from trimsurf.quality.deviation import _bary_grid
    w_all = _bary_grid(int(k))
    if surface_only:
        w_all = w_all[w_all.max(axis=1) < 1.0]
    seen = np.zeros(len(w_all), dtype=bool)
    idx = np.rint(w_all * k).astype(np.int64)
    for kq in {k_prev, k_first} - {0}:
        seen |= np.all(idx * kq % k == 0, axis=1)
    corner = w_all.max(axis=1) >= 1.0
    return w_all[~seen], w_all[~seen | corner]


def test_group_nodes_are_the_inline_selection():
    from trimsurf.quality.deviation import _group_nodes
    for k in range(1, 33):
        for k_prev in range(0, k):
            for k_first in sorted({0, 1, 2, 3, 4, k_prev}):
                for so in (False, True):
                    got = _group_nodes(k, k_prev, k_first, so)
                    ref = _group_nodes_inline(k, k_prev, k_first, so)
                    for g, r in zip(got, ref):
                        assert np.array_equal(g, r) and not g.flags.writeable
    assert len(_group_nodes(6, 3, 3, False)[0]) == 28 - 10      # k = 6 repeats k = 3's 10 nodes


def test_projection_cross_is_numpys():
    # the crease kink test's cross product (`projection._cross3`) on strided rows, as `_kink_rad` passes them
    rng = np.random.default_rng(9)
    for scale in (1e-9, 1.0, 1e7):
        d1 = rng.normal(size=(5000, 2, 3)) * scale
        assert np.array_equal(P._cross3(d1[:, 0], d1[:, 1]), np.cross(d1[:, 0], d1[:, 1]))
