"""``trimsurf tessellate --jobs N``: the same file whatever N; the report's time split."""

from __future__ import annotations

import json

from trimsurf.cli import main


def test_jobs_same_file_and_time_split(shared_data, tmp_path, capsys):
    src = shared_data / "cad" / "occt__screw.step"
    data, reports = {}, {}
    for jobs in (1, 2):
        out, rep = tmp_path / f"s{jobs}.ply", tmp_path / f"r{jobs}.json"
        assert main(["tessellate", str(src), "-o", str(out), "--report", str(rep), "--jobs", str(jobs)]) == 0
        data[jobs] = out.read_bytes()
        reports[jobs] = json.loads(rep.read_text())["inputs"][0]
    assert data[1] == data[2]               # byte for byte
    for e in reports.values():
        parts = [e["seconds_read"], e["seconds_mesh"], e["seconds_measure"]]
        assert all(p > 0 for p in parts)
        assert sum(parts) <= e["seconds"]   # writing the file is the rest
    capsys.readouterr()
    assert main(["tessellate", str(src), "-o", str(tmp_path / "x.ply"), "--jobs", "0"]) == 2
    assert "--jobs" in capsys.readouterr().err
    assert not (tmp_path / "x.ply").exists()
