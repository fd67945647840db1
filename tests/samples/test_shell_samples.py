"""The trimmed-face samples: valid loops, edge curves on the surface, topology, the documented gap, a closed box."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from numpy.testing import assert_allclose

from trimsurf.errors import InputError
from trimsurf.geom import bezier_patch_points, points_in_polygons, polyline_self_intersections
from trimsurf.model import Shell
from trimsurf.samples import bspline_box, build_sample, fender, gap_pair, hood
from trimsurf.samples.bspline_box import BOX_HALF_SIZE
from trimsurf.samples.gap_pair import GAP_REL
from trimsurf.samples.hood import HOOD_DEGREES, hood_patches

SHELL_SAMPLES = ["fender", "hood", "gap_pair", "bspline_box"]
N_T = 801  # samples per segment when measuring curve distances


@pytest.fixture(scope="module", params=SHELL_SAMPLES)
def shell(request) -> Shell:
    return build_sample(request.param)


def _segment_gap(face, seg, n=N_T) -> np.ndarray:
    """|F(p(t)) - b(t)| along a segment."""
    t = seg.parameters(n)
    return np.linalg.norm(face.surface.evaluate(seg.evaluate(t)) - seg.edge_curve.evaluate(t), axis=1)


def _is_gap_edge(shell, seg) -> bool:
    return shell.name == "gap_pair" and seg.edge_id == 0


def test_loops_closed_and_oriented(shell):
    for face in shell.faces:
        assert face.loops, face.name
        for k, loop in enumerate(face.loops):
            # segment ends meet exactly by construction (shared control points); 1e-12 allows
            # rounding in evaluating a curve at its end parameter
            assert loop.is_closed(1e-12), (face.name, k, loop.gaps())
            area = loop.signed_area(64)
            assert (area > 0) if k == 0 else (area < 0), (face.name, k, area)
            assert not len(polyline_self_intersections(loop.polyline(64))), (face.name, k)


def test_holes_inside_outer_loop_and_pcurves_in_domain(shell):
    for face in shell.faces:
        (u0, u1), (v0, v1) = face.surface.domain
        outer = face.loops[0].polyline(64)
        for loop in face.loops:
            p = loop.polyline(64)
            assert np.all((p[:, 0] >= u0) & (p[:, 0] <= u1) & (p[:, 1] >= v0) & (p[:, 1] <= v1)), face.name
        for hole in face.holes:
            assert points_in_polygons(hole.polyline(64), [outer]).all(), face.name


def test_edge_curves_follow_the_surface(shell):
    """b(t) = F(p(t)) within the face tolerance on every segment, except the gap_pair's shared edge."""
    n_checked = 0
    for face in shell.faces:
        assert face.tolerance > 0
        for loop in face.loops:
            for seg in loop.segments:
                assert seg.edge_curve is not None
                lo, hi = seg.edge_curve.domain
                assert lo <= min(seg.t0, seg.t1) and max(seg.t0, seg.t1) <= hi  # same parameter range
                if _is_gap_edge(shell, seg):
                    continue
                assert _segment_gap(face, seg).max() <= face.tolerance, (face.name, seg.edge_id)
                n_checked += 1
    assert n_checked >= 4


def test_topology_references_are_consistent(shell):
    uses = set()
    for i, edge in enumerate(shell.edges):
        assert edge.t0 < edge.t1 and edge.curve is not None
        assert 1 <= len(edge.uses) <= 2
        for f, l, s in edge.uses:
            assert shell.faces[f].loops[l].segments[s].edge_id == i
            uses.add((f, l, s))
        assert all(0 <= v < len(shell.vertices) for v in edge.vertices)
    every = {(f, l, s) for f, face in enumerate(shell.faces) for l, loop in enumerate(face.loops)
             for s in range(len(loop))}
    assert uses == every
    # each vertex is within the face tolerance of the 3D ends of the segments meeting there
    # (gap_pair: within its documented gap)
    allowed = GAP_REL * shell.diagonal() * 1.01 if shell.name == "gap_pair" else shell.faces[0].tolerance
    for edge in shell.edges:
        for f, l, s in edge.uses:
            seg = shell.faces[f].loops[l].segments[s]
            ends = seg.edge_curve.evaluate([seg.t0, seg.t1])
            v = shell.vertices[list(edge.vertices)]
            d = np.minimum(np.linalg.norm(ends - v, axis=1), np.linalg.norm(ends - v[::-1], axis=1))
            assert d.max() <= allowed, (shell.name, edge.vertices, d)


def test_open_samples_have_only_free_edges():
    for shell in (fender(), hood()):
        assert len(shell.faces) == 1 and not shell.is_closed()
        assert shell.free_edges() == list(range(len(shell.edges)))


def test_fender_has_concave_arch_and_one_hole():
    shell = fender()
    face = shell.faces[0]
    assert len(face.loops) == 2 and len(face.outer_loop) >= 5
    poly = face.outer_loop.polyline(64)
    d0, d1 = np.roll(poly, -1, 0) - poly, np.roll(poly, -2, 0) - np.roll(poly, -1, 0)
    turn = d0[:, 0] * d1[:, 1] - d0[:, 1] * d1[:, 0]
    assert (turn < -1e-9).sum() > 10                # clockwise turns: a concave part (the arch)
    lo, hi = shell.bounding_box()
    assert 900 < np.max(hi - lo) < 1200             # about 1 m in mm
    assert face.surface.degree_u == face.surface.degree_v == 3


def test_hood_matches_its_bezier_patches_and_is_c1():
    patches, ub, vb = hood_patches()
    surface = hood().faces[0].surface
    assert max(max(d) for row in HOOD_DEGREES for d in row) == 7              # one patch of order 8
    assert len({d for row in HOOD_DEGREES for d in row}) >= 4                 # mixed degrees
    assert (surface.degree_u, surface.degree_v) == (7, 7)
    rng = np.random.default_rng(1)
    local = rng.random((50, 2))
    diag = hood().diagonal()
    for i, row in enumerate(patches):
        for j, cp in enumerate(row):
            assert cp.shape[:2] == (HOOD_DEGREES[i][j][0] + 1, HOOD_DEGREES[i][j][1] + 1)
            uv = np.column_stack([ub[i] + (ub[i + 1] - ub[i]) * local[:, 0], vb[j] + (vb[j + 1] - vb[j]) * local[:, 1]])
            # conversion is exact up to rounding in degree elevation and evaluation
            assert_allclose(surface.evaluate(uv), bezier_patch_points(cp, local), rtol=0, atol=1e-9 * diag)
    # C1 across every interior break: one-sided first derivatives agree (the joints are C1 by
    # construction; 1e-7 of the derivative scale allows the one-sided difference quotient)
    h = 1e-7
    t = np.linspace(0.01, 0.99, 25)
    for b in ub[1:-1]:
        left = surface.evaluate(np.column_stack([np.full_like(t, b - h), t]))
        mid = surface.evaluate(np.column_stack([np.full_like(t, b), t]))
        right = surface.evaluate(np.column_stack([np.full_like(t, b + h), t]))
        assert_allclose((mid - left) / h, (right - mid) / h, rtol=0, atol=1e-3 * diag)
    for b in vb[1:-1]:
        left = surface.evaluate(np.column_stack([t, np.full_like(t, b - h)]))
        mid = surface.evaluate(np.column_stack([t, np.full_like(t, b)]))
        right = surface.evaluate(np.column_stack([t, np.full_like(t, b + h)]))
        assert_allclose((mid - left) / h, (right - mid) / h, rtol=0, atol=1e-3 * diag)


def _gaps(shell):
    """Per face, |F_k(p_k(t)) - b(t)| along the shared edge, at common t."""
    edge = shell.edges[0]
    t = np.linspace(edge.t0, edge.t1, N_T)
    out = []
    for f, l, s in edge.uses:
        face = shell.faces[f]
        seg = face.loops[l].segments[s]
        out.append(face.surface.evaluate(seg.evaluate(t)) - edge.curve.evaluate(t))
    return out


def test_gap_pair_has_the_documented_gap():
    shell = gap_pair()
    diag = shell.diagonal()
    assert len(shell.faces) == 2 and len(shell.edges) == 7 and len(shell.vertices) == 6
    edge = shell.edges[0]
    assert edge.faces == (0, 1) and shell.free_edges() == [1, 2, 3, 4, 5, 6]
    assert shell.adjacency() == {0: {1}, 1: {0}}
    d1, d2 = _gaps(shell)
    g1, g2 = np.linalg.norm(d1, axis=1), np.linalg.norm(d2, axis=1)
    # the largest gap is GAP_REL * diagonal to 1% (the sample scales the insets to it from a sampled maximum)
    for g in (g1, g2):
        assert abs(g.max() / (GAP_REL * diag) - 1) < 0.01
        assert g.min() > 0.1 * g.max() and g.min() < 0.6 * g.max()    # never closes, varies along the edge
    between = np.linalg.norm(d1 - d2, axis=1)
    assert GAP_REL * diag < between.max() <= 2.02 * GAP_REL * diag
    # the gap is far above the stated tolerance: the edge is inconsistent
    assert edge.tolerance < 0.01 * GAP_REL * diag
    # face 0 runs with b(t), face 1 against it
    seg0 = shell.faces[0].loops[0].segments[1]
    seg1 = shell.faces[1].loops[0].segments[3]
    assert seg0.t0 < seg0.t1 and seg1.t0 > seg1.t1
    assert seg0.edge_curve is edge.curve and seg1.edge_curve is edge.curve


@settings(max_examples=8, deadline=None)
@given(st.floats(1e-4, 1e-2))
def test_gap_pair_gap_follows_the_option(gap_rel):
    shell = gap_pair(gap_rel=gap_rel)
    g = max(np.linalg.norm(d, axis=1).max() for d in _gaps(shell))
    assert abs(g / (gap_rel * shell.diagonal()) - 1) < 0.01


@pytest.mark.parametrize("bad", [0.0, -1e-3, 0.1, float("nan")])
def test_gap_pair_rejects_bad_gap(bad):
    with pytest.raises(InputError, match="gap_rel"):
        gap_pair(gap_rel=bad)


def _oriented_volume(shell, n_gauss=8):
    """Volume by the divergence theorem, (1/3) sum over faces of int F . n dA with outward n (Gauss-Legendre)."""
    x, w = np.polynomial.legendre.leggauss(n_gauss)
    x, w = (x + 1) / 2, w / 2
    vol = 0.0
    for face in shell.faces:
        s = face.surface
        for ku, kv in [(np.unique(s.knots_u), np.unique(s.knots_v))]:
            for a, b in zip(ku[:-1], ku[1:]):
                for c, d in zip(kv[:-1], kv[1:]):
                    uu, vv = np.meshgrid(a + (b - a) * x, c + (d - c) * x, indexing="ij")
                    ww = np.outer(w, w).ravel() * (b - a) * (d - c)
                    der = s.derivatives(np.column_stack([uu.ravel(), vv.ravel()]), 1)
                    n = np.cross(der[1, 0], der[0, 1]) * (1.0 if face.same_sense else -1.0)
                    vol += np.sum(ww * np.einsum("ij,ij->i", der[0, 0], n)) / 3.0
    return vol


def test_box_is_closed_and_outward():
    shell = bspline_box()
    assert shell.is_closed() and len(shell.faces) == 6 and len(shell.edges) == 12 and len(shell.vertices) == 8
    assert not shell.non_manifold_edges() and all(len(e.uses) == 2 for e in shell.edges)
    assert all(len(v) == 4 for v in shell.adjacency().values())
    # the faces bulge outward, so the volume exceeds the box's; on each knot span the integrand
    # F . (Su x Sv) is a polynomial of degree <= 8 in u and in v, integrated exactly by 8 x 8
    # Gauss points, so 12 x 12 agrees to rounding
    box = 8 * np.prod(BOX_HALF_SIZE)
    vol = _oriented_volume(shell)
    assert box < vol < 1.6 * box
    assert_allclose(_oriented_volume(shell, 12), vol, rtol=1e-12, atol=0)
    # outward normals at the face centres point away from the centre of the solid
    for face in shell.faces:
        p = face.surface.evaluate([[0.5, 0.5]])
        assert float(face.oriented_normals([[0.5, 0.5]])[0] @ p[0]) > 0, face.name


def test_box_edges_are_shared_exactly_and_run_opposite():
    shell = bspline_box()
    for edge in shell.edges:
        (fa, la, sa), (fb, lb, sb) = edge.uses
        A, B = shell.faces[fa], shell.faces[fb]
        a, b = A.loops[la].segments[sa], B.loops[lb].segments[sb]
        pa = a.edge_curve.evaluate(a.parameters(33))
        pb = b.edge_curve.evaluate(b.parameters(33))
        pa_surface = A.surface.evaluate(a.evaluate(a.parameters(33)))
        pb_surface = B.surface.evaluate(b.evaluate(b.parameters(33)))
        # exact iso-curves with bit-identical control points: equal to rounding
        assert_allclose(pa, pa_surface, rtol=0, atol=1e-10)
        assert_allclose(pb, pb_surface, rtol=0, atol=1e-10)
        # a consistently oriented closed shell runs each edge once each way (same_sense flips a face)
        ra = pa if A.same_sense else pa[::-1]
        rb = pb if B.same_sense else pb[::-1]
        assert_allclose(ra, rb[::-1], rtol=0, atol=1e-10)


def test_samples_are_deterministic():
    a, b = gap_pair(), gap_pair()
    for fa, fb in zip(a.faces, b.faces):
        assert np.array_equal(fa.surface.control_points, fb.surface.control_points)
    assert np.array_equal(a.vertices, b.vertices)
