"""U_Joint edges 308 and 310: a Whitney polygon segment along a pole line, and the gap bound over it.

Face 96 of U_Joint is a rational biquadratic patch whose side v = -pi/2 is a pole (F(u, -pi/2) is one
point, the vertex where edges 308 and 310 start/end). The feet of the edge points next to that vertex
spread along the pole in u, so the face's Whitney polygon has a segment of length ~0.5 in u along
v = -pi/2. Bounded with the derivatives of the fixed pieces meeting that segment (F_uu ~ 3 there, away
from the pole) its chord remainder was 0.10, 4,000 times the file's tolerance 2.54e-5, while the gap
measured there is 3e-10: the bound was loose, not the model. Over the segment's own box F_uu -> 0.
"""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.certify import file_point_tolerance
from trimsurf.certify._boundary import sample_boundaries
from trimsurf.certify._bounds import box_bounds, max_over_boxes, surface_bounds
from trimsurf.certify._gap import BoundsCache, polygon_remainder
from trimsurf.certify._perturb import PerturbedFace
from trimsurf.io import read_shell

FACES = (96, 115, 116)


@pytest.fixture(scope="module")
def ujoint(shared_data):
    path = shared_data / "cad" / "gmsh__U_Joint_2.stp"
    shell = read_shell(path)
    tol = file_point_tolerance(path)
    bounds, edges, _ = sample_boundaries(shell, faces=FACES, point_tolerance=tol, max_chord=shell.diagonal() / 100)
    return shell, tol, bounds, {e.shell_edge: e for e in edges if e.shell_edge in (308, 310)}


def _gap(shell, bounds, e, s):
    pts = []
    for u in e.uses:
        poly = e.poly[(u.face, u.loop, u.seg)]
        uv = np.column_stack([np.interp(s, e.t, poly[:, 0]), np.interp(s, e.t, poly[:, 1])])
        pts.append(PerturbedFace(shell.faces[u.face], bounds[u.face], bounds[u.face].lipschitz).evaluate(uv))
    return np.linalg.norm(pts[0] - pts[1], axis=1)


def test_pole_edges_are_proven_within_the_file_tolerance(ujoint):
    shell, tol, bounds, edges = ujoint
    assert tol == pytest.approx(2.54e-5)
    v_pole = shell.faces[96].surface.domain[1][0]
    for k in (308, 310):
        e = edges[k]
        assert e.gap_bound <= tol, (k, e.gap_bound)                 # was 0.10
        # the reason it was loose: face 96's polygon runs along the pole line at the vertex
        use = next(u for u in e.uses if u.face == 96)
        poly = e.poly[(96, use.loop, use.seg)]
        on_pole = np.abs(poly[:, 1] - v_pole) < 1e-6
        assert np.ptp(poly[on_pole, 0]) > 0.1, poly[on_pole]
        end = 0 if on_pole[0] else -1
        assert on_pole[end] and not on_pole[len(poly) // 2]
        # measured <= bound on every interval: 64 points per interval, the pole intervals 20,001 points
        lam = np.linspace(0.0, 1.0, 64)[None, :]
        s = (e.t[:-1, None] + np.diff(e.t)[:, None] * lam).ravel()
        g = _gap(shell, bounds, e, s).reshape(len(e.t) - 1, -1).max(axis=1)
        assert np.all(g <= e.interval_bound), (k, np.max(g / e.interval_bound))
        i = 0 if end == 0 else len(e.t) - 2           # the interval at the pole vertex
        gi = _gap(shell, bounds, e, np.linspace(e.t[i], e.t[i + 1], 20001)).max()
        assert gi <= e.interval_bound[i] <= tol


def test_box_bounds_hold_and_vanish_on_the_pole_line(shared_data, ujoint):
    shell = ujoint[0]
    rng = np.random.default_rng(3)
    for f in FACES:
        s = shell.faces[f].surface
        (u0, u1), (v0, v1) = s.domain
        a = rng.uniform([u0, v0], [u1, v1], size=(12, 2))
        b = a + rng.uniform(0, 1, size=(12, 2)) ** 3 * ([u1, v1] - a)
        bb = box_bounds(s, a, b)
        for k in range(len(a)):
            uv = a[k] + (b[k] - a[k]) * rng.uniform(size=(4000, 2))
            d = s.derivatives(uv, 2)
            got = [np.linalg.norm(d[i, j], axis=1).max() for i, j in ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2))]
            assert np.all(np.array(got) <= bb[k] * (1 + 1e-9) + 1e-12), (f, k, got, bb[k])
    s = shell.faces[96].surface
    (u0, u1), (v0, _) = s.domain
    lo, hi = np.array([[3.354, v0]]), np.array([[3.916, v0]])
    assert box_bounds(s, lo, hi)[0, 2] < 1e-4 < 1.0 < max_over_boxes(surface_bounds(s), lo, hi)[0, 2]
    # the chord remainder along that pole segment: 0.1 before, ~0 over the segment's own box
    uv = np.array([[3.916, v0], [3.354, v0]])
    loose = polygon_remainder(s, uv, BoundsCache())[0]
    tight = polygon_remainder(s, uv, BoundsCache(), tighten=0.0)[0]
    assert tight < 1e-6 < 0.05 < loose
