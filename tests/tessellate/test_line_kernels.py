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
