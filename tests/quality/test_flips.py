"""Flipped triangles in the parameter domain and against the surface normal."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.errors import InputError
from trimsurf.model import TriMesh
from trimsurf.quality import flipped_triangles_normal, flipped_triangles_uv

from ._meshes import grid_mesh, icosphere, plane_patch, rect_face, sphere_patch


def _flip(m: TriMesh, k: int) -> TriMesh:
    t = m.triangles.copy()
    t[k] = t[k][::-1]
    return TriMesh(m.vertices, t, uv=m.uv)


def test_uv_flip_of_one_triangle():
    s = plane_patch()
    m = _flip(grid_mesh(s, 6), 7)
    r = flipped_triangles_uv(m)
    assert r.flipped.tolist() == [7] and r.expected_sign == 1 and r.n_zero == 0
    assert flipped_triangles_uv(m, face=rect_face(s)).flipped.tolist() == [7]
    # on a face whose normal is -(Su x Sv) every other triangle is the flipped one
    r = flipped_triangles_uv(m, face=rect_face(s, same_sense=False))
    assert r.n_flipped == m.n_triangles - 1 and 7 not in r.flipped


def test_uv_zero_area_triangle_is_reported():
    m = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], [[0, 1, 2], [0, 3, 2]],
                uv=[[0, 0], [1, 0], [0, 1], [1, 0]])
    r = flipped_triangles_uv(m, uv=[[0, 0], [1, 0], [0, 1], [2, 0]])
    assert r.n_zero == 0 and r.n_flipped == 0
    r = flipped_triangles_uv(m, uv=[[0, 0], [1, 0], [2, 0], [0, 1]])  # triangle 0 collinear in (u, v)
    assert r.zero.tolist() == [0]


def test_normal_flip_on_sphere_patch():
    s = sphere_patch()
    m = _flip(grid_mesh(s, 7), 11)
    assert flipped_triangles_normal(m, s).flipped.tolist() == [11]
    r = flipped_triangles_normal(m, rect_face(s, same_sense=False))
    assert r.n_flipped == m.n_triangles - 1


def test_bad_input():
    m = icosphere(0)
    with pytest.raises(InputError, match="has no uv"):
        flipped_triangles_uv(m)
    with pytest.raises(InputError, match=r"uv must have shape \(12, 2\)"):
        flipped_triangles_uv(m, uv=np.zeros((3, 2)))
    with pytest.raises(InputError, match="face must be a TrimmedFace"):
        flipped_triangles_uv(m, uv=np.zeros((12, 2)), face=plane_patch())
    with pytest.raises(InputError, match="NurbsSurface or TrimmedFace"):
        flipped_triangles_normal(m, None)
