"""Topology report and vertex welding."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from trimsurf.errors import InputError
from trimsurf.io import read_mesh
from trimsurf.model import TriMesh
from trimsurf.quality import boundary_loop_count, orientation_flips, topology_report, weld_vertices

from ..io.test_meshfile import _readme_table
from ._meshes import icosphere, torus


def soup(m: TriMesh) -> TriMesh:
    """Every triangle with its own three vertices (as an STL file stores it)."""
    return TriMesh(m.vertices[m.triangles].reshape(-1, 3), np.arange(3 * m.n_triangles).reshape(-1, 3))


def mobius(n: int = 20) -> TriMesh:
    a = 2 * np.pi * np.arange(n) / n
    v = []
    for t in a:
        for s in (-0.3, 0.3):
            v.append([(1 + s * np.cos(t / 2)) * np.cos(t), (1 + s * np.cos(t / 2)) * np.sin(t), s * np.sin(t / 2)])
    tris = []
    for i in range(n):
        j = (i + 1) % n
        b0, b1 = (2 * j, 2 * j + 1) if j else (1, 0)   # the half twist joins the strip's ends crosswise
        tris += [[2 * i, b0, b1], [2 * i, b1, 2 * i + 1]]
    return TriMesh(np.array(v), tris)


def test_real_meshes_genus_loops_components(shared_data):
    folder = shared_data / "meshes"
    for row in _readme_table((folder / "README.md").read_text()):
        r = topology_report(read_mesh(folder / row["file"]))
        assert (r.n_boundary_loops, r.euler_characteristic, r.genus, r.n_components) == \
               (row["loops"], row["chi"], row["genus"], 1), row["file"]
        assert r.is_consistently_oriented and r.is_orientable and not r.is_watertight
        assert r.n_non_manifold_edges == 0 and r.n_non_manifold_vertices == 0


def test_closed_meshes():
    r = topology_report(icosphere(3))
    assert r.is_watertight and r.genus == 0 and r.euler_characteristic == 2 and r.n_boundary_edges == 0
    r = topology_report(torus())
    assert r.is_watertight and r.genus == 1 and r.euler_characteristic == 0
    s, t = icosphere(1), torus()
    both = TriMesh(np.vstack([s.vertices, t.vertices + 10]), np.vstack([s.triangles, t.triangles + s.n_vertices]))
    r = topology_report(both)
    assert r.n_components == 2 and r.genus == 1 and sorted(r.component_genus.tolist()) == [0.0, 1.0]
    json.dumps(r.as_dict(arrays=True), allow_nan=False)


def test_soup_welds_back_to_a_closed_sphere():
    m = soup(icosphere(2))
    assert topology_report(m, weld_tol=None).is_watertight          # exact duplicates are merged by default
    noisy = TriMesh(m.vertices + np.random.default_rng(6).uniform(-1e-9, 1e-9, m.vertices.shape), m.triangles)
    raw = topology_report(noisy)
    assert not raw.is_watertight and raw.n_boundary_edges == 3 * m.n_triangles
    r = topology_report(noisy, weld_tol=1e-7)                        # far below the shortest edge (~0.3)
    assert r.is_watertight and r.genus == 0 and r.n_welded_vertices == m.n_vertices - 162


def test_one_flipped_triangle_is_found():
    m = icosphere(2)
    t = m.triangles.copy()
    t[17] = t[17][::-1]
    r = topology_report(TriMesh(m.vertices, t))
    assert not r.is_consistently_oriented and r.is_orientable
    assert r.n_inconsistent_edges == 3 and r.flipped_triangles.tolist() == [17]
    flip, bad = orientation_flips(TriMesh(m.vertices, t))
    fixed = t.copy()
    fixed[flip] = fixed[flip][:, ::-1]
    assert TriMesh(m.vertices, fixed).is_consistently_oriented() and not bad.any()


def test_mobius_strip_is_not_orientable():
    r = topology_report(mobius())
    assert not r.is_orientable and r.genus is None and r.n_boundary_loops == 1 and r.euler_characteristic == 0
    assert np.isnan(r.component_genus[0])


def test_non_manifold_cases():
    bow = TriMesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [-1, 0, 0], [-1, -1, 0]], [[0, 1, 2], [0, 3, 4]])
    r = topology_report(bow)
    assert r.n_non_manifold_vertices == 1 and r.genus is None and r.n_boundary_loops == 1
    assert boundary_loop_count(bow) == 1
    fin = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]], [[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    r = topology_report(fin)
    assert r.n_non_manifold_edges == 1 and r.genus is None and not r.is_watertight


def test_weld_vertices_details():
    m = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 1e-9], [0, 0, 5e-10]], [[0, 1, 2], [3, 1, 4]],
                uv=[[0, 0], [1, 0], [0, 1], [1, 0], [0, 0]], face_id=[4, 5])
    w = weld_vertices(m, 1e-8)
    assert w.vertex_map.tolist() == [0, 1, 2, 1, 0]
    assert w.dropped_triangles.tolist() == [1] and w.mesh.face_id.tolist() == [4]
    assert_array_equal(w.mesh.uv, [[0, 0], [1, 0], [0, 1]])
    conflicting = TriMesh(m.vertices, m.triangles, uv=[[0, 0], [1, 0], [0, 1], [9, 9], [0, 0]])
    assert weld_vertices(conflicting, 1e-8).mesh.uv is None
    assert_array_equal(m.vertices[3], [1, 0, 1e-9])  # input not mutated


def test_bad_input():
    with pytest.raises(InputError, match="finite number >= 0"):
        weld_vertices(icosphere(0), -1.0)
    with pytest.raises(InputError, match="needs a TriMesh"):
        weld_vertices("mesh", 0.0)
    with pytest.raises(InputError, match="needs a TriMesh"):
        topology_report([[0, 1, 2]])
