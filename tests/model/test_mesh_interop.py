"""TriMesh <-> trimesh.Trimesh and pyvista.PolyData: vertices, triangles, uv and face_id kept exactly."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from trimsurf.errors import MeshError
from trimsurf.model import TriMesh


def _mesh(seed: int = 0) -> TriMesh:
    """Random float64 coordinates, a duplicate vertex and an unused one (nothing may be merged or dropped)."""
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(30, 3)) * 1e3
    v[5] = v[4]                                   # duplicate coordinates: must stay two vertices
    tris = np.array([[i, i + 1, i + 2] for i in range(27)], dtype=np.int64)  # vertex 29 unused
    return TriMesh(v, tris, uv=rng.random((30, 2)), face_id=rng.integers(0, 4, 27))


def _same(a: TriMesh, b: TriMesh, *, extras: bool = True) -> None:
    assert a.vertices.dtype == np.float64 and a.triangles.dtype == np.int64
    assert_array_equal(a.vertices, b.vertices)
    assert_array_equal(a.triangles, b.triangles)
    if extras:
        assert_array_equal(a.uv, b.uv)
        assert_array_equal(a.face_id, b.face_id)


def test_trimesh_round_trip_is_exact():
    m = _mesh()
    before = m.vertices.copy()
    tm = m.to_trimesh()
    assert tm.vertices.shape == (30, 3) and tm.faces.shape == (27, 3)   # nothing merged, unused vertex kept
    back = TriMesh.from_trimesh(tm)
    _same(back, m)
    tm.vertices[0] = 0.0                           # a copy, not a view of the TriMesh's arrays
    assert_array_equal(m.vertices, before)


def test_pyvista_round_trip_is_exact():
    m = _mesh()
    pd = m.to_pyvista()
    assert pd.n_points == 30 and pd.n_cells == 27 and pd.is_all_triangles
    assert_array_equal(np.asarray(pd.points), m.vertices)
    back = TriMesh.from_pyvista(pd)
    _same(back, m)
    # an UnstructuredGrid of triangles (what pyvista.read gives for a .vtu) too
    _same(TriMesh.from_pyvista(pd.cast_to_unstructured_grid()), m)


def test_without_extras():
    m = TriMesh(_mesh().vertices, _mesh().triangles)
    assert TriMesh.from_trimesh(m.to_trimesh()).uv is None
    back = TriMesh.from_pyvista(m.to_pyvista())
    assert back.uv is None and back.face_id is None
    _same(back, m, extras=False)


def test_from_other_libraries_meshes():
    import pyvista
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=2)
    m = TriMesh.from_trimesh(sphere)
    assert m.is_watertight() and m.n_triangles == len(sphere.faces)
    assert_array_equal(m.vertices, sphere.vertices)
    pv = pyvista.Sphere(theta_resolution=12, phi_resolution=8)
    m = TriMesh.from_pyvista(pv)
    assert m.n_triangles == pv.n_cells
    assert_array_equal(m.triangles, pv.faces.reshape(-1, 4)[:, 1:])


def test_bad_input():
    import pyvista

    with pytest.raises(MeshError, match="expected a trimesh.Trimesh; got str"):
        TriMesh.from_trimesh("mesh.obj")
    with pytest.raises(MeshError, match="expected a pyvista mesh; got list"):
        TriMesh.from_pyvista([1, 2, 3])
    with pytest.raises(MeshError, match="not triangles.*triangulate"):
        TriMesh.from_pyvista(pyvista.Plane(i_resolution=2, j_resolution=2))   # quads
    with pytest.raises(MeshError, match="not triangles"):
        TriMesh.from_pyvista(pyvista.ImageData(dimensions=(3, 3, 3)).cast_to_unstructured_grid())  # hexahedra
