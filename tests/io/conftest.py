"""The io tests read through the reader server as a first read does: the cache of read shells is off
(`trimsurf.io._cache`), except in the tests of the cache, which give it a folder of their own."""

from __future__ import annotations

import pytest


@pytest.fixture(autouse=True)
def _no_read_cache(monkeypatch):
    monkeypatch.setenv("TRIMSURF_READ_CACHE", "0")
