"""The shell-level domain values (`face.shell_domain_values`, `face.face_fronts`) and the one-interval
shortcut of straight iso-lines (`IsoLines.single_interval`) against the per-face reference path they
replace: the same values bit for bit (the meshes' hashes depend on them), the same errors."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.errors import TrimLoopError
from trimsurf.io import read_shell
from trimsurf.model import Loop, NurbsCurve, PCurve, TrimmedFace
from trimsurf.tessellate import face as face_mod
from trimsurf.tessellate._line_kernels import equidistributed_kernel
from trimsurf.tessellate.domain import _clipped_values
from trimsurf.tessellate.face import (_inside_raster, _loop_polylines, face_domain_values, face_fronts, grid_box,
                                      shell_domain_values)
from trimsurf.tessellate.repair import repair_face
from trimsurf.tessellate.shell import SAMPLING_MARGIN

_MODELS = ["trimesh__featuretype.STEP", "occt__screw.step", "gmsh__U_Joint_2.stp"]


def _faces(path):
    """The faces tessellate_shell meshes (repaired; an untrimmed face gets its domain rectangle)."""
    shell = read_shell(path)
    d = shell.diagonal()
    out = []
    for f in shell.faces:
        rep = repair_face(f, tolerance=SAMPLING_MARGIN * 1e-3 * d)
        if rep.status != "failed":
            out.append(rep.face if rep.face.loops else face_mod._rectangle_face(rep.face))
    return out, d


@pytest.fixture(scope="module", params=_MODELS)
def model(request, shared_data):
    return _faces(shared_data / "cad" / request.param)


def _same(a, b):
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def test_lazy_rasters_are_the_batch_rasters(model):
    """A face `face_fronts` does not rasterize (`rasterize` False: `shell_domain_values` leaves the planes'
    rasters until a compiled placement reads one) builds the same raster when first read."""
    faces, _ = model
    every = face_fronts(faces)
    pick = [i % 3 == 0 for i in range(len(faces))]
    lazy = face_fronts(faces, pick)
    assert any(fr.polys is not None and fr._raster is face_mod._PENDING for fr in lazy)
    for fr, ref in zip(lazy, every):
        if ref.raster is None:
            assert fr.raster is None
            continue
        r = fr.raster
        assert _same(r.dil, ref.raster.dil) and _same(r.lo, ref.raster.lo) and _same(r.step, ref.raster.step)
        assert fr.raster is r       # built once


def _outside_face(face):
    """`face` with one loop outside its surface's domain (grid_box: TrimLoopError)."""
    (u0, u1), (v0, v1) = face.surface.domain
    du, dv = u1 - u0, v1 - v0
    c = [(u1 + du, v1 + dv), (u1 + 2 * du, v1 + dv), (u1 + 2 * du, v1 + 2 * dv), (u1 + du, v1 + 2 * dv)]
    segs = tuple(PCurve(NurbsCurve(1, [0.0, 0.0, 1.0, 1.0], np.array([c[i], c[(i + 1) % 4]], dtype=np.float64)),
                        0.0, 1.0) for i in range(4))
    return TrimmedFace(face.surface, (Loop(segs),), face.same_sense, "outside", face.tolerance)


def test_fronts_are_the_per_face_numbers(model):
    """Every face's grid box, trim polygons, polygon edges and inside raster from `face_fronts` (all faces
    at once) equal `_loop_polylines`, `grid_box`, `PolygonIndex` and `_inside_raster` of the face alone."""
    faces, _ = model
    bad = _outside_face(faces[0])
    fronts = face_fronts(faces + [bad])
    assert isinstance(fronts[-1], TrimLoopError)
    with pytest.raises(TrimLoopError, match=str(fronts[-1])):
        grid_box(bad, _loop_polylines(bad, 32, 6)[0])
    for f, fr in zip(faces, fronts):
        box, polys = _loop_polylines(f, 32, 6)
        lo, hi = grid_box(f, box)
        assert _same(fr.lo, lo) and _same(fr.hi, hi)
        assert len(fr.polys) == len(polys) and all(_same(a, b) for a, b in zip(fr.polys, polys))
        index = face_mod.PolygonIndex(polys)
        assert _same(fr.index.a, index.a) and _same(fr.index.b, index.b)
        r = _inside_raster(polys, lo, hi, index=index)
        assert _same(fr.raster.dil, r.dil) and _same(fr.raster.lo, r.lo) and _same(fr.raster.step, r.step)
        # the lazily built slab index answers as the full one
        pts = np.column_stack([np.linspace(lo[0], hi[0], 7), np.linspace(lo[1], hi[1], 7)])
        assert np.array_equal(fr.index.contains(pts), index.contains(pts))


@pytest.mark.parametrize("paper", [False, True])
def test_shell_domain_values_equal_face_domain_values(model, paper):
    """`shell_domain_values` (what tessellate_shell calls with jobs=1) gives each face the grid and fits of
    `face_domain_values` alone (what each --jobs worker computes), and a face's error in its place."""
    faces, d = model
    tol, h = SAMPLING_MARGIN * 1e-3 * d, (0.03 * d if paper else d)
    bad = _outside_face(faces[0])
    f0 = faces[0]
    untrimmed = TrimmedFace(f0.surface, (), f0.same_sense, "untrimmed", f0.tolerance)
    todo = faces[:40] + [untrimmed, bad]
    got = shell_domain_values(todo, tolerance=tol, max_edge=h)
    assert len(got) == len(todo)
    for f, g in zip(todo[:-1], got[:-1]):
        ref = face_domain_values(f, tolerance=tol, max_edge=h, with_fits=True)
        assert all(_same(a, b) for a, b in zip(g, ref))
    assert isinstance(got[-1], TrimLoopError)
    with pytest.raises(TrimLoopError, match=str(got[-1])):
        face_domain_values(bad, tolerance=tol, max_edge=h)


def _placements(faces, tol, h, check=False):
    """The (family, a, b, tolerance, max_edge, x0) of every placement `shell_domain_values` asks for. With
    `check`, each placement's values (or error) are also compared with the compiled placement's from the
    full family (no shortcut), and the count of the placements that skipped the compiled call
    (`_single_interval`) is returned too."""
    seen = []
    real = face_mod._place_axis
    skipped = [0]

    def record(family, axis, a, b, x0, info, tolerance, max_edge, max_values):
        ev = family(axis)
        seen.append((ev, float(a), float(b), float(tolerance), float(max_edge), x0))
        try:
            got = real(family, axis, a, b, x0, info, tolerance, max_edge, max_values)
        except face_mod.InputError as exc:
            got = exc
        if check:       # the compiled placement itself, no shortcut
            ref, needed = equidistributed_kernel(*ev.family(), x0, float(a), float(b), float(tolerance),
                                                 float(max_edge), float(max_values))
            if needed >= 0:
                assert isinstance(got, face_mod.InputError)
            else:
                assert _same(got, ref)
            assert ev.single_interval(a, b, tolerance, max_edge, len(x0) - 1) == \
                face_mod._single_interval(info, a, b, float(tolerance), float(max_edge), len(x0) - 1)
            skipped[0] += face_mod._single_interval(info, a, b, float(tolerance), float(max_edge), len(x0) - 1)
        if isinstance(got, Exception):
            raise got
        return got

    face_mod._place_axis = record
    try:
        shell_domain_values(faces, tolerance=tol, max_edge=h)
    finally:
        face_mod._place_axis = real
    return (seen, skipped[0]) if check else seen


@pytest.mark.parametrize("paper", [False, True])
def test_placement_shortcuts_are_the_full_path(model, paper):
    """Every placement of `shell_domain_values` (the start values kept per axis, `_single_interval` from
    the family's `_straight_info`, the family built only when the compiled call runs) gives the values
    the compiled placement gives from the full family, without the shortcut; the shortcut fires on some
    of them."""
    faces, d = model
    tol, h = SAMPLING_MARGIN * 1e-3 * d, (0.03 * d if paper else d)
    seen, skipped = _placements(faces, tol, h, check=True)
    assert seen and (skipped > 0 or paper)


def test_start_values_are_the_clipped_values():
    """`face._start_values` (init itself when it runs from a to b) equals `_clipped_values` on the starts
    `_domain_values` makes and where init does not start at a, end at b, or holds NaN."""
    from trimsurf.tessellate.face import _start_values

    for a, init, b in [(0.0, np.linspace(0.0, 1.0, 17), 1.0),
                       (0.1, np.unique(np.r_[np.linspace(0.1, 0.7, 17), 0.25, 0.5]), 0.7),
                       (0.0, np.linspace(0.1, 1.0, 17), 1.0), (0.0, np.linspace(0.0, 0.9, 17), 1.0),
                       (0.0, np.linspace(-0.5, 1.5, 17), 1.0), (0.0, np.r_[0.0, 0.5, np.nan], 1.0),
                       (0.0, np.r_[0.0, 0.5, 1.0, np.nan], 1.0), (-0.0, np.linspace(0.0, 1.0, 17), 1.0),
                       (-1.0, np.linspace(-1.0, 0.0, 17), -0.0)]:
        got, ref = _start_values(a, init, b), _clipped_values(a, init, b)
        assert _same(got, ref) and _same(np.signbit(got), np.signbit(ref))


def _check_single_interval(seen, scales):
    """(fired, wrong): how often the shortcut fired over the placements at max_edge x each scale, and how
    often the compiled placement then was not [a, b]."""
    fired = wrong = 0
    for ev, a, b, tol, me, x0 in seen:
        for s in scales:
            if not ev.single_interval(a, b, tol, me * s, len(x0) - 1):
                continue
            fired += 1
            x, needed = equidistributed_kernel(*ev.family(), x0, a, b, tol, me * s, 20000.0)
            wrong += not (needed < 0 and _same(x, np.array([a, b])))
    return fired, wrong


def test_single_interval_is_the_compiled_placement(model, monkeypatch):
    """Wherever `IsoLines.single_interval` says the placement is [a, b], the compiled placement it skips
    places [a, b] (bit for bit), at max edges from the model's tolerance-only setting down to where the
    shortcut stops firing; and the check can fail: with the bound's margin widened to 2.5 (densities
    up to 2.5 taken as one interval) the compiled placement differs on some of them."""
    faces, d = model
    tol = SAMPLING_MARGIN * 1e-3 * d
    seen = [p for p in _placements(faces, tol, d) if p[0]._straight()[0] >= 0]
    assert seen
    scales = [1.0, 0.5, 0.2, 0.1, 0.05, 0.03]
    fired, wrong = _check_single_interval(seen, scales)
    assert fired >= len(seen) // 2 and wrong == 0
    monkeypatch.setattr(face_mod, "_ONE_INTERVAL", 2.5)
    for ev in {id(p[0]): p[0] for p in seen}.values():
        ev._straight_v = None
    fired_wide, wrong_wide = _check_single_interval(seen, scales)
    assert fired_wide > fired and wrong_wide > 0


def _family(cp, weights=None, degree_u=1):
    from trimsurf.model import NurbsSurface
    from trimsurf.tessellate.face import IsoLines

    nu = cp.shape[0]
    ku = np.r_[[0.0] * (degree_u + 1), np.linspace(0, 1, nu - degree_u + 1)[1:-1], [1.0] * (degree_u + 1)]
    s = NurbsSurface(degree_u, 1, ku, np.array([0.0, 0.0, 1.0, 1.0]), cp, weights)
    return IsoLines(s, 0, np.linspace(0.0, 1.0, 24))


def _placed(ev, tol, me):
    x, needed = equidistributed_kernel(*ev.family(), np.linspace(0.0, 1.0, 17), 0.0, 1.0, tol, me, 20000.0)
    assert needed < 0
    return x


def test_single_interval_needs_the_same_weights_along_the_lines():
    """A unit square whose u-lines are straight but rational with weights that differ along them (1 to 100
    on v = 0, 100 to 1 on v = 1): the lines run through their chords at speeds that peak at opposite ends,
    so the largest chord per interval adds up to about twice the bound's (b - a) / span * D. The compiled
    placement needs 2 intervals where that bound is 0.6 max_edge; the shortcut must not fire there. With
    the same weights along each line (a plain square) it does, and the placement is [0, 1]."""
    cp = np.zeros((2, 2, 3))
    cp[1, :, 0] = 1.0
    cp[:, 1, 1] = 1.0
    tol, me = 1e-3, 1.0 / 0.6
    bent = _family(cp, np.array([[1.0, 100.0], [100.0, 1.0]]))
    assert len(_placed(bent, tol, me)) > 2
    assert not bent.single_interval(0.0, 1.0, tol, me, 16)
    flat = _family(cp, np.array([[2.0, 3.0], [2.0, 3.0]]))
    assert flat.single_interval(0.0, 1.0, tol, me, 16)
    assert _same(_placed(flat, tol, me), np.array([0.0, 1.0]))


def test_single_interval_needs_straight_lines():
    """Degree-2 u-lines whose first two control points are close (the net's first difference small) but
    which run on to length ~14: the compiled placement needs several intervals at max edge 5; the
    shortcut must not fire (it applies only to degree 1 with one span along the lines)."""
    cp = np.zeros((3, 2, 3))
    cp[1, :, 0] = 1e-3
    cp[2, :, 0] = 10.0
    cp[2, :, 2] = 10.0
    cp[:, 1, 1] = 1.0
    ev = _family(cp, degree_u=2)
    tol, me = 1e-3, 5.0
    assert len(_placed(ev, tol, me)) > 3
    assert not ev.single_interval(0.0, 1.0, tol, me, 16)


def _deviations(surface, us, vs, tol, lin=None):
    """`_CellCache.deviation(..., exact=False)` of a fresh cache (its bilinear bound replaced by `lin`)."""
    cache = face_mod._CellCache(surface)
    if lin is not None:
        cache._lin = np.asarray(lin, dtype=np.float64)
    return cache.deviation(us, vs, tol, exact=False)[0]


def _screen_agrees(surface, us, vs, tol, lin=None):
    """Whether the cells over the tolerance (the only use of the screened values, with their exact
    values) are the same with the bilinear bound as with every sample evaluated; and the cells the
    bound settles (values changed) are within the tolerance where every sample is evaluated."""
    ref = _deviations(surface, us, vs, tol, lin=(-1.0, 0.0))
    got = _deviations(surface, us, vs, tol, lin=lin)
    over = ref > tol
    return bool(np.array_equal(got > tol, over) and np.array_equal(got[over], ref[over])
                and np.all(ref[got != ref] <= tol))


def test_bilinear_screen_on_planar_faces(shared_data):
    """On the planar (degree 1 x 1) faces of featuretype, at grids of 4 to 40 lines and tolerances down to
    where cells leave them, the bilinear bound gives the same cells over the tolerance as the screened
    kernel, and settles most cells."""
    faces, d = _faces(shared_data / "cad" / "trimesh__featuretype.STEP")
    planar = [f for f in faces if (f.surface.degree_u, f.surface.degree_v) == (1, 1)][:12]
    assert planar
    settled = total = 0
    for f in planar:
        assert face_mod._CellCache(f.surface)._lin[0] >= 0
        (u0, u1), (v0, v1) = f.surface.domain
        for n in (4, 13, 40):
            us, vs = np.linspace(u0, u1, n), np.linspace(v0, v1, n + 3)
            for tol in (1e-3 * d, 1e-9 * d, 1e-13 * d):
                assert _screen_agrees(f.surface, us, vs, tol)
                ref = _deviations(f.surface, us, vs, tol, lin=(-1.0, 0.0))
                got = _deviations(f.surface, us, vs, tol)
                settled += int(np.count_nonzero(got != ref))
                total += got.size
    assert settled > total // 3


def test_bilinear_screen_on_a_twisted_patch():
    """A twisted bilinear patch (a hyperbolic paraboloid, |E| = 2): where the twist puts samples off the
    surface by about |E| du dv / 8, tolerances around that value give the same cells over them with the
    bound as without; the bound without its twist term (e = 0) would settle cells that are over."""
    from trimsurf.model import NurbsSurface

    cp = np.array([[[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0], [1.0, 1.0, 1.0]]])
    cp[1, 1, 2] = 2.0
    s = NurbsSurface(1, 1, np.array([0.0, 0.0, 1.0, 1.0]), np.array([0.0, 0.0, 1.0, 1.0]), cp)
    lin = face_mod._CellCache(s)._lin
    assert lin[0] >= 2.0
    us, vs = np.linspace(0, 1, 9), np.linspace(0, 1, 7)
    ref = _deviations(s, us, vs, 1.0, lin=(-1.0, 0.0))
    fired = 0
    for tol in np.geomspace(0.2, 5.0, 12) * float(np.max(ref)):
        assert _screen_agrees(s, us, vs, tol)
        fired += int(np.count_nonzero(_deviations(s, us, vs, tol) != _deviations(s, us, vs, tol, (-1.0, 0.0))))
    assert fired > 0
    tol = 0.5 * float(np.max(ref))
    assert not _screen_agrees(s, us, vs, tol, lin=(0.0, lin[1]))


def test_placement_start_record_is_the_fresh_placement(model):
    """`IsoLines.family` keeps the compiled placement's fine-sampling start (`equidistributed_kernel`'s
    record in the family's cf) for the face's second placement: a family that placed once places at
    another tolerance and max edge, and from other start values, exactly as a fresh family does; the
    record is taken only for the same start (bit for bit, zeros' signs too)."""
    from trimsurf.tessellate.face import IsoLines

    faces, d = model
    tol = SAMPLING_MARGIN * 1e-3 * d
    seen = [p for p in _placements(faces[:60], tol, 0.03 * d) if p[0]._straight()[0] < 0]
    assert seen
    used = 0
    for ev, a, b, t, me, x0 in seen[:25]:
        fam = ev.family()
        rec = fam[11]
        assert rec.shape == (face_mod._START_ROWS, 6)
        fresh = lambda: IsoLines(ev.surface, ev.axis, ev.lines, ev.raster, _surf=(ev._ku, ev._kv, ev._pw)).family()
        x1 = np.unique(np.r_[x0, 0.5 * (x0[:-1] + x0[1:])[::3]])     # other start values
        x2 = x0.copy()                                                  # as many, others inside
        x2[1:-1] = 0.5 * (x0[:-2] + x0[2:])
        for args in [(x0, a, b, t / 3.0, me), (x0, a, b, t, me / 2.0), (x1, a, b, t, me), (x0, a, b, t / 2.0, me),
                     (x2, a, b, t / 2.0, me), (x0, a, b, t / 2.0, me)]:
            before = rec[0, 0]
            got = equidistributed_kernel(*fam, *args, 20000.0)
            ref = equidistributed_kernel(*fresh(), *args, 20000.0)
            assert _same(got[0], ref[0]) and got[1] == ref[1]
            used += before == len(args[0]) - 1 and rec[0, 0] == before
        assert rec[0, 0] == len(x0) - 1
    assert used > 0


def test_knots_and_linspace_shortcuts_are_unique_values(model):
    """`face._knots_in` (no sort when no knot is inside) and `face._with_knots` (the linspace itself when
    no knot is added and it increases strictly) equal the unique_values path they skip, bit for bit, on
    every face's knots and grid box of the models and where a linspace has equal values, knots are added,
    or zeros of both signs and NaN are among the knots."""
    from trimsurf.tessellate.domain import unique_values
    from trimsurf.tessellate.face import _knots_in, _linspace, _with_knots

    def ref_kin(k, a, b):
        u = unique_values(k)
        return u[(u > a) & (u < b)]

    def ref_with(a, b, n, kin):
        return unique_values(np.concatenate((_linspace(a, b, n), kin)))

    faces, _ = model
    for f, fr in zip(faces, face_fronts(faces)):
        s = f.surface
        for axis, k in ((0, s.knots_u), (1, s.knots_v)):
            a, b = fr.lo[axis], fr.hi[axis]
            kin = _knots_in(k, a, b)
            assert _same(kin, ref_kin(k, a, b))
            for n in (17, 24):
                assert _same(_with_knots(a, b, n, kin), ref_with(a, b, n, kin))
    for k, a, b in [(np.array([0.0, 0.0, 1.0, 1.0]), 0.1, 0.9), (np.array([0.0, 0.0, 0.5, 1.0, 1.0]), 0.1, 0.9),
                    (np.array([0.0, 0.0, 0.5, 0.5, 1.0, 1.0]), 0.0, 1.0), (np.array([-1.0, -0.0, 0.0, 1.0]), -0.5, 0.5),
                    (np.array([0.0, np.nan, 1.0]), 0.0, 1.0), (np.array([0.0, 0.2, 0.1, 1.0]), 0.0, 1.0)]:
        assert _same(_knots_in(k, a, b), ref_kin(k, a, b))
    for a, b, n, kin in [(0.1, 0.7, 17, np.zeros(0)), (0.1, 0.7, 24, np.array([0.25, 0.5])),
                         (1.0, 1.0 + 4e-16, 17, np.zeros(0)), (0.0, 0.5, 17, np.array([0.25])),
                         (-1.0, 1.0, 24, np.zeros(0))]:
        assert _same(_with_knots(a, b, n, kin), ref_with(a, b, n, kin))
    assert len(_with_knots(1.0, 1.0 + 4e-16, 17, np.zeros(0))) < 17     # (repeats: the full path drops them)
