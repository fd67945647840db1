"""Mesh and trimmed-domain sampling."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from trimsurf.errors import InputError
from trimsurf.model import TriMesh
from trimsurf.quality import closest_points_on_mesh, distance_outside_face, sample_face_domain, sample_triangles

from ._meshes import plane_patch, rect_face, sphere_patch, lattice_mesh

TRI = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])


@pytest.mark.parametrize("density, n_edge, n_inner", [(1, 1, 0), (2, 1, 0), (3, 3, 1), (4, 3, 3), (5, 5, 6)])
def test_counts_and_midpoints(density, n_edge, n_inner):
    s = sample_triangles(TRI, density=density)
    assert np.bincount(s.kind, minlength=3).tolist() == [3, 3 * n_edge, n_inner]
    mids = np.array([[0.5, 0, 0], [0.5, 0.5, 0], [0, 0.5, 0]])
    for mid in mids:  # edge midpoints always sampled
        assert np.min(np.linalg.norm(s.points - mid, axis=1)) == 0.0


def test_samples_lie_on_mesh_once_each():
    m = lattice_mesh(sphere_patch(), 6)
    s = sample_triangles(m, density=4)
    assert_allclose(closest_points_on_mesh(s.points, m).distance, 0.0, rtol=0, atol=1e-15)
    assert len(np.unique(np.round(s.points, 12), axis=0)) == len(s.points)  # shared vertices/edges once
    si, ti = s.incidence(m)
    assert np.bincount(ti).tolist() == [3 + 3 * 3 + 3] * m.n_triangles   # every triangle sees all its nodes


def test_face_domain_samples_inside_the_loops():
    face = rect_face(plane_patch(), lo=(0.2, 0.3), hi=(0.7, 0.6))
    uv = sample_face_domain(face, n=20)
    assert np.all(distance_outside_face(face, uv) <= 1e-15)
    assert uv[:, 0].min() == pytest.approx(0.2) and uv[:, 1].max() == pytest.approx(0.6)
    # a point outside by 0.1 in u
    assert_allclose(distance_outside_face(face, [[0.8, 0.5]]), [0.1], rtol=0, atol=1e-15)


def test_bad_input():
    with pytest.raises(InputError, match="density must be >= 1"):
        sample_triangles(TRI, density=0)
    with pytest.raises(InputError, match="needs a TriMesh"):
        sample_triangles("mesh")
    with pytest.raises(InputError, match="NurbsSurface or TrimmedFace"):
        sample_face_domain(TRI)
    with pytest.raises(InputError, match=">= 2"):
        sample_face_domain(plane_patch(), n=1)
