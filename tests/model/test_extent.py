"""The model's extent comes from the trimmed faces, never from untrimmed surfaces (issue 16, item 10).

A CAx-IF model whose surfaces' nets span 905,382 while the part is ~300 mm got a default tolerance of 905.
Here: a face trimmed to a ~300 mm square of a bicubic surface ~1e6 across, alone and with a second small
face; its extent, `diagonal`, the default tolerances of `tessellate`, and the figures `info` prints
follow the trimmed region, in the library, through a STEP file and on the CLI.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose

from trimsurf.cli import main
from trimsurf.model import Loop, NurbsCurve, NurbsSurface, PCurve, Shell, TrimmedFace
from trimsurf.tessellate import default_parameters

CENTRE = np.array([0.43, 0.57])
HALF = 1.5e-4          # uv half-width of the trim square: ~300 mm on a surface 1e6 mm across


def _huge_surface() -> NurbsSurface:
    """Bicubic, 6 x 6 poles over x, y in [-5e5, 5e5], z up to 4e4: a net ~1.1e6 across."""
    rng = np.random.default_rng(10)
    g = np.linspace(-5e5, 5e5, 6)
    x, y = np.meshgrid(g, g, indexing="ij")
    z = rng.uniform(-4e4, 4e4, x.shape)
    knots = [0, 0, 0, 0, 1 / 3, 2 / 3, 1, 1, 1, 1]
    return NurbsSurface(3, 3, knots, knots, np.stack([x, y, z], axis=-1))


def _square(c, h) -> Loop:
    p = [c + [-h, -h], c + [h, -h], c + [h, h], c + [-h, h]]
    return Loop(tuple(PCurve(NurbsCurve(1, [0, 0, 1, 1], np.array([p[i], p[(i + 1) % 4]])), 0.0, 1.0)
                      for i in range(4)))


def _dense_box(surface, c, h, n=401):
    """Box of an n x n grid over the trimmed square (dense: the reference)."""
    t = np.linspace(-h, h, n)
    uu, vv = np.meshgrid(c[0] + t, c[1] + t)
    x = surface.evaluate(np.column_stack([uu.ravel(), vv.ravel()]))
    return x.min(axis=0), x.max(axis=0)


@pytest.fixture(scope="module")
def trimmed():
    s = _huge_surface()
    return Shell.from_faces([TrimmedFace(s, (_square(CENTRE, HALF),), name="small part of a huge surface")])


def test_extent_follows_the_trimmed_region(trimmed):
    s = trimmed.faces[0].surface
    lo_ref, hi_ref = _dense_box(s, CENTRE, HALF)
    ref = float(np.linalg.norm(hi_ref - lo_ref))
    assert 250 < ref < 700                                   # the part: a few hundred mm
    untrimmed = Shell.from_faces([TrimmedFace(s)]).diagonal()
    assert untrimmed > 1e6                                   # what the untrimmed surface would give
    lo, hi = trimmed.bounding_box()
    # a sampled inner bound: inside the dense box (1e-9 rel. for rounding), and short of it by at most the
    # bulge between 17 x 17 samples of a nearly flat 300 mm patch (measured 0; bound 1e-3 of the size)
    assert np.all(lo >= lo_ref - 1e-9 * ref) and np.all(hi <= hi_ref + 1e-9 * ref)
    assert_allclose(lo, lo_ref, rtol=0, atol=1e-3 * ref)
    assert_allclose(hi, hi_ref, rtol=0, atol=1e-3 * ref)
    tol, max_edge = default_parameters(trimmed)
    assert tol == pytest.approx(1e-3 * trimmed.diagonal(), rel=1e-12)
    assert tol == pytest.approx(1e-3 * ref, rel=1e-3) and max_edge == pytest.approx(0.03 * ref, rel=1e-3)


def test_a_hole_and_a_second_face_count_by_their_trimmed_parts():
    """A face whose hole covers most of its loop's box: the box still comes from the outer loop (the
    region's edge); a second face trimmed far away on the same huge surface widens the box to it."""
    s = _huge_surface()
    holed = TrimmedFace(s, (_square(CENTRE, HALF), _square(CENTRE, 0.9 * HALF)))
    far = CENTRE + [2e-3, 0.0]                                # ~2 km away on the surface
    other = TrimmedFace(s, (_square(far, HALF),))
    one = Shell.from_faces([holed])
    both = Shell.from_faces([holed, other])
    lo_a, hi_a = _dense_box(s, CENTRE, HALF)
    lo_b, hi_b = _dense_box(s, far, HALF)
    ref = float(np.linalg.norm(np.maximum(hi_a, hi_b) - np.minimum(lo_a, lo_b)))
    assert one.diagonal() == pytest.approx(float(np.linalg.norm(hi_a - lo_a)), rel=1e-3)
    assert both.diagonal() == pytest.approx(ref, rel=1e-3)
    assert both.diagonal() < 1e-2 * Shell.from_faces([TrimmedFace(s)]).diagonal()


def test_info_and_tessellate_use_the_trimmed_extent_through_a_step_file(trimmed, tmp_path, capsys):
    from trimsurf.io import write_shell

    path = tmp_path / "huge.step"
    write_shell(trimmed, path)
    lo_ref, hi_ref = _dense_box(trimmed.faces[0].surface, CENTRE, HALF)
    ref = float(np.linalg.norm(hi_ref - lo_ref))
    capsys.readouterr()
    assert main(["info", "--json", str(path)]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["diagonal"] == pytest.approx(ref, rel=1e-3)
    assert "trimmed faces" in r["extent_source"]
    assert r["tessellate_defaults"]["tolerance"] == pytest.approx(1e-3 * ref, rel=1e-3)
    assert main(["info", str(path)]) == 0
    text = capsys.readouterr().out
    assert "extent from" in text and "trimmed faces" in text and "tessellate defaults" in text
    rep = tmp_path / "r.json"
    assert main(["tessellate", str(path), "-o", str(tmp_path / "m.ply"), "--report", str(rep)]) == 0
    e = json.loads(rep.read_text())["inputs"][0]
    assert e["tolerance"] == pytest.approx(1e-3 * ref, rel=1e-3)
    assert e["max_deviation"] <= e["tolerance"] and e["flipped"] == 0
    # a grid of 0.03 x diagonal over the square: ~34 lines each way (2312 triangles measured), where
    # defaults from the untrimmed surface (diagonal 1.4e6: tolerance 1.4e3) give 2 (measured)
    assert 1000 <= e["triangles"] <= 5000
