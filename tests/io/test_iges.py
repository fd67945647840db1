"""IGES: agreement with Open CASCADE on the real unsewn surface model, its open topology, bad input."""

from __future__ import annotations

from pathlib import Path

import pytest

from trimsurf.errors import FileFormatError, IgesReadError
from trimsurf.io import _iges, read_shell, write_shell

from .test_step import (CAD, README_FACES, check_curves_match_occ, check_edge_uses, check_loops,
                        check_raised_tolerances_bounded, check_segments_on_surface, check_surfaces_match_occ, load)

IGES_FILES = sorted(p.name for p in CAD.glob("*") if p.suffix.lower() in (".iges", ".igs"))
BEARING = "occt__bearing.iges"


def test_real_iges_files_are_covered():
    assert IGES_FILES == [BEARING]


@pytest.mark.parametrize("name", IGES_FILES)
def test_iges_faces_agree_with_open_cascade(name):
    shell = load(name).shell
    assert len(shell.faces) == README_FACES[name]
    check_surfaces_match_occ(name)
    check_curves_match_occ(name)


@pytest.mark.parametrize("name", IGES_FILES)
def test_iges_segments_loops_and_uses(name):
    check_segments_on_surface(name)
    check_raised_tolerances_bounded(name)
    check_loops(name)
    check_edge_uses(name)


def test_unsewn_bearing_has_free_edges():
    shell = load(BEARING).shell
    # README: 925 free edges, faces not sewn: every edge belongs to one face only
    assert len(shell.free_edges()) == 925
    assert not shell.is_closed() and not shell.non_manifold_edges()
    assert all(len(e.faces) == 1 for e in shell.edges)
    # the rest are seams (two uses by one face) or degenerate pole edges
    others = [e for e in shell.edges if len(e.uses) != 1 or e.is_degenerate]
    assert all(e.is_degenerate or len(e.uses) == 2 for e in others)
    assert all(shell.adjacency()[i] == set() for i in range(len(shell.faces)))


def _bad_file(case: str, tmp_path: Path) -> Path:
    if case == "missing":
        return tmp_path / "missing_model.iges"
    path = tmp_path / f"{case}_model.iges"
    if case == "empty":
        path.write_bytes(b"")
    elif case == "garbage":
        path.write_text("garbage, not an IGES file\n" * 3)
    elif case == "truncated":
        data = (CAD / BEARING).read_bytes()
        path.write_bytes(data[: len(data) // 2])
    elif case == "wrong_counts":  # a complete-looking file whose Terminate record disagrees with its sections
        lines = (CAD / BEARING).read_bytes().splitlines(keepends=True)
        path.write_bytes(b"".join(lines[:-3] + lines[-1:]))
    return path


@pytest.mark.parametrize("case, match", [
    ("missing", "no such file"), ("empty", "empty"), ("garbage", "no Terminate record"),
    ("truncated", "truncated"), ("wrong_counts", "states 9993 P records"),
])
def test_bad_iges_files_raise_one_line_and_print_nothing(case, match, tmp_path, capfd):
    path = _bad_file(case, tmp_path)
    with pytest.raises(IgesReadError, match=match) as info:
        _iges.read(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)
    out, err = capfd.readouterr()
    assert out == "" and err == ""
    with pytest.raises(FileFormatError, match=path.name):
        read_shell(path)


def test_reading_iges_prints_nothing(tmp_path, capfd):
    # Open CASCADE's IGES reader prints "Total number of loaded entities" on stdout unless silenced;
    # a small IGES file written by Open CASCADE keeps this test fast
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.IGESControl import IGESControl_Writer

    from trimsurf.io._occ import quiet_occ

    path = tmp_path / "box.iges"
    with quiet_occ():
        writer = IGESControl_Writer("MM", 1)
        writer.AddShape(BRepPrimAPI_MakeBox(1.0, 2.0, 3.0).Shape())
        writer.ComputeModel()
        assert writer.Write(str(path))
    capfd.readouterr()
    shell = _iges.read(path)
    out, err = capfd.readouterr()
    assert out == "" and err == ""
    assert len(shell.faces) == 6 and shell.is_closed()


def test_writing_iges_is_refused(tmp_path):
    with pytest.raises(FileFormatError, match="writing IGES is not supported"):
        write_shell(load(BEARING).shell, tmp_path / "out.iges")
    assert list(tmp_path.iterdir()) == []
