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


def _surfaces(faces):
    """The faces' surfaces (rational and polynomial) and a rational quarter cone with a collapsed row."""
    from trimsurf.model.nurbs import NurbsSurface

    r = np.sqrt(0.5)
    cp = np.array([[[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], [[1.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                   [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]])
    cone = NurbsSurface(2, 1, [0, 0, 0, 1, 1, 1], [0, 0, 1, 1], cp, np.array([[1.0, 1.0], [r, r], [1.0, 1.0]]))
    return [f.surface for f in faces[:8]] + [faces[-1].surface, cone]


def test_points0_is_the_per_point_evaluation(faces):
    """`_points0` (the written-out nd = 0 point with its direct-mapped span / basis stores) is
    `NurbsSurface.evaluate` of the clipped parameters bit for bit: many distinct values (more than the
    stores' 256 slots: evictions and collisions), repeated values, values beyond the domain (clipped to its
    ends, the last span's search)."""
    from trimsurf.tessellate._line_kernels import _points0

    rng = np.random.default_rng(11)
    n = 0
    for s in _surfaces(faces):
        (u0, u1), (v0, v1) = s.domain
        du, dv = u1 - u0, v1 - v0
        u = np.r_[rng.uniform(u0 - 0.2 * du, u1 + 0.2 * du, 700), np.linspace(u0, u1, 9), u0, u1]
        v = np.r_[rng.uniform(v0 - 0.2 * dv, v1 + 0.2 * dv, 700), np.linspace(v0, v1, 9), v1, v0]
        q = np.column_stack([u, v])
        q = np.r_[q, q[::-1], np.column_stack([u, v[::-1]])]          # the same values again, other pairs
        out = np.empty((len(q), 3))
        _points0(*F._CellCache(s)._surf, q, out)
        ref = s.evaluate(np.clip(q, [u0, v0], [u1, v1]))
        assert np.array_equal(out, ref)
        n += len(q)
    assert n > 15000


def _split_reference(s, uv, p, rows, flags, screen):
    """op 1 of `cell_surface_kernel` per sample from `surface_distance` (the numpy wrapper of the per-point
    kernel): every one of the 2 x 7 samples of each cell, its start distance (steps = 0) and, over the
    screen (or screen 0), its distance (2 steps)."""
    out_f, out_b = np.empty(len(rows)), np.empty(len(rows), dtype=bool)
    for c, (r, m) in enumerate(zip(rows, flags)):
        tris = ((0, 1, 2), (0, 2, 3)) if m else ((0, 1, 3), (1, 2, 3))
        tuv = np.concatenate([(F._BARY[:, :1] * uv[r, t0] + F._BARY[:, 1:2] * uv[r, t1]) + F._BARY[:, 2:] * uv[r, t2]
                              for t0, t1, t2 in tris])
        tx = np.concatenate([(F._BARY[:, :1] * p[r, t0] + F._BARY[:, 1:2] * p[r, t1]) + F._BARY[:, 2:] * p[r, t2]
                             for t0, t1, t2 in tris])
        d0 = F.surface_distance(s, tuv, tx, steps=0)
        full = ~(d0 <= screen) if screen > 0 else np.ones(len(d0), dtype=bool)
        dk = F.surface_distance(s, tuv[full], tx[full], steps=2)
        ex = np.nan if np.isnan(dk).any() else float(np.max(dk, initial=0.0))
        bnd = float(np.max(d0[~full], initial=0.0))
        if screen > 0 and not (np.isnan(ex) or ex > screen):
            out_f[c], out_b[c] = max(bnd, ex), True
        else:
            out_f[c], out_b[c] = ex, False
    return out_f, out_b


def test_split_deviation_shortcuts_equal_the_per_sample_path(faces):
    """op 1 of `cell_surface_kernel` shares work between samples: a side's midpoint with the neighbour cell
    (same parameters and point bit for bit: one evaluation), the diagonal's midpoint start distance from the
    centre's point p[r, 4] (where its parameters are the centre's bit for bit), the spans and bases of
    repeated parameter values. Its values are the per-sample path's bit for bit, screened and exact, with
    either split per cell; also where the shortcuts must not apply: cells whose corner points differ from
    their neighbours' at the shared sides (every other cell moved), cells whose stored centre is not the
    centre of their corners."""
    from trimsurf.tessellate._line_kernels import cell_surface_kernel

    rng = np.random.default_rng(5)
    n_cells = n_bounded = n_exact = 0
    for s in _surfaces(faces):
        surf = F._CellCache(s)._surf
        (u0, u1), (v0, v1) = s.domain
        us, vs = np.linspace(u0, u1, 7), np.linspace(v0, v1, 6)
        ia, ib = (a.ravel() for a in np.meshgrid(np.arange(len(us) - 1), np.arange(len(vs) - 1), indexing="ij"))
        k = len(ia)
        uv, p, d = np.empty((k, 5, 2)), np.empty((k, 5, 3)), np.empty((k, 2))
        cell_surface_kernel(0, *surf, us, vs, ia, ib, F._NO_B, F._BARY, uv, p, 0.0, F._NO_F, F._NO_B, F._NO_B, d)
        flags = rng.random(k) < 0.5
        moved_p = p.copy()
        moved_p[::2, :4] += 0.05 * float(np.ptp(p))     # every other cell's corners: not the neighbours'
        moved_uv, moved_pc = uv.copy(), p.copy()
        moved_uv[1::3, 4] = uv[1::3, 0]                            # a stored "centre" at the first corner
        moved_pc[1::3, 4] = moved_pc[1::3, 0]
        for cuv, cp in ((uv, p), (uv, moved_p), (moved_uv, moved_pc)):
            rows = np.arange(k)
            for screen in (0.0, float(np.median(d[:, 0])), 1e-12, 1e300):
                got_f, got_b = np.empty(k), np.empty(k, dtype=bool)
                cell_surface_kernel(1, *surf, F._NO_F, F._NO_F, rows, F._NO_I, flags, F._BARY, cuv, cp, screen,
                                    got_f, got_b, F._NO_B, F._NO_D)
                ref_f, ref_b = _split_reference(s, cuv, cp, rows, flags, screen)
                assert np.array_equal(got_f, ref_f, equal_nan=True) and np.array_equal(got_b, ref_b)
                n_cells += k
                n_bounded += int(got_b.sum())
                n_exact += int((~got_b).sum())
    assert n_cells > 1000 and n_bounded > 300 and n_exact > 300


def test_refine_chain_inlines_the_cell_kernels_once():
    """The cold compile (session 29): `refine_cells_kernel` IR-inlines `grid_cells_kernel` (with
    `cache_cells_kernel` inside) and `cell_deviation_kernel` (their twins, inline="always", the same
    Python functions), so `cell_surface_kernel`'s body is linked into 2 libraries, not 5; the Python-facing
    kernels stay as they are."""
    import trimsurf.tessellate._line_kernels as L

    pairs = ((L._grid_cells_i, L.grid_cells_kernel), (L._cache_cells_i, L.cache_cells_kernel),
             (L._cell_deviation_i, L.cell_deviation_kernel))
    for twin, kernel in pairs:
        assert twin.targetoptions.get("inline") == "always"
        assert twin.py_func is kernel.py_func
    assert kernel.targetoptions.get("inline", "never") == "never"
    names = L.refine_cells_kernel.py_func.__code__.co_names
    assert "_grid_cells_i" in names and "_cell_deviation_i" in names
    assert "grid_cells_kernel" not in names and "cell_deviation_kernel" not in names
    names = L.grid_cells_kernel.py_func.__code__.co_names
    assert "_cache_cells_i" in names and "cache_cells_kernel" not in names
