"""Issue 16 (hostile input), the CLI's part: budgets, outputs, batches, bounded mesh coordinates.

Every refusal is exit 2 with exactly one ``trimsurf: error:`` line naming what the user typed, before the
work starts (so these tests are fast), and leaves no file behind.
"""

from __future__ import annotations

import json
import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from trimsurf import io
from trimsurf.cli import _common, main
from trimsurf.errors import InputError
from trimsurf.io._atomic import atomic_path, new_file_mode
from trimsurf.samples import build_sample


def _one_error(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("trimsurf: error: ") and "Traceback" not in err and "Warning" not in err, err
    return lines[0]


def _files(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


@pytest.fixture(scope="module")
def cad(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("cad")
    io.write_shell(build_sample("gap_pair"), folder / "gap_pair.step")
    return folder


@pytest.fixture(scope="module")
def sheet(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("mesh") / "sheet.obj"
    io.write_mesh(build_sample("holed_sheet"), path)
    return path


# -- budgets -------------------------------------------------------------------------------------------

@pytest.mark.parametrize("argv, message", [
    (["tessellate", "{gap}", "-o", "{out}/o.ply", "--max-edge=1e-3"], "--max-edge 0.001 too small: would make ~"),
    (["tessellate", "{gap}", "-o", "{out}/o.ply", "--tolerance=1e-9"], "--tolerance 1e-09 too small: would make ~"),
    (["reconstruct", "octahedron", "-o", "{out}/o.ply", "--density=100000"], "--density 100000 too large"),
    (["fit", "{sheet}", "-o", "{out}/o.step", "--grid", "400", "400"], "--grid 400 400 too large"),
    (["join", "{gap}", "-o", "{out}/o.ply", "--deflection=1e-8"], "--deflection 1e-08 too small"),
    (["join", "{gap}", "-o", "{out}/o.ply", "--deflection=1e-4", "--mesher", "trimsurf"],
     "--deflection 0.0001 too small: would make ~"),
])
def test_budget_refuses_before_computing(argv, message, cad, sheet, tmp_path, capsys):
    """The issue's 5.8 GB tessellate, 7.2 GB reconstruct, 5.1 GB fit: refused in seconds, exit 2, a hint."""
    out = tmp_path / "out"
    out.mkdir()
    argv = [a.format(gap=cad / "gap_pair.step", sheet=sheet, out=out) for a in argv]
    t0 = time.perf_counter()
    assert main(argv) == 2
    assert time.perf_counter() - t0 < 10
    line = _one_error(capsys.readouterr().err)
    assert message in line, line
    assert ("TRIMSURF_MEMORY_BUDGET" in line and "use a smaller" in line or "use a larger" in line
            or "below Open CASCADE's precision" in line), line
    assert _files(out) == []


def test_join_issue_deflection_refused(cad, tmp_path, capsys):
    """The issue's `join gap_pair --deflection=1e-6` (past 120 s, 4 GB): refused after the cheap face meshing."""
    t0 = time.perf_counter()
    assert main(["join", str(cad / "gap_pair.step"), "-o", str(tmp_path / "j.ply"), "--deflection=1e-6"]) == 2
    assert time.perf_counter() - t0 < 60
    line = _one_error(capsys.readouterr().err)
    assert "--deflection 1e-06 too small: would make ~" in line and "use a larger --deflection" in line
    assert _files(tmp_path) == []


def test_budget_environment_variable(monkeypatch):
    monkeypatch.delenv("TRIMSURF_MEMORY_BUDGET", raising=False)
    _common.check_budget(5e4, "fit_control_point", what="w", hint="h")  # 1.6 GB: within the default 2 GiB
    with pytest.raises(_common.BudgetError):
        _common.check_budget(1e5, "fit_control_point", what="w", hint="h")
    monkeypatch.setenv("TRIMSURF_MEMORY_BUDGET", "8G")
    _common.check_budget(1e5, "fit_control_point", what="w", hint="h")
    assert _common.memory_budget() == 8 * 2 ** 30
    for bad in ("lots", "-1G", "nan"):
        monkeypatch.setenv("TRIMSURF_MEMORY_BUDGET", bad)
        with pytest.raises(InputError, match="TRIMSURF_MEMORY_BUDGET"):
            _common.memory_budget()
    with pytest.raises(_common.BudgetError, match="unboundedly many"):
        monkeypatch.setenv("TRIMSURF_MEMORY_BUDGET", "1T")
        _common.check_budget(float("inf"), "tessellate_triangle", what="w", hint="h")


@pytest.mark.parametrize("name, tolerance, max_edge", [("gap_pair", None, None), ("hood", 0.05, None),
                                                       ("bspline_box", None, 20.0)])
def test_tessellate_estimate_is_within_a_factor_of_three(name, tolerance, max_edge):
    """The budget's triangle estimate against the triangles the tessellator writes (0.7-1.8x when measured)."""
    from trimsurf.cli.tessellate import check_tessellate_budget
    from trimsurf.tessellate import tessellate_shell
    from trimsurf.tessellate.shell import default_parameters

    shell = build_sample(name)
    d_tol, d_h = default_parameters(shell)
    estimate = 3.0 * _common.estimate_shell_triangles(shell, tolerance or d_tol, max_edge or d_h)
    res = tessellate_shell(shell, tolerance=tolerance, max_edge=max_edge, measure=False)
    assert 1 / 3 <= res.mesh.n_triangles / estimate <= 3, (res.mesh.n_triangles, estimate)
    check_tessellate_budget(shell, name, tolerance, max_edge)  # well within the budget: no error


def test_memory_error_is_one_line_exit_2(monkeypatch, cad, tmp_path, capsys):
    from trimsurf.cli import tessellate as cmd

    def boom(*a, **k):
        raise MemoryError()

    monkeypatch.setattr("trimsurf.tessellate.tessellate_shell", boom)
    assert main(["tessellate", str(cad / "gap_pair.step"), "-o", str(tmp_path / "o.ply")]) == 2
    assert "out of memory" in _one_error(capsys.readouterr().err)
    assert _files(tmp_path) == []
    assert cmd.NAME == "tessellate"


# -- item 4: --loose with every face failed ---------------------------------------------------------------

def test_loose_with_every_face_failed(cad, tmp_path, capsys):
    assert main(["tessellate", str(cad / "gap_pair.step"), "-o", str(tmp_path / "o.ply"), "--loose"]) == 1
    err = capsys.readouterr().err
    assert "no face could be tessellated" in err and "concatenate" not in err and "internal error" not in err
    assert _files(tmp_path) == []


# -- item 5: mesh coordinates ----------------------------------------------------------------------------------

@pytest.mark.parametrize("value, message", [("1e300", "beyond the supported magnitude"),
                                            ("inf", "non-finite"), ("nan", "non-finite"),
                                            ("-2e12", "beyond the supported magnitude")])
@pytest.mark.parametrize("suffix", [".off", ".obj"])
def test_mesh_coordinates_finite_and_bounded(value, message, suffix, tmp_path, capsys):
    path = tmp_path / f"m{suffix}"
    if suffix == ".off":
        path.write_text(f"OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n{value} 1 0\n3 0 1 2\n3 1 3 2\n")
    else:
        path.write_text(f"v 0 0 0\nv 1 0 0\nv 0 1 0\nv {value} 1 0\nf 1 2 3\nf 2 4 3\n")
    for argv in (["info", str(path)], ["view", str(path), "--png", str(tmp_path / "v.png")]):
        assert main(argv) == 2
        line = _one_error(capsys.readouterr().err)
        assert message in line and "vertex 3" in line and str(path) in line, line
    assert _files(tmp_path) == [path.name]


def test_stl_huge_coordinate_names_the_triangle(tmp_path):
    tri = build_sample("octahedron")
    v = tri.vertices.copy()
    v[tri.triangles[2, 1]] = [1e20, 0, 0]  # STL is float32
    path = tmp_path / "m.stl"
    io.write_mesh(type(tri)(v, tri.triangles), path)
    with pytest.raises(InputError, match=r"triangle \d+ has coordinate 1e\+20, beyond"):
        io.read_mesh(path)


def test_rejected_inputs_print_no_numpy_warning(tmp_path):
    """A real process: nothing but the one error line on stderr (no RuntimeWarning from numpy)."""
    path = tmp_path / "m.off"
    path.write_text("OFF\n3 1 0\n0 0 0\n1e300 1e300 1e300\n-1e300 1 0\n3 0 1 2\n")
    for cmd in ("info", "view"):
        res = subprocess.run([sys.executable, "-m", "trimsurf", cmd, str(path), "--png", str(tmp_path / "x.png")]
                             if cmd == "view" else [sys.executable, "-m", "trimsurf", cmd, str(path)],
                             capture_output=True, text=True, timeout=120, cwd=tmp_path)
        assert res.returncode == 2, res.stderr
        _one_error(res.stderr)


def test_view_large_coordinates_and_degenerate_extent(tmp_path, capsys):
    """Coordinates near the bound render (no camera assert); an extent below float32's reach is one line."""
    far = tmp_path / "far.off"
    far.write_text("OFF\n3 1 0\n1e11 0 0\n100000000010 0 0\n1e11 10 0\n3 0 1 2\n")
    assert main(["view", str(far), "--png", str(tmp_path / "far.png"), "--size", "160x120"]) == 0
    assert (tmp_path / "far.png").stat().st_size > 0
    tiny = tmp_path / "tiny.off"
    tiny.write_text("OFF\n3 1 0\n1e11 0 0\n1e11 1e-4 0\n1e11 0 1e-4\n3 0 1 2\n")
    capsys.readouterr()
    assert main(["view", str(tiny), "--png", str(tmp_path / "tiny.png")]) == 2
    assert "too small to render" in _one_error(capsys.readouterr().err)
    assert not (tmp_path / "tiny.png").exists()


# -- item 6: outputs ---------------------------------------------------------------------------------------

@pytest.fixture
def umask():
    def set_mask(mask: int) -> None:
        os.umask(mask)

    old = os.umask(0o022)
    yield set_mask
    os.umask(old)


@pytest.mark.parametrize("mask", [0o022, 0o002, 0o077])
def test_new_outputs_respect_the_umask(mask, umask, cad, tmp_path):
    umask(mask)
    with atomic_path(tmp_path / "a.txt") as tmp:
        tmp.write_text("x")
    assert stat.S_IMODE((tmp_path / "a.txt").stat().st_mode) == 0o666 & ~mask
    out = tmp_path / "o.ply"
    assert main(["tessellate", str(cad / "gap_pair.step"), "-o", str(out), "--tolerance", "20",
                 "--report", str(tmp_path / "r.json")]) == 0
    for p in (out, tmp_path / "r.json"):
        assert stat.S_IMODE(p.stat().st_mode) == 0o666 & ~mask, p


def test_overwrite_keeps_the_mode(umask, tmp_path):
    umask(0o077)
    target = tmp_path / "o.obj"
    target.write_text("old")
    target.chmod(0o664)
    assert new_file_mode(target) == 0o664
    io.write_mesh(build_sample("octahedron"), target)
    assert stat.S_IMODE(target.stat().st_mode) == 0o664 and target.read_text() != "old"
    assert _files(tmp_path) == ["o.obj"]


def test_atomic_errors_name_the_target(tmp_path):
    folder = tmp_path / "x.ply"
    folder.mkdir()
    with pytest.raises(IsADirectoryError) as info:
        with atomic_path(folder) as tmp:
            tmp.write_text("x")
    assert info.value.filename == str(folder)
    assert _files(tmp_path) == ["x.ply"] and _files(folder) == []


def test_write_errors_name_the_target(tmp_path, monkeypatch, capsys):
    """A full disk while the mesh is written: one line naming -o's path, no temporary file left."""
    import errno
    import pathlib

    def full(self, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self))

    monkeypatch.setattr(pathlib.Path, "write_bytes", full)
    out = tmp_path / "o.ply"
    assert main(["reconstruct", "octahedron", "-o", str(out)]) == 2
    assert _one_error(capsys.readouterr().err) == f"trimsurf: error: {out}: No space left on device"
    assert _files(tmp_path) == []


_SLOW_WRITE = """
import pathlib, sys, time
from trimsurf.cli import main
real = pathlib.Path.write_bytes
def slow(self, data):
    n = real(self, data[: len(data) // 2])
    print("WRITING", self.name, flush=True)
    time.sleep(60)
    return n
pathlib.Path.write_bytes = slow
sys.exit(main(sys.argv[1:]))
"""


def test_sigterm_during_a_write_leaves_nothing(tmp_path):
    """SIGTERM while the mesh is being written: exit 2, one line, neither the output nor a hidden temp file."""
    out = tmp_path / "out"
    out.mkdir()
    proc = subprocess.Popen([sys.executable, "-c", _SLOW_WRITE, "reconstruct", "octahedron", "-o",
                             str(out / "o.ply")], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        assert line.startswith("WRITING .o."), line       # the temporary file beside the target
        assert len(_files(out)) == 1
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 2
    assert _one_error(err) == "trimsurf: error: terminated"
    assert _files(out) == []


@pytest.mark.parametrize("argv, message", [
    (["reconstruct", "octahedron", "-o", "{dir}"], "-o {dir}: is a folder"),
    (["reconstruct", "octahedron", "-o", "{tmp}/o.ply", "--report", "{dir}"], "--report {dir}: is a folder"),
    (["reconstruct", "octahedron", "-o", "{tmp}/missing/o.ply"], "-o {tmp}/missing/o.ply: folder {tmp}/missing "
                                                                  "does not exist"),
    (["reconstruct", "octahedron", "-o", "{tmp}/file.txt/o.ply"], "{tmp}/file.txt is not a folder"),
    (["tessellate", "{gap}", "-o", "{tmp}/o.ply", "--report", "{dir}"], "--report {dir}: is a folder"),
    (["tessellate", "{gap}", "-o", "{tmp}/missing/o.ply"], "folder {tmp}/missing does not exist"),
    (["tessellate", "{gap}", "{gap}", "-o", "{tmp}/file.txt"], "several inputs need an output folder"),
    (["join", "{gap}", "-o", "{dir}"], "-o {dir}: is a folder"),
    (["certify", "{gap}", "--write-mesh", "{dir}"], "--write-mesh {dir}: is a folder"),
    (["certify", "{gap}", "--report", "{tmp}/missing/r.json"], "does not exist"),
    (["fit", "{sheet}", "-o", "{tmp}/o.step", "--png", "{tmp}/x.jpg"], "--png {tmp}/x.jpg: expected a .png"),
    (["fit", "{sheet}", "-o", "{tmp}/o.step", "--report", "{dir}"], "--report {dir}: is a folder"),
    (["view", "octahedron", "--html", "{dir}/v.html", "--report", "{dir}"], "--report {dir}: is a folder"),
    (["view", "octahedron", "--png", "{tmp}/missing/v.png"], "does not exist"),
    (["samples", "octahedron", "--out", "{dir}"], "--out {dir}: is a folder"),
    (["demo", "--out", "{tmp}/missing/demo"], "folder {tmp}/missing does not exist"),
])
def test_outputs_checked_before_the_work(argv, message, cad, sheet, tmp_path, capsys, monkeypatch):
    """Bad output paths fail in well under a second with the user's path; nothing is computed or written."""
    folder = tmp_path / "adir.ply"
    folder.mkdir()
    (tmp_path / "file.txt").write_text("x")
    fmt = dict(dir=folder, tmp=tmp_path, gap=cad / "gap_pair.step", sheet=sheet)

    def never(*a, **k):
        raise AssertionError("the work started")

    for name in ("trimsurf.reconstruct.reconstruct_mesh", "trimsurf.tessellate.tessellate_shell",
                 "trimsurf.io.read_shell", "trimsurf.io.read_mesh", "trimsurf.join.join_shell",
                 "trimsurf.certify.certify_shell"):
        monkeypatch.setattr(name, never)
    before = sorted(p.name for p in tmp_path.rglob("*"))
    assert main([a.format(**fmt) for a in argv]) == 2
    line = _one_error(capsys.readouterr().err)
    assert message.format(**fmt) in line, line
    assert "/." not in line  # never a temporary file's name
    assert sorted(p.name for p in tmp_path.rglob("*")) == before


def test_two_inputs_and_a_mesh_file_name(cad, tmp_path, capsys):
    other = tmp_path / "other.step"
    other.write_bytes((cad / "gap_pair.step").read_bytes())
    assert main(["tessellate", str(cad / "gap_pair.step"), str(other), "-o", str(tmp_path / "out.ply")]) == 2
    line = _one_error(capsys.readouterr().err)
    assert "2 inputs need an output folder" in line and "out.ply" in line
    assert _files(tmp_path) == ["other.step"]


def test_two_inputs_with_the_same_stem(cad, tmp_path, capsys):
    (tmp_path / "a").mkdir()
    twin = tmp_path / "a" / "gap_pair.step"
    twin.write_bytes((cad / "gap_pair.step").read_bytes())
    assert main(["tessellate", str(cad / "gap_pair.step"), str(twin), "-o", str(tmp_path / "out")]) == 2
    assert "would both be written to" in _one_error(capsys.readouterr().err)
    assert not (tmp_path / "out").exists()


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_unwritable_output_folder(tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        assert main(["reconstruct", "octahedron", "-o", str(ro / "o.ply")]) == 2
        assert f"folder {ro} is not writable" in _one_error(capsys.readouterr().err)
    finally:
        ro.chmod(0o755)


# -- item 7: folder inputs -----------------------------------------------------------------------------------

def test_folder_batch_goes_on_after_a_bad_file(cad, tmp_path, capsys):
    src = tmp_path / "cad"
    src.mkdir()
    good = (cad / "gap_pair.step").read_bytes()
    (src / "a.step").write_bytes(good)
    (src / "b.step").write_text("ISO-10303-21;\nthis is not STEP\n")
    (src / "c.step").write_bytes(good)
    out, report = tmp_path / "out", tmp_path / "r.json"
    assert main(["tessellate", str(src), "-o", str(out), "--tolerance", "20", "--report", str(report)]) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err
    errors = [ln for ln in err.splitlines() if ln.startswith("trimsurf: error: ")]
    assert len(errors) == 1 and str(src / "b.step") in errors[0]
    assert "1 of 3 inputs failed: b.step" in err
    assert _files(out) == ["a.ply", "c.ply"]
    data = json.loads(report.read_text())
    assert [e["input"] for e in data["failed_inputs"]] == [str(src / "b.step")]
    assert [e["output"] for e in data["inputs"]] == [str(out / "a.ply"), None, str(out / "c.ply")]
    assert data["total"]["triangles"] == 2 * io.read_mesh(out / "a.ply").n_triangles


def test_folder_batch_of_unreadable_files_exit_2(tmp_path, capsys):
    src = tmp_path / "cad"
    src.mkdir()
    for name in ("a.step", "b.igs", "c.vda"):
        (src / name).write_text("garbage\n")
    report = tmp_path / "r.json"
    assert main(["tessellate", str(src), "-o", str(tmp_path / "out"), "--report", str(report)]) == 2
    err = capsys.readouterr().err
    assert len([ln for ln in err.splitlines() if ln.startswith("trimsurf: error: ")]) == 3
    assert "3 of 3 inputs failed" in err
    assert len(json.loads(report.read_text())["failed_inputs"]) == 3
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name, triangles", [("gmsh__t20_data.step", 9436), ("gmsh__U_Joint_2.stp", 9720)])
def test_tessellate_estimate_on_real_files(name, triangles, shared_data):
    """Real faces with poles and collapsed rows (U_Joint): the estimate stays near the triangles written."""
    from trimsurf.tessellate.shell import default_parameters

    shell = io.read_shell(shared_data / "cad" / name)
    estimate = 3.0 * _common.estimate_shell_triangles(shell, *default_parameters(shell))
    assert 1 / 3 <= triangles / estimate <= 3, estimate


def test_folder_batch_goes_on_after_an_internal_error(cad, tmp_path, monkeypatch, capsys):
    """A bug on one file (not bad input) is named, the rest is written, exit 1 (not 2)."""
    import trimsurf.tessellate as tess

    src = tmp_path / "cad"
    src.mkdir()
    for name in ("a.step", "b.step"):
        (src / name).write_bytes((cad / "gap_pair.step").read_bytes())
    real = tess.tessellate_shell
    calls = []

    def flaky(shell, **kw):
        calls.append(1)
        if len(calls) == 1:
            raise ZeroDivisionError("boom")
        return real(shell, **kw)

    monkeypatch.setattr(tess, "tessellate_shell", flaky)
    assert main(["tessellate", str(src), "-o", str(tmp_path / "out"), "--tolerance", "20"]) == 1
    err = capsys.readouterr().err
    assert f"trimsurf: error: {src / 'a.step'}: internal error: ZeroDivisionError: boom" in err
    assert _files(tmp_path / "out") == ["b.ply"]


# -- item 11: the README's test command -----------------------------------------------------------------------

def test_readme_test_command_is_the_script_ci_runs(repo_root):
    """README's first block: install + demo, then scripts/test; .ci/run calls the same script."""
    readme = (repo_root / "README.md").read_text(encoding="utf-8").splitlines()
    block = readme[readme.index("```") + 1:readme.index("```", readme.index("```") + 1)]
    assert block[0].startswith("python3 -m venv .venv && .venv/bin/pip install -e '.[test]'") and "demo" in block[0]
    assert block[1] == "scripts/test"
    script = repo_root / "scripts" / "test"
    assert os.access(script, os.X_OK)
    assert subprocess.run(["bash", "-n", str(script)], capture_output=True, timeout=30).returncode == 0
    text = script.read_text(encoding="utf-8")
    assert "apt-get install -y -qq chromium" in text and "TRIMSURF_BROWSER_SKIP" in text and "-m pytest -q" in text
    ci = (repo_root / ".ci" / "run").read_text(encoding="utf-8")
    assert "\nscripts/test " in ci and "pytest -q" not in ci.replace("runs pytest -q", "")


def test_numpy_floating_point_warnings_stay_off_the_terminal(monkeypatch, capsys):
    """Inside a command numpy's divide/overflow/invalid warnings are off (pytest would raise them as errors)."""
    from trimsurf.cli import info as info_cmd

    def noisy(args):
        with np.errstate():  # the command's own state, inherited from main
            x = np.array([1.0, 0.0, 1e300])
            print(float(np.sum(x / np.array([0.0, 0.0, 1e-300]))), np.sqrt(-x[:1])[0])
        return 0

    monkeypatch.setattr(info_cmd, "run", noisy)
    assert main(["info", "anything.off"]) == 0
    out, err = capsys.readouterr()
    assert out.split() == ["nan", "nan"] and err == ""
