"""`cli._preload.Preload` loads with the cyclic GC off and hands it back as it found it."""

from __future__ import annotations

import gc

from trimsurf.cli import _preload


def test_gc_off_while_loading_and_restored(monkeypatch):
    seen = []
    real = _preload.import_module

    def spy(name):
        seen.append(gc.isenabled())
        return real(name)

    monkeypatch.setattr(_preload, "import_module", spy)
    assert gc.isenabled()
    p = _preload.Preload().start()
    p.join()
    assert p.error is None and seen and not any(seen)
    assert gc.isenabled()
    gc.disable()
    try:
        _preload.Preload().start().join()
        assert not gc.isenabled()                     # off before: left off
    finally:
        gc.enable()
