"""Session 29 (issue 17): the compiled shortcuts of `tessellate.seams` equal the numpy paths they replace."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.tessellate import seams as seams_mod


def _meshes():
    """Random triangulations with face ids in long runs (as a shell's meshes come) or scattered, a random
    alive mask (some vertices only on dead triangles), unused vertices, and degenerate cases."""
    from scipy.spatial import Delaunay

    rng = np.random.default_rng(29)
    for trial in range(40):
        n = int(rng.integers(4, 500))
        P = rng.random((n, 2))
        T = Delaunay(P).simplices.astype(np.int64)
        n_used = n + int(rng.integers(0, 5))           # vertices past n: on no triangle
        if trial % 2:
            fid = np.sort(rng.integers(0, 2 + trial % 7, len(T))).astype(np.int64)     # runs
        else:
            fid = rng.integers(0, 2 + trial % 7, len(T)).astype(np.int64)
        alive = rng.random(len(T)) < (1.0 if trial % 4 == 0 else 0.8)
        yield T, alive, fid, n_used
    T = np.array([[0, 1, 2], [2, 1, 3]], dtype=np.int64)
    yield T, np.ones(2, dtype=bool), np.array([0, 0], dtype=np.int64), 4     # one face: no vertex on two
    yield T, np.zeros(2, dtype=bool), np.array([0, 1], dtype=np.int64), 4    # (none alive: all multi)
    yield np.zeros((0, 3), dtype=np.int64), np.zeros(0, dtype=bool), np.zeros(0, dtype=np.int64), 3


def _broken_variants():
    """Plausible wrong versions of the flags: the test's meshes must tell each from the reference."""

    def ignores_alive(T, alive, fid, nv):
        return seams_mod._multi_face_numpy(T, np.ones(len(T), dtype=bool), fid, nv)

    def unused_not_multi(T, alive, fid, nv):
        multi, _ = seams_mod._multi_face_numpy(T, alive, fid, nv)
        used = np.zeros(nv, dtype=bool)
        used[T[alive].ravel()] = True
        multi = multi & used
        return multi, np.count_nonzero(multi[T], axis=1) >= 2

    def one_corner(T, alive, fid, nv):
        multi, _ = seams_mod._multi_face_numpy(T, alive, fid, nv)
        return multi, np.count_nonzero(multi[T], axis=1) >= 1

    def stri_alive_only(T, alive, fid, nv):
        multi, stri = seams_mod._multi_face_numpy(T, alive, fid, nv)
        return multi, stri & alive

    return [ignores_alive, unused_not_multi, one_corner, stri_alive_only]


def _same(a, b) -> bool:
    return all(x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y) for x, y in zip(a, b))


def test_multi_face_kernel_equals_numpy():
    """`_multi_face_kernel` (what `_State.seam` runs) gives `_multi_face_numpy`'s flags (numpy's
    minimum.at / maximum.at, the code it replaced) on every mesh; the meshes tell each broken variant
    from the reference (the comparison would catch such a kernel)."""
    caught = {f.__name__: False for f in _broken_variants()}
    n_multi = 0
    for T, alive, fid, nv in _meshes():
        ref = seams_mod._multi_face_numpy(T, alive, fid, nv)
        got = seams_mod._multi_face_kernel(T, alive, fid, np.int64(nv))
        assert _same(got, ref)
        n_multi += int(ref[0].sum())
        for f in _broken_variants():
            caught[f.__name__] |= not _same(f(T, alive, fid, nv), ref)
    assert n_multi > 1000
    assert all(caught.values()), caught


def test_state_seam_uses_the_kernel_flags(monkeypatch):
    """`reduce_seams` on a real shell gives the same mesh with the numpy flags as with the kernel's, and
    the kernel is what `_State.seam` calls (a broken kernel changes the result)."""
    from trimsurf.samples import build_sample
    from trimsurf.tessellate import tessellate_shell

    shell = build_sample("bspline_box")
    d = shell.diagonal()
    args = dict(tolerance=1e-3 * d, max_edge=3e-2 * d, measure=False)

    def run():
        res = tessellate_shell(shell, **args)
        return res.mesh.vertices.copy(), res.mesh.triangles.copy()

    base = run()
    monkeypatch.setattr(seams_mod, "_multi_face_kernel",
                        lambda T, alive, fid, nv: seams_mod._multi_face_numpy(T, alive, fid, int(nv)))
    assert _same(run(), base)

    def no_seams(T, alive, fid, nv):          # broken: no vertex on two faces, so no seam edge at all
        multi, stri = seams_mod._multi_face_numpy(T, alive, fid, int(nv))
        return np.zeros_like(multi), np.zeros_like(stri)

    monkeypatch.setattr(seams_mod, "_multi_face_kernel", no_seams)
    assert not _same(run(), base)
