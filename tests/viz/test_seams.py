"""Zebra across seams between faces: smooth (G1) seams draw no stripe break, creases stay creases.

The false alarm: `unshare_faces` used to duplicate every vertex on a face
boundary, so each copy got a one-sided normal and the stripe coordinate
jumped along every seam, also where the surface is G1 (reconstruct's
octahedron, g2 single, G1 error 2e-12 deg: a stripe offset of 1.47 periods
along a patch seam, 5.3 % of the picture's pixels differing from the same
mesh rendered without face ids; both 0 since the fix).
"""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from trimsurf.model import TriMesh
from trimsurf.samples import build_sample
from trimsurf.viz import Camera, ZebraOptions, render_png, stripe_coordinates, unshare_faces, vertex_normals

from .conftest import icosphere

_CAM = Camera((3.0, 2.0, 4.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0))


def seam_stripe_offset(mesh: TriMesh, camera: Camera, n_stripes: float) -> float:
    """Largest jump of the zebra stripe coordinate (in stripe periods) between the copies of one point.

    The renderer gives the copies of a seam vertex the stripe coordinate of
    their own normals; any difference is a stripe offset along the seam.
    """
    u = unshare_faces(mesh)
    t = stripe_coordinates(u.vertices, vertex_normals(u), camera, ZebraOptions(n_stripes))
    _, g = np.unique(u.vertices, axis=0, return_inverse=True)
    g = g.ravel()
    hi = np.full(g.max() + 1, -np.inf)
    lo = np.full(g.max() + 1, np.inf)
    np.maximum.at(hi, g, t)
    np.minimum.at(lo, g, t)
    return float((hi - lo).max())


@pytest.fixture(scope="module")
def g1_patches():
    """Reconstruct's octahedron filled G1 (g2 network, one degree-7 patch per facet), evaluated like the CLI."""
    from trimsurf.reconstruct import reconstruct_mesh

    rec = reconstruct_mesh(build_sample("octahedron"), network="g2", fill="single")
    assert rec.report["g1_error_max_deg"] < 1e-9
    mesh = rec.patches.evaluate_mesh(12)
    assert len(np.unique(mesh.face_id)) == 8  # one face id per patch: 8 faces, 12 seams
    return mesh


def test_g1_patch_seams_have_no_stripe_offset(g1_patches):
    # before the fix: 1.47 stripe periods
    assert seam_stripe_offset(g1_patches, _CAM, 12) < 1e-12


def test_g1_patch_seams_render_as_without_face_ids(g1_patches, tmp_path):
    kw = dict(camera=_CAM, n_stripes=12, window_size=(400, 400))
    a = np.asarray(Image.open(render_png(g1_patches, tmp_path / "faces.png", **kw))).astype(int)
    plain = TriMesh(g1_patches.vertices, g1_patches.triangles)
    b = np.asarray(Image.open(render_png(plain, tmp_path / "plain.png", **kw))).astype(int)
    differ = np.abs(a - b).max(axis=2) > 0
    # before the fix: 8493 pixels (5.3 %) differ, along the seams
    assert differ.mean() < 1e-3, f"{differ.sum()} pixels differ"


def test_sphere_cut_into_octants_has_no_stripe_offset():
    m = icosphere(4)
    c = m.vertices[m.triangles].mean(axis=1)
    octant = (c[:, 0] > 0) * 1 + (c[:, 1] > 0) * 2 + (c[:, 2] > 0) * 4
    cut = TriMesh(m.vertices, m.triangles, face_id=octant)
    assert unshare_faces(cut).n_vertices == m.n_vertices
    assert seam_stripe_offset(cut, _CAM, 20) < 1e-12


def _extruded(profile: np.ndarray, pieces: np.ndarray, depth: float = 2.0, n_z: int = 20) -> TriMesh:
    """A sheet swept along z from a polyline in the xy plane; face id of each strip from `pieces` (per segment)."""
    k = len(profile)
    z = np.linspace(0.0, depth, n_z + 1)
    V = np.column_stack([np.tile(profile, (n_z + 1, 1)), np.repeat(z, k)])
    i, j = np.meshgrid(np.arange(k - 1), np.arange(n_z), indexing="ij")
    a = (j * k + i).ravel()
    T = np.concatenate([np.column_stack([a, a + 1, a + k + 1]), np.column_stack([a, a + k + 1, a + k])])
    fid = np.tile(np.repeat(pieces, n_z), 2)
    return TriMesh(V, T, face_id=fid)


def _fillet(bend_deg: float, radius: float, n_arc: int) -> TriMesh:
    """Flat (face 0), circular bend of `bend_deg` (face 1; none for radius 0), flat (face 2)."""
    flat0 = np.column_stack([np.linspace(-2.0, 0.0, 21), np.zeros(21)])
    th = np.radians(np.linspace(0.0, bend_deg, max(n_arc, 1) + 1))
    arc = np.column_stack([radius * np.sin(th), radius * (1 - np.cos(th))])
    d = np.array([np.cos(th[-1]), np.sin(th[-1])])
    flat2 = arc[-1] + np.outer(np.linspace(0.0, 2.0, 21), d)
    prof = np.concatenate([flat0, arc[1:], flat2[1:]])
    pieces = np.r_[np.zeros(20), np.ones(n_arc), np.full(20, 2)].astype(np.int64)
    if radius == 0:
        prof = np.concatenate([flat0, flat2[1:]])
        pieces = np.r_[np.zeros(20), np.full(20, 2)].astype(np.int64)
    return _extruded(prof, pieces)


def test_tangent_fillet_seams_are_shared():
    m = _fillet(90.0, 1.0, 18)  # 5 degree chords; the seams' dihedral angle is 2.5 degrees
    assert unshare_faces(m).n_vertices == m.n_vertices
    cam = Camera((1.0, 3.0, 6.0), (0.0, 0.5, 1.0), (0.0, 1.0, 0.0))
    assert seam_stripe_offset(m, cam, 20) < 1e-12


@pytest.mark.parametrize("fold_deg", [10.0, 30.0, 90.0, 150.0])
def test_creases_between_faces_stay_split(fold_deg):
    m = _fillet(fold_deg, 0.0, 0)  # two flat faces meeting at a crease
    u = unshare_faces(m)
    assert u.n_vertices == m.n_vertices + 21  # the 21 crease vertices, one copy per face
    n = vertex_normals(u)
    want = np.cross(u.vertices[u.triangles[:, 1]] - u.vertices[u.triangles[:, 0]],
                    u.vertices[u.triangles[:, 2]] - u.vertices[u.triangles[:, 0]])
    want /= np.linalg.norm(want, axis=1, keepdims=True)
    # every corner's normal is its flat face's normal: nothing blends across the crease
    assert np.abs(np.einsum("tcj,tj->tc", n[u.triangles], want) - 1).max() < 1e-12


def test_crease_next_to_a_curved_face_stays_split():
    # a 40 degree kink where a coarse bend (10 degree chords) meets a flat face: 40 > 3 x 10
    flat0 = np.column_stack([np.linspace(-2.0, 0.0, 21), np.zeros(21)])
    th = np.radians(40.0 + np.arange(0.0, 50.1, 10.0))
    arc = np.column_stack([np.sin(th) - np.sin(th[0]), np.cos(th[0]) - np.cos(th)])
    prof = np.concatenate([flat0, arc[1:]])
    m = _extruded(prof, np.r_[np.zeros(20), np.ones(len(arc) - 1)].astype(np.int64))
    assert unshare_faces(m).n_vertices == m.n_vertices + 21


def seam_truth(shell):
    """Tessellate `shell`; per seam edge of the joined mesh: the exact normals' angle across it (degrees, the
    larger of its two ends; NaN where an end is not found) and whether `unshare_faces` shares it (smooth)."""
    from trimsurf.cli.view import mesh_with_face_uv
    from trimsurf.tessellate import tessellate_shell
    from trimsurf.viz._exact import seam_exact_angles

    res = tessellate_shell(shell)
    ends, smooth = seam_exact_angles(res.mesh, mesh_with_face_uv(res), shell)
    return np.maximum(*ends), smooth  # NaN where an end was not found


def test_cad_seams_smooth_exactly_where_the_faces_join_g1(shared_data):
    # the screw: plane, torus, cone and cylinder faces; 9 of its seam edges are tangent joins (exact normals
    # agree to < 1 deg), 387 are creases (> 5 deg; measured 2026-11-27)
    from trimsurf import io

    exact_deg, smooth = seam_truth(io.read_shell(shared_data / "cad" / "occt__screw.step"))
    found = np.isfinite(exact_deg)
    assert found.sum() >= 0.95 * len(found)
    g1, crease = found & (exact_deg < 1.0), found & (exact_deg > 5.0)
    assert g1.sum() >= 9 and crease.sum() >= 300
    assert not np.any(smooth & crease), np.sort(exact_deg[smooth & crease])  # no crease blended
    assert np.all(smooth[g1])  # every tangent join shared: no false stripe break


def test_web_viewer_keeps_g1_seam_vertices_shared(g1_patches, tmp_path):
    # the page's shader computes the stripes per vertex from the same prepared mesh: no seam copies in it
    import json
    import re

    from trimsurf.viz import write_html

    page = write_html(g1_patches, tmp_path / "v.html").read_text(encoding="utf-8")
    meta = json.loads(re.search(r'id="trimsurf-meta">(.*?)</script>', page, re.S).group(1))
    assert meta["meshes"][0]["n_vertices"] == g1_patches.n_vertices  # before the fix: 12 seams' vertices twice


@pytest.mark.parametrize("sample, network, fill, density", [("car_panel", "g2", "single", 4),
                                                            ("boundary_problem", "g1", "split", 8),
                                                            ("octahedron", "g2", "split", 16)])
def test_other_g1_fills_have_no_stripe_offset(sample, network, fill, density):
    # measured (2026-11-27): their seams' dihedral angles are at most 1.39 times those around them
    from trimsurf.reconstruct import reconstruct_mesh

    rec = reconstruct_mesh(build_sample(sample), network=network, fill=fill)
    assert rec.report["g1_error_max_deg"] < 1e-6
    m = rec.patches.evaluate_mesh(density)
    lo, hi = m.vertices.min(axis=0), m.vertices.max(axis=0)
    c, d = 0.5 * (lo + hi), float(np.linalg.norm(hi - lo))
    cam = Camera(tuple(c + d * np.array([0.6, 0.4, 0.8])), tuple(c), (0.0, 1.0, 0.0))
    assert unshare_faces(m).n_vertices == m.n_vertices
    assert seam_stripe_offset(m, cam, 12) < 1e-12
