"""The trimsurf command in-process: help, version, info, samples, errors, warnings."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

import trimsurf
from trimsurf.cli import _common, build_parser, info as info_cmd, main
from trimsurf.errors import TrimsurfWarning
from trimsurf.samples import SAMPLES
from trimsurf.samples.fender import FENDER_TOLERANCE


def cli(*args: str) -> int:
    """main() with --debug, so an unexpected exception fails the test with its traceback."""
    return main(["--debug", *args])


def _one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("trimsurf: error: "), err
    assert "Traceback" not in err
    return lines[0]


def test_version(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"trimsurf {trimsurf.__version__}"


@pytest.mark.parametrize("sub", [[], ["info"], ["samples"], ["demo"]])
def test_help_ends_with_examples(sub, capsys):
    assert main([*sub, "--help"]) == 0
    out = capsys.readouterr().out
    tail = out.rstrip().split("examples:\n")[-1].splitlines()
    assert "examples:\n" in out
    assert 2 <= len(tail) <= 3 and all(line.startswith("  trimsurf ") for line in tail), tail


@pytest.mark.parametrize("argv", [[], ["frobnicate"], ["info"], ["info", "a.step", "--bogus"], ["demo", "--quick=3"]])
def test_usage_errors_exit_2(argv, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "usage: trimsurf" in err and "Traceback" not in err


def test_samples_list_text_and_json(capsys):
    assert cli("samples", "--list") == 0
    out = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in out] == list(SAMPLES)
    assert all(s.description in line for s, line in zip(SAMPLES.values(), out))
    assert cli("samples") == 0                              # listing is the default
    assert capsys.readouterr().out.splitlines() == out
    assert cli("samples", "--list", "--json") == 0
    data = json.loads(capsys.readouterr().out)
    assert [d["name"] for d in data] == list(SAMPLES) and {d["kind"] for d in data} == {"shell", "mesh"}


def test_samples_write_and_info_on_a_cad_file(tmp_path, capsys):
    path = tmp_path / "fender.step"
    assert cli("samples", "fender", "--out", str(path)) == 0
    assert path.stat().st_size > 1000
    capsys.readouterr()
    assert cli("info", "--json", str(path)) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["kind"] == "shell" and report["n_faces"] == 1
    assert report["faces"][0]["segments_per_loop"] == [6, 4]
    assert report["faces"][0]["degree_u"] == 3 and not report["faces"][0]["rational"]
    assert report["closed"] is False and report["edges"]["free"] == report["edges"]["total"] == 10
    assert 1000 < report["diagonal"] < 1500
    # Open CASCADE re-derives edge tolerances on writing (sometimes just below our sampled gaps), so
    # only hold the file to the sample's stated tolerance: no open loops, p-curves in the domain
    assert {p["kind"] for p in report["problems"]} <= {"edge_curve_gap"}
    assert report["faces"][0]["edge_curve_gap_max"] <= FENDER_TOLERANCE
    assert cli("info", str(path)) == 0
    text = capsys.readouterr().out
    assert "faces" in text and "B-spline 3x3" in text and "problems" in text


def test_info_finds_the_gap_pair_gap_in_a_step_file(tmp_path, capsys):
    path = tmp_path / "gap.step"
    assert cli("samples", "gap_pair", "--out", str(path)) == 0
    capsys.readouterr()
    assert cli("info", "--json", str(path)) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["edges"]["shared"] == 1 and report["n_faces"] == 2
    # however the writer stores the inconsistency (edge-curve gaps, or p-curves re-projected that
    # leave the loops open), info reports gaps of the sample's size (1e-3 of the diagonal)
    gaps = [p["gap"] for p in report["problems"] if "gap" in p]
    assert gaps and 0.2e-3 * report["diagonal"] < max(gaps) < 3e-3 * report["diagonal"]


def _plane_face(loop_corners):
    from trimsurf.model import Loop, NurbsCurve, NurbsSurface, PCurve, TrimmedFace
    cp = np.array([[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]], dtype=float)
    plane = NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], cp)
    c = [np.asarray(p, dtype=float) for p in loop_corners]
    segs = [PCurve(NurbsCurve(1, [0, 0, 1, 1], np.array([c[i], c[(i + 1) % len(c)]])), 0.0, 1.0) for i in range(len(c))]
    return TrimmedFace(plane, (Loop(tuple(segs)),))


def test_info_reports_self_crossing_trim_loops():
    from trimsurf.model import Shell
    bow_tie = _plane_face([(0.1, 0.1), (0.9, 0.9), (0.9, 0.1), (0.1, 0.9)])  # segments 0 and 2 cross at the middle
    square = _plane_face([(0.1, 0.1), (0.9, 0.1), (0.9, 0.9), (0.1, 0.9)])
    # a zero-length p-curve (a point, repeated samples) between two segments is not a crossing
    with_point = _plane_face([(0.1, 0.1), (0.9, 0.1), (0.9, 0.1), (0.9, 0.9), (0.1, 0.9)])
    report = info_cmd.shell_report(Shell((square, bow_tie, with_point)))
    crossings = [p for p in report["problems"] if p["kind"] == "self_crossing_loop"]
    assert len(crossings) == 1
    c = crossings[0]
    assert (c["face"], c["loop"], c["n_crossings"], c["segments"]) == (1, 0, 1, [0, 2])
    np.testing.assert_allclose(c["uv"], [0.5, 0.5], rtol=0, atol=1e-12)  # two straight lines: exact to rounding
    assert "face 1 loop 0: trim loop crosses itself" in info_cmd.format_report(report)


def test_info_finds_the_self_crossing_loop_of_real_data():
    from tests.io.test_step import load  # shares the session's single read of the file with the STEP tests

    report = info_cmd.shell_report(load("occtpr946__bug32596_abc_0_13.step").shell)
    crossings = [p for p in report["problems"] if p["kind"] == "self_crossing_loop"]
    # after NurbsConvert, face 65's outer loop crosses itself (BRepCheck rejects that face, see test_step);
    # no other loop of the file does
    assert [(p["face"], p["loop"], p["segments"]) for p in crossings] == [(65, 0, [1, 2])]
    # where the sampled polylines cross; the curves' own crossing is within a chord's sag (< 1e-3 of the
    # face's (u, v) extent, about 1 x 0.02) of it
    np.testing.assert_allclose(crossings[0]["uv"], [0.0114, 0.766], rtol=0, atol=1e-3)


def test_shell_report_of_the_box_in_memory():
    from trimsurf.samples import bspline_box, gap_pair
    r = info_cmd.shell_report(bspline_box())
    assert r["closed"] and r["edges"] == {"total": 12, "shared": 12, "free": 0, "non_manifold": 0, "degenerate": 0}
    assert r["surface_kinds"] == {"B-spline 3x3": 6} and r["n_problems"] == 0
    g = info_cmd.shell_report(gap_pair())
    assert {p["kind"] for p in g["problems"]} == {"edge_curve_gap"}
    assert len(g["problems"]) == 2                      # the shared edge, once per face
    json.dumps(_common.jsonable(g), allow_nan=False)


@pytest.mark.parametrize("name,suffix", [("s_cone", ".ply"), ("octahedron", ".obj")])
def test_samples_write_and_info_on_a_mesh(name, suffix, tmp_path, capsys):
    path = tmp_path / f"{name}{suffix}"
    assert cli("samples", name, "--out", str(path)) == 0
    capsys.readouterr()
    assert cli("info", "--json", str(path)) == 0
    r = json.loads(capsys.readouterr().out)
    mesh = SAMPLES[name].build()
    assert (r["n_vertices"], r["n_triangles"]) == (mesh.n_vertices, mesh.n_triangles)
    assert r["euler_characteristic"] == mesh.euler_characteristic()
    assert r["is_consistently_oriented"] is True and r["n_non_manifold_edges"] == 0
    assert r["is_watertight"] == (name == "octahedron")
    assert r["n_boundary_loops"] == (0 if name == "octahedron" else 1)
    assert r["min_angle_deg"] > 20
    assert cli("info", str(path)) == 0
    assert "Euler characteristic" in capsys.readouterr().out


def _bad_inputs(tmp_path):
    (tmp_path / "empty.step").write_bytes(b"")
    (tmp_path / "empty.obj").write_bytes(b"")
    (tmp_path / "garbage.step").write_text("ISO-10303-21;\nHEADER;\nthis is not STEP at all\n")
    (tmp_path / "truncated.step").write_text("ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('x'),'2;1');\nDATA;\n#1=CARTE")
    (tmp_path / "nan.off").write_text("OFF\n3 1 0\n0 0 0\n1 0 nan\n0 1 0\n3 0 1 2\n")
    (tmp_path / "badindex.off").write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")
    (tmp_path / "part.xyz").write_text("1 2 3\n")
    return {"missing": tmp_path / "missing.step", "empty_step": tmp_path / "empty.step",
            "empty_obj": tmp_path / "empty.obj", "garbage": tmp_path / "garbage.step",
            "truncated": tmp_path / "truncated.step", "nan": tmp_path / "nan.off",
            "badindex": tmp_path / "badindex.off", "suffix": tmp_path / "part.xyz", "folder": tmp_path}


@pytest.mark.parametrize("case", ["missing", "empty_step", "empty_obj", "garbage", "truncated", "nan", "badindex",
                                  "suffix", "folder"])
def test_info_bad_input_is_one_line_exit_2(case, tmp_path, capsys):
    path = _bad_inputs(tmp_path)[case]
    assert main(["info", str(path)]) == 2
    captured = capsys.readouterr()
    line = _one_error_line(captured.err)
    assert captured.out == ""
    assert path.name in line or str(path) in line, line


@pytest.mark.parametrize("argv,match", [
    (["samples", "teapot", "--out", "x.step"], "unknown sample 'teapot'"),
    (["samples", "fender", "--out", "{tmp}/fender.obj"], "is a CAD shell"),
    (["samples", "s_cone", "--out", "{tmp}/s.step"], "is a mesh"),
    (["samples", "fender"], "--out"),
    (["samples", "--list", "fender"], "--list"),
    (["demo", "--sample", "teapot", "--out", "{tmp}/d"], "unknown sample 'teapot'"),
])
def test_samples_bad_arguments(argv, match, tmp_path, capsys):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(argv) == 2
    assert match in _one_error_line(capsys.readouterr().err)
    assert not (tmp_path / "fender.obj").exists() and not (tmp_path / "s.step").exists()
    assert not list(tmp_path.glob(".*"))                  # no temporary file left behind


def test_internal_error_is_one_line_exit_1_and_raises_with_debug(monkeypatch, tmp_path, capsys):
    def boom(args):
        raise RuntimeError("something broke\non two lines")
    monkeypatch.setattr(info_cmd, "run", boom)
    assert main(["info", str(tmp_path / "x.step")]) == 1
    line = _one_error_line(capsys.readouterr().err)
    assert "internal error" in line and "RuntimeError" in line and "--debug" in line
    with pytest.raises(RuntimeError, match="something broke"):
        main(["--debug", "info", str(tmp_path / "x.step")])
    with pytest.raises(RuntimeError):
        main(["info", "--debug", str(tmp_path / "x.step")])     # --debug after the subcommand too


def test_keyboard_interrupt_is_one_line(monkeypatch, capsys):
    def interrupted(args):
        raise KeyboardInterrupt
    monkeypatch.setattr(info_cmd, "run", interrupted)
    assert main(["info", "x.step"]) == 2
    assert "interrupted" in _one_error_line(capsys.readouterr().err)


def test_oserror_is_one_line(monkeypatch, tmp_path, capsys):
    def denied(args):
        raise PermissionError(13, "Permission denied", str(tmp_path / "secret.step"))
    monkeypatch.setattr(info_cmd, "run", denied)
    assert main(["info", "x.step"]) == 2
    line = _one_error_line(capsys.readouterr().err)
    assert "secret.step" in line and "Permission denied" in line


def test_trimsurf_warnings_are_one_line_each(monkeypatch, capsys):
    def warns(args):
        warnings.warn("loop 3 of face 7 is open:\n gap 0.2", TrimsurfWarning, stacklevel=2)
        warnings.warn("second", TrimsurfWarning, stacklevel=2)
        return 0
    monkeypatch.setattr(info_cmd, "run", warns)
    assert main(["info", "x.step"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err == ["trimsurf: warning: loop 3 of face 7 is open: gap 0.2", "trimsurf: warning: second"]


def test_parser_lists_every_subcommand():
    text = build_parser().format_help()
    for name in ("info", "samples", "demo"):
        assert name in text


def test_every_help_text_is_formatted():
    """argparse %-formats argument help but not descriptions: '%%' there shows up doubled."""
    import argparse

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    assert len(sub.choices) >= 10
    for name, p in sub.choices.items():
        text = p.format_help()
        assert "%%" not in text and "%(" not in text, name


def test_jsonable_and_table():
    value = {"a": np.float64(np.nan), "b": np.arange(3), "c": (np.int64(2), np.bool_(True)), "d": float("inf")}
    assert _common.jsonable(value) == {"a": None, "b": [0, 1, 2], "c": [2, True], "d": None}
    table = _common.format_table([["title"], ["x", "1"], ["longer", "22"]])
    assert table.splitlines() == ["title", "x       1", "longer  22"]


def test_mesh_report_without_quality_matches(monkeypatch):
    """Without trimsurf.quality, info falls back on TriMesh helpers and reports the same topology."""
    import sys
    from trimsurf.samples import holed_sheet
    mesh = holed_sheet()
    full = info_cmd.mesh_report(mesh)
    monkeypatch.setitem(sys.modules, "trimsurf.quality", None)    # import now raises ImportError
    bare = info_cmd.mesh_report(mesh)
    for key in ("n_boundary_loops", "n_components", "euler_characteristic", "is_watertight",
                "is_consistently_oriented", "n_non_manifold_edges", "n_degenerate_triangles"):
        assert bare[key] == full[key], key
    assert bare["min_angle_deg"] == pytest.approx(full["min_angle_deg"], abs=1e-9)


def test_progress_draws_only_on_a_terminal(monkeypatch, capsys):
    import sys
    with _common.progress(3, "work") as bar:
        bar.advance()
    assert capsys.readouterr().err == ""                      # not a terminal: silent
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    with _common.progress(3, "work") as bar:
        for _ in range(3):
            bar.advance(description="working")
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err != ""          # drawn on stderr, never on stdout


def test_info_strict_rejects_an_open_trim_loop_with_exit_2(tmp_path, capsys):
    from trimsurf import io
    from trimsurf.model import Shell
    # the last corner misses the first by 0.05 in u: the loop is open
    open_face = _plane_face([(0.1, 0.1), (0.9, 0.1), (0.9, 0.9), (0.15, 0.9), (0.15, 0.15)])
    segs = open_face.loops[0].segments[:-1]  # drop the closing segment: a 0.05 gap remains
    from trimsurf.model import Loop, TrimmedFace
    face = TrimmedFace(open_face.surface, (Loop(segs),))
    path = tmp_path / "open.vda"
    with pytest.warns(Warning):
        io.write_shell(Shell.from_faces([face]), path)
        io.read_shell(path)
    capsys.readouterr()
    assert main(["info", str(path)]) == 0  # a report, not a verdict
    capsys.readouterr()
    assert main(["info", "--strict", str(path)]) == 2
    err = capsys.readouterr().err
    # the reader's warning about the gap, then the one error line
    warning, line = err.strip().splitlines()
    assert warning.startswith("trimsurf: warning: ") and "not closed" in warning
    line = _one_error_line(line)
    assert "open.vda" in line and "problem" in line and "open" in line
    square = _plane_face([(0.1, 0.1), (0.9, 0.1), (0.9, 0.9), (0.1, 0.9)])
    good = tmp_path / "square.vda"
    io.write_shell(Shell.from_faces([square]), good)
    assert main(["info", "--strict", str(good)]) == 0
