"""The measurement's shortcuts change no figure (issue 17, item 2).

- `project_to_surface(..., skip_below=...)`: a point keeps its first run only where the full search's
  distance is below the threshold too; at or above it, the distance is the full search's, bit for bit.
- The refinement projects an edge node shared by two triangles once, and stops at the warm-started run
  for nodes below their triangle's and face's maxima: the report's figures on a real model equal those
  of projecting every node with the full search.
- The projection keeps each surface's checked arrays by their contents: changing an array in place
  between calls gives the new surface's answer.
- The seed grid's compiled radii and pole test are the numpy expressions' numbers.
"""

import numpy as np
import pytest

import trimsurf.geom.projection as P
import trimsurf.quality.deviation as D
from trimsurf.geom import project_to_surface
from trimsurf.geom._seed_kernels import seed_grid_kernel
from trimsurf.io import read_shell
from trimsurf.model import NurbsSurface
from trimsurf.tessellate import tessellate_shell
from trimsurf.tessellate.measure import measure_result


def wavy():
    rng = np.random.default_rng(7)
    n, p = 12, 3
    g = np.linspace(0, 1, n)
    cp = np.zeros((n, n, 3))
    cp[..., 0], cp[..., 1] = g[:, None], g[None, :]
    cp[..., 2] = 0.2 * np.sin(6 * g[:, None]) * np.cos(5 * g[None, :]) + 0.02 * rng.standard_normal((n, n))
    kn = np.r_[np.zeros(p), np.linspace(0, 1, n - p + 1), np.ones(p)]
    return NurbsSurface(p, p, kn, kn, cp, rng.uniform(0.5, 2.0, (n, n)))


def _args(s):
    return (s.degree_u, s.degree_v, s.knots_u, s.knots_v, s.control_points, s.weights)


def test_skip_below_changes_no_distance_at_or_above_the_threshold(monkeypatch):
    s = wavy()
    rng = np.random.default_rng(1)
    uv = rng.uniform(0, 1, (3000, 2))
    d1 = s.derivatives(uv, 1)
    nrm = np.cross(d1[1, 0], d1[0, 1])
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    pts = d1[0, 0] + rng.uniform(-0.05, 0.05, (len(uv), 1)) * nrm
    # warm starts near the foot, and a tenth far off (redone from the seeds)
    uv0 = np.clip(uv + rng.normal(0, 0.02, uv.shape), 0, 1)
    uv0[::10] = rng.uniform(0, 1, (len(uv0[::10]), 2))
    full = project_to_surface(pts, *_args(s), uv0=uv0, compiled=True)
    thr = rng.uniform(0, 0.06, len(pts))
    for start in (uv0, None):
        ref = full if start is not None else project_to_surface(pts, *_args(s), compiled=True)
        asked = []
        real = P._nearest_seeds
        monkeypatch.setattr(P, "_nearest_seeds", lambda tree, q, k: asked.append((len(q), k)) or real(tree, q, k))
        skip = project_to_surface(pts, *_args(s), uv0=start, compiled=True, skip_below=thr)
        monkeypatch.setattr(P, "_nearest_seeds", real)
        above = ref.distance >= thr
        # the same answer to "does it reach its threshold?", and the full search's numbers where it does
        np.testing.assert_array_equal(skip.distance >= thr, above)
        np.testing.assert_array_equal(skip.distance[above], ref.distance[above])
        np.testing.assert_array_equal(skip.uv[above], ref.uv[above])
        # below: the first run's distance, never below the full search's by more than its allowance
        assert np.all(skip.distance >= ref.distance - 1e-8)
        # the shortcut is taken: only the points left over ask for the k nearest seeds and restarts
        assert np.count_nonzero(~above) > 100 and np.count_nonzero(above) > 100
        n_search = sum(n for n, k in asked if k > 1)
        if start is None:       # without a warm start nothing is skipped
            assert n_search == len(pts)
        else:
            assert np.count_nonzero(above) <= n_search < 0.8 * len(pts)


def _plain_project_once(pts, uv0, on_edge, face, tol_rel, below=None):
    return D.project_to_face(pts, face, tol_rel=tol_rel, uv0=uv0).distance


@pytest.fixture(scope="module")
def screw(shared_data):
    import trimsurf.tessellate.face as face_mod

    shell = read_shell(shared_data / "cad" / "occt__screw.step")
    d = shell.diagonal()
    # the aspect limit on developable faces too (the rule before session 29): the 862-triangle mesh the
    # floors below were set on (540 triangles and 5,109 projected points with the new default)
    with pytest.MonkeyPatch.context() as m:
        m.setattr(face_mod, "LIMIT_DEVELOPABLE", True)
        return shell, tessellate_shell(shell, tolerance=1e-3 * d, max_edge=d, measure=False)


def test_refinement_shortcuts_change_no_figure(screw, monkeypatch):
    shell, res = screw
    P._SEED_CACHE.clear()
    fast = measure_result(res, shell)
    calls = []
    real = D.project_to_face

    def counted(*a, **k):
        calls.append(len(a[0]))
        return real(*a, **k)

    with monkeypatch.context() as m:
        # every node projected (no chord-bound pruning), each with the full search
        m.setattr(D, "_project_once", _plain_project_once)
        m.setattr(D, "project_to_face", counted)
        m.setattr(D, "_chord_bound", lambda surface, uv, pts, tol_rel: np.full(len(pts), np.inf))
        P._SEED_CACHE.clear()
        slow = measure_result(res, shell)
    for k in fast:
        if k not in ("seconds_measure", "deviation_samples"):
            assert fast[k] == slow[k], k
    assert fast["deviation_samples"] < slow["deviation_samples"]
    # the refinement ran (nodes were projected again), so the comparison covers the shortcuts
    assert fast["deviation_samples"] > 10 * res.mesh.n_triangles
    # (15,093 projected points since the shared-edge chord tolerance is the faces' own, SHARED_CHORD = 0.97:
    # the screw's tol-only mesh has 862 triangles, 906 before, and fewer thin ones at its arcs)
    assert sum(calls) > 10_000


def test_cached_surface_data_follow_in_place_changes():
    s = wavy()
    ku, kv, cp, w = s.knots_u.copy(), s.knots_v.copy(), s.control_points.copy(), s.weights.copy()
    pts = s.evaluate(np.array([[0.3, 0.6], [0.7, 0.2]])) + [0.0, 0.0, 0.01]
    before = project_to_surface(pts, 3, 3, ku, kv, cp, w, compiled=True)
    cp *= 2.0          # the caller's arrays change in place
    ku[:] = ku * 2.0
    w[:] = 1.0
    again = project_to_surface(pts, 3, 3, ku, kv, cp, w, compiled=True)
    P._SEED_CACHE.clear()
    fresh = project_to_surface(pts, 3, 3, ku.copy(), kv.copy(), cp.copy(), w.copy(), compiled=True)
    np.testing.assert_array_equal(again.uv, fresh.uv)
    np.testing.assert_array_equal(again.distance, fresh.distance)
    assert np.all(np.abs(again.distance - before.distance) > 1e-3)     # not the old surface's answer


def test_seed_grid_kernel_is_the_numpy_expression():
    s2 = np.sqrt(0.5)
    octant = NurbsSurface(2, 2, [0, 0, 0, 1, 1, 1], [0, 0, 0, 1, 1, 1],
                          np.array([[[0, 0, 1], [0, 0, 1], [0, 0, 1]], [[1, 0, 1], [1, 1, 1], [0, 1, 1]],
                                    [[1, 0, 0], [1, 1, 0], [0, 1, 0]]], float), np.outer([1, s2, 1], [1, s2, 1]))
    for s in (wavy(), octant):
        axes = P._seed_values(None, (s.knots_u, s.knots_v), (s.degree_u, s.degree_v), "t")
        params = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 2)
        pts = s.evaluate(params).reshape(len(axes[0]), len(axes[1]), 3)
        shape = pts.shape[:2]
        radius = np.zeros(shape)
        pad = np.pad(pts, [(1, 1), (1, 1), (0, 0)], mode="edge")
        for off in np.ndindex(3, 3):
            window = pad[off[0]:off[0] + shape[0], off[1]:off[1] + shape[1]]
            np.maximum(radius, np.linalg.norm(window - pts, axis=-1), out=radius)
        spread = [np.ptp(np.take(pts, e, axis=a), axis=0).max() for a in (0, 1) for e in (0, -1)]
        r2, s2_ = np.empty(shape), np.empty(4)
        seed_grid_kernel(np.ascontiguousarray(pts), r2, s2_)
        np.testing.assert_array_equal(r2, radius)
        np.testing.assert_array_equal(s2_, spread)
    # the octant's v = 0 line is a pole: spread 0 there
    assert s2_.min() == 0.0


def test_measure_at_a_density_without_centroid_nodes(screw):
    """`measure_mesh(density=2)`: no grid node at the centroids, so `flipped_against_normal` projects them
    itself (regression: the face state's trim-polygon list landed in its centroid field, positionally,
    and the flip check failed on a (0,) array); its figures obey the same stopping rule."""
    from trimsurf.tessellate.measure import measure_mesh

    shell, res = screw
    m2 = measure_mesh(res.mesh, shell, density=2)
    m3 = measure_mesh(res.mesh, shell)
    assert m2["flipped"] == m3["flipped"] == 0
    assert m2["max_deviation"] <= m2["max_deviation_bound"] <= 1.01 * m2["max_deviation"]
    assert abs(m2["max_deviation"] / m3["max_deviation"] - 1.0) < 0.01
