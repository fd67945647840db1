"""The tessellator refuses a grid it cannot afford before building it (issue 16, item 2/3).

`trimsurf tessellate --max-edge=1e-3` took 5.8 GB and ended in an internal error; the CLI now refuses
from an estimate, and the library itself refuses too: more than MAX_VALUES iso-values in a direction
(`adaptive_values`) or more than MAX_CELLS grid cells per face (`face_domain_values`, `refine_cells`)
is an InputError naming the face, raised before the grid is placed, in seconds.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from trimsurf.errors import InputError
from trimsurf.samples import build_sample
from trimsurf.tessellate import adaptive_values, tessellate_face, tessellate_shell


def _circle(t):
    return np.stack([np.cos(t), np.sin(t), 0 * t], axis=-1)[:, None, :]


@pytest.mark.parametrize("strategy", ["equidistributed", "bisection"])
def test_adaptive_values_refuses_beyond_max_values(strategy):
    # a half circle of length pi at max edge 1e-2: ~315 intervals
    x = adaptive_values(_circle, 0.0, np.pi, tolerance=1.0, max_edge=1e-2, strategy=strategy, max_values=400)
    assert 315 <= len(x) - 1 <= 400
    with pytest.raises(InputError, match=r"intervals needed \(more than 100\)"):
        adaptive_values(_circle, 0.0, np.pi, tolerance=1.0, max_edge=1e-2, strategy=strategy, max_values=100)


@pytest.mark.parametrize("kw", [{"max_edge": 1e-3, "tolerance": 1.0}, {"max_edge": 50.0, "tolerance": 1e-7}])
def test_a_face_refuses_a_grid_it_cannot_afford(kw):
    face = build_sample("fender").faces[0]          # ~1100 mm across
    start = time.perf_counter()
    with pytest.raises(InputError, match=r"fender.*too small for this face"):
        tessellate_face(face, **kw)
    assert time.perf_counter() - start < 60        # refused up front (measured ~2-5 s), not after gigabytes


def test_a_shell_reports_the_refused_face_and_goes_on():
    shell = build_sample("fender")
    res = tessellate_shell(shell, tolerance=1.0, max_edge=1e-3, measure=False)
    assert not res.ok and len(res.failed_faces) == 1
    assert "too small for this face" in " ".join(res.failed_faces[0].messages)
