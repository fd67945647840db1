"""`deviation._replace` (the refinement's per-face `dataclasses.replace` of a Deviation, issue 17 item 2)
makes the same object as ``dataclasses.replace``: same fields and values (arrays the same objects), a new
instance, the original untouched; unknown fields raise as before. A version that drops the changes fails."""

import dataclasses

import numpy as np
import pytest

import trimsurf.quality.deviation as D
from trimsurf.model import TriMesh


def _dev():
    m = TriMesh([[0, 0, 0], [1, 0, 0], [1, 1, 0.1], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    m2 = TriMesh([[0, 0, 0.2], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    return D.mesh_deviation(m, m2)


def _same(a, b):
    assert type(a) is type(b)
    assert a.__dict__.keys() == b.__dict__.keys()
    for k in a.__dict__:
        x, y = a.__dict__[k], b.__dict__[k]
        if isinstance(x, np.ndarray):
            assert x is y
        else:
            assert np.float64(x).tobytes() == np.float64(y).tobytes() if isinstance(x, float) else x == y


CHANGES = [dict(max_bound=0.5, n_refined=3),
           dict(max_mesh_to_target=1.25, where_mesh_to_target=np.ones(3), n_mesh_samples=7, max_two_sided=2.0),
           dict(max_target_to_mesh=float("nan"), where_target_to_mesh=np.zeros(3), n_target_samples=0),
           {}]


@pytest.mark.parametrize("changes", CHANGES)
def test_same_as_dataclasses_replace(changes):
    dev = _dev()
    before = dict(dev.__dict__)
    got, ref = D._replace(dev, **changes), dataclasses.replace(dev, **changes)
    assert got is not dev
    _same(got, ref)
    assert dev.__dict__ == before
    with pytest.raises(dataclasses.FrozenInstanceError):
        got.max_bound = 1.0


def test_unknown_field_raises():
    with pytest.raises(TypeError):
        D._replace(_dev(), no_such_field=1)


def test_dropped_changes_fail(monkeypatch):
    monkeypatch.setattr(D, "_replace", lambda dev, **kw: dataclasses.replace(dev))
    with pytest.raises(AssertionError):
        test_same_as_dataclasses_replace(CHANGES[0])
