"""`topology_report`'s per-component vertex count: a vertex where components touch counts in each."""

from __future__ import annotations

import numpy as np

from trimsurf.model import TriMesh
from trimsurf.quality import topology_report

TET = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]


def _brute_chi(mesh: TriMesh, labels: np.ndarray) -> list[int]:
    """V - E + F per component, V and E as Python sets of (component, vertex) and (component, edge)."""
    out = []
    for c in range(labels.max() + 1):
        tris = mesh.triangles[labels == c].tolist()
        verts = {v for t in tris for v in t}
        edges = {tuple(sorted((t[k], t[(k + 1) % 3]))) for t in tris for k in range(3)}
        out.append(len(verts) - len(edges) + len(tris))
    return out


def test_two_tetrahedra_touching_at_a_vertex():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 0, 0], [0, -1, 0], [0, 0, -1]], float)
    second = [[0, 5, 4], [0, 4, 6], [4, 5, 6], [0, 6, 5]]
    mesh = TriMesh(v, TET + second)
    r = topology_report(mesh)
    assert r.n_components == 2 and r.n_non_manifold_vertices == 1
    # each tetrahedron has its 4 vertices, the shared one included: chi = 4 - 6 + 4 = 2 each
    assert r.component_euler.tolist() == [2, 2] == _brute_chi(mesh, mesh.connected_components())
    assert r.euler_characteristic == 4


def test_random_soups_match_the_brute_count():
    rng = np.random.default_rng(7)
    for _ in range(20):
        n = int(rng.integers(4, 30))
        tris = []
        while len(tris) < 25:
            t = rng.choice(n, 3, replace=False).tolist()
            tris.append(t)
        mesh = TriMesh(rng.random((n, 3)), tris)
        r = topology_report(mesh)
        assert r.component_euler.tolist() == _brute_chi(mesh, mesh.connected_components())
