"""Self-intersections: k-d tree candidates and exact triangle-triangle tests."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from trimsurf.errors import InputError
from trimsurf.model import TriMesh
from trimsurf.quality import self_intersections, triangles_intersect
from trimsurf.quality.intersections import _test_pairs
from trimsurf.tolerance import default_tolerance

from ._meshes import flat_grid, icosphere


def brute_force(mesh: TriMesh) -> np.ndarray:
    """All pairs i < j through the same exact test (what the candidate search must not miss)."""
    i, j = np.triu_indices(mesh.n_triangles, 1)
    pairs = np.column_stack([i, j])
    tol = default_tolerance(mesh.diagonal())
    p = mesh.vertices[mesh.triangles]
    return pairs[_test_pairs(p, mesh.triangles, pairs, tol.point, tol.angle_rad)]


def union(a: TriMesh, b: TriMesh) -> TriMesh:
    return TriMesh(np.vstack([a.vertices, b.vertices]), np.vstack([a.triangles, b.triangles + a.n_vertices]))


@pytest.mark.parametrize("t1, t2, hit", [
    ([[0, 0, 0], [2, 0, 0], [0, 2, 0]], [[0.5, 0.5, -1], [0.5, 0.5, 1], [3, 3, 0.2]], True),    # piercing
    ([[0, 0, 0], [2, 0, 0], [0, 2, 0]], [[0, 0, 1], [2, 0, 1], [0, 2, 1]], False),             # parallel
    ([[0, 0, 0], [2, 0, 0], [0, 2, 0]], [[3, 3, -1], [3, 3, 1], [4, 3, 0]], False),            # plane crossed outside
    ([[0, 0, 0], [2, 0, 0], [0, 2, 0]], [[0.5, 0.5, 0], [1, 1, 1], [0, 1, 1]], True),          # vertex touches
    ([[0, 0, 0], [2, 0, 0], [0, 2, 0]], [[0.5, 0.5, 0], [3, 0.5, 0], [0.5, 3, 0]], True),      # coplanar overlap
    ([[0, 0, 0], [2, 0, 0], [0, 2, 0]], [[2, 2, 0], [3, 2, 0], [2, 3, 0]], False),             # coplanar apart
    ([[0, 0, 0], [2, 0, 0], [0, 2, 0]], [[1, 1, 0], [3, 1, 0], [1, 3, 0]], True),             # coplanar touching
])
def test_triangle_pairs(t1, t2, hit):
    assert triangles_intersect([t1], [t2]).tolist() == [hit]
    assert triangles_intersect([t2], [t1]).tolist() == [hit]


def test_closed_sphere_has_none():
    m = icosphere(3)
    r = self_intersections(m)
    assert r.n_pairs == 0 and r.n_candidates > m.n_triangles  # neighbours were tested, none intersect


def test_two_interpenetrating_spheres():
    a, b = icosphere(2), icosphere(2, center=(0.5, 0.0, 0.0))
    m = union(a, b)
    r = self_intersections(m)
    assert r.n_pairs > 0
    assert np.all(r.pairs[:, 0] < a.n_triangles) and np.all(r.pairs[:, 1] >= a.n_triangles)
    # every hit straddles the plane x = 0.25 of the intersection circle (up to the triangles' sagitta)
    xs = m.vertices[m.triangles[np.unique(r.pairs)]][:, :, 0]
    assert np.all((xs.min(axis=1) <= 0.25 + 0.05) & (xs.max(axis=1) >= 0.25 - 0.05))
    assert np.array_equal(r.pairs, brute_force(m))


def test_one_vertex_pushed_through():
    m = icosphere(2)
    top = int(np.argmax(m.vertices[:, 2]))
    v = m.vertices.copy()
    v[top] *= -1.5                                     # through the south side of the sphere
    pushed = TriMesh(v, m.triangles)
    r = self_intersections(pushed)
    fan = np.flatnonzero((m.triangles == top).any(axis=1))
    assert r.n_pairs > 0
    assert np.all(np.isin(r.pairs, fan).any(axis=1))   # every pair involves a triangle of the moved vertex
    assert np.array_equal(r.pairs, brute_force(pushed))


def test_flat_grid_is_clean_even_when_rotated():
    # coplanar neighbours everywhere: the coplanar path must not report touching-free pairs
    for seed in (None, 7):
        assert self_intersections(flat_grid(15, rotate_seed=seed)).n_pairs == 0


def test_shared_vertex_and_shared_edge_cases():
    # folded flat: two triangles on edge (0, 1) with their third corners on the same side
    fold = TriMesh([[0, 0, 0], [1, 0, 0], [0.3, 1, 0], [0.6, 0.5, 0]], [[0, 1, 2], [1, 0, 3]])
    assert self_intersections(fold).pairs.tolist() == [[0, 1]]
    hinge = TriMesh([[0, 0, 0], [1, 0, 0], [0.3, 1, 0], [0.6, -0.5, 0.2]], [[0, 1, 2], [1, 0, 3]])
    assert self_intersections(hinge).n_pairs == 0
    # sharing vertex 0: the far edge of triangle 1 pierces triangle 0
    pierce = TriMesh([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0.5, 0.5, -1], [0.5, 0.5, 1]], [[0, 1, 2], [0, 3, 4]])
    assert self_intersections(pierce).n_pairs == 1
    fan = TriMesh([[0, 0, 0], [2, 0, 0], [0, 2, 0], [-1, -1, 1]], [[0, 1, 2], [0, 2, 3]])
    assert self_intersections(fan).n_pairs == 0
    # coplanar wedges at a shared vertex that overlap
    wedge = TriMesh([[0, 0, 0], [2, 0, 0], [0, 2, 0], [2, 1, 0], [1, 2, 0]], [[0, 1, 2], [0, 3, 4]])
    assert self_intersections(wedge).n_pairs == 1
    dup = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 1]])
    assert self_intersections(dup).n_pairs == 1


def test_zero_area_triangles_are_skipped():
    m = TriMesh([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]], [[0, 1, 2], [0, 1, 3]])
    r = self_intersections(m)
    assert r.n_degenerate_skipped == 1 and r.n_pairs == 0


def test_bad_input():
    with pytest.raises(InputError, match="needs a TriMesh"):
        self_intersections(np.zeros((3, 3)))
    with pytest.raises(InputError, match="Tolerance"):
        self_intersections(icosphere(0), tol=1e-9)
    with pytest.raises(InputError, match="same shape"):
        triangles_intersect(np.zeros((2, 3, 3)), np.zeros((1, 3, 3)))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1))
def test_random_pairs_with_known_answer(seed):
    rng = np.random.default_rng(seed)
    t1 = rng.normal(size=(3, 3))
    w = rng.dirichlet([2, 2, 2])
    x = w @ t1                                   # a point inside t1
    # t2 through x with x inside it (random orientation): they intersect
    e1, e2 = rng.normal(size=(2, 3))
    t2 = x + np.array([e1, e2, -e1 - e2]) * rng.uniform(0.2, 2.0)
    assert triangles_intersect(t1[None], t2[None])[0] and triangles_intersect(t2[None], t1[None])[0]
    # t3 beyond a plane separating it from t1 with a margin: they do not
    n = rng.normal(size=3)
    n /= np.linalg.norm(n)
    top = (t1 @ n).max()
    t3 = rng.normal(size=(3, 3))
    t3 += n * (top + 0.1 - (t3 @ n).min())
    assert not triangles_intersect(t1[None], t3[None])[0] and not triangles_intersect(t3[None], t1[None])[0]
