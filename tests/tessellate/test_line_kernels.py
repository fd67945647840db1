"""The compiled 1-D adaptive sampling (`_line_kernels`) against the numpy path it replaces: the same
values bit for bit (the meshes' hashes depend on it), on real faces and trim curves."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.errors import InputError
from trimsurf.io import read_shell
from trimsurf.samples import build_sample
from trimsurf.tessellate import domain
from trimsurf.tessellate.face import IsoLines, _inside_raster, _loop_polys, face_domain_values, grid_box
from trimsurf.tessellate.trims import ChunkUse, _ChunkLines, _insert_iso_values, _insert_iso_values_numpy


class _Plain:
    """A family without `family()`: adaptive_values takes the numpy path."""

    def __init__(self, fam):
        self.fam = fam

    def __call__(self, x):
        return self.fam(x)

    def criteria(self, x, n_sub, weights):
        return self.fam.criteria(x, n_sub, weights)


@pytest.fixture(scope="module")
def t20(shared_data):
    return read_shell(shared_data / "cad" / "gmsh__t20_data.step")


def _faces(t20):
    return list(t20.faces[:10]) + [build_sample("fender").faces[0]]


@pytest.mark.parametrize("tol_scale", [1e-3, 3e-5])
def test_iso_line_values_equal_numpy_path(t20, tol_scale):
    # tol_scale 3e-5 makes some placements fail the check (the bisection rounds run)
    d = t20.diagonal()
    for face in _faces(t20):
        s = face.surface
        lo, hi = grid_box(face)
        raster = _inside_raster(_loop_polys(face), lo, hi) if face.loops else None
        for axis in (0, 1):
            o = 1 - axis
            lines = np.linspace(lo[o], hi[o], 9)
            fam = IsoLines(s, axis, lines, raster)
            wf = None if raster is None else fam.weights
            init = np.linspace(lo[axis], hi[axis], 17)
            kw = dict(tolerance=tol_scale * d, max_edge=0.05 * d / np.sqrt(2.0), init=init)
            got = domain.adaptive_values(fam, lo[axis], hi[axis], weights_fn=wf, **kw)
            ref = domain.adaptive_values(_Plain(fam), lo[axis], hi[axis], weights_fn=wf, **kw)
            assert np.array_equal(got, ref)
            # and the values meet both criteria on the counted lines, sampled 4x finer than the check
            ln, dv = domain.interval_criteria(fam, got, n_sub=31, weights=None if wf is None else wf(got))
            assert np.all(ln <= kw["max_edge"] * (1 + 1e-9))
            assert np.all(dv <= 1.05 * kw["tolerance"])     # checked at 7 samples: sampled, not proven


def test_compiled_placement_refuses_beyond_max_values(t20):
    face = t20.faces[0]
    s = face.surface
    lo, hi = grid_box(face)
    fam = IsoLines(s, 0, np.linspace(lo[1], hi[1], 5))
    with pytest.raises(InputError, match="intervals needed"):
        domain.adaptive_values(fam, lo[0], hi[0], tolerance=1e-9, max_edge=1e-6, max_values=50)


def test_chunk_values_and_iso_insertion_equal_numpy_path(t20):
    d = t20.diagonal()
    n = 0
    for fi, face in enumerate(t20.faces[:12]):
        us, vs = face_domain_values(face, tolerance=1e-3 * d, max_edge=0.03 * d)
        for li, loop in enumerate(face.loops):
            for si, seg in enumerate(loop.segments):
                uses = [ChunkUse(fi, li, si, seg, face.surface, us, vs, 1e-9 * max(np.ptp(us), np.ptp(vs)))]
                fam = _ChunkLines(uses)
                kw = dict(tolerance=1e-3 * d, max_edge=0.03 * d, init=np.linspace(0.0, 1.0, 9))
                s = domain.adaptive_values(fam, 0.0, 1.0, **kw)
                assert np.array_equal(s, domain.adaptive_values(_Plain(fam), 0.0, 1.0, **kw))
                got = _insert_iso_values(fam, uses, s)
                ref = _insert_iso_values_numpy(uses, s)
                assert np.array_equal(got[0], ref[0]) and np.array_equal(got[2], ref[2])
                assert all(np.array_equal(g, r) for g, r in zip(got[1], ref[1]))
                # every crossing of a grid line is a point exactly on it
                assert got[2].sum() >= 2
                n += 1
    assert n > 20


def test_inside_grid_equals_points_in_polygons(t20):
    # the row-wise kernel of the raster and of `_near_trim` against the per-point test it replaces, on
    # real trim polygons (grids through their vertices' coordinates too: rows at a vertex's height)
    from trimsurf.geom.predicates import PolygonIndex, points_in_polygons
    from trimsurf.tessellate._line_kernels import inside_grid_kernel

    rng = np.random.default_rng(3)
    n = 0
    for face in _faces(t20):
        if not face.loops:
            continue
        polys = _loop_polys(face)
        index = PolygonIndex(polys)
        lo, hi = grid_box(face)
        verts = np.concatenate(polys)
        for xs, ys in ((np.linspace(lo[0], hi[0], 37), np.linspace(lo[1], hi[1], 41)),
                       (np.sort(rng.choice(verts[:, 0], 15)), np.sort(rng.choice(verts[:, 1], 17)))):
            dil = np.empty((len(xs), len(ys)), dtype=bool)
            ero = np.empty_like(dil)
            inside_grid_kernel(xs, ys, index.a, index.b, dil, ero)
            uu, vv = np.meshgrid(xs, ys, indexing="ij")
            ins = points_in_polygons(np.column_stack([uu.ravel(), vv.ravel()]), polys).reshape(uu.shape)
            ref_d, ref_e = ins.copy(), ins.copy()
            for sl, sr in (((slice(1, None),), (slice(None, -1),)), ((slice(None, -1),), (slice(1, None),)),
                           ((slice(None), slice(1, None)), (slice(None), slice(None, -1))),
                           ((slice(None), slice(None, -1)), (slice(None), slice(1, None)))):
                ref_d[sl] |= ins[sr]
                ref_e[sl] &= ins[sr]
            assert np.array_equal(dil, ref_d) and np.array_equal(ero, ref_e)
            n += int(ins.sum())
    assert n > 100


def _inside_rows_every_edge(xs, ys, a, b):
    """The per-row test `_line_kernels._inside_rows` replaces: every edge tested on every row (as
    `predicates._points_in_polygons_kernel` decides a crossing and its abscissa), searchsorted per point."""
    ins = np.zeros((len(xs), len(ys)), dtype=bool)
    with np.errstate(all="ignore"):
        for j, y in enumerate(ys):
            xc = [a[e, 0] + (y - a[e, 1]) * (b[e, 0] - a[e, 0]) / (b[e, 1] - a[e, 1])
                  for e in range(len(a)) if (a[e, 1] > y) != (b[e, 1] > y)]
            if not xc:
                continue
            xc = np.array(xc)
            if not np.isnan(xc).any():
                srt = np.sort(xc)
                for i, x in enumerate(xs):
                    if not np.isnan(x):
                        ins[i, j] = (len(xc) - np.searchsorted(srt, x, side="right")) % 2 == 1
            else:
                for i, x in enumerate(xs):
                    ins[i, j] = int(np.sum(x < xc)) % 2 == 1
    return ins


def test_inside_rows_equal_every_edge_rows(t20):
    # `_inside_rows` gathers each row's crossings from the edges' row ranges (searchsorted of ys) and walks
    # increasing xs: the same decisions as every edge tested on every row, on real polygons with rows and
    # columns at their vertices' coordinates, and on edges with NaN / infinite / equal ends, horizontal
    # edges, repeated and unsorted rows and columns, NaN rows and columns
    from trimsurf.geom.predicates import PolygonIndex
    from trimsurf.tessellate._line_kernels import _inside_rows, inside_grid_kernel, inside_grids_kernel

    rng = np.random.default_rng(5)
    cases = []
    for face in _faces(t20):
        if face.loops:
            index = PolygonIndex(_loop_polys(face))
            verts = index.a
            lo, hi = grid_box(face)
            cases.append((np.linspace(lo[0], hi[0], 23), np.linspace(lo[1], hi[1], 29), index.a, index.b))
            cases.append((np.sort(rng.choice(verts[:, 0], 15)), np.sort(rng.choice(verts[:, 1], 17)), index.a, index.b))
    g = np.array([0.0, 0.25, 0.5, 0.5, 0.75, 1.0])
    for _ in range(60):
        m = int(rng.integers(1, 12))
        a = rng.choice(g, (m, 2)) + rng.choice([0.0, 0.1], (m, 2))
        b = rng.choice(g, (m, 2))
        for arr in (a, b):      # NaN / infinite / horizontal ends
            k = rng.integers(0, 4)
            if k == 1:
                arr[rng.integers(m), 1] = np.nan
            elif k == 2:
                arr[rng.integers(m), rng.integers(2)] = rng.choice([np.inf, -np.inf])
            elif k == 3:
                e = rng.integers(m)
                a[e, 1] = b[e, 1]
        ys = np.sort(np.concatenate((rng.choice(g, 4), rng.random(5))))
        xs = np.sort(np.concatenate((rng.choice(g, 3), rng.random(6))))
        cases.append((xs, ys, a, b))
        cases.append((xs[::-1].copy(), ys[::-1].copy(), a, b))          # decreasing: the per-edge rows
        xs2, ys2 = xs.copy(), ys.copy()
        xs2[2], ys2[3] = np.nan, np.nan
        cases.append((xs2, ys2, a, b))
    n_in = 0
    for xs, ys, a, b in cases:
        a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
        ref = _inside_rows_every_edge(xs, ys, a, b)
        assert np.array_equal(_inside_rows(xs, ys, a, b), ref)
        n_in += int(ref.sum())
        # the kernels around it: dilation and erosion of the same rows
        dil, ero = np.empty(ref.shape, dtype=bool), np.empty(ref.shape, dtype=bool)
        inside_grid_kernel(xs, ys, a, b, dil, ero)
        p = np.pad(ref, 1, mode="edge")
        nb = (p[1:-1, 1:-1], p[:-2, 1:-1], p[2:, 1:-1], p[1:-1, :-2], p[1:-1, 2:])
        assert np.array_equal(dil, np.logical_or.reduce(nb)) and np.array_equal(ero, np.logical_and.reduce(nb))
    assert n_in > 500
    # inside_grids_kernel: the linspace grid of each box, the dilated rows
    a, b = cases[0][2], cases[0][3]
    lo = np.array([[a[:, 0].min(), a[:, 1].min()], [a[:, 0].min(), a[:, 1].min()]])
    hi = np.array([[a[:, 0].max(), a[:, 1].max()], [0.5 * (a[:, 0].min() + a[:, 0].max()), a[:, 1].max()]])
    dil = np.empty((2, 31, 31), dtype=bool)
    inside_grids_kernel(lo, hi, a, b, np.array([[0, len(a)], [0, len(a)]], dtype=np.int64), dil)
    for f in range(2):
        ref = _inside_rows_every_edge(np.linspace(lo[f, 0], hi[f, 0], 31), np.linspace(lo[f, 1], hi[f, 1], 31), a, b)
        p = np.pad(ref, 1, mode="edge")
        assert np.array_equal(dil[f], p[1:-1, 1:-1] | p[:-2, 1:-1] | p[2:, 1:-1] | p[1:-1, :-2] | p[1:-1, 2:])
        assert 0 < ref.sum() < ref.size


@pytest.mark.parametrize("tol_scale, edge_scale", [(1e-3, 1.0), (1e-3, 0.01), (1e-9, 0.03)])
def test_straight_lines_give_the_sampled_values(shared_data, tol_scale, edge_scale):
    # degree-1 directions (planes, the straight direction of cylinders) skip the interior samples of long
    # intervals (`IsoLines.straight_bound`): the same values as the full sampling of the numpy path;
    # at tol_scale 1e-9 the grid is fine enough that short intervals are sampled after all
    shell = read_shell(shared_data / "cad" / "trimesh__featuretype.STEP")
    d = shell.diagonal()
    n_straight = 0
    for face in shell.faces[:40]:
        s = face.surface
        lo, hi = grid_box(face)
        raster = _inside_raster(_loop_polys(face), lo, hi) if face.loops else None
        for axis in (0, 1):
            o = 1 - axis
            fam = IsoLines(s, axis, np.linspace(lo[o], hi[o], 9), raster)
            n_straight += fam.straight_bound() >= 0
            wf = None if raster is None else fam.weights
            kw = dict(tolerance=tol_scale * d, max_edge=edge_scale * d / np.sqrt(2.0),
                      init=np.linspace(lo[axis], hi[axis], 17))
            try:
                got = domain.adaptive_values(fam, lo[axis], hi[axis], weights_fn=wf, **kw)
            except InputError:
                with pytest.raises(InputError):
                    domain.adaptive_values(_Plain(fam), lo[axis], hi[axis], weights_fn=wf, **kw)
                continue
            assert np.array_equal(got, domain.adaptive_values(_Plain(fam), lo[axis], hi[axis], weights_fn=wf, **kw))
    assert n_straight >= 30


def test_loop_polylines_equal_model(t20, shared_data):
    # the face's loops sampled in one compiled call are Loop.polylines' points (the grid box and the
    # trim polygons of face_domain_values depend on them bit for bit)
    from trimsurf.tessellate.face import _loop_polylines

    faces = _faces(t20) + list(read_shell(shared_data / "cad" / "occt__screw.step").faces)
    n = 0
    for face in faces:
        if not face.loops:
            continue
        a, b = _loop_polylines(face, 32, 6)
        for loop, pa, pb in zip(face.loops, a, b):
            ra, rb = loop.polylines(32, 6)
            assert np.array_equal(pa, ra) and np.array_equal(pb, rb)
            n += len(loop.segments)
    assert n > 30
