"""The ``trimsurf`` command starts the reader server first thing, and the isolation stays.

The server (`trimsurf.io._server`) is started when `trimsurf.cli` is imported by the command, before
the command's own heavy imports, so its start overlaps them; a library caller starts it at its first
read. A crash of Open CASCADE in a read through the early server is still a one-line error (exit 2),
and a server started for a read that never comes is stopped when the command ends.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

from trimsurf import io
from trimsurf.io import _server
from trimsurf.samples import build_sample

SRC = str(Path(_server.__file__).resolve().parents[2])


def _env(**extra) -> dict:
    env = dict(os.environ, PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""), **extra)
    env.pop("TRIMSURF_OCC_IN_PROCESS", None)
    return env


def _cli(*args, env=None, timeout=300):
    return subprocess.run([sys.executable, "-m", "trimsurf", *map(str, args)], capture_output=True, text=True,
                          env=env or _env(), timeout=timeout)


@pytest.fixture(scope="module")
def gap_step(tmp_path_factory):
    path = tmp_path_factory.mktemp("gap") / "gap_pair.step"
    io.write_shell(build_sample("gap_pair"), path)
    return path


def test_which_commands_start_the_reader_early(gap_step, tmp_path):
    folder = tmp_path / "cad"
    folder.mkdir()
    (folder / "a.step").write_bytes(gap_step.read_bytes())
    mesh = tmp_path / "m.ply"
    mesh.write_text("ply\n")
    assert _server._wants_reader(["tessellate", str(gap_step), "-o", "x.ply"])
    assert _server._wants_reader(["--debug", "info", str(gap_step)])
    assert _server._wants_reader(["certify", "--tolerance", "0.1", str(gap_step)])
    assert _server._wants_reader(["tessellate", str(folder), "-o", str(tmp_path / "out")])
    assert not _server._wants_reader(["info", str(folder)])                 # info does not take folders
    assert not _server._wants_reader(["batch", str(gap_step), "-o", "out"])  # read in Dask workers
    assert not _server._wants_reader(["view", str(mesh)])                   # a mesh
    assert not _server._wants_reader(["info", str(tmp_path / "missing.step")])
    assert not _server._wants_reader(["--help"])
    assert not _server._wants_reader([])


def test_a_library_caller_does_not_start_the_reader_on_import():
    # importing trimsurf.cli (tests, scripts) starts nothing: only the `trimsurf` command does
    code = ("import sys; sys.argv = ['myscript.py', 'tessellate', sys.argv[1], '-o', 'x.ply']\n"
            "import trimsurf.cli\nfrom trimsurf.io import _server\nprint(_server._SERVER is None)\n")
    step = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "cad" / "occt__screw.step"
    run = subprocess.run([sys.executable, "-c", code, str(step)], capture_output=True, text=True, env=_env(),
                         timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout == "True\n"


def test_the_command_reads_through_the_early_server_and_reports_it(shared_data, tmp_path):
    report = tmp_path / "r.json"
    run = _cli("tessellate", shared_data / "cad" / "occt__screw.step", "-o", tmp_path / "x.ply",
               "--report", report)
    assert run.returncode == 0, run.stderr
    e = json.loads(report.read_text())["inputs"][0]
    # the server started before the command's imports: part of its start ran before the read was asked for
    assert e["seconds_read_started_early"] > 0.05
    assert e["seconds_read"] > 0
    assert e["seconds_read"] + e["seconds_mesh"] + e["seconds_measure"] <= e["seconds"]


def test_a_crash_through_the_early_server_is_one_line_exit_2(gap_step, tmp_path):
    # the issue-16 IGES case (a blank knot kills Open CASCADE's transfer), through the command
    from trimsurf.io import _occ
    from OCP.IGESControl import IGESControl_Writer

    src = tmp_path / "gap.igs"
    with _occ.quiet_occ():
        writer = IGESControl_Writer("MM", 1)
        writer.AddShape(_occ.shell_to_shape(build_sample("gap_pair")))
        writer.ComputeModel()
        assert writer.Write(str(src))
    lines = src.read_bytes().split(b"\n")
    rec = next(i for i, ln in enumerate(lines) if ln.startswith(b"126,11,"))
    lines[rec + 1] = lines[rec + 1].replace(b"0.500540029,0.500540029,", b"           ,0.500540029,", 1)
    bad = tmp_path / "blank_knot.igs"
    bad.write_bytes(b"\n".join(lines))
    run = _cli("tessellate", bad, "-o", tmp_path / "x.ply")
    assert run.returncode == 2
    assert run.stderr.strip() == (f"trimsurf: error: {bad}: Open CASCADE crashed (SIGSEGV) while reading the IGES "
                                  "file (the file is probably malformed)")
    assert not (tmp_path / "x.ply").exists()


def _servers_marked(marker: str) -> list[int]:
    """Pids of live processes whose environment holds `marker` (the reader servers of one test)."""
    found = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            environ = (d / "environ").read_bytes()
            stat = (d / "stat").read_text()
        except OSError:
            continue
        if marker.encode() in environ and stat.rsplit(")", 1)[1].split()[0] != "Z":
            found.append(int(d.name))
    return found


@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="needs /proc")
def test_an_early_server_whose_read_never_comes_is_stopped_with_the_command(gap_step, tmp_path):
    marker = f"TRIMSURF_TEST_{uuid.uuid4().hex}"
    start = time.perf_counter()
    # the output folder does not exist: refused before any read
    run = _cli("tessellate", gap_step, "-o", tmp_path / "missing" / "x.ply", env=_env(**{marker: "1"}))
    took = time.perf_counter() - start
    assert run.returncode == 2 and "missing" in run.stderr
    for _ in range(50):
        if not _servers_marked(marker):
            break
        time.sleep(0.1)
    assert _servers_marked(marker) == []
    # and the command did not wait for the server's start to end it
    assert took < 30.0


def test_the_reader_server_imports_no_scipy_and_no_version_lookup():
    """What the server imports before forking (`_worker.serve`) leaves scipy's spatial and sparse parts out
    (0.13 s CPU of its start), and the package's version is looked up on first use only. (Loading the
    compiled kernels in the warm-up makes numba import scipy.linalg, and with it scipy.sparse.)"""
    code = ("import sys, numpy, OCP.BRepBuilderAPI, OCP.STEPControl, OCP.IGESControl\n"
            "from trimsurf.io import _brep, _iges, _step\n"
            "from trimsurf.io._occ import _isolate, _worker\n"
            "import trimsurf\n"
            "print(sorted(m for m in ('scipy.spatial', 'scipy.sparse') if m in sys.modules))\n"
            "_worker._warm_up()\n"
            "print('scipy.spatial' in sys.modules, '__version__' in vars(trimsurf))\n")
    out = subprocess.run([sys.executable, "-c", code], env=_env(), capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["[]", "False", "False"]


def test_geom_names_load_on_first_use():
    """``from trimsurf.geom import X`` works for every public name, lazily loaded or not."""
    code = ("import sys, trimsurf.geom as g\n"
            "assert 'trimsurf.geom.predicates' not in sys.modules\n"
            "assert all(getattr(g, name) is not None for name in g.__all__)\n"
            "from trimsurf.geom import orient2d, Projection, bezier_extract, whitney_extension\n"
            "from trimsurf.geom import predicates\n"
            "assert predicates.orient2d is orient2d and set(g.__all__) <= set(dir(g))\n"
            "try:\n    g.no_such_name\nexcept AttributeError:\n    print('ok')\n")
    out = subprocess.run([sys.executable, "-c", code], env=_env(), capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"
    import trimsurf

    assert isinstance(trimsurf.__version__, str) and trimsurf.__version__
