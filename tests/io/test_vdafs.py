"""VDA-FS subset (SURF, CURVE, CONS, FACE): layout, exact round trips, defects and bad input."""

from __future__ import annotations

import itertools
import math
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from trimsurf.errors import GeometryError, InputError, TrimsurfWarning, VdafsReadError
from trimsurf.geom.bezier import bezier_patch_points, monomial_to_bezier
from trimsurf.geom.knots import bezier_curve_to_nurbs, bezier_grid_to_nurbs
from trimsurf.io import _vdafs, read_shell, write_shell
from trimsurf.model import Loop, NurbsCurve, NurbsSurface, PCurve, Shell, TrimmedFace

# ------------------------------------------------------------------------------------------------
# a hand-written VDA-FS file: the layout is pinned here independently of the writer
# ------------------------------------------------------------------------------------------------

S_BREAKS = [0.0, 0.5, 2.0]
T_BREAKS = [-1.0, 0.0, 0.25, 1.0]
# global cubic z(s, t) = sum C[k, l] s^k t^l; x = s, y = t
CZ = np.zeros((4, 4))
CZ[0, 0], CZ[3, 0], CZ[1, 2], CZ[0, 3], CZ[2, 1] = 0.1, 0.3, -0.2, 0.5, 0.25
H5 = np.array([0.0, 0.0, 1.0, -1.0, -1.0, 1.0])  # u^2 (1-u)^2 (1+u): zero value and slope at 0 and 1
G3 = np.array([0.0, 1.0, -1.0])  # v (1 - v): zero at 0 and 1
# quintic bumps on some patches make the SURF mix orders (4, 4), (6, 4) and (6, 6)
BUMPS = {(1, 1): 0.05 * np.outer(H5, H5), (0, 2): -0.08 * np.outer(H5, H5), (1, 2): 0.03 * np.outer(H5, G3)}


def _shift(x0: float, h: float, order: int) -> np.ndarray:
    """T with local monomial coefficients a = T c of a polynomial sum c_k x^k, x = x0 + h u."""
    t = np.zeros((order, order))
    for j in range(order):
        for k in range(j, order):
            t[j, k] = math.comb(k, j) * x0 ** (k - j) * h ** j
    return t


def _patch_monomials() -> dict[tuple[int, int], np.ndarray]:
    """(i, j) -> (3, order_s, order_t) local monomial coefficients of the fixture SURF."""
    out = {}
    for i, j in itertools.product(range(2), range(3)):
        s0, s1 = S_BREAKS[i], S_BREAKS[i + 1]
        t0, t1 = T_BREAKS[j], T_BREAKS[j + 1]
        bump = BUMPS.get((i, j))
        ou = 4 if bump is None else max(4, bump.shape[0])
        ov = 4 if bump is None else max(4, bump.shape[1])
        a = np.zeros((3, ou, ov))
        a[0, :2, 0] = [s0, s1 - s0]
        a[1, 0, :2] = [t0, t1 - t0]
        a[2, :4, :4] = _shift(s0, s1 - s0, 4) @ CZ @ _shift(t0, t1 - t0, 4).T
        if bump is not None:
            a[2, :bump.shape[0], :bump.shape[1]] += bump
        out[i, j] = a
    return out


def _cubic_bezier_monomials(points) -> np.ndarray:
    """(2, 4) monomial coefficients of a 2D cubic Bezier segment (local u in [0, 1])."""
    p = np.asarray(points, dtype=float)
    return np.array([p[0], 3 * (p[1] - p[0]), 3 * (p[0] - 2 * p[1] + p[2]), p[3] - p[0] + 3 * (p[1] - p[2])]).T


def _curve_k1() -> list[np.ndarray]:
    """3D CURVE of the bottom CONS, on sigma in [10, 20] running against it (sigma = 20 at w = 0)."""
    segs = []
    for a, b in ((1.9, -0.9), (1.0, -0.9)):  # s = a + b r on each segment
        zc = CZ @ ((-0.9) ** np.arange(4))  # z(s, -0.9) as a cubic in s
        z = np.polynomial.Polynomial(zc)(np.polynomial.Polynomial([a, b])).coef
        seg = np.zeros((3, 4))
        seg[0, :2] = [a, b]
        seg[1, 0] = -0.9
        seg[2, :len(z)] = z
        segs.append(seg)
    return segs


HOLE = ((1.0, 0.1), 0.3)


def _fixture_statements() -> list[tuple[str, str, list[str] | None]]:
    f = repr
    surf = ["2", "3"] + [f(x) for x in S_BREAKS] + [f(x) for x in T_BREAKS]
    mono = _patch_monomials()
    for j in range(3):
        for i in range(2):
            a = mono[i, j]
            surf += [str(a.shape[1]), str(a.shape[2])]
            surf += [f(float(x)) for c in range(3) for x in a[c].T.ravel()]  # u-power fastest
    k1 = ["2", "10.0", "15.0", "20.0"]
    for seg in _curve_k1():
        k1 += ["4"] + [f(float(x)) for x in seg.ravel()]
    (cx, cy), r = HOLE
    k = 4.0 / 3.0 * r
    lower = _cubic_bezier_monomials([(cx + r, cy), (cx + r, cy - k), (cx - r, cy - k), (cx - r, cy)])
    upper = _cubic_bezier_monomials([(cx - r, cy), (cx - r, cy + k), (cx + r, cy + k), (cx + r, cy)])

    def cons(name, curve, s12, breaks, segs):
        tokens = ["S1", curve, f(s12[0]), f(s12[1]), str(len(segs))] + [f(x) for x in breaks]
        for seg in segs:
            seg = np.asarray(seg, dtype=float)
            tokens += [str(seg.shape[1])] + [f(float(x)) for x in seg.ravel()]
        return (name, "CONS", tokens)

    return [
        ("S1", "SURF", surf),
        ("K1", "CURVE", k1),
        cons("C1", "K1", (20.0, 10.0), [0.0, 1.0], [[[0.1, 1.8], [-0.9, 0.0]]]),
        cons("C2", "", (2.0, 5.0), [2.0, 3.5, 5.0], [[[1.9, 0.0], [-0.9, 0.9]],
                                                     [[1.9, -0.2, 0.2], [0.0, 0.9, 0.0]]]),
        cons("C3", "", (0.0, 1.0), [0.0, 1.0], [[[0.1, 1.8], [0.9, 0.0]]]),
        cons("C4", "", (-1.0, 0.0), [-1.0, 0.0], [[[0.1, 0.0], [0.9, -1.8]]]),
        cons("H1", "", (0.0, 1.0), [0.0, 1.0], [lower]),
        cons("H2", "", (0.0, 1.0), [0.0, 1.0], [upper]),
        ("F1", "FACE", ["S1", "2", "4", "C1", "0.0", "1.0", "C2", "2.0", "5.0", "C3", "1.0", "0.0",
                        "C4", "-1.0", "0.0", "2", "H1", "0.0", "1.0", "H2", "0.0", "1.0"]),
        ("S2", "SURF", ["1", "1", "0.0", "1.0", "0.0", "1.0", "2", "2",
                        "5.0", "1.0", "0.0", "0.0", "0.0", "0.0", "1.0", "0.0", "0.0", "0.0", "0.0", "0.0"]),
    ]


def _vda_text(statements, *, header=("hand-written trimsurf test file",)) -> str:
    """Records of 80 columns: statement text in 1-72 (continued after a comma), number in 73-80."""
    lines = [f"{'TEST':<8} = HEADER / {len(header)}", *header]
    for name, keyword, tokens in statements:
        if tokens is None:
            lines.append(f"{name:<8} = {keyword}")
            continue
        current = f"{name:<8} = {keyword} /"
        for i, token in enumerate(tokens):
            piece = token + ("," if i < len(tokens) - 1 else "")
            if len(current) + 1 + len(piece) > 72:
                lines.append(current)
                current = " " + piece
            else:
                current += " " + piece
        lines.append(current)
    lines.append(f"{'TEST':<8} = END")
    return "".join(f"{line:<72}{n:08d}\n" for n, line in enumerate(lines, start=1))


def _write(tmp_path, text: str, name: str = "fixture.vda"):
    path = tmp_path / name
    path.write_text(text, encoding="ascii")
    return path


@pytest.fixture
def fixture_file(tmp_path):
    return _write(tmp_path, _vda_text(_fixture_statements()))


def _eval_monomials(st_points: np.ndarray) -> np.ndarray:
    """The fixture SURF evaluated straight from its monomial coefficients (independent of the reader)."""
    mono = _patch_monomials()
    out = np.empty((len(st_points), 3))
    for n, (s, t) in enumerate(st_points):
        i = min(int(np.searchsorted(S_BREAKS, s, side="right")) - 1, 1)
        j = min(int(np.searchsorted(T_BREAKS, t, side="right")) - 1, 2)
        u = (s - S_BREAKS[i]) / (S_BREAKS[i + 1] - S_BREAKS[i])
        v = (t - T_BREAKS[j]) / (T_BREAKS[j + 1] - T_BREAKS[j])
        a = mono[i, j]
        out[n] = np.einsum("cjm,j,m->c", a, u ** np.arange(a.shape[1]), v ** np.arange(a.shape[2]))
    return out


def _random_st(rng, n: int) -> np.ndarray:
    return np.column_stack([rng.uniform(S_BREAKS[0], S_BREAKS[-1], n), rng.uniform(T_BREAKS[0], T_BREAKS[-1], n)])


# ------------------------------------------------------------------------------------------------
# reading the hand-written file: layout, monomial convention, trims
# ------------------------------------------------------------------------------------------------


def test_read_mixed_order_surf_matches_monomial_evaluation(fixture_file):
    shell = _vdafs.read(fixture_file)
    assert [f.name for f in shell.faces] == ["F1", "S2"]
    assert not shell.has_topology
    surf = shell.faces[0].surface
    assert (surf.degree_u, surf.degree_v) == (5, 5)  # orders 4 and 6 raised to the highest
    assert_allclose(surf.knots_u, [0.0] * 6 + [0.5] * 5 + [2.0] * 6, rtol=0, atol=0)
    assert_allclose(surf.knots_v, [-1.0] * 6 + [0.0] * 5 + [0.25] * 5 + [1.0] * 6, rtol=0, atol=0)
    st_pts = _random_st(np.random.default_rng(1), 300)
    # coefficients are O(1), degree <= 5: float evaluation of either form is good to ~1e-15
    assert_allclose(surf.evaluate(st_pts), _eval_monomials(st_pts), rtol=0, atol=1e-13)


def test_read_untrimmed_surf_is_a_face_without_loops(fixture_file):
    face = _vdafs.read(fixture_file).faces[1]
    assert face.loops == ()
    # x = 5 + s, y = t, z = 0 (bilinear, u-power fastest: ax(1,1), ax(2,1), ax(1,2), ax(2,2))
    assert_allclose(face.surface.evaluate([[0.25, 0.75]]), [[5.25, 0.75, 0.0]], rtol=0, atol=1e-15)


def test_read_trim_loops_cons_and_face_ranges(fixture_file):
    face = _vdafs.read(fixture_file).faces[0]
    outer, hole = face.loops
    assert len(outer) == 4 and len(hole) == 2
    # the 2D CONS is in the SURF's (s, t) with its own parameter w; C3 is used reversed (w1 > w2)
    starts = np.array([seg.start for seg in outer.segments])
    assert_allclose(starts, [[0.1, -0.9], [1.9, -0.9], [1.9, 0.9], [0.1, 0.9]], rtol=0, atol=1e-15)
    assert (outer.segments[2].t0, outer.segments[2].t1) == (1.0, 0.0)
    assert outer.segments[1].curve.domain == (2.0, 5.0)
    assert outer.segments[1].curve.degree == 2  # orders 2 and 3 unified
    assert_allclose(outer.segments[1].evaluate([4.25]), [[1.9 - 0.2 * 0.25, 0.45]], rtol=0, atol=1e-15)
    assert outer.signed_area() > 0 > hole.signed_area()
    assert_allclose(hole.gaps(), 0.0, rtol=0, atol=1e-15)  # ends from float monomials meet to rounding


def test_read_cons_curve_is_reparameterized_onto_the_cons_parameter(fixture_file):
    face = _vdafs.read(fixture_file).faces[0]
    seg = face.loops[0].segments[0]
    assert seg.edge_curve is not None
    assert seg.edge_curve.domain == (0.0, 1.0)  # CURVE sigma in [10, 20] runs against w in [0, 1]
    w = np.linspace(0.0, 1.0, 41)
    # b(w) = F(p(w)): coefficients O(1), cubic; rounding only
    assert_allclose(seg.edge_curve.evaluate(w), face.surface.evaluate(seg.evaluate(w)), rtol=0, atol=1e-13)
    assert all(s.edge_curve is None for s in face.loops[0].segments[1:])


def test_read_fortran_number_forms(tmp_path):
    coeffs = ["1.D0", "+0.5d+00", "2.", "-.5E-1", "0", "1.0E+00", "0.", "1.25D0", "0.0", "0.", "0.", "0."]
    path = _write(tmp_path, _vda_text([("S1", "SURF", ["1", "1", "0.", "1.D0", "0", "1E0", "2", "2"] + coeffs)]))
    surf = _vdafs.read(path).faces[0].surface
    # x = 1 + 0.5 u + 2 v - 0.05 u v, y = 0 + u + 0 v + 1.25 u v, z = 0
    expected = [[1 + 0.5 * 0.5 + 2 * 0.25 - 0.05 * 0.125, 0.5 + 1.25 * 0.125, 0.0]]
    assert_allclose(surf.evaluate([[0.5, 0.25]]), expected, rtol=0, atol=1e-15)


def test_read_comments_blank_records_sets_and_short_records(tmp_path):
    text = _vda_text(_fixture_statements()).splitlines()
    text.insert(3, "$$ a comment record")
    text.insert(4, "")
    text = [line[:72].rstrip() for line in text]  # no sequence field, no trailing blanks: allowed
    text.insert(2, "SET1     = BEGINSET")
    text.insert(-1, "SET1     = ENDSET $$ closing the set")
    path = _write(tmp_path, "\n".join(text) + "\n")
    assert [f.name for f in _vdafs.read(path).faces] == ["F1", "S2"]


def test_read_skips_known_entities_and_warns_on_unknown(tmp_path):
    statements = _fixture_statements() + [("P1", "POINT", ["1.0", "2.0", "3.0"]), ("W1", "WIDGET", ["1"])]
    path = _write(tmp_path, _vda_text(statements))
    with pytest.warns(TrimsurfWarning, match=r"WIDGET W1: entity type outside the VDA-FS subset"):
        shell = _vdafs.read(path)
    assert len(shell.faces) == 2


# ------------------------------------------------------------------------------------------------
# defects of real data: warnings naming the entity
# ------------------------------------------------------------------------------------------------


def _modified(statements, name, index, value):
    out = []
    for n, k, tokens in statements:
        if n == name:
            tokens = list(tokens)
            tokens[index] = value
        out.append((n, k, tokens))
    return out


def test_read_trim_loop_with_gap_warns_naming_face_and_gap(tmp_path):
    # C4 ends at t = 0.9 - 1.8 + 0.01: a gap of 0.01 before C1 starts
    statements = _modified(_fixture_statements(), "C4", 11, repr(-1.79))
    path = _write(tmp_path, _vda_text(statements))
    with pytest.warns(TrimsurfWarning, match=r"FACE F1: trim loop 1 is not closed: gap 0\.01 .*after CONS C4"):
        face = _vdafs.read(path).faces[0]
    assert_allclose(face.loops[0].gaps().max(), 0.01, rtol=1e-12, atol=0)


def test_read_surf_patches_that_do_not_meet_warn(tmp_path):
    statements = _fixture_statements()
    surf = list(statements[0][2])
    surf[11] = repr(float(surf[11]) + 0.5)  # constant x coefficient of the first patch: off by 0.5
    path = _write(tmp_path, _vda_text([("S1", "SURF", surf)]))
    with pytest.warns(TrimsurfWarning, match=r"SURF S1: adjacent patches \(1, 1\) and \(2, 1\) do not meet: "
                                             r"largest gap 0\.5 "):
        face = _vdafs.read(path).faces[0]
    # recorded for repair (`trimsurf.tessellate.repair` rejects faces that use the broken boundary)
    grid = face.surface.patch_grid
    assert_allclose(grid.gaps_s.max(), 0.5, rtol=1e-12)
    assert grid.gaps_t.max() <= 0.5 + 1e-12 and grid.breaks_problem() == ""


def test_read_surf_breakpoints_not_increasing_warn_and_are_recorded(tmp_path):
    """Not a read error: the FACE on the SURF is rejected by repair, the rest of the file is read."""
    path = _write(tmp_path, _vda_text(_modified(_fixture_statements(), "S1", 2, "1.0")))
    with pytest.warns(TrimsurfWarning, match=r"SURF S1: its s breakpoints do not increase strictly: "
                                             r"s\(1\) = 1\.0, s\(2\) = 0\.5; faces on it cannot be tessellated"):
        shell = _vdafs.read(path)
    assert [f.name for f in shell.faces] == ["F1", "S2"]
    assert_allclose(shell.faces[0].surface.patch_grid.s_breaks, [1.0, 0.5, 2.0])
    assert shell.faces[1].surface.patch_grid.breaks_problem() == ""


def test_read_zero_length_cons_in_loop_warns_and_is_left_out(tmp_path):
    statements = _fixture_statements()
    face = list(statements[8][2])
    face[3:3] = ["C3", "0.5", "0.5"]  # a degenerate use of C3 before C1
    face[2] = "5"
    statements[8] = ("F1", "FACE", face)
    path = _write(tmp_path, _vda_text(statements))
    with pytest.warns(TrimsurfWarning, match=r"CONS C3 is used over the empty range"):
        out = _vdafs.read(path).faces[0]
    assert len(out.loops[0]) == 4


def test_read_cons_range_outside_its_curve_warns(tmp_path):
    path = _write(tmp_path, _vda_text(_modified(_fixture_statements(), "C1", 2, "25.0")))
    with pytest.warns(TrimsurfWarning, match=r"CONS C1: its range \[25\.0, 10\.0\] on CURVE K1 exceeds the "
                                             r"curve's domain \[10\.0, 20\.0\]"):
        _vdafs.read(path)


def _with_face(statements, face_tokens):
    return [(n, k, face_tokens if n == "F1" else t) for n, k, t in statements]


def _same_loop(a: Loop, b: Loop) -> bool:
    return len(a) == len(b) and all(
        (s.t0, s.t1) == (r.t0, r.t1) and np.array_equal(s.curve.control_points, r.curve.control_points)
        and (s.edge_curve is None) == (r.edge_curve is None) for s, r in zip(a.segments, b.segments))


def test_read_clockwise_loops_are_normalised_to_the_model_orientation(tmp_path):
    # the fixture's loops run the other way: outer loop clockwise (C4, C3, C2, C1 each reversed), hole
    # counter-clockwise (H2, H1 reversed); the reader reverses both, giving back the fixture's loops exactly
    cw = ["S1", "2", "4", "C4", "0.0", "-1.0", "C3", "0.0", "1.0", "C2", "5.0", "2.0", "C1", "1.0", "0.0",
          "2", "H2", "1.0", "0.0", "H1", "1.0", "0.0"]
    reference = _vdafs.read(_write(tmp_path, _vda_text(_fixture_statements()))).faces[0]
    face = _vdafs.read(_write(tmp_path, _vda_text(_with_face(_fixture_statements(), cw)), "cw.vda")).faces[0]
    outer, hole = face.loops
    assert outer.signed_area() > 0 > hole.signed_area()
    assert _same_loop(outer, reference.loops[0]) and _same_loop(hole, reference.loops[1])
    assert outer.is_closed(1e-15) and hole.is_closed(1e-15)  # gaps 0 to rounding, as in the fixture


def test_read_only_the_sense_of_a_wrong_loop_is_changed(tmp_path):
    # outer loop as in the fixture (counter-clockwise), hole counter-clockwise: only the hole is reversed
    face_tokens = list(_fixture_statements()[8][2])
    face_tokens[16:22] = ["H2", "1.0", "0.0", "H1", "1.0", "0.0"]
    face = _vdafs.read(_write(tmp_path, _vda_text(_with_face(_fixture_statements(), face_tokens)))).faces[0]
    assert [s.t0 for s in face.loops[0].segments] == [0.0, 2.0, 1.0, -1.0]
    assert [(s.t0, s.t1) for s in face.loops[1].segments] == [(0.0, 1.0), (0.0, 1.0)]


def test_read_hole_listed_before_the_outer_loop_warns(tmp_path):
    # file order makes the small circle the outer loop: the big loop cannot be a hole inside it
    swapped = ["S1", "2", "2", "H1", "0.0", "1.0", "H2", "0.0", "1.0",
               "4", "C1", "0.0", "1.0", "C2", "2.0", "5.0", "C3", "1.0", "0.0", "C4", "-1.0", "0.0"]
    path = _write(tmp_path, _vda_text(_with_face(_fixture_statements(), swapped)))
    with pytest.warns(TrimsurfWarning, match=r"FACE F1: trim loop 2 \(a hole\) is not inside the outer trim loop 1"):
        face = _vdafs.read(path).faces[0]
    # roles still follow the file order: first loop counter-clockwise, the other clockwise
    assert face.loops[0].signed_area() > 0 > face.loops[1].signed_area()


def test_read_hole_inside_another_hole_warns(tmp_path):
    statements = _fixture_statements()
    nested = list(statements[8][2]) + ["2", "H1", "0.0", "1.0", "H2", "0.0", "1.0"]
    nested[1] = "3"
    # a third loop: the hole circle at half the radius (CONS H3, H4), inside the hole of loop 2
    (cx, cy), r = HOLE
    k = 4.0 / 3.0 * (r / 2)
    lower = _cubic_bezier_monomials([(cx + r / 2, cy), (cx + r / 2, cy - k), (cx - r / 2, cy - k), (cx - r / 2, cy)])
    upper = _cubic_bezier_monomials([(cx - r / 2, cy), (cx - r / 2, cy + k), (cx + r / 2, cy + k), (cx + r / 2, cy)])
    extra = [(name, "CONS", ["S1", "", "0.0", "1.0", "1", "0.0", "1.0", "4"] + [repr(float(x)) for x in seg.ravel()])
             for name, seg in (("H3", lower), ("H4", upper))]
    nested[-6:] = ["H3", "0.0", "1.0", "H4", "0.0", "1.0"]
    statements = _with_face(statements, nested)
    statements = statements[:8] + extra + statements[8:]
    path = _write(tmp_path, _vda_text(statements))
    with pytest.warns(TrimsurfWarning, match=r"FACE F1: trim loop 3 \(a hole\) lies inside the hole trim loop 2"):
        face = _vdafs.read(path).faces[0]
    assert len(face.loops) == 3 and face.loops[2].signed_area() < 0


# ------------------------------------------------------------------------------------------------
# bad input: VdafsReadError naming file, line and entity
# ------------------------------------------------------------------------------------------------


def test_read_missing_cons_raises_naming_face_and_cons(tmp_path):
    path = _write(tmp_path, _vda_text(_modified(_fixture_statements(), "F1", 3, "C9")))
    with pytest.raises(VdafsReadError, match=r"fixture\.vda:\d+: FACE F1: trim loop 1 refers to CONS C9, which "
                                             r"is not in the file"):
        _vdafs.read(path)


def test_read_missing_surf_raises_naming_face_and_surf(tmp_path):
    statements = [s for s in _fixture_statements() if s[0] not in ("S1",)]
    path = _write(tmp_path, _vda_text(statements))
    with pytest.raises(VdafsReadError, match=r"FACE F1: refers to SURF S1, which is not in the file"):
        _vdafs.read(path)


def test_read_missing_curve_raises_naming_cons(tmp_path):
    statements = [s for s in _fixture_statements() if s[0] != "K1"]
    path = _write(tmp_path, _vda_text(statements))
    with pytest.raises(VdafsReadError, match=r"CONS C1 \(used by FACE F1\) refers to CURVE K1"):
        _vdafs.read(path)


def test_read_empty_file(tmp_path):
    with pytest.raises(VdafsReadError, match=r"empty\.vda: file is empty"):
        _vdafs.read(_write(tmp_path, "", "empty.vda"))
    with pytest.raises(VdafsReadError, match=r"file is empty"):
        _vdafs.read(_write(tmp_path, "  \n\n", "blank.vda"))


def test_read_garbage(tmp_path):
    with pytest.raises(VdafsReadError, match=r"garbage\.vda:1: expected a statement"):
        _vdafs.read(_write(tmp_path, "this is not a VDA-FS file\n", "garbage.vda"))
    path = tmp_path / "binary.vda"
    path.write_bytes(bytes(range(256)))
    with pytest.raises(VdafsReadError, match=r"binary\.vda: binary data"):
        _vdafs.read(path)
    with pytest.raises(VdafsReadError, match=r"nohead\.vda:1: the first statement must be 'name = HEADER / n'"):
        _vdafs.read(_write(tmp_path, "S1       = SURF / 1\nX = END\n", "nohead.vda"))


def test_read_truncated_statement(tmp_path):
    lines = _vda_text(_fixture_statements()).splitlines(keepends=True)
    cut = next(i for i, line in enumerate(lines) if line.startswith("K1 ")) - 3  # inside the SURF
    with pytest.raises(VdafsReadError, match=r"SURF S1 \(line 3\) ends with ',' but this record starts a new "
                                             r"statement; statement truncated"):
        _vdafs.read(_write(tmp_path, "".join(lines[:cut] + lines[-1:])))


def test_read_truncated_file_without_end(tmp_path):
    lines = _vda_text(_fixture_statements()).splitlines(keepends=True)
    with pytest.raises(VdafsReadError, match=r"without an END statement; file truncated"):
        _vdafs.read(_write(tmp_path, "".join(lines[:-1])))
    with pytest.raises(VdafsReadError, match=r"cut\.vda:3: the file ends inside SURF S1 .*statement truncated"):
        _vdafs.read(_write(tmp_path, "".join(lines[:5]), "cut.vda"))


def test_read_too_few_coefficients(tmp_path):
    statements = _fixture_statements()
    path = _write(tmp_path, _vda_text([("S1", "SURF", statements[0][2][:-5])]))
    with pytest.raises(VdafsReadError, match=r"SURF S1: patch \(2, 3\): its 6 x 4 coefficients of x, y, z need "
                                             r"72 more parameters; the statement has 67"):
        _vdafs.read(path)


def test_read_record_longer_than_80_columns(tmp_path):
    lines = _vda_text(_fixture_statements()).splitlines()
    lines[4] = lines[4] + "X"
    with pytest.raises(VdafsReadError, match=r"long\.vda:5: record has 81 columns"):
        _vdafs.read(_write(tmp_path, "\n".join(lines) + "\n", "long.vda"))


def test_read_text_past_column_72(tmp_path):
    lines = _vda_text(_fixture_statements()).splitlines()
    lines[3] = lines[3][:70] + "1.,2.,3" + lines[3][77:]
    with pytest.raises(VdafsReadError, match=r":4: columns 73-80 must hold the sequence field"):
        _vdafs.read(_write(tmp_path, "\n".join(lines) + "\n"))


def test_read_malformed_number_names_line_and_entity(tmp_path):
    statements = _modified(_fixture_statements(), "K1", 7, "1.0X+01")
    path = _write(tmp_path, _vda_text(statements))
    line = next(n for n, rec in enumerate(path.read_text().splitlines(), 1) if "1.0X+01" in rec)
    with pytest.raises(VdafsReadError, match=rf"fixture\.vda:{line}: CURVE K1: segment 1: coefficient of x 3 "
                                             rf"must be a number; got '1\.0X\+01'"):
        _vdafs.read(path)


def test_read_number_out_of_range(tmp_path):
    path = _write(tmp_path, _vda_text(_modified(_fixture_statements(), "K1", 5, "1.0E+999")))
    with pytest.raises(VdafsReadError, match=r"CURVE K1: segment 1: coefficient of x 1 is out of the float64 range"):
        _vdafs.read(path)
    path = _write(tmp_path, _vda_text(_modified(_fixture_statements(), "K1", 1, "1.0D+999")), "big.vda")
    with pytest.raises(VdafsReadError, match=r"CURVE K1: segment breakpoint 1 is out of the float64 range"):
        _vdafs.read(path)


@pytest.mark.parametrize("index, value, message", [
    (0, "0", r"the number of patches in s \(nps\) must be >= 1"),
    (9, "2.5", r"patch \(1, 1\): the order in s must be an integer; got '2\.5'"),
])
def test_read_bad_surf_parameters(tmp_path, index, value, message):
    path = _write(tmp_path, _vda_text(_modified(_fixture_statements(), "S1", index, value)))
    with pytest.raises(VdafsReadError, match=message):
        _vdafs.read(path)


def test_read_duplicate_name_and_foreign_cons(tmp_path):
    statements = _fixture_statements()
    path = _write(tmp_path, _vda_text(statements + [("C1", "CONS", statements[2][2])]))
    with pytest.raises(VdafsReadError, match=r"CONS C1: the name is already used on line"):
        _vdafs.read(path)
    path = _write(tmp_path, _vda_text(_modified(statements, "H1", 0, "S2")), "foreign.vda")
    with pytest.raises(VdafsReadError, match=r"FACE F1: CONS H1 lies on SURF S2, not on the face's SURF S1"):
        _vdafs.read(path)


def test_read_unbalanced_sets_and_text_after_end(tmp_path):
    text = _vda_text([("A", "ENDSET", None)])
    with pytest.raises(VdafsReadError, match=r"ENDSET A: no BEGINSET is open"):
        _vdafs.read(_write(tmp_path, text))
    text = _vda_text(_fixture_statements()) + "S9       = SURF / 1\n"
    with pytest.raises(VdafsReadError, match=r"text after the END statement"):
        _vdafs.read(_write(tmp_path, text, "after.vda"))


def test_read_missing_file(tmp_path):
    with pytest.raises(VdafsReadError, match=r"none\.vda: cannot read file"):
        _vdafs.read(tmp_path / "none.vda")


# ------------------------------------------------------------------------------------------------
# writing and exact round trips
# ------------------------------------------------------------------------------------------------


def _mixed_grid_surface() -> NurbsSurface:
    """The fixture's 2 x 3 patches as Bezier patches of degree 3 or 5, joined by elevation."""
    mono = _patch_monomials()
    grid = [[monomial_to_bezier(monomial_to_bezier(np.moveaxis(mono[i, j], 0, -1), axis=0), axis=1)
             for j in range(3)] for i in range(2)]
    assert {g.shape[:2] for row in grid for g in row} == {(4, 4), (6, 4), (6, 6)}
    return NurbsSurface(*bezier_grid_to_nurbs(grid, S_BREAKS, T_BREAKS))


def _line(a, b, domain=(0.0, 1.0)) -> NurbsCurve:
    return NurbsCurve(1, [domain[0]] * 2 + [domain[1]] * 2, [a, b])


def _grid_face() -> TrimmedFace:
    """Outer loop of several p-curves (mixed-degree Bezier chains, one reversed, one with an edge
    curve) and a hole of two cubic arcs on the mixed-degree grid surface."""
    surface = _mixed_grid_surface()
    right = NurbsCurve(*bezier_curve_to_nurbs([np.array([[1.9, -0.9], [1.9, 0.0]]),
                                              np.array([[1.9, 0.0], [1.8, 0.3], [1.85, 0.6], [1.9, 0.9]])],
                                             [2.0, 3.5, 5.0])[:3])
    bottom = _line([0.1, -0.9], [1.9, -0.9])
    w = np.linspace(0.0, 1.0, 4)
    edge = NurbsCurve(3, [0.0] * 4 + [1.0] * 4,  # the cubic image of the bottom line, interpolated at 4 points
                      np.linalg.solve(np.array([[math.comb(3, i) * x ** i * (1 - x) ** (3 - i) for i in range(4)]
                                                for x in w]), surface.evaluate(bottom.evaluate(w))))
    outer = Loop((PCurve(bottom, 0.0, 1.0, edge_curve=edge), PCurve(right, 2.0, 5.0),
                  PCurve(_line([0.1, 0.9], [1.9, 0.9]), 1.0, 0.0), PCurve(_line([0.1, 0.9], [0.1, -0.9]), 0.0, 1.0)))
    (cx, cy), r = HOLE
    k = 4.0 / 3.0 * r
    lower = NurbsCurve(3, [0.0] * 4 + [1.0] * 4, [(cx + r, cy), (cx + r, cy - k), (cx - r, cy - k), (cx - r, cy)])
    upper = NurbsCurve(3, [0.0] * 4 + [1.0] * 4, [(cx - r, cy), (cx - r, cy + k), (cx + r, cy + k), (cx + r, cy)])
    hole = Loop((PCurve(lower, 0.0, 1.0), PCurve(upper, 0.0, 1.0)))
    return TrimmedFace(surface, (outer, hole), name="GRID")


def _assert_same_curve(a: NurbsCurve | None, b: NurbsCurve | None) -> None:
    assert (a is None) == (b is None)
    if a is not None:
        assert a.degree == b.degree
        assert np.array_equal(a.knots, b.knots)
        assert np.array_equal(a.control_points, b.control_points)


def _assert_same_shell(a: Shell, b: Shell) -> None:
    """Bitwise equal faces: surfaces, loops, p-curves, ranges and edge curves."""
    assert [f.name for f in a.faces] == [f.name for f in b.faces]
    for fa, fb in zip(a.faces, b.faces):
        sa, sb = fa.surface, fb.surface
        assert (sa.degree_u, sa.degree_v) == (sb.degree_u, sb.degree_v)
        assert np.array_equal(sa.knots_u, sb.knots_u) and np.array_equal(sa.knots_v, sb.knots_v)
        assert np.array_equal(sa.control_points, sb.control_points)
        assert sb.weights is None
        assert len(fa.loops) == len(fb.loops)
        for la, lb in zip(fa.loops, fb.loops):
            assert len(la) == len(lb)
            for pa, pb in zip(la.segments, lb.segments):
                assert (pa.t0, pa.t1) == (pb.t0, pb.t1)
                _assert_same_curve(pa.curve, pb.curve)
                _assert_same_curve(pa.edge_curve, pb.edge_curve)


def test_write_read_is_bitwise_for_a_bezier_grid_face(tmp_path):
    face = _grid_face()
    shell = Shell((face,), name="in")
    path = tmp_path / "grid.vda"
    _vdafs.write(shell, path)
    back = _vdafs.read(path)
    _assert_same_shell(shell, back)
    rng = np.random.default_rng(7)
    st_pts = _random_st(rng, 200)
    size = float(np.ptp(face.surface.control_points.reshape(-1, 3), axis=0).max())
    # same control points and knots: the evaluations agree to the last bit; 1e-12 of the size is the brief's bound
    assert_allclose(back.faces[0].surface.evaluate(st_pts), face.surface.evaluate(st_pts), rtol=0, atol=1e-12 * size)
    # and the surface is the monomial fixture (elevation and conversions in floating point: ~1e-15)
    assert_allclose(back.faces[0].surface.evaluate(st_pts), _eval_monomials(st_pts), rtol=0, atol=1e-12 * size)


def test_read_write_read_is_bitwise(fixture_file, tmp_path):
    first = _vdafs.read(fixture_file)
    _vdafs.write(first, tmp_path / "again.vda")
    second = _vdafs.read(tmp_path / "again.vda")
    _assert_same_shell(first, second)


def test_order_20_patch_round_trip(tmp_path):
    rng = np.random.default_rng(20)
    cp = rng.normal(size=(20, 20, 3)) * [100.0, 50.0, 5.0] + [1000.0, -200.0, 30.0]
    knots = np.array([2.0] * 20 + [3.5] * 20)
    surface = NurbsSurface(19, 19, knots, np.array([-1.0] * 20 + [1.0] * 20), cp)
    shell = Shell((TrimmedFace(surface, (), name="BLEND20"),))
    _vdafs.write(shell, tmp_path / "o20.vda")
    text = (tmp_path / "o20.vda").read_text()
    assert re.search(r"BLEND20  = SURF / 1, 1, 2\.0E\+00, 3\.5E\+00, -1\.0E\+00, 1\.0E\+00, 20, 20,", text)
    back = _vdafs.read(tmp_path / "o20.vda")
    _assert_same_shell(shell, back)
    uv = np.column_stack([rng.uniform(2.0, 3.5, 100), rng.uniform(-1.0, 1.0, 100)])
    local = np.column_stack([(uv[:, 0] - 2.0) / 1.5, (uv[:, 1] + 1.0) / 2.0])
    size = float(np.ptp(cp.reshape(-1, 3), axis=0).max())
    # degree 19 de Casteljau-type evaluation vs the B-spline evaluator: a few ulps of the size
    assert_allclose(back.faces[0].surface.evaluate(uv), bezier_patch_points(cp, local), rtol=0, atol=1e-12 * size)


def test_write_read_of_a_general_bspline_face_keeps_the_geometry(tmp_path):
    rng = np.random.default_rng(3)
    ku = np.array([0.0] * 4 + [0.3, 0.45, 0.8] + [1.0] * 4)
    kv = np.array([-2.0] * 4 + [-1.0] + [2.0] * 4)
    cp = rng.normal(size=(7, 5, 3)) * 10.0
    surface = NurbsSurface(3, 3, ku, kv, cp)
    ring = NurbsCurve(3, [0.0] * 4 + [0.25, 0.5, 0.75] + [1.0] * 4,  # simple knots: written by knot insertion
                      [(0.5, -1.0), (0.8, -0.5), (0.8, 1.0), (0.5, 1.5), (0.2, 1.0), (0.2, -0.5), (0.5, -1.0)])
    shell = Shell((TrimmedFace(surface, (Loop((PCurve(ring, 0.0, 1.0),)),), name="GEN"),))
    _vdafs.write(shell, tmp_path / "gen.vda")
    back = _vdafs.read(tmp_path / "gen.vda")
    face = back.faces[0]
    assert face.surface.knots_u.tolist() == [0.0] * 4 + [0.3] * 3 + [0.45] * 3 + [0.8] * 3 + [1.0] * 4
    uv = np.column_stack([rng.uniform(0, 1, 300), rng.uniform(-2, 2, 300)])
    size = float(np.ptp(cp.reshape(-1, 3), axis=0).max())
    # knot insertion (convex combinations) and exact conversion: rounding only
    assert_allclose(face.surface.evaluate(uv), surface.evaluate(uv), rtol=0, atol=1e-12 * size)
    t = np.linspace(0, 1, 101)
    assert_allclose(face.loops[0].segments[0].evaluate(t), ring.evaluate(t), rtol=0, atol=1e-14)
    _vdafs.write(back, tmp_path / "gen2.vda")
    _assert_same_shell(back, _vdafs.read(tmp_path / "gen2.vda"))


def test_written_records_have_80_columns_and_sequence_numbers(tmp_path):
    _vdafs.write(Shell((_grid_face(),)), tmp_path / "layout.vda")
    lines = (tmp_path / "layout.vda").read_text(encoding="ascii").splitlines()
    assert all(len(line) == 80 for line in lines)
    assert [int(line[72:]) for line in lines] == list(range(1, len(lines) + 1))
    assert lines[0].startswith("TRIMSURF = HEADER / 20")
    assert lines[-1].startswith("TRIMSURF = END")
    statements = [line[:72].split("=")[1].split("/")[0].strip() for line in lines[21:] if "=" in line[:72]]
    assert statements == ["SURF", "CURVE", "CONS", "CONS", "CONS", "CONS", "CONS", "CONS", "FACE", "END"]
    continued = [line[:72].rstrip() for line in lines[21:-1]]
    nxt = lines[22:]
    assert all(text.endswith(",") or "=" in n[:72] for text, n in zip(continued, nxt))
    assert "GRID     = FACE / S1, 2, 4, C1, 0.0, 1.0E+00" in "".join(lines)


def test_writer_lowers_the_order_of_elevated_patches(tmp_path):
    # the bilinear f = (3u, 2v, 0.5 + 1.5u - v + 6uv) as an exact Bezier patch of degree (3, 2): its
    # control points are f at (i/3, j/2), small dyadic numbers; written with orders 2 x 2
    i, j = np.meshgrid(np.arange(4.0), np.arange(3.0), indexing="ij")
    cp = np.stack([i, j, 0.5 + 0.5 * i - 0.5 * j + i * j], axis=-1)
    surface = NurbsSurface(3, 2, [0.0] * 4 + [1.0] * 4, [0.0] * 3 + [1.0] * 3, cp)
    _vdafs.write(Shell((TrimmedFace(surface, (), name="FLAT"),)), tmp_path / "low.vda")
    assert "FLAT     = SURF / 1, 1, 0.0, 1.0E+00, 0.0, 1.0E+00, 2, 2," in (tmp_path / "low.vda").read_text()
    back = _vdafs.read(tmp_path / "low.vda").faces[0].surface
    assert (back.degree_u, back.degree_v) == (1, 1)
    assert np.array_equal(back.control_points, cp[::3, ::2])


def test_write_through_the_io_dispatcher(tmp_path):
    shell = Shell((_grid_face(),))
    write_shell(shell, tmp_path / "part.vda")
    _assert_same_shell(shell, read_shell(tmp_path / "part.vda"))


def test_write_names_are_kept_when_valid_and_generated_otherwise(tmp_path):
    face = _grid_face()
    faces = (TrimmedFace(face.surface, face.loops, name="S1"), TrimmedFace(face.surface, face.loops, name="a long name"),
             TrimmedFace(face.surface, (), name="S1"))
    _vdafs.write(Shell(faces), tmp_path / "names.vda")
    back = _vdafs.read(tmp_path / "names.vda")
    names = [f.name for f in back.faces]
    assert names[0] == "S1" and len(set(names)) == 3 and all(len(n) <= 8 for n in names)


def test_write_rational_surface_raises_naming_the_face(tmp_path):
    w = np.ones((2, 2))
    w[0, 0] = 2.0
    surface = NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], np.zeros((2, 2, 3)) + [[[0, 0, 0]]], w)
    path = tmp_path / "rational.vda"
    with pytest.raises(GeometryError, match=r"rational\.vda: face 0 \('ROOF'\): rational surface"):
        _vdafs.write(Shell((TrimmedFace(surface, (), name="ROOF"),)), path)
    assert not path.exists() and not list(tmp_path.iterdir())  # nothing half-written


def test_write_rational_pcurve_raises_and_rational_edge_curve_warns(tmp_path):
    face = _grid_face()
    arc = NurbsCurve(2, [0, 0, 0, 1, 1, 1], [(0.5, 0.0), (1.0, 0.0), (1.0, 0.5)], [1.0, 0.7, 1.0])
    bad = TrimmedFace(face.surface, (Loop((PCurve(arc, 0.0, 1.0),)),), name="ARC")
    with pytest.raises(GeometryError, match=r"face 0 \('ARC'\): trim loop 0, segment 0: rational p-curve"):
        _vdafs.write(Shell((bad,)), tmp_path / "arc.vda")
    arc3 = NurbsCurve(2, [0, 0, 0, 1, 1, 1], [(0.5, 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, 0.5, 0.0)], [1.0, 0.7, 1.0])
    seg = face.loops[1].segments[0]
    loops = (face.loops[0], Loop((PCurve(seg.curve, 0.0, 1.0, edge_curve=arc3), face.loops[1].segments[1])))
    with pytest.warns(TrimsurfWarning, match=r"trim loop 1, segment 0: rational edge curve left out"):
        _vdafs.write(Shell((TrimmedFace(face.surface, loops, name="EDGE"),)), tmp_path / "edge.vda")


def test_write_bad_input(tmp_path):
    with pytest.raises(InputError, match=r"VDA-FS write expects a Shell; got TrimmedFace"):
        _vdafs.write(_grid_face(), tmp_path / "x.vda")
    with pytest.raises(InputError, match=r"the shell has no face"):
        _vdafs.write(Shell(()), tmp_path / "x.vda")


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(degrees=st.tuples(st.integers(1, 7), st.integers(1, 7)), counts=st.tuples(st.integers(1, 2), st.integers(1, 3)),
       seed=st.integers(0, 2 ** 32 - 1), spread=st.integers(0, 12))
def test_write_read_bitwise_for_random_bezier_grids(tmp_path, degrees, counts, seed, spread):
    """Any polynomial Bezier grid (any degrees, magnitudes over 10**spread) reads back bit for bit."""
    rng = np.random.default_rng(seed)
    (du, dv), (m, n) = degrees, counts
    cp = rng.normal(size=(m * du + 1, n * dv + 1, 3)) * 10.0 ** rng.uniform(-spread, spread, size=(1, 1, 3))
    ub = np.cumsum(np.r_[rng.uniform(-5, 5), rng.uniform(0.01, 3, m)])
    vb = np.cumsum(np.r_[rng.uniform(-5, 5), rng.uniform(0.01, 3, n)])
    surface = NurbsSurface(du, dv, np.r_[ub[0], np.repeat(ub, du), ub[-1]], np.r_[vb[0], np.repeat(vb, dv), vb[-1]],
                           cp)
    shell = Shell((TrimmedFace(surface, (), name="H"),))
    path = tmp_path / f"h{seed}.vda"
    _vdafs.write(shell, path)
    _assert_same_shell(shell, _vdafs.read(path))
