"""Open CASCADE .brep files: read like STEP (same Shell), written like STEP, bad files refused in one line.

../shared/data has no .brep file (its README lists STEP and IGES only), so the
.brep files here are written with Open CASCADE's own ``BRepTools::Write`` from
the shapes of shared STEP files.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from trimsurf.cli import main
from trimsurf.errors import BrepReadError, FileFormatError
from trimsurf.io import CAD_SUFFIXES, _brep, _occ, read_shell, write_shell

CAD = (Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "cad").resolve()


def _step_shape(name: str):
    """The shape Open CASCADE's STEP reader makes of a shared file (before any trimsurf conversion)."""
    from OCP.STEPControl import STEPControl_Reader

    with _occ.quiet_occ():
        reader = STEPControl_Reader()
        reader.ReadFile(str(CAD / name))
        reader.TransferRoots()
        return reader.OneShape()


def _occ_brep(shape, path: Path) -> Path:
    from OCP.BRepTools import BRepTools

    with _occ.quiet_occ():
        assert BRepTools.Write_s(shape, str(path))
    return path


def _same_shell(a, b) -> None:
    """Same faces (surface control points, degrees, loops and segments), same edges."""
    assert len(a.faces) == len(b.faces) and len(a.edges) == len(b.edges)
    assert a.is_closed() == b.is_closed()
    for fa, fb in zip(a.faces, b.faces):
        assert fa.same_sense == fb.same_sense
        sa, sb = fa.surface, fb.surface
        assert (sa.degree_u, sa.degree_v) == (sb.degree_u, sb.degree_v)
        # bit for bit on t20 (B-spline faces, no placements); on the screw (analytic faces placed by location
        # matrices, which the .brep stores as matrices and composes again) 6e-12 of the diagonal was measured
        assert_allclose(sa.control_points, sb.control_points, rtol=0, atol=2e-11 * a.diagonal())
        assert [len(lp.segments) for lp in fa.loops] == [len(lp.segments) for lp in fb.loops]


@pytest.mark.parametrize("name", ["gmsh__t20_data.step", "occt__screw.step"])
def test_brep_written_by_open_cascade_reads_as_its_step(name, tmp_path):
    brep = _occ_brep(_step_shape(name), tmp_path / f"{Path(name).stem}.brep")
    from_brep = read_shell(brep)
    from_step = read_shell(CAD / name)
    # BRepTools writes doubles with 17 significant digits: the same shape, so the same Shell bit for bit
    _same_shell(from_brep, from_step)
    assert from_brep.is_closed() and from_brep.name == brep.name


def test_brep_write_read_round_trip(tmp_path):
    from OCP.BRepCheck import BRepCheck_Analyzer

    shell = read_shell(CAD / "gmsh__t20_data.step")
    out = tmp_path / "t20.brep"
    write_shell(shell, out)
    assert b"\nCASCADE Topology V" in out.read_bytes()[:200]
    back = read_shell(out)
    _same_shell(back, shell)
    assert BRepCheck_Analyzer(_brep.read_occ_shape(out)).IsValid()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t20.brep"]


def test_every_cad_command_takes_brep(tmp_path, capsys):
    assert ".brep" in CAD_SUFFIXES
    brep = _occ_brep(_step_shape("occt__screw.step"), tmp_path / "screw.brep")
    assert main(["info", str(brep), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["n_faces"] == 10
    report = tmp_path / "r.json"
    assert main(["tessellate", str(brep), "-o", str(tmp_path / "m.ply"), "--report", str(report)]) == 0
    entry = json.loads(report.read_text())["inputs"][0]
    assert entry["boundary_edges"] == 0 and entry["flipped"] == 0
    assert entry["max_deviation"] <= entry["tolerance"]
    assert main(["samples", "bspline_box", "--out", str(tmp_path / "box.brep")]) == 0
    assert len(read_shell(tmp_path / "box.brep").faces) == 6


def _no_faces_brep(path: Path) -> Path:
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
    from OCP.gp import gp_Pnt

    return _occ_brep(BRepBuilderAPI_MakeVertex(gp_Pnt(1, 2, 3)).Shape(), path)


@pytest.mark.parametrize("case, match", [
    ("empty", "empty"), ("garbage", "not an Open CASCADE BREP file"), ("truncated", "not a readable BREP"),
    ("nofaces", "holds no faces"), ("huge", "1e\\+12 is above 1e\\+10"), ("inf", "1e\\+999 is not finite"),
    ("missing", "no such file"), ("nosurface", "face 0 has no surface"),
])
def test_bad_brep_files_raise_one_line_and_print_nothing(case, match, tmp_path, capfd):
    path = tmp_path / f"{case}.brep"
    if case == "empty":
        path.write_bytes(b"")
    elif case == "garbage":
        path.write_text("this is not a BREP file\n")
    elif case == "truncated":
        full = _occ_brep(_step_shape("occt__screw.step"), tmp_path / "full.brep").read_bytes()
        path.write_bytes(full[: len(full) // 2])
    elif case == "nofaces":
        _no_faces_brep(path)
    elif case in ("huge", "inf"):  # the origin of a 2D line (a p-curve) far away / infinite
        text = _occ_brep(_step_shape("occt__screw.step"), tmp_path / "full.brep").read_text()
        assert "\n1 0 0 0 1 \n" in text
        path.write_text(text.replace("\n1 0 0 0 1 \n", "\n1 %s 0 0 1 \n" % ("1e+12" if case == "huge" else "1e+999"), 1))
    elif case == "nosurface":  # a face naming a surface the file does not have: Open CASCADE reads it, then
        # crashes (SIGSEGV, measured) bounding or converting it; refused before that
        from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox

        text = _occ_brep(BRepPrimAPI_MakeBox(1.0, 2.0, 3.0).Shape(), tmp_path / "box.brep").read_text()
        assert "\nFa\n0  1e-07 1 0\n" in text
        path.write_text(text.replace("\nFa\n0  1e-07 1 0\n", "\nFa\n0  1e-07 9999 0\n", 1))
    capfd.readouterr()
    with pytest.raises(FileFormatError if case in ("empty", "missing") else BrepReadError, match=match) as info:
        read_shell(path)
    message = str(info.value)
    assert str(path) in message and "\n" not in message
    assert capfd.readouterr() == ("", "")
    assert main(["info", str(path)]) == 2
    err = capfd.readouterr().err
    assert err.startswith("trimsurf: error: ") and err.count("\n") == 1 and "Traceback" not in err
