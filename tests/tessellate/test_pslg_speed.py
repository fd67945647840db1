"""Session 29 (issue 17): `pslg.crossing_segments`' compiled candidate pairs equal the k-d tree path they replace."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.tessellate import pslg


def _graphs():
    """Random segment sets: free segments (many crossings), grid-line pieces (collinear, touching and
    zero-width boxes, shared ends), repeated and degenerate segments, all points on one vertical line."""
    rng = np.random.default_rng(2929)
    for trial in range(60):
        kind = trial % 4
        if kind == 0:                   # free segments in the unit square
            n = int(rng.integers(2, 300))
            q = rng.random((n, 2))
            seg = rng.integers(0, n, (int(rng.integers(1, 200)), 2))
        elif kind == 1:                 # a grid's nodes and sides, plus trim-like chords across it
            k = int(rng.integers(2, 9))
            g = np.linspace(0.0, 1.0, k)
            q = np.array([(x, y) for x in g for y in g])
            side = [(i * k + j, i * k + j + 1) for i in range(k) for j in range(k - 1)]
            side += [(i * k + j, (i + 1) * k + j) for i in range(k - 1) for j in range(k)]
            chords = rng.integers(0, len(q), (int(rng.integers(1, 20)), 2))
            seg = np.concatenate([np.array(side), chords])
        elif kind == 2:                 # short segments on a coarse lattice: equal coordinates everywhere
            n = int(rng.integers(3, 200))
            q = rng.integers(0, 6, (n, 2)).astype(np.float64) / 5.0
            seg = rng.integers(0, n, (int(rng.integers(2, 150)), 2))
        else:                           # every point on one vertical line (zero-width boxes), or one point
            n = int(rng.integers(2, 50))
            q = np.c_[np.full(n, 0.25), rng.random(n) if trial % 8 == 3 else np.full(n, 0.5)]
            seg = rng.integers(0, n, (int(rng.integers(2, 60)), 2))
        yield q, seg.astype(np.int64)


def _box_pairs_brute(q, seg, strict=False):
    a, b = q[seg[:, 0]], q[seg[:, 1]]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    i, j = np.triu_indices(len(seg), 1)
    lo_c, hi_c = np.maximum(lo[i], lo[j]), np.minimum(hi[i], hi[j])
    ok = np.all(lo_c < hi_c if strict else lo_c <= hi_c, axis=1)
    return set(zip(i[ok].tolist(), j[ok].tolist()))


def test_box_pairs_kernel_finds_every_pair_once():
    """`_box_pairs_kernel` reports exactly the pairs whose closed boxes meet (brute force), each once, i < j;
    the graphs hold pairs whose boxes only touch (a strict test would miss them: checked)."""
    touching = 0
    for q, seg in _graphs():
        got = pslg._box_pairs_kernel(q, seg)
        pairs = list(zip(got[:, 0].tolist(), got[:, 1].tolist()))
        assert len(pairs) == len(set(pairs))
        assert all(i < j for i, j in pairs)
        ref = _box_pairs_brute(q, seg)
        assert set(pairs) == ref
        touching += len(ref - _box_pairs_brute(q, seg, strict=True))
    assert touching > 100


def test_crossing_segments_equal_with_and_without_box_pairs(monkeypatch):
    """`crossing_segments` and `clean_pslg` give the same arrays with the compiled box pairs as with the k-d
    trees (`_BOX_PAIRS = False`, the code they replace) on every graph, and the candidates past the box test
    are the same pairs."""
    n_cross = 0
    for q, seg in _graphs():
        monkeypatch.setattr(pslg, "_BOX_PAIRS", False)
        ref = pslg.crossing_segments(q, seg)
        ref_pairs = pslg._candidate_segment_pairs(q, seg)
        ref_clean = pslg.clean_pslg(q, seg, eps=1e-9) if len(seg) < 80 else None
        monkeypatch.setattr(pslg, "_BOX_PAIRS", True)
        got = pslg.crossing_segments(q, seg)
        assert got.dtype == ref.dtype and np.array_equal(got, ref)
        if ref_clean is not None:
            got_clean = pslg.clean_pslg(q, seg, eps=1e-9)
            assert all(x.dtype == y.dtype and np.array_equal(x, y) for x, y in zip(got_clean, ref_clean))
        n_cross += len(ref)
        p = pslg._candidate_segment_pairs(q, seg)
        assert set(map(tuple, p.tolist())) == set(map(tuple, ref_pairs.tolist())) & _box_pairs_brute(q, seg)
    assert n_cross > 1000


@pytest.mark.parametrize("broken", ["strict", "lost_pairs"])
def test_crossing_segments_comparison_catches_a_broken_kernel(monkeypatch, broken):
    """The comparison above fails for a broken box-pair kernel: boxes met strictly (no pair with an
    axis-parallel segment, whose box has no width) or a pair in ten lost."""
    real = pslg._box_pairs_kernel
    if broken == "strict":
        def bad(q, seg):
            p = real(q, seg)
            keep = _box_pairs_brute(q, seg, strict=True)
            return p[np.array([tuple(r) in keep for r in p.tolist()], dtype=bool)] if len(p) else p
    else:
        def bad(q, seg):
            p = real(q, seg)
            return p[np.arange(len(p)) % 10 != 3]
    monkeypatch.setattr(pslg, "_box_pairs_kernel", bad)
    for q, seg in _graphs():
        monkeypatch.setattr(pslg, "_BOX_PAIRS", False)
        ref = pslg.crossing_segments(q, seg)
        monkeypatch.setattr(pslg, "_BOX_PAIRS", True)
        if not np.array_equal(pslg.crossing_segments(q, seg), ref):
            return
    pytest.fail("a broken box-pair kernel gave the same crossings on every graph")
