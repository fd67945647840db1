"""Triangle's input made safe: no crossing, near-duplicate point or point on a segment (issue 16).

Triangle computes the crossing point of two crossing constraints in floating point; on near-degenerate
input the inserted point misses both lines and the insertion never ends. `clean_pslg` removes every
crossing (by the exact orient2d, the sign Triangle sees), merges points closer than eps and splits
segments at points within eps of them, keeping the constraint set within eps of the input's. Triangle
runs in a child process here, with a time limit, so a regression fails instead of hanging the suite.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from trimsurf.errors import TrimLoopError
from trimsurf.tessellate.grid import SNAP, triangulate_domain
from trimsurf.tessellate.pslg import clean_pslg, crossing_segments

DATA = Path(__file__).parent / "data"
TURBINE = DATA / "turbine_face1_triangle_input.npz"


def _point_segment_distance(p, a, b):
    d = b - a
    t = np.clip(np.einsum("nd,nd->n", p - a, d) / np.maximum(np.einsum("nd,nd->n", d, d), 1e-300), 0, 1)
    return np.linalg.norm(p - a - t[:, None] * d, axis=1)


def _check_clean(v, s, q, seg, rep, eps):
    """The promises of clean_pslg, checked by brute force."""
    kept = np.flatnonzero(rep == np.arange(len(q)))
    assert np.all(rep[rep] == rep)                                  # representatives are kept
    assert np.isin(seg, kept).all()
    assert np.all(seg[:, 0] != seg[:, 1])
    assert len(np.unique(np.sort(seg, axis=1), axis=0)) == len(seg)
    assert len(crossing_segments(q, seg)) == 0
    # no two kept points within eps
    assert len(cKDTree(q[kept]).query_pairs(eps)) == 0
    # no kept point within eps of a segment it is not an end of
    a, b = q[seg[:, 0]], q[seg[:, 1]]
    for k in kept:
        other = (seg[:, 0] != k) & (seg[:, 1] != k)
        assert np.all(_point_segment_distance(np.broadcast_to(q[k], a[other].shape), a[other], b[other]) >= eps)
    # every input segment is covered by the cleaned ones, within a few eps (samples along it)
    t = np.linspace(0, 1, 9)
    pts = (v[s[:, 0], None] * (1 - t)[None, :, None] + v[s[:, 1], None] * t[None, :, None]).reshape(-1, 2)
    dist = np.min([_point_segment_distance(pts, np.broadcast_to(x, pts.shape), np.broadcast_to(y, pts.shape))
                   for x, y in zip(a, b)], axis=0)
    assert dist.max() <= 8 * eps, dist.max()


def _triangle_in_child(cases: dict, timeout: float = 60.0) -> subprocess.CompletedProcess:
    """Run clean_pslg + Triangle on each case in a child process; fails the test on a time-out."""
    import pickle
    import tempfile

    with tempfile.NamedTemporaryFile(suffix=".pkl", delete=False) as f:
        pickle.dump(cases, f)
    code = textwrap.dedent(f"""
        import pickle, numpy as np, triangle as tr
        from trimsurf.tessellate.pslg import clean_pslg
        cases = pickle.load(open({f.name!r}, "rb"))
        for name, (v, s) in cases.items():
            q, seg, rep = clean_pslg(v, s, eps={SNAP!r})
            keep = np.flatnonzero(rep == np.arange(len(q)))
            c = np.full(len(q), -1); c[keep] = np.arange(len(keep))
            r = tr.triangulate({{"vertices": q[keep], "segments": c[seg]}}, "pQ")
            assert len(r["vertices"]) == len(keep), name       # no point inserted: nothing crossed
            print(name, len(r.get("triangles", [])))
        """)
    try:
        return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout,
                              check=True)
    except subprocess.TimeoutExpired:
        pytest.fail(f"Triangle did not finish within {timeout} s on the cleaned input")
    finally:
        Path(f.name).unlink()


def _nasty_cases(seed: int = 16) -> dict:
    """Near-degenerate graphs of the kinds that make Triangle spin."""
    rng = np.random.default_rng(seed)
    cases = {}
    d = np.load(TURBINE)
    cases["turbine"] = (d["vertices"], d["segments"].astype(np.int64))
    # the turbine's input with its points jittered by a few ulps
    v = d["vertices"] + rng.normal(0, 1e-15, d["vertices"].shape)
    cases["turbine jittered"] = (v, d["segments"].astype(np.int64))
    # a fan of segments through nearly one point (ends off by 1e-16..1e-12)
    n = 40
    ang = rng.uniform(0, 2 * np.pi, n)
    ends = np.column_stack([np.cos(ang), np.sin(ang)])
    centre = 0.5 + rng.normal(0, 1e-13, (n, 2))
    v = np.concatenate([centre, 0.5 + 0.4 * ends])
    cases["fan"] = (v, np.column_stack([np.arange(n), n + np.arange(n)]))
    # crossings at tiny angles
    m = 30
    a = rng.uniform(0, 1, (m, 2))
    dirn = rng.normal(size=(m, 2))
    dirn /= np.linalg.norm(dirn, axis=1)[:, None]
    tilt = rng.choice([1e-15, 1e-12, 1e-9, 1e-6], m)
    rot = np.column_stack([np.cos(tilt), np.sin(tilt), -np.sin(tilt), np.cos(tilt)]).reshape(m, 2, 2)
    d2 = np.einsum("mij,mj->mi", rot, dirn)
    v = np.concatenate([a - 0.3 * dirn, a + 0.3 * dirn, a - 0.3 * d2 + 1e-14, a + 0.3 * d2])
    s = np.concatenate([np.column_stack([np.arange(m), m + np.arange(m)]),
                        np.column_stack([2 * m + np.arange(m), 3 * m + np.arange(m)])])
    cases["tiny angles"] = (v, s)
    # overlapping nearly collinear pieces of one line, and random segments across them
    x = np.sort(rng.uniform(0, 1, 60))
    v = np.column_stack([x, 0.5 + rng.normal(0, 1e-14, 60)])
    s = np.column_stack([np.arange(0, 58, 2), np.arange(3, 61, 2).clip(max=59)])
    w = rng.uniform(0, 1, (40, 2))
    v = np.concatenate([v, w])
    s = np.concatenate([s, 60 + np.arange(40).reshape(20, 2)])
    cases["collinear overlaps"] = (v, s)
    return cases


@pytest.mark.parametrize("name", list(_nasty_cases()))
def test_clean_pslg_promises(name):
    v, s = _nasty_cases()[name]
    q, seg, rep = clean_pslg(v, s, eps=SNAP)
    _check_clean(v, s, q, seg, rep, SNAP)


def test_turbine_face_input_had_the_defect():
    """The saved input of the turbine's face 1 crosses itself at two trim points 7e-16 apart (what
    Triangle spun on for > 15 min); after cleaning one point is left there and nothing crosses."""
    d = np.load(TURBINE)
    v, s = d["vertices"], d["segments"].astype(np.int64)
    assert len(crossing_segments(v, s)) == 2
    near = cKDTree(v).query_pairs(1e-12, output_type="ndarray")
    assert len(near) == 1
    q, seg, rep = clean_pslg(v, s, eps=SNAP)
    assert np.count_nonzero(rep != np.arange(len(q))) == 1 and len(q) == len(v)


def test_triangle_finishes_on_every_cleaned_case():
    out = _triangle_in_child(_nasty_cases())
    assert len(out.stdout.splitlines()) == len(_nasty_cases())


def test_triangulate_domain_with_touching_loops_finishes():
    """A hole touching the outer loop at a point given twice, 1e-15 apart (the turbine's face 1 in
    small): the crossed cells' triangulation covers the region exactly (area), nothing duplicated."""
    us = np.linspace(0, 1, 5)
    vs = np.linspace(0, 1, 5)
    outer = np.array([[0.1, 0.1], [0.9, 0.1], [0.9, 0.9], [0.5 + 1e-15, 0.9], [0.1, 0.9]])
    hole = np.array([[0.5, 0.9], [0.7, 0.5], [0.3, 0.5]])           # clockwise, touching at (0.5, 0.9)
    code = textwrap.dedent("""
        import numpy as np
        from trimsurf.tessellate.grid import triangulate_domain
        us = vs = np.linspace(0, 1, 5)
        outer = np.array([[0.1, 0.1], [0.9, 0.1], [0.9, 0.9], [0.5 + 1e-15, 0.9], [0.1, 0.9]])
        hole = np.array([[0.5, 0.9], [0.7, 0.5], [0.3, 0.5]])
        triangulate_domain(us, vs, [outer, hole])
        """)
    subprocess.run([sys.executable, "-c", code], timeout=60, check=True)
    dt = triangulate_domain(us, vs, [outer, hole])
    p = dt.uv[dt.triangles]
    area = 0.5 * ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                  - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
    assert np.all(area > 0)
    assert abs(area.sum() - (0.64 - 0.08)) < 1e-12                  # square minus the triangle hole


def test_clean_pslg_gives_up_with_an_error_not_a_hang(monkeypatch):
    """If crossings survived every round the face fails with TrimLoopError (never an endless loop)."""
    import trimsurf.tessellate.pslg as pslg

    monkeypatch.setattr(pslg, "_ROUNDS", 0)
    v = np.array([[0, 0], [1, 1], [0, 1], [1, 0]], float)
    with pytest.raises(TrimLoopError, match="still cross"):
        clean_pslg(v, np.array([[0, 1], [2, 3]]), eps=SNAP)


def _grid_with_trim(rng, n_cells=6, n_trim=40, jitter=0.0):
    """Cell sides of an n x n grid plus a closed trim polyline (a wobbly circle), as clean_pslg sees them."""
    g = np.linspace(0.0, 1.0, n_cells + 1)
    gu, gv = np.meshgrid(g, g, indexing="ij")
    nodes = np.column_stack([gu.ravel(), gv.ravel()])
    idx = np.arange(len(nodes)).reshape(n_cells + 1, n_cells + 1)
    sides = np.r_[np.column_stack([idx[:-1].ravel(), idx[1:].ravel()]),
                  np.column_stack([idx[:, :-1].ravel(), idx[:, 1:].ravel()])]
    a = np.sort(rng.uniform(0, 2 * np.pi, n_trim))
    r = 0.3 + 0.1 * rng.uniform(size=n_trim)
    trim = np.column_stack([0.5 + r * np.cos(a), 0.5 + r * np.sin(a)]) + jitter * rng.standard_normal((n_trim, 2))
    v = np.concatenate([nodes, trim])
    k = len(nodes) + np.arange(n_trim)
    return v, np.r_[sides, np.column_stack([k, np.roll(k, -1)])]


@pytest.mark.parametrize("seed", range(12))
def test_fast_path_is_the_full_rounds(seed, monkeypatch):
    """The compiled check that skips the rounds (`_is_clean`) never skips a graph the rounds would change:
    on grids with trims that cross their sides, near-duplicate points and points on segments, the output
    with the check is the output of the rounds alone, array for array."""
    import trimsurf.tessellate.pslg as pslg

    rng = np.random.default_rng(seed)
    v, s = _grid_with_trim(rng, jitter=0.05 if seed % 3 == 0 else 0.0)
    if seed % 3 == 1:           # a vertex within eps of another, and one within eps of a segment
        v = np.r_[v, [v[3] + 0.3e-10, 0.5 * (v[0] + v[1]) + [0.0, 0.4e-10]]]
        s = np.r_[s, [[len(v) - 2, 5], [len(v) - 1, 9]]]
    if seed % 3 == 2:           # the trim cut into the grid: sides split at the trim's points (clean)
        v, s = v, s[: (len(s) * 2) // 3]
    fast = clean_pslg(v, s, eps=1e-10)
    monkeypatch.setattr(pslg, "_is_clean", lambda *a: False)
    full = clean_pslg(v, s, eps=1e-10)
    for x, y in zip(fast, full):
        assert np.array_equal(x, y)


def test_fast_path_sees_what_the_rounds_change():
    """`_is_clean` says False for each kind of defect the rounds repair, True for a clean graph."""
    from trimsurf.tessellate.pslg import _is_clean

    v = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    sq = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
    assert _is_clean(v, sq, 1e-10)
    assert not _is_clean(v, np.r_[sq, [[0, 2], [1, 3]]], 1e-10)                          # a crossing
    assert not _is_clean(np.r_[v, [[0.5, 1e-11]]], sq, 1e-10)                            # on a segment
    assert not _is_clean(np.r_[v, [[1 + 1e-11, 1]]], sq, 1e-10)                          # a near duplicate
    # a crossing at a tiny angle whose float signs are uncertain
    w = np.array([[0, 0], [1, 1e-17], [0, 1e-17], [1, 0]], float)
    assert not _is_clean(w * 1e6, np.array([[0, 1], [2, 3]]), 1e-30)


def test_crossed_cells_kernel_is_cohen_sutherland():
    """The compiled crossed-cell marking of `triangulate_domain` marks exactly the cells of
    `cohen_sutherland_cells`: random segments on a non-uniform grid, segments along grid lines,
    through grid nodes, degenerate (a point) and outside the grid."""
    from trimsurf.tessellate.grid import _crossed_cells, cohen_sutherland_cells

    rng = np.random.default_rng(3)
    us = np.r_[0.0, np.sort(rng.uniform(0, 1, 9)), 1.0]
    vs = np.r_[0.0, np.sort(rng.uniform(0, 2, 6)), 2.0]
    p0 = np.column_stack([rng.uniform(-0.1, 1.1, 400), rng.uniform(-0.1, 2.1, 400)])
    p1 = p0 + 0.3 * rng.standard_normal((400, 2))
    gu, gv = us[rng.integers(0, len(us), 60)], vs[rng.integers(0, len(vs), 60)]
    p0 = np.r_[p0, np.column_stack([gu, gv]), np.column_stack([gu, vs[0] + 0 * gv])]
    p1 = np.r_[p1, np.column_stack([gu, vs[rng.integers(0, len(vs), 60)]]), np.column_stack([gu, gv])]
    p1[-5:] = p0[-5:]
    hits = cohen_sutherland_cells(p0, p1, us, vs)
    want = np.zeros((len(us) - 1, len(vs) - 1), bool)
    want[hits[:, 1], hits[:, 2]] = True
    got = _crossed_cells(p0, p1, us, vs)
    assert want.sum() > 20 and np.array_equal(got, want)
    for k in range(len(p0)):        # segment by segment too (a cell marked by one segment only)
        h = cohen_sutherland_cells(p0[[k]], p1[[k]], us, vs)
        w = np.zeros_like(want)
        w[h[:, 1], h[:, 2]] = True
        assert np.array_equal(_crossed_cells(p0[[k]], p1[[k]], us, vs), w)


def test_grid_helpers_equal_numpy():
    """`_first_equal` is the representative np.unique(axis=0) gives (lowest index of equal rows,
    -0.0 equal to 0.0), `_is_in` is np.isin on increasing values."""
    from trimsurf.tessellate.grid import _first_equal, _is_in

    rng = np.random.default_rng(5)
    p = rng.integers(0, 4, (300, 2)).astype(float) * 0.25
    p[rng.integers(0, 300, 20)] *= -1.0          # -0.0 rows among 0.0 ones
    _, inv = np.unique(p, axis=0, return_inverse=True)
    inv = inv.ravel()
    rep = np.full(inv.max() + 1, len(p))
    np.minimum.at(rep, inv, np.arange(len(p)))
    assert np.array_equal(_first_equal(p), rep[inv])
    vals = np.unique(rng.integers(0, 10, 6).astype(float))
    x = np.r_[rng.integers(-2, 12, 100).astype(float), np.nan, -0.0, 0.5]
    assert np.array_equal(_is_in(x, vals), np.isin(x, vals))


def test_unique_segments_is_numpy_unique():
    from trimsurf.tessellate.pslg import _unique_segments

    rng = np.random.default_rng(9)
    seg = rng.integers(0, 30, (500, 2))
    got = _unique_segments(seg)
    assert got.dtype == np.int64 and np.array_equal(got, np.unique(np.sort(seg, axis=1), axis=0))
    assert _unique_segments(seg[:0]).shape == (0, 2)


def test_side_segments_kernel_equals_numpy():
    """The compiled cell sides of `triangulate_domain` are the numpy reference's (as a set): grid nodes,
    points on grid lines (repeated ones too), points off them, some cells crossed."""
    from trimsurf.tessellate.grid import _side_segments, _side_segments_numpy

    rng = np.random.default_rng(11)
    for _ in range(20):
        us = np.r_[0.0, np.sort(rng.uniform(0, 1, 5)), 1.0]
        vs = np.r_[0.0, np.sort(rng.uniform(0, 1, 4)), 1.0]
        gu, gv = np.meshgrid(us, vs, indexing="ij")
        nodes = np.column_stack([gu.ravel(), gv.ravel()])
        on_u = np.column_stack([us[rng.integers(0, len(us), 15)], rng.uniform(0, 1, 15)])
        on_v = np.column_stack([rng.uniform(0, 1, 15), vs[rng.integers(0, len(vs), 15)]])
        uv = np.concatenate([on_u, rng.uniform(0, 1, (10, 2)), nodes, on_v, on_v[:3]])
        crossed = rng.uniform(size=(len(us) - 1, len(vs) - 1)) < 0.4
        got = _side_segments(uv, us, vs, crossed)
        want = _side_segments_numpy(uv, us, vs, crossed)
        assert len(want) > 5
        assert sorted(map(tuple, got.tolist())) == sorted(map(tuple, want.tolist()))
