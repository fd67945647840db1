"""Session 29 (issue 17): the lift's surface points through `_line_kernels._points0` (a parameter value's span
and basis computed once) equal the per-point evaluation they replace, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.model import NurbsSurface
from trimsurf.tessellate import face as face_mod


def _surfaces():
    rng = np.random.default_rng(17)
    out = []
    for trial in range(12):
        pu, pv = 1 + trial % 3, 1 + (trial // 3) % 3
        nu, nv = pu + 1 + int(rng.integers(0, 5)), pv + 1 + int(rng.integers(0, 5))

        def knots(p, n):
            inner = np.sort(rng.random(n - p - 1))
            if len(inner) > 1 and trial % 4 == 1:
                inner[1] = inner[0]                  # a repeated inner knot
            return np.r_[np.zeros(p + 1), inner, np.ones(p + 1)] * (1.0 + trial) - 0.5 * trial

        cp = rng.normal(size=(nu, nv, 3))
        w = rng.uniform(0.5, 2.0, size=(nu, nv)) if trial % 2 else None
        out.append(NurbsSurface(pu, pv, knots(pu, nu), knots(pv, nv), cp, w))
    return out


def _triangulation(s, rng, n_grid, n_free):
    """uv: trim-like points on a circle (first, the trim points), grid nodes (repeated u and v values),
    free points, a few outside the domain (clipped); Delaunay triangles."""
    from scipy.spatial import Delaunay

    u0, u1 = s.knots_u[s.degree_u], s.knots_u[-s.degree_u - 1]
    v0, v1 = s.knots_v[s.degree_v], s.knots_v[-s.degree_v - 1]
    a = np.linspace(0.0, 2 * np.pi, 40, endpoint=False)
    trim = np.c_[0.5 + 0.45 * np.cos(a), 0.5 + 0.45 * np.sin(a)]
    g = np.linspace(0.0, 1.0, n_grid)
    grid = np.array([(x, y) for x in g for y in g])
    free = rng.uniform(-0.05, 1.05, size=(n_free, 2))
    unit = np.concatenate([trim, grid, free])
    uv = np.c_[u0 + (u1 - u0) * unit[:, 0], v0 + (v1 - v0) * unit[:, 1]]
    uv[len(trim):len(trim) + 3] = [[u0, v0], [u1, v1], [s.knots_u[s.degree_u + 1], v0]]     # domain ends, a knot
    tris = Delaunay(unit).simplices.astype(np.int64)
    return uv, tris, len(trim)


def _lift_reference(s, uv, trim_xyz, tris, tol):
    """`_lift_points_numpy` with the start bounds from `NurbsSurface.evaluate` at `deviation_samples`' points
    (independent of `_points0`): (xyz, trim_off, maybe)."""
    from trimsurf.tessellate._mesh_kernels import deviation_samples

    nt = len(trim_xyz)
    xyz = s.evaluate(uv)
    trim_off = np.linalg.norm(xyz[:nt] - trim_xyz, axis=1)
    xyz[:nt] = trim_xyz
    suv, sx, rows = deviation_samples(face_mod._BARY, uv, xyz, tris)
    d = np.linalg.norm(s.evaluate(suv) - sx, axis=1)
    return xyz, trim_off, np.flatnonzero(~(d[rows].max(axis=1) <= tol))


def test_lift_points_equal_per_point_evaluation():
    """`_lift_points` (lift_kernel: S(uv) and the start bounds' samples through `_points0`) gives the arrays
    of `NurbsSurface.evaluate` per point, for the points and the start bounds' samples (the numbers of the
    per-point `_surface_point01` it replaced) on B-spline and rational surfaces, with grid
    nodes (shared values: the store's hits), more distinct values than the store's 256 slots (its
    collisions), points outside the domain (clipped) and on knots; with and without triangles."""
    rng = np.random.default_rng(3)
    n_maybe = n_not = 0
    for s in _surfaces():
        uv, tris, nt = _triangulation(s, rng, n_grid=int(rng.integers(5, 30)), n_free=int(rng.integers(50, 400)))
        exact = s.evaluate(uv[:nt])
        trim_xyz = exact + rng.normal(scale=1e-3, size=exact.shape) * (rng.random((nt, 1)) < 0.5)
        tol = float(rng.uniform(1e-3, 5e-2))
        got = face_mod._lift_points(s, uv, trim_xyz, tris, tol)
        ref = _lift_reference(s, uv, trim_xyz, tris, tol)
        for x, y in zip(got, ref):
            x, y = np.asarray(x), np.asarray(y)
            assert x.shape == y.shape and x.tobytes() == y.tobytes()
        n_maybe += len(ref[2])
        n_not += len(tris) - len(ref[2])
        got = face_mod._lift_points(s, uv, trim_xyz)          # the trim points not evaluated
        ref = face_mod._lift_points_numpy(s, uv, trim_xyz)
        assert got[0].tobytes() == ref[0].tobytes()
    assert n_maybe > 100 and n_not > 100


def test_lift_comparison_is_bitwise_sensitive():
    """The comparison above reads every bit: S evaluated one ulp away in u (what a wrong cached basis would
    give at the least) changes the arrays."""
    s = _surfaces()[4]
    rng = np.random.default_rng(5)
    uv, tris, nt = _triangulation(s, rng, n_grid=9, n_free=100)
    trim_xyz = s.evaluate(uv[:nt])
    ref = face_mod._lift_points_numpy(s, uv, trim_xyz)[0]
    moved = uv.copy()
    moved[nt:, 0] = np.nextafter(moved[nt:, 0], np.inf)
    assert face_mod._lift_points(s, moved, trim_xyz)[0].tobytes() != ref.tobytes()
