"""tessellate_shell(jobs=N): the same output arrays whatever N, and the compiled kernels against numpy."""

from __future__ import annotations

import multiprocessing

import numpy as np
import pytest

from trimsurf.errors import InputError
from trimsurf.io import read_shell
from trimsurf.samples import build_sample
from trimsurf.tessellate import tessellate_shell
from trimsurf.tessellate import shell as shell_mod


def _same(a, b):
    ma, mb = a.mesh, b.mesh
    assert np.array_equal(ma.vertices, mb.vertices)      # exactly: bit for bit
    assert np.array_equal(ma.triangles, mb.triangles)
    assert np.array_equal(ma.face_id, mb.face_id)
    assert np.array_equal(a.quads, b.quads)
    assert a.faces == b.faces
    for fa, fb in zip(a.face_meshes, b.face_meshes):
        assert (fa is None) == (fb is None)
        if fa is not None:
            assert np.array_equal(fa.uv, fb.uv) and np.array_equal(fa.triangles, fb.triangles)


@pytest.mark.parametrize("mode", ["conforming", "loose"])
def test_jobs_give_the_same_mesh(shared_data, mode):
    shell = read_shell(shared_data / "cad" / "gmsh__t20_data.step")
    d = shell.diagonal()
    kw = dict(tolerance=1e-3 * d, max_edge=0.1 * d, mode=mode, measure=False)
    one = tessellate_shell(shell, jobs=1, **kw)
    two = tessellate_shell(shell, jobs=2, **kw)
    assert one.mesh.n_triangles > 1000
    _same(one, two)


def test_jobs_with_threads_and_a_failed_face(monkeypatch):
    # where fork is unavailable the stages run on threads: same output; a face that fails in a
    # worker is reported as in the sequential run
    from dataclasses import replace  # noqa: F401
    from trimsurf.model import Loop, Shell, TrimmedFace

    shell = build_sample("bspline_box")
    f = shell.faces[0]
    faces = list(shell.faces)
    faces[0] = TrimmedFace(f.surface, (Loop(f.loops[0].segments[:-1]),), f.same_sense, "broken", f.tolerance)
    broken = Shell.from_faces(faces)
    one = tessellate_shell(broken, measure=False, jobs=1)
    monkeypatch.setattr(multiprocessing, "get_all_start_methods", lambda: ["spawn"])
    three = tessellate_shell(broken, measure=False, jobs=3)
    assert [x.name for x in three.failed_faces] == ["broken"]
    _same(one, three)


def test_parallel_map_keeps_order_and_errors():
    assert shell_mod.parallel_map(lambda x: x * x, range(7), 2) == [x * x for x in range(7)]

    def boom(x):
        if x == 3:
            raise RuntimeError("three")
        return x

    with pytest.raises(RuntimeError, match="three"):
        shell_mod.parallel_map(boom, range(5), 2)


@pytest.mark.parametrize("jobs", [0, -1, 1.5, True, "2"])
def test_bad_jobs(jobs):
    with pytest.raises(InputError, match="jobs"):
        tessellate_shell(build_sample("bspline_box"), measure=False, jobs=jobs)


def test_progress_follows_the_faces(monkeypatch):
    # one job: progress is reported face by face while the faces are meshed, not all at the end
    events = []
    mesh = shell_mod.mesh_face_from_chunks

    def meshing(*args, **kw):
        events.append("mesh")
        return mesh(*args, **kw)

    monkeypatch.setattr(shell_mod, "mesh_face_from_chunks", meshing)
    tessellate_shell(build_sample("bspline_box"), measure=False, progress=lambda d, n: events.append((d, n)))
    assert events == [e for k in range(1, 7) for e in ("mesh", (k, 6))]
