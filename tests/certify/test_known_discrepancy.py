"""Faces with deliberately introduced discrepancies: the certified figures contain the truth, tightly.

Stated tightness (measured on these faces): max_discrepancy_bound within 1 % above the true sup |eps|;
lipschitz within [0.98, 1.02] times a brute-force constant from 4000 boundary points; the sampled normal
bound within a factor 2.5 of the largest normal angle observed on a 60 x 60 grid (finite differences of G),
the rigorous one within 1.5 of the sampled.
"""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.certify import certify_shell
from trimsurf.samples import gap_pair

from ._faces import offset_face, true_lipschitz


def _offsets(seed):
    rng = np.random.default_rng(seed)
    d = np.zeros((5, 3))
    d[1:4] = rng.normal(size=(3, 3)) * 10 ** rng.uniform(-3, 0)
    return d


@pytest.mark.parametrize("seed", [0, 7])
def test_bounds_contain_true_discrepancy_and_lipschitz(seed):
    shell, delta = offset_face(_offsets(seed))
    # delta is the discrepancy at the same parameter: compare with that pairing
    cert = certify_shell(shell, intersections=False, pairing="parameter")
    f = cert.faces[0]
    truth = np.linalg.norm(delta.evaluate(np.linspace(0, 1, 20001)), axis=1).max()
    assert truth <= f.max_discrepancy_bound <= 1.01 * truth
    assert f.max_discrepancy <= truth * (1 + 1e-9)          # a sampled maximum never exceeds the sup
    lt = true_lipschitz(shell.faces[0], delta)
    # L is exact for the sampled data (the G it defines); it converges to the continuous constant
    assert np.all(f.lipschitz >= lt * 0.98), (f.lipschitz, lt)
    assert np.all(f.lipschitz <= lt * 1.02), (f.lipschitz, lt)
    assert f.certified
    # closest-point pairing (default): eps is b's distance from the surface, never above the same-parameter one
    near = certify_shell(shell, intersections=False).faces[0]
    assert near.max_discrepancy <= f.max_discrepancy * (1 + 1e-9) and near.certified


def _observed_normal_angle_deg(g, n=60, h=1e-5):
    gu, gv = np.meshgrid(np.linspace(0.01, 0.99, n), np.linspace(0.01, 0.99, n))
    uv = np.column_stack([gu.ravel(), gv.ravel()])
    du = (g.evaluate(uv + [h, 0]) - g.evaluate(uv - [h, 0])) / (2 * h)
    dv = (g.evaluate(uv + [0, h]) - g.evaluate(uv - [0, h])) / (2 * h)
    ng = np.cross(du, dv)
    ng /= np.linalg.norm(ng, axis=1)[:, None]
    nf = g.face.surface.normals(uv)
    return float(np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", ng, nf), -1, 1))).max())


@pytest.mark.parametrize("seed", [0, 3])
def test_normal_bound_contains_observed_angle(seed):
    shell, _ = offset_face(_offsets(seed))
    cert = certify_shell(shell, intersections=False, pairing="parameter")
    observed = _observed_normal_angle_deg(cert.perturbed[0])
    f = cert.faces[0]
    # the pointwise bound's sampled maximum is within 2.5x of the observed angle; the rigorous bound over the
    # whole face (control nets, pieces subdivided until within 1.5x of the sampled maximum) within 1.5x of it
    assert f.bound_kind == "rigorous"
    assert observed <= f.normal_bound_sampled_deg <= 2.5 * observed, (observed, f.normal_bound_sampled_deg)
    assert f.normal_bound_sampled_deg <= f.normal_bound_deg <= 1.5 * f.normal_bound_sampled_deg, f


def test_gap_pair_discrepancy_scales_with_the_gap():
    # gap_pair: the largest |F(p(t)) - b(t)| is gap_rel * diagonal to 1 % (before the vertex blend)
    small = certify_shell(gap_pair(gap_rel=1e-4), pairing="parameter")
    large = certify_shell(gap_pair(gap_rel=1e-3), pairing="parameter")
    assert small.certified and large.certified
    for fs, fl in zip(small.faces, large.faces):
        assert fl.max_discrepancy == pytest.approx(10 * fs.max_discrepancy, rel=0.02)
        assert fl.normal_bound_deg == pytest.approx(10 * fs.normal_bound_deg, rel=0.05)


def test_trim_polygon_crossing_itself_is_not_certified():
    # the bottom p-curve runs past the corner where the right one starts (a 0.07 gap, far above the merge
    # tolerance): the loop's polygon crosses itself, so the data has two values at one point and no
    # Lipschitz constant; the face must not be certified (and say where)
    from trimsurf.model import Loop, PCurve, TrimmedFace
    from trimsurf.samples._build import assemble_shell, line

    from ._faces import bicubic

    s = bicubic()
    pts = [((0.1, 0.1), (0.95, 0.1)), ((0.9, 0.05), (0.9, 0.9)), ((0.9, 0.9), (0.1, 0.9)), ((0.1, 0.9), (0.1, 0.1))]
    segs = tuple(PCurve(line(a, b), 0.0, 1.0) for a, b in pts)
    shell = assemble_shell([TrimmedFace(s, (Loop(segs),), name="crossing")], name="crossing")
    cert = certify_shell(shell, intersections=False)
    f = cert.faces[0]
    assert not f.certified
    assert any("crosses itself" in p for p in f.problems), f.problems
    crossings = cert.perturbed[0].boundary.crossings
    assert len(crossings) == 1 and np.abs(crossings[0] - [0.9, 0.1]).max() < 0.01
