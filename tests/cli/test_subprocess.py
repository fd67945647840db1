"""One real process each for the console script and ``python -m trimsurf``."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import trimsurf


def _script() -> str:
    found = Path(sys.executable).parent / "trimsurf"
    return str(found) if found.exists() else shutil.which("trimsurf") or "trimsurf"


def test_console_script_version():
    res = subprocess.run([_script(), "--version"], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == f"trimsurf {trimsurf.__version__}"


def test_python_m_trimsurf_bad_input(tmp_path):
    res = subprocess.run([sys.executable, "-m", "trimsurf", "info", str(tmp_path / "missing.step")],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 2
    assert res.stdout == ""
    assert res.stderr.strip() == (f"trimsurf: error: {tmp_path / 'missing.step'}: no such file, and not a sample name "
                                  "(`trimsurf samples --list` lists them)")


def test_python_m_trimsurf_version():
    res = subprocess.run([sys.executable, "-m", "trimsurf", "--version"], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0 and res.stdout.strip() == f"trimsurf {trimsurf.__version__}"


def test_reader_closing_stdout_early_is_quiet(shared_data):
    # `trimsurf info --json big.iges | head -c 10`: the JSON (~140 KB) overflows the pipe buffer after the
    # reader has gone; no "Broken pipe" line, no traceback, status 1 (the output was not delivered)
    proc = subprocess.Popen([sys.executable, "-m", "trimsurf", "info", "--json",
                             str(shared_data / "cad" / "occt__bearing.iges")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout.read(10)
    proc.stdout.close()
    _, err = proc.communicate(timeout=300)
    assert err.decode() == ""
    assert proc.returncode == 1
