"""`tessellate.measure.flipped_against_normal` (one stable sort, normals once) gives the per-face submesh
loop's numbers: every face's count, reversed or not, with and without the deviation's centroid feet."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from trimsurf.quality import flipped_triangles_normal
from trimsurf.quality import deviation as dv
from trimsurf.samples import build_sample
from trimsurf.tessellate import tessellate_shell
from trimsurf.tessellate.measure import flipped_against_normal


def _reference(mesh, shell, reversed_faces=(), centroid_uv=None) -> int:
    """The loop it replaces: `flipped_triangles_normal` on each face's submesh."""
    rev = {int(f) for f in reversed_faces}
    n = 0
    for i in np.unique(mesh.face_id):
        sub = mesh.submesh(mesh.face_id == i)
        cuv = None if centroid_uv is None else centroid_uv.get(int(i))
        r = flipped_triangles_normal(sub, shell.faces[int(i)], centroid_uv=cuv)
        n += int(sub.n_triangles - r.n_flipped - r.n_zero) if int(i) in rev else r.n_flipped
    return n


def _turned(mesh, rows):
    """`mesh` with the triangles `rows` turned over."""
    t = mesh.triangles.copy()
    t[rows] = t[rows, ::-1]
    return dataclasses.replace(mesh, triangles=t)


@pytest.fixture(scope="module", params=["screw", "bspline_box"])
def case(request, shared_data):
    if request.param == "screw":
        from trimsurf.io import read_shell

        shell = read_shell(shared_data / "cad" / "occt__screw.step")
    else:
        shell = build_sample("bspline_box")
    d = shell.diagonal()
    res = tessellate_shell(shell, tolerance=1e-3 * d, max_edge=d, measure=False)
    # interleaved faces (face ids not sorted along the triangles) and some triangles turned over
    rng = np.random.default_rng(3)
    perm = rng.permutation(res.mesh.n_triangles)
    m = dataclasses.replace(res.mesh, triangles=res.mesh.triangles[perm], face_id=res.mesh.face_id[perm])
    m = _turned(m, rng.choice(m.n_triangles, 25, replace=False))
    # and two triangles of zero area (three copies of one vertex each): counted as zero, not flipped
    k = m.n_vertices
    v = np.vstack([m.vertices, np.repeat(m.vertices[m.triangles[:2, 0]], 3, axis=0)])
    m = dataclasses.replace(m, vertices=v, triangles=np.vstack([m.triangles, [[k, k + 1, k + 2], [k + 3, k + 4, k + 5]]]),
                            face_id=np.r_[m.face_id, m.face_id[:2]])
    _, states = dv._shell_deviation(m, shell, density=3, n_domain=8, two_sided=False, tol_rel=1e-10, refine=0.01,
                                    skip=False)
    cuv = {i: st.centroid_uv for i, st in enumerate(states) if st is not None and st.centroid_uv is not None}
    return shell, m, cuv


def test_every_face_count_as_the_submesh_loop(case):
    shell, m, cuv = case
    assert cuv and len(cuv) == len(np.unique(m.face_id))
    for feet in (None, cuv):
        base = flipped_against_normal(m, shell, centroid_uv=feet)
        assert base == _reference(m, shell, centroid_uv=feet) >= 25
        assert flipped_against_normal(m, shell, reversed_faces=np.unique(m.face_id), centroid_uv=feet) == \
            m.n_triangles - base - 2                     # the two of zero area are neither
        for f in np.unique(m.face_id).tolist():       # each face reversed alone: its own flipped + zero count
            assert flipped_against_normal(m, shell, reversed_faces=[f], centroid_uv=feet) == \
                _reference(m, shell, reversed_faces=[f], centroid_uv=feet)


def test_feet_of_the_wrong_length_are_refused(case):
    from trimsurf.errors import InputError

    shell, m, cuv = case
    f = next(iter(cuv))
    with pytest.raises(InputError, match="centroid_uv"):
        flipped_against_normal(m, shell, centroid_uv={f: cuv[f][:-1]})


def _sense_turned(shell, faces):
    """`shell` with the faces `faces` of the opposite sense (`TrimmedFace.same_sense` False)."""
    new = list(shell.faces)
    for f in faces:
        new[f] = dataclasses.replace(new[f], same_sense=not new[f].same_sense)
    return dataclasses.replace(shell, faces=tuple(new))


def test_faces_of_reversed_sense(case):
    """The batched normals are negated on the faces whose sense is reversed, as `oriented_normals` does: the
    counts of the submesh loop; and a version that ignores the sense does not give them."""
    shell, m, cuv = case
    ids = np.unique(m.face_id).tolist()
    turned = _sense_turned(shell, ids[::2])
    for feet in (None, cuv):
        assert flipped_against_normal(m, turned, centroid_uv=feet) == _reference(m, turned, centroid_uv=feet)
        assert flipped_against_normal(m, turned, reversed_faces=ids[1::3], centroid_uv=feet) == \
            _reference(m, turned, reversed_faces=ids[1::3], centroid_uv=feet)
    # a version that ignored the sense would count as on the unturned shell: those counts differ
    assert flipped_against_normal(m, shell, centroid_uv=cuv) != _reference(m, turned, centroid_uv=cuv)
