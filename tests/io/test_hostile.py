"""Hostile CAD input: Open CASCADE crashes and hangs contained in the reader process, syntax errors and
non-finite or huge numbers refused before the transfer, periodic B-splines read exactly, and a face
that cannot be converted skipped (named) instead of the whole file refused."""

from __future__ import annotations

import json
import re
import time
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from trimsurf import io
from trimsurf.errors import FaceSkippedWarning, GeometryError, IgesReadError, StepReadError, TrimsurfWarning
from trimsurf.io import _occ, _step
from trimsurf.io._occ import _checks, _to_shell
from trimsurf.samples import build_sample


@pytest.fixture(scope="module")
def gap_step(tmp_path_factory):
    path = tmp_path_factory.mktemp("gap") / "gap_pair.step"
    io.write_shell(build_sample("gap_pair"), path)
    return path


def _sub_first(src, dst, pattern: bytes, repl: bytes):
    data = src.read_bytes()
    new = re.sub(pattern, repl, data, count=1, flags=re.M)
    assert new != data
    dst.write_bytes(new)
    return dst


def _one_line(exc) -> str:
    text = str(exc)
    assert "\n" not in text
    return text


# --------------------------------------------------------------------------------------------------------------
# syntax errors, non-finite and huge numbers, crashes, hangs
# --------------------------------------------------------------------------------------------------------------

def test_step_record_with_incorrect_syntax_is_refused_before_the_transfer(gap_step, tmp_path):
    # the case: transferring this file kills the process (exit 139) inside Open CASCADE
    bad = _sub_first(gap_step, tmp_path / "abc.step", rb"^#25 = CARTESIAN_POINT\(.*\);$",
                     b"#25 = CARTESIAN_POINT('',(abc,,));")
    with pytest.raises(StepReadError) as info:
        io.read_shell(bad)
    text = _one_line(info.value)
    assert text.startswith(f"{bad}: not a valid STEP file") and "incorrect syntax" in text
    assert "#25" in text and "not a Real" in text


@pytest.mark.parametrize("literal, why", [(b"250.E+999", "is not finite"), (b"1.E300", "above 1e+10"),
                                          (b"-123456789012.5", "above 1e+10")])
def test_non_finite_or_huge_control_point_is_refused_quickly(gap_step, tmp_path, literal, why):
    # 250.E+999 in a surface's control point made `info` spin for over 100 s (NurbsConvert, TransferRoots)
    lines = gap_step.read_text().split("\n")
    at = next(i for i, ln in enumerate(lines) if ln.startswith("#44 = CARTESIAN_POINT"))
    lines[at] = "#44 = CARTESIAN_POINT('',(" + literal.decode() + ",180.,-64.389320225));"
    bad = tmp_path / "huge.step"
    bad.write_text("\n".join(lines))
    start = time.perf_counter()
    with pytest.raises(StepReadError) as info:
        io.read_shell(bad)
    assert time.perf_counter() - start < 20.0
    text = _one_line(info.value)
    assert text == f"{bad}: line {at + 1} (#44): the number {literal.decode()} {why}" or why in text
    assert f"line {at + 1} (#44)" in text


def test_huge_knot_is_refused_naming_its_line(gap_step, tmp_path):
    text = gap_step.read_text()
    new = text.replace("(0.,0.5,1.),(0.,0.3,\n    0.6,1.)", "(0.,0.5,1.E20),(0.,0.3,\n    0.6,1.)", 1)
    assert new != text
    bad = tmp_path / "knot.step"
    bad.write_text(new)
    with pytest.raises(StepReadError, match=r"knot\.step: line \d+ \(#41\): the number 1\.E20 is above 1e\+10"):
        io.read_shell(bad)


def test_big_numbers_in_strings_and_names_are_not_refused(gap_step, tmp_path):
    data = gap_step.read_bytes().replace(b"FILE_NAME('", b"FILE_NAME('1.E999 99999999999. ", 1)
    ok = tmp_path / "names.step"
    ok.write_bytes(data)
    _checks.check_file_numbers(ok, "STEP", StepReadError)
    assert len(io.read_shell(ok).faces) == 2


def _iges_of(shell, path):
    from OCP.IGESControl import IGESControl_Writer

    with _occ.quiet_occ():
        writer = IGESControl_Writer("MM", 1)
        writer.AddShape(_occ.shell_to_shape(shell))
        writer.ComputeModel()
        assert writer.Write(str(path))
    return path


def test_native_crash_in_the_reader_becomes_one_line_error_and_the_next_read_works(gap_step, tmp_path):
    # the IGES case: a blank knot in a B-spline curve record (126) kills Open CASCADE's transfer
    src = _iges_of(build_sample("gap_pair"), tmp_path / "gap.igs")
    lines = src.read_bytes().split(b"\n")
    rec = next(i for i, ln in enumerate(lines) if ln.startswith(b"126,11,"))
    knots = lines[rec + 1]
    lines[rec + 1] = knots.replace(b"0.500540029,0.500540029,", b"           ,0.500540029,", 1)
    assert lines[rec + 1] != knots
    bad = tmp_path / "blank_knot.igs"
    bad.write_bytes(b"\n".join(lines))
    with pytest.raises(IgesReadError) as info:
        io.read_shell(bad)
    text = _one_line(info.value)
    assert text.startswith(f"{bad}: Open CASCADE crashed (SIGSEGV) while reading the IGES file")
    # the reader server survives its child's crash
    assert len(io.read_shell(src).faces) == 2
    assert len(io.read_shell(gap_step).faces) == 2


def test_read_that_does_not_finish_is_stopped_at_the_time_limit(shared_data, gap_step, monkeypatch):
    big = shared_data / "cad" / "occt__linkrods.step"  # ~1.3 s to read
    monkeypatch.setenv("TRIMSURF_READ_TIMEOUT", "0.05")
    start = time.perf_counter()
    with pytest.raises(StepReadError) as info:
        io.read_shell(big)
    assert time.perf_counter() - start < 10.0
    assert _one_line(info.value).startswith(f"{big}: reading the STEP file did not finish within 0.05 s")
    monkeypatch.setenv("TRIMSURF_READ_TIMEOUT", "60")
    assert len(io.read_shell(gap_step).faces) == 2


def test_reading_from_an_unguarded_script_runs_the_script_once(gap_step, tmp_path):
    # multiprocessing's spawn/forkserver would re-run a script without `if __name__ == "__main__"`
    import os
    import subprocess
    import sys

    script = tmp_path / "plain.py"
    script.write_text(f"from trimsurf import io\nprint('faces', len(io.read_shell({str(gap_step)!r}).faces))\n")
    src = str(Path(_occ.__file__).resolve().parents[3])
    env = dict(os.environ, PYTHONPATH=src + os.pathsep + os.environ.get("PYTHONPATH", ""))
    env.pop("TRIMSURF_OCC_IN_PROCESS", None)
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stdout == "faces 2\n" and run.stderr == ""


def test_default_time_limit_grows_with_the_file(tmp_path, monkeypatch):
    from trimsurf.io._occ._isolate import read_timeout

    monkeypatch.delenv("TRIMSURF_READ_TIMEOUT", raising=False)
    small, large = tmp_path / "s.step", tmp_path / "l.step"
    small.write_bytes(b"x" * 1000)
    large.write_bytes(b"x" * 2_000_000)
    assert read_timeout(small) == pytest.approx(30.03)
    assert read_timeout(large) == pytest.approx(90.0)


def test_shape_with_huge_geometry_is_refused_naming_the_face():
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace

    surface = _occ.surface_to_occ(build_sample("gap_pair").faces[0].surface)
    surface.SetPole(2, 2, surface.Pole(2, 2).Translated(__import__("OCP.gp", fromlist=["gp_Vec"]).gp_Vec(3e10, 0, 0)))
    face = BRepBuilderAPI_MakeFace(surface, 1e-7).Face()
    with pytest.raises(StepReadError) as info:
        _checks.check_shape_geometry(face, "x.step", StepReadError)
    assert _one_line(info.value).startswith("x.step: face 0: Geom_BSplineSurface has a control point value 3e+10")


# --------------------------------------------------------------------------------------------------------------
# periodic B-splines
# --------------------------------------------------------------------------------------------------------------

def _arr(values, cls=None):
    from OCP.collections import Array1_double, Array1_int

    cls = cls or Array1_double
    a = cls(1, len(values))
    for i, v in enumerate(values, start=1):
        a.SetValue(i, v)
    return a


def _periodic_surface(rational: bool, both: bool = False):
    """A u-periodic (and with `both` v-periodic) B-spline surface: degree 2 x 3, 7 poles in u, mixed multiplicities."""
    from OCP.collections import Array1_int, Array2_double, Array2_gp_Pnt
    from OCP.Geom import Geom_BSplineSurface
    from OCP.gp import gp_Pnt

    rng = np.random.default_rng(11)
    nu = 7
    uk, um = [0.0, 0.9, 2.0, 2.6, 4.0], [2, 1, 2, 2, 2]  # sum of mults without the last = 7 poles
    if both:
        vk, vm, nv, vdeg = [0.0, 1.0, 1.5, 2.5, 3.0], [1, 1, 1, 1, 1], 4, 3
    else:
        vk, vm, nv, vdeg = [0.0, 0.4, 1.0], [4, 1, 4], 5, 3
    poles, weights = Array2_gp_Pnt(1, nu, 1, nv), Array2_double(1, nu, 1, nv)
    for i in range(nu):
        a = 2 * np.pi * i / nu
        for j in range(nv):
            b = 2 * np.pi * j / nv
            r = 10.0 + 3.0 * np.cos(b) if both else 10.0 + rng.normal()
            z = 3.0 * np.sin(b) if both else 4.0 * j + rng.normal()
            poles.SetValue(i + 1, j + 1, gp_Pnt(r * np.cos(a), r * np.sin(a), z))
            weights.SetValue(i + 1, j + 1, float(rng.uniform(0.7, 1.4)) if rational else 1.0)
    args = (poles, weights) if rational else (poles,)
    bs = Geom_BSplineSurface(*args, _arr(uk), _arr(vk), _arr(um, Array1_int), _arr(vm, Array1_int), 2, vdeg,
                             True, both)
    assert bs.IsUPeriodic() and bs.IsVPeriodic() == both
    return bs


def _occ_points(surface, uv):
    return np.array([surface.Value(u, v).Coord() for u, v in uv])


@pytest.mark.parametrize("rational", [False, True])
@pytest.mark.parametrize("u_range", [(0.3, 3.1), (-1.2, 2.5), (3.0, 6.5), (0.0, 4.0)])
def test_periodic_bspline_surface_converts_point_by_point(rational, u_range):
    bs = _periodic_surface(rational)
    v_range = (0.1, 0.9)
    lo, hi = np.array([u_range[0], v_range[0]]), np.array([u_range[1], v_range[1]])
    surf = _occ.surface_from_occ(bs, lo, hi)
    (d0, d1), _ = surf.domain
    assert d0 <= lo[0] + 1e-12 and d1 >= hi[0] - 1e-12 and d1 - d0 == pytest.approx(4.0)
    rng = np.random.default_rng(2)
    uv = np.column_stack([rng.uniform(*u_range, 200), rng.uniform(*v_range, 200)])
    # Open CASCADE evaluates the periodic surface; ours is the clamped form on [d0, d0 + period]
    assert_allclose(surf.evaluate(uv), _occ_points(bs, uv), rtol=0, atol=1e-11)
    assert bs.IsUPeriodic()  # the input is not modified


def test_surface_periodic_in_both_directions_converts_point_by_point():
    bs = _periodic_surface(True, both=True)
    lo, hi = np.array([-0.5, -0.7]), np.array([3.2, 2.0])
    surf = _occ.surface_from_occ(bs, lo, hi)
    rng = np.random.default_rng(4)
    uv = np.column_stack([rng.uniform(lo[0], hi[0], 200), rng.uniform(lo[1], hi[1], 200)])
    assert_allclose(surf.evaluate(uv), _occ_points(bs, uv), rtol=0, atol=1e-11)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("t_range", [(0.2, 3.9), (-2.0, 1.0), (5.0, 7.5)])
def test_periodic_bspline_curve_converts_point_by_point(dim, t_range):
    from OCP.collections import Array1_gp_Pnt, Array1_gp_Pnt2d, Array1_int
    from OCP.Geom import Geom_BSplineCurve
    from OCP.Geom2d import Geom2d_BSplineCurve
    from OCP.gp import gp_Pnt, gp_Pnt2d

    rng = np.random.default_rng(dim)
    knots, mults = [0.0, 0.5, 1.7, 2.0, 3.1, 4.0], [1, 2, 1, 1, 1, 1]  # 6 poles, degree 3
    n = sum(mults[:-1])
    if dim == 3:
        poles = Array1_gp_Pnt(1, n)
        for i in range(n):
            poles.SetValue(i + 1, gp_Pnt(*rng.normal(size=3)))
        curve = Geom_BSplineCurve(poles, _arr(rng.uniform(0.5, 2.0, n).tolist()), _arr(knots), _arr(mults, Array1_int),
                                  3, True)
    else:
        poles = Array1_gp_Pnt2d(1, n)
        for i in range(n):
            poles.SetValue(i + 1, gp_Pnt2d(*rng.normal(size=2)))
        curve = Geom2d_BSplineCurve(poles, _arr(knots), _arr(mults, Array1_int), 3, True)
    assert curve.IsPeriodic()
    ours = _occ.curve_from_occ(curve, *t_range, dim)
    assert ours.domain[0] <= t_range[0] + 1e-12 and ours.domain[1] >= t_range[1] - 1e-12
    ts = np.linspace(*t_range, 101)
    ref = np.array([curve.Value(t).Coord() for t in ts])
    assert_allclose(ours.evaluate(ts), ref, rtol=0, atol=1e-11)


def test_face_on_a_periodic_surface_across_its_seam_reads_through_step(tmp_path):
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.BRepTools import BRepTools
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    bs = _periodic_surface(True)
    face = BRepBuilderAPI_MakeFace(bs, -1.0, 2.5, 0.05, 0.95, 1e-7).Face()  # crosses the seam u = 0
    path = tmp_path / "periodic.step"
    with _occ.quiet_occ():
        writer = STEPControl_Writer()
        writer.Transfer(face, STEPControl_AsIs)
        assert writer.Write(str(path))
    # Open CASCADE's NurbsConvert refuses this face ("Knots interval values too close"): it is read on its own
    with pytest.warns(TrimsurfWarning, match="converted one by one"):
        shell = io.read_shell(path)
    assert len(shell.faces) == 1
    with pytest.warns(TrimsurfWarning, match="converted one by one"):
        ref_shape = _step.read_occ_shape(path)  # Open CASCADE's own read of the same file
    ref_face = _occ.map_topology(ref_shape).faces[0]
    from OCP.BRep import BRep_Tool

    ref_surface = BRep_Tool.Surface_s(ref_face)
    u0, u1, v0, v1 = BRepTools.UVBounds_s(ref_face)
    rng = np.random.default_rng(8)
    uv = np.column_stack([rng.uniform(u0, u1, 200), rng.uniform(v0, v1, 200)])
    assert_allclose(shell.faces[0].surface.evaluate(uv), _occ_points(ref_surface, uv), rtol=0, atol=1e-10)
    # the loop closes on the surface: the trim is the face's boundary
    loop = shell.faces[0].loops[0]
    pts = shell.faces[0].surface.evaluate(loop.polyline(17))
    assert np.isfinite(pts).all()
    area_uv = (u1 - u0) * (v1 - v0)
    assert area_uv == pytest.approx(3.5 * 0.9, rel=1e-9)


# --------------------------------------------------------------------------------------------------------------
# a face that cannot be converted
# --------------------------------------------------------------------------------------------------------------

def _fail_face(monkeypatch, bad_index: int = 1):
    real = _to_shell.surface_from_occ
    calls = {"n": 0}

    def flaky(surface, lo, hi):
        calls["n"] += 1
        if calls["n"] == bad_index + 1:
            raise GeometryError("NurbsSurface (u): need 10 knots for 7 control points of degree 2; got 11")
        return real(surface, lo, hi)

    monkeypatch.setattr(_to_shell, "surface_from_occ", flaky)


def test_face_that_cannot_be_converted_is_skipped_and_named(shared_data, monkeypatch):
    path = shared_data / "cad" / "gmsh__t20_data.step"
    whole = _step.read_in_process(path)
    _fail_face(monkeypatch, 1)
    with pytest.warns(FaceSkippedWarning, match=r"gmsh__t20_data.step: face 1 skipped: GeometryError: "
                                                 r"NurbsSurface \(u\): need 10 knots"):
        shell = _step.read_in_process(path)
    assert len(shell.faces) == len(whole.faces) - 1 == 20
    assert [f.name for f in shell.faces] == [f.name for f in whole.faces if f.name != "gmsh__t20_data.step face 1"]
    # the edges of the skipped face are now free (one use) or gone; every use points at a kept face's segment
    assert len(shell.free_edges()) == sum(len(lp) for lp in whole.faces[1].loops)
    for e, edge in enumerate(shell.edges):
        for f, l, s in edge.uses:
            assert shell.faces[f].loops[l].segments[s].edge_id == e
    # without skipping, the first failure raises as before
    _fail_face(monkeypatch, 1)
    with pytest.raises(GeometryError):
        _occ.shape_to_shell(_step.read_occ_shape(path), name="x")


def test_cli_names_the_skipped_face_reports_it_and_exits_1(shared_data, monkeypatch, capsys, tmp_path):
    from trimsurf.cli import main

    monkeypatch.setenv("TRIMSURF_OCC_IN_PROCESS", "1")  # so that the monkeypatch reaches the conversion
    path = shared_data / "cad" / "gmsh__t20_data.step"
    _fail_face(monkeypatch, 3)
    assert main(["info", "--json", str(path)]) == 1
    out, err = capsys.readouterr()
    report = json.loads(out)
    assert report["n_faces"] == 20 and len(report["skipped_faces"]) == 1
    assert err.strip().splitlines() == [f"trimsurf: warning: {report['skipped_faces'][0]}"]
    assert "face 3 skipped" in err


def test_no_face_converted_is_one_error(shared_data, monkeypatch):
    def broken(surface, lo, hi):
        raise GeometryError("bad")

    monkeypatch.setattr(_to_shell, "surface_from_occ", broken)
    with pytest.warns(FaceSkippedWarning), pytest.raises(GeometryError, match="no face could be converted"):
        _step.read_in_process(shared_data / "cad" / "occt__screw.step")


def test_batch_goes_on_after_a_file_that_crashes_open_cascade(gap_step, tmp_path, capsys):
    from trimsurf.cli import main

    folder = tmp_path / "in"
    folder.mkdir()
    src = _iges_of(build_sample("gap_pair"), tmp_path / "gap.igs")
    lines = src.read_bytes().split(b"\n")
    rec = next(i for i, ln in enumerate(lines) if ln.startswith(b"126,11,"))
    lines[rec + 1] = lines[rec + 1].replace(b"0.500540029,0.500540029,", b"           ,0.500540029,", 1)
    (folder / "a_crash.igs").write_bytes(b"\n".join(lines))
    (folder / "b_good.step").write_bytes(gap_step.read_bytes())
    out = tmp_path / "out"
    assert main(["tessellate", str(folder), "-o", str(out) + "/"]) == 1
    err = capsys.readouterr().err
    assert f"trimsurf: error: {folder / 'a_crash.igs'}: Open CASCADE crashed (SIGSEGV)" in err
    assert sorted(p.name for p in out.iterdir()) == ["b_good.ply"]
    assert io.read_mesh(out / "b_good.ply").n_triangles > 0
