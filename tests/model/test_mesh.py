"""TriMesh: validation and topology helpers (edges, boundaries, manifoldness, orientation, components)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_array_equal

from trimsurf.errors import DegenerateError, MeshError
from trimsurf.model import TriMesh

SQUARE = TriMesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
TET = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])


def annulus(n: int = 8) -> TriMesh:
    """Flat ring: outer and inner circle of n vertices each, 2 n triangles, counter-clockwise from +z."""
    a = 2 * np.pi * np.arange(n) / n
    v = np.vstack([np.column_stack([2 * np.cos(a), 2 * np.sin(a), 0 * a]),
                   np.column_stack([np.cos(a), np.sin(a), 0 * a])])
    i = np.arange(n)
    j = (i + 1) % n
    return TriMesh(v, np.vstack([np.column_stack([i, j, n + j]), np.column_stack([i, n + j, n + i])]))


# -- validation ------------------------------------------------------------------------

@pytest.mark.parametrize("vertices, triangles, error, match", [
    ([[0, 0, 0], [1, 0, np.nan], [0, 1, 0]], [[0, 1, 2]], MeshError, "non-finite"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 3]], MeshError, "out of range"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, -1, 2]], MeshError, "out of range"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 1]], DegenerateError, "repeats a vertex"),
    ([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], MeshError, r"shape \(\.\.\., 3\)"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1.5, 2]], MeshError, "integers"),
])
def test_invalid_meshes_raise(vertices, triangles, error, match):
    with pytest.raises(error, match=match):
        TriMesh(vertices, triangles)


def test_uv_and_face_id_shapes_checked():
    with pytest.raises(MeshError, match=r"uv must have shape \(4, 2\)"):
        TriMesh(SQUARE.vertices, SQUARE.triangles, uv=np.zeros((3, 2)))
    with pytest.raises(MeshError, match=r"face_id must have shape \(2,\)"):
        TriMesh(SQUARE.vertices, SQUARE.triangles, face_id=[0])


def test_arrays_are_copied_and_read_only():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=float)
    t = np.array([[0, 1, 2]])
    m = TriMesh(v, t)
    v[0, 0] = 5.0
    assert m.vertices[0, 0] == 0.0
    assert m.vertices.dtype == np.float64 and m.triangles.dtype == np.int64
    with pytest.raises(ValueError):
        m.vertices[0, 0] = 1.0


# -- edges and boundaries ----------------------------------------------------------------

def test_edges_of_square():
    assert SQUARE.edges().tolist() == [[0, 1], [0, 2], [0, 3], [1, 2], [2, 3]]
    assert SQUARE.edge_triangle_counts().tolist() == [1, 2, 1, 1, 1]
    # boundary half-edges keep their triangle's direction: counter-clockwise around the square
    assert sorted(map(tuple, SQUARE.boundary_edges().tolist())) == [(0, 1), (1, 2), (2, 3), (3, 0)]
    loops = SQUARE.boundary_loops()
    assert len(loops) == 1 and np.roll(loops[0], -int(np.argmin(loops[0]))).tolist() == [0, 1, 2, 3]


def test_annulus_has_two_loops_and_euler_zero():
    m = annulus(8)
    loops = m.boundary_loops()
    assert [len(lp) for lp in loops] == [8, 8]
    assert m.euler_characteristic() == 0
    # outer loop runs counter-clockwise (positive signed area), the hole clockwise
    areas = []
    for lp in loops:
        p = m.vertices[lp, :2]
        q = np.roll(p, -1, axis=0)
        areas.append(0.5 * np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))
    assert sorted(np.sign(areas)) == [-1, 1]


def test_tetrahedron_is_closed():
    assert TET.is_watertight()
    assert TET.boundary_loops() == []
    assert TET.euler_characteristic() == 2
    assert TET.is_consistently_oriented()
    assert TET.n_components() == 1


def test_non_manifold_edge_and_boundary_loop_error():
    fin = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]], [[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    assert fin.non_manifold_edges().tolist() == [[0, 1]]
    assert not fin.is_watertight()


def test_bow_tie_vertex_is_non_manifold():
    bow = TriMesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [-1, 0, 0], [-1, -1, 0]], [[0, 1, 2], [0, 3, 4]])
    assert bow.non_manifold_vertices().tolist() == [0]
    assert not len(bow.non_manifold_edges())
    with pytest.raises(MeshError, match="vertex 0 has two outgoing boundary edges"):
        bow.boundary_loops()


def test_manifold_meshes_have_no_non_manifold_vertices():
    assert not len(SQUARE.non_manifold_vertices())
    assert not len(TET.non_manifold_vertices())
    assert not len(annulus().non_manifold_vertices())


# -- orientation and components -------------------------------------------------------

def test_one_flipped_triangle_gives_its_three_edges():
    t = TET.triangles.copy()
    t[2] = t[2][::-1]
    m = TriMesh(TET.vertices, t)
    assert not m.is_consistently_oriented()
    assert sorted(map(tuple, m.inconsistent_edges().tolist())) == sorted(
        tuple(sorted(e)) for e in [(t[2][0], t[2][1]), (t[2][1], t[2][2]), (t[2][2], t[2][0])])
    assert m.flipped().is_consistently_oriented() is False
    assert TET.flipped().is_consistently_oriented()


def test_components_and_submesh():
    two = TriMesh(np.vstack([TET.vertices, TET.vertices + 5]), np.vstack([TET.triangles, TET.triangles + 4]),
                  face_id=[0, 0, 0, 0, 1, 1, 1, 1])
    labels = two.connected_components()
    assert two.n_components() == 2 and len(set(labels[:4])) == 1 and labels[0] != labels[4]
    sub = two.submesh(labels == labels[4])
    assert sub.n_vertices == 4 and sub.face_id.tolist() == [1, 1, 1, 1]
    assert_array_equal(sub.vertices, TET.vertices + 5)
    assert two.euler_characteristic() == 4


def test_degenerate_triangles_found_and_reported():
    m = TriMesh([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]], [[0, 1, 2], [0, 1, 3]])
    assert m.degenerate_triangles().tolist() == [0]
    with pytest.raises(DegenerateError, match="1 degenerate"):
        m.check_degenerate()
    SQUARE.check_degenerate()


def test_vertex_adjacency_is_symmetric_with_edge_lengths():
    a = SQUARE.vertex_adjacency()
    assert (a - a.T).nnz == 0
    assert a[0, 2] == pytest.approx(np.sqrt(2), abs=1e-15)


@settings(max_examples=40, deadline=None)
@given(n=st.integers(3, 30), m=st.integers(1, 40), seed=st.integers(0, 2 ** 16))
def test_edge_index_matches_row_unique(n, m, seed):
    rng = np.random.default_rng(seed)
    tris = np.array([rng.choice(n, 3, replace=False) for _ in range(m)])
    mesh = TriMesh(rng.normal(size=(n, 3)), tris)
    he = np.sort(np.stack([tris, np.roll(tris, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    ref, counts = np.unique(he, axis=0, return_counts=True)
    assert_array_equal(mesh.edges(), ref)
    assert_array_equal(mesh.edge_triangle_counts(), counts)
    # Euler characteristic from its definition
    assert mesh.euler_characteristic() == len(np.unique(tris)) - len(ref) + m


# --------------------------------------------------------------------------- check_manifold

@pytest.mark.parametrize("vertices, triangles, error, match", [
    (np.eye(3), np.zeros((0, 3), int), "MeshError", "no triangles"),
    (np.r_[np.eye(3), [[1.0, 1.0, 1.0]], [[-1.0, 0.0, 0.0]]], [[0, 1, 2], [0, 1, 3], [1, 0, 4]],
     "NonManifoldError", "non-manifold edges"),
    (np.r_[np.eye(3), [[2.0, 2.0, 2.0]]], [[0, 1, 2]], "MeshError", "isolated vertices"),
    ([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]], "DegenerateError", "zero-area"),
    (np.r_[np.eye(3), [[1.0, 1.0, 1.0]]], [[0, 1, 2], [0, 1, 3]], "MeshError", "not consistently oriented"),
])
def test_check_manifold_names_the_problem(vertices, triangles, error, match):
    import trimsurf.errors as errors

    mesh = TriMesh(np.asarray(vertices, float), np.asarray(triangles, np.int64))
    with pytest.raises(getattr(errors, error), match=match) as info:
        mesh.check_manifold("scan.ply")
    assert str(info.value).startswith("scan.ply: ")


def test_check_manifold_accepts_open_and_closed_manifolds():
    from trimsurf.samples import holed_sheet, octahedron

    for mesh in (holed_sheet(), octahedron()):
        assert mesh.check_manifold() is None


def test_compact_indices_is_np_unique_with_inverse():
    """`compact_indices` (the shell's and seam reduction's vertex compaction) gives np.unique's used
    indices and inverse, values and dtypes, on random triangle arrays (gaps, repeats, empty)."""
    from trimsurf.model.mesh import compact_indices

    rng = np.random.default_rng(4)
    for trial in range(60):
        n = int(rng.integers(1, 500))
        m = int(rng.integers(0, 300)) if trial % 10 else 0
        tri = rng.integers(0, n, (m, 3)).astype(np.int64)
        used, inv = compact_indices(tri, n + int(rng.integers(0, 5)))
        ref_used, ref_inv = np.unique(tri, return_inverse=True)
        assert used.dtype == ref_used.dtype and np.array_equal(used, ref_used)
        assert inv.dtype == ref_inv.dtype and np.array_equal(inv, ref_inv.ravel())
        assert np.array_equal(used[inv].reshape(-1, 3), tri)
