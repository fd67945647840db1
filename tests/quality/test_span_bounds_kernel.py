"""`interpolation_bound.span_bounds` (one compiled call, `_bound_kernels.span_bounds_kernel`) against
`_span_bounds_numpy` (the numpy version it replaces) and `_span_bounds_by_part`: the same arrays bit for bit
on the shared models' surfaces, the samples and random surfaces (rational, repeated knots, degrees 1-5)
(session 28, issue 17 item 2)."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.io import read_shell
from trimsurf.model import NurbsSurface
from trimsurf.quality import interpolation_bound as ib
from trimsurf.samples import build_sample


def _same(a, b):
    return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(
        np.ascontiguousarray(a).view(np.uint8), np.ascontiguousarray(b).view(np.uint8))


def _check(surface):
    x, y, z = ib.span_bounds(surface), ib._span_bounds_numpy(surface), ib._span_bounds_by_part(surface)
    for name in ("bu", "bv", "crease_u", "crease_v", "m"):
        assert _same(getattr(x, name), getattr(y, name)), name
        assert _same(getattr(x, name), getattr(z, name)), name


MODELS = ["trimesh__featuretype.STEP", "gmsh__U_Joint_2.stp", "occt__bearing.iges", "gmsh__t20_data.step",
          "occt__screw.step"]


@pytest.mark.parametrize("name", MODELS)
def test_span_bounds_kernel_real_surfaces(shared_data, name):
    faces = read_shell(shared_data / "cad" / name).faces
    for f in faces:
        _check(f.surface)


def _random_surfaces(seed, count):
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        pu, pv = (int(x) for x in rng.integers(1, 6, 2))
        nu, nv = pu + 1 + int(rng.integers(0, 8)), pv + 1 + int(rng.integers(0, 8))

        def knots(p, n):
            k = np.r_[np.zeros(p + 1), np.sort(rng.random(n - p - 1)), np.ones(p + 1)]
            if n - p - 1 >= 2 and rng.random() < 0.6:      # a repeated interior knot, up to a crease
                r = int(rng.integers(1, p + 2))
                k[p + 1:p + 1 + min(r, n - p - 1)] = k[p + 1]
                k.sort()
            return k * 10.0 ** float(rng.integers(-3, 4)) + float(rng.normal())

        cp = rng.normal(size=(nu, nv, 3)) * np.exp(rng.normal(size=(nu, nv, 3)) * 3)
        w = None if rng.random() < 0.4 else np.exp(rng.normal(size=(nu, nv)))
        out.append(NurbsSurface(pu, pv, knots(pu, nu), knots(pv, nv), cp, w))
    return out


def test_span_bounds_kernel_samples_and_random():
    for s in ("fender", "hood", "bspline_box"):
        for f in build_sample(s).faces:
            _check(f.surface)
    surfaces = _random_surfaces(11, 400)
    assert sum(s.weights is not None for s in surfaces) > 150
    assert sum(ib.span_bounds(s).crease_u.any() for s in surfaces) > 20
    for s in surfaces:
        _check(s)


def test_span_bounds_kernel_sum_order_matters():
    """The check above can fail: another order of the squared lengths' sums (what a rewrite might write)
    gives other bits on these surfaces, so bit-identity is not a given of the data."""
    surfaces = _random_surfaces(11, 100)
    differs = 0
    for s in surfaces:
        m = ib.span_bounds(s).m
        cp = np.asarray(s.control_points)
        alt = np.sqrt((cp[..., 0] ** 2 + cp[..., 1] ** 2) + cp[..., 2] ** 2)
        ref = np.sqrt(np.einsum("...d,...d->...", cp, cp))
        differs += int(not np.array_equal(alt, ref))
        assert np.all(np.isfinite(m))
    assert differs > 50



_SIGS = """
import numpy as np
from trimsurf.quality import _bound_kernels as bk, interpolation_bound as ib
from tests.quality.test_span_bounds_kernel import _random_surfaces
surfaces = _random_surfaces(5, 40)
assert any(s.weights is None for s in surfaces) and any(s.weights is not None for s in surfaces)
assert any(not np.asarray(s.control_points).flags.writeable for s in surfaces)
for s in surfaces:
    ib.span_bounds(s)
print(len(bk._diff.signatures), len(bk._cell_max_k.signatures))
"""


def test_span_bounds_kernel_helpers_compile_once(tmp_path):
    """The cold compile: `_diff` (both axes, the net and the derivative nets) and `_cell_max_k` (both nets)
    each compile ONE specialization for polynomial and rational surfaces (a literal offset or axis, or the
    read-only control net passed as it is, made 2 to 4; session 29). On an empty numba cache (a cached
    kernel loads without compiling its helpers), in a child process (~4 s)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "nc"),
               PYTHONPATH=os.pathsep.join([str(root / "src"), str(root), os.environ.get("PYTHONPATH", "")]))
    out = subprocess.run([sys.executable, "-c", _SIGS], env=env, cwd=root, capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split() == ["1", "1"], out.stdout
