"""The compiled per-face triangulation (issue 17) against its numpy reference, value for value.

`triangulate_domain` runs two compiled passes around Triangle (`_domain_prepare_kernel`,
`_domain_finish_kernel`); `_triangulate_domain_numpy` is the reference and the fallback. Every field of
the result must be the same arrays (values and dtypes), on random trims made to hit the special cases
(trim points on grid lines and nodes, repeated points, holes, extra points, both tie directions), and on
the faces of a real model.
"""

from __future__ import annotations

import numpy as np
import pytest

import trimsurf.tessellate.grid as grid_mod
from trimsurf.tessellate.grid import _triangulate_domain_numpy, triangulate_domain

FIELDS = ("uv", "triangles", "grid_node", "quads")


def _same(a, b) -> bool:
    return (all(np.array_equal(getattr(a, f), getattr(b, f)) and getattr(a, f).dtype == getattr(b, f).dtype
                for f in FIELDS)
            and (a.n_trim, a.n_crossed_cells, a.n_cells) == (b.n_trim, b.n_crossed_cells, b.n_cells))


def _star(rng, c, r, n, us, vs):
    t = np.sort(rng.uniform(0, 2 * np.pi, n))
    rad = r * rng.uniform(0.6, 1.0, n)
    p = np.column_stack([c[0] + rad * np.cos(t), c[1] + rad * np.sin(t)])
    # some points exactly on grid lines, some on grid nodes, one repeated
    k = rng.integers(0, n, 6)
    p[k[:2], 0] = us[np.abs(us[:, None] - p[k[:2], 0]).argmin(axis=0)]
    p[k[2:4], 1] = vs[np.abs(vs[:, None] - p[k[2:4], 1]).argmin(axis=0)]
    p[k[4], 0] = us[np.abs(us - p[k[4], 0]).argmin()]
    p[k[4], 1] = vs[np.abs(vs - p[k[4], 1]).argmin()]
    return p


def _insert_iso(p, us, vs):
    """The polygon with a point wherever a segment crosses a grid line (the coordinate set exactly), as
    the trims `triangulate_domain` gets."""
    out = []
    for a, b in zip(p, np.roll(p, -1, axis=0)):
        ts, pts = [0.0], [a]
        for axis, vals in ((0, us), (1, vs)):
            lo, hi = sorted((a[axis], b[axis]))
            for x in vals[(vals > lo) & (vals < hi)]:
                t = (x - a[axis]) / (b[axis] - a[axis])
                q = a + t * (b - a)
                q[axis] = x
                ts.append(t)
                pts.append(q)
        out.extend(pts[k] for k in np.argsort(ts, kind="stable"))
    return np.array(out)


def _simple(polys) -> bool:
    from trimsurf.tessellate.pslg import crossing_segments

    pts = np.concatenate(polys)
    a = np.arange(len(pts))
    lens = np.array([len(p) for p in polys])
    b = a + 1
    b[np.cumsum(lens) - 1] = np.cumsum(lens) - lens
    return not len(crossing_segments(pts, np.column_stack([a, b])))


def _case(rng):
    while True:
        out = _case1(rng)
        if _simple(out[2]):
            return out


def _case1(rng):
    us = np.r_[0.0, np.sort(rng.uniform(0, 1, rng.integers(2, 9))), 1.0]
    vs = np.r_[0.0, np.sort(rng.uniform(0, 2, rng.integers(2, 9))), 2.0]
    outer = _insert_iso(_star(rng, (0.5, 1.0), 0.45, int(rng.integers(8, 40)), us, vs), us, vs)
    polys = [outer]
    if rng.uniform() < 0.5:
        polys.append(_insert_iso(_star(rng, (0.5, 1.0), 0.12, int(rng.integers(4, 12)), us, vs)[::-1], us, vs))
    if rng.uniform() < 0.3:     # a repeated point
        o = polys[0]
        polys[0] = np.insert(o, 3, o[3], axis=0)
    extra = None
    if rng.uniform() < 0.5:
        extra = np.column_stack([rng.uniform(0.1, 0.9, 6), rng.uniform(0.2, 1.8, 6)])
        extra[0, 0] = us[1]                          # on a grid line: ignored
        extra = np.r_[extra, extra[:2]]              # repeated
    cell_main = rng.uniform(size=(len(us) - 1) * (len(vs) - 1)) < 0.5
    tie = [None, True, False][int(rng.integers(0, 3))]
    return us, vs, polys, extra, cell_main, tie


def test_compiled_triangulation_equals_numpy(monkeypatch):
    rng = np.random.default_rng(17)
    calls = {"numpy": 0}
    real = grid_mod._triangulate_domain_numpy

    def counting(*a, **k):
        calls["numpy"] += 1
        return real(*a, **k)

    monkeypatch.setattr(grid_mod, "_triangulate_domain_numpy", counting)
    n_cases, n_extra, n_cdt_new = 150, 0, 0
    for _ in range(n_cases):
        us, vs, polys, extra, cell_main, tie = _case(rng)
        nv1 = len(vs) - 1
        got = triangulate_domain(us, vs, polys, cell_main=cell_main, extra=extra, tie_main=tie)
        want = real(us, vs, polys, split=lambda ki, kj: cell_main[ki * nv1 + kj], extra=extra, tie_main=tie)
        assert _same(got, want)
        # the callback form gives the same
        got2 = triangulate_domain(us, vs, polys, split=lambda ki, kj: cell_main[ki * nv1 + kj], extra=extra,
                                  tie_main=tie)
        assert _same(got2, want)
        n_extra += extra is not None
        n_cdt_new += int((got.grid_node[got.n_trim:] < 0).sum())
    assert n_extra > 30 and n_cdt_new > 30
    # the compiled path answered most (the numpy one only for graphs needing clean_pslg's rounds: here the
    # repeated points and points within 2e-10 of a cell side), both kinds are compared
    assert 0 < calls["numpy"] < 0.5 * 2 * n_cases


def test_compiled_triangulation_fallbacks():
    """Equal grid values, a metric, and crossing trims (clean_pslg's rounds) go the numpy way, same result."""
    us = np.array([0.0, 0.5, 0.5, 1.0])
    vs = np.array([0.0, 0.5, 1.0])
    sq = np.array([[0.1, 0.1], [0.9, 0.1], [0.9, 0.9], [0.1, 0.9]])
    assert _same(triangulate_domain(us, vs, [sq]), _triangulate_domain_numpy(us, vs, [sq]))
    us = np.array([0.0, 0.5, 1.0])
    assert _same(triangulate_domain(us, vs, [sq], metric=np.array([1.0, 3.0])),
                 _triangulate_domain_numpy(us, vs, [sq], metric=np.array([1.0, 3.0])))
    bow = np.array([[0.1, 0.1], [0.9, 0.9], [0.9, 0.1], [0.1, 0.9]])       # crosses itself
    assert _same(triangulate_domain(us, vs, [bow], tie_main=True), _triangulate_domain_numpy(us, vs, [bow], tie_main=True))


def test_cell_main_length_checked():
    us = np.array([0.0, 0.5, 1.0])
    sq = np.array([[0.1, 0.1], [0.9, 0.1], [0.9, 0.9], [0.1, 0.9]])
    with pytest.raises(ValueError, match="cell_main"):
        triangulate_domain(us, us, [sq], cell_main=np.ones(3, dtype=bool))


def test_argsort2_is_lexsort():
    from trimsurf.tessellate.grid import _domain_keep_kernel  # noqa: F401  (compiled module loads)

    rng = np.random.default_rng(2)
    a = rng.integers(0, 5, 400).astype(float)
    b = rng.integers(0, 5, 400).astype(float) * 0.5
    b[rng.integers(0, 400, 40)] *= -1.0      # -0.0 among 0.0
    from numba import njit

    @njit
    def call(a, b):
        return grid_mod._argsort2(a, b)

    assert np.array_equal(call(a, b), np.lexsort((b, a)))


@pytest.mark.parametrize("mode", ["tol", "paper"])
def test_compiled_triangulation_on_real_faces(shared_data, monkeypatch, mode):
    """Every triangulation of the screw's faces (the extra-point rounds too) equals the numpy reference."""
    import trimsurf.tessellate.face as face_mod
    from trimsurf.io import read_shell
    from trimsurf.tessellate import tessellate_shell

    shell = read_shell(shared_data / "cad" / "occt__screw.step")
    d = shell.diagonal()
    real = face_mod.triangulate_domain
    n = [0, 0]

    def check(us, vs, polys, *, cell_main=None, extra=None, tie_main=None, **k):
        out = real(us, vs, polys, cell_main=cell_main, extra=extra, tie_main=tie_main, **k)
        nv1 = len(vs) - 1
        ref = numpy_path(us, vs, polys, split=lambda ki, kj: cell_main[ki * nv1 + kj], extra=extra,
                                        tie_main=tie_main)
        n[0] += 1
        n[1] += _same(out, ref)
        return out

    fallback = [0]
    numpy_path = grid_mod._triangulate_domain_numpy

    def counting(*a, **k):
        fallback[0] += 1
        return numpy_path(*a, **k)

    monkeypatch.setattr(face_mod, "triangulate_domain", check)
    monkeypatch.setattr(grid_mod, "_triangulate_domain_numpy", counting)
    tessellate_shell(shell, tolerance=1e-3 * d, max_edge=d if mode == "tol" else 3e-2 * d, measure=False)
    assert n[0] >= 10 and n[1] == n[0]
    assert fallback[0] == 0         # every face of the screw took the compiled path


def _sliver_calls(shell, mode, raw=False):
    """The arguments of every `collapse_boundary_slivers` call of a tessellation (made by
    `collapse_face_slivers`: its triangles oriented, its trim vertices as a mask); raw: the arguments of
    `collapse_face_slivers` as they are."""
    import trimsurf.tessellate.face as face_mod
    from trimsurf.tessellate import tessellate_shell

    calls = []
    real = face_mod.collapse_face_slivers

    def rec(*a, **k):
        calls.append((a, k))
        return real(*a, **k)

    d = shell.diagonal()
    face_mod.collapse_face_slivers = rec
    # the aspect limit on developable faces too (the rule before session 29): the tol-only meshes these
    # comparisons were written for, with more cells cut along cylinders and so more sliver candidates
    limit = face_mod.LIMIT_DEVELOPABLE
    face_mod.LIMIT_DEVELOPABLE = True
    try:
        tessellate_shell(shell, tolerance=1e-3 * d, max_edge=d if mode == "tol" else 3e-2 * d, measure=False)
    finally:
        face_mod.collapse_face_slivers = real
        face_mod.LIMIT_DEVELOPABLE = limit
    if raw:
        return calls
    out = []
    for (s, uv, xyz, tris, reverse, grid_node, n_trim), k in calls:
        fixed = (grid_node < 0) | (np.arange(len(uv)) < n_trim)
        out.append(((s, uv, xyz, np.ascontiguousarray(tris[:, ::-1] if reverse else tris), fixed), k))
    return out


def test_face_slivers_equal_general(shared_data):
    """`collapse_face_slivers` (the copy, the trim mask and the first candidates in one compiled pass, kept
    None for the identity) equals `collapse_boundary_slivers` on the oriented triangles and the trim mask,
    on every face of t20, the screw and featuretype (both senses), at the default angle and at larger
    ones with a looser tolerance (collapses)."""
    from trimsurf.io import read_shell
    from trimsurf.tessellate.slivers import collapse_boundary_slivers, collapse_face_slivers

    n = {"cmp": 0, "identity": 0, "rounds": 0, "collapsed": 0, "reversed": 0}
    for name in ("gmsh__t20_data.step", "occt__screw.step", "trimesh__featuretype.STEP"):
        shell = read_shell(shared_data / "cad" / name)
        for (s, uv, xyz, tris, reverse, grid_node, n_trim), k in _sliver_calls(shell, "tol", raw=True):
            fixed = (grid_node < 0) | (np.arange(len(uv)) < n_trim)
            oriented = np.ascontiguousarray(tris[:, ::-1] if reverse else tris)
            for lim, scale in ((12.0, 1.0), (30.0, 100.0), (55.0, 100.0)):
                kw = dict(k, min_angle_deg=lim, tolerance=scale * k["tolerance"], max_edge=np.inf)
                t1, kept1 = collapse_face_slivers(s, uv, xyz, tris, reverse, grid_node, n_trim, **kw)
                t2, kept2 = collapse_boundary_slivers(s, uv, xyz, oriented, fixed, **kw)
                assert t1.dtype == t2.dtype == np.int64 and t1.flags.c_contiguous
                assert np.array_equal(t1, t2)
                if kept1 is None:
                    assert np.array_equal(kept2, np.arange(len(tris))) and np.array_equal(t1, oriented)
                    n["identity"] += 1
                else:
                    assert np.array_equal(kept1, kept2)
                    n["rounds"] += 1
                n["cmp"] += 1
                n["collapsed"] += len(t2) < len(tris)
                n["reversed"] += bool(reverse)
    assert n["cmp"] > 200 and n["identity"] > 50 and n["rounds"] > 20 and n["collapsed"] > 0 and n["reversed"] > 20, n


def test_compiled_slivers_equal_numpy(shared_data):
    """`collapse_boundary_slivers` (compiled candidates and picks, the arc cosine only where a cosine
    bound cannot settle "thin or not") equals its numpy reference on every face of t20 and the screw, at
    the default angle and at larger ones (many collapses), and with the threshold set to a triangle's own
    smallest angle and the next float above it (the exact boundary)."""
    from trimsurf.io import read_shell
    from trimsurf.tessellate.slivers import (_collapse_boundary_slivers_numpy, _min_angles_deg,
                                             collapse_boundary_slivers)

    n_cmp = n_collapsed = n_edge = 0
    for name in ("gmsh__t20_data.step", "occt__screw.step"):
        shell = read_shell(shared_data / "cad" / name)
        for mode in ("tol", "paper"):
            for (s, uv, xyz, tris, fixed), k in _sliver_calls(shell, mode):
                tt = fixed[tris]
                mixed = tt.any(axis=1) & ~tt.all(axis=1)
                ang = _min_angles_deg(xyz[tris[mixed]])
                limits = [12.0, 30.0, 55.0]
                if len(ang):
                    a0 = float(np.sort(ang)[len(ang) // 3])
                    limits += [a0, float(np.nextafter(a0, np.inf))]
                for lim in limits:
                    for tol in (k["tolerance"], 100 * k["tolerance"]):
                        kw = dict(k, tolerance=tol, min_angle_deg=lim, max_edge=np.inf)
                        t1, kept1 = collapse_boundary_slivers(s, uv, xyz, tris, fixed, **kw)
                        t2, kept2 = _collapse_boundary_slivers_numpy(s, uv, xyz, tris, fixed, **kw)
                        assert np.array_equal(t1, t2) and np.array_equal(kept1, kept2)
                        n_cmp += 1
                        n_collapsed += len(t2) < len(tris)
                        n_edge += lim not in (12.0, 30.0, 55.0) and len(t2) < len(tris)
    assert n_cmp > 300 and n_collapsed > 30 and n_edge > 10, (n_cmp, n_collapsed, n_edge)


def _face_calls(shell, mode):
    """The arguments of every `mesh_face_from_chunks` call of a tessellation."""
    import trimsurf.tessellate.shell as shell_mod
    from trimsurf.tessellate import tessellate_shell

    calls = []
    real = shell_mod.mesh_face_from_chunks

    def rec(*a, **k):
        calls.append((a, k))
        return real(*a, **k)

    d = shell.diagonal()
    shell_mod.mesh_face_from_chunks = rec
    try:
        tessellate_shell(shell, tolerance=1e-3 * d, max_edge=d if mode == "tol" else 3e-2 * d, measure=False)
    finally:
        shell_mod.mesh_face_from_chunks = real
    return calls


def _reference_paths(monkeypatch):
    """Every shortcut of `mesh_face_from_chunks` replaced by the general path it stands for."""
    import trimsurf.tessellate.face as face_mod
    from trimsurf.tessellate.slivers import _collapse_boundary_slivers_numpy

    def numpy_triangulation(us, vs, polys, *, cell_main=None, split=None, packed=None, **k):
        polys = [np.array(p) for p in polys]        # the packed polygons' views copied
        nv1 = len(vs) - 1
        if split is None and cell_main is not None:
            def split(ki, kj):
                return cell_main[ki * nv1 + kj]
        return _triangulate_domain_numpy(us, vs, polys, split=split, **k)

    real_loop = face_mod.trim_loop_kernel

    def loop_always_checked(*a):        # remove_polygon_loops decides every loop
        p, x, v, keep, status = real_loop(*a)
        return p, x, v, keep, 2 if status == 1 else status

    monkeypatch.setattr(face_mod, "triangulate_domain", numpy_triangulation)
    def numpy_slivers(s, uv, xyz, tris, reverse, grid_node, n_trim, **k):
        fixed = (grid_node < 0) | (np.arange(len(uv)) < n_trim)
        return _collapse_boundary_slivers_numpy(s, uv, xyz, np.ascontiguousarray(tris[:, ::-1] if reverse else tris),
                                                fixed, **k)

    monkeypatch.setattr(face_mod, "collapse_face_slivers", numpy_slivers)
    monkeypatch.setattr(face_mod, "trim_loop_kernel", loop_always_checked)
    monkeypatch.setattr(face_mod._TriangleDeviations, "start_bound",
                        lambda self, uv, xyz, t: np.full(len(t), np.inf))
    monkeypatch.setattr(face_mod, "_lift_points", face_mod._lift_points_numpy)
    monkeypatch.setattr(face_mod, "_face_loops", face_mod._face_loops_numpy)
    monkeypatch.setattr(face_mod, "_cell_main", face_mod._split_from_fits)


def test_face_meshes_equal_reference_paths(shared_data, monkeypatch):
    """`mesh_face_from_chunks` with its shortcuts (compiled triangulation and sliver rounds, certainly
    simple trim loops, deviations only of the triangles whose start bound exceeds the tolerance) gives
    every face's arrays, and `tri_dev` when read, equal to the general paths, on t20 and the screw in both
    settings and the wing's faces (two of which need extra-point rounds); the start bound is never below
    the deviation."""
    import trimsurf.tessellate.face as face_mod
    from trimsurf.io import read_shell

    cases = []
    for name, modes in (("gmsh__t20_data.step", ("tol", "paper")), ("occt__screw.step", ("tol", "paper")),
                        ("gmsh__wing_fuselage.step", ("paper",))):       # the last with extra-point rounds
        shell = read_shell(shared_data / "cad" / name)
        for mode in modes:
            cases += _face_calls(shell, mode)
    n_extra = [0]
    real_tri = face_mod.triangulate_domain

    def counting_tri(*a, extra=None, **k):
        n_extra[0] += extra is not None
        return real_tri(*a, extra=extra, **k)

    with monkeypatch.context() as mp:
        mp.setattr(face_mod, "triangulate_domain", counting_tri)
        fast = [face_mod.mesh_face_from_chunks(*a, **k) for a, k in cases]
    n_curved = 0
    for fm in fast:
        if fm._dev_task is not None:
            s, known, uv, xyz, tris = fm._dev_task[:5]
            bound = known.start_bound(uv, xyz, tris)
            dev = face_mod.triangle_deviation(s, uv, xyz, tris)
            assert np.all(bound >= dev)
            n_curved += 1
    with monkeypatch.context() as mp:
        _reference_paths(mp)
        ref = [face_mod.mesh_face_from_chunks(*a, **k) for a, k in cases]
    for a, b in zip(fast, ref):
        for f in ("uv", "xyz", "triangles", "vid", "quads", "tri_dev"):
            assert np.array_equal(getattr(a, f), getattr(b, f)), f
        assert (a.n_crossed_cells, a.removed_loop_points) == (b.n_crossed_cells, b.removed_loop_points)
    assert len(cases) > 50 and n_curved > 20 and n_extra[0] > 0, (len(cases), n_curved, n_extra)


def test_min_angles_compiled_cosines_equal_numpy():
    """`_min_angles_deg` (compiled cosines, numpy's arc cosine) equals the numpy one bit for bit: random,
    thin, degenerate (a repeated corner, all three equal) and collinear triangles at three scales, and
    NaN/inf corners."""
    from trimsurf.tessellate.slivers import _min_angles_deg, _min_angles_deg_numpy

    rng = np.random.default_rng(8)
    for scale in (1e-6, 1.0, 1e3):
        P = rng.normal(size=(30000, 3, 3)) * scale
        P[::7, 1] = P[::7, 0] + 1e-9 * scale * rng.normal(size=(len(P[::7]), 3))     # thin
        P[::11, 2] = P[::11, 0]                                                     # a repeated corner
        P[::13] = P[::13, :1]                                                       # a point
        P[::17, 2] = 0.5 * (P[::17, 0] + P[::17, 1])                                # collinear
        P[5, 0, 0], P[6, 1, 2] = np.nan, np.inf
        got, want = _min_angles_deg(P), _min_angles_deg_numpy(P)
        assert np.array_equal(got, want, equal_nan=True)
        assert (want == 0).sum() > 1000 and (want < 1e-3).sum() > 3000


def test_lift_points_equal_numpy(shared_data, monkeypatch):
    """`_lift_points` (one compiled pass: surface points, trim offsets, the triangles whose start bound
    exceeds the tolerance) equals `_lift_points_numpy` (`evaluate`, `start_bound`) bit for bit in every
    call of t20's and the screw's tessellations (planar and curved faces), and for the curved ones also at
    tolerances near the start bounds (the boundary: a bound equal to the tolerance is not "maybe") and with
    trim points off the surface; (u, v) that are not finite take the numpy path (which raises)."""
    import trimsurf.tessellate.face as face_mod
    from trimsurf.errors import GeometryError
    from trimsurf.io import read_shell
    from trimsurf.tessellate import tessellate_shell

    calls = []
    real = face_mod._lift_points

    def rec(*a):
        calls.append(a)
        return real(*a)

    monkeypatch.setattr(face_mod, "_lift_points", rec)
    for name in ("gmsh__t20_data.step", "occt__screw.step"):
        shell = read_shell(shared_data / "cad" / name)
        d = shell.diagonal()
        for mode in ("tol", "paper"):
            tessellate_shell(shell, tolerance=1e-3 * d, max_edge=d if mode == "tol" else 3e-2 * d, measure=False)
    n_cmp = n_maybe = n_flat = 0
    rng = np.random.default_rng(3)
    for s, uv, trim_xyz, *rest in calls:
        variants = [(trim_xyz, *rest)]
        if rest and rest[0] is not None:
            tris, tol, known = rest
            moved = trim_xyz + rng.normal(scale=tol, size=trim_xyz.shape)
            sb = known.start_bound(uv, real(s, uv, trim_xyz)[0], tris)
            variants += [(moved, tris, tol, known), (trim_xyz, tris, 1e-3 * tol, known)]
            variants += [(trim_xyz, tris, float(np.median(sb)), known)] if len(sb) else []
        else:
            n_flat += 1
        for v in variants:
            a, b = real(s, uv, *v), face_mod._lift_points_numpy(s, uv, *v)
            for x, y in zip(a, b):
                assert (x is None and y is None) or np.array_equal(x, y)
            n_cmp += 1
            n_maybe += a[2] is not None and 0 < len(a[2]) < len(v[1])
    assert n_cmp > 100 and n_maybe > 20 and n_flat > 10, (n_cmp, n_maybe, n_flat)
    s, uv, trim_xyz, tris, tol, known = next(c for c in calls if len(c) > 3 and c[3] is not None)
    uv = uv.copy()
    uv[-1, 0] = np.nan
    with pytest.raises(GeometryError):
        real(s, uv, trim_xyz, tris, tol, known)


def test_face_loops_and_cell_splits_equal_numpy(shared_data, monkeypatch):
    """`_face_loops` (`face_loops_kernel`: the chunks of every loop assembled and checked in one pass) and
    `_cell_main` (`cell_main_kernel`) equal `_face_loops_numpy` and `_split_from_fits` bit for bit on every
    face of featuretype and the screw in both settings and modes (conforming: vertex ids; loose: none),
    also with the chunks' ids partly missing and the cell fits scaled around the switching thresholds; a
    loop that is not certainly simple takes the loop-by-loop path (the same result)."""
    import trimsurf.tessellate.face as face_mod
    from trimsurf.errors import TrimLoopError
    from trimsurf.io import read_shell
    from trimsurf.tessellate import tessellate_shell

    calls = []
    real = face_mod._face_loops
    real_cm = face_mod._cell_main
    cm_calls = []

    def rec(*a):
        calls.append(a)
        return real(*a)

    def rec_cm(*a):
        cm_calls.append(a)
        return real_cm(*a)

    monkeypatch.setattr(face_mod, "_face_loops", rec)
    monkeypatch.setattr(face_mod, "_cell_main", rec_cm)
    for name in ("trimesh__featuretype.STEP", "occt__screw.step"):
        shell = read_shell(shared_data / "cad" / name)
        d = shell.diagonal()
        for mode in ("tol", "paper"):
            for m in ("conforming", "loose"):
                tessellate_shell(shell, tolerance=1e-3 * d, max_edge=d if mode == "tol" else 3e-2 * d,
                                 measure=False, mode=m)

    def same(a, b):
        polys_a, x_a, v_a, rem_a, packed = a
        polys_b, x_b, v_b, rem_b, _ = b
        assert len(polys_a) == len(polys_b) and rem_a == rem_b
        for p, q in zip(polys_a, polys_b):
            assert np.array_equal(p, q)
        assert np.array_equal(x_a, x_b) and np.array_equal(v_a, v_b)
        if packed is not None:
            assert np.array_equal(packed[0], np.concatenate(polys_b))
            assert packed[1].tolist() == [len(p) for p in polys_b]

    n_ids = n_packed = 0
    for face, chunks, tol in calls:
        same(real(face, chunks, tol), face_mod._face_loops_numpy(face, chunks, tol))
        n_packed += real(face, chunks, tol)[4] is not None
        # the ids of every other chunk dropped (a loop with ids and without)
        part = [[(c, u, None if k % 2 else ids) for k, (c, u, ids) in enumerate(entries)] for entries in chunks]
        if any(ids is not None for entries in chunks for _, _, ids in entries):
            same(real(face, part, tol), face_mod._face_loops_numpy(face, part, tol))
            n_ids += 1
    assert len(calls) > 400 and n_packed > 400 and n_ids > 100, (len(calls), n_packed, n_ids)
    # a self-crossing loop (a bow tie with a small lobe) and a loop without area next to a square: the
    # loop-by-loop path for the first (the same polygons), the compiled one for the second
    from types import SimpleNamespace as NS

    def chunk(uv, forward=True, ids=None):
        uv = np.array(uv, dtype=np.float64)
        pc = NS(t0=0.0 if forward else 1.0, t1=1.0 if forward else 0.0, edge_id=None)
        use = NS(pcurve=pc, segment=0, forward=forward)
        c = NS(uv=[uv], xyz=np.column_stack([uv, np.zeros(len(uv))]), uses=[use])
        return (c, 0, ids)

    face = calls[0][0]
    bow = [[chunk([(0, 0), (4, 0), (4, 4)]), chunk([(0, 4), (0, 3), (4, 4)][::-1], forward=False),
            chunk([(0, 3), (4.5, 3.2), (0, 0)])]]
    got = real(face, bow, None)
    assert got[4] is None and got[3] > 0
    same(got, face_mod._face_loops_numpy(face, bow, None))
    square = [[chunk([(0, 0), (1, 0), (1, 1), (0, 1), (0, 0)], ids=np.arange(5))],
              [chunk([(2, 2), (3, 2), (2, 2)])]]
    got = real(face, square, None)
    assert got[4] is not None and len(got[0]) == 1
    same(got, face_mod._face_loops_numpy(face, square, None))
    assert real(face, [], None)[0] == []        # no loop
    with pytest.raises(TrimLoopError):
        face_mod.mesh_face_from_chunks(face, np.array([0.0, 1.0]), np.array([0.0, 1.0]), [], tolerance=1.0)
    n_cmp = 0
    for fits, t, prefer in cm_calls:
        for scale in (1.0, 0.5 * t / max(float(fits.max()), 1e-300), t / max(float(fits.max()), 1e-300)):
            f = fits * scale
            for p in (prefer, not prefer) if t is not None else (None,):
                assert np.array_equal(real_cm(f, t, p), face_mod._split_from_fits(f, t, p))
                n_cmp += 1
        assert np.array_equal(real_cm(fits, None, None), face_mod._split_from_fits(fits, None, None))
    assert n_cmp > 1000, n_cmp
    # synthetic fits at the thresholds: the preferred cost at and around half and 0.9 of the tolerance,
    # the other at and just below 0.8 and 0.98 of it, either way round, NaN and infinite ones
    rng = np.random.default_rng(5)
    t = 0.01
    dp = np.concatenate([np.array([0.5, 0.9]) * t, np.nextafter(np.array([0.5, 0.9]) * t, np.inf),
                         rng.uniform(0, 2 * t, 200), [np.nan, np.inf, 0.0]])
    ratio = np.array([0.8, 0.98, np.nextafter(0.8, 0), np.nextafter(0.98, 0), 0.5, 0.9, 1.0, 1.5])
    pp, rr = np.meshgrid(dp, ratio, indexing="ij")
    do = (pp * rr).ravel()
    do = np.concatenate([do, np.nextafter(do, 0), np.nextafter(do, np.inf)])
    dq = np.tile(pp.ravel(), 3)
    for f in (np.column_stack([dq, do]), np.column_stack([do, dq])):
        for p in (True, False):
            got, want = real_cm(f, t, p), face_mod._split_from_fits(f, t, p)
            assert np.array_equal(got, want) and 0.05 < got.mean() < 0.95
        assert np.array_equal(real_cm(f, None, None), face_mod._split_from_fits(f, None, None))


def test_slivers_first_round_exit():
    """`collapse_boundary_slivers` stops after its first candidates only where no candidate's angle is
    unsure (none can be thin): a single thin triangle at the trim is still collapsed (as the numpy
    reference does), and without one the triangles come back unchanged, `kept` the identity."""
    from trimsurf.model import NurbsSurface
    from trimsurf.tessellate.slivers import _collapse_boundary_slivers_numpy, collapse_boundary_slivers

    cp = np.array([[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]], dtype=float)
    s = NurbsSurface(1, 1, np.array([0, 0, 1, 1.0]), np.array([0, 0, 1, 1.0]), cp)
    tris = np.array([[0, 1, 2], [0, 2, 4], [2, 3, 4], [2, 1, 5], [2, 5, 3]], dtype=np.int64)
    is_trim = np.array([True, True, False, False, True, True])
    for height, thin in ((0.02, True), (0.4, False)):
        uv = np.array([[0, 0], [1, 0], [0.5, height], [0.5, 1.0], [0, 1], [1, 1]], dtype=float)
        xyz = np.column_stack([uv, np.zeros(len(uv))])
        t1, k1 = collapse_boundary_slivers(s, uv, xyz, tris, is_trim, tolerance=1.0, max_edge=np.inf)
        t2, k2 = _collapse_boundary_slivers_numpy(s, uv, xyz, tris, is_trim, tolerance=1.0, max_edge=np.inf)
        assert np.array_equal(t1, t2) and np.array_equal(k1, k2)
        assert (len(t1) < len(tris)) == thin
        if not thin:
            assert np.array_equal(k1, np.arange(len(tris))) and t1 is not tris
