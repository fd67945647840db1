"""`deviation._sample_more`'s one-group shortcut (the refinement's first call per face: every triangle at the
starting density, none sampled before, so no `_groups` sort and no group masks; issue 17 item 2) gives the
figures of the general path: on real faces, every refined Deviation and every state's per-triangle values
and densities; with mixed densities the general path is taken, and a shortcut that took one group anyway
changes the figures."""

import copy

import numpy as np
import pytest

import trimsurf.quality.deviation as D
from trimsurf.io import read_shell
from trimsurf.tessellate import tessellate_shell


@pytest.fixture(scope="module")
def faces(shared_data):
    shell = read_shell(shared_data / "cad" / "trimesh__featuretype.STEP")
    d = shell.diagonal()
    mesh = tessellate_shell(shell, tolerance=1e-3 * d, max_edge=0.05 * d, measure=False).mesh
    out = []
    for i in range(len(shell.faces)):
        sub = mesh.submesh(mesh.face_id == i)
        if sub.n_triangles >= 8:
            dev, st = D._surface_deviation(sub, shell.faces[i], density=3, n_domain=16, two_sided=True,
                                           tol_rel=1e-10, trim_tol_uv=None, adaptive=True)
            out.append((dev, st))
        if len(out) == 6:
            break
    return out


def _refine(faces, mixed=False):
    devs = [dev for dev, _ in faces]
    states = [copy.deepcopy(st) for _, st in faces]
    if mixed:
        for st in states:
            st.density[::3] = 4
    out, bound = D.refine_deviation(devs, states, rel=0.01)
    return out, bound, states


def _key(run):
    out, bound, states = run
    vals = [np.float64(bound).tobytes()]
    for dev, st in zip(out, states):
        vals += [np.float64(dev.max_two_sided).tobytes(), np.float64(dev.max_bound).tobytes(),
                 dev.n_target_samples, dev.n_mesh_samples, st.tri_max.tobytes(), st.density.tobytes()]
    return vals


@pytest.mark.parametrize("mixed", [False, True])
def test_same_as_general_path(faces, monkeypatch, mixed):
    seen = []
    real = D._single_density
    monkeypatch.setattr(D, "_single_density", lambda dk: seen.append(real(dk)) or seen[-1])
    fast = _key(_refine(faces, mixed))
    assert any(seen) != mixed and len(seen) >= len(faces)     # the shortcut taken (uniform) or not (mixed)
    monkeypatch.setattr(D, "_single_density", lambda dk: False)
    assert fast == _key(_refine(faces, mixed))


def test_one_group_for_mixed_densities_differs(faces, monkeypatch):
    ref = _key(_refine(faces, mixed=True))
    monkeypatch.setattr(D, "_single_density", lambda dk: True)
    assert _key(_refine(faces, mixed=True)) != ref


def test_face_radii_as_per_face(faces):
    """`_face_radii` (one `_enclosing_radius` call over every face) gives each face's own call's radii."""
    states = [None] + [st for _, st in faces]
    live = list(range(1, len(states)))
    corners, radii = D._face_radii(states, live)
    assert len(radii) == len(live)
    for i, r in zip(live, radii):
        ref = D._enclosing_radius(states[i].mesh.vertices[states[i].mesh.triangles])
        assert r.tobytes() == ref.tobytes()
        assert corners[i].tobytes() == states[i].mesh.vertices[states[i].mesh.triangles].tobytes()


def _old_curvature_bound(st, tri_uv_ok: np.ndarray, rows: np.ndarray | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The per-face code `_curvature_bounds` replaced (session 29, before the batching)."""
    if rows is not None and not rows.any():
        return np.full(len(st.mesh.triangles), np.nan), np.full(len(st.mesh.triangles), np.nan)
    if rows is not None:
        tri_uv_ok = tri_uv_ok & rows
    t = st.mesh.triangles
    s = st.face.surface
    used = np.isfinite(st.vert_uv[:, 0])
    nv = len(st.vert_uv)
    wv = np.full((nv, 3, 3), np.nan)
    kv = np.full(nv, np.nan)
    m = len(t)
    wc = np.full((m, 3, 3), np.nan)
    kc = np.full(m, np.nan)
    # the forms at the vertices' feet and at the triangles' (u, v) centres, from one evaluation
    (wa, ka), (wb, kb) = D._second_forms_two(s, st.vert_uv[used], st.vert_uv[t[tri_uv_ok]].mean(axis=1))
    wv[used], kv[used] = wa, ka
    wc[tri_uv_ok], kc[tri_uv_ok] = wb, kb
    p = st.mesh.vertices[t]
    e = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 1], p[:, 0] - p[:, 2]], axis=1)      # (m, 3 edges, 3)
    q = np.zeros((m, 3))
    for w in (wv[t[:, 0]], wv[t[:, 1]], wv[t[:, 2]], wc):
        v = np.abs(np.einsum("mei,mij,mej->me", e, w, e))
        q = np.fmax(q, v)
    kt = np.fmax(np.fmax(np.fmax(kv[t[:, 0]], kv[t[:, 1]]), kv[t[:, 2]]), kc)
    if rows is not None:
        kt[~rows] = np.nan
        kt_all = np.fmax(kt, np.fmax(np.fmax(kv[t[:, 0]], kv[t[:, 1]]), kv[t[:, 2]]))
    else:
        kt_all = kt
    fin = np.isfinite(kt_all)
    face_max = float(kt_all[fin].max()) if fin.any() else 0.0
    fin = np.isfinite(kt)
    fallback = ~(fin & tri_uv_ok)
    kt = np.where(fallback, face_max, kt)
    q = np.where(fallback[:, None], face_max * np.einsum("mei,mei->me", e, e), q)
    beta = D.CURVATURE_MARGIN * D._simplex_max(q) / 2.0
    return beta, D.CURVATURE_MARGIN * kt


def test_curvature_bounds_as_before(faces):
    """`_curvature_bounds` (the forms and simplex maxima of every face in one call each) gives the former
    per-face `_curvature_bound`'s numbers bit for bit, with and without `rows`, faces mixed; a face whose rows
    are all left out gets NaN."""
    items = []
    for k, (_, st) in enumerate(faces):
        t = st.mesh.triangles
        ok = np.all(np.isfinite(st.vert_uv[t].reshape(len(t), -1)), axis=1)
        rows = None if k % 2 else (np.arange(len(t)) % 3 != 0)
        items.append((st, ok, rows))
    st0 = faces[0][1]
    items.append((st0, np.ones(len(st0.mesh.triangles), bool), np.zeros(len(st0.mesh.triangles), bool)))
    got = D._curvature_bounds(items)
    assert len(got) == len(items)
    for (st, ok, rows), (beta, kap) in zip(items, got):
        ref = _old_curvature_bound(st, ok.copy(), rows)
        assert beta.tobytes() == ref[0].tobytes() and kap.tobytes() == ref[1].tobytes()
        assert D._curvature_bound(st, ok.copy(), rows)[0].tobytes() == ref[0].tobytes()
    assert np.all(np.isnan(got[-1][0])) and np.all(np.isnan(got[-1][1]))
    assert any((b > 0).any() for b, _ in got[:-1])


def test_curvature_bounds_misaligned_fails(faces, monkeypatch):
    """A batch whose simplex maxima were handed to the wrong faces (split one row off) fails the comparison."""
    real_split = np.split

    def off(a, idx, *args):
        return real_split(a, np.asarray(idx) + 1, *args) if len(a) and len(np.atleast_1d(idx)) else \
            real_split(a, idx, *args)
    monkeypatch.setattr(D.np, "split", off)
    with pytest.raises(AssertionError):
        test_curvature_bounds_as_before(faces)
