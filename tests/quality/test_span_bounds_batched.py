"""`interpolation_bound.span_bounds` (points and weights differenced together, each cell's block gathered
once; multiplicities by searchsorted) against `_span_bounds_by_part`, the per-array version it replaces:
the same arrays bit for bit (session 27, issue 17 item 2)."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.io import read_shell
from trimsurf.model import NurbsSurface
from trimsurf.quality import interpolation_bound as ib
from trimsurf.samples import build_sample


def _same(a, b):
    assert a.shape == b.shape and a.dtype == b.dtype
    assert np.array_equal(np.ascontiguousarray(a).view(np.uint8), np.ascontiguousarray(b).view(np.uint8))


def _check(surface):
    x, y = ib.span_bounds(surface), ib._span_bounds_by_part(surface)
    for name in ("bu", "bv", "crease_u", "crease_v", "m"):
        _same(getattr(x, name), getattr(y, name))


@pytest.mark.parametrize("name", ["trimesh__featuretype.STEP", "gmsh__U_Joint_2.stp", "occt__bearing.iges"])
def test_span_bounds_real_surfaces(shared_data, name):
    faces = read_shell(shared_data / "cad" / name).faces
    if name != "occt__bearing.iges":
        assert any(f.surface.weights is not None for f in faces)
    for f in faces:
        _check(f.surface)


def test_span_bounds_samples_and_synthetic():
    for s in ("fender", "hood", "bspline_box"):
        for f in build_sample(s).faces:
            _check(f.surface)
    rng = np.random.default_rng(5)
    for pu, pv, nu, nv in [(1, 1, 2, 2), (3, 2, 7, 5), (2, 3, 6, 9), (3, 3, 8, 8)]:
        ku = np.r_[np.zeros(pu + 1), np.sort(rng.random(nu - pu - 1)), np.ones(pu + 1)]
        kv = np.r_[np.zeros(pv + 1), np.sort(rng.random(nv - pv - 1)), np.ones(pv + 1)]
        if nu - pu - 1 >= 2:        # a repeated interior knot (a crease when its multiplicity reaches pu)
            ku[pu + 2:pu + 1 + min(pu, nu - pu - 1)] = ku[pu + 1]
        ku.sort()
        cp = rng.normal(size=(nu, nv, 3))
        for w in (None, 0.2 + rng.random((nu, nv))):
            _check(NurbsSurface(pu, pv, ku, kv, cp, w))


def test_breaks_multiplicities():
    k = np.array([0, 0, 0, 0.3, 0.3, 0.5, 0.7, 0.7, 0.7, 1, 1, 1.0])
    for a, b in zip(ib._breaks(k, 2, 9), ib._breaks_by_count(k, 2, 9)):
        _same(a, b)
    assert list(ib._breaks(k, 2, 9)[2]) == [False, True, False, True, False]
