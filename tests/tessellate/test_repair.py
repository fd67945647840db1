"""CAD repair of a face (paper Sec. 4.1): patch grids, G1 flagging, trim loops."""

from __future__ import annotations

import json

import numpy as np
import pytest

from trimsurf.errors import TrimsurfWarning
from trimsurf.geom.knots import bezier_grid_to_nurbs
from trimsurf.io import read_mesh, read_shell
from trimsurf.model import Loop, NurbsCurve, NurbsSurface, PCurve, TrimmedFace
from trimsurf.tessellate import tessellate_shell
from trimsurf.tessellate.repair import repair_face

from ..io.test_vdafs import _vda_text

# ------------------------------------------------------------------------------------------------
# small VDA-FS files: a 2 x 2 grid of bilinear patches of z = 0.2 (x - 1) (y - 1) over [0, 2]^2
# ------------------------------------------------------------------------------------------------


def _surf_tokens(*, dx: float = 0.0, s_breaks=(0.0, 1.0, 2.0), displace=None) -> list[str]:
    """SURF parameters; ``displace = (i, j, dz)`` moves the corner (u, v) = (0, 0) of patch (i, j) by dz."""
    toks = ["2", "2"] + [repr(float(x)) for x in s_breaks] + ["0.0", "1.0", "2.0"]
    for j in range(2):
        for i in range(2):          # s-index fastest; monomial coefficients a00, a10, a01, a11
            x = [dx + i, 1.0, 0.0, 0.0]
            y = [float(j), 0.0, 1.0, 0.0]
            z = [0.2 * (i - 1) * (j - 1), 0.2 * (j - 1), 0.2 * (i - 1), 0.2]
            if displace is not None and displace[:2] == (i, j):   # dz (1 - u) (1 - v): the corner only
                z = [c + displace[2] * e for c, e in zip(z, (1.0, -1.0, -1.0, 1.0))]
            toks += ["2", "2"] + [repr(float(c)) for c in x + y + z]
    return toks


def _vda(path, statements) -> str:
    path.write_text(_vda_text(statements, header=("trimsurf repair test",)), encoding="ascii")
    return path


def _square_face(surf: str, lo: float, hi: float) -> list:
    """CONS of the square [lo, hi]^2 in (s, t) and a FACE F<surf> on them."""
    pts = [(lo, lo), (hi, lo), (hi, hi), (lo, hi)]
    out, face = [], [surf, "1", "4"]
    for k in range(4):
        (a, b), (c, d) = pts[k], pts[(k + 1) % 4]
        name = f"{surf}C{k}"
        out.append((name, "CONS", [surf, "", "0.0", "1.0", "1", "0.0", "1.0", "2",
                                   repr(a), repr(c - a), repr(b), repr(d - b)]))
        face += [name, "0.0", "1.0"]
    return out + [(f"F{surf}", "FACE", face)]


def _read(path):
    """The shell, with the reader's warnings (a broken grid warns; repair is what rejects it) recorded."""
    import warnings

    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        return read_shell(path)


def test_good_patch_grid_passes(tmp_path):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", TrimsurfWarning)          # nothing to report on a good grid
        shell = read_shell(_vda(tmp_path / "good.vda", [("S1", "SURF", _surf_tokens())]))
    d = shell.diagonal()
    rep = repair_face(shell.faces[0], tolerance=1e-3 * d)
    assert rep.status == "ok" and rep.messages == []
    # the grid the reader recorded: four shared boundaries, all closed to rounding
    grid = shell.faces[0].surface.patch_grid
    assert grid.gaps_s.shape == (1, 2) and grid.gaps_t.shape == (2, 1)
    assert max(g for g, *_ in grid.seams()) <= 1e-15


@pytest.mark.parametrize("dz, rejected", [(0.05, True), (1e-4, False)])
def test_displaced_shared_control_point_is_rejected_by_name(tmp_path, dz, rejected):
    shell = _read(_vda(tmp_path / "grid.vda", [("S1", "SURF", _surf_tokens(displace=(1, 1, dz)))]))
    tol = 1e-3 * shell.diagonal()           # 2.8e-3: between the two displacements
    rep = repair_face(shell.faces[0], tolerance=tol)
    if not rejected:
        assert rep.status == "ok"
        return
    assert rep.status == "failed"
    (msg,) = rep.messages
    # the face, the SURF (file and line), the patch pair and the gap (patch (2, 2)'s corner is shared
    # with three patches; the largest gap is named)
    assert msg.startswith("S1: ") and "SURF S1" in msg and "(2, 2)" in msg
    assert "0.05 apart" in msg and "cannot be repaired" in msg


def test_broken_boundary_outside_the_trim_is_only_reported(tmp_path):
    # patch (2, 2) displaced, but the face uses only [0.1, 0.9]^2 inside patch (1, 1)
    path = _vda(tmp_path / "bad_outside.vda",
                [("S1", "SURF", _surf_tokens(displace=(1, 1, 0.05)))] + _square_face("S1", 0.1, 0.9))
    face = _read(path).faces[0]
    assert face.name == "FS1"
    rep = repair_face(face, tolerance=2e-3)
    assert rep.status == "ok"
    assert len(rep.messages) == 2 and all("outside the trimmed area" in m for m in rep.messages)
    # the same grid trimmed across the broken corner is rejected
    path = _vda(tmp_path / "bad_inside.vda",
                [("S1", "SURF", _surf_tokens(displace=(1, 1, 0.05)))] + _square_face("S1", 0.5, 1.5))
    assert repair_face(_read(path).faces[0], tolerance=2e-3).status == "failed"


def test_breakpoints_not_increasing_reject_the_face_not_the_file(tmp_path):
    path = _vda(tmp_path / "bad_breaks.vda", [("S1", "SURF", _surf_tokens(s_breaks=(0.0, 1.0, 1.0))),
                                              ("S2", "SURF", _surf_tokens(dx=3.0))])
    shell = _read(path)
    assert [f.name for f in shell.faces] == ["S1", "S2"]
    rep = repair_face(shell.faces[0], tolerance=1e-3)
    assert rep.status == "failed"
    assert "SURF S1" in rep.messages[0] and "s breakpoints do not increase strictly" in rep.messages[0]
    assert repair_face(shell.faces[1], tolerance=1e-3).status == "ok"


def test_cli_broken_grid_exit_1_rest_written(tmp_path, capsys):
    from trimsurf.cli import main

    path = _vda(tmp_path / "bad_pair.vda", [("S1", "SURF", _surf_tokens()),
                                            ("S2", "SURF", _surf_tokens(dx=3.0, displace=(1, 1, 0.05)))])
    out, rep = tmp_path / "pair.ply", tmp_path / "r.json"
    assert main(["tessellate", str(path), "-o", str(out), "--report", str(rep)]) == 1
    err = capsys.readouterr().err
    assert "(S2) skipped: S2: " in err and "do not share their boundary control points (0.05 apart" in err
    faces = json.loads(rep.read_text())["inputs"][0]["faces"]
    assert [(f["name"], f["status"]) for f in faces] == [("S1", "ok"), ("S2", "failed")]
    mesh = read_mesh(out)
    assert mesh.n_triangles > 10 and mesh.vertices[:, 0].max() <= 2.0 + 1e-9     # S1 only, x in [0, 2]


def test_shell_keeps_the_rest_of_the_model(tmp_path):
    path = _vda(tmp_path / "bad_pair.vda", [("S1", "SURF", _surf_tokens()),
                                            ("S2", "SURF", _surf_tokens(dx=3.0, displace=(0, 1, -0.05)))])
    res = tessellate_shell(_read(path), measure=False)
    assert [f.status for f in res.faces] == ["ok", "failed"]
    # patch (1, 2)'s corner (s, t) = (0, 1) is shared with patches (1, 1) and (2, 1), (2, 2)
    assert "adjacent patches (1, 1) and (1, 2)" in res.faces[1].messages[0]
    assert set(res.mesh.face_id.tolist()) == {0}


def test_surface_broken_at_a_full_multiplicity_knot_is_rejected():
    """Any reader: an interior knot of multiplicity degree + 1 whose two control rows differ."""
    cp = np.zeros((4, 2, 3))
    cp[:, :, 0] = [[0, 0], [1, 1], [1, 1], [2, 2]]
    cp[:, 1, 1] = 1.0
    cp[2:, :, 2] = 0.3                     # the right piece lifted by 0.3: a step at u = 1
    s = NurbsSurface(1, 1, [0, 0, 1, 1, 2, 2], [0, 0, 1, 1], cp)
    rep = repair_face(TrimmedFace(s, name="step"), tolerance=1e-3)
    assert rep.status == "failed" and "breaks apart at u = 1" in rep.messages[0] and "0.3 apart" in rep.messages[0]
    cp[2:, :, 2] = 0.0
    assert repair_face(TrimmedFace(NurbsSurface(1, 1, [0, 0, 1, 1, 2, 2], [0, 0, 1, 1], cp)),
                       tolerance=1e-3).status == "ok"


# ------------------------------------------------------------------------------------------------
# G1 flagging along internal C0 knot lines inside the trim
# ------------------------------------------------------------------------------------------------


def _line(a, b) -> PCurve:
    return PCurve(NurbsCurve(1, [0, 0, 1, 1], np.array([a, b], float)), 0.0, 1.0)


def _loop(*pts) -> Loop:
    return Loop(tuple(_line(pts[k], pts[(k + 1) % len(pts)]) for k in range(len(pts))))


def _bent_plane(angle_deg: float) -> NurbsSurface:
    """Two bilinear patches on [0, 1] x [0, 1] and [1, 2] x [0, 1]; the second bent up by `angle_deg`."""
    a = np.radians(angle_deg)
    net = np.zeros((2, 1, 2, 2, 3))
    for j in range(2):
        net[0, 0, :, j] = [[0, j, 0], [1, j, 0]]
        net[1, 0, :, j] = [[1, j, 0], [1 + np.cos(a), j, np.sin(a)]]
    pu, pv, ku, kv, cp, _ = bezier_grid_to_nurbs(net, [0, 1, 2], [0, 1])
    return NurbsSurface(pu, pv, ku, kv, cp)


def test_crease_inside_the_trim_is_flagged_with_its_angle():
    rep = repair_face(TrimmedFace(_bent_plane(30.0), name="crease"), tolerance=1e-3)
    assert rep.status == "flagged" and rep.face is not None
    assert abs(rep.max_g1_angle_deg - 30.0) < 1e-3
    assert "crease: not G1" in rep.messages[0]


def test_crease_outside_the_trim_and_g1_joint_are_not_flagged():
    # trimmed to the flat half: the crease at u = 1 lies outside
    half = TrimmedFace(_bent_plane(30.0), (_loop((0.1, 0.1), (0.9, 0.1), (0.9, 0.9), (0.1, 0.9)),), name="half")
    rep = repair_face(half, tolerance=1e-3)
    assert rep.status == "ok" and rep.max_g1_angle_deg == 0.0
    # a C0 knot line across which the surface is flat: no normal jump
    rep = repair_face(TrimmedFace(_bent_plane(0.0)), tolerance=1e-3)
    assert rep.status == "ok" and rep.max_g1_angle_deg < 1e-6


# ------------------------------------------------------------------------------------------------
# trim loops: joined within tolerance, suit-case corner filled, open loop rejected
# ------------------------------------------------------------------------------------------------


def _plane() -> NurbsSurface:
    cp = np.zeros((2, 2, 3))
    cp[1, :, 0] = 1.0
    cp[:, 1, 1] = 1.0
    return NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], cp)


def test_loop_ends_within_tolerance_are_joined_beyond_it_rejected():
    sq = [(0.1, 0.1), (0.9, 0.1), (0.9, 0.9), (0.1, 0.9)]
    for gap, status in ((5e-4, "ok"), (5e-2, "failed")):
        segs = list(_loop(*sq).segments)
        segs[1] = _line((0.9, 0.1 + gap), (0.9, 0.9))        # starts `gap` above the end of segment 0
        rep = repair_face(TrimmedFace(_plane(), (Loop(tuple(segs)),), name="sq"), tolerance=1e-3)
        assert rep.status == status
        if status == "failed":
            assert rep.messages == [f"sq: trim loop 0 is open after segment 0 (gap {gap:.3g} in 3D > "
                                    f"tolerance {1e-3:.3g})"]
        else:
            assert rep.filled == [] and rep.face.loops[0].segments == tuple(segs)


def test_suitcase_corner_is_filled():
    # the edge v = 1 of the surface collapses to one point: the loop omits its zero-length segment
    cp = np.zeros((2, 2, 3))
    cp[1, 0, 0] = 1.0
    cp[:, 1] = [0.5, 1.0, 0.0]
    s = NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], cp)
    three = Loop((_line((0, 0), (1, 0)), _line((1, 0), (1, 1)), _line((0, 1), (0, 0))))
    rep = repair_face(TrimmedFace(s, (three,), name="suitcase"), tolerance=1e-3)
    assert rep.status == "repaired" and rep.filled == [(0, 2)]
    loop = rep.face.loops[0]
    assert len(loop) == 4 and loop.is_closed(1e-12)
    np.testing.assert_allclose([loop.segments[2].start, loop.segments[2].end], [[1, 1], [0, 1]])
    # the same gap on a surface whose edge v = 1 has length: not fillable, rejected
    rep = repair_face(TrimmedFace(_plane(), (three,), name="plane"), tolerance=1e-3)
    assert rep.status == "failed" and "plane: trim loop 0 is open after segment 1" in rep.messages[0]


def test_pole_of_a_surface_of_revolution_is_not_a_g1_defect(shared_data):
    """bug32596 face 11: its knot lines end at the axis (|Su x Sv| = 0), where the one-sided normals
    jump by up to 141 deg; everywhere else the surface is G1 (jump < 1e-3 deg)."""
    from trimsurf.io import read_shell
    from trimsurf.tessellate.repair import g1_defects

    face = read_shell(shared_data / "cad" / "occtpr946__bug32596_abc_0_13.step").faces[11]
    assert g1_defects(face) < 1e-3


def test_g1_defects_takes_the_worst_of_several_lines_inside_the_trim():
    """Three patches in a row, bent by 10 and 25 degrees at u = 1 and u = 2 (the lines are checked in one
    batch): the larger jump counts, and only while its line is inside the trim."""
    from trimsurf.tessellate.repair import g1_defects

    net = np.zeros((3, 1, 2, 2, 3))
    a1, a2 = np.radians(10.0), np.radians(10.0 + 25.0)
    for j in range(2):
        p1 = np.array([1.0, j, 0.0])
        p2 = p1 + [np.cos(a1), 0, np.sin(a1)]
        net[0, 0, :, j] = [[0, j, 0], p1]
        net[1, 0, :, j] = [p1, p2]
        net[2, 0, :, j] = [p2, p2 + [np.cos(a2), 0, np.sin(a2)]]
    pu, pv, ku, kv, cp, _ = bezier_grid_to_nurbs(net, [0, 1, 2, 3], [0, 1])
    s = NurbsSurface(pu, pv, ku, kv, cp)
    assert abs(g1_defects(TrimmedFace(s)) - 25.0) < 1e-3
    left = TrimmedFace(s, (_loop((0.1, 0.1), (1.5, 0.1), (1.5, 0.9), (0.1, 0.9)),))     # only u = 1 inside
    assert abs(g1_defects(left) - 10.0) < 1e-3
    none = TrimmedFace(s, (_loop((0.1, 0.1), (0.9, 0.1), (0.9, 0.9), (0.1, 0.9)),))     # no line inside
    assert g1_defects(none) == 0.0
