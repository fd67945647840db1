"""`deviation._face_submeshes` builds every face's submesh and its edge topology from one pass over the
shell's mesh (issue 17, item 2: the measurement's per-face glue). Each submesh must equal
``mesh.submesh(rows)`` and its filled-in ``_half_edges`` / ``_edge_index`` must equal what `TriMesh`
computes itself: same values, dtypes, shapes, read-only. Checked on a real multi-face mesh, on a synthetic
one with faces in shuffled order, empty faces, shared vertices and uv; and a deliberately wrong edge key
(no per-face offset: edges of different faces merge) fails the comparison.
"""

import numpy as np
import pytest

import trimsurf.quality.deviation as D
from trimsurf.io import read_shell
from trimsurf.model import TriMesh
from trimsurf.tessellate import tessellate_shell


def _split(mesh, n_faces):
    order = np.argsort(mesh.face_id, kind="stable")
    bounds = np.searchsorted(mesh.face_id[order], np.arange(n_faces + 1))
    return order, bounds


def _same(a, b):
    assert a.dtype == b.dtype and a.shape == b.shape
    assert np.array_equal(a, b)
    assert not a.flags.writeable


def _check(mesh, n_faces):
    order, bounds = _split(mesh, n_faces)
    subs = D._face_submeshes(mesh, order, bounds)
    want = [i for i in range(n_faces) if bounds[i + 1] > bounds[i]]
    assert sorted(subs) == want
    for i in want:
        ref = mesh.submesh(np.sort(order[bounds[i]:bounds[i + 1]]))
        got = subs[i]
        for name in ("vertices", "triangles", "uv", "face_id"):
            a, b = getattr(got, name), getattr(ref, name)
            assert (a is None) == (b is None)
            if a is not None:
                assert a.dtype == b.dtype and np.array_equal(a, b)
        _same(got.__dict__["_half_edges"], ref._half_edges)
        for a, b in zip(got.__dict__["_edge_index"], ref._edge_index):
            _same(a, b)
        # what the measurement reads through the public accessors
        assert np.array_equal(got.half_edge_edges(), ref.half_edge_edges())
        assert np.array_equal(got.edges(), ref.edges())


def _synthetic(rng, with_uv):
    n_v, n_faces = 60, 7
    tris = []
    for _ in range(120):
        tris.append(rng.choice(n_v, 3, replace=False))
    tris = np.array(tris)
    fid = rng.integers(0, n_faces, len(tris))
    fid[fid == 3] = 4                          # face 3 empty
    uv = rng.random((n_v, 2)) if with_uv else None
    return TriMesh(rng.random((n_v, 3)), tris, uv=uv, face_id=fid), n_faces


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_synthetic_equals_submesh(seed):
    rng = np.random.default_rng(seed)
    mesh, n_faces = _synthetic(rng, with_uv=bool(seed % 2))
    _check(mesh, n_faces)


def test_real_mesh_equals_submesh(shared_data):
    shell = read_shell(shared_data / "cad" / "occt__screw.step")
    d = shell.diagonal()
    r = tessellate_shell(shell, tolerance=1e-3 * d, max_edge=d, measure=False)
    assert len(shell.faces) > 5
    _check(r.mesh, len(shell.faces))


def test_wrong_offset_fails(monkeypatch):
    """Without the per-face key offset the faces' edges share keys: the comparison must fail."""
    rng = np.random.default_rng(5)
    mesh, n_faces = _synthetic(rng, with_uv=False)
    monkeypatch.setattr(D, "_key_offsets", lambda n_f: np.zeros(len(n_f) + 1, dtype=np.int64))
    with pytest.raises(AssertionError):
        _check(mesh, n_faces)
