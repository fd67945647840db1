"""The compiled edge discretization (`trims.discretize_chunks`, `_chunk_kernels`) against the numpy path it
replaces (`trims._discretize_chunk_numpy`): the same points bit for bit (the meshes' hashes depend on it),
on the shared and single-use chunks of real models, at tolerance-only and paper settings."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.errors import InputError
from trimsurf.io import read_shell
from trimsurf.samples import build_sample
from trimsurf.tessellate.face import face_domain_values
from trimsurf.tessellate.trims import ChunkUse, _discretize_chunk_numpy, discretize_chunk, discretize_chunks


def _ptol(face) -> float:
    (u0, u1), (v0, v1) = face.surface.domain
    return 1e-7 * min(u1 - u0, v1 - v0)


def _chunks(shell, tol, h):
    """Per edge its uses (as tessellate_shell builds them) and whether the edge is degenerate."""
    grids, chunks, degs = {}, [], []
    for e in shell.edges:
        uses = []
        for fi, li, si in e.uses:
            f = shell.faces[fi]
            if fi not in grids:
                grids[fi] = face_domain_values(f, tolerance=0.97 * tol, max_edge=h)
            us, vs = grids[fi]
            uses.append(ChunkUse(fi, li, si, f.loops[li].segments[si], f.surface, us, vs, _ptol(f)))
        chunks.append(uses)
        degs.append(True if e.is_degenerate else None)
    return chunks, degs


def _same(a, b) -> bool:
    return (a.s.tobytes() == b.s.tobytes() and a.degenerate == b.degenerate and np.array_equal(a.is_iso, b.is_iso)
            and len(a.uv) == len(b.uv) and all(x.tobytes() == y.tobytes() for x, y in zip(a.uv, b.uv))
            and a.xyz.tobytes() == b.xyz.tobytes())


@pytest.mark.parametrize("model", ["gmsh__t20_data.step", "occt__screw.step"])
@pytest.mark.parametrize("rel_h", [1.0, 0.03])
def test_compiled_chunks_equal_numpy_path(shared_data, model, rel_h):
    shell = read_shell(shared_data / "cad" / model)
    d = shell.diagonal()
    tol, h = 1e-3 * d, rel_h * d
    chunks, degs = _chunks(shell, tol, h)
    singles = [[u] for ch in chunks for u in ch]          # loose mode: every segment its own chunk
    for cl, dl in ((chunks, degs), (singles, [None] * len(singles))):
        got = discretize_chunks(cl, tolerance=tol, max_edge=h, degenerate=dl)
        ref = [_discretize_chunk_numpy(u, tolerance=tol, max_edge=h, degenerate=g) for u, g in zip(cl, dl)]
        assert len(got) == len(ref) == len(cl)
        bad = [i for i, (a, b) in enumerate(zip(got, ref)) if not _same(a, b)]
        assert not bad, f"{len(bad)} of {len(cl)} chunks differ"
        # the batch is the chunks one by one (no state carried from one chunk to the next)
        for i in range(0, len(cl), max(1, len(cl) // 5)):
            assert _same(discretize_chunk(cl[i], tolerance=tol, max_edge=h, degenerate=dl[i]), got[i])
        # shared chunks: several points, and every chunk longer than the chord rule kept more than its ends
        assert sum(len(c.s) > 2 for c in got) >= 5


def test_compiled_chunks_forced_degenerate_and_refusal():
    shell = build_sample("bspline_box")
    d = shell.diagonal()
    tol, h = 1e-3 * d, 0.03 * d
    chunks, _ = _chunks(shell, tol, h)
    uses = chunks[0]
    for deg in (True, False, None):
        got = discretize_chunks([uses], tolerance=tol, max_edge=h, degenerate=[deg])[0]
        ref = _discretize_chunk_numpy(uses, tolerance=tol, max_edge=h, degenerate=deg)
        assert _same(got, ref)
        assert got.degenerate == (deg is True)
        if deg:         # one 3D point for the whole curve
            assert np.all(got.xyz == got.xyz[0])
    # a grid size far too small for the curve: refused by name (the numpy path's InputError), not placed
    with pytest.raises(InputError, match="intervals needed"):
        discretize_chunks([uses], tolerance=tol, max_edge=1e-7 * d)
    # the other strategies take the numpy path: the same chunk
    for strategy in ("bisection", "uniform"):
        a = discretize_chunks([uses], tolerance=tol, max_edge=h, strategy=strategy)[0]
        assert _same(a, _discretize_chunk_numpy(uses, tolerance=tol, max_edge=h, strategy=strategy))


@pytest.mark.parametrize("model,rel_h,least", [("trimesh__featuretype.STEP", 1.0, 60), ("occt__screw.step", 1.0, 1),
                                               ("trimesh__featuretype.STEP", 0.03, 1)])
def test_straight_chunks_skip_placement(shared_data, monkeypatch, model, rel_h, least):
    """A straight chunk (`_chunk_kernels._straight_scale`) takes [0, 1] without the placement: every chunk
    is the same bit for bit as with the placement run on every chunk (`_STRAIGHT_SHORTCUT = False`) and
    as the numpy path, the placement of every skipped chunk gives exactly [0, 1], and the shortcut is
    taken on real straight edges."""
    from trimsurf.tessellate import trims
    from trimsurf.tessellate._line_kernels import equidistributed_kernel

    shell = read_shell(shared_data / "cad" / model)
    d = shell.diagonal()
    tol, h = 1e-3 * d, rel_h * d
    chunks, degs = _chunks(shell, tol, h)
    got = discretize_chunks(chunks, tolerance=tol, max_edge=h, degenerate=degs)
    x0, degen, straight = trims._placement_starts(chunks, tolerance=tol, max_edge=h, degenerate=degs)
    monkeypatch.setattr(trims, "_STRAIGHT_SHORTCUT", False)
    ref = discretize_chunks(chunks, tolerance=tol, max_edge=h, degenerate=degs)
    assert not trims._placement_starts(chunks, tolerance=tol, max_edge=h, degenerate=degs)[2].any()
    bad = [i for i, (a, b) in enumerate(zip(got, ref)) if not _same(a, b)]
    assert not bad, f"{len(bad)} of {len(chunks)} chunks differ"
    skipped = np.flatnonzero(straight).tolist()
    assert len(skipped) >= least and not degen[skipped].any()
    # the placement itself (as the kernel calls it) gives exactly [0, 1] on every skipped chunk
    fam = trims._ChunkLines
    for i in skipped:
        tol_i = tol if len(chunks[i]) < 2 else trims.SHARED_CHORD * tol
        x, needed = equidistributed_kernel(*fam(chunks[i]).family()[:10], *_rows(chunks[i]), x0[i].copy(), 0.0, 1.0,
                                           tol_i, h, 20000.0)
        assert x.tolist() == [0.0, 1.0] and needed < 0
    for i in skipped[:: max(1, len(skipped) // 5)]:
        assert _same(got[i], _discretize_chunk_numpy(chunks[i], tolerance=tol, max_edge=h, degenerate=degs[i]))


def _rows(uses):
    """The kind-1 family members of one chunk (ci, cf, ck, cpw, cku, ckv, cpw4) as `discretize_chunks` builds them."""
    from trimsurf.tessellate.trims import _batch_arrays

    return _batch_arrays([uses])[:7]


def test_straight_shortcut_refuses_curves(shared_data, monkeypatch):
    """Arcs whose chord passes the check on [0, 1] (grid size 1.01 x the chord, a tolerance far above the
    sagitta) but whose length needs more points: the placement gives more than [0, 1], and so must the
    chunk with the shortcut on (a shortcut that took curves for straight would give [0, 1])."""
    from trimsurf.tessellate import trims

    shell = read_shell(shared_data / "cad" / "trimesh__featuretype.STEP")
    d = shell.diagonal()
    chunks, degs = _chunks(shell, 1e-3 * d, d)
    tested = 0
    for uses, deg in zip(chunks, degs):
        if deg:
            continue
        p = uses[0].xyz(np.linspace(0.0, 1.0, 201))
        chord = float(np.linalg.norm(p[-1] - p[0]))
        arc = float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())
        if not (chord > 1e-3 * d and arc > 1.3 * chord):
            continue
        h = 1.01 * chord
        monkeypatch.setattr(trims, "_STRAIGHT_SHORTCUT", True)
        got = discretize_chunks([uses], tolerance=10 * d, max_edge=h)[0]
        monkeypatch.setattr(trims, "_STRAIGHT_SHORTCUT", False)
        ref = discretize_chunks([uses], tolerance=10 * d, max_edge=h)[0]
        assert _same(got, ref)
        assert len(ref.s) > 2
        tested += 1
    assert tested >= 5


def _criteria_caller():
    """`_line_kernels._chunk_criteria` (no Python wrapper) called from a compiled function."""
    from numba import njit

    from trimsurf.tessellate._line_kernels import _chunk_criteria

    @njit
    def call(fam, a, b, m):
        length, dev = np.empty(a.shape[0]), np.empty(a.shape[0])
        _chunk_criteria(fam[10], fam[11], fam[12], fam[13], fam[14], fam[15], fam[16], a, b, m, length, dev,
                        np.inf, np.inf, False, np.empty(0), np.empty(0))
        return length, dev

    return call


def _halves_caller():
    """`_chunk_criteria` over the intervals x (their points kept), then over the halves of some of them
    with (pin) and without the parents' points."""
    from numba import njit

    from trimsurf.tessellate._line_kernels import _chunk_criteria

    @njit
    def call(fam, x, sel, m, spoil):
        n, npt = x.shape[0] - 1, m * fam[10].shape[0] * 3
        ln, dv, P = np.empty(n), np.empty(n), np.empty(n * npt)
        _chunk_criteria(fam[10], fam[11], fam[12], fam[13], fam[14], fam[15], fam[16], x[:-1], x[1:], m, ln, dv,
                        np.inf, np.inf, False, np.empty(0), P)
        k = sel.shape[0]
        sa, sb, pin = np.empty(2 * k), np.empty(2 * k), np.empty(k * npt)
        for q in range(k):
            i = sel[q]
            mid = 0.5 * (x[i] + x[i + 1])
            sa[2 * q], sb[2 * q], sa[2 * q + 1], sb[2 * q + 1] = x[i], mid, mid, x[i + 1]
            for r in range(npt):
                pin[q * npt + r] = P[i * npt + r] + spoil
        out = []
        for use in range(2):
            ln, dv, po = np.empty(2 * k), np.empty(2 * k), np.empty(2 * k * npt)
            _chunk_criteria(fam[10], fam[11], fam[12], fam[13], fam[14], fam[15], fam[16], sa, sb, m, ln, dv,
                            np.inf, np.inf, False, pin if use else np.empty(0), po)
            out.append((ln, dv, po))
        return out

    return call


@pytest.mark.parametrize("model", ["trimesh__featuretype.STEP", "gmsh__t20_data.step"])
def test_chunk_criteria_halves_take_the_parents_points(shared_data, model):
    # the bisection rounds' halves take the points they share with their parent interval (same parameter
    # bits) from its stored points (pin) instead of evaluating them: lengths, deviations and the points
    # themselves bit for bit those of the evaluation, for 5 and 9 points per interval, on every chunk; and
    # the parents' points ARE read (spoiled by 1e-3 they change the results), so a reuse of the wrong
    # point, or of one whose parameter differs, fails here
    from trimsurf.tessellate.trims import _ChunkLines

    shell = read_shell(shared_data / "cad" / model)
    d = shell.diagonal()
    chunks, _ = _chunks(shell, 1e-3 * d, d)
    call = _halves_caller()
    rng = np.random.default_rng(7)
    n_spoiled = 0
    for uses in chunks:
        f = _ChunkLines(uses).family()
        x = np.unique(np.r_[0.0, rng.random(9), 1.0])
        sel = np.sort(rng.choice(len(x) - 1, 5, replace=False))
        for m in (5, 9):
            (l0, d0, p0), (l1, d1, p1) = call(f, x, sel, np.int64(m), 0.0)
            assert l0.tobytes() == l1.tobytes() and d0.tobytes() == d1.tobytes() and p0.tobytes() == p1.tobytes()
            (_, _, _), (l2, d2, p2) = call(f, x, sel, np.int64(m), 1e-3 * d)
            n_spoiled += p2.tobytes() != p0.tobytes()
    assert n_spoiled >= len(chunks)


@pytest.mark.parametrize("model", ["trimesh__featuretype.STEP", "gmsh__t20_data.step"])
def test_chunk_criteria_equal_numpy_criteria(shared_data, model):
    # the compiled criteria (span searches and bases written out, flat-array indexing, maxima of squares, the
    # point at the previous interval's end reused) against `_ChunkLines.criteria` (points by `ChunkUse.xyz`,
    # `chord_criteria_kernel`): the same lengths and deviations bit for bit, over every chunk's uses (rational
    # arcs on cylinders and planes, shared by two faces) on consecutive intervals (the reuse) and on
    # intervals out of order (none), with 5 and 9 points per interval
    from trimsurf.tessellate.trims import _ChunkLines

    shell = read_shell(shared_data / "cad" / model)
    d = shell.diagonal()
    chunks, _ = _chunks(shell, 1e-3 * d, d)
    call = _criteria_caller()
    rng = np.random.default_rng(5)
    n_rat = n_two = 0
    for uses in chunks:
        fam = _ChunkLines(uses)
        f = fam.family()
        n_rat += bool(f[10][:, 1].any() or f[10][:, 4].any())     # a rational p-curve or surface
        n_two += len(uses) == 2
        x = np.unique(np.r_[0.0, rng.random(12), 1.0, 0.5 * rng.random(3)])
        a, b = rng.random(6), rng.random(6)
        for m in (5, 9):
            got = call(f, x[:-1].copy(), x[1:].copy(), np.int64(m))
            ref = fam.criteria(x, m - 2, None)
            assert got[0].tobytes() == ref[0].tobytes() and got[1].tobytes() == ref[1].tobytes()
            got = call(f, a, b, np.int64(m))
            ref = [np.concatenate(r) for r in zip(*(fam.criteria(np.r_[a[i], b[i]], m - 2, None) for i in range(6)))]
            assert got[0].tobytes() == ref[0].tobytes() and got[1].tobytes() == ref[1].tobytes()
    assert n_rat >= 10 and n_two >= 10


@pytest.mark.parametrize("model,rel_h", [("gmsh__t20_data.step", 0.03), ("occt__screw.step", 1.0)])
def test_compiled_chunks_equal_numpy_iso_step(shared_data, monkeypatch, model, rel_h):
    """The numpy path calls the chunk kernel's own iso step (`_chunk_kernels.chunk_iso_kernel`, one
    implementation): here it takes numpy's (`trims._insert_iso_values_numpy`) instead, so the compiled
    kernel's iso-values are checked against numpy on the shared (several-use) chunks too, bit for bit."""
    from trimsurf.tessellate import trims

    shell = read_shell(shared_data / "cad" / model)
    d = shell.diagonal()
    tol, h = 1e-3 * d, rel_h * d
    chunks, degs = _chunks(shell, tol, h)
    got = discretize_chunks(chunks, tolerance=tol, max_edge=h, degenerate=degs)
    monkeypatch.setattr(trims, "_insert_iso_values", lambda evaluate, uses, s: trims._insert_iso_values_numpy(uses, s))
    ref = [_discretize_chunk_numpy(u, tolerance=tol, max_edge=h, degenerate=g) for u, g in zip(chunks, degs)]
    bad = [i for i, (a, b) in enumerate(zip(got, ref)) if not _same(a, b)]
    assert not bad, f"{len(bad)} of {len(chunks)} chunks differ"
    # shared chunks with grid-line crossings inside (not only their ends on iso-lines)
    assert sum(len(c.uv) > 1 and c.is_iso[1:-1].any() for c in got) >= 5
