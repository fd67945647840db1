"""Session 28's cheaper measurement steps against the paths they replace, bit for bit.

- `geom._seed_kernels.memo_points_kernel` (`quality.deviation._grid_points`, the seed grids of
  `geom.projection`): surface points with each distinct u and v value's span and basis computed once, the
  numbers of ``NurbsSurface.evaluate`` (`surface_derivatives_kernel` with nd = 0);
- `geom.projection`: a Newton run from a seed sample evaluates its start in the kernel (the seeds hold their
  points only), tested against seeds with every sample's derivatives in
  tests/quality/test_measure_shortcuts27.py (`_eager`).
"""

import numpy as np
import pytest

import trimsurf.geom._seed_kernels as SK
import trimsurf.geom.projection as P
from trimsurf.quality.deviation import _grid_points
from trimsurf.quality.sampling import sample_face_domain


def _same_bits(a, b):
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


def _cases(surface, rng, n_grid=(32, 32)):
    (u0, u1), (v0, v1) = surface.domain
    gu, gv = np.meshgrid(np.linspace(u0, u1, n_grid[0]), np.linspace(v0, v1, n_grid[1]), indexing="ij")
    grid = np.column_stack([gu.ravel(), gv.ravel()])
    rand = np.column_stack([rng.uniform(u0, u1, 200), rng.uniform(v0, v1, 200)])
    # values repeated in scattered order, points on and just outside the domain's ends (clamped)
    rep = rand[rng.integers(0, 200, 600)]
    rep[:, 1] = rand[rng.integers(0, 200, 600), 1]
    ends = np.array([[u0, v0], [u1, v1], [u0 - 1e-9, v1 + 1e-9], [np.nextafter(u1, np.inf), v0]])
    return [grid, rand, rep, ends, np.concatenate([grid, rep, ends])]


@pytest.mark.parametrize("name", ["occt__screw.step", "gmsh__U_Joint_2.stp", "gmsh__t20_data.step",
                                  "gmsh__wing_fuselage.step"])
def test_memo_points_are_the_surface_points(shared_data, name):
    # every face of four real shells (polynomial and rational, cubic, planar): the measurement's own grids
    # (32 x 32 and the footprint grid's) and grids, scattered points and repeated values over the domain
    from trimsurf.io import read_shell
    shell = read_shell(shared_data / "cad" / name)
    rng = np.random.default_rng(5)
    for face in shell.faces:
        s = face.surface
        cases = _cases(s, rng) + [sample_face_domain(face, n=32), sample_face_domain(face, n=(70, 45))]
        for uv in cases:
            assert _same_bits(_grid_points(s, uv), s.evaluate(uv))


@pytest.mark.parametrize("pu, pv, seed", [(1, 1, 102), (2, 3, 5), (3, 3, 7), (3, 2, 11)])
def test_memo_points_on_random_bsplines_with_creases(pu, pv, seed):
    from trimsurf.model import NurbsSurface
    from ..geom.test_projection import random_bspline
    surf, _ = random_bspline(pu, pv, seed)
    s = NurbsSurface(*surf)
    rng = np.random.default_rng(seed)
    for uv in _cases(s, rng, (41, 17)):
        assert _same_bits(_grid_points(s, uv), s.evaluate(uv))


def test_memo_table_overflow_computes_the_rest_directly():
    # more distinct values than half the table: the values beyond are computed per point, the same numbers
    from trimsurf.model import NurbsSurface
    from ..geom.test_projection import random_bspline
    surf, _ = random_bspline(3, 3, 7)
    s = NurbsSurface(*surf)
    rng = np.random.default_rng(1)
    (u0, u1), (v0, v1) = s.domain
    n = 3 * SK.MEMO_SLOTS
    uv = np.column_stack([rng.uniform(u0, u1, n), rng.uniform(v0, v1, n)])
    uv = np.concatenate([uv, uv[::-1]])             # the values seen before the table filled, and after
    assert _same_bits(_grid_points(s, uv), s.evaluate(uv))


def test_seed_grid_points_are_the_evaluated_points(shared_data):
    # the k-d tree and the neighbour radii are built on `memo_points_kernel`'s points: the same bits as the
    # points `_eval_d2` (the Newton kernel's start state) gives at the seed parameters
    from trimsurf.geom import project_to_surface
    from trimsurf.geom.nurbs import _homogeneous, read_only
    from trimsurf.io import read_shell
    shell = read_shell(shared_data / "cad" / "gmsh__U_Joint_2.stp")
    for face in shell.faces[::4]:
        s = face.surface
        P._SEED_CACHE.clear()
        project_to_surface(s.evaluate(np.array([[np.mean(s.domain[0]), np.mean(s.domain[1])]])), s.degree_u,
                           s.degree_v, s.knots_u, s.knots_v, s.control_points, s.weights, compiled=True)
        sd = [v for v in P._SEED_CACHE.values() if isinstance(v, P._Seeds)][0]
        surf = (s.degree_u, s.degree_v, read_only(s.knots_u), read_only(s.knots_v),
                _homogeneous(s.control_points, s.weights), s.weights is not None)
        assert _same_bits(sd.tree.data, P._surface_eval_compiled(surf, sd.params)[0])
    P._SEED_CACHE.clear()
