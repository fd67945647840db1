"""The cache of read shells (`trimsurf.io._cache`): a file read again, unchanged, by the same code, gives
the shell the reader's child gave (the same pickled bytes), and its warnings, without the reader server;
anything else is read again."""

from __future__ import annotations

import json
import os
import pickle
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from trimsurf import io
from trimsurf.errors import StepReadError, TrimsurfWarning
from trimsurf.io import _cache, _server
from trimsurf.samples import build_sample

SRC = str(Path(_server.__file__).resolve().parents[2])


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("TRIMSURF_READ_CACHE", str(folder))
    monkeypatch.delenv("TRIMSURF_OCC_IN_PROCESS", raising=False)
    return folder


def _no_server(monkeypatch):
    def refuse(*_a, **_k):
        raise AssertionError("the reader server was asked for a read the cache holds")
    monkeypatch.setattr(_server, "server", refuse)


def _read(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        shell = io.read_shell(path)
    return shell, [(w.category, str(w.message)) for w in caught]


def test_second_read_is_the_childs_shell_without_the_server(shared_data, cache, tmp_path, monkeypatch):
    path = tmp_path / "t20.step"
    shutil.copyfile(shared_data / "cad" / "gmsh__t20_data.step", path)
    first, w1 = _read(path)
    assert len(list(cache.glob("*.pickle"))) == 1
    _server.take_read_timing()
    with monkeypatch.context() as m:
        _no_server(m)
        again, w2 = _read(path)
    assert _server.take_read_timing().get("from_cache") == 1.0
    assert pickle.dumps(again) == pickle.dumps(first) and w2 == w1
    assert len(again.faces) == 21 and again.name == first.name
    # and the same as a read without the cache
    monkeypatch.setenv("TRIMSURF_READ_CACHE", "0")
    fresh, w3 = _read(path)
    assert pickle.dumps(fresh) == pickle.dumps(first) and w3 == w1


def test_changed_file_or_code_or_path_is_read_again(shared_data, cache, tmp_path, monkeypatch):
    path = tmp_path / "part.step"
    shutil.copyfile(shared_data / "cad" / "occt__screw.step", path)
    assert len(_read(path)[0].faces) == 10
    # other bytes under the same name (same size and mtime too): read again, not the screw
    t20 = (shared_data / "cad" / "gmsh__t20_data.step").read_bytes()
    st = path.stat()
    path.write_bytes(t20)
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert len(_read(path)[0].faces) == 21
    # the same bytes under another name: the shell is named after it
    other = tmp_path / "other.step"
    shutil.copyfile(path, other)
    assert _read(other)[0].name != _read(path)[0].name
    # other code: another key
    k = _cache.key(path, "STEP")
    monkeypatch.setattr(_cache, "_code_key", "other code")
    monkeypatch.setattr(_cache, "_seen", {})
    assert _cache.key(path, "STEP") != k


def test_warnings_are_given_again(cache, tmp_path, monkeypatch):
    from tests.io.test_hostile import _periodic_surface  # a face Open CASCADE converts on its own, with a warning

    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
    from trimsurf.io import _occ

    face = BRepBuilderAPI_MakeFace(_periodic_surface(True), -1.0, 2.5, 0.05, 0.95, 1e-7).Face()
    path = tmp_path / "periodic.step"
    with _occ.quiet_occ():
        writer = STEPControl_Writer()
        writer.Transfer(face, STEPControl_AsIs)
        assert writer.Write(str(path))
    first, w1 = _read(path)
    assert any(c is TrimsurfWarning and "converted one by one" in m for c, m in w1)
    _no_server(monkeypatch)
    again, w2 = _read(path)
    assert w2 == w1 and pickle.dumps(again) == pickle.dumps(first)


def test_errors_are_not_kept_and_damaged_entries_are_read_again(shared_data, cache, tmp_path, monkeypatch):
    bad = tmp_path / "bad.step"
    bad.write_text("ISO-10303-21;\nHEADER;\nENDSEC;\nDATA;\n#1=FOO(;\nENDSEC;\nEND-ISO-10303-21;\n")
    for _ in range(2):
        with pytest.raises(StepReadError):
            io.read_shell(bad)
    assert not list(cache.glob("*.pickle")) if cache.exists() else True
    path = tmp_path / "screw.step"
    shutil.copyfile(shared_data / "cad" / "occt__screw.step", path)
    first = _read(path)[0]
    (entry,) = cache.glob("*.pickle")
    entry.write_bytes(entry.read_bytes()[:100])  # truncated
    again = _read(path)[0]
    assert pickle.dumps(again) == pickle.dumps(first)
    assert entry.stat().st_size > 100  # stored again


def test_any_edit_of_the_code_changes_its_key(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "a.py").write_text("x = 1\n")
    (pkg / "sub" / "b.py").write_text("y = 2\n")
    (pkg / "data.txt").write_text("not code")
    keys = {_cache.sources_key(pkg)}
    (pkg / "data.txt").write_text("not code, changed")
    assert _cache.sources_key(pkg) in keys  # only .py files count
    st = (pkg / "sub" / "b.py").stat()
    os.utime(pkg / "sub" / "b.py", ns=(st.st_atime_ns, st.st_mtime_ns + 1))  # touched
    keys.add(_cache.sources_key(pkg))
    (pkg / "a.py").write_text("x = 12\n")  # edited
    keys.add(_cache.sources_key(pkg))
    (pkg / "sub" / "c.py").write_text("")  # a new module
    keys.add(_cache.sources_key(pkg))
    assert len(keys) == 4
    assert len(_cache.code_key()) == 32


def test_cache_off_keeps_nothing(shared_data, tmp_path, monkeypatch):
    monkeypatch.setenv("TRIMSURF_READ_CACHE", "0")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert _cache.cache_dir() is None and _cache.key(shared_data / "cad" / "occt__screw.step", "STEP") is None
    monkeypatch.delenv("TRIMSURF_READ_CACHE")
    assert _cache.cache_dir() == tmp_path / "xdg" / "trimsurf" / "read"


def test_the_least_recently_used_entries_go_beyond_the_limit(cache, tmp_path, monkeypatch):
    cache.mkdir()
    for i in range(5):
        p = cache / f"{i}.pickle"
        p.write_bytes(b"x" * 1000)
        os.utime(p, ns=(i * 10**9, i * 10**9))
    monkeypatch.setattr(_cache, "MAX_BYTES", 2500)
    _cache._trim(cache)
    assert sorted(p.name for p in cache.glob("*.pickle")) == ["3.pickle", "4.pickle"]


def test_command_with_a_cached_file_starts_no_server(shared_data, cache, tmp_path):
    path = tmp_path / "screw.step"
    shutil.copyfile(shared_data / "cad" / "occt__screw.step", path)
    env = dict(os.environ, PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""))
    reports = []
    for i in range(2):
        report = tmp_path / f"r{i}.json"
        run = subprocess.run([sys.executable, "-m", "trimsurf", "tessellate", str(path), "-o", str(tmp_path / "x.ply"),
                              "--report", str(report)], capture_output=True, text=True, env=env, timeout=600)
        assert run.returncode == 0, run.stderr
        reports.append(json.loads(report.read_text())["inputs"][0])
    assert reports[0]["read_from_cache"] is False and reports[1]["read_from_cache"] is True
    assert reports[1]["seconds_read_started_early"] == 0.0  # no server was started
    assert reports[1]["triangles"] == reports[0]["triangles"]
    assert not _server._wants_reader(["tessellate", str(path), "-o", "x.ply"])
