"""The compiled tessellation kernels against the numpy code they replace (same maths, same results)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from trimsurf.io import read_shell
from trimsurf.samples import build_sample
from trimsurf.tessellate import domain
from trimsurf.tessellate.face import IsoLines, _surface_distance_numpy, surface_distance
from trimsurf.tessellate.trims import ChunkUse, _ChunkLines


def _numpy_criteria(family, x, n_sub, weights):
    # interval_criteria's numpy path: the family seen as a plain callable
    return domain.interval_criteria(lambda t: family(t), x, n_sub=n_sub, weights=weights)


@pytest.fixture(scope="module")
def t20(shared_data):
    return read_shell(shared_data / "cad" / "gmsh__t20_data.step")


def _faces(t20):
    # rational (cylinders, cones) and polynomial surfaces of a real file, and a sample's B-spline panel
    return [f for f in t20.faces[:8]] + [build_sample("fender").faces[0]]


def test_iso_line_criteria_equal_numpy(t20):
    rng = np.random.default_rng(3)
    for face in _faces(t20):
        s = face.surface
        for axis in (0, 1):
            (a, b), (c, d) = s.domain[axis], s.domain[1 - axis]
            lines = np.r_[np.linspace(c, d, 7), c - 0.1 * (d - c)]      # one line beyond the domain: clamped
            fam = IsoLines(s, axis, lines)
            x = np.unique(np.r_[a, rng.uniform(a, b, 20), b])
            w = rng.random((len(x) - 1, len(lines))) < 0.7
            for weights in (None, w):
                got = fam.criteria(x, 7, weights)
                ref = _numpy_criteria(fam, x, 7, weights)
                # the same operations; only summation order may differ in the last bit
                for g, r in zip(got, ref):
                    assert_allclose(g, r, rtol=1e-12, atol=1e-14 * max(1.0, np.abs(r).max()))


def test_chunk_criteria_and_points_equal_numpy(t20):
    for fi, face in enumerate(t20.faces[:6]):
        s = face.surface
        (u0, u1), (v0, v1) = s.domain
        us, vs = np.linspace(u0, u1, 9), np.linspace(v0, v1, 7)
        uses = [ChunkUse(fi, 0, si, seg, s, us, vs, 1e-9) for si, seg in enumerate(face.loops[0].segments[:3])]
        fam = _ChunkLines(uses)
        x = np.linspace(0.0, 1.0, 13)
        got = fam.criteria(x, 3, None)
        ref = _numpy_criteria(fam, x, 3, None)
        for g, r in zip(got, ref):
            assert_allclose(g, r, rtol=1e-12, atol=1e-14 * max(1.0, np.abs(r).max()))
        # the fused p-curve -> clip -> surface pass against its parts
        for use in uses:
            t = np.linspace(0.0, 1.0, 17)
            uv, xyz = use.points(t)
            lo, hi = sorted((use.pcurve.t0, use.pcurve.t1))
            ref_uv = use.pcurve.curve.derivatives(lo + t * (hi - lo), 1)[0]     # the numpy path (n_derivs > 0)
            ref_uv = np.column_stack([np.clip(ref_uv[:, 0], us[0], us[-1]), np.clip(ref_uv[:, 1], vs[0], vs[-1])])
            assert_allclose(uv, ref_uv, rtol=0, atol=1e-12 * max(1.0, np.abs(ref_uv).max()))
            assert_allclose(xyz, s.evaluate(uv), rtol=0, atol=1e-12 * max(1.0, np.abs(xyz).max()))


@pytest.mark.parametrize("steps", [0, 1, 2])
def test_surface_distance_kernel_equals_numpy(t20, steps):
    rng = np.random.default_rng(5)
    for face in _faces(t20):
        s = face.surface
        (u0, u1), (v0, v1) = s.domain
        # starting parameters partly outside the domain (clamped), points off the surface
        uv = np.column_stack([rng.uniform(u0 - 0.05 * (u1 - u0), u1, 300), rng.uniform(v0, v1, 300)])
        x = s.evaluate(np.clip(uv, [u0, v0], [u1, v1])) + rng.normal(scale=0.01 * s.control_points.std(), size=(300, 3))
        got = surface_distance(s, uv, x, steps=steps)
        ref = _surface_distance_numpy(s, uv, x, steps=steps)
        assert_allclose(got, ref, rtol=1e-9, atol=1e-12 * np.abs(x).max())
        assert np.all(got <= np.linalg.norm(s.evaluate(np.clip(uv, [u0, v0], [u1, v1])) - x, axis=1) + 1e-15)


def test_cell_cache_equals_uncached(t20):
    # the cache serves cells shared between grids (a refined grid keeps most cells): same numbers as
    # computing every cell afresh
    from trimsurf.tessellate.face import _CellCache, _cell_deviation

    for face in _faces(t20)[:5]:
        s = face.surface
        (u0, u1), (v0, v1) = s.domain
        cache = _CellCache(s)
        us, vs = np.linspace(u0, u1, 7), np.linspace(v0, v1, 5)
        tol = 1e-4 * float(np.ptp(s.control_points, axis=(0, 1)).max())
        for grid in ((us, vs), (np.sort(np.r_[us, 0.5 * (us[2] + us[3])]), vs), (us, np.sort(np.r_[vs, 0.3 * v0 + 0.7 * v1]))):
            got = _cell_deviation(s, *grid, tol, cache)
            ref = _cell_deviation(s, *grid, tol)
            for g, r in zip(got, ref):
                assert np.array_equal(g, r)
        assert len(cache.p) < 3 * 6 * 4           # cells of the later grids were served from the cache


def test_triangle_deviations_cache_equals_direct(t20):
    from trimsurf.tessellate.face import _TriangleDeviations, triangle_deviation

    face = t20.faces[2]
    s = face.surface
    (u0, u1), (v0, v1) = s.domain
    rng = np.random.default_rng(7)
    uv = np.column_stack([rng.uniform(u0, u1, 40), rng.uniform(v0, v1, 40)])
    xyz = s.evaluate(uv)
    tris = rng.integers(0, 40, (60, 3))
    known = _TriangleDeviations(s)
    first = known.deviation(uv, xyz, tris)
    again = known.deviation(uv, xyz, np.r_[tris[::2], tris[:5, ::-1]])    # repeats and reversed rows
    assert np.array_equal(first, triangle_deviation(s, uv, xyz, tris))
    assert np.array_equal(again, triangle_deviation(s, uv, xyz, np.r_[tris[::2], tris[:5, ::-1]]))


def test_triangle_deviation_shared_edge_midpoints_are_the_full_sampling():
    """`triangle_deviation` measures the midpoint of an edge shared by two triangles once: the result is
    the max over all seven samples of each triangle, bit for bit (defaults on the B-spline box: a grid
    with trims, every inner edge shared)."""
    from trimsurf.samples import build_sample
    from trimsurf.tessellate import tessellate_shell
    from trimsurf.tessellate.face import _BARY, surface_distance, triangle_deviation

    shell = build_sample("bspline_box")
    res = tessellate_shell(shell, measure=False)
    n = 0
    for fm, face in zip(res.face_meshes, shell.faces):
        t = fm.triangles
        tuv = np.einsum("bk,mkd->mbd", _BARY, fm.uv[t])
        tx = np.einsum("bk,mkd->mbd", _BARY, fm.vertices[t])
        full = surface_distance(face.surface, tuv.reshape(-1, 2), tx.reshape(-1, 3)).reshape(len(t), -1).max(axis=1)
        assert np.array_equal(triangle_deviation(face.surface, fm.uv, fm.vertices, t), full)
        n += len(t)
    assert n > 1000


def test_cell_cache_screen_changes_no_decision(t20):
    # deviation(exact=False) may give cells within the tolerance an upper bound (the samples' start
    # distances) instead of their deviation: such a bound is within the tolerance and not below the
    # exact value, and every cell over the tolerance keeps its exact value
    from trimsurf.tessellate.face import _CellCache, _cell_deviation

    n_bounded = n_over = 0
    for face in _faces(t20)[:8]:
        s = face.surface
        (u0, u1), (v0, v1) = s.domain
        us, vs = np.linspace(u0, u1, 9), np.linspace(v0, v1, 6)
        ref = _cell_deviation(s, us, vs, 1.0)[0]
        for tol in np.quantile(ref, [0.2, 0.6, 0.95]):
            cache = _CellCache(s)
            got = _cell_deviation(s, us, vs, tol, cache, exact=False)
            exact = _cell_deviation(s, us, vs, tol)
            for g, r in zip(got[1:], exact[1:]):
                assert np.array_equal(g, r)
            over = exact[0] > tol
            assert np.array_equal(got[0][over], exact[0][over])
            assert np.all(got[0][~over] <= tol) and np.all(got[0][~over] >= exact[0][~over])
            n_bounded += int(np.sum(got[0] != exact[0]))
            n_over += int(over.sum())
            # an exact request afterwards gets the exact values from the same cache
            assert np.array_equal(_cell_deviation(s, us, vs, tol, cache)[0], exact[0])
    assert n_bounded > 50 and n_over > 50


def test_refine_round_bulges_equal_numpy(t20):
    # the side bulges of refine_cells' bad cells (which direction gets a mid-line; `cell_surface_kernel`
    # op 2) are those of face._side_bulge, the numpy reference
    from trimsurf.tessellate._line_kernels import cell_surface_kernel
    from trimsurf.tessellate.face import _BARY, _CellCache, _side_bulge

    n = 0
    for face in _faces(t20)[:6]:
        s = face.surface
        (u0, u1), (v0, v1) = s.domain
        us, vs = np.linspace(u0, u1, 6), np.linspace(v0, v1, 5)
        bi, bj = (a.ravel() for a in np.meshgrid(np.arange(5), np.arange(4), indexing="ij"))
        su, sv = _side_bulge(s, us, vs, bi, bj)
        cu, cv = np.empty(len(bi), dtype=bool), np.empty(len(bi), dtype=bool)
        cell_surface_kernel(2, *_CellCache(s)._surf, us, vs, bi, bj, np.zeros(0, bool), _BARY, np.zeros((0, 5, 2)),
                            np.zeros((0, 5, 3)), 0.0, np.zeros(0), cu, cv, np.zeros((0, 2)))
        assert np.array_equal(cu, su >= 0.5 * sv) and np.array_equal(cv, sv >= 0.5 * su)
        n += int(np.sum(cu != cv))
    assert n > 0


def test_cell_centres_and_diagonal_fits_equal_the_per_point_path(t20):
    """`cell_surface_kernel` op 0 evaluates a cell's centre once with its derivatives and takes both
    diagonals' one-step distances from it: its points and distances are bit for bit those of the per-point
    path it replaces (`NurbsSurface.evaluate` of the corners and the centre, `surface_distance(..., steps=1)`
    of the diagonals' midpoints from the centre, `face._diagonal_fits`), also for grids reaching past the
    surface's domain (clipped starts and steps) and at the degenerate rows of a cone's apex (the step's
    singular system: no step)."""
    from trimsurf.tessellate._line_kernels import cell_surface_kernel
    from trimsurf.tessellate.face import _BARY, _CellCache, _diagonal_fits

    from trimsurf.model.nurbs import NurbsSurface
    from trimsurf.model.trim import TrimmedFace

    # a rational quarter cone, its v = 1 row collapsed to the apex (S_u = 0 there: no step from it)
    r = np.sqrt(0.5)
    cp = np.array([[[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], [[1.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                   [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]])
    cone = NurbsSurface(2, 1, [0, 0, 0, 1, 1, 1], [0, 0, 1, 1], cp, np.array([[1.0, 1.0], [r, r], [1.0, 1.0]]))
    faces = _faces(t20) + [TrimmedFace(cone)]
    n_out = n_cells = 0
    for face in faces:
        s = face.surface
        (u0, u1), (v0, v1) = s.domain
        du, dv = u1 - u0, v1 - v0
        for us, vs in ((np.linspace(u0, u1, 9), np.linspace(v0, v1, 7)),
                       (np.linspace(u0 - 0.3 * du, u1 + 0.2 * du, 8), np.linspace(v0 - 0.25 * dv, v1 + 0.1 * dv, 6))):
            ia, ib = (a.ravel() for a in np.meshgrid(np.arange(len(us) - 1), np.arange(len(vs) - 1), indexing="ij"))
            k = len(ia)
            uv, p, d = np.empty((k, 5, 2)), np.empty((k, 5, 3)), np.empty((k, 2))
            cell_surface_kernel(0, *_CellCache(s)._surf, us, vs, ia, ib, np.zeros(0, bool), _BARY, uv, p, 0.0,
                                np.zeros(0), np.zeros(0, bool), np.zeros(0, bool), d)
            ref_p = s.evaluate(np.clip(uv.reshape(-1, 2), [u0, v0], [u1, v1])).reshape(k, 5, 3)
            assert np.array_equal(p, ref_p)
            assert np.array_equal(d, _diagonal_fits(s, us, vs))
            n_out += int(np.sum((uv[:, 4, 0] < u0) | (uv[:, 4, 0] > u1) | (uv[:, 4, 1] < v0) | (uv[:, 4, 1] > v1)))
            n_cells += k
    assert n_out > 100 and n_cells > 500
