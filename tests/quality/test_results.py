"""Every quality result turns into strict JSON (no NaN/inf) with as_dict()."""

from __future__ import annotations

import json

import numpy as np

from trimsurf.model import Shell, TriMesh
from trimsurf import quality as q

from ._meshes import grid_mesh, icosphere, rect_face, sphere_patch


def test_all_results_are_json():
    s = sphere_patch()
    m = grid_mesh(s, 5)
    face = rect_face(s)
    shell_mesh = TriMesh(m.vertices, m.triangles, face_id=np.zeros(m.n_triangles, int))
    results = [
        q.surface_deviation(m, face), q.shell_deviation(shell_mesh, Shell((face, face))), q.mesh_deviation(m, m),
        q.normal_deviation(m, face), q.height_field_slope(m, face), q.triangle_quality(m),
        q.flipped_triangles_uv(m), q.flipped_triangles_normal(m, face), q.topology_report(m),
        q.weld_vertices(m, 0.0), q.self_intersections(icosphere(1)),
        q.face_continuity(rect_face(s, (0.1, 0.1), (0.5, 0.9)), rect_face(s, (0.5, 0.1), (0.9, 0.9))),
        q.closest_points_on_mesh(m.vertices, m),
    ]
    for r in results:
        for arrays in (False, True):
            d = r.as_dict(arrays=arrays)
            assert isinstance(d, dict) and d
            json.dumps(d, allow_nan=False)
    assert q.__all__ and all(hasattr(q, name) for name in q.__all__)
