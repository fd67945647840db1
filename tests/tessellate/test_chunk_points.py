"""The chunk kernel's written-out point code (`_chunk_kernels._curve_uv` / `_uv_batch`, `_surface_xyz` /
`_shared_points`, `_probe_extent`) against the compiled calls it replaces (`ChunkUse.points`:
`_curve_point` then `_surface_point01` in `pcurve_surface_kernel`): the same numbers bit for bit on every
use of real models (rational and polynomial p-curves and surfaces), parameters outside [0, 1] included
(the clipping)."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from trimsurf.io import read_shell
from trimsurf.tessellate._chunk_kernels import _probe_extent, _scratch, _shared_points, _uv_batch
from trimsurf.tessellate.face import face_domain_values
from trimsurf.tessellate.trims import ChunkUse, _batch_arrays


@njit(cache=False)
def _use_points(ci, cf, ck, cpw, cku, ckv, cpw4, j, s):
    """uv and xyz of use j at s through `_uv_batch` and `_shared_points` (o_pts starts at -0.0: the sum
    -0.0 + x is x bit for bit, so the use's own points come out whatever j is)."""
    w = _scratch(ci)
    n = s.shape[0]
    uvs = np.empty((j + 1, n, 2))
    _uv_batch(ci, cf, ck, cpw, j, s, uvs[j], w)
    o_pts = np.full((n, 5), -0.0)
    o_uv = np.empty(((j + 1) * n, 2))
    _shared_points(ci, cku, ckv, cpw4, j, uvs, o_pts, o_uv, w)
    return uvs[j].copy(), o_pts[:, 1:4].copy(), o_uv[j * n:(j + 1) * n].copy()


@njit(cache=False)
def _probe(ci, cf, ck, cpw, cku, ckv, cpw4, j, s33, thr):
    return _probe_extent(ci, cf, ck, cpw, cku, ckv, cpw4, j, s33, thr, 0.0, _scratch(ci))


def _uses(shell):
    d = shell.diagonal()
    grids, uses = {}, []
    for e in shell.edges:
        for fi, li, si in e.uses:
            f = shell.faces[fi]
            if fi not in grids:
                grids[fi] = face_domain_values(f, tolerance=0.97e-3 * d, max_edge=d)
            us, vs = grids[fi]
            (u0, u1), (v0, v1) = f.surface.domain
            uses.append(ChunkUse(fi, li, si, f.loops[li].segments[si], f.surface, us, vs, 1e-7 * min(u1 - u0, v1 - v0)))
    return uses


@pytest.mark.parametrize("model", ["gmsh__t20_data.step", "occt__screw.step"])
def test_written_out_points_equal_compiled_calls(shared_data, model):
    uses = _uses(read_shell(shared_data / "cad" / model))
    ci, cf, ck, cpw, cku, ckv, cpw4, *_ = _batch_arrays([[u] for u in uses])
    s = np.r_[-0.25, -1e-12, np.linspace(0.0, 1.0, 41), 0.123456789, 1.0 + 1e-12, 1.5]
    kinds = set()
    for j, u in enumerate(uses):
        ref_uv, ref_xyz = u.points(s)
        uv, xyz, o_uv = _use_points(ci, cf, ck, cpw, cku, ckv, cpw4, np.int64(j), s)
        assert uv.tobytes() == ref_uv.tobytes() == o_uv.tobytes(), j
        assert xyz.tobytes() == ref_xyz.tobytes(), j
        kinds.add((u.pcurve.curve.weights is not None, u.surface.weights is not None, u.pcurve.curve.degree > 1,
                   u.surface.degree_u > 1 or u.surface.degree_v > 1))
    # both kinds of surface (rational: cylinders, cones; polynomial: planes) and of p-curve degree were run
    assert {k[1] for k in kinds} == {False, True} and {k[2] for k in kinds} == {False, True}, kinds


def test_probe_extent_equals_numpy_extent(shared_data):
    """`_probe_extent` from 0: the 3D extent of the 33 probe points as `_discretize_chunk_numpy` computes it
    (max distance from the first point) where it stays <= thr, and above thr once it is."""
    uses = _uses(read_shell(shared_data / "cad" / "occt__screw.step"))
    ci, cf, ck, cpw, cku, ckv, cpw4, *_ = _batch_arrays([[u] for u in uses])
    s33 = np.linspace(0.0, 1.0, 33)
    for j, u in enumerate(uses[:60]):
        xyz = u.xyz(s33)
        d = xyz - xyz[0]
        ext = float(np.max(np.sqrt((d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2])))
        got = _probe(ci, cf, ck, cpw, cku, ckv, cpw4, np.int64(j), s33, np.inf)
        assert got == ext, j
        # a threshold below the extent: it stops above it (the first point past it), never below
        thr = 0.5 * ext
        got = _probe(ci, cf, ck, cpw, cku, ckv, cpw4, np.int64(j), s33, thr)
        assert (got > thr) == (ext > thr) and got <= ext, j
