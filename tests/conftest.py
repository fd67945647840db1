"""Shared fixtures: paths of the repository and of the shared real data."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

# the suite reads every file for real (the reader server, Open CASCADE): no shells from an earlier run's
# cache of read shells (trimsurf.io._cache), none written into ~/.cache; tests/io/test_read_cache.py
# gives the cache its own folder
os.environ["TRIMSURF_READ_CACHE"] = "0"

_REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def repo_root() -> Path:
    """The repository root (the folder holding pyproject.toml)."""
    return _REPO


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``<repo>/../shared/data``: real CAD files and meshes. Fails (never skips) if missing."""
    path = (_REPO / ".." / "shared" / "data").resolve()
    if not (path / "cad").is_dir() or not (path / "meshes").is_dir():
        pytest.fail(f"shared data folder missing: expected {path} with cad/ and meshes/ "
                    f"(clone the project with ../shared beside it)")
    return path


# Property tests draw their examples from a fixed seed, so a CI run is reproducible:
# a failure found once is found again by the next run and can be debugged.
from hypothesis import settings as _settings  # noqa: E402

_settings.register_profile("trimsurf", derandomize=True, deadline=None, print_blob=True)
_settings.load_profile("trimsurf")
