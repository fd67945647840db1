"""trimsurf._numba_load: cached kernels load without parsing their linking bitcode, and still link and run."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from trimsurf import _numba_load

_REPO = Path(__file__).resolve().parents[2]

_MODULE = '''
from numba import njit

@njit(cache=True, no_cpython_wrapper=True)
def helper(x):
    return x * 2.0 + 1.0

@njit(cache=True)
def kernel(a):
    s = 0.0
    for v in a:
        s += helper(v)
    return s
'''

# runs in a fresh interpreter: load `kernel` from the cache, then compile a new function that calls the cached
# `helper` (numba links helper's library into it: the deferred bitcode is parsed then)
_SCRIPT = '''
import json, sys
import numpy as np
from numba import njit
from numba.core import codegen
import trimsurf._numba_load as nl
states = []
lazy = nl.install()
numba_unserialize = codegen.JITCodeLibrary._unserialize.__func__
def capture(cls, cg, state):
    lib = numba_unserialize(cls, cg, state)
    states.append((state, lib))
    return lib
codegen.JITCodeLibrary._unserialize = classmethod(capture)
import lazymod
out = {"lazy": lazy, "kernel": lazymod.kernel(np.arange(5.0))}
out["loaded"] = len(states)
out["pending"] = [hasattr(lib, "_trimsurf_bitcode") for _, lib in states]
if sys.argv[1] == "link":
    @njit
    def caller(x):
        return lazymod.helper(x) + 0.5
    out["caller"] = caller(3.0)
    out["pending_after_link"] = [hasattr(lib, "_trimsurf_bitcode") for _, lib in states]
    # what numba itself notes as defined, from the parsed bitcode, against what was read from the object file
    import llvmlite.binding as ll
    missing = []
    for (name, kind, data), lib in states:
        mod = ll.parse_bitcode(data[1])
        elf = nl.elf_defined_symbols(data[0])
        for gv in list(mod.functions) + list(mod.global_variables):
            if not gv.is_declaration and gv.linkage != ll.Linkage.private and gv.name not in elf:
                missing.append(gv.name)
    out["missing"] = missing
print(json.dumps(out))
'''


def _run(tmp_path: Path, mode: str, **env) -> dict:
    e = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), str(_REPO / "src")]),
             NUMBA_CACHE_DIR=str(tmp_path / "cache"), **env)
    p = subprocess.run([sys.executable, "-c", _SCRIPT, mode], env=e, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="ELF object files (elsewhere numba's own loading)")
def test_cached_kernel_runs_and_links_without_eager_bitcode(tmp_path):
    (tmp_path / "lazymod.py").write_text(textwrap.dedent(_MODULE))
    first = _run(tmp_path, "run")                 # compiles and writes the cache
    assert first["lazy"] and first["loaded"] == 0
    expected = sum(2.0 * v + 1.0 for v in range(5))
    assert first["kernel"] == expected
    again = _run(tmp_path, "link")                # loads from the cache
    assert again["lazy"] and again["kernel"] == expected
    assert again["loaded"] >= 1 and all(again["pending"]), "bitcode parsed at load time"
    assert again["caller"] == 2.0 * 3.0 + 1.0 + 0.5
    assert not all(again["pending_after_link"]), "the linked library's bitcode was never parsed"
    assert again["missing"] == []
    off = _run(tmp_path, "run", TRIMSURF_NUMBA_LAZY_BITCODE="0")
    assert not off["lazy"] and off["kernel"] == expected and not any(off["pending"])


def test_elf_symbols_refuses_other_formats():
    assert _numba_load.elf_defined_symbols(b"") is None
    assert _numba_load.elf_defined_symbols(b"\xcf\xfa\xed\xfe" + bytes(200)) is None   # Mach-O
    assert _numba_load.elf_defined_symbols(b"\x7fELF\x01\x01" + bytes(200)) is None    # 32-bit ELF
