"""The first run after an install compiles the numba kernels (tens of seconds): an interactive command
says so before its progress bar (`cli._common.kernels_cold`)."""

import os
import subprocess
import sys

from trimsurf.cli._common import kernels_cold

CHECK = ("import trimsurf.tessellate, trimsurf.quality\n"
         "from trimsurf.cli._common import kernels_cold\n"
         "print(kernels_cold())\n")


def test_an_empty_numba_cache_is_cold(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "empty"))
    out = subprocess.run([sys.executable, "-c", CHECK], env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "True"


def test_after_a_tessellation_the_cache_is_warm():
    from trimsurf.samples import build_sample
    from trimsurf.tessellate import tessellate_shell

    import trimsurf.quality  # noqa: F401  (its kernels count too)

    tessellate_shell(build_sample("bspline_box"))
    assert not kernels_cold()
