"""`refine_cells` in one compiled call (`refine_cells_kernel`) against `_refine_cells_rounds`, the rounds run
from Python (the reference): the same grids, the same first-round maxima for `_worst_cell_ratio`, the same
errors; and its parts (the interval ids' hash table, the mid-lines) against the dict and unique_values."""

from __future__ import annotations

import numpy as np
import pytest

import trimsurf.tessellate.face as F
from trimsurf.errors import InputError
from trimsurf.io import read_shell
from trimsurf.samples import build_sample
from trimsurf.tessellate.domain import unique_values
from trimsurf.tessellate._line_kernels import _interval_ids, _with_mids


@pytest.fixture(scope="module")
def faces(shared_data):
    t20 = read_shell(shared_data / "cad" / "gmsh__t20_data.step")
    ft = read_shell(shared_data / "cad" / "trimesh__featuretype.STEP")
    return list(t20.faces[:8]) + list(ft.faces[:12]) + [build_sample("fender").faces[0]]


def _grids(face, rng):
    lo, hi = F.grid_box(face)
    yield np.linspace(lo[0], hi[0], 3), np.linspace(lo[1], hi[1], 4)
    yield (np.unique(np.r_[lo[0], rng.uniform(lo[0], hi[0], 5), hi[0]]),
           np.unique(np.r_[lo[1], rng.uniform(lo[1], hi[1], 4), hi[1]]))


def _reference(face, us, vs, cache, **kw):
    """`_refine_cells_rounds`, and its rounds (calls of refine_round_kernel op 0)."""
    calls = []
    kernel = F.refine_round_kernel

    def counted(op, *a):
        calls.append(op)
        return kernel(op, *a)

    F.refine_round_kernel = counted
    try:
        out = F._refine_cells_rounds(face, us, vs, cache=cache, **kw)
    finally:
        F.refine_round_kernel = kernel
    return out, calls.count(0)


def test_compiled_refinement_equals_the_rounds(faces):
    rng = np.random.default_rng(11)
    rounds = []
    for face in faces:
        s = face.surface
        size = float(np.ptp(s.control_points.reshape(-1, 3), axis=0).max())
        for tol_f, edge_f, aspect in ((3e-3, 10.0, F.ASPECT), (3e-4, 0.2, F.ASPECT), (1e-3, 10.0, None)):
            kw = dict(tolerance=tol_f * size, max_edge=edge_f * size, aspect=aspect)
            shared_new, shared_ref = F._CellCache(s), F._CellCache(s)    # a cache serving several grids, as a face's
            for us, vs in _grids(face, rng):
                for new_cache, ref_cache in ((F._CellCache(s), F._CellCache(s)), (shared_new, shared_ref)):
                    got = F.refine_cells(face, us, vs, cache=new_cache, **kw)
                    ref, n = _reference(face, us, vs, ref_cache, **kw)
                    rounds.append(n)
                    assert len(got) == 2 and all(np.array_equal(g, r) for g, r in zip(got, ref))
                    assert new_cache.checked[3:5] == ref_cache.checked[3:5] or np.isnan(ref_cache.checked[3])
                    # the refined grid's fits from the rows the kernel returned
                    assert np.array_equal(new_cache.fits(*got), F._diagonal_fits(s, *got))
                    # _worst_cell_ratio of the first grid from the first round's maxima: what it computes afresh
                    polys = F._loop_polys(face) if face.loops else None
                    # (deviations within the tolerance may be bounds within it: only a ratio over 1 is a value)
                    r0, rd0 = F._worst_cell_ratio(face, us, vs, kw["tolerance"], polys, None, kw["max_edge"])
                    r1, rd1 = F._worst_cell_ratio(face, us, vs, kw["tolerance"], polys, new_cache, kw["max_edge"])
                    assert rd0 == rd1 and (r0 > 1) == (r1 > 1) and (r0 == r1 or r0 <= 1)
    rounds = np.array(rounds)
    # the cases refine (several rounds, up to the last) and leave grids alone
    assert (rounds == 1).any() and (rounds >= 3).any() and (rounds == F._ROUNDS).any(), np.bincount(rounds)


def test_compiled_refinement_cell_budget(faces, monkeypatch):
    face = faces[0]
    s = face.surface
    size = float(np.ptp(s.control_points.reshape(-1, 3), axis=0).max())
    lo, hi = F.grid_box(face)
    us, vs = np.linspace(lo[0], hi[0], 4), np.linspace(lo[1], hi[1], 4)
    kw = dict(tolerance=1e-5 * size, max_edge=0.01 * size)
    monkeypatch.setattr(F, "MAX_CELLS", 40)
    with pytest.raises(InputError) as a:
        F.refine_cells(face, us, vs, **kw)
    with pytest.raises(InputError) as b:
        F._refine_cells_rounds(face, us, vs, **kw)
    assert str(a.value) == str(b.value) and "more than 40" in str(a.value)


def test_compiled_refinement_declines_a_grid_not_increasing(faces, monkeypatch):
    # (the kernel assumes increasing grids: the reference sorts whatever it is given)
    face = faces[1]
    lo, hi = F.grid_box(face)
    us = np.linspace(lo[0], hi[0], 5)[[0, 2, 1, 3, 4]]
    vs = np.linspace(lo[1], hi[1], 4)
    size = float(np.ptp(face.surface.control_points.reshape(-1, 3), axis=0).max())
    kw = dict(tolerance=1e-3 * size, max_edge=size)
    ran = []
    rounds = F._refine_cells_rounds
    monkeypatch.setattr(F, "_refine_cells_rounds", lambda *a, **k: ran.append(1) or rounds(*a, **k))
    got = F.refine_cells(face, us, vs, **kw)
    assert ran and all(np.array_equal(g, r) for g, r in zip(got, rounds(face, us, vs, **kw)))


def test_interval_ids_are_a_dict_of_float_pairs():
    rng = np.random.default_rng(2)
    ref: dict = {}
    keys, ent, cnt = np.empty((0, 2)), np.empty((0, 2), dtype=np.int64), 0
    pool = np.r_[-0.0, 0.0, 1.0, np.nextafter(1.0, 2.0), rng.uniform(-1, 1, 40)]
    for _ in range(60):        # grids sharing intervals, the table grown several times
        x = rng.choice(pool, rng.integers(2, 30))
        out = np.empty(len(x) - 1, dtype=np.int64)
        keys, ent, cnt = _interval_ids(keys, ent, np.int64(cnt), np.ascontiguousarray(x), out)
        want = [ref.setdefault((a, b), len(ref)) for a, b in zip(x[:-1].tolist(), x[1:].tolist())]
        assert out.tolist() == want
    assert cnt == len(ref) and len(ent) > 128


def test_mid_lines_are_unique_values_of_the_midpoints():
    rng = np.random.default_rng(4)
    a = 1.0
    tight = np.array([a, np.nextafter(a, 2), np.nextafter(np.nextafter(a, 2), 2), 1.5, 3.0])   # midpoints = ends
    for x in [tight] + [np.unique(rng.uniform(-5, 5, rng.integers(2, 20))) for _ in range(50)]:
        split = rng.random(len(x) - 1) < 0.5
        split[:2] = True
        ref = unique_values(np.concatenate((x, (0.5 * (x[:-1] + x[1:]))[split])))
        assert np.array_equal(_with_mids(x, split), ref)
    for x in ([1e308, 1.7e308], [0.0, np.nan]):      # no midpoint inside (overflow, NaN): declined
        assert len(_with_mids(np.array(x), np.array([True]))) == 0


def test_bilinear_bound_is_the_numpy_one(shared_data):
    # every face of two files with planes (the bound's case) and twisted / offset / scaled bilinear patches
    from trimsurf.model import NurbsSurface

    surfaces = [f.surface for name in ("trimesh__featuretype.STEP", "occt__screw.step")
                for f in read_shell(shared_data / "cad" / name).faces]
    rng = np.random.default_rng(8)
    for k in range(200):
        cp = rng.normal(size=(2, 2, 3)) * 10.0 ** rng.integers(-6, 6) + rng.normal(size=3) * 10.0 ** rng.integers(-3, 8)
        a, b = sorted(rng.normal(size=2) * 10.0 ** rng.integers(-3, 4))
        knots = np.array([a, a, b, b])
        surfaces.append(NurbsSurface(1, 1, knots, knots[::-1] * -1.0, cp))
    planes = 0
    for s in surfaces:
        got, ref = F._CellCache._bilinear(s), F._CellCache._bilinear_numpy(s)
        assert np.array_equal(got, ref), (got, ref)
        planes += got[0] >= 0
    assert planes > 200
