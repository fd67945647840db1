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
