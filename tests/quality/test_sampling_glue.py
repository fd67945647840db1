"""The measurement's per-face sampling glue (issue 17, item 2) gives the arrays of the code it replaced,
bit for bit: `sample_triangles` with its per-density nodes cached (`sampling._density_nodes`) and
`sample_face_domain` with the (u, v) grid built by repeat / tile instead of ``np.meshgrid``; the former
code is copied here as the reference. Densities 1-9 on a real face mesh, trimmed and untrimmed faces,
square and rectangular grids; a cache entry that is deliberately wrong fails the comparison.
"""

import numpy as np
import pytest

from trimsurf.io import read_shell
from trimsurf.quality import sampling as S
from trimsurf.tessellate import tessellate_shell


def _old_sample_triangles(mesh, density):
    t = mesh.triangles
    m = len(t)
    used, first = np.unique(t.ravel(), return_index=True)
    v_tri, v_corner = first // 3, first % 3
    v_w = np.zeros((len(first), 3))
    v_w[np.arange(len(first)), v_corner] = 1.0
    inv = mesh.half_edge_edges()
    _, first_he = np.unique(inv, return_index=True)
    e_tri, c0 = first_he // 3, first_he % 3
    c1 = (c0 + 1) % 3
    s = np.arange(1, density) / density
    if density % 2:
        s = np.sort(np.r_[s, 0.5])
    ne, ns = len(first_he), len(s)
    e_w = np.zeros((ne, ns, 3))
    rows = np.arange(ne)[:, None]
    e_w[rows, np.arange(ns)[None, :], c0[:, None]] = 1.0 - s[None, :]
    e_w[rows, np.arange(ns)[None, :], c1[:, None]] = s[None, :]
    e_w = e_w.reshape(-1, 3)
    e_tri = np.repeat(e_tri, ns)
    ij = np.array([(i, j) for i in range(1, density) for j in range(1, density - i) if density - i - j >= 1],
                  dtype=np.float64).reshape(-1, 2)
    g_w = np.column_stack([ij[:, 0], ij[:, 1], density - ij.sum(axis=1)]) / density
    i_w = np.tile(g_w, (m, 1))
    i_tri = np.repeat(np.arange(m), len(g_w))
    tri = np.concatenate([v_tri, e_tri, i_tri]).astype(np.int64)
    bary = np.concatenate([v_w, e_w, i_w])
    kind = np.concatenate([np.zeros(len(v_tri)), np.ones(len(e_tri)), np.full(len(i_tri), 2)]).astype(np.int8)
    element = np.concatenate([used, np.repeat(np.arange(ne), ns), i_tri]).astype(np.int64)
    p = mesh.vertices[t[tri]]
    points = np.einsum("kj,kjd->kd", bary, p)
    return S.TriangleSamples(points, tri, bary, kind, element)


def _old_sample_face_domain(face, n, n_per_segment=32):
    face = S.as_face(face)
    nu, nv = (int(n), int(n)) if np.ndim(n) == 0 else (int(n[0]), int(n[1]))
    polys = S.loop_polygons(face, n_per_segment=n_per_segment)
    lo, hi = polys[0].min(axis=0), polys[0].max(axis=0)
    (du0, du1), (dv0, dv1) = face.surface.domain
    lo = np.maximum(lo, [du0, dv0])
    hi = np.minimum(hi, [du1, dv1])
    gu, gv = np.meshgrid(np.linspace(lo[0], hi[0], nu), np.linspace(lo[1], hi[1], nv), indexing="ij")
    grid = np.column_stack([gu.ravel(), gv.ravel()])
    if face.loops:
        grid = grid[S._inside_loops(face, grid, n_per_segment)]
        boundary = np.concatenate(polys)
        boundary = np.clip(boundary, [du0, dv0], [du1, dv1])
        return np.concatenate([grid, boundary])
    return grid


def _bitwise(a, b):
    assert a.dtype == b.dtype and a.shape == b.shape
    assert a.tobytes() == b.tobytes()


@pytest.fixture(scope="module")
def screw(shared_data):
    shell = read_shell(shared_data / "cad" / "occt__screw.step")
    d = shell.diagonal()
    return shell, tessellate_shell(shell, tolerance=1e-3 * d, max_edge=0.05 * d, measure=False).mesh


def _check_triangles(mesh):
    for density in range(1, 10):
        got, ref = S.sample_triangles(mesh, density=density), _old_sample_triangles(mesh, density)
        for a, b in zip(got, ref):
            _bitwise(a, b)


def test_sample_triangles_as_before(screw):
    shell, mesh = screw
    _check_triangles(mesh)
    for i in (0, int(mesh.face_id.max())):
        _check_triangles(mesh.submesh(mesh.face_id == i))


def test_sample_face_domain_as_before(screw):
    shell, _ = screw
    assert any(f.loops for f in shell.faces)
    for face in shell.faces:
        for n in (2, 7, 32, (5, 41), (64, 3)):
            _bitwise(S.sample_face_domain(face, n=n), _old_sample_face_domain(face, n))
    untrimmed = S.as_face(shell.faces[0].surface)
    _bitwise(S.sample_face_domain(untrimmed, n=(9, 4)), _old_sample_face_domain(untrimmed, (9, 4)))


def test_wrong_cached_nodes_fail(screw, monkeypatch):
    _, mesh = screw
    real = S._density_nodes.__wrapped__

    def wrong(density):
        s, g = real(density)
        return s, g[::-1].copy()          # the interior nodes in another order
    monkeypatch.setattr(S, "_density_nodes", wrong)
    with pytest.raises(AssertionError):
        _check_triangles(mesh)
