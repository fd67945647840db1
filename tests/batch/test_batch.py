"""trimsurf batch on a LocalCluster (2 worker processes on 127.0.0.1): good parts done, a file that crashes
Open CASCADE, a native crash of the worker itself, a hang past the time limit and memory exhaustion recorded as
failed with their reasons (retried once); a second run skips what is done; a batch killed half way and started
again completes."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from trimsurf import io
from trimsurf.batch import COLUMNS, collect_parts, local_cluster, read_table, run
from trimsurf.errors import InputError
from trimsurf.samples import build_sample

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def client():
    from distributed import Client

    with local_cluster(2) as cluster, Client(cluster) as c:
        yield c


@pytest.fixture(scope="module")
def parts(tmp_path_factory, shared_data):
    """good: the shared screw and a written gap_pair STEP; bad: an IGES whose blank knot crashes Open CASCADE."""
    folder = tmp_path_factory.mktemp("parts")
    gap = folder / "gap_pair.step"
    io.write_shell(build_sample("gap_pair"), gap)
    from OCP.IGESControl import IGESControl_Writer

    from trimsurf.io import _occ

    igs = folder / "gap.igs"
    with _occ.quiet_occ():
        writer = IGESControl_Writer("MM", 1)
        writer.AddShape(_occ.shell_to_shape(build_sample("gap_pair")))
        writer.ComputeModel()
        assert writer.Write(str(igs))
    lines = igs.read_bytes().split(b"\n")
    rec = next(i for i, ln in enumerate(lines) if ln.startswith(b"126,11,"))
    knots = lines[rec + 1]
    lines[rec + 1] = knots.replace(b"0.500540029,0.500540029,", b"           ,0.500540029,", 1)
    assert lines[rec + 1] != knots
    crash = folder / "blank_knot.igs"
    crash.write_bytes(b"\n".join(lines))
    igs.unlink()
    return {"screw": shared_data / "cad" / "occt__screw.step", "gap": gap, "crash": crash}


def _by_part(rows):
    return {r["part"]: r for r in rows}


def test_good_parts_done_bad_parts_failed_with_reasons_and_second_run_skips(client, parts, tmp_path):
    # a manifest gives the hanging part its own time limit (1 s); the hang is a test hook (a regular expression
    # that backtracks for hours inside C, holding the GIL): the huge-exponent files that hung Open CASCADE are
    # refused by the reader's number checks before the transfer now (tests/io/test_hostile.py)
    hang = tmp_path / "hang.step"
    hang.write_bytes(parts["gap"].read_bytes() + b"\n")
    manifest = tmp_path / "parts.csv"
    manifest.write_text("path,timeout\nhang.step,1\n")
    # the huge exponent that made Open CASCADE spin for over 100 s: refused at once by the reader
    huge = tmp_path / "huge.step"
    text = parts["gap"].read_text().split("\n")
    at = next(i for i, ln in enumerate(text) if ln.startswith("#44 = CARTESIAN_POINT"))
    text[at] = "#44 = CARTESIAN_POINT('',(250.E+999,180.,-64.389320225));"
    huge.write_text("\n".join(text))
    out = tmp_path / "out"
    inputs = [parts["screw"], parts["gap"], parts["crash"], manifest, huge]
    t0 = time.perf_counter()
    rows = run(inputs, out=out, jobs="tessellate,view", client=client, _hooks={("hang", "tessellate"): "hang"})
    first_s = time.perf_counter() - t0
    by = {(r["part"], r["job"]): r for r in rows}
    assert len(rows) == 10
    for part in ("occt__screw", "gap_pair"):
        tess = by[(part, "tessellate")]
        assert tess["status"] == "ok", tess["reason"]
        # the row's figures are the written mesh's: read it back
        mesh = io.read_mesh(out / part / "mesh.ply")
        assert tess["triangles"] == mesh.n_triangles > 0
        report = json.loads((out / part / "tessellate.json").read_text())
        assert report["max_deviation"] == tess["max_deviation"] <= report["tolerance"]
        assert tess["flips"] == 0 and tess["faces"] == report["faces_in"]
        # the screw is a closed solid; gap_pair two patches with a gap between them (open)
        assert tess["watertight"] is (part == "occt__screw") and report["watertight"] is tess["watertight"]
        assert by[(part, "view")]["status"] == "ok"
        assert by[(part, "view")]["triangles"] == mesh.n_triangles
        for name in ("zebra.png", "thumb.png", "view.html"):
            assert (out / part / name).stat().st_size > 1000
    crash = by[("blank_knot", "tessellate")]
    assert crash["status"] == "failed"
    assert crash["reason"].startswith(f"{parts['crash']}: Open CASCADE crashed (SIGSEGV) while reading the IGES")
    assert by[("blank_knot", "view")]["status"] == "failed"
    assert by[("blank_knot", "view")]["reason"] == "no mesh to show: the tessellate job failed"
    assert by[("huge", "tessellate")]["status"] == "failed" and by[("huge", "tessellate")]["attempts"] == 1
    assert by[("huge", "tessellate")]["reason"] == f"{huge}: line {at + 1} (#44): the number 250.E+999 is not finite"
    hung = by[("hang", "tessellate")]
    assert hung["status"] == "failed" and hung["attempts"] == 2, (hung["attempts"], hung["reason"])
    # faulthandler's C watchdog stopped the hook inside re.match although it held the GIL
    assert hung["reason"].startswith("timeout: stopped after 1 s in match"), hung["reason"]
    assert not (out / "hang" / "mesh.ply").exists()
    assert not list(out.glob("*/.*"))  # no attempt or crash files left behind

    # the table: both files, every column, the same rows
    assert read_table(out) == [{c: r[c] for c in COLUMNS} for r in rows]
    with open(out / "results.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    assert [(r["part"], r["job"], r["status"]) for r in table] == [(r["part"], r["job"], r["status"]) for r in rows]
    assert tuple(table[0]) == COLUMNS
    page = (out / "index.html").read_text()
    assert page.count("data:image/png;base64,") == 2  # the two zebra thumbnails, inlined
    assert 'href="occt__screw/view.html"' in page and 'href="gap_pair/tessellate.json"' in page
    assert "Open CASCADE crashed (SIGSEGV)" in page and "timeout: stopped after 1 s" in page
    assert "<script src" not in page and "<link" not in page  # self-contained

    # second run: what is done is skipped (files untouched), what failed is tried again (the hang, without its
    # hook now, succeeds)
    stamp = (out / "occt__screw" / "mesh.ply").stat().st_mtime_ns
    manifest.write_text("path,timeout\nhang.step,300\n")  # 1 s is too short for a real tessellation on a busy machine
    rows2 = run(inputs, out=out, jobs="tessellate,view", client=client)
    by2 = {(r["part"], r["job"]): r for r in rows2}
    for part in ("occt__screw", "gap_pair"):
        for job in ("tessellate", "view"):
            assert by2[(part, job)]["reused"] is True
            assert by2[(part, job)] | {"reused": False} == by[(part, job)]
    assert (out / "occt__screw" / "mesh.ply").stat().st_mtime_ns == stamp
    assert by2[("blank_knot", "tessellate")]["reused"] is False
    assert by2[("blank_knot", "tessellate")]["status"] == "failed"
    assert by2[("hang", "tessellate")]["reused"] is False
    assert by2[("hang", "tessellate")]["status"] == "ok", by2[("hang", "tessellate")]["reason"]
    assert by2[("hang", "view")]["status"] == "ok"
    # a job whose outputs are gone is redone even though its record exists
    (out / "gap_pair" / "zebra.png").unlink()
    rows3 = run([parts["gap"]], out=out, jobs="tessellate,view", client=client)
    assert [(r["job"], r["reused"], r["status"]) for r in rows3] == [("tessellate", True, "ok"), ("view", False, "ok")]
    print(f"first run {first_s:.1f} s")


def test_force_redoes_and_changed_options_or_input_redo(client, parts, tmp_path):
    out = tmp_path / "out"
    gap = tmp_path / "gap_pair.step"
    gap.write_bytes(parts["gap"].read_bytes())
    first = run([gap], out=out, client=client)
    assert first[0]["status"] == "ok" and first[0]["reused"] is False
    assert run([gap], out=out, client=client)[0]["reused"] is True
    assert run([gap], out=out, client=client, force=True)[0]["reused"] is False
    gap.write_bytes(parts["gap"].read_bytes() + b"\n")  # the same name, other bytes: its hash differs
    assert run([gap], out=out, client=client)[0]["reused"] is False
    h = 0.5 * json.loads((out / "gap_pair" / "tessellate.json").read_text())["max_edge_used"]
    finer = run([gap], out=out, client=client, max_edge=h)[0]
    assert finer["reused"] is False and finer["status"] == "ok", finer["reason"]
    assert json.loads((out / "gap_pair" / "tessellate.json").read_text())["max_edge_used"] == h
    assert finer["triangles"] > first[0]["triangles"]


def test_native_crash_and_memory_exhaustion_kill_the_worker_and_are_recorded(client, parts, tmp_path):
    # reading in the worker itself (no reader child): Open CASCADE's SIGSEGV on the blank knot kills the worker
    out = tmp_path / "out"
    rows = run([parts["crash"], parts["gap"], parts["screw"]], out=out, client=client,
               _env={"TRIMSURF_OCC_IN_PROCESS": "1"}, per_part_memory=600 * 2 ** 20,
               _hooks={("occt__screw", "tessellate"): "memory"})
    by = _by_part(rows)
    assert by["gap_pair"]["status"] == "ok"
    crash = by["blank_knot"]
    assert crash["status"] == "failed" and crash["attempts"] == 2
    assert crash["reason"].startswith("worker crashed (SIGSEGV)"), crash["reason"]
    hog = by["occt__screw"]
    assert hog["status"] == "failed" and hog["attempts"] == 2, hog["reason"]
    assert hog["reason"].startswith("out of memory: ") and "above the limit of 0.59 GB" in hog["reason"]
    # the dead workers were replaced
    client.wait_for_workers(2, timeout=120)
    assert not list(out.glob("*/.*"))  # no attempt files left; the crash dump kept for a bug report:
    assert "Segmentation fault" in (out / "blank_knot" / "tessellate.crash.txt").read_text()


def test_batch_killed_half_way_resumes_and_completes(client, parts, tmp_path):
    folder = tmp_path / "in"
    folder.mkdir()
    for k in range(4):
        (folder / f"gap{k}.step").write_bytes(parts["gap"].read_bytes() + b"\n" * k)
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"))
    log = tmp_path / "stderr.txt"
    with open(log, "wb") as err:
        proc = subprocess.Popen([sys.executable, "-m", "trimsurf", "batch", str(folder), "-o", str(out), "--workers",
                                 "1", "--jobs", "tessellate,view"], env=env, start_new_session=True,
                                stdout=subprocess.DEVNULL, stderr=err)
    try:
        deadline = time.monotonic() + 120
        while not list(out.glob("*/view.record.json")) and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.1)
        assert proc.poll() is None, log.read_text()
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the client, its cluster and the workers at once
        proc.wait()
    done_before = {p.parent.name for p in out.glob("*/view.record.json")}
    assert 1 <= len(done_before) < 4
    rows = run([folder], out=out, jobs="tessellate,view", client=client)
    assert [r["status"] for r in rows] == ["ok"] * 8
    reused = {r["part"] for r in rows if r["reused"] and r["job"] == "view"}
    assert reused == done_before
    assert len(read_table(out)) == 8


def test_cli_exit_status_and_one_line_errors(parts, tmp_path, capsys, monkeypatch):
    from trimsurf.batch import _run
    from trimsurf.cli import main

    monkeypatch.setattr(_run, "CONNECT_TIMEOUT_S", 1.0)
    out = tmp_path / "out"
    assert main(["batch", str(parts["gap"]), str(parts["crash"]), "-o", str(out), "--workers", "1"]) == 1
    captured = capsys.readouterr()
    assert "trimsurf: warning: blank_knot tessellate: failed: " in captured.err
    assert "tessellate  1   0        1" in captured.out
    # all done: nothing to run, no cluster started
    t0 = time.perf_counter()
    assert main(["batch", str(parts["gap"]), "-o", str(out)]) == 0
    assert time.perf_counter() - t0 < 5
    assert "reused" in capsys.readouterr().out
    for argv, message in [
            (["batch", str(tmp_path / "missing.step"), "-o", str(out)], "missing.step: no such file or folder"),
            (["batch", str(parts["gap"]), "-o", str(out), "--jobs", "mesh"], "unknown job 'mesh'"),
            (["batch", str(parts["gap"]), "-o", str(parts["gap"])], "is not a folder"),
            (["batch", str(parts["gap"]), "-o", str(out), "--per-part-timeout", "0"], "--per-part-timeout must be"),
            (["batch", str(parts["gap"]), "-o", str(tmp_path / "new"), "--scheduler", "tcp://127.0.0.1:9"],
             "cannot connect")]:
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.startswith("trimsurf: error: ") and message in err and err.count("\n") == 1, err


def test_inputs_manifest_and_names(parts, tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    (a / "x.step").write_bytes(parts["gap"].read_bytes())
    (b / "sub").mkdir()
    (b / "sub" / "x.stp").write_bytes(parts["gap"].read_bytes())
    (b / "notes.txt").write_text("not CAD")
    found = collect_parts([a, b])
    assert len(found) == 2 and len({p.name for p in found}) == 2  # same stem: told apart by a path hash
    assert all(p.name.startswith("x-") for p in found) and found[0].sha256 == found[1].sha256
    assert len(collect_parts([a, a / "x.step"])) == 1
    m = tmp_path / "m.csv"
    m.write_text("path,tolerance,max_edge\na/x.step,0.5,\n")
    (p,) = collect_parts([m])
    assert p.options == {"tolerance": 0.5} and p.path == a / "x.step"
    for text, message in [("file\nx\n", "no 'path' column"), ("path,colour\na/x.step,red\n", "unknown manifest"),
                          ("path,tolerance\na/x.step,-1\n", "line 2: tolerance must be a positive"),
                          ("path\nmissing.step\n", "missing.step: no such file"), ("path\n", "no rows")]:
        m.write_text(text)
        with pytest.raises(InputError, match=message):
            collect_parts([m])
    with pytest.raises(InputError, match="not a CAD file"):
        collect_parts([b / "notes.txt"])
    with pytest.raises(InputError, match="holds no STEP"):
        collect_parts([_empty(tmp_path)])
    with pytest.raises(InputError, match="unknown job"):
        run([a], out=tmp_path / "o", jobs="tessellate,mesh")


def _empty(tmp_path):
    e = tmp_path / "empty"
    e.mkdir()
    return e


def test_default_output_folder_is_beside_the_first_input(client, parts, tmp_path):
    gap = tmp_path / "gap_pair.step"
    gap.write_bytes(parts["gap"].read_bytes())
    (row,) = run([gap], jobs=["tessellate"], client=client)
    assert row["status"] == "ok"
    assert io.read_mesh(tmp_path / "trimsurf-batch" / "gap_pair" / "mesh.ply").n_triangles == row["triangles"]
