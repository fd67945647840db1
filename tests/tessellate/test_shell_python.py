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
    """`face._loop_arrays` (the p-curves packed by `model.trim._pcurve_rows`) against the per-segment packing
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


def test_increasing_only_where_the_linspace_increases():
    """`face._increasing` (an argued bound) never says True where `_linspace(a, b, n)` does not increase
    strictly: random boxes of every scale, steps just above and below its threshold, huge and tiny
    values, subnormal steps; and it says True on the usual boxes (else it saves nothing)."""
    from trimsurf.tessellate.face import _U, _increasing, _linspace, _with_knots

    rng = np.random.default_rng(7)
    cases = []
    for _ in range(4000):
        a = float(rng.uniform(-1, 1) * 10.0 ** rng.integers(-30, 30))
        n = int(rng.integers(2, 40))
        scale = abs(a) if a else 1.0
        # steps from far below to far above 8u (|a| + |b| + (b - a)): around the bound
        s = scale * 8.0 * _U * float(rng.uniform(0.1, 10.0)) * (4.0 if rng.random() < 0.5 else 1.0)
        if rng.random() < 0.3:
            s = scale * float(rng.uniform(1e-3, 1.0))
        cases.append((a, a + s * (n - 1), n))
    cases += [(0.0, 1.0, 17), (-1.0, 1.0, 24), (1e300, 1.1e300, 17), (-5e-324, 5e-324, 2), (0.0, 1e-310, 17),
              (1.0, 1.0 + 2 ** -40, 17), (0.0, 1.5e-323, 17), (0.0, 3e-322, 40), (1.0, 1.0, 17), (2.0, 1.0, 17), (0.0, np.inf, 17), (0.0, np.nan, 17)]
    n_true = 0
    for a, b, n in cases:
        if not np.isfinite(b):
            assert not _increasing(a, b, n)
            continue
        y = _linspace(a, b, n)
        inc = bool((y[1:] > y[:-1]).all())
        if _increasing(a, b, n):
            n_true += 1
            assert inc, (a, b, n)
        _same(( _with_knots(a, b, n, np.zeros(0)),), (
            y if inc else __import__("trimsurf.tessellate.domain", fromlist=["x"]).unique_values(y),))
    assert n_true >= 1000
    assert _increasing(0.0, 1.0, 17) and _increasing(np.float64(-3.0), np.float64(2.5), 24)


@pytest.mark.parametrize("model", ["trimesh__featuretype.STEP", "gmsh__U_Joint_2.stp"])
def test_straight_info_kept_equals_computed(shared_data, model):
    """`face._straight_info`'s kept answers (`_STRAIGHT`) are the computed ones, with and without the
    caller's `common`, for every surface and axis of the model; a writable net is not kept."""
    from trimsurf.geom.nurbs import _homogeneous
    from trimsurf.tessellate import face as fm

    shell = read_shell(shared_data / "cad" / model)
    fm._STRAIGHT.clear()
    n_straight = 0
    for f in shell.faces:
        s = f.surface
        pw = _homogeneous(s.control_points, s.weights)
        for axis in (0, 1):
            ref = fm._straight_info_computed(s, axis, pw) if fm._straight_dir(s, axis) else None
            for common in (None, fm._net_extremes(s, pw), None):
                assert fm._straight_info(s, axis, pw, common) == ref
            n_straight += ref is not None
            if ref is not None:
                assert fm._STRAIGHT[(id(s), axis)][2] == ref
                w = np.array(pw)            # (a writable copy: computed, not kept)
                assert fm._straight_info(s, axis, w) == ref and fm._STRAIGHT[(id(s), axis)][1] is pw
    assert n_straight >= 10


def test_normals_rows_equal_normals():
    """`seams._normals_rows` (scalars, a swap candidate's one or two triangles) against `seams._normals`, bit
    for bit, on coordinates of many scales, degenerate triangles and a repeated vertex."""
    from trimsurf.tessellate.seams import _normals, _normals_rows

    rng = np.random.default_rng(11)
    V = rng.normal(size=(60, 3)) * 10.0 ** rng.integers(-8, 8, size=(60, 1))
    V[5] = V[4] + 1e-17
    V[7] = 0.5 * (V[8] + V[9])
    rows = [tuple(int(x) for x in rng.choice(60, 3, replace=False)) for _ in range(300)]
    rows += [(4, 5, 6), (7, 8, 9), (1, 1, 2), (3, 2, 3)]
    for k in range(0, len(rows), 2):
        sel = rows[k:k + 2]
        got, ref = _normals_rows(V, sel), _normals(V, np.array(sel, dtype=np.int64))
        assert got.dtype == ref.dtype and got.shape == ref.shape and got.tobytes() == ref.tobytes()
