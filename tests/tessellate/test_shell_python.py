"""Session 27 (issue 17): the shell-level and per-edge Python of the meshing, batched, against the
per-face / per-segment code it replaces, array for array (bit for bit)."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.io import read_shell
from trimsurf.tessellate import repair


def _g1_items(shell):
    items = []
    for f in shell.faces:
        s = f.surface
        lines = [[v for v, _, _ in repair._full_knots(k[p + 1:-p - 1], p, p)]
                 for k, p in ((s.knots_u, s.degree_u), (s.knots_v, s.degree_v))]
        if lines[0] or lines[1]:
            items.append((f, lines))
    return items


def _same(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        x, y = np.asarray(x), np.asarray(y)
        assert x.dtype == y.dtype and x.shape == y.shape
        assert x.tobytes() == y.tobytes()


@pytest.mark.parametrize("model", ["trimesh__featuretype.STEP", "gmsh__U_Joint_2.stp"])
def test_g1_samples_batched_equal_per_face(shared_data, model):
    """`repair._g1_samples_faces` (all lines' points at once, one compiled derivative call) gives the
    samples of `_g1_samples` face by face; also with faces whose lines miss the trim and a subset."""
    shell = read_shell(shared_data / "cad" / model)
    items = _g1_items(shell)
    assert len(items) >= 20
    for sel in (items, items[::3], items[1:2]):
        got, n_got = repair._g1_samples_faces(sel, 33)
        ref, n_ref = repair._g1_samples_per_face(sel, 33)
        _same(got, ref)
        assert n_got.tolist() == n_ref.tolist()
        assert sum(n_got) > 0
    # a line outside the trim has no point inside: the face contributes nothing (as _g1_samples' None)
    f, lines = items[0]
    (u0, u1), _ = f.surface.domain
    odd = [(f, [[u0 + 1e-9 * (u1 - u0)], []])] + items[:2]
    got, n_got = repair._g1_samples_faces(odd, 33)
    ref, n_ref = repair._g1_samples_per_face(odd, 33)
    _same(got, ref)
    assert n_got.tolist() == n_ref.tolist()


def test_all_finite_equals_per_array():
    rng = np.random.default_rng(3)
    arrays = [rng.random((k, 3)) for k in (1, 4, 9, 2)]
    arrays[1][2, 1] = np.nan
    arrays[3][1, 0] = -np.inf
    ref = [bool(np.all(np.isfinite(a))) for a in arrays]
    assert repair._all_finite(arrays) == ref == [True, False, True, False]
    assert repair._all_finite(arrays[:1]) == [True]
    assert repair._all_finite([]) == []


def _loop_arrays_loop(faces):
    """`face._loop_arrays` segment by segment: the code `face._sample_loops` had before session 27."""
    from trimsurf.geom.nurbs import _homogeneous, read_only

    si, knots, pws, sf = [], [], [], []
    ko = po = 0
    loop_segs, face_loops = [], []
    for face in faces:
        face_loops.append((len(loop_segs), len(face.loops)))
        for loop in face.loops:
            loop_segs.append((len(si), len(loop.segments)))
            for seg in loop.segments:
                c = seg.curve
                k = np.asarray(c.knots, dtype=np.float64)
                pw = _homogeneous(c.control_points, c.weights)
                si.append((c.degree, ko, len(k), po, pw.shape[0], pw.shape[1], c.weights is not None))
                sf.append((seg.t0, seg.t1))
                knots.append(k)
                pws.append(pw.ravel())
                ko += len(k)
                po += pw.size
    return (np.array(si, dtype=np.int64), np.array(sf, dtype=np.float64), read_only(np.concatenate(knots)),
            read_only(np.concatenate(pws)), loop_segs, face_loops)


@pytest.mark.parametrize("model", ["trimesh__featuretype.STEP", "gmsh__U_Joint_2.stp", "occt__screw.step"])
def test_loop_arrays_equal_segment_by_segment(shared_data, model):
    """`face._loop_arrays` (the p-curves packed by `trims._pcurve_rows`) against the per-segment packing
    it replaces: the same arrays (bytes, dtype, shape, read-only flags) and bookkeeping; rational and
    polynomial p-curves both present."""
    from trimsurf.tessellate.face import _loop_arrays

    shell = read_shell(shared_data / "cad" / model)
    faces = list(shell.faces)
    rat = [sg.curve.weights is not None for f in faces for lp in f.loops for sg in lp.segments]
    if model != "occt__screw.step":
        assert any(rat) and not all(rat)
    for sel in (faces, faces[::-1][:7], faces[2:3]):
        got, ref = _loop_arrays(sel), _loop_arrays_loop(sel)
        _same(got[:4], ref[:4])
        assert got[4:] == ref[4:]
        assert [x.flags.writeable for x in got[:4]] == [x.flags.writeable for x in ref[:4]]


def _same_array(x, y):
    assert type(x) is type(y) is np.ndarray
    assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes()


@pytest.mark.parametrize("model", ["trimesh__featuretype.STEP", "gmsh__U_Joint_2.stp"])
def test_knots_in_equals_numpy_path(shared_data, model):
    """`face._knots_in`'s scalar path against numpy's (unique_values masked): every knot vector of the
    model, with boxes from its loops' extent, around and between its knots and at its knots."""
    from trimsurf.tessellate.face import _knots_in, _knots_in_numpy

    shell = read_shell(shared_data / "cad" / model)
    rng = np.random.default_rng(5)
    n_inside = 0
    for f in shell.faces:
        s = f.surface
        for knots in (s.knots_u, s.knots_v):
            k0, k1 = float(knots[0]), float(knots[-1])
            u = np.unique(knots)
            boxes = [(k0, k1), (np.float64(k0), np.float64(k1)), (k1, k0), (k0 - 1.0, k0)]
            boxes += [(float(a), float(b)) for a, b in zip(u[:-1], u[1:])]        # knots as ends: none inside
            boxes += [(float(u[0]), float(u[-1]))] + [tuple(np.sort(rng.uniform(k0, k1, 2))) for _ in range(4)]
            for a, b in boxes:
                got, ref = _knots_in(knots, a, b), _knots_in_numpy(knots, a, b)
                _same_array(got, ref)
                n_inside += len(ref) > 0
    assert n_inside >= 20


def test_knots_in_edge_values():
    """Zeros of both signs inside (numpy's path decides), a nan in the vector or as an end, repeated
    values, another dtype: the numpy path's arrays."""
    from trimsurf.tessellate.face import _knots_in, _knots_in_numpy

    cases = [np.array([-1.0, -0.0, 0.0, 0.0, 1.0]), np.array([-1.0, 0.0, -0.0, 1.0]), np.array([0.0, 0.3, 0.3, 0.3, 1.0]),
             np.array([0.0, np.nan, 0.5, 1.0]), np.array([0.0, 0.25, 0.75, 1.0])[::-1],
             np.array([0, 1, 2, 3], dtype=np.int64), np.array([-np.inf, 0.5, np.inf])]
    for knots in cases:
        for a, b in ((-0.5, 0.5), (-1.0, 1.0), (0.0, 1.0), (np.nan, 1.0), (0.1, np.nan), (-np.inf, np.inf), (2.0, 0.0)):
            _same_array(_knots_in(knots, a, b), _knots_in_numpy(knots, a, b))
    # a long sorted vector with -0.0 then 0.0 inside, where numpy's sort keeps 0.0 (found by search: a
    # sorted set keeps -0.0, the first seen): the sign shows in the bytes
    rng = np.random.default_rng(0)
    for _ in range(2000):
        n = int(rng.integers(17, 80))
        x = np.sort(rng.uniform(-1, 1, n))
        i, j = sorted(rng.choice(n, 2, replace=False))
        x[i], x[j] = -0.0, 0.0
        x = np.sort(x, kind="stable")
        ref = _knots_in_numpy(x, -0.5, 0.5)
        if not np.signbit(ref[ref == 0.0][0]):
            break
    assert not np.signbit(ref[ref == 0.0][0]) and np.signbit(x[x == 0.0][0])
    _same_array(_knots_in(x, -0.5, 0.5), ref)
